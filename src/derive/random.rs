//! Seeded randomness: ChaCha8 from rand_chacha, seeded with
//! `ChaCha8Rng::seed_from_u64(seed)`. Every draw is one `next_u64`, so a
//! seed gives the same string on every run and platform.

use rand_chacha::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The generator, its count of draws, and the step number the built-in
/// `step` reads (issue 11).
pub struct Random(ChaCha8Rng, u64, f64);

impl Random {
    pub fn new(seed: u64) -> Random {
        Random(ChaCha8Rng::seed_from_u64(seed), 0, 0.0)
    }

    /// The value of the built-in `step` from now on.
    pub fn set_step(&mut self, step: u64) {
        self.2 = step as f64;
    }

    #[inline]
    pub fn step(&self) -> f64 {
        self.2
    }

    /// The generator of random constants (`ran` in `define:`): the run's
    /// seed on stream 1, apart from the derivation's draws (stream 0).
    pub fn for_constants(seed: u64) -> Random {
        let mut r = ChaCha8Rng::seed_from_u64(seed);
        r.set_stream(1);
        Random(r, 0, 0.0)
    }

    /// How many draws were made so far (a step that made none and left the
    /// string unchanged is a fixed point).
    #[inline]
    pub fn draws(&self) -> u64 {
        self.1
    }

    /// A fresh seed from the operating system's randomness (through the
    /// standard library's hash keys), for runs without `seed:`/`--seed`.
    pub fn fresh_seed() -> u64 {
        use std::hash::{BuildHasher, Hasher};
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        h.finish()
    }

    /// Uniform in [0, 1): the top 53 bits of one draw.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        self.1 += 1;
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Normal deviate by Box-Muller from one draw: the high 32 bits give
    /// u1 in (0, 1], the low 32 bits u2 in [0, 1).
    #[inline]
    pub fn normal(&mut self, mean: f64, sd: f64) -> f64 {
        self.1 += 1;
        let x = self.0.next_u64();
        let u1 = ((x >> 32) as f64 + 1.0) / 4294967296.0;
        let u2 = (x & 0xffff_ffff) as f64 / 4294967296.0;
        let z = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
        mean + sd * z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream() {
        let mut a = Random::new(42);
        let mut b = Random::new(42);
        for _ in 0..100 {
            assert_eq!(a.uniform().to_bits(), b.uniform().to_bits());
        }
    }

    #[test]
    fn uniform_in_range_and_spread() {
        let mut r = Random::new(7);
        let mut sum = 0.0;
        for _ in 0..10_000 {
            let u = r.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u;
        }
        assert!((sum / 10_000.0 - 0.5).abs() < 0.02);
    }

    #[test]
    fn normal_moments() {
        let mut r = Random::new(9);
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| r.normal(3.0, 2.0)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!((mean - 3.0).abs() < 0.1, "{mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.1, "{var}");
    }
}
