//! Syntax tree of an `.ls` header, as the grammar builds it. Spans are byte
//! offsets into the header text.

use crate::lang::lexer::{GroupList, Span};

#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Num(f64, Span),
    Var(String, Span),
    Call(String, Vec<Expr>, Span),
    Unary(UnOp, Box<Expr>, Span),
    Binary(BinOp, Box<Expr>, Box<Expr>, Span),
    /// `c ? a : b` (cpfg dialect; all three are evaluated).
    Cond(Box<Expr>, Box<Expr>, Box<Expr>, Span),
}

impl Expr {
    pub fn span(&self) -> Span {
        match self {
            Expr::Num(_, s)
            | Expr::Var(_, s)
            | Expr::Call(_, _, s)
            | Expr::Unary(_, _, s)
            | Expr::Binary(_, _, _, s)
            | Expr::Cond(_, _, _, s) => *s,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnOp {
    Neg,
    Not,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    /// `%` (cpfg dialect: remainder of the truncated operands).
    Rem,
    Pow,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    And,
    Or,
}

/// A module as written: a symbol with optional parameter expressions.
#[derive(Clone, Debug, PartialEq)]
pub struct Module {
    pub sym: char,
    pub params: Vec<Expr>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Production {
    pub left: Vec<Module>,
    pub pred: Module,
    /// The rest of a predecessor of several modules (cpfg dialect: `AB
    /// --> C` rewrites the run); empty in `.ls` files.
    pub pred_rest: Vec<Module>,
    pub right: Vec<Module>,
    /// Boxed, as `prob`: most productions have neither.
    pub cond: Option<Box<Expr>>,
    pub succ: Vec<Module>,
    pub prob: Option<Box<Expr>>,
    /// Span of the whole line, for runtime errors.
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Setting {
    DerivationLength(Expr, Span),
    Define(String, Expr, Span),
    Seed(Expr, Span),
    /// `ignore:`: each symbol of the line once, at its first place (and
    /// the first module with parameters, which is an error), not the
    /// line's every module ([`Symbols`]).
    Ignore(Vec<Module>, Span),
    /// `consider:`, as `Ignore`.
    Consider(Vec<Module>, Span),
    /// `groups: G1 G2 ...`: the cycling group schedule (issue 11).
    Groups(GroupList, Span),
    /// `group: EXPR`: the group of step `step`.
    Group(Expr, Span),
}

/// An `ignore:` or `consider:` line's modules as the parser reads them:
/// what they mean is a set of symbols, so only each symbol's first module
/// is kept (and the first module with parameters, an error the compiler
/// reports where it is). A line of millions of modules costs the symbols
/// it names, not a syntax tree node per module (about 50 bytes each).
#[derive(Clone, Debug, Default)]
pub struct Symbols {
    pub modules: Vec<Module>,
    seen: std::collections::HashSet<char>,
    params: bool,
}

impl Symbols {
    /// The line's next module.
    pub fn push(&mut self, m: Module) {
        let first_params = !m.params.is_empty() && !self.params;
        if self.seen.insert(m.sym) || first_params {
            self.params |= !m.params.is_empty();
            self.modules.push(m);
        }
    }
}

/// A `maximum depth:` or `seed:` line of a decomposition or homomorphism
/// section.
#[derive(Clone, Debug, PartialEq)]
pub enum SectionSetting {
    MaximumDepth(Expr, Span),
    Seed(Expr, Span),
}

/// A `decomposition:` or `homomorphism:` section with its options.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Section {
    /// The keyword line.
    pub span: Span,
    pub warnings: bool,
    pub settings: Vec<SectionSetting>,
    pub productions: Vec<Production>,
}

#[derive(Clone, Debug, PartialEq, Default)]
pub struct Header {
    pub settings: Vec<Setting>,
    /// Group 0: `productions:` (or `productions 0:`).
    pub productions: Vec<Production>,
    pub homomorphism: Vec<Production>,
    /// `productions N:` sections, N > 0, in file order.
    pub groups: Vec<(u32, Span, Vec<Production>)>,
    pub decomposition: Option<Section>,
    /// The homomorphism section's options (its productions are in
    /// `homomorphism`).
    pub hom: Option<Section>,
}

impl Production {
    /// Drop the spare capacity the parser's vectors grew with: a file may
    /// hold millions of productions, when the whole tree is collected
    /// (`sink::Collect`; the compiler takes one at a time).
    pub fn compact(mut self) -> Self {
        self.pred.compact();
        self.pred_rest.shrink_to_fit();
        for m in self
            .left
            .iter_mut()
            .chain(self.right.iter_mut())
            .chain(self.succ.iter_mut())
        {
            m.compact();
        }
        self.left.shrink_to_fit();
        self.right.shrink_to_fit();
        self.succ.shrink_to_fit();
        for e in self.cond.iter_mut().chain(self.prob.iter_mut()) {
            e.compact();
        }
        self
    }
}

impl Module {
    fn compact(&mut self) {
        for e in &mut self.params {
            e.compact();
        }
        self.params.shrink_to_fit();
    }
}

impl Expr {
    fn compact(&mut self) {
        match self {
            Expr::Call(_, args, _) => {
                for a in args.iter_mut() {
                    a.compact();
                }
                args.shrink_to_fit();
            }
            Expr::Unary(_, a, _) => a.compact(),
            Expr::Binary(_, a, b, _) => {
                a.compact();
                b.compact();
            }
            Expr::Cond(c, a, b, _) => {
                c.compact();
                a.compact();
                b.compact();
            }
            Expr::Num(..) | Expr::Var(..) => {}
        }
    }
}
