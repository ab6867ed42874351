//! What an eye ray carries through the marching pass: its samples ([`RaySample`], one per
//! marching segment with σt > 0) and its pixel's [`Accumulator`] (the radiance sums, the
//! per-ray scratch of every stage, the row's counters).
//!
//! A leaf: it imports no sibling module, and every stage of the pass (the row loop in
//! [`super::marcher`], the eye ray in [`super::eye_ray`], thinning, the estimate track, the
//! beam estimate, the error probes) imports its types from here.

use glam::Vec3;

use crate::photon::GatherScratch;

/// One marching sample of an eye ray where σt > 0.
#[derive(Debug, Clone, Copy)]
pub(super) struct RaySample {
    pub(super) x: Vec3,
    pub(super) sigma_t: f32,
    /// The segment's quadrature weight times the eye transmittance before it.
    pub(super) weight: f32,
    /// Where the sample's segment begins along the ray, its length, and the eye's optical
    /// depth at its start (σt is constant over the segment in the march's model).
    pub(super) t_start: f32,
    pub(super) width: f32,
    pub(super) tau_start: f32,
}

/// Radiance accumulated for one pixel, plus scratch space and counters of its row.
pub(super) struct Accumulator {
    pub(super) single: Vec3,
    pub(super) emission: Vec3,
    /// Sum and count of the depths where the eye transmittance fell below ½.
    pub(super) depth_sum: f32,
    pub(super) depth_hits: u32,
    pub(super) multiple: Vec<Vec3>,
    pub(super) estimates: Vec<Vec3>,
    /// The estimates gathered behind the front of the current eye ray, and one variant's
    /// estimate at each of its samples (module [`super::estimate_track`]).
    pub(super) gathered: GatheredEstimates,
    pub(super) values: Vec<Vec3>,
    /// One gather scratch per map group (its candidates belong to that group's map).
    pub(super) gather: Vec<GatherScratch>,
    pub(super) counters: RowCounters,
    /// The current eye ray's samples, and per-sample values filled along it.
    pub(super) samples: Vec<RaySample>,
    pub(super) tau: Vec<f32>,
    /// The traversal stack of the beam estimate.
    pub(super) stack: Vec<u32>,
}

impl Accumulator {
    pub(super) fn new(variants: usize, groups: usize, max_group: usize) -> Self {
        Accumulator {
            single: Vec3::ZERO,
            emission: Vec3::ZERO,
            depth_sum: 0.0,
            depth_hits: 0,
            multiple: vec![Vec3::ZERO; variants],
            estimates: vec![Vec3::ZERO; max_group],
            gathered: GatheredEstimates::default(),
            values: Vec::new(),
            gather: vec![GatherScratch::default(); groups],
            counters: RowCounters::default(),
            samples: Vec::new(),
            tau: Vec::new(),
            stack: Vec::new(),
        }
    }

    /// Clears the per-pixel sums (scratch space and counters stay).
    pub(super) fn start_pixel(&mut self) {
        self.single = Vec3::ZERO;
        self.emission = Vec3::ZERO;
        self.depth_sum = 0.0;
        self.depth_hits = 0;
        self.multiple.iter_mut().for_each(|m| *m = Vec3::ZERO);
    }
}

/// What one row's eye rays did, summed into the pass's [`MarchStats`](super::MarchStats).
#[derive(Default)]
pub(super) struct RowCounters {
    pub(super) samples: u64,
    pub(super) shadow: u64,
    pub(super) gathers: u64,
}

/// Every variant's estimate at the samples of one eye ray gathered so far, for one map
/// group (shared by the group's estimate tracks, [`super::estimate_track`], which read
/// and fill its fields; it lives here because the [`Accumulator`] holds it).
#[derive(Debug, Default)]
pub(super) struct GatheredEstimates {
    /// The group's variants (estimates per sample).
    pub(super) variants: usize,
    /// `variants` estimates per sample.
    pub(super) at: Vec<Vec3>,
    /// Whether sample `i` was gathered (its estimates in `at` are valid).
    pub(super) done: Vec<bool>,
}

impl GatheredEstimates {
    /// Starts an eye ray of `n` samples for a group of `variants`; sample `front` is
    /// gathered already, with `estimates`.
    pub(super) fn start(&mut self, n: usize, variants: usize, front: usize, estimates: &[Vec3]) {
        self.variants = variants;
        self.at.clear();
        self.at.resize(n * variants, Vec3::ZERO);
        self.done.clear();
        self.done.resize(n, false);
        self.at[front * variants..(front + 1) * variants].copy_from_slice(estimates);
        self.done[front] = true;
    }
}
