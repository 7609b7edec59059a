//! Depth-first expansion for deterministic context-free byte systems.
//!
//! When every production that can apply is decided by its symbol alone (no
//! context, no condition, no probability, a constant successor of ASCII
//! symbols without parameters; a D0L system such as Koch or the bracketed
//! plants), the string after n steps is the concatenation, over the axiom,
//! of each symbol's own expansion. So the final string can be written
//! directly, depth first, with a stack of at most n frames and no temporary
//! generations. The expansions of each symbol for the last few steps (up to
//! 4 KiB each) are precomputed, so most of the output is copied in blocks.
//! The homomorphism, if it is as simple, is folded into those blocks.
//!
//! The result is byte-identical to the step-by-step engine (the tests
//! compare both), and generation lengths are computed exactly by dynamic
//! programming, for `--verbose` and `--max-length`.

use super::choose::{Chooser, Evals, Piece, KEEP_ALL};
use super::random::Random;
use crate::derive::{Origin, Out, Pass, PosReader, ASCII};
use crate::diag::Error;
use crate::rules::{Alphabet, ConstRun, Item, Production, Table};
use std::fs::File;

/// Deepest derivation expanded depth first (the stack holds one frame per
/// step).
pub const MAX_DEPTH: u64 = 1 << 16;
/// Largest precomputed expansion, and the budget for all of them.
const BLOCK: usize = 4096;
const BUDGET: usize = 4 << 20;
/// Most steps precomputed per symbol.
const MAX_LEVELS: usize = 64;

/// The rules as byte maps, if the system qualifies.
pub struct Plan<'t> {
    /// Successor of each ASCII symbol (binary = ASCII text); None: no rule.
    succ: [Option<&'t [u8]>; 128],
    /// Text written for each symbol at the end (its homomorphism image, or
    /// itself), with its module count.
    leaf: [(&'t [u8], u64); 128],
}

impl<'t> Plan<'t> {
    /// A plan for `steps` steps of `prods` then `hom` (if given), or None
    /// when the system needs the step-by-step engine.
    pub fn new(
        prods: &'t Table,
        hom: Option<&'t Table>,
        al: &Alphabet,
        steps: u64,
    ) -> Option<Self> {
        if steps == 0 || steps > MAX_DEPTH || prods.has_context() || prods.check_balance {
            return None;
        }
        if hom.is_some_and(|h| h.has_context() || h.check_balance) {
            return None;
        }
        // Rules only for ASCII symbols without parameters: other keys (from
        // the axiom) are copied as they are.
        for key in 128..al.len() as u32 {
            if prods.get(key).is_some() || hom.is_some_and(|h| h.get(key).is_some()) {
                return None;
            }
        }
        let mut succ = [None; 128];
        let mut leaf: [(&[u8], u64); 128] = std::array::from_fn(|b| (&ASCII[b..b + 1], 1));
        for b in 0..128u32 {
            match prods.fixed(b)? {
                None => {}
                // A symbol rewritten to itself stays for every later step
                // (a fixed point): a leaf, like a symbol without a rule.
                Some(f) if f.bin == [b as u8] => {}
                Some(f) if f.bin.iter().all(|&x| x < 0x80) => succ[b as usize] = Some(f.bin),
                Some(_) => return None,
            }
            if let Some(h) = hom {
                if let Some(f) = h.fixed(b)? {
                    leaf[b as usize] = (f.text, f.modules);
                }
            }
        }
        Some(Plan { succ, leaf })
    }

    /// Exact length of each generation 1..=steps, as (modules, bytes in the
    /// binary format), from generation 0's census. Modules with keys >= 128
    /// have no rule here, so they pass through every step unchanged.
    pub fn lengths(&self, census: &Census, steps: u64) -> Vec<(u64, u64)> {
        let Census {
            hist,
            other,
            other_bytes,
        } = *census;
        let mut cnt = [1u128; 128];
        let mut out = Vec::with_capacity(steps as usize);
        for _ in 0..steps {
            let prev = cnt;
            for (n, succ) in cnt.iter_mut().zip(&self.succ) {
                if let Some(s) = succ {
                    *n = s
                        .iter()
                        .fold(0u128, |acc, &c| acc.saturating_add(prev[c as usize]));
                }
            }
            // ASCII modules are one byte each.
            let ascii = (0..128).fold(0u128, |acc, b| {
                acc.saturating_add((hist[b] as u128).saturating_mul(cnt[b]))
            });
            let wide = |x: u128| u64::try_from(x).unwrap_or(u64::MAX);
            out.push((
                wide(ascii.saturating_add(other as u128)),
                wide(ascii.saturating_add(other_bytes as u128)),
            ));
        }
        out
    }

    /// Size of the final text after `steps` steps and the homomorphism,
    /// with its newline, from generation 0's census: exact when every
    /// module is an ASCII symbol, else a lower bound (other modules pass
    /// unchanged, and count one byte each here). Saturates at u128::MAX.
    pub fn final_text_bytes(&self, census: &Census, steps: u64) -> u128 {
        let mut len: [u128; 128] = std::array::from_fn(|b| self.leaf[b].0.len() as u128);
        for _ in 0..steps {
            let prev = len;
            for (n, succ) in len.iter_mut().zip(&self.succ) {
                if let Some(s) = succ {
                    *n = s
                        .iter()
                        .fold(0u128, |acc, &c| acc.saturating_add(prev[c as usize]));
                }
            }
        }
        (0..128)
            .fold(0u128, |acc, b| {
                acc.saturating_add((census.hist[b] as u128).saturating_mul(len[b]))
            })
            .saturating_add(census.other as u128)
            .saturating_add(1)
    }

    /// Write the expansion of generation 0 (`input`, binary) after `steps`
    /// steps, homomorphism applied, as text into `out`.
    pub fn expand(
        &self,
        input: &File,
        al: &Alphabet,
        steps: u64,
        out: &mut Out,
    ) -> Result<(), Error> {
        let cache = self.precompute();
        let steps = steps as usize;
        let mut rd = PosReader::new(input, 1 << 16, false);
        let mut stack: Vec<(&[u8], usize)> = Vec::new();
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        while let Some((key, s, e)) = rd.next_module(al).map_err(read_err)? {
            if key >= 128 {
                out.raw(key, rd.bytes(s, e), al)?;
                out.maybe_flush()?;
                continue;
            }
            // Expand `key` by `steps` steps; frame i of the stack is a
            // successor being walked at depth i + 1.
            if self.emit(key as u8, steps, &cache, out) {
                out.maybe_flush()?;
                continue;
            }
            stack.push((self.succ[key as usize].unwrap(), 0));
            while let Some(top) = stack.last_mut() {
                let (slice, pos) = *top;
                if pos == slice.len() {
                    stack.pop();
                    continue;
                }
                top.1 += 1;
                let left = steps - stack.len();
                let c = slice[pos];
                if !self.emit(c, left, &cache, out) {
                    stack.push((self.succ[c as usize].unwrap(), 0));
                }
                out.maybe_flush()?;
            }
        }
        Ok(())
    }

    /// Write symbol `b` expanded by `k` steps if it is a leaf at that depth
    /// (no rule, or precomputed); false if it must be walked.
    #[inline]
    fn emit(&self, b: u8, k: usize, cache: &Cache, out: &mut Out) -> bool {
        let b = b as usize;
        if self.succ[b].is_none() {
            let (text, n) = self.leaf[b];
            out.extend(text, n);
            return true;
        }
        match cache.levels[b].get(k) {
            Some(&(start, end, n)) => {
                out.extend(&cache.bytes[start..end], n);
                true
            }
            None => false,
        }
    }

    /// Expansions of each symbol for 0, 1, 2, ... steps while they fit a
    /// block (and the budget).
    fn precompute(&self) -> Cache {
        let mut c = Cache {
            bytes: Vec::new(),
            levels: std::array::from_fn(|_| Vec::new()),
        };
        for b in 0..128 {
            let (text, n) = self.leaf[b];
            let start = c.bytes.len();
            c.bytes.extend_from_slice(text);
            c.levels[b].push((start, c.bytes.len(), n));
        }
        for k in 1..MAX_LEVELS {
            let mut grew = false;
            for b in 0..128 {
                let Some(s) = self.succ[b] else { continue };
                if c.levels[b].len() != k {
                    continue;
                }
                // Every symbol of the successor needs its k-1 expansion.
                let mut len = 0;
                let mut ok = true;
                for &x in s {
                    let x = x as usize;
                    let r = if self.succ[x].is_none() {
                        c.levels[x][0]
                    } else if let Some(&r) = c.levels[x].get(k - 1) {
                        r
                    } else {
                        ok = false;
                        break;
                    };
                    len += r.1 - r.0;
                    if len > BLOCK {
                        ok = false;
                        break;
                    }
                }
                if !ok || c.bytes.len() + len > BUDGET {
                    continue;
                }
                let start = c.bytes.len();
                let mut n = 0u64;
                for &x in s {
                    let x = x as usize;
                    let (rs, re, rn) = if self.succ[x].is_none() {
                        c.levels[x][0]
                    } else {
                        c.levels[x][k - 1]
                    };
                    c.bytes.extend_from_within(rs..re);
                    n += rn;
                }
                c.levels[b].push((start, c.bytes.len(), n));
                grew = true;
            }
            if !grew {
                break;
            }
        }
        c
    }
}

struct Cache {
    bytes: Vec<u8>,
    /// Per symbol, per number of steps: (start, end, modules) in `bytes`.
    levels: [Vec<(usize, usize, u64)>; 128],
}

/// What generation 0 holds: how many of each ASCII symbol, and how many
/// other modules (with their size in bytes).
pub struct Census {
    pub hist: [u64; 128],
    pub other: u64,
    pub other_bytes: u64,
}

/// Count generation 0's modules for [`Plan::lengths`].
pub fn census(input: &File, al: &Alphabet) -> Result<Census, Error> {
    let mut c = Census {
        hist: [0; 128],
        other: 0,
        other_bytes: 0,
    };
    let mut rd = PosReader::new(input, 1 << 16, false);
    while let Some((key, s, e)) = rd
        .next_module(al)
        .map_err(|e| Error::io("temporary file", crate::diag::IoAction::Read, e))?
    {
        match c.hist.get_mut(key as usize) {
            Some(h) => *h += 1,
            None => {
                c.other += 1;
                c.other_bytes += (e - s) as u64;
            }
        }
    }
    Ok(c)
}

/// Depth-first expansion of deterministic context-free systems with
/// parameters and conditions (no context, no probability, no `ran`/`nran`):
/// a module's future depends only on itself, so the final string is each
/// axiom module's expansion in turn. One module is kept per step on the
/// current path, with where its successor's walk is ([`Level`]); nothing
/// goes through temporary files.
///
/// A module that no production matches stays the same for the remaining
/// steps (same symbol, same parameters, same conditions), so it is written
/// at once. A constant run of a successor whose modules nothing rewrites is
/// written as its text; the last step's successor is written as it is
/// evaluated, without a level.
pub struct ParamPlan<'t> {
    prods: &'t Table,
    hom: Option<&'t Table>,
    /// Which successor items are inert constant runs, made on first use
    /// and shared by every thread.
    inert: std::sync::OnceLock<Inert>,
    /// The generator each walker evaluates with, never drawn from: the
    /// cpfg dialect's carries its globals and functions, and makes the
    /// choice cpfg's.
    rng: Random,
}

/// One byte per successor item of every production, items of a production
/// from `start[production]` on: is the item a constant run that goes out
/// as its text ([`ParamPlan::inert_runs`])? Bit [`NOW`] for a step before
/// the last, [`LAST`] for the last step. A byte an item and 4 bytes a
/// production, where a list per production cost a block or two each
/// (issue 9 item 6).
struct Inert {
    start: Vec<u32>,
    flags: Vec<u8>,
}

const NOW: u8 = 1;
const LAST: u8 = 2;

impl Inert {
    #[inline]
    fn first(&self, production: u32) -> usize {
        self.start[production as usize] as usize
    }
    /// Is item `i` (counted over all productions) inert, by `which`?
    #[inline]
    fn is(&self, i: usize, which: u8) -> bool {
        self.flags.get(i).is_some_and(|f| f & which != 0)
    }
}

/// One generation on the current path: the successor being walked (its
/// production, the next item, the next module's offset in a constant run)
/// and the module of it expanded now. Its computed modules are evaluated
/// when the walk starts and kept or evaluated again as reached
/// ([`Evals`]); constant runs are decoded as they are reached. So the path
/// holds at most steps × [`KEEP_ALL`] modules' parameters,
/// however wide a successor is.
#[derive(Default)]
struct Level<'t> {
    /// The successor walked; None for a module of the input, alone.
    prod: Option<&'t Production>,
    /// Where its items' flags start in the plan's [`Inert`].
    first: usize,
    /// Its next item.
    item: usize,
    /// The next module's offset in the constant run at `item`.
    byte: usize,
    /// The module expanded now.
    key: u32,
    params: Vec<f64>,
    /// The values of the successor's computed modules.
    evals: Evals,
}

/// What [`Level::advance`] found next.
enum Next<'t> {
    /// A module, now the level's `key` and `params`.
    Module,
    /// A constant run that stays as it is until the end: written as its
    /// precompiled text, not decoded, chosen for nor formatted again.
    Inert(&'t ConstRun),
    /// The end of the successor.
    End,
}

impl<'t> Level<'t> {
    /// Walk `prod`'s successor, whose items' flags start at `first`,
    /// evaluated with `slots` (the parameters of the module it replaces):
    /// its computed modules are evaluated now ([`Evals::start`]).
    #[inline(always)]
    fn start(
        &mut self,
        (prod, first): (&'t Production, usize),
        slots: &[f64],
        (ch, rng): (&mut Chooser, &mut Random),
        (origin, pass): (&Origin, Pass),
    ) -> Result<(), Error> {
        self.prod = Some(prod);
        self.first = first;
        self.item = 0;
        self.byte = 0;
        let succ = (&prod.succ[..], KEEP_ALL);
        self.evals.start(ch, succ, (slots, rng), (origin, pass))
    }

    /// Make the first module of `bin` (binary form) the level's module:
    /// its length in bytes.
    #[inline(always)]
    fn decode(&mut self, bin: &[u8], al: &Alphabet) -> usize {
        let (key, kl) = crate::rules::codec::get_key(bin);
        let n = al.arity(key);
        self.key = key;
        self.params.clear();
        self.params
            .extend(crate::rules::codec::params_of(&bin[kl..], n));
        kl + 8 * n
    }

    /// Make the first module of `bin` a module of the input, alone on its
    /// level: its length in bytes.
    fn set_input(&mut self, bin: &[u8], al: &Alphabet) -> usize {
        self.prod = None;
        self.decode(bin, al)
    }

    /// The successor's next module, its parameters evaluated with `slots`
    /// (those of the module it replaces), or an inert run, or the end.
    #[inline(always)]
    fn advance(
        &mut self,
        slots: &[f64],
        (ch, rng): (&mut Chooser, &mut Random),
        (inert, origin, pass): (&Inert, &Origin, Pass),
        al: &Alphabet,
    ) -> Result<Next<'t>, Error> {
        let Some(prod) = self.prod else {
            return Ok(Next::End);
        };
        loop {
            match prod.succ.get(self.item) {
                None => return Ok(Next::End),
                Some(Item::Module { key, params }) => {
                    self.item += 1;
                    self.key = *key;
                    self.evals
                        .next(ch, params, (slots, rng), (origin, pass), &mut self.params)?;
                    return Ok(Next::Module);
                }
                Some(Item::Const(c)) => {
                    if self.byte == 0 && inert.is(self.first + self.item, NOW) {
                        self.item += 1;
                        return Ok(Next::Inert(c));
                    }
                    let bin = c.bin();
                    if self.byte == bin.len() {
                        self.item += 1;
                        self.byte = 0;
                        continue;
                    }
                    self.byte += self.decode(&bin[self.byte..], al);
                    return Ok(Next::Module);
                }
            }
        }
    }

    /// Is the successor done (nothing after the module last found)?
    #[inline(always)]
    fn exhausted(&self) -> bool {
        let Some(prod) = self.prod else {
            return true;
        };
        match prod.succ.get(self.item) {
            None => true,
            Some(Item::Const(c)) => self.item + 1 == prod.succ.len() && self.byte == c.bin().len(),
            Some(Item::Module { .. }) => false,
        }
    }
}

impl<'t> ParamPlan<'t> {
    /// A plan for `steps` steps of `prods` then `hom` (if given),
    /// evaluated with a copy of `rng` (see [`ParamPlan::rng`]), or None
    /// when the system needs the step-by-step engine.
    pub fn new(prods: &'t Table, hom: Option<&'t Table>, steps: u64, rng: &Random) -> Option<Self> {
        let ok = (1..=MAX_DEPTH).contains(&steps)
            && prods.deterministic_free()
            && hom.is_none_or(Table::deterministic_free);
        ok.then(|| ParamPlan {
            prods,
            hom,
            inert: std::sync::OnceLock::new(),
            rng: rng.clone(),
        })
    }

    /// Per production of `prods`, per successor item: is it a constant run
    /// none of whose modules the homomorphism rewrites nor, unless `last`
    /// (made by the last step), any production? It goes out as its text.
    fn inert_runs(&self, al: &Alphabet) -> &Inert {
        self.inert.get_or_init(|| {
            let ruled = |key: u32, last: bool| {
                (!last && self.prods.get(key).is_some())
                    || self.hom.is_some_and(|h| h.get(key).is_some())
            };
            let inert = |c: &ConstRun, last: bool| {
                !crate::rules::codec::modules_of(c.bin(), |k| al.arity(k))
                    .any(|(k, _)| ruled(k, last))
            };
            let mut r = Inert {
                start: Vec::with_capacity(self.prods.prods.len()),
                flags: Vec::new(),
            };
            for p in &self.prods.prods {
                r.start.push(r.flags.len() as u32);
                r.flags.extend(p.succ.iter().map(|i| match i {
                    Item::Const(c) => {
                        (if inert(c, false) { NOW } else { 0 })
                            | (if inert(c, true) { LAST } else { 0 })
                    }
                    Item::Module { .. } => 0,
                }));
            }
            r.flags.shrink_to_fit();
            r
        })
    }

    /// The production of `table` applying to (key, params), if any, with
    /// the parameters bound in `ch`.
    #[inline]
    fn choose(
        table: &Table,
        (key, params): (u32, &mut [f64]),
        ch: &mut Chooser,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
    ) -> Result<Option<u32>, Error> {
        let Some(kr) = table.get(key) else {
            return Ok(None);
        };
        ch.choose(params, table, kr, rng, origin, pass, |_, _| Ok(true))
    }

    /// Write generation 0 (`input`) expanded by `steps` steps, homomorphism
    /// applied, as text into `out`.
    pub fn expand(
        &self,
        input: &File,
        al: &Alphabet,
        origin: &Origin,
        steps: u64,
        out: &mut Out,
    ) -> Result<(), Error> {
        let mut w = Walker::new(self, al, steps);
        let mut rd = PosReader::new(input, 1 << 16, false);
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        while let Some((_, s, e)) = rd.next_module(al).map_err(read_err)? {
            w.expand(0, rd.bytes(s, e), al, origin, out)?;
        }
        Ok(())
    }

    /// Walk generation 0 (`input`) down to generation `depth` (< steps),
    /// calling `visit` in string order with each module of that generation
    /// and each module above it that no production rewrites (with its
    /// generation), or with an inert constant run; together they expand to
    /// the whole string. Stops when `visit` returns false. For splitting
    /// the work between threads (`super::par`).
    pub(crate) fn split(
        &self,
        input: &File,
        al: &Alphabet,
        origin: &Origin,
        depth: usize,
        mut visit: impl FnMut(Split<'_, 't>) -> Result<bool, Error>,
    ) -> Result<(), Error> {
        let mut levels: Vec<Level> = (0..=depth).map(|_| Level::default()).collect();
        let inert = self.inert_runs(al);
        let mut ch = Chooser::default();
        let mut rng = self.rng.clone(); // never drawn from
        let mut rd = PosReader::new(input, 1 << 16, false);
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        while let Some((_, s, e)) = rd.next_module(al).map_err(read_err)? {
            levels[0].set_input(rd.bytes(s, e), al);
            // Level j holds a module not yet looked at.
            let (mut j, mut fresh) = (0, true);
            loop {
                if !fresh {
                    if j == 0 {
                        break;
                    }
                    let (cur, next) = levels.split_at_mut(j);
                    let how = (inert, origin, Pass::Step(j as u64));
                    match next[0].advance(&cur[j - 1].params, (&mut ch, &mut rng), how, al)? {
                        Next::Module => {}
                        Next::Inert(c) => {
                            if !visit(Split::Inert(c))? {
                                return Ok(());
                            }
                            continue;
                        }
                        Next::End => {
                            j -= 1;
                            continue;
                        }
                    }
                }
                fresh = false;
                let c = &mut levels[j];
                let pass = Pass::Step(j as u64 + 1);
                let chosen = if j == depth {
                    None
                } else {
                    let m = (c.key, &mut c.params[..]);
                    Self::choose(self.prods, m, &mut ch, &mut rng, origin, pass)?
                };
                let Some(pi) = chosen else {
                    if !visit(Split::Module(j, c.key, &c.params))? {
                        return Ok(());
                    }
                    continue;
                };
                let (cur, next) = levels.split_at_mut(j + 1);
                let prod = (&self.prods.prods[pi as usize], inert.first(pi));
                let how = (origin, pass);
                next[0].start(prod, &cur[j].params, (&mut ch, &mut rng), how)?;
                j += 1;
            }
        }
        Ok(())
    }
    /// Write a module of the last generation, through the homomorphism.
    fn leaf(
        &self,
        (key, params): (u32, &mut [f64]),
        al: &Alphabet,
        origin: &Origin,
        out: &mut Out,
        ch: &mut Chooser,
        rng: &mut Random,
    ) -> Result<(), Error> {
        let pass = Pass::Homomorphism;
        let chosen = match self.hom {
            Some(h) => {
                Self::choose(h, (key, &mut *params), ch, rng, origin, pass)?.map(|pi| (h, pi))
            }
            None => None,
        };
        let Some((h, pi)) = chosen else {
            return out.module(key, params, al);
        };
        ch.successor(
            params,
            &h.prods[pi as usize],
            rng,
            origin,
            pass,
            |piece| match piece {
                Piece::Const(c) => out.constant(c),
                Piece::Module(key, vals) => out.module(key, vals, al),
            },
        )
    }
}

/// What [`ParamPlan::split`] hands out: a module of generation `.0` (its
/// key and parameters), or an inert constant run.
pub(crate) enum Split<'a, 't> {
    Module(usize, u32, &'a [f64]),
    Inert(&'t ConstRun),
}

/// One thread's state for expanding modules depth first: a level per step
/// on the current path, reused for every module.
pub(crate) struct Walker<'p, 't> {
    plan: &'p ParamPlan<'t>,
    n: usize,
    levels: Vec<Level<'t>>,
    // The homomorphism's own chooser and generator (never drawn from),
    // so a module of the last step goes out while `ch` still holds the
    // successor being evaluated; `scratch` holds that module's
    // parameters, the slots the homomorphism binds.
    hch: Chooser,
    hrng: Random,
    scratch: Vec<f64>,
    ch: Chooser,
    rng: Random,
}

impl<'p, 't> Walker<'p, 't> {
    pub(crate) fn new(plan: &'p ParamPlan<'t>, _al: &Alphabet, steps: u64) -> Self {
        let n = steps as usize;
        Walker {
            plan,
            n,
            levels: (0..=n.min(64)).map(|_| Level::default()).collect(),
            hch: Chooser::default(),
            hrng: plan.rng.clone(),
            scratch: Vec::new(),
            ch: Chooser::default(),
            rng: plan.rng.clone(), // never drawn from
        }
    }

    /// Write `bin` (modules in binary form) of generation `depth` expanded
    /// by the remaining steps, homomorphism applied, as text into `out`.
    pub(crate) fn expand(
        &mut self,
        depth: usize,
        bin: &[u8],
        al: &Alphabet,
        origin: &Origin,
        out: &mut Out,
    ) -> Result<(), Error> {
        let Walker {
            plan,
            n,
            levels,
            hch,
            hrng,
            scratch,
            ch,
            rng,
        } = self;
        let (plan, n) = (*plan, *n);
        let inert = plan.inert_runs(al);
        while levels.len() <= depth {
            levels.push(Level::default());
        }
        let mut at = 0;
        while at < bin.len() {
            at += levels[depth].set_input(&bin[at..], al);
            Self::walk(
                (plan, n, inert),
                (levels, depth),
                (hch, hrng, scratch),
                (ch, rng),
                al,
                origin,
                out,
            )?;
        }
        Ok(())
    }

    /// Expand the module of `levels[depth]` by the remaining steps.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn walk(
        (plan, n, inert): (&ParamPlan<'t>, usize, &Inert),
        (levels, depth): (&mut Vec<Level<'t>>, usize),
        (hch, hrng, scratch): (&mut Chooser, &mut Random, &mut Vec<f64>),
        (ch, rng): (&mut Chooser, &mut Random),
        al: &Alphabet,
        origin: &Origin,
        out: &mut Out,
    ) -> Result<(), Error> {
        // Level j holds a module not yet looked at.
        let (mut j, mut fresh) = (depth, true);
        loop {
            if !fresh {
                if j == depth {
                    return Ok(());
                }
                let (cur, next) = levels.split_at_mut(j);
                let how = (inert, origin, Pass::Step(j as u64));
                match next[0].advance(&cur[j - 1].params, (&mut *ch, &mut *rng), how, al)? {
                    Next::Module => {}
                    Next::Inert(c) => {
                        out.constant(c)?;
                        out.maybe_flush()?;
                        continue;
                    }
                    Next::End => {
                        j -= 1;
                        continue;
                    }
                }
            }
            fresh = false;
            if levels.len() <= j + 1 {
                levels.push(Level::default());
            }
            let (cur, next) = levels.split_at_mut(j + 1);
            let c = &mut cur[j];
            let pass = Pass::Step(j as u64 + 1);
            let chosen = if j == n {
                None
            } else {
                ParamPlan::choose(plan.prods, (c.key, &mut c.params), ch, rng, origin, pass)?
            };
            let Some(pi) = chosen else {
                plan.leaf((c.key, &mut c.params), al, origin, out, ch, rng)?;
                out.maybe_flush()?;
                continue;
            };
            let prod = &plan.prods.prods[pi as usize];
            if j + 1 == n {
                // The last step: its successor goes straight out (a
                // module rewritten to itself too: it would be a leaf).
                let first = inert.first(pi);
                let mut item = 0;
                ch.successor(&c.params, prod, rng, origin, pass, |piece| {
                    item += 1;
                    match piece {
                        Piece::Const(c) if inert.is(first + item - 1, LAST) => out.constant(c)?,
                        Piece::Const(c) => {
                            use crate::rules::codec::{modules_of, params_of};
                            for (key, body) in modules_of(c.bin(), |k| al.arity(k)) {
                                scratch.clear();
                                scratch.extend(params_of(body, al.arity(key)));
                                let m = (key, &mut scratch[..]);
                                plan.leaf(m, al, origin, out, hch, hrng)?;
                            }
                        }
                        // Without a homomorphism a leaf is written as it is:
                        // no copy into `scratch` (a memcpy call a module).
                        Piece::Module(key, vals) if plan.hom.is_none() => {
                            out.module(key, vals, al)?
                        }
                        Piece::Module(key, vals) => {
                            scratch.clear();
                            scratch.extend_from_slice(vals);
                            let m = (key, &mut scratch[..]);
                            plan.leaf(m, al, origin, out, hch, hrng)?;
                        }
                    }
                    out.maybe_flush()
                })?;
                continue;
            }
            // The successor becomes the next level, walked as it is reached.
            let next = &mut next[0];
            let how = (origin, pass);
            next.start(
                (prod, inert.first(pi)),
                &c.params,
                (&mut *ch, &mut *rng),
                how,
            )?;
            match next.advance(&c.params, (&mut *ch, &mut *rng), (inert, origin, pass), al)? {
                // A module rewritten to itself is a fixed point: the same
                // production applies at every later step (the system draws
                // no randomness), so it goes out as it is.
                Next::Module
                    if next.key == c.key
                        && next.exhausted()
                        && c.params
                            .iter()
                            .zip(&next.params)
                            .all(|(a, b)| a.to_bits() == b.to_bits()) =>
                {
                    plan.leaf((c.key, &mut c.params), al, origin, out, ch, rng)?;
                    out.maybe_flush()?;
                }
                Next::Module => (j, fresh) = (j + 1, true),
                Next::Inert(r) => {
                    out.constant(r)?;
                    out.maybe_flush()?;
                    j += 1;
                }
                Next::End => {}
            }
        }
    }
}
