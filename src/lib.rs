//! lsgen: a streaming L-system rewriter.
//!
//! The pipeline, one module per stage:
//! [`input`] splits an `.ls` file into header and axiom stream ->
//! [`lexer`] -> grammar ([`parse`]) -> [`rules`] (compiled productions) ->
//! [`engine`] (derivation steps through temp files) -> [`output`].

// Standard error may be closed or full: every diagnostic goes through
// `diag::eprint`, which never panics (issue 9, item 3).
#![deny(clippy::print_stderr)]

pub mod ast;
pub mod axiom;
pub mod cli;
pub mod codec;
pub mod cpfg;
pub mod dfs;
pub mod diag;
pub mod engine;
pub mod expr;
pub mod input;
pub mod lexer;
pub mod output;
pub mod parse;
pub mod random;
pub mod rules;
pub use cli::derive_bytes;
pub mod turtle;
