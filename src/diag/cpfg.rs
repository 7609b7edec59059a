//! What goes wrong only in the cpfg dialect's front end (`.l` files): the
//! constructs lsgen refuses ([`Refused`], stage parse) and the C
//! preprocessor's errors ([`PreprocessError`], staged by what they are).
//! Errors that are the same thing in both dialects use the `.ls` variants
//! of [`super::LexicalError`], [`super::ParseError`] and
//! [`super::CompileError`].

use super::Stage;
use std::fmt;
use std::path::PathBuf;

/// A cpfg construct lsgen refuses (it needs cpfg's turtle, files,
/// environment or sub-L-systems): stage parse.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Refused {
    /// A second `Lsystem:` (cpfg's sub-L-systems).
    SecondLsystem,
    /// `ring lsystem` as it starts a line.
    Ring,
    /// `ring lsystem` as a setting.
    RingSetting,
    /// `-o>`, an object production.
    ObjectProduction,
    /// `?E`: communication with an environment program.
    Environment,
    /// `?(id,s)`: a sub-L-system call.
    SubLsystemCall,
    /// Another `?` query module.
    Query,
    /// A query (`?P`, ...) without a view file (`--cpfg-view`).
    QueryWithoutView,
    /// A query in a system with a homomorphism production that can move
    /// the turtle (what it has).
    QueryWithHomomorphism(String),
    /// What a system with queries has that lsgen's query turtle does not
    /// follow (as the message names it).
    QueryNotFollowed(String),
    /// A `tropism:` or `torque:` line of the view file (the label) that
    /// cpfg cannot take (why), in a system with queries: a tenth (cpfg
    /// reads past its table), or one it crashes on.
    QueryMovements(String, &'static str),
    /// The view file's angle (the label) is past the largest float, in a
    /// system with queries.
    QueryAngle(String),
    /// `$`, the end of a sub-L-system.
    SubLsystemEnd,
    /// `@S`, a surface.
    Surface,
    /// `atan2(...)` (reserved in cpfg, a syntax error there).
    Atan2,
    /// A function that needs cpfg's files, curves, view or animation.
    Function(String),
    /// `&` (an address) in an expression.
    Address,
    /// `fprintf` on something else than `stderr`.
    FprintfNotStderr,
    /// `external` (the external arrays of cpfg's sub-L-system build).
    External,
    /// `func` in a run without function files (`--functions`); the hint
    /// names a view file beside the `.l` file, if there is one.
    FuncWithoutFunctions(Option<String>),
    /// `curveX` and the like (the name) in a run without curves (a view
    /// file's `curve:` lines); the hint as for `func`.
    CurveWithoutCurves(String, Option<String>),
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Refused::*;
        const QUERY: &str = ": not supported by lsgen, which only rewrites strings";
        match self {
            SecondLsystem => f.write_str(
                "a second `Lsystem:`: several L-systems in one file (cpfg's sub-L-systems) are not supported; lsgen derives one L-system per file",
            ),
            Ring => f.write_str(
                "`ring lsystem` is not supported: lsgen derives open strings (no ring of modules)",
            ),
            RingSetting => f.write_str("ring L-systems (`ring lsystem`) are not supported"),
            ObjectProduction => f.write_str(
                "`-o>` (an object production, for cpfg's surfaces and objects) is not supported: lsgen rewrites strings only",
            ),
            Environment => write!(
                f,
                "`?E` (communication with an environment program) needs cpfg's environment process{QUERY}"
            ),
            SubLsystemCall => {
                write!(f, "`?(id,s)` (a sub-L-system call) needs cpfg's sub-L-systems{QUERY}")
            }
            Query => write!(
                f,
                "a `?` not followed by `P`, `H`, `L` or `U` (the turtle queries lsgen fills, with `--cpfg-view`): its other query modules need cpfg's interpretation or environment{QUERY}"
            ),
            QueryWithoutView => f.write_str(
                "a query of the turtle (`?P`, `?H`, `?L`, `?U`) needs cpfg's view file: give it with --cpfg-view FILE.v (the turtle's angle, tropism and scale are there)",
            ),
            QueryWithHomomorphism(why) => write!(
                f,
                "a homomorphism production with {why} in a system with turtle queries (`?P`, `?H`, `?L`, `?U`) is not supported: cpfg's turtle interprets the string through the homomorphism, and lsgen's query turtle follows it where its productions have no block, probability or random draw, no `[ ] ? @ % $ ~` in a predecessor, no `?` in a successor, no `%` or `$` outside a successor's branches, balanced brackets, and no predecessor that a `?` or an `@` reads"
            ),
            QueryNotFollowed(what) => write!(
                f,
                "{what} in a system with turtle queries (`?P`, `?H`, `?L`, `?U`) is not supported: it moves cpfg's turtle, and lsgen's query turtle does not follow it"
            ),
            QueryMovements(label, why) => write!(
                f,
                "a `{label}` line that {why} is not supported with turtle queries (`?P`, `?H`, `?L`, `?U`)"
            ),
            QueryAngle(label) => write!(
                f,
                "`{label}` gives an angle past the largest float, which cpfg's turtle keeps its angle in: the turtle queries (`?P`, `?H`, `?L`, `?U`) would read no number after a turn"
            ),
            SubLsystemEnd => f.write_str(
                "`$` (the end of a sub-L-system) is not supported: lsgen has no sub-L-systems",
            ),
            Surface => f.write_str(
                "`@S` (a surface from cpfg's surface files) is not supported: lsgen has no surfaces",
            ),
            Atan2 => {
                f.write_str("`atan2` is reserved in cpfg but a syntax error there: use `atan(y / x)`")
            }
            Function(n) => write!(
                f,
                "`{n}` is not supported: it needs cpfg's function files, curves, view or animation"
            ),
            Address => f.write_str("`&` (an address) is not supported: write `&&`"),
            FprintfNotStderr => f.write_str("lsgen supports `fprintf` only on `stderr`"),
            External => f.write_str(
                "`external` (arrays shared with cpfg's sub-L-systems) is not supported: declare the array with `array`",
            ),
            FuncWithoutFunctions(hint) => {
                f.write_str("`func` needs the model's function files: ")?;
                match hint {
                    Some(v) => write!(f, "give its view file with `--functions {v}`"),
                    None => f.write_str(
                        "give its view file (`function:` lines) or its `.func` files with `--functions FILE`",
                    ),
                }
            }
            CurveWithoutCurves(name, hint) => {
                write!(f, "`{name}` needs the model's curves: ")?;
                match hint {
                    Some(v) => write!(f, "give its view file with `--functions {v}`"),
                    None => f.write_str(
                        "give its view file (`curve:` lines) or its `.con` files with `--functions FILE`",
                    ),
                }
            }
        }
    }
}

/// An error of the C preprocessor that cpfg runs every `.l` file through.
/// Its stage ([`PreprocessError::stage`]): lexical for an unterminated
/// comment or literal and the limits, I/O for an `#include` that cannot
/// be read (whose [`std::error::Error::source`] is the operating system's
/// error), parse for the rest.
#[derive(Debug)]
#[non_exhaustive]
pub enum PreprocessError {
    /// `/*` without `*/`.
    UnterminatedComment,
    /// A `"` or `'` literal not closed on its line.
    UnterminatedLiteral(char),
    /// `#if`/`#ifdef`/`#ifndef` (named) without `#endif` in the same file.
    UnterminatedConditional(&'static str),
    /// `#else`/`#elif`/`#endif` (named) without an open `#if` in the file.
    UnmatchedConditional(&'static str),
    /// `#else`/`#elif` (named) after the group's `#else`.
    AfterElse(&'static str),
    /// `#name` that is no directive.
    UnknownDirective(String),
    /// A directive with a malformed operand.
    InvalidDirective(DirectiveError),
    /// A malformed or unevaluable `#if`/`#elif` expression.
    BadExpression(IfError),
    /// A construct this preprocessor does not implement.
    NotSupported(PpConstruct),
    /// A bad macro call (argument count, pasting, ...).
    Macro(MacroError),
    /// An `#include` file could not be read.
    IncludeFailed {
        /// The file as named.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// An `#include` in a text read with includes turned off
    /// ([`crate::Load::includes`]): no file was read.
    IncludesOff,
    /// An `#include` that re-enters a file being included, past the
    /// include depth limit: a recursion without end; the chain from the
    /// file's last entry, and the limit.
    IncludeCycle { chain: String, limit: usize },
    /// A resource limit was reached.
    Limit {
        /// What outgrew it.
        what: &'static str,
        /// The limit.
        limit: usize,
    },
    /// `#error` with its text.
    ErrorDirective(String),
}

impl PreprocessError {
    /// The stage that found it.
    pub fn stage(&self) -> Stage {
        use PreprocessError::*;
        match self {
            UnterminatedComment | UnterminatedLiteral(_) | Limit { .. } => Stage::Lexical,
            IncludeFailed { .. } => Stage::Io,
            _ => Stage::Parse,
        }
    }

    /// The operating system's error of an `#include` that failed.
    pub fn os_error(&self) -> Option<&std::io::Error> {
        match self {
            PreprocessError::IncludeFailed { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl fmt::Display for PreprocessError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use PreprocessError::*;
        match self {
            UnterminatedComment => f.write_str("unterminated comment: `/*` without `*/`"),
            UnterminatedLiteral('"') => {
                f.write_str("unterminated string: missing `\"` on this line")
            }
            UnterminatedLiteral(q) => {
                write!(
                    f,
                    "unterminated character constant: missing `{q}` on this line"
                )
            }
            UnterminatedConditional(d) => write!(f, "unterminated `{d}`: no matching `#endif`"),
            UnmatchedConditional(d) => write!(f, "`{d}` without `#if`"),
            AfterElse(d) => write!(f, "`{d}` after `#else`"),
            UnknownDirective(n) => write!(f, "unknown directive `#{n}`"),
            InvalidDirective(e) => e.fmt(f),
            BadExpression(e) => e.fmt(f),
            Macro(e) => e.fmt(f),
            NotSupported(w) => write!(f, "{w} is not supported"),
            IncludeFailed { path, source } => write!(
                f,
                "cannot include `{}`: {}",
                path.display(),
                super::io_message(source)
            ),
            IncludesOff => f.write_str(
                "`#include` is turned off for this text (`Load::includes(false)`): no file is read",
            ),
            IncludeCycle { chain, limit } => write!(
                f,
                "#include recursion without end (over {limit} files deep; an include guard would stop it): {chain}"
            ),
            Limit { what, limit } => write!(f, "{what} (limit {limit})"),
            ErrorDirective(m) => write!(f, "#error {m}"),
        }
    }
}

/// The header block of a `.l` file that failed: its name, and the pass it
/// ran before or after.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Block {
    /// `define:`'s arrays' initial values, before `Start:`.
    Define,
    /// `Start:`, before the first step.
    Start,
    /// `StartEach:` before this pass.
    StartEach(crate::derive::Pass),
    /// `EndEach:` after this pass.
    EndEach(crate::derive::Pass),
    /// `End:`, after the last step.
    End,
}

impl fmt::Display for Block {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Block::Define => f.write_str("the initial values of `define:`"),
            Block::Start => f.write_str("`Start:`"),
            Block::StartEach(pass) => write!(f, "`StartEach:` before {pass}"),
            Block::EndEach(pass) => write!(f, "`EndEach:` after {pass}"),
            Block::End => f.write_str("`End:`"),
        }
    }
}

/// A preprocessor directive with a malformed operand.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum DirectiveError {
    /// `#ifdef`, `#ifndef`, `#undef` or `#define` (as written) without a
    /// name.
    NeedsMacroName(String),
    /// `#define defined`.
    DefinedAsName,
    /// A macro parameter list without its `)`.
    ParamListNotClosed,
    /// Something else than a name in a macro parameter list.
    ExpectedParamName,
    /// A macro parameter named twice.
    DuplicateParam(String),
    /// Neither `,` nor `)` after a macro parameter.
    ExpectedCommaOrParen,
    /// `##` first or last in a macro body.
    PasteAtEnd,
    /// `#` in a function-like macro not followed by a parameter.
    StringifyNeedsParam,
    /// `#include` alone.
    IncludeNeedsName,
    /// `#include` with something else than `"FILE"`.
    IncludeNotQuoted,
    /// `#include ""`.
    IncludeEmptyName,
}

impl fmt::Display for DirectiveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use DirectiveError::*;
        match self {
            NeedsMacroName(d) => write!(f, "`{d}` needs a macro name"),
            DefinedAsName => f.write_str("`defined` cannot be a macro name"),
            ParamListNotClosed => f.write_str("missing `)` in macro parameter list"),
            ExpectedParamName => f.write_str("expected a parameter name"),
            DuplicateParam(p) => write!(f, "duplicate macro parameter `{p}`"),
            ExpectedCommaOrParen => f.write_str("expected `,` or `)` in parameter list"),
            PasteAtEnd => f.write_str("`##` cannot be at either end of a macro body"),
            StringifyNeedsParam => f.write_str(
                "`#` in a function-like macro must be followed by a parameter name (C stringification)",
            ),
            IncludeNeedsName => f.write_str("`#include` needs a file name in quotes"),
            IncludeNotQuoted => f.write_str("`#include` expects \"FILE\""),
            IncludeEmptyName => f.write_str("empty file name in `#include`"),
        }
    }
}

/// A macro call that cannot be expanded.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum MacroError {
    /// The call's argument list has no `)` (the macro).
    UnterminatedArgs(String),
    /// Another number of arguments than the macro's parameters.
    Arity {
        /// The macro.
        name: String,
        /// Its parameters.
        want: usize,
        /// The arguments given.
        given: usize,
    },
    /// `##` joining two tokens into something that is not one token.
    Paste {
        /// The left token.
        left: String,
        /// The right token.
        right: String,
    },
}

impl fmt::Display for MacroError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MacroError::UnterminatedArgs(n) => {
                write!(f, "unterminated argument list of macro `{n}`")
            }
            MacroError::Arity { name, want, given } => write!(
                f,
                "macro `{name}` takes {want} argument{}, {given} given",
                if *want == 1 { "" } else { "s" }
            ),
            MacroError::Paste { left, right } => write!(
                f,
                "`##` pasting `{left}` and `{right}` does not give one token"
            ),
        }
    }
}

/// An `#if` or `#elif` expression that cannot be read or evaluated.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum IfError {
    /// `defined` without a name.
    DefinedNeedsName,
    /// `defined(NAME` without `)`.
    DefinedNotClosed,
    /// A token that does not belong here (as written).
    Unexpected(String),
    /// `#if` alone.
    Empty,
    /// Two values without an operator between them.
    MissingOperator,
    /// A number that is not an integer (as written).
    NotInteger(String),
    /// An integer past 64 bits (as written).
    IntegerTooLarge(String),
    /// A character constant with an escape C's preprocessor has not (as
    /// written).
    UnsupportedEscape(String),
    /// A character constant of several characters (as written).
    NotSingleChar(String),
    /// Parentheses, unary operators and `?:` nested past this limit.
    NestedTooDeeply(usize),
    /// `?` without `:`.
    MissingColon,
    /// A division or remainder by zero that is evaluated.
    DivisionByZero,
    /// The expression ends after an operator.
    EndsEarly,
    /// `(` without `)`.
    MissingParen,
}

impl fmt::Display for IfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use IfError::*;
        match self {
            DefinedNeedsName => f.write_str("`defined` needs a macro name"),
            DefinedNotClosed => f.write_str("missing `)` after `defined(NAME`"),
            Unexpected(t) => write!(f, "unexpected `{t}` in `#if` expression"),
            Empty => f.write_str("`#if` needs an expression"),
            MissingOperator => f.write_str("missing operator in `#if` expression"),
            NotInteger(s) => write!(
                f,
                "`{s}` is not an integer (only integers are allowed in `#if`)"
            ),
            IntegerTooLarge(s) => write!(f, "integer `{s}` too large"),
            UnsupportedEscape(s) => write!(f, "unsupported escape in `{s}`"),
            NotSingleChar(s) => write!(f, "`{s}` is not a single-character constant"),
            NestedTooDeeply(limit) => {
                write!(f, "`#if` expression nested too deeply (limit {limit})")
            }
            MissingColon => f.write_str("missing `:` after `?` in `#if` expression"),
            DivisionByZero => f.write_str("division by zero in `#if` expression"),
            EndsEarly => f.write_str("`#if` expression ends too early"),
            MissingParen => f.write_str("missing `)` in `#if` expression"),
        }
    }
}

/// A C preprocessor construct lsgen's preprocessor does not implement.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum PpConstruct {
    /// `# 12 "file"`.
    LineMarker,
    /// `#line`, `#include_next`, `#import`, `#ident`, `#sccs`, `#assert`
    /// or `#unassert` (the word).
    Directive(String),
    /// `__VA_ARGS__` in a macro.
    VaArgs,
    /// `...` in a macro's parameters.
    Ellipsis,
    /// `#include <...>`.
    SystemInclude,
}

impl fmt::Display for PpConstruct {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PpConstruct::LineMarker => f.write_str("a `# LINE \"file\"` line marker"),
            PpConstruct::Directive(word) => write!(f, "`#{word}`"),
            PpConstruct::VaArgs => f.write_str("variadic macros (`__VA_ARGS__`)"),
            PpConstruct::Ellipsis => f.write_str("variadic macros (`...`)"),
            PpConstruct::SystemInclude => {
                f.write_str("`#include <...>` (there is no system include path; use \"...\")")
            }
        }
    }
}

/// A file of cpfg functions (`--functions`: a view file's `function:` and
/// `function set:` lines, a function set, a `.func` file) that lsgen
/// cannot read: stage parse, at the place in that file.
#[derive(Debug)]
#[non_exhaustive]
pub enum FunctionFileError {
    /// A file a view file names that cannot be read (stage I/O).
    Unreadable {
        /// The file, relative to the view file's directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The first line is none of `fver 1 1`, `range: L U` (a function)
    /// or `funcgalleryver 1 1` (a set).
    UnknownFormat,
    /// A version cpfg does not read either (`fver 2 0`).
    Version {
        what: &'static str,
        major: i64,
        minor: i64,
    },
    /// A line that should be this (`name: NAME`, ...).
    Expected(&'static str),
    /// A function needs 4 control points (cpfg's cubic B-spline).
    TooFewPoints(u64),
    /// More points, samples, functions or multiplicity than lsgen holds.
    TooMany { what: &'static str, limit: u64 },
    /// The curve never comes within 0.001 of this x: cpfg's search for
    /// it never ends.
    NeverReaches(f64),
    /// A view file's `function:` / `function set:` / `curve:` line without
    /// a file.
    MissingFile(&'static str),
    /// A curve needs 4 control points (cpfg's cubic splines), counting
    /// multiplicities and a closed or phantom curve's extra points.
    TooFewCurvePoints(u64),
    /// What lsgen does not read in a contour file.
    CurveUnsupported(&'static str),
    /// A `curve:` line's SAMPLES below 2 (cpfg divides by SAMPLES - 1).
    CurveSamples,
}

impl FunctionFileError {
    /// I/O for a file that cannot be read, else parse.
    pub fn stage(&self) -> Stage {
        match self {
            FunctionFileError::Unreadable { .. } => Stage::Io,
            _ => Stage::Parse,
        }
    }

    /// The operating system's error of a file that cannot be read.
    pub fn os_error(&self) -> Option<&std::io::Error> {
        match self {
            FunctionFileError::Unreadable { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl fmt::Display for FunctionFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use FunctionFileError::*;
        match self {
            Unreadable { path, source } => write!(
                f,
                "cannot read `{}`: {}",
                path.display(),
                super::io_message(source)
            ),
            UnknownFormat => f.write_str(
                "not a cpfg function file: its first line should be `fver 1 1` or `range: 0 1` (a function) or `funcgalleryver 1 1` (a function set)",
            ),
            Version { what, major, minor } => write!(
                f,
                "{what} version {major}.{minor} is not supported (cpfg reads 1.1)"
            ),
            Expected(what) => write!(f, "expected {what}"),
            TooFewPoints(n) => write!(
                f,
                "a function needs at least 4 control points (a cubic B-spline), not {n}"
            ),
            TooMany { what, limit } => write!(f, "more than {limit} {what}"),
            NeverReaches(x) => write!(
                f,
                "the curve never comes within 0.001 of x = {x}: cpfg would search for its value forever (its control points must cover x from 0 to 1)"
            ),
            MissingFile(what) => write!(f, "`{what}` needs a file name"),
            TooFewCurvePoints(n) => write!(
                f,
                "a curve needs at least 4 control points (a cubic spline), not {n}"
            ),
            CurveUnsupported(what) => write!(f, "lsgen does not read {what} in a contour file"),
            CurveSamples => f.write_str(
                "a curve needs at least 2 samples (cpfg divides by SAMPLES - 1)",
            ),
        }
    }
}
