//! The sink of one generation: binary (a temp file, optionally with a
//! bracket index) or text (the output), buffered, counting modules and
//! bytes against `--max-length`.

use super::{spares, Pass};
use crate::diag::{Error, LengthUnit, OptionNames, RuntimeError};
use crate::rules::codec::{self, ENDS_BYTES, INDEX_BYTES, MAX_MODULE_BYTES};
use crate::rules::{Alphabet, ConstRun, CLOSE, OPEN};
use std::fs::File;
use std::io::Write;

pub(crate) const OUT_CHUNK: usize = 1 << 20;

/// The buffer of [`Out::new`]: a chunk and room for the module that ends
/// past it.
const OUT_BUF: usize = OUT_CHUNK + MAX_MODULE_BYTES * 4;

impl Drop for Out<'_> {
    fn drop(&mut self) {
        // (A buffer taken over by `taker`, or grown far, is not kept.)
        if spares::keeping() && (OUT_BUF..=2 * OUT_BUF).contains(&self.buf.capacity()) {
            if let Some(cache) = self.num.take_cache() {
                spares::leave_out((std::mem::take(&mut self.buf), cache));
            }
        }
    }
}

/// Limits on the size of any generation (`--max-length`).
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Most modules in any generation.
    pub modules: u64,
    /// Most bytes in any generation (of the binary temporary format for
    /// intermediate generations, of the text for the last).
    pub bytes: u64,
}

impl Limits {
    /// Is a generation of `modules` modules and `bytes` bytes, made by
    /// `pass`, too long? (The error names the limits as the library has
    /// them; `LSystem::run` renames them for the binary.)
    pub fn check(&self, modules: u64, bytes: u64, pass: Pass) -> Result<(), Error> {
        if modules > self.modules {
            return Err(Error::new(RuntimeError::TooLong {
                limit: self.modules,
                unit: LengthUnit::Modules,
                pass,
                names: OptionNames::Library,
            }));
        }
        if bytes > self.bytes {
            return Err(Error::new(RuntimeError::TooLong {
                limit: self.bytes,
                unit: LengthUnit::Bytes,
                pass,
                names: OptionNames::Library,
            }));
        }
        Ok(())
    }
}

impl Limits {
    /// Check the lengths of generations 1, 2, ... against the limits, as
    /// the step engine would: modules for every generation; bytes for those
    /// written in binary (all but the last, which is text, unless a
    /// homomorphism follows it: the text is checked as it is written).
    /// `lengths[0]` is step `first_step`'s (`--first-step`), and the error
    /// names the step so, as the step engine does.
    pub fn check_generations(
        &self,
        lengths: &[(u64, u64)],
        last_is_text: bool,
        first_step: u64,
    ) -> Result<(), Error> {
        for (i, (&(n, bytes), step)) in lengths.iter().zip(first_step..).enumerate() {
            let bytes = if last_is_text && i + 1 == lengths.len() {
                0
            } else {
                bytes
            };
            self.check(n, bytes, Pass::Step(step))?;
        }
        Ok(())
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            modules: u64::MAX,
            bytes: u64::MAX,
        }
    }
}

/// What of a chunk's bracket index a worker cannot write itself (it does
/// not know where the writer puts the chunk, and hands blocks over as they
/// fill), relative to the chunk's start (offset in the output, modules
/// before): [`Out::with_chunk_index`].
#[derive(Default, Debug)]
pub(crate) struct ChunkIndex {
    /// The worker's stream position where the chunk started.
    base: (u64, u64),
    /// `]`s that close a `[` of an earlier chunk, in order: (offset just
    /// past the `]`, modules through it).
    closes: Vec<(u64, u64)>,
    /// `[`s closed in this chunk after their block was handed over:
    /// (offset of the `[`, its distance, its module count).
    late: Vec<(u64, u64, u64)>,
    /// `[`s still open at the chunk's end: (offset, modules before it).
    opens: Vec<(u64, u64)>,
}

/// A buffered sink for one generation, binary or text.
pub struct Out<'w> {
    pub(crate) buf: Vec<u8>,
    w: &'w mut dyn Write,
    /// Bracket index mode: each `[` carries the distance from it to just
    /// past its `]`, patched in the buffer or, once flushed, in
    /// `index_file` (or noted in `chunk_index`).
    pub(crate) indexed: bool,
    index_file: Option<File>,
    /// Index words for `index_file`, written in batches.
    patches: super::patches::Patches,
    /// A worker's sink of a split pass (`super::split`): what of the index
    /// its chunk cannot complete itself, for the writer.
    chunk_index: Option<ChunkIndex>,
    /// Each open `[`: its offset, and the modules written before it.
    opens: Vec<(u64, u64)>,
    /// The index also holds each branch's module count.
    counts: bool,
    name: &'w str,
    pub text: bool,
    pub(crate) modules: u64,
    written: u64,
    num: codec::NumFmt,
    limits: Limits,
    /// What this generation is, for `--max-length` errors.
    pass: Pass,
    /// A progress display's meter, if one is installed.
    meter: Option<std::sync::Arc<super::meter::Meter>>,
    /// Flush when the buffer holds this much (`OUT_CHUNK`; less for the
    /// blocks of parallel tasks, `super::par`).
    pub(crate) chunk: usize,
    /// Where full buffers go whole, in place of `w` (a parallel task's
    /// blocks, `super::par`): no copy.
    pub(crate) taker: Option<&'w dyn Take>,
    /// The output's switch for writing around the page cache
    /// ([`crate::Options::direct_output`], [`Out::around_cache`]).
    pub(crate) direct: Option<std::sync::Arc<std::sync::atomic::AtomicU8>>,
}

/// Append `b` to `buf`: runs of at most 16 bytes (most constant runs:
/// `[+(30)`, `]`) by two overlapping fixed-size copies, inline, where a
/// call to `memcpy` cost parametric_tree about 3 % of its time.
#[inline(always)]
fn append_short(buf: &mut Vec<u8>, b: &[u8]) {
    let (n, len) = (b.len(), buf.len());
    if n > 16 || buf.capacity() - len < 16 {
        buf.extend_from_slice(b);
        return;
    }
    let (src, dst) = (b.as_ptr(), buf.as_mut_ptr());
    // SAFETY: every read is within `b` (each copy's start and end lie in
    // 0..n); every write is within `len..len + n`, spare capacity (16
    // bytes of it checked above), which `set_len` then marks written.
    unsafe {
        let dst = dst.add(len);
        if n >= 8 {
            let (x, y) = (
                src.cast::<u64>().read_unaligned(),
                src.add(n - 8).cast::<u64>().read_unaligned(),
            );
            dst.cast::<u64>().write_unaligned(x);
            dst.add(n - 8).cast::<u64>().write_unaligned(y);
        } else if n >= 4 {
            let (x, y) = (
                src.cast::<u32>().read_unaligned(),
                src.add(n - 4).cast::<u32>().read_unaligned(),
            );
            dst.cast::<u32>().write_unaligned(x);
            dst.add(n - 4).cast::<u32>().write_unaligned(y);
        } else if n > 0 {
            *dst = *src;
            *dst.add(n / 2) = *src.add(n / 2);
            *dst.add(n - 1) = *src.add(n - 1);
        }
        buf.set_len(len + n);
    }
}

/// The output's switch for writing around the page cache, on while this
/// lives ([`Out::around_cache`]).
pub(crate) struct AroundCache(std::sync::Arc<std::sync::atomic::AtomicU8>);

impl Drop for AroundCache {
    fn drop(&mut self) {
        let off = crate::io::output::around_cache::OFF;
        self.0.store(off, std::sync::atomic::Ordering::Relaxed);
    }
}

/// A destination that takes a full buffer over (leaving an empty one in
/// its place) rather than copying it: the workers of `super::par`.
pub(crate) trait Take {
    fn take(&self, buf: &mut Vec<u8>) -> std::io::Result<()>;
}

impl<'w> Out<'w> {
    pub fn new(w: &'w mut dyn Write, name: &'w str, text: bool, limits: Limits) -> Out<'w> {
        match spares::take_out() {
            Some((buf, cache)) => {
                let num = codec::NumFmt::with_cache(cache);
                Self::with_parts(w, name, text, limits, buf, num)
            }
            None => {
                let buf = Vec::with_capacity(OUT_BUF);
                Self::with_buffer(w, name, text, limits, buf)
            }
        }
    }

    /// [`Out::new`] with `buf` (emptied) as its buffer: a split's worker
    /// takes a block of its own size, which is what it sends on, instead
    /// of a new buffer of a file's size (which would join the blocks in
    /// use).
    pub(crate) fn with_buffer(
        w: &'w mut dyn Write,
        name: &'w str,
        text: bool,
        limits: Limits,
        buf: Vec<u8>,
    ) -> Out<'w> {
        Self::with_parts(w, name, text, limits, buf, codec::NumFmt::new())
    }

    fn with_parts(
        w: &'w mut dyn Write,
        name: &'w str,
        text: bool,
        limits: Limits,
        mut buf: Vec<u8>,
        num: codec::NumFmt,
    ) -> Out<'w> {
        buf.clear();
        Out {
            buf,
            w,
            indexed: false,
            index_file: None,
            patches: Default::default(),
            chunk_index: None,
            opens: Vec::new(),
            counts: false,
            name,
            text,
            modules: 0,
            written: 0,
            num,
            limits,
            pass: Pass::Axiom,
            meter: super::meter::current(),
            chunk: OUT_CHUNK,
            taker: None,
            direct: None,
        }
    }

    /// Name the pass that makes this generation (default: the axiom).
    pub fn for_pass(mut self, pass: Pass) -> Self {
        self.pass = pass;
        self
    }

    /// Write a bracket index: `file` is the file this sink writes to.
    pub fn with_index(mut self, file: File) -> Self {
        self.indexed = true;
        self.index_file = Some(file);
        self
    }

    /// A worker's sink of a split pass whose output has a bracket index
    /// (`counts`: with module counts): the index of each chunk's output
    /// is written where it can be (a branch within a block), and the rest
    /// is handed to the writer ([`Out::end_chunk`], [`Out::apply`]).
    pub(crate) fn with_chunk_index(mut self, counts: bool) -> Self {
        self.indexed = true;
        self.counts = counts;
        self.chunk_index = Some(ChunkIndex::default());
        self
    }

    /// Does the index hold module counts?
    pub(crate) fn counts(&self) -> bool {
        self.counts
    }

    /// Where the next module goes: (stream offset, modules before it).
    pub(crate) fn position(&self) -> (u64, u64) {
        (self.written + self.buf.len() as u64, self.modules)
    }

    /// While the guard lives, the output writes this sink's final text
    /// around the page cache, if it can (`io::output::WriteBehind`): for
    /// passes that make text slower than the disk takes it (parametric
    /// and step-by-step passes, the split's writer), not D0L expansion.
    /// None for a temporary generation or an output without the switch.
    /// `behind`: full buffers are written by a thread of the output's own
    /// (`io::output::around_cache::BEHIND`), not by this one.
    pub(crate) fn around_cache(&self, behind: bool) -> Option<AroundCache> {
        use crate::io::output::around_cache::{BEHIND, HERE};
        let switch = self.direct.clone().filter(|_| self.text)?;
        let mode = if behind { BEHIND } else { HERE };
        switch.store(mode, std::sync::atomic::Ordering::Relaxed);
        Some(AroundCache(switch))
    }

    /// A worker's next chunk starts here (its sink flushed).
    pub(crate) fn begin_chunk(&mut self) {
        let base = self.position();
        if let Some(ci) = &mut self.chunk_index {
            *ci = ChunkIndex {
                base,
                ..ChunkIndex::default()
            };
        }
        self.opens.clear();
    }

    /// The chunk's index entries the writer completes, its `[`s still open
    /// included; offsets and counts relative to the chunk's start.
    pub(crate) fn end_chunk(&mut self) -> Option<Box<ChunkIndex>> {
        let ci = self.chunk_index.as_mut()?;
        let (w, m) = ci.base;
        ci.opens.extend(
            self.opens
                .drain(..)
                .map(|(at, before)| (at - w, before - m)),
        );
        Some(Box::new(std::mem::take(ci)))
    }

    /// The writer's side: complete the index of a chunk whose output
    /// started at `base` ([`Out::position`] then) and is now all written
    /// here. Its `]`s that close earlier chunks' `[`s in order, then the
    /// late entries, then its open `[`s join this sink's.
    pub(crate) fn apply(&mut self, ci: &ChunkIndex, (w, m): (u64, u64)) -> Result<(), Error> {
        for &(end, through) in &ci.closes {
            self.patch(w + end, m + through)?;
        }
        for &(at, dist, count) in &ci.late {
            self.put_index(w + at, dist, count)?;
        }
        self.opens
            .extend(ci.opens.iter().map(|&(at, before)| (w + at, m + before)));
        Ok(())
    }

    /// With a bracket index, also write each branch's module count (see
    /// [`codec::INDEX_BYTES`]).
    pub fn with_counts(mut self, counts: bool) -> Self {
        self.counts = counts;
        self
    }

    /// Index bytes after each `[`.
    #[inline(always)]
    fn index_len(&self) -> usize {
        if self.counts {
            INDEX_BYTES
        } else {
            ENDS_BYTES
        }
    }

    /// Write a `[` (already counted in `modules`).
    #[inline(always)]
    pub(crate) fn open(&mut self) {
        self.open_after(self.modules - 1);
    }

    /// Write a `]` (already counted in `modules`).
    #[inline(always)]
    pub(crate) fn close(&mut self) -> Result<(), Error> {
        self.close_after(self.modules)
    }

    /// Write a `[` with `before` modules before it.
    #[inline(always)]
    fn open_after(&mut self, before: u64) {
        if self.indexed {
            self.opens
                .push((self.written + self.buf.len() as u64, before));
            self.buf.push(b'[');
            // (Fixed-size copies: no call to memcpy.)
            if self.counts {
                self.buf.extend_from_slice(&[0; INDEX_BYTES]);
            } else {
                self.buf.extend_from_slice(&[0; ENDS_BYTES]);
            }
        } else {
            self.buf.push(b'[');
        }
    }

    /// Write a `]`, the last of `through` modules.
    #[inline(always)]
    fn close_after(&mut self, through: u64) -> Result<(), Error> {
        self.buf.push(b']');
        if self.indexed {
            let end = self.written + self.buf.len() as u64;
            self.patch(end, through)?;
        }
        Ok(())
    }

    /// The `]` ending just before offset `end`, with `modules` modules
    /// written up to it, closes the last open `[`: write the distance to
    /// `end` and the branch's module count into that `[`'s index bytes.
    #[inline]
    pub(crate) fn patch(&mut self, end: u64, modules: u64) -> Result<(), Error> {
        let Some((at, before)) = self.opens.pop() else {
            self.close_unopened(end, modules);
            return Ok(()); // unbalanced: reported by the balance check
        };
        self.put_index(at, end - at, modules - before)
    }

    /// A `]` with no `[` open: a worker's `]` of a `[` in an earlier
    /// chunk, noted for the writer; else unbalanced.
    #[cold]
    fn close_unopened(&mut self, end: u64, modules: u64) {
        if let Some(ci) = &mut self.chunk_index {
            ci.closes.push((end - ci.base.0, modules - ci.base.1));
        }
    }

    /// Write the index of the `[` at `at`, in the buffer or, once flushed,
    /// in the file (a worker: noted for the writer).
    #[inline]
    fn put_index(&mut self, at: u64, dist: u64, count: u64) -> Result<(), Error> {
        // (A branch has no more modules than bytes: `count` fits too.)
        if dist > codec::WORD_MAX {
            return Err(self.branch_too_long());
        }
        if at < self.written {
            return self.put_index_flushed(at, dist, count);
        }
        let i = (at - self.written) as usize + 1;
        // (Fixed-size copies: no call to memcpy.)
        codec::put_word(&mut self.buf[i..], dist);
        if self.counts {
            codec::put_word(&mut self.buf[i + ENDS_BYTES..], count);
        }
        Ok(())
    }

    #[cold]
    fn branch_too_long(&self) -> Error {
        Error::new(RuntimeError::BranchTooLong(self.pass))
    }

    /// The `[` at `at` is flushed; its index bytes may not all be: the
    /// writer of a split pass copies spilled text in pieces that can cut
    /// a `[` from its index. The flushed part goes to the file, the rest
    /// to the buffer (which is written after it).
    #[cold]
    fn put_index_flushed(&mut self, at: u64, dist: u64, count: u64) -> Result<(), Error> {
        if let Some(ci) = &mut self.chunk_index {
            ci.late.push((at - ci.base.0, dist, count));
        } else if self.index_file.is_some() {
            let mut index = [0; INDEX_BYTES];
            codec::put_word(&mut index, dist);
            codec::put_word(&mut index[ENDS_BYTES..], count);
            let index = &index[..self.index_len()];
            // Index bytes before the buffer (flushed): `at + 1` is at
            // most `written`.
            let flushed = usize::try_from(self.written - (at + 1))
                .map_or(index.len(), |n| n.min(index.len()));
            let (in_file, in_buf) = index.split_at(flushed);
            self.buf[..in_buf.len()].copy_from_slice(in_buf);
            if self.patches.push(at + 1, in_file) {
                self.write_patches()?;
            }
        }
        Ok(())
    }

    /// Write the pending index patches to the file (all their bytes are
    /// in it).
    fn write_patches(&mut self) -> Result<(), Error> {
        if let Some(file) = &self.index_file {
            self.patches
                .write(file)
                .map_err(|(action, e)| Error::io(self.name, action, e))?;
        }
        Ok(())
    }

    /// Copy a module given in binary form.
    #[inline]
    pub fn raw(&mut self, key: u32, bytes: &[u8], al: &Alphabet) -> Result<(), Error> {
        self.modules += 1;
        if key < 128 {
            if key == OPEN {
                self.open();
            } else if key == CLOSE {
                self.close()?;
            } else {
                self.buf.push(key as u8);
            }
        } else if !self.text {
            self.buf.extend_from_slice(bytes);
        } else {
            let (_, kl) = codec::get_key(bytes);
            let body = &bytes[kl..];
            let params = codec::params_of(body, al.arity(key));
            self.num
                .module_of(&mut self.buf, al.text(key), params, al.numbers());
        }
        Ok(())
    }

    /// Text or binary known to hold `modules` modules, in this sink's format.
    #[inline]
    pub fn extend(&mut self, bytes: &[u8], modules: u64) {
        self.modules += modules;
        self.buf.extend_from_slice(bytes);
    }

    /// Plain modules ([`Self::plain`]), flushed as the buffer fills: in
    /// pieces whose bytes (each `[` with its index) are at most a quarter
    /// of a block (`chunk`), flushed once past three quarters, so that a
    /// buffer that held at most that many bytes before never holds more
    /// than a block and a module. A worker's buffer is a block that is
    /// reused: it must not grow (`par::axiom_prefix`; a piece of the signal
    /// axiom, a `[` in about six bytes, made blocks of 600 KiB).
    pub(crate) fn plain_in_blocks(&mut self, run: &[u8]) -> Result<(), Error> {
        let block = self.chunk;
        let most = if self.indexed {
            1 + self.index_len()
        } else {
            1
        };
        let quarter = (block / 4).max(1);
        for piece in run.chunks((quarter / most).max(1)) {
            self.plain(piece)?;
            if self.buf.len() > block - quarter {
                self.flush()?;
            }
        }
        Ok(())
    }

    /// Plain modules: ASCII symbols without parameters, one byte each in
    /// both formats.
    #[inline]
    pub fn plain(&mut self, run: &[u8]) -> Result<(), Error> {
        if !self.indexed {
            self.modules += run.len() as u64;
            self.buf.extend_from_slice(run);
            return Ok(());
        }
        let start = self.modules;
        self.modules += run.len() as u64;
        // The run's bytes at their places, each `[` followed by its index
        // bytes (zero until its `]` patches them): the buffer grows once,
        // and the loop stores each byte without a push.
        let il = self.index_len();
        let opens = run.iter().filter(|&&b| b == b'[').count();
        let mut j = self.buf.len();
        self.buf.resize(j + run.len() + opens * il, 0);
        for (i, &b) in run.iter().enumerate() {
            self.buf[j] = b;
            j += 1;
            if b == b'[' {
                let at = self.written + j as u64 - 1;
                self.opens.push((at, start + i as u64));
                j += il;
            } else if b == b']' {
                let end = self.written + j as u64;
                self.patch(end, start + i as u64 + 1)?;
            }
        }
        Ok(())
    }

    #[inline]
    pub fn constant(&mut self, c: &ConstRun) -> Result<(), Error> {
        let modules = c.modules();
        self.modules += modules;
        if self.text {
            append_short(&mut self.buf, c.text());
        } else if !self.indexed {
            append_short(&mut self.buf, c.bin());
        } else {
            let base = self.buf.len();
            let start = self.modules - modules;
            let ibin = c.ibin();
            // Without counts, each `[` of `ibin` has bytes to leave out.
            let extra = INDEX_BYTES - self.index_len();
            if extra == 0 {
                self.buf.extend_from_slice(ibin);
            }
            let mut copied = 0;
            let mut dropped = 0;
            for (at, open, before) in c.brackets() {
                let at = at as usize;
                let abs = self.written + (base + at - dropped) as u64;
                let before = start + before;
                if open {
                    if extra > 0 {
                        let keep = at + 1 + ENDS_BYTES;
                        self.buf.extend_from_slice(&ibin[copied..keep]);
                        copied = keep + extra;
                        dropped += extra;
                    }
                    self.opens.push((abs, before));
                } else {
                    if extra > 0 {
                        // The `]` and what precedes it: the patch below may
                        // write into this run's own `[`.
                        self.buf.extend_from_slice(&ibin[copied..at + 1]);
                        copied = at + 1;
                    }
                    self.patch(abs + 1, before + 1)?;
                }
            }
            if extra > 0 {
                self.buf.extend_from_slice(&ibin[copied..]);
            }
        }
        Ok(())
    }

    #[inline]
    pub fn module(&mut self, key: u32, params: &[f64], al: &Alphabet) -> Result<(), Error> {
        if key == OPEN || key == CLOSE {
            return self.raw(key, &[key as u8], al);
        }
        self.modules += 1;
        if self.text {
            self.num
                .module(&mut self.buf, al.text(key), params, al.numbers());
        } else {
            codec::put_key(&mut self.buf, key);
            codec::put_params(&mut self.buf, params);
        }
        Ok(())
    }

    #[inline]
    pub fn maybe_flush(&mut self) -> Result<(), Error> {
        if self.buf.len() >= self.chunk {
            self.flush()?;
        }
        Ok(())
    }

    pub(crate) fn flush(&mut self) -> Result<(), Error> {
        self.flush_but(0)
    }

    /// Flush, not counting the last `uncounted` bytes (the text's final
    /// newline) against `--max-length`.
    pub(crate) fn flush_but(&mut self, uncounted: u64) -> Result<(), Error> {
        self.written += self.buf.len() as u64;
        self.limits
            .check(self.modules, self.written - uncounted, self.pass)?;
        match self.taker {
            Some(t) => t.take(&mut self.buf),
            None => self.w.write_all(&self.buf),
        }
        .map_err(|e| Error::io(self.name, crate::diag::IoAction::Write, e))?;
        self.buf.clear();
        if let Some(m) = &self.meter {
            m.record(self.modules, self.written);
        }
        Ok(())
    }

    /// Write `bytes` (text of `modules` modules another thread formatted,
    /// `super::par`) after what is buffered, without copying it into the
    /// buffer.
    pub(crate) fn put_block(&mut self, bytes: &[u8], modules: u64) -> Result<(), Error> {
        // (A short block, the end of a task, is copied: one write call
        // instead of two.)
        if self.indexed || bytes.len() < self.chunk / 32 {
            // Flush first where the block would not fit: the buffer must
            // not grow (a file's buffer, almost full, doubled to 2 MiB).
            if self.buf.len() + bytes.len() > self.buf.capacity() && !self.buf.is_empty() {
                self.flush()?;
            }
            self.extend(bytes, modules);
            return self.maybe_flush();
        }
        if !self.buf.is_empty() {
            self.flush()?;
        }
        self.modules += modules;
        self.written += bytes.len() as u64;
        self.limits.check(self.modules, self.written, self.pass)?;
        self.w
            .write_all(bytes)
            .map_err(|e| Error::io(self.name, crate::diag::IoAction::Write, e))?;
        if let Some(m) = &self.meter {
            m.record(self.modules, self.written);
        }
        Ok(())
    }

    /// Flush everything; returns the generation's length: (modules,
    /// bytes), the bytes without the text's final newline.
    pub fn finish(mut self) -> Result<(u64, u64), Error> {
        let newline = u64::from(self.text);
        if self.text {
            self.buf.push(b'\n');
        }
        self.flush_but(newline)?;
        self.w
            .flush()
            .map_err(|e| Error::io(self.name, crate::diag::IoAction::Write, e))?;
        // (After the last bytes: the patches' groups read the bytes
        // between them from the file.)
        self.write_patches()?;
        Ok((self.modules, self.written - newline))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::{Alphabet, Filter};
    use std::io::{Read, Seek};
    use std::os::unix::fs::FileExt;

    /// Every run length, with spare capacity and without, after any
    /// content: the bytes of `extend_from_slice`.
    #[test]
    fn short_runs_append_exactly_their_bytes() {
        let src: Vec<u8> = (1..=40).collect();
        for n in 0..=20 {
            for (cap, pre) in [(64, 0), (64, 3), (64, 47), (64, 48), (64, 60), (20, 19)] {
                let mut buf = Vec::with_capacity(cap);
                buf.extend(std::iter::repeat_n(0xEE, pre));
                let mut want = buf.clone();
                let run = &src[7..7 + n];
                append_short(&mut buf, run);
                want.extend_from_slice(run);
                assert_eq!(buf, want, "n {n}, capacity {cap}, {pre} before");
            }
        }
    }

    /// A batch's thread keeps the last `Out`'s buffer and number cache for
    /// the next: the same buffer, emptied; the cache's entries in the form
    /// they were made in (a system with `--precision` after one without
    /// must not get the shortest forms). Without `KeepSpares` nothing is
    /// kept, and dropping it frees what was.
    #[test]
    fn spares_pass_the_buffer_and_a_cache_of_the_right_form() {
        let mut al = Alphabet::new(Filter::All);
        let f = al.intern('F', 1).unwrap();
        let write = |al: &Alphabet| {
            let mut v = Vec::new();
            let mut out = Out::new(&mut v, "out", true, Limits::default());
            let at = out.buf.as_ptr();
            out.module(f, &[0.1], al).unwrap();
            out.module(f, &[2.0 / 3.0], al).unwrap();
            out.finish().unwrap();
            (v, at)
        };
        let (v, _) = write(&al);
        assert_eq!(v, b"F(0.1)F(0.6666666666666666)\n");
        assert!(!spares::holds_out(), "not kept without KeepSpares");

        let keep = spares::KeepSpares::new();
        let (v, at) = write(&al);
        assert_eq!(v, b"F(0.1)F(0.6666666666666666)\n");
        al.set_numbers(codec::Numbers::Significant {
            digits: 3,
            c_exponent: false,
        });
        let (v, again) = write(&al);
        assert_eq!(again, at, "the kept buffer");
        assert_eq!(v, b"F(0.1)F(0.667)\n");
        al.set_numbers(codec::Numbers::Shortest);
        let (v, _) = write(&al);
        assert_eq!(v, b"F(0.1)F(0.6666666666666666)\n");
        drop(keep);
        assert!(!spares::holds_out());
        assert!(!spares::keeping());
    }

    #[test]
    fn text_prints_parameters_in_their_shortest_form() {
        let mut al = Alphabet::new(Filter::All);
        let f = al.intern('F', 2).unwrap();
        let mut v = Vec::new();
        let mut out = Out::new(&mut v, "out", true, Limits::default());
        out.module(f, &[1.5, 2.0], &al).unwrap();
        out.plain(b"+[G]").unwrap();
        out.module(f, &[-0.0, 1e-7], &al).unwrap();
        // 8 + 4 + 10 bytes, without the newline.
        assert_eq!(out.finish().unwrap(), (6, 22));
        assert_eq!(v, b"F(1.5,2)+[G]F(-0,1e-7)\n");
    }

    /// A branch longer than an index word holds is an error, not a
    /// distance cut to its low bits (which would skip to a wrong place).
    #[test]
    fn a_branch_longer_than_an_index_word_holds_is_an_error() {
        let mut file = tempfile::tempfile().unwrap();
        let index = file.try_clone().unwrap();
        let mut out = Out::new(&mut file, "tmp", false, Limits::default())
            .with_index(index)
            .for_pass(Pass::Step(3));
        out.plain(b"A[").unwrap();
        // Its `]` as if just past WORD_MAX bytes from the `[` at 1.
        let e = out.patch(1 + codec::WORD_MAX + 1, 2).unwrap_err();
        assert!(e.to_string().contains("256 TiB"), "{e}");
        let mut file = tempfile::tempfile().unwrap();
        let index = file.try_clone().unwrap();
        let mut out = Out::new(&mut file, "tmp", false, Limits::default()).with_index(index);
        out.plain(b"A[").unwrap();
        out.patch(1 + codec::WORD_MAX, 2).unwrap();
    }

    /// A deep nest whose `[`s were all flushed before their `]`s: each
    /// index is right (a scan with a stack finds the same ends), and the
    /// patches went to the file in batches, not a `pwrite` each (a nest
    /// 10^6 deep made 914,057).
    #[test]
    fn a_deep_nest_is_indexed_in_the_file_in_batches() {
        const DEPTH: usize = 50_000;
        let mut file = tempfile::tempfile().unwrap();
        let index = file.try_clone().unwrap();
        let al = Alphabet::new(Filter::All);
        let mut out = Out::new(&mut file, "tmp", false, Limits::default()).with_index(index);
        out.chunk = 4096;
        for _ in 0..DEPTH {
            out.plain(b"A[").unwrap();
            out.maybe_flush().unwrap();
        }
        out.flush().unwrap();
        for _ in 0..DEPTH {
            out.raw(CLOSE, b"]", &al).unwrap();
        }
        out.plain(b"B").unwrap();
        let calls = out.patches.calls;
        out.finish().unwrap();
        let calls = calls + 2; // (at most: the last batch's read and write)
        assert!(
            calls < DEPTH / 1000,
            "{calls} system calls for {DEPTH} patches"
        );
        let mut bin = Vec::new();
        file.rewind().unwrap();
        file.read_to_end(&mut bin).unwrap();
        let (mut i, mut open, mut checked) = (0, Vec::new(), 0);
        while i < bin.len() {
            match bin[i] {
                b'[' => {
                    open.push(i);
                    i += 1 + ENDS_BYTES;
                }
                b']' => {
                    let at = open.pop().unwrap();
                    let dist = codec::get_word(&bin[at + 1..]);
                    assert_eq!(at as u64 + dist, i as u64 + 1, "the `[` at {at}");
                    checked += 1;
                    i += 1;
                }
                _ => i += 1,
            }
        }
        assert_eq!(checked, DEPTH);
    }

    #[test]
    fn each_open_bracket_carries_the_offset_past_its_close() {
        // Small enough to stay in the buffer, and large enough that the
        // outer `]` is patched in the file after a flush.
        for filler in [1usize, OUT_CHUNK + 10] {
            let mut file = tempfile::tempfile().unwrap();
            let index = file.try_clone().unwrap();
            let al = Alphabet::new(Filter::All);
            let mut out = Out::new(&mut file, "tmp", false, Limits::default()).with_index(index);
            out.plain(b"[A[B]").unwrap();
            for _ in 0..filler {
                out.plain(b"C").unwrap();
                out.maybe_flush().unwrap();
            }
            out.raw(CLOSE, b"]", &al).unwrap();
            out.plain(b"D").unwrap();
            out.finish().unwrap();
            let mut bin = Vec::new();
            file.rewind().unwrap();
            file.read_to_end(&mut bin).unwrap();
            let index_at = |i: usize| codec::get_word(&bin[i + 1..]);
            // [ index A [ index B ] C... ] D
            let inner = 2 + ENDS_BYTES;
            let inner_end = inner + 3 + ENDS_BYTES;
            assert_eq!(bin[0], b'[');
            assert_eq!(bin[inner], b'[');
            // (The index holds the distance from the `[`.)
            assert_eq!(
                inner as u64 + index_at(inner),
                inner_end as u64,
                "inner, filler {filler}"
            );
            let outer_end = inner_end as u64 + filler as u64 + 1;
            assert_eq!(index_at(0), outer_end, "outer, filler {filler}");
            assert_eq!(bin[outer_end as usize - 1], b']');
            assert_eq!(&bin[outer_end as usize..], b"D");
        }
    }

    /// The writer of a split pass puts blocks of another thread's text
    /// into an indexed output's buffer: it flushes before one that would
    /// not fit, so the buffer never grows (it doubled to 2 MiB), and what
    /// is written is the blocks in order.
    #[test]
    fn blocks_put_into_an_indexed_output_never_grow_its_buffer() {
        let mut file = tempfile::tempfile().unwrap();
        let index = file.try_clone().unwrap();
        let mut out = Out::new(&mut file, "tmp", false, Limits::default()).with_index(index);
        let cap = out.buf.capacity();
        let mut want = Vec::new();
        for (i, len) in [100usize, 300 << 10, 7, 299 << 10, 301 << 10, 1, 280 << 10]
            .into_iter()
            .cycle()
            .take(40)
            .enumerate()
        {
            let block = vec![b'A' + (i % 26) as u8; len];
            out.put_block(&block, len as u64).unwrap();
            want.extend_from_slice(&block);
            assert_eq!(out.buf.capacity(), cap, "grew at block {i}");
        }
        assert_eq!(out.finish().unwrap().0, want.len() as u64);
        let mut got = Vec::new();
        file.rewind().unwrap();
        file.read_to_end(&mut got).unwrap();
        assert!(got == want, "the blocks were not written in order");
    }

    /// Issue 11: every way of writing a `[` (plain runs, precompiled
    /// successors, single modules; in the buffer or patched in the file)
    /// leaves the offset past its `]` and, with counts, its branch's
    /// module count in the index, as a scan of the written string finds
    /// them.
    #[test]
    fn the_index_counts_each_branchs_modules() {
        use crate::lang::parse::parse_header;
        use crate::rules::{compile, Item};
        let mut sys =
            compile(&parse_header("productions:\nF -> F(1)[+F[G]]H[]\n").unwrap()).unwrap();
        let Item::Const(c) = &sys.productions.prods[0].succ[0] else {
            panic!("a precompiled successor")
        };
        let c = c.clone();
        let al = &mut sys.alphabet;
        let x = al.intern('X', 1).unwrap();
        for (filler, counts) in [1usize, OUT_CHUNK + 10]
            .into_iter()
            .flat_map(|f| [(f, false), (f, true)])
        {
            let mut file = tempfile::tempfile().unwrap();
            let index = file.try_clone().unwrap();
            let mut out = Out::new(&mut file, "tmp", false, Limits::default())
                .with_index(index)
                .with_counts(counts);
            out.plain(b"A[B").unwrap();
            out.constant(&c).unwrap();
            out.module(OPEN, &[], al).unwrap();
            out.module(x, &[2.0], al).unwrap();
            for _ in 0..filler {
                out.plain(b"C").unwrap();
                out.maybe_flush().unwrap();
            }
            out.constant(&c).unwrap();
            out.raw(CLOSE, b"]", al).unwrap();
            out.plain(b"]D").unwrap();
            out.finish().unwrap();
            let mut bin = Vec::new();
            file.rewind().unwrap();
            file.read_to_end(&mut bin).unwrap();
            // Scan: (offset, modules before) of each open `[`.
            let (mut i, mut modules, mut open, mut checked) = (0, 0u64, Vec::new(), 0);
            while i < bin.len() {
                let (key, kl) = codec::get_key(&bin[i..]);
                modules += 1;
                if key == OPEN {
                    open.push((i, modules - 1));
                    i += 1 + if counts { INDEX_BYTES } else { ENDS_BYTES };
                    continue;
                }
                i += kl + 8 * al.arity(key);
                if key == CLOSE {
                    let (at, before) = open.pop().unwrap();
                    let word = |j: usize| codec::get_word(&bin[j..]);
                    assert_eq!(
                        at as u64 + word(at + 1),
                        i as u64,
                        "filler {filler}, counts {counts}"
                    );
                    if counts {
                        assert_eq!(
                            word(at + 1 + ENDS_BYTES),
                            modules - before,
                            "filler {filler}"
                        );
                    }
                    checked += 1;
                }
            }
            assert!(open.is_empty());
            // `A[B...]D` and `[X...]`, and 3 in each successor.
            assert_eq!(checked, 2 + 2 * 3);
        }
    }

    /// A worker's taker for tests: keeps the blocks handed over.
    #[derive(Default)]
    struct Blocks(std::cell::RefCell<Vec<Vec<u8>>>);

    impl Take for Blocks {
        fn take(&self, buf: &mut Vec<u8>) -> std::io::Result<()> {
            self.0.borrow_mut().push(std::mem::take(buf));
            Ok(())
        }
    }

    /// A split pass (issue 15): workers write their chunks' bracket index
    /// where they can and leave the rest to the writer ([`ChunkIndex`]),
    /// which completes it as it writes the chunks in order. The file is
    /// the one a single sink writes, byte for byte: branches within a
    /// block, across a worker's blocks (late), across chunks (closes and
    /// opens), patched in the writer's buffer or in the file; with and
    /// without counts; also when parameters hold the bytes of `[` and `]`.
    #[test]
    fn chunk_indices_completed_by_the_writer_give_one_sinks_file() {
        let mut al = Alphabet::new(Filter::All);
        let tricky = [f64::from_bits(0x5B5D_5B5D_5B5D_5B5D)];
        let g = al.intern('G', 1).unwrap();
        let mut string: Vec<(u32, &[f64])> = Vec::new();
        for &c in b"A[B[G]C[D[E]]F]G[[H]][I" {
            let key = if c == b'G' { g } else { u32::from(c) };
            let params: &[f64] = if c == b'G' { &tricky } else { &[] };
            string.push((key, params));
        }
        string.extend([(u32::from(b']'), &[][..]), (u32::from(b'J'), &[][..])]);
        let read = |f: &mut File| {
            let mut v = Vec::new();
            f.rewind().unwrap();
            f.read_to_end(&mut v).unwrap();
            v
        };
        for counts in [false, true] {
            let mut f = tempfile::tempfile().unwrap();
            let index = f.try_clone().unwrap();
            {
                let mut out = Out::new(&mut f, "gen", false, Limits::default())
                    .with_index(index)
                    .with_counts(counts);
                for &(key, params) in &string {
                    out.module(key, params, &al).unwrap();
                }
                out.finish().unwrap();
            }
            let want = read(&mut f);
            // Chunks of `per` modules; the worker hands over a block after
            // every module or never; the writer flushes after every block
            // or never, or copies the chunk's blocks from a spill file in
            // pieces of `piece` bytes, which cut modules (a `[` from its
            // index bytes too), flushing after each.
            let writers = [None, Some(None)]
                .into_iter()
                .chain((1..=INDEX_BYTES + 2).map(|p| Some(Some(p))));
            for (per, writer) in
                (1..=string.len()).flat_map(|p| writers.clone().map(move |w| (p, w)))
            {
                for worker_flushes in [false, true] {
                    let writer_flushes = writer.is_some();
                    let mut f = tempfile::tempfile().unwrap();
                    let index = f.try_clone().unwrap();
                    let blocks = Blocks::default();
                    let mut sink = std::io::sink();
                    let mut worker =
                        Out::new(&mut sink, "w", false, Limits::default()).with_chunk_index(counts);
                    worker.taker = Some(&blocks);
                    {
                        let mut out = Out::new(&mut f, "gen", false, Limits::default())
                            .with_index(index)
                            .with_counts(counts);
                        for chunk in string.chunks(per) {
                            worker.begin_chunk();
                            let before = worker.modules;
                            for &(key, params) in chunk {
                                worker.module(key, params, &al).unwrap();
                                if worker_flushes {
                                    worker.flush().unwrap();
                                }
                            }
                            worker.flush().unwrap();
                            let ci = worker.end_chunk().unwrap();
                            let base = out.position();
                            if let Some(Some(piece)) = writer {
                                let spill = tempfile::tempfile().unwrap();
                                let mut len = 0;
                                for b in blocks.0.borrow_mut().drain(..) {
                                    spill.write_all_at(&b, len).unwrap();
                                    len += b.len() as u64;
                                }
                                out.chunk = piece;
                                let mut copy = Vec::new();
                                super::super::handoff::copy_spill(
                                    &spill,
                                    (len, piece),
                                    &mut copy,
                                    &mut out,
                                )
                                .unwrap();
                            }
                            for b in blocks.0.borrow_mut().drain(..) {
                                out.put_block(&b, 0).unwrap();
                                if writer_flushes {
                                    out.flush().unwrap();
                                }
                            }
                            out.apply(&ci, base).unwrap();
                            out.extend(&[], worker.modules - before);
                        }
                        assert_eq!(out.finish().unwrap().0, string.len() as u64);
                    }
                    assert_eq!(
                        read(&mut f),
                        want,
                        "counts {counts}, {per} a chunk, flushes {worker_flushes} {writer:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn limits_name_the_pass() {
        let mut v = Vec::new();
        let limits = Limits {
            modules: 3,
            bytes: u64::MAX,
        };
        let mut out = Out::new(&mut v, "out", false, limits).for_pass(Pass::Step(7));
        out.plain(b"ABCD").unwrap();
        let e = out.finish().unwrap_err();
        assert_eq!(
            e.message(),
            "the string grew past `Limits::modules` (3 modules) in step 7"
        );
        // The binary's names, as `LSystem::run` gives them for it.
        let e = e.with_option_names(crate::diag::OptionNames::CommandLine);
        assert_eq!(
            e.message(),
            "the string grew past --max-length (3 modules) in step 7"
        );
        let lengths = [(1, 1), (2, 20), (3, 3)];
        let bytes = Limits {
            modules: u64::MAX,
            bytes: 10,
        };
        // Generation 2 is binary: its 20 bytes count.
        let e = bytes.check_generations(&lengths, true, 1).unwrap_err();
        assert!(
            e.message().ends_with("(10 bytes) in step 2"),
            "{}",
            e.message()
        );
        // The last (text) generation's bytes are checked as written.
        assert!(bytes.check_generations(&[(1, 1), (2, 20)], true, 1).is_ok());
        // Steps counted from `--first-step`.
        let e = bytes.check_generations(&lengths, true, 5).unwrap_err();
        assert!(
            e.message().ends_with("(10 bytes) in step 6"),
            "{}",
            e.message()
        );
    }

    /// A worker writes plain modules in blocks no larger than its block
    /// (but for a `[`'s index bytes), whatever the share of `[`s: every
    /// byte kept, each `[` with its index bytes.
    #[test]
    fn plain_modules_in_blocks_stay_within_the_block() {
        let mixed: Vec<u8> = b"F1[+F1F1]".iter().copied().cycle().take(5000).collect();
        let opens = vec![b'['; 3000];
        for run in [&mixed, &opens] {
            for counts in [false, true] {
                let il = if counts { INDEX_BYTES } else { ENDS_BYTES };
                for block in [1, 2, 7, 64, 1000, 4096] {
                    let blocks = Blocks::default();
                    let mut sink = std::io::sink();
                    let mut out =
                        Out::new(&mut sink, "w", false, Limits::default()).with_chunk_index(counts);
                    out.taker = Some(&blocks);
                    out.chunk = block;
                    out.begin_chunk();
                    out.plain_in_blocks(run).unwrap();
                    out.flush().unwrap();
                    assert_eq!(out.modules, run.len() as u64);
                    let _ = out.end_chunk();
                    drop(out);
                    let mut text = Vec::new();
                    for b in blocks.0.borrow().iter() {
                        assert!(b.len() <= block + il, "{} > {block}", b.len());
                        text.extend_from_slice(b);
                    }
                    let mut bytes = Vec::new();
                    let mut i = 0;
                    while i < text.len() {
                        bytes.push(text[i]);
                        i += if text[i] == b'[' { 1 + il } else { 1 };
                    }
                    assert_eq!(&bytes, run, "block {block}, counts {counts}");
                }
            }
        }
    }
}
