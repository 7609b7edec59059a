//! A boxed slice behind one pointer (issue 9 item 6): its length sits in
//! the block, before the items, so a production's slices take 8 bytes
//! each instead of 16 (a table may hold millions of productions). The
//! empty slice points at a shared static header and allocates nothing.

use std::alloc::{alloc, dealloc, handle_alloc_error, Layout};
use std::marker::PhantomData;
use std::ptr::NonNull;

/// The header: the item count. 8-byte aligned, so that items of any
/// alignment up to 8 follow it directly.
#[repr(C, align(8))]
struct Header {
    len: usize,
}

/// Every empty slice's header.
static EMPTY: Header = Header { len: 0 };

/// A boxed slice of `T` behind a thin pointer. `T`'s alignment must be at
/// most 8 (checked when one is made).
pub struct Thin<T> {
    ptr: NonNull<Header>,
    _items: PhantomData<T>,
}

// Safety: a `Thin<T>` owns its items as a `Box<[T]>` does.
unsafe impl<T: Send> Send for Thin<T> {}
unsafe impl<T: Sync> Sync for Thin<T> {}

impl<T> Thin<T> {
    /// The block for `n` items, and where the items start in it.
    fn layout(n: usize) -> (Layout, usize) {
        assert!(std::mem::align_of::<T>() <= 8);
        let (l, at) = Layout::new::<Header>()
            .extend(Layout::array::<T>(n).expect("a slice under isize::MAX"))
            .expect("a slice under isize::MAX");
        (l.pad_to_align(), at)
    }

    pub fn empty() -> Thin<T> {
        Thin {
            ptr: NonNull::from(&EMPTY),
            _items: PhantomData,
        }
    }

    #[inline(always)]
    fn is_static(&self) -> bool {
        std::ptr::eq(self.ptr.as_ptr(), &EMPTY)
    }

    #[inline(always)]
    fn items(&self) -> *mut T {
        // Items follow the 8-byte header (T's alignment is at most 8).
        unsafe { self.ptr.as_ptr().add(1).cast::<T>() }
    }
}

impl<T> Default for Thin<T> {
    fn default() -> Thin<T> {
        Thin::empty()
    }
}

impl<T> From<Vec<T>> for Thin<T> {
    fn from(mut v: Vec<T>) -> Thin<T> {
        let n = v.len();
        if n == 0 && std::mem::size_of::<T>() > 0 {
            return Thin::empty();
        }
        let (layout, at) = Self::layout(n);
        debug_assert_eq!(at, std::mem::size_of::<Header>());
        // Safety: the layout is not zero-sized (it holds the header); the
        // items are moved out of `v` (its length set to 0 first, so it
        // only frees its buffer).
        unsafe {
            let p = alloc(layout).cast::<Header>();
            let Some(ptr) = NonNull::new(p) else {
                handle_alloc_error(layout)
            };
            ptr.as_ptr().write(Header { len: n });
            let t = Thin {
                ptr,
                _items: PhantomData,
            };
            v.set_len(0);
            std::ptr::copy_nonoverlapping(v.as_ptr(), t.items(), n);
            t
        }
    }
}

impl<T> From<Box<[T]>> for Thin<T> {
    fn from(b: Box<[T]>) -> Thin<T> {
        Thin::from(b.into_vec())
    }
}

impl<T: Clone> From<&[T]> for Thin<T> {
    fn from(s: &[T]) -> Thin<T> {
        Thin::from(s.to_vec())
    }
}

impl<T> std::ops::Deref for Thin<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // Safety: the header holds the count of initialised items after it.
        unsafe { std::slice::from_raw_parts(self.items(), (*self.ptr.as_ptr()).len) }
    }
}

impl<T> std::ops::DerefMut for Thin<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // Safety: as `deref`; the static header has no items to hand out
        // (a slice of length 0), and the block is owned.
        unsafe { std::slice::from_raw_parts_mut(self.items(), (*self.ptr.as_ptr()).len) }
    }
}

impl<T> Drop for Thin<T> {
    fn drop(&mut self) {
        if self.is_static() {
            return;
        }
        // Safety: an owned block made by `From<Vec<T>>` with this length.
        unsafe {
            let n = (*self.ptr.as_ptr()).len;
            std::ptr::drop_in_place(std::ptr::slice_from_raw_parts_mut(self.items(), n));
            dealloc(self.ptr.as_ptr().cast(), Self::layout(n).0);
        }
    }
}

impl<T: Clone> Clone for Thin<T> {
    fn clone(&self) -> Thin<T> {
        Thin::from(&**self)
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for Thin<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

impl<T: PartialEq> PartialEq for Thin<T> {
    fn eq(&self, other: &Thin<T>) -> bool {
        **self == **other
    }
}

impl<'a, T> IntoIterator for &'a Thin<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// Two slices in one block behind one pointer: `A`s then `B`s after a
/// header that counts them (a production's left and right contexts: 8
/// bytes and, when either is not empty, one block). The header is one
/// u32 (`na | nb << 15`) when `na < 2^15` and `nb < 2^16`, so that a
/// one-module context on each side fits glibc's smallest chunk; else
/// [`BIG`] followed by the two counts. Both types' alignment must be at
/// most 4 and `A`'s size a multiple of `B`'s alignment.
pub struct Pair<A: Copy, B: Copy> {
    ptr: NonNull<u32>,
    _items: PhantomData<(A, B)>,
}

/// The header of a pair whose counts follow it.
const BIG: u32 = 1 << 31;

/// Every empty pair's header.
static NO_PAIR: u32 = 0;

// Safety: a `Pair` owns its items (plain `Copy` data).
unsafe impl<A: Copy + Send, B: Copy + Send> Send for Pair<A, B> {}
unsafe impl<A: Copy + Sync, B: Copy + Sync> Sync for Pair<A, B> {}

impl<A: Copy, B: Copy> Pair<A, B> {
    /// The header's bytes for these counts, and the block.
    fn layout(na: usize, nb: usize) -> (usize, Layout) {
        assert!(std::mem::align_of::<A>() <= 4 && std::mem::align_of::<B>() <= 4);
        assert!(std::mem::size_of::<A>() % std::mem::align_of::<B>() == 0);
        let header = if na < 1 << 15 && nb < 1 << 16 { 4 } else { 12 };
        let size = header + na * std::mem::size_of::<A>() + nb * std::mem::size_of::<B>();
        let layout = Layout::from_size_align(size, 4).expect("a slice under isize::MAX");
        (header, layout)
    }

    pub fn new(a: &[A], b: &[B]) -> Pair<A, B> {
        if a.is_empty() && b.is_empty() {
            return Pair {
                ptr: NonNull::from(&NO_PAIR),
                _items: PhantomData,
            };
        }
        let n = |x: usize| u32::try_from(x).expect("a header under 4 GiB");
        let (header, layout) = Self::layout(a.len(), b.len());
        // Safety: the layout is not zero-sized; the header, then the
        // `A`s, then the `B`s fill it, each at an offset aligned for it.
        unsafe {
            let p = alloc(layout).cast::<u32>();
            let Some(ptr) = NonNull::new(p) else {
                handle_alloc_error(layout)
            };
            if header == 4 {
                p.write(n(a.len()) | n(b.len()) << 15);
            } else {
                p.write(BIG);
                p.add(1).write(n(a.len()));
                p.add(2).write(n(b.len()));
            }
            let t = Pair {
                ptr,
                _items: PhantomData,
            };
            std::ptr::copy_nonoverlapping(a.as_ptr(), t.a_ptr(), a.len());
            std::ptr::copy_nonoverlapping(b.as_ptr(), t.b_ptr(), b.len());
            t
        }
    }

    /// The two counts, and where the `A`s start.
    #[inline(always)]
    fn counts(&self) -> (usize, usize, *mut A) {
        let p = self.ptr.as_ptr();
        // Safety: the header is always there (the static one if empty),
        // with the counts after it if it says BIG.
        unsafe {
            let h = *p;
            if h & BIG == 0 {
                (
                    (h & 0x7FFF) as usize,
                    (h >> 15) as usize,
                    p.add(1).cast::<A>(),
                )
            } else {
                (*p.add(1) as usize, *p.add(2) as usize, p.add(3).cast::<A>())
            }
        }
    }
    #[inline(always)]
    fn a_ptr(&self) -> *mut A {
        self.counts().2
    }
    #[inline(always)]
    fn b_ptr(&self) -> *mut B {
        let (na, _, a) = self.counts();
        unsafe { a.add(na).cast::<B>() }
    }
    #[inline(always)]
    pub fn a(&self) -> &[A] {
        let (na, _, a) = self.counts();
        // Safety: the header counts the initialised items.
        unsafe { std::slice::from_raw_parts(a, na) }
    }
    #[inline(always)]
    pub fn b(&self) -> &[B] {
        let (na, nb, a) = self.counts();
        unsafe { std::slice::from_raw_parts(a.add(na).cast::<B>(), nb) }
    }
    pub fn b_mut(&mut self) -> &mut [B] {
        let (na, nb, a) = self.counts();
        // Safety: owned; an empty pair's slice has no items to write.
        unsafe { std::slice::from_raw_parts_mut(a.add(na).cast::<B>(), nb) }
    }
}

impl<A: Copy, B: Copy> Drop for Pair<A, B> {
    fn drop(&mut self) {
        if std::ptr::eq(self.ptr.as_ptr(), &NO_PAIR) {
            return;
        }
        let (na, nb, _) = self.counts();
        // Safety: made by `new` with this layout; the items need no drop.
        unsafe { dealloc(self.ptr.as_ptr().cast(), Self::layout(na, nb).1) }
    }
}

impl<A: Copy, B: Copy> Clone for Pair<A, B> {
    fn clone(&self) -> Self {
        Pair::new(self.a(), self.b())
    }
}

impl<A: Copy + std::fmt::Debug, B: Copy + std::fmt::Debug> std::fmt::Debug for Pair<A, B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Pair")
            .field(&self.a())
            .field(&self.b())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::Thin;
    use std::rc::Rc;

    #[test]
    fn holds_moves_clones_and_drops() {
        assert_eq!(std::mem::size_of::<Thin<u64>>(), 8);
        let e: Thin<u32> = Thin::from(Vec::new());
        assert!(e.is_empty());
        let t = Thin::from(vec![1u8, 2, 3]);
        assert_eq!(&*t, [1, 2, 3]);
        let mut c = t.clone();
        c[0] = 9;
        assert_eq!((&*t, &*c), (&[1u8, 2, 3][..], &[9u8, 2, 3][..]));
        // Items with a destructor are dropped once each.
        let r = Rc::new(());
        let v: Thin<Rc<()>> = Thin::from(vec![r.clone(), r.clone()]);
        let w = v.clone();
        assert_eq!(Rc::strong_count(&r), 5);
        drop((v, w));
        assert_eq!(Rc::strong_count(&r), 1);
        let s: Thin<(u32, f64)> = Thin::from(vec![(1, 0.5)]);
        assert_eq!(s[0], (1, 0.5));
    }

    #[test]
    fn pair_holds_both_slices() {
        use super::Pair;
        let e: Pair<(u32, u32), u8> = Pair::new(&[], &[]);
        assert!(e.a().is_empty() && e.b().is_empty());
        let mut p = Pair::new(&[(1u32, 2u32), (3, 4)], &[7u8, 8, 9]);
        assert_eq!((p.a(), p.b()), (&[(1, 2), (3, 4)][..], &[7, 8, 9][..]));
        p.b_mut()[0] = 0;
        let q = p.clone();
        assert_eq!((q.a(), q.b()), (&[(1, 2), (3, 4)][..], &[0, 8, 9][..]));
        let r: Pair<(u32, u32), u8> = Pair::new(&[], &[5]);
        assert_eq!((r.a(), r.b()), (&[][..], &[5][..]));
        // Counts past the one-word header.
        for (na, nb) in [(1 << 15, 1), (1, 1 << 16), ((1 << 15) - 1, (1 << 16) - 1)] {
            let a: Vec<(u32, u32)> = (0..na).map(|i| (i, i)).collect();
            let b: Vec<u8> = (0..nb).map(|i| i as u8).collect();
            let p = Pair::new(&a, &b);
            assert_eq!((p.a(), p.b()), (&a[..], &b[..]));
            assert_eq!((p.clone().a(), p.clone().b()), (&a[..], &b[..]));
        }
    }
}
