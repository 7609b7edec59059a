//! From preprocessed cpfg text to syntax tree: the lexer's tokens, a scan
//! for the constructs lsgen refuses (each a located error naming it), the
//! LALRPOP grammar, and located parse errors.

use super::ast;
use super::lexer::{blank, misspaced_keyword, Lexer, Spanned, Tok};
use crate::diag::{Expected, ParseError as Syntax, Refused};
use crate::lang::parse::{HeaderError, UserError};
use lalrpop_util::{lalrpop_mod, ParseError};

lalrpop_mod!(
    #[allow(clippy::all, clippy::pedantic, unused)]
    grammar,
    "/cpfg.rs"
);

/// cpfg's curve functions (`src/cpfg/curve.rs`), which need curves.
const CURVE_FUNCTIONS: &[&str] = &["curveX", "curveY", "curveZ", "curveGAL"];

/// cpfg functions that need cpfg's files, view or animation.
const UNSUPPORTED_FUNCTIONS: &[&str] = &[
    "play",
    "vvXmin",
    "vvXmax",
    "vvYmin",
    "vvYmax",
    "vvZmin",
    "vvZmax",
    "vvScale",
    "Display",
    "SetDerivationLength",
    "GetDerivationLength",
    "stop",
    "fopen",
    "fclose",
    "fflush",
    "fscanf",
    "inblob",
];

/// Parse the preprocessed text of a `.l` file, whose run has no function
/// files: `func` is refused.
pub fn parse(text: &str) -> Result<ast::Lsystem, UserError> {
    parse_with(text, Some(None), Some(None))
}

/// [`parse`]; `no_functions`: the run has no function files, and `func`
/// is refused with this hint (a view file to give), else None;
/// `no_curves` likewise for the curve functions.
pub fn parse_with(
    text: &str,
    no_functions: Option<Option<String>>,
    no_curves: Option<Option<String>>,
) -> Result<ast::Lsystem, UserError> {
    // Tokens are checked for refused constructs as they stream into the
    // parser (one token of look-ahead; no token list is kept: memory is
    // the tree's, not the text's times a token's size).
    let mut checked = Checked {
        lex: Lexer::new(text),
        next: None,
        lsystems: 0,
        failed: false,
        no_functions,
        no_curves,
        strings: Vec::new(),
    };
    let mut tree = grammar::FileParser::new()
        .parse(&mut checked)
        .map_err(|e| respaced(text, convert(e, text, text.len())))?;
    tree.strings = checked.strings;
    Ok(*tree)
}

/// The modules of a run (a successor, a predecessor, a context:
/// [`ast::Run::modules`]), read again where the grammar read them. In a
/// run that parsed, every
/// character outside parentheses is a module's symbol or what the scanner
/// skips (blanks, a newline that a TAB continues): symbols are read as
/// characters, a module's parameters lexed again and each parsed as an
/// expression of the grammar (`grammar::ExprParser`), with one token
/// buffer for them all; or, for [`Shapes`], only counted.
pub struct RunModules<'a> {
    text: &'a str,
    /// Parse the parameters (else only count them).
    parse: bool,
    pos: usize,
    /// Modules still to read.
    left: usize,
    /// The tokens of the parameter being read.
    buf: Vec<Spanned<'a>>,
}

impl<'a> RunModules<'a> {
    pub(crate) fn new(text: &'a str, span: (usize, usize), len: usize) -> RunModules<'a> {
        RunModules {
            text,
            parse: true,
            pos: span.0,
            left: len,
            buf: Vec::new(),
        }
    }

    /// The next character the scanner does not skip, and where it is: on
    /// this line or one a TAB continues (None at another line's start: a
    /// successor's last module may end its line).
    fn next_char(&self, from: usize) -> Option<(usize, char)> {
        let bytes = self.text.as_bytes();
        let mut i = from;
        loop {
            match bytes.get(i)? {
                &c if blank(c) => i += 1,
                b'\n' if bytes.get(i + 1) == Some(&b'\t') => i += 2,
                b'\n' => return None,
                _ => return Some((i, self.text[i..].chars().next()?)),
            }
        }
    }

    /// The next module (its parameters left out unless `parse`), and how
    /// many parameters it has.
    fn module(&mut self) -> Result<(ast::Module, usize), UserError> {
        let end = self.text.len();
        let Some((l, sym)) = self.next_char(self.pos) else {
            return Err(UserError::new(
                (self.pos, end),
                Syntax::UnexpectedEof(Expected::Nothing),
            ));
        };
        let r = l + sym.len_utf8();
        self.pos = r;
        let span = (l, r);
        // (After the last module comes what the grammar read after the
        // run: not a `(`.)
        let Some((open, '(')) = self.next_char(r) else {
            let params = Vec::new();
            return Ok((ast::Module { sym, params, span }, 0));
        };
        let mut lex = Lexer::at_module(self.text, open);
        lex.next(); // the `(`
        let mut params = Vec::new();
        let mut arity = 0;
        let mut depth = 1usize;
        loop {
            let t = match lex.next() {
                Some(t) => t?,
                None => {
                    return Err(UserError::new(
                        (l, end),
                        Syntax::UnexpectedEof(Expected::Nothing),
                    ))
                }
            };
            match t.1 {
                Tok::LParen => depth += 1,
                Tok::Comma | Tok::RParen if depth == 1 => {
                    arity += 1;
                    if self.parse {
                        let e = grammar::ExprParser::new()
                            .parse(self.buf.drain(..))
                            .map_err(|e| convert(e, self.text, end))?;
                        params.push(e);
                    }
                    if t.1 == Tok::RParen {
                        self.pos = t.2;
                        let span = (l, t.2);
                        return Ok((ast::Module { sym, params, span }, arity));
                    }
                    continue;
                }
                Tok::RParen => depth -= 1,
                _ => {}
            }
            if self.parse {
                self.buf.push(Ok(t));
            }
        }
    }
}

impl RunModules<'_> {
    /// The next module and its number of parameters, None after the last
    /// or an error.
    fn read(&mut self) -> Option<Result<(ast::Module, usize), UserError>> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        let m = self.module();
        if m.is_err() {
            self.left = 0;
        }
        Some(m)
    }
}

impl Iterator for RunModules<'_> {
    type Item = Result<ast::Module, UserError>;

    fn next(&mut self) -> Option<Self::Item> {
        Some(self.read()?.map(|(m, _)| m))
    }
}

/// A run's modules as symbol, number of parameters and span, their
/// parameters lexed but not parsed ([`ast::Run::shapes`]).
pub struct Shapes<'a>(RunModules<'a>);

impl<'a> Shapes<'a> {
    pub(crate) fn new(text: &'a str, span: (usize, usize), len: usize) -> Shapes<'a> {
        let mut m = RunModules::new(text, span, len);
        m.parse = false;
        Shapes(m)
    }
}

impl Iterator for Shapes<'_> {
    type Item = Result<(char, usize, (usize, usize)), UserError>;

    fn next(&mut self) -> Option<Self::Item> {
        Some(self.0.read()?.map(|(m, n)| (m.sym, n, m.span)))
    }
}

/// An error on a line that starts with a keyword spaced otherwise than
/// cpfg's scanner reads it (`derivation /* c */ length: 3` is
/// `derivation   length: 3` after the preprocessor, which cpfg reads as
/// symbols: a syntax error) is that spacing, at the blanks. Only an error
/// is replaced: where cpfg reads the words as symbols of a valid line (a
/// predecessor of several modules), so does lsgen.
fn respaced(text: &str, e: UserError) -> UserError {
    if matches!(e.kind, HeaderError::Parse(Syntax::Refused(_))) {
        return e;
    }
    let at = e.span.0.min(text.len());
    let start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    match misspaced_keyword(&text[start..end]) {
        Some((off, kind)) => UserError::new((start + off, start + off + 1), kind),
        None => e,
    }
}

/// The lexer's tokens, each checked with [`refusal`] before the parser
/// sees it.
struct Checked<'a> {
    lex: Lexer<'a>,
    /// The look-ahead token.
    next: Option<Spanned<'a>>,
    lsystems: usize,
    failed: bool,
    /// `func` is refused with this hint (no function files).
    no_functions: Option<Option<String>>,
    /// The curve functions are refused with this hint (no curves).
    no_curves: Option<Option<String>>,
    /// Where each string literal starts, in order ([`ast::Lsystem::strings`]).
    strings: Vec<usize>,
}

impl<'a> Iterator for Checked<'a> {
    type Item = Spanned<'a>;

    fn next(&mut self) -> Option<Spanned<'a>> {
        if self.failed {
            return None;
        }
        let cur = match self.next.take() {
            Some(t) => t,
            None => self.lex.next()?,
        };
        let (l, t, r) = match cur {
            Ok(t) => t,
            Err(e) => {
                self.failed = true;
                return Some(Err(e));
            }
        };
        self.next = self.lex.next();
        let next = match &self.next {
            Some(Ok(n)) => Some(n),
            _ => None,
        };
        let func = matches!(t, Tok::Name("func"));
        if let (true, Some(hint)) = (func, &self.no_functions) {
            self.failed = true;
            return Some(Err(UserError::new(
                (l, r),
                Syntax::Refused(Refused::FuncWithoutFunctions(hint.clone())),
            )));
        }
        if let (Tok::Name(n), Some(hint)) = (&t, &self.no_curves) {
            if CURVE_FUNCTIONS.contains(n) {
                self.failed = true;
                return Some(Err(UserError::new(
                    (l, r),
                    Syntax::Refused(Refused::CurveWithoutCurves(n.to_string(), hint.clone())),
                )));
            }
        }
        if let Tok::Str(_) = t {
            self.strings.push(l);
        }
        if let Some(e) = refusal((l, &t, r), next, &mut self.lsystems) {
            self.failed = true;
            return Some(Err(e));
        }
        Some(Ok((l, t, r)))
    }
}

fn at(span: (usize, usize), refused: Refused) -> Option<UserError> {
    Some(UserError::new(span, Syntax::Refused(refused)))
}

/// Is the token `(l, t, r)` (followed by `next`) a construct lsgen
/// refuses? `lsystems` counts the `Lsystem:` keywords so far.
fn refusal(
    (l, t, r): (usize, &Tok<'_>, usize),
    next_tok: Option<&(usize, Tok<'_>, usize)>,
    lsystems: &mut usize,
) -> Option<UserError> {
    let span = (l, r);
    let next = next_tok.map(|n| &n.1);
    match t {
        Tok::KwLsystem => {
            *lsystems += 1;
            if *lsystems > 1 {
                return at(span, Refused::SecondLsystem);
            }
        }
        Tok::KwRing => return at(span, Refused::Ring),
        Tok::ObjArrow => return at(span, Refused::ObjectProduction),
        // A query of the turtle: `?` and the module it fills (`src/cpfg/query.rs`).
        Tok::Sym('?') if matches!(next, Some(Tok::Sym('P' | 'H' | 'L' | 'U'))) => {}
        Tok::Sym('?') => {
            let what = match next {
                Some(Tok::Sym('E')) => Refused::Environment,
                Some(Tok::LParen) => Refused::SubLsystemCall,
                _ => Refused::Query,
            };
            return at(span, what);
        }
        Tok::Sym('$') => return at(span, Refused::SubLsystemEnd),
        Tok::Sym('@') if next == Some(&Tok::Sym('S')) => {
            return at((l, next_tok.map_or(r, |n| n.2)), Refused::Surface)
        }
        Tok::Name(n) if *n == "atan2" && next == Some(&Tok::LParen) => {
            return at(span, Refused::Atan2)
        }
        Tok::Name("external") => return at(span, Refused::External),
        Tok::Name(n) if UNSUPPORTED_FUNCTIONS.contains(n) => {
            return at(span, Refused::Function(n.to_string()))
        }
        _ => {}
    }
    None
}

/// The tokens the grammar would have accepted, as the message names them.
fn describe_expected(expected: &[String]) -> Expected {
    Expected::OneOf(
        expected
            .iter()
            .map(|e| match e.as_str() {
                "Eol" => "end of line".to_string(),
                "Sym" => "a symbol".to_string(),
                "Num" => "a number".to_string(),
                "Name" => "a name".to_string(),
                "Str" => "a string".to_string(),
                "Null" => "`*`".to_string(),
                "LSep" => "`<`".to_string(),
                "RSep" => "`>`".to_string(),
                "Warnings" => "`warnings`".to_string(),
                other => format!("`{}`", other.trim_matches('"')),
            })
            .collect(),
    )
}

/// lalrpop's error for `grammar/cpfg.lalrpop`, converted once into the
/// typed, located error (the same variants as the `.ls` grammar's where
/// the error is the same).
fn convert(e: ParseError<usize, Tok<'_>, UserError>, text: &str, end: usize) -> UserError {
    match e {
        ParseError::User { error } => error,
        ParseError::InvalidToken { location } => {
            UserError::new((location, location), Syntax::InvalidToken)
        }
        ParseError::UnrecognizedEof { location, expected } => {
            let loc = text[..location.max(end).min(text.len())].trim_end().len();
            let kind = if expected.iter().any(|e| e == "\"endlsystem\"") {
                Syntax::MissingEndlsystem
            } else if expected.iter().any(|e| e == "\"Lsystem:\"") {
                Syntax::MissingLsystem
            } else {
                Syntax::UnexpectedEof(describe_expected(&expected))
            };
            UserError::new((loc, loc), kind)
        }
        ParseError::UnrecognizedToken {
            token: (l, tok, r),
            expected,
        } => {
            let has = |s: &str| expected.iter().any(|e| e == s);
            let found = tok.to_string();
            let kind = if has("\"Lsystem:\"") {
                Syntax::BeforeLsystem(found)
            } else if has("\"Axiom:\"") && !has("\"-->\"") {
                Syntax::SettingAfterAxiom(found)
            } else if has("\"endlsystem\"") && !has("\"-->\"") && !has("Eol") {
                Syntax::Unexpected {
                    found,
                    expected: Expected::OneOf(vec![
                        "a production".to_string(),
                        "`endlsystem`".to_string(),
                    ]),
                }
            } else {
                Syntax::Unexpected {
                    found,
                    expected: describe_expected(&expected),
                }
            };
            UserError::new((l, r.max(l + 1)), kind)
        }
        ParseError::ExtraToken { token: (l, tok, r) } => UserError::new(
            (l, r),
            Syntax::Unexpected {
                found: tok.to_string(),
                expected: Expected::Nothing,
            },
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpfg::ast::{BinOp, Expr, Setting, Stmt};

    /// The modules of `run`, read again from `src`: as many as the grammar
    /// counted, and their shapes the modules' symbols, arities and spans.
    fn read_run(run: &ast::Run, src: &str) -> Vec<ast::Module> {
        let all: Vec<_> = run.modules(src).map(|m| m.unwrap()).collect();
        assert_eq!(all.len(), run.len());
        let shapes: Vec<_> = run.shapes(src).map(|s| s.unwrap()).collect();
        let of_modules: Vec<_> = all
            .iter()
            .map(|m| (m.sym, m.params.len(), m.span))
            .collect();
        assert_eq!(shapes, of_modules);
        all
    }

    /// A successor is kept as the place of its text and read again: each
    /// module as the grammar read it, across blanks, a TAB-continued line,
    /// nested and comma-separated parentheses, strings and UTF-8, up to
    /// the weight or the line's end.
    #[test]
    fn a_successor_is_read_again_as_the_grammar_read_it() {
        let src =
            "Lsystem: 1\nAxiom: A\nA --> B  C(1, f(2, 3))\n\tD(-x)\u{e9}[E(\"s\", (4))]- F : 0.5\n\
                   B --> G(1,2)\nC --> *\nendlsystem\n";
        let ls = parse(src).unwrap();
        let read = |i: usize| {
            let all = read_run(&ls.productions[i].succ, src);
            all.into_iter()
                .map(|m| (m.sym, m.params, &src[m.span.0..m.span.1]))
                .collect::<Vec<_>>()
        };
        let brief = |v: Vec<(char, Vec<Expr>, &str)>| {
            v.into_iter()
                .map(|(c, p, t)| (c, p.len(), t.to_string()))
                .collect::<Vec<_>>()
        };
        let first = read(0);
        let expected = [
            ('B', 0, "B"),
            ('C', 2, "C(1, f(2, 3))"),
            ('D', 1, "D(-x)"),
            ('\u{e9}', 0, "\u{e9}"),
            ('[', 0, "["),
            ('E', 2, "E(\"s\", (4))"),
            (']', 0, "]"),
            ('-', 0, "-"),
            ('F', 0, "F"),
        ];
        let expected: Vec<_> = expected
            .iter()
            .map(|&(c, n, t)| (c, n, t.to_string()))
            .collect();
        assert_eq!(brief(first.clone()), expected);
        // The parameters are the grammar's expressions.
        let f = &first[1].1[1];
        assert!(
            matches!(f, Expr::Call(name, args, _) if name == "f" && args.len() == 2),
            "{f:?}"
        );
        assert!(matches!(&first[5].1[0], Expr::Str(s, _) if s == "s"));
        let second = brief(read(1));
        assert_eq!(second, [('G', 2, "G(1,2)".to_string())]);
        assert!(read(2).is_empty());
    }

    /// A production's head is kept as the places of its left context,
    /// strict predecessor and right context, each read again as the
    /// grammar read it: written without blanks, across blanks and a
    /// TAB-continued line, with formal parameters, up to the `<`, `>`, `:`
    /// or `-->` after it.
    #[test]
    fn a_head_is_read_again_as_the_grammar_read_it() {
        let src = "Lsystem: 1\nAxiom: A\nA(x)B<C(y, z)\n\t\u{e9}>[D(w)]E : x > 1 --> F\n\
                   * < G H > * --> I\nJ(k)-->K\nendlsystem\n";
        let ls = parse(src).unwrap();
        let read = |r: &ast::Run| {
            let all = read_run(r, src);
            all.iter()
                .map(|m| {
                    let names: Vec<_> = m
                        .params
                        .iter()
                        .map(|e| match e {
                            Expr::Var(n, _) => n.clone(),
                            e => panic!("{e:?}"),
                        })
                        .collect();
                    (m.sym, names, src[m.span.0..m.span.1].to_string())
                })
                .collect::<Vec<_>>()
        };
        let v = |c: char, names: &[&str], t: &str| {
            let names = names.iter().map(|n| n.to_string()).collect::<Vec<_>>();
            (c, names, t.to_string())
        };
        let p = &ls.productions[0];
        let left = read(p.left.as_ref().unwrap());
        assert_eq!(left, [v('A', &["x"], "A(x)"), v('B', &[], "B")]);
        let pred = read(&p.pred);
        assert_eq!(
            pred,
            [v('C', &["y", "z"], "C(y, z)"), v('\u{e9}', &[], "\u{e9}")]
        );
        let right = read(p.right.as_ref().unwrap());
        let expected = [
            v('[', &[], "["),
            v('D', &["w"], "D(w)"),
            v(']', &[], "]"),
            v('E', &[], "E"),
        ];
        assert_eq!(right, expected);
        assert_eq!(p.heads().count(), 3);
        let p = &ls.productions[1];
        assert!(p.left.is_none() && p.right.is_none());
        assert_eq!(read(&p.pred), [v('G', &[], "G"), v('H', &[], "H")]);
        assert_eq!(p.heads().count(), 1);
        let p = &ls.productions[2];
        assert_eq!(read(&p.pred), [v('J', &["k"], "J(k)")]);
        assert_eq!(read(&p.succ), [v('K', &[], "K")]);
    }

    #[test]
    fn layout_and_productions() {
        let src = "Lsystem: main\nignore: A\nDerivation length: 2 * 2\nconsider: AB\nAxiom: A , ;\nA < B --> X\n* < B > * : * --> *\nB(x) : x > 1 -> C(x)\n\tD\nHomomorphism: warnings\nmaximum depth: 2\nX --> x\nEndLsystem\n";
        let ls = parse(src).unwrap();
        assert_eq!(ls.settings.len(), 3);
        assert!(matches!(ls.settings[2], Setting::Consider(ref s, _) if s.len() == 2));
        assert_eq!(ls.axiom, vec![ast::AxiomPiece::Symbols("A,;".into())]);
        assert_eq!(ls.productions.len(), 3);
        let p = &ls.productions[1];
        assert!(p.left.is_none() && p.right.is_none() && p.cond.is_none());
        assert!(p.succ.is_empty());
        // newline + TAB continues the successor
        assert_eq!(ls.productions[2].succ.len(), 2);
        let h = ls.homomorphism.as_ref().unwrap();
        assert_eq!(h.warnings, Some(true));
        assert!(h.depth.is_some());
    }

    #[test]
    fn blocks_are_kept_as_syntax() {
        let src = "Lsystem: 1\nStart: {n = 0;\n  if (n < 1) { n = n + 1; } else { n = 2; }\n  while (n < 3) { n = n + 1; }\n  do { n = n - 1; } while (n > 0);\n  printf(\"%d\\n\", n); fprintf(stderr, \"x\");\n}\nAxiom: A\nA : { k = 2; } k > 1 { n = n + k; } --> B\nendlsystem\n";
        let ls = parse(src).unwrap();
        let (b, _) = ls.start.as_ref().unwrap();
        assert!(matches!(b[0], Stmt::Assign { ref name, .. } if name == "n"));
        assert!(matches!(b[1], Stmt::If { ref els, .. } if els.len() == 1));
        assert!(matches!(b[2], Stmt::While { .. }));
        assert!(matches!(b[3], Stmt::DoWhile { .. }));
        assert!(
            matches!(b[4], Stmt::Printf { stderr: false, ref format, ref args, .. } if format == "%d\n" && args.len() == 1)
        );
        assert!(matches!(b[5], Stmt::Printf { stderr: true, .. }));
        let p = &ls.productions[0];
        assert_eq!(p.pre().len(), 1);
        assert_eq!(p.post().len(), 1);
        assert!(matches!(
            p.cond.as_deref(),
            Some(Expr::Binary(BinOp::Gt, ..))
        ));
    }

    #[test]
    fn precedence() {
        let ls = parse("Lsystem: 1\nAxiom: A(-2^2, 1 ? 2 : 3, 7 % 2 * 3)\nendlsystem\n").unwrap();
        let ast::AxiomPiece::Module(m) = &ls.axiom[0] else {
            panic!("{:?}", ls.axiom)
        };
        let p = &m.params;
        // (-2)^2
        assert!(
            matches!(&p[0], Expr::Binary(BinOp::Pow, a, _, _) if matches!(**a, Expr::Unary(..)))
        );
        assert!(matches!(&p[1], Expr::Cond(..)));
        // (7 % 2) * 3
        assert!(
            matches!(&p[2], Expr::Binary(BinOp::Mul, a, _, _) if matches!(**a, Expr::Binary(BinOp::Rem, ..)))
        );
    }

    #[test]
    fn errors() {
        let e = parse("Lsystem: 1\nAxiom: A\nA --> B\n").unwrap_err();
        assert!(
            e.message().contains("missing `endlsystem`"),
            "{}",
            e.message()
        );
        let e = parse("Lsystem: 1\nAxiom: A\nA --> F?E\nendlsystem\n").unwrap_err();
        assert!(e.message().contains("`?E`"), "{}", e.message());
        assert_eq!(e.span.0, 27);
        let e = parse("Lsystem: 1\nAxiom: A(1e6)\nendlsystem\n").unwrap_err();
        assert!(e.message().contains("dot"), "{}", e.message());
    }
}

#[cfg(test)]
mod sniff_tests {
    use crate::cpfg::sniff;

    #[test]
    fn first_statement_decides() {
        assert_eq!(sniff("a.l", b"", false), Some(true));
        assert_eq!(sniff("-", b"/* x */ Lsystem: 1", false), Some(true));
        assert_eq!(sniff("-", b"// x\n#define A 1\n", false), Some(true));
        assert_eq!(sniff("-", b"#!/bin/lsgen\n", false), Some(false));
        assert_eq!(sniff("-", b"productions:\n", false), Some(false));
        assert_eq!(sniff("-", b"\xEF\xBB\xBFlsystem:", false), Some(true));
        // Undecided until more comes, decided at the end.
        assert_eq!(sniff("-", b"/* open", false), None);
        assert_eq!(sniff("-", b"/* open", true), Some(false));
        assert_eq!(sniff("-", b"  Lsys", false), None);
        assert_eq!(sniff("-", b"Lsys", true), Some(false));
        assert_eq!(sniff("-", b"#", false), None);
        assert_eq!(sniff("-", b"\xEF", false), None);
        assert_eq!(sniff("-", b"Lx", false), Some(false));
    }
}

#[cfg(test)]
mod limits {
    #[test]
    fn blocks_nest_at_most_256_deep() {
        let deep = |n: usize| {
            format!(
                "Lsystem: 1\nStart: {{{}{}}}\nAxiom: A\nendlsystem\n",
                "if (1) {".repeat(n),
                "}".repeat(n)
            )
        };
        assert!(super::parse(&deep(255)).is_ok());
        let e = super::parse(&deep(256)).unwrap_err();
        assert!(e.message().contains("nested too deep"), "{}", e.message());
    }
}
