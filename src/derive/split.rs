//! Cutting a pass of the step engine into chunks that threads derive
//! concurrently (`-j N`, issue 15), contexts included.
//!
//! A chunk is a run of whole modules of the generation being read. What a
//! module's rewriting reads besides the module and its index is:
//!
//! - its left context: the last k considered modules on the path to it,
//!   which the engine keeps in a [`LeftContext`] as it reads. The scan
//!   here ([`Scan`]) follows every module of the generation with that same
//!   [`LeftContext::follow`] (no second implementation) and hands each
//!   chunk a clone of it as it stands at the chunk's first module, with
//!   the nesting level there ([`ChunkStart`]): the worker starts its pass
//!   in the state one thread would have reached there. The clone holds at
//!   most k modules per open branch, so it costs O(k x depth), not the
//!   string;
//! - its right context: read ahead by the worker's own look-ahead reader
//!   (pread on the same file, its bracket index shared read-only), which
//!   is not limited to the chunk;
//! - its random draws: placed by module index, which the scan counts.
//!
//! So a chunk's output is a function of the generation and the chunk's
//! bounds, whichever thread derives it and whenever. Passes that track
//! bracket balance (`check_balance`: the output's depth at a chunk's start
//! depends on what earlier chunks wrote) stay on one thread; so do the
//! structural and cpfg features (`par::step_threads`).

use super::context::LeftContext;
use super::reader::PosReader;
use crate::rules::{Alphabet, Table, CLOSE, OPEN};
use std::fs::File;
use std::io;

/// The engine's state at a chunk's first module, as one thread would have
/// it there.
#[derive(Clone)]
pub(crate) struct ChunkStart {
    /// The left context (when the pass has left contexts).
    pub(crate) left: Option<LeftContext>,
    /// The nesting level of the input.
    pub(crate) level: i64,
}

/// One chunk: the generation's bytes `start..end`, the index of its first
/// module, and the state there.
pub(crate) struct Chunk {
    pub(crate) start: u64,
    pub(crate) end: u64,
    pub(crate) first: u64,
    pub(crate) at: ChunkStart,
}

/// The left context a pass of `table` (with decomposition `decomp`) keeps,
/// if any: the engine's and the scan's are made here, so they agree.
pub(crate) fn left_for(
    table: &Table,
    decomp: Option<&Table>,
    al: &Alphabet,
) -> Option<LeftContext> {
    (table.max_left > 0 || decomp.is_some_and(|d| d.max_left > 0)).then(|| {
        let mut ts = vec![table];
        ts.extend(decomp);
        LeftContext::new_for(&ts, al)
    })
}

/// The producer's scan: reads the generation once, module by module,
/// cutting it at the first module boundary past every `size` bytes.
pub(crate) struct Scan<'f> {
    rd: PosReader<'f>,
    left: Option<LeftContext>,
    level: i64,
    /// Where the next chunk starts, and its first module's index.
    start: u64,
    index: u64,
    size: u64,
    done: bool,
}

impl<'f> Scan<'f> {
    /// A scan of the generation in `src` (`indexed`: with a bracket index,
    /// `counts`: with module counts) for a pass of `table`.
    pub(crate) fn new(
        src: &'f File,
        (indexed, counts): (bool, bool),
        table: &Table,
        al: &Alphabet,
        size: u64,
    ) -> Self {
        Scan {
            rd: PosReader::new(src, 256 << 10, indexed).with_counts(counts),
            left: left_for(table, None, al),
            level: 0,
            start: 0,
            index: 0,
            size: size.max(1),
            done: false,
        }
    }

    /// The next chunk, None after the last.
    pub(crate) fn next_chunk(&mut self, al: &Alphabet) -> io::Result<Option<Chunk>> {
        if self.done {
            return Ok(None);
        }
        let at = ChunkStart {
            left: self.left.clone(),
            level: self.level,
        };
        let (start, first) = (self.start, self.index);
        loop {
            let Some((key, s, e)) = self.rd.next_module(al)? else {
                self.done = true;
                let end = self.rd.offset();
                return Ok((end > start).then_some(Chunk {
                    start,
                    end,
                    first,
                    at,
                }));
            };
            self.index += 1;
            if key == OPEN {
                self.level += 1;
            } else if key == CLOSE {
                self.level -= 1;
            }
            if let Some(left) = &mut self.left {
                left.follow(key, self.rd.bytes(s, e), al);
            }
            let end = self.rd.offset();
            if end - start >= self.size {
                self.start = end;
                return Ok(Some(Chunk {
                    start,
                    end,
                    first,
                    at,
                }));
            }
        }
    }
}

/// Append `block`, whole binary modules written without a bracket index
/// (a chunk's output), to `out`, which writes one: runs without brackets
/// are copied as they are, each bracket goes through `out` (which leaves
/// room for a `[`'s index and fills it in at its `]`, whichever chunks
/// they came from). Counts the modules.
pub(crate) fn put_indexed(
    out: &mut super::Out,
    block: &[u8],
    al: &Alphabet,
) -> Result<(), crate::diag::Error> {
    let (mut i, mut run, mut modules) = (0, 0, 0u64);
    while i < block.len() {
        let b = block[i];
        if b == b'[' || b == b']' {
            out.extend(&block[run..i], modules);
            out.raw(u32::from(b), &block[i..i + 1], al)?;
            i += 1;
            (run, modules) = (i, 0);
            continue;
        }
        i += if b < 0x80 {
            1
        } else {
            let (key, kl) = crate::rules::codec::get_key(&block[i..]);
            kl + 8 * al.arity(key)
        };
        modules += 1;
    }
    out.extend(&block[run..], modules);
    Ok(())
}
