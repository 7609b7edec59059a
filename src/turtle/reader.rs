//! Reading a module string as lsgen writes it (`F(1.5)[+F]...`), module by
//! module, from any byte stream: one 64 KiB buffer, whatever the length.

use crate::diag::{Error, TurtleError};
use std::io::{self, Read};

/// Parameters kept per module; further ones are read and ignored.
pub const MAX_PARAMS: usize = 8;

const BUF: usize = 1 << 16;

/// Longest parameter accepted, in characters.
pub const MAX_NUMBER: usize = 64;

pub struct Reader<R: Read> {
    inner: R,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    eof: bool,
    /// Stream offset of `buf[0]`.
    base: u64,
    name: String,
    /// Parameters of the module just read.
    pub params: [f64; MAX_PARAMS],
    pub nparams: usize,
    /// Stream offset of the module just read.
    pub last_at: u64,
}

impl<R: Read> Reader<R> {
    pub fn new(inner: R, name: impl Into<String>) -> Self {
        Reader {
            inner,
            buf: vec![0; BUF],
            pos: 0,
            end: 0,
            eof: false,
            base: 0,
            name: name.into(),
            params: [0.0; MAX_PARAMS],
            nparams: 0,
            last_at: 0,
        }
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Stream offset of the next byte.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// An error at stream offset `at`: `FILE:OFFSET: error: ...`.
    pub fn error_at(&self, at: u64, kind: TurtleError) -> Error {
        Error::about(format!("{}:{}", self.name, at), kind)
    }

    /// Refill so that at least `want` bytes (at most the buffer size) are
    /// available, unless the stream ends.
    fn fill(&mut self, want: usize) -> Result<(), Error> {
        if self.end - self.pos >= want || self.eof {
            return Ok(());
        }
        self.buf.copy_within(self.pos..self.end, 0);
        self.base += self.pos as u64;
        self.end -= self.pos;
        self.pos = 0;
        while self.end < want && !self.eof {
            match self.inner.read(&mut self.buf[self.end..]) {
                Ok(0) => self.eof = true,
                Ok(n) => self.end += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(Error::io(self.name.clone(), crate::diag::IoAction::Read, e)),
            }
        }
        Ok(())
    }

    #[inline]
    fn peek(&mut self) -> Result<Option<u8>, Error> {
        if self.pos == self.end {
            self.fill(1)?;
            if self.pos == self.end {
                return Ok(None);
            }
        }
        Ok(Some(self.buf[self.pos]))
    }

    fn skip_blanks(&mut self) -> Result<Option<u8>, Error> {
        loop {
            match self.peek()? {
                Some(b' ' | b'\t' | b'\r' | b'\n') => self.pos += 1,
                other => return Ok(other),
            }
        }
    }

    /// The next module's symbol (its parameters in `params[..nparams]`),
    /// or `None` at the end of the stream.
    pub fn next_module(&mut self) -> Result<Option<char>, Error> {
        let Some(b) = self.skip_blanks()? else {
            return Ok(None);
        };
        let at = self.offset();
        self.last_at = at;
        let sym = if b < 0x80 {
            self.pos += 1;
            if b < 0x20 || b == 0x7f {
                return Err(self.error_at(at, TurtleError::ControlByte(b)));
            }
            // `,` outside a parameter list is a module (cpfg's colour
            // decrement), as in lsgen's language: `F,G` is three modules.
            if matches!(b, b'(' | b')') {
                return Err(self.error_at(at, TurtleError::Unexpected(b as char)));
            }
            b as char
        } else {
            let len = match b {
                0xc2..=0xdf => 2,
                0xe0..=0xef => 3,
                0xf0..=0xf4 => 4,
                _ => return Err(self.error_at(at, TurtleError::InvalidUtf8)),
            };
            self.fill(len)?;
            let bytes = &self.buf[self.pos..self.end.min(self.pos + len)];
            match std::str::from_utf8(bytes)
                .ok()
                .and_then(|s| s.chars().next())
            {
                Some(c) if bytes.len() == len => {
                    self.pos += len;
                    c
                }
                _ => return Err(self.error_at(at, TurtleError::InvalidUtf8)),
            }
        };
        self.nparams = 0;
        if self.peek()? == Some(b'(') {
            self.pos += 1;
            self.read_params(at)?;
        }
        Ok(Some(sym))
    }

    fn read_params(&mut self, module_at: u64) -> Result<(), Error> {
        let mut n = 0;
        loop {
            self.skip_blanks()?;
            let at = self.offset();
            // A number: up to 64 bytes of [0-9+-.eE].
            self.fill(MAX_NUMBER + 1)?;
            let avail = &self.buf[self.pos..self.end];
            let is_num =
                |c: &&u8| c.is_ascii_digit() || matches!(c, b'+' | b'-' | b'.' | b'e' | b'E');
            let len = avail.iter().take(MAX_NUMBER + 1).take_while(is_num).count();
            if len > MAX_NUMBER {
                return Err(self.error_at(at, TurtleError::NumberTooLong(MAX_NUMBER)));
            }
            let text = std::str::from_utf8(&avail[..len]).unwrap_or("");
            let v = match text.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                _ => {
                    let shown: String = String::from_utf8_lossy(&avail[..avail.len().min(20)])
                        .chars()
                        .take_while(|c| !matches!(c, ',' | ')' | '\n'))
                        .collect();
                    return Err(if avail.is_empty() {
                        self.error_at(module_at, TurtleError::ParamsNotClosed)
                    } else {
                        self.error_at(at, TurtleError::ExpectedNumber(shown))
                    });
                }
            };
            self.pos += len;
            if n < MAX_PARAMS {
                self.params[n] = v;
            }
            n += 1;
            match self.skip_blanks()? {
                Some(b',') => self.pos += 1,
                Some(b')') => {
                    self.pos += 1;
                    self.nparams = n.min(MAX_PARAMS);
                    return Ok(());
                }
                None => return Err(self.error_at(module_at, TurtleError::ParamsNotClosed)),
                Some(c) => {
                    let at = self.offset();
                    return Err(self.error_at(at, TurtleError::ExpectedCommaOrParen(c as char)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(s: &str) -> Result<Vec<(char, Vec<f64>)>, String> {
        let mut r = Reader::new(s.as_bytes(), "in");
        let mut v = Vec::new();
        loop {
            match r.next_module() {
                Ok(Some(c)) => v.push((c, r.params[..r.nparams].to_vec())),
                Ok(None) => return Ok(v),
                Err(e) => return Err(e.to_string()),
            }
        }
    }

    #[test]
    fn comma_is_a_module() {
        assert_eq!(
            all("F,G,(2) ,").unwrap(),
            vec![
                ('F', vec![]),
                (',', vec![]),
                ('G', vec![]),
                (',', vec![2.0]),
                (',', vec![]),
            ]
        );
    }

    #[test]
    fn modules() {
        assert_eq!(
            all("F(1.5)[+F]é(-0,2e-3)\n").unwrap(),
            vec![
                ('F', vec![1.5]),
                ('[', vec![]),
                ('+', vec![]),
                ('F', vec![]),
                (']', vec![]),
                ('é', vec![-0.0, 2e-3]),
            ]
        );
    }

    #[test]
    fn errors() {
        assert_eq!(
            all("FF(1").unwrap_err(),
            "in:1: error: parameter list not closed: `(` without `)`\n"
        );
        assert_eq!(
            all("F(x)").unwrap_err(),
            "in:2: error: expected a number, found `x`\n"
        );
        assert_eq!(
            all("F(1;2)").unwrap_err(),
            "in:3: error: expected `,` or `)`, found `;`\n"
        );
        assert_eq!(
            all("F\u{1}").unwrap_err(),
            "in:1: error: unexpected control character 0x01\n"
        );
        assert!(all("F\u{ff}").is_ok());
        assert_eq!(
            all_bytes(b"F\xff").unwrap_err(),
            "in:1: error: invalid UTF-8\n"
        );
    }

    #[test]
    fn errors_are_typed() {
        use crate::diag::{ErrorKind, Stage};
        let mut r = Reader::new(&b"F(1"[..], "in");
        let e = r.next_module().unwrap_err();
        assert!(matches!(
            e.kind(),
            ErrorKind::Turtle(TurtleError::ParamsNotClosed)
        ));
        assert_eq!(e.stage(), Stage::Parse);
        assert_eq!(e.subject(), Some("in:0"));
        assert_eq!(
            Error::new(TurtleError::UnmatchedClose(']')).stage(),
            Stage::Runtime
        );
    }

    fn all_bytes(s: &[u8]) -> Result<usize, String> {
        let mut r = Reader::new(s, "in");
        let mut n = 0;
        loop {
            match r.next_module() {
                Ok(Some(_)) => n += 1,
                Ok(None) => return Ok(n),
                Err(e) => return Err(e.to_string()),
            }
        }
    }
}
