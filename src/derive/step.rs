//! The streaming rewriter. One derivation step reads a generation from a
//! temp file (binary format, see [`crate::rules::codec`]) and writes the next one
//! to another temp file, or, on the last pass, as text to the output.
//!
//! Memory does not grow with the string: the main reader and the look-ahead
//! reader each hold one buffer; left contexts keep the last k considered
//! modules per open branch; right contexts are matched by a second reader
//! over the same file, so skipping a branch of any size costs time, not
//! memory.

use super::bytetable::ByteTable;
use super::choose::{Chooser, Piece};
use super::context::{match_right, walk_right, Chains, LeftContext, RightCache, Walk};
use super::reader::PosReader;
use super::sink::Out;
use super::{Origin, Pass};
use crate::derive::random::Random;
use crate::diag::Error;
use crate::rules::codec;
use crate::rules::{Alphabet, KeyRules, Production, RPat, Table, CLOSE, OPEN};
use std::fs::File;
use std::io;

/// State shared by the passes of one derivation.
pub struct Deriver<'a> {
    pub alphabet: Alphabet,
    pub rng: Random,
    pub origin: Origin<'a>,
    slots: Vec<f64>,
    chooser: Chooser,
}

struct StepState<'f> {
    peek: Option<PosReader<'f>>,
    right: RightCache,
    max_right_simple: usize,
    left: Option<LeftContext>,
    /// A run of ignored modules: from any module end in `skip.0..=skip.1`
    /// only ignored modules (no bracket) lie before offset `skip.1`, so a
    /// right context may start there. Keeps right contexts over long
    /// ignored runs linear.
    skip: (u64, u64),
    /// Where walks over ignored modules and branches ended, per level.
    chains: Chains,
    /// Nesting level of the input at the current module.
    level: i64,
    depth: i64,
    /// Productions that last opened or closed more than they matched, to
    /// blame for unbalanced output.
    last_opener: Option<u32>,
    last_closer: Option<u32>,
}

impl StepState<'_> {
    /// Where the right context of the module ending at `end_off` starts:
    /// past the ignored modules that follow it. Each ignored run is read
    /// once per pass, however many of its modules ask.
    #[inline]
    fn right_start(&mut self, end_off: u64, al: &Alphabet) -> io::Result<u64> {
        if self.skip.0 <= end_off && end_off <= self.skip.1 {
            return Ok(self.skip.1);
        }
        let peek = self
            .peek
            .as_mut()
            .expect("a look-ahead reader for right contexts");
        let pos = match walk_right(peek, al, end_off, false)? {
            Walk::Module { at, .. } | Walk::Stop { at, .. } => at,
        };
        self.skip = (end_off, pos);
        Ok(pos)
    }

    /// Where the next considered module of the current level right of the
    /// module ending at `end_off` is (or the `]` or end that stops the
    /// search), passing over ignored modules and whole branches. Each such
    /// stretch is walked once per pass, however many of its modules ask.
    #[inline]
    fn level_start(&mut self, end_off: u64, al: &Alphabet) -> io::Result<u64> {
        let start = self.right_start(end_off, al)?;
        let level = self.level();
        let peek = self
            .peek
            .as_mut()
            .expect("a look-ahead reader for right contexts");
        self.chains.walk(peek, al, start, level)
    }

    /// The nesting level of the current module (the input is balanced, so
    /// it is never negative).
    fn level(&self) -> usize {
        usize::try_from(self.level).unwrap_or(0)
    }

    /// The next considered modules right of the module ending at `end_off`
    /// (read once per module).
    #[inline]
    fn right_of(&mut self, end_off: u64, al: &Alphabet) -> Result<&RightCache, Error> {
        let read_err = |e| Error::io("temporary file", "cannot read", e);
        let start = self.level_start(end_off, al).map_err(read_err)?;
        if self.right.at != start {
            let peek = self
                .peek
                .as_mut()
                .expect("a look-ahead reader for right contexts");
            self.right
                .fill(peek, al, start, self.max_right_simple)
                .map_err(read_err)?;
        }
        Ok(&self.right)
    }
}

impl<'a> Deriver<'a> {
    pub fn new(alphabet: Alphabet, rng: Random, origin: Origin<'a>) -> Self {
        Deriver {
            alphabet,
            rng,
            origin,
            slots: Vec::new(),
            chooser: Chooser::default(),
        }
    }

    /// One pass: rewrite the generation in `input` into `out`.
    pub fn pass(
        &mut self,
        table: &Table,
        input: &File,
        indexed: bool,
        out: &mut Out,
        pass: Pass,
    ) -> Result<(), Error> {
        let max_slots = table.prods.iter().map(|p| p.nslots).max().unwrap_or(0);
        self.slots.resize(max_slots.max(1), 0.0);
        let mut st = StepState {
            peek: table
                .has_right
                .then(|| PosReader::new(input, 1 << 16, indexed)),
            right: RightCache::new(),
            max_right_simple: table.max_right_simple,
            left: (table.max_left > 0).then(|| LeftContext::new(table, &self.alphabet)),
            depth: 0,
            skip: (u64::MAX, 0),
            chains: Chains::default(),
            level: 0,
            last_opener: None,
            last_closer: None,
        };
        let mut rd = PosReader::new(input, 1 << 20, indexed);
        // The index of the module being rewritten, for the random draws.
        let mut index: u64 = 0;
        let read_err = |e| Error::io("temporary file", "cannot read", e);
        // Bytes that need no decision take the table; with contexts, keys
        // that have context productions and brackets still go the long way.
        let fast = (!table.check_balance).then(|| {
            ByteTable::new(
                table,
                out.text,
                !indexed && st.left.is_none() && out.indexed.is_none(),
            )
        });
        loop {
            if let Some(fast) = &fast {
                let window = rd.window().map_err(read_err)?;
                let (used, modules) = fast.run(
                    window,
                    out,
                    st.left.as_mut(),
                    &self.alphabet,
                    indexed,
                    &mut st.level,
                )?;
                rd.advance(used);
                index += modules;
                out.maybe_flush()?;
                if used > 0 {
                    continue;
                }
            }
            let Some((key, s, e)) = rd.next_module(&self.alphabet).map_err(read_err)? else {
                break;
            };
            let end_off = rd.offset();
            let bytes = rd.bytes(s, e);
            self.rng.set_module(index);
            index += 1;
            let applied = match table.get(key) {
                Some(kr) => self.apply(table, kr, key, bytes, end_off, &mut st, out, pass)?,
                None => false,
            };
            if !applied {
                if table.check_balance {
                    if key == OPEN {
                        st.depth += 1;
                    } else if key == CLOSE {
                        st.depth -= 1;
                        if st.depth < 0 {
                            return Err(unbalanced(&self.origin, table, st.last_closer, pass));
                        }
                    }
                }
                out.raw(key, bytes, &self.alphabet)?;
            }
            if key == OPEN {
                st.level += 1;
            } else if key == CLOSE {
                st.level -= 1;
            }
            if let Some(left) = &mut st.left {
                if key == OPEN {
                    left.open();
                } else if key == CLOSE {
                    left.close();
                } else if !self.alphabet.ignored(key) {
                    left.push(key, bytes, self.alphabet.arity(key));
                }
            }
            out.maybe_flush()?;
        }
        if st.depth != 0 {
            let p = &table.prods[st.last_opener.unwrap_or(0) as usize];
            return Err(Error::at(
                self.origin.locate(p.span.0),
                format!(
                    "unbalanced brackets: {pass} leaves a `[` open, produced by this production"
                ),
            ));
        }
        Ok(())
    }

    /// Try the productions of `key`; emit the chosen successor.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn apply(
        &mut self,
        table: &Table,
        kr: &KeyRules,
        key: u32,
        bytes: &[u8],
        end_off: u64,
        st: &mut StepState,
        out: &mut Out,
        pass: Pass,
    ) -> Result<bool, Error> {
        let Deriver {
            alphabet: al,
            rng,
            origin,
            slots,
            chooser,
        } = self;
        // Predecessor parameters into the first slots.
        let arity = al.arity(key);
        if arity > 0 {
            codec::read_params(bytes, &mut slots[..arity]);
        }
        let chosen = chooser.choose(slots, table, kr, rng, origin, pass, |p, slots| {
            Ok(!surely_not(p, end_off, st, al)? && contexts_match(p, end_off, st, al, slots)?)
        })?;
        let Some(pi) = chosen else {
            return Ok(false);
        };
        let p = &table.prods[pi as usize];
        if table.check_balance {
            if st.depth + p.depth_min < 0 {
                return Err(unbalanced(origin, table, Some(pi), pass));
            }
            st.depth += p.depth_delta;
            if p.depth_delta > 0 {
                st.last_opener = Some(pi);
            }
            if p.depth_delta < 0 || p.depth_min < 0 {
                st.last_closer = Some(pi);
            }
        }
        chooser.successor(slots, p, rng, origin, pass, |piece| match piece {
            Piece::Const(c) => out.constant(c),
            Piece::Module(key, vals) => out.module(key, vals, al),
        })?;
        Ok(true)
    }
}

/// A step made a `]` without `[`: blame `culprit`.
fn unbalanced(origin: &Origin, table: &Table, culprit: Option<u32>, pass: Pass) -> Error {
    let p = &table.prods[culprit.unwrap_or(0) as usize];
    Error::at(
        origin.locate(p.span.0),
        format!("unbalanced brackets: {pass} produces a `]` without `[`, from this production"),
    )
}

/// A cheap first look: do the nearest context modules already differ?
/// (Fills the right-context cache on first use for this module.)
#[inline(always)]
fn surely_not(
    p: &Production,
    end_off: u64,
    st: &mut StepState,
    al: &Alphabet,
) -> Result<bool, Error> {
    if let (Some(pat), Some(left)) = (p.left.last(), &st.left) {
        if left.last_key() != Some(pat.key) {
            return Ok(true);
        }
    }
    if p.right_simple {
        let right = st.right_of(end_off, al)?;
        if let (Some(RPat::Module(pat)), first) = (p.right.first(), right.modules.keys.first()) {
            if first != Some(&pat.key) {
                return Ok(true);
            }
        }
    }
    Ok(false)
}

/// Do production `p`'s contexts match here? Binds their parameters.
#[inline]
fn contexts_match(
    p: &Production,
    end_off: u64,
    st: &mut StepState,
    al: &Alphabet,
    slots: &mut [f64],
) -> Result<bool, Error> {
    if !p.left.is_empty() && !st.left.as_ref().unwrap().matches(&p.left, al, slots) {
        return Ok(false);
    }
    if p.right_simple {
        let right = st.right_of(end_off, al)?;
        if !right.matches(&p.right, al, slots) {
            return Ok(false);
        }
    } else if !p.right.is_empty() {
        // Matching from past the ignored run is the same: every pattern
        // element passes over ignored modules first.
        let read_err = |e| Error::io("temporary file", "cannot read", e);
        let start = st.right_start(end_off, al).map_err(read_err)?;
        let level = st.level();
        let peek = st.peek.as_mut().unwrap();
        if !match_right(peek, al, start, &p.right, slots, &mut st.chains, level)
            .map_err(read_err)?
        {
            return Ok(false);
        }
    }
    Ok(true)
}
