//! The optical depth from an eye ray's samples to one light, filled along the ray by the
//! adaptive fill ([`super::adaptive_fill`]) in front and, spaced out by band, behind it
//! ([`super::thinning`]): the shadow counterpart of [`super::estimate_track`]. The eye ray
//! ([`super::eye_ray`]) turns the depths into transmittances for single scattering.

use super::adaptive_fill::{Track, fill_adaptive, fill_span, fraction};
use super::marcher::Marcher;
use super::sample::RaySample;
use super::thinning::{BANDS, Bands};
use crate::medium::{DepthCap, ShadowSegment, blocked_depth};
use crate::scene::Light;

/// The optical depth from each sample to one light, capped just above the blocking depth
/// (samples outside a spot light's cone count as blocked, so the cone's edge is refined).
pub(super) struct ShadowTrack<'a> {
    pub(super) marcher: &'a Marcher<'a>,
    pub(super) light: &'a Light,
    pub(super) samples: &'a [RaySample],
    pub(super) tau: &'a mut [f32],
    /// The largest optical-depth difference at a checked midpoint that still interpolates.
    pub(super) tolerance: f32,
}

impl ShadowTrack<'_> {
    /// Fills the optical depth at every sample: in front by `stride` and `shadow_tolerance`,
    /// in thinned band `b` by `2^b` times the stride and the tolerance divided by the band's
    /// largest eye transmittance, `2^(b−1) / thin_below` times it
    /// (module [`super::thinning`]); returns the number of exact evaluations.
    pub(super) fn fill(&mut self, stride: usize, bands: &Bands) -> usize {
        let tolerance = self.tolerance;
        let front = bands.last_in_front() + 1;
        let mut evaluations = fill_adaptive(front, stride, self);
        for b in 1..=BANDS {
            let (start, end) = (bands.band_start(b), bands.band_end(b));
            if start < end {
                self.tolerance = tolerance * bands.shadow_tolerance_factor(b);
                evaluations += fill_span(start, end + 1, stride << b, self);
            }
        }
        self.tolerance = tolerance;
        evaluations
    }
}

impl Track for ShadowTrack<'_> {
    fn evaluate(&mut self, i: usize) {
        let medium = self.marcher.medium;
        let tau_max = self.marcher.shadow_tau_max;
        let blocked = blocked_depth(tau_max);
        let x = self.samples[i].x;
        self.tau[i] = match self.light.incident(x) {
            None => blocked,
            Some(inc) => medium.shadow_depth(
                &ShadowSegment {
                    origin: x,
                    direction: inc.to_light,
                    distance: inc.distance,
                },
                DepthCap::Blocked(tau_max),
            ),
        };
    }

    fn interpolate(&mut self, a: usize, b: usize, i: usize) {
        let f = fraction(a, b, i);
        self.tau[i] = self.tau[a] + (self.tau[b] - self.tau[a]) * f;
    }

    fn agrees(&self, a: usize, b: usize, m: usize) -> bool {
        let f = fraction(a, b, m);
        let predicted = self.tau[a] + (self.tau[b] - self.tau[a]) * f;
        (predicted - self.tau[m]).abs() <= self.tolerance
    }
}
