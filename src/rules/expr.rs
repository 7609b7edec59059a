//! Expressions compiled once to a flat stack code, evaluated per module.
//!
//! Parameters are read from numbered slots; constants from `define:` are
//! folded in at compile time, and so is any sub-expression without a
//! parameter or a random draw. Every arithmetic result is checked: a
//! division by zero, an overflow or a NaN stops the run with the span of
//! the operation. The cpfg dialect computes as cpfg's C code does instead
//! ([`Op::Ieee`], [`Op::F1Ieee`]): a NaN or an infinity is a value (a
//! comparison with NaN is false, NaN is true as a condition), and only
//! what C leaves undefined (converting one to an `int`) or what lsgen
//! cannot store (a module parameter past a 32-bit float) is an error.

use super::Thin;
use crate::cpfg::curve::Coordinate;
use crate::derive::random::{Draw, Random};
use crate::diag::ExprError;
use crate::lang::ast::{BinOp, Expr, UnOp};
use crate::lang::lexer::Span;
use std::collections::HashMap;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Func1 {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sqrt,
    Exp,
    Log,
    Floor,
    Ceil,
    Trunc,
    Abs,
    /// cpfg's `trunc`: floor(x + 0.5).
    Round,
    /// cpfg's `sign`: -1, 0 or 1.
    Sign,
    /// Round to a 32-bit float: cpfg stores parameters as `float`s (the
    /// cpfg dialect wraps every successor parameter in it, [`CPFG_F32`]).
    Float32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Func2 {
    Min,
    Max,
    Atan2,
    /// cpfg's `atan(a, b)`: atan(b), in degrees.
    AtanSecond,
}

impl Func1 {
    fn apply(self, x: f64) -> f64 {
        match self {
            Func1::Sin => x.to_radians().sin(),
            Func1::Cos => x.to_radians().cos(),
            Func1::Tan => x.to_radians().tan(),
            Func1::Asin => x.asin().to_degrees(),
            Func1::Acos => x.acos().to_degrees(),
            Func1::Atan => x.atan().to_degrees(),
            Func1::Sqrt => x.sqrt(),
            Func1::Exp => x.exp(),
            Func1::Log => x.ln(),
            Func1::Floor => x.floor(),
            Func1::Ceil => x.ceil(),
            Func1::Trunc => x.trunc(),
            Func1::Abs => x.abs(),
            Func1::Round => (x + 0.5).floor(),
            Func1::Float32 => f64::from(x as f32),
            // cpfg's `sign` (generate.c): `x == 0 ? 0 : (x > 0 ? 1 : -1)`,
            // so NaN is -1.
            Func1::Sign => {
                if x == 0.0 {
                    0.0
                } else if x > 0.0 {
                    1.0
                } else {
                    -1.0
                }
            }
        }
    }
}

impl Func2 {
    fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Func2::Min => a.min(b),
            Func2::Max => a.max(b),
            Func2::Atan2 => a.atan2(b).to_degrees(),
            Func2::AtanSecond => b.atan().to_degrees(),
        }
    }
}

/// Functions by name with their arity.
fn lookup_function(name: &str) -> Option<(Fun, usize)> {
    use Func1::*;
    use Func2::*;
    Some(match name {
        "sin" => (Fun::F1(Sin), 1),
        "cos" => (Fun::F1(Cos), 1),
        "tan" => (Fun::F1(Tan), 1),
        "asin" => (Fun::F1(Asin), 1),
        "acos" => (Fun::F1(Acos), 1),
        "atan" => (Fun::F1(Atan), 1),
        "sqrt" => (Fun::F1(Sqrt), 1),
        "exp" => (Fun::F1(Exp), 1),
        "log" => (Fun::F1(Log), 1),
        "floor" => (Fun::F1(Floor), 1),
        "ceil" => (Fun::F1(Ceil), 1),
        "trunc" => (Fun::F1(Trunc), 1),
        "abs" => (Fun::F1(Abs), 1),
        "min" => (Fun::F2(Min), 2),
        "max" => (Fun::F2(Max), 2),
        "atan2" => (Fun::F2(Atan2), 2),
        "ran" => (Fun::Ran, 1),
        "nran" => (Fun::Nran, 2),
        _ => return None,
    })
}

/// The name of [`Func1::Float32`] for the cpfg dialect's compiler (no
/// lexer makes it a name).
pub const CPFG_F32: &str = "\u{0}f32";

/// An element of a cpfg array as `src/cpfg/lower.rs` names it, a call of
/// this name with the subscripts as arguments: `\u{2}r` reads the element,
/// `\u{2}w` gives its variable number (to assign), then the array's first
/// variable and its dimensions, `\u{2}r12:3x4`.
pub fn cpfg_array(write: bool, base: u32, dims: &[u32]) -> String {
    let dims: Vec<String> = dims.iter().map(u32::to_string).collect();
    format!(
        "\u{2}{}{base}:{}",
        if write { 'w' } else { 'r' },
        dims.join("x")
    )
}

/// [`cpfg_array`]'s name read back: (write, first variable, dimensions).
fn cpfg_array_of(name: &str) -> Option<(bool, u32, Vec<u32>)> {
    let rest = name.strip_prefix('\u{2}')?;
    let write = rest.starts_with('w');
    let (base, dims) = rest.get(1..)?.split_once(':')?;
    let dims = dims
        .split('x')
        .map(str::parse)
        .collect::<Result<Vec<u32>, _>>()
        .ok()?;
    Some((write, base.parse().ok()?, dims))
}

/// cpfg's variables as `src/cpfg/lower.rs` names them (issue 12):
/// variable `i` (a global, or a production's local) is `\u{1}g<i>`.
fn cpfg_variable(name: &str) -> Option<Op> {
    let n = name.strip_prefix("\u{1}g")?;
    n.parse().ok().map(Op::Global)
}

/// The cpfg dialect's functions (cpfg's `lsys_input.y`): degrees, `trunc`
/// rounds, `atan` takes 1 or 2 arguments. Random ones are the cpfg
/// runtime's.
fn lookup_cpfg_function(name: &str, args: usize) -> Option<(Fun, usize)> {
    use Func1::*;
    Some(match name {
        "sin" => (Fun::F1(Sin), 1),
        "cos" => (Fun::F1(Cos), 1),
        "tan" => (Fun::F1(Tan), 1),
        "asin" => (Fun::F1(Asin), 1),
        "acos" => (Fun::F1(Acos), 1),
        "atan" if args == 2 => (Fun::F2(Func2::AtanSecond), 2),
        "atan" => (Fun::F1(Atan), 1),
        "sqrt" => (Fun::F1(Sqrt), 1),
        "exp" => (Fun::F1(Exp), 1),
        "log" => (Fun::F1(Log), 1),
        "floor" => (Fun::F1(Floor), 1),
        "ceil" => (Fun::F1(Ceil), 1),
        "trunc" => (Fun::F1(Round), 1),
        "fabs" => (Fun::F1(Abs), 1),
        "sign" => (Fun::F1(Sign), 1),
        // On cpfg's function generator (src/cpfg/random.rs).
        "ran" => (Fun::Ran, 1),
        "nran" => (Fun::Nran, 2),
        "bran" => (Fun::Cpfg(CpfgFun::Bran), 2),
        "biran" => (Fun::Cpfg(CpfgFun::Biran), 2),
        "srand" => (Fun::Cpfg(CpfgFun::Srand), 1),
        // cpfg's functions drawn in vlab (src/cpfg/func.rs).
        "func" => (Fun::Func, 2),
        // cpfg's curves (src/cpfg/curve.rs).
        "curveX" => (Fun::Curve(CurveFn::Point(Coordinate::X)), 2),
        "curveY" => (Fun::Curve(CurveFn::Point(Coordinate::Y)), 2),
        "curveZ" => (Fun::Curve(CurveFn::Point(Coordinate::Z)), 2),
        "curveGAL" => (Fun::Curve(CurveFn::Length), 1),
        CPFG_F32 => (Fun::F1(Float32), 1),
        _ => return None,
    })
}

enum Fun {
    F1(Func1),
    F2(Func2),
    Ran,
    Nran,
    Cpfg(CpfgFun),
    Func,
    Curve(CurveFn),
}

/// cpfg's curve functions, on the run's curves ([`Draw::curve`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CurveFn {
    /// `curveX(id, t)` and the like (two operands).
    Point(Coordinate),
    /// `curveGAL(id)` (one).
    Length,
}

impl CurveFn {
    pub fn name(self) -> &'static str {
        match self {
            CurveFn::Point(c) => c.name(),
            CurveFn::Length => "curveGAL",
        }
    }
}

/// cpfg's random functions (issue 12), on its function generator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CpfgFun {
    /// `ran(x)`: x times one draw (NaN and infinities are values).
    Ran,
    /// `nran(mean, sd)`: a normal deviate (likewise).
    Nran,
    /// `bran(a, b)`: a beta deviate.
    Bran,
    /// `biran(n, p)`: a binomial deviate.
    Biran,
    /// `srand(x)`: reseed, giving 0.
    Srand,
}

/// One instruction. Operations that can fail carry the index of their span.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    Const(f64),
    Load(u32),
    /// The syntax tree's operators, one list for both (`lang::ast`).
    Un(UnOp),
    Bin(BinOp, u32),
    /// cpfg's `/`: a zero divisor divides by 1 (with a warning). Cannot
    /// fail: an infinite or NaN quotient is a value, as in C.
    DivOr1(u32),
    F1(Func1, u32),
    /// cpfg's `+ - * ^`: C's double arithmetic, whose NaN and infinities
    /// are values, not errors. Cannot fail.
    Ieee(BinOp),
    /// A function of the cpfg dialect (not [`Func1::Float32`]): C's
    /// result, NaN (`sqrt(-1)`) and infinities included. Cannot fail.
    F1Ieee(Func1),
    F2(Func2, u32),
    Ran(u32),
    Nran(u32),
    /// `bran`, `biran` (two operands) or `srand` (one).
    CpfgRan(CpfgFun, u32),
    /// cpfg's `func(id, x)` (two operands): the run's functions, read
    /// through the generator ([`Draw::func`]).
    Func(u32),
    /// cpfg's curve functions: the run's curves, read through the
    /// generator ([`Draw::curve`]).
    Curve(CurveFn, u32),
    /// A cpfg array subscript for a dimension of this size: one past the
    /// last or below 0 becomes the nearest in range (with a warning, as
    /// in cpfg); NaN fails.
    Subscript(u32, u32),
    /// A cpfg array element: the element number on the stack (the
    /// subscripts combined row-major, truncated as C's `(int)`) of the
    /// array of `total` elements at variable `base`; its value, or
    /// (`write`) its variable number.
    Element {
        base: u32,
        total: u32,
        write: bool,
        span: u32,
    },
    /// The built-in step number (issue 11), kept by the generator.
    Step,
    /// Not an instruction: the span of a fallible one, stored after the
    /// code (u32 offsets: headers are far below 4 GiB).
    At(u32, u32),
    /// A cpfg global variable (issue 12), kept by the generator.
    Global(u32),
    /// `c ? a : b` with c, a, b on the stack (all three evaluated, as
    /// cpfg does).
    Select,
}

/// The parameter slot that names the built-in `step` in a scope's
/// `params` (issue 11).
pub const STEP_SLOT: u32 = u32::MAX;

/// Parameter slots from here on name cpfg's global variables (issue 12):
/// `GLOBAL_SLOT + i` is global `i`, read from the generator
/// ([`Draw::global`]), not from the production's slots.
pub const GLOBAL_SLOT: u32 = 1 << 31;

/// A compiled expression: the shapes most successor parameters and
/// conditions have (a constant, a parameter, one binary operation on two
/// of those) in place, 24 bytes and no block of their own; others as a
/// block of instructions (a production table may hold millions of these).
#[derive(Clone, Debug, PartialEq)]
pub struct Code(Repr);

#[derive(Clone, Debug, PartialEq)]
enum Repr {
    Const {
        v: f64,
        start: u32,
    },
    /// A parameter, then (`f32`, the cpfg dialect) rounded to a 32-bit
    /// float, which fails at `span`.
    Load {
        slot: u32,
        f32: bool,
        span: (u32, u32),
    },
    /// `slot OP constant` (then `f32`); the operation and the rounding
    /// fail at `span`, which starts the expression.
    LoadConst {
        a: u32,
        c: f64,
        op: Bin2,
        f32: bool,
        span: (u32, u32),
    },
    /// `constant OP slot`.
    ConstLoad {
        c: f64,
        b: u32,
        op: Bin2,
        f32: bool,
        span: (u32, u32),
    },
    /// `slot OP slot`.
    LoadLoad {
        a: u32,
        b: u32,
        op: Bin2,
        f32: bool,
        span: (u32, u32),
    },
    /// The `n` instructions ([`ops`](Code::ops)), then the spans of those
    /// that can fail (`At`), in one block; where the expression starts
    /// (runtime errors of a probability or `group:` are located there).
    Packed {
        packed: Thin<Op>,
        n: u32,
        start: u32,
    },
}

/// A binary operation of [`Repr`]'s in-place shapes (an [`Op`] without
/// its span index).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Bin2 {
    Bin(BinOp),
    DivOr1,
    F2(Func2),
    Ieee(BinOp),
}

impl Bin2 {
    fn of(op: Op) -> Option<Bin2> {
        match op {
            Op::Bin(b, _) => Some(Bin2::Bin(b)),
            Op::DivOr1(_) => Some(Bin2::DivOr1),
            Op::F2(f, _) => Some(Bin2::F2(f)),
            Op::Ieee(b) => Some(Bin2::Ieee(b)),
            _ => None,
        }
    }
    /// The operation ([`Code::binary`]; an in-place shape has one span).
    #[inline(always)]
    fn op(self) -> Op {
        match self {
            Bin2::Bin(b) => Op::Bin(b, 0),
            Bin2::DivOr1 => Op::DivOr1(0),
            Bin2::F2(f) => Op::F2(f, 0),
            Bin2::Ieee(b) => Op::Ieee(b),
        }
    }
}

/// A failed evaluation: what, and where in the header text.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalError {
    pub span: Span,
    pub kind: ExprError,
}

impl EvalError {
    /// The message, as the error shows it.
    pub fn message(&self) -> String {
        self.kind.to_string()
    }
}

/// A compile error: unknown identifier, unknown function, wrong arity, or a
/// constant sub-expression that fails.
pub type CompileError = EvalError;

/// Names visible to an expression.
pub struct Scope<'a> {
    /// Formal parameters and their slots.
    pub params: &'a HashMap<String, u32>,
    /// Constants from `define:`.
    pub consts: &'a HashMap<String, f64>,
    /// The cpfg dialect: its functions, `/` and `%`.
    pub cpfg: bool,
}

/// A [`Code`] being compiled.
struct Draft {
    ops: Vec<Op>,
    spans: Vec<Span>,
    span: Span,
}

impl Code {
    pub fn compile(e: &Expr, scope: &Scope) -> Result<Code, CompileError> {
        let mut c = Draft {
            ops: Vec::new(),
            spans: Vec::new(),
            span: e.span(),
        };
        c.emit(e, scope)?;
        Ok(Code::pack(&c.ops, &c.spans, c.span))
    }

    /// The instructions, then the span of each one that can fail, in
    /// order (spans of folded or infallible operations are dropped); the
    /// common shapes in place ([`Repr`]).
    fn pack(ops: &[Op], spans: &[Span], span: Span) -> Code {
        let u = |x: usize| u32::try_from(x).unwrap_or(u32::MAX);
        let mut all = Vec::with_capacity(ops.len() + spans.len());
        let mut kept = Vec::new();
        for &op in ops {
            let mut at = |si: u32| {
                kept.push(spans[si as usize]);
                (kept.len() - 1) as u32
            };
            all.push(match op {
                // Comparisons and logic cannot fail: no span kept (a
                // condition's block is one operation shorter).
                Op::Bin(b, _) if !can_fail(b) => Op::Bin(b, u32::MAX),
                Op::Bin(b, si) => Op::Bin(b, at(si)),
                Op::DivOr1(si) => Op::DivOr1(at(si)),
                Op::CpfgRan(f, si) => Op::CpfgRan(f, at(si)),
                Op::Func(si) => Op::Func(at(si)),
                Op::Curve(f, si) => Op::Curve(f, at(si)),
                Op::Subscript(n, si) => Op::Subscript(n, at(si)),
                Op::Element {
                    base,
                    total,
                    write,
                    span,
                } => Op::Element {
                    base,
                    total,
                    write,
                    span: at(span),
                },
                Op::F1(f, si) => Op::F1(f, at(si)),
                Op::F2(f, si) => Op::F2(f, at(si)),
                Op::Ran(si) => Op::Ran(at(si)),
                Op::Nran(si) => Op::Nran(at(si)),
                other => other,
            });
        }
        let whole = (u(span.0), u(span.1));
        let kept: Vec<(u32, u32)> = kept.iter().map(|s| (u(s.0), u(s.1))).collect();
        if let Some(r) = Code::in_place(&all, &kept, whole) {
            return Code(r);
        }
        all.extend(kept.iter().map(|&(a, b)| Op::At(a, b)));
        Code(Repr::Packed {
            packed: Thin::from(all),
            n: ops.len() as u32,
            start: whole.0,
        })
    }

    /// `ops` (spans in `kept`, the whole expression at `whole`) as an
    /// in-place shape, if it is one whose every failure is at one span
    /// that starts where the expression does.
    fn in_place(ops: &[Op], kept: &[(u32, u32)], whole: (u32, u32)) -> Option<Repr> {
        // The span of a fallible operation, or of the whole expression.
        let span_of = |op: Op| match op {
            Op::Bin(b, _) if !can_fail(b) => Some(whole),
            Op::Ieee(_) => Some(whole),
            Op::Bin(_, si) | Op::DivOr1(si) | Op::F2(_, si) | Op::F1(_, si) => {
                kept.get(si as usize).copied()
            }
            _ => None,
        };
        // The binary operation and the optional rounding after it fail at
        // one span, which starts the expression.
        let one = |op: Op, rest: &[Op]| -> Option<(Bin2, bool, (u32, u32))> {
            let span = span_of(op)?;
            let f32 = match rest {
                [] => false,
                [r @ Op::F1(Func1::Float32, _)] if span_of(*r)? == span => true,
                _ => return None,
            };
            (span.0 == whole.0).then_some((Bin2::of(op)?, f32, span))
        };
        Some(match *ops {
            [Op::Const(v)] => Repr::Const { v, start: whole.0 },
            [Op::Load(slot)] => Repr::Load {
                slot,
                f32: false,
                span: whole,
            },
            [Op::Load(slot), r @ Op::F1(Func1::Float32, _)] => {
                let span = span_of(r)?;
                (span.0 == whole.0).then_some(Repr::Load {
                    slot,
                    f32: true,
                    span,
                })?
            }
            [Op::Load(a), Op::Const(c), op, ref rest @ ..] => {
                let (op, f32, span) = one(op, rest)?;
                Repr::LoadConst {
                    a,
                    c,
                    op,
                    f32,
                    span,
                }
            }
            [Op::Const(c), Op::Load(b), op, ref rest @ ..] => {
                let (op, f32, span) = one(op, rest)?;
                Repr::ConstLoad {
                    c,
                    b,
                    op,
                    f32,
                    span,
                }
            }
            [Op::Load(a), Op::Load(b), op, ref rest @ ..] => {
                let (op, f32, span) = one(op, rest)?;
                Repr::LoadLoad {
                    a,
                    b,
                    op,
                    f32,
                    span,
                }
            }
            _ => return None,
        })
    }

    /// Where the expression starts in the header.
    #[inline]
    pub fn start(&self) -> usize {
        (match self.0 {
            Repr::Const { start, .. } | Repr::Packed { start, .. } => start,
            Repr::Load { span, .. }
            | Repr::LoadConst { span, .. }
            | Repr::ConstLoad { span, .. }
            | Repr::LoadLoad { span, .. } => span.0,
        }) as usize
    }

    /// The instructions of a block (none for an in-place shape).
    #[inline]
    fn ops(&self) -> &[Op] {
        match &self.0 {
            Repr::Packed { packed, n, .. } => &packed[..*n as usize],
            _ => &[],
        }
    }

    /// The value, if the expression needs no parameter and no draw.
    #[inline]
    pub fn constant(&self) -> Option<f64> {
        match self.0 {
            Repr::Const { v, .. } => Some(v),
            _ => None,
        }
    }

    /// The value, worked out now, of an expression that needs no
    /// parameter, draw, step or global but was left as code: one with
    /// cpfg's `/` by zero, whose warning comes where it is evaluated (the
    /// compiler does not fold it). None if it needs any of them.
    pub fn value_now(&self) -> Option<Result<f64, EvalError>> {
        match &self.0 {
            Repr::Const { v, .. } => Some(Ok(*v)),
            Repr::Packed { .. } => {
                let needs = self.ops().iter().any(needs_input);
                (!needs).then(|| self.eval(&[], &mut Vec::new(), &mut Random::new(0)))
            }
            _ => None,
        }
    }

    /// Does evaluating this expression draw random numbers?
    pub fn uses_random(&self) -> bool {
        self.ops()
            .iter()
            .any(|o| matches!(o, Op::Ran(_) | Op::Nran(_) | Op::CpfgRan(..)))
    }

    /// Can evaluating it do more than give a value: warn (cpfg's `/` by
    /// zero, [`Op::DivOr1`]) or fail (a remainder by zero, a rounding to
    /// a 32-bit float, a function's NaN ...)? In the in-place shapes too.
    /// (Comparisons and logic, C's arithmetic of the cpfg dialect and its
    /// functions cannot.)
    pub fn may_warn_or_fail(&self) -> bool {
        let bin = |op: Bin2| match op {
            Bin2::DivOr1 => true,
            Bin2::Bin(b) => can_fail(b),
            Bin2::F2(f) => f != Func2::AtanSecond,
            Bin2::Ieee(_) => false,
        };
        match &self.0 {
            Repr::Const { .. } => false,
            Repr::Load { f32, .. } => *f32,
            Repr::LoadConst { op, f32, .. }
            | Repr::ConstLoad { op, f32, .. }
            | Repr::LoadLoad { op, f32, .. } => *f32 || bin(*op),
            Repr::Packed { .. } => self.ops().iter().any(|&o| match o {
                Op::Un(_) | Op::Const(_) | Op::Load(_) | Op::Step | Op::Global(_) => false,
                Op::Select | Op::At(..) | Op::F1Ieee(_) => false,
                // (Draws count as effects on their own: `uses_random`.)
                Op::Ran(_) | Op::Nran(_) | Op::CpfgRan(..) => false,
                o => Bin2::of(o).is_none_or(bin),
            }),
        }
    }

    /// Can evaluating it warn (cpfg's `/` by a divisor that is not a
    /// constant other than 0, a clamped array subscript)? Those warnings
    /// are said on the thread that evaluates.
    pub fn may_warn(&self) -> bool {
        match &self.0 {
            Repr::Const { .. } | Repr::Load { .. } => false,
            Repr::LoadConst { op, c, .. } => *op == Bin2::DivOr1 && *c == 0.0,
            Repr::ConstLoad { op, .. } | Repr::LoadLoad { op, .. } => *op == Bin2::DivOr1,
            Repr::Packed { .. } => {
                let ops = self.ops();
                ops.iter().enumerate().any(|(i, o)| match o {
                    Op::Subscript(..) => true,
                    // (The divisor is the operation before it if that is
                    // a constant.)
                    Op::DivOr1(_) => !matches!(i.checked_sub(1).map(|j| ops[j]),
                        Some(Op::Const(c)) if c != 0.0),
                    _ => false,
                })
            }
        }
    }

    /// Does evaluating it read what a cpfg block can assign while a step
    /// runs (a global variable, an array element, `Q`: the built-in step,
    /// which blocks of a `.l` file assign)?
    pub fn reads_state(&self) -> bool {
        self.ops()
            .iter()
            .any(|o| matches!(o, Op::Global(_) | Op::Element { .. } | Op::Step))
    }

    /// Does this expression read the built-in `step`?
    pub fn uses_step(&self) -> bool {
        self.ops().iter().any(|o| matches!(o, Op::Step))
    }
}

impl Draft {
    fn span_index(&mut self, s: Span) -> u32 {
        self.spans.push(s);
        (self.spans.len() - 1) as u32
    }

    fn emit(&mut self, e: &Expr, scope: &Scope) -> Result<(), CompileError> {
        let start = self.ops.len();
        match e {
            Expr::Num(v, _) => self.ops.push(Op::Const(*v)),
            Expr::Var(name, span) => {
                if let Some(&slot) = scope.params.get(name) {
                    self.ops.push(if slot == STEP_SLOT {
                        Op::Step
                    } else if slot >= GLOBAL_SLOT {
                        Op::Global(slot - GLOBAL_SLOT)
                    } else {
                        Op::Load(slot)
                    });
                } else if let Some(&v) = scope.consts.get(name) {
                    self.ops.push(Op::Const(v));
                } else if let Some(op) = scope.cpfg.then(|| cpfg_variable(name)).flatten() {
                    self.ops.push(op);
                } else {
                    return Err(EvalError {
                        span: *span,
                        kind: ExprError::UnknownIdentifier(name.clone()),
                    });
                }
            }
            Expr::Call(name, args, span) if scope.cpfg && name.starts_with('\u{2}') => {
                let Some((write, base, dims)) = cpfg_array_of(name) else {
                    unreachable!("an array name the lowering made: {name:?}");
                };
                // cpfg's tARRAYREF: each subscript clamped to its
                // dimension, then temp = (temp + s[k-1]) * size[k] for
                // each later dimension, plus the last subscript.
                let si = self.span_index(*span);
                for (k, (a, &size)) in args.iter().zip(&dims).enumerate() {
                    if k > 0 {
                        self.ops.push(Op::Const(f64::from(size)));
                        self.ops.push(Op::Ieee(BinOp::Mul));
                    }
                    self.emit(a, scope)?;
                    self.ops.push(Op::Subscript(size, si));
                    if k > 0 {
                        self.ops.push(Op::Ieee(BinOp::Add));
                    }
                }
                let total = dims.iter().product::<u32>();
                self.ops.push(Op::Element {
                    base,
                    total,
                    write,
                    span: si,
                });
            }
            Expr::Call(name, args, span) => {
                let found = if scope.cpfg {
                    lookup_cpfg_function(name, args.len())
                } else {
                    lookup_function(name)
                };
                let Some((fun, arity)) = found else {
                    return Err(EvalError {
                        span: (span.0, span.0 + name.len()),
                        kind: ExprError::UnknownFunction(name.clone()),
                    });
                };
                if args.len() != arity {
                    return Err(EvalError {
                        span: *span,
                        kind: ExprError::Arity {
                            name: name.clone(),
                            arity,
                            got: args.len(),
                        },
                    });
                }
                for a in args {
                    self.emit(a, scope)?;
                }
                let si = self.span_index(*span);
                self.ops.push(match fun {
                    // cpfg: C's results, NaN and infinities included.
                    Fun::F1(f) if scope.cpfg && f != Func1::Float32 => Op::F1Ieee(f),
                    Fun::F1(f) => Op::F1(f, si),
                    Fun::F2(f) => Op::F2(f, si),
                    Fun::Ran if scope.cpfg => Op::CpfgRan(CpfgFun::Ran, si),
                    Fun::Nran if scope.cpfg => Op::CpfgRan(CpfgFun::Nran, si),
                    Fun::Ran => Op::Ran(si),
                    Fun::Nran => Op::Nran(si),
                    Fun::Cpfg(f) => Op::CpfgRan(f, si),
                    Fun::Func => Op::Func(si),
                    Fun::Curve(f) => Op::Curve(f, si),
                });
            }
            Expr::Unary(op, a, _) => {
                self.emit(a, scope)?;
                self.ops.push(Op::Un(*op));
            }
            Expr::Cond(c, a, b, _) => {
                self.emit(c, scope)?;
                self.emit(a, scope)?;
                self.emit(b, scope)?;
                self.ops.push(Op::Select);
            }
            Expr::Binary(op, a, b, span) => {
                self.emit(a, scope)?;
                self.emit(b, scope)?;
                let si = self.span_index(*span);
                self.ops.push(match op {
                    BinOp::Div if scope.cpfg => Op::DivOr1(si),
                    BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Pow if scope.cpfg => {
                        Op::Ieee(*op)
                    }
                    BinOp::Rem => {
                        if matches!(self.ops.last(), Some(Op::Const(v)) if v.trunc() == 0.0) {
                            return Err(EvalError {
                                span: b.span(),
                                kind: ExprError::RemainderByZero,
                            });
                        }
                        Op::Bin(BinOp::Rem, si)
                    }
                    _ => Op::Bin(*op, si),
                });
            }
        }
        self.fold(start)
    }

    /// Fold the code emitted since `start` to one constant when it reads no
    /// parameter and draws nothing.
    fn fold(&mut self, start: usize) -> Result<(), CompileError> {
        let tail = &self.ops[start..];
        if tail.len() == 1 || tail.iter().any(needs_input) {
            return Ok(());
        }
        let sub = Code::pack(tail, &self.spans, self.span);
        // cpfg's `/` by zero warns where the expression is evaluated, as
        // in cpfg, not here (a successor that never applies says
        // nothing): such a division is left as it is.
        let said = tail
            .iter()
            .any(|o| matches!(o, Op::DivOr1(_)))
            .then(crate::diag::collect_warnings);
        let v = sub.eval(&[], &mut Vec::new(), &mut Random::new(0))?;
        if said.is_some_and(|c| !c.take().is_empty()) {
            return Ok(());
        }
        self.ops.truncate(start);
        self.ops.push(Op::Const(v));
        Ok(())
    }
}

impl Code {
    /// Evaluate with parameters in `slots`; `stack` is scratch space reused
    /// between calls.
    #[inline]
    pub fn eval<D: Draw + ?Sized>(
        &self,
        slots: &[f64],
        stack: &mut Vec<f64>,
        rng: &mut D,
    ) -> Result<f64, EvalError> {
        // The shapes most successors and conditions have, in place.
        let (r, f32) = match self.0 {
            Repr::Const { v, .. } => return Ok(v),
            Repr::Load { slot, f32, .. } => (slots[slot as usize], f32),
            Repr::LoadConst { a, c, op, f32, .. } => {
                (self.binary(op.op(), slots[a as usize], c)?, f32)
            }
            Repr::ConstLoad { c, b, op, f32, .. } => {
                (self.binary(op.op(), c, slots[b as usize])?, f32)
            }
            Repr::LoadLoad { a, b, op, f32, .. } => (
                self.binary(op.op(), slots[a as usize], slots[b as usize])?,
                f32,
            ),
            Repr::Packed { .. } => return self.eval_block(slots, stack, rng),
        };
        if f32 {
            self.float32(r, 0)
        } else {
            Ok(r)
        }
    }

    /// [`eval`](Self::eval) of a block of instructions. Out of line: the
    /// in-place shapes' path stays short (saves fewer registers).
    #[inline(never)]
    fn eval_block<D: Draw + ?Sized>(
        &self,
        slots: &[f64],
        stack: &mut Vec<f64>,
        rng: &mut D,
    ) -> Result<f64, EvalError> {
        stack.clear();
        for op in self.ops() {
            match *op {
                Op::Const(v) => stack.push(v),
                Op::Load(s) => stack.push(slots[s as usize]),
                Op::Step => stack.push(rng.step()),
                Op::At(..) => unreachable!("a span is not an instruction"),
                Op::Global(g) => stack.push(rng.global(g)),
                Op::Un(UnOp::Neg) => {
                    let a = stack.last_mut().unwrap();
                    *a = -*a;
                }
                Op::Un(UnOp::Not) => {
                    let a = stack.last_mut().unwrap();
                    *a = if *a == 0.0 { 1.0 } else { 0.0 };
                }
                Op::Select => {
                    let b = stack.pop().unwrap();
                    let a = stack.pop().unwrap();
                    let c = stack.last_mut().unwrap();
                    *c = if *c != 0.0 { a } else { b };
                }
                Op::Bin(..) | Op::DivOr1(_) | Op::F2(..) | Op::Ieee(_) => {
                    let b = stack.pop().unwrap();
                    let a = stack.last_mut().unwrap();
                    *a = self.binary(*op, *a, b)?;
                }
                Op::F1(Func1::Float32, si) => {
                    let a = stack.last_mut().unwrap();
                    *a = self.float32(*a, si)?;
                }
                Op::F1Ieee(f) => {
                    let a = stack.last_mut().unwrap();
                    *a = f.apply(*a);
                }
                Op::F1(f, si) => {
                    let a = stack.last_mut().unwrap();
                    let r = f.apply(*a);
                    if !r.is_finite() {
                        return Err(self.fail(si, ExprError::Undefined(self.name_at(si))));
                    }
                    *a = r;
                }
                Op::Ran(si) => {
                    let a = stack.last_mut().unwrap();
                    // Uniform in [0, x), or (x, 0] for negative x (cpfg's
                    // x * drand48()); + 0.0 turns a -0 into 0.
                    let r = *a
                        * rng
                            .uniform()
                            .map_err(|m| self.fail(si, ExprError::Random(m)))?
                        + 0.0;
                    if !r.is_finite() {
                        return Err(self.fail(si, ExprError::Undefined("ran()")));
                    }
                    *a = r;
                }
                Op::CpfgRan(f, si) => {
                    let r = match f {
                        // cpfg's `x * erand48()` (+ 0.0: no -0, as in the
                        // `.ls` dialect) and `nrand`: any value.
                        CpfgFun::Ran => {
                            let a = stack.pop().unwrap();
                            rng.uniform().map(|u| a * u + 0.0)
                        }
                        CpfgFun::Nran => {
                            let sd = stack.pop().unwrap();
                            let mean = stack.pop().unwrap();
                            rng.normal(mean, sd)
                        }
                        CpfgFun::Srand => {
                            let a = stack.pop().unwrap();
                            rng.srand(a)
                        }
                        CpfgFun::Bran | CpfgFun::Biran => {
                            let b = stack.pop().unwrap();
                            let a = stack.pop().unwrap();
                            if f == CpfgFun::Bran {
                                rng.bran(a, b)
                            } else {
                                rng.biran(a, b)
                            }
                        }
                    };
                    stack.push(r.map_err(|m| self.fail(si, ExprError::Random(m)))?);
                }
                Op::Subscript(size, si) => {
                    let s = stack.last_mut().unwrap();
                    if s.is_nan() {
                        return Err(self.fail(si, ExprError::SubscriptNaN));
                    }
                    if *s >= f64::from(size) || *s < 0.0 {
                        warn_subscript_clamped();
                        *s = if *s < 0.0 { 0.0 } else { f64::from(size - 1) };
                    }
                }
                Op::Element {
                    base,
                    total,
                    write,
                    span,
                } => {
                    let e = stack.last_mut().unwrap();
                    let i = e.trunc();
                    if !(i >= 0.0 && i < f64::from(total)) {
                        let kind = ExprError::OutsideArray {
                            index: i,
                            size: total,
                        };
                        return Err(self.fail(span, kind));
                    }
                    let var = base + i as u32;
                    *e = if write {
                        f64::from(var)
                    } else {
                        rng.global(var)
                    };
                }
                Op::Func(si) => {
                    let x = stack.pop().unwrap();
                    let id = stack.last_mut().unwrap();
                    *id = rng
                        .func(*id, x)
                        .map_err(|m| self.fail(si, ExprError::Func(m)))?;
                }
                Op::Curve(f, si) => {
                    let t = match f {
                        CurveFn::Point(_) => stack.pop().unwrap(),
                        CurveFn::Length => 0.0,
                    };
                    let id = stack.last_mut().unwrap();
                    *id = rng
                        .curve(f, *id, t)
                        .map_err(|m| self.fail(si, ExprError::Func(m)))?;
                }
                Op::Nran(si) => {
                    let sd = stack.pop().unwrap();
                    let mean = stack.last_mut().unwrap();
                    let r = rng
                        .normal(*mean, sd)
                        .map_err(|m| self.fail(si, ExprError::Random(m)))?;
                    if !r.is_finite() {
                        return Err(self.fail(si, ExprError::Undefined("nran()")));
                    }
                    *mean = r;
                }
            }
        }
        debug_assert_eq!(stack.len(), 1);
        Ok(stack[0])
    }

    /// `v` stored as cpfg stores a parameter: a 32-bit float.
    #[inline(always)]
    fn float32(&self, v: f64, si: u32) -> Result<f64, EvalError> {
        let r = f64::from(v as f32);
        if r.is_finite() {
            Ok(r)
        } else if r.is_nan() {
            Err(self.fail(si, ExprError::NanF32))
        } else {
            Err(self.fail(si, ExprError::OutOfF32))
        }
    }

    fn name_at(&self, si: u32) -> &'static str {
        match self.ops().iter().find_map(|o| match o {
            Op::F1(f, s) if *s == si => Some(*f),
            _ => None,
        }) {
            Some(Func1::Sqrt) => "sqrt",
            Some(Func1::Log) => "log",
            Some(Func1::Exp) => "exp",
            Some(Func1::Asin) => "asin",
            Some(Func1::Acos) => "acos",
            Some(Func1::Tan) => "tan",
            _ => "the function",
        }
    }

    /// A binary operation, checked: division by zero, NaN and overflow are
    /// errors at the operation's span.
    #[inline(always)]
    fn binary(&self, op: Op, a: f64, b: f64) -> Result<f64, EvalError> {
        let (r, si) = match op {
            Op::Bin(BinOp::Lt, _) => return Ok(bool_f(a < b)),
            Op::Bin(BinOp::Le, _) => return Ok(bool_f(a <= b)),
            Op::Bin(BinOp::Gt, _) => return Ok(bool_f(a > b)),
            Op::Bin(BinOp::Ge, _) => return Ok(bool_f(a >= b)),
            Op::Bin(BinOp::Eq, _) => return Ok(bool_f(a == b)),
            Op::Bin(BinOp::Ne, _) => return Ok(bool_f(a != b)),
            Op::Bin(BinOp::And, _) => return Ok(bool_f(a != 0.0 && b != 0.0)),
            Op::Bin(BinOp::Or, _) => return Ok(bool_f(a != 0.0 || b != 0.0)),
            Op::Bin(BinOp::Add, si) => (a + b, si),
            Op::Bin(BinOp::Sub, si) => (a - b, si),
            Op::Bin(BinOp::Mul, si) => (a * b, si),
            Op::Bin(BinOp::Pow, si) => (a.powf(b), si),
            Op::Bin(BinOp::Div, si) => {
                if b == 0.0 {
                    return Err(self.fail(si, ExprError::DivisionByZero));
                }
                (a / b, si)
            }
            Op::Bin(BinOp::Rem, si) => {
                // C's (int) conversions and `%`: truncation toward zero.
                let (x, y) = (a.trunc(), b.trunc());
                if y == 0.0 {
                    return Err(self.fail(si, ExprError::RemainderByZero));
                }
                // (Also NaN: its conversion is undefined in C.)
                if x.is_nan() || y.is_nan() || x.abs() >= 2147483648.0 || y.abs() >= 2147483648.0 {
                    return Err(self.fail(si, ExprError::RemainderOutOfRange));
                }
                (((x as i64) % (y as i64)) as f64, si)
            }
            // The cpfg dialect's: out of line, so that the `.ls` dialect's
            // inlined copies of this match stay as small as they were.
            Op::Ieee(_) | Op::DivOr1(_) | Op::F2(Func2::AtanSecond, _) => {
                return Ok(cpfg_binary(op, a, b))
            }
            Op::F2(f, si) => (f.apply(a, b), si),
            _ => unreachable!("not a binary operation: {op:?}"),
        };
        if r.is_finite() {
            Ok(r)
        } else {
            Err(self.fail(
                si,
                if r.is_nan() {
                    ExprError::NotANumber
                } else {
                    ExprError::Overflow
                },
            ))
        }
    }

    #[cold]
    fn fail(&self, si: u32, kind: ExprError) -> EvalError {
        let (a, b) = match &self.0 {
            Repr::Packed { packed, n, .. } => match packed[*n as usize + si as usize] {
                Op::At(a, b) => (a, b),
                _ => unreachable!("no span at {si}"),
            },
            Repr::Load { span, .. }
            | Repr::LoadConst { span, .. }
            | Repr::ConstLoad { span, .. }
            | Repr::LoadLoad { span, .. } => *span,
            Repr::Const { .. } => unreachable!("a constant cannot fail"),
        };
        EvalError {
            span: (a as usize, b as usize),
            kind,
        }
    }
}

/// Does the instruction need what only a derivation has: a parameter, a
/// draw, the step or a global? (An expression without one is a constant.)
fn needs_input(o: &Op) -> bool {
    matches!(
        o,
        Op::Load(_)
            | Op::Ran(_)
            | Op::Nran(_)
            | Op::CpfgRan(..)
            | Op::Func(_)
            | Op::Curve(..)
            | Op::Subscript(..)
            | Op::Element { .. }
            | Op::Step
            | Op::Global(_)
    )
}

/// Can the binary operation fail (division by zero, NaN, overflow)?
/// Comparisons and logic give 0 or 1.
fn can_fail(b: BinOp) -> bool {
    matches!(
        b,
        BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div | BinOp::Rem | BinOp::Pow
    )
}

/// cpfg's binary operations ([`Code::binary`]): C's doubles, whose NaN
/// and infinities are values, and its `/` that divides by 1 for 0 (with a
/// warning). Cannot fail.
#[inline(never)]
fn cpfg_binary(op: Op, a: f64, b: f64) -> f64 {
    match op {
        Op::Ieee(BinOp::Add) => a + b,
        Op::Ieee(BinOp::Sub) => a - b,
        Op::Ieee(BinOp::Mul) => a * b,
        Op::Ieee(BinOp::Pow) => a.powf(b),
        Op::F2(f @ Func2::AtanSecond, _) => f.apply(a, b),
        Op::DivOr1(_) if b == 0.0 => {
            warn_division_by_zero();
            a
        }
        Op::DivOr1(_) => a / b,
        _ => unreachable!("not a cpfg binary operation: {op:?}"),
    }
}

/// cpfg divides by 1 instead of 0, with a warning: once per library
/// derivation, once per process on standard error (unlocated: the
/// evaluator has no place to report; the division is cpfg's rule, not an
/// error).
/// cpfg uses the nearest element for a subscript out of range, with a
/// warning: once, as [`warn_division_by_zero`].
#[cold]
fn warn_subscript_clamped() {
    use std::sync::atomic::AtomicBool;
    static PRINTED: AtomicBool = AtomicBool::new(false);
    crate::diag::warn_once(&crate::diag::WarningKind::SubscriptClamped, &PRINTED);
}

#[cold]
fn warn_division_by_zero() {
    use std::sync::atomic::AtomicBool;
    static PRINTED: AtomicBool = AtomicBool::new(false);
    crate::diag::warn_once(&crate::diag::WarningKind::DivisionByZero, &PRINTED);
}

#[inline]
fn bool_f(b: bool) -> f64 {
    if b {
        1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::parse::parse_expr;

    fn eval_with(src: &str, names: &[(&str, f64)]) -> Result<f64, EvalError> {
        let e = parse_expr(src).expect("parses");
        let params: HashMap<String, u32> = names
            .iter()
            .enumerate()
            .map(|(i, (n, _))| (n.to_string(), i as u32))
            .collect();
        let consts: HashMap<String, f64> = [("R".to_string(), 1.5)].into_iter().collect();
        let code = Code::compile(
            &e,
            &Scope {
                params: &params,
                consts: &consts,
                cpfg: false,
            },
        )?;
        let slots: Vec<f64> = names.iter().map(|(_, v)| *v).collect();
        code.eval(&slots, &mut Vec::new(), &mut Random::new(1))
    }

    fn ev(src: &str) -> f64 {
        eval_with(src, &[("x", 2.0), ("y", 3.0)]).unwrap()
    }

    #[test]
    fn arithmetic_and_precedence() {
        assert_eq!(ev("1 + 2 * 3"), 7.0);
        assert_eq!(ev("(1 + 2) * 3"), 9.0);
        assert_eq!(ev("x*2 + y"), 7.0);
        assert_eq!(ev("2^3^2"), 512.0);
        assert_eq!(ev("-2^2"), -4.0);
        assert_eq!(ev("-x"), -2.0);
        assert_eq!(ev("10 - 4 - 3"), 3.0);
        assert_eq!(ev("12 / 3 / 2"), 2.0);
        assert_eq!(ev(".5 + 1e-3"), 0.501);
        assert_eq!(ev("R * 2"), 3.0);
    }

    #[test]
    fn comparisons_and_logic() {
        assert_eq!(ev("x < y"), 1.0);
        assert_eq!(ev("x >= y"), 0.0);
        assert_eq!(ev("x = 2"), 1.0);
        assert_eq!(ev("x == 2 && y != 3"), 0.0);
        assert_eq!(ev("x == 2 || y != 3"), 1.0);
        assert_eq!(ev("x == 2 & y == 3"), 1.0);
        assert_eq!(ev("x == 1 | y == 3"), 1.0);
        assert_eq!(ev("!(x < y)"), 0.0);
        assert_eq!(ev("1 + 1 < 3"), 1.0);
    }

    #[test]
    fn functions_in_degrees() {
        assert!((ev("sin(30)") - 0.5).abs() < 1e-12);
        assert!((ev("cos(60)") - 0.5).abs() < 1e-12);
        assert!((ev("atan(1)") - 45.0).abs() < 1e-12);
        assert!((ev("atan2(1, 1)") - 45.0).abs() < 1e-12);
        assert_eq!(
            ev("sqrt(16) + abs(-2) + floor(2.7) + ceil(2.1) + trunc(-2.7)"),
            9.0
        );
        assert_eq!(ev("min(x, y) + max(x, y)"), 5.0);
        assert!((ev("log(exp(2))") - 2.0).abs() < 1e-12);
    }

    #[test]
    fn random_functions_stay_in_range() {
        for _ in 0..10 {
            let v = ev("ran(5)");
            assert!((0.0..5.0).contains(&v));
        }
        assert!(ev("nran(10, 0)") == 10.0);
    }

    #[test]
    fn errors_are_located() {
        let e = eval_with("x / (y - 3)", &[("x", 1.0), ("y", 3.0)]).unwrap_err();
        assert_eq!(e.kind, ExprError::DivisionByZero);
        assert_eq!(e.span, (0, 11));
        let e = eval_with("1 + z", &[]).unwrap_err();
        assert_eq!(e.kind, ExprError::UnknownIdentifier("z".into()));
        assert_eq!(e.span, (4, 5));
        let e = eval_with("foo(1)", &[]).unwrap_err();
        assert_eq!(e.kind, ExprError::UnknownFunction("foo".into()));
        let e = eval_with("sin(1, 2)", &[]).unwrap_err();
        assert!(e.message().contains("takes 1 argument"), "{}", e.message());
        let e = eval_with("sqrt(x)", &[("x", -1.0)]).unwrap_err();
        assert!(e.message().contains("sqrt"), "{}", e.message());
        let e = eval_with("x * 1e308 * 10", &[("x", 1.0)]).unwrap_err();
        assert!(e.message().contains("overflow"), "{}", e.message());
    }

    /// The cpfg dialect computes as cpfg's C code: NaN and infinities are
    /// values, in the in-place shapes and in blocks of code alike; only
    /// storing one into a parameter (a 32-bit float) fails.
    #[test]
    fn cpfg_computes_as_c() {
        let cp = |src: &str, x: f64, store: bool| {
            let mut e = parse_expr(src).expect("parses");
            if store {
                e = Expr::Call(CPFG_F32.to_string(), vec![e.clone()], e.span());
            }
            let params: HashMap<String, u32> = [("x".to_string(), 0)].into_iter().collect();
            let scope = Scope {
                params: &params,
                consts: &HashMap::new(),
                cpfg: true,
            };
            let code = Code::compile(&e, &scope)?;
            code.eval(&[x], &mut Vec::new(), &mut Random::new(1))
        };
        assert!(cp("sqrt(x)", -1.0, false).unwrap().is_nan());
        assert_eq!(cp("sqrt(x) > 0", -1.0, false), Ok(0.0));
        assert_eq!(cp("sqrt(x) != sqrt(x)", -1.0, false), Ok(1.0));
        assert_eq!(cp("!log(x)", -1.0, false), Ok(0.0));
        assert_eq!(cp("x * 1e308", 10.0, false), Ok(f64::INFINITY));
        assert_eq!(cp("x * 1e308 * 10 > 1", 1.0, false), Ok(1.0));
        assert!(cp("x ^ 0.5 + 1", -4.0, false).unwrap().is_nan());
        assert!(cp("x * 1e308 * 10 - x * 1e308 * 10", 1.0, false)
            .unwrap()
            .is_nan());
        assert_eq!(cp("log(x)", 0.0, false), Ok(f64::NEG_INFINITY));
        // (A folded constant too.)
        assert!(cp("sqrt(-1)", 0.0, false).unwrap().is_nan());
        let e = cp("x * 1e308", 10.0, true).unwrap_err();
        assert_eq!(e.kind, ExprError::OutOfF32);
        let e = cp("sqrt(x) + 1", -1.0, true).unwrap_err();
        assert_eq!(e.kind, ExprError::NanF32);
        // A NaN operand of `%` (converted to an int) is undefined in C:
        // an error.
        let Expr::Binary(_, a, b, span) = parse_expr("sqrt(x) * 2").unwrap() else {
            unreachable!()
        };
        let rem = Expr::Binary(BinOp::Rem, a, b, span);
        let params: HashMap<String, u32> = [("x".to_string(), 0)].into_iter().collect();
        let scope = Scope {
            params: &params,
            consts: &HashMap::new(),
            cpfg: true,
        };
        let e = Code::compile(&rem, &scope)
            .unwrap()
            .eval(&[-1.0], &mut Vec::new(), &mut Random::new(1))
            .unwrap_err();
        assert_eq!(e.kind, ExprError::RemainderOutOfRange);
    }

    #[test]
    fn constants_fold() {
        let e = parse_expr("2 * R + 1").unwrap();
        let p = HashMap::new();
        let c: HashMap<String, f64> = [("R".to_string(), 2.0)].into_iter().collect();
        let code = Code::compile(
            &e,
            &Scope {
                params: &p,
                consts: &c,
                cpfg: false,
            },
        )
        .unwrap();
        assert_eq!(code.constant(), Some(5.0));
        // constant division by zero is found at compile time
        let e = parse_expr("1 / 0").unwrap();
        assert!(Code::compile(
            &e,
            &Scope {
                params: &p,
                consts: &c,
                cpfg: false,
            }
        )
        .is_err());
    }
}
