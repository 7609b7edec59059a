//! The byte table: ASCII symbols whose step needs no decision are
//! rewritten by a 128-entry table, in blocks; keys whose decision needs
//! only the draw or their neighbours' keys are decided there too
//! ([`Choices`]).

use super::choose::{draw_weighted, Folded, Neighbours};
use super::context::LeftContext;
use super::random::Random;
use super::sink::Out;
use crate::diag::Error;
use crate::rules::{codec, Alphabet, ConstRun, Item, Table, CLOSE, OPEN};

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

/// The keys a [`ByteTable`] decides itself ([`ByteTable::choices`]),
/// looked at only where its `succ` has none: folded keys, by the draw at
/// the module's index, and keys chosen by their neighbours, by the keys of
/// the nearest considered modules left and right. Apart from the table, so
/// a pass without them has the table's loop as it was.
#[derive(Default)]
pub(crate) struct Choices<'t> {
    folded: Vec<Option<FoldSucc<'t>>>,
    /// By byte: what the step writes for each (left class, right class)
    /// (`lclass * rn + rclass`).
    by_neighbours: Vec<Option<Box<[ByClass<'t>]>>>,
    /// The class of a left or right neighbour's byte: 0 for one no
    /// context asks for (and for none, or a module of several bytes).
    lclass: Vec<u8>,
    rclass: Vec<u8>,
    /// Right classes, 0 included.
    rn: usize,
}

/// What the table writes for a neighbour-decided key in one (left class,
/// right class).
enum ByClass<'t> {
    /// A copy, as the table's own successors (also the key itself, or
    /// nothing).
    Copy(FastSucc<'t>),
    /// A successor with brackets into an indexed output: through
    /// [`Out::constant`], which indexes them.
    Sink(&'t ConstRun),
}

/// Most (left, right) entries of the neighbour tables in all: past it,
/// further keys take the general path.
const NEIGHBOUR_ENTRIES: usize = 1 << 16;

impl Choices<'_> {
    /// Does the table decide key `b` itself?
    pub(crate) fn has(&self, b: u8) -> bool {
        let b = usize::from(b);
        matches!(self.folded.get(b), Some(Some(_)))
            || matches!(self.by_neighbours.get(b), Some(Some(_)))
    }

    /// Does it decide any key by its neighbours?
    pub(crate) fn by_neighbours(&self) -> bool {
        !self.by_neighbours.is_empty()
    }

    /// The right class of the module starting at `input[j]`'s nearest
    /// considered module to the right, passing over ignored modules and
    /// whole branches (their `[` holds the distance past their `]`:
    /// `open_len` > 1) as `super::context::walk_right` does; None if
    /// `input` does not tell (it ends first, a module of several bytes,
    /// a branch without an index).
    #[inline]
    fn right_class(
        &self,
        input: &[u8],
        mut j: usize,
        open_len: usize,
        al: &Alphabet,
    ) -> Option<usize> {
        loop {
            let b = *input.get(j)?;
            if b >= 0x80 {
                return None;
            }
            if b == b'[' {
                if open_len == 1 {
                    return None;
                }
                let dist = codec::branch_dist(input.get(j + 1..j + 1 + codec::ENDS_BYTES)?)?;
                j = j.checked_add(usize::try_from(dist).ok()?)?;
                continue;
            }
            if b == b']' {
                return Some(0);
            }
            if al.ignored(u32::from(b)) {
                j += 1;
                continue;
            }
            return Some(usize::from(self.rclass[usize::from(b)]));
        }
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
        rng.set_module(index);
        let i = draw_weighted(rng, self.total, self.cand.len(), |i| self.cand[i].0).ok()?;
        Some(&self.cand[i].1)
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

    /// The keys the table decides itself ([`ByteTable::run_choosing`]),
    /// from those of `folded` and `neighbours` (by byte):
    /// - [`Folded`] keys whose successors are each one run of modules the
    ///   table may copy (no brackets where they may not be copied here):
    ///   it draws for them at the module's index;
    /// - [`Neighbours`] keys (not ignored): it reads their neighbours'
    ///   keys, the left one from the left context (`left`: kept), the
    ///   right one from its input where that tells.
    ///
    /// The others still stop it. `indexed`: does the output take a bracket
    /// index?
    pub(crate) fn choices(
        &self,
        table: &'t Table,
        (folded, neighbours): (&[Option<Folded>], &[Option<Neighbours<'t>>]),
        al: &Alphabet,
        (left, indexed): (bool, bool),
    ) -> Choices<'t> {
        let mut ch = Choices::default();
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
                ch.folded.resize_with(ch.folded.len().max(b + 1), || None);
                ch.folded[b] = Some(FoldSucc {
                    cand,
                    total: f.total,
                });
            }
        }
        // Classes: each key a context asks for, numbered from 1 in the
        // order met; `lkeys`/`rkeys` hold them by class.
        let (mut lkeys, mut rkeys) = (vec![None], vec![None]);
        let (mut lclass, mut rclass) = (vec![0u8; 128], vec![0u8; 128]);
        let keys: Vec<(usize, &Neighbours)> = neighbours
            .iter()
            .enumerate()
            .filter_map(|(b, n)| Some((b, n.as_ref()?)))
            .filter(|&(b, n)| {
                self.succ.get(b).is_some_and(|s| s.is_none())
                    && !al.ignored(b as u32)
                    && (left || n.keys().all(|(l, _)| l.is_none()))
            })
            .collect();
        for (_, n) in &keys {
            for (l, r) in n.keys() {
                for (k, class, keys) in [(l, &mut lclass, &mut lkeys), (r, &mut rclass, &mut rkeys)]
                {
                    if let Some(k) = k {
                        if class[k as usize] == 0 {
                            class[k as usize] = keys.len() as u8;
                            keys.push(Some(k));
                        }
                    }
                }
            }
        }
        let entries = lkeys.len() * rkeys.len();
        let mut total = 0;
        for (b, n) in keys {
            total += entries;
            if total > NEIGHBOUR_ENTRIES {
                break;
            }
            let by = lkeys
                .iter()
                .flat_map(|&l| rkeys.iter().map(move |&r| n.pick(l, r)))
                .map(|p| match p {
                    None => ByClass::Copy(FastSucc::new(&ASCII[b..b + 1], 1)),
                    Some(None) => ByClass::Copy(FastSucc::new(&[], 0)),
                    Some(Some(c)) if indexed && c.has_brackets() => ByClass::Sink(c),
                    Some(Some(c)) => ByClass::Copy(FastSucc::new(
                        if self.text { c.text() } else { c.bin() },
                        c.modules(),
                    )),
                })
                .collect();
            ch.by_neighbours
                .resize_with(ch.by_neighbours.len().max(b + 1), || None);
            ch.by_neighbours[b] = Some(by);
        }
        if !ch.by_neighbours.is_empty() {
            ch.lclass = lclass;
            ch.rclass = rclass;
            ch.rn = rkeys.len();
        }
        ch
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
    /// the input's nesting `level`. The keys of [`Choices`] stop it
    /// ([`ByteTable::run_choosing`] decides them).
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

    /// [`ByteTable::run`], deciding the keys of `choices` too: folded ones
    /// draw from `rng` at their module's index (`index`: that of `input`'s
    /// first module). Out of line: the loop of passes without them stays
    /// as it was.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run_choosing(
        &self,
        choices: &Choices,
        input: &[u8],
        out: &mut Out,
        left: Option<&mut LeftContext>,
        al: &Alphabet,
        open_len: usize,
        level: &mut i64,
        draws: (&mut Random, u64),
    ) -> Result<(usize, u64), Error> {
        self.run_with::<true>(
            input,
            out,
            left,
            al,
            open_len,
            level,
            Some((choices, draws)),
        )
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
        draws: Option<(&Choices, (&mut Random, u64))>,
    ) -> Result<(usize, u64), Error> {
        // Stop where the output takes its buffer (a worker's block is
        // smaller than a file's): it must not grow past it.
        let limit = out.chunk;
        let (choices, mut draws) = match draws {
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
            } else if let Some(fs) = choices
                .filter(|_| FOLD)
                .and_then(|c| c.folded.get(b as usize))
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
            } else if let Some((ch, by)) = choices.filter(|_| FOLD).and_then(|c| {
                let by = c.by_neighbours.get(b as usize)?.as_ref()?;
                Some((c, by))
            }) {
                // Decided by its neighbours: the right one from the input,
                // the left one from the left context.
                // (No production asks for a right neighbour: no need to
                // read one, where an unindexed branch would stop the
                // table.)
                let r = if ch.rn == 1 {
                    0
                } else {
                    match ch.right_class(input, i + 1, open_len, al) {
                        Some(r) => r,
                        None => break,
                    }
                };
                let l = match left.as_deref().and_then(LeftContext::last_key) {
                    Some(k) if k < 128 => usize::from(ch.lclass[k as usize]),
                    _ => 0,
                };
                let at = l * ch.rn + r;
                match &by[at] {
                    ByClass::Copy(f) => f,
                    ByClass::Sink(c) => {
                        out.constant(c)?;
                        if let Some(left) = &mut left {
                            left.push(b as u32, &ASCII[b as usize..b as usize + 1], 0);
                        }
                        i += 1;
                        if out.buf.len() >= limit {
                            break;
                        }
                        continue;
                    }
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
                    if out.buf.len() >= limit {
                        break;
                    }
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
                    if out.buf.len() >= limit {
                        break;
                    }
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
            if out.buf.len() >= limit {
                break;
            }
        }
        *level = lv;
        let skipped = (open_len as u64 - 1) * opens;
        Ok((i, i as u64 - skipped))
    }
}
