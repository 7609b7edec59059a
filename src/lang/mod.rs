//! The `.ls` language: the lexer ([`lexer`], logos), the LALRPOP grammar
//! glue and located parse errors ([`parse`]), the syntax tree ([`ast`]),
//! what a comment is ([`comment`]).

pub mod ast;
pub mod comment;
pub mod lexer;
pub mod parse;
pub mod sink;
