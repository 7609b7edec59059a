//! The C-preprocessor subset that cpfg runs every `.l` file through.
//!
//! cpfg pipes each L-system file through vlab's `vlabcpp` (GNU `cccp`). This
//! module does the same job without an external program and keeps, for every
//! byte of its output, where it came from, so that the dialect's parser can
//! report errors at the original file, line and column — through `#include`
//! and through macro expansion.
//!
//! Supported, with C semantics unless noted:
//! - `\`-newline splices (also `\` CR LF); CR LF line ends become LF.
//! - `/* */` comments become one space followed by the newlines they
//!   contained (as `vlabcpp` does, so the text keeps its line count); `//`
//!   comments run to the end of the line. Comment markers inside `"..."` or
//!   `'...'` are not comments.
//! - `#define` object-like and function-like macros, nested expansion,
//!   rescanning, no recursive self-expansion (Prosser's hide sets, as C
//!   specifies: `#define A A B` expands `A` to `A B`), `#` stringification
//!   and `##` pasting; `#undef`. A redefinition with a different body is a
//!   warning, as in `vlabcpp`.
//! - `#include "file"`, resolved relative to the including file, through a
//!   caller-supplied loader (the file system for the CLI, a map in tests).
//! - `#if`/`#ifdef`/`#ifndef`/`#elif`/`#else`/`#endif` with C integer
//!   expressions: `defined X`, `defined(X)`, integer and character literals,
//!   `+ - * / % << >> < > <= >= == != & ^ | && || ! ~ ?:` and parentheses,
//!   64-bit signed arithmetic; an identifier left after macro expansion is 0.
//! - `#error` (an error), `#warning` and `#pragma` (warnings), `#` alone (an
//!   empty line).
//!
//! Deliberate differences from C and from `vlabcpp`:
//! - As in `vlabcpp`, `$` is an identifier character: `$X` does not expand a
//!   macro `X`.
//! - A line whose first character after `#` is neither a letter, `_` nor a
//!   digit (`#(2)F`, cpfg's line-width module) is kept as text with a
//!   warning; `vlabcpp` does the same.
//! - Not supported, each a located [`PpErrorKind::NotSupported`] error:
//!   variadic macros, `#include <...>`, `#line` and `# N "file"` markers,
//!   `#include_next`, `#import`, `#ident`, `#sccs`, `#assert`,
//!   `#unassert`. There are no predefined macros (`__LINE__`, `__FILE__`,
//!   ...), no trigraphs or digraphs (`%:` is cpfg's cut module).
//! - `#` in a function-like macro body must be followed by a parameter name
//!   (C stringification), as in `vlabcpp`; a `##` that does not paste into
//!   one token is an error.
//! - Unsigned arithmetic is not distinguished in `#if` (`u` suffixes are
//!   accepted and ignored); parentheses, unary operators and `?:` nest at
//!   most 128 deep.
//! - `'` starts a character constant as in C: its text is not
//!   macro-expanded. One not closed on its line of text is a warning and
//!   the rest of the line is kept as it is, as `vlabcpp` (`cccp.c`)
//!   reports it and goes on (cpfg reads its output whatever its status);
//!   comments after it are still removed (cpfg's scanner skips them). In
//!   a directive it is an error.
//!
//! # Limits
//!
//! Everything is bounded so that hostile input gives a located error instead
//! of eating memory or time ([`Limits`], defaults in brackets): the output
//! text (16 MiB), the `#include` nesting (200 files, so that a file that
//! includes itself without a guard stops: an error naming the cycle), the
//! number of `#include`s carried out in one run (65,536, which stops a
//! "diamond" of headers that each include the next one twice: 30 levels
//! of them would include an empty header 2^30 times) and the bytes of
//! the files they include, each inclusion counted (256 MiB), the nesting
//! of macro argument expansions (64 levels), and the total number of
//! tokens produced by macro expansion in one run (2^21, which stops a
//! "macro bomb" such as `#define B A A` / `#define C B B` / ...). Each is
//! an error at the directive or text that crosses it.
//!
//! # Lines
//!
//! Like `vlabcpp`, the output keeps each file's line numbers: a directive or
//! skipped line becomes an empty line, and newlines removed by splices,
//! macro calls over several lines, comments inside directives or an
//! `#include` line are written before the next line. Included text is
//! inserted in place, so lines after an include are shifted: use
//! [`SourceMap`] to go back.

use crate::diag::{excerpt, DirectiveError, IfError, Location, MacroError, PpConstruct};
use std::collections::{HashMap, VecDeque};
use std::fmt;
use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};
use std::rc::Rc;

mod files;
mod ifexpr;
mod macros;
mod map;
mod tokens;

use files::*;
use map::*;
pub use map::{Loc, Origin, Output, SourceMap};
use tokens::*;

/// Resource limits; see the module documentation.
#[derive(Clone, Debug)]
pub struct Limits {
    /// Bytes of preprocessed text.
    pub max_output: usize,
    /// Files open at once through `#include` (the main file counts).
    pub max_include_depth: usize,
    /// `#include`s carried out in the whole run (the work of a file
    /// included again is done again).
    pub max_includes: usize,
    /// Bytes of the files that `#include`s bring in, summed over every
    /// `#include` carried out (the main file does not count).
    pub max_included_bytes: usize,
    /// Nesting of macro calls inside macro arguments.
    pub max_expansion_depth: usize,
    /// Tokens produced by macro expansion in the whole run.
    pub max_expansion_tokens: usize,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            max_output: 16 << 20,
            max_include_depth: 200,
            max_includes: 1 << 16,
            max_included_bytes: 256 << 20,
            max_expansion_depth: 64,
            max_expansion_tokens: 1 << 21,
        }
    }
}

/// Largest file [`read_file`] accepts.
pub const MAX_FILE_SIZE: u64 = 64 << 20;

/// What reads an included file: its text, or why not.
pub type Loader<'l> = &'l dyn Fn(&Path) -> io::Result<String>;

/// A loader for [`preprocess`] that reads from the file system (at most
/// [`MAX_FILE_SIZE`] bytes, UTF-8).
pub fn read_file(path: &Path) -> io::Result<String> {
    // `#include "/dev/stdin"` with standard input closed (`<&-`) would
    // read the /dev/null the binary put there.
    if crate::io::output::leads_to_closed_fd(path) {
        return Err(io::Error::other("Bad file descriptor (closed at startup)"));
    }
    // `#include "/dev/stdin"` where lsgen reads the L-system or the
    // axiom from standard input: it would take what they need (or read
    // nothing, after the L-system).
    if crate::io::output::takes_stdin(path) {
        return Err(io::Error::other(
            "it is standard input, which this run reads itself (the L-system, `--axiom` or the module string)",
        ));
    }
    let f = std::fs::File::open(path)?;
    let mut buf = Vec::new();
    f.take(MAX_FILE_SIZE + 1).read_to_end(&mut buf)?;
    if buf.len() as u64 > MAX_FILE_SIZE {
        return Err(io::Error::other(format!(
            "file larger than {} MiB",
            MAX_FILE_SIZE >> 20
        )));
    }
    String::from_utf8(buf)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "file is not valid UTF-8"))
}

// ---------------------------------------------------------------- errors

/// A preprocessing error at a place in the original text.
#[derive(Debug)]
pub struct PpError {
    pub at: Location,
    pub kind: PpErrorKind,
}

/// What went wrong (the one typed enum, in `crate::diag`).
pub use crate::diag::PreprocessError as PpErrorKind;

impl PpError {
    /// The message without the location.
    pub fn message(&self) -> String {
        self.kind.to_string()
    }
}

impl fmt::Display for PpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.at.path,
            self.at.line,
            self.at.col,
            self.message()
        )
    }
}

impl std::error::Error for PpError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.kind
            .os_error()
            .map(|e| e as &(dyn std::error::Error + 'static))
    }
}

impl From<PpError> for crate::diag::Error {
    fn from(e: PpError) -> crate::diag::Error {
        crate::diag::Error::at(e.at, e.kind)
    }
}

/// A warning (the text was processed anyway).
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    pub at: Location,
    pub(crate) message: crate::diag::WarningKind,
}

impl fmt::Display for Warning {
    /// `lsgen: FILE:LINE:COL: warning: ...`, the line and a caret, as
    /// [`crate::diag::warn`] prints it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&crate::diag::warning_text(&self.at, &self.message))
    }
}

// ---------------------------------------------------------------- state

struct Macro {
    /// `None` for an object-like macro.
    params: Option<Vec<String>>,
    body: Vec<Tok>,
}

struct Frame {
    file: u32,
    /// Start of the next line in the file's cleaned text.
    pos: usize,
    /// Newlines written for this file so far (for line sync).
    emitted: usize,
}

struct Cond {
    at: Pos,
    directive: &'static str,
    /// Index of the file's frame.
    frame: usize,
    parent_active: bool,
    active: bool,
    /// A group of this conditional was taken already.
    taken: bool,
    seen_else: bool,
}

/// The current text line(s) being read by macro expansion.
struct Cursor {
    file: u32,
    pos: usize,
    eol: usize,
    nl_done: bool,
}

struct Pp<'l> {
    files: Vec<SourceFile>,
    text: String,
    segs: Vec<Seg>,
    warnings: crate::diag::FileWarnings<Warning>,
    macros: HashMap<String, usize>,
    defs: Vec<Macro>,
    hidesets: Vec<Vec<u32>>,
    hide_index: HashMap<Vec<u32>, u32>,
    frames: Vec<Frame>,
    conds: Vec<Cond>,
    /// None: `#include` is refused ([`PpErrorKind::IncludesOff`]).
    loader: Option<Loader<'l>>,
    limits: Limits,
    work: usize,
    /// `#include`s carried out, and the bytes of the files they brought.
    includes: usize,
    included_bytes: usize,
}

type Res<T> = Result<T, PpError>;

/// Add `n` to a run's counter of work (`#include`s, included bytes, macro
/// tokens); past `most`, the limit error `what` names.
fn spend(used: &mut usize, n: usize, most: usize, what: &'static str) -> Result<(), PpErrorKind> {
    *used = used.saturating_add(n);
    if *used > most {
        return Err(PpErrorKind::Limit { what, limit: most });
    }
    Ok(())
}

/// Preprocess `source`, the text of the file `path` (used for messages and
/// as the base of relative includes), with default [`Limits`]. `loader`
/// reads included files ([`read_file`] for the file system).
pub fn preprocess(
    path: &Path,
    source: &str,
    loader: &dyn Fn(&Path) -> io::Result<String>,
) -> Result<Output, PpError> {
    preprocess_with(path, source, loader, &Limits::default())
}

/// [`preprocess`] with object-like macros defined first, each `NAME`
/// as `VALUE` (cpfg's `-DNAME=VALUE` for a function set's names); without
/// a `loader`, an `#include` carried out is an error
/// ([`PpErrorKind::IncludesOff`]) and no file is read.
pub fn preprocess_defined(
    path: &Path,
    source: &str,
    loader: Option<Loader>,
    defines: &[(String, usize)],
) -> Result<Output, PpError> {
    preprocess_full(path, source, loader, &Limits::default(), defines)
}

/// [`preprocess`] with explicit limits.
pub fn preprocess_with(
    path: &Path,
    source: &str,
    loader: &dyn Fn(&Path) -> io::Result<String>,
    limits: &Limits,
) -> Result<Output, PpError> {
    preprocess_full(path, source, Some(loader), limits, &[])
}

fn preprocess_full(
    path: &Path,
    source: &str,
    loader: Option<Loader>,
    limits: &Limits,
    defines: &[(String, usize)],
) -> Result<Output, PpError> {
    let mut pp = Pp {
        files: Vec::new(),
        text: String::new(),
        segs: Vec::new(),
        warnings: crate::diag::FileWarnings::new(),
        macros: HashMap::new(),
        defs: Vec::new(),
        hidesets: vec![Vec::new()],
        hide_index: HashMap::new(),
        frames: Vec::new(),
        conds: Vec::new(),
        loader,
        limits: limits.clone(),
        work: 0,
        includes: 0,
        included_bytes: 0,
    };
    if !defines.is_empty() {
        // As `-D` options: a text of `#define`s read first, its (empty)
        // output lines dropped, its macros kept.
        let text: String = defines
            .iter()
            .map(|(n, v)| format!("#define {n} {v}\n"))
            .collect();
        pp.open("<command line>".to_string(), PathBuf::new(), text)?;
        pp.run()?;
        pp.text.clear();
        pp.segs.clear();
    }
    let name = path.display().to_string();
    pp.open(name, path.to_path_buf(), source.to_string())?;
    pp.run()?;
    Ok(Output {
        text: pp.text,
        map: SourceMap {
            files: pp.files,
            segs: pp.segs,
        },
        warnings: pp.warnings.finish(|at, message| Warning { at, message }),
    })
}

/// Where `p` is in the sources.
fn location_in(files: &[SourceFile], p: Pos) -> Location {
    let f = &files[p.file as usize];
    f.location_src(f.src_offset(p.off as usize))
}

impl Pp<'_> {
    // ------------------------------------------------------------ places

    fn location(&self, p: Pos) -> Location {
        location_in(&self.files, p)
    }

    fn err(&self, p: Pos, kind: PpErrorKind) -> PpError {
        PpError {
            at: self.location(p),
            kind,
        }
    }

    fn warn(&mut self, p: Pos, message: crate::diag::WarningKind) {
        let files = &self.files;
        self.warnings
            .push(|| location_in(files, p), |at| Warning { at, message });
    }

    fn text<'a>(&'a self, t: &'a Tok) -> &'a str {
        text_of(&self.files, t)
    }

    // ------------------------------------------------------------ output

    fn push_seg(&mut self, kind: SegKind, a: Pos, b: Pos) {
        let out = self.text.len();
        if let Some(l) = self.segs.last() {
            let same = l.kind == kind
                && (kind == SegKind::Text || l.b == b)
                && l.a.file == a.file
                && match kind {
                    SegKind::Fixed | SegKind::Synth => l.a == a,
                    _ => l.a.off as usize + (out - l.out) == a.off as usize,
                };
            if same {
                return;
            }
            if l.out == out {
                self.segs.pop();
            }
        }
        self.segs.push(Seg { out, kind, a, b });
    }

    fn check_output(&self, at: Pos) -> Res<()> {
        if self.text.len() > self.limits.max_output {
            return Err(self.err(
                at,
                PpErrorKind::Limit {
                    what: "preprocessed text too long",
                    limit: self.limits.max_output,
                },
            ));
        }
        Ok(())
    }

    fn emit_newline(&mut self, file: u32, eol: usize) {
        let p = Pos {
            file,
            off: eol as u32,
        };
        let f = &self.files[file as usize];
        let kind = if eol < f.clean.len() {
            SegKind::Text
        } else {
            SegKind::Fixed
        };
        self.push_seg(kind, p, p);
        self.text.push('\n');
        self.count_newlines(1);
    }

    fn count_newlines(&mut self, n: usize) {
        if let Some(fr) = self.frames.last_mut() {
            fr.emitted += n;
        }
    }

    /// Line sync, as `vlabcpp` keeps it: before the line at `pos`, write the
    /// newlines that splices, calls over several lines, comments in
    /// directives or an `#include` line left out, so that output line N of
    /// a file's own text is its line N.
    fn sync_lines(&mut self, file: u32, pos: usize) {
        let f = &self.files[file as usize];
        let src = f.src_offset(pos);
        let want = f.line_starts.partition_point(|&s| s <= src) - 1;
        let have = self.frames.last().map_or(want, |fr| fr.emitted);
        if have < want {
            let p = Pos {
                file,
                off: pos as u32,
            };
            self.push_seg(SegKind::Fixed, p, p);
            for _ in have..want {
                self.text.push('\n');
            }
            self.count_newlines(want - have);
        }
    }

    fn emit(&mut self, t: &Tok) -> Res<()> {
        match (t.kind, t.usage) {
            (K::Placemarker, _) => return Ok(()),
            (K::Newline, _) => self.emit_newline(t.at.file, t.at.off as usize),
            (K::Space, Some(u)) => {
                self.push_seg(SegKind::Synth, u, u);
                self.text.push(' ');
            }
            (K::Space, None) if t.nl > 0 => {
                // A comment's newlines follow its space, as in `vlabcpp`.
                let (file, start) = (t.at.file, t.at.off as usize);
                let end = start + t.len as usize;
                let mut from = start;
                let f = &self.files[file as usize];
                let a = f.comment_nl.partition_point(|&(o, _)| o < start);
                let b = f.comment_nl.partition_point(|&(o, _)| o < end);
                for k in a..b {
                    let (o, n) = self.files[file as usize].comment_nl[k];
                    let p = Pos {
                        file,
                        off: from as u32,
                    };
                    self.push_seg(SegKind::Text, p, p);
                    let f = &self.files[file as usize];
                    self.text.push_str(&f.clean[from..=o]);
                    let c = Pos {
                        file,
                        off: o as u32,
                    };
                    self.push_seg(SegKind::Fixed, c, c);
                    for _ in 0..n {
                        self.text.push('\n');
                    }
                    self.count_newlines(n as usize);
                    from = o + 1;
                }
                let p = Pos {
                    file,
                    off: from as u32,
                };
                self.push_seg(SegKind::Text, p, p);
                let f = &self.files[file as usize];
                self.text.push_str(&f.clean[from..end]);
            }
            (_, None) => {
                self.push_seg(SegKind::Text, t.at, t.at);
                let s = text_of(&self.files, t);
                self.text.push_str(s);
            }
            (_, Some(u)) => {
                let kind = match t.org {
                    Org::Src => SegKind::Arg,
                    Org::Body => SegKind::Body,
                    Org::Synth => SegKind::Synth,
                };
                let a = if kind == SegKind::Synth { u } else { t.at };
                self.push_seg(kind, a, u);
                let s = text_of(&self.files, t);
                self.text.push_str(s);
            }
        }
        self.check_output(t.primary())
    }

    // ------------------------------------------------------------ files

    fn open(&mut self, name: String, path: PathBuf, text: String) -> Res<()> {
        let id = self.files.len() as u32;
        if text.len() >= u32::MAX as usize {
            // Offsets are 32-bit.
            let f = SourceFile::new(name, path, String::new()).expect("empty file");
            return Err(PpError {
                at: f.location_src(0),
                kind: PpErrorKind::Limit {
                    what: "file too large",
                    limit: u32::MAX as usize - 1,
                },
            });
        }
        let f = SourceFile::new(name, path, text).map_err(|at| PpError {
            at,
            kind: PpErrorKind::UnterminatedComment,
        })?;
        self.files.push(f);
        self.frames.push(Frame {
            file: id,
            pos: 0,
            emitted: 0,
        });
        Ok(())
    }

    fn active(&self) -> bool {
        self.conds.last().is_none_or(|c| c.active)
    }

    fn run(&mut self) -> Res<()> {
        while let Some(fr) = self.frames.last() {
            let (file, pos) = (fr.file, fr.pos);
            let f = &self.files[file as usize];
            let len = f.clean.len();
            if pos >= len {
                if let Some(c) = self.conds.last() {
                    if c.frame + 1 == self.frames.len() {
                        let d = c.directive;
                        return Err(self.err(c.at, PpErrorKind::UnterminatedConditional(d)));
                    }
                }
                self.frames.pop();
                continue;
            }
            self.sync_lines(file, pos);
            let f = &self.files[file as usize];
            let b = f.clean.as_bytes();
            let eol = f.clean[pos..].find('\n').map_or(len, |e| pos + e);
            let mut i = pos;
            while i < eol && is_hspace(b[i]) {
                i += 1;
            }
            let mut j = i + 1;
            while j < eol && is_hspace(b[j]) {
                j += 1;
            }
            let module_line = i < eol && b[i] == b'#' && j < eol && {
                let c = b[j];
                !(is_idstart(c) || c.is_ascii_digit())
            };
            if i < eol && b[i] == b'#' && !module_line {
                self.frames.last_mut().unwrap().pos = eol + 1;
                self.directive(file, i, j, eol)?;
            } else if !self.active() {
                self.frames.last_mut().unwrap().pos = eol + 1;
                self.emit_newline(file, eol);
            } else {
                if module_line {
                    let p = Pos {
                        file,
                        off: i as u32,
                    };
                    self.warn(p, crate::diag::WarningKind::HashModule);
                }
                let mut cur = Cursor {
                    file,
                    pos,
                    eol,
                    nl_done: false,
                };
                let mut pending = VecDeque::new();
                self.expand(&mut pending, Some(&mut cur), None, 0)?;
                self.frames.last_mut().unwrap().pos = cur.eol + 1;
            }
        }
        Ok(())
    }

    // ------------------------------------------------------------ lexing

    /// The tokens of `[start, end)` of a file's cleaned text.
    fn lex_range(&self, file: u32, start: usize, end: usize) -> Res<Vec<Tok>> {
        let mut v = Vec::new();
        let mut i = start;
        while i < end {
            let t = self.lex_one(file, i, end, false)?;
            i += t.len as usize;
            v.push(t);
        }
        Ok(v)
    }

    /// The token at `i` (before `end`); `text`: in a line of text, where
    /// a `'` not closed on the line is a `BadLit` token to the line's end
    /// (elsewhere it is an error, as an unterminated `"` is everywhere).
    fn lex_one(&self, file: u32, i: usize, end: usize, text: bool) -> Res<Tok> {
        let f = &self.files[file as usize];
        let (kind, j) = lex(f.clean.as_bytes(), i, end);
        let mut t = Tok::src(kind, file, i, j - i);
        match kind {
            K::BadLit if text && f.clean.as_bytes()[i] == b'\'' => {}
            K::BadLit => {
                let q = f.clean.as_bytes()[i] as char;
                return Err(self.err(t.at, PpErrorKind::UnterminatedLiteral(q)));
            }
            K::Space => {
                let a = f.comment_nl.partition_point(|&(o, _)| o < i);
                let b = f.comment_nl.partition_point(|&(o, _)| o < j);
                t.nl = f.comment_nl[a..b].iter().map(|&(_, n)| n).sum();
            }
            _ => {}
        }
        Ok(t)
    }

    /// The next token: pending ones first, then the cursor's line, then (if
    /// `cross`) the following text lines of the file.
    fn next_tok(
        &mut self,
        pending: &mut VecDeque<Tok>,
        cur: Option<&mut Cursor>,
        cross: bool,
    ) -> Res<Option<Tok>> {
        if let Some(t) = pending.pop_front() {
            return Ok(Some(t));
        }
        let Some(cur) = cur else { return Ok(None) };
        loop {
            if cur.pos < cur.eol {
                let mut t = self.lex_one(cur.file, cur.pos, cur.eol, true)?;
                if t.kind == K::BadLit {
                    // A `'` not closed on its line of text: vlabcpp
                    // (cccp.c) reports it and goes on, the rest of the
                    // line copied as it is (no macro expansion); cpfg
                    // reads that output.
                    self.warn(t.at, crate::diag::WarningKind::UnterminatedCharConstant);
                    t.kind = K::Other;
                }
                cur.pos += t.len as usize;
                return Ok(Some(t));
            }
            if !cur.nl_done {
                cur.nl_done = true;
                return Ok(Some(Tok::src(K::Newline, cur.file, cur.eol, 1)));
            }
            if !cross {
                return Ok(None);
            }
            // Continue on the next line unless it is a directive or the end.
            let f = &self.files[cur.file as usize];
            let start = cur.eol + 1;
            if start >= f.clean.len() {
                return Ok(None);
            }
            let eol = f.clean[start..]
                .find('\n')
                .map_or(f.clean.len(), |e| start + e);
            let b = f.clean.as_bytes();
            let mut i = start;
            while i < eol && is_hspace(b[i]) {
                i += 1;
            }
            if i < eol && b[i] == b'#' {
                return Ok(None);
            }
            *cur = Cursor {
                file: cur.file,
                pos: start,
                eol,
                nl_done: false,
            };
        }
    }

    // ------------------------------------------------------------ directives

    /// Handle the directive whose `#` is at `hash` and name at `name`.
    fn directive(&mut self, file: u32, hash: usize, name: usize, eol: usize) -> Res<()> {
        let f = &self.files[file as usize];
        let b = f.clean.as_bytes();
        let mut ne = name;
        while ne < eol && is_idchar(b[ne]) {
            ne += 1;
        }
        let word = f.clean[name..ne].to_string();
        let at = Pos {
            file,
            off: hash as u32,
        };
        let name_at = Pos {
            file,
            off: name as u32,
        };
        let active = self.active();
        match word.as_str() {
            "if" | "ifdef" | "ifndef" => {
                let directive = match word.as_str() {
                    "if" => "#if",
                    "ifdef" => "#ifdef",
                    _ => "#ifndef",
                };
                let value = if active {
                    let toks = self.lex_range(file, ne, eol)?;
                    if word == "if" {
                        self.eval_if(toks, name_at)?
                    } else {
                        let n = self.macro_name(&toks, directive, name_at)?;
                        self.macros.contains_key(&n) == (word == "ifdef")
                    }
                } else {
                    false
                };
                self.conds.push(Cond {
                    at,
                    directive,
                    frame: self.frames.len() - 1,
                    parent_active: active,
                    active: value,
                    taken: value || !active,
                    seen_else: false,
                });
            }
            "elif" | "else" | "endif" => {
                let directive = match word.as_str() {
                    "elif" => "#elif",
                    "else" => "#else",
                    _ => "#endif",
                };
                let frame = self.frames.len() - 1;
                let Some(c) = self.conds.last() else {
                    return Err(self.err(at, PpErrorKind::UnmatchedConditional(directive)));
                };
                if c.frame != frame {
                    return Err(self.err(at, PpErrorKind::UnmatchedConditional(directive)));
                }
                if c.seen_else && word != "endif" {
                    return Err(self.err(at, PpErrorKind::AfterElse(directive)));
                }
                let (parent, taken) = (c.parent_active, c.taken);
                match word.as_str() {
                    "endif" | "else" => {
                        if parent {
                            self.no_extra(file, ne, eol, directive)?;
                        }
                        if word == "endif" {
                            self.conds.pop();
                        } else {
                            let c = self.conds.last_mut().unwrap();
                            c.seen_else = true;
                            c.active = parent && !taken;
                            c.taken = true;
                        }
                    }
                    _ => {
                        let value = if parent && !taken {
                            let toks = self.lex_range(file, ne, eol)?;
                            self.eval_if(toks, name_at)?
                        } else {
                            false
                        };
                        let c = self.conds.last_mut().unwrap();
                        c.active = value;
                        c.taken |= value;
                    }
                }
            }
            _ if !active => {}
            "" if name == eol => {} // `#` alone
            w if w.starts_with(|c: char| c.is_ascii_digit()) => {
                return Err(self.err(name_at, PpErrorKind::NotSupported(PpConstruct::LineMarker)));
            }
            "define" => {
                let toks = self.lex_range(file, ne, eol)?;
                self.define(toks, name_at)?;
            }
            "undef" => {
                let toks = self.lex_range(file, ne, eol)?;
                let n = self.macro_name(&toks, "#undef", name_at)?;
                self.macros.remove(&n);
            }
            "include" => {
                let toks = self.lex_range(file, ne, eol)?;
                // The included text replaces the line.
                return self.include(file, toks, at);
            }
            "error" | "warning" | "pragma" => {
                let msg = self.files[file as usize].clean[ne..eol].trim().to_string();
                match word.as_str() {
                    "error" => return Err(self.err(at, PpErrorKind::ErrorDirective(msg))),
                    "warning" => self.warn(at, crate::diag::WarningKind::UserDirective(msg)),
                    _ => self.warn(at, crate::diag::WarningKind::PragmaIgnored),
                }
            }
            "line" | "include_next" | "import" | "ident" | "sccs" | "assert" | "unassert" => {
                return Err(self.err(at, PpErrorKind::NotSupported(PpConstruct::Directive(word))));
            }
            _ => return Err(self.err(name_at, PpErrorKind::UnknownDirective(word))),
        }
        self.emit_newline(file, eol);
        Ok(())
    }

    /// Warn about tokens after a directive that takes none.
    fn no_extra(&mut self, file: u32, start: usize, eol: usize, directive: &str) -> Res<()> {
        let toks = self.lex_range(file, start, eol)?;
        if let Some(t) = toks.iter().find(|t| !t.is_space()) {
            self.warn(
                t.at,
                crate::diag::WarningKind::ExtraTokens(directive.to_string()),
            );
        }
        Ok(())
    }

    /// The single identifier operand of `#ifdef`, `#ifndef`, `#undef`.
    fn macro_name(&mut self, toks: &[Tok], directive: &str, at: Pos) -> Res<String> {
        let mut it = toks.iter().filter(|t| !t.is_space());
        let Some(t) = it.next().filter(|t| t.kind == K::Ident) else {
            let p = toks.iter().find(|t| !t.is_space()).map_or(at, |t| t.at);
            return Err(self.err(
                p,
                PpErrorKind::InvalidDirective(DirectiveError::NeedsMacroName(
                    directive.to_string(),
                )),
            ));
        };
        let n = self.text(t).to_string();
        if let Some(x) = it.next() {
            let p = x.at;
            self.warn(
                p,
                crate::diag::WarningKind::ExtraTokens(format!("{directive} {n}")),
            );
        }
        Ok(n)
    }

    fn include(&mut self, file: u32, toks: Vec<Tok>, at: Pos) -> Res<()> {
        let Some(loader) = self.loader else {
            return Err(self.err(at, PpErrorKind::IncludesOff));
        };
        let first = |v: &[Tok]| v.iter().position(|t| !t.is_space());
        let mut toks = toks;
        let Some(k) = first(&toks) else {
            let e = DirectiveError::IncludeNeedsName;
            return Err(self.err(at, PpErrorKind::InvalidDirective(e)));
        };
        if toks[k].kind == K::Other && self.text(&toks[k]).starts_with('<') {
            return Err(self.err(
                toks[k].at,
                PpErrorKind::NotSupported(PpConstruct::SystemInclude),
            ));
        }
        if toks[k].kind != K::Str {
            let mut dq: VecDeque<Tok> = toks.into();
            let mut out = Vec::new();
            self.expand(&mut dq, None, Some(&mut out), 0)?;
            toks = out;
        }
        let k = match first(&toks) {
            Some(k) if toks[k].kind == K::Str => k,
            k => {
                let p = k.map_or(at, |k| toks[k].primary());
                let e = DirectiveError::IncludeNotQuoted;
                return Err(self.err(p, PpErrorKind::InvalidDirective(e)));
            }
        };
        let name_at = toks[k].primary();
        if let Some(x) = toks[k + 1..].iter().find(|t| !t.is_space()) {
            let p = x.primary();
            self.warn(
                p,
                crate::diag::WarningKind::ExtraTokens("#include".to_string()),
            );
        }
        let quoted = self.text(&toks[k]);
        let name = quoted[1..quoted.len() - 1].to_string();
        if name.is_empty() {
            let e = DirectiveError::IncludeEmptyName;
            return Err(self.err(name_at, PpErrorKind::InvalidDirective(e)));
        }
        let path = include_path(&self.files[file as usize].path, &name);
        let key = normalize(&path);
        // A file may include itself (directly or not), as in cpp: include
        // guards end the recursion. Only the depth is limited (vlabcpp
        // stops at its input stack's end, gcc's cpp at 200 files).
        let limit = self.limits.max_include_depth;
        if self.frames.len() >= limit {
            let again = self
                .frames
                .iter()
                .rposition(|fr| self.files[fr.file as usize].key == key);
            let Some(i) = again else {
                return Err(self.err(
                    at,
                    PpErrorKind::Limit {
                        what: "#include nested too deeply",
                        limit,
                    },
                ));
            };
            let mut chain: Vec<String> = self.frames[i..]
                .iter()
                .map(|fr| self.files[fr.file as usize].name.clone())
                .collect();
            chain.push(path.display().to_string());
            let chain = chain.join(" -> ");
            return Err(self.err(at, PpErrorKind::IncludeCycle { chain, limit }));
        }
        // The work of the whole run is bounded too: headers that each
        // include the next one twice would otherwise include the last one
        // 2^depth times, within the depth limit.
        let most = self.limits.max_includes;
        spend(
            &mut self.includes,
            1,
            most,
            "too many `#include`s carried out in one run",
        )
        .map_err(|k| self.err(at, k))?;
        // A file included again is read once (its text is kept).
        if let Some(id) = self.files.iter().position(|f| f.key == key) {
            self.count_included(at, self.files[id].text.len())?;
            self.frames.push(Frame {
                file: id as u32,
                pos: 0,
                emitted: 0,
            });
            return Ok(());
        }
        let text = loader(&path).map_err(|source| {
            self.err(
                name_at,
                PpErrorKind::IncludeFailed {
                    path: path.clone(),
                    source,
                },
            )
        })?;
        self.count_included(at, text.len())?;
        self.open(path.display().to_string(), path, text)
    }

    /// Count the bytes of a file that an `#include` at `at` brings in.
    fn count_included(&mut self, at: Pos, bytes: usize) -> Res<()> {
        let most = self.limits.max_included_bytes;
        let what =
            "too much text included: the bytes of the `#include`d files, each inclusion counted";
        spend(&mut self.included_bytes, bytes, most, what).map_err(|k| self.err(at, k))
    }

    // ------------------------------------------------------------ expansion
}
