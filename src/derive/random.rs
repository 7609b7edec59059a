//! Seeded randomness: every draw is a function of (seed, pass, module
//! index, draw order), so a derivation can be chained or split anywhere
//! with byte-identical output (README, "Randomness").
//!
//! The key is `ChaCha8Rng::seed_from_u64(seed)`, made once per run. A draw
//! is the 64-bit value at draw position P of a ChaCha stream (words 2P and
//! 2P+1, little end first, as `next_u64` reads them after
//! `set_word_pos(2P)`):
//!
//! - stream: the step number for a step (`--first-step` numbers them), the
//!   number of the last step for the homomorphism, 0 for the axiom and the
//!   random constants;
//! - P = region·2^65 + draw·2^59 + module, with region 0 for the axiom and
//!   the steps, 1 for the homomorphism; module the index of the module
//!   being rewritten in its generation (every module counts, brackets
//!   included, from 0), draw its draw's order within that module (at most
//!   [`DRAWS_PER_MODULE`]);
//! - random constants (`define:`) draw in file order from P = 2·2^65 on
//!   (region 2, stream 0).
//!
//! Draws are read from windows of `WINDOW` consecutive positions, one
//! for the draws of order 0 and one for the others: a module's first draw
//! is an index into the window when an earlier module's fell in the same
//! one, however many modules between them drew nothing; a window is
//! refilled (`set_word_pos`, four ChaCha blocks) once per `WINDOW`
//! positions.

use crate::cpfg::func::Functions;
use crate::cpfg::random::CpfgRandom;
use crate::diag::FuncFault;
use crate::rules::expr::CurveFn;
use rand_chacha::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

/// Most draws one module may make in one pass.
pub const DRAWS_PER_MODULE: u64 = 64;
/// Module indices must be below this.
pub const MODULES_PER_GENERATION: u64 = 1 << 59;

/// Draw positions per window (64-bit draws: four ChaCha blocks).
const WINDOW: usize = 32;

/// A window of the stream: the draws at positions `at..at + WINDOW`.
#[derive(Clone)]
struct Window {
    /// The first position (a multiple of [`WINDOW`]); 2^127 when empty,
    /// far from every position (below 2^67).
    at: u128,
    draws: [u64; WINDOW],
}

impl Window {
    const EMPTY: Window = Window {
        at: 1 << 127,
        draws: [0; WINDOW],
    };
}

/// Where a pass draws from (the region of the draw position).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// The axiom (stream 0) and the steps (stream: the step number).
    Step = 0,
    /// The homomorphism (stream: the number of the last step).
    Homomorphism = 1,
    /// Random constants (stream 0), drawn in order.
    Constants = 2,
}

/// Something that yields draws (lsgen's [`Random`]; the tests' reference
/// has its own).
pub trait Draw {
    /// Uniform in [0, 1): the top 53 bits of one draw / 2^53. An error
    /// message when the module has drawn too often.
    fn uniform(&mut self) -> Result<f64, RandomError>;
    /// Normal deviate by Box-Muller from one draw: the high 32 bits give
    /// u1 in (0, 1], the low 32 bits u2 in [0, 1).
    fn normal(&mut self, mean: f64, sd: f64) -> Result<f64, RandomError>;
    /// The value of the built-in `step` (issue 11) where the expression
    /// compiler emitted it as such; a drawer that binds `step` as an
    /// ordinary parameter (the tests' reference) never reaches this.
    fn step(&self) -> f64 {
        0.0
    }
    /// cpfg's `Q = x;` in a block (issue 12): the built-in `step` reads
    /// `x` until the next step sets it again.
    fn assign_step(&mut self, _x: f64) {}
    /// cpfg's `bran(a, b)`, `biran(n, p)` and `srand(x)` (issue 12): only
    /// the cpfg dialect's generator has them.
    fn bran(&mut self, _a: f64, _b: f64) -> Result<f64, RandomError> {
        Err(RandomError::CpfgOnly)
    }
    fn biran(&mut self, _n: f64, _p: f64) -> Result<f64, RandomError> {
        Err(RandomError::CpfgOnly)
    }
    fn srand(&mut self, _x: f64) -> Result<f64, RandomError> {
        Err(RandomError::CpfgOnly)
    }
    /// cpfg's global variable `i` (issue 12; 0 until assigned).
    fn global(&self, _i: u32) -> f64 {
        0.0
    }
    fn set_global(&mut self, _i: u32, _v: f64) {}
    /// cpfg's `func(id, x)`: only a cpfg run with function files has it.
    fn func(&self, _id: f64, _x: f64) -> Result<f64, FuncFault> {
        Err(FuncFault::NoFunctions)
    }
    /// cpfg's `curveX(id, t)` and the like (`t`: 0 for `curveGAL(id)`):
    /// only a cpfg run with curves has them.
    fn curve(&self, f: CurveFn, _id: f64, _t: f64) -> Result<f64, FuncFault> {
        Err(FuncFault::NoCurves(f.name()))
    }
}

/// The uniform value of a draw.
#[inline]
pub fn uniform_of(x: u64) -> f64 {
    (x >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The normal value of a draw.
#[inline]
pub fn normal_of(x: u64, mean: f64, sd: f64) -> f64 {
    let u1 = ((x >> 32) as f64 + 1.0) / 4294967296.0;
    let u2 = (x & 0xffff_ffff) as f64 / 4294967296.0;
    let z = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
    mean + sd * z
}

pub use crate::diag::RandomError;
pub const TOO_MANY_DRAWS: RandomError = RandomError::TooManyDraws;
const TOO_MANY_MODULES: RandomError = RandomError::TooManyModules;

/// What the homomorphism's `seed:` replaced.
pub enum Saved {
    Whole(Box<Random>),
    /// cpfg's: the homomorphism's function generator runs beside the first.
    Functions,
}

#[derive(Clone)]
pub struct Random {
    rng: ChaCha8Rng,
    /// Draws made so far (a step that made none and left the string
    /// unchanged is a fixed point).
    draws: u64,
    /// The region's first draw position.
    base: u128,
    module: u64,
    draw: u64,
    /// The windows of the draws of order 0 and of the others (both of
    /// the current stream).
    windows: [Window; 2],
    /// Random constants: draws in order, no modules.
    sequential: bool,
    /// The step number the built-in `step` reads (issue 11).
    step: f64,
    /// The cpfg dialect's generators (issue 12): `ran`, `nran`, ... and
    /// the stochastic choice draw from them, in string order, instead of
    /// the draws by position.
    cpfg: Option<Box<CpfgRandom>>,
    /// cpfg's global variables (issue 12): the run's state that every
    /// expression reads, kept here with the step number.
    globals: Vec<f64>,
    /// cpfg's functions (`func(id, x)`), read-only and shared.
    functions: Option<Arc<Functions>>,
}

impl Random {
    /// Keyed with `seed`, at the axiom (stream 0, region 0, module 0).
    pub fn new(seed: u64) -> Random {
        Random {
            rng: ChaCha8Rng::seed_from_u64(seed),
            draws: 0,
            base: 0,
            module: 0,
            draw: 0,
            windows: [Window::EMPTY, Window::EMPTY],
            sequential: false,
            step: 0.0,
            cpfg: None,
            globals: Vec::new(),
            functions: None,
        }
    }

    /// cpfg's generators, for a file with `seed:` `seed` (None: no
    /// `seed:`, weights are ignored).
    pub fn cpfg(seed: Option<u64>, functions: Option<Arc<Functions>>) -> Random {
        let mut r = Random::new(0);
        r.cpfg = Some(Box::new(CpfgRandom::new(seed)));
        r.functions = functions;
        r
    }

    /// The homomorphism's own `seed:` `seed` takes over: lsgen's key for
    /// the pass, or in the cpfg dialect a function generator seeded as
    /// `srand(seed)` seeds it, for the successors of the productions it
    /// applies ([`CpfgRandom::begin_homomorphism`]). Give the result to
    /// [`Random::end_homomorphism`] to go back.
    pub fn begin_homomorphism(&mut self, seed: u64) -> Saved {
        if let Some(c) = self.cpfg.as_deref_mut() {
            c.begin_homomorphism(seed);
            return Saved::Functions;
        }
        Saved::Whole(Box::new(std::mem::replace(self, Random::new(seed))))
    }

    /// Back to the generator before [`Random::begin_homomorphism`].
    pub fn end_homomorphism(&mut self, saved: Saved) {
        match saved {
            Saved::Whole(r) => *self = *r,
            Saved::Functions => {
                if let Some(c) = self.cpfg.as_deref_mut() {
                    c.end_homomorphism();
                }
            }
        }
    }

    /// cpfg's generators, if this is the cpfg dialect's.
    #[inline]
    pub fn cpfg_mut(&mut self) -> Option<&mut CpfgRandom> {
        self.cpfg.as_deref_mut()
    }

    /// The stochastic choice draw of the current module, for the cpfg
    /// dialect's `SelectProd` (its choice generator, one draw per module
    /// of the string in string order); None outside the cpfg dialect or
    /// without `seed:`.
    #[inline]
    pub fn cpfg_choice(&mut self) -> Option<f64> {
        let c = self.cpfg.as_deref_mut()?;
        if !c.stochastic {
            return None;
        }
        self.draws += 1;
        Some(c.choice(self.module))
    }

    /// The value of the built-in `step` from now on.
    pub fn set_step(&mut self, step: u64) {
        self.step = step as f64;
    }

    /// The generator of random constants (`ran` in `define:`).
    pub fn for_constants(seed: u64) -> Random {
        let mut r = Random::new(seed);
        r.start_pass(0, Region::Constants);
        r.sequential = true;
        r
    }

    /// Start a pass: `stream` and `region` as in the module docs.
    pub fn start_pass(&mut self, stream: u64, region: Region) {
        if self.cpfg.is_some() {
            self.module = 0;
            return;
        }
        if self.rng.get_stream() != stream {
            self.rng.set_stream(stream);
            self.windows = [Window::EMPTY, Window::EMPTY];
        }
        self.base = (region as u128) << 65;
        self.module = 0;
        self.draw = 0;
    }

    /// The next draws are for the module at `index` of its generation.
    #[inline]
    pub fn set_module(&mut self, index: u64) {
        self.module = index;
        self.draw = 0;
    }

    /// How many draws were made so far.
    #[inline]
    pub fn draws(&self) -> u64 {
        self.draws
    }

    /// A fresh seed from the operating system's randomness (getrandom),
    /// for runs without `seed:`/`--seed`; should the system have none, the
    /// standard library's random hash keys mixed with the time.
    pub fn fresh_seed() -> u64 {
        if let Ok(seed) = getrandom::u64() {
            return seed;
        }
        use std::hash::{BuildHasher, Hasher};
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        h.finish()
    }

    /// The next draw of the current module.
    #[inline]
    fn next(&mut self) -> Result<u64, RandomError> {
        let p = if self.sequential {
            self.base + self.draw as u128
        } else {
            if self.draw >= DRAWS_PER_MODULE {
                return Err(TOO_MANY_DRAWS);
            }
            if self.module >= MODULES_PER_GENERATION {
                return Err(TOO_MANY_MODULES);
            }
            self.base | (self.draw as u128) << 59 | self.module as u128
        };
        let w = &self.windows[usize::from(self.draw != 0)];
        self.draw += 1;
        self.draws += 1;
        let off = p.wrapping_sub(w.at);
        if off < WINDOW as u128 {
            return Ok(w.draws[off as usize]);
        }
        Ok(self.refill(p))
    }

    /// Fill the window of draw `p` (of the current draw order) and return
    /// the draw.
    #[cold]
    #[inline(never)]
    fn refill(&mut self, p: u128) -> u64 {
        let at = p & !(WINDOW as u128 - 1);
        // Words 2P and 2P+1 of draw P: four whole blocks from `at`.
        self.rng.set_word_pos(2 * at);
        let mut bytes = [0u8; 8 * WINDOW];
        self.rng.fill_bytes(&mut bytes);
        let w = &mut self.windows[usize::from(self.draw != 1)];
        for (d, b) in w.draws.iter_mut().zip(bytes.chunks_exact(8)) {
            *d = u64::from_le_bytes(b.try_into().expect("8 bytes"));
        }
        w.at = at;
        w.draws[(p - at) as usize]
    }
}

impl Draw for Random {
    #[inline]
    fn uniform(&mut self) -> Result<f64, RandomError> {
        if let Some(c) = self.cpfg.as_deref_mut() {
            self.draws += 1;
            return Ok(c.ran(1.0));
        }
        self.next().map(uniform_of)
    }

    #[inline]
    fn normal(&mut self, mean: f64, sd: f64) -> Result<f64, RandomError> {
        if let Some(c) = self.cpfg.as_deref_mut() {
            self.draws += 1;
            return Ok(c.nran(mean, sd));
        }
        self.next().map(|x| normal_of(x, mean, sd))
    }

    fn bran(&mut self, a: f64, b: f64) -> Result<f64, RandomError> {
        let c = self.cpfg.as_deref_mut().ok_or(RandomError::CpfgOnly)?;
        self.draws += 1;
        c.bran(a, b)
    }

    fn biran(&mut self, n: f64, p: f64) -> Result<f64, RandomError> {
        let c = self.cpfg.as_deref_mut().ok_or(RandomError::CpfgOnly)?;
        self.draws += 1;
        // C's (int) conversion: toward zero.
        c.biran(n.trunc(), p)
    }

    fn srand(&mut self, x: f64) -> Result<f64, RandomError> {
        let c = self.cpfg.as_deref_mut().ok_or(RandomError::CpfgOnly)?;
        if !x.is_finite() {
            return Err(RandomError::SrandNotFinite);
        }
        // cpfg converts to an int (toward zero) and keeps 32 bits.
        c.srand(x.trunc() as i64);
        Ok(0.0)
    }

    #[inline]
    fn step(&self) -> f64 {
        self.step
    }

    fn assign_step(&mut self, x: f64) {
        self.step = x;
    }

    #[inline]
    fn global(&self, i: u32) -> f64 {
        self.globals.get(i as usize).copied().unwrap_or(0.0)
    }

    fn func(&self, id: f64, x: f64) -> Result<f64, FuncFault> {
        match &self.functions {
            Some(f) => f.value(id, x),
            None => Err(FuncFault::NoFunctions),
        }
    }

    fn curve(&self, f: CurveFn, id: f64, t: f64) -> Result<f64, FuncFault> {
        match (&self.functions, f) {
            (Some(c), CurveFn::Point(which)) => c.curve_value(which, id, t),
            (Some(c), CurveFn::Length) => c.curve_length(id),
            (None, _) => Err(FuncFault::NoCurves(f.name())),
        }
    }

    fn set_global(&mut self, i: u32, v: f64) {
        let i = i as usize;
        if self.globals.len() <= i {
            self.globals.resize(i + 1, 0.0);
        }
        self.globals[i] = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The draw at position `p` of `stream`, computed the slow way.
    fn at(seed: u64, stream: u64, p: u128) -> u64 {
        let mut r = ChaCha8Rng::seed_from_u64(seed);
        r.set_stream(stream);
        r.set_word_pos(2 * p);
        r.next_u64()
    }

    #[test]
    fn draws_are_positions() {
        let mut r = Random::new(42);
        r.start_pass(3, Region::Step);
        // Modules 0, 1, 2, 5, 40 draw once, module 7 three times, in
        // string order; gaps and returns all land on their positions.
        for m in [0u64, 1, 2, 5, 7, 40, 1000] {
            r.set_module(m);
            let n = if m == 7 { 3 } else { 1 };
            for d in 0..n {
                let want = uniform_of(at(42, 3, (d as u128) << 59 | m as u128));
                assert_eq!(r.uniform().unwrap().to_bits(), want.to_bits(), "{m} {d}");
            }
        }
        r.start_pass(3, Region::Homomorphism);
        r.set_module(2);
        let want = uniform_of(at(42, 3, 1 << 65 | 2));
        assert_eq!(r.uniform().unwrap().to_bits(), want.to_bits());
        let mut c = Random::for_constants(42);
        for i in 0..3u128 {
            let want = uniform_of(at(42, 0, 2 << 65 | i));
            assert_eq!(c.uniform().unwrap().to_bits(), want.to_bits());
        }
    }

    #[test]
    fn windows_are_positions() {
        // Gaps inside and across windows, returns to an earlier window,
        // several draws per module, and a stream change: each draw is the
        // one at its position.
        let mut r = Random::new(5);
        let mut m = 0u64;
        for (i, gap) in [0u64, 1, 1, 3, 30, 31, 32, 33, 1, 64, 2, 100, 5]
            .into_iter()
            .enumerate()
        {
            m += gap;
            r.set_module(m);
            for d in 0..(i as u64 % 4) {
                let want = uniform_of(at(5, 0, (d as u128) << 59 | m as u128));
                assert_eq!(r.uniform().unwrap().to_bits(), want.to_bits(), "{m} {d}");
            }
        }
        for m in [3u64, 2, 40, 39] {
            r.set_module(m);
            let want = uniform_of(at(5, 0, m as u128));
            assert_eq!(r.uniform().unwrap().to_bits(), want.to_bits(), "{m}");
        }
        r.start_pass(1, Region::Step);
        r.set_module(39);
        let want = uniform_of(at(5, 1, 39));
        assert_eq!(r.uniform().unwrap().to_bits(), want.to_bits());
        let mut c = Random::for_constants(5);
        for i in 0..100u128 {
            let want = uniform_of(at(5, 0, 2 << 65 | i));
            assert_eq!(c.uniform().unwrap().to_bits(), want.to_bits(), "{i}");
        }
    }

    #[test]
    fn draw_bound() {
        let mut r = Random::new(1);
        r.set_module(9);
        for _ in 0..DRAWS_PER_MODULE {
            r.uniform().unwrap();
        }
        assert_eq!(r.uniform(), Err(TOO_MANY_DRAWS));
        r.set_module(10);
        assert!(r.uniform().is_ok());
    }

    #[test]
    fn uniform_in_range_and_spread() {
        let mut r = Random::new(7);
        let mut sum = 0.0;
        for m in 0..10_000 {
            r.set_module(m);
            let u = r.uniform().unwrap();
            assert!((0.0..1.0).contains(&u));
            sum += u;
        }
        assert!((sum / 10_000.0 - 0.5).abs() < 0.02);
    }

    #[test]
    fn normal_moments() {
        let mut r = Random::new(9);
        let n = 20_000;
        let xs: Vec<f64> = (0..n)
            .map(|m| {
                r.set_module(m);
                r.normal(3.0, 2.0).unwrap()
            })
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!((mean - 3.0).abs() < 0.1, "{mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.1, "{var}");
    }
}
