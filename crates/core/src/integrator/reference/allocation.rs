//! Per-pixel effort where the noise is: how many of a reference's samples each pixel gets.
//!
//! A pilot traces [`PILOT_SAMPLES`] paths per pixel from random streams of their own
//! ([`Domain::ReferencePilot`]), measures each pixel's variance per sample `v` (of the
//! total, channels averaged) and its cost per sample `c` (work units the tracer counts:
//! eye rays, vertices and shadow rays, so the allocation does not depend on the machine or
//! the thread count), smooths both over a small window, and gives pixel `i` the share
//! `w ∝ √(v / c)` of the samples: the allocation that minimises the image's mean squared
//! error for a given cost (`Σ v/n` subject to `Σ c·n` fixed). The shares are scaled so
//! that a pass costs what a pass of one sample per pixel would (`Σ w·c = Σ c`).
//!
//! The estimate stays unbiased: the pilot's samples are not part of it, so how many
//! samples a pixel gets does not depend on the samples it averages. After `P` passes pixel
//! `i` holds `n_i(P) = max(⌊w_i·P⌋, min(P, 2))` samples — a function of `P` alone, so a
//! reference refined pass by pass holds the same samples as one rendered whole — and its
//! variance of the mean is its own `m2 / (n_i (n_i − 1))`.

use glam::Vec3;
use rayon::prelude::*;

use super::PathSample;
use crate::math::{Domain, Rng};
use crate::scene::Scene;

/// Pilot samples per pixel.
pub(super) const PILOT_SAMPLES: u32 = 8;
/// Every pixel keeps at least this many samples (once that many passes ran), so its
/// variance is known.
const MIN_SAMPLES: u32 = 2;
/// The smallest and largest share of a pixel (shares average 1 by cost).
const MIN_SHARE: f32 = 0.05;
const MAX_SHARE: f32 = 64.0;
/// Half the width of the window the pilot's variance and cost are averaged over.
const SMOOTHING_RADIUS: usize = 2;

/// Each pixel's share of the samples.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Allocation {
    shares: Vec<f32>,
}

impl Allocation {
    /// An allocation from stored shares.
    pub(super) fn from_shares(shares: Vec<f32>) -> Self {
        Allocation { shares }
    }

    /// The shares, pixel by pixel.
    pub(super) fn shares(&self) -> &[f32] {
        &self.shares
    }

    /// Samples pixel `i` holds after `passes` passes.
    #[inline]
    pub(super) fn samples(&self, i: usize, passes: u32) -> u32 {
        let n = (f64::from(self.shares[i]) * f64::from(passes)).floor() as u32;
        n.max(passes.min(MIN_SAMPLES))
    }

    /// Runs the pilot over `width × height` pixels, tracing with `trace(pixel, rng)`.
    pub(super) fn from_pilot<F>(scene: &Scene, width: usize, height: usize, trace: F) -> Self
    where
        F: Fn(usize, &mut Rng) -> PathSample + Sync,
    {
        let seed = scene.integrator().seed;
        let (variance, cost): (Vec<f32>, Vec<f32>) = (0..width * height)
            .into_par_iter()
            .map(|pixel| {
                let (mut mean, mut m2, mut work) = (0.0f64, 0.0f64, 0.0f64);
                for k in 0..PILOT_SAMPLES {
                    let mut rng =
                        Rng::stream2(seed, Domain::ReferencePilot, pixel as u64, k as u64);
                    let s = trace(pixel, &mut rng);
                    let v = mean3(s.single + s.multiple + s.emission);
                    let delta = v - mean;
                    mean += delta / f64::from(k + 1);
                    m2 += delta * (v - mean);
                    work += f64::from(s.work);
                }
                let n = f64::from(PILOT_SAMPLES);
                ((m2 / (n - 1.0)) as f32, (work / n).max(1.0) as f32)
            })
            .unzip();
        let variance = smooth(&variance, width, height);
        let cost = smooth(&cost, width, height);
        Allocation {
            shares: shares(&variance, &cost),
        }
    }
}

/// `w ∝ √(v / c)`, scaled so that `Σ w·c = Σ c`, within [`MIN_SHARE`, `MAX_SHARE`].
fn shares(variance: &[f32], cost: &[f32]) -> Vec<f32> {
    let raw: Vec<f64> = variance
        .iter()
        .zip(cost)
        .map(|(v, c)| (f64::from(*v) / f64::from(*c)).sqrt())
        .collect();
    let total_cost: f64 = cost.iter().map(|c| f64::from(*c)).sum();
    let spent: f64 = raw.iter().zip(cost).map(|(w, c)| w * f64::from(*c)).sum();
    if !(spent > 0.0 && spent.is_finite()) {
        // No noise anywhere (or none measured): one sample per pixel per pass.
        return vec![1.0; variance.len()];
    }
    let scale = total_cost / spent;
    raw.iter()
        .map(|w| ((w * scale) as f32).clamp(MIN_SHARE, MAX_SHARE))
        .collect()
}

/// A box average over `(2 r + 1)²` pixels (clipped at the edges), rows then columns.
fn smooth(values: &[f32], width: usize, height: usize) -> Vec<f32> {
    let r = SMOOTHING_RADIUS;
    let pass = |src: &[f32], stride: usize, len: usize, lines: usize, step: usize| {
        let mut out = vec![0.0f32; src.len()];
        for line in 0..lines {
            let base = line * step;
            for i in 0..len {
                let (lo, hi) = (i.saturating_sub(r), (i + r).min(len - 1));
                let sum: f32 = (lo..=hi).map(|j| src[base + j * stride]).sum();
                out[base + i * stride] = sum / (hi - lo + 1) as f32;
            }
        }
        out
    };
    let rows = pass(values, 1, width, height, width);
    pass(&rows, width, height, width, 1)
}

fn mean3(v: Vec3) -> f64 {
    (f64::from(v.x) + f64::from(v.y) + f64::from(v.z)) / 3.0
}
