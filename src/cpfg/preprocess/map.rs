//! The map from preprocessed text back to original files, lines and
//! columns.

use super::*;

/// A place in a file's cleaned text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Pos {
    pub(super) file: u32,
    pub(super) off: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum SegKind {
    /// Copied text: byte `k` of the segment is byte `a + k`.
    Text,
    /// Every byte maps to `a` (newlines of comments, end of file).
    Fixed,
    /// A macro argument spelled in the text at `a + k`, in the call at `b`.
    Arg,
    /// A macro body token spelled at `a + k`, in the call at `b`.
    Body,
    /// Made by `#`/`##`/`defined` in the call at `b`.
    Synth,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Seg {
    pub(super) out: usize,
    pub(super) kind: SegKind,
    pub(super) a: Pos,
    pub(super) b: Pos,
}

/// A place in an original file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Loc<'a> {
    pub file: &'a str,
    pub line: usize,
    pub col: usize,
}

/// Where an output byte comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Origin<'a> {
    /// The place to report: the text itself, or, for text that a macro
    /// body produced, the macro call.
    pub at: Loc<'a>,
    /// The outermost macro call the byte was produced by, if any.
    pub macro_use: Option<Loc<'a>>,
    /// Where the byte was written in a `#define` body, if it was.
    pub macro_def: Option<Loc<'a>>,
}

/// Maps offsets of the preprocessed text back to the original files.
#[derive(Debug)]
pub struct SourceMap {
    pub(super) files: Vec<SourceFile>,
    pub(super) segs: Vec<Seg>,
}

impl SourceMap {
    pub(super) fn loc(&self, p: Pos, delta: usize) -> (usize, usize) {
        let f = &self.files[p.file as usize];
        (p.file as usize, f.src_offset(p.off as usize + delta))
    }

    pub(super) fn to_loc(&self, (file, off): (usize, usize)) -> Loc<'_> {
        let f = &self.files[file];
        let (line, col, _) = f.line_col(off);
        Loc {
            file: &f.name,
            line,
            col,
        }
    }

    /// (primary, use, def) as (file index, original offset).
    pub(super) fn resolve(&self, offset: usize) -> [Option<(usize, usize)>; 3] {
        let i = self.segs.partition_point(|s| s.out <= offset);
        let Some(s) = self.segs.get(i.wrapping_sub(1)) else {
            return [Some((0, 0)), None, None];
        };
        let d = offset - s.out;
        match s.kind {
            SegKind::Text => [Some(self.loc(s.a, d)), None, None],
            SegKind::Fixed => [Some(self.loc(s.a, 0)), None, None],
            SegKind::Arg => {
                let u = self.loc(s.b, 0);
                [Some(self.loc(s.a, d)), Some(u), None]
            }
            SegKind::Body => {
                let u = self.loc(s.b, 0);
                [Some(u), Some(u), Some(self.loc(s.a, d))]
            }
            SegKind::Synth => {
                let u = self.loc(s.b, 0);
                [Some(u), Some(u), None]
            }
        }
    }

    /// Original file, line and column of byte `offset` of the output (for
    /// text made by a macro body: the macro call). Offsets past the end give
    /// the last place.
    pub fn locate(&self, offset: usize) -> Loc<'_> {
        self.origin(offset).at
    }

    /// Everything known about byte `offset`: see [`Origin`].
    pub fn origin(&self, offset: usize) -> Origin<'_> {
        let [at, u, d] = self.resolve(offset);
        Origin {
            at: self.to_loc(at.unwrap_or((0, 0))),
            macro_use: u.map(|x| self.to_loc(x)),
            macro_def: d.map(|x| self.to_loc(x)),
        }
    }

    #[cfg(test)]
    pub(crate) fn pieces(&self) -> usize {
        self.segs.len()
    }

    /// A located error position (with the source line) for byte `offset`.
    pub fn location(&self, offset: usize) -> Location {
        let [at, _, _] = self.resolve(offset);
        let (file, off) = at.unwrap_or((0, 0));
        self.files[file].location_src(off)
    }
}

/// The preprocessed text, its map back to the sources, and the warnings.
#[derive(Debug)]
pub struct Output {
    pub text: String,
    pub map: SourceMap,
    pub warnings: Vec<Warning>,
}
