//! Streams in and out: the input split into header and axiom ([`input`]),
//! the streaming axiom reader ([`axiom`]), atomic output files and signal
//! handling ([`output`]).

pub mod axiom;
pub mod input;
pub mod output;
#[cfg(feature = "cli")]
pub mod template;
