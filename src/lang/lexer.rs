//! Lexer for the header of an `.ls` file (settings, productions, homomorphism).
//!
//! The language has two lexical modes. In *module* mode (predecessors,
//! contexts, successors, `ignore:` lists) every non-blank character is a
//! symbol of its own: `F+F` is three tokens. In *expression* mode (inside a
//! module's parentheses, after `:` and in numeric settings) the usual
//! identifiers, numbers and operators apply. There is one token list,
//! [`Tok`]: its expression tokens are lexed by logos, their payloads filled
//! by callbacks; module mode is a character-by-character scan over the same
//! tokens (`Lexer::module_token`); keywords are recognised at the start
//! of a line. [`Lexer::next`] dispatches on the `Mode`. Comments are
//! found by `crate::lang::comment`, as everywhere else. The axiom is not
//! lexed here: it is streamed by [`crate::io::axiom`].

use crate::diag::LexicalError;
use crate::lang::comment;
use logos::Logos;

/// Byte span in the header text.
pub type Span = (usize, usize);

/// A `groups:` line (issue 11): its entries in order, two bytes each (a
/// line may hold 33 million), and where each group is named first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupList {
    pub entries: Vec<u16>,
    /// Each group's first entry and its span, in the line's order.
    pub first: Vec<(u16, Span)>,
}

/// A token handed to the LALRPOP grammar: the one token list of the header.
#[derive(Logos, Clone, Debug, PartialEq)]
#[logos(error(LexicalError, unexpected))]
#[logos(skip r"[\s&&[^\n]]+")]
pub enum Tok<'a> {
    #[token("\n")]
    Nl,
    KwDerivationLength,
    KwDefine,
    KwSeed,
    KwIgnore,
    KwConsider,
    KwProductions,
    KwHomomorphism,
    KwDecomposition,
    KwMaximumDepth,
    /// `productions N:` (issue 11), N a group number.
    KwProductionsN(u32),
    /// `groups: G1 G2 ...`.
    KwGroups(GroupList),
    KwGroup,
    /// `warnings` (true) or `no warnings` after a section keyword.
    Warnings(bool),
    /// A symbol (module mode only).
    Sym(char),
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?", number)]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?", number)]
    Num(f64),
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*", |lex| lex.slice())]
    Ident(&'a str),
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token(",")]
    Comma,
    #[token(":")]
    Colon,
    #[token("->")]
    #[token("-->")]
    Arrow,
    #[token("<")]
    Lt,
    #[token(">")]
    Gt,
    #[token("<=")]
    Le,
    #[token(">=")]
    Ge,
    #[token("==")]
    EqEq,
    #[token("!=")]
    Ne,
    #[token("=")]
    Assign,
    #[token("&&")]
    #[token("&")]
    AndAnd,
    #[token("||")]
    #[token("|")]
    OrOr,
    #[token("!")]
    Bang,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("^")]
    Caret,
    /// A whole comment (never handed to the grammar).
    #[token("/*", skip_comment)]
    Comment,
}

/// A number as written; too large for a float is an error.
fn number<'a>(lex: &mut logos::Lexer<'a, Tok<'a>>) -> Result<f64, LexicalError> {
    match lex.slice().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(LexicalError::NumberOutOfRange(lex.slice().to_string())),
    }
}

/// At `/*`: take the whole comment, or fail at its `/*`.
fn skip_comment<'a>(lex: &mut logos::Lexer<'a, Tok<'a>>) -> Result<(), LexicalError> {
    let at = lex.span().start;
    match comment::len(&lex.source()[at..]) {
        Some(n) => {
            lex.bump(n - comment::OPEN.len());
            Ok(())
        }
        None => Err(LexicalError::UnterminatedComment),
    }
}

/// logos wants a default error; `unexpected` gives the real one.
impl Default for LexicalError {
    fn default() -> LexicalError {
        LexicalError::UnexpectedChar('?')
    }
}

/// Input no token starts with: its first character.
fn unexpected<'a>(lex: &mut logos::Lexer<'a, Tok<'a>>) -> LexicalError {
    let c = lex.source()[lex.span().start..].chars().next();
    LexicalError::UnexpectedChar(c.unwrap_or('?'))
}

impl std::fmt::Display for Tok<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self {
            Tok::Nl => "end of line",
            Tok::KwDerivationLength => "`derivation length:`",
            Tok::KwDefine => "`define:`",
            Tok::KwSeed => "`seed:`",
            Tok::KwIgnore => "`ignore:`",
            Tok::KwConsider => "`consider:`",
            Tok::KwProductions => "`productions:`",
            Tok::KwHomomorphism => "`homomorphism:`",
            Tok::KwDecomposition => "`decomposition:`",
            Tok::KwMaximumDepth => "`maximum depth:`",
            Tok::KwProductionsN(n) => return write!(f, "`productions {n}:`"),
            Tok::KwGroups(_) => "`groups:`",
            Tok::KwGroup => "`group:`",
            Tok::Warnings(true) => "`warnings`",
            Tok::Warnings(false) => "`no warnings`",
            Tok::Sym(c) => return write!(f, "symbol `{c}`"),
            Tok::Num(n) => return write!(f, "number `{n}`"),
            Tok::Ident(s) => return write!(f, "identifier `{s}`"),
            Tok::LParen => "`(`",
            Tok::RParen => "`)`",
            Tok::Comma => "`,`",
            Tok::Colon => "`:`",
            Tok::Arrow => "`->`",
            Tok::Lt => "`<`",
            Tok::Gt => "`>`",
            Tok::Le => "`<=`",
            Tok::Ge => "`>=`",
            Tok::EqEq => "`==`",
            Tok::Ne => "`!=`",
            Tok::Assign => "`=`",
            Tok::AndAnd => "`&&`",
            Tok::OrOr => "`||`",
            Tok::Bang => "`!`",
            Tok::Plus => "`+`",
            Tok::Minus => "`-`",
            Tok::Star => "`*`",
            Tok::Slash => "`/`",
            Tok::Caret => "`^`",
            Tok::Comment => "a comment",
        };
        f.write_str(s)
    }
}

/// What went wrong while lexing, with the span it covers.
#[derive(Clone, Debug, PartialEq)]
pub struct LexError {
    pub span: Span,
    pub kind: LexicalError,
}

/// Which tokens come next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Every non-blank character a symbol.
    Module,
    /// A module's parameter list, `depth` parentheses deep (at least 1):
    /// module mode again after its `)`.
    Params { depth: u32 },
    /// A condition, probability or numeric setting, `depth` parentheses
    /// deep: until the arrow or the end of the line.
    Expr { depth: u32 },
}

/// Where the lexer is in its line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Line {
    /// At the start of a line (nothing yet, or after an end of line):
    /// look for a `view:` line and a keyword.
    Start,
    /// Nothing handed out on this line yet: another end of line is a
    /// blank line, collapsed.
    Empty,
    /// Tokens handed out on this line.
    Tokens,
    /// The input is over.
    Done,
}

/// Keywords recognised at the start of a line, with the mode that follows.
const KEYWORDS: &[(&str, Tok<'static>, bool)] = &[
    ("derivation length:", Tok::KwDerivationLength, true),
    ("define:", Tok::KwDefine, true),
    ("seed:", Tok::KwSeed, true),
    ("ignore:", Tok::KwIgnore, false),
    ("consider:", Tok::KwConsider, false),
    ("productions:", Tok::KwProductions, false),
    ("homomorphism:", Tok::KwHomomorphism, false),
    ("decomposition:", Tok::KwDecomposition, false),
    ("maximum depth:", Tok::KwMaximumDepth, true),
    ("group:", Tok::KwGroup, true),
];

/// A blank: any white space but a line break (README: space, tab,
/// no-break space, vertical tab, ...), as between tokens.
fn is_blank(c: char) -> bool {
    c != '\n' && c.is_whitespace()
}

/// The length of the blanks and comments at the start of `s`: what may
/// stand between the words of a keyword line, as between tokens. A comment
/// that spans lines ends its line, and one never closed is an error: the
/// token lexer finds both, so neither is taken here.
fn gap(s: &str) -> usize {
    let mut n = 0;
    loop {
        let t = s[n..].trim_start_matches(is_blank);
        n = s.len() - t.len();
        match t
            .starts_with(comment::OPEN)
            .then(|| comment::len(t))
            .flatten()
        {
            Some(len) if !t[..len].contains('\n') => n += len,
            _ => return n,
        }
    }
}

/// The length of the word at the start of `s`: up to a blank, a line
/// break or a comment (`/*` always starts one).
fn word_len(s: &str) -> usize {
    s.char_indices()
        .find(|&(i, c)| c.is_whitespace() || s[i..].starts_with(comment::OPEN))
        .map_or(s.len(), |(i, _)| i)
}

/// The words on the rest of a line from `rest`, as byte ranges of `rest`:
/// between them blanks and comments, after the last one only blanks and
/// comments up to the end of the line (or a comment that ends it).
fn line_words(rest: &str) -> impl Iterator<Item = Span> + '_ {
    // (An iterator: a `groups:` line may hold 33 million words.)
    let mut at = 0;
    std::iter::from_fn(move || {
        at += gap(&rest[at..]);
        let n = word_len(&rest[at..]);
        (n > 0).then(|| {
            at += n;
            (at - n, at)
        })
    })
}

/// Is `line` (from its first non-blank byte) a keyword line? Returns the
/// keyword's byte length. Keywords are matched case-insensitively, so cpfg's
/// `Derivation length:` works, and between the words of a keyword any
/// blanks and comments are allowed (at least one), and before its `:`
/// (any, or none: `seed : 3`, as between tokens).
pub fn match_keyword(rest: &str, keyword: &str) -> Option<usize> {
    let mut at = 0;
    for (i, word) in keyword.split(' ').enumerate() {
        if i > 0 {
            let n = gap(&rest[at..]);
            if n == 0 {
                return None;
            }
            at += n;
        }
        let (word, colon) = match word.strip_suffix(':') {
            Some(w) => (w, true),
            None => (word, false),
        };
        // Keywords are ASCII: a match is as long as the keyword's word.
        let text = rest.as_bytes().get(at..at + word.len())?;
        if !text.eq_ignore_ascii_case(word.as_bytes()) {
            return None;
        }
        at += word.len();
        if colon {
            at += gap(&rest[at..]);
            if !rest[at..].starts_with(':') {
                return None;
            }
            at += 1;
        }
    }
    Some(at)
}

/// The mode-switching lexer over the header text.
pub struct Lexer<'a> {
    src: &'a str,
    /// Byte offset of the next token.
    pos: usize,
    mode: Mode,
    line: Line,
    /// Tokens of the current expression, to bound the parser's and the
    /// compiler's recursion on absurd input.
    expr_tokens: usize,
    /// The settings of the `view:` lines met, when collected.
    views: Option<Vec<crate::turtle::view::Setting>>,
    /// Just after `decomposition:` / `homomorphism:` (at this offset,
    /// that keyword): look for `warnings` / `no warnings`.
    pending_warnings: Option<(usize, &'static str)>,
}

/// The settings of a header's `view:` lines, in order, found by the lexer
/// lsgen parses the header with (so lsgen-turtle's `--ls` and lsgen agree
/// on which lines are view lines). A lexical error of the header is an
/// error here too.
pub fn view_settings(src: &str) -> Result<Vec<crate::turtle::view::Setting>, LexError> {
    let mut l = Lexer::new(src);
    l.views = Some(Vec::new());
    for t in l.by_ref() {
        t?;
    }
    Ok(l.views.unwrap_or_default())
}

/// Longest expression (in tokens) and deepest parenthesis nesting accepted.
pub const MAX_EXPR_TOKENS: usize = 10_000;
pub const MAX_PAREN_DEPTH: u32 = 256;

/// A token or an error, with its span.
pub type Spanned<'a> = Result<(usize, Tok<'a>, usize), LexError>;

/// Characters that cannot be module symbols (logos' old `Control` class):
/// C0 and C1 controls that are not blanks.
fn is_control(c: char) -> bool {
    matches!(c, '\x00'..='\x08' | '\x0E'..='\x1F' | '\x7F' | '\u{80}'..='\u{84}' | '\u{86}'..='\u{9F}')
}

impl<'a> Lexer<'a> {
    pub fn new(src: &'a str) -> Self {
        Lexer {
            src,
            pos: 0,
            mode: Mode::Module,
            line: Line::Start,
            expr_tokens: 0,
            views: None,
            pending_warnings: None,
        }
    }

    /// A lexer for a lone expression (an axiom parameter, a test).
    pub fn new_expr(src: &'a str) -> Self {
        Lexer {
            mode: Mode::Expr { depth: 0 },
            line: Line::Empty,
            ..Lexer::new(src)
        }
    }

    /// Switch to `mode`; an expression starts with a fresh token budget.
    fn enter(&mut self, mode: Mode) {
        if mode != Mode::Module {
            self.expr_tokens = 0;
        }
        self.mode = mode;
    }

    /// Module mode: the next token at `self.pos`, its start and end; None
    /// at the end of the input.
    fn module_token(&self) -> Option<(Result<Tok<'a>, LexicalError>, usize, usize)> {
        let rest = &self.src[self.pos..];
        let t = rest.trim_start_matches(|c: char| c != '\n' && c.is_whitespace());
        let s = self.pos + rest.len() - t.len();
        let c = t.chars().next()?;
        let (tok, len) = match c {
            '\n' => (Ok(Tok::Nl), 1),
            '/' if t.starts_with(comment::OPEN) => match comment::len(t) {
                Some(n) => (Ok(Tok::Comment), n),
                None => (Err(LexicalError::UnterminatedComment), 2),
            },
            '(' => (Ok(Tok::LParen), 1),
            ')' => (Ok(Tok::RParen), 1),
            ':' => (Ok(Tok::Colon), 1),
            '<' => (Ok(Tok::Lt), 1),
            '>' => (Ok(Tok::Gt), 1),
            '-' if t.starts_with("-->") => (Ok(Tok::Arrow), 3),
            '-' if t.starts_with("->") => (Ok(Tok::Arrow), 2),
            c if is_control(c) => (Err(LexicalError::ControlChar(c)), c.len_utf8()),
            '\u{FEFF}' => (Err(LexicalError::ByteOrderMark), 3),
            c => (Ok(Tok::Sym(c)), c.len_utf8()),
        };
        Some((tok, s, s + len))
    }

    /// Expression mode: the next token, by logos.
    fn expr_token(&self) -> Option<(Result<Tok<'a>, LexicalError>, usize, usize)> {
        let mut lex = Tok::lexer(&self.src[self.pos..]);
        let tok = lex.next()?;
        let span = lex.span();
        Some((tok, self.pos + span.start, self.pos + span.end))
    }

    /// What follows a token in the current mode: the mode it leads to, or
    /// an error.
    fn after(&mut self, tok: &Tok<'a>) -> Result<(), LexicalError> {
        match (self.mode, tok) {
            (Mode::Module, Tok::LParen) => self.enter(Mode::Params { depth: 1 }),
            (Mode::Module, Tok::Colon) => self.enter(Mode::Expr { depth: 0 }),
            (Mode::Module, _) => {}
            (Mode::Params { depth } | Mode::Expr { depth }, Tok::LParen) => {
                if depth + 1 > MAX_PAREN_DEPTH {
                    return Err(LexicalError::NestedTooDeeply);
                }
                self.mode = match self.mode {
                    Mode::Params { .. } => Mode::Params { depth: depth + 1 },
                    _ => Mode::Expr { depth: depth + 1 },
                };
            }
            (Mode::Params { depth: 1 }, Tok::RParen) => self.enter(Mode::Module),
            (Mode::Params { depth }, Tok::RParen) => self.mode = Mode::Params { depth: depth - 1 },
            (Mode::Expr { depth }, Tok::RParen) => {
                self.mode = Mode::Expr {
                    depth: depth.saturating_sub(1),
                }
            }
            // The next parameter of a module: its own budget, so a long
            // list meets the arity limit instead.
            (Mode::Params { depth: 1 }, Tok::Comma) => self.expr_tokens = 0,
            (Mode::Expr { depth: 0 }, Tok::Arrow) => self.enter(Mode::Module),
            _ => {}
        }
        Ok(())
    }

    /// An end of line: module mode, and a keyword may follow.
    fn newline(&mut self) {
        self.enter(Mode::Module);
        self.line = Line::Start;
    }
}

impl<'a> Iterator for Lexer<'a> {
    type Item = Spanned<'a>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.line {
                Line::Done => return None,
                Line::Start => {
                    self.line = Line::Empty;
                    if let Err(e) = self.view_line() {
                        return Some(Err(e));
                    }
                    if let Some(t) = self.keyword() {
                        self.line = Line::Tokens;
                        return Some(t);
                    }
                }
                Line::Empty | Line::Tokens => {}
            }
            if let Some((at, keyword)) = self.pending_warnings.take() {
                if let Some(t) = self.warnings(at, keyword) {
                    return Some(t);
                }
            }
            let next = match self.mode {
                Mode::Module => self.module_token(),
                Mode::Params { .. } | Mode::Expr { .. } => self.expr_token(),
            };
            let Some((tok, s, e)) = next else {
                // Terminate the last line so the grammar sees whole lines.
                let ended = self.line == Line::Tokens;
                self.line = Line::Done;
                self.pos = self.src.len();
                return ended.then_some(Ok((self.src.len(), Tok::Nl, self.src.len())));
            };
            let error = |span: Span, kind| Some(Err(LexError { span, kind }));
            // Past the token, also a bad one: lexing may go on after an error.
            if let Err(LexicalError::UnexpectedChar(c)) = tok {
                self.pos = e.max(s + c.len_utf8());
                return error((s, s + c.len_utf8()), LexicalError::UnexpectedChar(c));
            }
            self.pos = e;
            if self.mode != Mode::Module {
                self.expr_tokens += 1;
                if self.expr_tokens > MAX_EXPR_TOKENS {
                    return error((s, e), LexicalError::ExpressionTooLong);
                }
            }
            let tok = match tok {
                Ok(t) => t,
                Err(kind) => return error((s, e), kind),
            };
            match tok {
                Tok::Nl => {
                    // Blank lines collapse into one end of line.
                    let ended = self.line == Line::Tokens;
                    self.newline();
                    if ended {
                        return Some(Ok((s, Tok::Nl, e)));
                    }
                    continue;
                }
                Tok::Comment => {
                    // A comment spanning lines ends the line it began on:
                    // what follows starts a line of its own.
                    if self.src[s..e].contains('\n') {
                        let ended = self.line == Line::Tokens;
                        self.newline();
                        if ended {
                            return Some(Ok((s, Tok::Nl, s)));
                        }
                    }
                    continue;
                }
                _ => {}
            }
            if let Err(kind) = self.after(&tok) {
                return error((s, e), kind);
            }
            self.line = Line::Tokens;
            return Some(Ok((s, tok, e)));
        }
    }
}

/// Keyword lines, `view:` lines and the blanks before them. Between the
/// words of a keyword line stand blanks and comments, as between tokens
/// (`gap`); a comment that spans lines ends the line there.
impl<'a> Lexer<'a> {
    /// At the start of a line: skip blanks and look for a keyword.
    /// Blanks and comments may come before the keyword.
    fn keyword(&mut self) -> Option<Spanned<'a>> {
        let at = self.pos + gap(&self.src[self.pos..]);
        let rest = &self.src[at..];
        if let Some(t) = self.structural_keyword(rest, at) {
            return Some(t);
        }
        for (kw, tok, expr) in KEYWORDS {
            if let Some(len) = match_keyword(rest, kw) {
                self.pos = at + len;
                self.enter(if *expr {
                    Mode::Expr { depth: 0 }
                } else {
                    Mode::Module
                });
                if matches!(tok, Tok::KwHomomorphism | Tok::KwDecomposition) {
                    self.pending_warnings = Some((at + len, *kw));
                }
                return Some(Ok((at, tok.clone(), at + len)));
            }
        }
        None
    }

    /// Keyword lines of issue 11 the keyword table cannot express:
    /// `productions N:`, `groups: ...`, and the `decomposition N:` /
    /// `homomorphism N:` mistakes.
    fn structural_keyword(&mut self, rest: &str, at: usize) -> Option<Spanned<'a>> {
        let err =
            |s: usize, e: usize, kind: LexicalError| Some(Err(LexError { span: (s, e), kind }));
        if let Some(len) = match_keyword(rest, "groups:") {
            let mut groups = GroupList::default();
            let mut seen = vec![0u64; 1 << 10];
            let mut end = at + len;
            for (ws, we) in line_words(&rest[len..]) {
                let word = &rest[len + ws..len + we];
                let (s, e) = (at + len + ws, at + len + we);
                if !word.bytes().all(|b| b.is_ascii_digit()) {
                    return err(s, e, LexicalError::GroupsNotNumbers);
                }
                match word.parse::<u32>() {
                    Ok(n) if n <= 65535 => {
                        let (word, bit) = (n as usize / 64, 1u64 << (n % 64));
                        if seen[word] & bit == 0 {
                            seen[word] |= bit;
                            groups.first.push((n as u16, (s, e)));
                        }
                        groups.entries.push(n as u16);
                    }
                    _ => return err(s, e, LexicalError::GroupOutOfRange),
                }
                end = e;
            }
            if groups.entries.is_empty() {
                return err(at, at + len, LexicalError::GroupsNotNumbers);
            }
            groups.entries.shrink_to_fit();
            // What follows the last group (blanks, comments, the line's
            // end) is the token lexer's.
            self.pos = end;
            self.enter(Mode::Module);
            return Some(Ok((at, Tok::KwGroups(groups), end)));
        }
        for word in ["productions", "decomposition", "homomorphism"] {
            let Some(len) = match_keyword(rest, word) else {
                continue;
            };
            let blanks = gap(&rest[len..]);
            if blanks == 0 {
                continue;
            }
            let t = &rest[len + blanks..];
            // The group: up to a blank, a comment or the colon.
            let wlen = t[..word_len(t)].find(':').unwrap_or(word_len(t));
            let tail = &t[wlen..];
            let colon = gap(tail);
            if wlen == 0 || !tail[colon..].starts_with(':') {
                continue;
            }
            let (s, e) = (at + len + blanks, at + len + blanks + wlen);
            if word != "productions" {
                return err(s, e, LexicalError::NoGroups(word));
            }
            let n = match t[..wlen].parse::<u32>() {
                Ok(n) if n <= 65535 && t[..wlen].bytes().all(|b| b.is_ascii_digit()) => n,
                _ => return err(s, e, LexicalError::GroupOutOfRange),
            };
            let end = e + colon + 1;
            self.pos = end;
            self.enter(Mode::Module);
            return Some(Ok((at, Tok::KwProductionsN(n), end)));
        }
        None
    }

    /// After `decomposition:` or `homomorphism:` (`keyword`, ending at
    /// `at`): `warnings`, `no warnings`, or nothing but blanks and comments
    /// on the rest of the line.
    fn warnings(&mut self, at: usize, keyword: &'static str) -> Option<Spanned<'a>> {
        let rest = &self.src[at..];
        // The first three words, and where the last one ends.
        let mut words = Vec::with_capacity(3);
        let mut last = None;
        for w in line_words(rest) {
            if words.len() < 3 {
                words.push(w);
            }
            last = Some(w);
        }
        let (&(s, _), (_, e)) = (words.first()?, last?);
        let is = |(a, b): Span, w: &str| rest[a..b].eq_ignore_ascii_case(w);
        let which = match *words.as_slice() {
            [w] if is(w, "warnings") => true,
            [n, w] if is(n, "no") && is(w, "warnings") => false,
            _ => {
                return Some(Err(LexError {
                    span: (at + s, at + e),
                    kind: LexicalError::ExpectedWarnings(keyword),
                }))
            }
        };
        self.pos = at + e;
        Some(Ok((at + s, Tok::Warnings(which), at + e)))
    }

    /// A `view:` line holds lsgen-turtle's view settings: a keyword like
    /// the others (blanks and comments may come first), checked by the
    /// same parser. The setting is the line's words after `view:`, with
    /// the blanks and comments between them; what follows the last word
    /// (blanks, comments, the line's end) is left to the token lexer.
    fn view_line(&mut self) -> Result<(), LexError> {
        let pos = self.pos + gap(&self.src[self.pos..]);
        let Some(kl) = match_keyword(&self.src[pos..], "view:") else {
            return Ok(());
        };
        let at = pos + kl;
        let end = line_words(&self.src[at..]).last().map_or(0, |(_, e)| e);
        // Comments become blanks of the same length: offsets still hold.
        let setting = blank_comments(&self.src[at..at + end]);
        match crate::turtle::view::parse_setting(&setting) {
            Ok(v) => {
                if let Some(views) = &mut self.views {
                    views.push(v);
                }
            }
            Err(e) => {
                return Err(LexError {
                    span: (at + e.span.0, at + e.span.1.max(e.span.0 + 1).min(end)),
                    kind: LexicalError::ViewSetting(e.kind),
                })
            }
        }
        self.pos = at + end;
        Ok(())
    }
}

/// `text` with each comment in it (closed, as [`gap`] takes them) turned
/// into as many spaces as it has bytes.
fn blank_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(comment::OPEN) {
        out.push_str(&rest[..i]);
        let n = comment::len(&rest[i..]).unwrap_or(rest.len() - i);
        out.extend(std::iter::repeat_n(' ', n));
        rest = &rest[i + n..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toks(src: &str) -> Vec<Tok<'_>> {
        Lexer::new(src).map(|t| t.unwrap().1).collect()
    }

    #[test]
    fn module_mode_makes_every_char_a_symbol() {
        assert_eq!(
            toks("productions:\nF -> F+F--F\n"),
            vec![
                Tok::KwProductions,
                Tok::Nl,
                Tok::Sym('F'),
                Tok::Arrow,
                Tok::Sym('F'),
                Tok::Sym('+'),
                Tok::Sym('F'),
                Tok::Sym('-'),
                Tok::Sym('-'),
                Tok::Sym('F'),
                Tok::Nl
            ]
        );
    }

    #[test]
    fn parameters_and_conditions_are_expressions() {
        assert_eq!(
            toks("A(x,y) : y <= 3 -> A(x*2, x+y)"),
            vec![
                Tok::Sym('A'),
                Tok::LParen,
                Tok::Ident("x"),
                Tok::Comma,
                Tok::Ident("y"),
                Tok::RParen,
                Tok::Colon,
                Tok::Ident("y"),
                Tok::Le,
                Tok::Num(3.0),
                Tok::Arrow,
                Tok::Sym('A'),
                Tok::LParen,
                Tok::Ident("x"),
                Tok::Star,
                Tok::Num(2.0),
                Tok::Comma,
                Tok::Ident("x"),
                Tok::Plus,
                Tok::Ident("y"),
                Tok::RParen,
                Tok::Nl
            ]
        );
    }

    #[test]
    fn keywords_case_insensitive_and_blank_lines_collapse() {
        assert_eq!(
            toks("\n\nDerivation  length: 4\n\n\nseed: 7\n"),
            vec![
                Tok::KwDerivationLength,
                Tok::Num(4.0),
                Tok::Nl,
                Tok::KwSeed,
                Tok::Num(7.0),
                Tok::Nl
            ]
        );
    }

    /// Blanks and comments before a keyword's `:` too (README,
    /// "Keywords"), as in `productions N :`; not a line break.
    #[test]
    fn blanks_and_comments_before_a_keywords_colon() {
        assert_eq!(
            toks("derivation length : 4\nseed/* c */:7\nPRODUCTIONS\t:\ngroups : 1 2\n"),
            vec![
                Tok::KwDerivationLength,
                Tok::Num(4.0),
                Tok::Nl,
                Tok::KwSeed,
                Tok::Num(7.0),
                Tok::Nl,
                Tok::KwProductions,
                Tok::Nl,
                Tok::KwGroups(GroupList {
                    entries: vec![1, 2],
                    first: vec![(1, (59, 60)), (2, (61, 62))]
                }),
                Tok::Nl
            ]
        );
        assert_eq!(match_keyword("maximum depth\n: 2", "maximum depth:"), None);
        assert_eq!(
            match_keyword("maximum  depth /**/ : 2", "maximum depth:"),
            Some(21)
        );
    }

    #[test]
    fn turtle_symbols_and_long_arrow() {
        let t = toks("X --> F[+X]&^\\/|$!'.;%#~@_?*{}");
        assert_eq!(t[0], Tok::Sym('X'));
        assert_eq!(t[1], Tok::Arrow);
        let syms: String = t[2..t.len() - 1]
            .iter()
            .map(|t| match t {
                Tok::Sym(c) => *c,
                other => panic!("not a symbol: {other:?}"),
            })
            .collect();
        assert_eq!(syms, "F[+X]&^\\/|$!'.;%#~@_?*{}");
    }

    #[test]
    fn comments_are_skipped_and_unterminated_is_an_error() {
        assert_eq!(
            toks("F /* a comment */ -> G /* x */\n"),
            vec![Tok::Sym('F'), Tok::Arrow, Tok::Sym('G'), Tok::Nl]
        );
        let errs: Vec<_> = Lexer::new("F -> G /* never closed")
            .filter_map(|t| t.err())
            .collect();
        assert_eq!(errs.len(), 1);
        assert_eq!(errs[0].span, (7, 9));
        assert_eq!(errs[0].kind, LexicalError::UnterminatedComment);
    }

    #[test]
    fn numbers() {
        assert_eq!(
            toks("define: a = .5 + 1e-3 * 2.5E2"),
            vec![
                Tok::KwDefine,
                Tok::Ident("a"),
                Tok::Assign,
                Tok::Num(0.5),
                Tok::Plus,
                Tok::Num(1e-3),
                Tok::Star,
                Tok::Num(250.0),
                Tok::Nl
            ]
        );
    }

    #[test]
    fn absurd_expressions_are_refused() {
        let deep = format!("seed: {}1", "(".repeat(1000));
        let errs: Vec<_> = Lexer::new(&deep).filter_map(|t| t.err()).collect();
        assert_eq!(errs[0].kind, LexicalError::NestedTooDeeply);
        let long = format!("seed: {}", "1+".repeat(20_000));
        let errs: Vec<_> = Lexer::new(&long).filter_map(|t| t.err()).collect();
        assert_eq!(errs[0].kind, LexicalError::ExpressionTooLong);
    }

    #[test]
    fn keywords_after_comments_on_their_line() {
        assert_eq!(
            toks("/* c */ derivation length: 3\n\u{a0}/* d */\t/**/ productions:\n"),
            vec![
                Tok::KwDerivationLength,
                Tok::Num(3.0),
                Tok::Nl,
                Tok::KwProductions,
                Tok::Nl
            ]
        );
        // A comment spanning lines ends the line it began on.
        assert_eq!(
            toks("seed: 1 /* a\nb */ productions:\n"),
            vec![
                Tok::KwSeed,
                Tok::Num(1.0),
                Tok::Nl,
                Tok::KwProductions,
                Tok::Nl
            ]
        );
    }

    #[test]
    fn unicode_blanks_separate_tokens() {
        assert_eq!(
            toks("F\u{a0}\u{b}(1)\u{2003}->\u{85}G"),
            vec![
                Tok::Sym('F'),
                Tok::LParen,
                Tok::Num(1.0),
                Tok::RParen,
                Tok::Arrow,
                Tok::Sym('G'),
                Tok::Nl
            ]
        );
    }

    /// Between the words of a keyword line stand any blanks and comments,
    /// as between tokens; a comment may stand for the blank.
    #[test]
    fn keyword_lines_take_any_blank_and_comments_between_words() {
        for sep in [
            " ",
            "\t",
            "\u{a0}",
            "\u{2003}",
            " /* c */ ",
            "/**/",
            "\u{a0}/* c */\t",
        ] {
            let src = format!(
                "derivation{sep}length: 2\ngroups:{sep}1{sep}2{sep}\n\
                 productions{sep}1{sep}:\ndecomposition:{sep}no{sep}warnings{sep}\n\
                 maximum{sep}depth: 3\nhomomorphism:{sep}warnings{sep}\n"
            );
            let t = toks(&src);
            assert_eq!(
                t,
                vec![
                    Tok::KwDerivationLength,
                    Tok::Num(2.0),
                    Tok::Nl,
                    Tok::KwGroups(t[3].clone().groups()),
                    Tok::Nl,
                    Tok::KwProductionsN(1),
                    Tok::Nl,
                    Tok::KwDecomposition,
                    Tok::Warnings(false),
                    Tok::Nl,
                    Tok::KwMaximumDepth,
                    Tok::Num(3.0),
                    Tok::Nl,
                    Tok::KwHomomorphism,
                    Tok::Warnings(true),
                    Tok::Nl,
                ],
                "{sep:?}"
            );
            let groups = t[3].clone().groups();
            let spans: Vec<&str> = groups.first.iter().map(|&(_, (s, e))| &src[s..e]).collect();
            assert_eq!(groups.entries, [1, 2]);
            assert_eq!(groups.first.iter().map(|g| g.0).collect::<Vec<_>>(), [1, 2]);
            assert_eq!(spans, ["1", "2"], "{sep:?}");
            let view = format!("view:{sep}width{sep}increment{sep}={sep}2{sep}\n");
            assert_eq!(
                view_settings(&view),
                Ok(vec![crate::turtle::view::Setting::WidthIncrement(2.0)]),
                "{sep:?}"
            );
        }
        // A comment that spans lines ends the line: no keyword across it.
        assert_eq!(toks("derivation /* a\n */ length: 2\n")[0], Tok::Sym('d'));
    }

    impl Tok<'_> {
        fn groups(self) -> GroupList {
            match self {
                Tok::KwGroups(g) => g,
                other => panic!("not `groups:`: {other:?}"),
            }
        }
    }

    #[test]
    fn each_parameter_has_its_own_token_budget() {
        let many = format!("F -> G({}1)", "1,".repeat(MAX_EXPR_TOKENS));
        assert!(Lexer::new(&many).all(|t| t.is_ok()));
    }

    #[test]
    fn unicode_symbols() {
        assert_eq!(toks("Ω → αβ")[0], Tok::Sym('Ω'));
    }
}
