//! Giving back a temporary generation's pages as a pass reads it.
//!
//! The last two passes of a run read generations whose files are never
//! written over again ([`super::step_passes`]: a generation's file takes
//! the one two passes later). Without this they stay whole in the page
//! cache until the run ends: a 3-step context run at 10^9 held 4.3 GB of
//! page cache to its end, and the kernel wrote about 1 GB of temporary
//! generations to disk in each run, data deleted a moment later
//! (benches/RESULTS.md). Each pass now punches the
//! part of its input it has read and will not read again out of the file
//! (`fallocate(FALLOC_FL_PUNCH_HOLE)`): those pages are freed unwritten and
//! the pass's output takes them, instead of fresh ones.
//!
//! Who may give what back: one thread reading the whole generation (the
//! main reader of [`super::Deriver::pass`]) gives back what lies before
//! its read position whenever it refills; in a split pass ([`super::par`]) the
//! writer, which completes chunks in string order, gives back what lies
//! before the end of each chunk it completes. Every reader of the
//! generation (the workers', the split's scan) checks that it never reads
//! below what was given back ([`super::PosReader`]): a read there is an
//! error, never zeros taken for modules.

use std::fs::File;
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Give back at least this many bytes at a time: one `fallocate` per
/// 16 MiB read.
const STRIDE: u64 = 16 << 20;

/// The part of a temporary generation a pass has given back.
pub(crate) struct Reclaim<'f> {
    file: &'f File,
    /// Bytes below this offset are given back (or being given back): no
    /// reader may read them.
    below: AtomicU64,
    /// Give back in steps of at least this many bytes ([`STRIDE`]; 1 in
    /// tests that split small strings).
    stride: u64,
    /// False after a punch failed (a file system without holes): the pages
    /// then stay until the run drops the file, as before.
    on: AtomicBool,
}

impl<'f> Reclaim<'f> {
    /// For the generation in `file`, read by one pass; `small`: give back
    /// byte by byte (tests: `Options::split`, `LSGEN_TEST_SPLIT`).
    pub(crate) fn new(file: &'f File, small: bool) -> Self {
        Reclaim {
            file,
            below: AtomicU64::new(0),
            stride: if small { 1 } else { STRIDE },
            on: AtomicBool::new(true),
        }
    }

    /// The offset below which the generation is given back.
    #[inline]
    pub(crate) fn below(&self) -> u64 {
        self.below.load(Ordering::Acquire)
    }

    /// Nothing below `off` is read again: give it back, if at least a
    /// stride lies there since the last time.
    pub(crate) fn upto(&self, off: u64) {
        let from = self.below();
        // Whole pages (a punch within a page only zeroes it).
        let to = if self.stride >= 4096 {
            off & !4095
        } else {
            off
        };
        if to < from.saturating_add(self.stride) || !self.on.load(Ordering::Relaxed) {
            return;
        }
        // The mark first: a read that races with the punch is refused.
        self.below.store(to, Ordering::Release);
        let (Ok(at), Ok(len)) = (
            libc::off_t::try_from(from),
            libc::off_t::try_from(to - from),
        ) else {
            return;
        };
        // SAFETY: a plain system call on an open descriptor; it reads no
        // memory of ours.
        let r = unsafe {
            libc::fallocate(
                self.file.as_raw_fd(),
                libc::FALLOC_FL_PUNCH_HOLE | libc::FALLOC_FL_KEEP_SIZE,
                at,
                len,
            )
        };
        if r != 0 {
            // Not supported here (or failed): the bytes are all still
            // there; give nothing more back.
            self.on.store(false, Ordering::Relaxed);
        } else {
            #[cfg(test)]
            GIVEN_BACK.with(|g| g.set(g.get() + (to - from)));
        }
    }
}

#[cfg(test)]
thread_local! {
    /// Bytes given back on this thread (tests: the passes that give back
    /// do it on the calling thread, the split's writer too).
    pub(crate) static GIVEN_BACK: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::os::unix::fs::FileExt;

    /// Given-back bytes read as zeros and take no room; the rest is kept.
    #[test]
    fn what_is_given_back_is_a_hole_and_the_rest_stays() {
        let mut f = tempfile::tempfile().unwrap();
        let data: Vec<u8> = (0..(3u32 << 20)).map(|i| (i % 251) as u8 + 1).collect();
        f.write_all(&data).unwrap();
        f.sync_all().unwrap();
        let r = Reclaim::new(&f, false);
        // Less than a stride: nothing.
        r.upto(1 << 20);
        assert_eq!(r.below(), 0);
        let r = Reclaim {
            stride: 4096,
            ..Reclaim::new(&f, false)
        };
        r.upto((2 << 20) + 100);
        assert_eq!(r.below(), 2 << 20, "whole pages only");
        let mut back = vec![0u8; data.len()];
        f.read_exact_at(&mut back, 0).unwrap();
        assert!(
            r.on.load(Ordering::Relaxed),
            "the temp directory's file system punches holes"
        );
        let zeros = back.iter().take_while(|&&b| b == 0).count();
        assert_eq!(zeros, 2 << 20);
        assert_eq!(back[2 << 20..], data[2 << 20..]);
        assert_eq!(
            f.metadata().unwrap().len(),
            data.len() as u64,
            "same length"
        );
    }

    /// Byte by byte (tests): exactly the bytes asked for.
    #[test]
    fn small_strides_give_back_exact_bytes() {
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(b"abcdefgh").unwrap();
        let r = Reclaim::new(&f, true);
        r.upto(3);
        r.upto(2);
        assert_eq!(r.below(), 3);
        let mut back = [0u8; 8];
        f.read_exact_at(&mut back, 0).unwrap();
        assert!(r.on.load(Ordering::Relaxed));
        assert_eq!(&back, b"\0\0\0defgh");
    }
}
