//! From header text to syntax tree: the logos lexer feeds the LALRPOP
//! grammar, and lalrpop's `ParseError` is turned into our located error in
//! one place.

use crate::diag::{CodeMap, Error, ErrorKind, Location};
use crate::lang::ast;
use crate::lang::lexer::{LexError, Lexer, Span, Tok};
use crate::lang::sink::{Collect, HeaderSink, Reader};
use lalrpop_util::{lalrpop_mod, ParseError};

lalrpop_mod!(
    #[allow(clippy::all, clippy::pedantic, unused)]
    grammar,
    "/ls.rs"
);

/// An error raised by the lexer or by a grammar action.
#[derive(Clone, Debug, PartialEq)]
pub struct UserError {
    pub span: Span,
    pub message: String,
    /// Found by the lexer (else by the grammar).
    pub lexical: bool,
}

impl UserError {
    pub fn new(span: Span, message: impl Into<String>) -> UserError {
        UserError {
            span,
            message: message.into(),
            lexical: false,
        }
    }
}

impl From<LexError> for UserError {
    fn from(e: LexError) -> UserError {
        UserError {
            span: e.span,
            message: e.message,
            lexical: true,
        }
    }
}

/// Parse the header (everything before `axiom:`) into a whole syntax tree.
pub fn parse_header(text: &str) -> Result<ast::Header, UserError> {
    let mut collect = Collect::default();
    parse_into(text, &mut collect)?;
    Ok(collect.header)
}

/// Parse the header, handing it to `sink` as it is read (the productions
/// one at a time). The sink keeps going after an error of its own: a
/// syntax error anywhere, returned here, comes first.
pub fn parse_into(text: &str, sink: &mut dyn HeaderSink) -> Result<(), UserError> {
    let lexer = Lexer::new(text).map(|t| t.map_err(UserError::from));
    let mut reader = Reader::new(sink);
    let finish = grammar::HeaderParser::new()
        .parse(&mut reader, lexer)
        .map_err(|e| convert(e, text))?;
    match finish.context {
        Some(c) => Err(c.error(text)),
        None => Ok(()),
    }
}

/// The last section keyword (`productions`, `decomposition`,
/// `homomorphism`) that starts a line of `text`, and how many times each
/// of the latter two occurs.
fn last_section(text: &str) -> (Option<&'static str>, usize, usize) {
    let mut last = None;
    let (mut d, mut h) = (0, 0);
    for line in text.lines() {
        let l = line.trim_start().to_ascii_lowercase();
        if l.starts_with("productions") {
            last = Some("productions");
        } else if l.starts_with("decomposition:") {
            last = Some("decomposition");
            d += 1;
        } else if l.starts_with("homomorphism:") {
            last = Some("homomorphism");
            h += 1;
        }
    }
    (last, d, h)
}

/// Parse a lone expression (an axiom parameter).
pub fn parse_expr(text: &str) -> Result<ast::Expr, UserError> {
    let lexer = Lexer::new_expr(text)
        .filter(|t| !matches!(t, Ok((_, Tok::Nl, _))))
        .map(|t| t.map_err(UserError::from));
    grammar::ExprParser::new()
        .parse(&mut Reader::new(&mut Collect::default()), lexer)
        .map_err(|e| convert(e, text))
}

/// Locate a header-relative error for display: a lexical or a parse error.
pub fn locate(path: &str, text: &str, e: UserError) -> Error {
    let map = CodeMap::new(text);
    let stage = if e.lexical {
        ErrorKind::Lexical
    } else {
        ErrorKind::Parse
    };
    Error::at(Location::from_map(path, &map, e.span.0), e.message).in_stage(stage)
}

fn describe_expected(expected: &[String]) -> String {
    let has = |s: &str| expected.iter().any(|e| e == s);
    if has("\"->\"") {
        return "expected `->`".into();
    }
    let names: Vec<String> = expected
        .iter()
        .map(|e| match e.as_str() {
            "Nl" => "end of line".to_string(),
            "Sym" => "a symbol".to_string(),
            "Num" => "a number".to_string(),
            "Ident" => "an identifier".to_string(),
            other => format!("`{}`", other.trim_matches('"')),
        })
        .collect();
    match names.len() {
        0 => String::new(),
        1 => format!("expected {}", names[0]),
        n if n <= 6 => format!("expected {} or {}", names[..n - 1].join(", "), names[n - 1]),
        _ => String::new(),
    }
}

fn convert(e: ParseError<usize, Tok<'_>, UserError>, text: &str) -> UserError {
    match e {
        ParseError::User { error } => error,
        ParseError::InvalidToken { location } => {
            UserError::new((location, location), "invalid token")
        }
        ParseError::UnrecognizedEof { location, expected } => {
            let exp = describe_expected(&expected);
            let loc = text[..location.min(text.len())].trim_end().len();
            UserError::new(
                (loc, loc),
                if exp.is_empty() {
                    "unexpected end of input".to_string()
                } else {
                    format!("unexpected end of input, {exp}")
                },
            )
        }
        ParseError::UnrecognizedToken {
            token: (l, tok, r),
            expected,
        } => {
            let exp = describe_expected(&expected);
            // After a comparison, in an expression: `1 < x < 3`.
            let in_expr = expected.iter().any(|e| e == "\"+\"");
            // `complete`: the message says all there is; no "expected ...".
            let (what, complete) = match &tok {
                Tok::Nl => ("unexpected end of line".to_string(), false),
                Tok::Gt | Tok::Lt | Tok::Le | Tok::Ge | Tok::EqEq | Tok::Ne | Tok::Assign
                    if in_expr =>
                {
                    (format!("unexpected {tok}: comparisons do not chain; write `a < x && x < b`"), true)
                }
                Tok::Gt => ("unexpected `>`: contexts are written only left of the arrow (`lc < pred > rc -> succ`)".to_string(), true),
                Tok::Lt => ("unexpected `<`: contexts are written only left of the arrow (`lc < pred > rc -> succ`)".to_string(), true),
                Tok::KwMaximumDepth => {
                    let (last, _, _) = last_section(&text[..l.min(text.len())]);
                    if matches!(last, Some("decomposition" | "homomorphism")) {
                        ("`maximum depth:` comes once, right after the section keyword".to_string(), true)
                    } else {
                        ("`maximum depth:` belongs to `decomposition:` or `homomorphism:`".to_string(), true)
                    }
                }
                Tok::KwDecomposition | Tok::KwHomomorphism if {
                    let (_, d, h) = last_section(&text[..l.min(text.len())]);
                    (tok == Tok::KwDecomposition && d > 0) || (tok == Tok::KwHomomorphism && h > 0)
                } => (format!("second {tok} section"), true),
                Tok::KwDecomposition => ("`decomposition:` comes after the productions and before `homomorphism:`".to_string(), true),
                Tok::KwProductions | Tok::KwProductionsN(_) | Tok::KwGroups(_) | Tok::KwGroup
                | Tok::KwHomomorphism | Tok::KwDerivationLength
                | Tok::KwDefine | Tok::KwSeed | Tok::KwIgnore | Tok::KwConsider => {
                    (format!("{tok} is out of place: the order is settings, `productions:`, `homomorphism:`, `axiom:`"), true)
                }
                // Quote a number as written (`.3`), not as read (`0.3`).
                Tok::Num(_) => match text.get(l..r) {
                    Some(written) => (format!("unexpected number `{written}`"), false),
                    None => (format!("unexpected {tok}"), false),
                },
                t => (format!("unexpected {t}"), false),
            };
            let msg = if exp.is_empty() || complete {
                what
            } else {
                format!("{what}, {exp}")
            };
            UserError::new((l, r), msg)
        }
        ParseError::ExtraToken { token: (l, tok, r) } => {
            UserError::new((l, r), format!("unexpected {tok}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::ast::{Expr, Setting};

    const ABOP_110: &str = "/* Parametric example, ABOP section 1.10 */
derivation length: 4
define: R = 1.456
seed: 42

productions:
A(x,y) : y <= 3 -> A(x*2, x+y)
A(x,y) : y > 3 -> B(x)A(x/y,0)
B(x) : x < 1 -> C
B(x) : x >= 1 -> B(x-1)

homomorphism:
C -> F(R)

";

    #[test]
    fn parses_the_reference_header() {
        let h = parse_header(ABOP_110).unwrap();
        assert_eq!(h.settings.len(), 3);
        assert!(
            matches!(&h.settings[1], Setting::Define(n, Expr::Num(v, _), _) if n == "R" && *v == 1.456)
        );
        assert_eq!(h.productions.len(), 4);
        assert_eq!(h.homomorphism.len(), 1);
        let p = &h.productions[1];
        assert_eq!(p.pred.sym, 'A');
        assert_eq!(p.pred.params.len(), 2);
        assert!(p.cond.is_some());
        assert_eq!(p.succ.len(), 2);
        assert_eq!(p.succ[0].sym, 'B');
    }

    #[test]
    fn contexts_and_probability() {
        let h = parse_header("productions:\nA(x) B < C(y) > [D(z)]E : x < z -> C(y+1) : 0.5\n")
            .unwrap();
        let p = &h.productions[0];
        assert_eq!(p.left.iter().map(|m| m.sym).collect::<String>(), "AB");
        assert_eq!(p.pred.sym, 'C');
        assert_eq!(p.right.iter().map(|m| m.sym).collect::<String>(), "[D]E");
        assert!(p.cond.is_some() && p.prob.is_some());
    }

    #[test]
    fn empty_successor_and_spaces() {
        let h = parse_header("productions:\nX ->\nF -> S ///// F\n").unwrap();
        assert!(h.productions[0].succ.is_empty());
        assert_eq!(h.productions[1].succ.len(), 7);
    }

    #[test]
    fn errors() {
        let e = parse_header("productions:\nF F\n").unwrap_err();
        assert!(e.message.contains("expected `->`"), "{}", e.message);
        let e = parse_header("productions:\nF -> G > H\n").unwrap_err();
        assert!(e.message.contains("unexpected `>`"), "{}", e.message);
        assert_eq!(e.span, (20, 21));
        let e = parse_header("productions:\nA B -> C\n").unwrap_err();
        assert!(
            e.message.contains("predecessor is one module"),
            "{}",
            e.message
        );
        let e = parse_header("productions:\nF -> F\nderivation length: 3\n").unwrap_err();
        assert!(e.message.contains("out of place"), "{}", e.message);
        let e = parse_header("productions:\nA(x) : 1 < x < 3 -> B\n").unwrap_err();
        assert!(e.message.contains("do not chain"), "{}", e.message);
        assert_eq!(e.span, (26, 27));
        let e = parse_header("productions:\nA(x) -> B(x == 1 >= 0)\n").unwrap_err();
        assert!(e.message.contains("do not chain"), "{}", e.message);
        let e = parse_header("productions:\nA(x -> B\n").unwrap_err();
        assert!(e.message.contains("unexpected"), "{}", e.message);
    }

    #[test]
    fn expression_parser() {
        assert!(parse_expr("1 + 2 * sin(x)").is_ok());
        assert!(parse_expr("1 +").is_err());
    }
}
