//! Lexer for the header of an `.ls` file (settings, productions, homomorphism).
//!
//! The language has two lexical modes. In *module* mode (predecessors,
//! contexts, successors, `ignore:` lists) every non-blank character is a
//! symbol of its own: `F+F` is three tokens. In *expression* mode (inside a
//! module's parentheses, after `:` and in numeric settings) the usual
//! identifiers, numbers and operators apply. Two logos lexers share one
//! position and are morphed into each other as the mode changes; keywords are
//! recognised at the start of a line. The axiom is not lexed here: it is
//! streamed by [`crate::io::axiom`].

use logos::Logos;

/// Byte span in the header text.
pub type Span = (usize, usize);

/// A token handed to the LALRPOP grammar.
#[derive(Clone, Debug, PartialEq)]
pub enum Tok<'a> {
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
    /// `groups: G1 G2 ...`, each group with its span.
    KwGroups(Vec<(u32, Span)>),
    KwGroup,
    /// `warnings` (true) or `no warnings` after a section keyword.
    Warnings(bool),
    Sym(char),
    Num(f64),
    Ident(&'a str),
    LParen,
    RParen,
    Comma,
    Colon,
    Arrow,
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
    Plus,
    Minus,
    Star,
    Slash,
    Caret,
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
        };
        f.write_str(s)
    }
}

/// What went wrong while lexing, with the span it covers.
#[derive(Clone, Debug, PartialEq)]
pub struct LexError {
    pub span: Span,
    pub message: String,
}

/// Tokens of module mode.
#[derive(Logos, Debug, Clone, Copy, PartialEq)]
#[logos(skip r"[\s&&[^\n]]+")]
enum ModTok {
    #[token("\n")]
    Nl,
    #[regex(r"/\*([^*]|\*+[^*/])*\*+/", allow_greedy = true)]
    Comment,
    #[token("/*")]
    OpenComment,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token(":")]
    Colon,
    #[token("->")]
    #[token("-->")]
    Arrow,
    #[token("<")]
    Lt,
    #[token(">")]
    Gt,
    #[regex(r"[^\s\p{Cc}():<>]")]
    Sym,
    #[regex(r"[\x00-\x08\x0E-\x1F\x7F\u{80}-\u{84}\u{86}-\u{9F}]")]
    Control,
}

/// Tokens of expression mode.
#[derive(Logos, Debug, Clone, Copy, PartialEq)]
#[logos(skip r"[\s&&[^\n]]+")]
enum ExprTok {
    #[token("\n")]
    Nl,
    #[regex(r"/\*([^*]|\*+[^*/])*\*+/", allow_greedy = true)]
    Comment,
    #[token("/*")]
    OpenComment,
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?")]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?")]
    Num,
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident,
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
}

enum Inner<'a> {
    Mod(logos::Lexer<'a, ModTok>),
    Expr(logos::Lexer<'a, ExprTok>),
    /// Transitional state while morphing.
    Gone,
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

/// The rest of a line from `rest`, up to a newline or a comment.
fn line_rest(rest: &str) -> &str {
    let end = rest.find(['\n', '\r']).unwrap_or(rest.len());
    let line = &rest[..end];
    match line.find("/*") {
        Some(c) => &line[..c],
        None => line,
    }
}

/// Is `line` (from its first non-blank byte) a keyword line? Returns the
/// keyword's byte length. Keywords are matched case-insensitively, so cpfg's
/// `Derivation length:` works, and inner runs of blanks are allowed.
pub fn match_keyword(rest: &str, keyword: &str) -> Option<usize> {
    let mut r = rest.char_indices().peekable();
    let mut end = 0;
    for kc in keyword.chars() {
        if kc == ' ' {
            // one or more blanks
            let mut n = 0;
            while let Some(&(_, c)) = r.peek() {
                if c == ' ' || c == '\t' {
                    r.next();
                    n += 1;
                } else {
                    break;
                }
            }
            if n == 0 {
                return None;
            }
            continue;
        }
        match r.next() {
            Some((i, c)) if c.eq_ignore_ascii_case(&kc) => end = i + c.len_utf8(),
            _ => return None,
        }
    }
    Some(end)
}

/// The mode-switching lexer over the header text.
pub struct Lexer<'a> {
    src: &'a str,
    inner: Inner<'a>,
    /// At the start of a line: check for keywords.
    line_start: bool,
    /// Last token emitted was a newline (or nothing yet): collapse blank lines.
    after_nl: bool,
    /// In expression mode: parenthesis depth, and whether depth 0 returns to
    /// module mode (a module's parameter list) or not (condition, probability,
    /// numeric setting).
    depth: u32,
    return_at_zero: bool,
    done: bool,
    /// Tokens of the current expression, to bound the parser's and the
    /// compiler's recursion on absurd input.
    expr_tokens: usize,
    /// The settings of the `view:` lines met, when collected.
    views: Option<Vec<crate::turtle::view::Setting>>,
    /// Just after `decomposition:` / `homomorphism:` (at this offset):
    /// look for `warnings` / `no warnings`.
    pending_warnings: Option<usize>,
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

impl<'a> Lexer<'a> {
    pub fn new(src: &'a str) -> Self {
        Lexer {
            src,
            inner: Inner::Mod(ModTok::lexer(src)),
            line_start: true,
            after_nl: true,
            depth: 0,
            return_at_zero: false,
            done: false,
            expr_tokens: 0,
            views: None,
            pending_warnings: None,
        }
    }

    /// A lexer for a lone expression (an axiom parameter, a test).
    pub fn new_expr(src: &'a str) -> Self {
        Lexer {
            src,
            inner: Inner::Expr(ExprTok::lexer(src)),
            line_start: false,
            after_nl: true,
            depth: 0,
            return_at_zero: false,
            done: false,
            expr_tokens: 0,
            views: None,
            pending_warnings: None,
        }
    }

    fn pos(&self) -> usize {
        match &self.inner {
            Inner::Mod(l) => l.span().end,
            Inner::Expr(l) => l.span().end,
            Inner::Gone => unreachable!("lexer used while morphing"),
        }
    }

    fn bump(&mut self, n: usize) {
        match &mut self.inner {
            Inner::Mod(l) => l.bump(n),
            Inner::Expr(l) => l.bump(n),
            Inner::Gone => unreachable!("lexer used while morphing"),
        }
    }

    fn enter_expr(&mut self) {
        self.expr_tokens = 0;
        if let Inner::Mod(l) = std::mem::replace(&mut self.inner, Inner::Gone) {
            self.inner = Inner::Expr(l.morph());
        } else {
            unreachable!("to_expr from expression mode")
        }
    }

    fn enter_mod(&mut self) {
        if let Inner::Expr(l) = std::mem::replace(&mut self.inner, Inner::Gone) {
            self.inner = Inner::Mod(l.morph());
        } else {
            unreachable!("to_mod from module mode")
        }
    }

    fn ensure_mod(&mut self) {
        if matches!(self.inner, Inner::Expr(_)) {
            self.enter_mod();
        }
    }

    /// Bytes of blanks and comments at `pos` before a keyword may start
    /// (a comment that spans lines starts a new line, handled by the
    /// caller as a newline).
    fn lead(&self, pos: usize) -> usize {
        let mut blank = 0;
        loop {
            let rest = &self.src[pos + blank..];
            let t = rest.trim_start_matches(|c: char| c != '\n' && c.is_whitespace());
            blank += rest.len() - t.len();
            match t.strip_prefix("/*").and_then(|c| c.find("*/")) {
                Some(end) if !t[..end + 4].contains('\n') => blank += end + 4,
                _ => break,
            }
        }
        blank
    }

    /// At the start of a line: skip blanks and look for a keyword.
    /// Blanks and comments may come before the keyword.
    fn keyword(&mut self) -> Option<Spanned<'a>> {
        let pos = self.pos();
        let blank = self.lead(pos);
        let rest = &self.src[pos + blank..];
        let at = pos + blank;
        if let Some(t) = self.structural_keyword(rest, at) {
            return Some(t);
        }
        for (kw, tok, expr) in KEYWORDS {
            if let Some(len) = match_keyword(rest, kw) {
                self.bump(blank + len);
                self.ensure_mod();
                if *expr {
                    self.enter_expr();
                    self.depth = 0;
                    self.return_at_zero = false;
                }
                if matches!(tok, Tok::KwHomomorphism | Tok::KwDecomposition) {
                    self.pending_warnings = Some(at + len);
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
        let err = |s: usize, e: usize, m: &str| {
            Some(Err(LexError {
                span: (s, e),
                message: m.to_string(),
            }))
        };
        if let Some(len) = match_keyword(rest, "groups:") {
            let line = line_rest(&rest[len..]);
            let mut groups = Vec::new();
            let mut off = 0;
            for word in line.split([' ', '\t']) {
                let s = at + len + off;
                off += word.len() + 1;
                if word.is_empty() {
                    continue;
                }
                if !word.bytes().all(|b| b.is_ascii_digit()) {
                    return err(
                        s,
                        s + word.len(),
                        "`groups:` takes whole group numbers separated by blanks",
                    );
                }
                match word.parse::<u32>() {
                    Ok(n) if n <= 65535 => groups.push((n, (s, s + word.len()))),
                    _ => {
                        return err(
                            s,
                            s + word.len(),
                            "a production group is a whole number from 0 to 65535",
                        )
                    }
                }
            }
            if groups.is_empty() {
                return err(
                    at,
                    at + len,
                    "`groups:` takes whole group numbers separated by blanks",
                );
            }
            self.bump(at - self.pos() + len + line.len());
            self.ensure_mod();
            return Some(Ok((at, Tok::KwGroups(groups), at + len + line.len())));
        }
        for word in ["productions", "decomposition", "homomorphism"] {
            let Some(len) = match_keyword(rest, word) else {
                continue;
            };
            let after = &rest[len..];
            let blanks = after.len() - after.trim_start_matches([' ', '\t']).len();
            if blanks == 0 {
                continue;
            }
            let t = &after[blanks..];
            let wlen = t.find([' ', '\t', ':', '\n', '\r']).unwrap_or(t.len());
            let tail = &t[wlen..];
            let colon = tail.len() - tail.trim_start_matches([' ', '\t']).len();
            if wlen == 0 || !tail[colon..].starts_with(':') {
                continue;
            }
            let (s, e) = (at + len + blanks, at + len + blanks + wlen);
            if word != "productions" {
                return err(s, e, &format!("{word} has no groups"));
            }
            let n = match t[..wlen].parse::<u32>() {
                Ok(n) if n <= 65535 && t[..wlen].bytes().all(|b| b.is_ascii_digit()) => n,
                _ => return err(s, e, "a production group is a whole number from 0 to 65535"),
            };
            let end = e + colon + 1;
            self.bump(end - self.pos());
            self.ensure_mod();
            return Some(Ok((at, Tok::KwProductionsN(n), end)));
        }
        None
    }

    /// After `decomposition:` or `homomorphism:`: `warnings`, `no
    /// warnings`, or nothing on the rest of the line.
    fn warnings(&mut self, at: usize) -> Option<Spanned<'a>> {
        let rest = &self.src[at..];
        let line = line_rest(rest);
        let blank = line.len() - line.trim_start_matches([' ', '\t']).len();
        let word = line[blank..].trim_end();
        if word.is_empty() {
            return None;
        }
        let s = at + blank;
        let which = if word.eq_ignore_ascii_case("warnings") {
            true
        } else if let Some(len) = match_keyword(word, "no warnings").filter(|&l| l == word.len()) {
            let _ = len;
            false
        } else {
            let kw = if self.src[..at]
                .trim_end()
                .to_ascii_lowercase()
                .ends_with("homomorphism:")
            {
                "homomorphism:"
            } else {
                "decomposition:"
            };
            return Some(Err(LexError {
                span: (s, s + word.len()),
                message: format!("expected `warnings` or `no warnings` after `{kw}`"),
            }));
        };
        self.bump(blank + word.len());
        Some(Ok((s, Tok::Warnings(which), s + word.len())))
    }

    /// A `view:` line holds lsgen-turtle's view settings: a keyword like
    /// the others (blanks and comments may come first), checked by the
    /// same parser, then skipped up to the end of the line (or a comment).
    fn view_line(&mut self) -> Result<(), LexError> {
        let pos = self.pos();
        let blank = self.lead(pos);
        let Some(kl) = match_keyword(&self.src[pos + blank..], "view:") else {
            return Ok(());
        };
        let at = pos + blank + kl;
        let end = crate::turtle::view::setting_end(&self.src[at..]);
        match crate::turtle::view::parse_setting(&self.src[at..at + end]) {
            Ok(v) => {
                if let Some(views) = &mut self.views {
                    views.push(v);
                }
            }
            Err(e) => {
                return Err(LexError {
                    span: (at + e.span.0, at + e.span.1.max(e.span.0 + 1).min(end)),
                    message: e.message,
                })
            }
        }
        self.bump(blank + kl + end);
        Ok(())
    }

    fn newline(&mut self) {
        self.ensure_mod();
        self.depth = 0;
        self.return_at_zero = false;
        self.line_start = true;
    }
}

pub type Spanned<'a> = Result<(usize, Tok<'a>, usize), LexError>;

impl<'a> Iterator for Lexer<'a> {
    type Item = Spanned<'a>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if self.done {
                return None;
            }
            if self.line_start {
                self.line_start = false;
                if let Err(e) = self.view_line() {
                    return Some(Err(e));
                }
                if let Some(t) = self.keyword() {
                    self.after_nl = false;
                    return Some(t);
                }
            }
            if let Some(at) = self.pending_warnings.take() {
                if let Some(t) = self.warnings(at) {
                    return Some(t);
                }
            }
            let (tok, span) = match &mut self.inner {
                Inner::Mod(l) => match l.next() {
                    None => (None, l.span()),
                    Some(t) => (Some(t.map(Left)), l.span()),
                },
                Inner::Expr(l) => match l.next() {
                    None => (None, l.span()),
                    Some(t) => (Some(t.map(Right)), l.span()),
                },
                Inner::Gone => unreachable!("lexer used while morphing"),
            };
            let (s, e) = (span.start, span.end);
            let Some(tok) = tok else {
                self.done = true;
                // Terminate the last line so the grammar sees whole lines.
                if !self.after_nl {
                    self.after_nl = true;
                    return Some(Ok((self.src.len(), Tok::Nl, self.src.len())));
                }
                return None;
            };
            let tok = match tok {
                Err(()) => {
                    let text = &self.src[s..e.max(s + 1).min(self.src.len())];
                    let c = text.chars().next().unwrap_or('?');
                    return Some(Err(LexError {
                        span: (s, s + c.len_utf8()),
                        message: format!("unexpected character `{}`", c.escape_default()),
                    }));
                }
                Ok(t) => t,
            };
            if let Right(_) = tok {
                self.expr_tokens += 1;
                if self.expr_tokens > MAX_EXPR_TOKENS {
                    return Some(Err(LexError {
                        span: (s, e),
                        message: format!("expression too long (over {MAX_EXPR_TOKENS} tokens)"),
                    }));
                }
            }
            let out = match tok {
                Left(ModTok::Nl) | Right(ExprTok::Nl) => {
                    self.newline();
                    if self.after_nl {
                        continue;
                    }
                    self.after_nl = true;
                    return Some(Ok((s, Tok::Nl, e)));
                }
                Left(ModTok::Comment) | Right(ExprTok::Comment) => {
                    // A comment spanning lines still ends the line it began on
                    // only if it contains a newline; treat that as a newline.
                    if self.src[s..e].contains('\n') {
                        // What follows the comment starts a line of its own.
                        self.newline();
                        if !self.after_nl {
                            self.after_nl = true;
                            return Some(Ok((s, Tok::Nl, s)));
                        }
                    }
                    continue;
                }
                Left(ModTok::OpenComment) | Right(ExprTok::OpenComment) => {
                    return Some(Err(LexError {
                        span: (s, e),
                        message: "unterminated comment: `/*` without `*/`".into(),
                    }));
                }
                Left(ModTok::Control) => {
                    let c = self.src[s..].chars().next().unwrap_or('?');
                    return Some(Err(LexError {
                        span: (s, e),
                        message: format!(
                            "control character `{}` cannot be a symbol",
                            c.escape_default()
                        ),
                    }));
                }
                Left(ModTok::Sym) => Tok::Sym(self.src[s..e].chars().next().unwrap()),
                Left(ModTok::LParen) => {
                    self.enter_expr();
                    self.depth = 1;
                    self.return_at_zero = true;
                    Tok::LParen
                }
                Left(ModTok::RParen) => Tok::RParen,
                Left(ModTok::Colon) => {
                    self.enter_expr();
                    self.depth = 0;
                    self.return_at_zero = false;
                    Tok::Colon
                }
                Left(ModTok::Arrow) => Tok::Arrow,
                Left(ModTok::Lt) => Tok::Lt,
                Left(ModTok::Gt) => Tok::Gt,
                Right(ExprTok::Num) => match self.src[s..e].parse::<f64>() {
                    Ok(v) if v.is_finite() => Tok::Num(v),
                    _ => {
                        return Some(Err(LexError {
                            span: (s, e),
                            message: format!("number `{}` is out of range", &self.src[s..e]),
                        }))
                    }
                },
                Right(ExprTok::Ident) => Tok::Ident(&self.src[s..e]),
                Right(ExprTok::LParen) => {
                    self.depth += 1;
                    if self.depth > MAX_PAREN_DEPTH {
                        return Some(Err(LexError {
                            span: (s, e),
                            message: format!(
                                "parentheses nested too deeply (over {MAX_PAREN_DEPTH})"
                            ),
                        }));
                    }
                    Tok::LParen
                }
                Right(ExprTok::RParen) => {
                    self.depth = self.depth.saturating_sub(1);
                    if self.depth == 0 && self.return_at_zero {
                        self.enter_mod();
                        self.return_at_zero = false;
                    }
                    Tok::RParen
                }
                Right(ExprTok::Comma) => {
                    if self.depth == 1 && self.return_at_zero {
                        // The next parameter of a module: its own budget,
                        // so a long list meets the arity limit instead.
                        self.expr_tokens = 0;
                    }
                    Tok::Comma
                }
                Right(ExprTok::Colon) => Tok::Colon,
                Right(ExprTok::Arrow) => {
                    if self.depth == 0 {
                        self.enter_mod();
                    }
                    Tok::Arrow
                }
                Right(ExprTok::Lt) => Tok::Lt,
                Right(ExprTok::Gt) => Tok::Gt,
                Right(ExprTok::Le) => Tok::Le,
                Right(ExprTok::Ge) => Tok::Ge,
                Right(ExprTok::EqEq) => Tok::EqEq,
                Right(ExprTok::Ne) => Tok::Ne,
                Right(ExprTok::Assign) => Tok::Assign,
                Right(ExprTok::AndAnd) => Tok::AndAnd,
                Right(ExprTok::OrOr) => Tok::OrOr,
                Right(ExprTok::Bang) => Tok::Bang,
                Right(ExprTok::Plus) => Tok::Plus,
                Right(ExprTok::Minus) => Tok::Minus,
                Right(ExprTok::Star) => Tok::Star,
                Right(ExprTok::Slash) => Tok::Slash,
                Right(ExprTok::Caret) => Tok::Caret,
            };
            self.after_nl = false;
            return Some(Ok((s, out, e)));
        }
    }
}

use Either::{Left, Right};
enum Either<A, B> {
    Left(A),
    Right(B),
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
        assert!(errs[0].message.contains("unterminated comment"));
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
        assert!(errs[0].message.contains("nested too deeply"));
        let long = format!("seed: {}", "1+".repeat(20_000));
        let errs: Vec<_> = Lexer::new(&long).filter_map(|t| t.err()).collect();
        assert!(errs[0].message.contains("too long"));
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
