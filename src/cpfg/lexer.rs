//! The cpfg lexer, after cpfg's `lsys_input.l`, on the preprocessor's
//! output.
//!
//! Two states as in cpfg. In the *symbol* state (the axiom, predecessors,
//! contexts, successors, `ignore:` lists) every non-blank character is a
//! module symbol (`*` is cpfg's "null", `<` `>` separate contexts, `(`
//! enters the expression state until its `)`). In the *expression* state
//! (after `:`, inside parentheses, in `seed:`, `derivation length:`,
//! `maximum depth:` and the statement blocks) names, numbers, strings and
//! operators apply (logos). Keywords (`Axiom:`, `homomorphism`, ...) are
//! recognised in both states, as cpfg's lexer does. A newline followed by
//! a TAB continues the statement; a newline inside `{ }` is a blank.

use crate::diag::{Expected, LexicalError, ParseError as Syntax, Refused};
use crate::lang::parse::{HeaderError, UserError};
use logos::Logos;
use std::fmt;

/// A token handed to the grammar.
#[derive(Clone, Debug, PartialEq)]
pub enum Tok<'a> {
    Eol,
    KwLsystem,
    KwSeed,
    KwDerivationLength,
    KwMaximumDepth,
    KwConsider,
    KwIgnore,
    KwAxiom,
    KwDefine,
    KwRing,
    KwStart,
    KwEnd,
    KwStartEach,
    KwEndEach,
    KwHomomorphism,
    KwDecomposition,
    /// `warnings` (true) or `no warnings` (false).
    Warnings(bool),
    KwEndLsystem,
    Sym(char),
    /// `*` in the symbol state.
    Null,
    /// `-->` (and lsgen's `->`).
    Arrow,
    /// `-o>` (refused).
    ObjArrow,
    /// `<` and `>` in the symbol state.
    LSep,
    RSep,
    Colon,
    LParen,
    RParen,
    Comma,
    Num(f64),
    Name(&'a str),
    Str(String),
    KwIf,
    KwElse,
    KwWhile,
    KwDo,
    KwArray,
    Plus,
    Minus,
    Star,
    Slash,
    Percent,
    Caret,
    Lt,
    Gt,
    Le,
    Ge,
    EqEq,
    Ne,
    Assign,
    AndAnd,
    OrOr,
    Bang,
    Question,
    Semi,
    LBrace,
    RBrace,
    LBracket,
    RBracket,
}

impl fmt::Display for Tok<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Tok::Eol => "end of line",
            Tok::KwLsystem => "`Lsystem:`",
            Tok::KwSeed => "`seed:`",
            Tok::KwDerivationLength => "`derivation length:`",
            Tok::KwMaximumDepth => "`maximum depth:`",
            Tok::KwConsider => "`consider:`",
            Tok::KwIgnore => "`ignore:`",
            Tok::KwAxiom => "`Axiom:`",
            Tok::KwDefine => "`define:`",
            Tok::KwRing => "`ring lsystem`",
            Tok::KwStart => "`Start:`",
            Tok::KwEnd => "`End:`",
            Tok::KwStartEach => "`StartEach:`",
            Tok::KwEndEach => "`EndEach:`",
            Tok::KwHomomorphism => "`homomorphism`",
            Tok::KwDecomposition => "`decomposition`",
            Tok::Warnings(true) => "`warnings`",
            Tok::Warnings(false) => "`no warnings`",
            Tok::KwEndLsystem => "`endlsystem`",
            Tok::Sym(c) => return write!(f, "symbol `{c}`"),
            Tok::Null => "`*`",
            Tok::Arrow => "`-->`",
            Tok::ObjArrow => "`-o>`",
            Tok::LSep | Tok::Lt => "`<`",
            Tok::RSep | Tok::Gt => "`>`",
            Tok::Colon => "`:`",
            Tok::LParen => "`(`",
            Tok::RParen => "`)`",
            Tok::Comma => "`,`",
            Tok::Num(_) => "a number",
            Tok::Name(n) => return write!(f, "`{n}`"),
            Tok::Str(_) => "a string",
            Tok::KwIf => "`if`",
            Tok::KwElse => "`else`",
            Tok::KwWhile => "`while`",
            Tok::KwDo => "`do`",
            Tok::KwArray => "`array`",
            Tok::Plus => "`+`",
            Tok::Minus => "`-`",
            Tok::Star => "`*`",
            Tok::Slash => "`/`",
            Tok::Percent => "`%`",
            Tok::Caret => "`^`",
            Tok::Le => "`<=`",
            Tok::Ge => "`>=`",
            Tok::EqEq => "`==`",
            Tok::Ne => "`!=`",
            Tok::Assign => "`=`",
            Tok::AndAnd => "`&&`",
            Tok::OrOr => "`||`",
            Tok::Bang => "`!`",
            Tok::Question => "`?`",
            Tok::Semi => "`;`",
            Tok::LBrace => "`{`",
            Tok::RBrace => "`}`",
            Tok::LBracket => "`[`",
            Tok::RBracket => "`]`",
        };
        f.write_str(s)
    }
}

/// Tokens of the expression state.
#[derive(Logos, Debug, Clone, Copy, PartialEq)]
enum ExprTok {
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?")]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?")]
    Num,
    #[regex(r"[a-zA-Z][a-zA-Z0-9_]*")]
    Name,
    #[regex(r#""[^"\n]*["\n]"#)]
    Str,
    #[token("-->")]
    #[token("->")]
    Arrow,
    #[token("-o>")]
    ObjArrow,
    #[token("<>")]
    #[token("!=")]
    Ne,
    #[token("==")]
    EqEq,
    #[token("<=")]
    Le,
    #[token(">=")]
    Ge,
    #[token("&&")]
    AndAnd,
    #[token("||")]
    OrOr,
    #[token("=")]
    Assign,
    #[token("&")]
    Amp,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("%")]
    Percent,
    #[token("^")]
    Caret,
    #[token(";")]
    Semi,
    #[token(",")]
    Comma,
    #[token("?")]
    Question,
    #[token(":")]
    Colon,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    #[token("<")]
    Lt,
    #[token(">")]
    Gt,
    #[token("!")]
    Bang,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Symbol,
    Expression,
}

/// Keyword patterns: an uppercase letter also matches its lowercase, a
/// character followed by `?` is optional.
const KEYWORDS: &[(&str, Kw)] = &[
    ("Lsystem:", Kw::Lsystem),
    ("Seed:", Kw::Seed),
    ("Derivation ?Length:", Kw::DerivationLength),
    ("Maximum Depth:", Kw::MaximumDepth),
    ("Consider:", Kw::Consider),
    ("Ignore:", Kw::Ignore),
    ("Axiom:", Kw::Axiom),
    ("Define:", Kw::Define),
    ("Ring Lsystem", Kw::Ring),
    ("Start:", Kw::Start),
    ("End:", Kw::End),
    ("Start ?Each:", Kw::StartEach),
    ("End ?Each:", Kw::EndEach),
    ("Homomorphism:?", Kw::Homomorphism),
    ("Decomposition:?", Kw::Decomposition),
    ("no warnings", Kw::NoWarnings),
    ("warnings", Kw::Warnings),
    ("EndLsystem", Kw::EndLsystem),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kw {
    Lsystem,
    Seed,
    DerivationLength,
    MaximumDepth,
    Consider,
    Ignore,
    Axiom,
    Define,
    Ring,
    Start,
    End,
    StartEach,
    EndEach,
    Homomorphism,
    Decomposition,
    NoWarnings,
    Warnings,
    EndLsystem,
}

/// Length of the match of `pat` at the start of `s`.
fn match_pattern(pat: &str, s: &[u8]) -> Option<usize> {
    let p = pat.as_bytes();
    let (mut i, mut j) = (0, 0);
    while i < p.len() {
        let c = p[i];
        let optional = p.get(i + 1) == Some(&b'?');
        let ok = s
            .get(j)
            .is_some_and(|&b| b == c || (c.is_ascii_uppercase() && b == c.to_ascii_lowercase()));
        if ok {
            j += 1;
        } else if !optional {
            return None;
        }
        i += if optional { 2 } else { 1 };
    }
    Some(j)
}

/// A keyword at the start of `line` (after its blanks) that cpfg's
/// scanner does not read because of its spacing: several blanks, a
/// comment and blanks, a tab or a no-break space between its words, a
/// blank before its `:`, no space where one is needed
/// (`derivation  length:`, `maximum\u{a0}depth:`, `Axiom :`,
/// `homomorphism no  warnings`). cpfg's patterns (`lsys_input.l`) have a
/// single `" "` (or `" "?`) between words and the `:` right after the
/// last word; there the words are symbols and the line a syntax error.
/// The offset of the misplaced blanks in `line`, and the error.
pub fn misspaced_keyword(line: &str) -> Option<(usize, LexicalError)> {
    let lead = line.len() - line.trim_start_matches([' ', '\t']).len();
    let mut at = lead;
    // `no warnings` after a section's keyword.
    let mut section = false;
    if let Some((n, Kw::Homomorphism | Kw::Decomposition)) = keyword(&line.as_bytes()[at..]) {
        section = true;
        at += n;
        at += line.len() - at - line[at..].trim_start_matches([' ', '\t']).len();
    }
    let rest = &line[at..];
    KEYWORDS
        .iter()
        .filter(|&&(_, kw)| !section || kw == Kw::NoWarnings)
        .find_map(|&(pat, _)| {
            let (off, e) = loose_match(pat, rest)?;
            Some((at + off, e))
        })
}

/// Is `c` a blank within a line (a space, a tab, a no-break space ...)?
fn is_line_blank(c: char) -> bool {
    c != '\n' && c.is_whitespace()
}

/// [`match_pattern`] with any run of blanks where the pattern has a space
/// (or none) and before its final `:`: the offset and error of the first
/// run that the strict pattern would refuse, if the rest matches.
fn loose_match(pat: &str, s: &str) -> Option<(usize, LexicalError)> {
    let p = pat.as_bytes();
    let (mut i, mut j) = (0, 0);
    let mut bad: Option<(usize, Option<usize>, bool, String)> = None;
    let mut words = vec![String::new()];
    while i < p.len() {
        let c = p[i];
        let optional = p.get(i + 1) == Some(&b'?');
        if c == b' ' || (c == b':' && i + 1 == p.len()) {
            let run: String = s[j..].chars().take_while(|&c| is_line_blank(c)).collect();
            let strict = if c == b' ' {
                run == " " || (optional && run.is_empty())
            } else {
                run.is_empty()
            };
            if !strict && bad.is_none() {
                let pos = (c == b' ').then_some(words.len() - 1);
                bad = Some((j, pos, optional, describe_blanks(&run)));
            }
            j += run.len();
            i += if optional { 2 } else { 1 };
            if c == b' ' {
                words.push(String::new());
                continue;
            }
        }
        let b = *s.as_bytes().get(j)?;
        if b == c || (c.is_ascii_uppercase() && b == c.to_ascii_lowercase()) {
            j += 1;
            if c != b':' {
                words.last_mut().unwrap().push(b as char);
            }
        } else if !optional {
            return None;
        }
        i += if optional { 2 } else { 1 };
    }
    let (off, pos, optional, found) = bad?;
    let colon = if pat.ends_with(':') { ":" } else { "" };
    let keyword = format!("{}{colon}", words.join(" "));
    let between = pos.map(|k| (words[k].clone(), words[k + 1].clone()));
    Some((
        off,
        LexicalError::KeywordSpacing {
            keyword,
            between,
            optional,
            found,
        },
    ))
}

/// A run of blanks as a message names it.
fn describe_blanks(run: &str) -> String {
    match run.chars().find(|&c| c != ' ') {
        None if run.is_empty() => "none".to_string(),
        None if run.len() == 1 => "a space".to_string(),
        None => format!("{} spaces", run.len()),
        Some('\t') => "a tab".to_string(),
        Some('\u{a0}') => "a no-break space (U+00A0)".to_string(),
        Some(c) => format!("a blank U+{:04X}", c as u32),
    }
}

/// The longest keyword at the start of `s`.
fn keyword(s: &[u8]) -> Option<(usize, Kw)> {
    let mut best: Option<(usize, Kw)> = None;
    for &(pat, kw) in KEYWORDS {
        if let Some(n) = match_pattern(pat, s) {
            if best.is_none_or(|(m, _)| n > m) {
                best = Some((n, kw));
            }
        }
    }
    best
}

pub type Spanned<'a> = Result<(usize, Tok<'a>, usize), UserError>;

/// The cpfg lexer over the preprocessed text (see the module docs).
pub struct Lexer<'a> {
    src: &'a str,
    pos: usize,
    state: State,
    /// Open `(` and `{` in the expression state.
    nesting: i64,
    /// Open `{` of blocks: newlines inside are blanks.
    braces: i64,
    /// The last token was an end of line (or nothing yet).
    after_eol: bool,
    done: bool,
    /// Expression tokens since the last statement boundary (`;`, `{`, `}`,
    /// the symbol state): at most [`MAX_EXPR_TOKENS`], as in `.ls` files,
    /// so that evaluation's recursion stays bounded.
    expr_tokens: usize,
}

pub use crate::lang::lexer::MAX_EXPR_TOKENS;

/// The blanks the scanner skips between tokens (as a newline that a TAB
/// follows: [`Lexer`]'s `next_token`).
pub fn blank(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\r' | b'\x0b' | b'\x0c')
}

/// Deepest nesting of `{ }` blocks (the tree walks recurse on it).
pub const MAX_BLOCK_DEPTH: i64 = 256;

impl<'a> Lexer<'a> {
    pub fn new(src: &'a str) -> Lexer<'a> {
        Lexer {
            src,
            pos: 0,
            state: State::Symbol,
            nesting: 0,
            braces: 0,
            after_eol: true,
            done: false,
            expr_tokens: 0,
        }
    }

    /// A lexer that reads `src` from `pos`, where the grammar read a
    /// successor's module or its `(` (symbols, no statement block open).
    pub fn at_module(src: &'a str, pos: usize) -> Lexer<'a> {
        Lexer {
            pos,
            after_eol: false,
            ..Lexer::new(src)
        }
    }

    fn err(&self, at: usize, len: usize, kind: impl Into<HeaderError>) -> UserError {
        UserError::new((at, at + len), kind)
    }

    fn next_token(&mut self) -> Option<Spanned<'a>> {
        let bytes = self.src.as_bytes();
        loop {
            let i = self.pos;
            let Some(&c) = bytes.get(i) else {
                if self.done {
                    return None;
                }
                self.done = true;
                if self.after_eol {
                    return None;
                }
                self.after_eol = true;
                return Some(Ok((i, Tok::Eol, i)));
            };
            match c {
                c if blank(c) => {
                    self.pos += 1;
                    continue;
                }
                // cpfg's scanner has no rule for `\` in an expression (flex
                // echoes it and reads on): a `\\` line continuation in a
                // `#define`, common in vlab models, leaves one there.
                b'\\' if self.state == State::Expression => {
                    self.pos += 1;
                    continue;
                }
                b'\n' => {
                    if bytes.get(i + 1) == Some(&b'\t') {
                        self.pos += 2;
                        continue;
                    }
                    self.pos += 1;
                    if self.braces > 0 || self.after_eol {
                        if self.braces == 0 {
                            self.state = State::Symbol;
                        }
                        continue;
                    }
                    self.state = State::Symbol;
                    self.after_eol = true;
                    return Some(Ok((i, Tok::Eol, i + 1)));
                }
                _ => {}
            }
            let t = self.token(i);
            if let Some(Ok((_, ref t, _))) = t {
                self.after_eol = *t == Tok::Eol;
            }
            return t;
        }
    }

    fn token(&mut self, i: usize) -> Option<Spanned<'a>> {
        let rest = &self.src[i..];
        let kw = keyword(rest.as_bytes());
        let mut name_len = 0;
        if self.state == State::Expression {
            name_len = rest
                .bytes()
                .take_while(|b| b.is_ascii_alphanumeric() || *b == b'_')
                .count();
            if !rest.as_bytes()[0].is_ascii_alphabetic() {
                name_len = 0;
            }
        }
        if let Some((n, kw)) = kw {
            if n >= name_len {
                self.pos = i + n;
                let (tok, state) = match kw {
                    Kw::Lsystem => (Tok::KwLsystem, Some(State::Symbol)),
                    Kw::Seed => (Tok::KwSeed, Some(State::Expression)),
                    Kw::DerivationLength => (Tok::KwDerivationLength, Some(State::Expression)),
                    Kw::MaximumDepth => (Tok::KwMaximumDepth, Some(State::Expression)),
                    Kw::Consider => (Tok::KwConsider, None),
                    Kw::Ignore => (Tok::KwIgnore, None),
                    Kw::Axiom => (Tok::KwAxiom, None),
                    Kw::Define => (Tok::KwDefine, Some(State::Expression)),
                    Kw::Ring => (Tok::KwRing, None),
                    Kw::Start => (Tok::KwStart, Some(State::Expression)),
                    Kw::End => (Tok::KwEnd, Some(State::Expression)),
                    Kw::StartEach => (Tok::KwStartEach, Some(State::Expression)),
                    Kw::EndEach => (Tok::KwEndEach, Some(State::Expression)),
                    Kw::Homomorphism => (Tok::KwHomomorphism, None),
                    Kw::Decomposition => (Tok::KwDecomposition, None),
                    Kw::NoWarnings => (Tok::Warnings(false), None),
                    Kw::Warnings => (Tok::Warnings(true), None),
                    Kw::EndLsystem => (Tok::KwEndLsystem, None),
                };
                if let Some(s) = state {
                    self.state = s;
                }
                return Some(Ok((i, tok, i + n)));
            }
        }
        match self.state {
            State::Symbol => {
                self.expr_tokens = 0;
                Some(self.symbol(i))
            }
            State::Expression => {
                let t = self.expression(i);
                match &t {
                    Ok((_, Tok::Semi | Tok::LBrace | Tok::RBrace, _)) => self.expr_tokens = 0,
                    Ok((s, _, e)) => {
                        self.expr_tokens += 1;
                        if self.expr_tokens > MAX_EXPR_TOKENS {
                            return Some(Err(self.err(*s, e - s, LexicalError::ExpressionTooLong)));
                        }
                    }
                    Err(_) => {}
                }
                Some(t)
            }
        }
    }

    fn symbol(&mut self, i: usize) -> Spanned<'a> {
        let rest = &self.src[i..];
        let (tok, n) = if rest.starts_with("-->") {
            (Tok::Arrow, 3)
        } else if rest.starts_with("-o>") {
            (Tok::ObjArrow, 3)
        } else if rest.starts_with("->") {
            (Tok::Arrow, 2)
        } else {
            let c = rest.chars().next().unwrap_or(' ');
            let tok = match c {
                '*' => Tok::Null,
                ')' => Tok::RParen,
                ':' => {
                    self.nesting = 1;
                    self.state = State::Expression;
                    Tok::Colon
                }
                '<' => Tok::LSep,
                '>' => Tok::RSep,
                '(' => {
                    self.nesting = 1;
                    self.state = State::Expression;
                    Tok::LParen
                }
                c if c.is_control() => {
                    return Err(self.err(i, c.len_utf8(), LexicalError::ControlChar(c)))
                }
                '\u{FEFF}' => return Err(self.err(i, 3, LexicalError::ByteOrderMark)),
                c => Tok::Sym(c),
            };
            (tok, c.len_utf8())
        };
        self.pos = i + n;
        Ok((i, tok, i + n))
    }

    fn expression(&mut self, i: usize) -> Spanned<'a> {
        let rest = &self.src[i..];
        let mut lx = ExprTok::lexer(rest);
        let Some(t) = lx.next() else {
            return Err(self.err(i, 1, Syntax::UnexpectedEof(Expected::Nothing)));
        };
        let span = lx.span();
        let (s, e) = (i + span.start, i + span.end);
        let text = &self.src[s..e];
        let Ok(t) = t else {
            let c = rest.chars().next().unwrap_or('?');
            return Err(self.err(i, c.len_utf8(), LexicalError::ExpressionChar(c)));
        };
        self.pos = e;
        let tok = match t {
            ExprTok::Num => {
                let next = self.src.as_bytes().get(e).copied();
                let exponent = matches!(next, Some(b'e' | b'E')) || text.contains(['e', 'E']);
                if exponent && !text.contains('.') {
                    return Err(self.err(
                        s,
                        e - s,
                        LexicalError::ExponentWithoutDot(text.to_string()),
                    ));
                }
                match text.parse::<f64>() {
                    Ok(v) if v.is_finite() => Tok::Num(v),
                    _ => {
                        return Err(self.err(
                            s,
                            e - s,
                            LexicalError::NumberOutOfRange(text.to_string()),
                        ))
                    }
                }
            }
            ExprTok::Name => match text {
                "if" => Tok::KwIf,
                "else" => Tok::KwElse,
                "while" => Tok::KwWhile,
                "do" => Tok::KwDo,
                "array" => Tok::KwArray,
                n => Tok::Name(n),
            },
            ExprTok::Str => {
                if !text.ends_with('"') || text.len() < 2 {
                    return Err(self.err(s, e - s, LexicalError::UnterminatedString));
                }
                Tok::Str(unescape(&text[1..text.len() - 1]))
            }
            ExprTok::Arrow => {
                self.state = State::Symbol;
                Tok::Arrow
            }
            ExprTok::ObjArrow => {
                self.state = State::Symbol;
                Tok::ObjArrow
            }
            ExprTok::Ne => Tok::Ne,
            ExprTok::EqEq => Tok::EqEq,
            ExprTok::Le => Tok::Le,
            ExprTok::Ge => Tok::Ge,
            ExprTok::AndAnd => Tok::AndAnd,
            ExprTok::OrOr => Tok::OrOr,
            ExprTok::Assign => Tok::Assign,
            ExprTok::Amp => return Err(self.err(s, 1, Syntax::Refused(Refused::Address))),
            ExprTok::Plus => Tok::Plus,
            ExprTok::Minus => Tok::Minus,
            ExprTok::Star => Tok::Star,
            ExprTok::Slash => Tok::Slash,
            ExprTok::Percent => Tok::Percent,
            ExprTok::Caret => Tok::Caret,
            ExprTok::Semi => Tok::Semi,
            ExprTok::Comma => Tok::Comma,
            ExprTok::Question => Tok::Question,
            ExprTok::Colon => Tok::Colon,
            ExprTok::LParen => {
                self.nesting += 1;
                Tok::LParen
            }
            ExprTok::RParen => {
                self.nesting -= 1;
                if self.nesting == 0 {
                    self.state = State::Symbol;
                }
                Tok::RParen
            }
            ExprTok::LBracket => Tok::LBracket,
            ExprTok::RBracket => Tok::RBracket,
            ExprTok::Lt => Tok::Lt,
            ExprTok::Gt => Tok::Gt,
            ExprTok::Bang => Tok::Bang,
            ExprTok::LBrace => {
                self.nesting += 1;
                self.braces += 1;
                if self.braces > MAX_BLOCK_DEPTH {
                    return Err(self.err(s, 1, LexicalError::BlocksNestedTooDeeply));
                }
                Tok::LBrace
            }
            ExprTok::RBrace => {
                self.nesting -= 1;
                if self.braces > 0 {
                    self.braces -= 1;
                }
                Tok::RBrace
            }
        };
        Ok((s, tok, e))
    }
}

/// cpfg's string escapes: `\n`, `\t`, `\r`; `\x` is `x`.
fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut it = s.chars();
    while let Some(c) = it.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match it.next() {
            Some('n') => out.push('\n'),
            Some('t') => out.push('\t'),
            Some('r') => out.push('\r'),
            Some(x) => out.push(x),
            None => out.push('\\'),
        }
    }
    out
}

impl<'a> Iterator for Lexer<'a> {
    type Item = Spanned<'a>;

    fn next(&mut self) -> Option<Spanned<'a>> {
        let t = self.next_token();
        if let Some(Err(_)) = t {
            self.done = true;
            self.pos = self.src.len();
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toks(s: &str) -> Vec<Tok<'_>> {
        Lexer::new(s).map(|t| t.unwrap().1).collect()
    }

    #[test]
    fn states_and_keywords() {
        assert_eq!(
            toks("Lsystem: 1\nAxiom: A(x*2)B\n"),
            vec![
                Tok::KwLsystem,
                Tok::Sym('1'),
                Tok::Eol,
                Tok::KwAxiom,
                Tok::Sym('A'),
                Tok::LParen,
                Tok::Name("x"),
                Tok::Star,
                Tok::Num(2.0),
                Tok::RParen,
                Tok::Sym('B'),
                Tok::Eol,
            ]
        );
        assert_eq!(
            toks("* < A : * --> *\n\tB"),
            vec![
                Tok::Null,
                Tok::LSep,
                Tok::Sym('A'),
                Tok::Colon,
                Tok::Star,
                Tok::Arrow,
                Tok::Null,
                Tok::Sym('B'),
                Tok::Eol,
            ]
        );
        assert_eq!(toks("derivation Length: 3")[0], Tok::KwDerivationLength);
        assert_eq!(toks("homomorphism no warnings")[1], Tok::Warnings(false));
        assert_eq!(toks("EndLsystem"), vec![Tok::KwEndLsystem, Tok::Eol]);
        assert_eq!(toks("StartEach: {\nx = 1;\n}")[2], Tok::Name("x"));
    }

    /// cpfg's patterns (lsys_input.l): one `" "` between words (`" "?` in
    /// `derivation length:`, `start each:`, `end each:`), `:` right after.
    #[test]
    fn misspaced_keywords() {
        let found = |line: &str| {
            misspaced_keyword(line).map(|(at, e)| match e {
                LexicalError::KeywordSpacing {
                    keyword,
                    between,
                    optional,
                    found,
                } => (at, keyword, between.map(|(a, _)| a), optional, found),
                e => panic!("{e:?}"),
            })
        };
        for ok in [
            "derivation length: 3",
            "Derivationlength: 3",
            "  maximum Depth: 2",
            "Start Each: {",
            "EndEach: {",
            "homomorphism: no warnings",
            "decomposition  warnings",
            "A --> B",
            "derivation",
        ] {
            assert_eq!(found(ok), None, "{ok}");
        }
        let d = Some("derivation".to_string());
        assert_eq!(
            found("derivation   length: 3"),
            Some((
                10,
                "derivation length:".into(),
                d.clone(),
                true,
                "3 spaces".into()
            ))
        );
        assert_eq!(
            found("\tDerivation\u{a0}Length: 3"),
            Some((
                11,
                "Derivation Length:".into(),
                Some("Derivation".into()),
                true,
                "a no-break space (U+00A0)".into()
            ))
        );
        assert_eq!(
            found("derivation \tlength: 3"),
            Some((10, "derivation length:".into(), d, true, "a tab".into()))
        );
        assert_eq!(
            found("maximumdepth: 2"),
            Some((
                7,
                "maximum depth:".into(),
                Some("maximum".into()),
                false,
                "none".into()
            ))
        );
        assert_eq!(
            found("Axiom  : A"),
            Some((5, "Axiom:".into(), None, false, "2 spaces".into()))
        );
        assert_eq!(
            found("homomorphism no  warnings"),
            Some((
                15,
                "no warnings".into(),
                Some("no".into()),
                false,
                "2 spaces".into()
            ))
        );
        // Only `no warnings` after a section keyword.
        assert_eq!(found("homomorphism maximum  depth: 2"), None);
    }

    #[test]
    fn exponent_needs_a_dot() {
        assert!(Lexer::new("A(1e6)").any(|t| t.is_err()));
        assert!(Lexer::new("A(1.0e6)").all(|t| t.is_ok()));
    }
}
