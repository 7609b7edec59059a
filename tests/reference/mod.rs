//! A tiny in-memory reference rewriter for differential tests.
//!
//! It reuses lsgen's header parser, expression compiler and random
//! generator, but does matching, choice, contexts and output itself, over a
//! plain `Vec<Module>` holding the whole string. It is written to be read
//! against the specification, not to be fast: every module looks up its
//! productions by a linear scan, and every context is found by walking the
//! string from the module outwards.
//!
//! It also implements the structural features designed in
//! `docs/structural.md` (issue 11), which lsgen's parser does not know yet:
//! production groups and their schedule, the built-in `step`,
//! decomposition, homomorphism depth and seed, and the cut `%`. Their lines
//! are taken out of the header here (`split_structure`) before the rest
//! goes to lsgen's header parser.

use lsgen::ast::{self, Expr, Setting};
use lsgen::expr::{Code, Scope};
use lsgen::parse::{parse_expr, parse_header};
use lsgen::random::{Draw, Random, RandomError};
use rand_chacha::rand_core::{Rng as _, SeedableRng as _};
use rand_chacha::ChaCha8Rng;
use std::cell::{Cell, RefCell};
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
    /// The slot of the built-in `step`, unless a formal parameter or a
    /// constant of that name hides it.
    step_slot: Option<usize>,
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

/// Which group each step uses.
enum Schedule {
    /// Always group 0.
    None,
    /// `groups: G1 G2 ...`, cycling.
    List(Vec<u32>),
    /// `group: EXPR` of `step` (slot 0, if not hidden by a constant).
    Expr(Code),
}

pub struct System {
    stats: Cell<Stats>,
    filter: Filter,
    /// Group 0.
    rules: Vec<Rule>,
    /// Groups 1 and up.
    groups: HashMap<u32, Vec<Rule>>,
    schedule: Schedule,
    decomposition: Vec<Rule>,
    decomposition_depth: usize,
    homomorphism: Vec<Rule>,
    homomorphism_depth: usize,
    homomorphism_seed: Option<u64>,
    /// The value of `step` while rewriting.
    step: Cell<f64>,
    pub derivation_length: Option<u64>,
    pub seed: Option<u64>,
    consts: HashMap<String, f64>,
    axiom_text: String,
    /// The bracket tables of the last long string asked about
    /// ([`System::close_after`], [`System::open_of`]).
    brackets: RefCell<Brackets>,
}

type R<T> = Result<T, String>;

fn compile_expr(e: &Expr, names: &HashMap<String, u32>, consts: &HashMap<String, f64>) -> R<Code> {
    Code::compile(
        e,
        &Scope {
            params: names,
            consts,
            cpfg: false,
        },
    )
    .map_err(|e| format!("compile error: {}", e.message()))
}

fn constant(e: &Expr, consts: &HashMap<String, f64>) -> R<f64> {
    let c = compile_expr(e, &HashMap::new(), consts)?;
    c.eval(&[], &mut Vec::new(), &mut Random::new(0))
        .map_err(|e| format!("eval error: {}", e.message()))
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
    let mut step_slot = None;
    let mut right = Vec::new();
    for m in &p.right {
        right.push(match m.sym {
            '[' | ']' if !m.params.is_empty() => return Err("bracket with parameters".into()),
            '[' => RightItem::Open,
            ']' => RightItem::Close,
            _ => RightItem::Module(formals(m, &mut names)?),
        });
    }
    if !names.contains_key(STEP) && !consts.contains_key(STEP) {
        step_slot = Some(names.len());
        names.insert(STEP.to_string(), names.len() as u32);
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
        step_slot,
        cond,
        prob,
        succ,
    })
}

/// Split an `.ls` text at the line that starts with `axiom:` (blanks and
/// comments on that line may stand before the `:`).
fn split(src: &str) -> R<(&str, &str)> {
    let mut at = 0;
    for line in src.split_inclusive('\n') {
        let t = line.trim_start();
        if t.get(..5).is_some_and(|k| k.eq_ignore_ascii_case("axiom")) {
            // Past blanks and comments that end on this line.
            let mut rest = &t[5..];
            loop {
                let r = rest.trim_start_matches(|c: char| c != '\n' && c.is_whitespace());
                match r
                    .strip_prefix("/*")
                    .and_then(|c| c.find("*/").map(|e| (c, e)))
                {
                    Some((c, e)) if !c[..e].contains('\n') => rest = &c[e + 2..],
                    _ => {
                        rest = r;
                        break;
                    }
                }
            }
            if rest.starts_with(':') {
                // (`rest` is the end of `line`.)
                let colon = at + line.len() - rest.len();
                return Ok((&src[..at], &src[colon + 1..]));
            }
        }
        at += line.len();
    }
    Err("no axiom".into())
}

/// The name of the built-in step number.
const STEP: &str = "step";
/// Limits of `maximum depth:` and of group numbers.
const MAX_DEPTH: u64 = 10_000;
const MAX_GROUP: u64 = 65_535;

/// The header with the structural lines taken out, and what they said.
#[derive(Default)]
struct Structure {
    /// Settings, group 0 and the homomorphism, for lsgen's parser.
    main: String,
    /// `productions N:` (N >= 1): the production lines of each group.
    groups: Vec<(u32, String)>,
    /// The production lines of `decomposition:`, if the section exists.
    decomposition: Option<String>,
    decomposition_depth: Option<u64>,
    homomorphism_depth: Option<u64>,
    homomorphism_seed: Option<u64>,
    /// `groups:` numbers, or the text of `group:`.
    list: Option<Vec<u32>>,
    expr: Option<String>,
}

/// Comments replaced by blanks (newlines kept), so that keywords are found
/// at the start of their lines.
fn blank_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find("/*") {
        let Some(len) = rest[at + 2..].find("*/") else {
            break; // unterminated: lsgen's parser reports it
        };
        out.push_str(&rest[..at]);
        for c in rest[at..at + 2 + len + 2].chars() {
            out.push(if c == '\n' { '\n' } else { ' ' });
        }
        rest = &rest[at + 2 + len + 2..];
    }
    out.push_str(rest);
    out
}

/// A whole number in `lo..=hi` written in decimal digits.
fn whole_text(t: &str, lo: u64, hi: u64, what: &str) -> R<u64> {
    let t = t.trim();
    match t.parse::<u64>() {
        Ok(v) if t.bytes().all(|b| b.is_ascii_digit()) && (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!(
            "{what} must be a whole number from {lo} to {hi}: `{t}`"
        )),
    }
}

/// `NAME [N]: REST` for the three section names.
fn section_line(low: &str) -> Option<(&'static str, Option<&str>, &str)> {
    for name in ["productions", "decomposition", "homomorphism"] {
        let Some(after) = low.strip_prefix(name) else {
            continue;
        };
        let colon = after.find(':')?;
        let num = after[..colon].trim();
        if !num.is_empty() && !after.starts_with(char::is_whitespace) {
            return None;
        }
        let rest = after[colon + 1..].trim();
        if name == "productions" && !rest.is_empty() {
            return None;
        }
        return Some((name, (!num.is_empty()).then_some(num), rest));
    }
    None
}

/// `maximum depth: V` or `seed: V`, with blanks normalized: (key, V).
fn head_setting(line: &str) -> Option<(String, &str)> {
    let colon = line.find(':')?;
    let key = line[..colon]
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_lowercase();
    matches!(key.as_str(), "maximum depth" | "seed").then(|| (key, &line[colon + 1..]))
}

/// Take the structural lines out of `header` (docs/structural.md).
fn split_structure(header: &str) -> R<Structure> {
    #[derive(Clone, Copy, PartialEq)]
    enum Sec {
        Settings,
        Group(u32),
        Decomposition,
        Homomorphism,
    }
    let text = blank_comments(header);
    let mut st = Structure::default();
    let mut sec = Sec::Settings;
    let mut in_head = false;
    let mut head_seen: Vec<String> = Vec::new();
    let mut declared: Vec<u32> = Vec::new();
    let mut seen_decomposition = false;
    let mut seen_homomorphism = false;
    for line in text.split_inclusive('\n') {
        let t = line.trim();
        let low = t.to_lowercase();
        if let Some((name, num, rest)) = section_line(&low) {
            if name == "productions" {
                if seen_decomposition || seen_homomorphism {
                    return Err("productions after decomposition/homomorphism".into());
                }
                let g = match num {
                    None => 0,
                    Some(n) => whole_text(n, 0, MAX_GROUP, "a production group")? as u32,
                };
                if declared.contains(&g) {
                    return Err(format!("group {g} is declared twice"));
                }
                declared.push(g);
                sec = Sec::Group(g);
                in_head = false;
                if g == 0 {
                    st.main.push_str("productions:\n");
                } else {
                    st.groups.push((g, String::new()));
                }
                continue;
            }
            if num.is_some() {
                return Err(format!("{name} has no groups"));
            }
            if !matches!(rest, "" | "warnings" | "no warnings") {
                return Err(format!(
                    "expected `warnings` or `no warnings` after `{name}:`"
                ));
            }
            if name == "decomposition" {
                if seen_decomposition {
                    return Err("second `decomposition:` section".into());
                }
                if seen_homomorphism {
                    return Err("`decomposition:` comes before `homomorphism:`".into());
                }
                seen_decomposition = true;
                st.decomposition = Some(String::new());
                sec = Sec::Decomposition;
            } else {
                if seen_homomorphism {
                    return Err("second `homomorphism:` section".into());
                }
                seen_homomorphism = true;
                st.main.push_str("homomorphism:\n");
                sec = Sec::Homomorphism;
            }
            in_head = true;
            head_seen.clear();
            continue;
        }
        if t.is_empty() {
            continue;
        }
        if let Some((key, value)) = head_setting(t) {
            match sec {
                Sec::Decomposition | Sec::Homomorphism => {
                    if !in_head || head_seen.contains(&key) {
                        return Err(format!(
                            "`{key}:` comes once, right after the section keyword"
                        ));
                    }
                    head_seen.push(key.clone());
                    if key == "maximum depth" {
                        let d = whole_text(value, 1, MAX_DEPTH, "maximum depth")?;
                        if sec == Sec::Decomposition {
                            st.decomposition_depth = Some(d);
                        } else {
                            st.homomorphism_depth = Some(d);
                        }
                    } else if sec == Sec::Decomposition {
                        return Err(
                            "decomposition uses the main random generator: no `seed:` here".into(),
                        );
                    } else {
                        st.homomorphism_seed = Some(whole_text(value, 0, 1 << 53, "seed")?);
                    }
                    continue;
                }
                _ if key == "maximum depth" => {
                    return Err(
                        "`maximum depth:` belongs to `decomposition:` or `homomorphism:`".into(),
                    );
                }
                _ => {} // the main `seed:`
            }
        }
        in_head = false;
        match sec {
            Sec::Settings => {
                let (key, value) = t.split_once(':').unwrap_or((t, ""));
                let key = key.trim().to_lowercase();
                if key == "groups" || key == "group" {
                    if st.list.is_some() || st.expr.is_some() {
                        return Err("use either `groups:` or `group:`, not both".into());
                    }
                    if key == "group" {
                        st.expr = Some(value.to_string());
                    } else {
                        let nums: Vec<&str> = value.split_whitespace().collect();
                        if nums.is_empty()
                            || !nums.iter().all(|n| n.bytes().all(|b| b.is_ascii_digit()))
                        {
                            return Err(
                                "`groups:` takes whole group numbers separated by blanks".into()
                            );
                        }
                        let list = nums
                            .iter()
                            .map(|n| n.parse::<u32>().map_err(|e| e.to_string()))
                            .collect::<R<Vec<u32>>>()?;
                        st.list = Some(list);
                    }
                } else {
                    st.main.push_str(line);
                }
            }
            Sec::Group(0) | Sec::Homomorphism => st.main.push_str(line),
            Sec::Group(g) => {
                let group = st
                    .groups
                    .iter_mut()
                    .find(|(n, _)| *n == g)
                    .expect("declared");
                group.1.push_str(line);
            }
            Sec::Decomposition => st.decomposition.as_mut().expect("section").push_str(line),
        }
    }
    for &g in st.list.iter().flatten() {
        if !declared.contains(&g) && g != 0 {
            return Err(format!(
                "unknown group {g}: there is no `productions {g}:` section"
            ));
        }
    }
    if st.list.is_none() && st.expr.is_none() {
        if let Some((g, _)) = st.groups.first() {
            return Err(format!(
                "group {g} is never used: add a `groups:` or `group:` setting"
            ));
        }
    }
    Ok(st)
}

/// The productions of a section's lines, through lsgen's parser.
fn section_rules(lines: &str, consts: &HashMap<String, f64>) -> R<Vec<Rule>> {
    let h = parse_header(&format!("productions:\n{lines}"))
        .map_err(|e| format!("parse error: {}", e.message()))?;
    h.productions
        .iter()
        .map(|p| compile_rule(p, consts))
        .collect()
}

impl System {
    pub fn load(src: &str) -> R<System> {
        let (header, axiom_text) = split(src)?;
        let st = split_structure(header)?;
        let h = parse_header(&st.main).map_err(|e| format!("parse error: {}", e.message()))?;
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
                // split_structure took the schedule lines out: this
                // reference reads them itself.
                Setting::Groups(..) | Setting::Group(..) => {
                    return Err("schedule left in the main header".into())
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
        let mut groups = HashMap::new();
        for (g, lines) in &st.groups {
            groups.insert(*g, section_rules(lines, &consts)?);
        }
        let decomposition = match &st.decomposition {
            None => Vec::new(),
            Some(lines) => section_rules(lines, &consts)?,
        };
        if decomposition.iter().any(Rule::has_context) {
            return Err("a decomposition production has no context".into());
        }
        let schedule = match (&st.list, &st.expr) {
            (Some(list), _) => Schedule::List(list.clone()),
            (None, Some(text)) => {
                let e = parse_expr(text).map_err(|e| format!("parse error: {}", e.message()))?;
                let mut names = HashMap::new();
                if !consts.contains_key(STEP) {
                    names.insert(STEP.to_string(), 0);
                }
                let code = compile_expr(&e, &names, &consts)?;
                if code.uses_random() {
                    return Err("`group:` cannot use ran or nran".into());
                }
                Schedule::Expr(code)
            }
            (None, None) => Schedule::None,
        };
        Ok(System {
            stats: Cell::new(Stats::default()),
            filter,
            rules,
            groups,
            schedule,
            decomposition,
            decomposition_depth: st.decomposition_depth.unwrap_or(1) as usize,
            homomorphism,
            homomorphism_depth: st.homomorphism_depth.unwrap_or(1) as usize,
            homomorphism_seed: st.homomorphism_seed,
            step: Cell::new(0.0),
            derivation_length,
            seed,
            consts,
            axiom_text: axiom_text.to_string(),
            brackets: RefCell::default(),
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
        let mut rng = Draws::new(seed.or(self.seed).unwrap_or(0));
        let mut s = self.parse_axiom(&mut rng)?;
        for k in 1..=steps {
            self.step.set(k as f64);
            rng.pass(k, 0);
            // (A string at the address and of the length of one before.)
            self.brackets.take();
            s = self.derive_step(&s, k, &mut rng)?;
            if s.len() > max_modules {
                return Err(TOO_LONG.into());
            }
        }
        if !self.homomorphism.is_empty() {
            self.step.set(steps as f64);
            let mut own = self.homomorphism_seed.map(Draws::new);
            let rng = own.as_mut().unwrap_or(&mut rng);
            rng.pass(steps, 1);
            self.brackets.take();
            let mut out = Vec::new();
            for pos in 0..s.len() {
                rng.module(pos);
                self.interpret(&s, pos, &s[pos], 0, rng, &mut out)?;
                if out.len() > max_modules {
                    return Err(TOO_LONG.into());
                }
            }
            s = out;
        }
        Ok(s)
    }

    /// The group step `k` uses.
    fn group_for(&self, k: u64) -> R<u32> {
        match &self.schedule {
            Schedule::None => Ok(0),
            Schedule::List(list) => Ok(list[((k - 1) % list.len() as u64) as usize]),
            Schedule::Expr(code) => {
                let v = eval(code, &[k as f64], &mut Draws::new(0))?;
                if v.fract() != 0.0
                    || v < 0.0
                    || (v != 0.0 && !self.groups.contains_key(&(v as u32)))
                {
                    return Err(format!(
                        "group: gives {v} in step {k}, not a declared group"
                    ));
                }
                Ok(v as u32)
            }
        }
    }

    /// Derivation step `k`: for each module, the step's group, then group
    /// 0; a `%` that nothing rewrites cuts; every result is decomposed.
    fn derive_step(&self, s: &[Module], k: u64, rng: &mut Draws) -> R<Vec<Module>> {
        let group = match self.group_for(k)? {
            0 => None,
            g => Some(&self.groups[&g]),
        };
        let mut out = Vec::new();
        let mut pos = 0;
        while pos < s.len() {
            let m = &s[pos];
            rng.module(pos);
            let mut result = None;
            if let Some(rules) = group {
                result = self.apply(rules, s, pos, m, rng)?;
            }
            if result.is_none() {
                result = self.apply(&self.rules, s, pos, m, rng)?;
            }
            match result {
                Some(succ) => {
                    for x in &succ {
                        self.decompose(x, 0, rng, &mut out)?;
                    }
                }
                None => {
                    let applied = self.decompose(m, 0, rng, &mut out)?;
                    if !applied && m.key() == ('%', 0) {
                        out.pop(); // the cut: drop `%` and the rest of its branch
                                   // (To the `]` that ends its branch, kept.)
                        pos = self.close_after(s, pos + 1).unwrap_or(s.len());
                        continue;
                    }
                }
            }
            pos += 1;
        }
        Ok(out)
    }

    /// Decompose `m` (of depth `depth`) into `out`, depth first. Did a
    /// decomposition production apply to `m` itself?
    fn decompose(
        &self,
        m: &Module,
        depth: usize,
        rng: &mut Draws,
        out: &mut Vec<Module>,
    ) -> R<bool> {
        if depth >= self.decomposition_depth || self.decomposition.is_empty() {
            out.push(m.clone());
            return Ok(false);
        }
        match self.apply(&self.decomposition, std::slice::from_ref(m), 0, m, rng)? {
            None => {
                out.push(m.clone());
                Ok(false)
            }
            Some(succ) => {
                for x in &succ {
                    self.decompose(x, depth + 1, rng, out)?;
                }
                Ok(true)
            }
        }
    }

    /// The homomorphism of `m` (of depth `depth`, made from the module at
    /// `pos`), contexts always around `pos` in `s`.
    fn interpret(
        &self,
        s: &[Module],
        pos: usize,
        m: &Module,
        depth: usize,
        rng: &mut Draws,
        out: &mut Vec<Module>,
    ) -> R<()> {
        if depth >= self.homomorphism_depth {
            out.push(m.clone());
            return Ok(());
        }
        match self.apply(&self.homomorphism, s, pos, m, rng)? {
            None => out.push(m.clone()),
            Some(succ) => {
                for x in &succ {
                    self.interpret(s, pos, x, depth + 1, rng, out)?;
                }
            }
        }
        Ok(())
    }

    /// The axiom: symbols, each with an optional parameter list.
    fn parse_axiom(&self, rng: &mut Draws) -> R<Vec<Module>> {
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
            rng.module(out.len());
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

    fn axiom_param(&self, t: &str, rng: &mut Draws) -> R<f64> {
        if let Ok(v) = t.parse::<f64>() {
            return Ok(v);
        }
        let e = parse_expr(t).map_err(|e| e.message())?;
        let c = compile_expr(&e, &HashMap::new(), &self.consts)?;
        c.eval(&[], &mut Vec::new(), rng).map_err(|e| e.message())
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

    /// The successor `rules` give module `m`, contexts taken around `pos`
    /// in `s` (`m` is `s[pos]` except in the homomorphism's recursion):
    /// context productions first, then context-free ones.
    fn apply(
        &self,
        rules: &[Rule],
        s: &[Module],
        pos: usize,
        m: &Module,
        rng: &mut Draws,
    ) -> R<Option<Vec<Module>>> {
        let mine: Vec<&Rule> = rules.iter().filter(|r| r.pred.key() == m.key()).collect();
        let context: Vec<&Rule> = mine.iter().copied().filter(|r| r.has_context()).collect();
        let free: Vec<&Rule> = mine.iter().copied().filter(|r| !r.has_context()).collect();
        let mut chosen = self.choose(&context, s, pos, m, rng)?;
        if chosen.is_none() {
            chosen = self.choose(&free, s, pos, m, rng)?;
        }
        let Some((rule, slots)) = chosen else {
            return Ok(None);
        };
        self.count(rule);
        let mut out = Vec::new();
        for (sym, codes) in &rule.succ {
            let mut params = Vec::new();
            for c in codes {
                params.push(eval(c, &slots, rng)?);
            }
            out.push(Module { sym: *sym, params });
        }
        Ok(Some(out))
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
        m: &Module,
        rng: &mut Draws,
    ) -> R<Option<(&'r Rule, Vec<f64>)>> {
        let stochastic = group.iter().any(|r| r.prob.is_some());
        if !stochastic {
            for r in group {
                if let Some(slots) = self.applies(r, s, pos, m, rng)? {
                    return Ok(Some((r, slots)));
                }
            }
            return Ok(None);
        }
        let mut candidates: Vec<(&Rule, Vec<f64>, f64)> = Vec::new();
        for r in group {
            if let Some(slots) = self.applies(r, s, pos, m, rng)? {
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
        if !total.is_finite() {
            return Err("the weights add up to more than the largest number".into());
        }
        let mut st = self.stats.get();
        st.draws += 1;
        self.stats.set(st);
        let mut u = rng.uniform().map_err(|e| e.to_string())? * total;
        let last = candidates.len() - 1;
        for (i, (r, slots, w)) in candidates.into_iter().enumerate() {
            u -= w;
            if u < 0.0 || i == last {
                return Ok(Some((r, slots)));
            }
        }
        unreachable!()
    }

    /// Does `r` apply to `m` at `pos` (contexts, then condition)? Its
    /// slots if so.
    fn applies(
        &self,
        r: &Rule,
        s: &[Module],
        pos: usize,
        m: &Module,
        rng: &mut Draws,
    ) -> R<Option<Vec<f64>>> {
        let mut slots = vec![0.0; r.nslots];
        r.pred.bind(m, &mut slots);
        if let Some(i) = r.step_slot {
            slots[i] = self.step.get();
        }
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
                    match self.open_of(s, i) {
                        Some(o) => i = o,
                        None => return false,
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
                    i = self.after_branch(s, i);
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
                    i = self.after_branch(s, i);
                    // Passed-over modules do not separate two branches.
                    while i < s.len() && !self.seen(&s[i]) {
                        i += 1;
                    }
                }
            }
            RightItem::Close => match self.close_after(s, i) {
                Some(j) => self.right_context(s, j + 1, rest, slots),
                None => false,
            },
        }
    }

    /// The index of the first `]` at or after `i` that no `[` from `i` on
    /// matches (the one that ends the branch `s[i]` is in; `s[i]` itself
    /// if a `]`), or None.
    fn close_after(&self, s: &[Module], i: usize) -> Option<usize> {
        if s.len() < LONG {
            return close_after(s, i);
        }
        let t = self.brackets_of(s);
        t.close.get(i).copied().filter(|&j| j < s.len())
    }

    /// The index of the `[` that the `]` at `j` closes, or None.
    fn open_of(&self, s: &[Module], j: usize) -> Option<usize> {
        if s.len() < LONG {
            return open_of(s, j);
        }
        let t = self.brackets_of(s);
        t.open.get(j).copied().filter(|&o| o < s.len())
    }

    /// The tables of `s`, made once per string (each pass forgets them).
    fn brackets_of(&self, s: &[Module]) -> std::cell::Ref<'_, Brackets> {
        let key = (s.as_ptr() as usize, s.len());
        if self.brackets.borrow().key != key {
            *self.brackets.borrow_mut() = Brackets::of(s, key);
        }
        self.brackets.borrow()
    }

    /// The index just after the `]` that closes the `[` at `open`, or the
    /// string's length.
    fn after_branch(&self, s: &[Module], open: usize) -> usize {
        self.close_after(s, open + 1).map_or(s.len(), |j| j + 1)
    }
}

/// From this length on, [`System::close_after`] and [`System::open_of`]
/// answer from tables made once per string, so that a `]` pattern, a cut
/// or a left context in each module of a long branch does not scan the
/// branch again each time; below it they scan.
const LONG: usize = 256;

/// A string's brackets: for each index, [`close_after`]'s answer; for
/// each `]`, [`open_of`]'s (the string's length for none).
#[derive(Default)]
struct Brackets {
    /// The string's address and length.
    key: (usize, usize),
    close: Vec<usize>,
    open: Vec<usize>,
}

impl Brackets {
    fn of(s: &[Module], key: (usize, usize)) -> Brackets {
        let n = s.len();
        // From the end, the `]`s no `[` has matched yet on a stack.
        let mut close = vec![n; n];
        let mut free: Vec<usize> = Vec::new();
        for j in (0..n).rev() {
            if s[j].is_close() {
                close[j] = j;
                free.push(j);
                continue;
            }
            if s[j].is_open() {
                free.pop();
            }
            close[j] = free.last().copied().unwrap_or(n);
        }
        let mut open = vec![n; n];
        let mut stack: Vec<usize> = Vec::new();
        for (j, m) in s.iter().enumerate() {
            if m.is_open() {
                stack.push(j);
            } else if m.is_close() {
                open[j] = stack.pop().unwrap_or(n);
            }
        }
        Brackets { key, close, open }
    }
}

/// [`System::close_after`], scanning.
fn close_after(s: &[Module], mut i: usize) -> Option<usize> {
    let mut depth = 0usize;
    while let Some(m) = s.get(i) {
        if m.is_open() {
            depth += 1;
        } else if m.is_close() {
            if depth == 0 {
                return Some(i);
            }
            depth -= 1;
        }
        i += 1;
    }
    None
}

/// [`System::open_of`], scanning.
fn open_of(s: &[Module], mut j: usize) -> Option<usize> {
    let mut depth = 1usize;
    while j > 0 {
        j -= 1;
        if s[j].is_close() {
            depth += 1;
        } else if s[j].is_open() {
            depth -= 1;
            if depth == 0 {
                return Some(j);
            }
        }
    }
    None
}

/// The message of the error `derive` gives for too long a string.
pub const TOO_LONG: &str = "the reference gives up: string too long";

/// The random scheme of README's "Randomness", written from its text
/// (not from `src/derive/random.rs`): each draw is computed on its own,
/// from a freshly keyed generator.
pub struct Draws {
    seed: u64,
    stream: u64,
    region: u128,
    module: u64,
    draw: u64,
}

impl Draws {
    pub fn new(seed: u64) -> Draws {
        Draws {
            seed,
            stream: 0,
            region: 0,
            module: 0,
            draw: 0,
        }
    }

    /// The pass: `stream`, and region 0 (axiom, steps) or 1 (homomorphism).
    fn pass(&mut self, stream: u64, region: u128) {
        self.stream = stream;
        self.region = region;
    }

    /// The module being rewritten: its index in its generation.
    fn module(&mut self, index: usize) {
        self.module = index as u64;
        self.draw = 0;
    }

    /// The draw at position P = region·2^65 + draw·2^59 + module.
    fn next(&mut self) -> Result<u64, &'static str> {
        if self.draw >= 64 {
            return Err("more than 64 random draws for one module");
        }
        let p =
            self.region * (1 << 65) + u128::from(self.draw) * (1 << 59) + u128::from(self.module);
        self.draw += 1;
        let mut g = ChaCha8Rng::seed_from_u64(self.seed);
        g.set_stream(self.stream);
        g.set_word_pos(2 * p);
        let lo = u64::from(g.next_u32());
        let hi = u64::from(g.next_u32());
        Ok(hi << 32 | lo)
    }
}

impl Draw for Draws {
    fn uniform(&mut self) -> Result<f64, RandomError> {
        // The top 53 bits / 2^53.
        let x = self.next().map_err(|_| RandomError::TooManyDraws)?;
        Ok((x >> 11) as f64 / 9007199254740992.0)
    }

    fn normal(&mut self, mean: f64, sd: f64) -> Result<f64, RandomError> {
        let x = self.next().map_err(|_| RandomError::TooManyDraws)?;
        let u1 = ((x >> 32) as f64 + 1.0) / 4294967296.0;
        let u2 = (x & 0xffff_ffff) as f64 / 4294967296.0;
        Ok(mean + sd * ((-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()))
    }
}

fn eval(c: &Code, slots: &[f64], rng: &mut Draws) -> R<f64> {
    c.eval(slots, &mut Vec::new(), rng)
        .map_err(|e| format!("eval error: {}", e.message()))
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

/// Hand-derived checks of the structural features (docs/structural.md).
/// Run with `cargo test --test differential reference::`.
#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::rand_core::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// (what, .ls text, steps, expected): the hand-derived cases of
    /// `tests/tools/ref.py --self-test`.
    const CASES: &[(&str, &str, u64, &str)] = &[
        ("groups cycle", "groups: 1 1 2\nproductions:\nA -> A\nproductions 1:\nA -> AB\nproductions 2:\nA -> A[+B]\nB -> BB\naxiom: A\n", 1, "AB"),
        ("groups cycle 2", "groups: 1 1 2\nproductions:\nA -> A\nproductions 1:\nA -> AB\nproductions 2:\nA -> A[+B]\nB -> BB\naxiom: A\n", 2, "ABB"),
        ("groups cycle 3", "groups: 1 1 2\nproductions:\nA -> A\nproductions 1:\nA -> AB\nproductions 2:\nA -> A[+B]\nB -> BB\naxiom: A\n", 3, "A[+B]BBBB"),
        ("groups cycle 4", "groups: 1 1 2\nproductions:\nA -> A\nproductions 1:\nA -> AB\nproductions 2:\nA -> A[+B]\nB -> BB\naxiom: A\n", 4, "AB[+B]BBBB"),
        ("groups fallback", "groups: 1\nproductions:\nA -> X\nB -> Y\nproductions 1:\nA -> Z\naxiom: AB\n", 1, "ZY"),
        ("groups fallback on a failed condition", "groups: 1\nproductions:\nA(x) -> A(x+1)\nproductions 1:\nA(x) : x > 1 -> Z(x)\naxiom: A(0)A(2)\n", 2, "A(2)Z(2)"),
        ("group expression", "group: 1 + (step > 2)\nproductions 1:\nA -> AB\nproductions 2:\nA -> AC\naxiom: A\n", 3, "ACBB"),
        ("productions 0 is group 0", "productions 0:\nA -> AB\naxiom: A\n", 2, "ABB"),
        ("step", "productions:\nA(x) -> A(x+step)\naxiom: A(0)\n", 3, "A(6)"),
        ("step in a condition", "productions:\nB : step == 2 -> C\naxiom: BB\n", 2, "CC"),
        ("step in a condition, other step", "productions:\nB : step == 2 -> C\naxiom: BB\n", 1, "BB"),
        ("a constant hides step", "define: step = 10\nproductions:\nA(x) -> A(x+step)\naxiom: A(0)\n", 2, "A(20)"),
        ("a formal parameter hides step", "productions:\nA(step) -> A(step*2)\naxiom: A(3)\n", 2, "A(12)"),
        ("step in the homomorphism is n", "productions:\nA(x) -> A(x+step)\nhomomorphism:\nA(x) -> B(x,step)\naxiom: A(0)\n", 2, "B(3,2)"),
        ("step in the homomorphism, n = 0", "productions:\nA(x) -> A(x+step)\nhomomorphism:\nA(x) -> B(x,step)\naxiom: A(0)\n", 0, "B(0,0)"),
        ("decomposition, axiom untouched", "productions:\nA -> IA\ndecomposition:\nI -> FF\naxiom: IA\n", 0, "IA"),
        ("decomposition step 1", "productions:\nA -> IA\ndecomposition:\nI -> FF\naxiom: IA\n", 1, "FFFFA"),
        ("decomposition step 2", "productions:\nA -> IA\ndecomposition:\nI -> FF\naxiom: IA\n", 2, "FFFFFFA"),
        ("decomposition depth 1", "productions:\nA -> LA\ndecomposition:\nL -> [+P][-P]\nP -> [F]\naxiom: A\n", 1, "[+P][-P]A"),
        ("decomposition depth 1, next step", "productions:\nA -> LA\ndecomposition:\nL -> [+P][-P]\nP -> [F]\naxiom: A\n", 2, "[+[F]][-[F]][+P][-P]A"),
        ("decomposition depth 2", "productions:\nA -> LA\ndecomposition:\nmaximum depth: 2\nL -> [+P][-P]\nP -> [F]\naxiom: A\n", 1, "[+[F]][-[F]]A"),
        ("decomposition limit", "productions:\nZ -> X\ndecomposition: warnings\nmaximum depth: 3\nX -> XY\naxiom: Z\n", 1, "XYYY"),
        ("decomposition with step, step 1", "productions:\nA -> AL\ndecomposition:\nL : step > 1 -> F(step)\naxiom: A\n", 1, "AL"),
        ("decomposition with step, step 2", "productions:\nA -> AL\ndecomposition:\nL : step > 1 -> F(step)\naxiom: A\n", 2, "AF(2)F(2)"),
        ("cut: manual 6.4, step 1", "productions:\nD(a) : a < 20 -> D(a+1)\nD(a) : a >= 20 -> %\naxiom: A[+D(19)F]B\n", 1, "A[+D(20)F]B"),
        ("cut: % produced in step 2", "productions:\nD(a) : a < 20 -> D(a+1)\nD(a) : a >= 20 -> %\naxiom: A[+D(19)F]B\n", 2, "A[+%F]B"),
        ("cut: % cuts in step 3", "productions:\nD(a) : a < 20 -> D(a+1)\nD(a) : a >= 20 -> %\naxiom: A[+D(19)F]B\n", 3, "A[+]B"),
        ("cut at top level", "axiom: AB%C[D]E\n", 1, "AB"),
        ("cut in a branch", "axiom: A[B%C[D]E]F\n", 1, "A[B]F"),
        ("cut: n = 0 cuts nothing", "axiom: A[B%C[D]E]F\n", 0, "A[B%C[D]E]F"),
        ("a rewritten % is no cut", "productions:\n% -> X\naxiom: A%B\n", 1, "AXB"),
        ("%(x) is no cut", "axiom: A%(1)B\n", 1, "A%(1)B"),
        ("contexts see the cut part", "productions:\nB > %C -> Y\naxiom: AB%C\n", 1, "AY"),
        ("cut modules are not evaluated", "productions:\nC(x) -> D(1/x)\naxiom: %C(0)\n", 1, ""),
        ("decomposition of % prevents the cut", "decomposition:\n% -> G\naxiom: A%B\n", 1, "AGB"),
        ("% from decomposition cuts next step", "productions:\nA -> K\ndecomposition:\nK -> %\naxiom: [AE]B\n", 1, "[%E]B"),
        ("% from decomposition cuts next step 2", "productions:\nA -> K\ndecomposition:\nK -> %\naxiom: [AE]B\n", 2, "[]B"),
        ("the homomorphism never cuts", "homomorphism:\nA -> F\nB -> %C\naxiom: A%B\n", 0, "F%%C"),
        ("homomorphism depth 2", "homomorphism:\nmaximum depth: 2\nF -> G P(0,0)\nG > P(x,y) : y > 3 -> f\naxiom: F P(1,5) F P(1,2)\n", 0, "fP(0,0)P(1,5)GP(0,0)P(1,2)"),
        ("homomorphism depth 1", "homomorphism:\nF -> G P(0,0)\nG > P(x,y) : y > 3 -> f\naxiom: F P(1,5) F P(1,2)\n", 0, "GP(0,0)P(1,5)GP(0,0)P(1,2)"),
        ("homomorphism limit", "homomorphism: no warnings\nseed: 4\nmaximum depth: 3\nX -> XY\naxiom: X\n", 0, "XYYY"),
    ];

    /// Refused when loaded (with a part of the message).
    const BAD: &[(&str, &str, &str)] = &[
        (
            "decomposition with a left context",
            "decomposition:\nA < L -> X\naxiom: L\n",
            "has no context",
        ),
        (
            "decomposition with a right context",
            "decomposition:\nL > A -> X\naxiom: L\n",
            "has no context",
        ),
        (
            "decomposition after homomorphism",
            "homomorphism:\nA -> B\ndecomposition:\nL -> X\naxiom: L\n",
            "comes before `homomorphism:`",
        ),
        (
            "productions after decomposition",
            "decomposition:\nL -> X\nproductions:\nA -> B\naxiom: L\n",
            "productions after decomposition",
        ),
        (
            "second decomposition",
            "decomposition:\nL -> X\ndecomposition:\nK -> X\naxiom: L\n",
            "second `decomposition:`",
        ),
        (
            "maximum depth 0",
            "decomposition:\nmaximum depth: 0\nL -> X\naxiom: L\n",
            "maximum depth must be",
        ),
        (
            "negative maximum depth",
            "homomorphism:\nmaximum depth: -1\nL -> X\naxiom: L\n",
            "maximum depth must be",
        ),
        (
            "fractional maximum depth",
            "homomorphism:\nmaximum depth: 2.5\nL -> X\naxiom: L\n",
            "maximum depth must be",
        ),
        (
            "maximum depth too large",
            "homomorphism:\nmaximum depth: 10001\nL -> X\naxiom: L\n",
            "maximum depth must be",
        ),
        (
            "maximum depth twice",
            "homomorphism:\nmaximum depth: 2\nmaximum depth: 2\naxiom: L\n",
            "comes once",
        ),
        (
            "maximum depth after a production",
            "homomorphism:\nL -> X\nmaximum depth: 2\naxiom: L\n",
            "comes once",
        ),
        (
            "maximum depth in the settings",
            "maximum depth: 2\naxiom: L\n",
            "belongs to",
        ),
        (
            "maximum depth in productions",
            "productions:\nmaximum depth: 2\naxiom: L\n",
            "belongs to",
        ),
        (
            "seed in decomposition",
            "decomposition:\nseed: 2\nL -> X\naxiom: L\n",
            "no `seed:` here",
        ),
        (
            "bad warnings word",
            "homomorphism: maybe\nL -> X\naxiom: L\n",
            "expected `warnings`",
        ),
        (
            "negative group",
            "groups: 1\nproductions -1:\nA -> B\naxiom: A\n",
            "production group must be",
        ),
        (
            "fractional group",
            "groups: 1\nproductions 1.5:\nA -> B\naxiom: A\n",
            "production group must be",
        ),
        (
            "group too large",
            "groups: 70000\nproductions 70000:\nA -> B\naxiom: A\n",
            "production group must be",
        ),
        (
            "group declared twice",
            "groups: 2\nproductions 2:\nA -> B\nproductions 2:\nA -> C\naxiom: A\n",
            "group 2 is declared twice",
        ),
        (
            "group 0 declared twice",
            "productions:\nA -> B\nproductions 0:\nA -> C\naxiom: A\n",
            "group 0 is declared twice",
        ),
        (
            "decomposition group",
            "decomposition 1:\nL -> X\naxiom: L\n",
            "has no groups",
        ),
        (
            "unknown group in a schedule",
            "groups: 1 3\nproductions 1:\nA -> B\naxiom: A\n",
            "unknown group 3",
        ),
        (
            "empty schedule",
            "groups:\nproductions:\nA -> B\naxiom: A\n",
            "`groups:` takes",
        ),
        (
            "schedule with a name",
            "groups: 1 x\nproductions 1:\nA -> B\naxiom: A\n",
            "`groups:` takes",
        ),
        (
            "both schedules",
            "groups: 1\ngroup: 1\nproductions 1:\nA -> B\naxiom: A\n",
            "not both",
        ),
        (
            "random group",
            "group: ran(3)\nproductions 1:\nA -> B\naxiom: A\n",
            "cannot use ran",
        ),
        (
            "unused group",
            "productions 1:\nA -> B\naxiom: A\n",
            "never used",
        ),
        ("step in define", "define: x = step\naxiom: A\n", "`step`"),
        ("step in the axiom", "axiom: A(step)\n", "`step`"),
    ];

    /// Refused while deriving.
    const BAD_AT_RUN: &[(&str, &str, u64)] = &[
        (
            "group expression names no group",
            "group: step\nproductions 1:\nA -> B\naxiom: A\n",
            2,
        ),
        (
            "group expression not whole",
            "group: step / 2\nproductions 1:\nA -> B\naxiom: A\n",
            1,
        ),
    ];

    fn derive(src: &str, steps: u64, seed: u64) -> R<String> {
        System::load(src)?
            .derive(Some(steps), Some(seed), usize::MAX)
            .map(|s| format_string(&s))
    }

    #[test]
    fn hand_derived_strings() {
        let mut failures = Vec::new();
        for (what, src, n, want) in CASES {
            match derive(src, *n, 0) {
                Ok(got) if got == *want => {}
                got => failures.push(format!("{what} (n={n}): got {got:?}, want {want:?}")),
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    #[test]
    fn bad_input_is_refused() {
        let mut failures = Vec::new();
        for (what, src, part) in BAD {
            // The reference reads the axiom when deriving.
            match System::load(src).and_then(|s| s.derive(Some(0), Some(0), usize::MAX)) {
                Err(e) if e.contains(part) => {}
                Err(e) => failures.push(format!("{what}: wrong error {e:?}, want {part:?}")),
                Ok(_) => failures.push(format!("{what}: accepted")),
            }
        }
        for (what, src, n) in BAD_AT_RUN {
            match System::load(src).map(|s| s.derive(Some(*n), Some(0), usize::MAX)) {
                Ok(Err(e)) if e.contains("group: gives") => {}
                other => failures.push(format!("{what}: {:?}", other.map(|r| r.is_ok()))),
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// Both references agree on the structural models: every
    /// `tests/expected/structural/NAME.nN.txt` (written by ref.py) is what
    /// this reference derives from `tests/structural/NAME.ls`.
    #[test]
    fn agrees_with_ref_py_on_the_structural_models() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = root.join("tests/expected/structural");
        let mut checked = 0;
        for entry in std::fs::read_dir(&dir).expect("tests/expected/structural") {
            let file = entry.unwrap().file_name().into_string().unwrap();
            let Some((name, n)) = file
                .strip_suffix(".txt")
                .and_then(|stem| stem.rsplit_once(".n"))
            else {
                continue;
            };
            let n: u64 = n.parse().unwrap();
            let src =
                std::fs::read_to_string(root.join(format!("tests/structural/{name}.ls"))).unwrap();
            // (The models lsgen implements moved to examples/ with their
            // expected files; `examples_match_the_reference`-style tests
            // cover them there.)
            let want = std::fs::read_to_string(dir.join(&file)).unwrap();
            let got = derive(&src, n, 0).unwrap_or_else(|e| panic!("{file}: {e}"));
            assert_eq!(format!("{got}\n"), want, "{file}");
            checked += 1;
        }
        assert!(checked >= 16, "only {checked} structural expected files");
    }

    /// Both references agree on random systems with every structural
    /// feature (written by `tests/tools/gen_cross_cases.py` with ref.py).
    #[test]
    fn agrees_with_ref_py_on_random_cases() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/expected/structural/random_cases.txt"
        );
        let text = std::fs::read_to_string(path).expect("random_cases.txt");
        let mut checked = 0;
        let mut failures = Vec::new();
        for case in text.split("=== ").skip(1) {
            let (steps, rest) = case.split_once('\n').unwrap();
            let (src, want) = rest.split_once("--- expected\n").unwrap();
            let steps: u64 = steps.parse().unwrap();
            match derive(src, steps, 0) {
                Ok(got) if got == want.trim_end_matches('\n') => {}
                got => failures.push(format!("n={steps}\n{src}got {got:?}, want {want:?}")),
            }
            checked += 1;
        }
        assert!(checked >= 300, "only {checked} cases");
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// The uniform of draw `draw` of module `module` in `stream`
    /// (region 0: steps, 1: the homomorphism), computed here from
    /// rand_chacha as README describes (the top 53 bits of one draw / 2^53).
    fn u(seed: u64, (stream, region): (u64, u128), module: u128, draw: u128) -> String {
        let mut r = ChaCha8Rng::seed_from_u64(seed);
        r.set_stream(stream);
        r.set_word_pos(2 * ((region << 65) + (draw << 59) + module));
        let x = r.next_u64();
        format_number((x >> 11) as f64 / (1u64 << 53) as f64)
    }

    const STEP1: (u64, u128) = (1, 0);

    #[test]
    fn decomposition_draws_right_after_its_module() {
        // Fused into the step: A1's successor, then its decomposition, on
        // module 0's draws; then A2's on module 1's.
        let src = "productions:\nA -> B(ran(1))\ndecomposition:\nB(x) -> C(x, ran(1))\naxiom: AA\n";
        let want = format!(
            "C({},{})C({},{})",
            u(5, STEP1, 0, 0),
            u(5, STEP1, 0, 1),
            u(5, STEP1, 1, 0),
            u(5, STEP1, 1, 1)
        );
        assert_eq!(derive(src, 1, 5).unwrap(), want);
    }

    #[test]
    fn cut_modules_make_no_draws() {
        // `A` is module 4 of `[%B]A`.
        let src = "productions:\nB -> X(ran(1))\nA -> Y(ran(1))\naxiom: [%B]A\n";
        assert_eq!(
            derive(src, 1, 6).unwrap(),
            format!("[]Y({})", u(6, STEP1, 4, 0))
        );
    }

    #[test]
    fn group_zero_draws_after_the_steps_group() {
        // Group 1's condition draws first (and fails), then group 0's successor.
        let src = "groups: 1\nproductions:\nA -> Y(ran(1))\nproductions 1:\nA : ran(1) > 2 -> X\naxiom: A\n";
        assert_eq!(
            derive(src, 1, 7).unwrap(),
            format!("Y({})", u(7, STEP1, 0, 1))
        );
    }

    #[test]
    fn homomorphism_seed_is_its_own_generator() {
        let own = "seed: 3\nproductions:\nA -> A(ran(1))\nhomomorphism:\nseed: 9\nA(x) -> B(x, ran(1))\naxiom: A\n";
        let got = System::load(own).unwrap().derive(Some(1), None, usize::MAX);
        let hom = (1, 1);
        let want = format!("B({},{})", u(3, STEP1, 0, 0), u(9, hom, 0, 0));
        assert_eq!(format_string(&got.unwrap()), want);
        // `--seed` changes the main generator only.
        let want = format!("B({},{})", u(4, STEP1, 0, 0), u(9, hom, 0, 0));
        assert_eq!(derive(own, 1, 4).unwrap(), want);
        // Without it, the homomorphism draws from the main key.
        let shared = own.replace("seed: 9\n", "");
        let want = format!("B({},{})", u(3, STEP1, 0, 0), u(3, hom, 0, 0));
        assert_eq!(derive(&shared, 1, 3).unwrap(), want);
    }

    #[test]
    fn homomorphism_recursion_draws_depth_first() {
        let src = "homomorphism:\nmaximum depth: 2\nA -> B(ran(1))C\nB(x) -> D(x, ran(1))\nC -> E(ran(1))\naxiom: A\n";
        // n = 0: the homomorphism of the axiom, on stream 0; all of A's.
        let h = (0, 1);
        let want = format!("D({},{})E({})", u(2, h, 0, 0), u(2, h, 0, 1), u(2, h, 0, 2));
        assert_eq!(derive(src, 0, 2).unwrap(), want);
    }
}
