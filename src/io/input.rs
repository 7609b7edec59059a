//! Reading an `.ls` file as a stream: the header (everything before
//! `axiom:`) is collected for the grammar; the axiom is left in the stream
//! for [`crate::io::axiom`] to read module by module, so it may be gigabytes long.

use crate::diag::{excerpt, Error, LexicalError, Location};
use crate::lang::comment;
use std::io::{self, Read};

/// A byte stream with look-ahead and enough history to quote the current
/// line in an error. lsgen reads its input through the boxed reader;
/// lsgen-turtle's module reader borrows its stream (`R`).
pub struct Input<R: Read = Box<dyn Read + Send>> {
    inner: R,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    eof: bool,
    /// Stream offset of `buf[0]`.
    base: u64,
    pub name: String,
    /// An offset an error may still quote after it leaves the buffer (the
    /// start of a comment): before the buffer drops the text around it,
    /// that text is copied to `saved` (from stream offset `saved_base`).
    mark: Option<u64>,
    saved: Vec<u8>,
    saved_base: u64,
    /// The regular file `inner` reads (sharing its offset), if it is one:
    /// then the stream may be read at any offset ([`Input::file`]) and
    /// moved ([`Input::skip_to`]).
    file: Option<std::fs::File>,
}

/// What [`Input::state`] keeps.
#[derive(Clone, Debug)]
pub struct InputState {
    buf: Vec<u8>,
    pos: usize,
    eof: bool,
    base: u64,
    mark: Option<u64>,
    saved: Vec<u8>,
    saved_base: u64,
}

const CHUNK: usize = 1 << 16;
/// Bytes kept before `pos` when the buffer is compacted, for error excerpts.
const HISTORY: usize = 512;
/// Bytes saved either side of a mark: an excerpt shows 60 characters
/// either side of its column, of at most 4 bytes each.
const MARK_WINDOW: u64 = 256;

impl Input {
    pub fn new(inner: Box<dyn Read + Send>, name: impl Into<String>) -> Input {
        Input::over(inner, name)
    }
}

impl<R: Read> Input<R> {
    /// An input over any reader.
    pub fn over(inner: R, name: impl Into<String>) -> Input<R> {
        Input {
            inner,
            buf: vec![0; CHUNK * 2],
            pos: 0,
            end: 0,
            eof: false,
            base: 0,
            name: name.into(),
            mark: None,
            saved: Vec::new(),
            saved_base: 0,
            file: None,
        }
    }

    /// `inner` reads the regular file `file` from its start (`file` shares
    /// its offset: a `try_clone`).
    pub fn with_file(mut self, file: std::fs::File) -> Input<R> {
        self.file = Some(file);
        self
    }

    /// The regular file the stream is, its stream offsets being the file's.
    pub fn file(&self) -> Option<&std::fs::File> {
        self.file.as_ref()
    }

    /// The stream's state, buffer and all, to come back to
    /// ([`Input::back_to`]; a regular file only).
    pub fn state(&self) -> InputState {
        InputState {
            buf: self.buf[..self.end].to_vec(),
            pos: self.pos,
            eof: self.eof,
            base: self.base,
            mark: self.mark,
            saved: self.saved.clone(),
            saved_base: self.saved_base,
        }
    }

    /// Back to `state`, as if nothing had been read since (a regular file
    /// only: false otherwise).
    pub fn back_to(&mut self, state: &InputState) -> Result<bool, Error> {
        let at = state.base + state.buf.len() as u64;
        if !self.skip_to(at)? {
            return Ok(false);
        }
        let n = state.buf.len();
        if self.buf.len() < n {
            self.buf.resize(n, 0);
        }
        self.buf[..n].copy_from_slice(&state.buf);
        self.end = n;
        self.pos = state.pos;
        self.eof = state.eof;
        self.base = state.base;
        self.mark = state.mark;
        self.saved.clone_from(&state.saved);
        self.saved_base = state.saved_base;
        Ok(true)
    }

    /// Go on reading at stream offset `at` (a regular file only: false
    /// otherwise), with nothing buffered before it.
    pub fn skip_to(&mut self, at: u64) -> Result<bool, Error> {
        use std::io::{Seek, SeekFrom};
        let Some(mut f) = self.file.as_ref() else {
            return Ok(false);
        };
        f.seek(SeekFrom::Start(at))
            .map_err(|e| Error::io(self.name.clone(), crate::diag::IoAction::Read, e))?;
        self.base = at;
        self.pos = 0;
        self.end = 0;
        self.eof = false;
        self.mark = None;
        self.saved.clear();
        Ok(true)
    }

    /// Keep the text around stream offset `at` (at most 512 bytes) quotable
    /// after it leaves the buffer, until the next mark.
    pub fn mark(&mut self, at: u64) {
        self.mark = Some(at);
        self.saved.clear();
    }

    /// Make at least `want` bytes available after the read position, unless
    /// the stream ends first. Returns the bytes available.
    pub fn fill(&mut self, want: usize) -> Result<&[u8], Error> {
        while self.end - self.pos < want && !self.eof {
            if self.end == self.buf.len() {
                let keep_from = self.pos.saturating_sub(HISTORY);
                if let Some(m) = self.mark {
                    let from = m.saturating_sub(MARK_WINDOW).max(self.base);
                    if self.base + keep_from as u64 > from && from <= m && self.saved.is_empty() {
                        let to = (m + MARK_WINDOW).min(self.base + self.end as u64);
                        let (s, e) = ((from - self.base) as usize, (to - self.base) as usize);
                        self.saved.extend_from_slice(&self.buf[s..e]);
                        self.saved_base = from;
                    }
                }
                if keep_from > 0 {
                    self.buf.copy_within(keep_from..self.end, 0);
                    self.pos -= keep_from;
                    self.end -= keep_from;
                    self.base += keep_from as u64;
                } else {
                    let n = self.buf.len();
                    self.buf.resize(n * 2, 0);
                }
            }
            let room = self.buf.len() - self.end;
            match self.inner.read(&mut self.buf[self.end..]) {
                Ok(0) => self.eof = true,
                // A reader (the library's `from_reader` takes any) that
                // says it read more than it was given room for: an error,
                // not a panic or bytes it never wrote.
                Ok(n) if n > room => {
                    let lie = io::Error::new(
                        io::ErrorKind::InvalidData,
                        format!("the reader returned {n} bytes for a buffer of {room}"),
                    );
                    return Err(Error::io(
                        self.name.clone(),
                        crate::diag::IoAction::Read,
                        lie,
                    ));
                }
                Ok(n) => self.end += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(Error::io(self.name.clone(), crate::diag::IoAction::Read, e)),
            }
        }
        Ok(&self.buf[self.pos..self.end])
    }

    /// The bytes available now (without reading).
    #[inline]
    pub fn available(&self) -> &[u8] {
        &self.buf[self.pos..self.end]
    }

    /// The byte at the read position, if one is available now.
    #[inline]
    pub fn peek(&self) -> Option<u8> {
        if self.pos < self.end {
            Some(self.buf[self.pos])
        } else {
            None
        }
    }

    #[inline]
    pub fn consume(&mut self, n: usize) {
        debug_assert!(self.pos + n <= self.end);
        self.pos += n;
    }

    /// Stream offset of the read position.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// Is stream offset `at` still in the buffer, or saved around the
    /// mark (so it can be quoted)?
    pub fn holds(&self, at: u64) -> bool {
        (at >= self.base && at <= self.base + self.end as u64) || self.saved_holds(at)
    }

    fn saved_holds(&self, at: u64) -> bool {
        !self.saved.is_empty()
            && at >= self.saved_base
            && at <= self.saved_base + self.saved.len() as u64
    }

    /// The line around stream offset `at` (which must be near the read
    /// position, or saved around the mark), with the 1-based caret column
    /// in that excerpt.
    pub fn excerpt_at(&mut self, at: u64) -> (String, usize) {
        let _ = self.fill(200);
        if at < self.base && self.saved_holds(at) {
            // The saved text may stop inside the line.
            let more = self.saved_base + (self.saved.len() as u64) < self.base + self.end as u64;
            return line_excerpt(&self.saved, self.saved_base, at, more);
        }
        line_excerpt(&self.buf[..self.end], self.base, at, false)
    }
}

/// The line of `bytes` (stream offset `base`) around stream offset `at`,
/// cut to an excerpt, with the 1-based caret column in it; `...` marks a
/// line that starts before `bytes`, or (`more`) goes on after them.
fn line_excerpt(bytes: &[u8], base: u64, at: u64, more: bool) -> (String, usize) {
    let end = bytes.len();
    let at = (at.saturating_sub(base) as usize).min(end);
    let lo = bytes[..at]
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let (hi, cut) = bytes[at..]
        .iter()
        .position(|&b| b == b'\n')
        .map_or((end, more), |i| (at + i, false));
    let before = String::from_utf8_lossy(&bytes[lo..at]);
    let line = String::from_utf8_lossy(&bytes[lo..hi]);
    let line = line.strip_suffix('\r').unwrap_or(&line);
    let col = before.chars().count() + 1;
    let (mut s, mut c) = excerpt(line, col);
    if lo == 0 && base > 0 && !s.starts_with("...") {
        s.insert_str(0, "...");
        c += 3;
    }
    if cut && !s.ends_with("...") {
        s.push_str("...");
    }
    (s, c)
}

/// Where the axiom starts, once the header has been split off.
pub struct Split {
    pub header: String,
    /// Was an `axiom:` line found?
    pub has_axiom: bool,
    /// Line and column (1-based) of the first byte after `axiom:`.
    pub axiom_line: usize,
    pub axiom_col: usize,
}

/// Most bytes read before `axiom:`: the header is held in memory and
/// parsed as a whole, so its size is bounded (the axiom is not).
pub const MAX_HEADER: usize = 64 << 20;

/// Bytes of look-ahead the header scanner wants (`axiom:`, a UTF-8
/// character, `/*`).
const LOOK: usize = 8;

/// What stopped the header scan.
enum Stop {
    Axiom(usize),
    Bad(LexicalError),
    TooLong,
}

/// Read the header: everything up to `axiom:` at the start of a line (only
/// blanks and comments before it on its line, outside a comment; blanks
/// and comments may stand before its `:` too, as in the lexer's
/// keywords). The stream is left just after the keyword.
///
/// The bytes are checked as they are read: NUL, invalid UTF-8 (comments
/// included) and a header over [`MAX_HEADER`] stop the read at once with
/// a located error, so `lsgen /dev/zero` or an unclosed `/*` fed forever
/// fail fast in bounded memory.
pub fn split_header(input: &mut Input) -> Result<Split, Error> {
    let mut header: Vec<u8> = Vec::new();
    if input.fill(3)?.starts_with(b"\xEF\xBB\xBF") {
        // A UTF-8 byte-order mark.
        input.consume(3);
    }
    // An executable script's interpreter line is skipped (but checked).
    let mut shebang = input.fill(2)?.starts_with(b"#!");
    // Header bytes of that line, dropped at the end.
    let mut shebang_len = 0;
    let mut in_comment = false;
    // Only blanks and comments since the last line break: `axiom:` may
    // come next. A comment that spans lines ends a line, as in the lexer.
    let mut line_start = true;
    // `axiom` read at the start of a line, only blanks and comments since:
    // the header's length before it (a `:` next ends the header there).
    let mut axiom_word: Option<usize> = None;
    let (mut line, mut col) = (1usize, 1usize);
    loop {
        let avail = input.fill(LOOK)?;
        if avail.is_empty() {
            break;
        }
        // Look at bytes with LOOK bytes after them, or all near the end.
        let lim = if avail.len() >= LOOK {
            avail.len() - LOOK + 1
        } else {
            avail.len()
        };
        let mut i = 0;
        let mut stop = None;
        while i < lim {
            let b = avail[i];
            let here = (line, col);
            let mut n = 1;
            match b {
                b'\n' => {
                    if shebang {
                        shebang_len = header.len() + i;
                    }
                    line += 1;
                    col = 0;
                    line_start = true;
                    axiom_word = None;
                    shebang = false;
                }
                0 => {
                    stop = Some(Stop::Bad(LexicalError::Nul));
                    break;
                }
                _ if shebang => {}
                b'/' if !in_comment && comment::opens(&avail[i..]) => {
                    in_comment = true;
                    n = 2;
                }
                b'*' if in_comment && comment::closes(&avail[i..]) => {
                    in_comment = false;
                    n = 2;
                }
                _ if in_comment => {}
                b' ' | b'\t' | b'\r' | 0x0B | 0x0C => {}
                b':' if axiom_word.is_some() => {
                    stop = Some(Stop::Axiom(1));
                    break;
                }
                b'a' | b'A' if line_start && avail[i..].len() >= 6 => {
                    if avail[i..i + 6].eq_ignore_ascii_case(b"axiom:") {
                        stop = Some(Stop::Axiom(6));
                        break;
                    }
                    let word = &avail[i..i + 6];
                    if word[..5].eq_ignore_ascii_case(b"axiom")
                        && (word[5].is_ascii_whitespace() || word[5] == b'/' || word[5] >= 0x80)
                    {
                        // Perhaps `axiom :`: the next byte is looked at as
                        // any other (a blank, a comment or a character).
                        axiom_word = Some(header.len() + i);
                        n = 5;
                    }
                    line_start = false;
                }
                _ if b < 0x80 => {
                    line_start = false;
                    axiom_word = None;
                }
                _ => {}
            }
            if b >= 0x80 {
                // A whole character, checked.
                n = utf8_len(b);
                match avail.get(i..i + n).map(std::str::from_utf8) {
                    Some(Ok(s)) if n > 0 => {
                        let c = s.chars().next().unwrap_or(' ');
                        if !in_comment && !shebang && !c.is_whitespace() {
                            line_start = false;
                            axiom_word = None;
                        }
                    }
                    _ => {
                        stop = Some(Stop::Bad(LexicalError::InvalidUtf8));
                        break;
                    }
                }
            }
            if header.len() + i + n > MAX_HEADER {
                (line, col) = here;
                stop = Some(Stop::TooLong);
                break;
            }
            // Columns count characters: a non-ASCII character is one, and
            // what is taken at once of ASCII (`/*`, `*/`, `axiom`) is a
            // character a byte.
            col += if b < 0x80 { n } else { 1 };
            i += n;
        }
        let need = header.len() + i;
        if need > header.capacity() {
            // Double, but never past the limit.
            let cap = (header.capacity() * 2).clamp(need, MAX_HEADER.max(need));
            header.reserve_exact(cap - header.len());
        }
        header.extend_from_slice(&avail[..i]);
        input.consume(i);
        match stop {
            None => continue,
            Some(Stop::Axiom(kl)) => {
                input.consume(kl);
                if let Some(start) = axiom_word {
                    // `axiom` and what stood before its `:`.
                    header.truncate(start);
                }
                return finish(input, header, shebang_len, true, line, col + kl);
            }
            Some(Stop::Bad(msg)) => return Err(header_error(input, line, col, msg)),
            Some(Stop::TooLong) => {
                return Err(header_error(input, line, col, LexicalError::HeaderTooLong))
            }
        }
    }
    finish(input, header, shebang_len, false, line, 1)
}

/// Length of the UTF-8 sequence a lead byte announces (0: not a lead byte).
fn utf8_len(b: u8) -> usize {
    match b {
        b if b < 0x80 => 1,
        b if b >> 5 == 0b110 => 2,
        b if b >> 4 == 0b1110 => 3,
        b if b >> 3 == 0b11110 => 4,
        _ => 0,
    }
}

/// An error at the read position of the header, at `line`:`col`.
fn header_error(input: &mut Input, line: usize, col: usize, kind: LexicalError) -> Error {
    let at = input.offset();
    let (snippet, caret_col) = input.excerpt_at(at);
    Error::at(
        Location {
            path: input.name.clone(),
            line,
            col,
            snippet,
            caret_col,
        },
        kind,
    )
}

fn finish(
    input: &mut Input,
    mut header: Vec<u8>,
    shebang_len: usize,
    has_axiom: bool,
    axiom_line: usize,
    axiom_col: usize,
) -> Result<Split, Error> {
    header.drain(..shebang_len);
    match String::from_utf8(header) {
        Ok(header) => Ok(Split {
            header,
            has_axiom,
            axiom_line,
            axiom_col,
        }),
        // Checked while reading: cannot happen.
        Err(_) => Err(header_error(
            input,
            axiom_line,
            1,
            LexicalError::InvalidUtf8,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::ErrorKind;

    fn split(src: &str) -> (Split, String) {
        let mut i = Input::new(Box::new(io::Cursor::new(src.as_bytes().to_vec())), "t.ls");
        let s = split_header(&mut i).unwrap();
        let mut rest = Vec::new();
        loop {
            let a = i.fill(1).unwrap().to_vec();
            if a.is_empty() {
                break;
            }
            i.consume(a.len());
            rest.extend(a);
        }
        (s, String::from_utf8(rest).unwrap())
    }

    #[test]
    fn splits_at_axiom() {
        let (s, rest) = split("#!/usr/bin/env lsgen\nproductions:\nF -> FF\n  Axiom: F+F\nF\n");
        assert_eq!(s.header, "\nproductions:\nF -> FF\n  ");
        assert!(s.has_axiom);
        assert_eq!((s.axiom_line, s.axiom_col), (4, 9));
        assert_eq!(rest, " F+F\nF\n");
    }

    /// Blanks and comments may stand before `axiom`'s `:`, as before any
    /// keyword's `:` (the lexer's `match_keyword`), however many.
    #[test]
    fn axiom_with_blanks_and_comments_before_its_colon() {
        let (s, rest) = split("F -> G\naxiom /* c */ : X");
        assert!(s.has_axiom);
        assert_eq!(s.header, "F -> G\n");
        assert_eq!((s.axiom_line, s.axiom_col), (2, 16));
        assert_eq!(rest, " X");
        // Past the scanner's buffer: the blanks go with the keyword.
        let long = format!("F -> G\n  AXIOM{}\u{a0}:X", " ".repeat(300_000));
        let (s, rest) = split(&long);
        assert!(s.has_axiom);
        assert_eq!(s.header, "F -> G\n  ");
        assert_eq!((s.axiom_line, s.axiom_col), (2, 300_010));
        assert_eq!(rest, "X");
        // A line break, or anything but blanks and comments, before the
        // colon: not the axiom.
        for src in [
            "F -> G\naxiom\n: X",
            "F -> G\naxiomX: X",
            "F -> G\naxiom X: Y",
            "F -> G\naxiom /* a\n */ : X",
            "F -> G\naxiom \u{e9}: X",
        ] {
            let (s, _) = split(src);
            assert!(!s.has_axiom, "{src:?}");
        }
    }

    #[test]
    fn axiom_inside_comment_is_not_the_axiom() {
        let (s, rest) = split("/* header\naxiom: not this\n*/\naxiom: X");
        assert_eq!(s.header, "/* header\naxiom: not this\n*/\n");
        assert_eq!(rest, " X");
    }

    #[test]
    fn axiom_after_comments_on_its_line() {
        let (s, rest) = split("F -> G\n/* c */ axiom: X");
        assert!(s.has_axiom);
        assert_eq!((s.axiom_line, s.axiom_col), (2, 15));
        assert_eq!(rest, " X");
        let (s, rest) = split("F -> G /* a\nb */ \u{a0}Axiom: X");
        assert!(s.has_axiom);
        assert_eq!((s.axiom_line, s.axiom_col), (2, 13));
        assert_eq!(rest, " X");
        let (s, _) = split("F -> G /* a */ axiom: X");
        assert!(!s.has_axiom);
    }

    #[test]
    fn nul_is_refused_at_once() {
        let mut i = Input::new(Box::new(io::repeat(0)), "zero");
        let e = split_header(&mut i).err().unwrap();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (1, 1));
        assert!(
            matches!(e.kind(), ErrorKind::Lexical(LexicalError::Nul)),
            "{e}"
        );
    }

    #[test]
    fn header_of_exactly_the_limit_is_accepted() {
        let line = format!("/* {} */\n", ".".repeat(57));
        assert_eq!(line.len(), 64);
        let mut src = line.repeat(MAX_HEADER / 64).into_bytes();
        src.extend_from_slice(b"axiom: F");
        let mut i = Input::new(Box::new(io::Cursor::new(src.clone())), "t.ls");
        let s = split_header(&mut i).unwrap();
        assert_eq!(s.header.len(), MAX_HEADER);
        assert_eq!((s.axiom_line, s.axiom_col), (MAX_HEADER / 64 + 1, 7));
        // One byte more is refused, at the byte past the limit: the
        // newline (column 64) of the last comment line.
        src.insert(0, b' ');
        let mut i = Input::new(Box::new(io::Cursor::new(src)), "t.ls");
        let e = split_header(&mut i).err().unwrap();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (MAX_HEADER / 64, 64));
        assert!(
            matches!(e.kind(), ErrorKind::Lexical(LexicalError::HeaderTooLong)),
            "{e}"
        );
    }

    #[test]
    fn missing_axiom() {
        let (s, rest) = split("productions:\nF -> G");
        assert!(!s.has_axiom);
        assert_eq!(rest, "");
    }

    #[test]
    fn invalid_utf8_is_located() {
        let mut i = Input::new(
            Box::new(io::Cursor::new(b"productions:\nF -> \xff\n".to_vec())),
            "t.ls",
        );
        let e = split_header(&mut i).err().unwrap();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (2, 6));
        assert_eq!(e.message(), "invalid UTF-8");
    }
}
