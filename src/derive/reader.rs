//! Reading a generation: a buffered reader at file offsets (pread), so the
//! main reader and the look-ahead reader of right contexts share one file.

use super::context::skip_branch;
use super::reclaim::Reclaim;
use crate::rules::codec::{self, ENDS_BYTES, INDEX_BYTES, MAX_MODULE_BYTES};
use crate::rules::Alphabet;
use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;

/// A buffered reader at file offsets (pread), so two can share one file.
pub struct PosReader<'f> {
    file: &'f File,
    /// The file has a bracket index (see
    /// [`Out::with_index`](super::sink::Out::with_index)).
    pub(crate) indexed: bool,
    /// Bytes of a `[`: 1, or with the index 1 + its index bytes.
    open_len: usize,
    pub(crate) buf: Vec<u8>,
    /// File offset of `buf[0]`.
    start: u64,
    pos: usize,
    end: usize,
    /// Where the file ends: its length when opened (a generation is
    /// complete before it is read), lowered if a read comes up short.
    /// Reads stop there, so the end of file costs no `pread` returning 0
    /// each time the reader nears it.
    eof: u64,
    /// The last `seek` left the buffer: the next read takes only
    /// [`JUMP_READ`] bytes around the target. A right context that jumps over a branch reads
    /// a few modules after its end, not a whole buffer (issue 15: at `-j 2`
    /// each chunk's look-ahead jumps past the chunk several times, and
    /// whole buffers read there doubled the bytes a context step read).
    jumped: bool,
    /// The bytes buffered before the last jump (`alt.1..alt.1 + alt.2` of
    /// the file in `alt.0`), kept: a walk goes back and forth between the
    /// modules being rewritten and the far end of a branch, and each of
    /// those with one buffer was a read.
    alt: (Vec<u8>, u64, usize),
    /// What of the file the pass gives back ([`Reclaim`]): never read
    /// below it. `frees`: this reader gives back what lies before its
    /// buffer as it reads on (the one reader of a whole generation).
    floor: Option<&'f Reclaim<'f>>,
    frees: bool,
}

/// Bytes read after a jump: four of the largest modules, rounded up to
/// 8 KiB; a quarter before the target ([`PosReader::read_around`]), so at
/// least one largest module after it (a refill comes when fewer are
/// left).
const JUMP_READ: usize = (4 * MAX_MODULE_BYTES).next_multiple_of(8 << 10);

impl<'f> PosReader<'f> {
    pub fn new(file: &'f File, capacity: usize, indexed: bool) -> Self {
        Self::reusing(file, capacity, indexed, Vec::new())
    }

    /// [`PosReader::new`] with `buf` as its buffer (what it held is
    /// overwritten before it is read): a split's worker reads chunk after
    /// chunk, and a new buffer for each cost an allocation and its zeroing
    /// (or, where the allocator maps large blocks, page faults) per chunk.
    /// [`PosReader::into_buffer`] gives it back.
    pub fn reusing(file: &'f File, capacity: usize, indexed: bool, mut buf: Vec<u8>) -> Self {
        let least = 2 * MAX_MODULE_BYTES;
        // Where the file ends, if asked: else found by the first short read.
        let mut eof = u64::MAX;
        let mut want = capacity.max(least);
        if want > buf.capacity() {
            // New memory (a new buffer, or a reused one too small): no
            // bigger than the file, so a short string does not pay for a
            // large buffer. (A batch's tiny job paid for 1 MiB, zeroed, in
            // its second pass: 256 page faults.)
            let len = file.metadata().map_or(u64::MAX, |m| m.len());
            eof = len;
            want = capacity
                .min(usize::try_from(len).unwrap_or(usize::MAX))
                .max(least);
        }
        // Cut or grown to `want` (no read larger than asked); within the
        // buffer's memory without asking the file its length: a split pass
        // makes two readers per chunk, thousands per step.
        buf.resize(want, 0);
        PosReader {
            file,
            indexed,
            open_len: if indexed { 1 + ENDS_BYTES } else { 1 },
            buf,
            start: 0,
            pos: 0,
            end: 0,
            eof,
            jumped: false,
            alt: (Vec::new(), 0, 0),
            floor: None,
            frees: false,
        }
    }

    /// Reading a generation that the pass gives back as it goes
    /// ([`Reclaim`]); `frees`: this reader is the one that says how far.
    pub(crate) fn giving_back(mut self, floor: Option<&'f Reclaim<'f>>, frees: bool) -> Self {
        self.set_floor(floor, frees);
        self
    }

    /// [`PosReader::giving_back`] in place.
    pub(crate) fn set_floor(&mut self, floor: Option<&'f Reclaim<'f>>, frees: bool) {
        self.floor = floor;
        self.frees = frees && floor.is_some();
    }

    /// Its buffer, for [`PosReader::reusing`].
    pub fn into_buffer(self) -> Vec<u8> {
        // The larger: the reader's own, whichever slot it is in.
        if self.alt.0.len() > self.buf.len() {
            self.alt.0
        } else {
            self.buf
        }
    }

    /// The index also holds module counts (see
    /// [`Out::with_counts`](super::sink::Out::with_counts)).
    pub(crate) fn with_counts(mut self, counts: bool) -> Self {
        if self.indexed && counts {
            self.open_len = 1 + INDEX_BYTES;
        }
        self
    }

    /// Bytes of a `[` in this generation.
    #[inline]
    pub(crate) fn open_len(&self) -> usize {
        self.open_len
    }

    #[inline]
    pub fn offset(&self) -> u64 {
        self.start + self.pos as u64
    }

    /// Read only the bytes `start..end` of the file (a chunk of a
    /// generation, `super::par`), as if they were all of it.
    pub(crate) fn limit(&mut self, start: u64, end: u64) {
        self.eof = self.eof.min(end);
        self.start = start;
        self.pos = 0;
        self.end = 0;
    }

    /// Move to file offset `off`, keeping the buffer if it covers `off`.
    #[inline]
    pub fn seek(&mut self, off: u64) {
        if off >= self.start && off <= self.start + self.end as u64 {
            self.pos = (off - self.start) as usize;
        } else {
            self.jump(off);
        }
    }

    /// [`PosReader::seek`] outside the buffer: back to the bytes buffered
    /// before the last jump if they cover `off`, else keep the buffer's
    /// bytes for that and read around `off` ([`PosReader::read_around`]).
    #[cold]
    fn jump(&mut self, off: u64) {
        let (alt, alt_start, alt_end) = &mut self.alt;
        let covered = off >= *alt_start && off <= *alt_start + *alt_end as u64;
        if self.end > 0 || covered {
            std::mem::swap(&mut self.buf, alt);
            std::mem::swap(&mut self.start, alt_start);
            std::mem::swap(&mut self.end, alt_end);
        }
        if covered {
            // Back in a buffer read before: its bytes are where they are
            // (a jump not yet read from must not make the next refill
            // read around this buffer's start instead of going on).
            self.pos = (off - self.start) as usize;
            self.jumped = false;
            return;
        }
        if self.buf.len() < JUMP_READ {
            // (Made once per reader; reading on from a jump goes on in
            // the larger buffer: `refill`.)
            self.buf.resize(JUMP_READ, 0);
        }
        self.start = off;
        self.pos = 0;
        self.end = 0;
        self.jumped = true;
    }

    #[cold]
    pub(crate) fn refill(&mut self) -> io::Result<()> {
        if let Some(r) = self.floor {
            // Nothing before the read position is read again by this
            // reader; if it is the generation's one reader, by none.
            let at = self.start + self.pos as u64;
            if self.frees {
                r.upto(at);
            }
            check_floor(r, at)?;
        }
        if self.start + self.end as u64 >= self.eof {
            return Ok(()); // all the rest is buffered
        }
        if std::mem::take(&mut self.jumped) {
            return self.read_around();
        }
        if self.alt.0.len() > self.buf.len() {
            // Reading on from a jump: on in the larger buffer (what it
            // held before the jump is given up for it; the smaller one
            // keeps what it holds).
            std::mem::swap(&mut self.buf, &mut self.alt.0);
            let rest = self.end - self.pos;
            self.buf[..rest].copy_from_slice(&self.alt.0[self.pos..self.end]);
            self.alt.1 = self.start;
            self.alt.2 = self.end;
            self.start += self.pos as u64;
            self.end = rest;
            self.pos = 0;
        } else {
            self.buf.copy_within(self.pos..self.end, 0);
            self.start += self.pos as u64;
            self.end -= self.pos;
            self.pos = 0;
        }
        // Never past `eof`: a reader limited to a range (`limit`) must not
        // see the bytes after it.
        let want = self.buf.len();
        let room = usize::try_from(self.eof - self.start).map_or(want, |r| r.min(want));
        self.read_to(room)
    }

    /// After a jump (the buffer is empty at `start`): read [`JUMP_READ`]
    /// bytes around the target, a quarter of them before it, so that walks
    /// that jump to the ends of nested branches, which lie side by side
    /// (`...]]]`) and are met from the innermost or the outermost first,
    /// share one read.
    fn read_around(&mut self) -> io::Result<()> {
        let target = self.start;
        let size = JUMP_READ.min(self.buf.len());
        // (Not back into what was given back.)
        let floor = self.floor.map_or(0, |r| r.below());
        let back =
            (size / 4).min(usize::try_from(target.saturating_sub(floor)).unwrap_or(usize::MAX));
        self.start = target - back as u64;
        self.pos = 0;
        self.end = 0;
        let room = usize::try_from(self.eof - self.start).map_or(size, |r| r.min(size));
        self.read_to(room)?;
        if self.end < back {
            // The file ends before the target: nothing there.
            self.start = target;
            self.end = 0;
        } else {
            self.pos = back;
        }
        Ok(())
    }

    /// Read into the buffer up to `room` bytes (less at the end of the
    /// file, which is then known).
    fn read_to(&mut self, room: usize) -> io::Result<()> {
        while self.end < room {
            let n = match self
                .file
                .read_at(&mut self.buf[self.end..room], self.start + self.end as u64)
            {
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if n == 0 {
                self.eof = self.start + self.end as u64;
                break;
            }
            self.end += n;
        }
        Ok(())
    }

    /// The next module: (key, start, end) with its bytes at
    /// `self.bytes(start, end)`.
    #[inline(always)]
    pub fn next_module(&mut self, al: &Alphabet) -> io::Result<Option<(u32, usize, usize)>> {
        if self.end - self.pos < MAX_MODULE_BYTES {
            self.refill()?;
            if self.pos == self.end {
                return Ok(None);
            }
        }
        let s = self.pos;
        let b = self.buf[s];
        if b < 0x80 {
            let n = if b == b'[' { self.open_len } else { 1 };
            self.pos += n;
            return Ok(Some((b as u32, s, s + n)));
        }
        let (key, kl) = codec::get_key(&self.buf[s..]);
        let e = s + kl + 8 * al.arity(key);
        self.pos = e;
        Ok(Some((key, s, e)))
    }

    /// The buffered bytes from the read position (refilled when short).
    #[inline]
    pub fn window(&mut self) -> io::Result<&[u8]> {
        if self.end - self.pos < MAX_MODULE_BYTES {
            self.refill()?;
        }
        Ok(&self.buf[self.pos..self.end])
    }

    #[inline]
    pub fn advance(&mut self, n: usize) {
        self.pos += n;
    }

    #[inline]
    pub fn bytes(&self, s: usize, e: usize) -> &[u8] {
        &self.buf[s..e]
    }

    /// For a `[` read at `s` of a generation indexed with counts: the
    /// offset just past its `]` and the number of modules of its branch,
    /// brackets included.
    #[inline]
    pub(crate) fn branch_index(&self, s: usize) -> (u64, u64) {
        let count = codec::get_word(&self.buf[s + 1 + ENDS_BYTES..]);
        (self.indexed_end(s).unwrap_or(0), count)
    }

    /// For a `[` read at `s` of an indexed generation: the offset just
    /// past its `]` (the index holds the distance to it), None if it is
    /// never closed (its index is 0).
    #[inline]
    pub(crate) fn indexed_end(&self, s: usize) -> Option<u64> {
        codec::branch_dist(&self.buf[s + 1..]).map(|dist| self.start + s as u64 + dist)
    }

    /// For a `[` read at `s` (next module at `next`): the offset just past
    /// its `]`, from the index or by scanning.
    #[inline]
    pub(crate) fn branch_end(
        &mut self,
        al: &Alphabet,
        s: usize,
        next: u64,
    ) -> io::Result<Option<u64>> {
        if self.indexed {
            Ok(self.indexed_end(s))
        } else {
            skip_branch(self, al, next)
        }
    }
}

/// A reader about to read from `at` on, which must not be given back.
#[cold]
fn check_floor(r: &Reclaim, at: u64) -> io::Result<()> {
    if at < r.below() {
        return Err(io::Error::other(format!(
            "offset {at} was read after the pass gave it back (below {})",
            r.below()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::Filter;
    use std::io::{Seek, SeekFrom, Write};

    /// Once the reader has met the end of the generation it does not ask
    /// the file again (issue 15: thousands of `pread`s returning 0 per
    /// context step). Bytes appended afterwards are never seen, which
    /// shows that no read reached the file past the end.
    #[test]
    fn end_of_file_is_read_once() {
        let al = Alphabet::new(Filter::All);
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(b"F1[F]1").unwrap();
        let mut rd = PosReader::new(&f, 1 << 16, false);
        read_to_the_end_and_no_further(&mut rd, &f, &al);
        assert!(rd.window().unwrap().is_empty());
        // Going back within the buffer still reads the generation.
        rd.seek(4);
        assert_eq!(rd.next_module(&al).unwrap(), Some((b']' as u32, 4, 5)));
    }

    /// A reader on a reused buffer does not ask the file its length (a
    /// split pass makes readers per chunk): it finds the end by one short
    /// read, and asks no more after it.
    #[test]
    fn a_reused_buffer_finds_the_end_by_reading() {
        let al = Alphabet::new(Filter::All);
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(b"F1[F]1").unwrap();
        let mut buf = Vec::with_capacity(1 << 16);
        buf.resize(100, 7);
        let mut rd = PosReader::reusing(&f, 1 << 16, false, buf);
        assert_eq!(rd.eof, u64::MAX);
        read_to_the_end_and_no_further(&mut rd, &f, &al);
    }

    /// A reused buffer that must grow (new memory) grows no bigger than
    /// the file: a batch's tiny job got 1 MiB, zeroed, in its second pass.
    #[test]
    fn a_reused_buffer_grows_no_bigger_than_the_file() {
        let al = Alphabet::new(Filter::All);
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(b"F1[F]1").unwrap();
        let mut rd = PosReader::reusing(&f, 1 << 20, false, vec![7; 100]);
        assert_eq!(rd.buf.len(), 2 * MAX_MODULE_BYTES);
        assert_eq!(rd.eof, 6);
        read_to_the_end_and_no_further(&mut rd, &f, &al);
    }

    /// `rd` reads `F1[F]1`, the whole of `f`; bytes appended to `f` then
    /// are never seen, which shows that no read reached past the end.
    fn read_to_the_end_and_no_further(rd: &mut PosReader, f: &File, al: &Alphabet) {
        let mut keys = Vec::new();
        while let Some((key, s, e)) = rd.next_module(al).unwrap() {
            assert_eq!(rd.bytes(s, e).len(), 1);
            keys.push(key as u8);
        }
        assert_eq!(keys, b"F1[F]1");
        let mut w = f;
        w.seek(SeekFrom::End(0)).unwrap();
        w.write_all(b"FF").unwrap();
        assert_eq!(rd.next_module(al).unwrap(), None);
    }

    /// A jump not yet read from, then a seek back into the buffer the jump
    /// left (the one before it): reading on from there goes on through the
    /// file. The jump's mark stayed set, and the next refill read around
    /// that buffer's start instead: the reader went back thousands of
    /// bytes and read modules from inside parameters (a crash at every
    /// `-j` and wrong strings at `-j 1` on long context-sensitive strings;
    /// found by the review helper's differential campaign).
    #[test]
    fn a_seek_back_before_reading_a_jump_reads_on() {
        const N: usize = 1 << 17;
        let byte = |i: u64| b'A' + (i % 26) as u8;
        let text: Vec<u8> = (0..N as u64).map(byte).collect();
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(&text).unwrap();
        let al = Alphabet::new(Filter::All);
        let mut rd = PosReader::new(&f, 4096, false);
        for i in 0..100u64 {
            assert_eq!(rd.next_module(&al).unwrap().unwrap().0, u32::from(byte(i)));
        }
        // Out of the buffer, and back into it before reading there.
        rd.seek(100_000);
        rd.seek(10);
        let mut at = 10u64;
        while at < 60_000 {
            assert_eq!(rd.offset(), at);
            let (key, ..) = rd.next_module(&al).unwrap().unwrap();
            assert_eq!(key, u32::from(byte(at)), "at {at}");
            at += 1;
        }
        // And the jump itself still reads where it goes.
        rd.seek(100_000);
        assert_eq!(
            rd.next_module(&al).unwrap().unwrap().0,
            u32::from(byte(100_000))
        );
    }

    /// After a jump (a seek outside the buffer) the reader reads a few
    /// modules' worth, not a whole buffer; reading on from there, whole
    /// buffers again.
    #[test]
    fn nothing_given_back_is_read_again() {
        use crate::derive::reclaim::Reclaim;
        const N: usize = 1 << 16;
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(&[b'A'; N]).unwrap();
        let al = Alphabet::new(Filter::All);
        let r = Reclaim::new(&f, true);
        // The generation's one reader gives back what lies before its
        // buffer as it reads on.
        let mut rd = PosReader::new(&f, 4096, false).giving_back(Some(&r), true);
        for _ in 0..30_000 {
            rd.next_module(&al).unwrap().unwrap();
        }
        let below = r.below();
        assert!(below > 20_000 && below <= 30_000, "{below}");
        let mut back = vec![1u8; N];
        f.read_exact_at(&mut back, 0).unwrap();
        assert!(back[..below as usize].iter().all(|&b| b == 0));
        assert!(back[below as usize..].iter().all(|&b| b == b'A'));
        // Another reader is refused there, also where it jumps to.
        let mut peek = PosReader::new(&f, 4096, false).giving_back(Some(&r), false);
        assert!(peek.next_module(&al).is_err());
        peek.seek(below - 1);
        assert!(peek.next_module(&al).is_err());
        // From there on it reads, and never the bytes before it (a jump
        // reads some bytes before its target).
        peek.seek(below);
        assert_eq!(peek.next_module(&al).unwrap().unwrap().0, u32::from(b'A'));
        peek.seek(below + 100);
        assert_eq!(peek.next_module(&al).unwrap().unwrap().0, u32::from(b'A'));
        assert!(peek.start >= below);
        // The one reader reads on to the end.
        let mut n = 30_000;
        while rd.next_module(&al).unwrap().is_some() {
            n += 1;
        }
        assert_eq!(n, N);
    }

    #[test]
    fn a_jump_reads_little_and_reading_on_reads_whole_buffers() {
        let al = Alphabet::new(Filter::All);
        let mut f = tempfile::tempfile().unwrap();
        f.write_all(&vec![b'F'; 1 << 20]).unwrap();
        let mut rd = PosReader::new(&f, 1 << 16, false);
        assert_eq!(rd.window().unwrap().len(), 1 << 16);
        rd.seek(1 << 19);
        // Half the read after the target, half before it.
        assert_eq!(rd.window().unwrap().len(), JUMP_READ * 3 / 4);
        // Back where the jump came from, and there again: the bytes of
        // both are kept, neither seek reads.
        rd.seek(100);
        assert!(!rd.jumped);
        assert_eq!(rd.window().unwrap().len(), (1 << 16) - 100);
        rd.seek(1 << 19);
        assert!(!rd.jumped);
        assert_eq!(rd.window().unwrap().len(), JUMP_READ * 3 / 4);
        const { assert!(JUMP_READ < 1 << 16) };
        // A jump back to just before the target is no jump.
        rd.seek((1 << 19) - 100);
        assert!(!rd.jumped);
        assert_eq!(rd.window().unwrap().len(), JUMP_READ * 3 / 4 + 100);
        rd.seek(1 << 19);
        // Every byte is read, in order, across the small read.
        for i in 0..(1 << 17) {
            assert_eq!(rd.offset(), (1 << 19) + i);
            assert_eq!(
                rd.next_module(&al).unwrap().map(|m| m.0),
                Some(u32::from(b'F'))
            );
        }
        assert_eq!(rd.window().unwrap().len() + rd.pos, 1 << 16);
        // Near the start of the file, less before the target.
        rd.seek(10);
        assert_eq!(rd.offset(), 10);
        assert_eq!(rd.window().unwrap().len(), JUMP_READ - 10);
        // Past the end of the file, nothing.
        rd.seek((1 << 20) + 5);
        assert!(rd.window().unwrap().is_empty());
        assert_eq!(rd.offset(), (1 << 20) + 5);
        rd.seek((1 << 20) - 1);
        assert_eq!(
            rd.next_module(&al).unwrap().map(|m| m.0),
            Some(u32::from(b'F'))
        );
        assert_eq!(rd.next_module(&al).unwrap(), None);
        // A seek within the buffer is no jump.
        let at = rd.offset() - 10;
        rd.seek(at);
        assert!(!rd.jumped);
        assert_eq!(rd.offset(), at);
    }
}
