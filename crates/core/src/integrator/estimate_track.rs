//! The photon-map estimate of one variant along the thinned samples of an eye ray
//! (module [`super::thinning`]), error-controlled like the shadow fill
//! ([`super::adaptive_fill`]).
//!
//! In thinned band `b` the estimate is gathered at every [`gather_stride`]-th sample and at
//! each interval's midpoint; where the midpoint agrees with the straight line through the
//! interval's ends to within `2^(b−1) ·` [`ESTIMATE_TOLERANCE`] of the largest of the three
//! (per colour channel), the samples between are interpolated, otherwise the interval is
//! halved and checked again. Where the estimate is smooth this costs what fixed spacing
//! without a check cost at half the interval; where it is noisy (few photons per sphere,
//! clumped photons, small `maxdist`) the samples are gathered, and the error of the
//! interpolation stays within the per-pixel bound it is measured against.
//!
//! Each variant of a map group is filled by its own track, so what it interpolates does
//! not depend on which variants share its map; the gathers are shared through
//! [`GatheredEstimates`] (a k-NN gather yields every variant of the group at once).

use glam::Vec3;

use super::adaptive_fill::{Track, fill_span, fraction};
use super::gather::MapGroup;
use super::marcher::Marcher;
use super::sample::{GatheredEstimates, RaySample};
use super::thinning::{BANDS, Bands, gather_stride};
use crate::photon::GatherScratch;

/// The relative difference at a checked midpoint below which the estimate of band 1 is
/// interpolated; band `b` allows `2^(b−1)` times this, as its samples reach the pixel with
/// at most half the weight of the band before.
pub(super) const ESTIMATE_TOLERANCE: f32 = 0.05;

/// One variant's estimate along the thinned samples of an eye ray.
pub(super) struct EstimateTrack<'a, 'm> {
    pub(super) marcher: &'a Marcher<'m>,
    pub(super) group: &'a MapGroup<'m>,
    /// Towards the eye.
    pub(super) wo: Vec3,
    /// Which of the group's variants this track fills.
    pub(super) variant: usize,
    pub(super) samples: &'a [RaySample],
    pub(super) gathered: &'a mut GatheredEstimates,
    pub(super) scratch: &'a mut GatherScratch,
    /// This variant's estimate at each sample, gathered or interpolated; the last sample in
    /// front holds its gathered value on entry.
    pub(super) values: &'a mut [Vec3],
    /// The relative difference at a checked midpoint that still interpolates.
    pub(super) tolerance: f32,
    /// Gathers this track ran (samples gathered for an earlier variant are not counted).
    pub(super) gathers: u64,
}

impl EstimateTrack<'_, '_> {
    /// Fills the thinned samples band by band (module docs); `cap` is the marcher's
    /// largest gather spacing in samples.
    pub(super) fn fill(&mut self, bands: &Bands, cap: usize) {
        for b in 1..=BANDS {
            let (start, end) = (bands.band_start(b), bands.band_end(b));
            if start < end {
                self.tolerance = ESTIMATE_TOLERANCE * (1u32 << (b - 1)) as f32;
                fill_span(start, end + 1, gather_stride(b, cap), self);
            }
        }
    }
}

impl Track for EstimateTrack<'_, '_> {
    fn evaluate(&mut self, i: usize) {
        let nv = self.gathered.variants;
        let at = &mut self.gathered.at[i * nv..(i + 1) * nv];
        if !self.gathered.done[i] {
            let medium = self.marcher.medium;
            if self
                .group
                .estimate(medium, self.samples[i].x, self.wo, self.scratch, at)
            {
                self.gathers += 1;
            }
            self.gathered.done[i] = true;
        }
        self.values[i] = at[self.variant];
    }

    fn interpolate(&mut self, a: usize, b: usize, i: usize) {
        let f = fraction(a, b, i);
        self.values[i] = self.values[a] + (self.values[b] - self.values[a]) * f;
    }

    fn agrees(&self, a: usize, b: usize, m: usize) -> bool {
        let (va, vb, vm) = (self.values[a], self.values[b], self.values[m]);
        let predicted = va + (vb - va) * fraction(a, b, m);
        let scale = va.abs().max(vb.abs()).max(vm.abs());
        (predicted - vm).abs().cmple(scale * self.tolerance).all()
    }
}
