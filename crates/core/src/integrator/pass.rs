//! The ray-marching pass: eye rays through every pixel, a source term at every marching
//! sample, layers accumulated front to back (thesis §6, eq. in §6 and §7.1.3).
//!
//! Here are the entry points ([`render_march`], [`render_march_beams`],
//! [`render_march_planes`], and their
//! measured forms the progressive loop calls), the pass itself (image rows in parallel,
//! each rendered by the [`Marcher`]) and the films and counters the rows are joined into.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::error_probes::CacheError;
use super::eye_samples::{EyeSampleStore, EyeSamples, SampleKeeper};
use super::gather::{MapGroup, MsVariant, group_by_map};
use super::marcher::{Marcher, Row};
use super::multiple::MsSource;
use crate::control::Control;
use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::photon::{BeamMap, PhotonMap, PlaneMap};
use crate::scene::{Camera, Scene};

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
    let source = MsSource::Gathers;
    run_march(scene, variants, groups, source, control, (measure, eye))
}

/// Renders a scene with the ray-marching integrator, the multiple-scattering term from the
/// beam radiance estimate over `beams` (Jarosz, Zwicker & Jensen 2008, exact along each
/// chord) instead of point gathers.
pub fn render_march_beams(
    scene: &Scene,
    beams: &BeamMap<'_>,
    control: &Control<'_>,
) -> Result<MarchOutput> {
    let (measure, eye) = (Measure::asked_by(control), EyeSamples::March);
    photons_measured(scene, MsSource::Beams(beams), control, measure, eye).map(|(out, _)| out)
}

/// Renders a scene with the ray-marching integrator, the multiple-scattering term from
/// photon planes ([`PlaneMap`], Bitterli & Jarosz 2017) instead of point gathers.
pub fn render_march_planes(
    scene: &Scene,
    planes: &PlaneMap<'_>,
    control: &Control<'_>,
) -> Result<MarchOutput> {
    let (measure, eye) = (Measure::asked_by(control), EyeSamples::March);
    photons_measured(scene, MsSource::Planes(planes), control, measure, eye).map(|(out, _)| out)
}

/// A pass whose multiple term comes from beams or planes (`source`), measuring the errors
/// or not, keeping or replaying the eye samples as `eye` says.
pub(super) fn photons_measured(
    scene: &Scene,
    source: MsSource<'_>,
    control: &Control<'_>,
    measure: Measure,
    eye: EyeSamples<'_>,
) -> Result<(MarchOutput, Option<EyeSampleStore>)> {
    let settings = scene.integrator();
    let own = [MsVariant::of_scene(settings)];
    let variants: &[MsVariant] = if settings.multiple { &own } else { &[] };
    run_march(scene, variants, Vec::new(), source, control, (measure, eye))
}

/// The pass itself: rows in parallel, then the films and counters (and the eye samples,
/// when the pass keeps them).
fn run_march<'a>(
    scene: &'a Scene,
    variants: &'a [MsVariant],
    groups: Vec<MapGroup<'a>>,
    source: MsSource<'a>,
    control: &Control<'_>,
    (measure, eye): (Measure, EyeSamples<'a>),
) -> Result<(MarchOutput, Option<EyeSampleStore>)> {
    let start = Instant::now();
    let settings = scene.integrator();
    let replay = match eye {
        EyeSamples::Replay(store) => Some(store),
        EyeSamples::March | EyeSamples::Record => None,
    };
    let marcher = Marcher::new(scene, variants, groups, source, replay);
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
            keeper.admit(&mut row.samples);
            control.report(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
            row
        })
        .collect();
    control.check()?;
    let store = keeper.store(rows.iter_mut().map(|row| row.samples.take()));
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
