//! Index words of `[`s whose bytes are already in the generation's file,
//! written in batches.
//!
//! A `]` whose `[` was flushed before it came patches that `[`'s index
//! words in the file ([`super::sink::Out`]). One `pwrite` each was one
//! system call of 6 bytes per such `[`: a string nested 10^6 deep made
//! 914,057 of them. Batched, they are sorted by offset, and patches close
//! together share one read and one write of the bytes between them (the
//! `[`s of a deep nest sit a few bytes apart).

use crate::diag::IoAction;
use crate::rules::codec::INDEX_BYTES;
use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;

/// Patches held before they are written (24 bytes each).
pub(crate) const BATCH: usize = 4096;
/// Patches at most this many bytes apart share a read and a write.
const GAP: u64 = 4096;
/// The most bytes one read and write cover.
const SPAN: u64 = 1 << 16;

#[derive(Clone, Copy)]
struct Patch {
    /// Offset of the first byte in the file.
    at: u64,
    len: u8,
    bytes: [u8; INDEX_BYTES],
}

/// Pending patches of a file; what it holds is bounded by [`BATCH`]. The
/// owner writes them when [`Patches::push`] says the batch is full and
/// before anything reads the file.
#[derive(Default)]
pub(crate) struct Patches {
    pending: Vec<Patch>,
    /// The bytes one read and write cover, reused.
    scratch: Vec<u8>,
    /// System calls made, for tests.
    #[cfg(test)]
    pub(crate) calls: usize,
}

impl Patches {
    /// Note `bytes` (at most [`INDEX_BYTES`]) for offset `at`; true when
    /// the batch is full.
    pub(crate) fn push(&mut self, at: u64, bytes: &[u8]) -> bool {
        let mut p = Patch {
            at,
            len: bytes.len() as u8,
            bytes: [0; INDEX_BYTES],
        };
        p.bytes[..bytes.len()].copy_from_slice(bytes);
        if self.pending.capacity() == 0 {
            self.pending.reserve_exact(BATCH);
        }
        self.pending.push(p);
        self.pending.len() >= BATCH
    }

    /// Write every pending patch to `file`: a patch alone with one
    /// `pwrite`, a group of patches close together (within [`GAP`] of
    /// each other, [`SPAN`] in all) with one read and one write of the
    /// bytes they cover. The bytes between them must be in the file.
    pub(crate) fn write(&mut self, file: &File) -> Result<(), (IoAction, io::Error)> {
        self.pending.sort_unstable_by_key(|p| p.at);
        let p = &self.pending;
        let mut i = 0;
        while i < p.len() {
            let start = p[i].at;
            let mut end = start + u64::from(p[i].len);
            let mut j = i + 1;
            while j < p.len() {
                let e = p[j].at + u64::from(p[j].len);
                if p[j].at > end + GAP || e - start > SPAN {
                    break;
                }
                end = end.max(e);
                j += 1;
            }
            if j == i + 1 {
                let q = &p[i];
                file.write_all_at(&q.bytes[..usize::from(q.len)], q.at)
                    .map_err(|e| (IoAction::Write, e))?;
            } else {
                let s = &mut self.scratch;
                s.clear();
                s.resize((end - start) as usize, 0);
                file.read_exact_at(s, start)
                    .map_err(|e| (IoAction::Read, e))?;
                for q in &p[i..j] {
                    let o = (q.at - start) as usize;
                    s[o..o + usize::from(q.len)].copy_from_slice(&q.bytes[..usize::from(q.len)]);
                }
                file.write_all_at(s, start)
                    .map_err(|e| (IoAction::Write, e))?;
                #[cfg(test)]
                {
                    self.calls += 1;
                }
            }
            #[cfg(test)]
            {
                self.calls += 1;
            }
            i = j;
        }
        self.pending.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Seek, Write};

    /// Random patches over a file (any order, lengths 1..=INDEX_BYTES, far
    /// apart or touching, never overlapping) leave the bytes one `pwrite`
    /// each would have, with fewer system calls where they are close.
    #[test]
    fn batched_patches_write_what_single_writes_would() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % n
        };
        for round in 0..40 {
            let len = 1 + next(300_000);
            let base: Vec<u8> = (0..len).map(|i| (i * 7 + round) as u8).collect();
            let mut file = tempfile::tempfile().unwrap();
            file.write_all(&base).unwrap();
            let mut want = base.clone();
            let mut patches = Patches::default();
            // Non-overlapping slots: a walk with gaps of every size.
            let mut slots = Vec::new();
            let mut at = next(20);
            let dense = round % 3 == 0;
            while at + INDEX_BYTES as u64 <= len {
                let n = 1 + next(INDEX_BYTES as u64);
                slots.push((at, n as usize));
                at += n + if dense { next(10) } else { next(20_000) };
            }
            // In a shuffled order.
            for k in (1..slots.len()).rev() {
                slots.swap(k, next(k as u64 + 1) as usize);
            }
            for &(at, n) in &slots {
                let bytes: Vec<u8> = (0..n).map(|_| next(256) as u8).collect();
                want[at as usize..at as usize + n].copy_from_slice(&bytes);
                if patches.push(at, &bytes) {
                    patches.write(&file).unwrap();
                }
            }
            patches.write(&file).unwrap();
            let mut got = Vec::new();
            file.rewind().unwrap();
            file.read_to_end(&mut got).unwrap();
            assert!(got == want, "round {round}: bytes differ");
            if dense && slots.len() > 100 {
                assert!(
                    patches.calls * 20 < slots.len(),
                    "round {round}: {} calls for {} patches",
                    patches.calls,
                    slots.len()
                );
            }
        }
    }
}
