//! lsgen: a streaming L-system rewriter.
//!
//! The pipeline, one folder per stage:
//! [`io::input`] splits an `.ls` file into header and axiom stream ->
//! [`lang`] (lexer, grammar, syntax tree) -> [`rules`] (alphabet, compiled
//! expressions and productions, the binary module format) -> [`derive`] (a
//! strategy chosen once: depth first, or step by step through temp files)
//! -> [`io::output`] (atomic output). Errors are rendered by [`diag`].

// Standard error may be closed or full: every diagnostic goes through
// `diag::eprint`, which never panics (issue 9, item 3).
#![deny(clippy::print_stderr)]

mod api;
pub mod cli;
pub mod cpfg;
pub mod derive;
pub mod diag;
pub mod io;
pub mod lang;
mod progress;
pub mod rules;
pub mod turtle;

pub use api::{derive_bytes, LSystem, Options, Stats, DEFAULT_DERIVATION_LENGTH};
pub use derive::{Event, Limits, Pass};
pub use diag::Error;

// Paths of the flat layout, kept for src/turtle, src/cpfg, the tests and
// the fuzz targets.
#[doc(hidden)]
pub use derive::random;
#[doc(hidden)]
pub use io::{axiom, input, output};
#[doc(hidden)]
pub use lang::{ast, lexer, parse};
#[doc(hidden)]
pub use rules::{codec, expr};
#[doc(hidden)]
pub mod engine {
    //! The former `engine` module's public names.
    pub use crate::derive::{Limits, Out, PosReader};
}
