//! The two string formats.
//!
//! *Binary* (between steps, in temp files): a module is its key as LEB128
//! followed by its parameters as little-endian f64. Keys 0..=127 are the
//! ASCII symbols without parameters, so the key *is* the character and a
//! bracketed D0L string is stored exactly as its text. Other keys (non-ASCII
//! symbols, modules with parameters) are numbered from 128 by the alphabet.
//!
//! *Text* (the output): the symbol, then `(p1,p2,...)` with each number in
//! the shortest form that reads back to the same f64.

/// The bracket index (see `Out::with_index`): in a generation written
/// with it, each `[` is followed by the distance from it to just past its
/// `]` (one [`WORD_BYTES`] word), so a branch is skipped in constant time;
/// with module counts (`Out::with_counts`, for systems that can cut), also
/// by the number of modules of its branch, both brackets included (a
/// second word), so a cut skips its branch in constant time and keeps the
/// draw positions.
pub const INDEX_BYTES: usize = 2 * WORD_BYTES;
/// Index bytes of a `[` without module counts.
pub const ENDS_BYTES: usize = WORD_BYTES;
/// Bytes of an index word: little-endian, 48 bits. Not 64: in a bracketed
/// string one module in six or so is a `[`, and its index was more than
/// half of an indexed generation (208 MB for a 93 MB axiom with 8-byte
/// words, 179 MB with 6), all of it written and read again each step.
/// 2^48 bytes (256 TiB) is more than any generation a disk holds; a larger
/// branch is an error ([`WORD_MAX`]), never a wrong skip.
pub const WORD_BYTES: usize = 6;
/// The largest value an index word holds.
pub const WORD_MAX: u64 = (1 << (8 * WORD_BYTES)) - 1;

/// The index word at the start of `b` (at least [`WORD_BYTES`] bytes).
#[inline(always)]
pub fn get_word(b: &[u8]) -> u64 {
    let mut w = [0; 8];
    w[..WORD_BYTES].copy_from_slice(&b[..WORD_BYTES]);
    u64::from_le_bytes(w)
}

/// Write the index word `v` (at most [`WORD_MAX`]) at the start of `b`.
#[inline(always)]
pub fn put_word(b: &mut [u8], v: u64) {
    debug_assert!(v <= WORD_MAX);
    b[..WORD_BYTES].copy_from_slice(&v.to_le_bytes()[..WORD_BYTES]);
}

/// From the index bytes after a `[` (at least [`ENDS_BYTES`]): the
/// distance from the `[` to just past its `]`, None if it is never
/// closed (0).
#[inline]
pub fn branch_dist(index: &[u8]) -> Option<u64> {
    let dist = get_word(index);
    (dist > 0).then_some(dist)
}

/// Longest encoded module: 5 key bytes + 255 parameters.
pub const MAX_ARITY: usize = 255;
pub const MAX_MODULE_BYTES: usize = 5 + 8 * MAX_ARITY;

#[inline]
pub fn put_key(out: &mut Vec<u8>, mut key: u32) {
    while key >= 0x80 {
        out.push((key as u8) | 0x80);
        key >>= 7;
    }
    out.push(key as u8);
}

/// Decode a key at the start of `b`: (key, bytes used). `b` must hold a
/// whole key (callers keep MAX_MODULE_BYTES available).
#[inline]
pub fn get_key(b: &[u8]) -> (u32, usize) {
    let first = b[0];
    if first < 0x80 {
        return (first as u32, 1);
    }
    let mut key = (first & 0x7f) as u32;
    let mut shift = 7;
    let mut i = 1;
    loop {
        let byte = b[i];
        key |= ((byte & 0x7f) as u32) << shift;
        i += 1;
        if byte < 0x80 {
            return (key, i);
        }
        shift += 7;
    }
}

#[inline]
pub fn put_params(out: &mut Vec<u8>, params: &[f64]) {
    for p in params {
        out.extend_from_slice(&p.to_le_bytes());
    }
}

#[inline]
pub fn get_param(b: &[u8], i: usize) -> f64 {
    f64::from_le_bytes(b[8 * i..8 * i + 8].try_into().unwrap())
}

/// The parameter bytes of an encoded module (what follows its key).
#[inline]
pub fn body(module: &[u8]) -> &[u8] {
    let (_, kl) = get_key(module);
    &module[kl..]
}

/// Decode the first `out.len()` parameters of the encoded module `module`
/// (key included) into `out`.
#[inline]
pub fn read_params(module: &[u8], out: &mut [f64]) {
    let b = body(module);
    for (i, o) in out.iter_mut().enumerate() {
        *o = get_param(b, i);
    }
}

/// Decoded modules in a row (keys with their parameters), reused without
/// allocating once grown: a generation's path level depth first, the
/// modules a right context looks at.
#[derive(Default)]
pub struct Modules {
    pub keys: Vec<u32>,
    /// Where each module's parameters start in `params`.
    pub starts: Vec<usize>,
    pub params: Vec<f64>,
}

impl Modules {
    pub fn clear(&mut self) {
        self.keys.clear();
        self.starts.clear();
        self.params.clear();
    }

    #[inline]
    pub fn push(&mut self, key: u32, params: &[f64]) {
        self.keys.push(key);
        self.starts.push(self.params.len());
        self.params.extend_from_slice(params);
    }

    /// Append the encoded module `module` (key included) with `arity`
    /// parameters.
    #[inline]
    pub fn push_encoded(&mut self, key: u32, module: &[u8], arity: usize) {
        self.push_body(key, body(module), arity);
    }

    /// Append module `key` whose `arity` encoded parameters are `body`.
    #[inline]
    pub fn push_body(&mut self, key: u32, body: &[u8], arity: usize) {
        self.keys.push(key);
        self.starts.push(self.params.len());
        for i in 0..arity {
            self.params.push(get_param(body, i));
        }
    }

    /// Module `i`: its key and its `arity` parameters.
    #[inline]
    pub fn get(&self, i: usize, arity: usize) -> (u32, &[f64]) {
        let s = self.starts[i];
        (self.keys[i], &self.params[s..s + arity])
    }

    /// Module `i`, its parameters writable.
    #[inline]
    pub fn get_mut(&mut self, i: usize, arity: usize) -> (u32, &mut [f64]) {
        let s = self.starts[i];
        (self.keys[i], &mut self.params[s..s + arity])
    }

    pub fn len(&self) -> usize {
        self.keys.len()
    }

    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }
}

/// Number printer: ryu's shortest round-trip digits without a trailing
/// `.0`, with a small direct-mapped cache, since the parameters of an
/// L-system string repeat a lot (the same lengths and angles everywhere).
pub struct NumFmt {
    ryu: ryu::Buffer,
    cache: Box<[CacheEntry]>,
}

#[derive(Clone, Copy)]
struct CacheEntry {
    bits: u64,
    len: u8,
    text: [u8; 24],
}

const CACHE_BITS: u32 = 12;

impl Default for NumFmt {
    fn default() -> Self {
        NumFmt::new()
    }
}

impl NumFmt {
    pub fn new() -> NumFmt {
        NumFmt {
            ryu: ryu::Buffer::new(),
            // len 0 marks an empty slot (no number prints as nothing).
            cache: vec![
                CacheEntry {
                    bits: 0,
                    len: 0,
                    text: [0; 24]
                };
                1 << CACHE_BITS
            ]
            .into_boxed_slice(),
        }
    }

    /// Append `v` in the shortest form that reads back to the same f64:
    /// `2`, `0.5`, `1.4142135623730951`, `1e-7`, `-0`.
    #[inline]
    pub fn put(&mut self, out: &mut Vec<u8>, v: f64) {
        self.put_cached(out, v)
    }

    /// The cache's look-up, inlined into [`NumFmt::module`]'s loop; the
    /// formatting of a number not in it is a call of its own.
    #[inline(always)]
    fn put_cached(&mut self, out: &mut Vec<u8>, v: f64) {
        let bits = v.to_bits();
        let slot = (bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - CACHE_BITS)) as usize;
        let e = &self.cache[slot];
        if e.len != 0 && e.bits == bits {
            // A fixed-size copy (inlined, no memcpy call), then cut.
            let end = out.len() + e.len as usize;
            out.extend_from_slice(&e.text);
            out.truncate(end);
            return;
        }
        self.put_miss(out, v, slot);
    }

    /// A number not in the cache: formatted, and cached.
    #[cold]
    #[inline(never)]
    fn put_miss(&mut self, out: &mut Vec<u8>, v: f64, slot: usize) {
        let s = self.ryu.format_finite(v).as_bytes();
        // ryu writes `2.0`, `1e-7`, `1.5e16`: only a trailing `.0` goes.
        let s = match s {
            [head @ .., b'.', b'0'] => head,
            _ => s,
        };
        out.extend_from_slice(s);
        if s.len() <= 24 {
            let e = &mut self.cache[slot];
            e.bits = v.to_bits();
            e.len = s.len() as u8;
            e.text[..s.len()].copy_from_slice(s);
        }
    }

    /// Append a module as text.
    #[inline]
    pub fn module(&mut self, out: &mut Vec<u8>, sym_text: &[u8], params: &[f64]) {
        match *sym_text {
            [b] => out.push(b),
            _ => out.extend_from_slice(sym_text),
        }
        if let Some((first, rest)) = params.split_first() {
            out.push(b'(');
            self.put_cached(out, *first);
            for p in rest {
                out.push(b',');
                self.put_cached(out, *p);
            }
            out.push(b')');
        }
    }
}

/// A number as lsgen prints it, for messages.
pub fn number_string(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let mut o = Vec::new();
    NumFmt::new().put(&mut o, v);
    String::from_utf8(o).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn num(v: f64) -> String {
        number_string(v)
    }

    #[test]
    fn cache_gives_the_same_text() {
        let mut f = NumFmt::new();
        let mut a = Vec::new();
        for i in 0..20_000 {
            let v = (i % 5000) as f64 * 0.37 - 100.0;
            let before = a.len();
            f.put(&mut a, v);
            assert_eq!(std::str::from_utf8(&a[before..]).unwrap(), number_string(v));
        }
        // Colliding slots are replaced, not mixed up.
        let mut b = Vec::new();
        f.put(&mut b, 0.0);
        f.put(&mut b, -0.0);
        assert_eq!(b, b"0-0");
    }

    #[test]
    fn shortest_round_trip_numbers() {
        assert_eq!(num(2.0), "2");
        assert_eq!(num(0.5), "0.5");
        assert_eq!(num(2f64.sqrt()), "1.4142135623730951");
        assert_eq!(num(1e-7), "1e-7");
        assert_eq!(num(-3.0), "-3");
        assert_eq!(num(-0.0), "-0");
        assert_eq!(num(1e16), "1e16");
        assert_eq!(num(123456.0), "123456");
        assert_eq!(num(1.5e300), "1.5e300");
        assert_eq!(num(0.1 + 0.2), "0.30000000000000004");
        for v in [
            1e-300,
            3.25e-9,
            1.0 / 3.0,
            6.02e23,
            f64::MAX,
            f64::MIN_POSITIVE,
        ] {
            assert_eq!(num(v).parse::<f64>().unwrap(), v);
        }
    }

    #[test]
    fn keys_round_trip() {
        for k in [0u32, 5, 127, 128, 300, 16383, 16384, 1 << 21, u32::MAX] {
            let mut o = Vec::new();
            put_key(&mut o, k);
            o.extend_from_slice(&[0; 8]);
            let (d, n) = get_key(&o);
            assert_eq!(d, k);
            assert_eq!(n, o.len() - 8);
        }
        let mut o = Vec::new();
        put_key(&mut o, b'F' as u32);
        assert_eq!(o, b"F");
    }
}
