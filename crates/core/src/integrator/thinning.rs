//! Thinning by eye transmittance: where little of a sample's light can reach the eye, its
//! light and photon-map evaluations are spaced out and interpolated.
//!
//! A sample's source term enters the pixel weighted by the eye transmittance before it
//! (eq. 3). Behind an opaque structure that weight falls geometrically: in the thesis's
//! bone (σt ≈ 28–80 per unit, step 0.0005) an eye ray spends about half its samples below
//! transmittance 0.1 and a third below 0.01, where an error in a source term reaches the
//! pixel scaled by that small weight. With `thin_below = c`, the samples whose eye
//! transmittance is below `c` fall into bands `[c/2^b, c/2^(b−1))`, `b = 1 … BANDS` (the
//! last band reaches down to `termination`), and in band `b`:
//!
//! * the photon-map estimate is gathered at every `2^(b+1)`-th sample and at each such
//!   interval's midpoint (so at most [`KNOT_VOXELS`] voxels apart, whatever the step), and
//!   is linear in between where the midpoint agrees with the line, else gathered closer
//!   ([`super::estimate_track`]) — σt and the albedo stay each sample's own;
//! * the optical depth to each light is filled with `2^b` times the scene's
//!   `shadow_stride` and the scene's `shadow_tolerance` divided by the band's largest eye
//!   transmittance, `c / 2^(b−1)` ([`super::adaptive_fill`]): an optical-depth error δτ
//!   reaches the pixel scaled by the eye transmittance, so no band may add more than the
//!   front.
//!
//! The spacing thus grows as the weight shrinks, so each band's share of the error stays
//! about the same. Every band boundary is an exact evaluation. The samples in front of the
//! first band (eye transmittance ≥ `c`) are evaluated exactly as without thinning, so
//! `thin_below = 0` renders the same image to the bit.
//!
//! This is the route "skip light evaluations where eye transmittance makes them
//! irrelevant" of the fast-and-exact issue; `sweep bench` measures its bias and 99th
//! percentile against the uncached marcher on the thesis's headline frame, and every
//! render measures it on its own pixels ([`ThinningError`], by the error probes of
//! [`super::error_probes`]).

use serde::{Deserialize, Serialize};

use super::error_bound::ErrorBound;
use super::sample::RaySample;

/// The largest distance between two gathers, in voxels (the smallest voxel extent). It
/// depends on the medium and the step only, which every variant of a march shares, so an
/// estimate does not depend on which variants are rendered together. Gather spheres span
/// 7–25 voxels on the thesis's foot, so the sphere moves by a fraction of its radius.
pub(super) const KNOT_VOXELS: f32 = 4.0;

/// Number of bands: below `c / 2^(BANDS − 1)` the spacing stops growing.
pub(super) const BANDS: usize = 5;

/// The bands of one eye ray's samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Bands {
    /// `starts[b − 1]` is the first sample of band `b`; `starts[BANDS]` is the sample count.
    starts: [usize; BANDS + 1],
    /// `thin_below`: band `b`'s samples have eye transmittance below `c / 2^(b−1)`.
    c: f32,
}

impl Bands {
    /// The bands of `samples` for `thin_below = c` (`c = 0`: none, every sample in front).
    pub(super) fn new(samples: &[RaySample], c: f32) -> Self {
        let n = samples.len();
        let mut starts = [n; BANDS + 1];
        if c > 0.0 {
            for (b, start) in starts[..BANDS].iter_mut().enumerate() {
                // Eye transmittance before a sample is exp(−tau_start), monotone along the
                // ray, so each band is a contiguous run.
                let tau = -(c / (1u32 << b) as f32).ln();
                *start = samples.partition_point(|s| s.tau_start <= tau);
            }
        }
        Bands { starts, c }
    }

    /// The last sample evaluated as in front: the first thinned sample (the start of band
    /// 1, itself exact), or the last sample when none is thinned (0 without samples).
    pub(super) fn last_in_front(&self) -> usize {
        self.starts[0].min(self.starts[BANDS].saturating_sub(1))
    }

    /// The band of sample `i`: 0 in front, else `1 ..= BANDS`.
    pub(super) fn band_of(&self, i: usize) -> usize {
        self.starts[..BANDS].partition_point(|&s| s <= i)
    }

    /// The last sample of band `b ≥ 1` that is also exact: the first sample of the next band
    /// (or the last sample).
    pub(super) fn band_end(&self, b: usize) -> usize {
        let n = self.starts[BANDS];
        self.starts
            .get(b)
            .copied()
            .unwrap_or(n)
            .min(n.saturating_sub(1))
    }

    /// The factor on the front's shadow tolerance in band `b ≥ 1`: `2^(b−1) / c`, the inverse
    /// of the band's largest eye transmittance. An optical-depth error δτ at a sample
    /// changes the pixel by about its eye transmittance times δτ (relative to the sample's
    /// source term), so each band may add at most what the front adds.
    pub(super) fn shadow_tolerance_factor(&self, b: usize) -> f32 {
        (1u32 << (b - 1)) as f32 / self.c
    }

    /// The first sample of band `b ≥ 1`.
    pub(super) fn band_start(&self, b: usize) -> usize {
        self.starts[b - 1]
    }

    /// The gather intervals behind the front where the estimate is smooth, `(a, b)`: the
    /// first `a` is the last sample gathered in front, each `b` is gathered, and so is the
    /// midpoint of each interval longer than 2 (the check, [`super::adaptive_fill`]);
    /// spacing [`gather_stride`], ending at every band's end.
    pub(super) fn knots(&self, cap: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        let n = self.starts[BANDS];
        let mut a = self.last_in_front();
        std::iter::from_fn(move || {
            if a + 1 >= n {
                return None;
            }
            let band = self.band_of(a + 1);
            let b = (a + gather_stride(band, cap)).min(self.band_end(band));
            let interval = (a, b);
            a = b;
            Some(interval)
        })
    }

    /// The gathers an eye ray with these bands makes per map where the estimate is smooth
    /// (where a midpoint disagrees its interval is halved and takes more).
    pub(super) fn gathers(&self, cap: usize) -> usize {
        if self.starts[BANDS] == 0 {
            return 0;
        }
        // Every sample up to the first thinned one, then each knot and checked midpoint.
        let knots: usize = self
            .knots(cap)
            .map(|(a, b)| if b - a >= 2 { 2 } else { 1 })
            .sum();
        self.last_in_front() + 1 + knots
    }
}

/// The largest gather spacing in samples: [`KNOT_VOXELS`] voxels of extent `voxel`.
pub(super) fn knot_cap(voxel: f32, stepsize: f32) -> usize {
    (KNOT_VOXELS * voxel / stepsize).floor().max(1.0) as usize
}

/// The gather interval in band `b`, in samples: `2^(b+1)`, at most `2 · cap`. Its midpoint
/// is gathered too (the check), so where the estimate is smooth the gathers are `2^b`
/// samples apart and never more than `cap`.
pub(super) fn gather_stride(b: usize, cap: usize) -> usize {
    (2usize << b).min(2 * cap)
}

/// What thinning by eye transmittance was measured to err by: the radiance of a regular
/// 32 × 32 subset of pixels (one eye ray each) as the render evaluated them against the
/// same rays with every sample evaluated (a gather and an exact optical depth at each:
/// no thinning and no `shadow_stride` interpolation), layer by layer. It is the whole
/// interpolation error of the render, not thinning's share of it: against the stride's
/// fill alone, a thinned and an unthinned render differ where the fills pick different
/// knots, and at σt(d_min) 290 on the engine (a mean free path per voxel) that difference
/// was the stride's error, not thinning's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThinningError {
    /// The eye transmittance below which the render thinned.
    pub thin_below: f32,
    /// Probe pixels.
    pub pixels: usize,
    /// The single-scattering layer (`None` when it is off or dark at every probe).
    pub single: Option<ErrorBound>,
    /// The variant's multiple-scattering layer.
    pub multiple: Option<ErrorBound>,
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn samples(taus: &[f32]) -> Vec<RaySample> {
        taus.iter()
            .map(|&tau_start| RaySample {
                x: Vec3::ZERO,
                sigma_t: 1.0,
                weight: 1.0,
                t_start: 0.0,
                width: 1.0,
                tau_start,
            })
            .collect()
    }

    #[test]
    fn bands_follow_the_eye_transmittance_in_halvings_below_the_threshold() {
        // Eye transmittance before each sample: 1, 0.6, 0.45, 0.3, 0.2, 0.1, 0.05, 0.001.
        let t = [1.0f32, 0.6, 0.45, 0.3, 0.2, 0.1, 0.05, 0.001];
        let taus: Vec<f32> = t.iter().map(|t| -t.ln()).collect();
        let bands = Bands::new(&samples(&taus), 0.5);
        // Bands: [0.25, 0.5) → 1, [0.125, 0.25) → 2, [0.0625, 0.125) → 3, [1/32, 1/16) → 4,
        // below 1/32 → 5.
        let of: Vec<usize> = (0..t.len()).map(|i| bands.band_of(i)).collect();
        assert_eq!(of, [0, 0, 1, 1, 2, 3, 4, 5]);
        assert_eq!(bands.last_in_front(), 2);
        assert_eq!((bands.band_start(1), bands.band_end(1)), (2, 4));
        assert_eq!((bands.band_start(5), bands.band_end(5)), (7, 7));
    }

    #[test]
    fn a_bands_shadow_tolerance_times_its_largest_eye_transmittance_is_the_fronts() {
        let t = samples(&[0.0; 4]);
        for c in [0.1, 0.5, 0.9, 1.0] {
            let bands = Bands::new(&t, c);
            for b in 1..=BANDS {
                let largest = c / (1u32 << (b - 1)) as f32;
                let budget = bands.shadow_tolerance_factor(b) * largest;
                assert!((budget - 1.0).abs() < 1e-6, "c {c}, band {b}: {budget}");
                assert!(bands.shadow_tolerance_factor(b) >= 1.0, "c {c}, band {b}");
            }
        }
    }

    #[test]
    fn no_threshold_thins_nothing() {
        let bands = Bands::new(&samples(&[0.0, 5.0, 9.0]), 0.0);
        assert_eq!(bands.last_in_front(), 2, "the last sample");
        assert!((0..3).all(|i| bands.band_of(i) == 0));
        assert_eq!(bands.knots(8).count(), 0);
        assert_eq!(bands.gathers(8), 3);
    }

    #[test]
    fn gather_intervals_double_per_band_and_end_on_band_ends() {
        // 4 samples in front (transmittance ≥ 0.5), then 8 in each band 1…5 by halving.
        let mut taus = vec![0.0f32; 4];
        for b in 1..=5 {
            let t = 0.5 / (1u32 << (b - 1)) as f32 * 0.99;
            taus.extend(std::iter::repeat_n(-t.ln(), 8));
        }
        let bands = Bands::new(&samples(&taus), 0.5);
        let knots: Vec<(usize, usize)> = bands.knots(31).collect();
        // Band 1 = samples 4..12 (intervals of 4), band 2 = 12..20 (8), bands 3 … 5 (16, 32,
        // 64) cut at their ends, band 5 at the last sample.
        assert_eq!(
            knots,
            [(4, 8), (8, 12), (12, 20), (20, 28), (28, 36), (36, 43)]
        );
        // Samples 0..=4 in front, then a knot and a checked midpoint per interval.
        assert_eq!(bands.gathers(31), 5 + 2 * 6);
        // At most 2 samples between gathers: intervals of 4.
        let cap2: Vec<(usize, usize)> = bands.knots(2).skip(2).take(2).collect();
        assert_eq!(cap2, [(12, 16), (16, 20)]);
    }

    #[test]
    fn the_gather_interval_doubles_per_band_up_to_twice_its_length_cap() {
        // The foot: voxels of 1/256, step 0.0005 → gathers at most 31 samples apart, so
        // intervals (a knot and its checked midpoint) of at most 62.
        let cap = knot_cap(1.0 / 256.0, 0.0005);
        assert_eq!(cap, 31);
        assert_eq!(gather_stride(1, cap), 4);
        assert_eq!(gather_stride(4, cap), 32);
        assert_eq!(gather_stride(5, cap), 62);
        // A coarse step: 4 voxels are 3 steps of 0.005.
        assert_eq!(gather_stride(5, knot_cap(1.0 / 256.0, 0.005)), 6);
        // A step longer than the cap: intervals of 2, so every sample is gathered.
        assert_eq!(gather_stride(3, knot_cap(0.001, 0.01)), 2);
    }
}
