//! Comments, `/* ... */` (not nested; a comment may span lines): what one
//! is, in one place for every reader of `.ls` text — the header lexer
//! ([`crate::lang::lexer`]), the header/axiom splitter
//! ([`crate::io::input`]) and the streaming axiom reader
//! ([`crate::io::axiom`]).

/// What opens a comment.
pub const OPEN: &str = "/*";
/// What closes it: the first one after [`OPEN`] (`/*/` does not close).
pub const CLOSE: &str = "*/";

/// Does a comment open at the start of `bytes`?
#[inline]
pub fn opens(bytes: &[u8]) -> bool {
    bytes.starts_with(OPEN.as_bytes())
}

/// Inside a comment: does it close at the start of `bytes`?
#[inline]
pub fn closes(bytes: &[u8]) -> bool {
    bytes.starts_with(CLOSE.as_bytes())
}

/// The length of the comment at the start of `text` (which starts with
/// [`OPEN`]), through its [`CLOSE`]; `None` if it is never closed.
pub fn len(text: &str) -> Option<usize> {
    debug_assert!(opens(text.as_bytes()));
    text[OPEN.len()..]
        .find(CLOSE)
        .map(|i| OPEN.len() + i + CLOSE.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_comment_ends_at_the_first_close_after_its_open() {
        assert_eq!(len("/**/ x"), Some(4));
        assert_eq!(len("/* a */ b */"), Some(7));
        assert_eq!(len("/*/ */"), Some(6));
        assert_eq!(len("/* a\n**/"), Some(8));
        assert_eq!(len("/*/"), None);
        assert_eq!(len("/* never"), None);
        assert!(opens(b"/*x") && !opens(b"/ *"));
        assert!(closes(b"*/") && !closes(b"*"));
    }
}
