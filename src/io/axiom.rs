//! Streaming axiom reader: modules one at a time from an [`Input`], with
//! line and column kept for errors. Plain numbers are read directly; any
//! other parameter text (`F(R*2)`) is parsed as an expression over the
//! `define:` constants.

use crate::derive::random::Random;
use crate::diag::{excerpt, CompileError, Error, ErrorKind, LexicalError, Location, ParseError};
use crate::io::input::Input;
use crate::lang::comment;
use crate::lang::parse::parse_expr;
use crate::rules::codec::MAX_ARITY;
use crate::rules::expr::{Code, Scope};
use crate::rules::Alphabet;
use std::collections::HashMap;

/// Longest parameter list text accepted for one module.
const MAX_PARAM_TEXT: usize = 1 << 20;

pub struct AxiomReader<'a> {
    input: Input,
    /// Recognise `/* ... */` comments (in an .ls file, not in `--axiom`).
    comments: bool,
    line: usize,
    col: usize,
    consts: &'a HashMap<String, f64>,
    text: Vec<u8>,
    stack: Vec<f64>,
    /// Bracket depth, and where the outermost open `[` was (line, column,
    /// stream offset).
    depth: u64,
    first_open: (usize, usize, u64),
    /// Where the last module started, for errors at the end of input.
    last: (usize, usize, u64),
    /// Has a byte-order mark at the very start of the stream been looked
    /// for (an `--axiom` file may start with one, as an .ls file may)?
    started: bool,
}

impl<'a> AxiomReader<'a> {
    pub fn new(
        input: Input,
        comments: bool,
        line: usize,
        col: usize,
        consts: &'a HashMap<String, f64>,
    ) -> Self {
        AxiomReader {
            input,
            comments,
            line,
            col,
            consts,
            text: Vec::new(),
            stack: Vec::new(),
            depth: 0,
            first_open: (0, 0, 0),
            last: (line, col, 0),
            started: false,
        }
    }

    /// Skip a UTF-8 byte-order mark at the start of the stream.
    fn start(&mut self) -> Result<(), Error> {
        self.started = true;
        if self.input.offset() == 0 && self.input.fill(3)?.starts_with(b"\xEF\xBB\xBF") {
            self.input.consume(3);
        }
        Ok(())
    }

    /// An error at the current read position.
    fn error_here(&mut self, msg: impl Into<ErrorKind>) -> Error {
        let at = self.input.offset();
        self.error_at(at, self.line, self.col, msg)
    }

    fn error_at(&mut self, at: u64, line: usize, col: usize, msg: impl Into<ErrorKind>) -> Error {
        let (snippet, caret_col) = if self.input.holds(at) {
            self.input.excerpt_at(at)
        } else {
            // Only a parameter list outgrows the buffer's history: quote
            // its start, the spot being its `(`.
            let head: String = String::from_utf8_lossy(&self.text)
                .chars()
                .take(60)
                .collect();
            (format!("({head}..."), 1)
        };
        Error::at(
            Location {
                path: self.input.name.clone(),
                line,
                col,
                snippet,
                caret_col,
            },
            msg,
        )
    }

    /// Advance over `n` bytes that hold no newline.
    #[inline]
    fn advance(&mut self, n: usize) {
        let cols = self.input.available()[..n]
            .iter()
            .filter(|&&b| b & 0xC0 != 0x80)
            .count();
        self.col += cols;
        self.input.consume(n);
    }

    /// Skip whitespace and comments. Returns false at end of input.
    fn skip_blank(&mut self) -> Result<bool, Error> {
        loop {
            let avail = self.input.fill(4)?;
            let Some(&b) = avail.first() else {
                return Ok(false);
            };
            match b {
                b'\n' => {
                    self.input.consume(1);
                    self.line += 1;
                    self.col = 1;
                }
                b' ' | b'\t' | b'\r' | 0x0B | 0x0C => self.advance(1),
                b'/' if self.comments && comment::opens(avail) => {
                    let (line, col, at) = (self.line, self.col, self.input.offset());
                    // An unterminated comment is reported at its start.
                    self.input.mark(at);
                    self.advance(2);
                    loop {
                        let avail = self.input.fill(2)?;
                        match avail {
                            [] | [_] => {
                                return Err(self.error_at(
                                    at,
                                    line,
                                    col,
                                    LexicalError::UnterminatedComment,
                                ))
                            }
                            c if comment::closes(c) => {
                                self.advance(comment::CLOSE.len());
                                break;
                            }
                            [b'\n', ..] => {
                                self.input.consume(1);
                                self.line += 1;
                                self.col = 1;
                            }
                            [0, ..] => return Err(self.error_here(LexicalError::Nul)),
                            [b, ..] if *b >= 0x80 => {
                                // Checked as in the header: text only.
                                let n = self.peek_char()?.map_or(1, |(_, n)| n);
                                self.advance(n);
                            }
                            _ => self.advance(1),
                        }
                    }
                }
                b if b >= 0x80 => {
                    let c = self.peek_char()?;
                    match c {
                        Some((c, n)) if c.is_whitespace() => self.advance(n),
                        _ => return Ok(true),
                    }
                }
                _ => return Ok(true),
            }
        }
    }

    /// Decode the UTF-8 character at the read position.
    fn peek_char(&mut self) -> Result<Option<(char, usize)>, Error> {
        let avail = self.input.fill(4)?;
        if avail.is_empty() {
            return Ok(None);
        }
        let n = match avail[0] {
            b if b < 0x80 => 1,
            b if b >> 5 == 0b110 => 2,
            b if b >> 4 == 0b1110 => 3,
            b if b >> 3 == 0b11110 => 4,
            _ => 0,
        };
        match avail.get(..n).map(std::str::from_utf8) {
            Some(Ok(s)) if n > 0 => Ok(Some((s.chars().next().unwrap(), n))),
            _ => Err(self.error_here(LexicalError::InvalidUtf8)),
        }
    }

    /// A run of plain modules at the read position: ASCII symbols without
    /// parameters, whose binary form is their own byte. `f` receives the
    /// run (possibly empty) before it is consumed. This is the fast path
    /// for long axioms; [`AxiomReader::next`] handles everything else.
    pub fn plain_run<T>(&mut self, f: impl FnOnce(&[u8]) -> T) -> Result<T, Error> {
        if !self.started {
            self.start()?;
        }
        let base = self.input.offset();
        let avail = self.input.fill(64)?;
        let n = avail.len();
        // One pass, one table look-up per byte: plain bytes, brackets
        // (counted on the way), and stops. With comments, `/` stops the
        // loop too: it is plain unless it opens a comment, or may (the last
        // byte buffered). A `]` that closes nothing ends the run before it
        // (reported by the general path).
        let class = if self.comments {
            &CLASS_BUT_SLASH
        } else {
            &CLASS
        };
        let mut depth = self.depth;
        let mut open_at = None;
        let mut i = 0;
        let mut unbalanced = false;
        'scan: loop {
            while i < n {
                // A block of plain bytes whose `]`s cannot close the run
                // (and so no `[` opens at depth 0): counted at once,
                // without a branch on each byte's class.
                if let Some(block) = avail.get(i..i + BLOCK) {
                    let (plain, opens, closes) = block_counts(block, self.comments);
                    if plain && closes < depth {
                        depth = depth + opens - closes;
                        i += BLOCK;
                        continue;
                    }
                }
                let end = n.min(i + BLOCK);
                while i < end {
                    match class[avail[i] as usize] {
                        C_PLAIN => {}
                        C_OPEN => {
                            if depth == 0 {
                                open_at = Some(i);
                            }
                            depth += 1;
                        }
                        C_CLOSE => {
                            if depth == 0 {
                                unbalanced = true;
                                break 'scan;
                            }
                            depth -= 1;
                        }
                        _ => break,
                    }
                    i += 1;
                }
                if i < end {
                    break; // a stop
                }
            }
            if self.comments && i + 1 < n && avail[i] == b'/' && !comment::opens(&avail[i..]) {
                i += 1;
                continue;
            }
            break;
        }
        // The last symbol may take parameters, after blanks and comments
        // too (`F(1)`, `F (1)`, `F/* c */(1)`, `F\u{a0}(1)`), or sit at the
        // end of what is buffered: leave it to the general path, which
        // applies the one rule of the language (and counts it if a bracket).
        let end = if unbalanced {
            i
        } else {
            let end = i.saturating_sub(1);
            if i > 0 {
                match avail[end] {
                    b'[' => depth -= 1,
                    b']' => depth += 1,
                    _ => {}
                }
            }
            end
        };
        let run = &avail[..end];
        if let Some(j) = open_at.filter(|&j| j < end) {
            self.first_open = (self.line, self.col + j, base + j as u64);
        }
        self.depth = depth;
        let r = f(&run[..end]);
        self.col += end;
        self.input.consume(end);
        Ok(r)
    }

    /// The rest of the axiom as a regular file, for reading plain modules
    /// on several threads ([`plain_prefix`]): the file, the offset of the
    /// first module, the file's length and whether `/` may open a comment.
    /// None for a stream.
    pub(crate) fn file_rest(&mut self) -> Result<Option<(&std::fs::File, u64, u64, bool)>, Error> {
        if !self.started {
            self.start()?;
        }
        // (Blanks and comments before the first module: as `next` does.)
        self.skip_blank()?;
        let at = self.input.offset();
        let comments = self.comments;
        Ok(self.input.file().and_then(|f| {
            let len = f.metadata().ok()?.len();
            Some((f, at, len, comments))
        }))
    }

    /// The input's name, for errors.
    pub(crate) fn name(&self) -> &str {
        &self.input.name
    }

    /// The same reader on `text` instead, before it has read anything: a
    /// cpfg axiom whose parameters are worked out after `Start:`.
    pub(crate) fn with_text(self, text: String) -> Self {
        let input = Input::new(Box::new(std::io::Cursor::new(text)), self.input.name);
        AxiomReader::new(input, self.comments, self.line, self.col, self.consts)
    }

    /// Where the reader is, its input's buffer included: to come back to
    /// ([`AxiomReader::back_to`]).
    pub(crate) fn state(&self) -> ReaderState {
        ReaderState {
            input: Some(self.input.state()),
            at: self.input.offset(),
            line: self.line,
            col: self.col,
            depth: self.depth,
            first_open: self.first_open,
            last: self.last,
        }
    }

    /// Go back (or on) to `state`, in a regular file: as it was, or (no
    /// buffer kept) with nothing buffered before it ([`Input::skip_to`]).
    pub(crate) fn back_to(&mut self, state: &ReaderState) -> Result<(), Error> {
        let done = match &state.input {
            Some(input) => self.input.back_to(input)?,
            None => self.input.skip_to(state.at)?,
        };
        if !done {
            return Err(Error::new(crate::diag::RuntimeError::WorkerStopped));
        }
        self.line = state.line;
        self.col = state.col;
        self.depth = state.depth;
        self.first_open = state.first_open;
        self.last = state.last;
        Ok(())
    }

    /// Go on at `at`, after plain modules read elsewhere (one line, one
    /// column a byte) that left the nesting depth at `depth`. (Where their
    /// first `[` was is not known: an error is found again by reading from
    /// the start, [`AxiomReader::back_to`].)
    pub(crate) fn skip_plain(&mut self, at: u64, depth: u64) -> Result<(), Error> {
        let at_now = self.input.offset();
        self.back_to(&ReaderState {
            input: None,
            at,
            line: self.line,
            col: self.col + (at - at_now) as usize,
            depth,
            first_open: self.first_open,
            last: self.last,
        })
    }

    /// The next module: its key, with its parameters in `params`.
    pub fn next(
        &mut self,
        alphabet: &mut Alphabet,
        params: &mut Vec<f64>,
        rng: &mut Random,
    ) -> Result<Option<u32>, Error> {
        params.clear();
        if !self.started {
            self.start()?;
        }
        if !self.skip_blank()? {
            if self.depth > 0 {
                let (l, c, at) = self.first_open;
                let msg = ParseError::UnclosedBracket { line: l, col: c };
                if self.input.holds(at) {
                    return Err(self.error_at(at, l, c, msg.clone()));
                }
                // Point at the last module instead, which is still buffered.
                let (l, c, at) = self.last;
                return Err(self.error_at(at, l, c, msg));
            }
            return Ok(None);
        }
        let (line, col, at) = (self.line, self.col, self.input.offset());
        self.last = (line, col, at);
        let (sym, n) = self.peek_char()?.expect("skip_blank saw a byte");
        match sym {
            '(' | ')' | ':' | '<' | '>' => return Err(self.error_here(ParseError::Reserved(sym))),
            c if c.is_control() => return Err(self.error_here(LexicalError::ControlChar(c))),
            '\u{FEFF}' => return Err(self.error_here(LexicalError::ByteOrderMark)),
            _ => {}
        }
        self.advance(n);
        // Parameters?
        if self.skip_blank()? && self.input.available().first() == Some(&b'(') {
            self.read_params(params, rng)?;
        }
        match sym {
            '[' if params.is_empty() => {
                if self.depth == 0 {
                    self.first_open = (line, col, at);
                }
                self.depth += 1;
            }
            ']' if params.is_empty() => {
                if self.depth == 0 {
                    return Err(self.error_at(at, line, col, ParseError::UnbalancedClose));
                }
                self.depth -= 1;
            }
            _ => {}
        }
        alphabet
            .intern(sym, params.len())
            .map(Some)
            .map_err(|m| self.error_at(at, line, col, m))
    }

    /// Read `( p, p, ... )` at the read position. Comments inside are
    /// skipped whole, so a `,` or `)` in them separates nothing.
    fn read_params(&mut self, params: &mut Vec<f64>, rng: &mut Random) -> Result<(), Error> {
        let (line, col, at) = (self.line, self.col, self.input.offset());
        self.advance(1);
        let mut depth = 0usize;
        self.text.clear();
        let mut piece_start = (self.line, self.col, self.input.offset());
        // Where an open comment started.
        let mut comment: Option<(usize, usize, u64)> = None;
        loop {
            let avail = self.input.fill(2)?;
            let Some(&b) = avail.first() else {
                if let Some((l, c, a)) = comment {
                    return Err(self.error_at(a, l, c, LexicalError::UnterminatedComment));
                }
                return Err(self.error_at(at, line, col, ParseError::UnclosedParen));
            };
            match b {
                0 => return Err(self.error_here(LexicalError::Nul)),
                b'\n' => {
                    // Kept, so that places in the text can be found again.
                    self.text.push(b'\n');
                    self.input.consume(1);
                    self.line += 1;
                    self.col = 1;
                    continue;
                }
                b'*' if comment.is_some() && comment::closes(avail) => {
                    comment = None;
                    self.text.push(b'*');
                    self.advance(1);
                }
                _ if comment.is_some() => {}
                b'/' if self.comments && comment::opens(avail) => {
                    comment = Some((self.line, self.col, self.input.offset()));
                    self.input.mark(self.input.offset());
                    self.text.push(b'/');
                    self.advance(1);
                }
                b'(' => depth += 1,
                b')' if depth > 0 => depth -= 1,
                b')' | b',' if depth == 0 => {
                    self.param(params, piece_start, rng)?;
                    self.advance(1);
                    if b == b')' {
                        return Ok(());
                    }
                    self.text.clear();
                    piece_start = (self.line, self.col, self.input.offset());
                    continue;
                }
                _ => {}
            }
            let b = self.input.available()[0];
            self.text.push(b);
            self.advance(1);
            if self.text.len() > MAX_PARAM_TEXT {
                return Err(self.error_at(at, line, col, ParseError::ParamListTooLong));
            }
        }
    }

    fn param(
        &mut self,
        params: &mut Vec<f64>,
        (line, col, at): (usize, usize, u64),
        rng: &mut Random,
    ) -> Result<(), Error> {
        if params.len() == MAX_ARITY {
            return Err(self.error_at(at, line, col, ParseError::TooManyParams));
        }
        let raw = match std::str::from_utf8(&self.text) {
            Ok(r) => r.to_string(),
            Err(e) => {
                let good = e.valid_up_to();
                let prefix = String::from_utf8_lossy(&self.text[..good]).into_owned();
                let (l, c, _, _) = place(&prefix, good, line, col);
                return Err(self.error_at(at + good as u64, l, c, LexicalError::InvalidUtf8));
            }
        };
        let t = raw.trim();
        // Fast path: a plain number.
        if !t.is_empty()
            && t.bytes()
                .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-'))
        {
            if let Ok(v) = t.parse::<f64>() {
                if v.is_finite() {
                    params.push(v);
                    return Ok(());
                }
            }
        }
        if t.is_empty() {
            return Err(self.error_at(at, line, col, ParseError::EmptyParameter));
        }
        let lead = raw.len() - raw.trim_start().len();
        let located = |s: &mut Self, off: usize, msg: ErrorKind| {
            let k = lead + off.min(t.len());
            let (l, c, text_line, caret) = place(&raw, k, line, col);
            let spot = at + k as u64;
            if s.input.holds(spot) && s.input.holds(at) {
                return s.error_at(spot, l, c, msg);
            }
            // The text has scrolled out of the buffer: quote the parameter.
            let (snippet, caret_col) = excerpt(text_line, caret);
            Error::at(
                Location {
                    path: s.input.name.clone(),
                    line: l,
                    col: c,
                    snippet,
                    caret_col,
                },
                msg,
            )
        };
        // The expression lexer ends a line at a newline; here newlines
        // are blanks.
        let e = match parse_expr(&t.replace('\n', " ")) {
            Ok(e) => e,
            Err(e) => return Err(located(self, e.span.0, e.kind.into())),
        };
        let empty = HashMap::new();
        let code = match Code::compile(
            &e,
            &Scope {
                params: &empty,
                consts: self.consts,
                cpfg: false,
            },
        ) {
            Ok(c) => c,
            Err(e) => return Err(located(self, e.span.0, CompileError::Expr(e.kind).into())),
        };
        match code.eval(&[], &mut self.stack, rng) {
            Ok(v) => {
                params.push(v);
                Ok(())
            }
            Err(e) => Err(located(self, e.span.0, CompileError::Expr(e.kind).into())),
        }
    }
}

/// A reader's place ([`AxiomReader::state`]).
#[derive(Clone, Debug)]
pub(crate) struct ReaderState {
    input: Option<crate::io::input::InputState>,
    at: u64,
    line: usize,
    col: usize,
    depth: u64,
    first_open: (usize, usize, u64),
    last: (usize, usize, u64),
}

/// What [`plain_prefix`] found.
#[derive(Debug, PartialEq, Eq)]
pub(crate) struct PlainPrefix {
    /// Bytes of plain modules from the start (at most `whole`), each a
    /// module of its own as [`AxiomReader::plain_run`] reads them.
    pub len: usize,
    /// Less than `whole`: the reader must go on after `len` bytes.
    pub stopped: bool,
    /// The nesting depth after them, and the lowest it reached, relative
    /// to the start.
    pub depth: i64,
    pub low: i64,
}

/// The leading plain modules of `bytes[..whole]`, a piece of an axiom
/// that starts where a module does, as [`AxiomReader::plain_run`] reads
/// them: a run of [`PLAIN`] bytes (with `comments`, `/` only where it opens
/// no comment) less its last byte, which may take parameters (it is known
/// not to when a plain byte follows it). `bytes` goes on up to two bytes
/// past `whole` where the axiom does (so a last `/` is judged); where it
/// ends at `whole`, so does the axiom.
pub(crate) fn plain_prefix(bytes: &[u8], whole: usize, comments: bool) -> PlainPrefix {
    let class = if comments { &CLASS_BUT_SLASH } else { &CLASS };
    let n = bytes.len();
    let (mut depth, mut low, mut low_before) = (0i64, 0i64, 0i64);
    let mut i = 0;
    'scan: while i < n {
        // A block of plain bytes inside the piece whose `]`s cannot take
        // the depth below its lowest: counted at once ([`block_counts`]).
        if i + BLOCK <= whole {
            let (plain, opens, closes) = block_counts(&bytes[i..i + BLOCK], comments);
            let (opens, closes) = (opens as i64, closes as i64);
            if plain && depth - closes >= low {
                if closes > 0 {
                    low_before = low;
                }
                depth += opens - closes;
                i += BLOCK;
                continue;
            }
        }
        let end = n.min(i + BLOCK);
        while i < end {
            match class[bytes[i] as usize] {
                C_PLAIN => {}
                C_OPEN => depth += 1,
                C_CLOSE => {
                    depth -= 1;
                    low_before = low;
                    low = low.min(depth);
                }
                _ if comments && bytes[i] == b'/' && i + 1 < n && !comment::opens(&bytes[i..]) => {}
                _ => break 'scan,
            }
            if i == whole {
                // The byte after the piece is plain: the piece is all modules.
                i += 1;
                break 'scan;
            }
            i += 1;
        }
    }
    // A stop at `i` (or the end): the byte before it is left to the
    // reader; else the piece is whole. The byte at `len` was counted above
    // and is not the prefix's.
    let (len, stopped) = if i > whole {
        (whole, false)
    } else {
        (i.saturating_sub(1), true)
    };
    if i > len {
        match bytes[len] {
            b'[' => depth -= 1,
            b']' => {
                depth += 1;
                low = low_before;
            }
            _ => {}
        }
    }
    PlainPrefix {
        len,
        stopped,
        depth,
        low,
    }
}

/// Where byte `k` of a parameter's text is, the text starting at
/// `line`:`col`: its line and column in the file, the text's line that
/// holds it (without its line end) and the 1-based column in that.
fn place(text: &str, k: usize, line: usize, col: usize) -> (usize, usize, &str, usize) {
    let k = k.min(text.len());
    let before = &text[..k];
    let lines = before.matches('\n').count();
    let from = before.rfind('\n').map_or(0, |i| i + 1);
    let to = text[from..].find('\n').map_or(text.len(), |i| from + i);
    let text_line = text[from..to].strip_suffix('\r').unwrap_or(&text[from..to]);
    let in_line = text[from..k.min(from + text_line.len()).max(from)]
        .chars()
        .count();
    let c = if lines == 0 {
        col + in_line
    } else {
        in_line + 1
    };
    (line + lines, c, text_line, in_line + 1)
}

/// Is `b` a whole module on its own when no `(` follows? ([`PLAIN`], and
/// [`block_counts`], which must not look it up.)
#[inline(always)]
const fn is_plain(b: u8) -> bool {
    (b >= 0x21) & (b < 0x7f) & !matches!(b, b'(' | b')' | b':' | b'<' | b'>')
}

/// Bytes that are a whole module on their own when no `(` follows.
static PLAIN: [bool; 256] = {
    let mut t = [false; 256];
    let mut b = 0;
    while b < 256 {
        t[b] = is_plain(b as u8);
        b += 1;
    }
    t
};

/// Bytes [`block_counts`] looks at together.
const BLOCK: usize = 32;

/// Are all of `block`'s bytes [`PLAIN`] (`/` not, with `comments`), and
/// how many `[` and `]` it holds. Compares only ([`is_plain`]), no table:
/// the compiler makes vector code of it.
#[inline]
fn block_counts(block: &[u8], comments: bool) -> (bool, u64, u64) {
    let (mut stops, mut opens, mut closes) = (0u8, 0u8, 0u8);
    for &b in block {
        let plain = is_plain(b) & !(comments & (b == b'/'));
        stops |= u8::from(!plain);
        opens += u8::from(b == b'[');
        closes += u8::from(b == b']');
    }
    (stops == 0, u64::from(opens), u64::from(closes))
}

/// Byte classes of [`AxiomReader::plain_run`]'s loop: [`PLAIN`] bytes,
/// the brackets among them, and the rest (a stop).
const C_STOP: u8 = 0;
const C_PLAIN: u8 = 1;
const C_OPEN: u8 = 2;
const C_CLOSE: u8 = 3;
static CLASS: [u8; 256] = {
    let mut t = [C_STOP; 256];
    let mut b = 0;
    while b < 256 {
        if PLAIN[b] {
            t[b] = C_PLAIN;
        }
        b += 1;
    }
    t[b'[' as usize] = C_OPEN;
    t[b']' as usize] = C_CLOSE;
    t
};

/// [`CLASS`] with `/` a stop: it may open a comment.
static CLASS_BUT_SLASH: [u8; 256] = {
    let mut t = CLASS;
    t[b'/' as usize] = C_STOP;
    t
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::Filter;

    fn read(src: &str) -> Result<Vec<(char, Vec<f64>)>, Error> {
        read_with(src, true)
    }

    /// The axiom's modules, read with or without plain runs.
    fn read_with(src: &str, runs: bool) -> Result<Vec<(char, Vec<f64>)>, Error> {
        let consts: HashMap<String, f64> = [("R".to_string(), 2.0)].into_iter().collect();
        let input = Input::new(
            Box::new(std::io::Cursor::new(src.as_bytes().to_vec())),
            "a.ls",
        );
        let mut r = AxiomReader::new(input, true, 1, 1, &consts);
        let mut al = Alphabet::new(Filter::All);
        let mut out = Vec::new();
        let mut p = Vec::new();
        let mut rng = Random::new(0);
        loop {
            let mut run = Vec::new();
            if runs {
                r.plain_run(|b| run.extend_from_slice(b))?;
            }
            out.extend(run.iter().map(|&b| (b as char, vec![])));
            match r.next(&mut al, &mut p, &mut rng)? {
                Some(k) => out.push((al.symbol(k), p.clone())),
                None => break,
            }
        }
        Ok(out)
    }

    /// `plain_prefix` against a model: the plain bytes from the start (as
    /// `plain_run` classes them), less the last, which may take parameters;
    /// a piece is whole only where the byte after it is plain too.
    #[test]
    fn plain_prefixes_are_what_the_reader_takes_as_plain() {
        // The second: long runs of plain bytes, for the blocks.
        let alphabets: [&[u8]; 2] = [b"FF[]]+(/* \n\xc3", b"FFFFF[[]]]+/FFFFFFFF[]["];
        let mut seed = 7u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let check = check_plain_prefix;
        for case in 0..8000 {
            let alphabet = alphabets[case % 2];
            let n = (next() % [24, 300][case % 2]) as usize;
            let bytes: Vec<u8> = (0..n)
                .map(|_| alphabet[(next() % alphabet.len() as u64) as usize])
                .collect();
            let whole = (next() % (n as u64 + 1)) as usize;
            // Up to two bytes past the piece, or the end of the axiom.
            let past = (next() % 3) as usize;
            check(case, &bytes[..(whole + past).min(n)], whole);
        }
        // A block whose only `]` is the prefix's last byte, after a `]`
        // that took the depth lowest.
        let bytes = format!("][[{}{}]", "F".repeat(BLOCK - 3), "F".repeat(BLOCK - 1));
        check(8000, bytes.as_bytes(), bytes.len());
    }

    fn check_plain_prefix(case: usize, bytes: &[u8], whole: usize) {
        {
            for comments in [false, true] {
                let p = plain_prefix(bytes, whole, comments);
                // The model: plain bytes from the start, as the reader's
                // own test of a byte says (a `/` needs the byte after it).
                let plain_at = |i: usize| {
                    let b = bytes[i];
                    let class = if comments { &CLASS_BUT_SLASH } else { &CLASS };
                    class[b as usize] != C_STOP
                        || (comments && b == b'/' && i + 1 < bytes.len() && bytes[i + 1] != b'*')
                };
                let run = (0..bytes.len()).take_while(|&i| plain_at(i)).count();
                let (len, stopped) = if run > whole {
                    (whole, false)
                } else {
                    (run.saturating_sub(1), true)
                };
                let mut depth = 0i64;
                let mut low = 0i64;
                for &b in &bytes[..len] {
                    match b {
                        b'[' => depth += 1,
                        b']' => {
                            depth -= 1;
                            low = low.min(depth);
                        }
                        _ => {}
                    }
                }
                let want = PlainPrefix {
                    len,
                    stopped,
                    depth,
                    low,
                };
                assert_eq!(
                    p, want,
                    "case {case}: {bytes:?}, piece of {whole}, comments {comments}"
                );
            }
        }
    }

    /// Plain runs (blocks of [`BLOCK`] bytes counted at once where the
    /// depth allows) read what the reader reads a module at a time: the
    /// same modules, the same error at the same place. Long strings,
    /// mostly deep, with stops, comments and unbalanced brackets.
    #[test]
    fn plain_runs_read_what_modules_read() {
        let alphabet: &[&str] = &[
            "F",
            "F",
            "+",
            "[",
            "[",
            "]",
            "]",
            "[[[[",
            "]]]]",
            "(1)",
            " ",
            "/*c*/",
            "/",
            "\n",
            "A(2)",
            "FFFFFFFFFFFFFFFFFFFFFFFFFFFFFFFF",
        ];
        let mut seed = 11u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let (mut long_ok, mut errors) = (0, 0);
        for case in 0..3000 {
            let n = (next() % 120) as usize;
            let mut depth = (next() % 40) as i64;
            let mut src = "[".repeat(depth as usize);
            for _ in 0..n {
                let t = alphabet[(next() % alphabet.len() as u64) as usize];
                let d = t.matches('[').count() as i64 - t.matches(']').count() as i64;
                // Mostly balanced: few `]`s of nothing.
                if depth + d < 0 && next() % 8 != 0 {
                    continue;
                }
                depth += d;
                src.push_str(t);
            }
            if next() % 4 != 0 {
                src.push_str(&"]".repeat(depth.max(0) as usize));
            }
            let a = read_with(&src, true);
            let b = read_with(&src, false);
            match (&a, &b) {
                (Ok(x), Ok(y)) => {
                    assert_eq!(x, y, "case {case}: {src:?}");
                    long_ok += usize::from(x.len() > 3 * BLOCK);
                }
                (Err(x), Err(y)) => {
                    assert_eq!(x.message(), y.message(), "case {case}: {src:?}");
                    assert_eq!(x.location(), y.location(), "case {case}: {src:?}");
                    errors += 1;
                }
                _ => panic!(
                    "case {case}: {src:?}: {:?} against {:?}",
                    a.is_ok(),
                    b.is_ok()
                ),
            }
        }
        // The cases reach long runs, and errors.
        assert!(long_ok > 100 && errors > 300, "{long_ok} {errors}");
    }

    #[test]
    fn modules_and_parameters() {
        let m = read(" B(2)A(4, 4)\n F /* c */ Ω(R*3) [+F(-2e-3)]").unwrap();
        assert_eq!(
            m,
            vec![
                ('B', vec![2.0]),
                ('A', vec![4.0, 4.0]),
                ('F', vec![]),
                ('Ω', vec![6.0]),
                ('[', vec![]),
                ('+', vec![]),
                ('F', vec![-2e-3]),
                (']', vec![]),
            ]
        );
    }

    #[test]
    fn long_plain_runs_with_brackets() {
        let src = format!("{}[+F]{}G(1)", "F".repeat(100_000), "-".repeat(70_000));
        let m = read(&src).unwrap();
        assert_eq!(m.len(), 170_005);
        assert_eq!(m[100_000], ('[', vec![]));
        assert_eq!(m.last().unwrap(), &('G', vec![1.0]));
        let e = read(&format!("{}]", "F".repeat(100_000))).unwrap_err();
        assert_eq!(e.location().unwrap().clone().col, 100_001);
        let e = read("[[F]").unwrap_err();
        assert!(
            e.message().contains("1:1 is never closed"),
            "{}",
            e.message()
        );
    }

    /// The plain-run loop counts brackets as it goes and leaves a run's
    /// last byte to the general path, which may find it takes parameters
    /// (a `[` with parameters is a module, not a branch) or is a bracket.
    #[test]
    fn brackets_at_the_end_of_a_plain_run() {
        let m = read("F[(2)G").unwrap();
        assert_eq!(m, [('F', vec![]), ('[', vec![2.0]), ('G', vec![])]);
        let m = read("F[F]](1)").unwrap();
        assert_eq!(m.len(), 5);
        assert_eq!(m[4], (']', vec![1.0]));
        for (src, at) in [
            ("FFF[", "1:4"),
            ("FF[[F]F", "1:3"),
            ("F[F][", "1:5"),
            // `](1)` is a module: the `[` stays open.
            ("F[F](1)", "1:2"),
        ] {
            let e = read(src).unwrap_err();
            let want = format!("{at} is never closed");
            assert!(e.message().contains(&want), "{src}: {}", e.message());
        }
        let e = read("F[F]]F").unwrap_err();
        assert_eq!(e.location().unwrap().clone().col, 5);
    }

    #[test]
    fn errors_are_located() {
        let e = read("F\nFF)").unwrap_err();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (2, 3));
        assert!(e.message().contains("reserved"));
        assert_eq!(l.snippet, "FF)");
        let e = read("F(1,2").unwrap_err();
        assert!(e.message().contains("never closed"), "{}", e.message());
        let e = read("F]").unwrap_err();
        assert!(e.message().contains("without `[`"), "{}", e.message());
        let e = read("[F[G]").unwrap_err();
        assert!(
            e.message().contains("1:1 is never closed"),
            "{}",
            e.message()
        );
        let e = read("F(1/0)").unwrap_err();
        assert_eq!(e.message(), "division by zero");
        let e = read("F(x)").unwrap_err();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (1, 3));
        let e = read("F /* open").unwrap_err();
        assert!(e.message().contains("unterminated comment"));
    }

    #[test]
    fn comments_in_parameter_lists() {
        let m = read("F(1 /* a, b) */)G F(1, /* a,\n b */ 2) H(/*)*/3)").unwrap();
        assert_eq!(
            m,
            vec![
                ('F', vec![1.0]),
                ('G', vec![]),
                ('F', vec![1.0, 2.0]),
                ('H', vec![3.0]),
            ]
        );
        let e = read("F(1 /* open, 2)").unwrap_err();
        assert!(
            e.message().contains("unterminated comment"),
            "{}",
            e.message()
        );
        assert_eq!(e.location().unwrap().clone().col, 5);
    }

    #[test]
    fn parameters_attach_across_blanks_and_comments_anywhere() {
        for src in [
            "GF/* c */(1)",
            "GF\u{a0}(1)",
            "GF\u{b}(1)",
            "GF \n (1)",
            "GF(1)",
        ] {
            assert_eq!(
                read(src).unwrap(),
                vec![('G', vec![]), ('F', vec![1.0])],
                "{src:?}"
            );
        }
    }

    #[test]
    fn multi_line_parameters_are_located() {
        let e = read("F\nF(1 +\n  x)").unwrap_err();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (3, 3));
        assert_eq!((l.snippet.as_str(), l.caret_col), ("  x)", 3));
        // The end of the text, just after the `+`.
        let e = read("F(1,\r\n 2 /* c\n */ +)").unwrap_err();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (3, 6));
    }

    #[test]
    fn invalid_utf8_and_nul_in_comments() {
        let input = Input::new(
            Box::new(std::io::Cursor::new(b"F /* \xff */ G".to_vec())),
            "a",
        );
        let consts = HashMap::new();
        let mut r = AxiomReader::new(input, true, 1, 1, &consts);
        let mut al = Alphabet::new(Filter::All);
        let (mut p, mut rng) = (Vec::new(), Random::new(0));
        let e = loop {
            match r.next(&mut al, &mut p, &mut rng) {
                Ok(_) => continue,
                Err(e) => break e,
            }
        };
        assert_eq!(e.message(), "invalid UTF-8");
        assert_eq!(e.location().unwrap().clone().col, 6);
        let e = read("F /* \0 */").unwrap_err();
        assert!(e.message().contains("NUL"), "{}", e.message());
    }

    #[test]
    fn byte_order_mark_at_the_start_is_skipped() {
        let input = Input::new(
            Box::new(std::io::Cursor::new(b"\xEF\xBB\xBFF".to_vec())),
            "a",
        );
        let consts = HashMap::new();
        let mut r = AxiomReader::new(input, false, 1, 1, &consts);
        let mut al = Alphabet::new(Filter::All);
        let (mut p, mut rng) = (Vec::new(), Random::new(0));
        let k = r.next(&mut al, &mut p, &mut rng).unwrap().unwrap();
        assert_eq!(al.symbol(k), 'F');
        assert!(r.next(&mut al, &mut p, &mut rng).unwrap().is_none());
    }

    #[test]
    fn invalid_utf8() {
        let input = Input::new(Box::new(std::io::Cursor::new(b"FF\xc3(".to_vec())), "a");
        let consts = HashMap::new();
        let mut r = AxiomReader::new(input, false, 1, 1, &consts);
        let mut al = Alphabet::new(Filter::All);
        let mut p = Vec::new();
        let mut rng = Random::new(0);
        assert!(r.next(&mut al, &mut p, &mut rng).unwrap().is_some());
        // The second F is read, then the bad byte is met looking for `(`.
        let e = r.next(&mut al, &mut p, &mut rng).unwrap_err();
        assert_eq!(e.message(), "invalid UTF-8");
        assert_eq!(e.location().unwrap().clone().col, 3);
    }
}
