//! Reading an `.ls` file as a stream: the header (everything before
//! `axiom:`) is collected for the grammar; the axiom is left in the stream
//! for [`crate::axiom`] to read module by module, so it may be gigabytes long.

use crate::diag::{excerpt, Error, Location};
use crate::lexer::match_keyword;
use std::io::{self, Read};

/// A byte stream with look-ahead and enough history to quote the current
/// line in an error.
pub struct Input {
    inner: Box<dyn Read>,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    eof: bool,
    /// Stream offset of `buf[0]`.
    base: u64,
    pub name: String,
}

const CHUNK: usize = 1 << 16;
/// Bytes kept before `pos` when the buffer is compacted, for error excerpts.
const HISTORY: usize = 512;

impl Input {
    pub fn new(inner: Box<dyn Read>, name: impl Into<String>) -> Input {
        Input {
            inner,
            buf: vec![0; CHUNK * 2],
            pos: 0,
            end: 0,
            eof: false,
            base: 0,
            name: name.into(),
        }
    }

    /// Make at least `want` bytes available after the read position, unless
    /// the stream ends first. Returns the bytes available.
    pub fn fill(&mut self, want: usize) -> Result<&[u8], Error> {
        while self.end - self.pos < want && !self.eof {
            if self.end == self.buf.len() {
                let keep_from = self.pos.saturating_sub(HISTORY);
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
            match self.inner.read(&mut self.buf[self.end..]) {
                Ok(0) => self.eof = true,
                Ok(n) => self.end += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(Error::io(self.name.clone(), "cannot read", e)),
            }
        }
        Ok(&self.buf[self.pos..self.end])
    }

    /// The bytes available now (without reading).
    #[inline]
    pub fn available(&self) -> &[u8] {
        &self.buf[self.pos..self.end]
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

    /// Is stream offset `at` still in the buffer (so it can be quoted)?
    pub fn holds(&self, at: u64) -> bool {
        at >= self.base && at <= self.base + self.end as u64
    }

    /// The line around stream offset `at` (which must be near the read
    /// position), with the 1-based caret column in that excerpt.
    pub fn excerpt_at(&mut self, at: u64) -> (String, usize) {
        let _ = self.fill(200);
        let at = (at.saturating_sub(self.base) as usize).min(self.end);
        let lo = self.buf[..at]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let hi = self.buf[at..self.end]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(self.end, |i| at + i);
        let before = String::from_utf8_lossy(&self.buf[lo..at]);
        let line = String::from_utf8_lossy(&self.buf[lo..hi]);
        let line = line.strip_suffix('\r').unwrap_or(&line);
        let col = before.chars().count() + 1;
        let (s, c) = excerpt(line, col);
        if lo == 0 && self.base > 0 && !s.starts_with("...") {
            (format!("...{s}"), c + 3)
        } else {
            (s, c)
        }
    }
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

/// Read the header: lines up to the one that starts with `axiom:` (outside
/// a comment). The stream is left just after the keyword.
pub fn split_header(input: &mut Input) -> Result<Split, Error> {
    let mut header: Vec<u8> = Vec::new();
    let mut in_comment = false;
    let mut line_no = 1;
    loop {
        // At a line start: is it the axiom line?
        let avail = input.fill(256)?;
        if avail.is_empty() {
            break;
        }
        if line_no == 1 && header.is_empty() && avail.starts_with(b"\xEF\xBB\xBF") {
            // A UTF-8 byte-order mark.
            input.consume(3);
            continue;
        }
        if line_no == 1 && avail.starts_with(b"#!") {
            // An executable script's interpreter line.
            let n = line_len(input)?;
            input.consume(n);
            header.push(b'\n');
            line_no += 1;
            continue;
        }
        if !in_comment {
            let blank = avail
                .iter()
                .take_while(|&&b| b == b' ' || b == b'\t' || b == b'\r')
                .count();
            let probe_len = avail.len().min(blank + 16);
            let probe = &avail[blank..probe_len];
            // The probe may end inside a character: keep its valid prefix.
            let probe = match std::str::from_utf8(probe) {
                Ok(p) => p,
                Err(e) => std::str::from_utf8(&probe[..e.valid_up_to()]).unwrap_or(""),
            };
            {
                if let Some(kl) = match_keyword(probe, "axiom:") {
                    let col = String::from_utf8_lossy(&avail[..blank + kl])
                        .chars()
                        .count()
                        + 1;
                    input.consume(blank + kl);
                    return finish(input, header, true, line_no, col);
                }
            }
        }
        // An ordinary header line: keep it, tracking comments.
        let n = line_len(input)?;
        let line = &input.available()[..n];
        let mut i = 0;
        while i + 1 < line.len() {
            if !in_comment && line[i] == b'/' && line[i + 1] == b'*' {
                in_comment = true;
                i += 2;
            } else if in_comment && line[i] == b'*' && line[i + 1] == b'/' {
                in_comment = false;
                i += 2;
            } else {
                i += 1;
            }
        }
        header.extend_from_slice(line);
        input.consume(n);
        line_no += 1;
    }
    finish(input, header, false, line_no, 1)
}

/// Length of the current line including its newline, reading as needed.
fn line_len(input: &mut Input) -> Result<usize, Error> {
    let mut want = 256;
    loop {
        let avail = input.fill(want)?;
        if let Some(i) = avail.iter().position(|&b| b == b'\n') {
            return Ok(i + 1);
        }
        if avail.len() < want {
            return Ok(avail.len()); // end of stream
        }
        want = avail.len() * 2;
    }
}

fn finish(
    input: &Input,
    header: Vec<u8>,
    has_axiom: bool,
    axiom_line: usize,
    axiom_col: usize,
) -> Result<Split, Error> {
    match String::from_utf8(header) {
        Ok(header) => Ok(Split {
            header,
            has_axiom,
            axiom_line,
            axiom_col,
        }),
        Err(e) => {
            let good = e.utf8_error().valid_up_to();
            let bytes = e.into_bytes();
            let prefix = String::from_utf8_lossy(&bytes[..good]);
            let line = prefix.matches('\n').count() + 1;
            let line_start = prefix.rfind('\n').map_or(0, |i| i + 1);
            let col = prefix[line_start..].chars().count() + 1;
            let rest = &bytes[line_start..];
            let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            let text = String::from_utf8_lossy(&rest[..end]).into_owned();
            let (snippet, caret_col) = excerpt(&text, col);
            Err(Error::at(
                Location {
                    path: input.name.clone(),
                    line,
                    col,
                    snippet,
                    caret_col,
                },
                "invalid UTF-8",
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(s.header, "\nproductions:\nF -> FF\n");
        assert!(s.has_axiom);
        assert_eq!((s.axiom_line, s.axiom_col), (4, 9));
        assert_eq!(rest, " F+F\nF\n");
    }

    #[test]
    fn axiom_inside_comment_is_not_the_axiom() {
        let (s, rest) = split("/* header\naxiom: not this\n*/\naxiom: X");
        assert_eq!(s.header, "/* header\naxiom: not this\n*/\n");
        assert_eq!(rest, " X");
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
        let l = e.location.clone().unwrap();
        assert_eq!((l.line, l.col), (2, 6));
        assert_eq!(e.message, "invalid UTF-8");
    }
}
