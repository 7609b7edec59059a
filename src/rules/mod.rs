//! From syntax tree to compiled rules: the alphabet of module keys, the
//! productions with their expressions compiled and their successors turned
//! into byte templates, and a table that finds a module's productions by key
//! in O(1).

use crate::derive::random::Random;
use crate::diag::CompileError;
use crate::lang::ast::{self, Expr, Setting};
use crate::lang::lexer::Span;
use crate::lang::parse::UserError;
use crate::lang::sink::{HeadPart, HeaderSink, SectionKind, SectionStart};
use codec::MAX_ARITY;
use expr::{Code, Scope, CPFG_F32};
use std::collections::{HashMap, HashSet};

pub mod codec;
mod compile;
pub use compile::{
    compile, compile_dialect, compile_text, compile_with, Compiler, LoadError, Seeds,
};
pub mod expr;
mod keys;
mod thin;
use keys::{KeyList, KeyMap};
pub use thin::{Pair, Thin};

pub const OPEN: u32 = b'[' as u32;
pub const CLOSE: u32 = b']' as u32;

/// Which symbols contexts see.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Filter {
    #[default]
    All,
    Ignore(HashSet<char>),
    Consider(HashSet<char>),
}

impl Filter {
    fn ignores(&self, c: char) -> bool {
        if c == '[' || c == ']' {
            return false;
        }
        match self {
            Filter::All => false,
            Filter::Ignore(s) => s.contains(&c),
            Filter::Consider(s) => !s.contains(&c),
        }
    }
}

/// Every module kind (symbol, number of parameters) gets a key. Keys below
/// 128 are the ASCII symbols without parameters, equal to their byte.
#[derive(Clone)]
pub struct Alphabet {
    sym: Vec<char>,
    arity: Vec<u16>,
    /// Each key's symbol as UTF-8, in place (5 bytes a key; a boxed slice
    /// was 16 and a 32-byte chunk, for a header naming millions).
    text: Vec<KeyText>,
    ignored: Vec<bool>,
    /// (symbol, arity) to key, beyond the ASCII ones.
    map: KeyMap,
    filter: Filter,
    /// How a derivation writes parameters as text ([`Alphabet::numbers`]).
    numbers: codec::Numbers,
}

impl Alphabet {
    pub fn new(filter: Filter) -> Alphabet {
        let mut a = Alphabet {
            sym: Vec::new(),
            arity: Vec::new(),
            text: Vec::new(),
            ignored: Vec::new(),
            map: KeyMap::default(),
            filter,
            numbers: codec::Numbers::Shortest,
        };
        for b in 0u8..128 {
            let c = b as char;
            a.sym.push(c);
            a.arity.push(0);
            a.text.push(KeyText::of(c));
            a.ignored.push(a.filter.ignores(c));
        }
        a
    }

    /// The key of `sym` with `arity` parameters, made on first use.
    pub fn intern(&mut self, sym: char, arity: usize) -> Result<u32, CompileError> {
        if arity > MAX_ARITY {
            return Err(CompileError::TooManyParams(arity));
        }
        if arity == 0 && sym.is_ascii() {
            return Ok(sym as u32);
        }
        let arity = arity as u16;
        let is = |k: u32| self.sym[k as usize] == sym && self.arity[k as usize] == arity;
        if let Some(k) = self.map.get(sym, arity, is) {
            return Ok(k);
        }
        let k = self.sym.len() as u32;
        self.sym.push(sym);
        self.arity.push(arity);
        self.text.push(KeyText::of(sym));
        self.ignored.push(self.filter.ignores(sym));
        let (syms, arities) = (&self.sym, &self.arity);
        self.map
            .insert(sym, arity, k, |o| (syms[o as usize], arities[o as usize]));
        Ok(k)
    }

    #[inline]
    pub fn arity(&self, key: u32) -> usize {
        self.arity[key as usize] as usize
    }
    #[inline]
    pub fn text(&self, key: u32) -> &[u8] {
        let t = &self.text[key as usize];
        &t.bytes[..t.len as usize]
    }
    /// How parameters are written as text: lsgen's shortest form, or
    /// `--precision`'s and the cpfg dialect's significant digits. Set once
    /// before a derivation, with its tables' constant runs written again
    /// in it ([`Table::retext`]).
    #[inline]
    pub fn numbers(&self) -> codec::Numbers {
        self.numbers
    }
    pub fn set_numbers(&mut self, numbers: codec::Numbers) {
        self.numbers = numbers;
    }
    #[inline]
    pub fn symbol(&self, key: u32) -> char {
        self.sym[key as usize]
    }
    /// cpfg's right contexts (issue 12): is bracket `b` passed over like
    /// an ignored symbol? Under `consider:`, when not listed; under
    /// `ignore:`, when listed.
    pub fn bracket_passed(&self, b: char) -> bool {
        match &self.filter {
            Filter::All => false,
            Filter::Ignore(s) => s.contains(&b),
            Filter::Consider(s) => !s.contains(&b),
        }
    }

    /// Is this key passed over when matching contexts?
    #[inline]
    pub fn ignored(&self, key: u32) -> bool {
        self.ignored[key as usize]
    }
    pub fn len(&self) -> usize {
        self.sym.len()
    }
    pub fn is_empty(&self) -> bool {
        self.sym.is_empty()
    }
}

/// A symbol's UTF-8 bytes and their count.
#[derive(Clone, Copy)]
struct KeyText {
    len: u8,
    bytes: [u8; 4],
}

impl KeyText {
    fn of(c: char) -> KeyText {
        let mut bytes = [0u8; 4];
        let len = c.encode_utf8(&mut bytes).len() as u8;
        KeyText { len, bytes }
    }
}

/// A context module to match: its key and the slot of its first parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pat {
    pub key: u32,
    pub slot: u32,
}

/// An element of a right context.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RPat {
    Module(Pat),
    /// `[`: enter a lateral branch.
    Open,
    /// `]`: skip the rest of the current branch (the cpfg dialect: match
    /// a `]` of the string).
    Close,
    /// cpfg's `=`: skip to the end of the current branch (the cpfg dialect
    /// only; README, "Coming from cpfg").
    SkipRest,
}

/// Modules known at load time, precomputed in each format, in one
/// allocation behind a thin pointer (a production table may hold millions
/// of these: 8 bytes each, and the block no bigger than its bytes).
pub struct ConstRun {
    /// A 16-byte header (little-endian u32s: the module count, its top
    /// bit set if the run holds brackets; then where the binary, the
    /// indexed binary and the text end), the binary format, the binary
    /// with bracket index, the text; then, if it holds brackets, their
    /// count (4 bytes) and for each its offset in the indexed binary (4
    /// bytes), 1 if `[`, and how many of the run's modules come before it
    /// (4 bytes).
    data: NonNull<u8>,
}

use std::ptr::NonNull;

// Safety: a `ConstRun` owns its block, never changed after it is made.
unsafe impl Send for ConstRun {}
unsafe impl Sync for ConstRun {}

impl Default for ConstRun {
    fn default() -> ConstRun {
        ConstRun::new(&[], &[], &[], &[], 0)
    }
}

const HEADER: usize = 16;
/// The bytes of one bracket entry.
const BRACKET: usize = 9;
/// The module count's top bit: the run holds brackets.
const HAS_BRACKETS: u32 = 1 << 31;
/// A run held in place (`ConstRun::new`): the pointer's `W` bytes, the
/// one holding its low bit (never set in a block's address) at `TAG` with
/// the length times 2 plus 1, the bytes at `DATA..` (up to `INLINE`).
const W: usize = std::mem::size_of::<usize>();
const INLINE: usize = W - 1;
const TAG: usize = if cfg!(target_endian = "little") {
    0
} else {
    W - 1
};
const DATA: usize = if cfg!(target_endian = "little") { 1 } else { 0 };
/// Bit 1 of the word: a short block (a run without brackets whose block
/// is at most 255 bytes, e.g. of non-ASCII symbols, which cannot sit in
/// place): a 3-byte header (the module count, where the binary and where
/// the text end), the binary (also the indexed binary: no brackets), the
/// text. Two runs of a 4-byte symbol take 17 bytes, a 32-byte chunk, where
/// the full header and both binaries took 36, a 48-byte chunk.
const SHORT: usize = 2;
const SHORT_HEADER: usize = 3;
/// Blocks are 4-byte aligned: bits 0 and 1 of their address are tags.
const ALIGN: usize = 4;

impl ConstRun {
    fn new(
        bin: &[u8],
        ibin: &[u8],
        text: &[u8],
        brackets: &[(u32, bool, u32)],
        modules: u32,
    ) -> Self {
        assert!(modules < HAS_BRACKETS, "a header under 2 GiB");
        // Up to 7 ASCII symbols (3 on a 32-bit target) without parameters
        // or brackets: the three formats are the same bytes, held in the
        // pointer's place.
        if text.len() <= INLINE
            && bin == text
            && ibin == text
            && brackets.is_empty()
            && modules as usize == text.len()
        {
            let mut w = [0u8; W];
            w[TAG] = (text.len() as u8) << 1 | 1;
            w[DATA..DATA + text.len()].copy_from_slice(text);
            // Never dereferenced: a word of bytes in a pointer's place.
            let word = std::ptr::without_provenance_mut(usize::from_ne_bytes(w));
            let ptr = NonNull::new(word).expect("the tag bit is set");
            return ConstRun { data: ptr };
        }
        let short = SHORT_HEADER + bin.len() + text.len();
        // Only for runs naming a symbol outside ASCII (the ones that
        // cannot sit in place; a table of millions has millions of them):
        // reading the short form in the hot paths costs a little more.
        if !text.is_ascii() && brackets.is_empty() && bin == ibin && short <= 255 && modules <= 255
        {
            let mut data = Vec::with_capacity(short);
            data.extend_from_slice(&[modules as u8, (SHORT_HEADER + bin.len()) as u8, short as u8]);
            data.extend_from_slice(bin);
            data.extend_from_slice(text);
            let mut run = Self::in_block(&data);
            run.data = run.data.map_addr(|a| a | SHORT);
            return run;
        }
        let tail = if brackets.is_empty() {
            0
        } else {
            4 + BRACKET * brackets.len()
        };
        let mut data = Vec::with_capacity(HEADER + bin.len() + ibin.len() + text.len() + tail);
        let bin_end = HEADER + bin.len();
        let ibin_end = bin_end + ibin.len();
        let text_end = ibin_end + text.len();
        let flag = if brackets.is_empty() { 0 } else { HAS_BRACKETS };
        for v in [(modules | flag) as usize, bin_end, ibin_end, text_end] {
            let v = u32::try_from(v).expect("a header under 4 GiB");
            data.extend_from_slice(&v.to_le_bytes());
        }
        data.extend_from_slice(bin);
        data.extend_from_slice(ibin);
        data.extend_from_slice(text);
        if !brackets.is_empty() {
            data.extend_from_slice(&(brackets.len() as u32).to_le_bytes());
        }
        for &(at, open, before) in brackets {
            data.extend_from_slice(&at.to_le_bytes());
            data.push(u8::from(open));
            data.extend_from_slice(&before.to_le_bytes());
        }
        debug_assert_eq!(data.len(), data.capacity());
        Self::in_block(&data)
    }

    /// A run whose block holds `data` (header included).
    fn in_block(data: &[u8]) -> ConstRun {
        let layout = Self::layout(data.len());
        // Safety: the layout holds at least the header (not zero-sized);
        // `data` fills it.
        unsafe {
            let p = std::alloc::alloc(layout);
            let Some(ptr) = NonNull::new(p) else {
                std::alloc::handle_alloc_error(layout)
            };
            std::ptr::copy_nonoverlapping(data.as_ptr(), p, data.len());
            ConstRun { data: ptr }
        }
    }

    fn layout(len: usize) -> std::alloc::Layout {
        std::alloc::Layout::from_size_align(len, ALIGN).expect("a header under 4 GiB")
    }

    /// Is the run in place or in a short block (a tag bit set)?
    #[inline(always)]
    fn tagged(&self) -> bool {
        self.data.as_ptr().addr() & (1 | SHORT) != 0
    }

    /// The bytes of a run held in place (the same in every format).
    #[inline(always)]
    fn inline(&self) -> Option<&[u8]> {
        // Safety: the pointer's own 8 bytes, read as bytes.
        let w: &[u8; W] = unsafe { &*(&self.data as *const NonNull<u8>).cast::<[u8; W]>() };
        let t = w[TAG];
        (t & 1 == 1).then(|| &w[DATA..DATA + (t >> 1) as usize])
    }

    /// A short block's start.
    #[inline(always)]
    fn short(&self) -> *const u8 {
        self.data.as_ptr().map_addr(|a| a & !SHORT)
    }

    /// Is the run in a short block?
    #[inline(always)]
    fn is_short(&self) -> bool {
        self.data.as_ptr().addr() & SHORT != 0
    }

    /// A short block's binary (the same as its indexed binary).
    #[cold]
    #[inline(never)]
    fn short_bin(&self) -> &[u8] {
        let p = self.short();
        // Safety: a short block: the 3-byte header, the binary up to
        // where its second byte says.
        unsafe {
            std::slice::from_raw_parts(p.add(SHORT_HEADER), p.add(1).read() as usize - SHORT_HEADER)
        }
    }

    /// A short block's text.
    #[cold]
    #[inline(never)]
    fn short_text(&self) -> &[u8] {
        let p = self.short();
        // Safety: a short block: the text from the binary's end to the
        // block's end (the header's second and third bytes).
        unsafe {
            let (from, to) = (p.add(1).read() as usize, p.add(2).read() as usize);
            std::slice::from_raw_parts(p.add(from), to - from)
        }
    }

    /// The whole block (not for a run in place).
    fn bytes(&self) -> &[u8] {
        if self.tagged() {
            let p = self.data.as_ptr().map_addr(|a| a & !SHORT);
            // Safety: a short block's length is its header's last number.
            return unsafe { std::slice::from_raw_parts(p, p.add(2).read() as usize) };
        }
        let n = self.at(3);
        let len = if self.has_brackets() {
            n + 4 + BRACKET * self.word(n) as usize
        } else {
            n
        };
        // Safety: the block is `len` bytes (see `new`).
        unsafe { std::slice::from_raw_parts(self.data.as_ptr(), len) }
    }

    /// The little-endian u32 at byte `at` of the block.
    #[inline(always)]
    fn word(&self, at: usize) -> u32 {
        // Safety: callers read inside the block: the header, or the
        // bracket count after the text.
        u32::from_le_bytes(unsafe { self.data.as_ptr().add(at).cast::<[u8; 4]>().read() })
    }

    /// The header's `i`th number.
    #[inline(always)]
    fn at(&self, i: usize) -> usize {
        self.word(4 * i) as usize
    }

    /// Bytes `from..to` of the block.
    #[inline(always)]
    fn range(&self, from: usize, to: usize) -> &[u8] {
        // Safety: the header's offsets are in order and inside the block.
        unsafe { std::slice::from_raw_parts(self.data.as_ptr().add(from), to - from) }
    }

    /// Binary format.
    #[inline(always)]
    pub fn bin(&self) -> &[u8] {
        if let Some(b) = self.inline() {
            return b;
        }
        if self.is_short() {
            return self.short_bin();
        }
        self.range(HEADER, self.at(1))
    }
    /// Binary with bracket index: each `[` followed by
    /// [`codec::INDEX_BYTES`] that will hold the offset just past its `]`
    /// and the module count of its branch.
    #[inline(always)]
    pub fn ibin(&self) -> &[u8] {
        if let Some(b) = self.inline() {
            return b;
        }
        if self.is_short() {
            return self.short_bin();
        }
        self.range(self.at(1), self.at(2))
    }
    #[inline(always)]
    pub fn text(&self) -> &[u8] {
        if let Some(b) = self.inline() {
            return b;
        }
        if self.is_short() {
            return self.short_text();
        }
        self.range(self.at(2), self.at(3))
    }
    /// How many modules.
    #[inline(always)]
    pub fn modules(&self) -> u64 {
        if let Some(b) = self.inline() {
            return b.len() as u64;
        }
        if self.is_short() {
            // Safety: a short block's first byte is its module count.
            return u64::from(unsafe { self.short().read() });
        }
        u64::from(self.word(0) & !HAS_BRACKETS)
    }
    /// Offsets of the brackets in [`ibin`](Self::ibin) (true: `[`), and
    /// how many of the run's modules come before each.
    pub fn brackets(&self) -> impl Iterator<Item = (u32, bool, u64)> + '_ {
        let entries = if self.has_brackets() {
            &self.bytes()[self.at(3) + 4..]
        } else {
            &[]
        };
        entries.chunks_exact(BRACKET).map(|b| {
            (
                u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                b[4] == 1,
                u64::from(u32::from_le_bytes([b[5], b[6], b[7], b[8]])),
            )
        })
    }
    /// Does the run hold `[` or `]`?
    #[inline]
    pub fn has_brackets(&self) -> bool {
        !self.tagged() && self.word(0) & HAS_BRACKETS != 0
    }
}

impl Clone for ConstRun {
    fn clone(&self) -> ConstRun {
        if self.inline().is_some() {
            return ConstRun { data: self.data };
        }
        let mut run = ConstRun::in_block(self.bytes());
        // The same form: a short block's tag.
        let tag = self.data.as_ptr().addr() & SHORT;
        run.data = run.data.map_addr(|a| a | tag);
        run
    }
}

impl Drop for ConstRun {
    fn drop(&mut self) {
        if self.inline().is_some() {
            return;
        }
        let layout = Self::layout(self.bytes().len());
        let block = self.data.as_ptr().map_addr(|a| a & !SHORT);
        // Safety: the block was allocated with this layout (`new`).
        unsafe { std::alloc::dealloc(block, layout) }
    }
}

impl std::fmt::Debug for ConstRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConstRun")
            .field("modules", &self.modules())
            .field("text", &String::from_utf8_lossy(self.text()))
            .finish()
    }
}

/// Builds a [`ConstRun`] module by module.
#[derive(Default)]
struct ConstBuilder {
    bin: Vec<u8>,
    ibin: Vec<u8>,
    brackets: Vec<(u32, bool, u32)>,
    text: Vec<u8>,
    modules: u64,
}

impl ConstBuilder {
    fn push(&mut self, key: u32, vals: &[f64], al: &Alphabet, num: &mut codec::NumFmt) {
        codec::put_key(&mut self.bin, key);
        codec::put_params(&mut self.bin, vals);
        if key == OPEN || key == CLOSE {
            self.brackets
                .push((self.ibin.len() as u32, key == OPEN, self.modules as u32));
        }
        codec::put_key(&mut self.ibin, key);
        if key == OPEN {
            self.ibin.extend_from_slice(&[0; codec::INDEX_BYTES]);
        }
        codec::put_params(&mut self.ibin, vals);
        num.module(&mut self.text, al.text(key), vals, al.numbers());
        self.modules += 1;
    }

    fn take(&mut self) -> Option<ConstRun> {
        if self.modules == 0 {
            return None;
        }
        let b = std::mem::take(self);
        Some(ConstRun::new(
            &b.bin,
            &b.ibin,
            &b.text,
            &b.brackets,
            b.modules as u32,
        ))
    }
}

/// Part of a successor.
#[derive(Clone, Debug)]
pub enum Item {
    /// A run of modules known at load time, in every format.
    Const(ConstRun),
    /// A module whose parameters are computed.
    Module { key: u32, params: Thin<Code> },
}

/// A successor's items: a slice ([`Deref`](std::ops::Deref)). Most
/// successors are one item, kept in place (no block of their own).
#[derive(Clone, Debug)]
pub enum Succ {
    One(Item),
    Many(Thin<Item>),
}

impl std::ops::Deref for Succ {
    type Target = [Item];
    #[inline]
    fn deref(&self) -> &[Item] {
        match self {
            Succ::One(i) => std::slice::from_ref(i),
            Succ::Many(m) => m,
        }
    }
}

impl<'a> IntoIterator for &'a Succ {
    type Item = &'a Item;
    type IntoIter = std::slice::Iter<'a, Item>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl From<Vec<Item>> for Succ {
    fn from(mut v: Vec<Item>) -> Succ {
        match v.pop() {
            Some(i) if v.is_empty() => Succ::One(i),
            Some(i) => {
                v.push(i);
                Succ::Many(Thin::from(v))
            }
            None => Succ::Many(Thin::empty()),
        }
    }
}

impl From<Box<[Item]>> for Succ {
    fn from(b: Box<[Item]>) -> Succ {
        Succ::from(b.into_vec())
    }
}

/// A compiled production. Kept small (boxed slices, boxed expressions, a
/// one-item successor in place, u32 offsets and depths, the parts few
/// productions have behind one optional box): a table may hold millions.
#[derive(Debug)]
pub struct Production {
    pub key: u32,
    /// Slots ([`nslots`](Self::nslots)) in the low 31 bits; the top bit
    /// set: the right context has no brackets
    /// ([`right_simple`](Self::right_simple)).
    slots_simple: u32,
    /// Where the production starts in the header, for runtime errors
    /// ([`start`](Self::start); headers are far below 4 GiB).
    start: u32,
    /// The left context's length (the count `contexts` leaves to its
    /// owner; a word that would otherwise be padding).
    nleft: u32,
    /// Bracket depth change of the successor, and its lowest prefix.
    pub depth_delta: i32,
    pub depth_min: i32,
    /// The left context ([`left`](Self::left)) and the right context
    /// ([`right`](Self::right)), in one block.
    contexts: Pair<Pat, RPat>,
    pub cond: Option<Box<Code>>,
    pub succ: Succ,
    /// The probability and what only the cpfg dialect has (None for a
    /// production with neither: most).
    extra: Option<Box<Extra>>,
}

impl Clone for Production {
    fn clone(&self) -> Production {
        Production {
            key: self.key,
            slots_simple: self.slots_simple,
            start: self.start,
            nleft: self.nleft,
            depth_delta: self.depth_delta,
            depth_min: self.depth_min,
            // Safety: `nleft` is the left context's length.
            contexts: unsafe { self.contexts.copy(self.nleft as usize) },
            cond: self.cond.clone(),
            succ: self.succ.clone(),
            extra: self.extra.clone(),
        }
    }
}

impl Drop for Production {
    fn drop(&mut self) {
        // Safety: `nleft` is the left context's length.
        unsafe { self.contexts.free(self.nleft as usize) }
    }
}

/// The parts of a production few productions have.
#[derive(Clone, Debug, Default)]
struct Extra {
    prob: Option<Code>,
    cpfg: Option<Box<CpfgParts>>,
}

/// The top bit of `Production::slots_simple`.
const RIGHT_SIMPLE: u32 = 1 << 31;
/// The next bit: no context of any kind ([`Production::context_free`]).
const NO_CONTEXT: u32 = 1 << 30;
/// The bits of `slots_simple` that are flags.
const FLAGS: u32 = RIGHT_SIMPLE | NO_CONTEXT;

/// A production's cpfg-only parts (issue 12).
#[derive(Clone, Debug, Default)]
pub struct CpfgParts {
    /// The modules after the first of a predecessor of several modules,
    /// matched strictly one after the other.
    pub rest: Box<[Pat]>,
    /// The pre-condition block (runs before the condition, also when it
    /// fails) and the post-condition block (runs when the production is
    /// applied, before its successor).
    pub pre: Option<crate::cpfg::blocks::Block>,
    pub post: Option<crate::cpfg::blocks::Block>,
}

impl Production {
    /// A production; its slots are predecessor parameters, then left
    /// context, then right context.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        key: u32,
        nslots: usize,
        left: &[Pat],
        right: &[RPat],
        cond: Option<Box<Code>>,
        prob: Option<Code>,
        succ: Succ,
        start: u32,
        depth: (i32, i32),
    ) -> Production {
        let right_simple = !right.is_empty() && right.iter().all(|r| matches!(r, RPat::Module(_)));
        let mut p = Production {
            key,
            slots_simple: 0,
            start,
            depth_delta: depth.0,
            depth_min: depth.1,
            nleft: u32::try_from(left.len()).expect("a header under 4 GiB"),
            contexts: Pair::new(left, right),
            cond,
            succ,
            extra: prob.map(|c| {
                Box::new(Extra {
                    prob: Some(c),
                    cpfg: None,
                })
            }),
        };
        p.set_nslots(nslots);
        p.set_right_simple(right_simple);
        if left.is_empty() && right.is_empty() {
            p.slots_simple |= NO_CONTEXT;
        }
        p
    }
    /// No left or right context, and a predecessor of one module: every
    /// context test passes without binding anything, so the choice skips
    /// it. (A production given cpfg's parts loses the flag.)
    #[inline(always)]
    pub fn context_free(&self) -> bool {
        self.slots_simple & NO_CONTEXT != 0
    }
    pub fn has_context(&self) -> bool {
        !self.left().is_empty() || !self.right().is_empty() || !self.rest().is_empty()
    }
    /// The left context.
    #[inline(always)]
    pub fn left(&self) -> &[Pat] {
        // Safety: `nleft` is the left context's length.
        unsafe { self.contexts.a(self.nleft as usize) }
    }
    /// The right context.
    #[inline(always)]
    pub fn right(&self) -> &[RPat] {
        // Safety: as `left`.
        unsafe { self.contexts.b(self.nleft as usize) }
    }
    /// How many parameter slots matching the production fills.
    #[inline(always)]
    pub fn nslots(&self) -> usize {
        (self.slots_simple & !FLAGS) as usize
    }
    pub fn set_nslots(&mut self, n: usize) {
        let n = u32::try_from(n)
            .ok()
            .filter(|n| n & FLAGS == 0)
            .expect("a header under 1 GiB");
        self.slots_simple = (self.slots_simple & FLAGS) | n;
    }
    /// The right context has no brackets: it is matched against the cached
    /// list of the next considered modules.
    #[inline(always)]
    pub fn right_simple(&self) -> bool {
        self.slots_simple & RIGHT_SIMPLE != 0
    }
    fn set_right_simple(&mut self, simple: bool) {
        self.slots_simple =
            (self.slots_simple & !RIGHT_SIMPLE) | if simple { RIGHT_SIMPLE } else { 0 };
    }
    /// The probability (weight) expression.
    #[inline]
    pub fn prob(&self) -> Option<&Code> {
        self.extra.as_ref().and_then(|x| x.prob.as_ref())
    }
    /// Where the production starts in the header.
    #[inline]
    pub fn start(&self) -> usize {
        self.start as usize
    }
    #[inline]
    fn cpfg(&self) -> Option<&CpfgParts> {
        self.extra.as_ref().and_then(|x| x.cpfg.as_deref())
    }
    /// cpfg: the predecessor's modules after the first.
    #[inline]
    pub fn rest(&self) -> &[Pat] {
        self.cpfg().map_or(&[], |c| &c.rest)
    }
    /// cpfg's pre-condition block.
    #[inline]
    pub fn pre(&self) -> Option<&crate::cpfg::blocks::Block> {
        self.cpfg().and_then(|c| c.pre.as_ref())
    }
    /// cpfg's post-condition block.
    #[inline]
    pub fn post(&self) -> Option<&crate::cpfg::blocks::Block> {
        self.cpfg().and_then(|c| c.post.as_ref())
    }
    /// The cpfg-only parts, made on first use.
    pub fn cpfg_mut(&mut self) -> &mut CpfgParts {
        // (Its `rest` may be set: a context for the choice.)
        self.slots_simple &= !NO_CONTEXT;
        self.extra
            .get_or_insert_with(Box::default)
            .cpfg
            .get_or_insert_with(Box::default)
    }
}

/// The productions of one key, in file order, split by kind (numbers in
/// the table's `prods`): lists of their exact size, made once the table is
/// complete (`Table::index`), each one word with its "stochastic" flag, a
/// one-production list in place (a header may name millions of symbols:
/// 24 bytes a key, no block for the common one).
#[derive(Clone, Debug, Default)]
pub struct KeyRules {
    /// Context-sensitive productions: a match beats every context-free one.
    context: KeyList,
    free: KeyList,
    /// Group 0's productions of the key, tried when a numbered group's
    /// choose nothing (issue 11, lpfg's rule).
    fallback: Option<Box<KeyRules>>,
}

impl KeyRules {
    /// Has the key context-sensitive productions?
    #[inline]
    pub fn has_context(&self) -> bool {
        !self.context.is_empty()
    }
    /// Has the key context-free productions?
    #[inline]
    pub fn has_free(&self) -> bool {
        !self.free.is_empty()
    }
    /// Is one of the context-sensitive productions stochastic?
    #[inline]
    pub fn context_stochastic(&self) -> bool {
        self.context.stochastic()
    }
    /// Is one of the context-free productions stochastic?
    #[inline]
    pub fn free_stochastic(&self) -> bool {
        self.free.stochastic()
    }
    /// Group 0's productions of the key, for a numbered group.
    #[inline]
    pub fn fallback(&self) -> Option<&KeyRules> {
        self.fallback.as_deref()
    }
    /// cpfg's order ([`Table::cpfg_order`]) for this key.
    fn cpfg_order(&mut self) {
        if self.has_context() && self.has_free() {
            let (c, f) = (self.context.as_slice(), self.free.as_slice());
            let mut all: Vec<u32> = c.iter().chain(f).copied().collect();
            all.sort_unstable();
            let stochastic = self.context.stochastic() || self.free.stochastic();
            self.context = KeyList::from_slice(&all);
            self.context.set_stochastic(stochastic);
            self.free = KeyList::empty();
        }
    }
}

#[derive(Debug, Default)]
pub struct Table {
    pub prods: Vec<Production>,
    /// Each key's productions ([`index`](Self::index)).
    by_key: Vec<Option<KeyRules>>,
    /// Longest left context.
    pub max_left: usize,
    pub has_right: bool,
    /// Some predecessor has several modules (cpfg dialect): only the step
    /// engine, which looks ahead, derives it.
    pub has_multi: bool,
    /// Longest bracket-free right context.
    pub max_right_simple: usize,
    /// Some successor is not bracket-balanced: check each step's output.
    pub check_balance: bool,
}

/// A rewriting that needs no decision: the successor of a key whose first
/// context-free production always applies (no context production for the
/// key, no condition, no probability) and is known at load time.
pub struct Fixed<'t> {
    pub bin: &'t [u8],
    pub text: &'t [u8],
    pub modules: u64,
    /// The successor holds `[` or `]`.
    pub brackets: bool,
}

impl Table {
    /// Does trying a production (not applying it) change anything, in the
    /// cpfg dialect: a pre-condition block, or a condition that draws or
    /// reseeds (`ran`, `srand` ...) or may warn or fail (a division or a
    /// remainder by zero)?
    /// cpfg tries a module's productions also where it then does not
    /// apply them (at the depth limit of the decomposition and the
    /// homomorphism): such tries must happen.
    pub fn tries_have_effects(&self) -> bool {
        self.prods.iter().any(|p| {
            p.pre().is_some()
                || p.cond
                    .as_ref()
                    .is_some_and(|c| c.uses_random() || c.may_warn_or_fail())
        })
    }

    /// How `key` is rewritten if no decision is needed: `Some(None)` it has
    /// no production (copied), `Some(Some(f))` always `f`, `None` it needs
    /// the general path.
    pub fn fixed(&self, key: u32) -> Option<Option<Fixed<'_>>> {
        let Some(kr) = self.get(key) else {
            return Some(None);
        };
        let p = &self.prods[*self.free(kr).first()? as usize];
        // (cpfg's blocks run whenever the production is tried.)
        if kr.has_context()
            || kr.free_stochastic()
            || p.cond.is_some()
            || p.pre().is_some()
            || p.post().is_some()
        {
            return None;
        }
        match &*p.succ {
            [] => Some(Some(Fixed {
                bin: &[],
                text: &[],
                modules: 0,
                brackets: false,
            })),
            [Item::Const(c)] => Some(Some(Fixed {
                bin: c.bin(),
                text: c.text(),
                modules: c.modules(),
                brackets: c.has_brackets(),
            })),
            _ => None,
        }
    }

    /// Add a compiled production after the others.
    pub fn push(&mut self, p: Production) {
        self.max_left = self.max_left.max(p.left().len());
        self.has_right |= !p.right().is_empty();
        self.has_multi |= !p.rest().is_empty();
        if p.right_simple() {
            self.max_right_simple = self.max_right_simple.max(p.right().len());
        }
        // (A bracket predecessor, cpfg's: the step checks what replaces
        // it, on its general path.)
        self.check_balance |=
            p.depth_delta != 0 || p.depth_min < 0 || p.key == OPEN || p.key == CLOSE;
        self.prods.push(p);
    }

    /// Drop the spare capacity the table grew with, and find each key's
    /// productions (before [`get`](Self::get)).
    fn shrink(&mut self) {
        self.prods.shrink_to_fit();
        self.index(self.prods.len());
    }

    /// Group `prods[..own]` by key: each key's lists in file order, made
    /// at their exact size (counted first), context-sensitive and
    /// context-free apart. Filled in place: nothing per key but the counts
    /// (8 bytes) exists beside the result (a header may name millions of
    /// symbols).
    fn index(&mut self, own: usize) {
        let keys = self.prods[..own]
            .iter()
            .map(|p| p.key as usize + 1)
            .max()
            .unwrap_or(0);
        let mut counts = vec![[0u32; 2]; keys];
        for p in &self.prods[..own] {
            counts[p.key as usize][usize::from(!p.has_context())] += 1;
        }
        let list = |n: u32| KeyList::zeroed(n as usize);
        self.by_key = counts
            .iter()
            .map(|&[c, f]| {
                (c + f > 0).then(|| KeyRules {
                    context: list(c),
                    free: list(f),
                    fallback: None,
                })
            })
            .collect();
        // Now the number of each key's entries filled so far.
        counts.iter_mut().for_each(|c| *c = [0; 2]);
        for (i, p) in self.prods[..own].iter().enumerate() {
            let k = p.key as usize;
            let Some(kr) = &mut self.by_key[k] else {
                continue;
            };
            let free = !p.has_context();
            let at = &mut counts[k][usize::from(free)];
            let list = if free { &mut kr.free } else { &mut kr.context };
            list.as_mut_slice()[*at as usize] = i as u32;
            if p.prob().is_some() {
                list.set_stochastic(true);
            }
            *at += 1;
        }
    }

    #[inline]
    pub fn get(&self, key: u32) -> Option<&KeyRules> {
        self.by_key.get(key as usize).and_then(Option::as_ref)
    }
    /// `kr`'s context-sensitive productions (numbers in `prods`), in file
    /// order.
    #[inline]
    pub fn context<'a>(&'a self, kr: &'a KeyRules) -> &'a [u32] {
        kr.context.as_slice()
    }
    /// `kr`'s context-free productions, in file order.
    #[inline]
    pub fn free<'a>(&'a self, kr: &'a KeyRules) -> &'a [u32] {
        kr.free.as_slice()
    }
    pub fn is_empty(&self) -> bool {
        self.prods.is_empty()
    }
    pub fn has_context(&self) -> bool {
        self.max_left > 0 || self.has_right || self.has_multi
    }

    /// Can rewriting with this table draw a random number: a stochastic
    /// choice, or `ran`/`nran` in a condition, a probability or a
    /// successor's parameter? (cpfg's statement blocks are not looked at:
    /// cpfg passes neither split nor go depth first.)
    pub fn may_draw(&self) -> bool {
        self.prods.iter().any(|p| {
            p.prob().is_some()
                || p.cond.as_ref().is_some_and(|c| c.uses_random())
                || p.succ.iter().any(|i| match i {
                    Item::Const(_) => false,
                    Item::Module { params, .. } => params.iter().any(|c| c.uses_random()),
                })
        })
    }

    /// Write the text of every constant run with parameters again, in
    /// `al`'s number form ([`Alphabet::numbers`]): before a derivation
    /// whose form is not the one they were compiled in. Once per run; the
    /// runs without parameters stay as they are.
    pub fn retext(&mut self, al: &Alphabet) {
        let mut num = codec::NumFmt::new();
        let mut vals = Vec::new();
        for p in &mut self.prods {
            let items: &mut [Item] = match &mut p.succ {
                Succ::One(i) => std::slice::from_mut(i),
                Succ::Many(m) => m,
            };
            for item in items {
                let Item::Const(c) = item else {
                    continue;
                };
                let mut b = ConstBuilder::default();
                let mut params = false;
                for (key, body) in codec::modules_of(c.bin(), |k| al.arity(k)) {
                    let n = body.len() / 8;
                    vals.clear();
                    vals.extend(codec::params_of(body, n));
                    params |= n > 0;
                    b.push(key, &vals, al, &mut num);
                }
                // (A text that reads the same keeps its run.)
                if params && b.text != c.text() {
                    if let Some(run) = b.take() {
                        *c = run;
                    }
                }
            }
        }
    }

    /// Does a successor of these productions hold a module that one of
    /// them rewrites (the first module of its predecessor, or a later
    /// one of cpfg's predecessors of several modules)? Only then can a
    /// homomorphism of depth 1 reach its depth limit.
    pub fn rewrites_own_successors(&self, al: &Alphabet) -> bool {
        // (The later modules of predecessors, once: a table may be large.)
        let later: HashSet<u32> = match self.has_multi {
            true => self
                .prods
                .iter()
                .flat_map(|p| p.rest())
                .map(|r| r.key)
                .collect(),
            false => HashSet::new(),
        };
        let rewritten = |key: u32| self.get(key).is_some() || later.contains(&key);
        self.prods.iter().any(|p| {
            p.succ.iter().any(|i| match i {
                Item::Module { key, .. } => rewritten(*key),
                Item::Const(c) => {
                    codec::modules_of(c.bin(), |k| al.arity(k)).any(|(k, _)| rewritten(k))
                }
            })
        })
    }

    /// Does every production that can apply depend on its module alone and
    /// nothing else: no context (nor predecessor of several modules), no
    /// bracket balance check, no draw? Then a string's modules can be
    /// rewritten in any order (`derive::dfs`).
    pub fn deterministic_free(&self) -> bool {
        !self.has_context() && !self.check_balance && !self.may_draw()
    }

    /// Can the cpfg dialect apply these productions to a string's modules
    /// in any order (depth first, on several threads) and get what cpfg
    /// gets in string order? Not if trying or applying one can draw, warn
    /// or run a block, or if one has a context or a predecessor of several
    /// modules. (The file's own blocks, `seed:` and queries are the
    /// caller's to check.)
    pub fn cpfg_any_order(&self) -> bool {
        self.deterministic_free()
            && self.prods.iter().all(|p| {
                p.pre().is_none()
                    && p.post().is_none()
                    && !p
                        .cond
                        .iter()
                        .map(|c| &**c)
                        .chain(p.prob())
                        .any(Code::may_warn)
                    && p.succ.iter().all(|i| match i {
                        Item::Const(_) => true,
                        Item::Module { params, .. } => !params.iter().any(Code::may_warn),
                    })
            })
    }

    /// cpfg's right contexts (issue 12): every one goes through cpfg's
    /// matcher (no cached bracket-free shortcut), and a `=` module in a
    /// right context is cpfg's "skip the rest of the branch".
    pub fn for_cpfg(&mut self, al: &Alphabet) {
        for p in &mut self.prods {
            p.set_right_simple(false);
            // Safety: `nleft` is the left context's length.
            for r in unsafe { p.contexts.b_mut(p.nleft as usize) } {
                if let RPat::Module(m) = r {
                    if m.key == u32::from(b'=') && al.arity(m.key) == 0 {
                        *r = RPat::SkipRest;
                    }
                }
            }
        }
        self.max_right_simple = 0;
    }

    /// A seeded cpfg system's productions (cpfg's `seed:`, or `--seed`):
    /// each one without a probability has probability 1 (cpfg's
    /// `lsys_input.y`), so every key with two productions or more draws
    /// among them. Marked stochastic, so that no fast path that takes a
    /// key's first production (`fixed`, the byte table, the depth-first
    /// plans) takes theirs. (Decomposition and homomorphism productions
    /// never compete: not for their tables.)
    pub fn cpfg_seeded(&mut self) {
        for kr in self.by_key.iter_mut().flatten() {
            for list in [&mut kr.context, &mut kr.free] {
                if list.as_slice().len() > 1 {
                    list.set_stochastic(true);
                }
            }
        }
    }

    /// cpfg's choice: the first applicable production in file order,
    /// context-sensitive or not. One list per key, in file order, tried
    /// by the one chooser as it tries a context group.
    fn cpfg_order(&mut self) {
        for kr in self.by_key.iter_mut().flatten() {
            kr.cpfg_order();
        }
    }

    /// Lay numbered group `g` over this table, group 0's, for one step
    /// (issue 11): the group's productions go after group 0's, each key
    /// of the group gets the group's lists with group 0's (if any) as
    /// their fallback, and every other key keeps group 0's. Taken off
    /// again when the result is dropped. Costs the group's size, not
    /// group 0's: nothing of group 0 is copied.
    pub fn lay<'a>(&'a mut self, g: &'a mut Group) -> Laid<'a> {
        assert_eq!(
            self.prods.len(),
            g.at as usize,
            "a group's numbers follow group 0's productions"
        );
        let saved = Saved {
            keys: self.by_key.len(),
            max_left: self.max_left,
            has_right: self.has_right,
            has_multi: self.has_multi,
            max_right_simple: self.max_right_simple,
            check_balance: self.check_balance,
        };
        // (The group's vector keeps its capacity for `lift`; group 0's
        // keeps the room it gets here for the next time.)
        self.prods.reserve_exact(g.own.prods.len());
        self.prods.append(&mut g.own.prods);
        let top = g.keys.last().map_or(0, |(k, _)| *k as usize + 1);
        if self.by_key.len() < top {
            self.by_key.resize_with(top, || None);
        }
        for (key, kr) in &mut g.keys {
            let slot = &mut self.by_key[*key as usize];
            let under = slot.take().map(Box::new);
            *slot = Some(KeyRules {
                fallback: under,
                ..std::mem::take(kr)
            });
        }
        let own = &g.own;
        self.max_left = self.max_left.max(own.max_left);
        self.has_right |= own.has_right;
        self.has_multi |= own.has_multi;
        self.max_right_simple = self.max_right_simple.max(own.max_right_simple);
        self.check_balance |= own.check_balance;
        Laid {
            base: self,
            group: Some((g, saved)),
        }
    }
}

/// A numbered production group (issue 11): its own productions only, and
/// the lists of the keys it has (sorted by key: a group naming a few keys
/// of a large alphabet holds a few entries), numbered as they are while
/// the group is laid over group 0 ([`Table::lay`]), after group 0's
/// productions. Memory: the group's own size, however large group 0 or
/// the alphabet.
#[derive(Debug)]
pub struct Group {
    /// The group's productions and their flags (`by_key` unused: the
    /// lists are `keys`); empty while the group is laid.
    own: Table,
    keys: Vec<(u32, KeyRules)>,
    /// Group 0's number of productions: the group's first production's
    /// number while it is laid.
    at: u32,
}

impl Group {
    /// The group of the productions of `t` (in file order), over group 0
    /// (`base`, complete).
    fn new(mut t: Table, base: &Table, cpfg: bool) -> Group {
        t.prods.shrink_to_fit();
        let at = u32::try_from(base.prods.len()).expect("a header under 4 GiB");
        let mut order: Vec<u32> = (0..t.prods.len() as u32).collect();
        // (Stable: each key's productions stay in file order.)
        order.sort_by_key(|&i| t.prods[i as usize].key);
        let prods = &t.prods;
        let mut keys = Vec::new();
        for run in order.chunk_by(|&a, &b| prods[a as usize].key == prods[b as usize].key) {
            // Context-sensitive, then context-free, each in file order.
            let list = |context: bool| {
                let mine = run
                    .iter()
                    .filter(|&&i| prods[i as usize].has_context() == context);
                let v: Vec<u32> = mine.clone().map(|i| at + i).collect();
                let mut l = KeyList::from_slice(&v);
                l.set_stochastic(mine.clone().any(|&i| prods[i as usize].prob().is_some()));
                l
            };
            let mut kr = KeyRules {
                context: list(true),
                free: list(false),
                fallback: None,
            };
            if cpfg {
                kr.cpfg_order();
            }
            keys.push((prods[run[0] as usize].key, kr));
        }
        keys.shrink_to_fit();
        Group { own: t, keys, at }
    }

    /// The group's own productions and flags (not a table to rewrite
    /// with: see [`Table::lay`]).
    pub fn own(&self) -> &Table {
        &self.own
    }

    /// [`Table::retext`] for its own productions (what it lays).
    pub fn retext(&mut self, al: &Alphabet) {
        self.own.retext(al)
    }
}

/// What [`Table::lay`] changed in group 0's table, to restore.
struct Saved {
    keys: usize,
    max_left: usize,
    has_right: bool,
    has_multi: bool,
    max_right_simple: usize,
    check_balance: bool,
}

/// The table of one step: group 0's, or a numbered group laid over it
/// ([`Table::lay`]), taken off when this is dropped.
pub struct Laid<'a> {
    base: &'a mut Table,
    group: Option<(&'a mut Group, Saved)>,
}

impl<'a> Laid<'a> {
    /// Group 0's table as it is.
    pub fn plain(base: &'a mut Table) -> Laid<'a> {
        Laid { base, group: None }
    }
}

impl std::ops::Deref for Laid<'_> {
    type Target = Table;
    fn deref(&self) -> &Table {
        self.base
    }
}

impl Drop for Laid<'_> {
    fn drop(&mut self) {
        let Some((g, saved)) = self.group.take() else {
            return;
        };
        let base = &mut *self.base;
        for (key, kr) in &mut g.keys {
            let slot = &mut base.by_key[*key as usize];
            let laid = slot.take().expect("a laid group's key");
            *slot = laid.fallback.map(|b| *b);
            *kr = KeyRules {
                fallback: None,
                ..laid
            };
        }
        base.by_key.truncate(saved.keys);
        g.own.prods.extend(base.prods.drain(g.at as usize..));
        base.max_left = saved.max_left;
        base.has_right = saved.has_right;
        base.has_multi = saved.has_multi;
        base.max_right_simple = saved.max_right_simple;
        base.check_balance = saved.check_balance;
    }
}

pub struct System {
    pub alphabet: Alphabet,
    pub productions: Table,
    pub homomorphism: Table,
    pub derivation_length: Option<u64>,
    pub seed: Option<u64>,
    pub consts: HashMap<String, f64>,
    /// Issue 11: numbered production groups, each laid over group 0 (its
    /// fallback) for its steps, and the schedule (group numbers, cycling;
    /// empty: every step uses group 0).
    pub groups: Vec<(u32, Group)>,
    pub schedule: Vec<u32>,
    /// `group: EXPR`, evaluated with `step` before each step.
    pub group_expr: Option<Code>,
    /// Decomposition and its maximum depth.
    pub decomposition: Option<(Table, usize)>,
    pub hom_depth: usize,
    /// The homomorphism's own seed (`seed:` in its section).
    pub hom_seed: Option<u64>,
    /// `warnings` on the decomposition and on the homomorphism.
    pub warnings: [bool; 2],
    /// Where a constant or a formal parameter named `step` hides the
    /// built-in step number (a warning each).
    pub step_hidden: Vec<Span>,
    /// A `.l` file's run-time settings (issue 12): cpfg's generators,
    /// context rules and the step strategy.
    pub cpfg: Option<Box<crate::cpfg::run::CpfgRun>>,
    /// A cpfg file's map from preprocessed text to original places (set by
    /// the loader): runtime errors are located through it.
    pub source_map: Option<std::sync::Arc<crate::cpfg::preprocess::SourceMap>>,
}

/// `v` in a block of its exact size. Shrinking the vector in place would
/// leave the rest of its block behind as a small free chunk, one per
/// production: a table of millions of productions grows by a third.
fn exact<T>(mut v: Vec<T>) -> Box<[T]> {
    if v.len() == v.capacity() {
        return v.into_boxed_slice();
    }
    let mut b = Vec::with_capacity(v.len());
    b.append(&mut v);
    b.into_boxed_slice()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::parse::parse_header;

    fn sys(src: &str) -> Result<System, UserError> {
        compile(&parse_header(src).unwrap())
    }

    /// A production's slots are its predecessor's parameters, then its
    /// rest's (cpfg), then its left context's, then its right context's,
    /// though the left context comes first in the text and is compiled as
    /// it is read: the same from the text and from a tree, in both
    /// dialects.
    #[test]
    fn slots_put_the_predecessor_first() {
        let src = "productions:\nA(a) B(b, c) < P(p) > [C(d)] E(e) -> X(a+b+c+d+e+p)\n";
        let streamed = compile_text(src, Seeds::default()).unwrap();
        let tree = sys(src).unwrap();
        for s in [&streamed, &tree] {
            let p = &s.productions.prods[0];
            assert_eq!(p.nslots(), 6);
            let left: Vec<u32> = p.left().iter().map(|x| x.slot).collect();
            assert_eq!(left, [1, 2]);
            let right: Vec<Option<u32>> = p
                .right()
                .iter()
                .map(|r| match r {
                    RPat::Module(m) => Some(m.slot),
                    _ => None,
                })
                .collect();
            assert_eq!(right, [None, Some(4), None, Some(5)]);
        }
        // cpfg: `P(p) Q(q)` is a predecessor of two modules.
        let mut h = parse_header("productions:\nA(a) < P(p) > E(e) -> X\n").unwrap();
        let q = ast::Module {
            sym: 'Q',
            params: vec![ast::Expr::Var("q".into(), (0, 0))],
            span: (0, 0),
        };
        h.productions[0].pred_rest.push(q);
        let s = compile_dialect(h, None, Seeds::default(), true).unwrap();
        let p = &s.productions.prods[0];
        assert_eq!((p.nslots(), p.rest()[0].slot, p.left()[0].slot), (4, 1, 2));
        assert!(matches!(p.right()[0], RPat::Module(m) if m.slot == 3));
    }

    #[test]
    fn keys() {
        let mut a = Alphabet::new(Filter::All);
        assert_eq!(a.intern('F', 0).unwrap(), b'F' as u32);
        let k = a.intern('F', 1).unwrap();
        assert!(k >= 128);
        assert_eq!(a.intern('F', 1).unwrap(), k);
        let o = a.intern('Ω', 0).unwrap();
        assert_eq!(a.text(o), "Ω".as_bytes());
        assert_eq!(a.arity(k), 1);
    }

    /// A numbered group holds its own productions only (issue 11). Laid
    /// over group 0 for a step, a key of the group tries the group's
    /// lists, then group 0's as their fallback; every other key has group
    /// 0's; the flags are both tables'. Taken off, group 0's table is as
    /// it was, and the group can be laid again.
    #[test]
    fn a_group_is_laid_over_group_0_and_taken_off() {
        let src = "groups: 1\nproductions:\nA -> X\nA : 1 -> Y\nB < C -> Z\n\
                   productions 1:\nA : 0 -> W\nD > E -> V\nD -> U\n";
        let mut s = sys(src).unwrap();
        let (base, g) = (&mut s.productions, &mut s.groups[0].1);
        assert_eq!(g.own().prods.len(), 3);
        assert!(g.own().get(u32::from(b'A')).is_none());
        let before = format!("{base:?}");
        let key = |c: u8| u32::from(c);
        for _ in 0..2 {
            let t = base.lay(g);
            assert_eq!(t.prods.len(), 6);
            // The group's productions are numbered after group 0's.
            let a = t.get(key(b'A')).unwrap();
            assert_eq!(t.free(a), [3]);
            let under = a.fallback().unwrap();
            assert_eq!(
                (t.free(under), under.fallback().is_none()),
                (&[0, 1][..], true)
            );
            let c = t.get(key(b'C')).unwrap();
            assert_eq!((t.context(c), c.fallback().is_none()), (&[2][..], true));
            let d = t.get(key(b'D')).unwrap();
            assert_eq!((t.context(d), t.free(d)), (&[4][..], &[5][..]));
            assert!(d.fallback().is_none());
            assert!(t.get(key(b'E')).is_none());
            assert_eq!((t.max_left, t.has_right), (1, true));
            drop(t);
            assert_eq!(format!("{base:?}"), before);
            assert_eq!(g.own().prods.len(), 3);
        }
    }

    #[test]
    fn constant_successors_are_precompiled() {
        let s = sys("define: R = 2\nproductions:\nF -> F(R)[+F]G(1,R*3)\n").unwrap();
        let p = &s.productions.prods[0];
        assert_eq!(p.succ.len(), 1);
        match &p.succ[0] {
            Item::Const(c) => {
                assert_eq!(std::str::from_utf8(c.text()).unwrap(), "F(2)[+F]G(1,6)");
                assert_eq!(c.modules(), 6);
                // F(2) is 10 bytes; the `[` carries the index; modules
                // F(2) [ + F ] G: the `[` is the second, the `]` the fifth.
                let close = 13 + codec::INDEX_BYTES as u32;
                assert_eq!(
                    c.brackets().collect::<Vec<_>>(),
                    [(10, true, 1), (close, false, 4)]
                );
                assert_eq!(c.ibin().len(), c.bin().len() + codec::INDEX_BYTES);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!((p.depth_delta, p.depth_min), (0, 0));
        assert!(!s.productions.check_balance);
    }

    /// Up to 7 ASCII symbols without parameters or brackets sit in the
    /// pointer's place (issue 9 item 6); longer runs, parameters or
    /// brackets take a block. Every reader sees the same bytes.
    #[test]
    fn small_runs_sit_in_place() {
        let s = sys("productions:\nA -> FF\nB -> F+F--FF\nC -> F+F--F+F\nD -> F(1)\nE -> [F]\n")
            .unwrap();
        let run = |i: usize| match &s.productions.prods[i].succ[0] {
            Item::Const(c) => c.clone(),
            other => panic!("{other:?}"),
        };
        for (i, text, inline) in [
            (0, "FF", true),
            (1, "F+F--FF", true),
            (2, "F+F--F+F", false),
            (3, "F(1)", false),
            (4, "[F]", false),
        ] {
            let c = run(i);
            assert_eq!(c.inline().is_some(), inline, "{text}");
            assert_eq!(c.text(), text.as_bytes());
            assert_eq!(c.modules(), if i == 3 { 1 } else { text.len() as u64 });
            assert_eq!(c.has_brackets(), i == 4);
            assert_eq!(c.brackets().count(), if i == 4 { 2 } else { 0 });
            if i < 3 {
                assert_eq!((c.bin(), c.ibin()), (text.as_bytes(), text.as_bytes()));
            }
        }
    }

    /// A run naming a symbol outside ASCII, without brackets, in a short
    /// block (3-byte header, one binary): its formats, clones and drops.
    #[test]
    fn non_ascii_runs_take_a_short_block() {
        let long = "é".repeat(180);
        let s = sys(&format!(
            "productions:\nA -> {x}{x}\nB -> é(1)F{y}\nC -> é[F]\nD -> F+F--F+F\nE -> {long}\n",
            x = '\u{10000}',
            y = '\u{10FFFF}',
        ))
        .unwrap();
        let al = &s.alphabet;
        let run = |i: usize| match &s.productions.prods[i].succ[0] {
            Item::Const(c) => c.clone(),
            other => panic!("{other:?}"),
        };
        let bin = |mods: &[(char, &[f64])]| {
            let mut b = Vec::new();
            for &(c, vals) in mods {
                let k = (0..al.len() as u32)
                    .find(|&k| al.symbol(k) == c && al.arity(k) == vals.len())
                    .unwrap();
                codec::put_key(&mut b, k);
                codec::put_params(&mut b, vals);
            }
            b
        };
        let x = '\u{10000}';
        let y = '\u{10FFFF}';
        let cases: [(usize, String, Vec<u8>, bool); 5] = [
            (0, format!("{x}{x}"), bin(&[(x, &[]), (x, &[])]), true),
            (
                1,
                format!("é(1)F{y}"),
                bin(&[('é', &[1.0]), ('F', &[]), (y, &[])]),
                true,
            ),
            (
                2,
                "é[F]".to_string(),
                bin(&[('é', &[]), ('[', &[]), ('F', &[]), (']', &[])]),
                false,
            ),
            (3, "F+F--F+F".to_string(), b"F+F--F+F".to_vec(), false),
            (4, long.clone(), bin(&[('é', &[][..]); 180]), false),
        ];
        for (i, text, b, short) in cases {
            let c = run(i);
            assert_eq!(c.is_short(), short, "{text}");
            assert!(c.inline().is_none());
            let modules = text
                .chars()
                .filter(|&c| c != '(' && c != ')' && c != '1')
                .count();
            for c in [c.clone(), c] {
                assert_eq!(c.text(), text.as_bytes(), "{text}");
                assert_eq!(c.modules(), modules as u64, "{text}");
                assert_eq!(c.bin(), &b[..], "{text}");
                if i != 2 {
                    assert_eq!(c.ibin(), &b[..], "{text}");
                }
                assert_eq!(c.has_brackets(), i == 2);
                assert_eq!(c.brackets().count(), if i == 2 { 2 } else { 0 });
            }
        }
    }

    /// A table may hold millions of productions and keys (issue 9 item
    /// 6): 152 and 64 bytes before the cpfg parts were boxed, offsets
    /// narrowed and keys' lists made exact boxes.
    #[test]
    fn compiled_parts_stay_small() {
        assert_eq!(std::mem::size_of::<Production>(), 64);
        assert_eq!(std::mem::size_of::<Code>(), 24);
        assert_eq!(std::mem::size_of::<KeyRules>(), 24);
        assert_eq!(std::mem::size_of::<Option<KeyRules>>(), 24);
        assert_eq!(std::mem::size_of::<Item>(), 16);
        assert_eq!(std::mem::size_of::<Succ>(), 16);
    }

    #[test]
    fn lookup_by_key_and_kinds() {
        let s = sys("productions:\nA < B -> C\nB -> D\nB -> E : 2\n").unwrap();
        let kr = s.productions.get(b'B' as u32).unwrap();
        assert_eq!(s.productions.context(kr), [0]);
        assert_eq!(s.productions.free(kr), [1, 2]);
        assert!(kr.free_stochastic() && !kr.context_stochastic());
        assert!(s.productions.get(b'A' as u32).is_none());
        assert_eq!(s.productions.max_left, 1);
    }

    #[test]
    fn compile_errors() {
        let e = sys("productions:\nA(x) -> B(y)\n").err().unwrap();
        assert_eq!(e.message(), "unknown identifier `y`");
        let e = sys("define: a = 1\ndefine: a = 2\n").err().unwrap();
        assert!(e.message().contains("defined twice"));
        let e = sys("ignore: +\nconsider: F\n").err().unwrap();
        assert!(e.message().contains("cannot both"));
        let e = sys("productions:\nA -> B : -1\n").err().unwrap();
        assert!(e.message().contains("negative"));
        let e = sys("productions:\nA(x) : z > 1 -> B\n").err().unwrap();
        assert!(e.message().contains("unknown identifier `z`"));
        let e = sys("productions:\nA(1) -> B\n").err().unwrap();
        assert!(e.message().contains("formal parameter"));
        let e = sys("productions:\nA(x) < B(x) -> B\n").err().unwrap();
        assert!(e.message().contains("bound twice"));
        let e = sys("derivation length: 2.5\n").err().unwrap();
        assert!(e.message().contains("whole number"));
    }

    #[test]
    fn unbalanced_successor_is_flagged() {
        let s = sys("productions:\nA -> ]B[\n").unwrap();
        assert!(s.productions.check_balance);
        assert_eq!(s.productions.prods[0].depth_min, -1);
    }

    /// Compiled as read, in file order, a header still reports the error
    /// the whole-tree compiler did: a syntax error anywhere first, then by
    /// stage (settings, group 0, numbered groups, ...), each stage's first.
    #[test]
    fn streaming_keeps_the_error_order() {
        let first = |src: &str| match compile_text(src, Seeds::default()) {
            Ok(_) => "ok".to_string(),
            Err(LoadError::Parse(e)) => format!("parse {}: {}", e.span.0, e.message()),
            Err(LoadError::Compile(e)) => format!("compile {}: {}", e.span.0, e.message()),
        };
        // Group 0 is checked before group 1, wherever it stands.
        let src = "groups: 1\nproductions 1:\nA -> B(y)\nproductions:\nC -> D(z)\n";
        assert_eq!(first(src), "compile 55: unknown identifier `z`");
        // A `groups:` entry naming no section comes before a later setting's
        // error, though it is known only at the end.
        let src = "groups: 5\ndefine: a = 1/0\nproductions:\nF -> G\n";
        assert_eq!(
            first(src),
            "compile 8: unknown group 5: there is no `productions 5:` section"
        );
        let src = "define: a = 1/0\ngroups: 5\n";
        assert_eq!(first(src), "compile 12: division by zero");
        // A syntax error after a compile error wins.
        let src = "productions:\nA -> B(q)\nC C\n";
        assert_eq!(
            first(src),
            "parse 26: unexpected end of line, expected `->`"
        );
        // A group declared twice, after the parse, before compile errors.
        let src = "productions 1:\nA -> B(q)\nproductions 1:\nC -> D\n";
        assert_eq!(first(src), "parse 25: group 1 is declared twice");
        // A numbered group's error before "never used"; that before the
        // decomposition's.
        let src = "productions 2:\nA -> B(q)\nproductions:\nF -> G\n";
        assert_eq!(first(src), "compile 22: unknown identifier `q`");
        let src = "productions 2:\nA -> B\nproductions:\nF -> G\ndecomposition:\nG -> H(q)\n";
        assert_eq!(
            first(src),
            "compile 0: group 2 is never used: add a `groups:` or `group:` setting"
        );
        // Within a section: its settings, its productions, then balance.
        let src = "productions:\nF -> G\ndecomposition:\nseed: 3\nG -> H(q)\n";
        assert_eq!(
            first(src),
            "compile 35: decomposition uses the main random generator: no `seed:` here"
        );
        let src = "productions:\nF -> G\ndecomposition:\nG -> [H\nH -> I(q)\n";
        assert_eq!(first(src), "compile 50: unknown identifier `q`");
        let src = "productions:\nF -> G\ndecomposition:\nG -> [H\n";
        assert_eq!(
            first(src),
            "compile 35: a decomposition successor must balance its brackets"
        );
        // `step` hidden: warned in stage order (group 0 before group 1).
        let src = "groups: 1 0\nproductions 1:\nA(step) -> B\nproductions:\nC(step) -> D\n";
        let s = compile_text(src, Seeds::default()).unwrap();
        assert_eq!(s.step_hidden, vec![(55, 59), (29, 33)]);
    }
}
