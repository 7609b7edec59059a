//! cpfg's statement blocks, compiled (issue 12): `Start:`, `StartEach:`,
//! `EndEach:`, `End:` and the pre- and post-condition blocks of
//! productions. Expressions are the one evaluator's ([`Code`]); an
//! assignment stores into a slot of the production (a formal parameter)
//! or into a run variable (a global, or a production's local), kept by the
//! generator ([`Draw::global`]).
//!
//! Loops are bounded: a `while` or `do … while` that runs
//! [`MAX_ITERATIONS`] times in one execution stops the run with a located
//! error (cpfg would hang).

use crate::derive::random::Draw;
use crate::diag::{CompileError, ExprError};
use crate::lang::lexer::Span;
use crate::rules::expr::{Code, EvalError};

/// Most iterations of loops, all of a block's loops together (nested
/// ones included), in one execution of the block: a budget per loop let
/// two nested loops of 9 million iterations each run for days.
pub const MAX_ITERATIONS: u64 = 10_000_000;

/// Where an assignment stores.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Var {
    /// A slot of the production being applied (a formal parameter).
    Local(u32),
    /// A run variable: a global, or a production's local (cpfg keeps
    /// those between applications).
    Global(u32),
    /// cpfg's built-in `Q`, the step number: a global that Derive sets
    /// to the step at the start of each step ([`Draw::assign_step`]).
    Step,
}

/// A compiled statement.
#[derive(Clone, Debug)]
pub enum Stmt {
    Assign(Var, Code),
    If(Code, Block, Block),
    While(Code, Block, Span),
    DoWhile(Block, Code, Span),
    /// `printf` / `fprintf(stderr, …)`: to standard error in the binary,
    /// an [`crate::Event::Printf`] in the library (`diag::printf`).
    Printf(Format, Box<[Code]>, Span),
    /// An expression for its effect (`srand(3);`).
    Eval(Code),
    /// `a[i][j] = value;`: the value, then the element's variable number
    /// (the code of [`crate::rules::expr::cpfg_array`]'s write form), as
    /// cpfg's `AssignArrayElement(LHS, Eval(value))` evaluates them.
    AssignElement(Code, Code),
    /// `define:`'s arrays at the start of a run (cpfg's
    /// `ProcessArrayDef`, before `Start:`): the array at variable `.0` of
    /// `.1` elements takes the initial values in order, 0 past their end
    /// (values past its last element are not evaluated).
    InitArray(u32, u32, Box<[Code]>),
}

/// A block: statements in order.
#[derive(Clone, Debug, Default)]
pub struct Block(pub Box<[Stmt]>);

impl Block {
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Run the block: locals in `slots`, globals in `rng`.
    pub fn run<D: Draw + ?Sized>(
        &self,
        slots: &mut [f64],
        stack: &mut Vec<f64>,
        rng: &mut D,
    ) -> Result<(), EvalError> {
        self.run_within(slots, stack, rng, &mut { MAX_ITERATIONS })
    }

    /// [`Block::run`], its loops' iterations counted down from `left`.
    fn run_within<D: Draw + ?Sized>(
        &self,
        slots: &mut [f64],
        stack: &mut Vec<f64>,
        rng: &mut D,
        left: &mut u64,
    ) -> Result<(), EvalError> {
        for s in self.0.iter() {
            match s {
                Stmt::Assign(v, e) => {
                    let x = e.eval(slots, stack, rng)?;
                    match *v {
                        Var::Local(i) => slots[i as usize] = x,
                        Var::Global(i) => rng.set_global(i, x),
                        Var::Step => rng.assign_step(x),
                    }
                }
                Stmt::If(c, then, els) => {
                    if c.eval(slots, stack, rng)? != 0.0 {
                        then.run_within(slots, stack, rng, left)?;
                    } else {
                        els.run_within(slots, stack, rng, left)?;
                    }
                }
                Stmt::While(c, body, span) => {
                    while c.eval(slots, stack, rng)? != 0.0 {
                        spend(left, "while", span)?;
                        body.run_within(slots, stack, rng, left)?;
                    }
                }
                Stmt::DoWhile(body, c, span) => loop {
                    spend(left, "do … while", span)?;
                    body.run_within(slots, stack, rng, left)?;
                    if c.eval(slots, stack, rng)? == 0.0 {
                        break;
                    }
                },
                Stmt::Printf(f, args, _) => {
                    let mut vals = Vec::with_capacity(args.len());
                    for a in args.iter() {
                        vals.push(a.eval(slots, stack, rng)?);
                    }
                    crate::diag::printf(f.render(&vals));
                }
                Stmt::Eval(e) => {
                    e.eval(slots, stack, rng)?;
                }
                Stmt::AssignElement(at, value) => {
                    let x = value.eval(slots, stack, rng)?;
                    let var = at.eval(slots, stack, rng)?;
                    rng.set_global(var as u32, x);
                }
                Stmt::InitArray(base, total, init) => {
                    for i in 0..*total {
                        let x = match init.get(i as usize) {
                            Some(c) => c.eval(slots, stack, rng)?,
                            None => 0.0,
                        };
                        rng.set_global(base + i, x);
                    }
                }
            }
        }
        Ok(())
    }
}

/// One more iteration of the loop at `span`, if the block has any left.
fn spend(left: &mut u64, what: &'static str, span: &Span) -> Result<(), EvalError> {
    *left = left.checked_sub(1).ok_or_else(|| runaway(what, *span))?;
    Ok(())
}

fn runaway(what: &'static str, span: Span) -> EvalError {
    EvalError {
        span,
        kind: ExprError::Runaway(what, MAX_ITERATIONS),
    }
}

/// A `printf` format, parsed at load time: text and conversions.
#[derive(Clone, Debug, PartialEq)]
pub struct Format(Box<[Piece]>);

#[derive(Clone, Debug, PartialEq)]
enum Piece {
    Text(String),
    Conv(Conv),
}

/// `%[flags][width][.precision]conv`.
#[derive(Clone, Debug, PartialEq)]
struct Conv {
    left: bool,
    plus: bool,
    space: bool,
    zero: bool,
    alt: bool,
    width: usize,
    prec: Option<usize>,
    conv: u8,
}

impl Format {
    /// Parse a C format string (escapes already decoded). The conversions
    /// `d i u o x X c f F e E g G` and `%%`; an error message otherwise.
    /// Returns the format and how many numbers it takes.
    pub fn parse(s: &str) -> Result<(Format, usize), CompileError> {
        let mut pieces = Vec::new();
        let mut text = String::new();
        let mut it = s.chars().peekable();
        let mut n = 0;
        while let Some(c) = it.next() {
            if c != '%' {
                text.push(c);
                continue;
            }
            if it.peek() == Some(&'%') {
                it.next();
                text.push('%');
                continue;
            }
            let mut cv = Conv {
                left: false,
                plus: false,
                space: false,
                zero: false,
                alt: false,
                width: 0,
                prec: None,
                conv: 0,
            };
            while let Some(&f) = it.peek() {
                match f {
                    '-' => cv.left = true,
                    '+' => cv.plus = true,
                    ' ' => cv.space = true,
                    '0' => cv.zero = true,
                    '#' => cv.alt = true,
                    _ => break,
                }
                it.next();
            }
            let num = |it: &mut std::iter::Peekable<std::str::Chars>| {
                let mut v = 0usize;
                while let Some(d) = it.peek().and_then(|c| c.to_digit(10)) {
                    v = (v * 10 + d as usize).min(4096);
                    it.next();
                }
                v
            };
            cv.width = num(&mut it);
            if it.peek() == Some(&'.') {
                it.next();
                cv.prec = Some(num(&mut it));
            }
            // Length modifiers mean nothing here: every value is a number.
            while matches!(it.peek(), Some('l' | 'h' | 'L')) {
                it.next();
            }
            match it.next() {
                Some(
                    c @ ('d' | 'i' | 'u' | 'o' | 'x' | 'X' | 'c' | 'f' | 'F' | 'e' | 'E' | 'g'
                    | 'G'),
                ) => cv.conv = c as u8,
                Some(c) => return Err(CompileError::PrintfConversion(c)),
                None => return Err(CompileError::PrintfUnfinished),
            }
            if !text.is_empty() {
                pieces.push(Piece::Text(std::mem::take(&mut text)));
            }
            pieces.push(Piece::Conv(cv));
            n += 1;
        }
        if !text.is_empty() {
            pieces.push(Piece::Text(text));
        }
        Ok((Format(pieces.into()), n))
    }

    /// The text for `vals` (missing values print as 0).
    pub fn render(&self, vals: &[f64]) -> String {
        let mut out = String::new();
        let mut vals = vals.iter().copied();
        for p in self.0.iter() {
            match p {
                Piece::Text(t) => out.push_str(t),
                Piece::Conv(c) => c.render(vals.next().unwrap_or(0.0), &mut out),
            }
        }
        out
    }
}

impl Conv {
    fn render(&self, v: f64, out: &mut String) {
        let upper = self.conv.is_ascii_uppercase();
        let (neg, body) = match self.conv {
            b'd' | b'i' | b'u' | b'o' | b'x' | b'X' | b'c' => {
                // C converts toward zero (the reference's `%d` too).
                let i = if v.is_finite() { v.trunc() } else { 0.0 };
                let neg = i < 0.0;
                let a = i.abs().min(u64::MAX as f64) as u64;
                let mut s = match self.conv {
                    b'o' => format!("{a:o}"),
                    b'x' => format!("{a:x}"),
                    b'X' => format!("{a:X}"),
                    b'c' => char::from_u32(a as u32)
                        .map(String::from)
                        .unwrap_or_default(),
                    _ => a.to_string(),
                };
                if let Some(p) = self.prec {
                    while s.len() < p {
                        s.insert(0, '0');
                    }
                }
                (neg, s)
            }
            _ if !v.is_finite() => {
                let s = if v.is_nan() { "nan" } else { "inf" };
                (
                    v.is_sign_negative() && !v.is_nan(),
                    if upper { s.to_uppercase() } else { s.into() },
                )
            }
            b'f' | b'F' => (
                v.is_sign_negative(),
                format!("{:.*}", self.prec.unwrap_or(6), v.abs()),
            ),
            b'e' | b'E' => (
                v.is_sign_negative(),
                exp_form(v.abs(), self.prec.unwrap_or(6), upper),
            ),
            _ => (
                v.is_sign_negative(),
                g_form(v.abs(), self.prec.unwrap_or(6), self.alt, upper),
            ),
        };
        let sign = if neg {
            "-"
        } else if self.plus {
            "+"
        } else if self.space {
            " "
        } else {
            ""
        };
        let len = sign.len() + body.chars().count();
        let pad = self.width.saturating_sub(len);
        if self.left {
            out.push_str(sign);
            out.push_str(&body);
            out.extend(std::iter::repeat_n(' ', pad));
        } else if self.zero && v.is_finite() {
            out.push_str(sign);
            out.extend(std::iter::repeat_n('0', pad));
            out.push_str(&body);
        } else {
            out.extend(std::iter::repeat_n(' ', pad));
            out.push_str(sign);
            out.push_str(&body);
        }
    }
}

/// C's `%.pe` of a non-negative finite `v`: `1.500000e+00`.
fn exp_form(v: f64, p: usize, upper: bool) -> String {
    let s = format!("{v:.p$e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    let x = if upper { 'E' } else { 'e' };
    format!("{m}{x}{sign}{:02}", e.abs())
}

/// C's `%.pg` of a non-negative finite `v`.
fn g_form(v: f64, p: usize, alt: bool, upper: bool) -> String {
    let p = p.max(1);
    if v == 0.0 {
        return if alt {
            format!("{:.*}", p - 1, 0.0)
        } else {
            "0".into()
        };
    }
    // The exponent after rounding to p significant digits.
    let e: i32 = format!("{:.*e}", p - 1, v)
        .split_once('e')
        .map_or(0, |(_, e)| e.parse().unwrap_or(0));
    let s = if e < -4 || e >= p as i32 {
        exp_form(v, p - 1, upper)
    } else {
        format!("{:.*}", (p as i32 - 1 - e) as usize, v)
    };
    if alt {
        return s;
    }
    // Trailing zeros of the fraction go.
    let (m, x) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], &s[i..]),
        None => (&s[..], ""),
    };
    let m = if m.contains('.') {
        m.trim_end_matches('0').trim_end_matches('.')
    } else {
        m
    };
    format!("{m}{x}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::derive::random::Random;
    use crate::lang::parse::parse_expr;
    use crate::rules::expr::{Scope, GLOBAL_SLOT};
    use std::collections::HashMap;

    fn fmt(f: &str, vals: &[f64]) -> String {
        Format::parse(f).unwrap().0.render(vals)
    }

    #[test]
    fn printf_formats_as_c() {
        // Expected strings: C's printf by hand (glibc's rules).
        assert_eq!(fmt("end: n=%g\n", &[9.0]), "end: n=9\n");
        assert_eq!(
            fmt("%g %g %g", &[0.0001, 123456.0, 1234567.0]),
            "0.0001 123456 1.23457e+06"
        );
        assert_eq!(fmt("%g|%g|%g", &[1e-5, -0.5, 100.0]), "1e-05|-0.5|100");
        assert_eq!(
            fmt("%d %5.2f|%-4d|%04d", &[-2.7, 3.14659, 7.0, -5.0]),
            "-2  3.15|7   |-005"
        );
        assert_eq!(fmt("%e %x %%", &[1234.5, 255.0]), "1.234500e+03 ff %");
        assert_eq!(fmt("%.3g %G", &[0.00012345, 1e20]), "0.000123 1E+20");
        assert_eq!(
            Format::parse("%d and %s").err().unwrap().to_string(),
            "printf: `%s` is not a conversion lsgen prints"
        );
        assert_eq!(Format::parse("a %g b %5.1f").unwrap().1, 2);
    }

    /// Compile `src` with locals `x` (slot 0), `y` (slot 1) and globals
    /// `g` (0), `h` (1).
    fn code(src: &str) -> Code {
        let params: HashMap<String, u32> = [
            ("x".to_string(), 0),
            ("y".to_string(), 1),
            ("g".to_string(), GLOBAL_SLOT),
            ("h".to_string(), GLOBAL_SLOT + 1),
        ]
        .into_iter()
        .collect();
        Code::compile(
            &parse_expr(src).unwrap(),
            &Scope {
                params: &params,
                consts: &HashMap::new(),
                cpfg: true,
            },
        )
        .unwrap()
    }

    fn block(stmts: Vec<Stmt>) -> Block {
        Block(stmts.into())
    }

    #[test]
    fn statements_run_in_order_with_locals_and_globals() {
        // g = 3; y = 0; while (x < g) { y = y + x; x = x + 1; }
        // do { h = h + 10; } while (h < 25); if (y > 2) {g = 100} else {g = -1}
        let b = block(vec![
            Stmt::Assign(Var::Global(0), code("3")),
            Stmt::Assign(Var::Local(1), code("0")),
            Stmt::While(
                code("x < g"),
                block(vec![
                    Stmt::Assign(Var::Local(1), code("y + x")),
                    Stmt::Assign(Var::Local(0), code("x + 1")),
                ]),
                (0, 1),
            ),
            Stmt::DoWhile(
                block(vec![Stmt::Assign(Var::Global(1), code("h + 10"))]),
                code("h < 25"),
                (0, 1),
            ),
            Stmt::If(
                code("y > 2"),
                block(vec![Stmt::Assign(Var::Global(0), code("100"))]),
                block(vec![Stmt::Assign(Var::Global(0), code("0 - 1"))]),
            ),
        ]);
        let mut rng = Random::new(0);
        let mut slots = [0.0, 0.0];
        b.run(&mut slots, &mut Vec::new(), &mut rng).unwrap();
        // x: 0, 1, 2 -> 3; y = 0 + 1 + 2 = 3; h: 10, 20, 30.
        assert_eq!(slots, [3.0, 3.0]);
        assert_eq!((rng.global(0), rng.global(1)), (100.0, 30.0));
        // A do-while body runs once even when the condition fails.
        let b = block(vec![Stmt::DoWhile(
            block(vec![Stmt::Assign(Var::Local(0), code("x + 1"))]),
            code("0"),
            (0, 1),
        )]);
        let mut slots = [5.0, 0.0];
        b.run(&mut slots, &mut Vec::new(), &mut rng).unwrap();
        assert_eq!(slots[0], 6.0);
    }

    #[test]
    fn a_runaway_loop_is_a_located_error() {
        let b = block(vec![Stmt::While(code("1"), Block::default(), (7, 12))]);
        let e = b
            .run(&mut [0.0, 0.0], &mut Vec::new(), &mut Random::new(0))
            .unwrap_err();
        assert_eq!(e.span, (7, 12));
        assert!(e.message().contains("10000000 times"), "{}", e.message());
    }
}
