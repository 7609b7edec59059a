//! Context matching. Left contexts: the considered modules on the path to
//! the current one, kept per open branch. Right contexts: walked by the
//! look-ahead reader over the same generation file.

use super::reader::PosReader;
use crate::rules::codec::{self, Modules};
use crate::rules::{Alphabet, Pat, RPat, Table, CLOSE, OPEN};
use std::collections::HashMap;
use std::io;

/// Left context: the considered modules on the path from the start of the
/// string to the current module, as one shared stack. Each open branch
/// (level) owns a segment at the top of its parent's and keeps at most the
/// last k of its own modules there (a ring once full); a left context is
/// read backwards through the current level, then its ancestors. Opening a
/// branch copies nothing, so memory is the modules kept per level (at most
/// k each, and no more than the level has) plus O(1) per level: a long
/// context and deep nesting do not multiply. Only the parameters of keys
/// that some left context asks for are kept, up to their largest arity.
/// A clone is the state at one point of a scan: a chunk of a split pass
/// starts from it (`super::split`).
pub(crate) struct LeftContext {
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
    /// The nearest considered module to the left ([`LeftContext::last_key`]),
    /// or [`NO_KEY`]: kept as modules are pushed and branches close, so the
    /// step's byte table reads it without walking the levels.
    last: u32,
}

/// No module (for [`LeftContext::last`]).
const NO_KEY: u32 = u32::MAX;

/// No such level.
pub(crate) const NONE: usize = usize::MAX;

#[derive(Clone, Copy)]
pub(crate) struct Level {
    /// Where the level's own modules start in `keys`.
    start: usize,
    /// How many it keeps (at most k).
    cnt: usize,
    /// Ring index of the most recent one.
    head: usize,
    /// Nearest enclosing level that keeps any module, or NONE.
    up: usize,
    /// The nearest considered module to the left when the level opened
    /// (its parent's: [`LeftContext::last`] again once it closes).
    before: u32,
}

/// A copy holds the open levels only: `levels` keeps the deepest nesting
/// met so far for reuse, and a split pass copies the left context for
/// each chunk (`super::split`).
impl Clone for LeftContext {
    fn clone(&self) -> Self {
        LeftContext {
            k: self.k,
            width: self.width,
            wanted: self.wanted.clone(),
            depth: self.depth,
            keys: self.keys.clone(),
            params: self.params.clone(),
            levels: self.levels[..=self.depth].to_vec(),
            last: self.last,
        }
    }
}

impl LeftContext {
    /// The bytes a copy of it holds ([`Clone`]), about.
    pub(crate) fn copy_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.wanted.len()
            + self.keys.len() * std::mem::size_of::<u32>()
            + self.params.len() * std::mem::size_of::<f64>()
            + (self.depth + 1) * std::mem::size_of::<Level>()
    }

    /// The left context `tables` need together (a step's productions and
    /// the decomposition, whose contexts are read in the same string).
    pub(crate) fn new_for(tables: &[&Table], al: &Alphabet) -> Self {
        let k = tables.iter().map(|t| t.max_left).max().unwrap_or(0);
        let mut wanted = Vec::new();
        let mut width = 0;
        for p in tables.iter().flat_map(|t| t.prods.iter()) {
            for pat in p.left() {
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
                before: NO_KEY,
            }],
            last: NO_KEY,
        }
    }

    #[inline]
    pub(crate) fn open(&mut self) {
        let d = self.depth;
        let cur = self.levels[d];
        let child = Level {
            start: self.keys.len(),
            cnt: 0,
            head: 0,
            up: if cur.cnt > 0 { d } else { cur.up },
            before: self.last,
        };
        self.depth += 1;
        if self.levels.len() <= self.depth {
            self.levels.push(child);
        } else {
            self.levels[self.depth] = child;
        }
    }

    #[inline]
    pub(crate) fn close(&mut self) {
        if self.depth == 0 {
            return; // unbalanced: reported by the balance check
        }
        let Level { start, before, .. } = self.levels[self.depth];
        self.keys.truncate(start);
        self.params.truncate(start * self.width);
        self.depth -= 1;
        self.last = before;
    }

    /// The nearest considered module to the left, if any.
    #[inline(always)]
    pub(crate) fn last_key(&self) -> Option<u32> {
        #[cfg(debug_assertions)]
        assert_eq!(self.walk_last(), (self.last != NO_KEY).then_some(self.last));
        (self.last != NO_KEY).then_some(self.last)
    }

    /// [`LeftContext::last_key`] from the levels (debug builds check the
    /// one kept against it).
    #[cfg(debug_assertions)]
    fn walk_last(&self) -> Option<u32> {
        let mut l = self.levels[self.depth];
        if l.cnt == 0 {
            if l.up == NONE {
                return None;
            }
            l = self.levels[l.up];
        }
        Some(self.keys[l.start + l.head])
    }

    /// Record the considered module `key`, encoded as `module` (key
    /// included), with `arity` parameters.
    #[inline(always)]
    pub(crate) fn push(&mut self, key: u32, module: &[u8], arity: usize) {
        let (k, w) = (self.k, self.width);
        let l = &mut self.levels[self.depth];
        let slot = if l.cnt < k {
            // The level's segment is the top of the stack.
            l.head = l.cnt;
            l.cnt += 1;
            self.keys.push(key);
            if w > 0 {
                self.params.resize(self.params.len() + w, 0.0);
            }
            l.start + l.head
        } else {
            l.head = if l.head + 1 == k { 0 } else { l.head + 1 };
            let slot = l.start + l.head;
            self.keys[slot] = key;
            slot
        };
        self.last = key;
        if self.wanted.get(key as usize).copied().unwrap_or(false) {
            codec::read_params(module, &mut self.params[slot * w..slot * w + arity]);
        }
    }

    /// Follow module `key` (encoded as `module`) of the string being
    /// read: a `[` opens a level, a `]` closes one, a considered module is
    /// recorded. The one rule both the step engine and the scan that splits
    /// a pass (`super::split`) keep the left context by.
    #[inline(always)]
    pub(crate) fn follow(&mut self, key: u32, module: &[u8], al: &Alphabet) {
        if key == OPEN {
            self.open();
        } else if key == CLOSE {
            self.close();
        } else if !al.ignored(key) {
            self.push(key, module, al.arity(key));
        }
    }

    /// The last k considered modules on the path to the current one,
    /// nearest last: (key, its first parameter if kept). Tests.
    #[cfg(test)]
    pub(crate) fn path(&self) -> Vec<(u32, Option<f64>)> {
        let mut v = Vec::new();
        let mut l = self.levels[self.depth];
        let (mut left, mut idx) = (l.cnt, l.head);
        while v.len() < self.k {
            while left == 0 {
                if l.up == NONE {
                    v.reverse();
                    return v;
                }
                l = self.levels[l.up];
                (left, idx) = (l.cnt, l.head);
            }
            let slot = l.start + idx;
            let key = self.keys[slot];
            let kept = self.width > 0 && self.wanted.get(key as usize).copied().unwrap_or(false);
            let p = kept.then(|| self.params[slot * self.width]);
            v.push((key, p));
            idx = if idx == 0 { l.cnt - 1 } else { idx - 1 };
            left -= 1;
        }
        v.reverse();
        v
    }

    /// Does the path to the current module end with `pat`? Binds its
    /// parameters.
    pub(crate) fn matches(&self, pat: &[Pat], al: &Alphabet, slots: &mut [f64]) -> bool {
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

/// The next considered modules right of the current one, read once per
/// module for all bracket-free right contexts.
pub(crate) struct RightCache {
    /// Offset the cache was filled from (u64::MAX: empty).
    pub(crate) at: u64,
    pub(crate) modules: Modules,
}

impl RightCache {
    pub(crate) fn new() -> Self {
        RightCache {
            at: u64::MAX,
            modules: Modules::default(),
        }
    }

    pub(crate) fn fill(
        &mut self,
        peek: &mut PosReader,
        al: &Alphabet,
        pos: u64,
        want: usize,
    ) -> io::Result<()> {
        self.at = pos;
        self.modules.clear();
        let mut pos = pos;
        while self.modules.len() < want {
            let Walk::Module {
                key, s, e, next, ..
            } = walk_right(peek, al, pos, true)?
            else {
                break;
            };
            pos = next;
            self.modules
                .push_encoded(key, peek.bytes(s, e), al.arity(key));
        }
        Ok(())
    }

    pub(crate) fn matches(&self, pat: &[RPat], al: &Alphabet, slots: &mut [f64]) -> bool {
        if pat.len() > self.modules.len() {
            return false;
        }
        for (i, r) in pat.iter().enumerate() {
            let RPat::Module(p) = r else {
                unreachable!("bracket in a simple right context")
            };
            if self.modules.keys[i] != p.key {
                return false;
            }
        }
        for (i, r) in pat.iter().enumerate() {
            if let RPat::Module(p) = r {
                let n = al.arity(p.key);
                let (_, params) = self.modules.get(i, n);
                slots[p.slot as usize..p.slot as usize + n].copy_from_slice(params);
            }
        }
        true
    }
}

/// Where the right-walker stopped.
pub(crate) enum Walk {
    /// A considered module at offset `at`, its bytes at `peek.bytes(s, e)`,
    /// `next` the offset just after it.
    Module {
        key: u32,
        s: usize,
        e: usize,
        at: u64,
        next: u64,
    },
    /// A `]`, the end of the string, or (without `skip_branches`) a `[`
    /// (`open`), at offset `at`.
    Stop { at: u64, open: bool },
}

/// The right-walker, the one loop behind every right context: from offset
/// `pos`, pass over ignored modules and, with `skip_branches`, over whole
/// branches `[...]` (in O(1) with a bracket index), to the next considered
/// module of the same branch. A `]` or the end of the string stops it: a
/// context never runs past the end of its own branch.
#[inline(always)]
pub(crate) fn walk_right(
    peek: &mut PosReader,
    al: &Alphabet,
    mut pos: u64,
    skip_branches: bool,
) -> io::Result<Walk> {
    loop {
        peek.seek(pos);
        let Some((key, s, e)) = peek.next_module(al)? else {
            return Ok(Walk::Stop {
                at: pos,
                open: false,
            });
        };
        let next = peek.offset();
        if key == OPEN {
            if !skip_branches {
                return Ok(Walk::Stop {
                    at: pos,
                    open: true,
                });
            }
            // A branch the pattern does not ask for: skip it whole.
            match peek.branch_end(al, s, next)? {
                Some(after) => pos = after,
                None => {
                    return Ok(Walk::Stop {
                        at: pos,
                        open: false,
                    })
                }
            }
            continue;
        }
        if key == CLOSE {
            return Ok(Walk::Stop {
                at: pos,
                open: false,
            });
        }
        if al.ignored(key) {
            pos = next;
            continue;
        }
        return Ok(Walk::Module {
            key,
            s,
            e,
            at: pos,
            next,
        });
    }
}

/// Walks kept per nesting level.
const WAYS: usize = 4;

/// Where the last walks over each nesting level ended: from any offset in
/// `lo..=hi` at that level, only ignored modules and whole branches lie
/// before `hi`, where the next considered module of the level (or its `]`,
/// or the end) is. So a stretch of ignored modules interleaved with
/// branches (`A[A]A[A]...B`) is walked once per step, however many modules
/// ask for a right context across it. A few per level, for patterns that
/// walk several stretches of one level; memory grows with the nesting
/// depth only.
///
/// Likewise the last [`skip_branch`] per level: from any offset in
/// `lo..after` at that level, the branch ends just before `after`, so the
/// modules of one long branch that each ask for a `]` in their right
/// context (`A > ]B` on `[AA...A]B`) scan it once, not once each.
///
/// And, per `[` of a right-context pattern and nesting level, the
/// consecutive branches in which the rest of the pattern was found not to
/// match, and the one after them where it did ([`open_branches`]), so that
/// no branch is tried twice for one `[` in a pass: not for each choice of
/// branches by the `[`s before it (`[A][A]...B` on a string of `[A]`s,
/// which would cost the branches to the power of the `[`s), nor for each
/// module of an ignored run that reaches the same branches.
#[derive(Default)]
pub(crate) struct Chains {
    ways: Vec<[(u64, u64); WAYS]>,
    turn: Vec<usize>,
    closes: Vec<(u64, u64)>,
    /// Some ignored module asks for a right context (the pass's
    /// `StepState::memo`): then the modules of one ignored run all reach
    /// the same branches, and `runs` is used for every pattern.
    pub(crate) across: bool,
    /// The pattern being matched has several `[`: `runs` is used for it.
    several: bool,
    /// Per `[` of a pattern (its rest's address and length) and nesting
    /// level: what its search of consecutive branches found.
    runs: HashMap<(usize, usize, usize), Tried>,
}

/// Consecutive branches tried by a `[` of a pattern ([`Chains`]`::runs`):
/// the first and the last in which the rest did not match, and the one
/// after them in which it did (None: none).
type Tried = (u64, u64, Option<u64>);

/// The most `(pattern, level)` entries [`Chains::runs`] holds (past that
/// it starts again).
const MAX_RUNS: usize = 1 << 12;

impl Chains {
    /// Where [`walk_right`] with `skip_branches` from `pos`, at nesting
    /// level `level` of the input, stops.
    #[inline]
    pub(crate) fn walk(
        &mut self,
        peek: &mut PosReader,
        al: &Alphabet,
        pos: u64,
        level: usize,
    ) -> io::Result<u64> {
        if let Some(ways) = self.ways.get(level) {
            for &(lo, hi) in ways {
                if lo <= pos && pos <= hi {
                    return Ok(hi);
                }
            }
        }
        let at = match walk_right(peek, al, pos, true)? {
            Walk::Module { at, .. } | Walk::Stop { at, .. } => at,
        };
        if at != pos {
            if self.ways.len() <= level {
                self.ways.resize(level + 1, [(u64::MAX, 0); WAYS]);
                self.turn.resize(level + 1, 0);
            }
            let t = self.turn[level];
            self.ways[level][t] = (pos, at);
            self.turn[level] = (t + 1) % WAYS;
        }
        Ok(at)
    }

    /// [`skip_branch`] from `pos`, at nesting level `level` of the input.
    #[inline]
    pub(crate) fn skip(
        &mut self,
        peek: &mut PosReader,
        al: &Alphabet,
        pos: u64,
        level: usize,
    ) -> io::Result<Option<u64>> {
        if let Some(&(lo, after)) = self.closes.get(level) {
            if lo <= pos && pos < after {
                return Ok(Some(after));
            }
        }
        let r = skip_branch(peek, al, pos)?;
        if let Some(after) = r {
            if self.closes.len() <= level {
                self.closes.resize(level + 1, (u64::MAX, 0));
            }
            self.closes[level] = (pos, after);
        }
        Ok(r)
    }
}

/// Match a right context starting at file offset `pos` (just after the
/// predecessor, at nesting `level`), binding parameters into `slots`.
pub(crate) fn match_right(
    peek: &mut PosReader,
    al: &Alphabet,
    pos: u64,
    pat: &[RPat],
    slots: &mut [f64],
    chains: &mut Chains,
    level: usize,
) -> io::Result<bool> {
    chains.several = pat.iter().filter(|&&p| p == RPat::Open).nth(1).is_some();
    match_right_from(peek, al, pos, pat, slots, chains, level)
}

/// [`match_right`] of the pattern's rest `pat`, from `pos` (at nesting
/// `level`).
fn match_right_from(
    peek: &mut PosReader,
    al: &Alphabet,
    pos: u64,
    pat: &[RPat],
    slots: &mut [f64],
    chains: &mut Chains,
    level: usize,
) -> io::Result<bool> {
    let Some((&first, rest)) = pat.split_first() else {
        return Ok(true);
    };
    match first {
        RPat::Module(p) => {
            let pos = chains.walk(peek, al, pos, level)?;
            let Walk::Module {
                key, s, e, next, ..
            } = walk_right(peek, al, pos, true)?
            else {
                return Ok(false);
            };
            if key != p.key {
                return Ok(false);
            }
            let n = al.arity(key);
            codec::read_params(
                peek.bytes(s, e),
                &mut slots[p.slot as usize..p.slot as usize + n],
            );
            match_right_from(peek, al, next, rest, slots, chains, level)
        }
        RPat::Open => {
            // Step over ignored modules to the first `[`, then try each of
            // the consecutive branches there.
            let Walk::Stop { at, open: true } = walk_right(peek, al, pos, false)? else {
                return Ok(false);
            };
            open_branches(peek, al, at, rest, slots, chains, level)
        }
        // cpfg's `=` comes only with cpfg's rules (`match_right_cpfg`).
        RPat::SkipRest => Ok(false),
        RPat::Close => {
            // The walk stays in the branch: skipping its rest from where
            // the walk stops is the same.
            let pos = chains.walk(peek, al, pos, level)?;
            match chains.skip(peek, al, pos, level)? {
                Some(after) => match_right_from(
                    peek,
                    al,
                    after,
                    rest,
                    slots,
                    chains,
                    level.saturating_sub(1),
                ),
                None => Ok(false),
            }
        }
    }
}

/// [`match_right_from`]'s `[`: try each of the consecutive branches from
/// the one at `start` on.
///
/// Where the pattern has several `[`, or an ignored module has a
/// right-context production (`chains.across`), the branches in which the
/// rest was found not to match (`chains.runs`, noted at the end of each
/// search) are not tried again, in this match or a later module's of the
/// pass: a search landing among them goes on at the branch after them
/// where the rest matched (matched again there, so its parameters bind)
/// or fails. Whether the rest matches in a branch depends only on the
/// branch (the pattern's elements before it fix the nesting; parameters
/// are only bound), and only ignored modules lie between consecutive
/// branches of one level, so a `[` of that level between the first and
/// the last branch noted is one of them.
#[allow(clippy::too_many_arguments)]
fn open_branches(
    peek: &mut PosReader,
    al: &Alphabet,
    start: u64,
    rest: &[RPat],
    slots: &mut [f64],
    chains: &mut Chains,
    level: usize,
) -> io::Result<bool> {
    let memo = chains.across || chains.several;
    let key = (rest.as_ptr() as usize, rest.len(), level);
    let mut pos = start;
    // The first and the last branch from which on, and up to which, the
    // rest did not match in any (a noted stretch met joins them).
    let mut from = start;
    let mut failed: Option<u64> = None;
    let matched = loop {
        if memo {
            if let Some(&(lo, hi, next)) = chains.runs.get(&key) {
                if lo <= pos && pos <= hi {
                    from = from.min(lo);
                    failed = Some(hi);
                    match next {
                        Some(n) => pos = n,
                        None => break false,
                    }
                }
            }
        }
        peek.seek(pos);
        if peek.next_module(al)?.is_none() {
            break false;
        }
        let next = peek.offset();
        if match_right_from(peek, al, next, rest, slots, chains, level + 1)? {
            break true;
        }
        failed = Some(pos);
        // The recursion moved the buffer: read the `[` again.
        peek.seek(pos);
        let Some((_, s, _)) = peek.next_module(al)? else {
            break false;
        };
        let Some(after) = peek.branch_end(al, s, next)? else {
            break false;
        };
        // The next branch is another candidate, also after passed-over
        // modules (`[A]X[B]` with `X` ignored is `[A][B]` to a context).
        match walk_right(peek, al, after, false)? {
            Walk::Stop { at, open: true } => pos = at,
            _ => break false,
        }
    };
    // (A search that tried one branch alone notes nothing: trying it
    // again costs no more than looking it up.)
    if let Some(hi) = failed.filter(|&hi| memo && (from != start || hi != start)) {
        if chains.runs.len() >= MAX_RUNS {
            chains.runs.clear();
        }
        // (The branch that matched, to go to at once; none: no branch
        // after `hi` matches either.)
        chains.runs.insert(key, (from, hi, matched.then_some(pos)));
    }
    Ok(matched)
}

/// cpfg's right-context rules (issue 12), chosen once per pass for a `.l`
/// file: which brackets are passed over like ignored symbols.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct CpfgBrackets {
    pub(crate) open: bool,
    pub(crate) close: bool,
}

impl CpfgBrackets {
    pub(crate) fn of(al: &Alphabet) -> Self {
        CpfgBrackets {
            open: al.bracket_passed('['),
            close: al.bracket_passed(']'),
        }
    }
}

/// Match a right context the way cpfg's `RconDiff` (generate.c) does, from
/// offset `pos` just after the predecessor, binding parameters into
/// `slots`. Module by module: an ignored module (a bracket when `passed`
/// says so: an unlisted bracket under `consider:`) is passed over; a `[`
/// that the pattern element is not a `[` skips its whole branch; anything
/// else must equal the pattern element: so a `[` of the pattern enters
/// only the first of several consecutive branches, a `]` of the pattern
/// must meet a `]` and goes on after it, and a context never leaves its
/// branch otherwise. `=` moves to the `]` that ends the current branch
/// (through `chains`, so that the modules of one long branch do not each
/// scan it; `level` is the predecessor's nesting level, followed here).
pub(crate) fn match_right_cpfg(
    peek: &mut PosReader,
    al: &Alphabet,
    mut pos: u64,
    pat: &[RPat],
    slots: &mut [f64],
    passed: CpfgBrackets,
    (chains, mut level): (&mut Chains, usize),
) -> io::Result<bool> {
    let mut i = 0;
    while i < pat.len() {
        if pat[i] == RPat::SkipRest {
            pos = match chains.skip(peek, al, pos, level)? {
                // `]` is one byte: stop on it.
                Some(after) => after - 1,
                None => u64::MAX,
            };
            i += 1;
            continue;
        }
        peek.seek(pos);
        let Some((key, s, e)) = peek.next_module(al)? else {
            return Ok(false);
        };
        let next = peek.offset();
        let ignored = match key {
            OPEN => passed.open,
            CLOSE => passed.close,
            _ => al.ignored(key),
        };
        if ignored {
            // A passed-over bracket enters or leaves a branch.
            if key == OPEN {
                level += 1;
            } else if key == CLOSE {
                level = level.saturating_sub(1);
            }
            pos = next;
            continue;
        }
        if key == OPEN && pat[i] != RPat::Open {
            match peek.branch_end(al, s, next)? {
                Some(after) => pos = after,
                None => return Ok(false),
            }
            continue;
        }
        match pat[i] {
            RPat::Module(p) if p.key == key => {
                let n = al.arity(key);
                codec::read_params(
                    peek.bytes(s, e),
                    &mut slots[p.slot as usize..p.slot as usize + n],
                );
            }
            RPat::Open if key == OPEN => level += 1,
            RPat::Close if key == CLOSE => level = level.saturating_sub(1),
            _ => return Ok(false),
        }
        pos = next;
        i += 1;
    }
    Ok(true)
}

/// From inside a branch at `pos`, the offset just after the `]` that closes
/// it; None if the string ends first.
pub(crate) fn skip_branch(
    peek: &mut PosReader,
    al: &Alphabet,
    pos: u64,
) -> io::Result<Option<u64>> {
    peek.seek(pos);
    let mut depth = 0u64;
    while let Some((key, s, _)) = peek.next_module(al)? {
        if key == OPEN {
            if peek.indexed {
                // Jump over the nested branch.
                let Some(end) = peek.indexed_end(s) else {
                    return Ok(None); // never closed: nor is this branch
                };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::derive::{Limits, Out};
    use crate::lang::parse::parse_header;
    use crate::rules::{compile, System};
    use std::fs::File;

    /// The compiled header `src`.
    fn system(src: &str) -> System {
        compile(&parse_header(src).unwrap()).unwrap()
    }

    /// A generation in the binary format (with a bracket index if
    /// `indexed`) holding `modules`: (symbol, parameters).
    fn generation(al: &mut Alphabet, modules: &[(char, &[f64])], indexed: bool) -> File {
        let mut f = tempfile::tempfile().unwrap();
        let index = f.try_clone().unwrap();
        let mut out = Out::new(&mut f, "gen", false, Limits::default());
        if indexed {
            out = out.with_index(index);
        }
        for &(sym, params) in modules {
            let key = al.intern(sym, params.len()).unwrap();
            out.module(key, params, al).unwrap();
        }
        out.finish().unwrap();
        f
    }

    /// The offset just after the first module with symbol `sym`.
    fn after(f: &File, al: &Alphabet, sym: char, indexed: bool) -> u64 {
        let mut rd = PosReader::new(f, 1 << 10, indexed);
        while let Some((key, _, _)) = rd.next_module(al).unwrap() {
            if al.symbol(key) == sym {
                return rd.offset();
            }
        }
        panic!("no {sym}");
    }

    // README, "Contexts": `A(a) < B(b) > [C(c)]D(d)` on
    // `A(1)[E]B(2)[C(3)[E][E]D(4)]D(5)` binds c = 3, d = 5.
    const README: &[(char, &[f64])] = &[
        ('A', &[1.0]),
        ('[', &[]),
        ('E', &[]),
        (']', &[]),
        ('B', &[2.0]),
        ('[', &[]),
        ('C', &[3.0]),
        ('[', &[]),
        ('E', &[]),
        (']', &[]),
        ('[', &[]),
        ('E', &[]),
        (']', &[]),
        ('D', &[4.0]),
        (']', &[]),
        ('D', &[5.0]),
    ];

    /// `Chains::skip` answers what `skip_branch` answers, and a second
    /// module of the same branch gets it without reading: `A > ]B` on
    /// `[AA...A]B` was quadratic.
    #[test]
    fn skipping_to_a_branch_end_is_remembered_per_level() {
        // `[ A [ A ] A [ A ] A ] B [ A ] B`: levels 1, 2, 1, 2, 1, then a
        // sibling branch at level 1.
        let syms = "[A[A]A[A]A]B[A]B";
        let modules: Vec<(char, &[f64])> = syms.chars().map(|c| (c, &[][..])).collect();
        for indexed in [false, true] {
            let mut s = system("productions:\nA > ]B -> X\n");
            let f = generation(&mut s.alphabet, &modules, indexed);
            let al = &s.alphabet;
            // Each A: the offset after it and its level.
            let mut rd = PosReader::new(&f, 1 << 10, indexed);
            let (mut level, mut at) = (0usize, Vec::new());
            while let Some((key, _, _)) = rd.next_module(al).unwrap() {
                match al.symbol(key) {
                    '[' => level += 1,
                    ']' => level -= 1,
                    'A' => at.push((rd.offset(), level)),
                    _ => {}
                }
            }
            let mut chains = Chains::default();
            let mut peek = PosReader::new(&f, 1 << 10, indexed);
            let mut fresh = PosReader::new(&f, 1 << 10, indexed);
            for (i, &(pos, level)) in at.iter().enumerate() {
                let want = skip_branch(&mut fresh, al, pos).unwrap();
                peek.seek(0);
                let got = chains.skip(&mut peek, al, pos, level).unwrap();
                assert_eq!(got, want, "A number {i}, indexed {indexed}");
                // The level-1 A after the first nested branch, and the
                // one after the second: remembered, nothing read.
                if i == 2 || i == 4 {
                    assert_eq!(peek.offset(), 0, "A number {i} read the branch again");
                }
            }
        }
    }

    #[test]
    fn right_context_enters_a_branch_and_skips_the_rest() {
        for indexed in [false, true] {
            let mut s = system("productions:\nA(a) < B(b) > [C(c)]D(d) -> X\n");
            let f = generation(&mut s.alphabet, README, indexed);
            let al = &s.alphabet;
            let p = &s.productions.prods[0];
            let mut slots = vec![f64::NAN; p.nslots()];
            let mut peek = PosReader::new(&f, 1 << 10, indexed);
            let pos = after(&f, al, 'B', indexed);
            let mut chains = Chains::default();
            // `B` is at nesting level 0, the `C` below at level 1.
            assert!(
                match_right(&mut peek, al, pos, p.right(), &mut slots, &mut chains, 0).unwrap()
            );
            let bound: Vec<(char, f64)> = p
                .right()
                .iter()
                .filter_map(|r| match r {
                    RPat::Module(m) => Some((al.symbol(m.key), slots[m.slot as usize])),
                    _ => None,
                })
                .collect();
            assert_eq!(bound, [('C', 3.0), ('D', 5.0)], "indexed {indexed}");
            // From the `C`, the rest of its branch holds no `[C]D`.
            let pos = after(&f, al, 'C', indexed);
            assert!(
                !match_right(&mut peek, al, pos, p.right(), &mut slots, &mut chains, 1).unwrap()
            );
        }
    }

    #[test]
    fn the_walker_skips_branches_and_ignored_modules_and_stops_at_a_close() {
        let mut s = system("ignore: +\nproductions:\nB > D -> X\n");
        let modules: &[(char, &[f64])] = &[
            ('B', &[]),
            ('+', &[]),
            ('[', &[]),
            ('D', &[]),
            (']', &[]),
            ('+', &[]),
            ('D', &[7.0]),
            (']', &[]),
            ('F', &[]),
        ];
        let f = generation(&mut s.alphabet, modules, true);
        let al = &s.alphabet;
        let mut peek = PosReader::new(&f, 1 << 10, true);
        let pos = after(&f, al, 'B', true);
        // Skipping branches: the `+`, the branch, the `+`, then D(7).
        match walk_right(&mut peek, al, pos, true).unwrap() {
            Walk::Module {
                key, s, e, next, ..
            } => {
                assert_eq!((al.symbol(key), al.arity(key)), ('D', 1));
                let mut p = [0.0];
                codec::read_params(peek.bytes(s, e), &mut p);
                assert_eq!(p, [7.0]);
                // Past D(7) the branch ends: the walk stops there.
                assert!(matches!(
                    walk_right(&mut peek, al, next, true).unwrap(),
                    Walk::Stop { open: false, .. }
                ));
            }
            Walk::Stop { .. } => panic!("stopped before D(7)"),
        }
        // Without skipping: the `+` is passed over, the `[` stops the walk.
        match walk_right(&mut peek, al, pos, false).unwrap() {
            Walk::Stop { at, open } => assert_eq!((at, open), (pos + 1, true)),
            Walk::Module { .. } => panic!("walked into the branch"),
        }
    }
}
