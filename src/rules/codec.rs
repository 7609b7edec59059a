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
        self.params.extend(params_of(body, arity));
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

    /// Drop the first `n` modules.
    pub fn drop_front(&mut self, n: usize) {
        let s = self.starts.get(n).copied().unwrap_or(self.params.len());
        self.keys.drain(..n);
        self.starts.drain(..n);
        self.params.drain(..s);
        for at in &mut self.starts {
            *at -= s;
        }
    }

    pub fn len(&self) -> usize {
        self.keys.len()
    }

    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }
}

/// The `arity` parameters of a module whose encoded parameters are `body`.
#[inline(always)]
pub fn params_of(body: &[u8], arity: usize) -> impl Iterator<Item = f64> + '_ {
    (0..arity).map(move |i| get_param(body, i))
}

/// The modules of `bin` (modules in binary form, no bracket index) in
/// order: each key and its parameters' bytes (`arity` gives their number).
pub fn modules_of(
    mut bin: &[u8],
    arity: impl Fn(u32) -> usize,
) -> impl Iterator<Item = (u32, &[u8])> {
    std::iter::from_fn(move || {
        if bin.is_empty() {
            return None;
        }
        let (key, kl) = get_key(bin);
        let end = kl + 8 * arity(key);
        let body = &bin[kl..end];
        bin = &bin[end..];
        Some((key, body))
    })
}

/// How parameters are written as text: the one setting of [`NumFmt`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Numbers {
    /// The shortest form that reads back to the same f64 (lsgen's).
    #[default]
    Shortest,
    /// `--precision N` and the cpfg dialect: `digits` significant digits,
    /// as C's `%.Ng` ([`put_g`]); `c_exponent`: the exponent as C writes
    /// it (`e+07`, cpfg's), else as lsgen does (`e7`).
    Significant { digits: u32, c_exponent: bool },
}

/// Most significant digits `--precision` accepts (an f64 holds 17).
pub const MAX_PRECISION: u32 = 17;

/// Number printer: ryu's shortest round-trip digits without a trailing
/// `.0`, or [`Numbers::Significant`]'s, with a small direct-mapped cache,
/// since the parameters of an L-system string repeat a lot (the same
/// lengths and angles everywhere). Every number of a derivation's text is
/// written here (modules through [`NumFmt::module`], constant runs by
/// `Table::retext`), in the form its alphabet says.
pub struct NumFmt {
    ryu: ryu::Buffer,
    /// The form the cache holds.
    form: Numbers,
    scratch: String,
    cache: Box<[CacheEntry]>,
}

/// A [`NumFmt`]'s cache and the form its entries are in
/// ([`NumFmt::take_cache`]).
pub(crate) struct NumCache(Box<[CacheEntry]>, Numbers);

#[derive(Clone, Copy)]
struct CacheEntry {
    bits: u64,
    len: u8,
    text: [u8; 24],
}

const CACHE_BITS: u32 = 12;

/// An empty slot: len 0 (no number prints as nothing).
const EMPTY_ENTRY: CacheEntry = CacheEntry {
    bits: 0,
    len: 0,
    text: [0; 24],
};

impl Default for NumFmt {
    fn default() -> Self {
        NumFmt::new()
    }
}

impl NumFmt {
    pub fn new() -> NumFmt {
        NumFmt {
            ryu: ryu::Buffer::new(),
            form: Numbers::Shortest,
            scratch: String::new(),
            cache: vec![EMPTY_ENTRY; 1 << CACHE_BITS].into_boxed_slice(),
        }
    }

    /// Its cache, for another `NumFmt` ([`NumFmt::with_cache`]): filling a
    /// new one writes 160 KiB, which a batch's tiny jobs paid for in each
    /// pass (`derive::spares`). This one is left without a cache,
    /// unusable: for a printer being dropped. None if it has none.
    pub(crate) fn take_cache(&mut self) -> Option<NumCache> {
        (self.cache.len() == 1 << CACHE_BITS)
            .then(|| NumCache(std::mem::take(&mut self.cache), self.form))
    }

    /// A printer with `cache` (and the form it holds).
    pub(crate) fn with_cache(cache: NumCache) -> NumFmt {
        NumFmt {
            ryu: ryu::Buffer::new(),
            form: cache.1,
            scratch: String::new(),
            cache: cache.0,
        }
    }

    /// Append `v` in the shortest form that reads back to the same f64:
    /// `2`, `0.5`, `1.4142135623730951`, `1e-7`, `-0`.
    #[inline]
    pub fn put(&mut self, out: &mut Vec<u8>, v: f64) {
        self.put_in(out, v, Numbers::Shortest)
    }

    /// Append `v` in `form`.
    #[inline]
    pub fn put_in(&mut self, out: &mut Vec<u8>, v: f64, form: Numbers) {
        self.set_form(form);
        self.put_cached(out, v)
    }

    /// Hold numbers in `form` from now on (the cache is for one form).
    #[inline(always)]
    fn set_form(&mut self, form: Numbers) {
        if form != self.form {
            self.new_form(form);
        }
    }

    #[cold]
    fn new_form(&mut self, form: Numbers) {
        self.form = form;
        self.cache.fill(EMPTY_ENTRY);
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
        let start = out.len();
        match self.form {
            Numbers::Shortest => {
                let s = self.ryu.format_finite(v).as_bytes();
                // ryu writes `2.0`, `1e-7`, `1.5e16`: only a trailing `.0`
                // goes.
                let s = match s {
                    [head @ .., b'.', b'0'] => head,
                    _ => s,
                };
                out.extend_from_slice(s);
            }
            Numbers::Significant { digits, c_exponent } => {
                put_g(out, &mut self.scratch, v, digits, c_exponent)
            }
        }
        let s = &out[start..];
        if s.len() <= 24 {
            let e = &mut self.cache[slot];
            e.bits = v.to_bits();
            e.len = s.len() as u8;
            e.text[..s.len()].copy_from_slice(s);
        }
    }

    /// Append a module as text, its parameters in `form`.
    #[inline]
    pub fn module(&mut self, out: &mut Vec<u8>, sym_text: &[u8], params: &[f64], form: Numbers) {
        self.module_of(out, sym_text, params.iter().copied(), form)
    }

    /// [`NumFmt::module`] with the parameters from an iterator (a module
    /// in binary form, decoded as it is written): the one place a module
    /// becomes text.
    #[inline(always)]
    pub fn module_of(
        &mut self,
        out: &mut Vec<u8>,
        sym_text: &[u8],
        mut params: impl Iterator<Item = f64>,
        form: Numbers,
    ) {
        match *sym_text {
            [b] => out.push(b),
            _ => out.extend_from_slice(sym_text),
        }
        if let Some(first) = params.next() {
            self.set_form(form);
            out.push(b'(');
            self.put_cached(out, first);
            for p in params {
                out.push(b',');
                self.put_cached(out, p);
            }
            out.push(b')');
        }
    }
}

/// Append `v` with `digits` significant digits, `%g` style: scientific when
/// the exponent is below -4 or at least `digits`, trailing zeros dropped.
/// `scratch` is reused, so nothing is allocated once it has grown. With
/// `c_exponent` the exponent is exactly as C's `%g` writes it: a sign and
/// at least two digits (`1.67772e+07`, `1e-05`), as cpfg prints (the cpfg
/// dialect's output); else as lsgen writes numbers (`1.67772e7`), so the
/// output still reads back as an axiom.
pub fn put_g(out: &mut Vec<u8>, scratch: &mut String, v: f64, digits: u32, c_exponent: bool) {
    use std::fmt::Write as _;
    use std::io::Write as _;
    let p = digits.clamp(1, MAX_PRECISION) as usize;
    if !v.is_finite() || v == 0.0 {
        if v == 0.0 && v.is_sign_negative() {
            out.extend_from_slice(b"-0");
        } else if v == 0.0 {
            out.push(b'0');
        } else {
            let _ = write!(out, "{v}");
        }
        return;
    }
    scratch.clear();
    let _ = write!(scratch, "{:.*e}", p - 1, v);
    let Some(at) = scratch.find('e') else {
        out.extend_from_slice(scratch.as_bytes());
        return;
    };
    let exp: i32 = scratch[at + 1..].parse().unwrap_or(0);
    if exp < -4 || exp >= p as i32 {
        out.extend_from_slice(trim_zeros(&scratch.as_bytes()[..at]));
        if c_exponent {
            let sign = if exp < 0 { '-' } else { '+' };
            let _ = write!(out, "e{sign}{:02}", exp.unsigned_abs());
        } else {
            let _ = write!(out, "e{exp}");
        }
    } else {
        scratch.clear();
        let _ = write!(scratch, "{:.*}", (p as i32 - 1 - exp) as usize, v);
        out.extend_from_slice(trim_zeros(scratch.as_bytes()));
    }
}

/// `1.500` -> `1.5`, `2.000` -> `2`; a number without `.` is left alone.
fn trim_zeros(s: &[u8]) -> &[u8] {
    if !s.contains(&b'.') {
        return s;
    }
    let mut end = s.len();
    while end > 0 && s[end - 1] == b'0' {
        end -= 1;
    }
    if end > 0 && s[end - 1] == b'.' {
        end -= 1;
    }
    &s[..end]
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

    fn g(v: f64, p: u32) -> String {
        let mut o = Vec::new();
        put_g(&mut o, &mut String::new(), v, p, false);
        String::from_utf8(o).unwrap()
    }

    #[test]
    fn significant_cache_gives_what_formatting_gives() {
        // Many numbers, repeated, colliding in the cache, the form changed
        // on the way: the text equals formatting each number afresh.
        let mut x: u64 = 12345;
        let mut f = NumFmt::new();
        for round in 0..6 {
            let form = match round % 3 {
                0 => Numbers::Significant {
                    digits: 6,
                    c_exponent: true,
                },
                1 => Numbers::Shortest,
                _ => Numbers::Significant {
                    digits: 3,
                    c_exponent: false,
                },
            };
            for _ in 0..9000 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let v =
                    ((x % 100_000) as f64 - 50_000.0) / 7.0 * [1.0, 1e9, 1e-9][(x % 3) as usize];
                let mut got = Vec::new();
                f.module(&mut got, b"F", &[v, 1.0], form);
                let mut want = b"F(".to_vec();
                match form {
                    Numbers::Shortest => want.extend_from_slice(number_string(v).as_bytes()),
                    Numbers::Significant { digits, c_exponent } => {
                        put_g(&mut want, &mut String::new(), v, digits, c_exponent)
                    }
                }
                want.extend_from_slice(b",1)");
                assert!(got == want, "{v}: {got:?}");
            }
        }
    }

    #[test]
    fn c_exponent_like_printf_g() {
        // Expected: C's printf("%g") (checked by hand against glibc's).
        let c = |v: f64| {
            let mut o = Vec::new();
            put_g(&mut o, &mut String::new(), v, 6, true);
            String::from_utf8(o).unwrap()
        };
        assert_eq!(c(16777216.0), "1.67772e+07");
        assert_eq!(c(1e-30), "1e-30");
        assert_eq!(c(0.00001), "1e-05");
        assert_eq!(c(1.5e100), "1.5e+100");
        assert_eq!(c(123456.0), "123456");
        assert_eq!(c(-0.0), "-0");
    }

    #[test]
    fn like_printf_g() {
        // Expected: C's printf("%.Ng"), exponent in lsgen's form.
        assert_eq!(g(5.55555, 3), "5.56");
        assert_eq!(g(1234567.0, 3), "1.23e6");
        assert_eq!(g(0.000012345, 3), "1.23e-5");
        assert_eq!(g(100.0, 3), "100");
        assert_eq!(g(999.9, 3), "1e3");
        assert_eq!(g(0.0001, 3), "0.0001");
        assert_eq!(g(-2.5, 6), "-2.5");
        assert_eq!(g(9.9996, 4), "10");
        assert_eq!(g(1.0 / 3.0, 6), "0.333333");
        assert_eq!(g(-0.0, 6), "-0");
        assert_eq!(g(0.0, 6), "0");
        assert_eq!(g(123456.0, 6), "123456");
        assert_eq!(g(1234567.0, 6), "1.23457e6");
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
