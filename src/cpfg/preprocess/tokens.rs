//! The preprocessor's tokens.

use super::*;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum K {
    Space,
    Newline,
    Ident,
    Number,
    Str,
    Char,
    LParen,
    RParen,
    Comma,
    Hash,
    HashHash,
    /// A run of other characters (operators, module symbols, ...).
    Other,
    /// An unterminated `"` or `'` literal (lexing only).
    BadLit,
    /// Empty macro argument next to `##`.
    Placemarker,
    /// In macro bodies: a parameter, `#parameter`, the `##` operator.
    Param,
    Stringify,
    Paste,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Org {
    /// Spelled in the text outside `#define`.
    Src,
    /// Spelled in a `#define` body.
    Body,
    /// Made by the preprocessor.
    Synth,
}

#[derive(Clone, Debug)]
pub(super) struct Tok {
    pub(super) kind: K,
    pub(super) org: Org,
    /// Where it was spelled (for `Synth`: where it was made).
    pub(super) at: Pos,
    pub(super) len: u32,
    /// The outermost macro call that produced it.
    pub(super) usage: Option<Pos>,
    pub(super) hide: u32,
    /// Newlines of comments inside a `Space`.
    pub(super) nl: u32,
    /// Parameter index of `Param`/`Stringify`.
    pub(super) arg: u32,
    pub(super) own: Option<Rc<str>>,
}

impl Tok {
    pub(super) fn src(kind: K, file: u32, off: usize, len: usize) -> Tok {
        Tok {
            kind,
            org: Org::Src,
            at: Pos {
                file,
                off: off as u32,
            },
            len: len as u32,
            usage: None,
            hide: 0,
            nl: 0,
            arg: u32::MAX,
            own: None,
        }
    }

    pub(super) fn synth(kind: K, text: &str, at: Pos, usage: Option<Pos>) -> Tok {
        Tok {
            kind,
            org: Org::Synth,
            at,
            len: text.len() as u32,
            usage,
            hide: 0,
            nl: 0,
            arg: u32::MAX,
            own: Some(text.into()),
        }
    }

    /// The place to report for this token.
    pub(super) fn primary(&self) -> Pos {
        match self.org {
            Org::Src => self.at,
            _ => self.usage.unwrap_or(self.at),
        }
    }

    pub(super) fn is_space(&self) -> bool {
        matches!(self.kind, K::Space | K::Newline)
    }
}

pub(super) fn text_of<'a>(files: &'a [SourceFile], t: &'a Tok) -> &'a str {
    match &t.own {
        Some(s) => s,
        None => {
            let c = &files[t.at.file as usize].clean;
            let o = t.at.off as usize;
            c.get(o..(o + t.len as usize).min(c.len())).unwrap_or("")
        }
    }
}

pub(super) fn is_hspace(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\x0b' | b'\x0c' | b'\r')
}

pub(super) fn is_idstart(c: u8) -> bool {
    c.is_ascii_alphabetic() || c == b'_' || c == b'$'
}

pub(super) fn is_idchar(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'$'
}

/// The token starting at `b[i]` (`i < end`): its kind and end.
pub(super) fn lex(b: &[u8], i: usize, end: usize) -> (K, usize) {
    let c = b[i];
    let number_at = |j: usize| {
        b[j].is_ascii_digit() || (b[j] == b'.' && j + 1 < end && b[j + 1].is_ascii_digit())
    };
    let mut j = i + 1;
    let kind = if is_hspace(c) {
        while j < end && is_hspace(b[j]) {
            j += 1;
        }
        K::Space
    } else if is_idstart(c) {
        while j < end && is_idchar(b[j]) {
            j += 1;
        }
        K::Ident
    } else if number_at(i) {
        while j < end && (is_idchar(b[j]) || b[j] == b'.') {
            let e = matches!(b[j], b'e' | b'E' | b'p' | b'P');
            j += 1;
            if e && j < end && matches!(b[j], b'+' | b'-') {
                j += 1;
            }
        }
        K::Number
    } else if c == b'"' || c == b'\'' {
        loop {
            if j >= end {
                return (K::BadLit, end);
            }
            if b[j] == c {
                j += 1;
                break;
            }
            j += if b[j] == b'\\' && j + 1 < end { 2 } else { 1 };
        }
        if c == b'"' {
            K::Str
        } else {
            K::Char
        }
    } else {
        match c {
            b'(' => K::LParen,
            b')' => K::RParen,
            b',' => K::Comma,
            b'#' if j < end && b[j] == b'#' => {
                j += 1;
                K::HashHash
            }
            b'#' => K::Hash,
            _ => {
                while j < end
                    && !(is_hspace(b[j])
                        || is_idchar(b[j])
                        || number_at(j)
                        || matches!(b[j], b'"' | b'\'' | b'(' | b')' | b',' | b'#'))
                {
                    j += 1;
                }
                K::Other
            }
        }
    };
    (kind, j)
}
