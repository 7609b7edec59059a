//! Streaming axiom reader: modules one at a time from an [`Input`], with
//! line and column kept for errors. Plain numbers are read directly; any
//! other parameter text (`F(R*2)`) is parsed as an expression over the
//! `define:` constants.

use crate::codec::MAX_ARITY;
use crate::diag::{excerpt, Error, Location};
use crate::expr::{Code, Scope};
use crate::input::Input;
use crate::parse::parse_expr;
use crate::random::Random;
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
        }
    }

    /// An error at the current read position.
    fn error_here(&mut self, msg: impl Into<String>) -> Error {
        let at = self.input.offset();
        self.error_at(at, self.line, self.col, msg)
    }

    fn error_at(&mut self, at: u64, line: usize, col: usize, msg: impl Into<String>) -> Error {
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
                b'/' if self.comments && avail.get(1) == Some(&b'*') => {
                    let (line, col, at) = (self.line, self.col, self.input.offset());
                    self.advance(2);
                    loop {
                        let avail = self.input.fill(2)?;
                        match avail {
                            [] | [_] => {
                                return Err(self.error_at(
                                    at,
                                    line,
                                    col,
                                    "unterminated comment: `/*` without `*/`",
                                ))
                            }
                            [b'*', b'/', ..] => {
                                self.advance(2);
                                break;
                            }
                            [b'\n', ..] => {
                                self.input.consume(1);
                                self.line += 1;
                                self.col = 1;
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
            _ => Err(self.error_here("invalid UTF-8")),
        }
    }

    /// A run of plain modules at the read position: ASCII symbols without
    /// parameters, whose binary form is their own byte. `f` receives the
    /// run (possibly empty) before it is consumed. This is the fast path
    /// for long axioms; [`AxiomReader::next`] handles everything else.
    pub fn plain_run<T>(&mut self, f: impl FnOnce(&[u8]) -> T) -> Result<T, Error> {
        let base = self.input.offset();
        let avail = self.input.fill(64)?;
        let n = avail.len();
        let mut i = 0;
        while i < n && PLAIN[avail[i] as usize] {
            if avail[i] == b'/' && self.comments && avail.get(i + 1).is_none_or(|&b| b == b'*') {
                break;
            }
            i += 1;
        }
        // The last symbol may take parameters (`F(`, `F (`) or sit at the
        // end of what is buffered: leave it to the general path.
        if i > 0 && (i == n || avail[i] == b'(' || avail[i].is_ascii_whitespace()) {
            i -= 1;
        }
        let run = &avail[..i];
        // Brackets: stop before a `]` that closes nothing (reported by the
        // general path).
        let mut depth = self.depth;
        let mut end = run.len();
        for (j, &b) in run.iter().enumerate() {
            if b == b'[' {
                if depth == 0 {
                    self.first_open = (self.line, self.col + j, base + j as u64);
                }
                depth += 1;
            } else if b == b']' {
                if depth == 0 {
                    end = j;
                    break;
                }
                depth -= 1;
            }
        }
        self.depth = depth;
        let r = f(&run[..end]);
        self.col += end;
        self.input.consume(end);
        Ok(r)
    }

    /// The next module: its key, with its parameters in `params`.
    pub fn next(
        &mut self,
        alphabet: &mut Alphabet,
        params: &mut Vec<f64>,
        rng: &mut Random,
    ) -> Result<Option<u32>, Error> {
        params.clear();
        if !self.skip_blank()? {
            if self.depth > 0 {
                let (l, c, at) = self.first_open;
                let msg = format!("unbalanced brackets: the `[` at {l}:{c} is never closed");
                if self.input.holds(at) {
                    return Err(self.error_at(at, l, c, msg));
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
            '(' | ')' | ',' | ':' | '<' | '>' => {
                return Err(self.error_here(format!(
                    "`{sym}` is reserved and cannot be a symbol{}",
                    if sym == '(' {
                        " (parameters follow a symbol: `F(1)`)"
                    } else {
                        ""
                    }
                )))
            }
            c if c.is_control() => {
                return Err(self.error_here(format!(
                    "control character `{}` cannot be a symbol",
                    c.escape_default()
                )))
            }
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
                    return Err(self.error_at(
                        at,
                        line,
                        col,
                        "unbalanced brackets: `]` without `[`",
                    ));
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

    /// Read `( p, p, ... )` at the read position.
    fn read_params(&mut self, params: &mut Vec<f64>, rng: &mut Random) -> Result<(), Error> {
        let (line, col, at) = (self.line, self.col, self.input.offset());
        self.advance(1);
        let mut depth = 0usize;
        self.text.clear();
        let mut piece_start = (self.line, self.col, self.input.offset());
        loop {
            let avail = self.input.fill(1)?;
            let Some(&b) = avail.first() else {
                return Err(self.error_at(
                    at,
                    line,
                    col,
                    "unbalanced parentheses: `(` is never closed",
                ));
            };
            match b {
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
                b'\n' => {
                    self.text.push(b' ');
                    self.input.consume(1);
                    self.line += 1;
                    self.col = 1;
                    continue;
                }
                _ => {}
            }
            self.text.push(b);
            self.advance(1);
            if self.text.len() > MAX_PARAM_TEXT {
                return Err(self.error_at(
                    at,
                    line,
                    col,
                    "parameter list too long (over 1 MiB): is a `)` missing?",
                ));
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
            return Err(self.error_at(
                at,
                line,
                col,
                format!("a module has at most {MAX_ARITY} parameters"),
            ));
        }
        let raw = match std::str::from_utf8(&self.text) {
            Ok(r) => r.to_string(),
            Err(e) => {
                let good = e.valid_up_to();
                let prefix = String::from_utf8_lossy(&self.text[..good]);
                let c = col + prefix.chars().count();
                return Err(self.error_at(at + good as u64, line, c, "invalid UTF-8"));
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
            return Err(self.error_at(at, line, col, "empty parameter"));
        }
        let lead = raw.len() - raw.trim_start().len();
        let located = |s: &mut Self, off: usize, msg: String| {
            let prefix = &t[..off.min(t.len())];
            let c = col + lead + prefix.chars().count();
            let spot = at + (lead + off) as u64;
            if s.input.holds(spot) && s.input.holds(at) {
                return s.error_at(spot, line, c, msg);
            }
            // The text has scrolled out of the buffer: quote the parameter.
            let (snippet, caret_col) = excerpt(&raw, lead + prefix.chars().count() + 1);
            Error::at(
                Location {
                    path: s.input.name.clone(),
                    line,
                    col: c,
                    snippet,
                    caret_col,
                },
                msg,
            )
        };
        let e = match parse_expr(t) {
            Ok(e) => e,
            Err(e) => return Err(located(self, e.span.0, e.message)),
        };
        let empty = HashMap::new();
        let code = match Code::compile(
            &e,
            &Scope {
                params: &empty,
                consts: self.consts,
            },
        ) {
            Ok(c) => c,
            Err(e) => return Err(located(self, e.span.0, e.message)),
        };
        match code.eval(&[], &mut self.stack, rng) {
            Ok(v) => {
                params.push(v);
                Ok(())
            }
            Err(e) => Err(located(self, e.span.0, e.message)),
        }
    }
}

/// Bytes that are a whole module on their own when no `(` follows.
static PLAIN: [bool; 256] = {
    let mut t = [false; 256];
    let mut b = 0x21;
    while b < 0x7f {
        t[b] = !matches!(b as u8, b'(' | b')' | b',' | b':' | b'<' | b'>');
        b += 1;
    }
    t
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::Filter;

    fn read(src: &str) -> Result<Vec<(char, Vec<f64>)>, Error> {
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
            r.plain_run(|b| run.extend_from_slice(b))?;
            out.extend(run.iter().map(|&b| (b as char, vec![])));
            match r.next(&mut al, &mut p, &mut rng)? {
                Some(k) => out.push((al.symbol(k), p.clone())),
                None => break,
            }
        }
        Ok(out)
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
        assert_eq!(e.location.clone().unwrap().col, 100_001);
        let e = read("[[F]").unwrap_err();
        assert!(e.message.contains("1:1 is never closed"), "{}", e.message);
    }

    #[test]
    fn errors_are_located() {
        let e = read("F\nFF)").unwrap_err();
        let l = e.location.clone().unwrap();
        assert_eq!((l.line, l.col), (2, 3));
        assert!(e.message.contains("reserved"));
        assert_eq!(l.snippet, "FF)");
        let e = read("F(1,2").unwrap_err();
        assert!(e.message.contains("never closed"), "{}", e.message);
        let e = read("F]").unwrap_err();
        assert!(e.message.contains("without `[`"), "{}", e.message);
        let e = read("[F[G]").unwrap_err();
        assert!(e.message.contains("1:1 is never closed"), "{}", e.message);
        let e = read("F(1/0)").unwrap_err();
        assert_eq!(e.message, "division by zero");
        let e = read("F(x)").unwrap_err();
        let l = e.location.clone().unwrap();
        assert_eq!((l.line, l.col), (1, 3));
        let e = read("F /* open").unwrap_err();
        assert!(e.message.contains("unterminated comment"));
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
        assert_eq!(e.message, "invalid UTF-8");
        assert_eq!(e.location.clone().unwrap().col, 3);
    }
}
