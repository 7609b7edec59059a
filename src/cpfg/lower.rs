//! From a cpfg syntax tree to the shared `.ls` syntax tree's pieces
//! ([`crate::lang::ast`]), handed in file order to a
//! [`HeaderSink`] (the compiler, `rules::Compiler::cpfg`, which compiles
//! them with cpfg's semantics, in the order `rules::compile_dialect`
//! hands a whole header over): one set of rules, strategies and errors
//! for both dialects, and no whole shared tree.
//!
//! Names are resolved here, as cpfg resolves them: a formal parameter, `Q`
//! (the step), `Z` (the derivation length) once `derivation length:` has
//! defined them, else an undefined name, which is 0 with a warning. The
//! axiom's constant parameters are evaluated here (cpfg evaluates them
//! once, as `float`s) and the axiom becomes module text; the others (a
//! global, `ran`, a `Q` or `Z` that `Start:` assigns) are code worked out
//! after `Start:` ([`CpfgRun::axiom`]).
//!
//! For the cpfg runtime (statement blocks, cpfg's generators), the
//! refusals to lift are: `no_block` (blocks, here), the seeded
//! probability in `Lowerer::production` (here), and `PENDING_FUNCTIONS`
//! in `parse.rs` (`ran nran bran biran srand`). Names assigned in blocks
//! (globals, production locals) must then resolve in `Lowerer::expr`
//! before the "undefined name is 0" rule.

use super::ast::{self, Block, Expr, Module, Production, Section, Setting};
use super::blocks;
use super::run::CpfgRun;
use crate::diag::{CompileError as Invalid, WarningKind};
use crate::lang::ast as ls;
use crate::lang::lexer::Span;
use crate::lang::parse::{HeaderError, UserError};
use crate::lang::sink::{HeadPart, HeaderSink, SectionKind, SectionStart, BATCH};
use crate::rules::expr::{Code, Scope, STEP_SLOT};
use std::collections::HashMap;

type R<T> = Result<T, UserError>;

fn err<T>(span: Span, kind: impl Into<HeaderError>) -> R<T> {
    Err(UserError::new(span, kind))
}

/// A lowered `.l` file (its header went to the sink).
pub struct Lowered {
    /// The file has `seed:` (cpfg's stochastic mode).
    pub seeded: bool,
    /// The axiom as module text (parameters evaluated, in full precision;
    /// `0` in place of those worked out after `Start:`, [`CpfgRun::axiom`]).
    pub axiom: String,
    /// What the shared tree cannot hold, for [`attach`]: the
    /// header blocks, and per production (in file order) of the
    /// productions, the decomposition and the homomorphism, its blocks and
    /// slots (issue 12).
    pub run: CpfgRun,
    pub extra: [Vec<ProdExtra>; 3],
}

/// A production's statement blocks and how many slots it needs: its formal
/// parameters (predecessor, left context, right context, as the shared
/// compiler numbers them); its local variables are run variables, as the
/// globals (see `Lowerer::locals`).
#[derive(Clone, Debug, Default)]
pub struct ProdExtra {
    pub pre: Option<blocks::Block>,
    pub post: Option<blocks::Block>,
    pub nslots: usize,
}

/// Give the compiled `system` what the shared tree could not hold (see
/// [`Lowered`]).
pub fn attach(run: &CpfgRun, extra: &[Vec<ProdExtra>; 3], system: &mut crate::rules::System) {
    {
        let mut run = run.clone();
        run.seed = system.seed;
        run.derivation_length = system.derivation_length.unwrap_or(0);
        let tables = [
            Some(&mut system.productions),
            system.decomposition.as_mut().map(|(t, _)| t),
            Some(&mut system.homomorphism),
        ];
        for (t, extra) in tables.into_iter().zip(extra) {
            let Some(t) = t else { continue };
            for (p, x) in t.prods.iter_mut().zip(extra) {
                p.set_nslots(p.nslots().max(x.nslots));
                if x.pre.is_some() || x.post.is_some() {
                    let c = p.cpfg_mut();
                    c.pre.clone_from(&x.pre);
                    c.post.clone_from(&x.post);
                }
            }
        }
        // A decomposition of maximum depth 0 only tries its productions
        // (cpfg's `ApplyRecursiveProductions` at depth 0): nothing to do
        // unless a try changes something.
        if matches!(&system.decomposition, Some((t, 0)) if !t.tries_have_effects()) {
            system.decomposition = None;
        }
        // Blocks that can run: a decomposition's only if it is kept, its
        // post-condition blocks only past depth 0 (there a production is
        // tried, never applied).
        let decomposition = match &system.decomposition {
            None => |_: &ProdExtra| false,
            Some((_, 0)) => |x: &ProdExtra| x.pre.is_some(),
            Some(_) => |x: &ProdExtra| x.pre.is_some() || x.post.is_some(),
        };
        let any = |x: &ProdExtra| x.pre.is_some() || x.post.is_some();
        run.production_blocks = extra[0].iter().any(any)
            || extra[1].iter().any(decomposition)
            || extra[2].iter().any(any);
        system.cpfg = Some(Box::new(run));
    }
}

/// The shared tree's name of cpfg variable `i` (a global, or a
/// production's local: both live in the run's variable slots): a name no
/// lexer makes, which the expression compiler resolves in the cpfg dialect
/// ([`crate::rules::expr`]).
fn global_name(i: u32) -> String {
    format!("\u{1}g{i}")
}

/// Every name an expression reads, in order.
fn expr_names(e: &Expr, out: &mut Vec<String>) {
    match e {
        Expr::Var(n, _) => out.push(n.clone()),
        Expr::Num(..) | Expr::Str(..) => {}
        Expr::Call(_, a, _) => a.iter().for_each(|e| expr_names(e, out)),
        Expr::Unary(_, a, _) => expr_names(a, out),
        Expr::Binary(_, a, b, _) => {
            expr_names(a, out);
            expr_names(b, out);
        }
        Expr::Cond(c, a, b, _) => {
            expr_names(c, out);
            expr_names(a, out);
            expr_names(b, out);
        }
        // (An array's name is no variable.)
        Expr::Index(_, subs, _) => subs.iter().for_each(|e| expr_names(e, out)),
    }
}

/// Every name a block reads or assigns, in order.
fn block_names(b: &Block, out: &mut Vec<String>, assigned_only: bool) {
    let expr = expr_names;
    for s in b {
        match s {
            ast::Stmt::Assign { name, value, .. } => {
                out.push(name.clone());
                if !assigned_only {
                    expr(value, out);
                }
            }
            ast::Stmt::If {
                cond, then, els, ..
            } => {
                if !assigned_only {
                    expr(cond, out);
                }
                block_names(then, out, assigned_only);
                block_names(els, out, assigned_only);
            }
            ast::Stmt::While { cond, body, .. } | ast::Stmt::DoWhile { body, cond, .. } => {
                if !assigned_only {
                    expr(cond, out);
                }
                block_names(body, out, assigned_only);
            }
            ast::Stmt::Printf { args, .. } => {
                if !assigned_only {
                    args.iter().for_each(|e| expr(e, out));
                }
            }
            ast::Stmt::Expr(e) => {
                if !assigned_only {
                    expr(e, out);
                }
            }
            ast::Stmt::AssignIndex { subs, value, .. } => {
                if !assigned_only {
                    expr(value, out);
                    subs.iter().for_each(|e| expr(e, out));
                }
            }
        }
    }
}

/// Most elements of all the arrays of `define:` together (8 MiB).
pub const MAX_ARRAY_ELEMENTS: u64 = 1 << 20;

/// The name a formal parameter gets in the shared tree: `step` is the
/// shared tree's built-in step number (cpfg's `Q`), so a cpfg formal named
/// `step` is renamed to a name no lexer makes.
fn formal_name(name: &str) -> String {
    if name == "step" {
        "step\u{0}".to_string()
    } else {
        name.to_string()
    }
}

struct Lowerer<'w> {
    /// The preprocessed text the tree was parsed from (its successors'
    /// symbols, [`ast::Run`]).
    text: &'w str,
    /// What the header goes to, production by production.
    sink: &'w mut dyn HeaderSink,
    /// The successor batch handed to the sink (one buffer for all).
    batch: Vec<ls::Module>,
    /// The weights of `productions` count though the file has no `seed:`
    /// (`--seed` stands for it); else, without `seed:`, they are left out
    /// as cpfg leaves them, unevaluated at run time.
    weights: bool,
    /// The file's `derivation length:` (cpfg's `Z`), once read.
    z: Option<f64>,
    /// `Q` and `Z` are cpfg's built-in variables (the step, the
    /// derivation length) in the productions and header blocks: the file
    /// has `derivation length:`, and no header item before it read or
    /// assigned them (see [`lower`]).
    builtin: [bool; 2],
    /// The variable that holds `Z` where it is built in and a block
    /// assigns it (cpfg's global `Z` is an ordinary variable, the length
    /// its first value): see [`lower`]. None: `Z` reads as the constant.
    z_global: Option<u32>,
    /// `Start:` assigns `Q`, `Z` (built in or the L-system's own
    /// variables): the axiom, which cpfg reads after `Start:`, cannot take
    /// them as constants (it reads them after `Start:`, [`CpfgRun::axiom`]).
    start_assigns: [bool; 2],
    /// A block assigns the built-in `Q` (the step number, then, is the
    /// value cpfg's Derive gives it at each step until a block changes it).
    assigns_q: bool,
    /// Lowering the axiom (read after `Start:`), not a setting (read
    /// while the file is parsed).
    axiom: bool,
    /// `seed:` given: cpfg's stochastic mode.
    seeded: bool,
    /// Lowering a value needed before the derivation (`Q` is 0).
    constant: bool,
    warn: &'w mut dyn FnMut(Span, WarningKind),
    /// Warnings held instead of said (an axiom parameter tried as a
    /// constant first: said only if it is one).
    held: Option<Vec<(Span, WarningKind)>>,
    /// Global variables: every name of the header blocks (cpfg's L-system
    /// symbol table), by number.
    globals: HashMap<String, u32>,
    /// The current production's local variables (assigned in its blocks,
    /// not formal, not global), by variable number: each production has
    /// its own, which keep their values between applications, as cpfg's
    /// per-production symbol tables do.
    locals: HashMap<String, u32>,
    /// Variables numbered so far (globals, then every production's locals).
    variables: u32,
    /// `define:`'s arrays: first variable and dimensions, by name.
    arrays: HashMap<String, (u32, Vec<u32>)>,
    /// Where each string literal starts, in order ([`ast::Lsystem::strings`]).
    strings: Vec<usize>,
    /// Blocks and slots of the productions lowered so far, per section.
    extra: [Vec<ProdExtra>; 3],
    /// The section being lowered (index into `extra`).
    section: usize,
}

impl Lowerer<'_> {
    /// Say a warning (or hold it: [`Lowerer::held`]).
    fn say(&mut self, at: Span, kind: WarningKind) {
        match &mut self.held {
            Some(h) => h.push((at, kind)),
            None => (self.warn)(at, kind),
        }
    }

    /// Is `name` cpfg's built-in `Q` or `Z` here?
    fn is_builtin(&self, name: &str) -> bool {
        match name {
            "Q" => self.builtin[0],
            "Z" => self.builtin[1],
            _ => false,
        }
    }

    fn expr(&mut self, e: &Expr, formals: &HashMap<String, ()>) -> R<ls::Expr> {
        Ok(match e {
            Expr::Num(v, s) => ls::Expr::Num(*v, *s),
            Expr::Var(name, s) => {
                let q_or_z = name == "Q" || name == "Z";
                if formals.contains_key(name) {
                    ls::Expr::Var(formal_name(name), *s)
                } else if self.arrays.contains_key(name) {
                    return err(*s, Invalid::ArrayWithoutSubscripts(name.clone()));
                } else if q_or_z
                    && self.constant
                    && self.axiom
                    && self.start_assigns[usize::from(name == "Z")]
                {
                    // The axiom is read after `Start:` (control.c's
                    // Rewind), which assigns this `Q` or `Z` (built in or
                    // the L-system's own variable): no constant.
                    return err(*s, Invalid::NotConstant);
                } else if q_or_z && self.constant {
                    // A setting or the axiom, read before any step or
                    // block: `Q` is 0 and `Z` the length once
                    // `derivation length:` has defined them; before that
                    // line (or without it) they are undefined names, 0
                    // with the warning (and, cpfg's parser having made
                    // them variables of the L-system, not built in
                    // afterwards: see `lower`).
                    match self.z {
                        Some(z) if self.is_builtin(name) => {
                            ls::Expr::Num(if name == "Z" { z } else { 0.0 }, *s)
                        }
                        Some(_) => ls::Expr::Num(0.0, *s),
                        None => {
                            self.say(*s, WarningKind::NotDefined(name.clone()));
                            ls::Expr::Num(0.0, *s)
                        }
                    }
                } else if let (true, Some(&l)) = (q_or_z, self.locals.get(name)) {
                    // `=(Q)` in a right context: the production's own
                    // variable (cpfg adds it to the production's table),
                    // which hides the global one.
                    ls::Expr::Var(global_name(l), *s)
                } else if name == "Q" && self.is_builtin(name) {
                    ls::Expr::Var("step".to_string(), *s)
                } else if let (Some(z), true) = (self.z, name == "Z" && self.is_builtin(name)) {
                    match self.z_global {
                        Some(g) => ls::Expr::Var(global_name(g), *s),
                        None => ls::Expr::Num(z, *s),
                    }
                } else if let Some(&g) = self.globals.get(name) {
                    ls::Expr::Var(global_name(g), *s)
                } else if let Some(&l) = self.locals.get(name) {
                    ls::Expr::Var(global_name(l), *s)
                } else {
                    self.say(*s, WarningKind::NotDefined(name.clone()));
                    ls::Expr::Num(0.0, *s)
                }
            }
            // A string is the number cpfg's global string table gives it
            // (`@L("%.f", x)` is `@L(0,x)` when it is the file's first).
            Expr::Str(_, s) => {
                // (The table has 255 places: past them, cpfg gives every
                // string the last one's number.)
                let i = self.strings.partition_point(|&o| o < s.0).min(254);
                ls::Expr::Num(i as f64, *s)
            }
            Expr::Call(name, args, s) => {
                if name == "printf" || name == "fprintf" {
                    return err(*s, Invalid::StatementAsValue(name.clone()));
                }
                let args = args
                    .iter()
                    .map(|a| self.expr(a, formals))
                    .collect::<R<Vec<_>>>()?;
                ls::Expr::Call(name.clone(), args, *s)
            }
            Expr::Unary(op, a, s) => ls::Expr::Unary(*op, Box::new(self.expr(a, formals)?), *s),
            Expr::Binary(op, a, b, s) => ls::Expr::Binary(
                *op,
                Box::new(self.expr(a, formals)?),
                Box::new(self.expr(b, formals)?),
                *s,
            ),
            Expr::Cond(c, a, b, s) => ls::Expr::Cond(
                Box::new(self.expr(c, formals)?),
                Box::new(self.expr(a, formals)?),
                Box::new(self.expr(b, formals)?),
                *s,
            ),
            Expr::Index(name, subs, s) => self.element(name, subs, *s, false, formals)?,
        })
    }

    /// `name[subs...]`: an array element's value, or (`write`) its
    /// variable number, as the expression compiler reads
    /// [`crate::rules::expr::cpfg_array`]'s call.
    fn element(
        &mut self,
        name: &str,
        subs: &[Expr],
        s: Span,
        write: bool,
        formals: &HashMap<String, ()>,
    ) -> R<ls::Expr> {
        let name_span = (s.0, s.0 + name.len());
        let Some((base, dims)) = self.arrays.get(name).cloned() else {
            return err(name_span, Invalid::NotAnArray(name.to_string()));
        };
        if dims.len() != subs.len() {
            let kind = Invalid::Subscripts {
                name: name.to_string(),
                dims: dims.len(),
                given: subs.len(),
            };
            return err(s, kind);
        }
        let subs = subs
            .iter()
            .map(|e| self.expr(e, formals))
            .collect::<R<Vec<_>>>()?;
        let f = crate::rules::expr::cpfg_array(write, base, &dims);
        Ok(ls::Expr::Call(f, subs, s))
    }

    /// A constant expression's value (settings, the axiom), in cpfg's
    /// semantics.
    fn constant(&mut self, e: &Expr) -> R<f64> {
        self.constant = true;
        let e = self.expr(e, &HashMap::new());
        self.constant = false;
        let e = e?;
        let params = HashMap::new();
        let consts = HashMap::new();
        let scope = Scope {
            params: &params,
            consts: &consts,
            cpfg: true,
        };
        let code = Code::compile(&e, &scope).map_err(|x| UserError::new(x.span, x.kind))?;
        match code.value_now() {
            Some(Ok(v)) => Ok(v),
            Some(Err(x)) => Err(UserError::new(x.span, x.kind)),
            None => err(e.span(), Invalid::NotConstant),
        }
    }

    /// A setting's value as cpfg's `(int) Eval(...)` of `lsys_input.y`
    /// gives it: truncated toward zero. A value no `int` holds (or NaN) is
    /// undefined behaviour in C: a located error here.
    fn c_int(&mut self, e: &Expr, what: &'static str) -> R<i64> {
        let v = self.constant(e)?.trunc();
        let (min, max) = (f64::from(i32::MIN), f64::from(i32::MAX));
        if !(min..=max).contains(&v) {
            return err(
                e.span(),
                Invalid::OutOfRange {
                    what,
                    min,
                    max,
                    value: v,
                },
            );
        }
        Ok(v as i64)
    }

    fn module(&mut self, m: &Module, formals: &HashMap<String, ()>) -> R<ls::Module> {
        Ok(ls::Module {
            sym: m.sym,
            params: m
                .params
                .iter()
                .map(|e| self.expr(e, formals))
                .collect::<R<Vec<_>>>()?,
            span: m.span,
        })
    }

    fn formals(
        &mut self,
        mods: &[Module],
        formals: &mut HashMap<String, ()>,
    ) -> R<Vec<ls::Module>> {
        let mut out = Vec::new();
        for m in mods {
            let mut params = Vec::new();
            for e in &m.params {
                match e {
                    Expr::Var(name, s) => {
                        if formals.insert(name.clone(), ()).is_some() {
                            return err(*s, Invalid::FormalTwice(name.clone()));
                        }
                        params.push(ls::Expr::Var(formal_name(name), *s));
                    }
                    other => return err(other.span(), Invalid::FormalNotName),
                }
            }
            out.push(ls::Module {
                sym: m.sym,
                params,
                span: m.span,
            });
        }
        Ok(out)
    }

    /// Compile a block: `names` maps the shared names of the formal
    /// parameters to their slots.
    fn block(
        &mut self,
        b: &Block,
        formals: &HashMap<String, ()>,
        names: &HashMap<String, u32>,
    ) -> R<blocks::Block> {
        let mut out = Vec::new();
        for s in b {
            out.push(match s {
                ast::Stmt::Assign {
                    name,
                    name_span,
                    value,
                } => {
                    // cpfg's parser looks the name up in the production's
                    // table, the L-system's, then the global one
                    // (lsys_input.y's LHS, SymbolTableFind): the built-in
                    // `Q` and `Z` are that global table's ordinary
                    // variables, which an assignment changes (Derive sets
                    // `Q` again at the next step; `Z` stays).
                    let var = if formals.contains_key(name) {
                        blocks::Var::Local(names[&formal_name(name)])
                    } else if self.arrays.contains_key(name) {
                        return err(*name_span, Invalid::ArrayWithoutSubscripts(name.clone()));
                    } else if let Some(&l) = self.locals.get(name) {
                        // (A production's own, also an `=(Q)`'s.)
                        blocks::Var::Global(l)
                    } else if name == "Q" && self.is_builtin(name) {
                        self.assigns_q = true;
                        blocks::Var::Step
                    } else if let (true, Some(g)) = (self.is_builtin(name), self.z_global) {
                        blocks::Var::Global(g)
                    } else if let Some(&g) = self.globals.get(name) {
                        blocks::Var::Global(g)
                    } else {
                        unreachable!("`{name}` assigned in a block has a variable: {name_span:?}")
                    };
                    blocks::Stmt::Assign(var, self.code(value, formals, names)?)
                }
                ast::Stmt::If {
                    cond, then, els, ..
                } => blocks::Stmt::If(
                    self.code(cond, formals, names)?,
                    self.block(then, formals, names)?,
                    self.block(els, formals, names)?,
                ),
                ast::Stmt::While { cond, body, span } => blocks::Stmt::While(
                    self.code(cond, formals, names)?,
                    self.block(body, formals, names)?,
                    *span,
                ),
                ast::Stmt::DoWhile { body, cond, span } => blocks::Stmt::DoWhile(
                    self.block(body, formals, names)?,
                    self.code(cond, formals, names)?,
                    *span,
                ),
                ast::Stmt::Printf {
                    format, args, span, ..
                } => {
                    let (f, n) =
                        blocks::Format::parse(format).map_err(|m| UserError::new(*span, m))?;
                    if n != args.len() {
                        return err(
                            *span,
                            Invalid::PrintfArity {
                                takes: n,
                                given: args.len(),
                            },
                        );
                    }
                    let args = args
                        .iter()
                        .map(|a| self.code(a, formals, names))
                        .collect::<R<Vec<_>>>()?;
                    blocks::Stmt::Printf(f, args.into(), *span)
                }
                ast::Stmt::Expr(e) => blocks::Stmt::Eval(self.code(e, formals, names)?),
                ast::Stmt::AssignIndex {
                    name,
                    name_span,
                    subs,
                    value,
                } => {
                    let value = self.code(value, formals, names)?;
                    let at = (
                        name_span.0,
                        subs.last().map_or(name_span.1, |e| e.span().1 + 1),
                    );
                    let element = self.element(name, subs, at, true, formals)?;
                    let scope = Scope {
                        params: names,
                        consts: &HashMap::new(),
                        cpfg: true,
                    };
                    let at = Code::compile(&element, &scope)
                        .map_err(|x| UserError::new(x.span, x.kind))?;
                    blocks::Stmt::AssignElement(at, value)
                }
            });
        }
        Ok(blocks::Block(out.into()))
    }

    /// An axiom parameter worked out after `Start:`: its code, with the
    /// value rounded to the 32-bit float cpfg stores (an overflow is the
    /// located error of a successor's parameter).
    fn late(&mut self, e: &Expr, names: &HashMap<String, u32>) -> R<Code> {
        let f32 = crate::rules::expr::CPFG_F32.to_string();
        let rounded = Expr::Call(f32, vec![e.clone()], e.span());
        self.code(&rounded, &HashMap::new(), names)
    }

    fn code(
        &mut self,
        e: &Expr,
        formals: &HashMap<String, ()>,
        names: &HashMap<String, u32>,
    ) -> R<Code> {
        let e = self.expr(e, formals)?;
        let scope = Scope {
            params: names,
            consts: &HashMap::new(),
            cpfg: true,
        };
        Code::compile(&e, &scope).map_err(|x| UserError::new(x.span, x.kind))
    }

    /// Lower `p` into the sink.
    fn production(&mut self, p: &Production, section: &'static str) -> R<()> {
        // The head's modules, read again from the text (a file of many
        // productions keeps only their places).
        let text = self.text;
        let read = |r: &ast::Run| r.modules(text).collect::<R<Vec<Module>>>();
        let p_left = p.left.as_ref().map(read).transpose()?;
        let p_pred = read(&p.pred)?;
        let p_right = p.right.as_ref().map(read).transpose()?;
        let mut formals = HashMap::new();
        let mut left = match &p_left {
            Some(l) => self.formals(l, &mut formals)?,
            None => Vec::new(),
        };
        let mut pred = self.formals(&p_pred, &mut formals)?;
        let pred_rest = pred.split_off(1);
        if let Some(m) = p_right.as_ref().and_then(|r| r.last()) {
            // cpfg's `RconDiff` skips the branch at `=` and then reads the
            // next pattern module without checking that there is one: a
            // segmentation fault wherever the match gets that far.
            if m.sym == '=' {
                return err(m.span, Invalid::RightContextEndsInSkip);
            }
        }
        let mut right = match &p_right {
            Some(r) => self.formals(r, &mut formals)?,
            None => Vec::new(),
        };
        // `=(x)`: cpfg's RconDiff skips the branch at any `=`, whatever
        // its parameters, and GetRconVars binds nothing from it (generate.c
        // passes over `=`): its names stay the production's variables,
        // 0 until a block assigns them, kept between applications (cpfg's
        // per-production symbol table) — a local here.
        let mut skipped = Vec::new();
        for m in p_right.iter().flatten().filter(|m| m.sym == '=') {
            for e in &m.params {
                if let Expr::Var(name, _) = e {
                    formals.remove(name);
                    skipped.push(name.clone());
                }
            }
        }
        for m in right.iter_mut().filter(|m| m.sym == '=') {
            m.params.clear();
        }
        // Slots as the shared compiler numbers them: predecessor (its
        // first module, then the rest), left context, right context.
        let mut names = HashMap::new();
        for m in pred.iter().chain(&pred_rest).chain(&left).chain(&right) {
            for e in &m.params {
                if let ls::Expr::Var(n, _) = e {
                    let k = names.len() as u32;
                    names.insert(n.clone(), k);
                }
            }
        }
        names.insert("step".to_string(), STEP_SLOT);
        let mut assigned = Vec::new();
        block_names(p.pre(), &mut assigned, true);
        block_names(p.post(), &mut assigned, true);
        self.locals.clear();
        for n in skipped {
            if !self.globals.contains_key(&n) {
                self.locals.insert(n, self.variables);
                self.variables += 1;
            }
        }
        for n in assigned {
            // `Q` and `Z`, where built in, are cpfg's global variables:
            // assigning one assigns that (`Lowerer::block`), never a
            // private copy. Where they are not (no `derivation length:`),
            // they are names like any other, as in cpfg.
            if !formals.contains_key(&n)
                && !self.is_builtin(&n)
                && !self.globals.contains_key(&n)
                && !self.locals.contains_key(&n)
            {
                self.locals.insert(n, self.variables);
                self.variables += 1;
            }
        }
        let pre = (!p.pre().is_empty())
            .then(|| self.block(p.pre(), &formals, &names))
            .transpose()?;
        let post = (!p.post().is_empty())
            .then(|| self.block(p.post(), &formals, &names))
            .transpose()?;
        self.extra[self.section].push(ProdExtra {
            pre,
            post,
            // (`names` holds `step` too.)
            nslots: names.len() - 1,
        });
        let mut cond = match &p.cond {
            Some(c) => Some(Box::new(self.expr(c, &formals)?)),
            None => None,
        };
        let bracket = p_left.iter().flatten().find(|m| matches!(m.sym, '[' | ']'));
        if let Some(m) = bracket {
            // cpfg's `LconDiff` passes over the string's brackets (`]`
            // skips a branch, `[` is stepped over) and compares the pattern
            // with other modules only: a bracket in a left context matches
            // nothing, so the production never applies (its contexts fail
            // before its pre-condition block or condition would run). Kept
            // for its errors, with a false condition and no blocks (the
            // warning comes after the production's others, below).
            left.retain(|m| !matches!(m.sym, '[' | ']'));
            cond = Some(Box::new(ls::Expr::Num(0.0, m.span)));
            let x = self.extra[self.section].last_mut().expect("pushed above");
            x.pre = None;
            x.post = None;
        }
        // The head, then the successor in batches: a successor line of
        // millions of modules never exists whole in the shared tree.
        let parts = [
            (HeadPart::Left, left),
            (HeadPart::Pred, vec![pred.pop().expect("one module")]),
            (HeadPart::Rest, pred_rest),
            (HeadPart::Right, right),
        ];
        for (part, modules) in parts {
            for m in modules {
                self.sink.head_module(part, m);
            }
        }
        self.sink.head_end(cond, p.span);
        let mut batch = std::mem::take(&mut self.batch);
        for m in p.succ.modules(self.text) {
            batch.push(self.module(&m?, &formals)?);
            if batch.len() == BATCH {
                self.sink.successor(&mut batch);
            }
        }
        if !batch.is_empty() {
            self.sink.successor(&mut batch);
        }
        self.batch = batch;
        let prob = match &p.prob {
            None => None,
            // cpfg's stochastic choice (src/cpfg/random.rs).
            Some(e) if self.seeded && section.is_empty() => Some(Box::new(self.expr(e, &formals)?)),
            // Without `seed:` the weights are ignored at run time, as in
            // cpfg, unless `--seed` stands for `seed:` (README).
            Some(e) if section.is_empty() => {
                // The library's names; `cpfg::load` gives it the caller's.
                let names = crate::diag::OptionNames::Library;
                (self.warn)(e.span(), WarningKind::ProbabilityWithoutSeed { names });
                Some(Box::new(self.expr(e, &formals)?))
            }
            Some(e) => {
                (self.warn)(e.span(), WarningKind::ProbabilityInSection(section));
                None
            }
        };
        self.locals.clear();
        if let Some(m) = bracket {
            (self.warn)(m.span, WarningKind::LeftContextBracket);
        }
        // Without `seed:` (or `--seed`) cpfg never evaluates the weights:
        // `A --> B : -1` is no error there.
        let counts = self.seeded || self.weights || !section.is_empty();
        self.sink.end(prob.filter(|_| counts), p.span);
        Ok(())
    }

    /// Lower the section `s` into the sink, its productions dropped as
    /// they are lowered.
    fn section(&mut self, mut s: Section, kind: SectionKind) -> R<()> {
        let name = match kind {
            SectionKind::Decomposition => "decomposition ",
            _ => "homomorphism ",
        };
        let mut settings = Vec::new();
        if let Some((e, span)) = &s.depth {
            // `(int) Eval(...)` (lsys_input.y's ProdDepth): truncated; 0 or
            // below stops at the top: no decomposition
            // (ApplyRecursiveProductions returns at once), the
            // homomorphism applies nothing but still warns
            // (InterpretHomomorphism). lsgen recurses at most 10000 deep.
            let v = self.c_int(e, "the maximum depth")?;
            if v > 10_000 {
                return err(
                    e.span(),
                    Invalid::OutOfRange {
                        what: "the maximum depth",
                        min: f64::from(i32::MIN),
                        max: 10_000.0,
                        value: v as f64,
                    },
                );
            }
            settings.push(ls::SectionSetting::MaximumDepth(
                ls::Expr::Num(v.max(0) as f64, e.span()),
                *span,
            ));
        }
        if let Some((e, span)) = &s.seed {
            // `(int) Eval(...)` (lsys_input.y's HomoSeed); interpret.c
            // gives the homomorphism its own generator only for a seed
            // >= 0: a negative one is as none (its default is -1).
            let v = self.c_int(e, "the homomorphism's seed")?;
            if v >= 0 {
                settings.push(ls::SectionSetting::Seed(
                    ls::Expr::Num(v as f64, e.span()),
                    *span,
                ));
            }
        }
        self.sink.section(SectionStart {
            kind,
            span: s.span,
            // cpfg warns unless told `no warnings`.
            warnings: s.warnings.unwrap_or(true),
            settings,
        });
        for p in std::mem::take(&mut s.productions) {
            self.production(&p, name)?;
        }
        Ok(())
    }
}

/// Lower `lsys`, parsed from `text`, into `sink` (the shared tree's
/// header in file order, productions dropped as they are lowered);
/// `weights`: `--seed` is given, so production weights count without
/// `seed:`; `warn` receives each warning with its span.
pub(crate) fn lower(
    mut lsys: ast::Lsystem,
    text: &str,
    weights: bool,
    sink: &mut dyn HeaderSink,
    warn: &mut dyn FnMut(Span, WarningKind),
) -> R<Lowered> {
    // cpfg's parser defines `Q` and `Z` in the global symbol table at the
    // `derivation length:` line (lsys_input.y, Dlength), after evaluating
    // its value; a name it does not find is made a variable (0, with a
    // warning) of the table in use: the L-system's, in the header. So a
    // header item up to that line (or anywhere, without it) that reads or
    // assigns `Q` or `Z` makes it an ordinary variable of the L-system,
    // which hides the built-in one everywhere after (Derive updates only
    // the global `Q`). Without such an item and without the line, they are
    // undefined names (a production that assigns one has its own) unless
    // the axiom names them.
    let dl_at = lsys.settings.iter().find_map(|s| match s {
        Setting::DerivationLength(_, span) => Some(span.0),
        _ => None,
    });
    let before = |at: usize| dl_at.is_none_or(|d| at <= d);
    let mut early = Vec::new();
    for s in &lsys.settings {
        match s {
            Setting::Seed(e, span) | Setting::DerivationLength(e, span) if before(span.0) => {
                expr_names(e, &mut early)
            }
            _ => {}
        }
    }
    for (b, span) in [&lsys.start, &lsys.start_each, &lsys.end_each, &lsys.end]
        .into_iter()
        .flatten()
    {
        if before(span.0) {
            block_names(b, &mut early, false);
        }
    }
    if dl_at.is_none() {
        // (The axiom is read in the L-system's table too.)
        for piece in &lsys.axiom {
            if let ast::AxiomPiece::Module(m) = piece {
                m.params.iter().for_each(|e| expr_names(e, &mut early));
            }
        }
    }
    let builtin = ["Q", "Z"].map(|n| dl_at.is_some() && !early.iter().any(|e| e == n));
    // Where they are built in, `Q` and `Z` are ordinary variables of
    // cpfg's global table: a block may assign them (`Lowerer::block`).
    // `Start:` runs before the axiom is read; `Z` assigned anywhere
    // becomes a run variable that starts at the length (below).
    let assigned_in = |b: &Block| {
        let mut names = Vec::new();
        block_names(b, &mut names, true);
        ["Q", "Z"].map(|n| names.iter().any(|x| x == n))
    };
    let start_assigns = lsys
        .start
        .as_ref()
        .map_or([false; 2], |(b, _)| assigned_in(b));
    // (A production's formal `Z` counts too: then `Z` is a variable that
    // holds the length, which reads the same.)
    let z_assigned = builtin[1] && {
        let blocks = [&lsys.start, &lsys.start_each, &lsys.end_each, &lsys.end]
            .into_iter()
            .flatten()
            .map(|(b, _)| b);
        let sections = [&lsys.decomposition, &lsys.homomorphism]
            .into_iter()
            .flatten()
            .flat_map(|s| &s.productions);
        let prods = lsys.productions.iter().chain(sections);
        blocks
            .chain(prods.flat_map(|p| [p.pre(), p.post()]))
            .any(|b| assigned_in(b)[1])
    };
    let mut lw = Lowerer {
        text,
        sink,
        batch: Vec::new(),
        weights,
        z: None,
        builtin,
        z_global: None,
        start_assigns,
        assigns_q: false,
        axiom: false,
        seeded: false,
        constant: false,
        warn,
        held: None,
        globals: HashMap::new(),
        locals: HashMap::new(),
        variables: 0,
        arrays: HashMap::new(),
        strings: std::mem::take(&mut lsys.strings),
        extra: Default::default(),
        section: 0,
    };
    // Every name of the header blocks is global (cpfg's L-system table);
    // so are `Q` and `Z` where they are not built in and a header item
    // names them.
    let mut names = Vec::new();
    for (b, _) in [&lsys.start, &lsys.start_each, &lsys.end_each, &lsys.end]
        .into_iter()
        .flatten()
    {
        block_names(b, &mut names, false);
    }
    names.extend(early.iter().filter(|n| *n == "Q" || *n == "Z").cloned());
    for n in names {
        if !lw.is_builtin(&n) {
            let k = lw.globals.len() as u32;
            lw.globals.entry(n).or_insert(k);
        }
    }
    if z_assigned {
        lw.z_global = Some(lw.globals.len() as u32);
    }
    lw.variables = lw.globals.len() as u32 + u32::from(z_assigned);
    // `define:`'s arrays: run variables after the globals, each its
    // elements in row-major order (cpfg's AllocateArray), allocated in
    // file order with the settings (a dimension may read `Z`).
    let mut inits = Vec::new();
    let mut elements = 0u64;
    let mut blocks_seen = 0;
    // The shared tree's settings.
    let mut settings = Vec::new();
    // (ignore, symbols, span) of the last `ignore:`/`consider:`.
    let mut filter = None;
    for s in &lsys.settings {
        match s {
            Setting::Unsupported(what, span) => {
                return err(*span, crate::diag::ParseError::Refused(what.clone()))
            }
            Setting::Arrays(defs, _) => {
                blocks_seen += 1;
                for d in defs {
                    if lw.arrays.contains_key(&d.name) {
                        return err(d.span, Invalid::ArrayTwice(d.name.clone()));
                    }
                    if lw.globals.contains_key(&d.name) {
                        return err(d.span, Invalid::ArrayIsVariable(d.name.clone()));
                    }
                    let mut dims = Vec::new();
                    let mut size = 1u64;
                    for e in &d.dims {
                        let n = lw.c_int(e, "an array dimension")?;
                        if n < 1 {
                            return err(e.span(), Invalid::ArrayDimension(n as f64));
                        }
                        size = size.saturating_mul(n as u64);
                        if size > MAX_ARRAY_ELEMENTS {
                            return err(e.span(), Invalid::ArraysTooLarge(MAX_ARRAY_ELEMENTS));
                        }
                        dims.push(n as u32);
                    }
                    elements += size;
                    if elements > MAX_ARRAY_ELEMENTS {
                        return err(d.span, Invalid::ArraysTooLarge(MAX_ARRAY_ELEMENTS));
                    }
                    let base = lw.variables;
                    lw.variables += size as u32;
                    lw.arrays.insert(d.name.clone(), (base, dims));
                    inits.push((d, base, size, blocks_seen));
                }
            }
            Setting::Seed(e, span) => {
                // `(int) Eval(...)` (lsys_input.y); control.c seeds with
                // `seed48({seed, 0, 155})` when it is not 0, the `int`
                // stored in an `unsigned short`: its low 16 bits, modulo
                // 2^16 for a negative one. The shared setting keeps a
                // value that says the same (src/cpfg/random.rs keeps 16
                // bits of a non-zero seed): a non-negative seed as it is,
                // a negative one as the non-zero 65536 + (seed mod 2^16).
                let v = lw.c_int(e, "the seed")?;
                let v = if v >= 0 {
                    v as f64
                } else {
                    f64::from(v as u16) + 65536.0
                };
                lw.seeded = true;
                settings.retain(|s| !matches!(s, ls::Setting::Seed(..)));
                settings.push(ls::Setting::Seed(ls::Expr::Num(v, e.span()), *span));
            }
            Setting::DerivationLength(e, span) => {
                // `(int) Eval(...)`: truncated; below 0 cpfg derives no
                // step (GenerateNSteps' loop), but `Z` keeps the value.
                // A later line sets the length (lsys_input.y's Dlength
                // assigns it) but not `Z`: its SymbolTableAdd appends a
                // second `Z` that SymbolTableFind, which returns the
                // first, never reaches.
                let n = lw.c_int(e, "the derivation length")?;
                lw.z.get_or_insert(n as f64);
                settings.retain(|s| !matches!(s, ls::Setting::DerivationLength(..)));
                settings.push(ls::Setting::DerivationLength(
                    ls::Expr::Num(n.max(0) as f64, e.span()),
                    *span,
                ));
            }
            // A later `ignore:`/`consider:` replaces an earlier one.
            Setting::Ignore(syms, span) => filter = Some((true, syms, *span)),
            Setting::Consider(syms, span) => filter = Some((false, syms, *span)),
        }
    }
    if lw.z.is_none() {
        // cpfg derives 0 steps without `derivation length:`.
        let at = (lsys.span.0, lsys.span.0);
        settings.push(ls::Setting::DerivationLength(ls::Expr::Num(0.0, at), at));
    }
    if let Some((ignore, syms, span)) = filter {
        let mods = syms
            .iter()
            .map(|&(sym, s)| ls::Module {
                sym,
                params: Vec::new(),
                span: s,
            })
            .collect();
        settings.push(if ignore {
            ls::Setting::Ignore(mods, span)
        } else {
            ls::Setting::Consider(mods, span)
        });
    }
    // The axiom: values now, stored as cpfg stores them (32-bit floats);
    // a parameter that is no constant (a global, `ran`, a `Q` or `Z` that
    // `Start:` assigns) is worked out after `Start:`, as cpfg reads the
    // axiom after it (control.c's Rewind): `0` holds its place in the
    // text, and its code goes to `late`.
    let step_names: HashMap<String, u32> = [("step".to_string(), STEP_SLOT)].into_iter().collect();
    let mut late = Vec::new();
    let mut axiom = String::new();
    for piece in &lsys.axiom {
        let m = match piece {
            ast::AxiomPiece::Symbols(s) => {
                axiom.push_str(s);
                continue;
            }
            ast::AxiomPiece::Module(m) => m,
        };
        // Here, where the module's place in the file is known: the axiom
        // reader that reads the lowered text would point into that text.
        if m.params.len() > crate::rules::codec::MAX_ARITY {
            return err(m.span, crate::diag::ParseError::TooManyParams);
        }
        axiom.push(m.sym);
        axiom.push('(');
        for (i, e) in m.params.iter().enumerate() {
            if i > 0 {
                axiom.push(',');
            }
            lw.axiom = true;
            lw.held = Some(Vec::new());
            let v = lw.constant(e);
            lw.axiom = false;
            let held = lw.held.take().unwrap_or_default();
            let v = match v {
                Err(x) if x.kind == HeaderError::Compile(Invalid::NotConstant) => {
                    // (Its warnings come again as it is lowered as code.)
                    late.push((axiom.len(), lw.late(e, &step_names)?));
                    axiom.push('0');
                    continue;
                }
                v => {
                    for (at, kind) in held {
                        (lw.warn)(at, kind);
                    }
                    v?
                }
            };
            let v = f64::from(v as f32);
            if v.is_nan() {
                return err(e.span(), Invalid::NanF32);
            }
            if !v.is_finite() {
                return err(e.span(), Invalid::OutOfF32);
            }
            axiom.push_str(&crate::rules::codec::number_string(v));
        }
        axiom.push(')');
    }
    if lsys.axiom.is_empty() {
        return err(lsys.axiom_span, Invalid::EmptyAxiom);
    }
    // Header blocks: globals only (after the settings, which set `Z`).
    let mut run = CpfgRun::default();
    if !late.is_empty() {
        run.axiom = Some((axiom.clone(), late));
    }
    // `Q` is the shared tree's built-in step number.
    let none = step_names;
    for (b, slot) in [
        (&lsys.start, &mut run.start),
        (&lsys.start_each, &mut run.start_each),
        (&lsys.end_each, &mut run.end_each),
        (&lsys.end, &mut run.end),
    ] {
        if let Some((b, _)) = b {
            *slot = lw.block(b, &HashMap::new(), &none)?;
        }
    }
    // The arrays' initial values, as many as an array has elements, at the
    // start of the run before `Start:`, twice as in cpfg: for every array
    // as the file is read (lsys_input.y calls InitializeArray), then for
    // those of the last `define:` (control.c's InitialiseForStart runs the
    // L-system's `defineBlock`, ProcessArrayDef). Only the draws (`ran`)
    // and the values an initial value reads can tell.
    let mut define = Vec::new();
    let mut again = Vec::new();
    for (d, base, size, block) in inits {
        let given = d.init.as_ref().map_or(0, Vec::len);
        if d.init.is_some() && given as u64 != size {
            let name = d.name.clone();
            lw.say(d.span, WarningKind::ArrayInitialisers { name, given, size });
        }
        let codes = d
            .init
            .iter()
            .flatten()
            .take(size as usize)
            .map(|e| lw.code(e, &HashMap::new(), &none))
            .collect::<R<Vec<_>>>()?;
        let init = blocks::Stmt::InitArray(base, size as u32, codes.into());
        if block == blocks_seen {
            again.push(init.clone());
        }
        define.push(init);
    }
    define.extend(again);
    run.define = blocks::Block(define.into());
    if let (Some(g), Some(z)) = (lw.z_global, lw.z) {
        // `Z` holds the length from the `derivation length:` line on
        // (lsys_input.y's Dlength), before `Start:` runs.
        let at = lsys.span;
        let scope = Scope {
            params: &HashMap::new(),
            consts: &HashMap::new(),
            cpfg: true,
        };
        let value = Code::compile(&ls::Expr::Num(z, at), &scope)
            .map_err(|x| UserError::new(x.span, x.kind))?;
        let mut start = vec![blocks::Stmt::Assign(blocks::Var::Global(g), value)];
        start.extend(std::mem::take(&mut run.start).0.into_vec());
        run.start = blocks::Block(start.into());
    }
    // The header in the order `rules::compile_dialect` hands a whole one
    // over.
    lw.sink.settings(settings);
    lw.sink.section(SectionStart {
        kind: SectionKind::Group(0),
        span: (0, 0),
        warnings: false,
        settings: Vec::new(),
    });
    for p in std::mem::take(&mut lsys.productions) {
        lw.production(&p, "")?;
    }
    if let Some(d) = lsys.decomposition.take() {
        lw.section = 1;
        lw.section(*d, SectionKind::Decomposition)?;
    }
    if let Some(h) = lsys.homomorphism.take() {
        lw.section = 2;
        lw.section(*h, SectionKind::Homomorphism)?;
    }
    run.assigns_q = lw.assigns_q;
    Ok(Lowered {
        seeded: lw.seeded,
        axiom,
        run,
        extra: lw.extra,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpfg::parse::parse;

    /// `src` lowered into the shared tree, as derived with `--seed`.
    fn lowered(src: &str) -> (R<(Lowered, ls::Header)>, Vec<String>) {
        lowered_with(src, true)
    }

    fn lowered_with(src: &str, weights: bool) -> (R<(Lowered, ls::Header)>, Vec<String>) {
        let mut warnings = Vec::new();
        let tree = parse(src).unwrap();
        let mut sink = crate::lang::sink::Collect::default();
        let r = lower(tree, src, weights, &mut sink, &mut |_, m| {
            warnings.push(m.to_string())
        });
        (r.map(|l| (l, sink.header)), warnings)
    }

    #[test]
    fn names_and_axiom() {
        let (r, w) = lowered(
            "Lsystem: 1\nderivation length: 3\nAxiom: A(Z, Q, 0.1, nothing)\nA(x) --> A(x + Q + Z)\nendlsystem\n",
        );
        let (l, h) = r.unwrap();
        // 0.1 stored as a float: 0.10000000149011612.
        assert_eq!(l.axiom, "A(3,0,0.10000000149011612,0)");
        assert_eq!(w.len(), 1);
        assert!(w[0].contains("`nothing` is not defined"));
        let succ = &h.productions[0].succ[0].params[0];
        let text = format!("{succ:?}");
        assert!(
            text.contains("\"step\"") && text.contains("Num(3.0"),
            "{text}"
        );
    }

    #[test]
    fn assigned_q_and_z_are_variables() {
        // Z assigned (here in EndEach:) is a run variable that `Start:`
        // sets to the length first; productions read it; Q assigned is the
        // step value, kept into the homomorphism.
        let (r, w) = lowered(
            "Lsystem: 1\nderivation length: 4\nEndEach: {Z = Z * 2; Q = 1;}\nAxiom: A\n\
             A --> B(Z, Q)\nendlsystem\n",
        );
        let (l, h) = r.unwrap();
        assert!(w.is_empty(), "{w:?}");
        assert!(l.run.assigns_q);
        let start = &l.run.start.0;
        assert_eq!(start.len(), 1);
        assert!(
            matches!(&start[0], blocks::Stmt::Assign(blocks::Var::Global(_), c) if c.constant() == Some(4.0)),
            "{start:?}"
        );
        assert!(matches!(
            &l.run.end_each.0[1],
            blocks::Stmt::Assign(blocks::Var::Step, _)
        ));
        let text = format!("{:?}", h.productions[0].succ[0].params);
        assert!(
            text.contains("\\u{1}g") && !text.contains("Num(4.0"),
            "{text}"
        );
        // Neither assigned: Z is the constant, Q the step, nothing added.
        let (r, _) = lowered(
            "Lsystem: 1\nderivation length: 4\nEndEach: {x = Z + Q;}\nAxiom: A\n\
             A --> B(Z, Q)\nendlsystem\n",
        );
        let (l, h) = r.unwrap();
        assert!(!l.run.assigns_q);
        assert_eq!(l.run.start.0.len(), 0);
        let text = format!("{:?}", h.productions[0].succ[0].params);
        assert!(text.contains("Num(4.0"), "{text}");
    }

    #[test]
    fn depth_zero_decomposition_is_kept_only_for_its_tries() {
        // cpfg tries the productions at depth 0 and applies none: kept
        // where a try has an effect (a pre-condition block, a condition
        // that draws), dropped otherwise (nothing to do).
        for (prod, kept) in [
            ("A : {n = n + 1;} * --> B", true),
            ("A : ran(1) > 2 --> B", true),
            ("A : * {n = n + 1;} --> B", false),
            ("A : n > 0 --> B", false),
        ] {
            let src = format!(
                "Lsystem: 1\nderivation length: 1\nStart: {{n = 0;}}\nAxiom: A\n\
                 decomposition\nmaximum depth: 0\n{prod}\nendlsystem\n"
            );
            let (r, _) = lowered(&src);
            let (_, h) = r.unwrap();
            assert!(h.decomposition.is_some(), "{prod}: lowered");
            let (_, s) = crate::cpfg::load(
                "t.l",
                &src,
                false,
                crate::diag::OptionNames::Library,
                (&Default::default(), true),
            )
            .unwrap();
            assert_eq!(s.decomposition.is_some(), kept, "{prod}");
        }
    }

    #[test]
    fn refusals_not_yet() {
        let (r, _) = lowered("Lsystem: 1\nAxiom: AB\nAB --> C\nendlsystem\n");
        assert_eq!(r.unwrap().1.productions[0].pred_rest.len(), 1);
        // cpfg matches one in the decomposition and the homomorphism too.
        for section in ["decomposition", "homomorphism"] {
            let (r, _) = lowered(&format!(
                "Lsystem: 1\nAxiom: AB\n{section}\nAB --> C\nendlsystem\n"
            ));
            let h = r.unwrap().1;
            let prods = match &h.decomposition {
                Some(d) => &d.productions,
                None => &h.homomorphism,
            };
            assert_eq!(prods[0].pred_rest.len(), 1, "{section}");
        }
        // Weights: kept with `seed:`; without it kept with `--seed`, else
        // left out (cpfg never evaluates them), with a warning either way.
        for weights in [false, true] {
            let src = "Lsystem: 1\nseed: 2\nAxiom: A\nA --> B : 0.5\nendlsystem\n";
            let (r, w) = lowered_with(src, weights);
            assert!(r.unwrap().1.productions[0].prob.is_some());
            assert!(w.is_empty(), "{w:?}");
            let src = "Lsystem: 1\nAxiom: A\nA --> B : 0.5\nendlsystem\n";
            let (r, w) = lowered_with(src, weights);
            assert_eq!(r.unwrap().1.productions[0].prob.is_some(), weights);
            assert!(w[0].contains("ignored"));
        }
    }
}

#[cfg(test)]
mod soup {
    use crate::cpfg::parse::parse;

    /// Random token soup: parse and lower give a tree or an error, never
    /// a panic.
    #[test]
    fn random_input_never_panics() {
        let pieces = [
            "Lsystem: 1\n",
            "Axiom: ",
            "endlsystem\n",
            "A",
            "B(x)",
            "(",
            ")",
            "*",
            "<",
            ">",
            ":",
            "-->",
            "->",
            "\n",
            "\n\t",
            "{",
            "}",
            "x = 1;",
            "if (x) {",
            "} else {",
            "while (1) {",
            "do {",
            "} while (0);",
            "printf(\"%d\", x);",
            "?",
            "$",
            "@S",
            "1.0e3",
            "1e3",
            "\"s",
            "%",
            ",",
            ";",
            "homomorphism\n",
            "decomposition\n",
            "maximum depth: 2\n",
            "seed: 3\n",
            "derivation length: Z\n",
            "ignore: A\n",
            "Start: {",
            "x ? 1 : 2",
            "-",
            "^",
            "!",
            "&&",
            "||",
            "==",
            "<>",
            "[",
            "]",
            "AB(a)C(b)",
            "Q",
            "atan(1,2)",
            "sin(",
            "\u{7}",
            "é",
        ];
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..3000 {
            let mut s = String::from("Lsystem: 1\n");
            for _ in 0..(x % 24) {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                s.push_str(pieces[(x % pieces.len() as u64) as usize]);
            }
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            if let Ok(ls) = parse(&s) {
                let mut c = crate::rules::Compiler::cpfg(Some(&s));
                if super::lower(ls, &s, false, &mut c, &mut |_, _| {}).is_ok() {
                    let _ = c.finish();
                }
            }
        }
    }
}
