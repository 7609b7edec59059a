//! The cpfg (L-studio / vlab) dialect: `.l` files (issue 12).
//!
//! Work in progress: only the first stage exists so far, the built-in
//! C-preprocessor subset ([`preprocess`]) that cpfg runs every `.l` file
//! through (cpfg calls vlab's `vlabcpp`, a GNU `cccp`). The dialect's parser
//! will read [`preprocess::Output::text`] and turn byte offsets into original
//! file/line/column with [`preprocess::SourceMap`].
//!
//! # Newline + TAB continues a statement: the parser's job
//!
//! In cpfg a newline followed by a TAB continues the current statement. That
//! rule lives in cpfg's lexer (`lsys_input.l`), which reads `vlabcpp`'s
//! *output*; the preprocessor itself is line based like every C
//! preprocessor (a TAB-indented line after a `#define` is not part of the
//! definition, a TAB-indented `#if` is a directive). So the rule belongs to
//! the later cpfg parser, and the preprocessor guarantees what the parser
//! needs to apply it exactly as cpfg does: ordinary text keeps its newlines
//! and leading TABs byte for byte, every directive line and every line of a
//! skipped `#if` group becomes an empty line (as `vlabcpp` makes it), a
//! `/* */` comment becomes a space followed by the newlines it contained,
//! and the newlines that `\`-newline splices, a macro call over several
//! lines or an `#include` line take away are written after the line, before
//! the next one, as `vlabcpp` resynchronises its line numbers. So a TAB line
//! continues the statement before it exactly when it does in cpfg, and line
//! N of the output is line N of the file outside included text.

pub mod blocks;
pub mod preprocess;
pub mod random;
pub mod run;

#[cfg(test)]
mod tests;
