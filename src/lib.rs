//! lsgen: a streaming L-system rewriter, as a library.
//!
//! Parse an L-system ([`LSystem::parse`], [`LSystem::from_reader`]), choose
//! [`Options`], and [`derive`](LSystem::derive) it into any
//! [`Write`](std::io::Write): the final string is streamed, generations in
//! between live in temporary files, so memory does not grow with the
//! string. [`LSystem::derive_with`] also reports each generation and
//! each warning ([`Event`]). Errors ([`Error`]) carry what went wrong, typed by stage
//! ([`ErrorKind`], payloads in [`diag`]), and their location; they render
//! as `FILE:LINE:COL: error: ...`, the source line and a caret.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let src = "productions:\nF -> F+F-F-F+F\naxiom: F\n";
//! let mut koch = lsgen::LSystem::parse(src)?;
//! let mut out = Vec::new();
//! koch.derive(&lsgen::Options::new().steps(1), &mut out)?;
//! assert_eq!(out, b"F+F-F-F+F\n");
//! # Ok(())
//! # }
//! ```
//!
//! Inside, one folder per stage of the pipeline: `src/io/input.rs` splits
//! the `.ls` text into header and axiom stream; `src/lang/` (lexer,
//! grammar, syntax tree); `src/rules/` (alphabet, compiled expressions and
//! productions, the binary module format); `src/derive/` (a strategy chosen
//! once: depth first, or step by step through temporary files; production
//! choice shared by both); `src/io/` (the streaming axiom reader, atomic
//! output); `src/diag.rs` (errors and their rendering); `src/cli.rs` (the
//! `lsgen` command line).

// Standard error may be closed or full: every diagnostic goes through
// `diag::eprint`, which never panics (issue 9, item 3).
#![deny(clippy::print_stderr)]

mod api;
#[cfg(feature = "cli")]
#[doc(hidden)]
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
pub mod cli;
#[doc(hidden)]
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
pub mod cpfg;
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
mod derive;
#[allow(missing_docs)] // partly internal; `Error` is documented
pub mod diag;
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
mod io;
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
mod lang;
#[cfg(feature = "cli")]
mod progress;
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
#[doc(hidden)]
pub mod rules;
mod spawn;
#[cfg(feature = "turtle")]
#[doc(hidden)]
#[allow(missing_docs)] // internal (tests and fuzzing reach it hidden)
pub mod turtle;
/// Without the renderer: the `view:` settings, which lsgen checks, and
/// cpfg's view file for the turtle of the cpfg dialect's queries.
#[cfg(not(feature = "turtle"))]
pub(crate) mod turtle {
    #[allow(dead_code)]
    pub mod cpfg_view;
    #[allow(dead_code)]
    pub mod movements;
    #[allow(dead_code)]
    pub mod state;
    #[allow(dead_code)]
    pub mod view;
}

pub use api::{
    derive_bytes, derive_bytes_on, LSystem, Load, Options, Stats, DEFAULT_DERIVATION_LENGTH,
};
pub use cpfg::Dialect;
pub use derive::{Event, Limits, Pass};
pub use diag::{Error, ErrorKind, Stage};

// Paths of the flat layout, kept for src/turtle, src/cpfg, the tests and
// the fuzz targets.
#[doc(hidden)]
pub use derive::random;
#[doc(hidden)]
pub use io::{axiom, input, output};
#[doc(hidden)]
pub use lang::{ast, lexer, parse, sink};
#[doc(hidden)]
pub use rules::{codec, expr};
#[doc(hidden)]
pub mod engine {
    //! The former `engine` module's public names.
    pub use crate::derive::{Limits, Out, PosReader};
}
