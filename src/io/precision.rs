//! `--precision N`: the final string's parameters with N significant
//! digits, as C's `%.Ng` (cpfg prints `%g`, 6 digits), applied in one place
//! for every strategy: a filter on the text on its way out. Exponents are
//! written as lsgen writes them by default (`1.23e6`, `1e-5`: no `+`, no
//! leading zeros), so the output still reads back as an axiom.

use std::fmt::Write as _;
use std::io::{self, Write};

/// Most significant digits accepted (an f64 holds 17).
pub const MAX_PRECISION: u32 = 17;

/// Append `v` with `digits` significant digits, `%g` style: scientific when
/// the exponent is below -4 or at least `digits`, trailing zeros dropped.
/// `scratch` is reused, so nothing is allocated once it has grown. With
/// `c_exponent` the exponent is exactly as C's `%g` writes it: a sign and
/// at least two digits (`1.67772e+07`, `1e-05`), as cpfg prints (the cpfg
/// dialect's output); else as lsgen writes numbers (`1.67772e7`).
pub fn put_g(out: &mut Vec<u8>, scratch: &mut String, v: f64, digits: u32, c_exponent: bool) {
    let p = digits.clamp(1, MAX_PRECISION) as usize;
    if !v.is_finite() || v == 0.0 {
        if v == 0.0 && v.is_sign_negative() {
            out.extend_from_slice(b"-0");
        } else if v == 0.0 {
            out.push(b'0');
        } else {
            let _ = write!(out, "{v}");
        }
        return;
    }
    scratch.clear();
    let _ = write!(scratch, "{:.*e}", p - 1, v);
    let Some(at) = scratch.find('e') else {
        out.extend_from_slice(scratch.as_bytes());
        return;
    };
    let exp: i32 = scratch[at + 1..].parse().unwrap_or(0);
    if exp < -4 || exp >= p as i32 {
        out.extend_from_slice(trim_zeros(&scratch.as_bytes()[..at]));
        if c_exponent {
            let sign = if exp < 0 { '-' } else { '+' };
            let _ = write!(out, "e{sign}{:02}", exp.unsigned_abs());
        } else {
            let _ = write!(out, "e{exp}");
        }
    } else {
        scratch.clear();
        let _ = write!(scratch, "{:.*}", (p as i32 - 1 - exp) as usize, v);
        out.extend_from_slice(trim_zeros(scratch.as_bytes()));
    }
}

/// `1.500` -> `1.5`, `2.000` -> `2`; a number without `.` is left alone.
fn trim_zeros(s: &[u8]) -> &[u8] {
    if !s.contains(&b'.') {
        return s;
    }
    let mut end = s.len();
    while end > 0 && s[end - 1] == b'0' {
        end -= 1;
    }
    if end > 0 && s[end - 1] == b'.' {
        end -= 1;
    }
    &s[..end]
}

/// A writer that rewrites each parameter of the module text going through
/// it (the numbers between `(`, `,` and `)`) with `digits` significant
/// digits. Memory is bounded: a number longer than any lsgen prints is
/// passed through as it is.
pub struct Significant<W: Write> {
    inner: W,
    digits: u32,
    /// C's exponent form (`e+07`), see [`put_g`].
    c_exponent: bool,
    in_params: bool,
    /// The current parameter's text is longer than [`MAX_TOKEN`]: passed
    /// through up to its end.
    long: bool,
    token: Vec<u8>,
    buf: Vec<u8>,
    scratch: String,
    /// Rewritten numbers by their text, direct mapped: parameters repeat,
    /// and formatting one costs far more than looking it up (the cpfg
    /// dialect rewrites every number). Made on first use.
    cache: Vec<CacheEntry>,
}

/// Longest number text held for rewriting.
const MAX_TOKEN: usize = 64;

/// Entries of [`Significant`]'s cache.
const CACHE_SIZE: usize = 1024;

/// A number's text and its rewriting (at most 17 digits, a sign, a point
/// and an exponent: well under 40 bytes).
#[derive(Clone, Copy)]
struct CacheEntry {
    tok_len: u8,
    out_len: u8,
    tok: [u8; MAX_TOKEN],
    out: [u8; 40],
}

const EMPTY: CacheEntry = CacheEntry {
    tok_len: u8::MAX,
    out_len: 0,
    tok: [0; MAX_TOKEN],
    out: [0; 40],
};

impl<W: Write> Significant<W> {
    pub fn new(inner: W, digits: u32) -> Self {
        Significant {
            inner,
            digits,
            c_exponent: false,
            in_params: false,
            long: false,
            token: Vec::with_capacity(MAX_TOKEN + 1),
            buf: Vec::with_capacity(1 << 16),
            scratch: String::with_capacity(64),
            cache: Vec::new(),
        }
    }

    /// Write exponents as C's `%g` does (`e+07`), see [`put_g`].
    pub fn c_exponent(mut self, on: bool) -> Self {
        self.c_exponent = on;
        self
    }

    fn emit_token(&mut self) {
        let t = &self.token;
        if t.len() > MAX_TOKEN {
            self.buf.extend_from_slice(t);
            self.token.clear();
            return;
        }
        if self.cache.is_empty() {
            self.cache = vec![EMPTY; CACHE_SIZE];
        }
        // FNV-1a of the text.
        let mut h: u32 = 0x811c_9dc5;
        for &b in t {
            h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
        let at = h as usize % CACHE_SIZE;
        let e = &self.cache[at];
        if usize::from(e.tok_len) == t.len() && e.tok[..t.len()] == t[..] {
            self.buf.extend_from_slice(&e.out[..usize::from(e.out_len)]);
            self.token.clear();
            return;
        }
        let start = self.buf.len();
        self.emit_uncached();
        let out = &self.buf[start..];
        let e = &mut self.cache[at];
        if out.len() <= e.out.len() {
            let t = &self.token;
            e.tok[..t.len()].copy_from_slice(t);
            e.tok_len = t.len() as u8;
            e.out[..out.len()].copy_from_slice(out);
            e.out_len = out.len() as u8;
        }
        self.token.clear();
    }

    fn emit_uncached(&mut self) {
        let parsed = std::str::from_utf8(&self.token)
            .ok()
            .and_then(|s| s.parse::<f64>().ok());
        match parsed {
            Some(v) if self.token.len() <= MAX_TOKEN => put_g(
                &mut self.buf,
                &mut self.scratch,
                v,
                self.digits,
                self.c_exponent,
            ),
            _ => self.buf.extend_from_slice(&self.token),
        }
    }
}

impl<W: Write> Write for Significant<W> {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        let mut rest = data;
        while !rest.is_empty() {
            if !self.in_params {
                match rest.iter().position(|&b| b == b'(') {
                    Some(i) => {
                        self.buf.extend_from_slice(&rest[..=i]);
                        self.in_params = true;
                        rest = &rest[i + 1..];
                    }
                    None => {
                        self.buf.extend_from_slice(rest);
                        rest = &[];
                    }
                }
            } else {
                // A parameter's text, up to its `,` or `)`, in one piece.
                let end = rest.iter().position(|&b| b == b',' || b == b')');
                let part = &rest[..end.unwrap_or(rest.len())];
                if self.long {
                    self.buf.extend_from_slice(part);
                } else {
                    self.token.extend_from_slice(part);
                    if self.token.len() > MAX_TOKEN {
                        // Not a number lsgen wrote: pass it on unchanged.
                        self.buf.extend_from_slice(&self.token);
                        self.token.clear();
                        self.long = true;
                    }
                }
                match end {
                    Some(i) => {
                        let b = rest[i];
                        if self.long {
                            self.long = false;
                        } else {
                            self.emit_token();
                        }
                        self.buf.push(b);
                        self.in_params = b == b',';
                        rest = &rest[i + 1..];
                    }
                    None => rest = &[],
                }
            }
        }
        if self.buf.len() >= 1 << 16 {
            self.inner.write_all(&self.buf)?;
            self.buf.clear();
        }
        Ok(data.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        // A number cut by the end of a write is still whole in the token;
        // only what is complete goes out.
        self.inner.write_all(&self.buf)?;
        self.buf.clear();
        self.inner.flush()
    }
}

impl<W: Write> Drop for Significant<W> {
    fn drop(&mut self) {
        // Errors here were already reported by the last flush, or the run
        // failed anyway; nothing may be lost on success, and the sink
        // flushes before it finishes.
        if !self.token.is_empty() {
            let t = std::mem::take(&mut self.token);
            self.buf.extend_from_slice(&t);
        }
        if !self.buf.is_empty() {
            let _ = self.inner.write_all(&self.buf);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g(v: f64, p: u32) -> String {
        let mut o = Vec::new();
        put_g(&mut o, &mut String::new(), v, p, false);
        String::from_utf8(o).unwrap()
    }

    #[test]
    fn cache_gives_what_formatting_gives() {
        // Many numbers, repeated, colliding in the cache: the filter's text
        // equals formatting each number afresh.
        let mut x: u64 = 12345;
        let mut vals = Vec::new();
        for _ in 0..5000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            vals.push(((x % 100_000) as f64 - 50_000.0) / 7.0);
        }
        let mut text = String::new();
        let mut want = Vec::new();
        for round in 0..3 {
            for (i, v) in vals.iter().enumerate() {
                if (i + round) % 3 == 0 {
                    continue;
                }
                text.push_str(&format!("F({v},1)"));
                want.extend_from_slice(b"F(");
                put_g(&mut want, &mut String::new(), *v, 6, true);
                want.extend_from_slice(b",1)");
            }
        }
        let mut out = Vec::new();
        {
            let mut w = Significant::new(&mut out, 6).c_exponent(true);
            for chunk in text.as_bytes().chunks(7) {
                w.write_all(chunk).unwrap();
            }
            w.flush().unwrap();
        }
        assert!(out == want);
    }

    #[test]
    fn c_exponent_like_printf_g() {
        // Expected: C's printf("%g") (checked by hand against glibc's).
        let c = |v: f64| {
            let mut o = Vec::new();
            put_g(&mut o, &mut String::new(), v, 6, true);
            String::from_utf8(o).unwrap()
        };
        assert_eq!(c(16777216.0), "1.67772e+07");
        assert_eq!(c(1e-30), "1e-30");
        assert_eq!(c(0.00001), "1e-05");
        assert_eq!(c(1.5e100), "1.5e+100");
        assert_eq!(c(123456.0), "123456");
        assert_eq!(c(-0.0), "-0");
    }

    #[test]
    fn like_printf_g() {
        // Expected: C's printf("%.Ng"), exponent in lsgen's form.
        assert_eq!(g(5.55555, 3), "5.56");
        assert_eq!(g(1234567.0, 3), "1.23e6");
        assert_eq!(g(0.000012345, 3), "1.23e-5");
        assert_eq!(g(100.0, 3), "100");
        assert_eq!(g(999.9, 3), "1e3");
        assert_eq!(g(0.0001, 3), "0.0001");
        assert_eq!(g(-2.5, 6), "-2.5");
        assert_eq!(g(9.9996, 4), "10");
        assert_eq!(g(1.0 / 3.0, 6), "0.333333");
        assert_eq!(g(-0.0, 6), "-0");
        assert_eq!(g(0.0, 6), "0");
        assert_eq!(g(123456.0, 6), "123456");
        assert_eq!(g(1234567.0, 6), "1.23457e6");
    }

    #[test]
    fn filter_rewrites_parameters_only() {
        let mut out = Vec::new();
        {
            let mut w = Significant::new(&mut out, 2);
            // Split mid-number: the token survives across writes.
            w.write_all(b"F(1.2345,6)[+(2").unwrap();
            w.write_all(b"2.7)]A12(0.0001234)\n").unwrap();
            w.flush().unwrap();
        }
        assert_eq!(out, b"F(1.2,6)[+(23)]A12(0.00012)\n");
    }
}
