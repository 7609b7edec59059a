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
    /// `define:` (cpfg's arrays).
    Define,
    /// `-o>`, an object production.
    ObjectProduction,
    /// `?P`, `?H`, `?L` or `?U` (the letter): a query of the turtle.
    TurtleQuery(char),
    /// `?E`: communication with an environment program.
    Environment,
    /// `?(id,s)`: a sub-L-system call.
    SubLsystemCall,
    /// Another `?` query module.
    Query,
    /// `$`, the end of a sub-L-system.
    SubLsystemEnd,
    /// `@S`, a surface.
    Surface,
    /// `atan2(...)` (reserved in cpfg, a syntax error there).
    Atan2,
    /// A function that needs cpfg's files, curves, view or animation.
    Function(String),
    /// `name[...]`: an array.
    Array(String),
    /// `&` (an address) in an expression.
    Address,
    /// `fprintf` on something else than `stderr`.
    FprintfNotStderr,
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
            Define => f.write_str(
                "`define:` (cpfg's arrays) is not supported: lsgen has no arrays; use `#define` for constants",
            ),
            ObjectProduction => f.write_str(
                "`-o>` (an object production, for cpfg's surfaces and objects) is not supported: lsgen rewrites strings only",
            ),
            TurtleQuery(c) => write!(
                f,
                "`?{c}` (a query of the turtle's state) needs cpfg's turtle interpretation between steps{QUERY}"
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
                "a `?` query module needs cpfg's interpretation or environment{QUERY}"
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
            Array(n) => write!(f, "`{n}[...]`: arrays are not supported by lsgen"),
            Address => f.write_str("`&` (an address) is not supported: write `&&`"),
            FprintfNotStderr => f.write_str("lsgen supports `fprintf` only on `stderr`"),
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
    /// A directive with a malformed operand (the message says which).
    InvalidDirective(String),
    /// A malformed or unevaluable `#if`/`#elif` expression (the message).
    BadExpression(String),
    /// A construct this preprocessor does not implement (named).
    NotSupported(String),
    /// A bad macro call or definition use (argument count, pasting, ...;
    /// the message).
    Macro(String),
    /// An `#include` file could not be read.
    IncludeFailed {
        /// The file as named.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// An `#include` that re-enters a file being included; the chain.
    IncludeCycle(String),
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
            InvalidDirective(m) | BadExpression(m) | Macro(m) => f.write_str(m),
            NotSupported(w) => write!(f, "{w} is not supported"),
            IncludeFailed { path, source } => write!(
                f,
                "cannot include `{}`: {}",
                path.display(),
                super::io_message(source)
            ),
            IncludeCycle(chain) => write!(f, "#include cycle: {chain}"),
            Limit { what, limit } => write!(f, "{what} (limit {limit})"),
            ErrorDirective(m) => write!(f, "#error {m}"),
        }
    }
}

/// The header block of a `.l` file that failed: its name, and the pass it
/// ran before or after.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Block {
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
            Block::Start => f.write_str("`Start:`"),
            Block::StartEach(pass) => write!(f, "`StartEach:` before {pass}"),
            Block::EndEach(pass) => write!(f, "`EndEach:` after {pass}"),
            Block::End => f.write_str("`End:`"),
        }
    }
}
