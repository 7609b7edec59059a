//! Compiling a header: settings, constants and productions from the
//! syntax tree (or production by production as the parser reduces them:
//! [`Compiler`]) into a [`System`]'s tables.

use super::*;

/// Formal parameters named `step` (issue 11) in a head's module, with the
/// stage they are in.
fn hidden_step(m: &ast::Module, stage: u8, out: &mut Vec<(u8, Span)>) {
    for e in &m.params {
        if let Expr::Var(name, span) = e {
            if name == "step" {
                out.push((stage, *span));
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

/// A setting that must be a whole number from 0 to 2^53: as written, when
/// it is digits in `src` (2^53 + 1 would read as 2^53).
fn whole_number(
    e: &Expr,
    consts: &HashMap<String, f64>,
    what: &'static str,
    src: Option<&str>,
) -> R<u64> {
    if let Some(text) = digits(e, src) {
        return match text.parse::<u64>() {
            // (In integers: as a float, 2^53 + 1 would be 2^53.)
            Ok(n) if n <= 1 << 53 => Ok(n),
            _ => err(
                e.span(),
                CompileError::WholeNumberLiteralRange {
                    what,
                    text: text.to_string(),
                },
            ),
        };
    }
    let v = constant(e, consts, &mut Random::new(0))?;
    if v < 0.0 || v.fract() != 0.0 || v > EXACT_LIMIT {
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
    if let Some(text) = digits(e, src) {
        return text
            .parse::<u64>()
            .or_else(|_| err(e.span(), CompileError::SeedLiteralRange(text.to_string())));
    }
    let v = constant(e, consts, &mut Random::new(0))?;
    if v < 0.0 || v.fract() != 0.0 || v >= EXACT_LIMIT {
        return err(e.span(), CompileError::SeedComputedRange(v));
    }
    Ok(v as u64)
}

/// The text of `e` in `src` if it is a number written as digits alone.
fn digits<'s>(e: &Expr, src: Option<&'s str>) -> Option<&'s str> {
    let (Expr::Num(_, (a, b)), Some(src)) = (e, src) else {
        return None;
    };
    src.get(*a..*b)
        .filter(|t| !t.is_empty() && t.bytes().all(|c| c.is_ascii_digit()))
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
    /// Each group's first `groups:` entry, to check once every section is
    /// known: (group, where).
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
    /// The head being read.
    head: Head,
    /// The production whose successor is being read (none after an
    /// error in it, or where no error of its stage could be reported).
    pending: Option<Pending>,
}

/// Where the compiler is in a production's head.
enum Head {
    /// Between heads.
    Idle,
    Building(HeadBuilder),
    /// An error in it is recorded, or none of its stage could be reported:
    /// the rest of the production is skipped.
    Skipped,
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
            head: Head::Idle,
            pending: None,
        }
    }

    /// A compiler for a header lowered from a cpfg `.l` file
    /// ([`compile_dialect`]'s `cpfg`), handed over as the lowering goes.
    pub fn cpfg(src: Option<&'a str>) -> Compiler<'a> {
        let mut c = Compiler::new(src, Seeds::default());
        c.cpfg = true;
        c
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
                    // Each group's first entry, checked when every section
                    // is known (a list of 33 million entries names at most
                    // 65,536 groups).
                    for &(n, at) in list.first.iter().filter(|g| g.0 != 0) {
                        self.scheduled_groups.push((u32::from(n), at));
                    }
                    schedule = list.entries.iter().map(|&n| u32::from(n)).collect();
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
                    derivation_length =
                        Some(whole_number(e, &consts, "the derivation length", src)?);
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
        // (A set: a header may declare 65,536 groups and schedule each.)
        let declared: HashSet<u32> = self.groups.iter().map(|g| g.0).collect();
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
            .map(|(n, _, t)| (n, Group::new(t, &productions, cpfg)))
            .collect();
        // A decomposition of maximum depth 0 (cpfg dialect) decomposes
        // nothing: cpfg's `ApplyRecursiveProductions` returns at depth 0,
        // after trying the productions (kept for that: `cpfg::lower::attach`
        // drops it if trying them changes nothing).
        let decomposition = self
            .decomposition
            .filter(|(_, depth)| *depth > 0 || cpfg)
            .map(|(mut t, depth)| {
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
                match section_settings(&start.settings, consts, self.cpfg) {
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
                let hom =
                    section_settings(&start.settings, consts, self.cpfg).and_then(|(depth, _)| {
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

    fn head_module(&mut self, part: HeadPart, m: ast::Module) {
        let stage = self.stage();
        if matches!(self.head, Head::Idle) {
            self.pending = None;
            self.head = if self.open(stage) {
                Head::Building(HeadBuilder::default())
            } else {
                Head::Skipped
            };
        }
        let Head::Building(b) = &mut self.head else {
            return;
        };
        if part != HeadPart::Rest {
            hidden_step(&m, stage, &mut self.step_hidden);
        }
        let st = self.settled.as_mut().expect("open: settled");
        if let Err(e) = b.push(part, &m, &mut st.alphabet, self.cpfg) {
            self.head = Head::Skipped;
            self.fail(stage, e);
        }
    }

    fn head_end(&mut self, cond: Option<Box<Expr>>, _span: Span) {
        let Head::Building(b) = std::mem::replace(&mut self.head, Head::Idle) else {
            return;
        };
        let consts = &self.settled.as_ref().expect("open: settled").consts;
        match b.finish(cond.as_deref(), consts, self.cpfg) {
            Ok(pending) => self.pending = Some(pending),
            Err(e) => self.fail(self.stage(), e),
        }
    }

    fn successor(&mut self, modules: &mut Vec<ast::Module>) {
        let Some(p) = &mut self.pending else {
            modules.clear();
            return;
        };
        let st = self.settled.as_mut().unwrap();
        let mut failed = None;
        for m in modules.drain(..) {
            let r = p.succ.push(
                &m,
                &mut st.alphabet,
                &p.names,
                &st.consts,
                &mut self.num,
                self.cpfg,
            );
            if let Err(e) = r {
                // (The rest of the batch is dropped with the drain.)
                failed = Some(e);
                break;
            }
        }
        if let Some(e) = failed {
            self.pending = None;
            self.fail(self.stage(), e);
        }
    }

    fn end(&mut self, prob: Option<Box<Expr>>, span: Span) {
        let Some(p) = self.pending.take() else {
            return;
        };
        let stage = self.stage();
        let consts = &self.settled.as_ref().unwrap().consts;
        let table = match self.section {
            SectionKind::Group(0) => &mut self.productions,
            SectionKind::Group(_) => &mut self.groups.last_mut().unwrap().2,
            SectionKind::Decomposition => &mut self.decomposition.as_mut().unwrap().0,
            SectionKind::Homomorphism => &mut self.homomorphism,
        };
        match p.finish(prob.as_deref(), span, consts, self.cpfg) {
            Ok(cp) => table.push(cp),
            Err(e) => self.fail(stage, e),
        }
    }
}

/// Recursive rewriting does not track brackets: every successor of `t`
/// must balance (each `]` after its `[`), against the bracket it replaces
/// where the predecessor is one (cpfg): `[ --> [F`, `] --> F]`.
fn balanced(t: &Table, kind: CompileError) -> R<()> {
    match t.prods.iter().find(|p| {
        let d = bracket_depth(p.key);
        p.depth_delta != d || p.depth_min < d.min(0)
    }) {
        Some(p) => err((p.start(), p.start()), kind),
        None => Ok(()),
    }
}

/// The depth a bracket key opens (1) or closes (-1); 0 for other keys.
fn bracket_depth(key: u32) -> i32 {
    match key {
        OPEN => 1,
        CLOSE => -1,
        _ => 0,
    }
}

/// A decomposition or homomorphism section's `maximum depth:` (default 1)
/// and where its `seed:` is, if any.
///
/// In the cpfg dialect the lowering has made the depth cpfg's `(int)` of
/// the value, 0 for one at or below 0 (`src/cpfg/lower.rs`): 0 is no
/// decomposition, and a homomorphism that applies nothing (but warns).
fn section_settings(
    settings: &[ast::SectionSetting],
    consts: &HashMap<String, f64>,
    cpfg: bool,
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
                let min = if cpfg { 0.0 } else { 1.0 };
                if !(min..=10000.0).contains(&v) || v.fract() != 0.0 {
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

/// Bind `m`'s formal parameters to the slots from `*next` on, in `names`
/// with `tag` added; returns the first slot.
fn bind_formals(
    m: &ast::Module,
    names: &mut HashMap<String, u32>,
    next: &mut usize,
    tag: u32,
) -> R<u32> {
    let first = *next as u32;
    for e in &m.params {
        match e {
            Expr::Var(name, span) => {
                // The modules come in text order, so a name bound twice is
                // reported at its second place in the text.
                if names.insert(name.clone(), *next as u32 | tag).is_some() {
                    return err(*span, CompileError::BoundTwice(name.clone()));
                }
                *next += 1;
            }
            other => return err(other.span(), CompileError::FormalNotName),
        }
    }
    Ok(first)
}

/// Marks the slot of a left context's parameter in [`HeadBuilder::names`]
/// while it is numbered from 0 (a header of at most 64 MiB has fewer
/// slots).
const LEFT: u32 = 1 << 31;

/// A production's head, compiled as its modules arrive in text order
/// ([`HeaderSink::head_module`]): a context of millions of modules costs
/// its compiled patterns, never its syntax tree. The slots are the
/// predecessor's parameters, then its rest's (cpfg), then the left
/// context's, then the right context's; the left context comes first in
/// the text, so its slots are numbered from 0 and moved behind the
/// predecessor's once those are all known ([`HeadBuilder::seal`]).
#[derive(Default)]
struct HeadBuilder {
    key: Option<u32>,
    names: HashMap<String, u32>,
    /// Slots of the predecessor and its rest.
    front: usize,
    /// Slots of the left context.
    nleft: usize,
    /// All the slots so far, once sealed.
    sealed: Option<usize>,
    left: Vec<Pat>,
    rest: Vec<Pat>,
    right: Vec<RPat>,
}

impl HeadBuilder {
    /// The head's next module.
    fn push(
        &mut self,
        part: HeadPart,
        m: &ast::Module,
        alphabet: &mut Alphabet,
        cpfg: bool,
    ) -> R<()> {
        let intern = |a: &mut Alphabet| {
            a.intern(m.sym, m.params.len())
                .map_err(|e| UserError::new(m.span, e))
        };
        let bracket = matches!(m.sym, '[' | ']');
        match part {
            HeadPart::Left => {
                if bracket {
                    return err(m.span, CompileError::LeftContextBracket);
                }
                let key = intern(alphabet)?;
                let slot = bind_formals(m, &mut self.names, &mut self.nleft, LEFT)?;
                self.left.push(Pat { key, slot });
            }
            HeadPart::Pred => {
                // cpfg rewrites a bracket like any module (generate.c's
                // Derive tries the productions of every module of the
                // string, `[` and `]` too).
                if bracket && !cpfg {
                    return err(m.span, CompileError::BracketRewritten);
                }
                if bracket && !m.params.is_empty() {
                    return err(m.span, CompileError::BracketParams);
                }
                self.key = Some(intern(alphabet)?);
                bind_formals(m, &mut self.names, &mut self.front, 0)?;
            }
            HeadPart::Rest => {
                if bracket {
                    let kind = if cpfg {
                        CompileError::BracketInRun
                    } else {
                        CompileError::BracketRewritten
                    };
                    return err(m.span, kind);
                }
                let key = intern(alphabet)?;
                let slot = bind_formals(m, &mut self.names, &mut self.front, 0)?;
                self.rest.push(Pat { key, slot });
            }
            HeadPart::Right => {
                self.seal();
                match m.sym {
                    '[' | ']' if !m.params.is_empty() => {
                        return err(m.span, CompileError::BracketParams)
                    }
                    '[' => self.right.push(RPat::Open),
                    ']' => self.right.push(RPat::Close),
                    _ => {
                        let key = intern(alphabet)?;
                        let next = self.sealed.as_mut().expect("sealed");
                        let slot = bind_formals(m, &mut self.names, next, 0)?;
                        self.right.push(RPat::Module(Pat { key, slot }));
                    }
                }
            }
        }
        Ok(())
    }

    /// The predecessor and its rest are complete: move the left context's
    /// slots behind theirs.
    fn seal(&mut self) {
        if self.sealed.is_some() {
            return;
        }
        let shift = self.front as u32;
        for p in &mut self.left {
            p.slot += shift;
        }
        if self.nleft > 0 {
            for v in self.names.values_mut().filter(|v| **v & LEFT != 0) {
                *v = (*v & !LEFT) + shift;
            }
        }
        self.sealed = Some(self.front + self.nleft);
    }

    /// The head is complete: compile its condition.
    fn finish(
        mut self,
        cond: Option<&Expr>,
        consts: &HashMap<String, f64>,
        cpfg: bool,
    ) -> R<Pending> {
        self.seal();
        let mut names = self.names;
        // The built-in step number, unless a parameter or constant hides it.
        if !consts.contains_key("step") {
            names.entry("step".to_string()).or_insert(expr::STEP_SLOT);
        }
        let cond = cond
            .map(|e| compile_code_in(e, &names, consts, cpfg))
            .transpose()?
            // A condition folded to a non-zero constant always holds.
            .filter(|c| c.constant().is_none_or(|v| v == 0.0))
            .map(Box::new);
        Ok(Pending {
            key: self.key.expect("a head has a predecessor"),
            nslots: self.sealed.expect("sealed"),
            names,
            left: self.left,
            right: self.right,
            rest: self.rest,
            cond,
            succ: SuccessorBuilder::default(),
        })
    }
}

/// A production whose head is compiled and whose successor is arriving
/// ([`HeaderSink::successor`]): what the successor and the probability
/// need of the head.
struct Pending {
    key: u32,
    nslots: usize,
    names: HashMap<String, u32>,
    left: Vec<Pat>,
    right: Vec<RPat>,
    rest: Vec<Pat>,
    cond: Option<Box<Code>>,
    succ: SuccessorBuilder,
}

impl Pending {
    /// The production, given its probability and its line's span.
    fn finish(
        self,
        prob: Option<&Expr>,
        span: Span,
        consts: &HashMap<String, f64>,
        cpfg: bool,
    ) -> R<Production> {
        let weight = prob
            .map(|e| compile_code_in(e, &self.names, consts, cpfg))
            .transpose()?;
        // (cpfg takes a negative weight as it is: `SelectProd`.)
        if let Some(w) = weight.as_ref().and_then(|c| c.constant()).filter(|_| !cpfg) {
            if w < 0.0 {
                return err(prob.unwrap().span(), CompileError::NegativeProbability(w));
            }
        }
        let (succ, depth_delta, depth_min) = self.succ.finish();
        // (Depths and offsets fit: a header is at most 64 MiB.)
        let narrow = |x: i64| i32::try_from(x).expect("a header under 2 GiB");
        let offset = |x: usize| u32::try_from(x).expect("a header under 4 GiB");
        let mut prod = Production::new(
            self.key,
            self.nslots,
            &self.left,
            &self.right,
            self.cond,
            weight,
            Succ::from(succ),
            offset(span.0),
            (narrow(depth_delta), narrow(depth_min)),
        );
        if !self.rest.is_empty() {
            prod.cpfg_mut().rest = exact(self.rest);
        }
        Ok(prod)
    }
}

/// A successor compiled module by module: runs of modules whose parameters
/// are all constant become precomputed bytes.
#[derive(Default)]
struct SuccessorBuilder {
    items: Vec<Item>,
    run: ConstBuilder,
    /// Bracket depth at the end, and its lowest point.
    depth: i64,
    min: i64,
}

impl SuccessorBuilder {
    /// Compile the next module; `names` are the head's formal parameters.
    fn push(
        &mut self,
        m: &ast::Module,
        alphabet: &mut Alphabet,
        names: &HashMap<String, u32>,
        consts: &HashMap<String, f64>,
        num: &mut codec::NumFmt,
        cpfg: bool,
    ) -> R<()> {
        let key = alphabet
            .intern(m.sym, m.params.len())
            .map_err(|e| UserError::new(m.span, e))?;
        if m.params.is_empty() {
            match m.sym {
                '[' => self.depth += 1,
                ']' => {
                    self.depth -= 1;
                    self.min = self.min.min(self.depth);
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
            Some(vals) => self.run.push(key, &vals, alphabet, num),
            None => {
                if let Some(c) = self.run.take() {
                    self.items.push(Item::Const(c));
                }
                self.items.push(Item::Module {
                    key,
                    params: Thin::from(codes),
                });
            }
        }
        Ok(())
    }

    /// The items, the bracket depth at the end and its lowest point.
    fn finish(mut self) -> (Vec<Item>, i64, i64) {
        if let Some(c) = self.run.take() {
            self.items.push(Item::Const(c));
        }
        (self.items, self.depth, self.min)
    }
}
