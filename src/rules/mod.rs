//! From syntax tree to compiled rules: the alphabet of module keys, the
//! productions with their expressions compiled and their successors turned
//! into byte templates, and a table that finds a module's productions by key
//! in O(1).

use crate::derive::random::Random;
use crate::diag::CompileError;
use crate::lang::ast::{self, Expr, Setting};
use crate::lang::lexer::Span;
use crate::lang::parse::UserError;
use crate::lang::sink::{HeaderSink, SectionKind, SectionStart};
use codec::MAX_ARITY;
use expr::{Code, Scope, CPFG_F32};
use std::collections::{HashMap, HashSet};

pub mod codec;
pub mod expr;

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
    text: Vec<Box<[u8]>>,
    ignored: Vec<bool>,
    map: HashMap<(char, u16), u32>,
    filter: Filter,
}

impl Alphabet {
    pub fn new(filter: Filter) -> Alphabet {
        let mut a = Alphabet {
            sym: Vec::new(),
            arity: Vec::new(),
            text: Vec::new(),
            ignored: Vec::new(),
            map: HashMap::new(),
            filter,
        };
        for b in 0u8..128 {
            let c = b as char;
            a.sym.push(c);
            a.arity.push(0);
            a.text.push(vec![b].into_boxed_slice());
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
        if let Some(&k) = self.map.get(&(sym, arity)) {
            return Ok(k);
        }
        let k = self.sym.len() as u32;
        self.sym.push(sym);
        self.arity.push(arity);
        let mut t = [0u8; 4];
        self.text.push(
            sym.encode_utf8(&mut t)
                .as_bytes()
                .to_vec()
                .into_boxed_slice(),
        );
        self.ignored.push(self.filter.ignores(sym));
        self.map.insert((sym, arity), k);
        Ok(k)
    }

    #[inline]
    pub fn arity(&self, key: u32) -> usize {
        self.arity[key as usize] as usize
    }
    #[inline]
    pub fn text(&self, key: u32) -> &[u8] {
        &self.text[key as usize]
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
/// allocation (a production table may hold millions of these).
#[derive(Clone, Debug)]
pub struct ConstRun {
    /// A 16-byte header (little-endian u32s: the module count, then where
    /// the binary, the indexed binary and the text end), the binary format,
    /// the binary with bracket index, the text, and for each bracket its
    /// offset in the indexed binary (4 bytes), 1 if `[`, and how many of
    /// the run's modules come before it (4 bytes).
    data: Box<[u8]>,
}

impl Default for ConstRun {
    fn default() -> ConstRun {
        ConstRun::new(&[], &[], &[], &[], 0)
    }
}

const HEADER: usize = 16;
/// The bytes of one bracket entry.
const BRACKET: usize = 9;

impl ConstRun {
    fn new(
        bin: &[u8],
        ibin: &[u8],
        text: &[u8],
        brackets: &[(u32, bool, u32)],
        modules: u32,
    ) -> Self {
        let mut data = Vec::with_capacity(
            HEADER + bin.len() + ibin.len() + text.len() + BRACKET * brackets.len(),
        );
        let bin_end = HEADER + bin.len();
        let ibin_end = bin_end + ibin.len();
        let text_end = ibin_end + text.len();
        for v in [modules as usize, bin_end, ibin_end, text_end] {
            data.extend_from_slice(&(v as u32).to_le_bytes());
        }
        data.extend_from_slice(bin);
        data.extend_from_slice(ibin);
        data.extend_from_slice(text);
        for &(at, open, before) in brackets {
            data.extend_from_slice(&at.to_le_bytes());
            data.push(u8::from(open));
            data.extend_from_slice(&before.to_le_bytes());
        }
        ConstRun { data: data.into() }
    }

    /// The header's `i`th number.
    #[inline(always)]
    fn at(&self, i: usize) -> usize {
        let b: [u8; 4] = self.data[4 * i..4 * i + 4].try_into().unwrap();
        u32::from_le_bytes(b) as usize
    }

    /// Binary format.
    #[inline(always)]
    pub fn bin(&self) -> &[u8] {
        &self.data[HEADER..self.at(1)]
    }
    /// Binary with bracket index: each `[` followed by
    /// [`codec::INDEX_BYTES`] that will hold the offset just past its `]`
    /// and the module count of its branch.
    #[inline(always)]
    pub fn ibin(&self) -> &[u8] {
        &self.data[self.at(1)..self.at(2)]
    }
    #[inline(always)]
    pub fn text(&self) -> &[u8] {
        &self.data[self.at(2)..self.at(3)]
    }
    /// How many modules.
    #[inline(always)]
    pub fn modules(&self) -> u64 {
        self.at(0) as u64
    }
    /// Offsets of the brackets in [`ibin`](Self::ibin) (true: `[`), and
    /// how many of the run's modules come before each.
    pub fn brackets(&self) -> impl Iterator<Item = (u32, bool, u64)> + '_ {
        self.data[self.at(3)..].chunks_exact(BRACKET).map(|b| {
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
        self.data.len() > self.at(3)
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
        num.module(&mut self.text, al.text(key), vals);
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
    Module { key: u32, params: Box<[Code]> },
}

/// A successor's items: a slice ([`Deref`](std::ops::Deref)). Most
/// successors are one item, kept in place (no block of their own).
#[derive(Clone, Debug)]
pub enum Succ {
    One(Item),
    Many(Box<[Item]>),
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
                Succ::Many(exact(v))
            }
            None => Succ::Many(Box::default()),
        }
    }
}

impl From<Box<[Item]>> for Succ {
    fn from(b: Box<[Item]>) -> Succ {
        Succ::from(b.into_vec())
    }
}

/// A compiled production. Kept small (boxed slices, boxed expressions, a
/// one-item successor in place, u32 offsets and depths, the cpfg-only
/// parts behind one optional box): a table may hold millions.
#[derive(Clone, Debug)]
pub struct Production {
    pub key: u32,
    /// The right context has no brackets: it is matched against the cached
    /// list of the next considered modules.
    pub right_simple: bool,
    /// Slots: predecessor parameters, then left context, then right context.
    pub nslots: usize,
    pub left: Box<[Pat]>,
    pub right: Box<[RPat]>,
    pub cond: Option<Box<Code>>,
    pub prob: Option<Box<Code>>,
    pub succ: Succ,
    /// Where the production starts and ends in the header, for runtime
    /// errors ([`span`](Self::span); headers are far below 4 GiB).
    span: (u32, u32),
    /// Bracket depth change of the successor, and its lowest prefix.
    pub depth_delta: i32,
    pub depth_min: i32,
    /// What only the cpfg dialect has (None in `.ls`).
    pub cpfg: Option<Box<CpfgParts>>,
}

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
    pub fn has_context(&self) -> bool {
        !self.left.is_empty() || !self.right.is_empty() || !self.rest().is_empty()
    }
    /// Where the production is in the header.
    #[inline]
    pub fn span(&self) -> Span {
        (self.span.0 as usize, self.span.1 as usize)
    }
    /// cpfg: the predecessor's modules after the first.
    #[inline]
    pub fn rest(&self) -> &[Pat] {
        self.cpfg.as_ref().map_or(&[], |c| &c.rest)
    }
    /// cpfg's pre-condition block.
    #[inline]
    pub fn pre(&self) -> Option<&crate::cpfg::blocks::Block> {
        self.cpfg.as_ref().and_then(|c| c.pre.as_ref())
    }
    /// cpfg's post-condition block.
    #[inline]
    pub fn post(&self) -> Option<&crate::cpfg::blocks::Block> {
        self.cpfg.as_ref().and_then(|c| c.post.as_ref())
    }
    /// The cpfg-only parts, made on first use.
    pub fn cpfg_mut(&mut self) -> &mut CpfgParts {
        self.cpfg.get_or_insert_with(Box::default)
    }
}

/// The productions of one key, in file order, split by kind (numbers in
/// the table's `prods`): lists of their exact size, made once the table is
/// complete ([`Table::index`]), no spare capacity (a header may name
/// millions of symbols).
#[derive(Clone, Debug, Default)]
pub struct KeyRules {
    /// Context-sensitive productions: a match beats every context-free one.
    context: Box<[u32]>,
    free: Box<[u32]>,
    pub context_stochastic: bool,
    pub free_stochastic: bool,
    /// Group 0's productions of the key, tried when a numbered group's
    /// choose nothing (issue 11, lpfg's rule).
    pub fallback: Option<Box<KeyRules>>,
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
            || kr.free_stochastic
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
        self.max_left = self.max_left.max(p.left.len());
        self.has_right |= !p.right.is_empty();
        self.has_multi |= !p.rest().is_empty();
        if p.right_simple {
            self.max_right_simple = self.max_right_simple.max(p.right.len());
        }
        self.check_balance |= p.depth_delta != 0 || p.depth_min < 0;
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
    /// context-free apart.
    fn index(&mut self, own: usize) {
        let keys = self.prods[..own]
            .iter()
            .map(|p| p.key as usize + 1)
            .max()
            .unwrap_or(0);
        let mut counts = vec![[0usize; 2]; keys];
        for p in &self.prods[..own] {
            counts[p.key as usize][usize::from(!p.has_context())] += 1;
        }
        // A key's context-sensitive and context-free lists, and whether
        // each has a probability.
        type Lists = (Vec<u32>, Vec<u32>, bool, bool);
        let mut lists: Vec<Option<Lists>> = counts
            .iter()
            .map(|&[c, f]| {
                (c + f > 0).then(|| (Vec::with_capacity(c), Vec::with_capacity(f), false, false))
            })
            .collect();
        drop(counts);
        for (i, p) in self.prods[..own].iter().enumerate() {
            if let Some((c, f, cs, fs)) = &mut lists[p.key as usize] {
                if p.has_context() {
                    c.push(i as u32);
                    *cs |= p.prob.is_some();
                } else {
                    f.push(i as u32);
                    *fs |= p.prob.is_some();
                }
            }
        }
        self.by_key = lists
            .into_iter()
            .map(|l| {
                l.map(|(c, f, cs, fs)| KeyRules {
                    context: c.into_boxed_slice(),
                    free: f.into_boxed_slice(),
                    context_stochastic: cs,
                    free_stochastic: fs,
                    fallback: None,
                })
            })
            .collect();
    }

    #[inline]
    pub fn get(&self, key: u32) -> Option<&KeyRules> {
        self.by_key.get(key as usize).and_then(Option::as_ref)
    }
    /// `kr`'s context-sensitive productions (numbers in `prods`), in file
    /// order.
    #[inline]
    pub fn context<'a>(&'a self, kr: &'a KeyRules) -> &'a [u32] {
        &kr.context
    }
    /// `kr`'s context-free productions, in file order.
    #[inline]
    pub fn free<'a>(&'a self, kr: &'a KeyRules) -> &'a [u32] {
        &kr.free
    }
    pub fn is_empty(&self) -> bool {
        self.prods.is_empty()
    }
    pub fn has_context(&self) -> bool {
        self.max_left > 0 || self.has_right || self.has_multi
    }

    /// cpfg's right contexts (issue 12): every one goes through cpfg's
    /// matcher (no cached bracket-free shortcut), and a `=` module in a
    /// right context is cpfg's "skip the rest of the branch".
    pub fn for_cpfg(&mut self, al: &Alphabet) {
        for p in &mut self.prods {
            p.right_simple = false;
            for r in p.right.iter_mut() {
                if let RPat::Module(m) = r {
                    if m.key == u32::from(b'=') && al.arity(m.key) == 0 {
                        *r = RPat::SkipRest;
                    }
                }
            }
        }
        self.max_right_simple = 0;
    }

    /// cpfg's choice: the first applicable production in file order,
    /// context-sensitive or not. One list per key, in file order, tried
    /// by the one chooser as it tries a context group.
    fn cpfg_order(&mut self) {
        for kr in self.by_key.iter_mut().flatten() {
            if kr.has_context() && kr.has_free() {
                let mut all: Vec<u32> = kr.context.iter().chain(&*kr.free).copied().collect();
                all.sort_unstable();
                kr.context = all.into_boxed_slice();
                kr.free = Box::default();
                kr.context_stochastic |= std::mem::take(&mut kr.free_stochastic);
            }
        }
    }

    /// A numbered group's table with group 0 (`base`) as its fallback:
    /// group 0's productions come after the group's own, and a key with
    /// productions in both tries the group's first.
    fn with_fallback(mut self, base: &Table) -> Table {
        let by = self.prods.len() as u32;
        self.prods.extend(base.prods.iter().cloned());
        if self.by_key.len() < base.by_key.len() {
            self.by_key.resize(base.by_key.len(), None);
        }
        for (key, b) in base.by_key.iter().enumerate() {
            let Some(b) = b else { continue };
            let b = KeyRules {
                context: b.context.iter().map(|i| i + by).collect(),
                free: b.free.iter().map(|i| i + by).collect(),
                ..b.clone()
            };
            match &mut self.by_key[key] {
                Some(kr) => kr.fallback = Some(Box::new(b)),
                none => *none = Some(b),
            }
        }
        self.max_left = self.max_left.max(base.max_left);
        self.has_right |= base.has_right;
        self.has_multi |= base.has_multi;
        self.max_right_simple = self.max_right_simple.max(base.max_right_simple);
        self.check_balance |= base.check_balance;
        self
    }
}

pub struct System {
    pub alphabet: Alphabet,
    pub productions: Table,
    pub homomorphism: Table,
    pub derivation_length: Option<u64>,
    pub seed: Option<u64>,
    pub consts: HashMap<String, f64>,
    /// Issue 11: numbered production groups, each with group 0 as its
    /// fallback, and the schedule (group numbers, cycling; empty: every
    /// step uses group 0).
    pub groups: Vec<(u32, Table)>,
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

/// Formal parameters named `step` (issue 11) in a production.
fn hidden_step(p: &ast::Production, out: &mut Vec<Span>) {
    for m in p.left.iter().chain([&p.pred]).chain(p.right.iter()) {
        for e in &m.params {
            if let Expr::Var(name, span) = e {
                if name == "step" {
                    out.push(*span);
                }
            }
        }
    }
}

type R<T> = Result<T, UserError>;

fn err<T>(span: Span, kind: CompileError) -> R<T> {
    Err(UserError::new(span, kind))
}

fn compile_code(e: &Expr, params: &HashMap<String, u32>, consts: &HashMap<String, f64>) -> R<Code> {
    compile_code_in(e, params, consts, false)
}

fn compile_code_in(
    e: &Expr,
    params: &HashMap<String, u32>,
    consts: &HashMap<String, f64>,
    cpfg: bool,
) -> R<Code> {
    Code::compile(
        e,
        &Scope {
            params,
            consts,
            cpfg,
        },
    )
    .map_err(|e| UserError::new(e.span, e.kind))
}

/// Evaluate a setting's expression: constants only.
fn constant(e: &Expr, consts: &HashMap<String, f64>, rng: &mut Random) -> R<f64> {
    let code = compile_code(e, &HashMap::new(), consts)?;
    code.eval(&[], &mut Vec::new(), rng)
        .map_err(|e| UserError::new(e.span, e.kind))
}

fn whole_number(e: &Expr, consts: &HashMap<String, f64>, what: &'static str) -> R<u64> {
    let v = constant(e, consts, &mut Random::new(0))?;
    if v < 0.0 || v.fract() != 0.0 || v > 9.007_199_254_740_992e15 {
        return err(e.span(), CompileError::NotWholeNumber { what, value: v });
    }
    Ok(v as u64)
}

fn symbols(mods: &[ast::Module]) -> R<HashSet<char>> {
    let mut s = HashSet::new();
    for m in mods {
        if !m.params.is_empty() {
            return err(m.span, CompileError::SymbolsOnly);
        }
        s.insert(m.sym);
    }
    Ok(s)
}

/// 2^53: from there on, a computed whole number may have been rounded
/// (2^53 + 1 evaluates to 2^53).
const EXACT_LIMIT: f64 = 9_007_199_254_740_992.0;

/// `seed:`: a whole-number literal is read exactly (0 to 2^64 - 1, from the
/// source `src` when given); any other expression must give a whole number
/// below 2^53, where floating point is exact.
fn seed_value(e: &Expr, consts: &HashMap<String, f64>, src: Option<&str>) -> R<u64> {
    if let (Expr::Num(_, (a, b)), Some(src)) = (e, src) {
        if let Some(text) = src.get(*a..*b) {
            if !text.is_empty() && text.bytes().all(|c| c.is_ascii_digit()) {
                return text
                    .parse::<u64>()
                    .or_else(|_| err(e.span(), CompileError::SeedLiteralRange(text.to_string())));
            }
        }
    }
    let v = constant(e, consts, &mut Random::new(0))?;
    if v < 0.0 || v.fract() != 0.0 || v >= EXACT_LIMIT {
        return err(e.span(), CompileError::SeedComputedRange(v));
    }
    Ok(v as u64)
}

/// Does `e` draw random numbers, itself or through a random constant?
fn is_random(e: &Expr, random: &HashSet<String>) -> bool {
    match e {
        Expr::Num(..) => false,
        Expr::Var(name, _) => random.contains(name),
        Expr::Call(name, args, _) => {
            name == "ran" || name == "nran" || args.iter().any(|a| is_random(a, random))
        }
        Expr::Unary(_, a, _) => is_random(a, random),
        Expr::Binary(_, a, b, _) => is_random(a, random) || is_random(b, random),
        Expr::Cond(c, a, b, _) => [c, a, b].iter().any(|e| is_random(e, random)),
    }
}

/// The file's seed, read ahead of the constants (random constants are
/// drawn with the run's seed, wherever `seed:` stands). None if there is
/// none or it cannot be read: then the settings report the error in order.
fn file_seed(settings: &[Setting], src: Option<&str>) -> Option<R<u64>> {
    let mut consts = HashMap::new();
    let mut random = HashSet::new();
    for s in settings {
        match s {
            Setting::Define(name, e, _) if is_random(e, &random) => {
                random.insert(name.clone());
            }
            Setting::Define(name, e, _) => {
                let v = constant(e, &consts, &mut Random::new(0)).ok()?;
                consts.insert(name.clone(), v);
            }
            Setting::Seed(e, _) if is_random(e, &random) => {
                return Some(err(e.span(), CompileError::SeedRandom));
            }
            Setting::Seed(e, _) => return Some(seed_value(e, &consts, src)),
            _ => {}
        }
    }
    None
}

/// The seeds a run can have.
#[derive(Clone, Copy, Debug, Default)]
pub struct Seeds {
    /// `--seed`, which wins over the file's `seed:`.
    pub command_line: Option<u64>,
    /// The seed without either (fresh from the system).
    pub fallback: u64,
}

/// Compile a parsed header (no source text: a large `seed:` literal is
/// read as a number; no `--seed`; fallback seed 0).
pub fn compile(h: &ast::Header) -> R<System> {
    compile_with(h.clone(), None, Seeds::default())
}

/// Compile a parsed header whose text is `src`: hands the tree to a
/// [`Compiler`] as the parser would, production by production.
pub fn compile_with(h: ast::Header, src: Option<&str>, seeds: Seeds) -> R<System> {
    compile_dialect(h, src, seeds, false)
}

/// [`compile_with`] for a dialect: `cpfg` (a header lowered from a `.l`
/// file, see `src/cpfg/lower.rs`) takes cpfg's functions, `/` and `%`,
/// rounds every computed parameter to a 32-bit float, and chooses the
/// first applicable production in file order, context or not.
pub fn compile_dialect(h: ast::Header, src: Option<&str>, seeds: Seeds, cpfg: bool) -> R<System> {
    let mut c = Compiler::new(src, seeds);
    c.cpfg = cpfg;
    c.settings(h.settings);
    c.section(SectionStart {
        kind: SectionKind::Group(0),
        span: (0, 0),
        warnings: false,
        settings: Vec::new(),
    });
    for p in h.productions {
        c.production(p);
    }
    for (n, span, prods) in h.groups {
        c.section(SectionStart {
            kind: SectionKind::Group(n),
            span,
            warnings: false,
            settings: Vec::new(),
        });
        for p in prods {
            c.production(p);
        }
    }
    if let Some(d) = h.decomposition {
        c.section(SectionStart {
            kind: SectionKind::Decomposition,
            span: d.span,
            warnings: d.warnings,
            settings: d.settings,
        });
        for p in d.productions {
            c.production(p);
        }
    }
    if let Some(s) = h.hom {
        c.section(SectionStart {
            kind: SectionKind::Homomorphism,
            span: s.span,
            warnings: s.warnings,
            settings: s.settings,
        });
    }
    if !h.homomorphism.is_empty() && !c.in_section(SectionKind::Homomorphism) {
        c.section(SectionStart {
            kind: SectionKind::Homomorphism,
            span: (0, 0),
            warnings: false,
            settings: Vec::new(),
        });
    }
    for p in h.homomorphism {
        c.production(p);
    }
    c.finish()
}

/// A header's parse error, or its compile error (found only if it parses).
#[derive(Clone, Debug, PartialEq)]
pub enum LoadError {
    Parse(UserError),
    Compile(UserError),
}

/// Parse and compile the header text `src`, each production as it is
/// read: the whole syntax tree never exists. Errors as [`parse_header`]
/// then [`compile_with`] would report them. Random constants (`ran` and
/// `nran` in `define:`) are drawn in file order from a generator of their
/// own seeded with the run's seed: `--seed`, else `seed:`, else the
/// fallback.
///
/// [`parse_header`]: crate::lang::parse::parse_header
pub fn compile_text(src: &str, seeds: Seeds) -> Result<System, LoadError> {
    let mut c = Compiler::new(Some(src), seeds);
    crate::lang::parse::parse_into(src, &mut c).map_err(LoadError::Parse)?;
    c.finish().map_err(LoadError::Compile)
}

/// Where a compile error was found, in the order the checks are made: the
/// first error of the lowest stage is the one reported. Sections are
/// compiled in file order as they arrive, but group 0 is checked before
/// the numbered groups wherever it stands.
mod stage {
    pub const SETTINGS: u8 = 0;
    pub const GROUP0: u8 = 1;
    pub const GROUPS: u8 = 2;
    pub const UNUSED: u8 = 3;
    pub const DECOMPOSITION: u8 = 4;
    pub const HOMOMORPHISM: u8 = 5;
}

/// What the settings give the productions.
struct Settled {
    derivation_length: Option<u64>,
    seed: Option<u64>,
    consts: HashMap<String, f64>,
    schedule: Vec<u32>,
    scheduled: bool,
    group_expr: Option<Code>,
    alphabet: Alphabet,
}

/// Compiles a header handed over by the parser ([`HeaderSink`]): the
/// settings, then each production into its section's table as soon as it
/// is read. After an error it keeps reading (the parser may still find a
/// syntax error, which comes first) but compiles only what could still
/// hold an earlier error.
pub struct Compiler<'a> {
    src: Option<&'a str>,
    /// The cpfg dialect ([`compile_dialect`]).
    cpfg: bool,
    seeds: Seeds,
    settled: Option<Settled>,
    /// The first error of the lowest stage so far.
    error: Option<(u8, UserError)>,
    /// `groups:` entries to check once every section is known: (group, where).
    scheduled_groups: Vec<(u32, Span)>,
    /// `step` hidden by a constant or a formal parameter, with its stage
    /// (warned in the stages' order).
    step_hidden: Vec<(u8, Span)>,
    num: codec::NumFmt,
    section: SectionKind,
    productions: Table,
    groups: Vec<(u32, Span, Table)>,
    decomposition: Option<(Table, usize)>,
    hom: Option<(usize, Option<u64>)>,
    homomorphism: Table,
    warnings: [bool; 2],
}

impl<'a> Compiler<'a> {
    /// `src` is the header text, for reading a large `seed:` literal
    /// exactly.
    pub fn new(src: Option<&'a str>, seeds: Seeds) -> Compiler<'a> {
        Compiler {
            src,
            cpfg: false,
            seeds,
            settled: None,
            error: None,
            scheduled_groups: Vec::new(),
            step_hidden: Vec::new(),
            num: codec::NumFmt::new(),
            section: SectionKind::Group(0),
            productions: Table::default(),
            groups: Vec::new(),
            decomposition: None,
            hom: None,
            homomorphism: Table::default(),
            warnings: [false; 2],
        }
    }

    fn in_section(&self, kind: SectionKind) -> bool {
        self.section == kind
    }

    fn stage(&self) -> u8 {
        match self.section {
            SectionKind::Group(0) => stage::GROUP0,
            SectionKind::Group(_) => stage::GROUPS,
            SectionKind::Decomposition => stage::DECOMPOSITION,
            SectionKind::Homomorphism => stage::HOMOMORPHISM,
        }
    }

    /// Could an error found at `stage` still be the one reported?
    fn open(&self, stage: u8) -> bool {
        self.settled.is_some() && self.error.as_ref().is_none_or(|(s, _)| stage < *s)
    }

    fn fail(&mut self, stage: u8, e: UserError) {
        if self.error.as_ref().is_none_or(|(s, _)| stage < *s) {
            self.error = Some((stage, e));
        }
    }

    fn settle(&mut self, settings: &[Setting]) -> R<Settled> {
        let mut derivation_length = None;
        let mut seed = None;
        let mut filter: Option<(Filter, Span)> = None;
        let mut consts: HashMap<String, f64> = HashMap::new();
        let src = self.src;
        let ahead = file_seed(settings, src);
        let run_seed = self.seeds.command_line.unwrap_or(match &ahead {
            Some(Ok(s)) => *s,
            _ => self.seeds.fallback,
        });
        let mut define_rng = Random::for_constants(run_seed);
        let mut schedule: Vec<u32> = Vec::new();
        let mut schedule_span: Option<Span> = None;
        let mut group_expr: Option<Code> = None;
        for s in settings {
            match s {
                Setting::Groups(list, span) => {
                    if schedule_span.is_some() {
                        return err(*span, CompileError::GroupsAndGroup);
                    }
                    schedule_span = Some(*span);
                    for &(n, at) in list {
                        if n != 0 {
                            // Checked when every section is known.
                            self.scheduled_groups.push((n, at));
                        }
                        schedule.push(n);
                    }
                }
                Setting::Group(e, span) => {
                    if schedule_span.is_some() {
                        return err(*span, CompileError::GroupsAndGroup);
                    }
                    schedule_span = Some(*span);
                    if is_random(e, &HashSet::new()) {
                        return err(e.span(), CompileError::GroupRandom);
                    }
                    let mut names = HashMap::new();
                    if !consts.contains_key("step") {
                        names.insert("step".to_string(), expr::STEP_SLOT);
                    }
                    group_expr = Some(compile_code(e, &names, &consts)?);
                }
                Setting::DerivationLength(e, span) => {
                    if derivation_length.is_some() {
                        return err(*span, CompileError::SetTwice("derivation length"));
                    }
                    derivation_length = Some(whole_number(e, &consts, "the derivation length")?);
                }
                Setting::Seed(e, span) => {
                    if seed.is_some() {
                        return err(*span, CompileError::SetTwice("seed"));
                    }
                    seed = Some(match &ahead {
                        Some(Ok(v)) => *v,
                        Some(Err(e)) => return Err(e.clone()),
                        None => seed_value(e, &consts, src)?,
                    });
                }
                Setting::Define(name, e, span) => {
                    if consts.contains_key(name) {
                        return err(*span, CompileError::DefinedTwice(name.clone()));
                    }
                    let v = constant(e, &consts, &mut define_rng)?;
                    consts.insert(name.clone(), v);
                }
                Setting::Ignore(m, span) | Setting::Consider(m, span) => {
                    let set = symbols(m)?;
                    let f = if matches!(s, Setting::Ignore(..)) {
                        Filter::Ignore(set)
                    } else {
                        Filter::Consider(set)
                    };
                    match (&mut filter, f) {
                        (None, f) => filter = Some((f, *span)),
                        (Some((Filter::Ignore(a), _)), Filter::Ignore(b))
                        | (Some((Filter::Consider(a), _)), Filter::Consider(b)) => a.extend(b),
                        (Some(_), _) => return err(*span, CompileError::IgnoreAndConsider),
                    }
                }
            }
        }
        Ok(Settled {
            derivation_length,
            seed,
            consts,
            schedule,
            scheduled: schedule_span.is_some(),
            group_expr,
            alphabet: Alphabet::new(filter.map(|f| f.0).unwrap_or_default()),
        })
    }

    /// The compiled system, or the first error of the earliest stage.
    pub fn finish(mut self) -> R<System> {
        // A `groups:` entry naming no section is an error of the settings,
        // before any later setting's.
        let declared: Vec<u32> = self.groups.iter().map(|g| g.0).collect();
        if let Some(&(n, at)) = self
            .scheduled_groups
            .iter()
            .find(|(n, _)| !declared.contains(n))
        {
            return err(at, CompileError::UnknownGroup(n));
        }
        if let Some(st) = &self.settled {
            if let (Some((n, span, _)), false) = (self.groups.first(), st.scheduled) {
                let e = UserError::new(*span, CompileError::GroupUnused(*n));
                self.fail(stage::UNUSED, e);
            }
        }
        if let Some((t, _)) = &self.decomposition {
            if let Err(e) = balanced(t, CompileError::DecompositionUnbalanced) {
                self.fail(stage::DECOMPOSITION, e);
            }
        }
        let (hom_depth, hom_seed) = self.hom.unwrap_or((1, None));
        if hom_depth > 1 {
            if let Err(e) = balanced(&self.homomorphism, CompileError::HomomorphismUnbalanced) {
                self.fail(stage::HOMOMORPHISM, e);
            }
        }
        if let Some((_, e)) = self.error {
            return Err(e);
        }
        let st = self.settled.expect("settings come first");
        let cpfg = self.cpfg;
        let done = |t: &mut Table| {
            t.shrink();
            if cpfg {
                t.cpfg_order();
            }
        };
        let mut productions = self.productions;
        done(&mut productions);
        let groups = self
            .groups
            .into_iter()
            .map(|(n, _, mut t)| {
                done(&mut t);
                (n, t.with_fallback(&productions))
            })
            .collect();
        let decomposition = self.decomposition.map(|(mut t, depth)| {
            done(&mut t);
            (t, depth)
        });
        let mut homomorphism = self.homomorphism;
        done(&mut homomorphism);
        let mut step_hidden = self.step_hidden;
        step_hidden.sort_by_key(|h| h.0);
        Ok(System {
            alphabet: st.alphabet,
            productions,
            homomorphism,
            derivation_length: st.derivation_length,
            seed: st.seed,
            consts: st.consts,
            groups,
            schedule: st.schedule,
            group_expr: st.group_expr,
            decomposition,
            hom_depth,
            hom_seed,
            warnings: self.warnings,
            step_hidden: step_hidden.into_iter().map(|h| h.1).collect(),
            cpfg: cpfg.then(|| Box::new(crate::cpfg::run::CpfgRun::default())),
            source_map: None,
        })
    }
}

impl HeaderSink for Compiler<'_> {
    fn settings(&mut self, settings: Vec<Setting>) {
        for s in &settings {
            if let Setting::Define(name, _, span) = s {
                if name == "step" {
                    self.step_hidden.push((stage::SETTINGS, *span));
                }
            }
        }
        match self.settle(&settings) {
            Ok(st) => self.settled = Some(st),
            Err(e) => self.fail(stage::SETTINGS, e),
        }
    }

    fn section(&mut self, start: SectionStart) {
        self.section = start.kind;
        let stage = self.stage();
        match start.kind {
            SectionKind::Group(0) => {}
            SectionKind::Group(n) => self.groups.push((n, start.span, Table::default())),
            SectionKind::Decomposition => {
                self.warnings[0] = start.warnings;
                self.decomposition = Some((Table::default(), 1));
                if !self.open(stage) {
                    return;
                }
                let consts = &self.settled.as_ref().unwrap().consts;
                match section_settings(&start.settings, consts) {
                    Ok((depth, None)) => self.decomposition = Some((Table::default(), depth)),
                    Ok((_, Some(span))) => {
                        self.fail(stage, UserError::new(span, CompileError::DecompositionSeed))
                    }
                    Err(e) => self.fail(stage, e),
                }
            }
            SectionKind::Homomorphism => {
                self.warnings[1] = start.warnings;
                if !self.open(stage) {
                    return;
                }
                let consts = &self.settled.as_ref().unwrap().consts;
                let hom = section_settings(&start.settings, consts).and_then(|(depth, _)| {
                    let seed = start
                        .settings
                        .iter()
                        .find_map(|x| match x {
                            ast::SectionSetting::Seed(e, _) => Some(e),
                            _ => None,
                        })
                        .map(|e| seed_value(e, consts, self.src))
                        .transpose()?;
                    Ok((depth, seed))
                });
                match hom {
                    Ok(h) => self.hom = Some(h),
                    Err(e) => self.fail(stage, e),
                }
            }
        }
    }

    fn production(&mut self, p: ast::Production) {
        let stage = self.stage();
        if !self.open(stage) {
            return;
        }
        hidden_step_at(&p, stage, &mut self.step_hidden);
        let st = self.settled.as_mut().unwrap();
        let table = match self.section {
            SectionKind::Group(0) => &mut self.productions,
            SectionKind::Group(_) => &mut self.groups.last_mut().unwrap().2,
            SectionKind::Decomposition => &mut self.decomposition.as_mut().unwrap().0,
            SectionKind::Homomorphism => &mut self.homomorphism,
        };
        match compile_production(&p, &mut st.alphabet, &st.consts, &mut self.num, self.cpfg) {
            Ok(cp) => table.push(cp),
            Err(e) => self.fail(stage, e),
        }
    }
}

fn hidden_step_at(p: &ast::Production, stage: u8, out: &mut Vec<(u8, Span)>) {
    let mut spans = Vec::new();
    hidden_step(p, &mut spans);
    out.extend(spans.into_iter().map(|s| (stage, s)));
}

/// Recursive rewriting does not track brackets: every successor of `t`
/// must balance (each `]` after its `[`).
fn balanced(t: &Table, kind: CompileError) -> R<()> {
    match t
        .prods
        .iter()
        .find(|p| p.depth_delta != 0 || p.depth_min < 0)
    {
        Some(p) => err(p.span(), kind),
        None => Ok(()),
    }
}

/// A decomposition or homomorphism section's `maximum depth:` (default 1)
/// and where its `seed:` is, if any.
fn section_settings(
    settings: &[ast::SectionSetting],
    consts: &HashMap<String, f64>,
) -> R<(usize, Option<Span>)> {
    let mut depth = None;
    let mut seed = None;
    for x in settings {
        match x {
            ast::SectionSetting::MaximumDepth(e, span) => {
                if depth.is_some() {
                    return err(*span, CompileError::MaximumDepthTwice);
                }
                let v = constant(e, consts, &mut Random::new(0))?;
                if !(1.0..=10000.0).contains(&v) || v.fract() != 0.0 {
                    return err(e.span(), CompileError::MaximumDepthRange);
                }
                depth = Some(v as usize);
            }
            ast::SectionSetting::Seed(_, span) => {
                if seed.is_some() {
                    return err(*span, CompileError::SetTwice("seed"));
                }
                seed = Some(*span);
            }
        }
    }
    Ok((depth.unwrap_or(1), seed))
}

fn bind_formals(m: &ast::Module, names: &mut HashMap<String, u32>, nslots: &mut usize) -> R<u32> {
    let first = *nslots as u32;
    for e in &m.params {
        match e {
            Expr::Var(name, span) => {
                if names.insert(name.clone(), *nslots as u32).is_some() {
                    return err(*span, CompileError::BoundTwice(name.clone()));
                }
                *nslots += 1;
            }
            other => return err(other.span(), CompileError::FormalNotName),
        }
    }
    Ok(first)
}

fn compile_production(
    p: &ast::Production,
    alphabet: &mut Alphabet,
    consts: &HashMap<String, f64>,
    num: &mut codec::NumFmt,
    cpfg: bool,
) -> R<Production> {
    let intern = |a: &mut Alphabet, m: &ast::Module| {
        a.intern(m.sym, m.params.len())
            .map_err(|e| UserError::new(m.span, e))
    };
    if matches!(p.pred.sym, '[' | ']') {
        return err(p.pred.span, CompileError::BracketRewritten);
    }
    let mut names = HashMap::new();
    let mut nslots = 0;
    let key = intern(alphabet, &p.pred)?;
    bind_formals(&p.pred, &mut names, &mut nslots)?;
    let mut rest = Vec::new();
    for m in &p.pred_rest {
        if matches!(m.sym, '[' | ']') {
            return err(m.span, CompileError::BracketRewritten);
        }
        let k = intern(alphabet, m)?;
        let slot = bind_formals(m, &mut names, &mut nslots)?;
        rest.push(Pat { key: k, slot });
    }
    let mut left = Vec::new();
    for m in &p.left {
        if matches!(m.sym, '[' | ']') {
            return err(m.span, CompileError::LeftContextBracket);
        }
        let k = intern(alphabet, m)?;
        let slot = bind_formals(m, &mut names, &mut nslots)?;
        left.push(Pat { key: k, slot });
    }
    let mut right = Vec::new();
    for m in &p.right {
        match m.sym {
            '[' | ']' if !m.params.is_empty() => return err(m.span, CompileError::BracketParams),
            '[' => right.push(RPat::Open),
            ']' => right.push(RPat::Close),
            _ => {
                let k = intern(alphabet, m)?;
                let slot = bind_formals(m, &mut names, &mut nslots)?;
                right.push(RPat::Module(Pat { key: k, slot }));
            }
        }
    }
    // The built-in step number, unless a parameter or constant hides it.
    if !consts.contains_key("step") {
        names.entry("step".to_string()).or_insert(expr::STEP_SLOT);
    }
    let cond = p
        .cond
        .as_ref()
        .map(|e| compile_code_in(e, &names, consts, cpfg))
        .transpose()?
        // A condition folded to a non-zero constant always holds.
        .filter(|c| c.constant().is_none_or(|v| v == 0.0))
        .map(Box::new);
    let prob = p
        .prob
        .as_ref()
        .map(|e| compile_code_in(e, &names, consts, cpfg))
        .transpose()?
        .map(Box::new);
    if let Some(w) = prob.as_ref().and_then(|c| c.constant()) {
        if w < 0.0 {
            return err(
                prob.as_ref().unwrap().span,
                CompileError::NegativeProbability(w),
            );
        }
    }
    let (succ, depth_delta, depth_min) =
        compile_successor(&p.succ, alphabet, &names, consts, num, cpfg)?;
    let right_simple = !right.is_empty() && right.iter().all(|r| matches!(r, RPat::Module(_)));
    // (Depths and offsets fit: a header is at most 64 MiB.)
    let narrow = |x: i64| i32::try_from(x).expect("a header under 2 GiB");
    let offset = |x: usize| u32::try_from(x).expect("a header under 4 GiB");
    Ok(Production {
        key,
        nslots,
        left: exact(left),
        right: exact(right),
        right_simple,
        cond,
        prob,
        succ: Succ::from(succ),
        span: (offset(p.span.0), offset(p.span.1)),
        depth_delta: narrow(depth_delta),
        depth_min: narrow(depth_min),
        cpfg: (!rest.is_empty()).then(|| {
            Box::new(CpfgParts {
                rest: exact(rest),
                ..CpfgParts::default()
            })
        }),
    })
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

/// Successor to items: runs of modules whose parameters are all constant
/// become precomputed bytes.
fn compile_successor(
    succ: &[ast::Module],
    alphabet: &mut Alphabet,
    names: &HashMap<String, u32>,
    consts: &HashMap<String, f64>,
    num: &mut codec::NumFmt,
    cpfg: bool,
) -> R<(Vec<Item>, i64, i64)> {
    let mut items = Vec::new();
    let mut run = ConstBuilder::default();
    let mut depth = 0i64;
    let mut min = 0i64;
    for m in succ {
        let key = alphabet
            .intern(m.sym, m.params.len())
            .map_err(|e| UserError::new(m.span, e))?;
        if m.params.is_empty() {
            match m.sym {
                '[' => depth += 1,
                ']' => {
                    depth -= 1;
                    min = min.min(depth);
                }
                _ => {}
            }
        }
        let codes = m
            .params
            .iter()
            .map(|e| {
                if cpfg {
                    // cpfg stores parameters as 32-bit floats.
                    let e = Expr::Call(CPFG_F32.to_string(), vec![e.clone()], e.span());
                    compile_code_in(&e, names, consts, true)
                } else {
                    compile_code(e, names, consts)
                }
            })
            .collect::<R<Vec<Code>>>()?;
        let values: Option<Vec<f64>> = codes.iter().map(Code::constant).collect();
        match values {
            Some(vals) => run.push(key, &vals, alphabet, num),
            None => {
                if let Some(c) = run.take() {
                    items.push(Item::Const(c));
                }
                items.push(Item::Module {
                    key,
                    params: exact(codes),
                });
            }
        }
    }
    if let Some(c) = run.take() {
        items.push(Item::Const(c));
    }
    Ok((items, depth, min))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::parse::parse_header;

    fn sys(src: &str) -> Result<System, UserError> {
        compile(&parse_header(src).unwrap())
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
                assert_eq!(
                    c.brackets().collect::<Vec<_>>(),
                    [(10, true, 1), (29, false, 4)]
                );
                assert_eq!(c.ibin().len(), c.bin().len() + codec::INDEX_BYTES);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!((p.depth_delta, p.depth_min), (0, 0));
        assert!(!s.productions.check_balance);
    }

    /// A table may hold millions of productions and keys (issue 9 item
    /// 6): 152 and 64 bytes before the cpfg parts were boxed, offsets
    /// narrowed and keys' lists made exact boxes.
    #[test]
    fn compiled_parts_stay_small() {
        assert_eq!(std::mem::size_of::<Production>(), 112);
        assert_eq!(std::mem::size_of::<KeyRules>(), 48);
        assert_eq!(std::mem::size_of::<Item>(), 24);
    }

    #[test]
    fn lookup_by_key_and_kinds() {
        let s = sys("productions:\nA < B -> C\nB -> D\nB -> E : 2\n").unwrap();
        let kr = s.productions.get(b'B' as u32).unwrap();
        assert_eq!(s.productions.context(kr), [0]);
        assert_eq!(s.productions.free(kr), [1, 2]);
        assert!(kr.free_stochastic && !kr.context_stochastic);
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
