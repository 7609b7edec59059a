//! The D0L byte table: ASCII symbols whose step needs no decision are
//! rewritten by a 128-entry table, in blocks.

use super::choose::{by_weight, Folded};
use super::context::LeftContext;
use super::random::{Draw, Random};
use super::sink::{Out, OUT_CHUNK};
use crate::diag::Error;
use crate::rules::{Alphabet, Item, Table, CLOSE, OPEN};

/// Each ASCII byte, so a symbol can be copied as a one-byte slice.
pub(crate) static ASCII: [u8; 128] = {
    let mut t = [0u8; 128];
    let mut i = 0;
    while i < 128 {
        t[i] = i as u8;
        i += 1;
    }
    t
};

/// The D0L fast path: for each ASCII symbol without parameters, what a
/// step does to it when that needs no decision (no context, no condition,
/// no probability, a constant successor). Bytes it cannot handle stop the
/// run and go through the general path.
pub(crate) struct ByteTable<'t> {
    /// None: take the general path.
    succ: [Option<FastSucc<'t>>; 128],
    /// Brackets take the general path too (it tracks branches for cuts).
    brackets_general: bool,
    /// May successors with `[` or `]` be copied here?
    brackets: bool,
    text: bool,
}

/// The keys a [`ByteTable`] draws for ([`ByteTable::folds`]), by byte:
/// looked at only where its `succ` has none. Apart from the table, so a
/// pass without them has the table's loop as it was.
#[derive(Default)]
pub(crate) struct Folds<'t>(Vec<Option<FoldSucc<'t>>>);

impl Folds<'_> {
    /// Does the table draw for the folded key `b`?
    pub(crate) fn has(&self, b: u8) -> bool {
        matches!(self.0.get(usize::from(b)), Some(Some(_)))
    }
}

/// A [`Folded`] key in the table: the draw at the module's index picks one
/// of its successors, as [`super::choose::pick`] does.
struct FoldSucc<'t> {
    /// (weight, successor), in file order.
    cand: Box<[(f64, FastSucc<'t>)]>,
    total: f64,
}

impl<'t> FoldSucc<'t> {
    /// The successor of the module at `index`; None if the draw fails
    /// (the general path reports it).
    #[inline]
    fn pick(&self, rng: &mut Random, index: u64) -> Option<&FastSucc<'t>> {
        let n = self.cand.len();
        if n == 1 {
            return Some(&self.cand[0].1);
        }
        rng.set_module(index);
        let u = rng.uniform().ok()?;
        Some(&self.cand[by_weight(u, self.total, n, |i| self.cand[i].0)].1)
    }
}

/// A successor for the byte table. Short ones are padded to 16 bytes and
/// copied with one fixed-size copy, then the buffer is cut back.
#[derive(Clone, Copy)]
pub(crate) struct FastSucc<'t> {
    small: [u8; 16],
    len: usize,
    long: &'t [u8],
    modules: u64,
}

impl<'t> FastSucc<'t> {
    pub(crate) fn new(bytes: &'t [u8], modules: u64) -> Self {
        let mut small = [0; 16];
        if bytes.len() <= 16 {
            small[..bytes.len()].copy_from_slice(bytes);
        }
        FastSucc {
            small,
            len: bytes.len(),
            long: bytes,
            modules,
        }
    }
}

impl<'t> ByteTable<'t> {
    /// `brackets`: may `[` and `]` be copied here? Not when the step tracks
    /// branches (left contexts) or writes a bracket index.
    pub(crate) fn new(table: &'t Table, text: bool, brackets: bool) -> Self {
        let mut succ: [Option<FastSucc>; 128] =
            std::array::from_fn(|b| Some(FastSucc::new(&ASCII[b..b + 1], 1)));
        if !brackets {
            succ[OPEN as usize] = None;
            succ[CLOSE as usize] = None;
        }
        for (b, slot) in succ.iter_mut().enumerate() {
            *slot = match table.fixed(b as u32) {
                Some(None) => continue, // no rule: copied
                Some(Some(f)) if brackets || !f.brackets => {
                    Some(FastSucc::new(if text { f.text } else { f.bin }, f.modules))
                }
                _ => None,
            };
        }
        ByteTable {
            succ,
            brackets_general: false,
            brackets,
            text,
        }
    }

    /// The [`Folded`] keys (`folded`, by byte) whose successors are each
    /// one run of modules the table may copy (no brackets where they may
    /// not be copied here): [`ByteTable::run_folding`] draws for them at
    /// the module's index instead of stopping. The others still stop it.
    pub(crate) fn folds(&self, table: &'t Table, folded: &[Option<Folded>]) -> Folds<'t> {
        let mut folds = Folds::default();
        for (b, f) in folded.iter().enumerate() {
            let Some(f) = f else {
                continue;
            };
            if self.succ.get(b).is_none_or(|s| s.is_some()) {
                continue;
            }
            let cand: Option<Box<[(f64, FastSucc)]>> = f
                .cand
                .iter()
                .map(|&(pi, w)| match &*table.prods[pi as usize].succ {
                    [] => Some((w, FastSucc::new(&[], 0))),
                    [Item::Const(c)] if self.brackets || !c.has_brackets() => Some((
                        w,
                        FastSucc::new(if self.text { c.text() } else { c.bin() }, c.modules()),
                    )),
                    _ => None,
                })
                .collect();
            if let Some(cand) = cand {
                folds.0.resize_with(folds.0.len().max(b + 1), || None);
                folds.0[b] = Some(FoldSucc {
                    cand,
                    total: f.total,
                });
            }
        }
        folds
    }

    /// Send byte `b` down the general path (the cut `%`).
    pub(crate) fn general(&mut self, b: u8) {
        self.succ[b as usize] = None;
    }

    /// Send `[` and `]` down the general path.
    pub(crate) fn brackets_general(&mut self) {
        self.general(b'[');
        self.general(b']');
        self.brackets_general = true;
    }

    /// Rewrite the leading bytes of `input` it can handle; returns how many
    /// bytes and how many modules it used. Modules that left contexts consider are recorded in
    /// `left`; brackets open and close its levels and the output's bracket
    /// index (`open_len`: the bytes of the input's `[`), and follow
    /// the input's nesting `level`. Folded keys stop it
    /// ([`ByteTable::run_folding`] draws for them).
    #[inline]
    pub(crate) fn run(
        &self,
        input: &[u8],
        out: &mut Out,
        left: Option<&mut LeftContext>,
        al: &Alphabet,
        open_len: usize,
        level: &mut i64,
    ) -> Result<(usize, u64), Error> {
        self.run_with::<false>(input, out, left, al, open_len, level, None)
    }

    /// [`ByteTable::run`], drawing for the keys of `folds` from `rng` at
    /// their module's index (`index`: that of `input`'s first module). Out
    /// of line: the loop of passes without them stays as it was.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run_folding(
        &self,
        folds: &Folds,
        input: &[u8],
        out: &mut Out,
        left: Option<&mut LeftContext>,
        al: &Alphabet,
        open_len: usize,
        level: &mut i64,
        draws: (&mut Random, u64),
    ) -> Result<(usize, u64), Error> {
        self.run_with::<true>(input, out, left, al, open_len, level, Some((folds, draws)))
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn run_with<const FOLD: bool>(
        &self,
        input: &[u8],
        out: &mut Out,
        mut left: Option<&mut LeftContext>,
        al: &Alphabet,
        open_len: usize,
        level: &mut i64,
        draws: Option<(&Folds, (&mut Random, u64))>,
    ) -> Result<(usize, u64), Error> {
        let (folds, mut draws) = match draws {
            Some((f, d)) => (Some(f), Some(d)),
            None => (None, None),
        };
        let mut i = 0;
        // Modules = bytes, less the index bytes of each `[`.
        let mut opens = 0u64;
        let mut lv = *level;
        while i < input.len() {
            let b = input[i];
            if b >= 0x80 {
                break;
            }
            let f = if let Some(f) = &self.succ[b as usize] {
                f
            } else if let Some(fs) = folds
                .filter(|_| FOLD)
                .and_then(|f| f.0.get(b as usize))
                .and_then(Option::as_ref)
            {
                let Some((rng, index)) = &mut draws else {
                    break;
                };
                let at = *index + i as u64 - (open_len as u64 - 1) * opens;
                match fs.pick(rng, at) {
                    Some(f) => f,
                    None => break,
                }
            } else {
                if self.brackets_general {
                    break;
                }
                if b == b'[' {
                    let n = open_len;
                    if i + n > input.len() {
                        break;
                    }
                    out.modules += 1;
                    out.open();
                    lv += 1;
                    if let Some(left) = &mut left {
                        left.open();
                    }
                    i += n;
                    opens += 1;
                    continue;
                }
                if b == b']' {
                    out.modules += 1;
                    out.close()?;
                    lv -= 1;
                    if let Some(left) = &mut left {
                        left.close();
                    }
                    i += 1;
                    continue;
                }
                break;
            };
            let buf = &mut out.buf;
            if f.len == 1 {
                buf.push(f.small[0]);
            } else if f.len <= 16 {
                let at = buf.len();
                buf.extend_from_slice(&f.small);
                buf.truncate(at + f.len);
            } else {
                buf.extend_from_slice(f.long);
            }
            out.modules += f.modules;
            if let Some(left) = &mut left {
                if !al.ignored(b as u32) {
                    left.push(b as u32, &ASCII[b as usize..b as usize + 1], 0);
                }
            }
            i += 1;
            if out.buf.len() >= OUT_CHUNK {
                break;
            }
        }
        *level = lv;
        let skipped = (open_len as u64 - 1) * opens;
        Ok((i, i as u64 - skipped))
    }
}
