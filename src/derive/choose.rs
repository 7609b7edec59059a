//! Production choice and successor evaluation, shared by every strategy
//! (the step engine and depth first): which production of a module's
//! group wins (conditions, weights, the draw), then the successor's
//! parameters evaluated left to right.

use super::random::{Draw, Random};
use super::{Origin, Pass};
use crate::cpfg::random::select;
use crate::diag::{Error, RandomError};
use crate::rules::expr::Code;
use crate::rules::{ConstRun, Item, KeyRules, Production, Table};

/// A `.l` file's productions of a key: one list (the front end merges
/// them).
#[inline(always)]
fn cpfg_list<'t>(table: &'t Table, kr: &'t KeyRules) -> &'t [u32] {
    if kr.has_context() {
        table.context(kr)
    } else {
        table.free(kr)
    }
}

/// One piece of a successor, in string order.
pub(crate) enum Piece<'a> {
    /// A precompiled run of modules without parameter expressions.
    Const(&'a ConstRun),
    /// A module with evaluated parameters.
    Module(u32, &'a [f64]),
}

/// The weighted draw (README "Choice"): which of the matching
/// candidates `cand` (production, weight > 0; not empty), whose weights
/// add up to `total` in order, wins. One candidate wins without a draw.
/// Every weighted choice of an `.ls` file draws here.
#[inline(always)]
pub(crate) fn pick(
    cand: &[(u32, f64)],
    total: f64,
    rng: &mut Random,
    table: &Table,
    origin: &Origin,
    pass: Pass,
) -> Result<usize, Error> {
    draw_weighted(rng, total, cand.len(), |i| cand[i].1).map_err(|m| {
        let p = &table.prods[cand[0].0 as usize];
        Error::at(
            origin.locate(p.start()),
            crate::diag::RuntimeError::Eval {
                error: crate::diag::ExprError::Random(m),
                pass,
            },
        )
    })
}

/// Which of `n` (> 0) candidates of weights `w(i)`, adding up to `total`
/// in order, the current module's draw picks; one wins without a draw.
/// The one copy of the weighted choice, for [`pick`] and the byte table's
/// folded keys.
#[inline(always)]
pub(crate) fn draw_weighted(
    rng: &mut Random,
    total: f64,
    n: usize,
    w: impl Fn(usize) -> f64,
) -> Result<usize, RandomError> {
    if n == 1 {
        return Ok(0);
    }
    // (Each weight is finite; their sum may not be. An infinite total
    // made every draw pick the last positive weight.)
    if !total.is_finite() {
        return Err(RandomError::WeightsOverflow);
    }
    let mut u = rng.uniform()? * total;
    let mut i = 0;
    while i < n - 1 {
        u -= w(i);
        if u < 0.0 {
            break;
        }
        i += 1;
    }
    Ok(i)
}

/// [`pick`] out of line: the general choice's, so that the step pass's
/// loop (which holds the choice) stays as small as without it.
#[inline(never)]
fn pick_out_of_line(
    cand: &[(u32, f64)],
    total: f64,
    rng: &mut Random,
    table: &Table,
    origin: &Origin,
    pass: Pass,
) -> Result<usize, Error> {
    pick(cand, total, rng, table, origin, pass)
}

/// A key whose choice depends on nothing but the draw, folded once per
/// pass: what [`Chooser::choose_ls`] computes for it at every module. Its
/// productions are one context-free group (no context group, no numbered
/// group's fallback), none has a condition, each weight is a constant
/// that is not negative (a negative one is an error at each module that
/// tries it: the general path reports it), and each successor is known at
/// load time.
pub(crate) struct Folded {
    /// The candidates of weight > 0, in file order, and their sum as the
    /// choice adds it up; never empty.
    pub(crate) cand: Box<[(u32, f64)]>,
    pub(crate) total: f64,
}

impl Folded {
    /// `kr`'s folded choice, if it depends on nothing but the draw.
    pub(crate) fn of(table: &Table, kr: &KeyRules) -> Option<Folded> {
        if kr.has_context() || kr.fallback().is_some() || !kr.free_stochastic() {
            return None;
        }
        let mut cand = Vec::new();
        let mut total = 0.0;
        for &pi in table.free(kr) {
            let p = &table.prods[pi as usize];
            if !p.context_free() || p.cond.is_some() {
                return None;
            }
            if !p.succ.iter().all(|i| matches!(i, Item::Const(_))) {
                return None;
            }
            let w = match p.prob() {
                None => 1.0,
                Some(c) => c.constant().filter(|w| w.is_nan() || *w >= 0.0)?,
            };
            if w > 0.0 {
                total += w;
                cand.push((pi, w));
            }
        }
        (!cand.is_empty()).then(|| Folded {
            cand: cand.into_boxed_slice(),
            total,
        })
    }
}

/// A key whose choice depends on nothing but the keys of the nearest
/// considered modules left and right of its module, each a one-byte module
/// (ASCII, no parameters): what [`Chooser::choose_ls`] computes for it at
/// every module, as a list. Its productions are a deterministic context
/// group (no condition, no weight), each context at most one module of
/// such a key, and optionally a deterministic context-free group whose
/// first production (no condition) wins when no context matches; no
/// numbered group's fallback; every successor known at load time.
pub(crate) struct Neighbours<'t> {
    /// The context group in order.
    prods: Box<[ByNeighbours<'t>]>,
    /// When none matches: the free group's winner, or the module is
    /// copied (None).
    otherwise: Pick<'t>,
}

/// A successor known at load time: None if empty.
pub(crate) type Successor<'t> = Option<&'t ConstRun>;

/// What a step writes for a module: a successor, or None: the module
/// copied.
pub(crate) type Pick<'t> = Option<Successor<'t>>;

/// A production of a [`Neighbours`] key: its left and right context
/// keys (None where it has no such context) and its successor.
struct ByNeighbours<'t> {
    left: Option<u32>,
    right: Option<u32>,
    succ: Successor<'t>,
}

impl<'t> Neighbours<'t> {
    /// `kr`'s choice by neighbours, if it depends on nothing else.
    pub(crate) fn of(table: &'t Table, kr: &KeyRules) -> Option<Neighbours<'t>> {
        if !kr.has_context() || kr.fallback().is_some() || kr.context_stochastic() {
            return None;
        }
        let succ = |p: &'t Production| -> Option<Successor<'t>> {
            if p.cond.is_some() || p.pre().is_some() || p.post().is_some() || !p.rest().is_empty() {
                return None;
            }
            match &*p.succ {
                [] => Some(None),
                [Item::Const(c)] => Some(Some(c)),
                _ => None,
            }
        };
        let byte = |k: u32| (k < 128).then_some(k);
        let mut prods = Vec::new();
        for &pi in table.context(kr) {
            let p = &table.prods[pi as usize];
            let left = match p.left() {
                [] => None,
                [pat] => Some(byte(pat.key)?),
                _ => return None,
            };
            let right = match p.right() {
                [] => None,
                [crate::rules::RPat::Module(pat)] => Some(byte(pat.key)?),
                _ => return None,
            };
            prods.push(ByNeighbours {
                left,
                right,
                succ: succ(p)?,
            });
        }
        let otherwise = if kr.has_free() {
            if kr.free_stochastic() {
                return None;
            }
            let p = &table.prods[*table.free(kr).first()? as usize];
            if !p.context_free() {
                return None;
            }
            Some(succ(p)?)
        } else {
            None
        };
        Some(Neighbours {
            prods: prods.into_boxed_slice(),
            otherwise,
        })
    }

    /// The left and right context keys the productions ask for.
    pub(crate) fn keys(&self) -> impl Iterator<Item = (Option<u32>, Option<u32>)> + '_ {
        self.prods.iter().map(|p| (p.left, p.right))
    }

    /// What the step writes for a module whose nearest considered
    /// modules are `left` and `right` (None: none, or not a one-byte
    /// module).
    pub(crate) fn pick(&self, left: Option<u32>, right: Option<u32>) -> Pick<'t> {
        for p in self.prods.iter() {
            if p.left.is_none_or(|l| left == Some(l)) && p.right.is_none_or(|r| right == Some(r)) {
                return Some(p.succ);
            }
        }
        self.otherwise
    }
}

/// The reusable buffers of choice and evaluation: nothing is allocated per
/// module once they have grown. The formal parameters of the production
/// being tried (the predecessor's first, then its contexts') are the
/// caller's `slots`: the step engine binds them there, depth first they
/// are the module's own parameters, not copied.
#[derive(Default)]
pub(crate) struct Chooser {
    stack: Vec<f64>,
    vals: Vec<f64>,
    /// Matching candidates of a weighted group, with their bindings.
    cand: Vec<(u32, f64)>,
    cand_slots: Vec<f64>,
    /// The module's bound parameters before a cpfg pre-condition block
    /// could assign to them ([`Chooser::rebind`]).
    bound: Vec<f64>,
    /// Chooses for decomposition or a deep homomorphism: in a `.l` file,
    /// always the first applicable production, no draw.
    pub(crate) nested: bool,
}

impl Chooser {
    /// The chooser of decomposition and deep homomorphisms.
    pub(crate) fn nested() -> Chooser {
        Chooser {
            nested: true,
            ..Chooser::default()
        }
    }

    /// The production of `kr` that rewrites the bound module: the context
    /// group first, then the context-free one (see README, "Choice").
    /// The choice policy is in `kr`'s lists: for the cpfg dialect (first
    /// applicable in file order, context or not) `rules::compile_table`
    /// puts every production of a key that has a context one into the
    /// context group, in file order, so this one loop serves both.
    /// `contexts(p, slots)` tells whether `p`'s contexts match here,
    /// binding their parameters into `slots`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn choose<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        kr: &KeyRules,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        mut contexts: F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        if rng.cpfg_mut().is_some() {
            return self.choose_cpfg(
                slots,
                table,
                cpfg_list(table, kr),
                rng,
                origin,
                pass,
                &mut contexts,
            );
        }
        self.choose_ls(slots, table, kr, rng, origin, pass, contexts)
    }

    /// [`Chooser::choose`] for a `.l` file (`rng` is cpfg's), inlined: the
    /// step engine's own out-of-line cpfg choice calls it.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn choose_cpfg_here<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        kr: &KeyRules,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        mut contexts: F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        self.choose_cpfg_in(
            slots,
            table,
            cpfg_list(table, kr),
            rng,
            origin,
            pass,
            &mut contexts,
        )
    }

    /// The first of `kr`'s productions that applies, as cpfg tries them
    /// (contexts, pre-condition block, condition), without applying it:
    /// its post-condition block does not run. For the depth limit, where
    /// cpfg's `InterpretHomomorphism` and `ApplyRecursiveProductions` try
    /// a module's productions, then keep the module (with a warning if
    /// one applies): a homomorphism of `maximum depth:` 0, and the limit
    /// of the recursion (`step::depth_limit_cpfg`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn first_cpfg<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        kr: &KeyRules,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        mut contexts: F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        self.hom_conditions(rng, pass);
        let list = cpfg_list(table, kr);
        self.first_matching_cpfg(slots, table, list, rng, origin, pass, &mut contexts)
    }

    /// Conditions at the top of a cpfg homomorphism draw on cpfg's first
    /// function generator (a homomorphism `seed:` is for successors).
    fn hom_conditions(&self, rng: &mut Random, pass: Pass) {
        if pass == Pass::Homomorphism && !self.nested {
            if let Some(c) = rng.cpfg_mut() {
                c.hom_condition();
            }
        }
    }

    /// The first production of `list` that matches (contexts,
    /// pre-condition block, condition), its parameters bound in `slots`.
    #[allow(clippy::too_many_arguments)]
    fn first_matching_cpfg<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        list: &[u32],
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        contexts: &mut F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        let mut saved = false;
        for &pi in list {
            let p = &table.prods[pi as usize];
            self.rebind(slots, p, &mut saved);
            if self.matches_cpfg(slots, p, rng, origin, pass, contexts)? {
                return Ok(Some(pi));
            }
        }
        Ok(None)
    }

    /// cpfg binds a production's formal parameters from the string each
    /// time it tries one (generate.c's `CondDiff` calls `CreateVarTable`),
    /// so what a pre-condition block assigned to them is gone for the next
    /// production tried. Before the first production with such a block the
    /// bindings are saved (`saved`), and restored before every later try.
    #[inline(always)]
    fn rebind(&mut self, slots: &mut [f64], p: &Production, saved: &mut bool) {
        if *saved {
            slots.copy_from_slice(&self.bound);
        } else if p.pre().is_some() {
            self.bound.clear();
            self.bound.extend_from_slice(slots);
            *saved = true;
        }
    }

    /// [`Chooser::choose`] for an `.ls` file (`rng` is not cpfg's): the
    /// step engine decides that once per pass, so its hot loop holds no
    /// cpfg path.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn choose_ls<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        kr: &KeyRules,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        mut contexts: F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        let mut chosen = None;
        let mut kr = kr;
        loop {
            if kr.has_context() {
                let group = (table.context(kr), kr.context_stochastic(), false);
                chosen = self.choose_in(slots, table, group, rng, origin, pass, &mut contexts)?;
            }
            if chosen.is_none() && kr.has_free() {
                let group = (table.free(kr), kr.free_stochastic(), true);
                chosen = self.choose_in(slots, table, group, rng, origin, pass, &mut contexts)?;
            }
            // A numbered group that chose nothing falls back to group 0.
            match (&chosen, kr.fallback()) {
                (None, Some(f)) => kr = f,
                _ => break,
            }
        }
        Ok(chosen)
    }

    /// Does `p` match: contexts, then its condition? `free`: `p` is of a
    /// context-free group, whose productions may skip the context test.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn matches<F>(
        &mut self,
        slots: &mut [f64],
        free: bool,
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        contexts: &mut F,
    ) -> Result<bool, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        // (Without contexts there is nothing to test or bind. A context
        // group's productions have contexts: no flag to test there.)
        let none = free && p.context_free();
        if !none && !contexts(p, slots)? {
            return Ok(false);
        }
        self.condition(slots, p, rng, origin, pass)
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn choose_in<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        (list, stochastic, free): (&[u32], bool, bool),
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        contexts: &mut F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        if !stochastic {
            for &pi in list {
                let p = &table.prods[pi as usize];
                if self.matches(slots, free, p, rng, origin, pass, contexts)? {
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
            if !self.matches(slots, free, p, rng, origin, pass, contexts)? {
                continue;
            }
            let w = self.weight(slots, p, rng, origin, pass)?;
            if w > 0.0 {
                total += w;
                self.cand.push((pi, w));
                self.cand_slots.extend_from_slice(&slots[..p.nslots()]);
            }
        }
        if self.cand.is_empty() {
            return Ok(None);
        }
        let pick = pick_out_of_line(&self.cand, total, rng, table, origin, pass)?;
        Ok(Some(self.restore(slots, table, pick)))
    }

    /// A matching production's weight (1 without one); negative is an
    /// error. Both dialects' weighted choices.
    #[inline(always)]
    fn weight(
        &mut self,
        slots: &mut [f64],
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
    ) -> Result<f64, Error> {
        let Some(c) = p.prob() else {
            return Ok(1.0);
        };
        // (A constant is what `eval` would return, without the call.)
        let w = match c.constant() {
            Some(v) => v,
            None => c
                .eval(slots, &mut self.stack, rng)
                .map_err(|e| origin.eval_error(e, pass))?,
        };
        if w < 0.0 {
            return Err(Error::at(
                origin.locate(c.start()),
                crate::diag::RuntimeError::NegativeProbability { value: w, pass },
            ));
        }
        Ok(w)
    }

    /// A matching production's weight in cpfg's choice (1 without one):
    /// any value, a negative one included, as cpfg's
    /// `FindApplProductions` adds it to the total and `SelectProd`
    /// subtracts it ([`crate::cpfg::random::select`]).
    #[inline(always)]
    fn weight_cpfg(
        &mut self,
        slots: &mut [f64],
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
    ) -> Result<f64, Error> {
        match p.prob() {
            None => Ok(1.0),
            Some(c) => c
                .eval(slots, &mut self.stack, rng)
                .map_err(|e| origin.eval_error(e, pass)),
        }
    }

    /// Candidate `pick` of a weighted choice: its production, with its
    /// bindings restored into `slots`.
    #[inline(always)]
    fn restore(&self, slots: &mut [f64], table: &Table, pick: usize) -> u32 {
        let pi = self.cand[pick].0;
        let off: usize = self.cand[..pick]
            .iter()
            .map(|(q, _)| table.prods[*q as usize].nslots())
            .sum();
        let n = table.prods[pi as usize].nslots();
        slots[..n].copy_from_slice(&self.cand_slots[off..off + n]);
        pi
    }

    /// cpfg's choice (a `.l` file, README "Coming from cpfg"): the first
    /// applicable production in file order; with `seed:`, `SelectProd`
    /// over all applicable ones (weights as 32-bit floats, weight 0
    /// competing) with the module's draw from cpfg's choice generator.
    /// The chosen production's post-condition block runs before this
    /// returns, its successor right after. Out of line: the `.ls` path
    /// pays one test per module for it.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn choose_cpfg<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        list: &[u32],
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        contexts: &mut F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        self.choose_cpfg_in(slots, table, list, rng, origin, pass, contexts)
    }

    /// The body of [`Chooser::choose_cpfg`].
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn choose_cpfg_in<F>(
        &mut self,
        slots: &mut [f64],
        table: &Table,
        list: &[u32],
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        contexts: &mut F,
    ) -> Result<Option<u32>, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        self.hom_conditions(rng, pass);
        // With `seed:` every production competes, weighted 1 by default.
        let stochastic = rng.cpfg_mut().is_some_and(|c| c.stochastic);
        if !stochastic || self.nested || !matches!(pass, Pass::Step(_)) {
            let Some(pi) =
                self.first_matching_cpfg(slots, table, list, rng, origin, pass, contexts)?
            else {
                return Ok(None);
            };
            let p = &table.prods[pi as usize];
            return self.post(slots, p, rng, origin, pass).map(|()| Some(pi));
        }
        self.cand.clear();
        self.cand_slots.clear();
        let mut saved = false;
        for &pi in list {
            let p = &table.prods[pi as usize];
            self.rebind(slots, p, &mut saved);
            if !self.matches_cpfg(slots, p, rng, origin, pass, contexts)? {
                continue;
            }
            let w = self.weight_cpfg(slots, p, rng, origin, pass)?;
            self.cand.push((pi, w));
            self.cand_slots.extend_from_slice(&slots[..p.nslots()]);
        }
        let Some(u) = rng.cpfg_choice() else {
            return Ok(None);
        };
        let Some(pick) = select(self.cand.iter().map(|&(_, w)| w as f32), u) else {
            return Ok(None);
        };
        let pi = self.restore(slots, table, pick);
        let p = &table.prods[pi as usize];
        self.post(slots, p, rng, origin, pass).map(|()| Some(pi))
    }
    /// `p`'s condition (true without one), in both dialects.
    #[inline(always)]
    fn condition(
        &mut self,
        slots: &mut [f64],
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
    ) -> Result<bool, Error> {
        match &p.cond {
            None => Ok(true),
            Some(c) => match c.eval(slots, &mut self.stack, rng) {
                Ok(v) => Ok(v != 0.0),
                Err(e) => Err(origin.eval_error(e, pass)),
            },
        }
    }

    /// [`Chooser::matches`] with cpfg's pre-condition block: contexts,
    /// the block (also when the condition then fails), the condition.
    #[inline(always)]
    fn matches_cpfg<F>(
        &mut self,
        slots: &mut [f64],
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        contexts: &mut F,
    ) -> Result<bool, Error>
    where
        F: FnMut(&Production, &mut [f64]) -> Result<bool, Error>,
    {
        if !p.context_free() && !contexts(p, slots)? {
            return Ok(false);
        }
        if let Some(b) = p.pre() {
            b.run(slots, &mut self.stack, rng)
                .map_err(|e| origin.eval_error(e, pass))?;
        }
        self.condition(slots, p, rng, origin, pass)
    }

    /// cpfg's post-condition block of the chosen production `p` (locals in
    /// `slots`), before its successor is evaluated.
    #[inline]
    fn post(
        &mut self,
        slots: &mut [f64],
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
    ) -> Result<(), Error> {
        if pass == Pass::Homomorphism && !self.nested {
            // The homomorphism's `seed:` generator, from here on for this
            // module (successor, deeper homomorphism).
            if let Some(c) = rng.cpfg_mut() {
                c.hom_successor();
            }
        }
        match p.post() {
            Some(b) => b
                .run(slots, &mut self.stack, rng)
                .map_err(|e| origin.eval_error(e, pass)),
            None => Ok(()),
        }
    }

    /// Evaluate `p`'s successor with the bound parameters, handing each
    /// piece to `emit` in string order.
    #[inline(always)]
    pub(crate) fn successor<F>(
        &mut self,
        slots: &[f64],
        p: &Production,
        rng: &mut Random,
        origin: &Origin,
        pass: Pass,
        mut emit: F,
    ) -> Result<(), Error>
    where
        F: FnMut(Piece) -> Result<(), Error>,
    {
        for item in &p.succ {
            match item {
                Item::Const(c) => emit(Piece::Const(c))?,
                Item::Module { key, params } => {
                    self.vals.clear();
                    eval_into(
                        params,
                        slots,
                        (&mut self.stack, rng),
                        origin,
                        pass,
                        &mut self.vals,
                    )?;
                    emit(Piece::Module(*key, &self.vals))?;
                }
            }
        }
        Ok(())
    }
}

/// A successor module's parameters evaluated while its successor is walked
/// a module at a time (depth first, and the recursion's wide successors:
/// neither holds a whole evaluated successor per level).
///
/// [`Evals::start`] evaluates the successor's computed modules in string
/// order before anything of it is rewritten, as evaluating the whole
/// successor would: a failing module stops the run there (not after
/// expanding the modules before it, which may be endless), and draws,
/// warnings and reads of a variable that blocks assign come in cpfg's
/// order. It keeps the values of every computed module of a successor of
/// at most `keep_all` of them ([`KEEP_ALL`] but in tests); in a wider one,
/// those of the modules whose evaluation draws, warns or reads such a
/// variable ([`Evals::keeps`], asked again as the walk reaches each module
/// when some are kept), and [`Evals::next`] evaluates the others again as
/// the walk reaches them, with the same bound parameters (so the same
/// values). A walk so holds at most `keep_all` modules' values plus those
/// with effects, and nothing per module of the successor.
#[derive(Default)]
pub(crate) struct Evals {
    /// The kept values, in string order, and where the next one starts.
    vals: Vec<f64>,
    at: usize,
    /// Every computed module is kept.
    all: bool,
    /// Else: some module is ([`Evals::keeps`] says which).
    some: bool,
}

/// A walked successor with at most this many computed modules keeps all
/// their values ([`Evals`]).
pub(crate) const KEEP_ALL: usize = 64;

impl Evals {
    /// Start a walk of the successor `succ`, whose parameters are bound to
    /// `slots`: evaluate its computed modules, keeping all of them if at
    /// most `keep_all` (see [`Evals`]).
    #[inline(always)]
    pub(crate) fn start(
        &mut self,
        ch: &mut Chooser,
        (succ, keep_all): (&[Item], usize),
        (slots, rng): (&[f64], &mut Random),
        (origin, pass): (&Origin, Pass),
    ) -> Result<(), Error> {
        self.vals.clear();
        self.at = 0;
        self.some = false;
        let computed = succ
            .iter()
            .filter(|i| matches!(i, Item::Module { .. }))
            .take(keep_all + 1)
            .count();
        self.all = computed <= keep_all;
        let stack = &mut ch.stack;
        for item in succ {
            let Item::Module { params, .. } = item else {
                continue;
            };
            let keep = self.all || Evals::keeps(params);
            self.some |= keep;
            if keep || params.iter().any(Code::may_warn_or_fail) {
                let len = self.vals.len();
                eval_into(params, slots, (stack, rng), origin, pass, &mut self.vals)?;
                if !keep {
                    self.vals.truncate(len);
                }
            }
        }
        Ok(())
    }

    /// Does a wider successor keep the values of a module whose parameters
    /// are `codes`? Where evaluating it again would draw, warn or read a
    /// variable again (that a block below may have assigned since).
    fn keeps(codes: &[Code]) -> bool {
        codes
            .iter()
            .any(|c| c.uses_random() || c.may_warn() || c.reads_state())
    }

    /// The parameters of the successor's next computed module (`codes`,
    /// bound to `slots`), in `into`.
    #[inline(always)]
    pub(crate) fn next(
        &mut self,
        ch: &mut Chooser,
        codes: &[Code],
        (slots, rng): (&[f64], &mut Random),
        (origin, pass): (&Origin, Pass),
        into: &mut Vec<f64>,
    ) -> Result<(), Error> {
        into.clear();
        if self.all || (self.some && Evals::keeps(codes)) {
            let at = self.at;
            self.at += codes.len();
            into.extend_from_slice(&self.vals[at..self.at]);
            Ok(())
        } else {
            eval_into(codes, slots, (&mut ch.stack, rng), origin, pass, into)
        }
    }
}

/// The one loop that evaluates a successor module's parameters, left to
/// right, appending them to `into`.
#[inline(always)]
fn eval_into(
    codes: &[Code],
    slots: &[f64],
    (stack, rng): (&mut Vec<f64>, &mut Random),
    origin: &Origin,
    pass: Pass,
    into: &mut Vec<f64>,
) -> Result<(), Error> {
    for c in codes {
        match c.eval(slots, stack, rng) {
            Ok(v) => into.push(v),
            Err(e) => return Err(origin.eval_error(e, pass)),
        }
    }
    Ok(())
}
