//! Per-key structures kept small for a header naming millions of symbols
//! (issue 9 item 6): a key's list of production numbers in one tagged word
//! ([`KeyList`]: one number in place, more in a block behind it), and the
//! interning map as an open-addressing table of key numbers only
//! ([`KeyMap`]: the symbol and arity are read from the alphabet).

use std::alloc::{alloc, dealloc, handle_alloc_error, Layout};
use std::ptr::NonNull;

/// Bit 0 of a [`KeyList`]'s word: one number, in place.
const ONE: usize = 1;
/// Bit 1: the list holds a stochastic production (either form).
const STOCHASTIC: usize = 2;
/// One number fits in place beside the tags on a 64-bit target only.
const IN_PLACE: bool = usize::BITS == 64;
/// Which `u32` of the word holds the number in place (its upper half).
const HI: usize = if cfg!(target_endian = "little") { 1 } else { 0 };

/// Every empty list's block: its length, 0.
static EMPTY: u32 = 0;

/// A key's production numbers (indices in the table), in one word: its
/// low bit set, the one number in the word's upper half; otherwise a
/// pointer (4-byte aligned) to a block holding the count, then the
/// numbers; the empty list points at a shared static count. Bit 1 is the
/// "some production is stochastic" flag in both forms. A header of 10^6
/// distinct symbols has 10^6 one-number lists: no block for any of them.
/// (Lists as pointers into one table-wide array, with the flags in the
/// pointers or beside them, measured 1.0-1.7 % more instructions on the
/// context, stochastic and parametric rows: benches/RESULTS.md.)
pub struct KeyList {
    word: NonNull<u32>,
}

// Safety: a `KeyList` owns its block as a `Box<[u32]>` does.
unsafe impl Send for KeyList {}
unsafe impl Sync for KeyList {}

impl KeyList {
    /// The empty list.
    pub fn empty() -> KeyList {
        KeyList {
            word: NonNull::from(&EMPTY),
        }
    }

    /// A list of `n` numbers, each 0 until set through
    /// [`as_mut_slice`](Self::as_mut_slice).
    pub fn zeroed(n: usize) -> KeyList {
        match n {
            0 => KeyList::empty(),
            1 if IN_PLACE => KeyList {
                // Never dereferenced: the number 0 in place, and the tag.
                word: NonNull::new(std::ptr::without_provenance_mut(ONE))
                    .expect("the tag bit is set"),
            },
            _ => {
                let count = u32::try_from(n).expect("fewer than 2^32 productions");
                let layout = Self::layout(n);
                // Safety: the layout is not zero-sized (it holds the
                // count); zeroed memory is a valid count and numbers.
                unsafe {
                    let p = alloc(layout).cast::<u32>();
                    let Some(word) = NonNull::new(p) else {
                        handle_alloc_error(layout)
                    };
                    p.write(count);
                    std::ptr::write_bytes(p.add(1), 0, n);
                    KeyList { word }
                }
            }
        }
    }

    fn layout(n: usize) -> Layout {
        Layout::array::<u32>(n + 1).expect("fewer than 2^32 productions")
    }

    #[inline(always)]
    fn bits(&self) -> usize {
        self.word.as_ptr().addr()
    }

    /// The block's count (pointer form only).
    #[inline(always)]
    fn block(&self) -> *mut u32 {
        self.word.as_ptr().map_addr(|a| a & !STOCHASTIC)
    }

    /// The numbers.
    #[inline(always)]
    pub fn as_slice(&self) -> &[u32] {
        if self.bits() & ONE != 0 {
            // Safety: the word's upper `u32`, read in place.
            unsafe { std::slice::from_raw_parts((&raw const self.word).cast::<u32>().add(HI), 1) }
        } else {
            let p = self.block();
            // Safety: the block holds its count, then that many numbers.
            unsafe { std::slice::from_raw_parts(p.add(1), p.read() as usize) }
        }
    }

    /// The numbers, to fill in.
    pub fn as_mut_slice(&mut self) -> &mut [u32] {
        if self.bits() & ONE != 0 {
            // Safety: the word's upper `u32`, written in place.
            unsafe { std::slice::from_raw_parts_mut((&raw mut self.word).cast::<u32>().add(HI), 1) }
        } else {
            let p = self.block();
            // Safety: as in `as_slice`; the static empty block has no
            // numbers to write.
            unsafe { std::slice::from_raw_parts_mut(p.add(1), p.read() as usize) }
        }
    }

    /// A list holding `items`.
    pub fn from_slice(items: &[u32]) -> KeyList {
        let mut l = KeyList::zeroed(items.len());
        l.as_mut_slice().copy_from_slice(items);
        l
    }

    /// (An empty list is never flagged stochastic: no mask needed.)
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.bits() == (&raw const EMPTY).addr()
    }

    #[inline(always)]
    pub fn stochastic(&self) -> bool {
        self.bits() & STOCHASTIC != 0
    }

    pub fn set_stochastic(&mut self, on: bool) {
        if self.is_empty() {
            // An empty list has no stochastic production.
            return;
        }
        let p = self.word.as_ptr();
        let p = if on {
            p.map_addr(|a| a | STOCHASTIC)
        } else {
            p.map_addr(|a| a & !STOCHASTIC)
        };
        self.word = NonNull::new(p).expect("a tagged word is not 0");
    }

    /// Does the list own a block?
    fn owns_block(&self) -> bool {
        self.bits() & ONE == 0 && !self.is_empty()
    }
}

impl Default for KeyList {
    fn default() -> KeyList {
        KeyList::empty()
    }
}

impl Clone for KeyList {
    fn clone(&self) -> KeyList {
        if !self.owns_block() {
            return KeyList { word: self.word };
        }
        let mut l = KeyList::from_slice(self.as_slice());
        l.set_stochastic(self.stochastic());
        l
    }
}

impl Drop for KeyList {
    fn drop(&mut self) {
        if self.owns_block() {
            let layout = Self::layout(self.as_slice().len());
            // Safety: the block was allocated with this layout (`zeroed`).
            unsafe { dealloc(self.block().cast::<u8>(), layout) }
        }
    }
}

impl std::fmt::Debug for KeyList {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KeyList")
            .field("items", &self.as_slice())
            .field("stochastic", &self.stochastic())
            .finish()
    }
}

/// No key in a [`KeyMap`] slot.
const VACANT: u32 = u32::MAX;

/// The interning map, (symbol, arity) to key: an open-addressing table
/// (linear probing, at most 3/4 full) of key numbers, 4 bytes a slot; the
/// symbol and arity of a slot's key are read from the alphabet. (A
/// `HashMap<(char, u16), u32>` took about 27 bytes a key.)
#[derive(Clone, Debug, Default)]
pub struct KeyMap {
    slots: Vec<u32>,
    len: usize,
}

impl KeyMap {
    #[inline]
    fn start(&self, sym: char, arity: u16) -> usize {
        let h = (u64::from(u32::from(sym)) << 16 | u64::from(arity))
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        // The top bits: `slots.len()` is a power of two.
        (h >> (64 - self.slots.len().trailing_zeros())) as usize
    }

    /// The key of `(sym, arity)`; `is(k)` tells whether key `k` is it.
    pub fn get(&self, sym: char, arity: u16, is: impl Fn(u32) -> bool) -> Option<u32> {
        if self.slots.is_empty() {
            return None;
        }
        let mask = self.slots.len() - 1;
        let mut i = self.start(sym, arity);
        loop {
            match self.slots[i] {
                VACANT => return None,
                k if is(k) => return Some(k),
                _ => i = (i + 1) & mask,
            }
        }
    }

    /// Add key `k` for `(sym, arity)` (not in the map); `of(k)` gives the
    /// symbol and arity of any key already in it.
    pub fn insert(&mut self, sym: char, arity: u16, k: u32, of: impl Fn(u32) -> (char, u16)) {
        if (self.len + 1) * 4 > self.slots.len() * 3 {
            let bigger = vec![VACANT; (self.slots.len() * 2).max(16)];
            let old = std::mem::replace(&mut self.slots, bigger);
            for &o in old.iter().filter(|&&o| o != VACANT) {
                let (s, a) = of(o);
                self.put(s, a, o);
            }
        }
        self.put(sym, arity, k);
        self.len += 1;
    }

    fn put(&mut self, sym: char, arity: u16, k: u32) {
        let mask = self.slots.len() - 1;
        let mut i = self.start(sym, arity);
        while self.slots[i] != VACANT {
            i = (i + 1) & mask;
        }
        self.slots[i] = k;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_lists_in_every_form() {
        assert_eq!(std::mem::size_of::<KeyList>(), std::mem::size_of::<usize>());
        assert_eq!(
            std::mem::size_of::<Option<KeyList>>(),
            std::mem::size_of::<usize>()
        );
        let e = KeyList::empty();
        assert!(e.is_empty() && !e.stochastic());
        assert_eq!(e.as_slice(), &[] as &[u32]);
        assert!(KeyList::from_slice(&[]).is_empty());
        assert!(KeyList::default().is_empty());
        for items in [
            &[][..],
            &[0][..],
            &[7][..],
            &[u32::MAX][..],
            &[3, 5][..],
            &[1, 2, 3, 4, 5, 6, 7, 8, 9][..],
        ] {
            for flag in [false, true, false] {
                // An empty list is never stochastic.
                let stochastic = flag && !items.is_empty();
                let mut l = KeyList::from_slice(items);
                l.set_stochastic(flag);
                assert_eq!(l.as_slice(), items);
                assert_eq!(l.is_empty(), items.is_empty());
                assert_eq!(l.stochastic(), stochastic);
                // The one-number form owns no block.
                assert_eq!(l.owns_block(), items.len() > usize::from(IN_PLACE));
                let c = l.clone();
                assert_eq!(c.as_slice(), items);
                assert_eq!(c.stochastic(), stochastic);
                assert_eq!(c.owns_block(), l.owns_block());
                if l.owns_block() {
                    assert_ne!(c.block(), l.block());
                }
                drop(l);
                assert_eq!(c.as_slice(), items);
                let mut z = KeyList::zeroed(items.len());
                z.set_stochastic(true);
                z.as_mut_slice().copy_from_slice(items);
                z.set_stochastic(false);
                assert_eq!(z.as_slice(), items);
                assert!(!z.stochastic());
            }
        }
    }

    #[test]
    fn key_map_finds_what_it_holds() {
        let mut keys: Vec<(char, u16)> = Vec::new();
        let mut m = KeyMap::default();
        assert_eq!(m.get('A', 1, |_| true), None);
        for i in 0..5000u32 {
            let sym = char::from_u32(0x10000 + i / 3).unwrap();
            let arity = (i % 3) as u16;
            let is = |k: u32| keys[k as usize] == (sym, arity);
            assert_eq!(m.get(sym, arity, is), None);
            let k = keys.len() as u32;
            keys.push((sym, arity));
            m.insert(sym, arity, k, |o| keys[o as usize]);
            assert!(m.slots.len() * 3 >= m.len * 4);
        }
        for (k, &(sym, arity)) in keys.iter().enumerate() {
            assert_eq!(
                m.get(sym, arity, |o| keys[o as usize] == (sym, arity)),
                Some(k as u32)
            );
        }
        assert_eq!(m.get('x', 9, |o| keys[o as usize] == ('x', 9)), None);
        let c = m.clone();
        assert_eq!(c.get(keys[77].0, keys[77].1, |o| o == 77), Some(77));
    }
}
