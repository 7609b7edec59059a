//! Differential tests: random L-systems are derived by lsgen's streaming
//! engine (`derive_bytes`) and by the small in-memory reference rewriter in
//! `tests/reference/`, and the outputs must be byte-identical; and the same
//! (string or error) on 1, 2 and 8 threads (`derive_bytes_on`).
//!
//! Cases come from a self-written deterministic generator (splitmix64) over
//! fixed seed ranges, so every run checks the same cases. On a mismatch the
//! case is shrunk (productions, settings and axiom modules removed, fewer
//! steps) and both the original and the shrunk `.ls` text are printed with
//! both outputs.

mod common;
mod reference;

use lsgen::engine::Limits;
use reference::{derive_text, derive_text_stats, format_number, Stats, TOO_LONG};
use std::fmt::Write as _;

/// The reference gives up on generations longer than this (the case is
/// then skipped, and counted).
const MAX_MODULES: usize = 6_000;

// ---------------------------------------------------------------------------
// A small deterministic generator.

struct Gen(u64);

impl Gen {
    fn new(seed: u64) -> Gen {
        Gen(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }

    /// splitmix64
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// `lo..=hi`
    fn range(&mut self, lo: usize, hi: usize) -> usize {
        lo + self.below(hi - lo + 1)
    }

    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 > 1.0 - p
    }

    fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[self.below(xs.len())]
    }
}

// ---------------------------------------------------------------------------
// Random L-systems.

/// What a generated system may contain.
#[derive(Clone, Copy, Default)]
struct Cfg {
    /// Modules may have 1 or 2 parameters.
    params: bool,
    /// Conditions on productions.
    cond: bool,
    /// `define:` constants used in expressions.
    defines: bool,
    /// Probabilities on (some) productions.
    stochastic: bool,
    /// `ran()`/`nran()` in successors, conditions and probabilities.
    random_fns: bool,
    /// Brackets in the axiom and successors.
    brackets: bool,
    /// Longest left context (0: none).
    left: usize,
    /// Longest right context (0: none).
    right: usize,
    /// `[` and `]` in right contexts.
    right_brackets: bool,
    /// An `ignore:` or `consider:` setting.
    filter: bool,
    /// A homomorphism section.
    hom: bool,
    /// Share of productions that get contexts (when `left`/`right` allow).
    context_share: f64,
    max_steps: u64,
    /// Issue 11 (docs/structural.md): production groups with a `groups:`
    /// or `group:` schedule, decomposition with a maximum depth,
    /// homomorphism depth and seed, the cut `%`, the built-in `step`.
    structural: bool,
    /// A long axiom (about 30,000 modules) with branches longer than the
    /// look-ahead reader's buffer, side by side and nested.
    long: bool,
}

/// Symbols used for modules (no brackets; `/` and `*` are left out so no
/// comment can start by accident).
const SYMBOLS: &[char] = &[
    'A', 'B', 'C', 'D', 'F', 'G', 'a', 'b', '0', '1', '+', '-', '&', '^', 'Ω', '!', '.',
];
const LITERALS: &[&str] = &["0", "1", "2", "3", "0.5", "1.5", "0.25", "10", "0.1", "7"];
const DIVISORS: &[&str] = &["2", "3", "0.5", "4", "10"];
const AXIOM_VALUES: &[f64] = &[0.0, 1.0, 2.0, 3.0, -1.0, 0.5, 2.5, 10.0, -0.25, 1e-3, 4.0];

#[derive(Clone, Debug)]
enum AxItem {
    Open,
    Close,
    Mod(char, Vec<f64>),
}

/// One generated case, kept in parts so it can be shrunk.
#[derive(Clone, Debug)]
struct Case {
    settings: Vec<String>,
    prods: Vec<String>,
    hom: Vec<String>,
    axiom: Vec<AxItem>,
    steps: Option<u64>,
    seed: Option<u64>,
    /// Issue 11: `productions N:` sections, the decomposition (its
    /// `maximum depth:` line, then productions), the homomorphism's
    /// `maximum depth:` / `seed:` lines.
    groups: Vec<(u32, Vec<String>)>,
    decomposition: Option<(String, Vec<String>)>,
    hom_settings: Vec<String>,
    /// Keyword lines written with blanks and a comment before their `:`
    /// (`axiom /* : */ :`), as README allows.
    spaced: bool,
}

impl Case {
    /// A keyword line (`key: rest`), spaced or not.
    fn kw(&self, line: &str) -> String {
        match line.split_once(':') {
            Some((key, rest)) if self.spaced => format!("{key} /* : */ :{rest}"),
            _ => line.to_string(),
        }
    }

    fn text(&self) -> String {
        let mut t = String::new();
        for s in &self.settings {
            t.push_str(&self.kw(s));
            t.push('\n');
        }
        t.push_str(&self.kw("productions:\n"));
        for p in &self.prods {
            t.push_str(p);
            t.push('\n');
        }
        for (n, prods) in &self.groups {
            t.push_str(&self.kw(&format!("productions {n}:\n")));
            for p in prods {
                t.push_str(p);
                t.push('\n');
            }
        }
        if let Some((depth, prods)) = &self.decomposition {
            t.push_str(&self.kw("decomposition:\n"));
            t.push_str(&self.kw(depth));
            for p in prods {
                t.push_str(p);
                t.push('\n');
            }
        }
        if !self.hom.is_empty() {
            t.push_str(&self.kw("homomorphism:\n"));
            for h in &self.hom_settings {
                t.push_str(&self.kw(h));
                t.push('\n');
            }
            for p in &self.hom {
                t.push_str(p);
                t.push('\n');
            }
        }
        t.push_str(&self.kw("axiom:\n"));
        t.push_str(&axiom_text(&self.axiom));
        t.push('\n');
        t
    }
}

fn axiom_text(items: &[AxItem]) -> String {
    let mut t = String::new();
    for it in items {
        match it {
            AxItem::Open => t.push('['),
            AxItem::Close => t.push(']'),
            AxItem::Mod(c, ps) => {
                t.push(*c);
                if !ps.is_empty() {
                    let p: Vec<String> = ps.iter().map(|&v| format_number(v)).collect();
                    let _ = write!(t, "({})", p.join(","));
                }
            }
        }
    }
    t
}

struct Builder<'a> {
    g: &'a mut Gen,
    cfg: Cfg,
    kinds: Vec<(char, usize)>,
    consts: Vec<String>,
    /// `ignore:` (true) or `consider:` (false), and the symbols listed.
    filter: Option<(bool, Vec<char>)>,
    axiom: Vec<AxItem>,
}

/// A right-context element.
#[derive(Clone, Copy)]
enum RPat {
    Open,
    Close,
    M((char, usize)),
}

/// The index just after the `]` that closes the branch `i` is in.
fn skip_to_close(ax: &[AxItem], mut i: usize) -> usize {
    let mut depth = 0;
    while i < ax.len() {
        match ax[i] {
            AxItem::Open => depth += 1,
            AxItem::Close if depth == 0 => return i + 1,
            AxItem::Close => depth -= 1,
            AxItem::Mod(..) => {}
        }
        i += 1;
    }
    i
}

impl Builder<'_> {
    fn literal(&mut self) -> String {
        self.g.pick(LITERALS).to_string()
    }

    /// A numeric expression that cannot fail for moderate parameter values.
    fn num(&mut self, vars: &[String], depth: u32) -> String {
        if depth == 0 || self.g.chance(0.35) {
            let r = self.g.below(10);
            return if r < 5 && !vars.is_empty() {
                vars[self.g.below(vars.len())].clone()
            } else if r < 7 && !self.consts.is_empty() {
                self.consts[self.g.below(self.consts.len())].clone()
            } else {
                self.literal()
            };
        }
        let d = depth - 1;
        let random = self.cfg.random_fns;
        loop {
            return match self.g.below(15) {
                0 | 1 => format!("({} + {})", self.num(vars, d), self.num(vars, d)),
                2 | 3 => format!("({} - {})", self.num(vars, d), self.num(vars, d)),
                4 => format!("({} * {})", self.num(vars, d), self.literal()),
                5 => format!("({} * {})", self.num(vars, d), self.num(vars, d)),
                6 => format!("({} / {})", self.num(vars, d), self.g.pick(DIVISORS)),
                7 => format!("min({}, {})", self.num(vars, d), self.num(vars, d)),
                8 => format!("max({}, {})", self.num(vars, d), self.num(vars, 0)),
                9 => format!(
                    "{}({})",
                    self.g
                        .pick(&["abs", "floor", "ceil", "trunc", "sin", "cos"]),
                    self.num(vars, d)
                ),
                10 => format!("-{}", self.num(vars, d)),
                11 => format!(
                    "({} {} {})",
                    self.num(vars, d),
                    self.g.pick(&["<", ">=", "=="]),
                    self.num(vars, 0)
                ),
                12 if random => format!("ran({})", self.num(vars, d)),
                13 if random => format!("nran({}, {})", self.num(vars, d), self.literal()),
                14 if random => format!("({} + ran(1))", self.num(vars, d)),
                12..=14 => continue,
                _ => unreachable!(),
            };
        }
    }

    /// A condition.
    fn cond(&mut self, vars: &[String], depth: u32) -> String {
        let ops = ["<", "<=", ">", ">=", "==", "!=", "="];
        if depth == 0 || self.g.chance(0.6) {
            if self.cfg.random_fns && self.g.chance(0.2) {
                return format!("ran(1) < {}", self.g.pick(&["0.3", "0.5", "0.8"]));
            }
            if self.g.chance(0.1) {
                return self.num(vars, 1);
            }
            let op = self.g.pick(&ops);
            return format!("{} {} {}", self.num(vars, 1), op, self.num(vars, 1));
        }
        match self.g.below(3) {
            0 => format!(
                "({}) && ({})",
                self.cond(vars, depth - 1),
                self.cond(vars, depth - 1)
            ),
            1 => format!(
                "({}) || ({})",
                self.cond(vars, depth - 1),
                self.cond(vars, depth - 1)
            ),
            _ => format!("!({})", self.cond(vars, depth - 1)),
        }
    }

    /// A probability: never negative.
    fn prob(&mut self, vars: &[String]) -> String {
        match self.g.below(10) {
            0..=5 => self
                .g
                .pick(&["0", "0.5", "1", "2", "0.3", "1.7", "3", "0.1"])
                .to_string(),
            6 if !vars.is_empty() => format!("abs({})", self.num(vars, 1)),
            7 if !vars.is_empty() => format!("max({}, 0)", self.num(vars, 1)),
            8 if self.cfg.random_fns => "ran(1)".to_string(),
            _ => self.g.pick(&["1", "2", "0.5"]).to_string(),
        }
    }

    /// A module pattern with fresh formal names `x<n>`.
    fn pattern(&mut self, kind: (char, usize), vars: &mut Vec<String>) -> String {
        let mut t = kind.0.to_string();
        if kind.1 > 0 {
            let mut names = Vec::new();
            for _ in 0..kind.1 {
                let n = format!("x{}", vars.len());
                names.push(n.clone());
                vars.push(n);
            }
            let _ = write!(t, "({})", names.join(","));
        }
        t
    }

    fn kind(&mut self) -> (char, usize) {
        self.kinds[self.g.below(self.kinds.len())]
    }

    /// A bracket-balanced successor.
    fn succ(&mut self, vars: &[String], depth: u32, extra: &[char]) -> String {
        let mut t = String::new();
        let n = self.g.range(0, if depth == 0 { 4 } else { 3 });
        for _ in 0..n {
            if self.cfg.brackets && depth < 2 && self.g.chance(0.25) {
                t.push('[');
                t.push_str(&self.succ(vars, depth + 1, extra));
                t.push(']');
                continue;
            }
            let (c, arity) = if !extra.is_empty() && self.g.chance(0.3) {
                (self.g.pick(extra), self.g.below(2))
            } else {
                self.kind()
            };
            t.push(c);
            if arity > 0 {
                let ps: Vec<String> = (0..arity).map(|_| self.num(vars, 2)).collect();
                let _ = write!(t, "({})", ps.join(", "));
            }
        }
        t
    }

    /// One production line for `pred`; `with_prob` adds a probability.
    /// With `context`, contexts are mostly read off an occurrence of `pred`
    /// in the axiom (so that they match at least in the first step), else
    /// made up.
    fn production(
        &mut self,
        pred: (char, usize),
        context: bool,
        with_prob: bool,
        extra: &[char],
    ) -> String {
        let mut vars = Vec::new();
        let pred_text = self.pattern(pred, &mut vars);
        let mut left_kinds = Vec::new();
        let mut right_items = Vec::new();
        if context {
            let want_left = self.cfg.left > 0 && (self.cfg.right == 0 || self.g.chance(0.6));
            let want_right = self.cfg.right > 0 && (!want_left || self.g.chance(0.5));
            let at: Vec<usize> = (0..self.axiom.len())
                .filter(|&i| matches!(&self.axiom[i], AxItem::Mod(c, ps) if (*c, ps.len()) == pred))
                .collect();
            let witness = (!at.is_empty() && self.g.chance(0.75)).then(|| self.g.pick(&at));
            if want_left {
                let n = self.g.range(1, self.cfg.left);
                left_kinds = match witness {
                    Some(p) => self.left_witness(p, n),
                    None => (0..n).map(|_| self.kind()).collect(),
                };
            }
            if want_right {
                let n = self.g.range(1, self.cfg.right);
                right_items = match witness {
                    Some(p) => self.right_witness(p, n),
                    None => self.right_random(n),
                };
            }
            // Now and then a near miss.
            if !left_kinds.is_empty() && self.g.chance(0.15) {
                let i = self.g.below(left_kinds.len());
                left_kinds[i] = self.kind();
            }
            if !right_items.is_empty() && self.g.chance(0.15) {
                let i = self.g.below(right_items.len());
                if let RPat::M(_) = right_items[i] {
                    right_items[i] = RPat::M(self.kind());
                }
            }
            if left_kinds.is_empty() && right_items.is_empty() {
                // the witness had no neighbours: make one up
                if self.cfg.left > 0 {
                    left_kinds.push(self.kind());
                } else {
                    right_items.push(RPat::M(self.kind()));
                }
            }
        }
        let mut left = String::new();
        for k in left_kinds {
            left.push_str(&self.pattern(k, &mut vars));
        }
        let mut right = String::new();
        for r in right_items {
            match r {
                RPat::M(k) => right.push_str(&self.pattern(k, &mut vars)),
                RPat::Open => right.push('['),
                RPat::Close => right.push(']'),
            }
        }
        let mut line = String::new();
        if !left.is_empty() {
            let _ = write!(line, "{left} < ");
        }
        line.push_str(&pred_text);
        if !right.is_empty() {
            let _ = write!(line, " > {right}");
        }
        if self.cfg.cond && self.g.chance(0.5) {
            let c = self.cond(&vars, 2);
            let _ = write!(line, " : {c}");
        }
        let s = self.succ(&vars, 0, extra);
        let _ = write!(line, " -> {s}");
        if with_prob {
            let p = self.prob(&vars);
            let _ = write!(line, " : {p}");
        }
        line
    }

    /// Is `c` passed over by contexts?
    fn unseen(&self, c: char) -> bool {
        match &self.filter {
            None => false,
            Some((true, set)) => set.contains(&c),
            Some((false, set)) => !set.contains(&c),
        }
    }

    /// A left context that the module at `p` of the axiom has: the seen
    /// modules on its path towards the root, nearest last.
    fn left_witness(&mut self, p: usize, n: usize) -> Vec<(char, usize)> {
        let ax = &self.axiom;
        let mut found = Vec::new();
        let mut i = p;
        while found.len() < n && i > 0 {
            i -= 1;
            match &ax[i] {
                AxItem::Close => {
                    let mut depth = 1;
                    while depth > 0 {
                        i -= 1;
                        match ax[i] {
                            AxItem::Close => depth += 1,
                            AxItem::Open => depth -= 1,
                            AxItem::Mod(..) => {}
                        }
                    }
                }
                AxItem::Open => {}
                AxItem::Mod(c, ps) if !self.unseen(*c) => found.push((*c, ps.len())),
                AxItem::Mod(..) => {}
            }
        }
        found.reverse();
        found
    }

    /// A right context that the module at `p` of the axiom has, with `n`
    /// modules at most: branches are entered or skipped, and branches left
    /// early with `]`.
    fn right_witness(&mut self, p: usize, n: usize) -> Vec<RPat> {
        let brackets = self.cfg.right_brackets;
        let mut out = Vec::new();
        let mut modules = 0;
        let mut i = p + 1;
        while i < self.axiom.len() && modules < n {
            match self.axiom[i].clone() {
                AxItem::Open => {
                    if brackets && self.g.chance(0.7) {
                        out.push(RPat::Open);
                        i += 1;
                    } else {
                        i = skip_to_close(&self.axiom, i + 1);
                    }
                }
                AxItem::Close => {
                    if !brackets {
                        break;
                    }
                    out.push(RPat::Close);
                    i += 1;
                }
                AxItem::Mod(c, _) if self.unseen(c) => i += 1,
                AxItem::Mod(c, ps) => {
                    if brackets && self.g.chance(0.15) {
                        out.push(RPat::Close);
                        i = skip_to_close(&self.axiom, i);
                    } else {
                        out.push(RPat::M((c, ps.len())));
                        modules += 1;
                        i += 1;
                    }
                }
            }
        }
        out
    }

    /// A made-up right context with `n` modules.
    fn right_random(&mut self, n: usize) -> Vec<RPat> {
        let brackets = self.cfg.right_brackets;
        let mut out = Vec::new();
        for _ in 0..n {
            if brackets && self.g.chance(0.3) {
                out.push(RPat::Open);
            }
            if brackets && self.g.chance(0.15) {
                out.push(RPat::Close);
            }
            out.push(RPat::M(self.kind()));
            if brackets && self.g.chance(0.25) {
                out.push(RPat::Close);
            }
        }
        out
    }

    /// Productions for a few keys, several per key.
    fn productions(&mut self, extra: &[char]) -> Vec<String> {
        let mut lines = Vec::new();
        let nkeys = self.g.range(1, self.kinds.len().min(4));
        for _ in 0..nkeys {
            // mostly a kind that occurs in the axiom
            let i = self.g.below(self.axiom.len());
            let pred = match &self.axiom[i] {
                AxItem::Mod(c, ps) if self.g.chance(0.7) => (*c, ps.len()),
                _ => self.kind(),
            };
            let per_key = self.g.range(1, 4);
            let key_stochastic = self.cfg.stochastic && self.g.chance(0.7);
            for _ in 0..per_key {
                let context = (self.cfg.left > 0 || self.cfg.right > 0)
                    && self.g.chance(self.cfg.context_share);
                let with_prob = key_stochastic && self.g.chance(0.7);
                lines.push(self.production(pred, context, with_prob, extra));
            }
        }
        lines
    }

    fn axiom(&mut self) -> Vec<AxItem> {
        if self.cfg.long {
            let mut items = Vec::with_capacity(45_000);
            self.long_run(30_000, 0, &mut items);
            return items;
        }
        let mut items = Vec::new();
        let contexts = self.cfg.left > 0 || self.cfg.right > 0;
        let n = self.g.range(1, if contexts { 14 } else { 9 });
        let mut depth = 0;
        for _ in 0..n {
            if self.cfg.brackets && self.g.chance(0.2) {
                items.push(AxItem::Open);
                depth += 1;
            }
            let (c, arity) = self.kind();
            let ps = (0..arity).map(|_| self.g.pick(AXIOM_VALUES)).collect();
            items.push(AxItem::Mod(c, ps));
            if depth > 0 && self.g.chance(0.3) {
                items.push(AxItem::Close);
                depth -= 1;
            }
        }
        items.extend((0..depth).map(|_| AxItem::Close));
        items
    }

    /// `len` modules or more into `out` at nesting `depth`, with branches
    /// nested up to three deep: some short, some of 6,000 to 14,000
    /// modules (longer than the look-ahead reader's 64 KiB buffer once
    /// written with their parameters), often several side by side. Right
    /// contexts then skip or search such branches by jumping out of the
    /// reader's buffer, and come back into it.
    fn long_run(&mut self, len: usize, depth: u32, out: &mut Vec<AxItem>) {
        let end = out.len() + len;
        while out.len() < end {
            if depth < 3 && self.g.chance(0.08) {
                loop {
                    let inner = if self.g.chance(0.3) {
                        self.g.range(6_000, 14_000)
                    } else {
                        self.g.range(0, 6)
                    };
                    out.push(AxItem::Open);
                    self.long_run(inner, depth + 1, out);
                    out.push(AxItem::Close);
                    if !self.g.chance(0.5) {
                        break;
                    }
                }
            } else {
                let (c, arity) = self.kind();
                let ps = (0..arity).map(|_| self.g.pick(AXIOM_VALUES)).collect();
                out.push(AxItem::Mod(c, ps));
            }
        }
    }
}

/// A random case for `cfg`, the same one for the same `seed`.
fn gen_case(cfg: Cfg, seed: u64) -> Case {
    let mut g = Gen::new(seed);
    // The alphabet: a few symbols, each with one arity (sometimes two).
    let nsym = g.range(2, 4);
    let mut syms: Vec<char> = Vec::new();
    while syms.len() < nsym {
        let c = g.pick(SYMBOLS);
        if !syms.contains(&c) {
            syms.push(c);
        }
    }
    let mut kinds = Vec::new();
    for &c in &syms {
        let arity = if cfg.params { g.range(0, 2) } else { 0 };
        kinds.push((c, arity));
        if cfg.params && g.chance(0.15) {
            kinds.push((c, (arity + 1) % 3));
        }
    }
    let mut settings = Vec::new();
    let mut consts = Vec::new();
    if cfg.defines {
        for i in 0..g.range(1, 3) {
            let v = if i > 0 && g.chance(0.5) {
                format!("K{} * 2 + {}", i - 1, g.pick(LITERALS))
            } else {
                g.pick(LITERALS).to_string()
            };
            settings.push(format!("define: K{i} = {v}"));
            consts.push(format!("K{i}"));
        }
    }
    let steps_in_file = g.chance(0.2);
    let steps = g.range(0, cfg.max_steps as usize) as u64;
    if steps_in_file {
        settings.push(format!("derivation length: {steps}"));
    }
    let seed_in_file = g.chance(0.3);
    let rng_seed = g.next() % 1000;
    if seed_in_file {
        settings.push(format!("seed: {rng_seed}"));
    }
    let mut filter = None;
    if cfg.filter {
        let ignore = g.chance(0.5);
        let mut set: Vec<char> = Vec::new();
        let n = g.range(1, syms.len().max(2) - 1);
        for _ in 0..n {
            set.push(g.pick(&syms));
        }
        if g.chance(0.2) {
            set.push(g.pick(SYMBOLS));
        }
        let list: String = set.iter().collect();
        settings.push(format!(
            "{}: {list}",
            if ignore { "ignore" } else { "consider" }
        ));
        filter = Some((ignore, set));
    }
    if cfg.structural {
        // `%` is a symbol like the others (a cut when nothing rewrites
        // it), and `step` a name like the constants.
        kinds.push(('%', 0));
        consts.push("step".to_string());
        match g.below(3) {
            0 => {}
            1 => {
                let list: Vec<String> = (0..g.range(1, 3))
                    .map(|_| g.range(0, 2).to_string())
                    .collect();
                settings.push(format!("groups: {}", list.join(" ")));
            }
            _ => settings.push("group: step - 2 * floor(step / 2)".to_string()),
        }
    }
    let mut b = Builder {
        g: &mut g,
        cfg,
        kinds,
        consts,
        filter,
        axiom: Vec::new(),
    };
    b.axiom = b.axiom();
    let prods = b.productions(&[]);
    let mut groups = Vec::new();
    let mut decomposition = None;
    let mut hom_settings = Vec::new();
    if cfg.structural {
        let scheduled = settings.iter().any(|s| s.starts_with("group"));
        if scheduled {
            groups.push((1, b.productions(&[])));
            groups.push((2, b.productions(&[])));
        }
        if b.g.chance(0.6) {
            // Context-free: the decomposition has no contexts.
            let saved = b.cfg;
            b.cfg.left = 0;
            b.cfg.right = 0;
            let prods = b.productions(&['X']);
            b.cfg = saved;
            let depth = if b.g.chance(0.5) {
                format!("maximum depth: {}\n", b.g.range(1, 3))
            } else {
                String::new()
            };
            decomposition = Some((depth, prods));
        }
        if b.g.chance(0.5) {
            hom_settings.push(format!("maximum depth: {}", b.g.range(1, 3)));
        }
        if b.g.chance(0.3) {
            hom_settings.push(format!("seed: {}", b.g.range(0, 99)));
        }
    }
    let hom = if cfg.hom && b.g.chance(0.8) {
        b.productions(&['X', 'Y', '~'])
    } else {
        Vec::new()
    };
    let axiom = b.axiom;
    Case {
        settings,
        prods,
        hom,
        axiom,
        steps: if steps_in_file { None } else { Some(steps) },
        seed: if seed_in_file { None } else { Some(rng_seed) },
        groups,
        decomposition,
        hom_settings,
        // (The last draw: the cases before it are as they were.)
        spaced: b.g.chance(0.25),
    }
}

// ---------------------------------------------------------------------------
// Running and comparing.

enum Outcome {
    Same {
        error: bool,
        stats: Stats,
        /// Output length in bytes.
        len: usize,
    },
    Skipped,
    Differ {
        expected: Result<String, String>,
        actual: Result<String, String>,
    },
}

fn lsgen_text(src: &str, steps: Option<u64>, seed: Option<u64>) -> Result<String, String> {
    lsgen::derive_bytes(src.as_bytes(), steps, seed, Limits::default())
        .map(|v| String::from_utf8(v).expect("lsgen writes UTF-8"))
        .map_err(|e| e.to_string())
}

/// `lsgen_text` on `threads` threads (`-j`, issue 15), in tasks of
/// `split` (modules per thread depth first, bytes per chunk step by step).
fn lsgen_text_on(
    src: &str,
    steps: Option<u64>,
    seed: Option<u64>,
    (threads, split): (usize, u64),
) -> Result<String, String> {
    // Tiny tasks, so that these small strings split.
    let split = (threads, Some(split));
    lsgen::derive_bytes_on(src.as_bytes(), steps, seed, Limits::default(), split)
        .map(|v| String::from_utf8(v).expect("lsgen writes UTF-8"))
        .map_err(|e| e.to_string())
}

/// The real binary forced onto the step-by-step engine (`--strategy
/// step`), the system on standard input: its output, or its stderr. It
/// walks every successor of the decomposition and the homomorphism's
/// depth as it is reached (`LSGEN_TEST_WALK=0`; the library's runs walk
/// those of more than 64 modules only).
fn lsgen_step_text(src: &str, steps: Option<u64>, seed: Option<u64>) -> Result<String, String> {
    let mut cmd = common::lsgen();
    cmd.env("LSGEN_TEST_WALK", "0");
    cmd.args([
        "--strategy",
        "step",
        "--seed",
        &seed.unwrap_or(0).to_string(),
    ]);
    if let Some(n) = steps {
        cmd.args(["-n", &n.to_string()]);
    }
    let r = common::run_with_stdin(&mut cmd, src);
    r.assert_no_crash();
    match r.code() {
        Some(0) => Ok(r.out().trim_end_matches('\n').to_string()),
        _ => Err(r.stderr),
    }
}

fn compare(src: &str, steps: Option<u64>, seed: Option<u64>, max_modules: usize) -> Outcome {
    let (expected, stats) = derive_text_stats(src, steps, seed, max_modules);
    if matches!(&expected, Err(e) if e == TOO_LONG) {
        return Outcome::Skipped;
    }
    let actual = lsgen_text(src, steps, seed);
    match (&expected, &actual) {
        (Ok(a), Ok(b)) if a == b => Outcome::Same {
            error: false,
            stats,
            len: a.len(),
        },
        (Err(_), Err(_)) => Outcome::Same {
            error: true,
            stats,
            len: 0,
        },
        _ => Outcome::Differ { expected, actual },
    }
}

fn run(case: &Case) -> Outcome {
    compare(&case.text(), case.steps, case.seed, MAX_MODULES)
}

fn differs(case: &Case) -> bool {
    matches!(run(case), Outcome::Differ { .. })
}

/// Smaller variants of a case.
fn shrink_candidates(c: &Case) -> Vec<Case> {
    let mut out = Vec::new();
    for i in 0..c.prods.len() {
        let mut d = c.clone();
        d.prods.remove(i);
        out.push(d);
    }
    for i in 0..c.hom.len() {
        let mut d = c.clone();
        d.hom.remove(i);
        out.push(d);
    }
    for i in 0..c.settings.len() {
        let mut d = c.clone();
        d.settings.remove(i);
        out.push(d);
    }
    for i in 0..c.axiom.len() {
        let mut d = c.clone();
        match c.axiom[i] {
            AxItem::Mod(..) => {
                d.axiom.remove(i);
            }
            AxItem::Open => {
                // remove the bracket pair, keep what it holds
                let mut depth = 0;
                let close = (i..c.axiom.len())
                    .find(|&j| {
                        match c.axiom[j] {
                            AxItem::Open => depth += 1,
                            AxItem::Close => depth -= 1,
                            AxItem::Mod(..) => {}
                        }
                        depth == 0
                    })
                    .expect("balanced axiom");
                d.axiom.remove(close);
                d.axiom.remove(i);
            }
            AxItem::Close => continue,
        }
        out.push(d);
    }
    let cur = c.steps.unwrap_or(u64::MAX);
    for k in 0..cur.min(8) {
        let mut d = c.clone();
        d.steps = Some(k);
        out.push(d);
    }
    out
}

/// Greedy shrinking: take any smaller variant that still differs.
fn shrink(mut c: Case) -> Case {
    'outer: loop {
        for d in shrink_candidates(&c) {
            if differs(&d) {
                c = d;
                continue 'outer;
            }
        }
        return c;
    }
}

fn clip(s: &Result<String, String>) -> String {
    let (tag, t) = match s {
        Ok(t) => ("Ok", t),
        Err(t) => ("Err", t),
    };
    if t.len() > 3000 {
        let mut end = 3000;
        while !t.is_char_boundary(end) {
            end -= 1;
        }
        format!("{tag}: {}... ({} bytes)", &t[..end], t.len())
    } else {
        format!("{tag}: {t}")
    }
}

fn report(what: &str, c: &Case) -> String {
    let mut r = String::new();
    let _ = writeln!(
        r,
        "--- {what}: steps {:?}, seed {:?} (None: from the file)\n{}",
        c.steps,
        c.seed,
        c.text()
    );
    if let Outcome::Differ { expected, actual } = run(c) {
        let _ = writeln!(r, "reference: {}", clip(&expected));
        let _ = writeln!(r, "lsgen:     {}", clip(&actual));
    }
    r
}

/// Generate and compare `count` cases of `cfg`; panic with a report of the
/// first few mismatches (shrunk).
/// `LSGEN_DIFF_SCALE=N` runs N times as many cases (other seeds too).
fn check_many(name: &str, cfg: Cfg, count: u64) {
    let scale: u64 = std::env::var("LSGEN_DIFF_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let count = count * scale.max(1);
    let base = name
        .bytes()
        .fold(0u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64))
        << 20;
    let (mut same, mut errors, mut skipped) = (0, 0, 0);
    // How many cases applied a left context, a right context, ... at least once.
    let mut seen = [0usize; 5];
    let mut failures = Vec::new();
    // derive_bytes expands deterministic context-free systems depth first;
    // every 4th such case also goes through the step-by-step engine.
    let context_free = cfg.left == 0 && cfg.right == 0 && !cfg.stochastic && !cfg.random_fns;
    let mut stepwise = 0;
    // Structural cases with decomposition, groups, a `%`, homomorphism depth.
    let mut structural = [0usize; 4];
    for i in 0..count {
        let case = gen_case(cfg, base + i);
        let text = case.text();
        for (n, what) in
            structural
                .iter_mut()
                .zip(["decomposition:", "productions 1:", "%", "maximum depth: 2"])
        {
            *n += usize::from(text.contains(what));
        }
        match run(&case) {
            Outcome::Same { error, stats, .. } => {
                // The same string, or the same error, on any number of
                // threads.
                let (src, n, seed) = (case.text(), case.steps, case.seed);
                let one = lsgen_text(&src, n, seed);
                // Chunks of 1 to 4 bytes (context passes split too: every
                // module a chunk start, contexts across chunks).
                let split = 1 + i % 4;
                for threads in [2, 8] {
                    let many = lsgen_text_on(&src, n, seed, (threads, split));
                    assert!(
                        one == many,
                        "{name}: case {i}: -j {threads} (split {split}) differs from -j 1 on\n{src}\n\
                         -j 1: {}\n-j {threads}: {}",
                        clip(&one),
                        clip(&many)
                    );
                }
                if context_free && i % 4 == 0 {
                    let (src, n, seed) = (case.text(), case.steps, case.seed);
                    let (dfs, step) = (lsgen_text(&src, n, seed), lsgen_step_text(&src, n, seed));
                    match (&dfs, &step) {
                        (Ok(a), Ok(b)) if a.trim_end_matches('\n') == b => stepwise += 1,
                        (Err(_), Err(_)) => stepwise += 1,
                        _ => panic!(
                            "{name}: case {i}: --strategy step differs from depth first on\n{src}\n\
                             depth first: {}\nstep by step: {}",
                            clip(&dfs),
                            clip(&step)
                        ),
                    }
                }
                same += 1;
                errors += usize::from(error);
                let st = [
                    stats.left,
                    stats.right,
                    stats.right_brackets,
                    stats.filtered,
                    stats.draws,
                ];
                for (n, v) in seen.iter_mut().zip(st) {
                    *n += usize::from(v > 0);
                }
            }
            Outcome::Skipped => skipped += 1,
            Outcome::Differ { .. } => failures.push((i, case)),
        }
    }
    eprintln!(
        "{name}: {count} cases: {same} identical ({errors} of them errors on both sides), \
         {skipped} skipped as too long, {} mismatches; cases that applied a left context {}, \
         a right context {}, one with brackets {}, a context with ignore/consider {}, drew a choice {}; {stepwise} also with --strategy step",
        failures.len(), seen[0], seen[1], seen[2], seen[3], seen[4]
    );
    if !failures.is_empty() {
        let mut msg = format!("{name}: {} of {count} cases differ\n", failures.len());
        for (i, case) in failures.iter().take(3) {
            msg.push_str(&report(&format!("case {i} as generated"), case));
            msg.push_str(&report(&format!("case {i} shrunk"), &shrink(case.clone())));
        }
        panic!("{msg}");
    }
    assert!(
        !context_free || stepwise * 5 >= count as usize,
        "{name}: only {stepwise} cases compared with --strategy step"
    );
    assert!(
        skipped * 10 < count as usize,
        "{name}: too many cases skipped ({skipped})"
    );
    assert!(
        errors * 20 < count as usize,
        "{name}: too many cases fail on both sides ({errors})"
    );
    for (k, &n) in structural.iter().enumerate() {
        assert!(
            !cfg.structural || n * 10 >= count as usize,
            "{name}: structural feature {k} in only {n} cases"
        );
    }
    // The generator must exercise what the configuration asks for.
    let want = [
        cfg.left > 0,
        cfg.right > 0,
        cfg.right_brackets,
        cfg.filter && cfg.context_share > 0.0,
        cfg.stochastic,
    ];
    for (k, (&w, &n)) in want.iter().zip(&seen).enumerate() {
        assert!(
            !w || n * 10 >= count as usize,
            "{name}: feature {k} exercised in only {n} cases"
        );
    }
}

// ---------------------------------------------------------------------------
// Context-free systems.

const BASE: Cfg = Cfg {
    params: false,
    cond: false,
    defines: false,
    stochastic: false,
    random_fns: false,
    brackets: false,
    left: 0,
    right: 0,
    right_brackets: false,
    filter: false,
    hom: false,
    context_share: 0.0,
    max_steps: 5,
    structural: false,
    long: false,
};

#[test]
fn d0l() {
    check_many("d0l", BASE, 400);
}

#[test]
fn bracketed_d0l() {
    check_many(
        "bracketed_d0l",
        Cfg {
            brackets: true,
            ..BASE
        },
        400,
    );
}

#[test]
fn parametric_with_conditions_and_defines() {
    let cfg = Cfg {
        params: true,
        cond: true,
        defines: true,
        brackets: true,
        ..BASE
    };
    check_many("parametric", cfg, 500);
}

#[test]
fn stochastic() {
    let cfg = Cfg {
        stochastic: true,
        brackets: true,
        ..BASE
    };
    check_many("stochastic", cfg, 400);
}

#[test]
fn stochastic_parametric_with_random_functions() {
    let cfg = Cfg {
        params: true,
        cond: true,
        defines: true,
        stochastic: true,
        random_fns: true,
        brackets: true,
        ..BASE
    };
    check_many("stochastic_parametric_random", cfg, 500);
}

#[test]
fn homomorphism() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        random_fns: true,
        brackets: true,
        hom: true,
        max_steps: 4,
        ..BASE
    };
    check_many("homomorphism", cfg, 400);
}

// ---------------------------------------------------------------------------
// Context-sensitive systems.

const CS: Cfg = Cfg {
    brackets: true,
    context_share: 0.6,
    max_steps: 4,
    ..BASE
};

#[test]
fn left_contexts() {
    check_many("left_contexts", Cfg { left: 3, ..CS }, 400);
}

#[test]
fn right_contexts() {
    check_many("right_contexts", Cfg { right: 3, ..CS }, 400);
}

#[test]
fn one_module_contexts_around_ignored_modules() {
    // At most one module (no parameters) on each side, deterministic,
    // with ignored modules and branches between: keys whose choice
    // depends on their neighbours' keys alone, which the step engine's
    // byte table decides (derive::choose::Neighbours).
    let cfg = Cfg {
        left: 1,
        right: 1,
        filter: true,
        context_share: 0.8,
        ..CS
    };
    check_many("one_module_contexts", cfg, 500);
}

#[test]
fn right_contexts_with_brackets() {
    let cfg = Cfg {
        right: 3,
        right_brackets: true,
        ..CS
    };
    check_many("right_contexts_with_brackets", cfg, 500);
}

#[test]
fn both_contexts_parametric() {
    let cfg = Cfg {
        params: true,
        cond: true,
        defines: true,
        left: 3,
        right: 3,
        right_brackets: true,
        ..CS
    };
    check_many("both_contexts_parametric", cfg, 500);
}

#[test]
fn contexts_with_ignore_and_consider() {
    let cfg = Cfg {
        params: true,
        cond: true,
        left: 2,
        right: 3,
        right_brackets: true,
        filter: true,
        ..CS
    };
    check_many("contexts_with_filters", cfg, 500);
}

#[test]
fn stochastic_contexts() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        random_fns: true,
        left: 2,
        right: 2,
        right_brackets: true,
        filter: true,
        ..CS
    };
    check_many("stochastic_contexts", cfg, 500);
}

#[test]
fn homomorphism_with_contexts() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        left: 2,
        right: 2,
        right_brackets: true,
        filter: true,
        hom: true,
        max_steps: 3,
        ..CS
    };
    check_many("homomorphism_with_contexts", cfg, 400);
}

// ---------------------------------------------------------------------------
// Structural rewriting (issue 11): groups, decomposition, homomorphism
// depth and seed, the cut, `step`.

#[test]
fn structural_parametric() {
    let cfg = Cfg {
        params: true,
        cond: true,
        defines: true,
        brackets: true,
        hom: true,
        structural: true,
        max_steps: 4,
        ..BASE
    };
    check_many("structural_parametric", cfg, 400);
}

#[test]
fn structural_stochastic() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        random_fns: true,
        brackets: true,
        hom: true,
        structural: true,
        max_steps: 4,
        ..BASE
    };
    check_many("structural_stochastic", cfg, 400);
}

#[test]
fn structural_with_contexts() {
    let cfg = Cfg {
        params: true,
        cond: true,
        left: 2,
        right: 2,
        right_brackets: true,
        hom: true,
        structural: true,
        max_steps: 4,
        ..CS
    };
    check_many("structural_with_contexts", cfg, 400);
}

/// Strings larger than lsgen's read buffers: generated cases with their
/// axiom repeated many times (every third one in branches of their own).
#[test]
fn large_strings() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        random_fns: true,
        left: 2,
        right: 3,
        right_brackets: true,
        filter: true,
        hom: true,
        max_steps: 2,
        ..CS
    };
    let (mut checked, mut total) = (0, 0);
    for i in 0..16u64 {
        let mut case = gen_case(cfg, 0x1A26E + i);
        let unit = case.axiom.clone();
        case.axiom.clear();
        while case.axiom.len() < 6_000 {
            if i % 3 == 0 {
                case.axiom.push(AxItem::Open);
            }
            case.axiom.extend(unit.iter().cloned());
            if i % 3 == 0 {
                case.axiom.push(AxItem::Close);
            }
        }
        let src = case.text();
        match compare(&src, case.steps, case.seed, 200_000) {
            Outcome::Same { len, .. } => {
                checked += 1;
                total += len;
            }
            Outcome::Skipped => {}
            Outcome::Differ { expected, actual } => panic!(
                "large case {i} differs: steps {:?}, seed {:?}; the axiom is\n{}\nrepeated{}; the system:\n{}\nreference: {}\nlsgen:     {}",
                case.steps,
                case.seed,
                axiom_text(&unit),
                if i % 3 == 0 { " in brackets" } else { "" },
                src.split("axiom:").next().unwrap(),
                clip(&expected),
                clip(&actual)
            ),
        }
    }
    eprintln!("large_strings: {checked} cases, {total} bytes of output");
    assert!(checked >= 12, "only {checked} large cases checked");
}

/// Long strings (30,000 axiom modules, one step) with branches longer than
/// the look-ahead reader's buffer, right contexts that skip or search them,
/// and ignored or considered modules: lsgen at `-j 1` against the
/// reference, and split at `-j 2` against `-j 1`. The random cases
/// elsewhere are too short to leave the reader's buffer. With the reader
/// fix of 0a971c1 reverted (a seek back into the buffer a jump left), two
/// of these 40 cases fail (and about one in twenty of other seeds:
/// `LSGEN_DIFF_SCALE`), where the other random tests here all passed.
#[test]
fn long_branches() {
    let cfg = Cfg {
        params: true,
        left: 2,
        right: 3,
        right_brackets: true,
        filter: true,
        context_share: 1.0,
        max_steps: 1,
        long: true,
        ..CS
    };
    check_long("long_branches", cfg, 0x104B_0000, 40);
}

/// [`long_branches`] with the structural features (groups, decomposition,
/// the cut, homomorphism depth) and a homomorphism with contexts.
#[test]
fn long_branches_structural() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        left: 2,
        right: 3,
        right_brackets: true,
        filter: true,
        hom: true,
        context_share: 0.8,
        max_steps: 1,
        structural: true,
        long: true,
        ..CS
    };
    check_long("long_branches_structural", cfg, 0x104C_0000, 16);
}

/// Generate `count` long cases of `cfg` from seed `base` on and compare
/// them (one step): lsgen `-j 1` with the reference, split `-j 2` with
/// `-j 1`.
fn check_long(name: &str, cfg: Cfg, base: u64, count: u64) {
    let scale: u64 = std::env::var("LSGEN_DIFF_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let (mut checked, mut right, mut filtered, mut total) = (0, 0, 0, 0);
    let count = count * scale.max(1);
    for i in 0..count {
        let mut case = gen_case(cfg, base + i);
        case.steps = Some(1);
        let src = case.text();
        let (expected, stats) = derive_text_stats(&src, case.steps, case.seed, 2_000_000);
        if matches!(&expected, Err(e) if e == TOO_LONG) {
            continue;
        }
        let one = lsgen_text(&src, case.steps, case.seed);
        let agree = match (&expected, &one) {
            (Ok(a), Ok(b)) => a == b,
            (Err(_), Err(_)) => true,
            _ => false,
        };
        assert!(
            agree,
            "{name}: case {i} differs from the reference; the system:\n{}\nreference: {}\nlsgen:     {}",
            src.split("axiom:").next().unwrap(),
            clip(&expected),
            clip(&one)
        );
        // The same string or error when split into chunks of 4 KiB.
        let two = lsgen_text_on(&src, case.steps, case.seed, (2, 4096));
        assert!(
            one == two,
            "{name}: case {i}: -j 2 differs from -j 1 on\n{src}"
        );
        checked += 1;
        total += one.as_ref().map_or(0, String::len);
        right += usize::from(stats.right_brackets > 0);
        filtered += usize::from(stats.filtered > 0);
    }
    eprintln!(
        "{name}: {checked} of {count} cases, {right} with a bracketed right context, \
         {filtered} with a context through ignored modules, {total} bytes of output"
    );
    assert!(
        checked as u64 == count,
        "{name}: only {checked} of {count} cases checked"
    );
    assert!(
        right * 4 >= checked && filtered * 2 >= checked,
        "{name}: features rarely exercised"
    );
}

// ---------------------------------------------------------------------------
// Fixed cases.

/// The reference and lsgen must both give `want`.
fn check_fixed(src: &str, steps: Option<u64>, seed: Option<u64>, want: &str) {
    let expected = derive_text(src, steps, seed, usize::MAX);
    assert_eq!(expected.as_deref(), Ok(want), "reference on\n{src}");
    let actual = lsgen_text(src, steps, seed);
    assert_eq!(actual.as_deref(), Ok(want), "lsgen on\n{src}");
}

#[test]
fn fixed_abop_context_example() {
    // ABOP p. 32: in ABC[DE][SG[HI[JK]L]MNO], S has left context BC and
    // right context G[H]M.
    check_fixed(
        "productions:\nB C < S > G [ H ] M -> X\naxiom: ABC[DE][SG[HI[JK]L]MNO]\n",
        Some(1),
        None,
        "ABC[DE][XG[HI[JK]L]MNO]\n",
    );
    // The same contexts must not match once a module is changed.
    check_fixed(
        "productions:\nB C < S > G [ H ] N -> X\nA C < S > G[H]M -> Y\naxiom: ABC[DE][SG[HI[JK]L]MNO]\n",
        Some(1),
        None,
        "ABC[DE][SG[HI[JK]L]MNO]\n",
    );
}

#[test]
fn fixed_parametric_context_example() {
    check_fixed(
        "productions:\nA(a) < B(b) > [C(c)]D(d) -> X(a,b,c,d)\naxiom: A(1)[E]B(2)[C(3)[E][E]D(4)]D(5)\n",
        Some(1),
        None,
        "A(1)[E]X(1,2,3,5)[C(3)[E][E]D(4)]D(5)\n",
    );
}

#[test]
fn fixed_number_formatting() {
    check_fixed(
        "productions:\nF(x) -> F(x*2)G(x/10000000)H(-x*0)I(x+0.5)\naxiom: F(1)\n",
        Some(1),
        None,
        "F(2)G(1e-7)H(-0)I(1.5)\n",
    );
}

/// Run-time errors: both sides must fail.
#[test]
fn fixed_errors_agree() {
    for src in [
        // a negative weight, computed at run time
        "productions:\nA(x) -> B : x\nA(x) -> C : 1\naxiom: A(1)A(-1)\n",
        // division by zero in a successor, a condition, a weight
        "productions:\nA(x) -> B(1/x)\naxiom: A(2)A(0)\n",
        "productions:\nA(x) : 1/x > 0 -> B\naxiom: A(0)\n",
        "productions:\nA(x) -> B : 1/x\nA(x) -> C : 1\naxiom: A(0)\n",
        // overflow, only in the homomorphism
        "productions:\nA(x) -> A(x*x)\nhomomorphism:\nA(x) -> B(x*1e308)\naxiom: A(10)\n",
    ] {
        let expected = derive_text(src, Some(1), Some(0), usize::MAX);
        let actual = lsgen_text(src, Some(1), Some(0));
        assert!(expected.is_err(), "reference accepts\n{src}");
        assert!(actual.is_err(), "lsgen accepts\n{src}: {actual:?}");
    }
}

/// lsgen looks for `axiom:` in the first 16 bytes of a line; a multi-byte
/// character straddling byte 16 once hid the keyword (fixed in 118675f,
/// found by this file's random cases).
#[test]
fn axiom_line_with_multibyte_symbols() {
    check_fixed("axiom: ΩΩΩΩΩ\n", Some(0), None, "ΩΩΩΩΩ\n");
    check_fixed("axiom: FFΩΩΩΩ\n", Some(0), None, "FFΩΩΩΩ\n");
    check_fixed(
        "productions:\nF -> G\naxiom:\nF\nΩΩΩΩ\n",
        Some(1),
        None,
        "GΩΩΩΩ\n",
    );
}

/// The reference against the expectations in tests/expected/, which come
/// from an independent Python rewriter: a check of the reference itself.
#[test]
fn reference_agrees_with_expected_files() {
    let root = env!("CARGO_MANIFEST_DIR");
    let mut checked = 0;
    let mut entries: Vec<_> = std::fs::read_dir(format!("{root}/tests/expected"))
        .expect("tests/expected")
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    entries.sort();
    for name in entries {
        let Some(stem) = name.strip_suffix(".txt") else {
            continue;
        };
        let Some((example, n)) = stem.rsplit_once(".n") else {
            continue;
        };
        let Ok(n) = n.parse::<u64>() else { continue };
        let src = std::fs::read_to_string(format!("{root}/examples/{example}.ls")).unwrap();
        let want = std::fs::read_to_string(format!("{root}/tests/expected/{name}")).unwrap();
        let got = derive_text(&src, Some(n), None, usize::MAX).unwrap();
        assert!(got == want, "reference differs from tests/expected/{name}");
        checked += 1;
    }
    assert!(checked > 50, "only {checked} expected files");
}

// ---------------------------------------------------------------------------
// Metamorphic checks.

/// Deterministic systems: deriving a+b steps equals deriving b steps (with
/// the real binary, `--axiom -`, `--no-homomorphism`) from the string after
/// a steps.
#[test]
fn split_derivation_through_the_binary() {
    let cfg = Cfg {
        params: true,
        cond: true,
        defines: true,
        brackets: true,
        left: 2,
        right: 2,
        right_brackets: true,
        filter: true,
        context_share: 0.4,
        max_steps: 2,
        ..BASE
    };
    let dir = common::tempdir();
    let path = dir.path().join("p.ls");
    let mut done = 0;
    for i in 0..80u64 {
        let mut case = gen_case(cfg, 0xA11CE + i);
        case.hom.clear();
        case.settings
            .retain(|s| !s.starts_with("derivation length"));
        let src = case.text();
        let (a, b) = (1 + i % 2, 1 + (i / 2) % 2);
        let Ok(whole) = lsgen_text(&src, Some(a + b), Some(0)) else {
            continue;
        };
        if whole.len() > 200_000 {
            continue;
        }
        let mid = lsgen_text(&src, Some(a), Some(0)).expect("fewer steps succeed too");
        std::fs::write(&path, &src).unwrap();
        let out = common::run_with_stdin(
            common::lsgen()
                .arg(&path)
                .args(["-n", &b.to_string(), "--axiom", "-", "--no-homomorphism"])
                .args(["--seed", "0"]),
            mid.clone(),
        );
        assert!(out.status.success(), "lsgen failed: {}\n{src}", out.stderr);
        assert_eq!(
            out.out(),
            whole,
            "{a}+{b} steps differ from {} steps on\n{src}",
            a + b
        );
        done += 1;
    }
    assert!(done > 60, "only {done} split derivations checked");
}

/// Productions for a symbol that never occurs change nothing, not even the
/// random stream.
#[test]
fn unused_productions_change_nothing() {
    let cfg = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        random_fns: true,
        brackets: true,
        left: 1,
        right: 2,
        right_brackets: true,
        context_share: 0.3,
        max_steps: 3,
        ..BASE
    };
    for i in 0..150u64 {
        let case = gen_case(cfg, 0xBEEF + i);
        let Ok(plain) = lsgen_text(&case.text(), case.steps, case.seed) else {
            continue;
        };
        let mut more = case.clone();
        let at = i as usize % (more.prods.len() + 1);
        more.prods
            .insert(at, "Z(z) : ran(1) < 2 -> Z(z+ran(1))Z : 0.5".into());
        more.prods.insert(0, "Y > Z -> Y : ran(3)".into());
        let got = lsgen_text(&more.text(), more.steps, more.seed);
        assert_eq!(got.as_ref(), Ok(&plain), "on\n{}", more.text());
    }
}

// ---------------------------------------------------------------------------
// Chained runs (issue 13): `-n a --no-homomorphism | -n b --first-step a+1
// --axiom -` equals `-n a+b`, with the same seed, for every system.

/// The binary on `path` with `args`, the axiom (if any) on standard input.
fn binary(
    path: &std::path::Path,
    args: &[String],
    stdin: Option<String>,
) -> Result<String, String> {
    let mut cmd = common::lsgen();
    cmd.arg(path).args(args);
    let r = match stdin {
        Some(s) => common::run_with_stdin(&mut cmd, s),
        None => common::run(&mut cmd),
    };
    r.assert_no_crash();
    match r.code() {
        Some(0) => Ok(r.out()),
        _ => Err(r.stderr),
    }
}

/// Split `a + b` steps of `path` at `a`: (the whole run, the chained run,
/// the chained run without `--first-step`).
fn chain(
    path: &std::path::Path,
    a: u64,
    b: u64,
    seed: u64,
) -> (
    Result<String, String>,
    Result<String, String>,
    Result<String, String>,
) {
    let s = |x: &str| x.to_string();
    let seed = seed.to_string();
    let whole = binary(
        path,
        &[s("-n"), (a + b).to_string(), s("--seed"), seed.clone()],
        None,
    );
    let Ok(mid) = binary(
        path,
        &[
            s("-n"),
            a.to_string(),
            s("--seed"),
            seed.clone(),
            s("--no-homomorphism"),
        ],
        None,
    ) else {
        return (whole, Err("first half failed".into()), Err(String::new()));
    };
    let second = |first: u64| {
        binary(
            path,
            &[
                s("-n"),
                b.to_string(),
                s("--seed"),
                seed.clone(),
                s("--first-step"),
                first.to_string(),
                s("--axiom"),
                s("-"),
            ],
            Some(mid.clone()),
        )
    };
    (whole, second(a + 1), second(1))
}

#[test]
fn chained_runs_equal_one_run() {
    let stochastic = Cfg {
        params: true,
        cond: true,
        stochastic: true,
        random_fns: true,
        brackets: true,
        hom: true,
        max_steps: 3,
        ..BASE
    };
    let context = Cfg {
        left: 2,
        right: 2,
        right_brackets: true,
        filter: true,
        context_share: 0.5,
        ..stochastic
    };
    let parametric = Cfg {
        stochastic: false,
        defines: true,
        ..stochastic
    };
    let dir = common::tempdir();
    let path = dir.path().join("p.ls");
    for (name, cfg) in [
        ("stochastic", stochastic),
        ("context", context),
        ("parametric", parametric),
    ] {
        let (mut done, mut step_matters) = (0, 0);
        for i in 0..40u64 {
            let mut case = gen_case(cfg, 0xC4A1 + i);
            case.settings
                .retain(|s| !s.starts_with("derivation length"));
            let src = case.text();
            std::fs::write(&path, &src).unwrap();
            let (a, b) = (1 + i % 2, 1 + (i / 2) % 2);
            let seed = case.seed.unwrap_or(7);
            let (whole, chained, unnumbered) = chain(&path, a, b, seed);
            let Ok(whole) = whole else { continue };
            if whole.len() > 100_000 {
                continue;
            }
            assert_eq!(
                chained.as_ref(),
                Ok(&whole),
                "{name}: {a}+{b} steps differ from {} on\n{src}",
                a + b
            );
            done += 1;
            step_matters += usize::from(unnumbered.as_ref() != Ok(&whole));
        }
        assert!(done >= 25, "{name}: only {done} chained runs checked");
        // The check can fail: without --first-step the draws differ.
        if name != "parametric" {
            assert!(
                step_matters >= 10,
                "{name}: the step number changed only {step_matters} outputs"
            );
        }
    }
}

#[test]
fn chained_runs_equal_one_run_on_the_examples() {
    let mut done = 0;
    let mut step_matters = 0;
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/examples")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "ls") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let n: u64 = text
            .lines()
            .find_map(|l| l.strip_prefix("derivation length:"))
            .map_or(1, |v| v.trim().parse().unwrap());
        let n = n.clamp(2, 8);
        let a = n / 2;
        let (whole, chained, unnumbered) = chain(&path, a, n - a, 7);
        let whole = whole.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(
            chained.as_ref(),
            Ok(&whole),
            "{}: {a}+{} steps",
            path.display(),
            n - a
        );
        step_matters += usize::from(unnumbered.as_ref() != Ok(&whole));
        done += 1;
    }
    assert!(done >= 30, "only {done} examples");
    // stochastic_plant and stochastic_row draw.
    assert!(
        step_matters >= 2,
        "the step number changed only {step_matters} examples"
    );
}

/// The uniform at draw position `p` of `stream` for `seed`, from README's
/// description of the scheme.
fn uniform_at(seed: u64, stream: u64, p: u128) -> String {
    use rand_chacha::rand_core::{Rng, SeedableRng};
    let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r.set_word_pos(2 * p);
    format_number((r.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
}

#[test]
fn draws_sit_at_their_documented_positions() {
    // The axiom: stream 0, module index in the axiom, draws in order.
    let src = "axiom: F(ran(1))[G(ran(1),ran(1))]\n";
    let d = |i: u128, k: u128| uniform_at(3, 0, k << 59 | i);
    let want = format!("F({})[G({},{})]\n", d(0, 0), d(2, 0), d(2, 1));
    assert_eq!(lsgen_text(src, Some(0), Some(3)).unwrap(), want);
    // Step 5 (`--first-step 4`, 2 steps): stream 5, index in generation 4;
    // the homomorphism after it: stream 5, region 1.
    let dir = common::tempdir();
    let path = dir.path().join("p.ls");
    std::fs::write(
        &path,
        "productions:\nA(x) : x > 0 -> [A(0)]A(ran(1))\nhomomorphism:\nA(x) -> B(x,ran(1))\naxiom: A(1)\n",
    )
    .unwrap();
    let out = binary(
        &path,
        &["--seed", "9", "--first-step", "4", "-n", "2"].map(String::from),
        None,
    )
    .unwrap();
    // Step 4: A(1) -> [A(0)]A(u), u = module 0's draw on stream 4.
    let u = uniform_at(9, 4, 0);
    // Step 5: [A(0)]A(u) -> [A(0)][A(0)]A(v), v = module 3's draw on stream 5.
    let v = uniform_at(9, 5, 3);
    // Homomorphism: modules 1, 4, 6 of `[A(0)][A(0)]A(v)` draw.
    let h = |i: u128| uniform_at(9, 5, 1 << 65 | i);
    let want = format!("[B(0,{})][B(0,{})]B({v},{})\n", h(1), h(4), h(6));
    assert_eq!(out, want, "u = {u}");
}

// ---------------------------------------------------------------------------
// Issue 11 on the position-based draws (issue 13).

/// A cut drops the rest of its branch, but the modules after it keep their
/// indices in the old generation for their draws (README, "Structural
/// rewriting"): `X` is module 7 of `[%AAAA]X`, not module 3.
#[test]
fn draws_after_a_cut_keep_their_indices() {
    for extra in ["", "C > D -> C\n"] {
        let src = format!("productions:\nX -> Y(ran(1))\n{extra}axiom: [%AAAA]X\n");
        let want = uniform_at(5, 1, 7);
        let (reference, _) = derive_text_stats(&src, Some(1), Some(5), usize::MAX);
        assert_eq!(reference, Ok(format!("[]Y({want})\n")), "{src}");
        assert_eq!(lsgen_text(&src, Some(1), Some(5)), reference, "{src}");
        assert_eq!(
            lsgen_step_text(&src, Some(1), Some(5)).map(|s| s + "\n"),
            reference,
            "{src}"
        );
    }
}

/// `step` and the group schedule number the steps as the draws do, so a
/// chained run with `--first-step` equals one run for them too.
#[test]
fn chained_runs_with_step_and_groups_equal_one_run() {
    let dir = common::tempdir();
    let path = dir.path().join("p.ls");
    std::fs::write(
        &path,
        "groups: 1 2\nproductions:\nA -> A\nproductions 1:\nA -> F(step)A\nproductions 2:\nA -> [+G(step, ran(1))]A\ndecomposition:\nG(x, y) -> H(x)\naxiom: A\n",
    )
    .unwrap();
    let (whole, chained, unnumbered) = chain(&path, 2, 3, 11);
    let whole = whole.unwrap();
    // Steps 1..5 use groups 1 2 1 2 1.
    assert!(whole.starts_with("F(1)[+H(2)]F(3)[+H(4)]F(5)A"), "{whole}");
    assert_eq!(chained, Ok(whole.clone()));
    assert_ne!(unnumbered, Ok(whole));
}

/// `--frames` applies decomposition in the steps, never to a frame's copy,
/// and the homomorphism's own `seed:` to each frame alone: every frame is
/// what `lsgen -n k` prints.
#[test]
fn frames_of_structural_systems_equal_single_runs() {
    let dir = common::tempdir();
    let path = dir.path().join("p.ls");
    std::fs::write(
        &path,
        "productions:\nA(x) -> [%Q]A(ran(1))I\ndecomposition:\nI -> J\nJ -> F(step)\nhomomorphism:\nmaximum depth: 2\nseed: 4\nA(x) -> B(ran(1))\nB(x) -> C(x, ran(1))\nF(x) -> G(x)\naxiom: A(0) I\n",
    )
    .unwrap();
    let args = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    // Without the homomorphism a frame is a plain copy of its generation,
    // which holds a `%` and a `J` (kept by the maximum depth 1).
    for hom in [&[][..], &["--no-homomorphism"][..]] {
        let frames = binary(
            &path,
            &args(&[&["--seed", "3", "--frames", "0..4"][..], hom].concat()),
            None,
        )
        .unwrap();
        let lines: Vec<&str> = frames.lines().collect();
        assert_eq!(lines.len(), 5);
        for (k, line) in lines.iter().enumerate() {
            let n = k.to_string();
            let one = binary(
                &path,
                &args(&[&["--seed", "3", "-n", &n][..], hom].concat()),
                None,
            );
            assert_eq!(format!("{line}\n"), one.unwrap(), "frame {k} {hom:?}");
        }
        assert!(hom.is_empty() || lines[2].contains("[%Q]") && lines[2].contains('J'));
    }
}

/// Keys decided by their neighbours in the byte table
/// (derive::choose::Neighbours) over a generation larger than the step
/// reader's window (1 MiB): windows and chunks end next to such keys, inside
/// ignored runs longer than a window and inside branches, where the table
/// must leave the module to the general path.
#[test]
fn one_module_contexts_across_reader_windows() {
    let mut axiom = String::new();
    let mut i = 0usize;
    while axiom.len() < 4_000_000 {
        let run = [0, 1, 3, 700, 5_000][i % 5] + (i % 7);
        axiom.push_str(["ba", "ab", "ca", "a[", "da", "a]", "ac"][i % 7]);
        axiom.push_str(&"+".repeat(run));
        if i % 11 == 0 {
            axiom.push_str("[c+a]");
        }
        if i % 1_001 == 500 {
            axiom.push_str(&"+".repeat(1_200_000));
        }
        i += 1;
    }
    let depth = axiom.matches('[').count() - axiom.matches(']').count();
    axiom.push_str(&"]".repeat(depth));
    // (`]` never runs ahead of `[`: each `a]` follows an earlier `a[`.)
    let src = format!(
        "ignore: +\nproductions:\nb < a > c -> b[+c]\nc < a -> \na > d -> dd\nb > a -> c\nd < b -> a\nc > b -> [a]\na > a -> e\naxiom:\n{axiom}\n"
    );
    for steps in [1, 2] {
        agrees_with_the_reference(&src, steps, None, &format!("{steps} steps"));
        let one = lsgen_text(&src, Some(steps), None);
        assert!(
            one == lsgen_text_on(&src, Some(steps), None, (2, 65_536)),
            "{steps} steps: -j 2 differs from -j 1"
        );
    }
}

/// `src` derived `steps` steps with `seed` gives the reference's string,
/// without an error (`what` names the case in the panic).
fn agrees_with_the_reference(src: &str, steps: u64, seed: Option<u64>, what: &str) {
    match compare(src, Some(steps), seed, 50_000_000) {
        Outcome::Same { error: false, .. } => {}
        Outcome::Same { error: true, .. } => panic!("{what}: an error"),
        Outcome::Skipped => panic!("{what}: too long for the reference"),
        Outcome::Differ { expected, actual } => panic!(
            "{what} differs:\nreference: {}\nlsgen:     {}",
            clip(&expected),
            clip(&actual)
        ),
    }
}

/// Two strings where a right-context walk jumped out of the look-ahead
/// reader's buffer and came back into it before reading there: the next
/// refill read around that buffer's start (a mark of the jump left set),
/// so the walk went back thousands of bytes. `-j 1` gave the wrong string
/// (`jump_back_ignore.ls`, `ignore: a1`, `a > ]]`) or crashed reading a
/// module from inside a parameter (`jump_back_consider.ls`, `consider:`,
/// a context naming a module never considered); the split runs, whose
/// workers start with fresh readers, crashed elsewhere. Found by the
/// review helper's differential campaign on strings of 10^5 to 10^7
/// modules; both fail before the fix. Each agrees with the reference, at
/// `-j 1` and split at `-j 2`.
#[test]
fn a_walk_that_jumps_and_comes_back_reads_on() {
    for (file, seed) in [
        ("jump_back_ignore.ls", None),
        ("jump_back_consider.ls", Some(491_349)),
    ] {
        let path = format!("{}/tests/regressions/{file}", env!("CARGO_MANIFEST_DIR"));
        let src = std::fs::read_to_string(path).unwrap();
        agrees_with_the_reference(&src, 1, seed, file);
        let one = lsgen_text(&src, Some(1), seed);
        for split in [64, 4096] {
            assert!(
                one == lsgen_text_on(&src, Some(1), seed, (2, split)),
                "{file}: -j 2 (split {split}) differs from -j 1"
            );
        }
    }
}
