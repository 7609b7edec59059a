//! cpfg's two random generators (issue 12), written from the POSIX
//! description of the `drand48` family (not from a C library's code):
//! a 48-bit linear congruential generator X' = (a X + c) mod 2^48 with
//! a = 0x5DEECE66D and c = 0xB, whose value is X' / 2^48.
//!
//! - The **choice generator** is `drand48()`'s global state. Interactive
//!   cpfg calls `seed48({seed, 0, 155})` when the file's `seed:` is
//!   non-zero (`control.c`); otherwise it starts from glibc's unseeded
//!   state, X = 0. Every module of the string draws once per step, in
//!   string order (README, "Coming from cpfg"); the step engine reports
//!   module indices and this generator jumps over the modules that did not
//!   ask (an LCG can jump n draws in O(log n)).
//! - The **function generator** is `main_xsubi` of `utility.c`, read by
//!   `erand48`: `ran`, `nran`, `bran`, `biran`. It starts as
//!   {0x330E, 0, 0} and `srand(x)` sets {0x330E, x & 0xFFFF, x >> 16}; the
//!   file's `seed:` does not touch it.

use crate::diag::RandomError;

/// The multiplier, increment and modulus mask of the 48-bit LCG.
const A: u64 = 0x5_DEEC_E66D;
const C: u64 = 0xB;
const MASK: u64 = (1 << 48) - 1;

/// One drand48-family state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rand48 {
    x: u64,
}

impl Rand48 {
    /// The state with X = `x` (mod 2^48).
    pub fn new(x: u64) -> Rand48 {
        Rand48 { x: x & MASK }
    }

    /// The state an `unsigned short xsubi[3]` describes (low word first),
    /// as `seed48` and `erand48` read it.
    pub fn from_xsubi(x0: u16, x1: u16, x2: u16) -> Rand48 {
        Rand48::new(u64::from(x2) << 32 | u64::from(x1) << 16 | u64::from(x0))
    }

    /// The raw state.
    pub fn state(&self) -> u64 {
        self.x
    }

    /// Advance once and return X' / 2^48, in [0, 1).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        self.x = (A.wrapping_mul(self.x).wrapping_add(C)) & MASK;
        self.x as f64 / (1u64 << 48) as f64
    }

    /// Advance `n` draws at once: X_n = A^n X + C (A^n - 1)/(A - 1), by
    /// squaring (the affine map x -> a x + c composed with itself).
    pub fn jump(&mut self, mut n: u64) {
        // (mul, add) of the map applied so far, and of the current power.
        let (mut am, mut ac) = (1u64, 0u64);
        let (mut pm, mut pc) = (A, C);
        while n > 0 {
            if n & 1 == 1 {
                am = am.wrapping_mul(pm) & MASK;
                ac = (ac.wrapping_mul(pm).wrapping_add(pc)) & MASK;
            }
            pc = (pc.wrapping_mul(pm).wrapping_add(pc)) & MASK;
            pm = pm.wrapping_mul(pm) & MASK;
            n >>= 1;
        }
        self.x = (am.wrapping_mul(self.x).wrapping_add(ac)) & MASK;
    }
}

/// `SelectProd` of cpfg's `generate.c`: `u` is one `drand48()` draw; the
/// applicable productions' `weights` in file order (already 32-bit
/// floats). `totalprob * u` is a `float`; each weight is subtracted in
/// turn and the first production where the remainder is `<= 0` wins, so a
/// lone applicable production of weight 0 still wins. Negative weights
/// count as they are (cpfg checks none): they lower the total and raise
/// the remainder. `None`: the remainder is still above 0 after the last
/// one (rounding, or negative weights; cpfg then copies the module).
pub fn select(weights: impl Iterator<Item = f32> + Clone, u: f64) -> Option<usize> {
    let total = weights.clone().fold(0f32, |t, w| t + w);
    let mut r = (f64::from(total) * u) as f32;
    for (i, w) in weights.enumerate() {
        r -= w;
        if r <= 0.0 {
            return Some(i);
        }
    }
    None
}

/// Most rounds `bran` tries before giving up (cpfg loops forever on
/// parameters such as `bran(0, 1)`).
pub const BRAN_ROUNDS: u32 = 1_000_000;
/// Largest `n` of `biran(n, p)` (one draw per trial).
pub const BIRAN_MAX: f64 = 16_777_216.0;

/// cpfg's generators and where the choice generator stands.
#[derive(Clone, Debug)]
pub struct CpfgRandom {
    /// `drand48()`'s state, at draw number `main_at` of the run.
    main: Rand48,
    main_at: u64,
    /// Draw number of the current pass's module 0, and how many modules of
    /// the pass drew nothing (the cut part, the later modules of a
    /// multi-module predecessor).
    pass_base: u64,
    skipped: u64,
    /// `main_xsubi` and `nrand`'s state (`iset` starts at 10, so the first
    /// `nran` before any `srand` returns its mean; `gset` is kept by
    /// `srand`).
    xsubi: Rand48,
    iset: i32,
    gset: f64,
    /// Whether the choice is stochastic (`seed:` given).
    pub stochastic: bool,
    /// The homomorphism's own function generator while it runs, and
    /// whether it is the one in `xsubi` now (swapped).
    hom: Option<(Rand48, bool)>,
}

impl CpfgRandom {
    /// The generators of a run of a file with `seed:` (`None`: no
    /// `seed:`, the system is not stochastic).
    pub fn new(seed: Option<u64>) -> CpfgRandom {
        let main = match seed {
            // seed48({seed, 0, 155}): an unsigned short takes the low 16
            // bits of the seed.
            Some(s) if s != 0 => Rand48::from_xsubi(s as u16, 0, 155),
            _ => Rand48::new(0),
        };
        CpfgRandom {
            main,
            main_at: 0,
            pass_base: 0,
            skipped: 0,
            xsubi: Rand48::from_xsubi(0x330E, 0, 0),
            iset: 10,
            gset: 0.0,
            stochastic: seed.is_some(),
            hom: None,
        }
    }

    /// A step starts; the previous one had `modules` modules in its input,
    /// of which `skipped` drew nothing. Call with the counts of the pass
    /// that ends (0, 0 before the first step).
    pub fn end_pass(&mut self, modules: u64) {
        self.pass_base += modules - self.skipped.min(modules);
        self.skipped = 0;
    }

    /// `n` modules of the current pass draw nothing.
    pub fn skip_modules(&mut self, n: u64) {
        self.skipped += n;
    }

    /// The draw of the module at `index` of the current pass (in string
    /// order: indices never go back within a pass).
    pub fn choice(&mut self, index: u64) -> f64 {
        let at = self.pass_base + index - self.skipped.min(index);
        debug_assert!(at >= self.main_at, "draws go back: {at} < {}", self.main_at);
        self.main.jump(at.saturating_sub(self.main_at));
        self.main_at = at + 1;
        self.main.next_f64()
    }

    /// `srand(x)`: {0x330E, x & 0xFFFF, (x >> 16) & 0xFFFF}.
    pub fn srand(&mut self, x: i64) {
        self.xsubi = Rand48::from_xsubi(0x330E, x as u16, (x >> 16) as u16);
        self.iset = 0;
    }

    /// The homomorphism's `seed:` (interpret.c): a second function
    /// generator, seeded as `srand(seed)` seeds it, that takes over while
    /// an applied homomorphism production's successor is evaluated (and
    /// what it rewrites further), while the top level's conditions still
    /// read the first one. [`CpfgRandom::hom_successor`] and
    /// [`CpfgRandom::hom_condition`] switch; `end_homomorphism` ends it.
    pub fn begin_homomorphism(&mut self, seed: u64) {
        self.end_homomorphism();
        self.hom = Some((
            Rand48::from_xsubi(0x330E, seed as u16, (seed >> 16) as u16),
            false,
        ));
    }

    /// Back to the first function generator for good.
    pub fn end_homomorphism(&mut self) {
        self.hom_condition();
        self.hom = None;
    }

    /// A top-level homomorphism production applies: its post-condition
    /// block and successor draw from the homomorphism's generator.
    #[inline]
    pub fn hom_successor(&mut self) {
        if let Some((x, active @ false)) = &mut self.hom {
            std::mem::swap(&mut self.xsubi, x);
            *active = true;
        }
    }

    /// The top level tries a module's homomorphism productions: their
    /// pre-condition blocks and conditions draw from the first generator.
    #[inline]
    pub fn hom_condition(&mut self) {
        if let Some((x, active @ true)) = &mut self.hom {
            std::mem::swap(&mut self.xsubi, x);
            *active = false;
        }
    }

    /// `ran(v)`: `erand48(main_xsubi) * v`.
    pub fn ran(&mut self, v: f64) -> f64 {
        self.xsubi.next_f64() * v
    }

    /// `nran(mean, sd)`: the polar method of `utility.c`'s `nrand`, which
    /// keeps the second deviate for the next call.
    pub fn nran(&mut self, mean: f64, sd: f64) -> f64 {
        if self.iset == 0 {
            let (v1, v2, rsq) = loop {
                let v1 = 2.0 * self.xsubi.next_f64() - 1.0;
                let v2 = 2.0 * self.xsubi.next_f64() - 1.0;
                let rsq = v1 * v1 + v2 * v2;
                if rsq < 1.0 && rsq != 0.0 {
                    break (v1, v2, rsq);
                }
            };
            let fac = (-2.0 * rsq.ln() / rsq).sqrt();
            self.gset = v1 * fac;
            self.iset = 1;
            v2 * fac * sd + mean
        } else {
            self.iset = 0;
            self.gset * sd + mean
        }
    }

    /// `bran(a, b)`: a beta deviate by `utility.c`'s `brand` (Cheng's
    /// method). An error message when it finds nothing in
    /// [`BRAN_ROUNDS`] rounds.
    pub fn bran(&mut self, a: f64, b: f64) -> Result<f64, RandomError> {
        let s = a + b;
        let lambda = if a.min(b) <= 1.0 {
            a.min(b)
        } else {
            ((2.0 * a * b - s) / (s - 2.0)).sqrt()
        };
        let u = a + lambda;
        for _ in 0..BRAN_ROUNDS {
            let u1 = self.nonzero();
            let u2 = self.nonzero();
            let v = (1.0 / lambda) * (u1 / (1.0 - u1)).ln();
            let ym = a * v.exp();
            // cpfg loops while the test is `<`: a NaN ends the loop too.
            let lhs = s * (s / (b + ym)).ln() + u * v - 4f64.ln();
            if lhs.partial_cmp(&(u1 * u1 * u2).ln()) != Some(std::cmp::Ordering::Less) {
                return Ok(ym / (b + ym));
            }
        }
        Err(RandomError::BranNoValue)
    }

    fn nonzero(&mut self) -> f64 {
        loop {
            let u = self.xsubi.next_f64();
            if u != 0.0 {
                return u;
            }
        }
    }

    /// `biran(n, p)`: the number of n draws that are `<= p` (`n` already
    /// converted to an integer as C's `(int)` does).
    pub fn biran(&mut self, n: f64, p: f64) -> Result<f64, RandomError> {
        if n > BIRAN_MAX {
            return Err(RandomError::BiranTooManyTrials);
        }
        if n.is_nan() || n <= -2_147_483_649.0 {
            return Err(RandomError::BiranTrialsUndefined);
        }
        let mut j = 0u32;
        for _ in 0..(n.max(0.0) as u32) {
            if self.xsubi.next_f64() <= p {
                j += 1;
            }
        }
        Ok(f64::from(j))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Values from tests/tools/cpfg_ref.py's self-test (printed once by
    // glibc's drand48 / erand48).
    #[test]
    fn drand48_matches_glibc() {
        let mut r = Rand48::new(0);
        assert_eq!(r.next_f64(), 11.0 / (1u64 << 48) as f64);
        assert_eq!(r.next_f64(), 0.0009853946746503084);
        assert_eq!(Rand48::from_xsubi(7, 0, 155).state(), 155 << 32 | 7);
        let mut c = CpfgRandom::new(Some(7));
        assert_eq!(c.choice(0), 0.5162368105493655);
        assert_eq!(c.choice(1), 0.4207841637977232);
        let mut c = CpfgRandom::new(Some(0));
        assert!(c.stochastic);
        assert_eq!(c.choice(0), 3.907985046680551e-14);
        let mut f = CpfgRandom::new(None);
        assert!(!f.stochastic);
        assert_eq!(f.ran(1.0), 0.17082803610628972);
        assert_eq!(f.ran(1.0), 0.7499019804849638);
        f.srand(42);
        assert_eq!(f.ran(1.0), 0.7445250000610066);
    }

    #[test]
    fn seeds_keep_16_bits() {
        let mut a = CpfgRandom::new(Some(7 + 65536 * 3));
        let mut b = CpfgRandom::new(Some(7));
        assert_eq!(a.choice(0), b.choice(0));
        // A multiple of 65536 seeds X = 155 << 32, not glibc's X = 0.
        let a = CpfgRandom::new(Some(65536));
        assert_eq!(a.main.state(), 155 << 32);
    }

    #[test]
    fn jumps_equal_single_steps() {
        for n in [0u64, 1, 2, 3, 7, 64, 1000, 123_456_789] {
            let mut a = Rand48::new(0x1234_5678_9ABC);
            let mut b = a;
            a.jump(n);
            for _ in 0..n.min(1000) {
                b.next_f64();
            }
            if n <= 1000 {
                assert_eq!(a, b, "{n}");
            }
        }
        // Jumps compose: 123456789 = 123456000 + 789.
        let mut a = Rand48::new(5);
        let mut b = a;
        a.jump(123_456_789);
        b.jump(123_456_000);
        b.jump(789);
        assert_eq!(a, b);
    }

    #[test]
    fn one_draw_per_module_in_string_order() {
        // Modules 0..5 in pass 1, 2 of them cut; 3 modules in pass 2.
        let mut seq = Rand48::from_xsubi(9, 0, 155);
        let want: Vec<f64> = (0..6).map(|_| seq.next_f64()).collect();
        let mut c = CpfgRandom::new(Some(9));
        c.end_pass(0);
        assert_eq!(c.choice(1), want[1]); // module 0 drew without asking
        c.skip_modules(2); // modules 2 and 3 are cut
        assert_eq!(c.choice(4), want[2]);
        c.end_pass(5);
        assert_eq!(c.choice(2), want[5]);
    }

    #[test]
    fn select_prod() {
        let w = [1f32, 2.0, 1.0];
        assert_eq!(select(w.iter().copied(), 0.0), Some(0));
        assert_eq!(select(w.iter().copied(), 0.25), Some(0)); // 1 - 1 <= 0
        assert_eq!(select(w.iter().copied(), 0.26), Some(1));
        assert_eq!(select(w.iter().copied(), 0.99), Some(2));
        // A lone production of weight 0 wins; a leading one only at u = 0.
        assert_eq!(select([0f32].into_iter(), 0.7), Some(0));
        assert_eq!(select([0f32, 1.0].into_iter(), 0.7), Some(1));
        assert_eq!(select([0f32, 1.0].into_iter(), 0.0), Some(0));
        assert_eq!(select(std::iter::empty(), 0.5), None);
        // Negative weights: total 3, r = 3u; 1 wins up to u = 1/3, then the
        // -1 raises r and 3 wins; a lone negative weight never does.
        let w = [1f32, -1.0, 3.0];
        assert_eq!(select(w.iter().copied(), 0.3), Some(0));
        assert_eq!(select(w.iter().copied(), 0.34), Some(2));
        assert_eq!(select([-2f32].into_iter(), 0.5), None);
        assert_eq!(select([-1f32, 1.0].into_iter(), 0.9), Some(1));
    }

    #[test]
    fn nran_starts_with_its_mean_then_polar_pairs() {
        let mut c = CpfgRandom::new(None);
        assert_eq!(c.nran(5.0, 2.0), 5.0);
        // The polar method by hand from the same xsubi sequence.
        let mut x = Rand48::from_xsubi(0x330E, 0, 0);
        let (v1, v2, rsq) = loop {
            let v1 = 2.0 * x.next_f64() - 1.0;
            let v2 = 2.0 * x.next_f64() - 1.0;
            let rsq = v1 * v1 + v2 * v2;
            if rsq < 1.0 && rsq != 0.0 {
                break (v1, v2, rsq);
            }
        };
        let fac = (-2.0 * rsq.ln() / rsq).sqrt();
        // iset was 10: the first call set it to 0 and returned gset = 0.
        assert_eq!(c.nran(0.0, 1.0), v2 * fac);
        assert_eq!(c.nran(1.0, 2.0), v1 * fac * 2.0 + 1.0);
        c.srand(3);
        assert_ne!(c.nran(0.0, 1.0), 0.0);
    }

    #[test]
    fn bran_and_biran() {
        let mut c = CpfgRandom::new(None);
        for _ in 0..100 {
            let v = c.bran(2.0, 3.0).unwrap();
            assert!((0.0..=1.0).contains(&v), "{v}");
        }
        assert_eq!(c.biran(10.0, 1.0).unwrap(), 10.0);
        assert_eq!(c.biran(10.0, -1.0).unwrap(), 0.0);
        assert!(c.biran(1e9, 0.5).is_err());
        // (int) of NaN is undefined in C.
        assert_eq!(
            c.biran(f64::NAN, 0.5),
            Err(RandomError::BiranTrialsUndefined)
        );
        // biran draws exactly n times.
        let mut a = CpfgRandom::new(None);
        let mut b = CpfgRandom::new(None);
        a.biran(5.0, 0.5).unwrap();
        for _ in 0..5 {
            b.ran(1.0);
        }
        assert_eq!(a.ran(1.0), b.ran(1.0));
    }
}
