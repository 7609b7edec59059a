//! Reading a module string as lsgen writes it (`F(1.5)[+F]...`), module by
//! module, from any byte stream, through lsgen's own [`Input`]: one buffer
//! whatever the length, with the history an error needs to quote its line.
//! Errors are located as lsgen's are, `FILE:LINE:COL`, the line (an
//! excerpt of a long one) and a caret.

use crate::diag::{Error, Location, TurtleError};
use crate::io::input::Input;
use std::io::Read;

/// Parameters kept per module; further ones are read and ignored.
pub const MAX_PARAMS: usize = 8;

/// Longest parameter accepted, in characters.
pub const MAX_NUMBER: usize = 64;

/// Where something starts in the stream: its offset and line (1-based),
/// and what its column is counted from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Spot {
    pub at: u64,
    pub line: usize,
    /// The line's start plus the UTF-8 continuation bytes before `at` on
    /// it: `at` less this is the column less one.
    col_base: u64,
}

impl Spot {
    /// The column (1-based, in characters).
    pub fn col(&self) -> u64 {
        self.at - self.col_base + 1
    }
}

pub struct Reader<R: Read> {
    input: Input<R>,
    /// The read position's line (1-based), and the offset that line
    /// starts at plus the UTF-8 continuation bytes read on it: a column is
    /// the bytes from the line's start less those, so nothing is counted
    /// per byte (a parameter list is ASCII; only a module's symbol may not
    /// be).
    line: usize,
    col_base: u64,
    /// Parameters of the module just read.
    pub params: [f64; MAX_PARAMS],
    pub nparams: usize,
    /// Where the module just read starts, and its symbol.
    pub last: Spot,
    last_sym: char,
}

impl<R: Read> Reader<R> {
    pub fn new(inner: R, name: impl Into<String>) -> Self {
        Reader {
            input: Input::over(inner, name),
            line: 1,
            col_base: 0,
            params: [0.0; MAX_PARAMS],
            nparams: 0,
            last: Spot {
                at: 0,
                line: 1,
                col_base: 0,
            },
            last_sym: ' ',
        }
    }

    /// Where the read position is.
    #[inline]
    fn here(&self) -> Spot {
        Spot {
            at: self.input.offset(),
            line: self.line,
            col_base: self.col_base,
        }
    }

    /// Keep the text at `spot` quotable until the next call, however far
    /// the reader goes on (the start of an open polygon, reported at the
    /// end of the input).
    pub fn keep(&mut self, spot: Spot) {
        self.input.mark(spot.at);
    }

    /// An error at `spot`: `FILE:LINE:COL: error: ...`, the line and a
    /// caret. `spot` is the read position, the module just read, or the
    /// one [`Reader::keep`] holds.
    pub fn error_at(&mut self, spot: Spot, kind: TurtleError) -> Error {
        let (snippet, caret_col) = if self.input.holds(spot.at) {
            self.input.excerpt_at(spot.at)
        } else {
            // Past the buffer's history only a parameter list reaches
            // (one longer than the buffer, not closed): its module is
            // quoted by its symbol and `(`.
            let shown = if spot.at == self.last.at {
                format!("{}(...", self.last_sym)
            } else {
                "...".to_string()
            };
            (shown, 1)
        };
        Error::at(
            Location {
                path: self.input.name.clone(),
                line: spot.line,
                col: usize::try_from(spot.col()).unwrap_or(usize::MAX),
                snippet,
                caret_col,
            },
            kind,
        )
    }

    #[inline]
    fn peek(&mut self) -> Result<Option<u8>, Error> {
        if let Some(b) = self.input.peek() {
            return Ok(Some(b));
        }
        Ok(self.input.fill(1)?.first().copied())
    }

    /// The next byte that is no blank (not consumed), or `None` at the end.
    #[inline]
    fn skip_blanks(&mut self) -> Result<Option<u8>, Error> {
        match self.input.peek() {
            Some(b) if !matches!(b, b' ' | b'\t' | b'\r' | b'\n') => Ok(Some(b)),
            _ => self.skip_blanks_slow(),
        }
    }

    #[cold]
    fn skip_blanks_slow(&mut self) -> Result<Option<u8>, Error> {
        loop {
            match self.peek()? {
                Some(b'\n') => {
                    self.input.consume(1);
                    self.line += 1;
                    self.col_base = self.input.offset();
                }
                Some(b' ' | b'\t' | b'\r') => self.input.consume(1),
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
        let here = self.here();
        self.last = here;
        let sym = if b < 0x80 {
            if b < 0x20 || b == 0x7f {
                return Err(self.error_at(here, TurtleError::ControlByte(b)));
            }
            // `,` outside a parameter list is a module (cpfg's colour
            // decrement), as in lsgen's language: `F,G` is three modules.
            if matches!(b, b'(' | b')') {
                return Err(self.error_at(here, TurtleError::Unexpected(b as char)));
            }
            self.input.consume(1);
            b as char
        } else {
            let c = self.char_here()?;
            let Some(c) = c else {
                return Err(self.error_at(here, TurtleError::InvalidUtf8));
            };
            let len = c.len_utf8();
            self.input.consume(len);
            self.col_base += len as u64 - 1;
            c
        };
        self.nparams = 0;
        self.last_sym = sym;
        if self.peek()? == Some(b'(') {
            self.input.consume(1);
            self.read_params(here)?;
        }
        Ok(Some(sym))
    }

    /// The character at the read position (not consumed), or `None` for
    /// bytes that are not UTF-8.
    fn char_here(&mut self) -> Result<Option<char>, Error> {
        let avail = self.input.fill(4)?;
        let len = match avail.first() {
            Some(0xc2..=0xdf) => 2,
            Some(0xe0..=0xef) => 3,
            Some(0xf0..=0xf4) => 4,
            Some(&b) if b < 0x80 => 1,
            _ => return Ok(None),
        };
        Ok(avail
            .get(..len)
            .and_then(|b| std::str::from_utf8(b).ok())
            .and_then(|s| s.chars().next()))
    }

    fn read_params(&mut self, module: Spot) -> Result<(), Error> {
        let mut n = 0;
        loop {
            self.skip_blanks()?;
            let here = self.here();
            // A number: up to 64 bytes of [0-9+-.eE].
            let avail = self.input.fill(MAX_NUMBER + 1)?;
            let is_num =
                |c: &&u8| c.is_ascii_digit() || matches!(c, b'+' | b'-' | b'.' | b'e' | b'E');
            let len = avail.iter().take(MAX_NUMBER + 1).take_while(is_num).count();
            if len > MAX_NUMBER {
                return Err(self.error_at(here, TurtleError::NumberTooLong(MAX_NUMBER)));
            }
            let text = std::str::from_utf8(&avail[..len]).unwrap_or("");
            let v = match text.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                // Digits past the largest number (`1e400`): a number all
                // the same, out of range, as lsgen says of it.
                Ok(_) => {
                    let kind = TurtleError::NumberOutOfRange(text.to_string());
                    return Err(self.error_at(here, kind));
                }
                _ => {
                    let shown: String = String::from_utf8_lossy(&avail[..avail.len().min(20)])
                        .chars()
                        .take_while(|c| !matches!(c, ',' | ')' | '\n'))
                        .collect();
                    return Err(if avail.is_empty() {
                        self.error_at(module, TurtleError::ParamsNotClosed)
                    } else {
                        self.error_at(here, TurtleError::ExpectedNumber(shown))
                    });
                }
            };
            self.input.consume(len);
            if n < MAX_PARAMS {
                self.params[n] = v;
            }
            n += 1;
            match self.skip_blanks()? {
                Some(b',') => self.input.consume(1),
                Some(b')') => {
                    self.input.consume(1);
                    self.nparams = n.min(MAX_PARAMS);
                    return Ok(());
                }
                None => return Err(self.error_at(module, TurtleError::ParamsNotClosed)),
                Some(_) => {
                    let here = self.here();
                    let kind = match self.char_here()? {
                        Some(c) => TurtleError::ExpectedCommaOrParen(c),
                        None => TurtleError::InvalidUtf8,
                    };
                    return Err(self.error_at(here, kind));
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
            "in:1:2: error: parameter list not closed: `(` without `)`\nFF(1\n ^\n"
        );
        assert_eq!(
            all("F(x)").unwrap_err(),
            "in:1:3: error: expected a number, found `x`\nF(x)\n  ^\n"
        );
        assert_eq!(
            all("F(1;2)").unwrap_err(),
            "in:1:4: error: expected `,` or `)`, found `;`\nF(1;2)\n   ^\n"
        );
        assert_eq!(
            all("F\u{1}").unwrap_err(),
            "in:1:2: error: unexpected control character 0x01\nF\u{fffd}\n ^\n"
        );
        assert!(all("F\u{ff}").is_ok());
        assert_eq!(
            all("F(2,-1e400)").unwrap_err(),
            "in:1:5: error: number `-1e400` is out of range (past the largest number, about 1.8e308)\nF(2,-1e400)\n    ^\n"
        );
        assert_eq!(
            all_bytes(b"F\xff").unwrap_err(),
            "in:1:2: error: invalid UTF-8\nF\u{fffd}\n ^\n"
        );
        // Not a `,` or `)`: the character (escaped as lsgen's lexer
        // escapes one), not its first byte.
        assert_eq!(
            all("F(1é)").unwrap_err(),
            "in:1:4: error: expected `,` or `)`, found `\\u{e9}`\nF(1é)\n   ^\n"
        );
        assert_eq!(
            all_bytes(b"F(1\xff)").unwrap_err(),
            "in:1:4: error: invalid UTF-8\nF(1\u{fffd})\n   ^\n"
        );
    }

    #[test]
    fn errors_are_located_by_line_and_character() {
        // Lines counted at `\n`, columns in characters (`é` is two bytes,
        // `漢` three), the caret under the module by display width.
        assert_eq!(
            all("F\n é漢F(1,\n x)").unwrap_err(),
            "in:3:2: error: expected a number, found `x`\n x)\n ^\n"
        );
        assert_eq!(
            all("F\né漢 (").unwrap_err(),
            "in:2:4: error: unexpected `(`\né漢 (\n    ^\n"
        );
        // A line of a million modules is quoted around the spot.
        let mut long = "F".repeat(1_000_000);
        long.push_str("F(1;2)");
        let e = all(&long).unwrap_err();
        // 60 characters before the spot, after `...`.
        assert_eq!(
            e,
            format!(
                "in:1:1000004: error: expected `,` or `)`, found `;`\n...{}(1;2)\n{}^\n",
                "F".repeat(58),
                " ".repeat(63)
            )
        );
    }

    #[test]
    fn kept_spots_and_long_parameter_lists_are_quoted() {
        // The kept spot stays quotable however far the reader goes.
        let text = format!("F{{F{}", "+F".repeat(500_000));
        let mut r = Reader::new(text.as_bytes(), "in");
        r.next_module().unwrap();
        r.next_module().unwrap();
        let open = r.last;
        r.keep(open);
        while r.next_module().unwrap().is_some() {}
        assert_eq!(
            r.error_at(open, TurtleError::PolygonNotClosed).to_string(),
            format!(
                "in:1:2: error: polygon not closed: `{{` without `}}`\nF{{F{}+...\n ^\n",
                "+F".repeat(29)
            )
        );
        // A parameter list not closed after more than the buffer holds:
        // its module by symbol and `(`, at its line and column.
        let text = format!("F\n G(1{}", ",1".repeat(1_000_000));
        assert_eq!(
            all(&text).unwrap_err(),
            "in:2:2: error: parameter list not closed: `(` without `)`\nG(...\n^\n"
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
        let l = e.location().unwrap();
        assert_eq!((l.path.as_str(), l.line, l.col), ("in", 1, 1));
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
