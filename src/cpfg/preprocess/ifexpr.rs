//! The values of `#if` expressions.

use super::*;

#[derive(Clone, Copy, Debug)]
pub(super) enum E {
    Num(V),
    Op(&'static str),
}

/// A value of an `#if` expression, as C computes it there: `intmax_t` or
/// `uintmax_t` (`unsigned`), both 64 bits here. An operation with an
/// unsigned operand is unsigned (C's usual arithmetic conversions), so
/// `-1 > 0u` holds and `0xFFFFFFFFFFFFFFFF > 0` too.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct V {
    /// The bits (two's complement when signed).
    pub(super) v: i64,
    pub(super) unsigned: bool,
}

impl V {
    pub(super) fn signed(v: i64) -> V {
        V { v, unsigned: false }
    }

    fn truth(b: bool) -> V {
        V::signed(b as i64)
    }

    fn is_true(self) -> bool {
        self.v != 0
    }
}

/// Longest first.
pub(super) const OPS: &[&str] = &[
    "||", "&&", "==", "!=", "<=", ">=", "<<", ">>", "<", ">", "+", "-", "*", "/", "%", "&", "|",
    "^", "!", "~", "?", ":",
];

/// An integer literal: unsigned with a `u` suffix, or when it does not
/// fit `intmax_t` (as gcc and cpfg's cccp take it).
pub(super) fn parse_int(s: &str) -> Result<V, IfError> {
    let body = s.trim_end_matches(['u', 'U', 'l', 'L']);
    let suffix_u = s[body.len()..].contains(['u', 'U']);
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
        .map(|v| V {
            v: v as i64,
            unsigned: suffix_u || v > i64::MAX as u64,
        })
        .map_err(|_| IfError::IntegerTooLarge(s.to_string()))
}

pub(super) fn parse_char(s: &str) -> Result<V, IfError> {
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
    Ok(V::signed(v))
}

pub(super) type ERes = Result<V, (IfError, Pos)>;

/// Precedence climbing over `#if` tokens; `ev == false` parses without
/// evaluating (the untaken side of `&&`, `||`, `?:`).
pub(super) struct ExprParser<'a> {
    pub(super) toks: &'a [(E, Pos)],
    pub(super) i: usize,
    pub(super) end: Pos,
    /// Recursion depth (parentheses, unary operators, `?:`).
    pub(super) depth: usize,
}

/// Deepest `#if` nesting of parentheses, unary operators and `?:`.
pub(super) const MAX_EXPR_DEPTH: usize = 128;

impl ExprParser<'_> {
    pub(super) fn peek_op(&self) -> Option<&'static str> {
        match self.toks.get(self.i) {
            Some((E::Op(o), _)) => Some(o),
            _ => None,
        }
    }

    pub(super) fn pos(&self) -> Pos {
        self.toks.get(self.i).map_or(self.end, |t| t.1)
    }

    pub(super) fn comma(&mut self, ev: bool) -> ERes {
        let mut v = self.cond(ev)?;
        while self.peek_op() == Some(",") {
            self.i += 1;
            v = self.cond(ev)?;
        }
        Ok(v)
    }

    pub(super) fn enter(&mut self) -> Result<(), (IfError, Pos)> {
        self.depth += 1;
        if self.depth > MAX_EXPR_DEPTH {
            return Err((IfError::NestedTooDeeply(MAX_EXPR_DEPTH), self.pos()));
        }
        Ok(())
    }

    pub(super) fn cond(&mut self, ev: bool) -> ERes {
        let c = self.binary(0, ev)?;
        if self.peek_op() != Some("?") {
            return Ok(c);
        }
        self.enter()?;
        self.i += 1;
        let a = self.comma(ev && c.is_true())?;
        if self.peek_op() != Some(":") {
            return Err((IfError::MissingColon, self.pos()));
        }
        self.i += 1;
        let b = self.cond(ev && !c.is_true())?;
        self.depth -= 1;
        // The type of both branches' usual conversions.
        let unsigned = a.unsigned || b.unsigned;
        let v = if c.is_true() { a.v } else { b.v };
        Ok(V { v, unsigned })
    }

    /// Operators of precedence `level` and higher (0 is `||`).
    pub(super) fn binary(&mut self, level: usize, ev: bool) -> ERes {
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
                "||" => ev && !a.is_true(),
                "&&" => ev && a.is_true(),
                _ => ev,
            };
            let b = self.binary(p + 1, ev_b)?;
            a = binary_op(op, a, b, ev).map_err(|e| (e, at))?;
        }
        Ok(a)
    }

    pub(super) fn unary(&mut self, ev: bool) -> ERes {
        self.enter()?;
        let r = self.unary_inner(ev);
        self.depth -= 1;
        r
    }

    pub(super) fn unary_inner(&mut self, ev: bool) -> ERes {
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
            E::Op("-") => {
                let a = self.unary(ev)?;
                Ok(V {
                    v: a.v.wrapping_neg(),
                    ..a
                })
            }
            E::Op("+") => self.unary(ev),
            E::Op("!") => Ok(V::truth(!self.unary(ev)?.is_true())),
            E::Op("~") => {
                let a = self.unary(ev)?;
                Ok(V { v: !a.v, ..a })
            }
            E::Op(o) => Err((IfError::Unexpected(o.to_string()), at)),
        }
    }
}

/// `a op b` for a binary operator other than `&&`, `||` (whose right side
/// `ev == false` did not evaluate: a division by zero there is no error).
fn binary_op(op: &str, a: V, b: V, ev: bool) -> Result<V, IfError> {
    let unsigned = a.unsigned || b.unsigned;
    let (x, y) = (a.v, b.v);
    let (ux, uy) = (x as u64, y as u64);
    let arith = |v: i64| V { v, unsigned };
    let cmp = |signed: bool, unsigned_: bool| V::truth(if unsigned { unsigned_ } else { signed });
    Ok(match op {
        "||" => V::truth(a.is_true() || b.is_true()),
        "&&" => V::truth(a.is_true() && b.is_true()),
        "|" => arith(x | y),
        "^" => arith(x ^ y),
        "&" => arith(x & y),
        "==" => V::truth(x == y),
        "!=" => V::truth(x != y),
        "<" => cmp(x < y, ux < uy),
        ">" => cmp(x > y, ux > uy),
        "<=" => cmp(x <= y, ux <= uy),
        ">=" => cmp(x >= y, ux >= uy),
        // A shift has its left operand's type; a count past 63 (or, signed,
        // below -63) shifts everything out.
        "<<" | ">>" => {
            let count = if b.unsigned && y < 0 { i64::MAX } else { y };
            let count = if op == ">>" {
                count.saturating_neg()
            } else {
                count
            };
            V {
                v: shift(a, count),
                unsigned: a.unsigned,
            }
        }
        "+" => arith(x.wrapping_add(y)),
        "-" => arith(x.wrapping_sub(y)),
        "*" => arith(x.wrapping_mul(y)),
        _ if y == 0 => {
            if ev {
                return Err(IfError::DivisionByZero);
            }
            arith(0)
        }
        "/" if unsigned => arith((ux / uy) as i64),
        "/" => arith(x.wrapping_div(y)),
        _ if unsigned => arith((ux % uy) as i64),
        _ => arith(x.wrapping_rem(y)),
    })
}

/// `a << s` for s >= 0, `a >> -s` otherwise (arithmetic when `a` is
/// signed, logical when unsigned; saturating).
pub(super) fn shift(a: V, s: i64) -> i64 {
    let x = a.v;
    if s >= 64 {
        0
    } else if s >= 0 {
        x << s
    } else if s <= -64 {
        if x < 0 && !a.unsigned {
            -1
        } else {
            0
        }
    } else if a.unsigned {
        ((x as u64) >> -s) as i64
    } else {
        x >> -s
    }
}

impl Pp<'_> {
    pub(super) fn eval_if(&mut self, toks: Vec<Tok>, at: Pos) -> Res<bool> {
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
                K::Ident => ex.push((E::Num(V::signed(0)), p)),
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
        r.map(V::is_true)
            .map_err(|(e, q)| self.err(q, PpErrorKind::BadExpression(e)))
    }
}
