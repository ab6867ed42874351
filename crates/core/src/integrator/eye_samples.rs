//! The eye samples a pass keeps for later passes. A progressive render's iterations (and
//! the progressive beam estimate's) shoot the same eye rays from the same random streams
//! through the same medium, so their marching samples are the same: the first march
//! records them ([`EyeSamples::Record`]), the later ones shade them again
//! ([`EyeSamples::Replay`]) instead of marching the medium.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use super::sample::RaySample;

/// The most eye samples a pass keeps for later passes (32 bytes each: 4 GiB). A render
/// of more marches every pass again.
const EYE_SAMPLE_CAP: u64 = 1 << 27;

/// What a pass does with the samples of its eye rays.
#[derive(Debug, Clone, Copy)]
pub(super) enum EyeSamples<'a> {
    /// Marches the medium and forgets them.
    March,
    /// Marches the medium and keeps them (up to [`EYE_SAMPLE_CAP`]) for later passes.
    Record,
    /// Takes them from an earlier pass over the same camera, medium, seed and marching
    /// settings: the eye rays' samples do not depend on the photon map or the layers.
    Replay(&'a EyeSampleStore),
}

/// The eye samples of one pass, row by row: what a progressive render's later iterations
/// march again (their eye rays and random streams are the first iteration's).
#[derive(Debug, Default)]
pub(super) struct EyeSampleStore {
    rows: Vec<RowSamples>,
}

impl EyeSampleStore {
    /// The samples of eye ray `ray` (pixel `x`, sample `s`: `x · spp + s`) of row `y`.
    pub(super) fn ray(&self, y: u32, ray: usize) -> &[RaySample] {
        let row = &self.rows[y as usize];
        let start = if ray == 0 {
            0
        } else {
            row.ends[ray - 1] as usize
        };
        &row.samples[start..row.ends[ray] as usize]
    }
}

/// One row's eye samples, its rays' in order; `ends[i]` is where ray `i`'s end.
#[derive(Debug, Default)]
pub(super) struct RowSamples {
    samples: Vec<RaySample>,
    ends: Vec<u32>,
}

impl RowSamples {
    /// Appends the samples of the row's next eye ray.
    pub(super) fn push_ray(&mut self, samples: &[RaySample]) {
        self.samples.extend_from_slice(samples);
        self.ends.push(self.samples.len() as u32);
    }
}

/// Keeps the rows' eye samples up to [`EYE_SAMPLE_CAP`]; past it, none.
pub(super) struct SampleKeeper {
    asked: bool,
    kept: AtomicU64,
    overflowed: AtomicBool,
}

impl SampleKeeper {
    pub(super) fn new(asked: bool) -> Self {
        SampleKeeper {
            asked,
            kept: AtomicU64::new(0),
            overflowed: Default::default(),
        }
    }

    /// Whether rows still keep their samples.
    pub(super) fn keeping(&self) -> bool {
        self.asked && !self.overflowed.load(Ordering::Relaxed)
    }

    /// Counts a finished row's samples (`kept`); drops them once the cap is passed (the
    /// rows kept before are dropped by [`Self::store`]).
    pub(super) fn admit(&self, kept: &mut Option<RowSamples>) {
        let Some(samples) = kept else { return };
        let total = self
            .kept
            .fetch_add(samples.samples.len() as u64, Ordering::Relaxed)
            + samples.samples.len() as u64;
        if total > EYE_SAMPLE_CAP {
            self.overflowed.store(true, Ordering::Relaxed);
            *kept = None;
        }
    }

    /// The rows' samples (in row order) as one store, when every row kept them.
    pub(super) fn store(
        &self,
        rows: impl Iterator<Item = Option<RowSamples>>,
    ) -> Option<EyeSampleStore> {
        if !self.asked || self.overflowed.load(Ordering::Relaxed) {
            return None;
        }
        let rows = rows.collect::<Option<_>>()?;
        Some(EyeSampleStore { rows })
    }
}
