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
//! - A file that includes itself, directly or through others, is an error
//!   even when include guards would stop the recursion.
//! - Unsigned arithmetic is not distinguished in `#if` (`u` suffixes are
//!   accepted and ignored); parentheses, unary operators and `?:` nest at
//!   most 128 deep.
//! - `'` starts a character constant as in C (cpfg has no `'` module); one
//!   not closed on its line is an error (`vlabcpp` reports it too).
//!
//! # Limits
//!
//! Everything is bounded so that hostile input gives a located error instead
//! of eating memory or time ([`Limits`], defaults in brackets): the output
//! text (16 MiB), the `#include` nesting (32 files), the nesting of macro
//! argument expansions (64 levels), and the total number of tokens produced
//! by macro expansion in one run (2^21, which stops a "macro bomb" such as
//! `#define B A A` / `#define C B B` / ...).
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

/// Resource limits; see the module documentation.
#[derive(Clone, Debug)]
pub struct Limits {
    /// Bytes of preprocessed text.
    pub max_output: usize,
    /// Files open at once through `#include` (the main file counts).
    pub max_include_depth: usize,
    /// Nesting of macro calls inside macro arguments.
    pub max_expansion_depth: usize,
    /// Tokens produced by macro expansion in the whole run.
    pub max_expansion_tokens: usize,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            max_output: 16 << 20,
            max_include_depth: 32,
            max_expansion_depth: 64,
            max_expansion_tokens: 1 << 21,
        }
    }
}

/// Largest file [`read_file`] accepts.
pub const MAX_FILE_SIZE: u64 = 64 << 20;

/// A loader for [`preprocess`] that reads from the file system (at most
/// [`MAX_FILE_SIZE`] bytes, UTF-8).
pub fn read_file(path: &Path) -> io::Result<String> {
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
    pub(crate) message: crate::diag::Warning,
}

impl fmt::Display for Warning {
    /// `lsgen: FILE:LINE:COL: warning: ...`, the line and a caret, as
    /// [`crate::diag::warn`] prints it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&crate::diag::warning_text(&self.at, &self.message))
    }
}

// ---------------------------------------------------------------- files

/// One input file: its original text and the maps from its cleaned text
/// (splices, CR LF and comments removed) back to it.
#[derive(Debug)]
struct SourceFile {
    name: String,
    /// Lexically normalised path, for cycle detection.
    key: PathBuf,
    /// The path as loaded, base for nested includes.
    path: PathBuf,
    text: String,
    line_starts: Vec<usize>,
    clean: String,
    /// (offset in spliced text, offset in `text`) at every change of delta.
    splice_breaks: Vec<(usize, usize)>,
    /// (offset in `clean`, offset in spliced text).
    clean_breaks: Vec<(usize, usize)>,
    /// (offset in `clean` of a comment's space, newlines in the comment).
    comment_nl: Vec<(usize, u32)>,
}

fn back(breaks: &[(usize, usize)], off: usize) -> usize {
    let i = breaks.partition_point(|&(o, _)| o <= off);
    let (o, s) = breaks[i.saturating_sub(1)];
    s + off.saturating_sub(o)
}

impl SourceFile {
    /// Prepare a file; `Err` locates an unterminated comment.
    fn new(name: String, path: PathBuf, text: String) -> Result<SourceFile, Location> {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        let (spliced, splice_breaks) = splice(&text);
        let mut f = SourceFile {
            name,
            key: normalize(&path),
            path,
            text,
            line_starts,
            clean: String::new(),
            splice_breaks,
            clean_breaks: vec![(0, 0)],
            comment_nl: Vec::new(),
        };
        match strip_comments(&spliced) {
            Ok((clean, clean_breaks, comment_nl)) => {
                f.clean = clean;
                f.clean_breaks = clean_breaks;
                f.comment_nl = comment_nl;
                Ok(f)
            }
            Err(at) => Err(f.location_src(back(&f.splice_breaks, at))),
        }
    }

    fn src_offset(&self, clean: usize) -> usize {
        back(&self.splice_breaks, back(&self.clean_breaks, clean)).min(self.text.len())
    }

    /// Line, column (1-based, column in characters) and line text of a
    /// byte offset of the original text.
    fn line_col(&self, off: usize) -> (usize, usize, &str) {
        let off = off.min(self.text.len());
        let idx = self.line_starts.partition_point(|&s| s <= off) - 1;
        let start = self.line_starts[idx];
        let end = self.text[start..]
            .find('\n')
            .map_or(self.text.len(), |e| start + e);
        let line = &self.text[start..end];
        let line = line.strip_suffix('\r').unwrap_or(line);
        let col = self.text.as_bytes()[start..off]
            .iter()
            .filter(|&&b| (b & 0xC0) != 0x80)
            .count()
            + 1;
        (idx + 1, col, line)
    }

    fn location_src(&self, off: usize) -> Location {
        let (line, col, text) = self.line_col(off);
        let (snippet, caret_col) = excerpt(text, col);
        Location {
            path: self.name.clone(),
            line,
            col,
            snippet,
            caret_col,
        }
    }
}

/// Remove `\`-newline splices and the CR of CR LF.
fn splice(src: &str) -> (String, Vec<(usize, usize)>) {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut breaks = vec![(0, 0)];
    let (mut i, mut run) = (0, 0);
    while i < b.len() {
        let skip = match b[i] {
            b'\\' if b.get(i + 1) == Some(&b'\n') => 2,
            b'\\' if b.get(i + 1) == Some(&b'\r') && b.get(i + 2) == Some(&b'\n') => 3,
            b'\r' if b.get(i + 1) == Some(&b'\n') => 1,
            _ => 0,
        };
        if skip == 0 {
            i += 1;
            continue;
        }
        out.push_str(&src[run..i]);
        i += skip;
        run = i;
        breaks.push((out.len(), i));
    }
    out.push_str(&src[run..]);
    (out, breaks)
}

type Stripped = (String, Vec<(usize, usize)>, Vec<(usize, u32)>);

/// Replace comments by one space; `Err(offset)` of an unterminated `/*`.
fn strip_comments(s: &str) -> Result<Stripped, usize> {
    let b = s.as_bytes();
    let mut out = String::with_capacity(s.len());
    let mut breaks = vec![(0, 0)];
    let mut nls = Vec::new();
    let (mut i, mut run) = (0, 0);
    while i < b.len() {
        match b[i] {
            q @ (b'"' | b'\'') => {
                let mut j = i + 1;
                while j < b.len() && b[j] != q && b[j] != b'\n' {
                    j += if b[j] == b'\\' && j + 1 < b.len() && b[j + 1] != b'\n' {
                        2
                    } else {
                        1
                    };
                }
                i = if j < b.len() && b[j] == q { j + 1 } else { j };
            }
            b'/' if matches!(b.get(i + 1), Some(b'*') | Some(b'/')) => {
                let end = if b[i + 1] == b'*' {
                    match s[i + 2..].find("*/") {
                        Some(e) => i + 2 + e + 2,
                        None => return Err(i),
                    }
                } else {
                    s[i..].find('\n').map_or(b.len(), |e| i + e)
                };
                out.push_str(&s[run..i]);
                breaks.push((out.len(), i));
                let n = b[i..end].iter().filter(|&&c| c == b'\n').count() as u32;
                if n > 0 {
                    nls.push((out.len(), n));
                }
                out.push(' ');
                breaks.push((out.len(), end));
                i = end;
                run = end;
            }
            _ => i += 1,
        }
    }
    out.push_str(&s[run..]);
    Ok((out, breaks, nls))
}

/// Drop `.` components and resolve `..` lexically.
fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if matches!(out.components().next_back(), Some(Component::Normal(_))) {
                    out.pop();
                } else {
                    out.push("..");
                }
            }
            c => out.push(c.as_os_str()),
        }
    }
    out
}

fn include_path(including: &Path, name: &str) -> PathBuf {
    let dir = including.parent().unwrap_or(Path::new(""));
    dir.join(name)
        .components()
        .filter(|c| *c != Component::CurDir)
        .collect()
}

// ---------------------------------------------------------------- map

/// A place in a file's cleaned text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pos {
    file: u32,
    off: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SegKind {
    /// Copied text: byte `k` of the segment is byte `a + k`.
    Text,
    /// Every byte maps to `a` (newlines of comments, end of file).
    Fixed,
    /// A macro argument spelled in the text at `a + k`, in the call at `b`.
    Arg,
    /// A macro body token spelled at `a + k`, in the call at `b`.
    Body,
    /// Made by `#`/`##`/`defined` in the call at `b`.
    Synth,
}

#[derive(Clone, Copy, Debug)]
struct Seg {
    out: usize,
    kind: SegKind,
    a: Pos,
    b: Pos,
}

/// A place in an original file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Loc<'a> {
    pub file: &'a str,
    pub line: usize,
    pub col: usize,
}

/// Where an output byte comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Origin<'a> {
    /// The place to report: the text itself, or, for text that a macro
    /// body produced, the macro call.
    pub at: Loc<'a>,
    /// The outermost macro call the byte was produced by, if any.
    pub macro_use: Option<Loc<'a>>,
    /// Where the byte was written in a `#define` body, if it was.
    pub macro_def: Option<Loc<'a>>,
}

/// Maps offsets of the preprocessed text back to the original files.
#[derive(Debug)]
pub struct SourceMap {
    files: Vec<SourceFile>,
    segs: Vec<Seg>,
}

impl SourceMap {
    fn loc(&self, p: Pos, delta: usize) -> (usize, usize) {
        let f = &self.files[p.file as usize];
        (p.file as usize, f.src_offset(p.off as usize + delta))
    }

    fn to_loc(&self, (file, off): (usize, usize)) -> Loc<'_> {
        let f = &self.files[file];
        let (line, col, _) = f.line_col(off);
        Loc {
            file: &f.name,
            line,
            col,
        }
    }

    /// (primary, use, def) as (file index, original offset).
    fn resolve(&self, offset: usize) -> [Option<(usize, usize)>; 3] {
        let i = self.segs.partition_point(|s| s.out <= offset);
        let Some(s) = self.segs.get(i.wrapping_sub(1)) else {
            return [Some((0, 0)), None, None];
        };
        let d = offset - s.out;
        match s.kind {
            SegKind::Text => [Some(self.loc(s.a, d)), None, None],
            SegKind::Fixed => [Some(self.loc(s.a, 0)), None, None],
            SegKind::Arg => {
                let u = self.loc(s.b, 0);
                [Some(self.loc(s.a, d)), Some(u), None]
            }
            SegKind::Body => {
                let u = self.loc(s.b, 0);
                [Some(u), Some(u), Some(self.loc(s.a, d))]
            }
            SegKind::Synth => {
                let u = self.loc(s.b, 0);
                [Some(u), Some(u), None]
            }
        }
    }

    /// Original file, line and column of byte `offset` of the output (for
    /// text made by a macro body: the macro call). Offsets past the end give
    /// the last place.
    pub fn locate(&self, offset: usize) -> Loc<'_> {
        self.origin(offset).at
    }

    /// Everything known about byte `offset`: see [`Origin`].
    pub fn origin(&self, offset: usize) -> Origin<'_> {
        let [at, u, d] = self.resolve(offset);
        Origin {
            at: self.to_loc(at.unwrap_or((0, 0))),
            macro_use: u.map(|x| self.to_loc(x)),
            macro_def: d.map(|x| self.to_loc(x)),
        }
    }

    #[cfg(test)]
    pub(crate) fn pieces(&self) -> usize {
        self.segs.len()
    }

    /// A located error position (with the source line) for byte `offset`.
    pub fn location(&self, offset: usize) -> Location {
        let [at, _, _] = self.resolve(offset);
        let (file, off) = at.unwrap_or((0, 0));
        self.files[file].location_src(off)
    }
}

/// The preprocessed text, its map back to the sources, and the warnings.
#[derive(Debug)]
pub struct Output {
    pub text: String,
    pub map: SourceMap,
    pub warnings: Vec<Warning>,
}

// ---------------------------------------------------------------- tokens

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum K {
    Space,
    Newline,
    Ident,
    Number,
    Str,
    Char,
    LParen,
    RParen,
    Comma,
    Hash,
    HashHash,
    /// A run of other characters (operators, module symbols, ...).
    Other,
    /// An unterminated `"` or `'` literal (lexing only).
    BadLit,
    /// Empty macro argument next to `##`.
    Placemarker,
    /// In macro bodies: a parameter, `#parameter`, the `##` operator.
    Param,
    Stringify,
    Paste,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Org {
    /// Spelled in the text outside `#define`.
    Src,
    /// Spelled in a `#define` body.
    Body,
    /// Made by the preprocessor.
    Synth,
}

#[derive(Clone, Debug)]
struct Tok {
    kind: K,
    org: Org,
    /// Where it was spelled (for `Synth`: where it was made).
    at: Pos,
    len: u32,
    /// The outermost macro call that produced it.
    usage: Option<Pos>,
    hide: u32,
    /// Newlines of comments inside a `Space`.
    nl: u32,
    /// Parameter index of `Param`/`Stringify`.
    arg: u32,
    own: Option<Rc<str>>,
}

impl Tok {
    fn src(kind: K, file: u32, off: usize, len: usize) -> Tok {
        Tok {
            kind,
            org: Org::Src,
            at: Pos {
                file,
                off: off as u32,
            },
            len: len as u32,
            usage: None,
            hide: 0,
            nl: 0,
            arg: u32::MAX,
            own: None,
        }
    }

    fn synth(kind: K, text: &str, at: Pos, usage: Option<Pos>) -> Tok {
        Tok {
            kind,
            org: Org::Synth,
            at,
            len: text.len() as u32,
            usage,
            hide: 0,
            nl: 0,
            arg: u32::MAX,
            own: Some(text.into()),
        }
    }

    /// The place to report for this token.
    fn primary(&self) -> Pos {
        match self.org {
            Org::Src => self.at,
            _ => self.usage.unwrap_or(self.at),
        }
    }

    fn is_space(&self) -> bool {
        matches!(self.kind, K::Space | K::Newline)
    }
}

fn text_of<'a>(files: &'a [SourceFile], t: &'a Tok) -> &'a str {
    match &t.own {
        Some(s) => s,
        None => {
            let c = &files[t.at.file as usize].clean;
            let o = t.at.off as usize;
            c.get(o..(o + t.len as usize).min(c.len())).unwrap_or("")
        }
    }
}

fn is_hspace(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\x0b' | b'\x0c' | b'\r')
}

fn is_idstart(c: u8) -> bool {
    c.is_ascii_alphabetic() || c == b'_' || c == b'$'
}

fn is_idchar(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'$'
}

/// The token starting at `b[i]` (`i < end`): its kind and end.
fn lex(b: &[u8], i: usize, end: usize) -> (K, usize) {
    let c = b[i];
    let number_at = |j: usize| {
        b[j].is_ascii_digit() || (b[j] == b'.' && j + 1 < end && b[j + 1].is_ascii_digit())
    };
    let mut j = i + 1;
    let kind = if is_hspace(c) {
        while j < end && is_hspace(b[j]) {
            j += 1;
        }
        K::Space
    } else if is_idstart(c) {
        while j < end && is_idchar(b[j]) {
            j += 1;
        }
        K::Ident
    } else if number_at(i) {
        while j < end && (is_idchar(b[j]) || b[j] == b'.') {
            let e = matches!(b[j], b'e' | b'E' | b'p' | b'P');
            j += 1;
            if e && j < end && matches!(b[j], b'+' | b'-') {
                j += 1;
            }
        }
        K::Number
    } else if c == b'"' || c == b'\'' {
        loop {
            if j >= end {
                return (K::BadLit, end);
            }
            if b[j] == c {
                j += 1;
                break;
            }
            j += if b[j] == b'\\' && j + 1 < end { 2 } else { 1 };
        }
        if c == b'"' {
            K::Str
        } else {
            K::Char
        }
    } else {
        match c {
            b'(' => K::LParen,
            b')' => K::RParen,
            b',' => K::Comma,
            b'#' if j < end && b[j] == b'#' => {
                j += 1;
                K::HashHash
            }
            b'#' => K::Hash,
            _ => {
                while j < end
                    && !(is_hspace(b[j])
                        || is_idchar(b[j])
                        || number_at(j)
                        || matches!(b[j], b'"' | b'\'' | b'(' | b')' | b',' | b'#'))
                {
                    j += 1;
                }
                K::Other
            }
        }
    };
    (kind, j)
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
    warnings: Vec<Warning>,
    macros: HashMap<String, usize>,
    defs: Vec<Macro>,
    hidesets: Vec<Vec<u32>>,
    hide_index: HashMap<Vec<u32>, u32>,
    frames: Vec<Frame>,
    conds: Vec<Cond>,
    loader: &'l dyn Fn(&Path) -> io::Result<String>,
    limits: Limits,
    work: usize,
}

type Res<T> = Result<T, PpError>;

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

/// [`preprocess`] with explicit limits.
pub fn preprocess_with(
    path: &Path,
    source: &str,
    loader: &dyn Fn(&Path) -> io::Result<String>,
    limits: &Limits,
) -> Result<Output, PpError> {
    let mut pp = Pp {
        files: Vec::new(),
        text: String::new(),
        segs: Vec::new(),
        warnings: Vec::new(),
        macros: HashMap::new(),
        defs: Vec::new(),
        hidesets: vec![Vec::new()],
        hide_index: HashMap::new(),
        frames: Vec::new(),
        conds: Vec::new(),
        loader,
        limits: limits.clone(),
        work: 0,
    };
    let name = path.display().to_string();
    pp.open(name, path.to_path_buf(), source.to_string())?;
    pp.run()?;
    Ok(Output {
        text: pp.text,
        map: SourceMap {
            files: pp.files,
            segs: pp.segs,
        },
        warnings: pp.warnings,
    })
}

impl Pp<'_> {
    // ------------------------------------------------------------ places

    fn location(&self, p: Pos) -> Location {
        let f = &self.files[p.file as usize];
        f.location_src(f.src_offset(p.off as usize))
    }

    fn err(&self, p: Pos, kind: PpErrorKind) -> PpError {
        PpError {
            at: self.location(p),
            kind,
        }
    }

    fn warn(&mut self, p: Pos, message: crate::diag::Warning) {
        let at = self.location(p);
        self.warnings.push(Warning { at, message });
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
                    self.warn(p, crate::diag::Warning::HashModule);
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
            let t = self.lex_one(file, i, end)?;
            i += t.len as usize;
            v.push(t);
        }
        Ok(v)
    }

    fn lex_one(&self, file: u32, i: usize, end: usize) -> Res<Tok> {
        let f = &self.files[file as usize];
        let (kind, j) = lex(f.clean.as_bytes(), i, end);
        let mut t = Tok::src(kind, file, i, j - i);
        match kind {
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
                let t = self.lex_one(cur.file, cur.pos, cur.eol)?;
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
                    "warning" => self.warn(at, crate::diag::Warning::UserDirective(msg)),
                    _ => self.warn(at, crate::diag::Warning::PragmaIgnored),
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
                crate::diag::Warning::ExtraTokens(directive.to_string()),
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
                crate::diag::Warning::ExtraTokens(format!("{directive} {n}")),
            );
        }
        Ok(n)
    }

    fn define(&mut self, toks: Vec<Tok>, at: Pos) -> Res<()> {
        let bad = |s: &Self, p: Pos, e: DirectiveError| s.err(p, PpErrorKind::InvalidDirective(e));
        let mut i = 0;
        while i < toks.len() && toks[i].is_space() {
            i += 1;
        }
        let Some(nt) = toks.get(i).filter(|t| t.kind == K::Ident) else {
            let p = toks.get(i).map_or(at, |t| t.at);
            return Err(bad(
                self,
                p,
                DirectiveError::NeedsMacroName("#define".to_string()),
            ));
        };
        let name = self.text(nt).to_string();
        if name == "defined" {
            return Err(bad(self, nt.at, DirectiveError::DefinedAsName));
        }
        if name == "__VA_ARGS__" {
            return Err(self.err(nt.at, PpErrorKind::NotSupported(PpConstruct::VaArgs)));
        }
        i += 1;
        let mut params = None;
        if toks.get(i).is_some_and(|t| t.kind == K::LParen) {
            let mut ps: Vec<String> = Vec::new();
            let open = toks[i].at;
            i += 1;
            let skip = |i: &mut usize| {
                while *i < toks.len() && toks[*i].is_space() {
                    *i += 1;
                }
            };
            skip(&mut i);
            if toks.get(i).is_some_and(|t| t.kind == K::RParen) {
                i += 1;
            } else {
                loop {
                    skip(&mut i);
                    let Some(t) = toks.get(i) else {
                        return Err(bad(self, open, DirectiveError::ParamListNotClosed));
                    };
                    let s = self.text(t);
                    if t.kind == K::Other && s.starts_with("...") || s == "__VA_ARGS__" {
                        return Err(
                            self.err(t.at, PpErrorKind::NotSupported(PpConstruct::Ellipsis))
                        );
                    }
                    if t.kind != K::Ident {
                        return Err(bad(self, t.at, DirectiveError::ExpectedParamName));
                    }
                    if ps.iter().any(|p| p == s) {
                        let e = DirectiveError::DuplicateParam(s.to_string());
                        return Err(bad(self, t.at, e));
                    }
                    ps.push(s.to_string());
                    i += 1;
                    skip(&mut i);
                    match toks.get(i).map(|t| t.kind) {
                        Some(K::Comma) => i += 1,
                        Some(K::RParen) => {
                            i += 1;
                            break;
                        }
                        Some(_) => {
                            let p = toks[i].at;
                            return Err(bad(self, p, DirectiveError::ExpectedCommaOrParen));
                        }
                        None => return Err(bad(self, open, DirectiveError::ParamListNotClosed)),
                    }
                }
            }
            params = Some(ps);
        }
        // The body: trimmed, white space runs as one space, operators marked.
        let mut body: Vec<Tok> = Vec::new();
        for t in &toks[i..] {
            let mut t = t.clone();
            t.org = Org::Body;
            t.nl = 0;
            if t.is_space() {
                if body.last().is_some_and(|l| l.kind != K::Space) {
                    t.kind = K::Space;
                    t.len = 1;
                    body.push(t);
                }
                continue;
            }
            if t.kind == K::Ident && self.text(&t) == "__VA_ARGS__" {
                return Err(self.err(t.at, PpErrorKind::NotSupported(PpConstruct::VaArgs)));
            }
            if let Some(ps) = &params {
                if t.kind == K::Ident {
                    if let Some(k) = ps.iter().position(|p| p == self.text(&t)) {
                        t.kind = K::Param;
                        t.arg = k as u32;
                    }
                }
            }
            if t.kind == K::HashHash {
                t.kind = K::Paste;
                if body.last().is_some_and(|l| l.kind == K::Space) {
                    body.pop();
                }
            }
            if body.last().is_some_and(|l| l.kind == K::Space)
                && body.len() >= 2
                && body[body.len() - 2].kind == K::Paste
            {
                body.pop();
            }
            body.push(t);
        }
        if body.last().is_some_and(|l| l.kind == K::Space) {
            body.pop();
        }
        if let Some(t) = [body.first(), body.last()]
            .into_iter()
            .flatten()
            .find(|t| t.kind == K::Paste)
        {
            return Err(bad(self, t.at, DirectiveError::PasteAtEnd));
        }
        if params.is_some() {
            // `#` must be followed by a parameter: stringification.
            let mut out: Vec<Tok> = Vec::with_capacity(body.len());
            let mut k = 0;
            while k < body.len() {
                if body[k].kind == K::Hash {
                    let mut n = k + 1;
                    if body.get(n).is_some_and(|t| t.kind == K::Space) {
                        n += 1;
                    }
                    match body.get(n) {
                        Some(p) if p.kind == K::Param => {
                            let mut s = body[k].clone();
                            s.kind = K::Stringify;
                            s.arg = p.arg;
                            out.push(s);
                            k = n + 1;
                            continue;
                        }
                        _ => {
                            return Err(self.err(
                                body[k].at,
                                PpErrorKind::InvalidDirective(DirectiveError::StringifyNeedsParam),
                            ));
                        }
                    }
                }
                out.push(body[k].clone());
                k += 1;
            }
            body = out;
        }
        let m = Macro { params, body };
        if let Some(&old) = self.macros.get(&name) {
            if !self.same_macro(&self.defs[old], &m) {
                self.warn(nt.at, crate::diag::Warning::MacroRedefined(name.clone()));
            }
        }
        self.defs.push(m);
        self.macros.insert(name, self.defs.len() - 1);
        Ok(())
    }

    fn same_macro(&self, a: &Macro, b: &Macro) -> bool {
        a.params == b.params
            && a.body.len() == b.body.len()
            && a.body
                .iter()
                .zip(&b.body)
                .all(|(x, y)| x.kind == y.kind && x.arg == y.arg && self.text(x) == self.text(y))
    }

    fn include(&mut self, file: u32, toks: Vec<Tok>, at: Pos) -> Res<()> {
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
            self.warn(p, crate::diag::Warning::ExtraTokens("#include".to_string()));
        }
        let quoted = self.text(&toks[k]);
        let name = quoted[1..quoted.len() - 1].to_string();
        if name.is_empty() {
            let e = DirectiveError::IncludeEmptyName;
            return Err(self.err(name_at, PpErrorKind::InvalidDirective(e)));
        }
        if self.frames.len() >= self.limits.max_include_depth {
            return Err(self.err(
                at,
                PpErrorKind::Limit {
                    what: "#include nested too deeply",
                    limit: self.limits.max_include_depth,
                },
            ));
        }
        let path = include_path(&self.files[file as usize].path, &name);
        let key = normalize(&path);
        if let Some(i) = self
            .frames
            .iter()
            .position(|fr| self.files[fr.file as usize].key == key)
        {
            let mut chain: Vec<String> = self.frames[i..]
                .iter()
                .map(|fr| self.files[fr.file as usize].name.clone())
                .collect();
            chain.push(path.display().to_string());
            return Err(self.err(at, PpErrorKind::IncludeCycle(chain.join(" -> "))));
        }
        let text = (self.loader)(&path).map_err(|source| {
            self.err(
                name_at,
                PpErrorKind::IncludeFailed {
                    path: path.clone(),
                    source,
                },
            )
        })?;
        self.open(path.display().to_string(), path, text)
    }

    // ------------------------------------------------------------ expansion

    fn hide_union(&mut self, a: u32, add: &[u32]) -> u32 {
        let mut v = self.hidesets[a as usize].clone();
        for &m in add {
            if let Err(k) = v.binary_search(&m) {
                v.insert(k, m);
            }
        }
        self.intern(v)
    }

    fn hide_intersect(&mut self, a: u32, b: u32) -> u32 {
        let v: Vec<u32> = self.hidesets[a as usize]
            .iter()
            .filter(|m| self.hidesets[b as usize].binary_search(m).is_ok())
            .copied()
            .collect();
        self.intern(v)
    }

    fn intern(&mut self, v: Vec<u32>) -> u32 {
        if v.is_empty() {
            return 0;
        }
        if let Some(&i) = self.hide_index.get(&v) {
            return i;
        }
        self.hidesets.push(v.clone());
        let i = (self.hidesets.len() - 1) as u32;
        self.hide_index.insert(v, i);
        i
    }

    /// The macro `t` names, unless `t` is hidden from it.
    fn expandable(&self, t: &Tok) -> Option<usize> {
        if t.kind != K::Ident || self.macros.is_empty() {
            return None;
        }
        let m = *self.macros.get(self.text(t))?;
        let hidden = self.hidesets[t.hide as usize]
            .binary_search(&(m as u32))
            .is_ok();
        (!hidden).then_some(m)
    }

    fn charge(&mut self, n: usize, at: Pos) -> Res<()> {
        self.work += n;
        if self.work > self.limits.max_expansion_tokens {
            return Err(self.err(
                at,
                PpErrorKind::Limit {
                    what: "macro expansion too large",
                    limit: self.limits.max_expansion_tokens,
                },
            ));
        }
        Ok(())
    }

    /// Expand `pending` followed by the cursor's text (if any), writing to
    /// `out` or, without `out`, to the output text.
    fn expand(
        &mut self,
        pending: &mut VecDeque<Tok>,
        mut cur: Option<&mut Cursor>,
        mut out: Option<&mut Vec<Tok>>,
        depth: usize,
    ) -> Res<()> {
        while let Some(t) = self.next_tok(pending, cur.as_deref_mut(), false)? {
            let Some(m) = self.expandable(&t) else {
                match out.as_deref_mut() {
                    Some(v) => v.push(t),
                    None => self.emit(&t)?,
                }
                continue;
            };
            let usage = t.usage.unwrap_or(t.at);
            let body = if self.defs[m].params.is_none() {
                let hs = self.hide_union(t.hide, &[m as u32]);
                self.subst(m, Vec::new(), hs, usage, depth)?
            } else {
                // A function-like macro name is a call only before `(`.
                let mut skipped = Vec::new();
                let mut call = false;
                while let Some(x) = self.next_tok(pending, cur.as_deref_mut(), true)? {
                    if x.is_space() {
                        skipped.push(x);
                        continue;
                    }
                    call = x.kind == K::LParen;
                    if !call {
                        skipped.push(x);
                    }
                    break;
                }
                if !call {
                    for x in skipped.into_iter().rev() {
                        pending.push_front(x);
                    }
                    match out.as_deref_mut() {
                        Some(v) => v.push(t),
                        None => self.emit(&t)?,
                    }
                    continue;
                }
                let (args, rparen) = self.collect_args(m, &t, pending, cur.as_deref_mut())?;
                let hs = self.hide_intersect(t.hide, rparen.hide);
                let hs = self.hide_union(hs, &[m as u32]);
                self.subst(m, args, hs, usage, depth)?
            };
            for x in body.into_iter().rev() {
                pending.push_front(x);
            }
        }
        Ok(())
    }

    /// The arguments of a call of `m` (named by `name`, after its `(`) and
    /// the closing `)`.
    fn collect_args(
        &mut self,
        m: usize,
        name: &Tok,
        pending: &mut VecDeque<Tok>,
        mut cur: Option<&mut Cursor>,
    ) -> Res<(Vec<Vec<Tok>>, Tok)> {
        let mut args: Vec<Vec<Tok>> = vec![Vec::new()];
        let mut level = 0usize;
        let at = name.primary();
        let rparen = loop {
            let Some(mut x) = self.next_tok(pending, cur.as_deref_mut(), true)? else {
                let n = self.text(name).to_string();
                let e = MacroError::UnterminatedArgs(n);
                return Err(self.err(at, PpErrorKind::Macro(e)));
            };
            self.charge(1, at)?;
            match x.kind {
                K::LParen => level += 1,
                K::RParen if level == 0 => break x,
                K::RParen => level -= 1,
                K::Comma if level == 0 => {
                    args.push(Vec::new());
                    continue;
                }
                K::Newline => {
                    x.kind = K::Space;
                    x.nl = 0;
                }
                K::Space => x.nl = 0,
                _ => {}
            }
            args.last_mut().unwrap().push(x);
        };
        for a in &mut args {
            while a.last().is_some_and(|t| t.is_space()) {
                a.pop();
            }
            let lead = a.iter().take_while(|t| t.is_space()).count();
            a.drain(..lead);
        }
        let want = self.defs[m].params.as_ref().map_or(0, |p| p.len());
        if want == 0 && args.len() == 1 && args[0].is_empty() {
            args.clear();
        }
        if args.len() != want {
            let n = self.text(name).to_string();
            let e = MacroError::Arity {
                name: n,
                want,
                given: args.len(),
            };
            return Err(self.err(at, PpErrorKind::Macro(e)));
        }
        Ok((args, rparen))
    }

    /// The replacement of a call of `m`: parameters substituted, `#` and `##`
    /// applied, hide set `hs` added, every token marked as from `usage`.
    fn subst(
        &mut self,
        m: usize,
        args: Vec<Vec<Tok>>,
        hs: u32,
        usage: Pos,
        depth: usize,
    ) -> Res<Vec<Tok>> {
        if depth >= self.limits.max_expansion_depth {
            return Err(self.err(
                usage,
                PpErrorKind::Limit {
                    what: "macro calls nested too deeply in macro arguments",
                    limit: self.limits.max_expansion_depth,
                },
            ));
        }
        let body = self.defs[m].body.clone();
        self.charge(body.len(), usage)?;
        let mut expanded: Vec<Option<Vec<Tok>>> = vec![None; args.len()];
        let mut res: Vec<Tok> = Vec::with_capacity(body.len());
        for (i, bt) in body.iter().enumerate() {
            match bt.kind {
                K::Stringify => {
                    let s = self.stringify(&args[bt.arg as usize]);
                    res.push(Tok::synth(K::Str, &s, bt.at, Some(usage)));
                }
                K::Param => {
                    let a = bt.arg as usize;
                    let pasted = (i > 0 && body[i - 1].kind == K::Paste)
                        || body.get(i + 1).is_some_and(|t| t.kind == K::Paste);
                    if pasted {
                        if args[a].is_empty() {
                            res.push(Tok::synth(K::Placemarker, "", bt.at, Some(usage)));
                        } else {
                            self.charge(args[a].len(), usage)?;
                            res.extend(args[a].iter().cloned());
                        }
                    } else {
                        if expanded[a].is_none() {
                            let mut dq: VecDeque<Tok> = args[a].iter().cloned().collect();
                            let mut v = Vec::new();
                            self.expand(&mut dq, None, Some(&mut v), depth + 1)?;
                            expanded[a] = Some(v);
                        }
                        let v = expanded[a].as_ref().unwrap();
                        self.charge(v.len(), usage)?;
                        res.extend(v.iter().cloned());
                    }
                }
                _ => res.push(bt.clone()),
            }
        }
        // `##`
        let mut out: Vec<Tok> = Vec::with_capacity(res.len());
        let mut it = res.into_iter();
        while let Some(t) = it.next() {
            if t.kind != K::Paste {
                out.push(t);
                continue;
            }
            let (Some(l), Some(r)) = (out.pop(), it.next()) else {
                continue; // cannot happen: `##` is never at an end
            };
            out.push(self.paste(l, r, usage)?);
        }
        out.retain(|t| t.kind != K::Placemarker);
        for t in &mut out {
            if t.usage.is_none() {
                t.usage = Some(usage);
            }
        }
        let add = self.hidesets[hs as usize].clone();
        for t in &mut out {
            t.hide = match t.hide {
                0 => hs,
                h if h == hs => hs,
                h => self.hide_union(h, &add),
            };
        }
        Ok(out)
    }

    fn stringify(&self, arg: &[Tok]) -> String {
        let mut s = String::from("\"");
        for t in arg {
            if t.is_space() {
                s.push(' ');
                continue;
            }
            let x = self.text(t);
            if matches!(t.kind, K::Str | K::Char) {
                for c in x.chars() {
                    if c == '"' || c == '\\' {
                        s.push('\\');
                    }
                    s.push(c);
                }
            } else {
                s.push_str(x);
            }
        }
        s.push('"');
        s
    }

    fn paste(&mut self, l: Tok, r: Tok, usage: Pos) -> Res<Tok> {
        if l.kind == K::Placemarker {
            return Ok(r);
        }
        if r.kind == K::Placemarker {
            return Ok(l);
        }
        let s = format!("{}{}", self.text(&l), self.text(&r));
        let (kind, end) = lex(s.as_bytes(), 0, s.len());
        if end != s.len() || matches!(kind, K::BadLit | K::Space) {
            let e = MacroError::Paste {
                left: self.text(&l).to_string(),
                right: self.text(&r).to_string(),
            };
            return Err(self.err(usage, PpErrorKind::Macro(e)));
        }
        Ok(Tok::synth(kind, &s, l.at, Some(usage)))
    }

    // ------------------------------------------------------------ #if

    fn eval_if(&mut self, toks: Vec<Tok>, at: Pos) -> Res<bool> {
        // `defined` before expansion.
        let mut v: Vec<Tok> = Vec::with_capacity(toks.len());
        let mut i = 0;
        while i < toks.len() {
            let t = &toks[i];
            if !(t.kind == K::Ident && self.text(t) == "defined") {
                v.push(t.clone());
                i += 1;
                continue;
            }
            let d = t.at;
            let mut j = i + 1;
            let skip = |j: &mut usize| {
                while *j < toks.len() && toks[*j].is_space() {
                    *j += 1;
                }
            };
            skip(&mut j);
            let paren = toks.get(j).is_some_and(|t| t.kind == K::LParen);
            if paren {
                j += 1;
                skip(&mut j);
            }
            let Some(n) = toks.get(j).filter(|t| t.kind == K::Ident) else {
                return Err(self.err(d, PpErrorKind::BadExpression(IfError::DefinedNeedsName)));
            };
            let yes = self.macros.contains_key(self.text(n));
            j += 1;
            if paren {
                skip(&mut j);
                if !toks.get(j).is_some_and(|t| t.kind == K::RParen) {
                    let e = IfError::DefinedNotClosed;
                    return Err(self.err(d, PpErrorKind::BadExpression(e)));
                }
                j += 1;
            }
            v.push(Tok::synth(K::Number, if yes { "1" } else { "0" }, d, None));
            i = j;
        }
        let mut dq: VecDeque<Tok> = v.into();
        let mut out = Vec::new();
        self.expand(&mut dq, None, Some(&mut out), 0)?;
        let mut ex: Vec<(E, Pos)> = Vec::new();
        for t in out.iter().filter(|t| !t.is_space()) {
            let p = t.primary();
            let s = self.text(t);
            let bad = |e: IfError| self.err(p, PpErrorKind::BadExpression(e));
            match t.kind {
                K::Number => ex.push((E::Num(parse_int(s).map_err(bad)?), p)),
                K::Char => ex.push((E::Num(parse_char(s).map_err(bad)?), p)),
                K::Ident => ex.push((E::Num(0), p)),
                K::LParen => ex.push((E::Op("("), p)),
                K::RParen => ex.push((E::Op(")"), p)),
                K::Comma => ex.push((E::Op(","), p)),
                K::Other => {
                    let mut k = 0;
                    while k < s.len() {
                        let Some(op) = OPS.iter().find(|o| s[k..].starts_with(**o)) else {
                            let c = s[k..].chars().next().unwrap();
                            return Err(bad(IfError::Unexpected(c.to_string())));
                        };
                        let q = Pos {
                            file: p.file,
                            off: if t.org == Org::Src {
                                p.off + k as u32
                            } else {
                                p.off
                            },
                        };
                        ex.push((E::Op(op), q));
                        k += op.len();
                    }
                }
                _ => return Err(bad(IfError::Unexpected(s.to_string()))),
            }
        }
        if ex.is_empty() {
            return Err(self.err(at, PpErrorKind::BadExpression(IfError::Empty)));
        }
        let end = out
            .iter()
            .rfind(|t| !t.is_space())
            .map_or(at, |t| match t.org {
                Org::Src => Pos {
                    file: t.at.file,
                    off: t.at.off + t.len,
                },
                _ => t.primary(),
            });
        let mut p = ExprParser {
            toks: &ex,
            i: 0,
            end,
            depth: 0,
        };
        let r = p.comma(true);
        let r = r.and_then(|v| match p.toks.get(p.i) {
            None => Ok(v),
            Some((E::Op(o), q)) => Err((IfError::Unexpected(o.to_string()), *q)),
            Some((E::Num(_), q)) => Err((IfError::MissingOperator, *q)),
        });
        r.map(|v| v != 0)
            .map_err(|(e, q)| self.err(q, PpErrorKind::BadExpression(e)))
    }
}

// ---------------------------------------------------------------- #if values

#[derive(Clone, Copy, Debug)]
enum E {
    Num(i64),
    Op(&'static str),
}

/// Longest first.
const OPS: &[&str] = &[
    "||", "&&", "==", "!=", "<=", ">=", "<<", ">>", "<", ">", "+", "-", "*", "/", "%", "&", "|",
    "^", "!", "~", "?", ":",
];

fn parse_int(s: &str) -> Result<i64, IfError> {
    let body = s.trim_end_matches(['u', 'U', 'l', 'L']);
    let bad = || IfError::NotInteger(s.to_string());
    let (digits, radix) = if let Some(h) = body.strip_prefix("0x").or(body.strip_prefix("0X")) {
        (h, 16)
    } else if body.len() > 1 && body.starts_with('0') {
        (&body[1..], 8)
    } else {
        (body, 10)
    };
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return Err(bad());
    }
    u64::from_str_radix(digits, radix)
        .map(|v| v as i64)
        .map_err(|_| IfError::IntegerTooLarge(s.to_string()))
}

fn parse_char(s: &str) -> Result<i64, IfError> {
    let inner = &s[1..s.len() - 1];
    let mut cs = inner.chars();
    let v = match (cs.next(), cs.next(), cs.next()) {
        (Some('\\'), Some(e), None) => match e {
            'n' => 10,
            't' => 9,
            'r' => 13,
            '0' => 0,
            'a' => 7,
            'b' => 8,
            'f' => 12,
            'v' => 11,
            '\\' | '\'' | '"' | '?' => e as i64,
            _ => return Err(IfError::UnsupportedEscape(s.to_string())),
        },
        (Some(c), None, None) if c != '\\' => c as i64,
        _ => return Err(IfError::NotSingleChar(s.to_string())),
    };
    Ok(v)
}

type ERes = Result<i64, (IfError, Pos)>;

/// Precedence climbing over `#if` tokens; `ev == false` parses without
/// evaluating (the untaken side of `&&`, `||`, `?:`).
struct ExprParser<'a> {
    toks: &'a [(E, Pos)],
    i: usize,
    end: Pos,
    /// Recursion depth (parentheses, unary operators, `?:`).
    depth: usize,
}

/// Deepest `#if` nesting of parentheses, unary operators and `?:`.
const MAX_EXPR_DEPTH: usize = 128;

impl ExprParser<'_> {
    fn peek_op(&self) -> Option<&'static str> {
        match self.toks.get(self.i) {
            Some((E::Op(o), _)) => Some(o),
            _ => None,
        }
    }

    fn pos(&self) -> Pos {
        self.toks.get(self.i).map_or(self.end, |t| t.1)
    }

    fn comma(&mut self, ev: bool) -> ERes {
        let mut v = self.cond(ev)?;
        while self.peek_op() == Some(",") {
            self.i += 1;
            v = self.cond(ev)?;
        }
        Ok(v)
    }

    fn enter(&mut self) -> Result<(), (IfError, Pos)> {
        self.depth += 1;
        if self.depth > MAX_EXPR_DEPTH {
            return Err((IfError::NestedTooDeeply(MAX_EXPR_DEPTH), self.pos()));
        }
        Ok(())
    }

    fn cond(&mut self, ev: bool) -> ERes {
        let c = self.binary(0, ev)?;
        if self.peek_op() != Some("?") {
            return Ok(c);
        }
        self.enter()?;
        self.i += 1;
        let a = self.comma(ev && c != 0)?;
        if self.peek_op() != Some(":") {
            return Err((IfError::MissingColon, self.pos()));
        }
        self.i += 1;
        let b = self.cond(ev && c == 0)?;
        self.depth -= 1;
        Ok(if c != 0 { a } else { b })
    }

    /// Operators of precedence `level` and higher (0 is `||`).
    fn binary(&mut self, level: usize, ev: bool) -> ERes {
        const LEVELS: &[&[&str]] = &[
            &["||"],
            &["&&"],
            &["|"],
            &["^"],
            &["&"],
            &["==", "!="],
            &["<", ">", "<=", ">="],
            &["<<", ">>"],
            &["+", "-"],
            &["*", "/", "%"],
        ];
        // Precedence climbing: operators of level >= `level`, left to right.
        let mut a = self.unary(ev)?;
        while let Some(op) = self.peek_op() {
            let Some(p) = LEVELS.iter().position(|l| l.contains(&op)) else {
                break;
            };
            if p < level {
                break;
            }
            let at = self.pos();
            self.i += 1;
            let ev_b = match op {
                "||" => ev && a == 0,
                "&&" => ev && a != 0,
                _ => ev,
            };
            let b = self.binary(p + 1, ev_b)?;
            a = match op {
                "||" => (a != 0 || b != 0) as i64,
                "&&" => (a != 0 && b != 0) as i64,
                "|" => a | b,
                "^" => a ^ b,
                "&" => a & b,
                "==" => (a == b) as i64,
                "!=" => (a != b) as i64,
                "<" => (a < b) as i64,
                ">" => (a > b) as i64,
                "<=" => (a <= b) as i64,
                ">=" => (a >= b) as i64,
                "<<" => shift(a, b),
                ">>" => shift(a, b.wrapping_neg()),
                "+" => a.wrapping_add(b),
                "-" => a.wrapping_sub(b),
                "*" => a.wrapping_mul(b),
                _ if b == 0 => {
                    if ev {
                        return Err((IfError::DivisionByZero, at));
                    }
                    0
                }
                "/" => a.wrapping_div(b),
                _ => a.wrapping_rem(b),
            };
        }
        Ok(a)
    }

    fn unary(&mut self, ev: bool) -> ERes {
        self.enter()?;
        let r = self.unary_inner(ev);
        self.depth -= 1;
        r
    }

    fn unary_inner(&mut self, ev: bool) -> ERes {
        let Some((tok, at)) = self.toks.get(self.i).copied() else {
            return Err((IfError::EndsEarly, self.end));
        };
        self.i += 1;
        match tok {
            E::Num(v) => Ok(v),
            E::Op("(") => {
                let v = self.comma(ev)?;
                if self.peek_op() != Some(")") {
                    return Err((IfError::MissingParen, self.pos()));
                }
                self.i += 1;
                Ok(v)
            }
            E::Op("-") => Ok(self.unary(ev)?.wrapping_neg()),
            E::Op("+") => self.unary(ev),
            E::Op("!") => Ok((self.unary(ev)? == 0) as i64),
            E::Op("~") => Ok(!self.unary(ev)?),
            E::Op(o) => Err((IfError::Unexpected(o.to_string()), at)),
        }
    }
}

/// `a << s` for s >= 0, `a >> -s` otherwise (arithmetic, saturating).
fn shift(a: i64, s: i64) -> i64 {
    if s >= 64 {
        0
    } else if s >= 0 {
        a << s
    } else if s <= -64 {
        if a < 0 {
            -1
        } else {
            0
        }
    } else {
        a >> -s
    }
}
