//! A tiny in-memory reference rewriter for differential tests.
//!
//! It reuses lsgen's header parser, expression compiler and random
//! generator, but does matching, choice, contexts and output itself, over a
//! plain `Vec<Module>` holding the whole string. It is written to be read
//! against the specification, not to be fast: every module looks up its
//! productions by a linear scan, and every context is found by walking the
//! string from the module outwards.

use lsgen::ast::{self, Expr, Setting};
use lsgen::expr::{Code, Scope};
use lsgen::parse::{parse_expr, parse_header};
use lsgen::random::Random;
use std::cell::Cell;
use std::collections::{HashMap, HashSet};

/// A module of a string: a symbol and its parameter values.
#[derive(Clone, Debug, PartialEq)]
pub struct Module {
    pub sym: char,
    pub params: Vec<f64>,
}

impl Module {
    /// Modules are told apart by symbol and number of parameters.
    pub fn key(&self) -> (char, usize) {
        (self.sym, self.params.len())
    }
    pub fn is_open(&self) -> bool {
        self.key() == ('[', 0)
    }
    pub fn is_close(&self) -> bool {
        self.key() == (']', 0)
    }
}

/// `2.0` -> `2`, `1e-7` -> `1e-7`, `-0.0` -> `-0`.
pub fn format_number(v: f64) -> String {
    let mut b = ryu::Buffer::new();
    let s = b.format_finite(v);
    s.strip_suffix(".0").unwrap_or(s).to_string()
}

/// A string on one line, without the final newline.
pub fn format_string(s: &[Module]) -> String {
    let mut out = String::new();
    for m in s {
        out.push(m.sym);
        if !m.params.is_empty() {
            let p: Vec<String> = m.params.iter().map(|&v| format_number(v)).collect();
            out.push('(');
            out.push_str(&p.join(","));
            out.push(')');
        }
    }
    out
}

/// Which modules contexts see.
#[derive(Clone, Debug)]
enum Filter {
    All,
    Ignore(HashSet<char>),
    Consider(HashSet<char>),
}

/// A module in a pattern (predecessor or context): its key, and the slot
/// its first parameter is bound to.
#[derive(Clone, Debug)]
struct Pattern {
    sym: char,
    arity: usize,
    first_slot: usize,
}

impl Pattern {
    fn key(&self) -> (char, usize) {
        (self.sym, self.arity)
    }
    fn bind(&self, m: &Module, slots: &mut [f64]) {
        slots[self.first_slot..self.first_slot + self.arity].copy_from_slice(&m.params);
    }
}

#[derive(Clone, Debug)]
enum RightItem {
    Module(Pattern),
    Open,
    Close,
}

struct Rule {
    pred: Pattern,
    left: Vec<Pattern>,
    right: Vec<RightItem>,
    nslots: usize,
    cond: Option<Code>,
    prob: Option<Code>,
    succ: Vec<(char, Vec<Code>)>,
}

impl Rule {
    fn has_context(&self) -> bool {
        !self.left.is_empty() || !self.right.is_empty()
    }
}

/// What happened during a derivation, to see that tests exercise what they
/// should.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    /// Productions applied that have a left context.
    pub left: u64,
    /// ... a right context.
    pub right: u64,
    /// ... a right context with `[` or `]` in it.
    pub right_brackets: u64,
    /// ... a context, while some modules are ignored.
    pub filtered: u64,
    /// Choices between several candidates (one draw each).
    pub draws: u64,
}

pub struct System {
    stats: Cell<Stats>,
    filter: Filter,
    rules: Vec<Rule>,
    homomorphism: Vec<Rule>,
    pub derivation_length: Option<u64>,
    pub seed: Option<u64>,
    consts: HashMap<String, f64>,
    axiom_text: String,
}

type R<T> = Result<T, String>;

fn compile_expr(e: &Expr, names: &HashMap<String, u32>, consts: &HashMap<String, f64>) -> R<Code> {
    Code::compile(
        e,
        &Scope {
            params: names,
            consts,
        },
    )
    .map_err(|e| format!("compile error: {}", e.message))
}

fn constant(e: &Expr, consts: &HashMap<String, f64>) -> R<f64> {
    let c = compile_expr(e, &HashMap::new(), consts)?;
    c.eval(&[], &mut Vec::new(), &mut Random::new(0))
        .map_err(|e| format!("eval error: {}", e.message))
}

fn whole(e: &Expr, consts: &HashMap<String, f64>) -> R<u64> {
    let v = constant(e, consts)?;
    if v < 0.0 || v.fract() != 0.0 {
        return Err(format!("not a whole number: {v}"));
    }
    Ok(v as u64)
}

/// Give each formal parameter of `m` the next slot.
fn formals(m: &ast::Module, names: &mut HashMap<String, u32>) -> R<Pattern> {
    let first_slot = names.len();
    for e in &m.params {
        let Expr::Var(name, _) = e else {
            return Err("a formal parameter must be a name".into());
        };
        let slot = names.len() as u32;
        if names.insert(name.clone(), slot).is_some() {
            return Err(format!("`{name}` is bound twice"));
        }
    }
    Ok(Pattern {
        sym: m.sym,
        arity: m.params.len(),
        first_slot,
    })
}

fn compile_rule(p: &ast::Production, consts: &HashMap<String, f64>) -> R<Rule> {
    if matches!(p.pred.sym, '[' | ']') {
        return Err("brackets cannot be rewritten".into());
    }
    let mut names = HashMap::new();
    let pred = formals(&p.pred, &mut names)?;
    let mut left = Vec::new();
    for m in &p.left {
        if matches!(m.sym, '[' | ']') {
            return Err("no brackets in a left context".into());
        }
        left.push(formals(m, &mut names)?);
    }
    let mut right = Vec::new();
    for m in &p.right {
        right.push(match m.sym {
            '[' | ']' if !m.params.is_empty() => return Err("bracket with parameters".into()),
            '[' => RightItem::Open,
            ']' => RightItem::Close,
            _ => RightItem::Module(formals(m, &mut names)?),
        });
    }
    let cond = p
        .cond
        .as_ref()
        .map(|e| compile_expr(e, &names, consts))
        .transpose()?;
    let prob = p
        .prob
        .as_ref()
        .map(|e| compile_expr(e, &names, consts))
        .transpose()?;
    let mut succ = Vec::new();
    for m in &p.succ {
        let codes = m
            .params
            .iter()
            .map(|e| compile_expr(e, &names, consts))
            .collect::<R<Vec<Code>>>()?;
        succ.push((m.sym, codes));
    }
    Ok(Rule {
        pred,
        left,
        right,
        nslots: names.len(),
        cond,
        prob,
        succ,
    })
}

/// Split an `.ls` text at the line that starts with `axiom:`.
fn split(src: &str) -> R<(&str, &str)> {
    let mut at = 0;
    for line in src.split_inclusive('\n') {
        let t = line.trim_start();
        if t.get(..6).is_some_and(|k| k.eq_ignore_ascii_case("axiom:")) {
            let kw = at + (line.len() - t.len());
            return Ok((&src[..at], &src[kw + 6..]));
        }
        at += line.len();
    }
    Err("no axiom".into())
}

impl System {
    pub fn load(src: &str) -> R<System> {
        let (header, axiom_text) = split(src)?;
        let h = parse_header(header).map_err(|e| format!("parse error: {}", e.message))?;
        let mut consts = HashMap::new();
        let mut derivation_length = None;
        let mut seed = None;
        let mut filter = Filter::All;
        for s in &h.settings {
            match s {
                Setting::DerivationLength(e, _) => derivation_length = Some(whole(e, &consts)?),
                Setting::Seed(e, _) => seed = Some(whole(e, &consts)?),
                Setting::Define(name, e, _) => {
                    let v = constant(e, &consts)?;
                    consts.insert(name.clone(), v);
                }
                Setting::Ignore(ms, _) => {
                    let mut set: HashSet<char> = ms.iter().map(|m| m.sym).collect();
                    if let Filter::Ignore(old) = &filter {
                        set.extend(old);
                    }
                    filter = Filter::Ignore(set);
                }
                Setting::Consider(ms, _) => {
                    let mut set: HashSet<char> = ms.iter().map(|m| m.sym).collect();
                    if let Filter::Consider(old) = &filter {
                        set.extend(old);
                    }
                    filter = Filter::Consider(set);
                }
            }
        }
        let rules = h
            .productions
            .iter()
            .map(|p| compile_rule(p, &consts))
            .collect::<R<Vec<_>>>()?;
        let homomorphism = h
            .homomorphism
            .iter()
            .map(|p| compile_rule(p, &consts))
            .collect::<R<Vec<_>>>()?;
        Ok(System {
            stats: Cell::new(Stats::default()),
            filter,
            rules,
            homomorphism,
            derivation_length,
            seed,
            consts,
            axiom_text: axiom_text.to_string(),
        })
    }

    /// Derive; `steps`/`seed` override the file's. Gives up with an error
    /// when a generation exceeds `max_modules`.
    pub fn derive(
        &self,
        steps: Option<u64>,
        seed: Option<u64>,
        max_modules: usize,
    ) -> R<Vec<Module>> {
        let steps = steps.or(self.derivation_length).unwrap_or(1);
        let mut rng = Random::new(seed.or(self.seed).unwrap_or(0));
        let mut s = self.parse_axiom(&mut rng)?;
        for _ in 0..steps {
            s = self.rewrite(&self.rules, &s, &mut rng)?;
            if s.len() > max_modules {
                return Err(TOO_LONG.into());
            }
        }
        if !self.homomorphism.is_empty() {
            s = self.rewrite(&self.homomorphism, &s, &mut rng)?;
        }
        Ok(s)
    }

    /// The axiom: symbols, each with an optional parameter list.
    fn parse_axiom(&self, rng: &mut Random) -> R<Vec<Module>> {
        let chars: Vec<char> = self.axiom_text.chars().collect();
        let mut out = Vec::new();
        let mut i = 0;
        let skip_blank = |i: &mut usize| {
            while *i < chars.len() && chars[*i].is_whitespace() {
                *i += 1;
            }
        };
        loop {
            skip_blank(&mut i);
            if i == chars.len() {
                break;
            }
            let sym = chars[i];
            i += 1;
            let mut params = Vec::new();
            skip_blank(&mut i);
            if i < chars.len() && chars[i] == '(' {
                i += 1;
                let mut depth = 0;
                let mut piece = String::new();
                loop {
                    let c = *chars.get(i).ok_or("unclosed `(` in the axiom")?;
                    i += 1;
                    match c {
                        '(' => depth += 1,
                        ')' if depth > 0 => depth -= 1,
                        ')' | ',' if depth == 0 => {
                            params.push(self.axiom_param(piece.trim(), rng)?);
                            piece.clear();
                            if c == ')' {
                                break;
                            }
                            continue;
                        }
                        _ => {}
                    }
                    piece.push(c);
                }
            }
            out.push(Module { sym, params });
        }
        Ok(out)
    }

    fn axiom_param(&self, t: &str, rng: &mut Random) -> R<f64> {
        if let Ok(v) = t.parse::<f64>() {
            return Ok(v);
        }
        let e = parse_expr(t).map_err(|e| e.message)?;
        let c = compile_expr(&e, &HashMap::new(), &self.consts)?;
        c.eval(&[], &mut Vec::new(), rng).map_err(|e| e.message)
    }

    /// Do contexts see this module? Brackets are always seen.
    fn seen(&self, m: &Module) -> bool {
        if m.sym == '[' || m.sym == ']' {
            return true;
        }
        match &self.filter {
            Filter::All => true,
            Filter::Ignore(s) => !s.contains(&m.sym),
            Filter::Consider(s) => s.contains(&m.sym),
        }
    }

    /// One parallel rewriting pass with `rules` over `s`.
    fn rewrite(&self, rules: &[Rule], s: &[Module], rng: &mut Random) -> R<Vec<Module>> {
        let mut out = Vec::new();
        for pos in 0..s.len() {
            let mine: Vec<&Rule> = rules
                .iter()
                .filter(|r| r.pred.key() == s[pos].key())
                .collect();
            let context: Vec<&Rule> = mine.iter().copied().filter(|r| r.has_context()).collect();
            let free: Vec<&Rule> = mine.iter().copied().filter(|r| !r.has_context()).collect();
            let mut chosen = self.choose(&context, s, pos, rng)?;
            if chosen.is_none() {
                chosen = self.choose(&free, s, pos, rng)?;
            }
            match chosen {
                None => out.push(s[pos].clone()),
                Some((rule, slots)) => {
                    self.count(rule);
                    for (sym, codes) in &rule.succ {
                        let mut params = Vec::new();
                        for c in codes {
                            params.push(eval(c, &slots, rng)?);
                        }
                        out.push(Module { sym: *sym, params });
                    }
                }
            }
        }
        Ok(out)
    }

    fn count(&self, rule: &Rule) {
        let mut st = self.stats.get();
        st.left += u64::from(!rule.left.is_empty());
        st.right += u64::from(!rule.right.is_empty());
        st.right_brackets += u64::from(
            rule.right
                .iter()
                .any(|r| !matches!(r, RightItem::Module(_))),
        );
        st.filtered += u64::from(rule.has_context() && !matches!(self.filter, Filter::All));
        self.stats.set(st);
    }

    pub fn stats(&self) -> Stats {
        self.stats.get()
    }

    /// Pick a production of `group` for the module at `pos`, with its slots.
    fn choose<'r>(
        &self,
        group: &[&'r Rule],
        s: &[Module],
        pos: usize,
        rng: &mut Random,
    ) -> R<Option<(&'r Rule, Vec<f64>)>> {
        let stochastic = group.iter().any(|r| r.prob.is_some());
        if !stochastic {
            for r in group {
                if let Some(slots) = self.applies(r, s, pos, rng)? {
                    return Ok(Some((r, slots)));
                }
            }
            return Ok(None);
        }
        let mut candidates: Vec<(&Rule, Vec<f64>, f64)> = Vec::new();
        for r in group {
            if let Some(slots) = self.applies(r, s, pos, rng)? {
                let w = match &r.prob {
                    None => 1.0,
                    Some(c) => eval(c, &slots, rng)?,
                };
                if w < 0.0 {
                    return Err(format!("negative probability {w}"));
                }
                if w > 0.0 {
                    candidates.push((r, slots, w));
                }
            }
        }
        if candidates.len() <= 1 {
            return Ok(candidates.pop().map(|(r, slots, _)| (r, slots)));
        }
        let mut total = 0.0;
        for c in &candidates {
            total += c.2;
        }
        let mut st = self.stats.get();
        st.draws += 1;
        self.stats.set(st);
        let mut u = rng.uniform() * total;
        let last = candidates.len() - 1;
        for (i, (r, slots, w)) in candidates.into_iter().enumerate() {
            u -= w;
            if u < 0.0 || i == last {
                return Ok(Some((r, slots)));
            }
        }
        unreachable!()
    }

    /// Does `r` apply at `pos` (contexts, then condition)? Its slots if so.
    fn applies(&self, r: &Rule, s: &[Module], pos: usize, rng: &mut Random) -> R<Option<Vec<f64>>> {
        let mut slots = vec![0.0; r.nslots];
        r.pred.bind(&s[pos], &mut slots);
        if !self.left_context(s, pos, &r.left, &mut slots) {
            return Ok(None);
        }
        if !self.right_context(s, pos + 1, &r.right, &mut slots) {
            return Ok(None);
        }
        if let Some(c) = &r.cond {
            if eval(c, &slots, rng)? == 0.0 {
                return Ok(None);
            }
        }
        Ok(Some(slots))
    }

    /// Walk left from `pos`: step over `[`, skip whole branches `[...]`
    /// and unseen modules; the modules found, nearest first, must be the
    /// pattern read from its end.
    fn left_context(&self, s: &[Module], pos: usize, pats: &[Pattern], slots: &mut [f64]) -> bool {
        let mut i = pos; // the next candidate is s[i - 1]
        for pat in pats.iter().rev() {
            let found = loop {
                if i == 0 {
                    return false;
                }
                i -= 1;
                let m = &s[i];
                if m.is_close() {
                    // back to the `[` that opens this branch
                    let mut depth = 1;
                    while depth > 0 {
                        if i == 0 {
                            return false;
                        }
                        i -= 1;
                        if s[i].is_close() {
                            depth += 1;
                        } else if s[i].is_open() {
                            depth -= 1;
                        }
                    }
                    continue;
                }
                if m.is_open() || !self.seen(m) {
                    continue;
                }
                break m;
            };
            if found.key() != pat.key() {
                return false;
            }
            pat.bind(found, slots);
        }
        true
    }

    /// Match the right-context pattern `pats` from `s[i]` on.
    fn right_context(
        &self,
        s: &[Module],
        mut i: usize,
        pats: &[RightItem],
        slots: &mut [f64],
    ) -> bool {
        let Some((first, rest)) = pats.split_first() else {
            return true;
        };
        match first {
            RightItem::Module(pat) => loop {
                let Some(m) = s.get(i) else {
                    return false;
                };
                if m.is_open() {
                    i = after_branch(s, i);
                } else if m.is_close() {
                    return false;
                } else if !self.seen(m) {
                    i += 1;
                } else if m.key() != pat.key() {
                    return false;
                } else {
                    pat.bind(m, slots);
                    return self.right_context(s, i + 1, rest, slots);
                }
            },
            RightItem::Open => {
                while i < s.len() && !self.seen(&s[i]) {
                    i += 1;
                }
                loop {
                    if !s.get(i).is_some_and(Module::is_open) {
                        return false;
                    }
                    if self.right_context(s, i + 1, rest, slots) {
                        return true;
                    }
                    i = after_branch(s, i);
                }
            }
            RightItem::Close => {
                let mut depth = 0;
                loop {
                    let Some(m) = s.get(i) else {
                        return false;
                    };
                    i += 1;
                    if m.is_open() {
                        depth += 1;
                    } else if m.is_close() {
                        if depth == 0 {
                            break;
                        }
                        depth -= 1;
                    }
                }
                self.right_context(s, i, rest, slots)
            }
        }
    }
}

/// The message of the error `derive` gives for too long a string.
pub const TOO_LONG: &str = "the reference gives up: string too long";

/// The index just after the `]` that closes the `[` at `open`.
fn after_branch(s: &[Module], open: usize) -> usize {
    let mut depth = 0;
    for (j, m) in s.iter().enumerate().skip(open) {
        if m.is_open() {
            depth += 1;
        } else if m.is_close() {
            depth -= 1;
            if depth == 0 {
                return j + 1;
            }
        }
    }
    s.len()
}

fn eval(c: &Code, slots: &[f64], rng: &mut Random) -> R<f64> {
    c.eval(slots, &mut Vec::new(), rng)
        .map_err(|e| format!("eval error: {}", e.message))
}

/// Load and derive: the whole output as `derive_bytes` would give it.
pub fn derive_text(
    src: &str,
    steps: Option<u64>,
    seed: Option<u64>,
    max_modules: usize,
) -> R<String> {
    derive_text_stats(src, steps, seed, max_modules).0
}

/// `derive_text`, with what happened on the way.
pub fn derive_text_stats(
    src: &str,
    steps: Option<u64>,
    seed: Option<u64>,
    max_modules: usize,
) -> (R<String>, Stats) {
    let sys = match System::load(src) {
        Ok(s) => s,
        Err(e) => return (Err(e), Stats::default()),
    };
    let r = sys.derive(steps, seed, max_modules).map(|s| {
        let mut t = format_string(&s);
        t.push('\n');
        t
    });
    (r, sys.stats())
}
