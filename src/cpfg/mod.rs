//! The cpfg (L-studio / vlab) dialect: `.l` files (issue 12).
//!
//! The stages: the built-in C-preprocessor subset ([`preprocess`]) that
//! cpfg runs every `.l` file through (cpfg calls vlab's `vlabcpp`, a GNU
//! `cccp`); the lexer ([`lexer`], logos) and the LALRPOP grammar
//! (`grammar/cpfg.lalrpop`, [`parse`]) on its output, giving the syntax
//! tree ([`ast`], statement blocks kept as data, the modules of
//! predecessors, contexts and successors as places in the text); the
//! lowering ([`lower`]), which hands the shared `.ls`
//! syntax tree's pieces production by production to the shared compiler
//! (`rules::Compiler::cpfg`: cpfg's semantics), derived by the shared
//! engine. Every offset of
//! the preprocessed text maps back to its original file, line and column
//! through [`preprocess::SourceMap`].
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

pub mod ast;
pub mod blocks;
pub mod curve;
pub mod func;
pub mod lexer;
pub mod lower;
pub mod parse;
pub mod preprocess;
pub mod query;
pub mod random;
pub mod run;

use crate::diag::{Error, ErrorKind, ParseError};
use crate::lang::parse::UserError;
use crate::rules::{Compiler, System};
use preprocess::SourceMap;
use std::path::Path;
use std::sync::Arc;

/// Which language a file is written in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Dialect {
    /// From the file: see [`sniff`].
    #[default]
    Auto,
    /// lsgen's `.ls`.
    Ls,
    /// cpfg's `.l`.
    Cpfg,
}

/// The files the `#include`s of the `.l` file `path` read, in order, as
/// the preprocessor finds them with `functions`' macros defined (as a run
/// with these functions would), each read; or, at the first included file
/// that is neither a regular file nor a directory (a pipe, a device,
/// read once), its path, unread. A file that cannot be read, or a text
/// that fails, ends the list there (its run reports the error). A batch
/// reads a `.l` file again in every job: no job may write over what it
/// includes, and nothing it includes may be a stream.
///
/// `dialect`: the file's language ([`Dialect::Auto`]: told as a run tells
/// it); an `.ls` file includes nothing.
pub fn included_files(
    path: &Path,
    dialect: Dialect,
    functions: &func::Functions,
) -> Result<Vec<std::path::PathBuf>, std::path::PathBuf> {
    use std::cell::RefCell;
    let Ok(source) = preprocess::read_file(path) else {
        return Ok(Vec::new());
    };
    let head = &source.as_bytes()[..source.len().min(crate::api::SNIFF)];
    let name = path.display().to_string();
    let cpfg = match dialect {
        Dialect::Cpfg => true,
        Dialect::Ls => false,
        Dialect::Auto => sniff(&name, head, true) == Some(true),
    };
    if !cpfg {
        return Ok(Vec::new());
    }
    let read = RefCell::new(Vec::new());
    let stream = RefCell::new(None);
    let loader = |p: &Path| {
        if std::fs::metadata(p).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
            *stream.borrow_mut() = Some(p.to_path_buf());
            return Err(std::io::Error::other("read once"));
        }
        read.borrow_mut().push(p.to_path_buf());
        preprocess::read_file(p)
    };
    let _ = preprocess::preprocess_defined(path, &source, Some(&loader), functions.macros());
    match stream.into_inner() {
        Some(p) => Err(p),
        None => Ok(read.into_inner()),
    }
}

/// Is a file cpfg's: its name ends in `.l`, or its first statement (after
/// blanks and comments) is `Lsystem:` or a `#` directive (`#` and a name,
/// as `#define`; not an `.ls` file's `#!` line)? `head` is the start of
/// the file, `complete` says whether it is all of it; None: more bytes are
/// needed to tell (so a file on a pipe is not waited for longer than its
/// first statement).
pub fn sniff(name: &str, head: &[u8], complete: bool) -> Option<bool> {
    if name.ends_with(".l") {
        return Some(true);
    }
    let more = if complete { Some(false) } else { None };
    let bom = b"\xEF\xBB\xBF".as_slice();
    if !complete && head.len() < 3 && bom.starts_with(head) {
        return None;
    }
    let mut s = head.strip_prefix(bom).unwrap_or(head);
    loop {
        let t = s.trim_ascii_start();
        if t.is_empty() || t == b"/" {
            return more;
        }
        if let Some(r) = t.strip_prefix(b"/*".as_slice()) {
            match r.windows(2).position(|w| w == b"*/") {
                Some(i) => s = &r[i + 2..],
                None => return more,
            }
        } else if let Some(r) = t.strip_prefix(b"//".as_slice()) {
            match r.iter().position(|&b| b == b'\n') {
                Some(i) => s = &r[i..],
                None => return more,
            }
        } else if let Some(r) = t.strip_prefix(b"#".as_slice()) {
            // A directive: `#`, blanks, a name (`#!` is an `.ls` shebang).
            let r = r.trim_ascii_start();
            return match r.first() {
                Some(c) => Some(c.is_ascii_alphabetic()),
                None => more,
            };
        } else {
            let word = b"system:";
            let n = t.len().min(8);
            let fits = matches!(t[0], b'L' | b'l') && t[1..n] == word[..n - 1];
            return if fits && n < 8 { more } else { Some(fits) };
        }
    }
}

/// A `.l` file read, preprocessed, parsed and lowered: what its compiled
/// systems need beside the compiled rules ([`load`], [`compile`]).
pub struct Loaded {
    /// The preprocessed text (the spans' text).
    pub text: String,
    pub map: Arc<SourceMap>,
    /// The file has `seed:` (cpfg's stochastic mode: its weights count).
    pub seeded: bool,
    /// The axiom as module text.
    pub axiom: String,
    /// Header blocks and the productions' blocks and slots (issue 12),
    /// given to the compiled system by [`lower::attach`].
    pub run: run::CpfgRun,
    pub extra: [Vec<lower::ProdExtra>; 3],
}

/// A view file beside the `.l` file `name` (same stem, `.v`), for the
/// hint of a `func` without function files.
fn view_beside(name: &str) -> Option<String> {
    let v = Path::new(name).with_extension("v");
    (name.ends_with(".l") && v.is_file()).then(|| v.display().to_string())
}

/// A located error of the preprocessed text.
pub fn locate(map: &SourceMap, e: UserError) -> Error {
    Error::at(map.location(e.span.0), ErrorKind::from(e.kind))
}

/// Preprocess, parse, lower and compile `source`, the text of the file
/// `name` (includes are read relative to it); warnings are reported
/// (`crate::diag::warn`).
/// `seed_option`: it is derived with `--seed`, which makes its weights
/// count (no warning that they are ignored); `names`: how the warnings
/// name the options; `functions`: what `func` reads (a function set's
/// names are macros); `includes`: `#include` reads files (else it is an
/// error, and no file beside `name` is looked at for a hint).
///
/// The rules are compiled as the lowering hands them over: no whole
/// syntax tree of the shared language is made, and none is kept. Only the
/// preprocessed text is, to compile again ([`compile`]).
pub fn load(
    name: &str,
    source: &str,
    seed_option: bool,
    names: crate::diag::OptionNames,
    (functions, includes): (&Arc<func::Functions>, bool),
) -> Result<(Loaded, System), Error> {
    let read: preprocess::Loader = &preprocess::read_file;
    let out = preprocess::preprocess_defined(
        Path::new(name),
        source,
        includes.then_some(read),
        functions.macros(),
    )?;
    for w in &out.warnings {
        crate::diag::warn(w.at.clone(), &w.message);
    }
    let map = out.map;
    let text = out.text;
    let beside = || includes.then(|| view_beside(name)).flatten();
    let no_functions = functions.is_empty().then(beside);
    let no_curves = functions.no_curves().then(beside);
    let tree = parse::parse_with(&text, no_functions, no_curves).map_err(|e| locate(&map, e))?;
    axiom_brackets(&tree.axiom_brackets, &map)?;
    // (Before the lowering's warnings: a file refused here is one error.)
    let queries = match query::check(&tree, &text, functions.view()) {
        Ok(Some((q, warnings))) => {
            warnings.into_iter().for_each(crate::diag::say);
            Some(q)
        }
        Ok(None) => None,
        Err(query::CheckError::At(span, r)) => {
            let e = UserError::new(span, ParseError::Refused(r));
            return Err(locate(&map, e));
        }
        Err(query::CheckError::View(at, r)) => {
            return Err(Error::at(at, ParseError::Refused(r)));
        }
        Err(query::CheckError::ViewFile(e)) => return Err(e),
    };
    let mut warn = |span: crate::lang::lexer::Span, warning| {
        if seed_option
            && matches!(
                warning,
                crate::diag::WarningKind::ProbabilityWithoutSeed { .. }
            )
        {
            return;
        }
        crate::diag::warn(map.location(span.0), &warning.with_option_names(names))
    };
    let (lowered, system) =
        lower_and_compile(tree, &text, seed_option, &mut warn).map_err(|e| locate(&map, e))?;
    let mut run = lowered.run;
    run.queries = queries.map(Arc::new);
    if !functions.is_empty() || !functions.no_curves() {
        run.functions = Some(functions.clone());
    }
    let loaded = Loaded {
        text,
        map: Arc::new(map),
        seeded: lowered.seeded,
        axiom: lowered.axiom,
        run,
        extra: lowered.extra,
    };
    let system = loaded.attach(system);
    Ok((loaded, system))
}

/// Compile a loaded file again (its first compiled system was derived,
/// or its weights count now and did not then): parsed and lowered again
/// from its preprocessed text, saying nothing (its warnings were said
/// when it was loaded). `seed_option`: as for [`load`].
pub fn compile(l: &Loaded, seed_option: bool) -> Result<System, Error> {
    // (The text parsed once with these function files: `func` and the
    // curve functions are not refused again.)
    let tree = parse::parse_with(&l.text, None, None).map_err(|e| locate(&l.map, e))?;
    let (_, system) = lower_and_compile(tree, &l.text, seed_option, &mut |_, _| {})
        .map_err(|e| locate(&l.map, e))?;
    Ok(l.attach(system))
}

/// Lower `tree`, parsed from `text`, into the shared compiler, production
/// by production: the lowering's error first, else the compiler's.
fn lower_and_compile(
    tree: ast::Lsystem,
    text: &str,
    seed_option: bool,
    warn: &mut dyn FnMut(crate::lang::lexer::Span, crate::diag::WarningKind),
) -> Result<(lower::Lowered, System), UserError> {
    let mut compiler = Compiler::cpfg(Some(text));
    let lowered = lower::lower(tree, text, seed_option, &mut compiler, warn)?;
    Ok((lowered, compiler.finish()?))
}

impl Loaded {
    /// Give a system compiled from this file what the shared rules cannot
    /// hold ([`lower::attach`]).
    fn attach(&self, mut s: System) -> System {
        s.source_map = Some(self.map.clone());
        lower::attach(&self.run, &self.extra, &mut s);
        s
    }
}

/// An unbalanced axiom, located in the original files (the axiom reader
/// that reads the lowered axiom would point into that text instead).
fn axiom_brackets(b: &ast::AxiomBrackets, map: &SourceMap) -> Result<(), Error> {
    if let Some(s) = b.bad_close {
        return Err(Error::at(map.location(s.0), ParseError::UnbalancedClose));
    }
    if let Some(s) = b.unclosed() {
        let at = map.location(s.0);
        let (line, col) = (at.line, at.col);
        return Err(Error::at(at, ParseError::UnclosedBracket { line, col }));
    }
    Ok(())
}

#[cfg(test)]
mod error_tests;
#[cfg(test)]
mod tests;
