//! The one-call entry: from a [`Scene`] to a [`Film`] — photon tracing, kd-tree, marching
//! (or the reference path tracer) — with timings per phase and a record of everything used;
//! and [`render_shared`], which renders several integrator settings that differ only in
//! their multiple-scattering parameters from ONE march (one eye-ray pass, one single-
//! scattering layer, photon maps shared where their parameters agree).

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::control::Control;
use crate::error::Result;
use crate::film::{Film, Layer};
use crate::integrator::{
    CacheError, MarchOutput, MarchStats, MsVariant, ProgressiveStats, progress_rows, render_march,
    render_progressive, render_reference,
};
use crate::medium::{FreePath, SigmaReport};
use crate::photon::{PhotonMap, PhotonStats, TraceSettings, trace};
use crate::scene::{
    Estimate, IntegratorParams, Method, Quadrature, Scene, SceneParams, ShadowEstimator,
};
use crate::util::peak_memory_bytes;
use crate::volume::{NormalizationRecord, VolumeSource};

/// Seconds per phase.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Photon tracing.
    pub photon_tracing: f64,
    /// kd-tree construction.
    pub tree_build: f64,
    /// Ray marching or path tracing.
    pub render: f64,
    /// Everything.
    pub total: f64,
}

/// What a render was made from: the effective parameters and where the volume, transfer
/// function and σ mapping came from. Shared by every record of a render (render sidecars,
/// sweep cells), flattened into their JSON.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Provenance {
    /// Effective scene parameters (after overrides).
    pub scene: SceneParams,
    /// Where the volume came from (file + sha256, or phantom + parameters).
    pub volume: VolumeSource,
    /// Transfer function, described.
    pub transfer: String,
    /// σ mapping, described.
    pub sigma_mapping: String,
    /// What the σ mapping gives on this volume.
    pub sigma: SigmaReport,
    /// How the volume's raw values were scaled to densities (absent in records written
    /// before it was recorded).
    #[serde(default)]
    pub normalization: Option<NormalizationRecord>,
}

impl Provenance {
    /// The provenance of a render of `scene`.
    pub fn of(scene: &Scene) -> Self {
        Provenance {
            scene: scene.params().clone(),
            volume: scene.volume_source().clone(),
            transfer: scene.medium().transfer_description().to_string(),
            sigma_mapping: scene.medium().mapping().describe(),
            sigma: *scene.medium().report(),
            normalization: Some(scene.medium().normalization().clone()),
        }
    }
}

/// Everything needed to understand and rerun a render, written as a JSON sidecar.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RenderRecord {
    /// Program version.
    pub version: String,
    /// Parameters and sources.
    #[serde(flatten)]
    pub provenance: Provenance,
    /// Photon statistics (photon method with multiple scattering).
    pub photons: Option<PhotonStats>,
    /// Marching counters (photon method).
    pub march: Option<MarchStats>,
    /// What the caches were measured to err by, when the render used one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cache_error: Option<CacheError>,
    /// What the iterations of a progressive render did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub progressive: Option<ProgressiveStats>,
    /// Reference samples per pixel (reference method).
    pub reference_spp: Option<u32>,
    /// Seconds per phase.
    pub timings: Timings,
    /// Peak resident memory of the process in bytes, when the OS reports it.
    pub peak_memory_bytes: Option<u64>,
    /// Worker threads used.
    pub threads: usize,
    /// What the render's settings cannot resolve ([`crate::render_warnings`]), as sentences.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A finished render.
#[derive(Debug, Clone)]
pub struct RenderOutput {
    /// The image layers.
    pub film: Film,
    /// Provenance, parameters, statistics and timings.
    pub record: RenderRecord,
}

/// Traces the scene's photons and builds the photon map.
pub fn build_photon_map(scene: &Scene, control: &Control<'_>) -> Result<PhotonMap> {
    let s = scene.integrator();
    let (photons, stats) = trace(
        scene.medium(),
        scene.lights(),
        &TraceSettings {
            photons: s.volume_photons,
            stored_target: s.stored_photons,
            free_path: s.free_path,
            stepsize: s.stepsize,
            seed: s.seed,
        },
        control,
    )?;
    Ok(PhotonMap::new(photons, stats))
}

/// Renders a scene with the method it asks for.
pub fn render(scene: &Scene, control: &Control<'_>) -> Result<RenderOutput> {
    let start = Instant::now();
    let s = scene.integrator();
    let mut timings = Timings::default();
    let mut cache_error = None;
    let mut progressive = None;
    let (film, photons, march, reference_spp) = match (s.method, s.estimator) {
        (Method::Photon, _) if s.iterates() => {
            let out = render_progressive(scene, control)?;
            timings.photon_tracing = out.stats.photon_seconds;
            timings.tree_build = out.stats.tree_seconds;
            timings.render = out.stats.march_seconds;
            cache_error = out.cache_error;
            progressive = Some(out.stats);
            (out.film, Some(out.photons), Some(out.march), None)
        }
        (Method::Photon, _) => {
            let map = if s.multiple {
                let map = build_photon_map(scene, control)?;
                timings.photon_tracing = map.stats().seconds;
                timings.tree_build = map.build_seconds();
                Some(map)
            } else {
                None
            };
            let maps: Vec<&PhotonMap> = map.iter().collect();
            let out = render_march(scene, &maps, &[], control)?;
            timings.render = out.stats.seconds;
            let film = out.films.into_iter().next().expect("one variant, one film");
            cache_error = out.cache_errors.into_iter().next().flatten();
            (film, map.map(|m| m.stats().clone()), Some(out.stats), None)
        }
        (Method::Reference, _) => {
            let (film, seconds) = render_reference(scene, s.reference_spp, control)?;
            timings.render = seconds;
            (film, None, None, Some(s.reference_spp))
        }
    };
    timings.total = start.elapsed().as_secs_f64();
    let mut record = record(scene, photons, march, reference_spp, timings);
    record.cache_error = cache_error;
    record.progressive = progressive;
    record.warnings = crate::render_warnings(
        s,
        scene.params().sigma.mapping,
        scene.medium().report(),
        record.photons.as_ref(),
        Some(film.mean(crate::film::Layer::Multiple)),
    )
    .iter()
    .map(ToString::to_string)
    .collect();
    Ok(RenderOutput { film, record })
}

/// Builds the provenance record for a render of `scene`.
pub fn record(
    scene: &Scene,
    photons: Option<PhotonStats>,
    march: Option<MarchStats>,
    reference_spp: Option<u32>,
    timings: Timings,
) -> RenderRecord {
    RenderRecord {
        version: env!("CARGO_PKG_VERSION").to_string(),
        provenance: Provenance::of(scene),
        photons,
        march,
        cache_error: None,
        progressive: None,
        reference_spp,
        timings,
        peak_memory_bytes: peak_memory_bytes(),
        threads: rayon::current_num_threads(),
        warnings: Vec::new(),
    }
}

/// Renders each variant alone (estimators that do not share a march: progressive and beam).
fn render_each(
    scene: &Scene,
    variants: &[IntegratorParams],
    control: &Control<'_>,
) -> Result<SharedRender> {
    let mut films = Vec::with_capacity(variants.len());
    let mut render_seconds = 0.0;
    let rows = scene.camera().height();
    let mut done = 0;
    for integrator in variants {
        // Progress continues across the variants (see [`shared_progress_units`]).
        let progress = |r: u64| control.report(done + r);
        let out = render(
            &scene.with_integrator(integrator.clone())?,
            &control.with_progress(&progress),
        )?;
        done += progress_rows(integrator, rows);
        render_seconds += out.record.timings.render;
        films.push(SharedFilm {
            film: out.film,
            photon_seconds: out.record.timings.photon_tracing,
            tree_seconds: out.record.timings.tree_build,
            map_shared_by: usize::from(out.record.photons.is_some()),
            photons: out.record.photons,
            cache_error: out.record.cache_error,
            progressive: out.record.progressive,
        });
    }
    Ok(SharedRender {
        films,
        photon_maps: variants.iter().filter(|v| v.multiple).count(),
        render_seconds,
    })
}

/// Progress units (see [`Control`]) that [`render_shared`] reports for `variants` of an
/// image `rows` high: one march, or each variant's own render in turn.
pub fn shared_progress_units(variants: &[IntegratorParams], rows: u32) -> u64 {
    match variants.first() {
        Some(v) if v.method == Method::Photon && v.estimator.iterates() => {
            variants.iter().map(|v| progress_rows(v, rows)).sum()
        }
        _ => rows as u64,
    }
}

/// The scene parameters that only change the multiple-scattering layer, reset: scenes with
/// equal keys render from one march ([`render_shared`]).
pub fn march_key(params: &SceneParams) -> String {
    let mut p = params.clone();
    // Progressive and beam renders march per iteration or per photon set: each renders
    // alone, so its time is its own.
    if p.integrator.method == Method::Photon && p.integrator.estimator.iterates() {
        return serde_json::to_string(&p).expect("scene params serialise");
    }
    p.integrator.volume_photons = 0;
    p.integrator.nused = 1;
    p.integrator.maxdist = 1.0;
    p.integrator.free_path = FreePath::Delta;
    p.integrator.estimate = Estimate::Masked;
    p.integrator.multiple = false;
    p.integrator.reference_spp = 1;
    serde_json::to_string(&p).expect("scene params serialise")
}

/// The scene parameters that determine a photon map (everything else reset): variants with
/// equal keys share one map.
pub fn photon_map_key(params: &SceneParams) -> String {
    let mut p = params.clone();
    let i = &mut p.integrator;
    i.nused = 1;
    i.maxdist = 1.0;
    i.estimate = Estimate::Masked;
    i.multiple = true;
    i.single = true;
    i.emission = false;
    i.spp = 1;
    i.shadow = ShadowEstimator::March;
    i.quadrature = Quadrature::Exact;
    i.termination = 0.0;
    i.shadow_cache = 0;
    i.ms_cache = 0;
    i.shadow_tolerance = 0.0;
    i.reference_spp = 1;
    p.camera.resolution = [1, 1];
    p.camera.fov = 1.0;
    p.film = Default::default();
    serde_json::to_string(&p).expect("scene params serialise")
}

/// One variant of a [`render_shared`] call.
#[derive(Debug, Clone)]
pub struct SharedFilm {
    /// The image layers (the multiple layer black when the variant has `multiple = false`).
    pub film: Film,
    /// Statistics of the variant's photon map, when it used one.
    pub photons: Option<PhotonStats>,
    /// Seconds spent tracing that photon map (shared maps count fully for each variant).
    pub photon_seconds: f64,
    /// Seconds spent building its kd-tree.
    pub tree_seconds: f64,
    /// Variants that used the same photon map (0 without one).
    pub map_shared_by: usize,
    /// What the caches were measured to err by, when the render used one.
    pub cache_error: Option<CacheError>,
    /// What the iterations did, for the progressive and beam estimators.
    pub progressive: Option<ProgressiveStats>,
}

/// What [`render_shared`] produced.
#[derive(Debug, Clone)]
pub struct SharedRender {
    /// One film per requested integrator setting, in order.
    pub films: Vec<SharedFilm>,
    /// Photon maps built.
    pub photon_maps: usize,
    /// Seconds of the shared march (or of the reference render).
    pub render_seconds: f64,
}

/// Renders `scene` once for several integrator settings that share its [`march_key`] — i.e.
/// differ only in `volume_photons`, `nused`, `maxdist`, `free_path`, `estimate` and
/// `multiple` — from ONE march. `scene` is any of them with `multiple` on when any variant
/// wants it. Each distinct [`photon_map_key`] gets one photon map, and variants on one map
/// share one k-NN query per sample. Films are identical to rendering each setting alone.
pub fn render_shared(
    scene: &Scene,
    variants: &[IntegratorParams],
    control: &Control<'_>,
) -> Result<SharedRender> {
    if scene.integrator().method == Method::Reference {
        return render_reference_shared(scene, variants.len(), control);
    }
    if scene.integrator().estimator.iterates() {
        return render_each(scene, variants, control);
    }
    let shared = SharedMaps::build(scene, variants, control)?;
    let map_refs: Vec<&PhotonMap> = shared.maps.iter().map(|(_, m)| m).collect();
    let out = render_march(scene, &map_refs, &shared.ms_variants, control)?;
    let films = shared
        .film_of
        .iter()
        .map(|slot| match slot {
            Some(i) => shared.film_of_variant(*i, &out),
            None => single_only_film(&out),
        })
        .collect();
    Ok(SharedRender {
        films,
        photon_maps: shared.maps.len(),
        render_seconds: out.stats.seconds,
    })
}

/// The reference render of `scene`, given to each of `variants` variants (the path
/// tracer does not depend on what they vary).
fn render_reference_shared(
    scene: &Scene,
    variants: usize,
    control: &Control<'_>,
) -> Result<SharedRender> {
    let out = render(scene, control)?;
    let film = SharedFilm::without_map(out.film, None);
    Ok(SharedRender {
        films: vec![film; variants],
        photon_maps: 0,
        render_seconds: out.record.timings.render,
    })
}

/// The photon maps of a shared march, one per distinct [`photon_map_key`], and which
/// multiple-scattering variant of the march each requested setting is.
struct SharedMaps {
    maps: Vec<(String, PhotonMap)>,
    ms_variants: Vec<MsVariant>,
    /// `film_of[k]`: setting k's variant in the march (`None` without multiple scattering).
    film_of: Vec<Option<usize>>,
}

impl SharedMaps {
    /// Traces each distinct photon map `variants` ask for once.
    fn build(scene: &Scene, variants: &[IntegratorParams], control: &Control<'_>) -> Result<Self> {
        let mut shared = SharedMaps {
            maps: Vec::new(),
            ms_variants: Vec::new(),
            film_of: Vec::new(),
        };
        for integrator in variants {
            if !integrator.multiple {
                shared.film_of.push(None);
                continue;
            }
            let mut params = scene.params().clone();
            params.integrator = integrator.clone();
            let key = photon_map_key(&params);
            let map = match shared.maps.iter().position(|(k, _)| *k == key) {
                Some(i) => i,
                None => {
                    let s = scene.with_integrator(integrator.clone())?;
                    shared.maps.push((key, build_photon_map(&s, control)?));
                    shared.maps.len() - 1
                }
            };
            shared.film_of.push(Some(shared.ms_variants.len()));
            shared.ms_variants.push(MsVariant {
                map,
                nused: integrator.nused,
                maxdist: integrator.maxdist,
                estimate: integrator.estimate,
            });
        }
        Ok(shared)
    }

    /// The film of the march's variant `i`, with its photon map's statistics.
    fn film_of_variant(&self, i: usize, out: &MarchOutput) -> SharedFilm {
        let map_index = self.ms_variants[i].map;
        let map = &self.maps[map_index].1;
        SharedFilm {
            film: out.films[i].clone(),
            photons: Some(map.stats().clone()),
            photon_seconds: map.stats().seconds,
            tree_seconds: map.build_seconds(),
            map_shared_by: self
                .ms_variants
                .iter()
                .filter(|v| v.map == map_index)
                .count(),
            cache_error: out.cache_errors[i].clone(),
            progressive: None,
        }
    }
}

/// The film of a setting without multiple scattering: the march's first film with its
/// multiple layer zeroed (the direct layers are the same for every variant).
fn single_only_film(out: &MarchOutput) -> SharedFilm {
    let mut film = out.films[0].clone();
    film.set_layer(
        Layer::Multiple,
        vec![glam::Vec3::ZERO; film.width() * film.height()],
    );
    SharedFilm::without_map(film, out.cache_errors[0].clone())
}

impl SharedFilm {
    /// A film rendered without a photon map of its own (a reference, or a setting
    /// without multiple scattering).
    fn without_map(film: Film, cache_error: Option<CacheError>) -> Self {
        SharedFilm {
            film,
            photons: None,
            photon_seconds: 0.0,
            tree_seconds: 0.0,
            map_shared_by: 0,
            cache_error,
            progressive: None,
        }
    }
}
