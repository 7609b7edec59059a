//! The streaming rewriter. One derivation step reads a generation from a
//! temp file (binary format, see [`crate::rules::codec`]) and writes the next one
//! to another temp file, or, on the last pass, as text to the output.
//!
//! Memory does not grow with the string: the main reader and the look-ahead
//! reader each hold one buffer; left contexts keep the last k considered
//! modules per open branch; right contexts are matched by a second reader
//! over the same file, so skipping a branch of any size costs time, not
//! memory.

use super::bytetable::ASCII;
use super::bytetable::{ByteTable, Choices};
use super::choose::{pick, Chooser, Evals, Folded, Neighbours, Piece};
use super::context::{
    match_right, match_right_cpfg, walk_right, Chains, CpfgBrackets, LeftContext, RightCache, Walk,
};
use super::reader::PosReader;
use super::reclaim::Reclaim;
use super::sink::Out;
use super::{Origin, Pass};
use crate::derive::random::Random;
use crate::diag::Error;
use crate::rules::codec::{self, Modules};
use crate::rules::{Alphabet, Item, KeyRules, Pat, Production, RPat, Table, CLOSE, OPEN};
use std::cell::Cell;
use std::fs::File;
use std::io;

/// State shared by the passes of one derivation.
pub struct Deriver<'a> {
    pub alphabet: Alphabet,
    pub rng: Random,
    pub origin: Origin<'a>,
    slots: Vec<f64>,
    chooser: Chooser,
    /// Issue 11: decomposition (table, maximum depth), applied in every
    /// step; the homomorphism's maximum depth; whether a `%` that nothing
    /// rewrites cuts its branch.
    pub decomp: Option<(Table, usize)>,
    pub hom_depth: usize,
    /// A `.l` file's homomorphism whose tries have effects
    /// ([`Table::tries_have_effects`]): its successors are gone through at
    /// depth 1 also where nothing rewrites them there, so that the
    /// productions are tried as cpfg tries them.
    pub hom_tries: bool,
    /// cpfg's movements of the query turtle over this run: their sums go
    /// on from one fill to the next (`crate::turtle::movements`).
    pub query_movements: Option<crate::turtle::movements::Movements>,
    /// A `.l` file's decomposition whose tries have effects: its
    /// productions are tried at the depth limit also when no warning is
    /// due.
    pub decomp_tries: bool,
    pub cut: bool,
    /// Indexed generations also hold module counts (see
    /// [`Out::with_counts`]): set when the steps can cut.
    pub counts: bool,
    /// Right contexts follow cpfg's rules (a `.l` file, issue 12).
    pub cpfg_contexts: bool,
    /// A `.l` file's header blocks (issue 12).
    pub cpfg: Option<Box<crate::cpfg::run::CpfgRun>>,
    /// `warnings` on the decomposition / homomorphism section, and whether
    /// each has warned (once per run).
    pub warnings: [bool; 2],
    warned: [Cell<bool>; 2],
    rc: Recur,
    /// Rewrite only the bytes `start..end` of the generation, whose first
    /// module has index `first` (a chunk, `super::par`).
    pub(crate) range: Option<(u64, u64, u64)>,
    /// The state at the chunk's first module (left context, nesting
    /// level), from the scan that cut it (`super::split`).
    pub(crate) chunk_start: Option<super::split::ChunkStart>,
    /// A chunk of a pass that checks bracket balance: its balance, for
    /// the writer to judge (`super::split::Balance`).
    pub(crate) balance: Option<super::split::Balance>,
    /// The pass's reader's buffer, kept for the next pass or chunk.
    read_buf: Vec<u8>,
    /// Its look-ahead reader's, likewise.
    peek_buf: Vec<u8>,
}

/// Recursive rewriting (decomposition, homomorphism depth): one chooser,
/// and one buffer of modules per depth level, reused.
struct Recur {
    chooser: Chooser,
    /// The formal parameters of the production being tried (see
    /// [`Chooser`]).
    slots: Vec<f64>,
    levels: Vec<Modules>,
    /// Per depth level, for a successor walked as it is reached
    /// ([`descend`]).
    walks: Vec<WalkLevel>,
    /// Scratch stack of the depth-warning check.
    stack: Vec<f64>,
    /// Successors of more modules than this are walked as they are
    /// reached ([`descend`]), keeping the values of all their computed
    /// modules if there are at most this many ([`Evals`]);
    /// `LSGEN_TEST_WALK` sets it for tests (0: every successor walked,
    /// only values with effects kept).
    walk_above: u64,
}

/// A level of the recursion whose successor is walked ([`descend`]): the
/// bound parameters it is evaluated with, the values of the successor's
/// computed modules, and the window of its modules being rewritten.
#[derive(Default)]
struct WalkLevel {
    bound: Vec<f64>,
    one: Vec<f64>,
    evals: Evals,
    /// The modules from the one being rewritten on ([`walk_level`]).
    ahead: Modules,
}

/// Successors of more modules than this are walked as they are reached
/// in the recursion ([`descend`]): below it, evaluating a successor at
/// once costs the least and holds little.
const WALK_ABOVE: u64 = 64;

impl Default for Recur {
    fn default() -> Recur {
        Recur {
            chooser: Chooser::nested(),
            slots: Vec::new(),
            levels: Vec::new(),
            walks: Vec::new(),
            stack: Vec::new(),
            walk_above: std::env::var("LSGEN_TEST_WALK")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(WALK_ABOVE),
        }
    }
}

/// Append the modules of a precompiled run to `m`.
fn push_const(m: &mut Modules, c: &crate::rules::ConstRun, al: &Alphabet) {
    let b = c.bin();
    let mut i = 0;
    while i < b.len() {
        let (k, kl) = codec::get_key(&b[i..]);
        let n = al.arity(k);
        m.push_encoded(k, &b[i..i + kl + 8 * n], n);
        i += kl + 8 * n;
    }
}

/// Does a production match the module being rewritten recursively: the
/// rest of its predecessor (several modules, cpfg dialect) where
/// [`After`] says the later modules are, then its contexts (binding their
/// parameters)?
type ContextFn<'c> = dyn FnMut(&Production, &mut [f64], After) -> Result<bool, Error> + 'c;

/// Where the modules after the one being rewritten recursively are, for
/// the rest of a predecessor of several modules (cpfg dialect). cpfg's
/// `ApplyRecursiveProductions` (generate.c) and `InterpretHomomorphism`
/// (interpret.c) match it with `PredDiff` in the string they are going
/// through: a successor being expanded, or, for the decomposition of a
/// module that no production rewrote, the old string itself.
#[derive(Clone, Copy)]
enum After<'b> {
    /// The modules of a level buffer from this index on (the end of the
    /// buffer ends the run: cpfg's successor buffer ends there).
    Level(&'b Modules, usize),
    /// The old string after the copied module, which ends at this offset.
    Input(u64),
}

/// Do the modules of `buf` from `from` on match `rest`, one after the
/// other? Binds their parameters into `slots`.
fn level_run(buf: &Modules, from: usize, rest: &[Pat], al: &Alphabet, slots: &mut [f64]) -> bool {
    if buf.len() < from + rest.len() {
        return false;
    }
    for (j, pat) in rest.iter().enumerate() {
        let k = buf.keys[from + j];
        if k != pat.key {
            return false;
        }
        let (_, v) = buf.get(from + j, al.arity(k));
        let at = pat.slot as usize;
        slots[at..at + v.len()].copy_from_slice(v);
    }
    true
}

/// Everything the recursion reads.
struct RecCtx<'r, 'o> {
    table: &'r Table,
    max: usize,
    al: &'r Alphabet,
    origin: &'r Origin<'o>,
    pass: Pass,
    /// Warn (once: the cell) when the depth limit keeps a module that a
    /// production would still rewrite.
    warn: Option<&'r Cell<bool>>,
    /// A `.l` file's table whose tries have effects
    /// ([`Table::tries_have_effects`]): try its productions at the limit
    /// even when no warning is due.
    tries: bool,
    /// The most modules a predecessor takes after its first ([`ahead`]).
    ahead: usize,
}

/// The most modules a predecessor of `t` takes after its first (cpfg's
/// predecessors of several modules; 0 for others).
fn ahead(t: &Table) -> usize {
    if !t.has_multi {
        return 0;
    }
    t.prods.iter().map(|p| p.rest().len()).max().unwrap_or(0)
}

/// The depth limit keeps (key, params): with `warnings`, say once if a
/// production of the section would still apply (docs/structural.md,
/// section 4). Makes no draw: a condition that draws counts as applying,
/// and so does one that fails.
fn depth_warning(
    rc: &mut Recur,
    cx: &RecCtx,
    (key, params, after): (u32, &[f64], After),
    rng: &mut Random,
    ctx: &mut ContextFn,
) {
    let Some(done) = cx.warn.filter(|d| !d.get()) else {
        return;
    };
    let Some(kr) = cx.table.get(key) else {
        return;
    };
    let mut first: Option<u32> = None;
    for &pi in cx.table.context(kr).iter().chain(cx.table.free(kr)) {
        if first.is_some_and(|f| f < pi) {
            continue;
        }
        let p = &cx.table.prods[pi as usize];
        rc.slots[..params.len()].copy_from_slice(params);
        if !ctx(p, &mut rc.slots, after).unwrap_or(true) {
            continue;
        }
        let applies = match &p.cond {
            None => true,
            Some(c) if c.uses_random() => true,
            Some(c) => !matches!(c.eval(&rc.slots, &mut rc.stack, rng), Ok(v) if v == 0.0),
        };
        if applies {
            first = Some(pi);
        }
    }
    if let Some(pi) = first {
        say_depth_limit(cx, key, pi, done);
    }
}

/// The depth limit keeps a module (`key`) that production `pi` would
/// still rewrite: say so, once (`done`), at the production.
fn say_depth_limit(cx: &RecCtx, key: u32, pi: u32, done: &Cell<bool>) {
    done.set(true);
    let p = &cx.table.prods[pi as usize];
    let warning = crate::diag::WarningKind::MaximumDepth {
        max: cx.max,
        symbol: cx.al.symbol(key),
        pass: cx.pass,
    };
    crate::diag::warn(cx.origin.locate(p.start()), &warning);
}

/// The depth limit keeps (key, params), in the cpfg dialect: cpfg's
/// `ApplyRecursiveProductions` (generate.c) and `InterpretHomomorphism`
/// (interpret.c) look for the module's production before they compare the
/// depth with the maximum, so the productions are tried there as at any
/// depth, in file order up to the first that applies: contexts, then the
/// pre-condition block, then the condition (generate.c's `CondDiff`), with
/// their effects on the variables and generators. That production is not
/// applied (no post-condition block); with `warnings`, the depth warning
/// says that one applied (once), except for a decomposition of maximum
/// depth 0, where cpfg acts as if there were none.
#[cold]
#[inline(never)]
fn depth_limit_cpfg(
    rc: &mut Recur,
    cx: &RecCtx,
    (key, params, after): (u32, &[f64], After),
    rng: &mut Random,
    ctx: &mut ContextFn,
) -> Result<(), Error> {
    let pending = cx.max > 0 && cx.warn.is_some_and(|d| !d.get());
    if !(cx.tries || pending) {
        // Nothing to see: no effect, no warning.
        return Ok(());
    }
    let Some(kr) = cx.table.get(key) else {
        return Ok(());
    };
    rc.slots[..params.len()].copy_from_slice(params);
    let found = rc.chooser.first_cpfg(
        &mut rc.slots,
        cx.table,
        kr,
        rng,
        cx.origin,
        cx.pass,
        |p, s| ctx(p, s, after),
    )?;
    let Some(pi) = found else {
        return Ok(());
    };
    if let Some(done) = cx.warn.filter(|_| pending) {
        say_depth_limit(cx, key, pi, done);
    }
    Ok(())
}

/// Rewrite each module of `rc.levels[depth]` (its modules have depth
/// `depth`) recursively, writing what is left to `out`.
fn expand_level(
    rc: &mut Recur,
    cx: &RecCtx,
    depth: usize,
    rng: &mut Random,
    ctx: &mut ContextFn,
    out: &mut Out,
) -> Result<(), Error> {
    let buf = std::mem::take(&mut rc.levels[depth]);
    let mut r = Ok(());
    let mut i = 0;
    while i < buf.len() {
        match rewrite_at(rc, cx, depth, (&buf, i), rng, ctx, out) {
            Ok(n) => i += n,
            Err(e) => {
                r = Err(e);
                break;
            }
        }
    }
    rc.levels[depth] = buf;
    r
}

/// Rewrite module `i` of `buf` (a level's modules, of depth `depth`)
/// recursively, or write it: how many modules of `buf` that took (a
/// predecessor of several modules takes the next ones too).
#[inline]
fn rewrite_at(
    rc: &mut Recur,
    cx: &RecCtx,
    depth: usize,
    (buf, i): (&Modules, usize),
    rng: &mut Random,
    ctx: &mut ContextFn,
    out: &mut Out,
) -> Result<usize, Error> {
    let key = buf.keys[i];
    let (_, params) = buf.get(i, cx.al.arity(key));
    let after = After::Level(buf, i + 1);
    match try_rewrite(rc, cx, depth, (key, params, after), rng, ctx, out)? {
        Some(pi) => Ok(1 + cx.table.prods[pi as usize].rest().len()),
        // (A flush per module: one module's recursion may write a lot.)
        None => {
            out.module(key, params, cx.al)?;
            out.maybe_flush()?;
            Ok(1)
        }
    }
}

/// Rewrite the module (key, params) of depth `depth`, the later modules
/// where `after` says, if it is below the maximum depth and a production
/// applies: its successor (depth + 1) is rewritten in turn, depth first.
/// The production applied (a predecessor of several modules took its
/// rest's modules too: the caller passes over them), None if none did (at
/// the depth limit the module stays alone, whatever its productions
/// match: cpfg copies one module there).
fn try_rewrite(
    rc: &mut Recur,
    cx: &RecCtx,
    depth: usize,
    (key, params, after): (u32, &[f64], After),
    rng: &mut Random,
    ctx: &mut ContextFn,
    out: &mut Out,
) -> Result<Option<u32>, Error> {
    if depth >= cx.max {
        if rng.cpfg_mut().is_some() {
            depth_limit_cpfg(rc, cx, (key, params, after), rng, ctx)?;
        } else {
            depth_warning(rc, cx, (key, params, after), rng, ctx);
        }
        return Ok(None);
    }
    let Some(kr) = cx.table.get(key) else {
        return Ok(None);
    };
    rc.slots[..params.len()].copy_from_slice(params);
    let Some(pi) = rc.chooser.choose(
        &mut rc.slots,
        cx.table,
        kr,
        rng,
        cx.origin,
        cx.pass,
        |p, s| ctx(p, s, after),
    )?
    else {
        return Ok(None);
    };
    let p = &cx.table.prods[pi as usize];
    descend(rc, cx, depth + 1, p, rng, ctx, out)?;
    Ok(Some(pi))
}

/// Rewrite `p`'s successor (its parameters bound in `rc.slots`), whose
/// modules have depth `depth`, recursively, writing what is left to `out`.
///
/// A successor of more than [`WALK_ABOVE`] modules is walked as it is
/// reached, so that a level holds one module, not the whole successor
/// (depth × the widest successor could be gigabytes from a small file).
/// cpfg evaluates a successor before it rewrites its first module, and
/// the order shows only where an evaluation draws, warns, reads a
/// variable that blocks assign, or fails: [`Evals`] evaluates them first,
/// as depth first does. A table with predecessors of several modules
/// matches their rest against the modules after the one rewritten: the
/// walk keeps as many evaluated ahead ([`RecCtx::ahead`]).
#[inline]
fn descend(
    rc: &mut Recur,
    cx: &RecCtx,
    depth: usize,
    p: &Production,
    rng: &mut Random,
    ctx: &mut ContextFn,
    out: &mut Out,
) -> Result<(), Error> {
    if !wider_than(p, rc.walk_above) {
        fill_level(rc, cx.al, depth, p, rng, cx.origin, cx.pass)?;
        return expand_level(rc, cx, depth, rng, ctx, out);
    }
    if rc.walks.len() <= depth {
        rc.walks.resize_with(depth + 1, Default::default);
    }
    let mut w = std::mem::take(&mut rc.walks[depth]);
    w.bound.clear();
    w.bound.extend_from_slice(&rc.slots[..p.nslots()]);
    let r = walk_level(rc, cx, depth, p, &mut w, rng, ctx, out);
    rc.walks[depth] = w;
    r
}

/// Has `p`'s successor more than `n` modules?
fn wider_than(p: &Production, n: u64) -> bool {
    let mut m = 0u64;
    for item in p.succ.iter() {
        m += match item {
            Item::Const(c) => c.modules(),
            Item::Module { .. } => 1,
        };
        if m > n {
            return true;
        }
    }
    false
}

/// [`descend`]'s walk of `p`'s successor, evaluated with `w.bound`: each
/// module in string order, rewritten recursively. `w.ahead` holds the
/// module rewritten now and the [`RecCtx::ahead`] after it (fewer at the
/// successor's end, which ends a predecessor's run as the whole
/// successor's end does), so a level holds a bounded window of it.
#[allow(clippy::too_many_arguments)]
fn walk_level(
    rc: &mut Recur,
    cx: &RecCtx,
    depth: usize,
    p: &Production,
    w: &mut WalkLevel,
    rng: &mut Random,
    ctx: &mut ContextFn,
    out: &mut Out,
) -> Result<(), Error> {
    let at = (cx.origin, cx.pass);
    // (Keeping all the values of a successor with at most as many computed
    // modules as a successor has modules before it is walked: one bound,
    // and one test hook for both.)
    let succ = (&p.succ[..], rc.walk_above as usize);
    w.evals.start(&mut rc.chooser, succ, (&w.bound, rng), at)?;
    let arity = |k| cx.al.arity(k);
    let mut items = p.succ.iter();
    let mut run = codec::modules_of(&[], arity);
    w.ahead.clear();
    // The module rewritten next, in `w.ahead`.
    let mut cur = 0;
    loop {
        while w.ahead.len() <= cur + cx.ahead {
            if let Some((key, body)) = run.next() {
                w.ahead.push_body(key, body, arity(key));
                continue;
            }
            match items.next() {
                None => break,
                Some(Item::Const(c)) => run = codec::modules_of(c.bin(), arity),
                Some(Item::Module { key, params }) => {
                    w.evals
                        .next(&mut rc.chooser, params, (&w.bound, rng), at, &mut w.one)?;
                    w.ahead.push(*key, &w.one);
                }
            }
        }
        if cur == w.ahead.len() {
            return Ok(());
        }
        cur += rewrite_at(rc, cx, depth, (&w.ahead, cur), rng, ctx, out)?;
        if cur >= WINDOW {
            w.ahead.drop_front(cur);
            cur = 0;
        }
    }
}

/// A walked level drops the modules it is done with once there are this
/// many ([`walk_level`]).
const WINDOW: usize = 64;

/// Evaluate `p`'s successor (parameters bound in `rc.chooser`) into
/// `rc.levels[level]`.
fn fill_level(
    rc: &mut Recur,
    al: &Alphabet,
    level: usize,
    p: &Production,
    rng: &mut Random,
    origin: &Origin,
    pass: Pass,
) -> Result<(), Error> {
    if rc.levels.len() <= level {
        rc.levels.resize_with(level + 1, Modules::default);
    }
    let mut next = std::mem::take(&mut rc.levels[level]);
    next.clear();
    let r = rc
        .chooser
        .successor(&rc.slots, p, rng, origin, pass, |piece| {
            match piece {
                Piece::Const(c) => push_const(&mut next, c, al),
                Piece::Module(k, v) => next.push(k, v),
            }
            Ok(())
        });
    rc.levels[level] = next;
    r
}

#[cfg(test)]
thread_local! {
    /// Modules a cut walked over one by one (tests).
    pub(crate) static CUT_SCANNED: Cell<u64> = const { Cell::new(0) };
}

struct StepState<'f> {
    peek: Option<PosReader<'f>>,
    /// cpfg's right-context rules (a `.l` file), chosen once per pass.
    cpfg: Option<CpfgBrackets>,
    right: RightCache,
    max_right_simple: usize,
    left: Option<LeftContext>,
    /// A run of ignored modules: from any module end in `skip.0..=skip.1`
    /// only ignored modules (no bracket) lie before offset `skip.1`, so a
    /// right context may start there. Keeps right contexts over long
    /// ignored runs linear.
    skip: (u64, u64),
    /// The ignored run of `skip` ends at a `[`: only then can a walk
    /// over whole branches go further (see [`Chains`]).
    skip_open: bool,
    /// The module end `right` was last looked up for: the productions
    /// tried on one module share one look-up.
    right_end: u64,
    /// Some ignored module asks for a right context: then walks
    /// from inside one stretch of ignored modules and branches repeat, and
    /// `skip` and `chains` keep them linear. Otherwise only considered
    /// modules start walks, each stretch is walked by at most
    /// `max_right_simple` of them, and a plain walk is cheaper.
    memo: bool,
    /// Where walks over ignored modules and branches ended, per level.
    chains: Chains,
    /// Nesting level of the input at the current module.
    level: i64,
    /// With cuts over an indexed generation: for each open branch of the
    /// input, the offset just past its `]` and that `]`'s module index, so
    /// a cut skips the rest of the branch in constant time.
    branches: Option<Vec<(u64, u64)>>,
    depth: i64,
    /// Productions that last opened or closed more than they matched, to
    /// blame for unbalanced output.
    last_opener: Option<u32>,
    last_closer: Option<u32>,
    /// A production with a predecessor of several modules (cpfg dialect)
    /// was applied: the old string's modules up to this offset are its.
    run_end: Option<u64>,
    /// Choose the cpfg dialect's way (its generator, or predecessors of
    /// several modules): decided once per pass.
    cpfg_choice: bool,
}

impl StepState<'_> {
    /// Do the modules right after the one ending at `end_off` match `rest`,
    /// one after the other (the rest of a predecessor of several modules,
    /// cpfg's rule: no module passed over)? Returns where the run ends, and
    /// binds their parameters into `slots` if given (not when a chosen
    /// production's run is only skipped: its blocks may have assigned them,
    /// and cpfg's successor sees what they left).
    fn match_run(
        &mut self,
        end_off: u64,
        rest: &[Pat],
        al: &Alphabet,
        mut slots: Option<&mut [f64]>,
    ) -> Result<Option<u64>, Error> {
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        let peek = self
            .peek
            .as_mut()
            .expect("a look-ahead reader for predecessors of several modules");
        let mut pos = end_off;
        for pat in rest {
            peek.seek(pos);
            let Some((k, s, e)) = peek.next_module(al).map_err(read_err)? else {
                return Ok(None);
            };
            if k != pat.key {
                return Ok(None);
            }
            if let Some(slots) = slots.as_deref_mut() {
                let n = al.arity(k);
                let at = pat.slot as usize;
                codec::read_params(peek.bytes(s, e), &mut slots[at..at + n]);
            }
            pos = peek.offset();
        }
        Ok(Some(pos))
    }

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
        let (pos, open) = match walk_right(peek, al, end_off, false)? {
            Walk::Module { at, .. } => (at, false),
            Walk::Stop { at, open } => (at, open),
        };
        self.skip = (end_off, pos);
        self.skip_open = open;
        Ok(pos)
    }

    /// Where the next considered module of the current level right of the
    /// module ending at `end_off` is (or the `]` or end that stops the
    /// search), passing over ignored modules and whole branches. Each such
    /// stretch is walked once per pass, however many of its modules ask.
    #[inline]
    fn level_start(&mut self, end_off: u64, al: &Alphabet) -> io::Result<u64> {
        let start = self.right_start(end_off, al)?;
        if !self.skip_open {
            // A considered module, a `]` or the end: no branch to pass
            // over, the walk over branches would stop where it starts.
            return Ok(start);
        }
        let level = self.level();
        let peek = self
            .peek
            .as_mut()
            .expect("a look-ahead reader for right contexts");
        self.chains.walk(peek, al, start, level)
    }

    /// The nesting level of the current module (the input is balanced, so
    /// it is never negative).
    fn level(&self) -> usize {
        usize::try_from(self.level).unwrap_or(0)
    }

    /// The next considered modules right of the module ending at `end_off`
    /// (read once per module).
    #[inline(always)]
    fn right_of(&mut self, end_off: u64, al: &Alphabet) -> Result<&RightCache, Error> {
        if self.right_end != end_off {
            self.look_right(end_off, al)
                .map_err(|e| Error::io("temporary file", crate::diag::IoAction::Read, e))?;
        }
        Ok(&self.right)
    }

    /// Fill `right` for the module ending at `end_off`.
    #[inline(never)]
    fn look_right(&mut self, end_off: u64, al: &Alphabet) -> io::Result<()> {
        self.right_end = u64::MAX;
        let start = if self.memo {
            self.level_start(end_off, al)?
        } else {
            end_off
        };
        if self.right.at != start {
            let peek = self
                .peek
                .as_mut()
                .expect("a look-ahead reader for right contexts");
            self.right.fill(peek, al, start, self.max_right_simple)?;
        }
        self.right_end = end_off;
        Ok(())
    }
}

impl<'a> Deriver<'a> {
    pub fn new(alphabet: Alphabet, rng: Random, origin: Origin<'a>) -> Self {
        Deriver {
            alphabet,
            rng,
            origin,
            slots: Vec::new(),
            chooser: Chooser::default(),
            decomp: None,
            hom_depth: 1,
            hom_tries: false,
            query_movements: None,
            decomp_tries: false,
            cut: false,
            counts: false,
            cpfg_contexts: false,
            cpfg: None,
            warnings: [false; 2],
            warned: [Cell::new(false), Cell::new(false)],
            rc: Recur::default(),
            range: None,
            chunk_start: None,
            balance: None,
            read_buf: Vec::new(),
            peek_buf: Vec::new(),
        }
    }

    /// A `.l` file whose blocks assign `Q`: the homomorphism reads the
    /// value the blocks left (cpfg's global `Q`), not the last step's
    /// number.
    pub fn keeps_q(&self) -> bool {
        self.cpfg.as_ref().is_some_and(|c| c.assigns_q)
    }

    /// Run a `.l` file's header block `which` (its errors located in
    /// `pass`); nothing for other files.
    pub fn cpfg_block(&mut self, which: crate::cpfg::run::When, pass: Pass) -> Result<(), Error> {
        use crate::cpfg::run::When;
        let Some(c) = &self.cpfg else {
            return Ok(());
        };
        c.run(which, &mut self.rng).map_err(|e| {
            use crate::diag::Block;
            let block = match which {
                When::Define => Block::Define,
                When::Start => Block::Start,
                When::StartEach => Block::StartEach(pass),
                When::EndEach => Block::EndEach(pass),
                When::End => Block::End,
            };
            crate::diag::Error::at(
                self.origin.locate(e.span.0),
                crate::diag::RuntimeError::Block {
                    error: e.kind,
                    block,
                },
            )
        })
    }

    /// A `.l` file's axiom with parameters worked out after `Start:` (a
    /// global, `ran`): its text now; None for every other axiom.
    pub fn cpfg_axiom(&mut self) -> Result<Option<String>, Error> {
        let Some(c) = &self.cpfg else {
            return Ok(None);
        };
        c.axiom_text(&mut self.rng)
            .map_err(|e| self.origin.eval_error(e, Pass::Axiom))
    }

    /// One pass: rewrite the generation in `input` into `out`.
    ///
    /// `reclaim`: what of `input` the pass gives back as it reads
    /// ([`Reclaim`]); this pass gives back unless it reads a chunk only.
    pub fn pass(
        &mut self,
        table: &Table,
        (input, reclaim): (&File, Option<&Reclaim>),
        indexed: bool,
        out: &mut Out,
        pass: Pass,
    ) -> Result<(), Error> {
        let decomp = if matches!(pass, Pass::Step(_)) {
            self.decomp.take()
        } else {
            None
        };
        let r = self.pass_with(table, decomp.as_ref(), (input, reclaim), indexed, out, pass);
        if decomp.is_some() {
            self.decomp = decomp;
        }
        r
    }

    fn pass_with(
        &mut self,
        table: &Table,
        decomp: Option<&(Table, usize)>,
        (input, reclaim): (&File, Option<&Reclaim>),
        indexed: bool,
        out: &mut Out,
        pass: Pass,
    ) -> Result<(), Error> {
        let max_slots = |t: &Table| t.prods.iter().map(|p| p.nslots()).max().unwrap_or(0);
        let n = max_slots(table).max(decomp.map_or(0, |(d, _)| max_slots(d)));
        self.slots.resize(max_slots(table).max(1), 0.0);
        if self.rc.slots.len() < n.max(1) {
            self.rc.slots.resize(n.max(1), 0.0);
        }
        if self.rc.levels.len() < 2 {
            self.rc.levels.resize_with(2, Modules::default);
        }
        let cut = self.cut && matches!(pass, Pass::Step(_));
        let hom_depth = if pass == Pass::Homomorphism {
            self.hom_depth
        } else {
            1
        };
        // Decomposition contexts (cpfg dialect) are read in the same string,
        // around the predecessor.
        let d = decomp.map(|(d, _)| d);
        let mut st = StepState {
            peek: (table.has_right
                || table.has_multi
                || d.is_some_and(|d| d.has_right || d.has_multi))
            .then(|| {
                let buf = std::mem::take(&mut self.peek_buf);
                PosReader::reusing(input, 1 << 16, indexed, buf)
                    .with_counts(self.counts)
                    .giving_back(reclaim, false)
            }),
            cpfg: self.cpfg_contexts.then(|| CpfgBrackets::of(&self.alphabet)),
            right: RightCache::new(),
            max_right_simple: table
                .max_right_simple
                .max(d.map_or(0, |d| d.max_right_simple)),
            left: super::split::left_for(table, d, &self.alphabet),
            depth: 0,
            skip: (u64::MAX, 0),
            skip_open: false,
            right_end: u64::MAX,
            memo: table
                .prods
                .iter()
                .chain(d.iter().flat_map(|d| d.prods.iter()))
                .any(|p| !p.right().is_empty() && self.alphabet.ignored(p.key)),
            chains: Chains::default(),
            level: 0,
            branches: (cut && indexed && self.counts).then(Vec::new),
            last_opener: None,
            last_closer: None,
            run_end: None,
            cpfg_choice: self.cpfg_contexts || table.has_multi || self.rng.cpfg_mut().is_some(),
        };
        st.chains.across = st.memo;
        // (A chunk's reader needs no more than the chunk; the buffer is
        // the last pass's or chunk's, `read_buf`, grown where it is short.)
        let capacity = self.range.map_or(1 << 20, |(start, end, _)| {
            (end - start).min(1 << 20) as usize
        });
        let buf = std::mem::take(&mut self.read_buf);
        let mut rd = PosReader::reusing(input, capacity, indexed, buf)
            .with_counts(self.counts)
            .giving_back(reclaim, self.range.is_none());
        let open_len = rd.open_len();
        // The index of the module being rewritten, for the random draws.
        let mut index: u64 = 0;
        if let Some((start, end, first)) = self.range {
            rd.limit(start, end);
            index = first;
        }
        if let Some(at) = self.chunk_start.take() {
            // A chunk of a split pass: go on from where one thread would be.
            st.level = at.level;
            if st.left.is_some() {
                st.left = at.left;
            }
        }
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        // Bytes that need no decision take the table; with contexts, keys
        // that have context productions and brackets still go the long way.
        let hom_rec =
            pass == Pass::Homomorphism && (hom_depth != 1 || self.warnings[1] || self.hom_tries);
        let fast = (!table.check_balance && decomp.is_none() && !hom_rec).then(|| {
            let mut t = ByteTable::new(
                table,
                out.text,
                !indexed && st.left.is_none() && !out.indexed,
            );
            if cut {
                t.general(b'%');
                if st.branches.is_some() {
                    // The general path keeps `branches`.
                    t.brackets_general();
                }
            }
            t
        });
        // With the table, ASCII keys without parameters whose choice
        // depends on nothing but the draw (`Folded`) or on the keys of
        // their neighbours (`Neighbours`) take a short way too
        // (`chosen_next`): the table decides those it can.
        let (folded, neighbours) = match &fast {
            Some(_) if !st.cpfg_choice => (
                one_byte_keys(table, &self.alphabet, cut, Folded::of),
                one_byte_keys(table, &self.alphabet, cut, Neighbours::of),
            ),
            _ => (Vec::new(), Vec::new()),
        };
        let choices = match &fast {
            Some(t) if !folded.is_empty() || !neighbours.is_empty() => t.choices(
                table,
                (&folded, &neighbours),
                &self.alphabet,
                (st.left.is_some(), out.indexed),
            ),
            _ => Choices::default(),
        };
        // Keys that take `chosen_next`.
        let short = !folded.is_empty() || choices.by_neighbours();
        loop {
            if let Some(fast) = &fast {
                let window = rd.window().map_err(read_err)?;
                let (used, modules) = fast.run(
                    window,
                    out,
                    st.left.as_mut(),
                    &self.alphabet,
                    open_len,
                    &mut st.level,
                )?;
                rd.advance(used);
                index += modules;
                out.maybe_flush()?;
                if short
                    && self.chosen_next(
                        (&folded, fast, &choices, open_len),
                        &mut rd,
                        &mut index,
                        table,
                        &mut st,
                        out,
                        pass,
                    )?
                {
                    continue;
                }
                if used > 0 {
                    continue;
                }
            }
            let Some((key, s, e)) = rd.next_module(&self.alphabet).map_err(read_err)? else {
                break;
            };
            let end_off = rd.offset();
            let bytes = rd.bytes(s, e);
            self.rng.set_module(index);
            index += 1;
            // The input's level after this module: where the right context
            // of a bracket predecessor (cpfg dialect) starts.
            if key == OPEN {
                st.level += 1;
            } else if key == CLOSE {
                st.level -= 1;
            }
            let applied = match table.get(key) {
                Some(kr) => self.apply(
                    table,
                    kr,
                    (key, bytes, end_off),
                    (decomp, hom_depth),
                    &mut st,
                    out,
                    pass,
                )?,
                None => false,
            };
            let mut decomposed = false;
            if !applied && (decomp.is_some() || (cut && key == u32::from(b'%'))) {
                // The copied module, decomposed; a `%` that nothing
                // rewrites is a cut.
                let n = self.alphabet.arity(key);
                self.rc.levels[0].clear();
                self.rc.levels[0].push_encoded(key, bytes, n);
                // (levels[0] holds the copied module for try_rewrite.)
                decomposed = match decomp {
                    Some((d, max)) => {
                        self.decompose_copied((d, *max), (key, n, end_off), &mut st, out, pass)?
                    }
                    None => false,
                };
                // (A decomposed bracket, cpfg dialect, goes on below: its
                // decomposition balances against it.)
                if decomposed && key != OPEN && key != CLOSE {
                    if let Some(left) = &mut st.left {
                        if key != OPEN && key != CLOSE && !self.alphabet.ignored(key) {
                            left.push(key, bytes, n);
                        }
                    }
                    if let Some(run_end) = st.run_end.take() {
                        index = self.skip_run(&mut rd, run_end, index, &mut st, pass)?;
                    }
                    out.maybe_flush()?;
                    continue;
                }
                if cut && key == u32::from(b'%') && n == 0 {
                    // Drop the rest of the branch; its `]` stays. The
                    // dropped modules still count in the draw positions of
                    // the modules after them (module index in the old
                    // generation): the bracket index has the `]`'s, else
                    // walk them one by one.
                    if let Some(&(end, close)) = st.branches.as_ref().and_then(|b| b.last()) {
                        // cpfg's choice generator: the cut part draws nothing.
                        if let Some(c) = self.rng.cpfg_mut() {
                            c.skip_modules(close - index);
                        }
                        index = close;
                        rd.seek(end - 1);
                        continue;
                    }
                    let mut depth = 0u64;
                    let mut close = None;
                    let cut_from = index;
                    while let Some((k, _, _)) = rd.next_module(&self.alphabet).map_err(read_err)? {
                        #[cfg(test)]
                        CUT_SCANNED.with(|c| c.set(c.get() + 1));
                        if k == CLOSE {
                            if depth == 0 {
                                close = Some(rd.offset());
                                break;
                            }
                            depth -= 1;
                        } else if k == OPEN {
                            depth += 1;
                        }
                        index += 1;
                    }
                    // cpfg's choice generator: the cut part draws nothing.
                    if let Some(c) = self.rng.cpfg_mut() {
                        c.skip_modules(index - cut_from);
                    }
                    match close {
                        Some(after) => {
                            rd.seek(after - 1);
                            continue;
                        }
                        None => break,
                    }
                }
            }
            if !applied {
                // (A decomposed bracket counts as the bracket it was.)
                if table.check_balance {
                    if key == OPEN {
                        st.depth += 1;
                    } else if key == CLOSE {
                        st.depth -= 1;
                        if st.depth < 0 {
                            match &mut self.balance {
                                Some(b) => b.dip(st.depth, st.last_closer),
                                None => {
                                    return Err(unbalanced(
                                        &self.origin,
                                        table,
                                        st.last_closer,
                                        pass,
                                    ))
                                }
                            }
                        }
                    }
                }
                if !decomposed {
                    out.raw(key, bytes, &self.alphabet)?;
                }
            }
            if key == OPEN {
                if let Some(b) = &mut st.branches {
                    // This `[` is module `index - 1`.
                    let (end, modules) = rd.branch_index(s);
                    b.push((end, index + modules - 2));
                }
            } else if key == CLOSE {
                if let Some(b) = &mut st.branches {
                    b.pop();
                }
            }
            if let Some(left) = &mut st.left {
                left.follow(key, bytes, &self.alphabet);
            }
            if let Some(run_end) = st.run_end.take() {
                index = self.skip_run(&mut rd, run_end, index, &mut st, pass)?;
            }
            out.maybe_flush()?;
        }
        self.read_buf = rd.into_buffer();
        if let Some(peek) = st.peek.take() {
            self.peek_buf = peek.into_buffer();
        }
        if let (Some(c), Pass::Step(_)) = (self.rng.cpfg_mut(), pass) {
            // cpfg's choice generator: every module of the step drew once.
            c.end_pass(index);
        }
        if let Some(b) = &mut self.balance {
            // A chunk: the writer judges.
            (b.depth, b.last_opener, b.last_closer) = (st.depth, st.last_opener, st.last_closer);
        } else if st.depth != 0 {
            return Err(unclosed(&self.origin, table, st.last_opener, pass));
        }
        Ok(())
    }

    /// If the next module is of a key the byte table decides (`choices`)
    /// or of a key with a [`Folded`] choice (`folded`, by key: ASCII keys
    /// without parameters, so the module is one byte), rewrite it as
    /// [`Deriver::apply`] would and do the rest of the pass's work on it;
    /// and so on while the next module is one, with the byte table
    /// (`fast`, its input's `[` taking `open_len` bytes) copying what it
    /// can between them. False if the next module was not one. Out of
    /// line: the loop of passes without such keys stays as it was.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn chosen_next(
        &mut self,
        (folded, fast, choices, open_len): (&[Option<Folded>], &ByteTable, &Choices, usize),
        rd: &mut PosReader,
        index: &mut u64,
        table: &Table,
        st: &mut StepState,
        out: &mut Out,
        pass: Pass,
    ) -> Result<bool, Error> {
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        let mut any = false;
        loop {
            let window = rd.window().map_err(read_err)?;
            let Some(&b) = window.first() else {
                return Ok(any);
            };
            if choices.has(b) {
                let (used, modules) = fast.run_choosing(
                    choices,
                    window,
                    out,
                    st.left.as_mut(),
                    &self.alphabet,
                    open_len,
                    &mut st.level,
                    (&mut self.rng, *index),
                )?;
                rd.advance(used);
                *index += modules;
                out.maybe_flush()?;
                if used > 0 {
                    any = true;
                    continue;
                }
                // (A draw failed, `pick` below reports it; or the input
                // does not tell a right neighbour: the general path.)
            }
            let Some(Some(f)) = folded.get(usize::from(b)) else {
                return Ok(any);
            };
            let key = u32::from(b);
            rd.advance(1);
            self.rng.set_module(*index);
            *index += 1;
            let i = pick(&f.cand, f.total, &mut self.rng, table, &self.origin, pass)?;
            for item in table.prods[f.cand[i].0 as usize].succ.iter() {
                if let Item::Const(c) = item {
                    out.constant(c)?;
                }
            }
            if let Some(left) = &mut st.left {
                left.follow(key, &ASCII[key as usize..][..1], &self.alphabet);
            }
            out.maybe_flush()?;
            any = true;
        }
    }

    /// The copied module (key, arity `n`, ending at `end_off`; in
    /// `rc.levels[0]`) decomposed with `d` (maximum depth `max`); false if
    /// no production applied. Out of line: the pass's loop stays small.
    #[inline(never)]
    fn decompose_copied(
        &mut self,
        (d, max): (&Table, usize),
        (key, n, end_off): (u32, usize, u64),
        st: &mut StepState,
        out: &mut Out,
        pass: Pass,
    ) -> Result<bool, Error> {
        let cx = RecCtx {
            table: d,
            max,
            al: &self.alphabet,
            origin: &self.origin,
            pass,
            warn: self.warnings[0].then_some(&self.warned[0]),
            tries: self.decomp_tries,
            ahead: ahead(d),
        };
        let lv = std::mem::take(&mut self.rc.levels[0]);
        let (_, params) = lv.get(0, n);
        let al = &self.alphabet;
        // cpfg's `ApplyProd` decomposes a module that no production
        // rewrote with its contexts around that one module (the right one
        // right after it), and a predecessor of several modules takes the
        // old string's next modules, which no production rewrites then.
        let r = try_rewrite(
            &mut self.rc,
            &cx,
            0,
            (key, params, After::Input(end_off)),
            &mut self.rng,
            &mut |p, slots, after| recursion_contexts(p, slots, after, st, al, end_off),
            out,
        );
        self.rc.levels[0] = lv;
        let Some(pi) = r? else {
            return Ok(false);
        };
        let rest = d.prods[pi as usize].rest();
        if !rest.is_empty() {
            // Skipped by the caller, as a production's run. Not bound
            // again (see `apply`).
            st.run_end = st.match_run(end_off, rest, al, None)?;
        }
        Ok(true)
    }

    /// The rest of a predecessor of several modules (cpfg dialect; a
    /// production's, or a decomposition's that took the old string's
    /// modules, or the homomorphism's), up to `run_end`: replaced with the
    /// first module; still the old string for left contexts and draw
    /// positions. Returns the module index after it.
    #[cold]
    #[inline(never)]
    fn skip_run(
        &mut self,
        rd: &mut PosReader,
        run_end: u64,
        mut index: u64,
        st: &mut StepState,
        pass: Pass,
    ) -> Result<u64, Error> {
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        while rd.offset() < run_end {
            let Some((k, s, e)) = rd.next_module(&self.alphabet).map_err(read_err)? else {
                break;
            };
            index += 1;
            // cpfg draws once for the whole predecessor (a step's draws:
            // the homomorphism makes none).
            if let (Some(c), Pass::Step(_)) = (self.rng.cpfg_mut(), pass) {
                c.skip_modules(1);
            }
            if let Some(left) = &mut st.left {
                if !self.alphabet.ignored(k) {
                    left.push(k, rd.bytes(s, e), self.alphabet.arity(k));
                }
            }
        }
        Ok(index)
    }

    /// Try the productions of `key`; emit the chosen successor.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn apply(
        &mut self,
        table: &Table,
        kr: &KeyRules,
        (key, bytes, end_off): (u32, &[u8], u64),
        (decomp, hom_depth): (Option<&(Table, usize)>, usize),
        st: &mut StepState,
        out: &mut Out,
        pass: Pass,
    ) -> Result<bool, Error> {
        let Deriver {
            alphabet: al,
            rng,
            origin,
            slots,
            chooser,
            rc,
            warnings,
            warned,
            balance,
            hom_tries,
            decomp_tries,
            ..
        } = self;
        // Predecessor parameters into the first slots.
        let arity = al.arity(key);
        if arity > 0 {
            codec::read_params(bytes, &mut slots[..arity]);
        }
        // The nearest considered module to the left, looked up once.
        let last = st.left.as_ref().map(|l| l.last_key());
        if pass == Pass::Homomorphism && hom_depth == 0 {
            // cpfg dialect, `maximum depth:` 0 or below: cpfg's
            // `InterpretHomomorphism` tries the productions, then stops at
            // depth 0 >= the maximum: the module stays, with the depth
            // warning if one applied.
            let found = chooser.first_cpfg(slots, table, kr, rng, origin, pass, |p, slots| {
                run_contexts(p, slots, st, al, (last, pass), end_off)
            })?;
            if let Some(pi) = found {
                if warnings[1] && !warned[1].get() {
                    warned[1].set(true);
                    let warning = crate::diag::WarningKind::MaximumDepth {
                        max: 0,
                        symbol: al.symbol(key),
                        pass,
                    };
                    let at = origin.locate(table.prods[pi as usize].start());
                    crate::diag::warn(at, &warning);
                }
            }
            return Ok(false);
        }
        let chosen = if st.cpfg_choice {
            choose_cpfg(
                chooser,
                slots,
                (table, kr),
                rng,
                origin,
                pass,
                st,
                al,
                last,
                end_off,
            )?
        } else {
            // (Inlined: the cheap first look runs in the choice loop; a
            // call per production tried costs the context rows ~10 %.)
            chooser.choose_ls(
                slots,
                table,
                kr,
                rng,
                origin,
                pass,
                #[inline(always)]
                |p, slots| {
                    Ok(!surely_not(p, last, end_off, st, al)?
                        && contexts_match(p, end_off, st, al, slots)?)
                },
            )?
        };
        let Some(pi) = chosen else {
            return Ok(false);
        };
        let p = &table.prods[pi as usize];
        if !p.rest().is_empty() {
            // The run the chosen production matched: skipped by the caller.
            // Its parameters are not bound again: the production's blocks
            // may have assigned them (cpfg's successor sees the values the
            // pre- and post-condition blocks left).
            st.run_end = st.match_run(end_off, p.rest(), al, None)?;
        }
        if table.check_balance {
            if st.depth + i64::from(p.depth_min) < 0 {
                match balance {
                    Some(b) => b.dip(st.depth + i64::from(p.depth_min), Some(pi)),
                    None => return Err(unbalanced(origin, table, Some(pi), pass)),
                }
            }
            st.depth += i64::from(p.depth_delta);
            // Against the bracket it replaces, for a bracket predecessor
            // (cpfg dialect): `[ --> X` closes more than it matched.
            let d = match key {
                OPEN => 1,
                CLOSE => -1,
                _ => 0,
            };
            if p.depth_delta > d {
                st.last_opener = Some(pi);
            }
            if p.depth_delta < d || p.depth_min < d.min(0) {
                st.last_closer = Some(pi);
            }
        }
        if let Some((d, max)) = decomp {
            // The successor has depth 0: decompose it.
            rc.slots[..p.nslots()].copy_from_slice(&slots[..p.nslots()]);
            let cx = RecCtx {
                table: d,
                max: *max,
                al,
                origin,
                pass,
                warn: warnings[0].then_some(&warned[0]),
                tries: *decomp_tries,
                ahead: ahead(d),
            };
            // Contexts (cpfg dialect) are read around the predecessor in
            // the string before the step, at every depth: the right one
            // after the whole predecessor (generate.c's `ApplyProd` moves
            // the string pointer past `predLen` before it decomposes).
            let end_off = st.run_end.unwrap_or(end_off);
            let mut ctx = |p: &Production, slots: &mut [f64], after: After<'_>| {
                recursion_contexts(p, slots, after, st, al, end_off)
            };
            return descend(rc, &cx, 0, p, rng, &mut ctx, out).map(|()| true);
        }
        if pass == Pass::Homomorphism && (hom_depth > 1 || warnings[1] || *hom_tries) {
            // The successor has depth 1; contexts are those of the
            // original module, at every depth.
            rc.slots[..p.nslots()].copy_from_slice(&slots[..p.nslots()]);
            let cx = RecCtx {
                table,
                max: hom_depth,
                al,
                origin,
                pass,
                warn: warnings[1].then_some(&warned[1]),
                tries: *hom_tries,
                ahead: ahead(table),
            };
            // (cpfg's `InterpretHomomorphism` passes the contexts of the
            // module at depth 0 down: the right one right after that
            // module, also when its predecessor took several.)
            let mut ctx = |p: &Production, slots: &mut [f64], after: After<'_>| {
                recursion_contexts(p, slots, after, st, al, end_off)
            };
            return descend(rc, &cx, 1, p, rng, &mut ctx, out).map(|()| true);
        }
        chooser.successor(slots, p, rng, origin, pass, |piece| match piece {
            Piece::Const(c) => out.constant(c),
            Piece::Module(key, vals) => out.module(key, vals, al),
        })?;
        Ok(true)
    }
}

/// [`Deriver::apply`]'s choice for a `.l` file (cpfg's choice, and
/// predecessors of several modules, whose right context starts after the
/// run): out of line, so that the `.ls` path's loop holds none of it.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn choose_cpfg(
    chooser: &mut Chooser,
    slots: &mut [f64],
    (table, kr): (&Table, &KeyRules),
    rng: &mut Random,
    origin: &Origin,
    pass: Pass,
    st: &mut StepState,
    al: &Alphabet,
    last: Option<Option<u32>>,
    end_off: u64,
) -> Result<Option<u32>, Error> {
    if rng.cpfg_mut().is_none() {
        // (Predecessors of several modules without cpfg's generator: not
        // made by the front ends; the general choice.)
        return chooser.choose(slots, table, kr, rng, origin, pass, |p, slots| {
            run_contexts(p, slots, st, al, (last, pass), end_off)
        });
    }
    chooser.choose_cpfg_here(
        slots,
        table,
        kr,
        rng,
        origin,
        pass,
        #[inline(always)]
        |p, slots| run_contexts(p, slots, st, al, (last, pass), end_off),
    )
}

/// Does `p`, a predecessor of one module or of several (cpfg dialect),
/// match at the module ending at `end_off`, with its contexts? Binds the
/// run's and the contexts' parameters. The right context of a run starts
/// after it among the L-system's productions (generate.c's `FindProd`
/// reads it at `curPtr + preflength`), right after its first module in
/// the homomorphism (interpret.c's `TurtleDrawNsteps` passes the string
/// pointer past that one module as `InterpretHomomorphism`'s right
/// context).
#[inline(always)]
fn run_contexts(
    p: &Production,
    slots: &mut [f64],
    st: &mut StepState,
    al: &Alphabet,
    (last, pass): (Option<Option<u32>>, Pass),
    end_off: u64,
) -> Result<bool, Error> {
    let end = if p.rest().is_empty() {
        end_off
    } else {
        match st.match_run(end_off, p.rest(), al, Some(slots))? {
            Some(_) if pass == Pass::Homomorphism => end_off,
            Some(e) => e,
            None => return Ok(false),
        }
    };
    Ok(!surely_not(p, last, end, st, al)? && contexts_match(p, end, st, al, slots)?)
}

/// Does `p` match in the recursion (decomposition, a deep homomorphism):
/// the rest of its predecessor where `after` says (cpfg's `PredDiff`
/// first), then its contexts, read in the old string around the module
/// the recursion started from, whose right context starts at `end_off`
/// (cpfg passes the same context pointers down to every depth)? Binds
/// their parameters.
#[inline]
fn recursion_contexts(
    p: &Production,
    slots: &mut [f64],
    after: After,
    st: &mut StepState,
    al: &Alphabet,
    end_off: u64,
) -> Result<bool, Error> {
    let run = match after {
        _ if p.rest().is_empty() => true,
        After::Level(buf, from) => level_run(buf, from, p.rest(), al, slots),
        After::Input(end) => st.match_run(end, p.rest(), al, Some(slots))?.is_some(),
    };
    let last = st.left.as_ref().map(|l| l.last_key());
    Ok(run && !surely_not(p, last, end_off, st, al)? && contexts_match(p, end_off, st, al, slots)?)
}

/// The choice `of` gives each ASCII key without parameters that has one
/// ([`Folded`], [`Neighbours`]), indexed by the key (empty if none has).
/// Not for brackets, nor the cut `%` (`cut`), whose copy is a cut.
fn one_byte_keys<'t, T>(
    table: &'t Table,
    al: &Alphabet,
    cut: bool,
    of: impl Fn(&'t Table, &'t KeyRules) -> Option<T>,
) -> Vec<Option<T>> {
    let mut keys: Vec<Option<T>> = Vec::new();
    for b in 0..128u32 {
        if b == OPEN || b == CLOSE || (cut && b == u32::from(b'%')) {
            continue;
        }
        let Some(kr) = table.get(b) else {
            continue;
        };
        if al.arity(b) != 0 {
            continue;
        }
        if let Some(f) = of(table, kr) {
            keys.resize_with(b as usize + 1, || None);
            keys[b as usize] = Some(f);
        }
    }
    keys
}

/// A pass left a `[` open: blame `culprit`, the last production that
/// opened more than it closed.
pub(crate) fn unclosed(origin: &Origin, table: &Table, culprit: Option<u32>, pass: Pass) -> Error {
    let p = &table.prods[culprit.unwrap_or(0) as usize];
    Error::at(
        origin.locate(p.start()),
        crate::diag::RuntimeError::UnclosedBracket(pass),
    )
}

/// A step made a `]` without `[`: blame `culprit`.
pub(crate) fn unbalanced(
    origin: &Origin,
    table: &Table,
    culprit: Option<u32>,
    pass: Pass,
) -> Error {
    let p = &table.prods[culprit.unwrap_or(0) as usize];
    Error::at(
        origin.locate(p.start()),
        crate::diag::RuntimeError::UnopenedBracket(pass),
    )
}

/// A cheap first look: do the nearest context modules already differ?
/// `last`: the nearest considered module to the left, if left contexts are
/// kept. (Fills the right-context cache on first use for this module.)
#[inline(always)]
fn surely_not(
    p: &Production,
    last: Option<Option<u32>>,
    end_off: u64,
    st: &mut StepState,
    al: &Alphabet,
) -> Result<bool, Error> {
    if let (Some(pat), Some(last)) = (p.left().last(), last) {
        if last != Some(pat.key) {
            return Ok(true);
        }
    }
    if p.right_simple() {
        let right = st.right_of(end_off, al)?;
        if let (Some(RPat::Module(pat)), first) = (p.right().first(), right.modules.keys.first()) {
            if first != Some(&pat.key) {
                return Ok(true);
            }
        }
    }
    Ok(false)
}

/// cpfg's right contexts (a `.l` file), kept out of line so that
/// [`contexts_match`] stays as small as the `.ls` path needs.
#[inline(never)]
fn right_cpfg(
    p: &Production,
    end_off: u64,
    st: &mut StepState,
    al: &Alphabet,
    slots: &mut [f64],
    passed: CpfgBrackets,
) -> Result<bool, Error> {
    let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
    // From just after the predecessor, at its level; where no bracket is
    // passed over, from past the ignored run after it, as every pattern
    // element passes over ignored modules first (a run walked once per
    // pass, not once for each of its modules: a run of 10,000 ignored
    // modules that have productions with right contexts took 10^8 reads).
    let start = if passed.open || passed.close {
        end_off
    } else {
        st.right_start(end_off, al).map_err(read_err)?
    };
    let level = st.level();
    let peek = st.peek.as_mut().unwrap();
    let chains = (&mut st.chains, level);
    match_right_cpfg(peek, al, start, p.right(), slots, passed, chains).map_err(read_err)
}

/// Do production `p`'s contexts match here? Binds their parameters.
#[inline]
fn contexts_match(
    p: &Production,
    end_off: u64,
    st: &mut StepState,
    al: &Alphabet,
    slots: &mut [f64],
) -> Result<bool, Error> {
    if !p.left().is_empty() && !st.left.as_ref().unwrap().matches(p.left(), al, slots) {
        return Ok(false);
    }
    if p.right_simple() {
        let right = st.right_of(end_off, al)?;
        if !right.matches(p.right(), al, slots) {
            return Ok(false);
        }
    } else if !p.right().is_empty() {
        let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
        if let Some(passed) = st.cpfg {
            return right_cpfg(p, end_off, st, al, slots, passed);
        }
        // Matching from past the ignored run is the same: every pattern
        // element passes over ignored modules first.
        let start = st.right_start(end_off, al).map_err(read_err)?;
        let level = st.level();
        let peek = st.peek.as_mut().unwrap();
        if !match_right(peek, al, start, p.right(), slots, &mut st.chains, level)
            .map_err(read_err)?
        {
            return Ok(false);
        }
    }
    Ok(true)
}
