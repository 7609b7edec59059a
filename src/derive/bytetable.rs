//! The D0L byte table: ASCII symbols whose step needs no decision are
//! rewritten by a 128-entry table, in blocks.

use super::context::LeftContext;
use super::sink::{Out, OUT_CHUNK};
use crate::diag::Error;
use crate::rules::{Alphabet, Table, CLOSE, OPEN};

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
        }
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
    /// the input's nesting `level`.
    #[inline]
    pub(crate) fn run(
        &self,
        input: &[u8],
        out: &mut Out,
        mut left: Option<&mut LeftContext>,
        al: &Alphabet,
        open_len: usize,
        level: &mut i64,
    ) -> Result<(usize, u64), Error> {
        let mut i = 0;
        // Modules = bytes, less the index bytes of each `[`.
        let mut opens = 0u64;
        let mut lv = *level;
        while i < input.len() {
            let b = input[i];
            if b >= 0x80 {
                break;
            }
            let Some(f) = &self.succ[b as usize] else {
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
