//! Syntax tree of a cpfg `.l` file, as grammar/cpfg.lalrpop builds it.
//! Spans are byte offsets into the preprocessed text (map them back to the
//! original files with [`super::preprocess::SourceMap`]).
//!
//! Expressions keep their names unresolved ([`Expr::Var`]): a name may be a
//! formal parameter, a local or global variable of the statement blocks, `Q`
//! (the step) or `Z` (the derivation length); [`super::lower`] resolves them.
//! Statement blocks are kept as data ([`Block`]) on the productions and the
//! L-system for the runtime that executes them.

use crate::lang::lexer::Span;

/// A cpfg expression.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Num(f64, Span),
    Var(String, Span),
    /// A string literal (only `printf`/`fprintf` take one).
    Str(String, Span),
    Call(String, Vec<Expr>, Span),
    Unary(UnOp, Box<Expr>, Span),
    Binary(BinOp, Box<Expr>, Box<Expr>, Span),
    /// `c ? a : b` (cpfg evaluates both branches).
    Cond(Box<Expr>, Box<Expr>, Box<Expr>, Span),
    /// `a[i][j]`: an element of a `define:` array.
    Index(String, Vec<Expr>, Span),
}

impl Expr {
    pub fn span(&self) -> Span {
        match self {
            Expr::Num(_, s)
            | Expr::Var(_, s)
            | Expr::Str(_, s)
            | Expr::Call(_, _, s)
            | Expr::Unary(_, _, s)
            | Expr::Binary(_, _, _, s)
            | Expr::Cond(_, _, _, s)
            | Expr::Index(_, _, s) => *s,
        }
    }
}

pub use crate::lang::ast::{BinOp, UnOp};

/// A statement of a block.
#[derive(Clone, Debug, PartialEq)]
pub enum Stmt {
    /// `name = value;`
    Assign {
        name: String,
        name_span: Span,
        value: Expr,
    },
    /// `name[i][j] = value;`: an element of a `define:` array.
    AssignIndex {
        name: String,
        name_span: Span,
        subs: Vec<Expr>,
        value: Expr,
    },
    /// `if (cond) { then } else { els }` (`els` empty without `else`).
    If {
        cond: Expr,
        then: Block,
        els: Block,
        span: Span,
    },
    /// `while (cond) { body }`
    While { cond: Expr, body: Block, span: Span },
    /// `do { body } while (cond);`
    DoWhile { body: Block, cond: Expr, span: Span },
    /// `printf(format, args...);` or `fprintf(stderr, format, args...);`
    /// (both to standard error in lsgen: standard output holds the string).
    Printf {
        stderr: bool,
        format: String,
        args: Vec<Expr>,
        span: Span,
    },
    /// Any other expression, for its effect (`srand(3);`).
    Expr(Expr),
}

/// `{ stmt ... }`
pub type Block = Vec<Stmt>;

/// The block of a production without one.
static NO_BLOCK: Block = Vec::new();

/// A module as written: a symbol and its parameter expressions (formal
/// parameters: [`Expr::Var`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Module {
    pub sym: char,
    pub params: Vec<Expr>,
    pub span: Span,
}

/// A run of modules as the grammar read it (a successor, a predecessor, a
/// context): the place of its text. A successor line may be megabytes
/// long, and a file may hold millions of productions; a module of the tree
/// costs 50 bytes and more (a formal parameter a name of its own), a module
/// of the text a few. Its modules are read again from the text when they
/// are needed ([`Run::modules`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Run {
    /// From the first module's start to the last one's end.
    span: Span,
    len: usize,
}

impl Run {
    /// Count the next module, read by the grammar (its tree is dropped).
    pub fn push(&mut self, m: &Module) {
        if self.len == 0 {
            self.span.0 = m.span.0;
        }
        self.span.1 = m.span.1;
        self.len += 1;
    }

    /// How many modules.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The modules in order, parsed again from `text`, the text the run
    /// was parsed from: each is what the grammar read there (an error
    /// only if `text` is another one).
    pub fn modules<'a>(&self, text: &'a str) -> super::parse::RunModules<'a> {
        super::parse::RunModules::new(text, self.span, self.len)
    }

    /// [`Run::modules`] as (symbol, number of parameters, span): the
    /// parameters are passed over, not parsed.
    pub fn shapes<'a>(&self, text: &'a str) -> super::parse::Shapes<'a> {
        super::parse::Shapes::new(text, self.span, self.len)
    }
}

/// `lc < pred > rc : { pre } cond { post } --> succ : prob`
#[derive(Clone, Debug, PartialEq)]
pub struct Production {
    /// None: no left context (also `*`).
    pub left: Option<Run>,
    /// The strict predecessor: one module or a run of them (`AB --> C`).
    pub pred: Run,
    pub right: Option<Run>,
    /// The pre-condition and post-condition blocks ([`Production::pre`],
    /// [`Production::post`]), None where both are empty. (Boxed, as
    /// `cond` and `prob`: most productions have none.)
    pub blocks: Option<Box<[Block; 2]>>,
    /// None: always true (also `*`).
    pub cond: Option<Box<Expr>>,
    pub succ: Run,
    pub prob: Option<Box<Expr>>,
    /// The whole production.
    pub span: Span,
}

impl Production {
    /// The pre-condition block (runs before the condition is tested).
    pub fn pre(&self) -> &Block {
        self.blocks.as_ref().map_or(&NO_BLOCK, |b| &b[0])
    }

    /// The post-condition block (runs when the production is applied).
    pub fn post(&self) -> &Block {
        self.blocks.as_ref().map_or(&NO_BLOCK, |b| &b[1])
    }

    /// The left context, the strict predecessor and the right context, in
    /// the order of the text.
    pub fn heads(&self) -> impl Iterator<Item = &Run> {
        self.left
            .iter()
            .chain([&self.pred])
            .chain(self.right.iter())
    }
}

/// A setting before `Axiom:`.
#[derive(Clone, Debug, PartialEq)]
pub enum Setting {
    Seed(Expr, Span),
    DerivationLength(Expr, Span),
    /// Symbols and their spans; a later `ignore:`/`consider:` replaces an
    /// earlier one.
    Ignore(Vec<(char, Span)>, Span),
    Consider(Vec<(char, Span)>, Span),
    /// `define: { array ... }`: cpfg's arrays.
    Arrays(Vec<ArrayDef>, Span),
    /// `ring lsystem`: refused by the lowering.
    Unsupported(crate::diag::Refused, Span),
}

/// An array of `define:`: `name[d1][d2]... = {init, ...}`.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayDef {
    pub name: String,
    /// The name's span.
    pub span: Span,
    /// The size of each dimension.
    pub dims: Vec<Expr>,
    /// The initial values, in row-major order (None: all 0).
    pub init: Option<Vec<Expr>>,
}

/// A `decomposition` or `homomorphism` section.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    pub span: Span,
    /// `warnings` (Some(true)) or `no warnings` (Some(false)).
    pub warnings: Option<bool>,
    pub depth: Option<(Expr, Span)>,
    pub seed: Option<(Expr, Span)>,
    pub productions: Vec<Box<Production>>,
}

/// One `Lsystem: ... endlsystem` block.
#[derive(Clone, Debug, PartialEq)]
pub struct Lsystem {
    pub span: Span,
    pub settings: Vec<Setting>,
    pub start: Option<(Block, Span)>,
    pub start_each: Option<(Block, Span)>,
    pub end_each: Option<(Block, Span)>,
    pub end: Option<(Block, Span)>,
    pub axiom: Vec<AxiomPiece>,
    pub axiom_span: Span,
    pub axiom_brackets: AxiomBrackets,
    pub productions: Vec<Box<Production>>,
    pub decomposition: Option<Box<Section>>,
    pub homomorphism: Option<Box<Section>>,
    /// Where each string literal of the file starts, in order: cpfg keeps
    /// every string in a global table as the parser meets it (control.c's
    /// `GlobalStringIndex`), and a string's value is its number there.
    pub strings: Vec<usize>,
}

/// A statement block of the header (`Start:` ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockKind {
    Start,
    StartEach,
    EndEach,
    End,
}

/// A piece of the axiom: a run of symbols without parameters (kept as
/// text: an axiom line may be megabytes long), or a module with them.
#[derive(Clone, Debug, PartialEq)]
pub enum AxiomPiece {
    Symbols(String),
    Module(Module),
}

impl AxiomPiece {
    /// Append `m` to the axiom `v`.
    pub fn push(v: &mut Vec<AxiomPiece>, m: Module) {
        if !m.params.is_empty() {
            v.push(AxiomPiece::Module(m));
            return;
        }
        match v.last_mut() {
            Some(AxiomPiece::Symbols(s)) => s.push(m.sym),
            _ => v.push(AxiomPiece::Symbols(m.sym.to_string())),
        }
    }
}

/// The axiom's bracket balance, judged as the grammar reads it (its
/// pieces keep no spans): the first `]` without `[`, and the `[` still
/// open at the end (the first of the outermost level), as the axiom
/// reader of `.ls` files reports them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxiomBrackets {
    depth: usize,
    first_open: Span,
    /// The first `]` without `[`.
    pub bad_close: Option<Span>,
}

impl AxiomBrackets {
    /// Count the module `m` (a bracket with parameters is a module).
    pub fn push(&mut self, m: &Module) {
        if !m.params.is_empty() {
            return;
        }
        match m.sym {
            '[' => {
                if self.depth == 0 {
                    self.first_open = m.span;
                }
                self.depth += 1;
            }
            ']' if self.depth == 0 => {
                self.bad_close.get_or_insert(m.span);
            }
            ']' => self.depth -= 1,
            _ => {}
        }
    }

    /// The `[` never closed, if any.
    pub fn unclosed(&self) -> Option<Span> {
        (self.depth > 0).then_some(self.first_open)
    }
}

/// A line before `Axiom:` (the grammar's).
#[derive(Clone, Debug, PartialEq)]
pub enum HeaderItem {
    Setting(Setting),
    Block(BlockKind, Block, Span),
}
