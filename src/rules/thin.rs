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

/// Two slices in one block behind one pointer: the second's count (a
/// u32), then `A`s, then `B`s. The first's count is kept by the owner
/// (a production keeps its left context's count in a spare word), so
/// that a one-module context on each side (4 + 8 + 12 bytes) fits glibc's
/// smallest chunk; the owner passes it back to every call and frees the
/// block ([`free`](Self::free): a `Pair` has no destructor of its own).
/// Both types' alignment must be at most 4 and `A`'s size a multiple of
/// `B`'s alignment.
pub struct Pair<A: Copy, B: Copy> {
    ptr: NonNull<u32>,
    _items: PhantomData<(A, B)>,
}

/// Every empty pair's header.
static NO_PAIR: u32 = 0;

// Safety: a `Pair` owns its items (plain `Copy` data).
unsafe impl<A: Copy + Send, B: Copy + Send> Send for Pair<A, B> {}
unsafe impl<A: Copy + Sync, B: Copy + Sync> Sync for Pair<A, B> {}

impl<A: Copy, B: Copy> Pair<A, B> {
    fn layout(na: usize, nb: usize) -> Layout {
        assert!(std::mem::align_of::<A>() <= 4 && std::mem::align_of::<B>() <= 4);
        assert!(std::mem::size_of::<A>() % std::mem::align_of::<B>() == 0);
        let size = 4 + na * std::mem::size_of::<A>() + nb * std::mem::size_of::<B>();
        Layout::from_size_align(size, 4).expect("a slice under isize::MAX")
    }

    /// `a` and `b` in one block; the owner keeps `a.len()`.
    pub fn new(a: &[A], b: &[B]) -> Pair<A, B> {
        if a.is_empty() && b.is_empty() {
            return Pair {
                ptr: NonNull::from(&NO_PAIR),
                _items: PhantomData,
            };
        }
        let nb = u32::try_from(b.len()).expect("a header under 4 GiB");
        let layout = Self::layout(a.len(), b.len());
        // Safety: the layout is not zero-sized; the count, then the `A`s,
        // then the `B`s fill it, each at an offset aligned for it.
        unsafe {
            let p = alloc(layout).cast::<u32>();
            let Some(ptr) = NonNull::new(p) else {
                handle_alloc_error(layout)
            };
            p.write(nb);
            let t = Pair {
                ptr,
                _items: PhantomData,
            };
            std::ptr::copy_nonoverlapping(a.as_ptr(), t.a_ptr(), a.len());
            std::ptr::copy_nonoverlapping(b.as_ptr(), t.a_ptr().add(a.len()).cast::<B>(), b.len());
            t
        }
    }

    #[inline(always)]
    fn a_ptr(&self) -> *mut A {
        // Safety: one past the count (for the static empty pair, one past
        // its end: only ever a slice of length 0).
        unsafe { self.ptr.as_ptr().add(1).cast::<A>() }
    }
    #[inline(always)]
    fn nb(&self) -> usize {
        // Safety: the count is always there (the static one if empty).
        unsafe { *self.ptr.as_ptr() as usize }
    }
    /// The `A`s.
    ///
    /// # Safety
    /// `na` is the length of the `a` this pair was made with.
    #[inline(always)]
    pub unsafe fn a(&self, na: usize) -> &[A] {
        unsafe { std::slice::from_raw_parts(self.a_ptr(), na) }
    }
    /// The `B`s.
    ///
    /// # Safety
    /// As [`a`](Self::a).
    #[inline(always)]
    pub unsafe fn b(&self, na: usize) -> &[B] {
        unsafe { std::slice::from_raw_parts(self.a_ptr().add(na).cast::<B>(), self.nb()) }
    }
    /// # Safety
    /// As [`a`](Self::a).
    pub unsafe fn b_mut(&mut self, na: usize) -> &mut [B] {
        // An empty pair's slice has no items to write.
        unsafe { std::slice::from_raw_parts_mut(self.a_ptr().add(na).cast::<B>(), self.nb()) }
    }
    /// A copy.
    ///
    /// # Safety
    /// As [`a`](Self::a).
    pub unsafe fn copy(&self, na: usize) -> Pair<A, B> {
        unsafe { Pair::new(self.a(na), self.b(na)) }
    }
    /// Free the block; the pair is empty after.
    ///
    /// # Safety
    /// As [`a`](Self::a).
    pub unsafe fn free(&mut self, na: usize) {
        if std::ptr::eq(self.ptr.as_ptr(), &NO_PAIR) {
            return;
        }
        let layout = Self::layout(na, self.nb());
        // Safety: made by `new` with this layout; the items need no drop.
        unsafe { dealloc(self.ptr.as_ptr().cast(), layout) };
        self.ptr = NonNull::from(&NO_PAIR);
    }
}

impl<A: Copy, B: Copy> std::fmt::Debug for Pair<A, B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Pair({} B)", self.nb())
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
        let mut e: Pair<(u32, u32), u8> = Pair::new(&[], &[]);
        unsafe {
            assert!(e.a(0).is_empty() && e.b(0).is_empty());
            e.free(0);
            let mut p = Pair::new(&[(1u32, 2u32), (3, 4)], &[7u8, 8, 9]);
            assert_eq!((p.a(2), p.b(2)), (&[(1, 2), (3, 4)][..], &[7, 8, 9][..]));
            p.b_mut(2)[0] = 0;
            let mut q = p.copy(2);
            p.free(2);
            assert_eq!((q.a(2), q.b(2)), (&[(1, 2), (3, 4)][..], &[0, 8, 9][..]));
            q.free(2);
            let mut r: Pair<(u32, u32), u8> = Pair::new(&[], &[5]);
            assert_eq!((r.a(0), r.b(0)), (&[][..], &[5][..]));
            r.free(0);
        }
    }
}
