//! The streaming rewriter. One derivation step reads a generation from a
//! temp file (binary format, see [`crate::codec`]) and writes the next one
//! to another temp file, or, on the last pass, as text to the output.
//!
//! Memory does not grow with the string: the main reader and the look-ahead
//! reader each hold one buffer; left contexts keep the last k considered
//! modules per open branch; right contexts are matched by a second reader
//! over the same file, so skipping a branch of any size costs time, not
//! memory.

use crate::codec::{self, MAX_MODULE_BYTES};
use crate::diag::{CodeMap, Error, Location};
use crate::expr::EvalError;
use crate::random::Random;
use crate::rules::{Alphabet, ConstRun, Item, KeyRules, Pat, Production, RPat, Table, CLOSE, OPEN};
use std::fs::File;
use std::io::{self, Write};
use std::os::unix::fs::FileExt;

const OUT_CHUNK: usize = 1 << 20;

/// Limits on the size of any generation (`--max-length`).
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    pub modules: u64,
    pub bytes: u64,
}

impl Limits {
    /// Is a generation of `modules` modules and `bytes` bytes, made by
    /// `pass`, too long?
    pub fn check(&self, modules: u64, bytes: u64, pass: Pass) -> Result<(), Error> {
        if modules > self.modules {
            return Err(Error::new(format!(
                "the string grew past --max-length ({} modules) in {pass}",
                self.modules
            )));
        }
        if bytes > self.bytes {
            return Err(Error::new(format!(
                "the string grew past --max-length ({} bytes) in {pass}",
                self.bytes
            )));
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

/// A buffered sink for one generation, binary or text.
pub struct Out<'w> {
    buf: Vec<u8>,
    w: &'w mut dyn Write,
    /// Bracket index mode: each `[` carries the offset just past its `]`,
    /// patched in the buffer or, once flushed, in `file`.
    indexed: Option<File>,
    opens: Vec<u64>,
    name: &'w str,
    pub text: bool,
    modules: u64,
    written: u64,
    num: codec::NumFmt,
    limits: Limits,
    /// What this generation is, for `--max-length` errors.
    pass: Pass,
}

impl<'w> Out<'w> {
    pub fn new(w: &'w mut dyn Write, name: &'w str, text: bool, limits: Limits) -> Out<'w> {
        Out {
            buf: Vec::with_capacity(OUT_CHUNK + MAX_MODULE_BYTES * 4),
            w,
            indexed: None,
            opens: Vec::new(),
            name,
            text,
            modules: 0,
            written: 0,
            num: codec::NumFmt::new(),
            limits,
            pass: Pass::Axiom,
        }
    }

    /// Name the pass that makes this generation (default: the axiom).
    pub fn for_pass(mut self, pass: Pass) -> Self {
        self.pass = pass;
        self
    }

    /// Write a bracket index: `file` is the file this sink writes to.
    pub fn with_index(mut self, file: File) -> Self {
        self.indexed = Some(file);
        self
    }

    #[inline]
    fn open(&mut self) {
        if self.indexed.is_some() {
            self.opens.push(self.written + self.buf.len() as u64);
            self.buf.push(b'[');
            self.buf.extend_from_slice(&[0; 8]);
        } else {
            self.buf.push(b'[');
        }
    }

    #[inline]
    fn close(&mut self) -> Result<(), Error> {
        self.buf.push(b']');
        if self.indexed.is_some() {
            let end = self.written + self.buf.len() as u64;
            self.patch(end)?;
        }
        Ok(())
    }

    /// The `]` ending just before offset `end` closes the last open `[`:
    /// write `end` into that `[`'s index bytes, in the buffer or, once
    /// flushed, in the file.
    #[inline]
    fn patch(&mut self, end: u64) -> Result<(), Error> {
        let Some(at) = self.opens.pop() else {
            return Ok(()); // unbalanced: reported by the balance check
        };
        let end = end.to_le_bytes();
        if at >= self.written {
            let i = (at - self.written) as usize + 1;
            self.buf[i..i + 8].copy_from_slice(&end);
        } else if let Some(file) = &self.indexed {
            file.write_all_at(&end, at + 1)
                .map_err(|e| Error::io(self.name, "cannot write", e))?;
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
            self.buf.extend_from_slice(al.text(key));
            let n = al.arity(key);
            if n > 0 {
                self.buf.push(b'(');
                for i in 0..n {
                    if i > 0 {
                        self.buf.push(b',');
                    }
                    self.num.put(&mut self.buf, codec::get_param(body, i));
                }
                self.buf.push(b')');
            }
        }
        Ok(())
    }

    /// Text or binary known to hold `modules` modules, in this sink's format.
    #[inline]
    pub fn extend(&mut self, bytes: &[u8], modules: u64) {
        self.modules += modules;
        self.buf.extend_from_slice(bytes);
    }

    /// Plain modules: ASCII symbols without parameters, one byte each in
    /// both formats.
    #[inline]
    pub fn plain(&mut self, run: &[u8]) -> Result<(), Error> {
        if self.indexed.is_none() {
            self.modules += run.len() as u64;
            self.buf.extend_from_slice(run);
            return Ok(());
        }
        self.modules += run.len() as u64;
        for &b in run {
            match b {
                b'[' => self.open(),
                b']' => self.close()?,
                _ => self.buf.push(b),
            }
        }
        Ok(())
    }

    #[inline]
    pub fn constant(&mut self, c: &ConstRun) -> Result<(), Error> {
        self.modules += c.modules;
        if self.text {
            self.buf.extend_from_slice(c.text());
        } else if self.indexed.is_none() {
            self.buf.extend_from_slice(c.bin());
        } else {
            let base = self.buf.len();
            self.buf.extend_from_slice(c.ibin());
            for &(at, open) in c.brackets.iter() {
                let abs = self.written + (base + at as usize) as u64;
                if open {
                    self.opens.push(abs);
                } else {
                    self.patch(abs + 1)?;
                }
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
            self.num.module(&mut self.buf, al.text(key), params);
        } else {
            codec::put_key(&mut self.buf, key);
            codec::put_params(&mut self.buf, params);
        }
        Ok(())
    }

    #[inline]
    pub fn maybe_flush(&mut self) -> Result<(), Error> {
        if self.buf.len() >= OUT_CHUNK {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), Error> {
        self.flush_but(0)
    }

    /// Flush, not counting the last `uncounted` bytes (the text's final
    /// newline) against `--max-length`.
    fn flush_but(&mut self, uncounted: u64) -> Result<(), Error> {
        self.written += self.buf.len() as u64;
        self.limits
            .check(self.modules, self.written - uncounted, self.pass)?;
        self.w
            .write_all(&self.buf)
            .map_err(|e| Error::io(self.name, "cannot write", e))?;
        self.buf.clear();
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
            .map_err(|e| Error::io(self.name, "cannot write", e))?;
        Ok((self.modules, self.written - newline))
    }
}

/// A buffered reader at file offsets (pread), so two can share one file.
pub struct PosReader<'f> {
    file: &'f File,
    /// The file has a bracket index (see [`Out::with_index`]).
    indexed: bool,
    buf: Vec<u8>,
    /// File offset of `buf[0]`.
    start: u64,
    pos: usize,
    end: usize,
}

impl<'f> PosReader<'f> {
    pub fn new(file: &'f File, capacity: usize, indexed: bool) -> Self {
        // No bigger than the file: many steps over a short string must not
        // pay for a large buffer each time.
        let len = file.metadata().map_or(u64::MAX, |m| m.len());
        let capacity = capacity.min(usize::try_from(len).unwrap_or(usize::MAX));
        PosReader {
            file,
            indexed,
            buf: vec![0; capacity.max(2 * MAX_MODULE_BYTES)],
            start: 0,
            pos: 0,
            end: 0,
        }
    }

    #[inline]
    pub fn offset(&self) -> u64 {
        self.start + self.pos as u64
    }

    /// Move to file offset `off`, keeping the buffer if it covers `off`.
    #[inline]
    pub fn seek(&mut self, off: u64) {
        if off >= self.start && off <= self.start + self.end as u64 {
            self.pos = (off - self.start) as usize;
        } else {
            self.start = off;
            self.pos = 0;
            self.end = 0;
        }
    }

    #[cold]
    fn refill(&mut self) -> io::Result<()> {
        self.buf.copy_within(self.pos..self.end, 0);
        self.start += self.pos as u64;
        self.end -= self.pos;
        self.pos = 0;
        while self.end < self.buf.len() {
            let n = match self
                .file
                .read_at(&mut self.buf[self.end..], self.start + self.end as u64)
            {
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if n == 0 {
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
            let n = if b == b'[' && self.indexed { 9 } else { 1 };
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

    /// For a `[` read at `s` (next module at `next`): the offset just past
    /// its `]`, from the index or by scanning.
    #[inline]
    fn branch_end(&mut self, al: &Alphabet, s: usize, next: u64) -> io::Result<Option<u64>> {
        if self.indexed {
            Ok(Some(u64::from_le_bytes(
                self.buf[s + 1..s + 9].try_into().unwrap(),
            )))
        } else {
            skip_branch(self, al, next)
        }
    }
}

/// Each ASCII byte, so a symbol can be copied as a one-byte slice.
pub(crate) static ASCII: [u8; 128] = {
    let mut t = [0u8; 128];
    let mut i = 0;
    while i < 128 {
        t[i] = i as u8;
        i += 1;
    }
    t
};

/// The D0L fast path: for each ASCII symbol without parameters, what a
/// step does to it when that needs no decision (no context, no condition,
/// no probability, a constant successor). Bytes it cannot handle stop the
/// run and go through the general path.
struct ByteTable<'t> {
    /// None: take the general path.
    succ: [Option<FastSucc<'t>>; 128],
}

/// A successor for the byte table. Short ones are padded to 16 bytes and
/// copied with one fixed-size copy, then the buffer is cut back.
#[derive(Clone, Copy)]
struct FastSucc<'t> {
    small: [u8; 16],
    len: usize,
    long: &'t [u8],
    modules: u64,
}

impl<'t> FastSucc<'t> {
    fn new(bytes: &'t [u8], modules: u64) -> Self {
        let mut small = [0; 16];
        if bytes.len() <= 16 {
            small[..bytes.len()].copy_from_slice(bytes);
        }
        FastSucc {
            small,
            len: bytes.len(),
            long: bytes,
            modules,
        }
    }
}

impl<'t> ByteTable<'t> {
    /// `brackets`: may `[` and `]` be copied here? Not when the step tracks
    /// branches (left contexts) or writes a bracket index.
    fn new(table: &'t Table, text: bool, brackets: bool) -> Self {
        let mut succ: [Option<FastSucc>; 128] =
            std::array::from_fn(|b| Some(FastSucc::new(&ASCII[b..b + 1], 1)));
        if !brackets {
            succ[OPEN as usize] = None;
            succ[CLOSE as usize] = None;
        }
        for (b, slot) in succ.iter_mut().enumerate() {
            *slot = match table.fixed(b as u32) {
                Some(None) => continue, // no rule: copied
                Some(Some(f)) if brackets || !f.brackets => {
                    Some(FastSucc::new(if text { f.text } else { f.bin }, f.modules))
                }
                _ => None,
            };
        }
        ByteTable { succ }
    }

    /// Rewrite the leading bytes of `input` it can handle; returns how many
    /// bytes it used. Modules that left contexts consider are recorded in
    /// `left`; brackets open and close its levels and the output's bracket
    /// index (`indexed`: the input's `[` carry 8 index bytes).
    #[inline]
    fn run(
        &self,
        input: &[u8],
        out: &mut Out,
        mut left: Option<&mut LeftContext>,
        al: &Alphabet,
        indexed: bool,
    ) -> Result<usize, Error> {
        let mut i = 0;
        while i < input.len() {
            let b = input[i];
            if b >= 0x80 {
                break;
            }
            let Some(f) = &self.succ[b as usize] else {
                if b == b'[' {
                    let n = if indexed { 9 } else { 1 };
                    if i + n > input.len() {
                        break;
                    }
                    out.modules += 1;
                    out.open();
                    if let Some(left) = &mut left {
                        left.open();
                    }
                    i += n;
                    continue;
                }
                if b == b']' {
                    out.modules += 1;
                    out.close()?;
                    if let Some(left) = &mut left {
                        left.close();
                    }
                    i += 1;
                    continue;
                }
                break;
            };
            let buf = &mut out.buf;
            if f.len <= 16 {
                let at = buf.len();
                buf.extend_from_slice(&f.small);
                buf.truncate(at + f.len);
            } else {
                buf.extend_from_slice(f.long);
            }
            out.modules += f.modules;
            if let Some(left) = &mut left {
                if !al.ignored(b as u32) {
                    left.push(b as u32, &[], 0);
                }
            }
            i += 1;
            if out.buf.len() >= OUT_CHUNK {
                break;
            }
        }
        Ok(i)
    }
}

/// Left context: the considered modules on the path from the start of the
/// string to the current module, as one shared stack. Each open branch
/// (level) owns a segment at the top of its parent's and keeps at most the
/// last k of its own modules there (a ring once full); a left context is
/// read backwards through the current level, then its ancestors. Opening a
/// branch copies nothing, so memory is the modules kept per level (at most
/// k each, and no more than the level has) plus O(1) per level: a long
/// context and deep nesting do not multiply. Only the parameters of keys
/// that some left context asks for are kept, up to their largest arity.
struct LeftContext {
    k: usize,
    /// Parameters kept per slot.
    width: usize,
    /// Keys whose parameters are kept (indexed by key).
    wanted: Vec<bool>,
    depth: usize,
    keys: Vec<u32>,
    params: Vec<f64>,
    /// One per open level (reused as branches open and close).
    levels: Vec<Level>,
}

/// No such level.
const NONE: usize = usize::MAX;

#[derive(Clone, Copy)]
struct Level {
    /// Where the level's own modules start in `keys`.
    start: usize,
    /// How many it keeps (at most k).
    cnt: usize,
    /// Ring index of the most recent one.
    head: usize,
    /// Nearest enclosing level that keeps any module, or NONE.
    up: usize,
}

impl LeftContext {
    fn new(table: &Table, al: &Alphabet) -> Self {
        let k = table.max_left;
        let mut wanted = Vec::new();
        let mut width = 0;
        for p in &table.prods {
            for pat in &p.left {
                let n = al.arity(pat.key);
                if n > 0 {
                    let key = pat.key as usize;
                    if wanted.len() <= key {
                        wanted.resize(key + 1, false);
                    }
                    wanted[key] = true;
                    width = width.max(n);
                }
            }
        }
        LeftContext {
            k,
            width,
            wanted,
            depth: 0,
            keys: Vec::new(),
            params: Vec::new(),
            levels: vec![Level {
                start: 0,
                cnt: 0,
                head: 0,
                up: NONE,
            }],
        }
    }

    fn open(&mut self) {
        let d = self.depth;
        let cur = self.levels[d];
        let child = Level {
            start: self.keys.len(),
            cnt: 0,
            head: 0,
            up: if cur.cnt > 0 { d } else { cur.up },
        };
        self.depth += 1;
        if self.levels.len() <= self.depth {
            self.levels.push(child);
        } else {
            self.levels[self.depth] = child;
        }
    }

    fn close(&mut self) {
        if self.depth == 0 {
            return; // unbalanced: reported by the balance check
        }
        let start = self.levels[self.depth].start;
        self.keys.truncate(start);
        self.params.truncate(start * self.width);
        self.depth -= 1;
    }

    /// The nearest considered module to the left, if any.
    #[inline(always)]
    fn last_key(&self) -> Option<u32> {
        let mut l = self.levels[self.depth];
        if l.cnt == 0 {
            if l.up == NONE {
                return None;
            }
            l = self.levels[l.up];
        }
        Some(self.keys[l.start + l.head])
    }

    #[inline]
    fn push(&mut self, key: u32, params: &[u8], arity: usize) {
        let (k, w) = (self.k, self.width);
        let l = &mut self.levels[self.depth];
        let slot = if l.cnt < k {
            // The level's segment is the top of the stack.
            l.head = l.cnt;
            l.cnt += 1;
            self.keys.push(key);
            self.params.resize(self.params.len() + w, 0.0);
            l.start + l.head
        } else {
            l.head = if l.head + 1 == k { 0 } else { l.head + 1 };
            let slot = l.start + l.head;
            self.keys[slot] = key;
            slot
        };
        if self.wanted.get(key as usize).copied().unwrap_or(false) {
            for i in 0..arity {
                self.params[slot * w + i] = codec::get_param(params, i);
            }
        }
    }

    /// Does the path to the current module end with `pat`? Binds its
    /// parameters.
    fn matches(&self, pat: &[Pat], al: &Alphabet, slots: &mut [f64]) -> bool {
        let mut l = self.levels[self.depth];
        let mut left = l.cnt;
        let mut idx = l.head;
        for p in pat.iter().rev() {
            while left == 0 {
                if l.up == NONE {
                    return false;
                }
                l = self.levels[l.up];
                left = l.cnt;
                idx = l.head;
            }
            let slot = l.start + idx;
            if self.keys[slot] != p.key {
                return false;
            }
            let n = al.arity(p.key);
            if n > 0 {
                let w = self.width;
                slots[p.slot as usize..p.slot as usize + n]
                    .copy_from_slice(&self.params[slot * w..slot * w + n]);
            }
            idx = if idx == 0 { l.cnt - 1 } else { idx - 1 };
            left -= 1;
        }
        true
    }
}

/// Where a pass's errors point and what they call the pass.
pub struct Origin<'a> {
    pub path: &'a str,
    pub header: &'a str,
}

impl Origin<'_> {
    pub(crate) fn locate(&self, offset: usize) -> Location {
        Location::from_map(self.path, &CodeMap::new(self.header), offset)
    }
}

/// State shared by the passes of one derivation.
pub struct Deriver<'a> {
    pub alphabet: Alphabet,
    pub rng: Random,
    pub origin: Origin<'a>,
    slots: Vec<f64>,
    vals: Vec<f64>,
    stack: Vec<f64>,
    cand: Vec<(u32, f64)>,
    cand_slots: Vec<f64>,
}

/// What one pass is: a numbered step or the homomorphism.
#[derive(Clone, Copy)]
pub enum Pass {
    Step(u64),
    Homomorphism,
    /// Reading the axiom (generation 0).
    Axiom,
}

impl std::fmt::Display for Pass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Pass::Step(n) => write!(f, "step {n}"),
            Pass::Homomorphism => f.write_str("the homomorphism"),
            Pass::Axiom => f.write_str("the axiom"),
        }
    }
}

/// The next considered modules right of the current one, read once per
/// module for all bracket-free right contexts.
#[derive(Default)]
struct RightCache {
    /// Offset the cache was filled from (u64::MAX: empty).
    at: u64,
    keys: Vec<u32>,
    /// Start of each module's parameters in `params`.
    starts: Vec<usize>,
    params: Vec<f64>,
}

impl RightCache {
    fn fill(
        &mut self,
        peek: &mut PosReader,
        al: &Alphabet,
        pos: u64,
        want: usize,
    ) -> io::Result<()> {
        self.at = pos;
        self.keys.clear();
        self.starts.clear();
        self.params.clear();
        let mut pos = pos;
        while self.keys.len() < want {
            peek.seek(pos);
            let Some((key, s, e)) = peek.next_module(al)? else {
                break;
            };
            let next = peek.offset();
            if key == OPEN {
                match peek.branch_end(al, s, next)? {
                    Some(after) => pos = after,
                    None => break,
                }
                continue;
            }
            if key == CLOSE {
                break;
            }
            pos = next;
            if al.ignored(key) {
                continue;
            }
            self.keys.push(key);
            self.starts.push(self.params.len());
            let bytes = peek.bytes(s, e);
            let (_, kl) = codec::get_key(bytes);
            for i in 0..al.arity(key) {
                self.params.push(codec::get_param(&bytes[kl..], i));
            }
        }
        Ok(())
    }

    fn matches(&self, pat: &[RPat], al: &Alphabet, slots: &mut [f64]) -> bool {
        if pat.len() > self.keys.len() {
            return false;
        }
        for (i, r) in pat.iter().enumerate() {
            let RPat::Module(p) = r else {
                unreachable!("bracket in a simple right context")
            };
            if self.keys[i] != p.key {
                return false;
            }
        }
        for (i, r) in pat.iter().enumerate() {
            if let RPat::Module(p) = r {
                let n = al.arity(p.key);
                let s = self.starts[i];
                slots[p.slot as usize..p.slot as usize + n].copy_from_slice(&self.params[s..s + n]);
            }
        }
        true
    }
}

struct StepState<'f> {
    peek: Option<PosReader<'f>>,
    right: RightCache,
    max_right_simple: usize,
    left: Option<LeftContext>,
    /// A run of ignored modules: from any module end in `skip.0..=skip.1`
    /// only ignored modules (no bracket) lie before offset `skip.1`, so a
    /// right context may start there. Keeps right contexts over long
    /// ignored runs linear.
    skip: (u64, u64),
    depth: i64,
    /// Productions that last opened or closed more than they matched, to
    /// blame for unbalanced output.
    last_opener: Option<u32>,
    last_closer: Option<u32>,
}

impl StepState<'_> {
    /// Where the right context of the module ending at `end_off` starts:
    /// past the ignored modules that follow it. Each ignored run is read
    /// once per pass, however many of its modules ask.
    #[inline]
    fn right_start(&mut self, end_off: u64, al: &Alphabet) -> io::Result<u64> {
        if self.skip.0 <= end_off && end_off <= self.skip.1 {
            return Ok(self.skip.1);
        }
        let peek = self
            .peek
            .as_mut()
            .expect("a look-ahead reader for right contexts");
        let mut pos = end_off;
        loop {
            peek.seek(pos);
            match peek.next_module(al)? {
                Some((key, _, _)) if key != OPEN && key != CLOSE && al.ignored(key) => {
                    pos = peek.offset();
                }
                _ => break,
            }
        }
        self.skip = (end_off, pos);
        Ok(pos)
    }

    /// The next considered modules right of the module ending at `end_off`
    /// (read once per module).
    #[inline]
    fn right_of(&mut self, end_off: u64, al: &Alphabet) -> Result<&RightCache, Error> {
        let read_err = |e| Error::io("temporary file", "cannot read", e);
        let start = self.right_start(end_off, al).map_err(read_err)?;
        if self.right.at != start {
            let peek = self
                .peek
                .as_mut()
                .expect("a look-ahead reader for right contexts");
            self.right
                .fill(peek, al, start, self.max_right_simple)
                .map_err(read_err)?;
        }
        Ok(&self.right)
    }
}

impl<'a> Deriver<'a> {
    pub fn new(alphabet: Alphabet, rng: Random, origin: Origin<'a>) -> Self {
        Deriver {
            alphabet,
            rng,
            origin,
            slots: Vec::new(),
            vals: Vec::new(),
            stack: Vec::new(),
            cand: Vec::new(),
            cand_slots: Vec::new(),
        }
    }

    fn eval_error(&self, e: EvalError, pass: Pass) -> Error {
        Error::at(
            self.origin.locate(e.span.0),
            format!("{} (in {pass})", e.message),
        )
    }

    /// One pass: rewrite the generation in `input` into `out`.
    pub fn pass(
        &mut self,
        table: &Table,
        input: &File,
        indexed: bool,
        out: &mut Out,
        pass: Pass,
    ) -> Result<(), Error> {
        let max_slots = table.prods.iter().map(|p| p.nslots).max().unwrap_or(0);
        self.slots.resize(max_slots.max(1), 0.0);
        let mut st = StepState {
            peek: table
                .has_right
                .then(|| PosReader::new(input, 1 << 16, indexed)),
            right: RightCache {
                at: u64::MAX,
                ..RightCache::default()
            },
            max_right_simple: table.max_right_simple,
            left: (table.max_left > 0).then(|| LeftContext::new(table, &self.alphabet)),
            depth: 0,
            skip: (u64::MAX, 0),
            last_opener: None,
            last_closer: None,
        };
        let mut rd = PosReader::new(input, 1 << 20, indexed);
        let read_err = |e| Error::io("temporary file", "cannot read", e);
        // Bytes that need no decision take the table; with contexts, keys
        // that have context productions and brackets still go the long way.
        let fast = (!table.check_balance).then(|| {
            ByteTable::new(
                table,
                out.text,
                !indexed && st.left.is_none() && out.indexed.is_none(),
            )
        });
        loop {
            if let Some(fast) = &fast {
                let window = rd.window().map_err(read_err)?;
                let used = fast.run(window, out, st.left.as_mut(), &self.alphabet, indexed)?;
                rd.advance(used);
                out.maybe_flush()?;
                if used > 0 {
                    continue;
                }
            }
            let Some((key, s, e)) = rd.next_module(&self.alphabet).map_err(read_err)? else {
                break;
            };
            let end_off = rd.offset();
            let bytes = rd.bytes(s, e);
            let applied = match table.get(key) {
                Some(kr) => self.apply(table, kr, key, bytes, end_off, &mut st, out, pass)?,
                None => false,
            };
            if !applied {
                if table.check_balance {
                    if key == OPEN {
                        st.depth += 1;
                    } else if key == CLOSE {
                        st.depth -= 1;
                        if st.depth < 0 {
                            return Err(self.unbalanced(table, st.last_closer, pass));
                        }
                    }
                }
                out.raw(key, bytes, &self.alphabet)?;
            }
            if let Some(left) = &mut st.left {
                if key == OPEN {
                    left.open();
                } else if key == CLOSE {
                    left.close();
                } else if !self.alphabet.ignored(key) {
                    let (_, kl) = codec::get_key(bytes);
                    left.push(key, &bytes[kl..], self.alphabet.arity(key));
                }
            }
            out.maybe_flush()?;
        }
        if st.depth != 0 {
            let p = &table.prods[st.last_opener.unwrap_or(0) as usize];
            return Err(Error::at(
                self.origin.locate(p.span.0),
                format!(
                    "unbalanced brackets: {pass} leaves a `[` open, produced by this production"
                ),
            ));
        }
        Ok(())
    }

    fn unbalanced(&self, table: &Table, culprit: Option<u32>, pass: Pass) -> Error {
        let p = &table.prods[culprit.unwrap_or(0) as usize];
        Error::at(
            self.origin.locate(p.span.0),
            format!("unbalanced brackets: {pass} produces a `]` without `[`, from this production"),
        )
    }

    /// Try the productions of `key`; emit the chosen successor.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn apply(
        &mut self,
        table: &Table,
        kr: &KeyRules,
        key: u32,
        bytes: &[u8],
        end_off: u64,
        st: &mut StepState,
        out: &mut Out,
        pass: Pass,
    ) -> Result<bool, Error> {
        // Predecessor parameters into the first slots.
        let arity = self.alphabet.arity(key);
        if arity > 0 {
            let (_, kl) = codec::get_key(bytes);
            for i in 0..arity {
                self.slots[i] = codec::get_param(&bytes[kl..], i);
            }
        }
        let mut chosen = None;
        if !kr.context.is_empty() {
            chosen = self.choose(table, &kr.context, kr.context_stochastic, end_off, st, pass)?;
        }
        if chosen.is_none() && !kr.free.is_empty() {
            chosen = self.choose(table, &kr.free, kr.free_stochastic, end_off, st, pass)?;
        }
        let Some(pi) = chosen else {
            return Ok(false);
        };
        let p = &table.prods[pi as usize];
        if table.check_balance {
            if st.depth + p.depth_min < 0 {
                return Err(self.unbalanced(table, Some(pi), pass));
            }
            st.depth += p.depth_delta;
            if p.depth_delta > 0 {
                st.last_opener = Some(pi);
            }
            if p.depth_delta < 0 || p.depth_min < 0 {
                st.last_closer = Some(pi);
            }
        }
        self.emit(p, out, pass)?;
        Ok(true)
    }

    /// A cheap first look: do the nearest context modules already differ?
    /// (Fills the right-context cache on first use for this module.)
    #[inline(always)]
    fn surely_not(&self, p: &Production, end_off: u64, st: &mut StepState) -> Result<bool, Error> {
        if let (Some(pat), Some(left)) = (p.left.last(), &st.left) {
            if left.last_key() != Some(pat.key) {
                return Ok(true);
            }
        }
        if p.right_simple {
            let right = st.right_of(end_off, &self.alphabet)?;
            if let (Some(RPat::Module(pat)), first) = (p.right.first(), right.keys.first()) {
                if first != Some(&pat.key) {
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }

    /// Does production `p` match here (contexts and condition)?
    #[inline]
    fn matches(
        &mut self,
        p: &Production,
        end_off: u64,
        st: &mut StepState,
        pass: Pass,
    ) -> Result<bool, Error> {
        if !p.left.is_empty()
            && !st
                .left
                .as_ref()
                .unwrap()
                .matches(&p.left, &self.alphabet, &mut self.slots)
        {
            return Ok(false);
        }
        if p.right_simple {
            let right = st.right_of(end_off, &self.alphabet)?;
            if !right.matches(&p.right, &self.alphabet, &mut self.slots) {
                return Ok(false);
            }
        } else if !p.right.is_empty() {
            // Matching from past the ignored run is the same: every pattern
            // element passes over ignored modules first.
            let read_err = |e| Error::io("temporary file", "cannot read", e);
            let start = st.right_start(end_off, &self.alphabet).map_err(read_err)?;
            let peek = st.peek.as_mut().unwrap();
            let ok = match_right(peek, &self.alphabet, start, &p.right, &mut self.slots)
                .map_err(read_err)?;
            if !ok {
                return Ok(false);
            }
        }
        match &p.cond {
            None => Ok(true),
            Some(c) => match c.eval(&self.slots, &mut self.stack, &mut self.rng) {
                Ok(v) => Ok(v != 0.0),
                Err(e) => Err(self.eval_error(e, pass)),
            },
        }
    }

    fn choose(
        &mut self,
        table: &Table,
        list: &[u32],
        stochastic: bool,
        end_off: u64,
        st: &mut StepState,
        pass: Pass,
    ) -> Result<Option<u32>, Error> {
        if !stochastic {
            for &pi in list {
                let p = &table.prods[pi as usize];
                if self.surely_not(p, end_off, st)? {
                    continue;
                }
                if self.matches(p, end_off, st, pass)? {
                    return Ok(Some(pi));
                }
            }
            return Ok(None);
        }
        // Weighted choice among all matching productions.
        self.cand.clear();
        self.cand_slots.clear();
        let mut total = 0.0;
        for &pi in list {
            let p = &table.prods[pi as usize];
            if self.surely_not(p, end_off, st)? || !self.matches(p, end_off, st, pass)? {
                continue;
            }
            let w = match &p.prob {
                None => 1.0,
                Some(c) => c
                    .eval(&self.slots, &mut self.stack, &mut self.rng)
                    .map_err(|e| self.eval_error(e, pass))?,
            };
            if w < 0.0 {
                return Err(Error::at(
                    self.origin.locate(p.prob.as_ref().unwrap().span.0),
                    format!("a probability cannot be negative ({w}, in {pass})"),
                ));
            }
            if w > 0.0 {
                total += w;
                self.cand.push((pi, w));
                self.cand_slots.extend_from_slice(&self.slots[..p.nslots]);
            }
        }
        let pick = match self.cand.len() {
            0 => return Ok(None),
            1 => 0,
            n => {
                let mut u = self.rng.uniform() * total;
                let mut i = 0;
                while i < n - 1 {
                    u -= self.cand[i].1;
                    if u < 0.0 {
                        break;
                    }
                    i += 1;
                }
                i
            }
        };
        // Restore the chosen production's bindings.
        let pi = self.cand[pick].0;
        let off: usize = self.cand[..pick]
            .iter()
            .map(|(q, _)| table.prods[*q as usize].nslots)
            .sum();
        let n = table.prods[pi as usize].nslots;
        self.slots[..n].copy_from_slice(&self.cand_slots[off..off + n]);
        Ok(Some(pi))
    }

    #[inline]
    fn emit(&mut self, p: &Production, out: &mut Out, pass: Pass) -> Result<(), Error> {
        for item in &p.succ {
            match item {
                Item::Const(c) => out.constant(c)?,
                Item::Module { key, params } => {
                    self.vals.clear();
                    for c in params.iter() {
                        match c.eval(&self.slots, &mut self.stack, &mut self.rng) {
                            Ok(v) => self.vals.push(v),
                            Err(e) => return Err(self.eval_error(e, pass)),
                        }
                    }
                    out.module(*key, &self.vals, &self.alphabet)?;
                }
            }
        }
        Ok(())
    }
}

/// Match a right context starting at file offset `pos` (just after the
/// predecessor), binding parameters into `slots`.
pub fn match_right(
    peek: &mut PosReader,
    al: &Alphabet,
    pos: u64,
    pat: &[RPat],
    slots: &mut [f64],
) -> io::Result<bool> {
    let Some((&first, rest)) = pat.split_first() else {
        return Ok(true);
    };
    match first {
        RPat::Module(p) => {
            let mut pos = pos;
            loop {
                peek.seek(pos);
                let Some((key, s, e)) = peek.next_module(al)? else {
                    return Ok(false);
                };
                let next = peek.offset();
                if key == OPEN {
                    // A branch the pattern does not ask for: skip it whole.
                    match peek.branch_end(al, s, next)? {
                        Some(after) => pos = after,
                        None => return Ok(false),
                    }
                    continue;
                }
                if key == CLOSE {
                    return Ok(false);
                }
                if al.ignored(key) {
                    pos = next;
                    continue;
                }
                if key != p.key {
                    return Ok(false);
                }
                let bytes = peek.bytes(s, e);
                let (_, kl) = codec::get_key(bytes);
                for i in 0..al.arity(key) {
                    slots[p.slot as usize + i] = codec::get_param(&bytes[kl..], i);
                }
                return match_right(peek, al, next, rest, slots);
            }
        }
        RPat::Open => {
            // Step over ignored modules to the first `[`, then try each of
            // the consecutive branches there.
            let mut pos = pos;
            loop {
                peek.seek(pos);
                let Some((key, _, _)) = peek.next_module(al)? else {
                    return Ok(false);
                };
                let next = peek.offset();
                if key == OPEN {
                    if match_right(peek, al, next, rest, slots)? {
                        return Ok(true);
                    }
                    // The recursion moved the buffer: read the `[` again.
                    peek.seek(pos);
                    let Some((_, s, _)) = peek.next_module(al)? else {
                        return Ok(false);
                    };
                    match peek.branch_end(al, s, next)? {
                        Some(after) => pos = after,
                        None => return Ok(false),
                    }
                    // Only a directly following branch is another candidate.
                    peek.seek(pos);
                    match peek.next_module(al)? {
                        Some((k, _, _)) if k == OPEN => continue,
                        _ => return Ok(false),
                    }
                }
                if key != CLOSE && al.ignored(key) {
                    pos = next;
                    continue;
                }
                return Ok(false);
            }
        }
        RPat::Close => match skip_branch(peek, al, pos)? {
            Some(after) => match_right(peek, al, after, rest, slots),
            None => Ok(false),
        },
    }
}

/// From inside a branch at `pos`, the offset just after the `]` that closes
/// it; None if the string ends first.
fn skip_branch(peek: &mut PosReader, al: &Alphabet, pos: u64) -> io::Result<Option<u64>> {
    peek.seek(pos);
    let mut depth = 0u64;
    while let Some((key, s, _)) = peek.next_module(al)? {
        if key == OPEN {
            if peek.indexed {
                // Jump over the nested branch.
                let end = u64::from_le_bytes(peek.buf[s + 1..s + 9].try_into().unwrap());
                peek.seek(end);
                continue;
            }
            depth += 1;
        } else if key == CLOSE {
            if depth == 0 {
                return Ok(Some(peek.offset()));
            }
            depth -= 1;
        }
    }
    Ok(None)
}
