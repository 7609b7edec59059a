//! Source files of the preprocessor: reading, line splicing, comments
//! and include paths.

use super::*;

/// One input file: its original text and the maps from its cleaned text
/// (splices, CR LF and comments removed) back to it.
#[derive(Debug)]
pub(super) struct SourceFile {
    pub(super) name: String,
    /// Lexically normalised path, for cycle detection.
    pub(super) key: PathBuf,
    /// The path as loaded, base for nested includes.
    pub(super) path: PathBuf,
    pub(super) text: String,
    pub(super) line_starts: Vec<usize>,
    pub(super) clean: String,
    /// (offset in spliced text, offset in `text`) at every change of delta.
    pub(super) splice_breaks: Vec<(usize, usize)>,
    /// (offset in `clean`, offset in spliced text).
    pub(super) clean_breaks: Vec<(usize, usize)>,
    /// (offset in `clean` of a comment's space, newlines in the comment).
    pub(super) comment_nl: Vec<(usize, u32)>,
}

pub(super) fn back(breaks: &[(usize, usize)], off: usize) -> usize {
    let i = breaks.partition_point(|&(o, _)| o <= off);
    let (o, s) = breaks[i.saturating_sub(1)];
    s + off.saturating_sub(o)
}

impl SourceFile {
    /// Prepare a file; `Err` locates an unterminated comment.
    pub(super) fn new(name: String, path: PathBuf, text: String) -> Result<SourceFile, Location> {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        let (spliced, splice_breaks) = splice(&text);
        let mut f = SourceFile {
            name,
            key: normalize(&path),
            path,
            text,
            line_starts,
            clean: String::new(),
            splice_breaks,
            clean_breaks: vec![(0, 0)],
            comment_nl: Vec::new(),
        };
        match strip_comments(&spliced) {
            Ok((clean, clean_breaks, comment_nl)) => {
                f.clean = clean;
                f.clean_breaks = clean_breaks;
                f.comment_nl = comment_nl;
                Ok(f)
            }
            Err(at) => Err(f.location_src(back(&f.splice_breaks, at))),
        }
    }

    pub(super) fn src_offset(&self, clean: usize) -> usize {
        back(&self.splice_breaks, back(&self.clean_breaks, clean)).min(self.text.len())
    }

    /// Line, column (1-based, column in characters) and line text of a
    /// byte offset of the original text.
    pub(super) fn line_col(&self, off: usize) -> (usize, usize, &str) {
        let (idx, col, line) = crate::diag::line_col(&self.text, &self.line_starts, off);
        (idx + 1, col, line)
    }

    pub(super) fn location_src(&self, off: usize) -> Location {
        let (line, col, text) = self.line_col(off);
        let (snippet, caret_col) = excerpt(text, col);
        Location {
            path: self.name.clone(),
            line,
            col,
            snippet,
            caret_col,
        }
    }
}

/// Remove `\`-newline splices and the CR of CR LF.
pub(super) fn splice(src: &str) -> (String, Vec<(usize, usize)>) {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut breaks = vec![(0, 0)];
    let (mut i, mut run) = (0, 0);
    while i < b.len() {
        let skip = match b[i] {
            b'\\' if b.get(i + 1) == Some(&b'\n') => 2,
            b'\\' if b.get(i + 1) == Some(&b'\r') && b.get(i + 2) == Some(&b'\n') => 3,
            b'\r' if b.get(i + 1) == Some(&b'\n') => 1,
            _ => 0,
        };
        if skip == 0 {
            i += 1;
            continue;
        }
        out.push_str(&src[run..i]);
        i += skip;
        run = i;
        breaks.push((out.len(), i));
    }
    out.push_str(&src[run..]);
    (out, breaks)
}

pub(super) type Stripped = (String, Vec<(usize, usize)>, Vec<(usize, u32)>);

/// Replace comments by one space; `Err(offset)` of an unterminated `/*`.
pub(super) fn strip_comments(s: &str) -> Result<Stripped, usize> {
    let b = s.as_bytes();
    let mut out = String::with_capacity(s.len());
    let mut breaks = vec![(0, 0)];
    let mut nls = Vec::new();
    let (mut i, mut run) = (0, 0);
    while i < b.len() {
        match b[i] {
            q @ (b'"' | b'\'') => {
                let mut j = i + 1;
                while j < b.len() && b[j] != q && b[j] != b'\n' {
                    j += if b[j] == b'\\' && j + 1 < b.len() && b[j + 1] != b'\n' {
                        2
                    } else {
                        1
                    };
                }
                i = if j < b.len() && b[j] == q {
                    j + 1
                } else if q == b'\'' {
                    // A `'` not closed on its line: vlabcpp keeps the rest
                    // of the line as it is (a warning, in `next_tok`), and
                    // cpfg's scanner skips a `/* */` comment there: strip
                    // comments after it as anywhere.
                    i + 1
                } else {
                    j
                };
            }
            b'/' if matches!(b.get(i + 1), Some(b'*') | Some(b'/')) => {
                let end = if b[i + 1] == b'*' {
                    match s[i + 2..].find("*/") {
                        Some(e) => i + 2 + e + 2,
                        None => return Err(i),
                    }
                } else {
                    s[i..].find('\n').map_or(b.len(), |e| i + e)
                };
                out.push_str(&s[run..i]);
                breaks.push((out.len(), i));
                let n = b[i..end].iter().filter(|&&c| c == b'\n').count() as u32;
                if n > 0 {
                    nls.push((out.len(), n));
                }
                out.push(' ');
                breaks.push((out.len(), end));
                i = end;
                run = end;
            }
            _ => i += 1,
        }
    }
    out.push_str(&s[run..]);
    Ok((out, breaks, nls))
}

/// Drop `.` components and resolve `..` lexically.
pub(super) fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if matches!(out.components().next_back(), Some(Component::Normal(_))) {
                    out.pop();
                } else {
                    out.push("..");
                }
            }
            c => out.push(c.as_os_str()),
        }
    }
    out
}

pub(super) fn include_path(including: &Path, name: &str) -> PathBuf {
    let dir = including.parent().unwrap_or(Path::new(""));
    dir.join(name)
        .components()
        .filter(|c| *c != Component::CurDir)
        .collect()
}
