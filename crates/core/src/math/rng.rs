//! Deterministic random streams.
//!
//! Every stream is seeded from `(seed, domain, index)` — e.g. the scene seed, "photons" and
//! the photon's index, or "pixels" and the pixel's index — never from a thread id, so the
//! same seed gives bit-identical results whatever the thread count or scheduling.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Independent purposes that draw random numbers; each gets its own family of streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u64)]
pub enum Domain {
    /// Photon tracing, one stream per emitted photon.
    Photons = 1,
    /// Ray-marching integrator, one stream per pixel (and pass).
    Pixels = 2,
    /// Reference path tracer, one stream per pixel and pass.
    Reference = 3,
    /// Cache construction, one stream per cache cell.
    Cache = 4,
    /// Tests and tools.
    Misc = 5,
    /// The reference path tracer's pilot (per-pixel allocation), one stream per pixel and
    /// sample, apart from the samples the estimate averages.
    ReferencePilot = 6,
    /// Photon planes: the draws a plane adds to its photon's path, one stream per photon.
    Planes = 7,
    /// The reference's variance budget: its rungs and replicates, apart from any reference.
    ReferenceBudget = 8,
}

/// SplitMix64 finaliser: a bijective avalanche mix of 64 bits.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A random stream for one unit of work.
#[derive(Debug, Clone)]
pub struct Rng(Pcg64Mcg);

impl Rng {
    /// The stream for `index` within `domain` under `seed`.
    pub fn stream(seed: u64, domain: Domain, index: u64) -> Self {
        let key = mix64(mix64(mix64(seed) ^ domain as u64) ^ index);
        Rng(Pcg64Mcg::seed_from_u64(key))
    }

    /// The stream for `(index, sub)` within `domain`, e.g. pixel and pass.
    pub fn stream2(seed: u64, domain: Domain, index: u64, sub: u64) -> Self {
        Self::stream(
            mix64(seed ^ mix64(sub.wrapping_add(0x51ED_2701))),
            domain,
            index,
        )
    }

    /// Uniform in `[0, 1)`.
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        self.0.random::<f32>()
    }

    /// Uniform in `(0, 1]`, safe for `−ln ξ`.
    #[inline]
    pub fn uniform_open0(&mut self) -> f32 {
        1.0 - self.uniform()
    }

    /// Two uniforms.
    #[inline]
    pub fn uniform2(&mut self) -> [f32; 2] {
        [self.uniform(), self.uniform()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = {
            let mut r = Rng::stream(7, Domain::Photons, 3);
            (0..4).map(|_| r.uniform()).collect()
        };
        let b: Vec<f32> = {
            let mut r = Rng::stream(7, Domain::Photons, 3);
            (0..4).map(|_| r.uniform()).collect()
        };
        let c: Vec<f32> = {
            let mut r = Rng::stream(7, Domain::Photons, 4);
            (0..4).map(|_| r.uniform()).collect()
        };
        let d: Vec<f32> = {
            let mut r = Rng::stream(7, Domain::Pixels, 3);
            (0..4).map(|_| r.uniform()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
        let mut r = Rng::stream(1, Domain::Misc, 0);
        for _ in 0..10000 {
            let u = r.uniform_open0();
            assert!(u > 0.0 && u <= 1.0);
        }
    }
}
