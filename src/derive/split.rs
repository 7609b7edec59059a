//! Cutting a pass of the step engine into chunks that threads derive
//! concurrently (`-j N`, issue 15), contexts included.
//!
//! A chunk is a run of whole modules of the generation being read. What a
//! module's rewriting reads besides the module and its index is:
//!
//! - its left context: the last k considered modules on the path to it,
//!   which the engine keeps in a [`LeftContext`] as it reads. The scan
//!   here ([`Scan`]) follows the modules of the generation with that same
//!   [`LeftContext::follow`] (no second implementation) and hands each
//!   chunk a clone of it as it stands at the chunk's first module, with
//!   the nesting level there ([`ChunkStart`]): the worker starts its pass
//!   in the state one thread would have reached there. The clone holds at
//!   most k modules per open branch, so it costs O(k x depth), not the
//!   string. A whole branch leaves both as they were, so where the
//!   generation has a bracket index and the pass draws nothing the scan
//!   jumps over the branches that end before the next cut;
//! - its right context: read ahead by the worker's own look-ahead reader
//!   (pread on the same file, its bracket index shared read-only), which
//!   is not limited to the chunk;
//! - its random draws: placed by module index, which the scan counts
//!   (where the pass can draw: [`Chunk::exact`]).
//!
//! So a chunk's output is a function of the generation and the chunk's
//! bounds, whichever thread derives it and whenever. Passes that track
//! bracket balance judge each chunk's balance on the writer ([`Balance`],
//! [`BalanceCheck`]); the structural and cpfg features stay on one thread
//! (`par::step_threads`).

use super::bytetable::ASCII;
use super::context::LeftContext;
use super::reader::PosReader;
use crate::rules::{codec, Alphabet, Table, CLOSE, OPEN};
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
    /// `first` is the module's index (else the pass draws nothing and the
    /// scan jumped over branches without counting their modules).
    pub(crate) exact: bool,
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

/// A chunk's start state of this many bytes or more makes the chunk at
/// least as long ([`Scan::next_chunk`]).
const LARGE_STATE: u64 = 64 << 10;

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
    /// Per ASCII byte: the one-byte module is recorded by the left
    /// context (considered: not ignored, not a bracket).
    kept: [bool; 128],
    /// Jump over whole branches before a cut by the bracket index: the
    /// generation has one and the pass makes no random draw, so the
    /// chunks' module indices are not needed (they are not counted
    /// inside the branches jumped over; [`Chunk::exact`]).
    skip: bool,
    /// Cut without reading ([`Scan::one_byte`]): the generation's length.
    flat: Option<u64>,
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
        let left = left_for(table, None, al);
        let kept = std::array::from_fn(|b| {
            left.is_some() && b != OPEN as usize && b != CLOSE as usize && !al.ignored(b as u32)
        });
        let skip = indexed && !table.may_draw();
        // Jumping over whole branches, the scan reads only the bytes on
        // the way to each cut when its window is small (a jump past the
        // window reads nothing of the branch): context_signal's producer
        // 25-30 ms a pass with 256 KiB, 15-16 ms with 16 KiB; a string
        // without long branches costs a read call per 16 KiB.
        let window = if skip { 16 << 10 } else { 256 << 10 };
        Scan {
            skip,
            rd: PosReader::new(src, window, indexed).with_counts(counts),
            left,
            kept,
            level: 0,
            start: 0,
            index: 0,
            size: size.max(1),
            done: false,
            flat: None,
        }
    }

    /// A generation the pass gives back behind the chunks it completes
    /// ([`super::reclaim`]): the scan, ahead of them, never reads there.
    pub(crate) fn giving_back(mut self, floor: Option<&'f super::reclaim::Reclaim<'f>>) -> Self {
        self.rd.set_floor(floor, false);
        self
    }

    /// The generation is `len` bytes of one-byte modules (as many modules
    /// as bytes, which the pass that wrote it counted): without a left
    /// context to follow or a bracket index, the scan cuts it every `size`
    /// bytes without reading it. Each byte is a module boundary and a
    /// module's index is its offset. The level each chunk starts at is
    /// left at 0: only right contexts read it (by level), and a pass with
    /// them has an indexed input.
    pub(crate) fn one_byte(mut self, len: Option<u64>) -> Self {
        if self.left.is_none() && self.rd.open_len() == 1 {
            self.flat = len;
        }
        self
    }

    /// [`Scan::next_chunk`] for [`Scan::one_byte`].
    fn next_flat(&mut self, len: u64) -> Option<Chunk> {
        let start = self.start;
        if start >= len {
            self.done = true;
            return None;
        }
        let end = len.min(start.saturating_add(self.size));
        self.start = end;
        self.done = end == len;
        Some(Chunk {
            start,
            end,
            first: start,
            exact: true,
            at: ChunkStart {
                left: None,
                level: 0,
            },
        })
    }

    /// The next chunk, None after the last.
    pub(crate) fn next_chunk(&mut self, al: &Alphabet) -> io::Result<Option<Chunk>> {
        if self.done {
            return Ok(None);
        }
        if let Some(len) = self.flat {
            return Ok(self.next_flat(len));
        }
        let state = self.left.as_ref().map_or(0, LeftContext::copy_bytes) as u64;
        let at = ChunkStart {
            left: self.left.clone(),
            level: self.level,
        };
        let (start, first, exact) = (self.start, self.index, !self.skip);
        let chunk = |end| Chunk {
            start,
            end,
            first,
            exact,
            at,
        };
        // Cut once the chunk reaches this offset: past `size` bytes, and
        // past as many bytes as a large start state holds, so that copying
        // the state of a deeply nested string stays a small part of a
        // chunk's work (the worker spends some ns per byte, the copy a
        // fraction). (Small states do not count: tests cut chunks of a few
        // bytes.)
        let least = if state >= LARGE_STATE { state } else { 0 };
        let stop = start + self.size.max(least);
        let open_len = self.rd.open_len();
        loop {
            // One-byte symbols and `[`s in a tight loop (the bytes of
            // [`super::bytetable`]'s fast path), the rest module by module.
            let base = self.rd.offset();
            let Scan {
                rd,
                left,
                level,
                kept,
                skip,
                ..
            } = self;
            let w = rd.window()?;
            let (mut i, mut n) = (0, 0);
            // A branch jumped over that ends past the window.
            let mut jump = None;
            if left.is_none() && open_len == 1 {
                // Nothing to follow but the count and the level: up to
                // the cut, every ASCII byte is a module, `[` and `]`
                // included.
                let cut = usize::try_from(stop - base).map_or(w.len(), |c| c.min(w.len()));
                let (len, depth) = plain_counts(&w[..cut]);
                *level += depth;
                (i, n) = (len, len as u64);
            }
            while i < w.len() && base + (i as u64) < stop {
                let b = w[i];
                if b >= 0x80 {
                    break;
                }
                if b == b'[' {
                    if i + open_len > w.len() {
                        break;
                    }
                    if *skip {
                        // A whole branch before the cut leaves the left
                        // context and the level as they were: jump to its
                        // end (an unclosed `[`'s index is 0: not taken).
                        let dist = codec::get_word(&w[i + 1..]);
                        let end = base + i as u64 + dist;
                        if dist > 0 && end <= stop {
                            match usize::try_from(end - base) {
                                Ok(e) if e <= w.len() => {
                                    i = e;
                                    if end == stop {
                                        break;
                                    }
                                    continue;
                                }
                                _ => {
                                    jump = Some(end);
                                    break;
                                }
                            }
                        }
                    }
                    *level += 1;
                    if let Some(left) = left {
                        left.open();
                    }
                    i += open_len;
                } else {
                    // (What `LeftContext::follow` does, decided per byte
                    // once in `kept`.)
                    if kept[b as usize] {
                        if let Some(left) = left {
                            let b = b as usize;
                            left.push(b as u32, &ASCII[b..b + 1], 0);
                        }
                    } else if b == b']' {
                        *level -= 1;
                        if let Some(left) = left {
                            left.close();
                        }
                    }
                    i += 1;
                }
                n += 1;
                if base + i as u64 >= stop {
                    break;
                }
            }
            self.rd.advance(i);
            if let Some(to) = jump {
                self.rd.seek(to);
            }
            self.index += n;
            let end = self.rd.offset();
            if i > 0 || jump.is_some() {
                if end >= stop {
                    self.start = end;
                    return Ok(Some(chunk(end)));
                }
                continue;
            }
            let Some((key, s, e)) = self.rd.next_module(al)? else {
                self.done = true;
                let end = self.rd.offset();
                return Ok((end > start).then(|| chunk(end)));
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
            if end >= stop {
                self.start = end;
                return Ok(Some(chunk(end)));
            }
        }
    }
}

/// The length of `w`'s run of ASCII bytes from its start, and the
/// `[`s less the `]`s in it. Blocks of 32 bytes are counted with compares
/// and byte sums the compiler makes vector code of (an 8-byte word with
/// `count_ones` cost a multiply per word: no `popcnt` in the baseline
/// target); the rest, and a block with a byte of 0x80 or more, byte by
/// byte.
fn plain_counts(w: &[u8]) -> (usize, i64) {
    const BLOCK: usize = 32;
    let (mut i, mut depth) = (0, 0i64);
    while let Some(block) = w.get(i..i + BLOCK) {
        // (In one byte: the sum of 32 bytes of -1, 0 or 1 fits.)
        let (mut high, mut delta) = (0u8, 0i8);
        for &b in block {
            high |= b;
            delta = delta.wrapping_add(i8::from(b == b'[') - i8::from(b == b']'));
        }
        if high >= 0x80 {
            break;
        }
        depth += i64::from(delta);
        i += BLOCK;
    }
    while let Some(&b) = w.get(i) {
        if b >= 0x80 {
            break;
        }
        depth += i64::from(b == b'[') - i64::from(b == b']');
        i += 1;
    }
    (i, depth)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::derive::{Limits, Out};
    use crate::lang::parse::parse_header;
    use crate::rules::{compile, System};
    use std::io::{Read, Seek};

    fn system(src: &str) -> System {
        compile(&parse_header(src).unwrap()).unwrap()
    }

    /// `modules` (symbol, parameters) written through one [`Out`], binary,
    /// with a bracket index if `indexed`; and the file's bytes.
    fn write(al: &mut Alphabet, modules: &[(char, &[f64])], indexed: bool) -> (File, Vec<u8>) {
        let mut f = tempfile::tempfile().unwrap();
        let index = f.try_clone().unwrap();
        {
            let mut out = Out::new(&mut f, "gen", false, Limits::default());
            if indexed {
                out = out.with_index(index);
            }
            for &(sym, params) in modules {
                let key = al.intern(sym, params.len()).unwrap();
                out.module(key, params, al).unwrap();
            }
            out.finish().unwrap();
        }
        let mut bytes = Vec::new();
        f.rewind().unwrap();
        f.read_to_end(&mut bytes).unwrap();
        (f, bytes)
    }

    // A(1) B(2) [ C(3) + [ D(4) ] E(5) ] F(6), `+` ignored.
    const STRING: &[(char, &[f64])] = &[
        ('A', &[1.0]),
        ('B', &[2.0]),
        ('[', &[]),
        ('C', &[3.0]),
        ('+', &[]),
        ('[', &[]),
        ('D', &[4.0]),
        (']', &[]),
        ('E', &[5.0]),
        (']', &[]),
        ('F', &[6.0]),
    ];

    /// A pass that draws nothing jumps over the whole branches before a
    /// cut by the bracket index: every chunk starts where it would have
    /// and from the same state (left context, level), and only the module
    /// index, which nothing reads then, is left uncounted.
    #[test]
    fn the_scan_jumps_over_whole_branches_to_the_same_state() {
        let src = "ignore: +\nproductions:\nA(a) B(b) < C(c) -> X\nF(f) -> F\n";
        let mut s = system(src);
        assert!(!s.productions.may_draw());
        let mut string = STRING.to_vec();
        string.extend_from_within(..);
        string.extend_from_within(..);
        let (f, bytes) = write(&mut s.alphabet, &string, true);
        let al = &s.alphabet;
        let mut jumped = false;
        for size in 1..=bytes.len() as u64 + 1 {
            let chunks = |skip: bool| {
                let mut scan = Scan::new(&f, (true, false), &s.productions, al, size);
                assert!(scan.skip);
                scan.skip = skip;
                let mut v = Vec::new();
                while let Some(ch) = scan.next_chunk(al).unwrap() {
                    assert_eq!(ch.exact, !skip);
                    let left = ch.at.left.expect("left contexts are kept");
                    v.push(((ch.start, ch.end, left.path(), ch.at.level), ch.first));
                }
                v
            };
            let (with, without) = (chunks(true), chunks(false));
            let state =
                |v: &[((u64, u64, _, i64), u64)]| v.iter().map(|c| c.0.clone()).collect::<Vec<_>>();
            assert_eq!(state(&with), state(&without), "size {size}");
            jumped |= with.iter().zip(&without).any(|(a, b)| a.1 < b.1);
        }
        assert!(jumped, "some branch was jumped over");
    }

    /// The same with branches longer than the scan's window, which it
    /// jumps over without reading them (`jump`, then a read from past the
    /// branch): the same chunks and states as with a window that holds the
    /// whole string, and as without jumping.
    #[test]
    fn the_scan_jumps_over_branches_longer_than_its_window() {
        let src = "ignore: +\nproductions:\nA(a) B(b) < C(c) -> X\nF(f) -> F\n";
        let mut s = system(src);
        let mut string: Vec<(char, &[f64])> = STRING.to_vec();
        let long = |n: usize| {
            let mut b = vec![('[', &[][..])];
            b.extend(STRING.iter().copied().cycle().take(n * STRING.len()));
            b.push((']', &[]));
            b
        };
        string.extend(long(300));
        string.extend_from_slice(STRING);
        string.push(('[', &[]));
        string.extend(long(400));
        string.extend(long(2));
        string.push((']', &[]));
        string.extend_from_slice(STRING);
        let (f, bytes) = write(&mut s.alphabet, &string, true);
        let al = &s.alphabet;
        let window = 2 * crate::rules::codec::MAX_MODULE_BYTES;
        assert!(bytes.len() > 4 * window, "{} bytes", bytes.len());
        for size in (1..=bytes.len() as u64 + 1).step_by(97) {
            let chunks = |small: bool, skip: bool| {
                let mut scan = Scan::new(&f, (true, false), &s.productions, al, size);
                scan.skip = skip;
                let len = if small { window } else { bytes.len() };
                scan.rd = PosReader::new(&f, len, true);
                let mut v = Vec::new();
                while let Some(ch) = scan.next_chunk(al).unwrap() {
                    let left = ch.at.left.expect("left contexts are kept");
                    v.push((ch.start, ch.end, left.path(), ch.at.level));
                }
                v
            };
            let want = chunks(false, false);
            assert_eq!(chunks(true, true), want, "size {size}, small window");
            assert_eq!(chunks(false, true), want, "size {size}");
        }
    }

    /// Without left contexts or an index, the scan counts modules and
    /// nesting eight bytes at a time: each chunk's first module index and
    /// level are those of a walk module by module, wherever it cuts.
    #[test]
    fn a_scan_without_contexts_counts_modules_and_levels() {
        let mut s = system("productions:\nA(a) -> B(a)\n");
        let mut string: Vec<(char, &[f64])> = Vec::new();
        for c in "AB[[C]D[E]]]FG[HIJKLMNOP[Q]RS]TU".chars() {
            string.push((c, &[]));
        }
        string.insert(9, ('A', &[1.0]));
        string.insert(20, ('A', &[93.0]));
        let (f, bytes) = write(&mut s.alphabet, &string, false);
        // Module starts, indices and the level at each.
        let (mut at, mut level, mut walk) = (0, 0i64, Vec::new());
        for (c, p) in &string {
            walk.push((at as u64, level));
            let (_, kl) = crate::rules::codec::get_key(&bytes[at..]);
            at += if p.is_empty() { 1 } else { kl + 8 * p.len() };
            level += i64::from(*c == '[') - i64::from(*c == ']');
        }
        assert_eq!(at, bytes.len());
        let al = &s.alphabet;
        for size in 1..=bytes.len() as u64 + 1 {
            let mut scan = Scan::new(&f, (false, false), &s.productions, al, size);
            while let Some(ch) = scan.next_chunk(al).unwrap() {
                assert!(ch.exact && ch.at.left.is_none());
                let (start, lvl) = walk[ch.first as usize];
                assert_eq!((ch.start, ch.at.level), (start, lvl), "size {size}");
            }
        }
        assert_eq!(plain_counts(b"[[a]]]]xyz[[["), (13, 1));
        assert_eq!(plain_counts(b"[]]]]]]]]]\x80[["), (10, -8));
    }

    /// A generation of one-byte modules is cut without being read
    /// ([`Scan::one_byte`]) where the reading scan cuts it, with the same
    /// first module indices; not where it has a left context to follow or
    /// a bracket index.
    #[test]
    fn a_one_byte_generation_is_cut_where_the_reading_scan_cuts_it() {
        let s = system("productions:\nA -> B\n");
        let mut al = s.alphabet.clone();
        let string: Vec<(char, &[f64])> = "AB[[C]D[E]]]FG[HIJK]"
            .chars()
            .map(|c| (c, &[][..]))
            .collect();
        let (f, bytes) = write(&mut al, &string, false);
        let len = bytes.len() as u64;
        assert_eq!(len, string.len() as u64);
        for size in 1..=len + 1 {
            let cuts = |one_byte: Option<u64>| {
                let mut scan =
                    Scan::new(&f, (false, false), &s.productions, &al, size).one_byte(one_byte);
                let mut v = Vec::new();
                while let Some(ch) = scan.next_chunk(&al).unwrap() {
                    assert!(ch.exact && ch.at.left.is_none());
                    v.push((ch.start, ch.end, ch.first));
                }
                (v, scan.flat.is_some())
            };
            let (read, _) = cuts(None);
            let (flat, cut_unread) = cuts(Some(len));
            assert!(cut_unread);
            assert_eq!(flat, read, "size {size}");
            assert_eq!(flat.last().map(|c| c.1), Some(len));
        }
        // A left context to follow, or an index: the scan reads.
        let ctx = system("productions:\nA < B -> C\n");
        let scan = Scan::new(&f, (false, false), &ctx.productions, &al, 4).one_byte(Some(len));
        assert!(scan.flat.is_none());
        let scan = Scan::new(&f, (true, false), &s.productions, &al, 4).one_byte(Some(len));
        assert!(scan.flat.is_none());
    }

    /// The block count agrees with a byte-by-byte one on strings longer
    /// than a block, with the stop (a byte of 0x80 or more) before,
    /// inside and after blocks, and deep levels either way.
    #[test]
    fn plain_counts_agrees_with_counting_byte_by_byte() {
        let by_byte = |w: &[u8]| {
            let len = w.iter().position(|&b| b >= 0x80).unwrap_or(w.len());
            let depth = w[..len]
                .iter()
                .map(|&b| i64::from(b == b'[') - i64::from(b == b']'))
                .sum::<i64>();
            (len, depth)
        };
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for round in 0..4000 {
            let len = (next() % 300) as usize;
            let w: Vec<u8> = (0..len)
                .map(|_| match next() % 16 {
                    0..=5 => b'[',
                    6..=9 if round % 2 == 0 => b']',
                    10 if round % 3 == 0 => 0x80 | (next() % 128) as u8,
                    _ => b"AF+-01%"[(next() % 7) as usize],
                })
                .collect();
            assert_eq!(plain_counts(&w), by_byte(&w), "{w:?}");
        }
        let long = [b'['; 1000];
        assert_eq!(plain_counts(&long), (1000, 1000));
        let mut stop = [b']'; 100];
        stop[64] = 0xff;
        assert_eq!(plain_counts(&stop), (64, -64));
    }

    /// Each chunk (here: each module) starts from the left context one
    /// thread has there: the last two considered modules on the path to
    /// it (derived by hand), with the parameters a left context asks for
    /// (of A and B), and the nesting level.
    #[test]
    fn each_chunk_starts_from_the_path_to_its_first_module() {
        // The same string with parameters (module by module) and without
        // (one-byte modules: the scan's byte loop).
        let ascii: Vec<(char, &[f64])> = STRING.iter().map(|&(c, _)| (c, &[][..])).collect();
        for (indexed, plain) in [(false, false), (true, false), (false, true), (true, true)] {
            let (mut s, string) = if plain {
                (
                    system("ignore: +\nproductions:\nA B < C -> X\n"),
                    &ascii[..],
                )
            } else {
                let src = "ignore: +\nproductions:\nA(a) B(b) < C(c) -> X\nF(f) -> F\n";
                (system(src), STRING)
            };
            let (f, _) = write(&mut s.alphabet, string, indexed);
            let arity = usize::from(!plain);
            let mut key = |c: char| s.alphabet.intern(c, arity).unwrap();
            let (a, b, c, d, e) = (key('A'), key('B'), key('C'), key('D'), key('E'));
            let al = &s.alphabet;
            let (one, two) = if plain {
                (None, None)
            } else {
                (Some(1.0), Some(2.0))
            };
            type Path<'p> = &'p [(u32, Option<f64>)];
            let want: [(Path, i64); 11] = [
                (&[], 0),
                (&[(a, one)], 0),
                (&[(a, one), (b, two)], 0),
                (&[(a, one), (b, two)], 1),
                (&[(b, two), (c, None)], 1),
                (&[(b, two), (c, None)], 1),
                (&[(b, two), (c, None)], 2),
                (&[(c, None), (d, None)], 2),
                (&[(b, two), (c, None)], 1),
                (&[(c, None), (e, None)], 1),
                (&[(a, one), (b, two)], 0),
            ];
            let mut scan = Scan::new(&f, (indexed, false), &s.productions, al, 1);
            let mut next = (0, 0);
            let mut got = Vec::new();
            while let Some(ch) = scan.next_chunk(al).unwrap() {
                // Contiguous chunks of one module each, numbered in order.
                assert_eq!(
                    (ch.start, ch.first),
                    next,
                    "indexed {indexed}, plain {plain}"
                );
                assert!(ch.end > ch.start);
                next = (ch.end, ch.first + 1);
                let left = ch.at.left.expect("left contexts are kept");
                got.push((left.path(), ch.at.level));
            }
            assert_eq!(next.0, f.metadata().unwrap().len());
            let want: Vec<_> = want.iter().map(|(p, l)| (p.to_vec(), *l)).collect();
            assert_eq!(got, want, "indexed {indexed}, plain {plain}");
        }
        // Without left contexts, only the nesting level is kept.
        let mut s = system("productions:\nA > B -> X\n");
        let (f, _) = write(&mut s.alphabet, STRING, true);
        let mut scan = Scan::new(&f, (true, false), &s.productions, &s.alphabet, 4);
        let ch = scan.next_chunk(&s.alphabet).unwrap().unwrap();
        assert!(ch.at.left.is_none());
        // Chunks end at the first module boundary past 4 bytes: A(1) is
        // more than 4 bytes.
        let ch = scan.next_chunk(&s.alphabet).unwrap().unwrap();
        assert_eq!(ch.first, 1);
    }
}

/// `LSGEN_DEBUG_PAR=1` (hidden, for measuring, benches/RESULTS.md; the
/// one switch of the split's diagnostics, `super::handoff::Shared::debug`
/// too): each split step pass also reports on stderr the CPU time of its
/// producer, of each worker and of the writer, a speed-up proxy that does
/// not depend on how loaded the machine is.
pub(crate) fn thread_times() -> bool {
    std::env::var_os("LSGEN_DEBUG_PAR").is_some_and(|v| v == "1")
}

/// Nanoseconds the calling thread has run on a CPU (the one thread clock,
/// [`super::handoff::thread_cpu`], shared with `LSGEN_DEBUG_PAR`).
pub(crate) fn thread_cpu_ns() -> u64 {
    super::handoff::thread_cpu().as_nanos() as u64
}

/// One line per split pass: the CPU time (ms) of the producer, the
/// workers and the writer, and the speed-up on free cores they imply: the
/// sum over the critical path, the longest of producer, writer, the
/// workers' share per thread and the sum's share per core.
pub(crate) fn report_times(pass: super::Pass, producer: u64, workers: &[u64], writer: u64) {
    let ms = |ns: u64| ns as f64 / 1e6;
    let total: u64 = producer + writer + workers.iter().sum::<u64>();
    let per = workers.iter().sum::<u64>() / workers.len().max(1) as u64;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as u64;
    let critical = producer.max(writer).max(per).max(total / cores).max(1);
    let w: Vec<String> = workers.iter().map(|&n| format!("{:.1}", ms(n))).collect();
    crate::diag::eprint(&format!(
        "lsgen: threads: {pass}: producer {:.1} ms, workers [{}] ms, writer {:.1} ms; \
         total {:.1} ms, producer share {:.1} %, bound {:.2}x\n",
        ms(producer),
        w.join(", "),
        ms(writer),
        ms(total),
        100.0 * producer as f64 / total.max(1) as f64,
        total as f64 / critical as f64,
    ));
}

/// The CPU times of a split pass's threads ([`thread_times`]).
#[derive(Default)]
pub(crate) struct CpuTimes {
    producer: std::sync::atomic::AtomicU64,
    workers: std::sync::Mutex<Vec<u64>>,
}

/// Records its thread's CPU time into a [`CpuTimes`] when the thread's
/// work ends (dropped), however it ends.
pub(crate) struct Timed<'a>(pub(crate) &'a CpuTimes, pub(crate) bool);

impl Drop for Timed<'_> {
    fn drop(&mut self) {
        let ns = thread_cpu_ns();
        if self.1 {
            self.0
                .producer
                .store(ns, std::sync::atomic::Ordering::Relaxed);
        } else if let Ok(mut w) = self.0.workers.lock() {
            w.push(ns);
        }
    }
}

impl CpuTimes {
    /// Report them (the writer's `writer` ns) with [`report_times`].
    pub(crate) fn report(&self, pass: super::Pass, writer: u64) {
        let producer = self.producer.load(std::sync::atomic::Ordering::Relaxed);
        let workers = self.workers.lock().map(|w| w.clone()).unwrap_or_default();
        report_times(pass, producer, &workers, writer);
    }
}

/// A chunk's bracket balance, for a pass that checks it (`check_balance`):
/// the output's depth at a chunk's start depends on what the chunks
/// before it wrote, so a worker counts depth from 0 at its chunk's start
/// and leaves the verdict to the writer, which knows the depth there
/// ([`BalanceCheck`]).
#[derive(Default, Debug)]
pub(crate) struct Balance {
    /// Each new low of the depth (relative to the chunk's start, with what
    /// the production about to be written dips) below 0, in string order,
    /// with the production to blame (None: the last one that closed a
    /// branch before the chunk).
    pub(crate) lows: Vec<(i64, Option<u32>)>,
    /// The depth at the chunk's end, relative to its start.
    pub(crate) depth: i64,
    /// The chunk's last productions that opened and closed more than
    /// they matched.
    pub(crate) last_opener: Option<u32>,
    pub(crate) last_closer: Option<u32>,
}

impl Balance {
    /// The depth (relative) dips to `low` (< 0) here, blaming `culprit`.
    #[cold]
    pub(crate) fn dip(&mut self, low: i64, culprit: Option<u32>) {
        if low < self.lows.last().map_or(0, |l| l.0) {
            self.lows.push((low, culprit));
        }
    }
}

/// The writer's side: the output's depth at the next chunk's start, and
/// the productions one thread would blame there.
#[derive(Default)]
pub(crate) struct BalanceCheck {
    depth: i64,
    pub(crate) last_opener: Option<u32>,
    last_closer: Option<u32>,
}

impl BalanceCheck {
    /// The next chunk's balance: Err(the production to blame) at the first
    /// of its lows that takes the depth below 0, where one thread stops
    /// (the first new low below `-depth` is the first point below it).
    pub(crate) fn next(&mut self, b: &Balance) -> Result<(), Option<u32>> {
        if let Some(&(_, culprit)) = b.lows.iter().find(|l| self.depth + l.0 < 0) {
            return Err(culprit.or(self.last_closer));
        }
        self.depth += b.depth;
        self.last_opener = b.last_opener.or(self.last_opener);
        self.last_closer = b.last_closer.or(self.last_closer);
        Ok(())
    }

    /// The depth after the last chunk (0: balanced).
    pub(crate) fn depth(&self) -> i64 {
        self.depth
    }
}
