//! The marcher: what one marching pass reads, and the pass's unit of work, one image row
//! (`spp` eye rays per pixel, each from its own random stream).
//!
//! `impl Marcher` is split by stage of the pass, one file each:
//!
//! * here — construction, a pixel's scratch space and eye rays, one row
//!   ([`Marcher::render_row`] → [`Row`]), and the caches' counters;
//! * [`super::eye_ray`] — one eye ray: its samples, then single and multiple scattering
//!   at them;
//! * [`super::beam`] — the beam estimate's multiple-scattering term along one eye ray;
//! * [`super::error_probes`] — after the pass, what its caches and thinning err by.

use std::sync::atomic::Ordering;

use glam::Vec3;

use super::cache::TransmittanceCache;
use super::eye_samples::{EyeSampleStore, RowSamples};
use super::gather::{MapGroup, MsVariant};
use super::multiple::MsSource;
use super::sample::{Accumulator, RowCounters};
use super::thinning::knot_cap;
use crate::math::{Domain, Ray, Rng};
use crate::medium::Medium;
use crate::scene::{Camera, IntegratorParams, Light, Scene};

/// What one marching pass reads: the medium, lights and settings, the variants' photon
/// maps (grouped by map) or the beams, the caches, and the eye samples it replays.
pub(super) struct Marcher<'a> {
    pub(super) medium: &'a Medium,
    pub(super) lights: &'a [Light],
    pub(super) settings: &'a IntegratorParams,
    pub(super) variants: &'a [MsVariant],
    pub(super) groups: Vec<MapGroup<'a>>,
    /// Where the multiple term comes from: the groups' gathers, beams or planes.
    pub(super) source: MsSource<'a>,
    /// Each light's transmittance cache (`None` for a light without one position).
    pub(super) shadow_caches: Option<Vec<Option<TransmittanceCache>>>,
    /// `−ln(termination)`: optical depth at which a marched shadow ray counts as blocked.
    pub(super) shadow_tau_max: f32,
    /// The largest spacing of gathers in a thinned band, in samples.
    pub(super) gather_knot_cap: usize,
    /// An earlier pass's eye samples, marched again from there instead of the medium.
    pub(super) replay: Option<&'a EyeSampleStore>,
}

impl<'a> Marcher<'a> {
    /// The marcher of one pass over `scene`: `variants` from `groups` (point gathers) or
    /// from the beams or planes of `source`, the transmittance caches when the scene asks
    /// for them, and the eye samples of `replay` instead of marching the medium.
    pub(super) fn new(
        scene: &'a Scene,
        variants: &'a [MsVariant],
        groups: Vec<MapGroup<'a>>,
        source: MsSource<'a>,
        replay: Option<&'a EyeSampleStore>,
    ) -> Self {
        let settings = scene.integrator();
        let medium = scene.medium();
        let bounds = medium.bounds();
        Marcher {
            medium,
            lights: scene.lights(),
            settings,
            variants,
            groups,
            source,
            gather_knot_cap: knot_cap(
                medium.density_grid().voxel_size().min_element(),
                settings.stepsize,
            ),
            shadow_tau_max: if settings.termination > 0.0 {
                -settings.termination.ln()
            } else {
                f32::INFINITY
            },
            shadow_caches: (settings.shadow_cache > 0 && settings.single).then(|| {
                scene
                    .lights()
                    .iter()
                    .map(|light| TransmittanceCache::towards(light, bounds, settings.shadow_cache))
                    .collect()
            }),
            replay,
        }
    }

    /// A marcher that only collects eye samples (the cost probe, [`super::eye_probe`]):
    /// no variants, photon maps, beams or caches.
    pub(super) fn probe(scene: &'a Scene) -> Self {
        let settings = scene.integrator();
        Marcher {
            medium: scene.medium(),
            lights: scene.lights(),
            settings,
            variants: &[],
            groups: Vec::new(),
            source: MsSource::Gathers,
            shadow_caches: None,
            shadow_tau_max: f32::INFINITY,
            gather_knot_cap: knot_cap(
                scene.medium().density_grid().voxel_size().min_element(),
                settings.stepsize,
            ),
            replay: None,
        }
    }
}

impl Marcher<'_> {
    /// Scratch space for tracing this marcher's eye rays.
    pub(super) fn accumulator(&self) -> Accumulator {
        let max_group = self.groups.iter().map(|g| g.gather.len()).max();
        Accumulator::new(
            self.variants.len(),
            self.groups.len(),
            max_group.unwrap_or(0),
        )
    }

    /// Eye ray `sample` of pixel `(x, y)`, jittered, and the random stream
    /// `(seed, pixel, sample)` it goes on with: the render's and every probe's.
    pub(super) fn eye_ray(&self, camera: &Camera, x: u32, y: u32, sample: u32) -> (Ray, Rng) {
        let pixel = y as u64 * camera.width() as u64 + x as u64;
        let mut rng = Rng::stream2(self.settings.seed, Domain::Pixels, pixel, sample as u64);
        let [jx, jy] = rng.uniform2();
        (camera.ray(x as f32 + jx, y as f32 + jy), rng)
    }

    /// Renders image row `y`: `spp` jittered eye rays per pixel, each from its own random
    /// stream `(seed, pixel, sample)`; keeps the rays' samples when `record` asks.
    pub(super) fn render_row(&self, camera: &Camera, y: u32, record: bool) -> Row {
        let width = camera.width();
        let spp = self.settings.spp;
        let mut row = Row::new(width as usize, self.variants.len());
        let mut kept = record.then(RowSamples::default);
        let mut acc = self.accumulator();
        for x in 0..width {
            acc.start_pixel();
            for sample in 0..spp {
                let (ray, mut rng) = self.eye_ray(camera, x, y, sample);
                match self.replay {
                    Some(store) => {
                        let index = (x * spp + sample) as usize;
                        self.trace_replayed(&ray, &mut rng, store.ray(y, index), &mut acc);
                    }
                    None => self.trace(&ray, &mut rng, &mut acc),
                }
                if let Some(kept) = &mut kept {
                    kept.push_ray(&acc.samples);
                }
            }
            row.store(x as usize, &acc, spp);
        }
        row.samples = kept;
        row.counters = std::mem::take(&mut acc.counters);
        row
    }

    /// The nodes the transmittance caches and the multiple-scattering caches computed.
    pub(super) fn cache_nodes(&self) -> (u64, u64) {
        let shadow = self
            .shadow_caches
            .as_ref()
            .map(|c| {
                c.iter()
                    .flatten()
                    .map(|c| c.computed.load(Ordering::Relaxed))
                    .sum()
            })
            .unwrap_or(0);
        let multiple = self
            .groups
            .iter()
            .filter_map(|g| g.cache.as_ref())
            .map(|c| c.computed.load(Ordering::Relaxed))
            .sum();
        (shadow, multiple)
    }
}

/// One finished image row.
pub(super) struct Row {
    pub(super) single: Vec<Vec3>,
    pub(super) emission: Vec<Vec3>,
    pub(super) depth: Vec<f32>,
    pub(super) multiple: Vec<Vec<Vec3>>,
    pub(super) counters: RowCounters,
    /// The row's eye samples, when the pass keeps them.
    pub(super) samples: Option<RowSamples>,
}

impl Row {
    pub(super) fn new(width: usize, variants: usize) -> Self {
        Row {
            single: vec![Vec3::ZERO; width],
            emission: vec![Vec3::ZERO; width],
            depth: vec![f32::INFINITY; width],
            multiple: vec![vec![Vec3::ZERO; width]; variants],
            counters: RowCounters::default(),
            samples: None,
        }
    }

    /// Stores pixel `x` as the mean of its `spp` samples.
    fn store(&mut self, x: usize, acc: &Accumulator, spp: u32) {
        let inv = 1.0 / spp as f32;
        self.single[x] = acc.single * inv;
        self.emission[x] = acc.emission * inv;
        if acc.depth_hits > 0 {
            self.depth[x] = acc.depth_sum / acc.depth_hits as f32;
        }
        for (dst, m) in self.multiple.iter_mut().zip(&acc.multiple) {
            dst[x] = *m * inv;
        }
    }
}
