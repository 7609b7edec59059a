//! The `.ls` language: the lexer ([`lexer`], logos), the LALRPOP grammar
//! glue and located parse errors ([`parse`]), the syntax tree ([`ast`]).

pub mod ast;
pub mod lexer;
pub mod parse;
pub mod sink;
