//! Per-key structures kept small for a header naming millions of symbols
//! (issue 9 item 6): the keys' lists of production numbers ([`KeyIndex`]:
//! one array for all, each key's [`KeyRules`] pointing into it), and the
//! interning map as an open-addressing table of key numbers only
//! ([`KeyMap`]: the symbol and arity are read from the alphabet).

use std::ptr::NonNull;

/// The context-sensitive list, then the context-free one.
const CONTEXT: usize = 0;
const FREE: usize = 1;

/// A list's numbers: its pointer without the stochastic flag (bit 0; the
/// numbers are 4-byte aligned).
#[inline(always)]
fn untag(p: NonNull<u32>) -> *const u32 {
    p.as_ptr().map_addr(|a| a & !1)
}

/// The productions of one key, in file order, split by kind (numbers in
/// the table's `prods`): context-sensitive ones (a match beats every
/// context-free one), then context-free ones. Each list is a pointer into
/// its [`KeyIndex`]'s one array of numbers (its low bit set if some
/// production of the list is stochastic) and a length: 24 bytes a key and
/// no block of its own (a header may name millions of symbols; a list as
/// an offset and a length cost the hot paths 1.8-2.5 %, a pointer reads
/// as the boxed slice did).
pub struct KeyRules {
    len: [u32; 2],
    data: [NonNull<u32>; 2],
}

// Safety: a `KeyRules` reads its index's numbers, never changed while
// the index is shared.
unsafe impl Send for KeyRules {}
unsafe impl Sync for KeyRules {}

impl KeyRules {
    /// No productions (while an index is built).
    const NONE: KeyRules = KeyRules {
        len: [0; 2],
        data: [NonNull::dangling(); 2],
    };

    #[inline(always)]
    fn list(&self, which: usize) -> &[u32] {
        // Safety: `len` numbers at `data`, inside the index's array (which
        // outlives `self`: both are the index's).
        unsafe { std::slice::from_raw_parts(untag(self.data[which]), self.len[which] as usize) }
    }

    /// The context-sensitive productions.
    #[inline(always)]
    pub fn context(&self) -> &[u32] {
        self.list(CONTEXT)
    }
    /// The context-free productions.
    #[inline(always)]
    pub fn free(&self) -> &[u32] {
        self.list(FREE)
    }
    /// Has the key context-sensitive productions?
    #[inline(always)]
    pub fn has_context(&self) -> bool {
        self.len[CONTEXT] != 0
    }
    /// Has the key context-free productions?
    #[inline(always)]
    pub fn has_free(&self) -> bool {
        self.len[FREE] != 0
    }
    /// Has the key no production?
    #[inline(always)]
    fn is_none(&self) -> bool {
        self.len == [0, 0]
    }
    /// Is one of the context-sensitive productions stochastic?
    #[inline(always)]
    pub fn context_stochastic(&self) -> bool {
        self.data[CONTEXT].as_ptr().addr() & 1 != 0
    }
    /// Is one of the context-free productions stochastic?
    #[inline(always)]
    pub fn free_stochastic(&self) -> bool {
        self.data[FREE].as_ptr().addr() & 1 != 0
    }

    fn set_stochastic(&mut self, which: usize) {
        self.data[which] = self.data[which].map_addr(|a| a | 1);
    }
}

impl std::fmt::Debug for KeyRules {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KeyRules")
            .field("context", &self.context())
            .field("context_stochastic", &self.context_stochastic())
            .field("free", &self.free())
            .field("free_stochastic", &self.free_stochastic())
            .finish()
    }
}

/// Each key's productions: the lists of all keys in one array, in key
/// order (a key's context-sensitive list, then its context-free one), the
/// keys' [`KeyRules`] pointing into it. A numbered group's table also has
/// group 0's lists, the fallback (issue 11), in a second array.
#[derive(Default)]
pub struct KeyIndex {
    by_key: Vec<Option<KeyRules>>,
    /// Empty unless the table has a fallback.
    fallback: Vec<Option<KeyRules>>,
    /// The numbers `by_key`'s lists point into (never changed in size
    /// once they do).
    numbers: Vec<u32>,
    /// The numbers moved in `fallback`'s or `by_key`'s lists point into.
    fallback_numbers: Vec<u32>,
}

impl KeyIndex {
    /// The index of `entries()`: each production's (key, is it context
    /// free, is it stochastic), numbered from `first` in order. Counted
    /// first, in the lists' own lengths: nothing per key exists beside the
    /// result.
    pub fn build<I>(entries: impl Fn() -> I, first: u32) -> KeyIndex
    where
        I: Iterator<Item = (u32, bool, bool)>,
    {
        let keys = entries().map(|e| e.0 as usize + 1).max().unwrap_or(0);
        let mut by_key: Vec<Option<KeyRules>> = (0..keys).map(|_| Some(KeyRules::NONE)).collect();
        let mut total = 0usize;
        for (k, free, _) in entries() {
            let kr = by_key[k as usize].as_mut().expect("counting");
            let n = &mut kr.len[usize::from(free)];
            *n = n.checked_add(1).expect("fewer than 2^32 productions");
            total += 1;
        }
        let mut numbers = vec![0u32; total];
        let base = numbers.as_mut_ptr();
        let mut at = 0;
        for slot in &mut by_key {
            let Some(kr) = slot else { continue };
            if kr.is_none() {
                *slot = None;
                continue;
            }
            for which in [CONTEXT, FREE] {
                // Safety: the lists' counts add up to `total`.
                kr.data[which] = unsafe { NonNull::new_unchecked(base.add(at)) };
                at += kr.len[which] as usize;
                kr.len[which] = 0;
            }
        }
        for (i, (k, free, stochastic)) in entries().enumerate() {
            let which = usize::from(free);
            let kr = by_key[k as usize].as_mut().expect("a list for each key named");
            let n = kr.len[which];
            // Safety: the list has room for the productions counted, and
            // `numbers` is not otherwise touched while it is filled.
            unsafe { untag(kr.data[which]).cast_mut().add(n as usize).write(first + i as u32) };
            kr.len[which] = n + 1;
            if stochastic {
                kr.set_stochastic(which);
            }
        }
        KeyIndex {
            by_key,
            fallback: Vec::new(),
            numbers,
            fallback_numbers: Vec::new(),
        }
    }

    /// The productions of `key`, if it has any.
    #[inline(always)]
    pub fn get(&self, key: u32) -> Option<&KeyRules> {
        self.by_key.get(key as usize).and_then(Option::as_ref)
    }

    /// Group 0's productions of `kr`'s key, in a numbered group's table
    /// (`kr` from [`get`](Self::get)).
    #[inline(always)]
    pub fn fallback(&self, kr: &KeyRules) -> Option<&KeyRules> {
        if self.fallback.is_empty() {
            return None;
        }
        // Which key: where `kr` sits in `by_key` (a fallback's own entry
        // is not in it, and has no fallback).
        let at = (kr as *const KeyRules)
            .addr()
            .wrapping_sub(self.by_key.as_ptr().addr())
            / std::mem::size_of::<Option<KeyRules>>();
        self.fallback.get(at).and_then(Option::as_ref)
    }

    /// Every key's lists.
    #[cfg(test)]
    fn iter(&self) -> impl Iterator<Item = &KeyRules> {
        self.by_key.iter().flatten()
    }

    /// cpfg's choice: one list per key in file order. A key with both
    /// kinds gets them merged into its context-sensitive list (the two
    /// lists are side by side in the array).
    pub fn merge_kinds(&mut self) {
        for kr in self.by_key.iter_mut().flatten() {
            if kr.has_context() && kr.has_free() {
                let n = kr.len[CONTEXT] + kr.len[FREE];
                let at = untag(kr.data[CONTEXT]);
                // Safety: the context-free list follows the context one
                // in `numbers` (`build`), which `&mut self` holds alone.
                let all = unsafe { std::slice::from_raw_parts_mut(at.cast_mut(), n as usize) };
                all.sort_unstable();
                let stochastic = kr.context_stochastic() || kr.free_stochastic();
                kr.len = [n, 0];
                if stochastic {
                    kr.set_stochastic(CONTEXT);
                }
            }
        }
    }

    /// Add `base`'s lists, each number plus `by`, as the fallback: where
    /// this index has no list for a key, `base`'s becomes its own.
    pub fn add_fallback(&mut self, base: &KeyIndex, by: u32) {
        let numbers: Vec<u32> = base.numbers.iter().map(|i| i + by).collect();
        let keys = self.by_key.len().max(base.by_key.len());
        self.by_key.resize_with(keys, || None);
        self.fallback = (0..keys).map(|_| None).collect();
        for (key, b) in base.by_key.iter().enumerate() {
            let Some(b) = b else { continue };
            let mut moved = KeyRules {
                len: b.len,
                data: b.data,
            };
            for which in [CONTEXT, FREE] {
                let at = (untag(b.data[which]).addr() - base.numbers.as_ptr().addr()) / 4;
                let tag = b.data[which].as_ptr().addr() & 1;
                // Safety: the same place in the copy as in `base.numbers`
                // (at most its end).
                let p = unsafe { NonNull::new_unchecked(numbers.as_ptr().add(at).cast_mut()) };
                moved.data[which] = p.map_addr(|a| a | tag);
            }
            match self.by_key[key] {
                None => self.by_key[key] = Some(moved),
                Some(_) => self.fallback[key] = Some(moved),
            }
        }
        self.fallback_numbers = numbers;
    }
}

impl std::fmt::Debug for KeyIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KeyIndex")
            .field("keys", &self.by_key.len())
            .field("productions", &self.numbers.len())
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

    /// (key, free, stochastic) of some productions.
    const ENTRIES: [(u32, bool, bool); 9] = [
        (5, true, false),
        (2, false, false),
        (5, false, true),
        (9, true, false),
        (5, true, false),
        (2, false, false),
        (0, true, true),
        (5, false, false),
        (9, true, false),
    ];

    fn lists(kr: &KeyRules) -> (Vec<u32>, bool, Vec<u32>, bool) {
        (
            kr.context().to_vec(),
            kr.context_stochastic(),
            kr.free().to_vec(),
            kr.free_stochastic(),
        )
    }

    #[test]
    fn key_index_lists_each_keys_productions() {
        assert_eq!(
            std::mem::size_of::<KeyRules>(),
            8 + 2 * std::mem::size_of::<usize>()
        );
        let empty = KeyIndex::build(|| ENTRIES.iter().copied().take(0), 0);
        assert!(empty.get(0).is_none() && empty.iter().count() == 0);
        assert_eq!(std::mem::size_of::<Option<KeyRules>>(), std::mem::size_of::<KeyRules>());
        let none = KeyRules::NONE;
        assert!(none.is_none() && !none.has_context() && !none.has_free());
        assert_eq!((none.context(), none.free()), (&[][..], &[][..]));
        let ix = KeyIndex::build(|| ENTRIES.iter().copied(), 10);
        assert_eq!(ix.iter().count(), 4);
        assert!(ix.get(1).is_none() && ix.get(3).is_none() && ix.get(10).is_none());
        assert_eq!(lists(ix.get(0).unwrap()), (vec![], false, vec![16], true));
        assert_eq!(
            lists(ix.get(2).unwrap()),
            (vec![11, 15], false, vec![], false)
        );
        assert_eq!(
            lists(ix.get(5).unwrap()),
            (vec![12, 17], true, vec![10, 14], false)
        );
        assert_eq!(
            lists(ix.get(9).unwrap()),
            (vec![], false, vec![13, 18], false)
        );
        let kr = ix.get(5).unwrap();
        assert!(kr.has_context() && kr.has_free());
        assert!(ix.fallback(kr).is_none());
        // Moved, the index's lists stay where they are.
        let moved = Box::new(ix);
        assert_eq!(
            lists(moved.get(9).unwrap()),
            (vec![], false, vec![13, 18], false)
        );
    }

    #[test]
    fn key_index_merges_kinds_and_falls_back() {
        let mut ix = KeyIndex::build(|| ENTRIES.iter().copied(), 0);
        ix.merge_kinds();
        assert_eq!(
            lists(ix.get(5).unwrap()),
            (vec![0, 2, 4, 7], true, vec![], false)
        );
        assert_eq!(
            lists(ix.get(9).unwrap()),
            (vec![], false, vec![3, 8], false)
        );
        // A group with productions for keys 5 and 7; group 0 is `ix`.
        let mut group = KeyIndex::build(|| [(7, true, false), (5, true, true)].into_iter(), 0);
        group.add_fallback(&ix, 2);
        let five = group.get(5).unwrap();
        assert_eq!(lists(five), (vec![], false, vec![1], true));
        let back = group.fallback(five).unwrap();
        assert_eq!(lists(back), (vec![2, 4, 6, 9], true, vec![], false));
        assert!(group.fallback(back).is_none());
        let seven = group.get(7).unwrap();
        assert!(group.fallback(seven).is_none());
        // Keys only group 0 rewrites take its lists as their own.
        let nine = group.get(9).unwrap();
        assert_eq!(lists(nine), (vec![], false, vec![5, 10], false));
        assert!(group.fallback(nine).is_none());
        assert_eq!(lists(group.get(0).unwrap()), (vec![], false, vec![8], true));
        drop(ix);
        assert_eq!(
            lists(group.get(2).unwrap()),
            (vec![3, 7], false, vec![], false)
        );
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
