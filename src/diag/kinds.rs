//! What went wrong, by stage of the pipeline: one enum per stage, each
//! variant with the data its message needs. The message text is written
//! in one place, the `Display` of these enums; [`super::Error`] adds the
//! location, the source line and the caret.

use crate::cpfg::lexer::MAX_BLOCK_DEPTH;
use crate::derive::Pass;
use crate::lang::lexer::{MAX_EXPR_TOKENS, MAX_PAREN_DEPTH};
use crate::rules::codec::{number_string, MAX_ARITY};
use std::fmt;
use std::path::PathBuf;

pub use super::cpfg::{
    Block, DirectiveError, FunctionFileError, IfError, MacroError, PpConstruct, PreprocessError,
    Refused,
};

/// What went wrong, by stage; [`super::Error::kind`] gives it.
#[derive(Debug)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Unreadable text: invalid UTF-8, a NUL byte, an unterminated comment,
    /// a character that starts no token.
    Lexical(LexicalError),
    /// Text that does not follow the grammar, in the header or the axiom.
    Parse(ParseError),
    /// A well-formed file that does not make sense: an unknown name, a
    /// constant defined twice, a production that cannot apply.
    Compile(CompileError),
    /// Found while deriving: an arithmetic error, unbalanced brackets, a
    /// negative probability, a generation past the limits.
    Runtime(RuntimeError),
    /// Reading or writing failed; [`std::error::Error::source`] gives the
    /// operating system's error.
    Io(IoError),
    /// The request itself is wrong (the command line, the options).
    Usage(UsageError),
    /// lsgen-turtle: a module string it cannot read or draw.
    Turtle(TurtleError),
    /// The cpfg dialect's C preprocessor; its stage depends on the error
    /// ([`PreprocessError::stage`]).
    Preprocess(PreprocessError),
    /// A cpfg function file (`--functions`) that cannot be read as one.
    FunctionFile(FunctionFileError),
}

/// Which stage found an error: [`ErrorKind`] without its data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Stage {
    /// [`ErrorKind::Lexical`] (and some [`ErrorKind::Preprocess`]).
    Lexical,
    /// [`ErrorKind::Parse`] (and most [`ErrorKind::Preprocess`]).
    Parse,
    /// [`ErrorKind::Compile`].
    Compile,
    /// [`ErrorKind::Runtime`].
    Runtime,
    /// [`ErrorKind::Io`] (and an `#include` the cpfg preprocessor cannot
    /// read).
    Io,
    /// [`ErrorKind::Usage`].
    Usage,
}

impl ErrorKind {
    /// The stage that found it.
    pub fn stage(&self) -> Stage {
        match self {
            ErrorKind::Lexical(_) => Stage::Lexical,
            ErrorKind::Parse(_) => Stage::Parse,
            ErrorKind::Compile(_) => Stage::Compile,
            ErrorKind::Runtime(_) => Stage::Runtime,
            ErrorKind::Io(_) => Stage::Io,
            ErrorKind::Usage(_) => Stage::Usage,
            ErrorKind::Turtle(e) if e.is_drawing() => Stage::Runtime,
            ErrorKind::Turtle(_) => Stage::Parse,
            ErrorKind::Preprocess(e) => e.stage(),
            ErrorKind::FunctionFile(e) => e.stage(),
        }
    }
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ErrorKind::Lexical(e) => e.fmt(f),
            ErrorKind::Parse(e) => e.fmt(f),
            ErrorKind::Compile(e) => e.fmt(f),
            ErrorKind::Runtime(e) => e.fmt(f),
            ErrorKind::Io(e) => e.fmt(f),
            ErrorKind::Usage(e) => e.fmt(f),
            ErrorKind::Turtle(e) => e.fmt(f),
            ErrorKind::Preprocess(e) => e.fmt(f),
            ErrorKind::FunctionFile(e) => e.fmt(f),
        }
    }
}

macro_rules! into_kind {
    ($($t:ident => $v:ident),*) => {$(
        impl From<$t> for ErrorKind {
            fn from(e: $t) -> ErrorKind {
                ErrorKind::$v(e)
            }
        }
    )*};
}
into_kind!(LexicalError => Lexical, ParseError => Parse, CompileError => Compile,
    RuntimeError => Runtime, IoError => Io, UsageError => Usage, TurtleError => Turtle,
    PreprocessError => Preprocess, FunctionFileError => FunctionFile);

/// Unreadable text.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum LexicalError {
    /// A character that starts no token.
    UnexpectedChar(char),
    /// A control character where a symbol would be.
    ControlChar(char),
    /// U+FEFF where a symbol would be: invisible, and skipped where it
    /// starts a file or an `--axiom` text, so it cannot be a module.
    ByteOrderMark,
    /// `/*` without `*/`.
    UnterminatedComment,
    /// A NUL byte.
    Nul,
    /// Bytes that are not UTF-8.
    InvalidUtf8,
    /// A number too large for a 64-bit float, as written.
    NumberOutOfRange(String),
    /// More than [`MAX_EXPR_TOKENS`] tokens in one expression.
    ExpressionTooLong,
    /// More than [`MAX_PAREN_DEPTH`] nested parentheses.
    NestedTooDeeply,
    /// `groups:` followed by something else than group numbers.
    GroupsNotNumbers,
    /// A group number past 65535.
    GroupOutOfRange,
    /// `decomposition N:` or `homomorphism N:` (the section word).
    NoGroups(&'static str),
    /// Neither `warnings` nor `no warnings` after the section keyword.
    ExpectedWarnings(&'static str),
    /// A `view:` line lsgen-turtle cannot read.
    ViewSetting(ViewError),
    /// The header outgrew its bound: `axiom:` is probably missing.
    HeaderTooLong,
    /// cpfg: a character that starts no token of an expression.
    ExpressionChar(char),
    /// cpfg: an exponent literal without a dot (`1e6`; as written).
    ExponentWithoutDot(String),
    /// cpfg: a string without its closing `"`.
    UnterminatedString,
    /// cpfg: more than [`MAX_BLOCK_DEPTH`] nested blocks.
    BlocksNestedTooDeeply,
    /// cpfg: a file past the size that is read whole, in MiB (the file is
    /// the error's subject).
    FileTooLarge { mib: u64 },
    /// cpfg: a keyword whose words, or whose `:`, are not spaced as cpfg's
    /// scanner matches them (`derivation  length:`, `Axiom :`).
    KeywordSpacing {
        /// The keyword as written, one space between its words.
        keyword: String,
        /// The words the blanks stand between; `None`: before the `:`.
        between: Option<(String, String)>,
        /// No space at all would do there too (`derivationlength:`).
        optional: bool,
        /// What stands there ("3 spaces", "a tab", ...).
        found: String,
    },
}

impl fmt::Display for LexicalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use LexicalError::*;
        match self {
            UnexpectedChar(c) => write!(f, "unexpected character `{}`", c.escape_default()),
            ControlChar(c) => write!(
                f,
                "control character `{}` cannot be a symbol",
                c.escape_default()
            ),
            ByteOrderMark => f.write_str(
                "U+FEFF (a byte-order mark, invisible) cannot be a symbol: only a file's \
                 first character may be one, and it is skipped",
            ),
            UnterminatedComment => f.write_str("unterminated comment: `/*` without `*/`"),
            Nul => f.write_str("NUL byte: the input is not text"),
            InvalidUtf8 => f.write_str("invalid UTF-8"),
            NumberOutOfRange(n) => write!(f, "number `{n}` is out of range"),
            ExpressionTooLong => {
                write!(f, "expression too long (over {MAX_EXPR_TOKENS} tokens)")
            }
            NestedTooDeeply => {
                write!(f, "parentheses nested too deeply (over {MAX_PAREN_DEPTH})")
            }
            GroupsNotNumbers => {
                f.write_str("`groups:` takes whole group numbers separated by blanks")
            }
            GroupOutOfRange => f.write_str("a production group is a whole number from 0 to 65535"),
            NoGroups(word) => write!(f, "{word} has no groups"),
            ExpectedWarnings(kw) => {
                write!(f, "expected `warnings` or `no warnings` after `{kw}`")
            }
            ViewSetting(e) => e.fmt(f),
            HeaderTooLong => f.write_str(
                "the part before `axiom:` is too long (over 64 MiB); is `axiom:` missing?",
            ),
            ExpressionChar(c) => write!(
                f,
                "unexpected character `{}` in an expression",
                c.escape_default()
            ),
            ExponentWithoutDot(text) => write!(
                f,
                "cpfg needs a dot in an exponent literal (`1.0e6`, not `1e6`): `{text}`"
            ),
            UnterminatedString => f.write_str("unterminated string"),
            BlocksNestedTooDeeply => {
                write!(f, "blocks nested too deep (over {MAX_BLOCK_DEPTH})")
            }
            FileTooLarge { mib } => write!(f, "file larger than {mib} MiB"),
            KeywordSpacing {
                keyword,
                between: Some((a, b)),
                optional,
                found,
            } => write!(
                f,
                "`{keyword}` takes {} between `{a}` and `{b}`, as cpfg's scanner reads it (a comment counts as a space): found {found}",
                if *optional { "one space or none" } else { "exactly one space" }
            ),
            KeywordSpacing {
                keyword,
                between: None,
                found,
                ..
            } => write!(
                f,
                "`{keyword}` takes no blank before `:`, as cpfg's scanner reads it: found {found}"
            ),
        }
    }
}

/// The tokens the grammar would have accepted, as words for a message.
#[derive(Clone, Debug, PartialEq)]
pub enum Expected {
    /// Too many (or none) to be worth listing.
    Nothing,
    /// `->`, whatever else would do.
    Arrow,
    /// These (each already written as the message shows it).
    OneOf(Vec<String>),
}

impl Expected {
    fn is_empty(&self) -> bool {
        match self {
            Expected::Nothing => true,
            Expected::Arrow => false,
            Expected::OneOf(names) => names.is_empty() || names.len() > 6,
        }
    }
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expected::Arrow => f.write_str("expected `->`"),
            Expected::OneOf(names) if !self.is_empty() => match names.split_last() {
                Some((last, [])) => write!(f, "expected {last}"),
                Some((last, rest)) => write!(f, "expected {} or {last}", rest.join(", ")),
                None => Ok(()),
            },
            _ => Ok(()),
        }
    }
}

/// Text that does not follow the grammar.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ParseError {
    /// A token the lexer could not hand over.
    InvalidToken,
    /// The text ended early.
    UnexpectedEof(Expected),
    /// A token the grammar does not accept here (as the message shows it:
    /// "end of line", "symbol `F`", "number `.3`").
    Unexpected { found: String, expected: Expected },
    /// `1 < x < 3`: the second comparison operator.
    ChainedComparison(String),
    /// `<` or `>` right of the arrow.
    ContextRightOfArrow(char),
    /// A second `maximum depth:` in a section.
    MaximumDepthTwice,
    /// `maximum depth:` outside `decomposition:` and `homomorphism:`.
    MaximumDepthOutside,
    /// A second `decomposition:` or `homomorphism:` (the keyword).
    SecondSection(String),
    /// `decomposition:` after `homomorphism:`.
    DecompositionOutOfPlace,
    /// A keyword out of the order of sections (the keyword).
    OutOfPlace(String),
    /// `productions N:` twice.
    GroupDeclaredTwice(u32),
    /// `A B -> C`.
    PredecessorIsOneModule,
    /// A context in a decomposition production.
    DecompositionContext,
    /// No `axiom:` after a header.
    MissingAxiom,
    /// No `axiom:` and no header.
    EmptySystem,
    /// A reserved character where an axiom symbol would be.
    Reserved(char),
    /// `]` without `[` in the axiom.
    UnbalancedClose,
    /// A `[` of the axiom never closed, at this line and column.
    UnclosedBracket { line: usize, col: usize },
    /// An axiom module's `(` never closed.
    UnclosedParen,
    /// An axiom module's parameter text past 1 MiB.
    ParamListTooLong,
    /// An axiom module with more than [`MAX_ARITY`] parameters.
    TooManyParams,
    /// `F(1,,2)`.
    EmptyParameter,
    /// cpfg: a construct lsgen refuses.
    Refused(Refused),
    /// cpfg: no `endlsystem` at the end.
    MissingEndlsystem,
    /// cpfg: no `Lsystem:` in the file.
    MissingLsystem,
    /// cpfg: a token before `Lsystem:` (as the message shows it).
    BeforeLsystem(String),
    /// cpfg: a token where a setting or `Axiom:` would be (as the
    /// message shows it).
    SettingAfterAxiom(String),
    /// cpfg: a `Start:`, `StartEach:`, `EndEach:` or `End:` block twice.
    BlockTwice,
    /// cpfg: a section's setting twice.
    SettingTwice,
    /// cpfg: `*` as the strict predecessor.
    NullPredecessor,
    /// cpfg: `printf` or `fprintf` (the name) without a format string.
    NoFormat(String),
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ParseError::*;
        const CONTEXTS: &str =
            "contexts are written only left of the arrow (`lc < pred > rc -> succ`)";
        match self {
            InvalidToken => f.write_str("invalid token"),
            UnexpectedEof(e) if e.is_empty() => f.write_str("unexpected end of input"),
            UnexpectedEof(e) => write!(f, "unexpected end of input, {e}"),
            Unexpected { found, expected } if expected.is_empty() => {
                write!(f, "unexpected {found}")
            }
            Unexpected { found, expected } => write!(f, "unexpected {found}, {expected}"),
            ChainedComparison(tok) => write!(
                f,
                "unexpected {tok}: comparisons do not chain; write `a < x && x < b`"
            ),
            ContextRightOfArrow(c) => write!(f, "unexpected `{c}`: {CONTEXTS}"),
            MaximumDepthTwice => {
                f.write_str("`maximum depth:` comes once, among the settings right after the section keyword")
            }
            MaximumDepthOutside => {
                f.write_str("`maximum depth:` belongs to `decomposition:` or `homomorphism:`")
            }
            SecondSection(tok) => write!(f, "second {tok} section"),
            DecompositionOutOfPlace => f.write_str(
                "`decomposition:` comes after the productions and before `homomorphism:`",
            ),
            OutOfPlace(tok) => write!(
                f,
                "{tok} is out of place: the order is settings, `productions:`, `decomposition:`, \
                 `homomorphism:`, `axiom:`"
            ),
            GroupDeclaredTwice(n) => write!(f, "group {n} is declared twice"),
            PredecessorIsOneModule => {
                f.write_str("a predecessor is one module; use `<` and `>` for contexts")
            }
            DecompositionContext => f.write_str(
                "a decomposition production has no context (decomposition is context-free)",
            ),
            MissingAxiom => {
                f.write_str("missing `axiom:`: the axiom comes last, after the productions")
            }
            EmptySystem => f.write_str("empty L-system: no `axiom:` found"),
            Reserved(c) => write!(
                f,
                "`{c}` is reserved and cannot be a symbol{}",
                if *c == '(' {
                    " (parameters follow a symbol: `F(1)`)"
                } else {
                    ""
                }
            ),
            UnbalancedClose => f.write_str("unbalanced brackets: `]` without `[`"),
            UnclosedBracket { line, col } => write!(
                f,
                "unbalanced brackets: the `[` at {line}:{col} is never closed"
            ),
            UnclosedParen => f.write_str("unbalanced parentheses: `(` is never closed"),
            ParamListTooLong => {
                f.write_str("parameter list too long (over 1 MiB): is a `)` missing?")
            }
            TooManyParams => write!(f, "a module has at most {MAX_ARITY} parameters"),
            EmptyParameter => f.write_str("empty parameter"),
            Refused(r) => r.fmt(f),
            MissingEndlsystem => f.write_str("missing `endlsystem`: a cpfg L-system ends with it"),
            MissingLsystem => f.write_str("empty file: a cpfg L-system starts with `Lsystem:`"),
            BeforeLsystem(tok) => write!(
                f,
                "unexpected {tok}: a cpfg L-system starts with `Lsystem:`"
            ),
            SettingAfterAxiom(tok) => write!(
                f,
                "unexpected {tok}: the settings (`seed:`, `derivation length:`, `ignore:`, `consider:`, blocks) come before `Axiom:`, one per line"
            ),
            BlockTwice => f.write_str("this block is given twice"),
            SettingTwice => f.write_str("this setting is given twice"),
            NullPredecessor => f.write_str("the strict predecessor cannot be `*`"),
            NoFormat(name) => write!(f, "`{name}` needs a format string"),
        }
    }
}

/// What the random generator cannot do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum RandomError {
    /// More than 64 draws for one module.
    TooManyDraws,
    /// A generation of 2^59 modules or more.
    TooManyModules,
    /// `bran`, `biran` or `srand` outside a `.l` file.
    CpfgOnly,
    /// cpfg's `bran(a, b)` without a value for its parameters.
    BranNoValue,
    /// cpfg's `biran(n, p)` with more than 2^24 trials.
    BiranTooManyTrials,
    /// cpfg's `srand(x)` with x infinite or NaN.
    SrandNotFinite,
    /// cpfg's `biran(n, p)` with n NaN or below a C `int` (its conversion
    /// to `int` is undefined in C).
    BiranTrialsUndefined,
    /// The weights of a stochastic choice add up to more than the largest
    /// finite number: the draw could not tell them apart.
    WeightsOverflow,
}

impl fmt::Display for RandomError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RandomError::TooManyDraws => {
                "more than 64 random draws for one module (the limit of the random scheme)"
            }
            RandomError::TooManyModules => "a generation of 2^59 modules or more cannot draw",
            RandomError::CpfgOnly => "bran, biran and srand are cpfg functions, only in `.l` files",
            RandomError::BranNoValue => "bran() finds no value for these parameters",
            RandomError::BiranTooManyTrials => "biran() takes at most 16777216 trials",
            RandomError::SrandNotFinite => "srand() needs a finite number",
            RandomError::BiranTrialsUndefined => {
                "biran() needs a number of trials a C int holds (cpfg converts it to one)"
            }
            RandomError::WeightsOverflow => {
                "the probabilities of the applicable productions add up to more than the largest number"
            }
        })
    }
}

/// An expression that cannot be compiled or evaluated.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ExprError {
    /// A name that is neither a parameter nor a constant.
    UnknownIdentifier(String),
    /// A function lsgen does not have.
    UnknownFunction(String),
    /// A function called with the wrong number of arguments.
    Arity {
        name: String,
        arity: usize,
        got: usize,
    },
    /// A function (or `ran()`, `nran()`) outside its domain.
    Undefined(&'static str),
    /// `x / 0`.
    DivisionByZero,
    /// A cpfg block's `while` / `do` loop that ran too often (its kind and
    /// the limit).
    Runaway(&'static str, u64),
    /// A value stored into a cpfg module parameter that a 32-bit float
    /// cannot hold.
    OutOfF32,
    /// A NaN stored into a cpfg module parameter.
    NanF32,
    /// cpfg's `x % 0` (which crashes cpfg).
    RemainderByZero,
    /// cpfg's `%` on an operand that does not fit a C int.
    RemainderOutOfRange,
    /// A result that is NaN.
    NotANumber,
    /// A result past the largest float.
    Overflow,
    /// The random generator's limits.
    Random(RandomError),
    /// cpfg's `func(id, x)` that has no value.
    Func(FuncFault),
    /// A cpfg array subscript that is NaN.
    SubscriptNaN,
    /// A cpfg array's element number (from fractional subscripts) past its
    /// last element: cpfg reads or writes outside the array.
    OutsideArray { index: f64, size: u32 },
}

/// Why cpfg's `func(id, x)` has no value.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum FuncFault {
    /// No function was given (`--functions`); only the cpfg dialect has
    /// them.
    NoFunctions,
    /// `id` (as C's `(int)` makes it) is not one of the functions 1 to
    /// `count`.
    NoSuchFunction { id: f64, count: usize },
    /// `x` is NaN for a function with a table of samples (cpfg's index
    /// into it is undefined).
    NotANumber,
    /// The curve of function `id` never comes within 0.001 of `x`.
    NeverReaches { id: usize, x: f64 },
    /// `curveX` and the like (the name) without curves.
    NoCurves(&'static str),
    /// `id` (as C's `(int)` makes it) is not one of the curves 1 to
    /// `count`.
    NoSuchCurve {
        name: &'static str,
        id: f64,
        count: usize,
    },
    /// `t` is NaN (cpfg's search gives a NaN parameter).
    CurveNotANumber { name: &'static str },
    /// Curve `id` has no arc-length parameter at `t`: its length is 0 (or
    /// its last chord is, at t = 1), and cpfg divides 0 by 0.
    CurveUndefined {
        name: &'static str,
        id: usize,
        t: f64,
    },
}

impl fmt::Display for FuncFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FuncFault::NoFunctions => {
                f.write_str("func() needs cpfg's function files (`--functions`)")
            }
            FuncFault::NoSuchFunction { id, count: 0 } => write!(
                f,
                "func({}, x): no function is defined",
                number_string(id + 0.0)
            ),
            FuncFault::NoSuchFunction { id, count } => {
                let id = number_string(id + 0.0);
                write!(
                    f,
                    "func({id}, x): there is no function {id}; the function files define 1 to {count}"
                )
            }
            FuncFault::NotANumber => {
                f.write_str("func(id, x) with x not a number (cpfg's table lookup is undefined)")
            }
            FuncFault::NeverReaches { id, x } => write!(
                f,
                "func({id}, {x}): the curve never comes within 0.001 of x = {x}: cpfg would search for its value forever"
            ),
            FuncFault::NoCurves(name) => {
                write!(f, "{name}() needs cpfg's curves (`--functions` with a view file's `curve:` lines)")
            }
            FuncFault::NoSuchCurve { name, id, count: 0 } => {
                write!(f, "{name}({}, ...): no curve is defined", number_string(id + 0.0))
            }
            FuncFault::NoSuchCurve { name, id, count } => {
                let id = number_string(id + 0.0);
                write!(
                    f,
                    "{name}({id}, ...): there is no curve {id}; the view files define 1 to {count}"
                )
            }
            FuncFault::CurveNotANumber { name } => write!(
                f,
                "{name}(id, t) with t not a number (cpfg's arc-length search is undefined)"
            ),
            FuncFault::CurveUndefined { name, id, t } => write!(
                f,
                "{name}({id}, {t}): curve {id} has no arc-length parameter there (its length, or its last chord's, is 0: cpfg divides 0 by 0)"
            ),
        }
    }
}

impl fmt::Display for ExprError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ExprError::*;
        match self {
            UnknownIdentifier(n) => write!(f, "unknown identifier `{n}`"),
            UnknownFunction(n) => write!(f, "unknown function `{n}`"),
            Arity { name, arity, got } => write!(
                f,
                "function `{name}` takes {arity} argument{}, not {got}",
                if *arity == 1 { "" } else { "s" }
            ),
            Undefined(what) => write!(f, "{what} is undefined here"),
            DivisionByZero => f.write_str("division by zero"),
            Runaway(what, n) => write!(
                f,
                "the loops of this block ran {n} times in one run of it: lsgen stops this `{what}` (cpfg would hang)"
            ),
            OutOfF32 => {
                f.write_str("the value is out of the range of a 32-bit float (cpfg's parameters)")
            }
            NanF32 => f.write_str(
                "the value is NaN (not a number), which lsgen does not store in a \
                 parameter (cpfg would store `nan`)",
            ),
            RemainderByZero => f.write_str("remainder by zero (`x % 0` crashes cpfg)"),
            RemainderOutOfRange => f.write_str("`%` needs operands that fit a C int"),
            NotANumber => f.write_str("result is not a number"),
            Overflow => f.write_str("result overflows a 64-bit float"),
            Random(e) => e.fmt(f),
            Func(e) => e.fmt(f),
            SubscriptNaN => f.write_str("an array subscript is not a number"),
            OutsideArray { index, size } => write!(
                f,
                "the subscripts make element {index} of an array of {size} (cpfg goes past its end)"
            ),
        }
    }
}

/// A well-formed header that does not make sense.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum CompileError {
    /// An expression that does not compile, or a constant one that fails.
    Expr(ExprError),
    /// A module with more than [`MAX_ARITY`] parameters (how many).
    TooManyParams(usize),
    /// A setting that must be a whole number (which, and its value).
    NotWholeNumber { what: &'static str, value: f64 },
    /// The same, written as digits past 2^53 (which, and as written).
    WholeNumberLiteralRange { what: &'static str, text: String },
    /// `ignore:` / `consider:` with a parameter.
    SymbolsOnly,
    /// A `seed:` literal past 2^64 - 1 (as written).
    SeedLiteralRange(String),
    /// A computed `seed:` that is not a whole number below 2^53.
    SeedComputedRange(f64),
    /// A `seed:` using `ran` or `nran`.
    SeedRandom,
    /// Both `groups:` and `group:`.
    GroupsAndGroup,
    /// `groups:` naming a group without a section.
    UnknownGroup(u32),
    /// `group:` using `ran` or `nran`.
    GroupRandom,
    /// A group section no setting schedules.
    GroupUnused(u32),
    /// A setting given twice (its keyword, without the colon).
    SetTwice(&'static str),
    /// A `define:` name given twice.
    DefinedTwice(String),
    /// Both `ignore:` and `consider:`.
    IgnoreAndConsider,
    /// `seed:` in the decomposition section.
    DecompositionSeed,
    /// A decomposition successor with unbalanced brackets.
    DecompositionUnbalanced,
    /// A recursive homomorphism successor with unbalanced brackets.
    HomomorphismUnbalanced,
    /// `maximum depth:` twice in a section.
    MaximumDepthTwice,
    /// `maximum depth:` outside 1 to 10000.
    MaximumDepthRange,
    /// A formal parameter name used twice in a production.
    BoundTwice(String),
    /// A formal parameter that is not a name.
    FormalNotName,
    /// `[` or `]` as a predecessor.
    BracketRewritten,
    /// cpfg: `[` or `]` in a predecessor of several modules.
    BracketInRun,
    /// `[` or `]` in a left context.
    LeftContextBracket,
    /// `[(1)`.
    BracketParams,
    /// A constant negative probability.
    NegativeProbability(f64),
    /// cpfg: `printf` or `fprintf` (the name) used as a value.
    StatementAsValue(String),
    /// cpfg: a setting or axiom parameter that is not a constant.
    NotConstant,
    /// cpfg: a setting (which) outside `min` to `max` (its value,
    /// truncated).
    OutOfRange {
        what: &'static str,
        min: f64,
        max: f64,
        value: f64,
    },
    /// cpfg: a formal parameter name used twice in a production.
    FormalTwice(String),
    /// cpfg: a `printf` conversion lsgen does not print (its letter).
    PrintfConversion(char),
    /// cpfg: a `printf` format that ends inside a conversion.
    PrintfUnfinished,
    /// cpfg: a `printf` with another number of values than its format
    /// takes.
    PrintfArity { takes: usize, given: usize },
    /// cpfg: an axiom parameter past a 32-bit float.
    OutOfF32,
    /// cpfg: an axiom parameter that is NaN.
    NanF32,
    /// cpfg: `Axiom:` without modules.
    EmptyAxiom,
    /// cpfg: a right context whose last module is `=` (cpfg's `RconDiff`
    /// reads past the end of the pattern there and crashes).
    RightContextEndsInSkip,
    /// cpfg: a name used with subscripts that is no array of `define:`.
    NotAnArray(String),
    /// cpfg: an array used without its subscripts (or assigned as a
    /// variable).
    ArrayWithoutSubscripts(String),
    /// cpfg: an array given another number of subscripts than its
    /// dimensions.
    Subscripts {
        name: String,
        dims: usize,
        given: usize,
    },
    /// cpfg: an array defined twice.
    ArrayTwice(String),
    /// cpfg: an array with the name of a variable of the blocks.
    ArrayIsVariable(String),
    /// cpfg: an array dimension below 1 (its value).
    ArrayDimension(f64),
    /// cpfg: the arrays of `define:` hold more than this many elements.
    ArraysTooLarge(u64),
}

impl From<ExprError> for CompileError {
    fn from(e: ExprError) -> CompileError {
        CompileError::Expr(e)
    }
}

impl fmt::Display for CompileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use CompileError::*;
        const SEED: &str = "the seed must be a whole number from 0 to 18446744073709551615";
        match self {
            Expr(e) => e.fmt(f),
            TooManyParams(n) => write!(
                f,
                "a module has at most {MAX_ARITY} parameters, this one has {n}"
            ),
            NotWholeNumber { what, value } => write!(
                f,
                "{what} must be a whole number from 0 to 2^53, not {}",
                number_string(*value)
            ),
            WholeNumberLiteralRange { what, text } => {
                write!(f, "{what} must be a whole number from 0 to 2^53, not {text}")
            }
            SymbolsOnly => f.write_str("list symbols here, without parameters"),
            SeedLiteralRange(text) => write!(f, "{SEED}, not {text}"),
            SeedComputedRange(v) => write!(
                f,
                "{SEED} (computed: below 2^53; write larger seeds as digits), not {}",
                number_string(*v)
            ),
            SeedRandom => f.write_str("the seed cannot depend on random numbers (`ran`, `nran`)"),
            GroupsAndGroup => f.write_str("use either `groups:` or `group:`, not both"),
            UnknownGroup(n) => write!(
                f,
                "unknown group {n}: there is no `productions {n}:` section"
            ),
            GroupRandom => f.write_str("`group:` cannot use ran or nran"),
            GroupUnused(n) => write!(
                f,
                "group {n} is never used: add a `groups:` or `group:` setting"
            ),
            SetTwice(what) => write!(f, "`{what}:` is set twice"),
            DefinedTwice(name) => write!(f, "`{name}` is defined twice"),
            IgnoreAndConsider => {
                f.write_str("`ignore:` and `consider:` cannot both be used: pick one")
            }
            DecompositionSeed => {
                f.write_str("decomposition uses the main random generator: no `seed:` here")
            }
            DecompositionUnbalanced => {
                f.write_str("a decomposition successor must balance its brackets")
            }
            HomomorphismUnbalanced => f.write_str(
                "with `maximum depth:` above 1, a homomorphism successor must balance its brackets",
            ),
            MaximumDepthTwice => {
                f.write_str("`maximum depth:` comes once, among the settings right after the section keyword")
            }
            MaximumDepthRange => {
                f.write_str("maximum depth must be a whole number from 1 to 10000")
            }
            BoundTwice(name) => write!(f, "parameter `{name}` is bound twice"),
            FormalNotName => f.write_str(
                "a formal parameter must be a name (values go in the successor or the condition)",
            ),
            BracketRewritten => f.write_str("brackets cannot be rewritten"),
            BracketInRun => f.write_str(
                "a predecessor of several modules cannot hold `[` or `]` (lsgen rewrites a bracket only as a predecessor of its own)",
            ),
            LeftContextBracket => f.write_str(
                "a left context cannot hold brackets: branches to the left are skipped by the matcher",
            ),
            BracketParams => f.write_str("a bracket takes no parameters"),
            NegativeProbability(w) => write!(f, "a probability cannot be negative ({w})"),
            StatementAsValue(name) => {
                write!(f, "`{name}` is a statement of a block, not a value")
            }
            NotConstant => f.write_str(
                "this value must be known before the derivation (a constant expression)",
            ),
            OutOfRange {
                what,
                min,
                max,
                value,
            } => write!(f, "{what} must be from {min} to {max}, not {value}"),
            FormalTwice(name) => write!(
                f,
                "formal parameter `{name}` is named twice in this production (cpfg: multiple definition)"
            ),
            PrintfConversion(c) => write!(f, "printf: `%{c}` is not a conversion lsgen prints"),
            PrintfUnfinished => f.write_str("printf: the format ends inside a `%` conversion"),
            PrintfArity { takes, given } => write!(
                f,
                "printf: the format takes {takes} value{}, {given} given",
                if *takes == 1 { "" } else { "s" }
            ),
            OutOfF32 => f.write_str("this value does not fit cpfg's 32-bit float"),
            NanF32 => f.write_str(
                "this value is NaN (not a number), which lsgen does not store in a \
                 parameter (cpfg would store `nan`)",
            ),
            EmptyAxiom => f.write_str("the axiom is empty"),
            RightContextEndsInSkip => f.write_str(
                "a right context cannot end with `=`: `=` skips to the end of the branch and needs a module after it (cpfg crashes here)",
            ),
            NotAnArray(n) => write!(f, "`{n}` is not an array of `define:`"),
            ArrayWithoutSubscripts(n) => {
                write!(f, "`{n}` is an array: an element needs its subscripts, `{n}[i]`")
            }
            Subscripts { name, dims, given } => write!(
                f,
                "`{name}` has {dims} dimension{}, not {given}",
                if *dims == 1 { "" } else { "s" }
            ),
            ArrayTwice(n) => write!(f, "the array `{n}` is defined twice"),
            ArrayIsVariable(n) => write!(
                f,
                "`{n}` is a variable of the blocks: an array needs a name of its own"
            ),
            ArrayDimension(v) => write!(
                f,
                "an array dimension must be at least 1, not {}",
                number_string(*v)
            ),
            ArraysTooLarge(n) => write!(f, "the arrays of `define:` hold more than {n} elements"),
        }
    }
}

/// What `--max-length` counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LengthUnit {
    /// Modules.
    Modules,
    /// Bytes of the output text.
    Bytes,
}

/// Found while deriving.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum RuntimeError {
    /// An expression failed in a pass.
    Eval { error: ExprError, pass: Pass },
    /// A probability evaluated negative in a pass.
    NegativeProbability { value: f64, pass: Pass },
    /// The string outgrew a limit of [`crate::Options::limits`]
    /// (`--max-length`), made by `pass`; `names`: whose names the message
    /// gives the limit.
    TooLong {
        limit: u64,
        unit: LengthUnit,
        pass: Pass,
        names: OptionNames,
    },
    /// The final string would not fit on the output's file system, or in
    /// [`crate::Options::free_space`] (its size as the message says it,
    /// the bytes free); `names`: whose names the message gives the
    /// options.
    NoSpace {
        size: String,
        free: u64,
        names: OptionNames,
    },
    /// `group:` gave something else than a whole number.
    GroupNotNumber { value: f64, step: u64 },
    /// `group:` gave a group without a section.
    GroupMissing { group: u64, step: u64 },
    /// A pass left a `[` open.
    UnclosedBracket(Pass),
    /// A pass produced a `]` without `[`.
    UnopenedBracket(Pass),
    /// A branch too long for the bracket index of a temporary generation
    /// (`codec::WORD_MAX` bytes).
    BranchTooLong(Pass),
    /// An [`crate::LSystem`] read from a stream as `.ls` text was derived
    /// (or checked) before: its axiom was streamed (a cpfg `.l` text
    /// keeps its axiom, and derives again).
    AlreadyDerived,
    /// Jobs of a batch failed (how many, of how many).
    JobsFailed { failed: u64, total: u64 },
    /// A panic, caught.
    Internal,
    /// A worker thread of the parallel split stopped without an answer.
    WorkerStopped,
    /// cpfg: an expression of a header block failed.
    Block { error: ExprError, block: Block },
    /// cpfg: the turtle that fills the queries (`?P`, ...) of generation
    /// `generation` (0: the axiom) could not go on.
    Query {
        fault: crate::cpfg::query::QueryFault,
        generation: u64,
    },
}

impl fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use RuntimeError::*;
        match self {
            Eval { error, pass } => write!(f, "{error} (in {pass})"),
            NegativeProbability { value, pass } => {
                write!(f, "a probability cannot be negative ({value}, in {pass})")
            }
            TooLong {
                limit,
                unit,
                pass,
                names,
            } => {
                let unit = match unit {
                    LengthUnit::Modules => "modules",
                    LengthUnit::Bytes => "bytes",
                };
                let option = match names {
                    OptionNames::Library => format!("`Limits::{unit}`"),
                    OptionNames::CommandLine => "--max-length".to_string(),
                };
                write!(
                    f,
                    "the string grew past {option} ({limit} {unit}) in {pass}"
                )
            }
            NoSpace { size, free, names } => match names {
                OptionNames::Library => write!(
                    f,
                    "the final string would be {size}, more than `free_space({free})`: \
                     nothing written (fewer steps; `limits()` stops any run early)"
                ),
                OptionNames::CommandLine => write!(
                    f,
                    "the final string would be {size}, more than the {} bytes free on \
                     its file system: nothing written (fewer steps; --max-length stops \
                     any run early)",
                    super::group_digits(*free)
                ),
            },
            GroupNotNumber { value, step } => write!(
                f,
                "group: gives {} in step {step}, not a group number",
                number_string(*value)
            ),
            GroupMissing { group, step } => write!(
                f,
                "group: gives {group} in step {step}, but there is no `productions {group}:` section"
            ),
            UnclosedBracket(pass) => write!(
                f,
                "unbalanced brackets: {pass} leaves a `[` open, produced by this production"
            ),
            UnopenedBracket(pass) => write!(
                f,
                "unbalanced brackets: {pass} produces a `]` without `[`, from this production"
            ),
            BranchTooLong(pass) => write!(
                f,
                "{pass} makes a branch of 256 TiB or more, longer than a temporary \
                 generation can index"
            ),
            AlreadyDerived => f.write_str(
                "the axiom stream was already read (by a derivation or a check): it can be read once",
            ),
            JobsFailed { failed, total } => write!(
                f,
                "{} of {} jobs failed",
                super::group_digits(*failed),
                super::group_digits(*total)
            ),
            Internal => f.write_str("internal error (please report this)"),
            WorkerStopped => f.write_str("internal error: a worker thread stopped"),
            Block { error, block } => write!(f, "{error} (in {block})"),
            Query { fault, generation } => {
                use crate::cpfg::query::QueryFault::*;
                let what: String = match fault {
                    BendPastRightAngle => {
                        "cpfg's tropism bends the turtle by a sine past 1 (elasticity times the tropism's component), which is no angle".into()
                    }
                    MovementOverflow => "cpfg's tropism or torque (the view file's movements) overflows: an elasticity this large leaves the turtle no heading (cpfg's turtle becomes NaN)".into(),
                    NotFinite => "a query's vector is past the largest number".into(),
                    TooDeep => "branches nested deeper than 1048576 (the turtle keeps each open one)".into(),
                    NotAQuery(Some('Q')) => "`?Q` (cpfg's quaternion query) is not filled by lsgen's query turtle".into(),
                    NotAQuery(Some('E')) => "`?E` (cpfg's communication with an environment program) is not filled by lsgen's query turtle".into(),
                    NotAQuery(Some(c)) => format!("`?` followed by `{c}`, not by the `P`, `H`, `L` or `U` it fills (a production rewrote it; cpfg skips the `{c}` with a warning)"),
                    NotAQuery(None) => "`?` at the end of the string, without the `P`, `H`, `L` or `U` it fills".into(),
                    NotFollowed(what) => format!("{what} moves cpfg's turtle, and lsgen's query turtle does not follow it"),
                    ReadPastHomomorphism(c) => format!("`{c}`, read by a `?` or an `@`, has a homomorphism production: cpfg's turtle reads it from the string, past the homomorphism, and lsgen's query turtle reads the homomorphism's image"),
                };
                let string = match generation {
                    0 => "the axiom".to_string(),
                    n => format!("the string of step {n}"),
                };
                write!(f, "{what}, as the turtle interprets {string} to fill its queries")
            }
        }
    }
}

/// What was being done when reading or writing failed.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum IoAction {
    /// Opening a file to read.
    Open,
    /// Reading.
    Read,
    /// Writing.
    Write,
    /// Creating a file.
    Create,
    /// Creating a file in this directory.
    CreateIn(PathBuf),
    /// Creating a temporary file.
    CreateTemp,
    /// Reading a symbolic link.
    ReadLink,
    /// Rendering (the man page).
    Render,
}

impl fmt::Display for IoAction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IoAction::Open => f.write_str("cannot open"),
            IoAction::Read => f.write_str("cannot read"),
            IoAction::Write => f.write_str("cannot write"),
            IoAction::Create => f.write_str("cannot create"),
            IoAction::CreateIn(dir) => write!(f, "cannot create a file in {}", dir.display()),
            IoAction::CreateTemp => f.write_str("cannot create a temporary file"),
            IoAction::ReadLink => f.write_str("cannot read the link"),
            IoAction::Render => f.write_str("cannot render"),
        }
    }
}

/// Why reading or writing failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum IoReason {
    /// The operating system said so.
    Os(std::io::Error),
    /// Standard output was closed when the program started.
    ClosedAtStartup,
    /// Standard input (or a standard descriptor read through a path, as
    /// `/dev/stdin`) was closed when the program started.
    ClosedWhenStarted,
    /// `-o` names a directory.
    IsADirectory,
    /// `-o name/` where `name` is not a directory.
    NotADirectory,
    /// `-o dir/` where `dir` does not exist.
    NoSuchDirectory,
}

/// Reading or writing failed (the file or stream is the error's subject).
#[derive(Debug)]
pub struct IoError {
    /// What was being done.
    pub action: IoAction,
    /// Why it failed.
    pub reason: IoReason,
}

impl IoError {
    /// The operating system's error, if that is the reason.
    pub fn os_error(&self) -> Option<&std::io::Error> {
        match &self.reason {
            IoReason::Os(e) => Some(e),
            _ => None,
        }
    }
}

impl fmt::Display for IoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.action)?;
        match &self.reason {
            IoReason::Os(e) => f.write_str(&super::io_message(e)),
            IoReason::ClosedAtStartup => f.write_str("Bad file descriptor (closed at startup)"),
            IoReason::ClosedWhenStarted => f.write_str("Bad file descriptor (closed at startup)"),
            IoReason::IsADirectory => f.write_str("is a directory; -o takes a file name"),
            IoReason::NotADirectory => f.write_str("not a directory, but the name ends with `/`"),
            IoReason::NoSuchDirectory => {
                f.write_str("no such directory, and -o takes a file name, not a directory")
            }
        }
    }
}

/// A placeholder of an `-o` template.
pub type Placeholder = &'static str;

/// Whose names an error gives the options it mentions: the library's
/// [`crate::Options`] methods and [`crate::Limits`] fields
/// (`first_step(K)`, `Limits::modules`) or lsgen's flags
/// (`--first-step K`, `--max-length`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptionNames {
    /// The methods of [`crate::Options`].
    Library,
    /// The flags of the `lsgen` binary.
    CommandLine,
}

/// The request itself is wrong.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum UsageError {
    /// `-o` template with a lone `}` (the template).
    LoneCloseBrace(String),
    /// `-o` template with `{` not closed (the template).
    UnclosedBrace(String),
    /// `-o` template with an unknown placeholder (template, name).
    UnknownPlaceholder { template: String, name: String },
    /// A placeholder without a value for this run.
    NoValue(Placeholder),
    /// `--strategy dfs` for a system that cannot be derived depth first.
    NotDepthFirst,
    /// `--first-step 0`.
    FirstStepZero,
    /// Step numbers past 2^64 - 1: the first step, the number of steps,
    /// and the names the message gives the first step's option.
    StepsOverflow {
        first: u64,
        steps: u64,
        names: OptionNames,
    },
    /// A view option of lsgen-turtle (its name, `view` for the
    /// direction) that cannot be read.
    ViewOption { option: String, error: ViewError },
    /// `--frames` with an `-o` file name without `{n}`.
    FramesNeedN,
    /// Standard input as an L-system of a batch.
    StdinInBatch,
    /// `--axiom -` in a batch.
    StdinAxiomInBatch,
    /// An `--axiom` file that can be read once only (a pipe, a device) in a
    /// batch: its name.
    StreamAxiomInBatch(PathBuf),
    /// An L-system file that can be read once only, with several seeds:
    /// its name.
    StreamFileInBatch(PathBuf),
    /// A `.l` file of a batch whose `#include` reads a file that can be
    /// read once only (a pipe, a device).
    StreamIncludeInBatch { file: PathBuf, include: PathBuf },
    /// A batch without an `-o` template.
    BatchNeedsTemplate,
    /// A seed range with an `-o` template without `{seed}`.
    SeedRangeNeedsSeed,
    /// Several files with an `-o` template without `{stem}`.
    FilesNeedStem,
    /// Two outputs of a batch that the `-o` template names alike.
    SameOutput {
        first: String,
        second: String,
        name: PathBuf,
    },
    /// Two outputs of a batch whose names differ but lead to one file.
    SameFile {
        first: String,
        second: String,
        first_name: PathBuf,
        second_name: PathBuf,
    },
    /// A batch too large to check its output names one by one, whose
    /// template does not show them distinct.
    OutputNamesUnchecked(u64),
    /// Two files of a batch with the same `{stem}`.
    SameStem {
        first: PathBuf,
        second: PathBuf,
        stem: String,
    },
    /// The L-system and `--axiom` both on standard input (`-`,
    /// `/dev/stdin`, or the pipe or device standard input is).
    BothFromStdin,
    /// `--strategy dfs` for a cpfg file.
    CpfgNotDepthFirst,
    /// lsgen-turtle: the option named (`--ls`, `--cpfg-view`, ...) reads
    /// standard input, the string too.
    ViewAndStringFromStdin(&'static str),
    /// lsgen-turtle: `-f` with an unknown format (as given).
    UnknownFormat(String),
    /// lsgen-turtle: an output name whose extension names no format.
    FormatFromName(PathBuf),
    /// lsgen-turtle: an OBJ's MTL file name (as it would be written in
    /// `mtllib`) with blanks, which OBJ readers take as separators.
    MtlNameWithBlanks(String),
    /// lsgen-turtle: an OBJ's MTL file (beside it) that exists and is not
    /// a regular file: a directory, a FIFO (which would block), a device.
    MtlNotAFile(PathBuf),
    /// `LSGEN_JOBS` that is not a number of threads (its value, lossy).
    JobsVariable(String),
}

impl fmt::Display for UsageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use UsageError::*;
        match self {
            LoneCloseBrace(s) => write!(f, "-o `{s}`: a lone `}}`; write `}}}}` for a literal brace"),
            UnclosedBrace(s) => write!(f, "-o `{s}`: unclosed `{{`; write `{{{{` for a literal brace"),
            UnknownPlaceholder { template, name } => write!(
                f,
                "-o `{template}`: unknown placeholder `{{{name}}}`: use {{stem}}, {{seed}} or {{n}} ({{{{ and }}}} for braces)"
            ),
            NoValue(name) => write!(
                f,
                "-o: `{{{name}}}` has no value here{}",
                if *name == "n" {
                    " (it numbers frames)"
                } else {
                    ""
                }
            ),
            NotDepthFirst => f.write_str(
                "`--strategy dfs`: this system cannot be derived depth first with these options",
            ),
            FirstStepZero => f.write_str("the first step is step 1 or later"),
            StepsOverflow {
                first,
                steps,
                names,
            } => {
                match names {
                    OptionNames::Library => write!(f, "`first_step({first})`")?,
                    OptionNames::CommandLine => write!(f, "`--first-step {first}`")?,
                }
                write!(
                    f,
                    " with {steps} steps: step numbers must stay below 2^64 - 1"
                )
            }
            ViewOption { option, error } => write!(f, "--{option}: {error}"),
            FramesNeedN => f.write_str(
                "`--frames` with `-o` needs `{n}` (the generation number) in the file name",
            ),
            StdinInBatch => f.write_str(
                "standard input can feed one job only: a batch (several files or seeds) needs file names",
            ),
            StdinAxiomInBatch => {
                f.write_str("`--axiom -` can feed one job only: a batch needs an axiom file")
            }
            StreamAxiomInBatch(name) => write!(
                f,
                "`--axiom {}` is not a regular file (a pipe or a device is read once) and can feed one job only: a batch needs an axiom file",
                name.display()
            ),
            StreamIncludeInBatch { file, include } => write!(
                f,
                "{} includes {}, which is not a regular file (a pipe or a device is read once) and can feed one job only: a batch (several files or seeds) needs included files",
                file.display(),
                include.display()
            ),
            StreamFileInBatch(name) => write!(
                f,
                "{} is not a regular file (a pipe or a device is read once) and can feed one job only: a seed range needs a file",
                name.display()
            ),
            BatchNeedsTemplate => f.write_str(
                "several jobs (files or seeds) need -o with a template, e.g. -o 'out/{stem}-{seed}.txt', so that each has its own file",
            ),
            SeedRangeNeedsSeed => f.write_str(
                "a seed range needs `{seed}` in the -o template, so that each seed has its own file",
            ),
            FilesNeedStem => f.write_str(
                "several files need `{stem}` in the -o template, so that each has its own file",
            ),
            SameOutput {
                first,
                second,
                name,
            } => write!(
                f,
                "{first} and {second} would both write `{}`: the -o template \
                 must name each output apart (put a separator such as `-` between \
                 its placeholders)",
                name.display()
            ),
            SameFile {
                first,
                second,
                first_name,
                second_name,
            } => write!(
                f,
                "{first} would write `{}` and {second} `{}`, which are one file \
                 (through `..` or a symbolic link): the -o template must lead \
                 each output to a file of its own",
                first_name.display(),
                second_name.display()
            ),
            OutputNamesUnchecked(n) => write!(
                f,
                "cannot check that the -o template names the {} outputs apart: \
                 put a character that is no digit and in no file's {{stem}} (such \
                 as `-`) between its placeholders",
                crate::diag::group_digits(*n)
            ),
            SameStem {
                first,
                second,
                stem,
            } => write!(
                f,
                "{} and {} have the same {{stem}} `{stem}`: their outputs would collide",
                first.display(),
                second.display()
            ),
            ViewAndStringFromStdin(option) => write!(
                f,
                "the module string and `{option}` cannot both come from standard input: give the string's file",
            ),
            BothFromStdin => {
                f.write_str("the L-system and `--axiom` cannot both come from standard input")
            }
            CpfgNotDepthFirst => f.write_str(
                "`--strategy dfs`: this cpfg (`.l`) file is derived step by step: it has what cpfg runs in string order (draws, blocks, queries, warnings) or what only that strategy derives (README, \"Coming from cpfg\")",
            ),
            UnknownFormat(name) => {
                write!(f, "unknown format `{name}` (svg, png, obj, segments)")
            }
            FormatFromName(path) => write!(
                f,
                "cannot tell the format from `{}`: give -f svg|png|obj|segments",
                path.display()
            ),
            MtlNameWithBlanks(name) => write!(
                f,
                "the OBJ would name its materials `mtllib {name}`, but OBJ readers split that \
                 line at blanks: give -o a name without blanks"
            ),
            MtlNotAFile(path) => write!(
                f,
                "the OBJ's materials go to `{}` beside it, which is there and is not a regular \
                 file (a directory, a FIFO, a device): give -o another name",
                path.display()
            ),
            JobsVariable(value) => write!(
                f,
                "LSGEN_JOBS=`{value}`: the number of threads must be a whole number from 1 to 4096 (or unset or empty: all CPUs)"
            ),
        }
    }
}

/// lsgen-turtle: a module string it cannot read (stage parse) or draw
/// (stage runtime).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum TurtleError {
    /// A control byte where a module would be.
    ControlByte(u8),
    /// `(` or `)` where a module would be.
    Unexpected(char),
    /// Bytes that are not UTF-8.
    InvalidUtf8,
    /// A parameter longer than this many characters.
    NumberTooLong(usize),
    /// Something else than a number in a parameter list (its start).
    ExpectedNumber(String),
    /// A parameter past the largest number (`F(1e400)`), as written.
    NumberOutOfRange(String),
    /// A parameter list without its `)`.
    ParamsNotClosed,
    /// Neither `,` nor `)` after a parameter.
    ExpectedCommaOrParen(char),
    /// A `{` without its `}` at the end.
    PolygonNotClosed,
    /// A `]` or `}` without its opener.
    UnmatchedClose(char),
    /// The turtle's position overflowed.
    Overflow,
    /// The tropism bend overflowed.
    TropismOverflow,
    /// cpfg's tropism bend: a sine past ±1.
    BendPastRightAngle,
    /// The width drawn (width × width scale) overflowed.
    WidthOverflow,
    /// Open polygons with more than this many vertices in all.
    PolygonTooLarge(usize),
    /// Branches or polygons nested past the limit.
    TooDeep,
    /// The drawing's extent overflowed.
    ExtentOverflow,
    /// cpfg's movements (a view file's tropisms, torque) overflowed.
    MovementOverflow,
}

impl TurtleError {
    /// Found while drawing (else while reading).
    pub fn is_drawing(&self) -> bool {
        use TurtleError::*;
        matches!(
            self,
            PolygonNotClosed
                | UnmatchedClose(_)
                | Overflow
                | TropismOverflow
                | BendPastRightAngle
                | WidthOverflow
                | PolygonTooLarge(_)
                | TooDeep
                | ExtentOverflow
                | MovementOverflow
        )
    }
}

impl fmt::Display for TurtleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use TurtleError::*;
        match self {
            ControlByte(b) => write!(f, "unexpected control character 0x{b:02x}"),
            Unexpected(c) => write!(f, "unexpected `{c}`"),
            InvalidUtf8 => f.write_str("invalid UTF-8"),
            NumberTooLong(n) => write!(f, "number too long (over {n} characters)"),
            ExpectedNumber(shown) => write!(f, "expected a number, found `{shown}`"),
            NumberOutOfRange(text) => write!(
                f,
                "number `{text}` is out of range (past the largest number, about 1.8e308)"
            ),
            ParamsNotClosed => f.write_str("parameter list not closed: `(` without `)`"),
            ExpectedCommaOrParen(c) => {
                write!(f, "expected `,` or `)`, found `{}`", c.escape_default())
            }
            PolygonNotClosed => f.write_str("polygon not closed: `{` without `}`"),
            UnmatchedClose(c) => write!(f, "unmatched `{c}`"),
            Overflow => f.write_str("the turtle moved out of range (overflow)"),
            TropismOverflow => {
                f.write_str("the tropism bend overflows (elasticity × |tropism| is too large)")
            }
            BendPastRightAngle => f.write_str(
                "cpfg's tropism bend is no angle here: elasticity × (tropism · U) or × (tropism · L) is past ±1 (cpfg's turtle becomes NaN)",
            ),
            WidthOverflow => f.write_str(
                "the line width overflows (width × --width-scale is past the largest number)",
            ),
            PolygonTooLarge(n) => {
                write!(f, "open polygons too large (over {n} vertices in all)")
            }
            TooDeep => f.write_str("branches or polygons nested too deeply"),
            ExtentOverflow => {
                f.write_str("the drawing is too large to lay out (its extent overflows)")
            }
            MovementOverflow => f.write_str(
                "cpfg's tropism or torque (the view file's movements) overflows: an elasticity \
                 this large leaves the turtle no heading (cpfg's turtle becomes NaN)",
            ),
        }
    }
}

/// A view setting (`view:` line, lsgen-turtle option) that cannot be read.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ViewError {
    /// Not `NAME = VALUE`.
    Syntax,
    /// A name that is no setting (as written, lower case).
    Unknown(String),
    /// A word that is not a number.
    NotANumber(String),
    /// A number past the largest one (`1e400`).
    OutOfRange(String),
    /// A word that is not a colour.
    NotAColour(String),
    /// Not exactly one number.
    OneNumber,
    /// A negative width or width scale.
    Negative,
    /// An elevation outside -90 to 90.
    ElevationRange,
    /// A direction that is none of the forms.
    Direction,
    /// A tropism that is not three numbers.
    Tropism,
    /// An empty palette.
    Palette,
    /// A background that is neither a colour nor `none`.
    Background,
    /// A word that is none of these.
    OneOf(&'static [&'static str]),
    /// cpfg's view file: a label's arguments are not what it takes.
    CpfgArguments {
        label: &'static str,
        expected: &'static str,
    },
    /// cpfg's view file: a value cpfg would turn into NaN or infinity.
    CpfgNoValue(&'static str, &'static str),
}

impl fmt::Display for ViewError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ViewError::*;
        match self {
            Syntax => f.write_str("a view setting is `view: NAME = VALUE`"),
            Unknown(name) => write!(
                f,
                "unknown view setting `{name}` (known: {})",
                crate::turtle::view::NAMES.join(", ")
            ),
            NotANumber(w) => write!(f, "`{w}` is not a number"),
            OutOfRange(w) => write!(
                f,
                "`{w}` is out of range (past the largest number, about 1.8e308)"
            ),
            NotAColour(w) => write!(f, "`{w}` is not a colour `#rrggbb`"),
            OneNumber => f.write_str("expected one number"),
            Negative => f.write_str("must not be negative"),
            ElevationRange => f.write_str("the elevation is between -90 and 90"),
            Direction => f.write_str(
                "a direction is `front`, `side`, `top` or `AZIMUTH ELEVATION` in degrees",
            ),
            Tropism => f.write_str("a tropism is three numbers `X Y Z`"),
            Palette => f.write_str("a palette is one or more colours `#rrggbb`"),
            Background => f.write_str("a background is `#rrggbb` or `none`"),
            CpfgArguments { label, expected } => write!(f, "`{label}` takes {expected}"),
            CpfgNoValue(label, why) => write!(f, "this `{label}`: {why}"),
            OneOf(words) => write!(
                f,
                "expected one of: {}",
                words
                    .iter()
                    .map(|w| format!("`{w}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}
