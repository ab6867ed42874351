//! The ray-marching pass: eye rays through every pixel, a source term at every marching
//! sample, layers accumulated front to back (thesis §6, eq. in §6 and §7.1.3).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::cache::TransmittanceCache;
use super::error_probes::CacheError;
use super::gather::{MapGroup, MsVariant, group_by_map};
use super::sample::{Accumulator, RaySample, RowCounters};
use super::thinning::knot_cap;
use crate::control::Control;
use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::math::{Domain, Ray, Rng};
use crate::medium::Medium;
use crate::photon::{BeamMap, PhotonMap};
use crate::scene::{Camera, IntegratorParams, Light, Scene};

/// Counters of one marching pass.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MarchStats {
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Eye rays traced.
    pub eye_rays: u64,
    /// Samples where the source term was evaluated (σt > 0).
    pub samples: u64,
    /// Shadow transmittance evaluations (cache look-ups included).
    pub shadow_queries: u64,
    /// Radiance-estimate gathers (cache look-ups excluded).
    pub gathers: u64,
    /// Transmittance-cache nodes computed.
    pub shadow_cache_nodes: u64,
    /// Multiple-scattering-cache nodes computed.
    pub ms_cache_nodes: u64,
}

/// The films of one pass: one per multiple-scattering variant. Their single and emission
/// layers are identical.
#[derive(Debug, Clone)]
pub struct MarchOutput {
    /// One film per [`MsVariant`] (one film when `multiple` is off).
    pub films: Vec<Film>,
    /// Counters.
    pub stats: MarchStats,
    /// The measured error of the caches, per film (`None` without caches).
    pub cache_errors: Vec<Option<CacheError>>,
}

pub(super) struct Marcher<'a> {
    pub(super) medium: &'a Medium,
    pub(super) lights: &'a [Light],
    pub(super) settings: &'a IntegratorParams,
    pub(super) variants: &'a [MsVariant],
    pub(super) groups: Vec<MapGroup<'a>>,
    /// The photons as spheres, when the beam estimate gives the multiple term.
    pub(super) beams: Option<&'a BeamMap<'a>>,
    pub(super) shadow_caches: Option<Vec<TransmittanceCache>>,
    /// `−ln(termination)`: optical depth at which a marched shadow ray counts as blocked.
    pub(super) shadow_tau_max: f32,
    /// The largest spacing of gathers in a thinned band, in samples.
    pub(super) gather_knot_cap: usize,
    /// An earlier pass's eye samples, marched again from there instead of the medium.
    pub(super) replay: Option<&'a EyeSampleStore>,
}

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
    fn ray(&self, y: u32, ray: usize) -> &[RaySample] {
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
struct RowSamples {
    samples: Vec<RaySample>,
    ends: Vec<u32>,
}

/// One finished image row.
struct Row {
    single: Vec<Vec3>,
    emission: Vec<Vec3>,
    depth: Vec<f32>,
    multiple: Vec<Vec<Vec3>>,
    counters: RowCounters,
    /// The row's eye samples, when the pass keeps them.
    samples: Option<RowSamples>,
}

impl Row {
    fn new(width: usize, variants: usize) -> Self {
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
    fn render_row(&self, camera: &Camera, y: u32, record: bool) -> Row {
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
                    kept.samples.extend_from_slice(&acc.samples);
                    kept.ends.push(kept.samples.len() as u32);
                }
            }
            row.store(x as usize, &acc, spp);
        }
        row.samples = kept;
        row.counters = std::mem::take(&mut acc.counters);
        row
    }
}

/// Renders a scene with the ray-marching integrator.
///
/// `maps` are photon maps of this scene (e.g. with different photon counts or free-path
/// rules); `variants` lists the multiple-scattering images to produce from one march, each
/// naming its map and estimate parameters (empty means the scene's own settings on
/// `maps[0]`). Variants on the same map share one k-NN query per sample; all share the
/// eye rays, the single-scattering and the emission layers. `control` receives the number
/// of rows finished and may stop the pass (a time limit).
pub fn render_march(
    scene: &Scene,
    maps: &[&PhotonMap],
    variants: &[MsVariant],
    control: &Control<'_>,
) -> Result<MarchOutput> {
    march_measured(
        scene,
        maps,
        variants,
        control,
        Measure::asked_by(control),
        EyeSamples::March,
    )
    .map(|(out, _)| out)
}

/// Whether a pass measures what its caches and thinning err by ([`super::error_probes`]).
/// A progressive or beam render measures its first march, which renders every layer; its
/// later iterations do not (they march the same eye samples with another photon map and
/// a smaller radius, and the record holds one measurement).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Measure {
    Errors,
    Skip,
}

impl Measure {
    /// What `control` asks for ([`Control::without_error_probes`] skips the measurement).
    pub(super) fn asked_by(control: &Control<'_>) -> Self {
        if control.error_probes() {
            Measure::Errors
        } else {
            Measure::Skip
        }
    }
}

/// [`render_march`], measuring the errors or not, keeping or replaying the eye samples as
/// `eye` says (the samples it kept, when it kept them).
pub(super) fn march_measured(
    scene: &Scene,
    maps: &[&PhotonMap],
    variants: &[MsVariant],
    control: &Control<'_>,
    measure: Measure,
    eye: EyeSamples<'_>,
) -> Result<(MarchOutput, Option<EyeSampleStore>)> {
    let settings = scene.integrator();
    let medium = scene.medium();
    let own = [MsVariant::of_scene(settings)];
    let variants: &[MsVariant] = if !settings.multiple {
        &[]
    } else if variants.is_empty() {
        &own
    } else {
        variants
    };
    if settings.ms_cache > 0 && settings.multiple && !medium.phase().is_isotropic() {
        return Err(Error::parameter(
            "integrator.ms_cache",
            settings.ms_cache,
            "0 when phase.g != 0 (the cached estimate is only view-independent for isotropic scattering)",
        ));
    }
    let groups = group_by_map(variants, maps, settings, medium.bounds())?;
    run_march(scene, variants, groups, None, control, (measure, eye))
}

/// Renders a scene with the ray-marching integrator, the multiple-scattering term from the
/// beam radiance estimate over `beams` (Jarosz, Zwicker & Jensen 2008, exact along each
/// chord) instead of point gathers.
pub fn render_march_beams(
    scene: &Scene,
    beams: &BeamMap<'_>,
    control: &Control<'_>,
) -> Result<MarchOutput> {
    beams_measured(
        scene,
        beams,
        control,
        Measure::asked_by(control),
        EyeSamples::March,
    )
    .map(|(out, _)| out)
}

/// [`render_march_beams`], measuring the errors or not, keeping or replaying the eye
/// samples as `eye` says.
pub(super) fn beams_measured(
    scene: &Scene,
    beams: &BeamMap<'_>,
    control: &Control<'_>,
    measure: Measure,
    eye: EyeSamples<'_>,
) -> Result<(MarchOutput, Option<EyeSampleStore>)> {
    let settings = scene.integrator();
    let own = [MsVariant::of_scene(settings)];
    let variants: &[MsVariant] = if settings.multiple { &own } else { &[] };
    run_march(
        scene,
        variants,
        Vec::new(),
        Some(beams),
        control,
        (measure, eye),
    )
}

/// The pass itself: rows in parallel, then the films and counters (and the eye samples,
/// when the pass keeps them).
fn run_march<'a>(
    scene: &'a Scene,
    variants: &'a [MsVariant],
    groups: Vec<MapGroup<'a>>,
    beams: Option<&'a BeamMap<'a>>,
    control: &Control<'_>,
    (measure, eye): (Measure, EyeSamples<'a>),
) -> Result<(MarchOutput, Option<EyeSampleStore>)> {
    let start = Instant::now();
    let settings = scene.integrator();
    let medium = scene.medium();
    let bounds = medium.bounds();
    let marcher = Marcher {
        medium,
        lights: scene.lights(),
        settings,
        variants,
        groups,
        beams,
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
                .map(|_| TransmittanceCache::new(bounds, settings.shadow_cache))
                .collect()
        }),
        replay: match eye {
            EyeSamples::Replay(store) => Some(store),
            EyeSamples::March | EyeSamples::Record => None,
        },
    };
    let camera = scene.camera();
    let rows_done = AtomicU64::new(0);
    let keeper = SampleKeeper::new(matches!(eye, EyeSamples::Record));
    let mut rows: Vec<Row> = (0..camera.height() as usize)
        .into_par_iter()
        .map(|y| {
            if control.expired() {
                // Past the time limit: the remaining rows are skipped and the pass fails.
                return Row::new(0, 0);
            }
            let mut row = marcher.render_row(camera, y as u32, keeper.keeping());
            keeper.admit(&mut row);
            control.report(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
            row
        })
        .collect();
    control.check()?;
    let store = keeper.store(&mut rows);
    let (films, mut stats) = assemble(rows, camera, variants.len(), settings.spp);
    (stats.shadow_cache_nodes, stats.ms_cache_nodes) = marcher.cache_nodes();
    let cache_errors = match measure {
        Measure::Errors => marcher.cache_errors(camera),
        Measure::Skip => vec![None; variants.len().max(1)],
    };
    stats.seconds = start.elapsed().as_secs_f64();
    let out = MarchOutput {
        films,
        stats,
        cache_errors,
    };
    Ok((out, store))
}

impl Marcher<'_> {
    /// The nodes the transmittance caches and the multiple-scattering caches computed.
    fn cache_nodes(&self) -> (u64, u64) {
        let shadow = self
            .shadow_caches
            .as_ref()
            .map(|c| c.iter().map(|c| c.computed.load(Ordering::Relaxed)).sum())
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

/// Keeps the rows' eye samples up to [`EYE_SAMPLE_CAP`]; past it, none.
struct SampleKeeper {
    asked: bool,
    kept: AtomicU64,
    overflowed: std::sync::atomic::AtomicBool,
}

impl SampleKeeper {
    fn new(asked: bool) -> Self {
        SampleKeeper {
            asked,
            kept: AtomicU64::new(0),
            overflowed: Default::default(),
        }
    }

    /// Whether rows still keep their samples.
    fn keeping(&self) -> bool {
        self.asked && !self.overflowed.load(Ordering::Relaxed)
    }

    /// Counts a finished row's samples; drops them once the cap is passed (the rows kept
    /// before are dropped by [`Self::store`]).
    fn admit(&self, row: &mut Row) {
        let Some(samples) = &row.samples else { return };
        let total = self
            .kept
            .fetch_add(samples.samples.len() as u64, Ordering::Relaxed)
            + samples.samples.len() as u64;
        if total > EYE_SAMPLE_CAP {
            self.overflowed.store(true, Ordering::Relaxed);
            row.samples = None;
        }
    }

    /// The rows' samples as one store, when every row kept them.
    fn store(&self, rows: &mut [Row]) -> Option<EyeSampleStore> {
        if !self.asked || self.overflowed.load(Ordering::Relaxed) {
            return None;
        }
        let rows = rows
            .iter_mut()
            .map(|row| row.samples.take())
            .collect::<Option<_>>()?;
        Some(EyeSampleStore { rows })
    }
}

/// Joins the rows into one film per variant (sharing the single, emission and depth
/// layers) and sums the rows' counters.
fn assemble(rows: Vec<Row>, camera: &Camera, variants: usize, spp: u32) -> (Vec<Film>, MarchStats) {
    let (width, height) = (camera.width() as usize, camera.height() as usize);
    let mut single = Vec::with_capacity(width * height);
    let mut emission = Vec::with_capacity(width * height);
    let mut depth = Vec::with_capacity(width * height);
    let mut multiple: Vec<Vec<Vec3>> = vec![Vec::with_capacity(width * height); variants];
    let mut stats = MarchStats {
        eye_rays: (width * height) as u64 * spp as u64,
        ..Default::default()
    };
    for row in rows {
        single.extend(row.single);
        emission.extend(row.emission);
        depth.extend(row.depth);
        for (dst, src) in multiple.iter_mut().zip(row.multiple) {
            dst.extend(src);
        }
        stats.samples += row.counters.samples;
        stats.shadow_queries += row.counters.shadow;
        stats.gathers += row.counters.gathers;
    }
    let films = (0..variants.max(1))
        .map(|i| {
            let mut film = Film::new(width, height).with_depth(depth.clone());
            film.set_layer(Layer::Single, single.clone());
            film.set_layer(Layer::Emission, emission.clone());
            if let Some(m) = multiple.get(i) {
                film.set_layer(Layer::Multiple, m.clone());
            }
            film
        })
        .collect();
    (films, stats)
}
