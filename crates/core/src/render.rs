//! One call from a [`Scene`] to a [`Film`]: photon tracing, kd-tree, marching (or the
//! reference path tracer), with timings per phase and a record of everything used.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::film::Film;
use crate::integrator::{MarchStats, render_march};
use crate::photon::{PhotonStats, TraceSettings, trace};
use crate::photon_map::PhotonMap;
use crate::scene::{Scene, SceneParams};
use crate::settings::Method;
use crate::sigma::SigmaReport;
use crate::volume::VolumeSource;

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
    /// Reference samples per pixel (reference method).
    pub reference_spp: Option<u32>,
    /// Seconds per phase.
    pub timings: Timings,
    /// Peak resident memory of the process in bytes, when the OS reports it.
    pub peak_memory_bytes: Option<u64>,
    /// Worker threads used.
    pub threads: usize,
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
pub fn build_photon_map(scene: &Scene) -> PhotonMap {
    let s = scene.integrator();
    let (photons, stats) = trace(
        scene.medium(),
        scene.lights(),
        &TraceSettings {
            photons: s.volume_photons,
            free_path: s.free_path,
            stepsize: s.stepsize,
            seed: s.seed,
        },
    );
    PhotonMap::new(photons, stats)
}

/// Peak resident set size of this process (Linux `VmHWM`), if available.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Renders a scene with the method it asks for.
pub fn render(scene: &Scene, progress: &(dyn Fn(u64) + Sync)) -> Result<RenderOutput> {
    let start = Instant::now();
    let s = scene.integrator();
    let mut timings = Timings::default();
    let (film, photons, march, reference_spp) = match s.method {
        Method::Photon => {
            let map = if s.multiple {
                let map = build_photon_map(scene);
                timings.photon_tracing = map.stats().seconds;
                timings.tree_build = map.build_seconds();
                Some(map)
            } else {
                None
            };
            let maps: Vec<&PhotonMap> = map.iter().collect();
            let out = render_march(scene, &maps, &[], progress)?;
            timings.render = out.stats.seconds;
            let film = out.films.into_iter().next().expect("one variant, one film");
            (film, map.map(|m| m.stats().clone()), Some(out.stats), None)
        }
        Method::Reference => {
            let (film, seconds) =
                crate::reference::render_reference(scene, s.reference_spp, progress)?;
            timings.render = seconds;
            (film, None, None, Some(s.reference_spp))
        }
    };
    timings.total = start.elapsed().as_secs_f64();
    Ok(RenderOutput {
        film,
        record: record(scene, photons, march, reference_spp, timings),
    })
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
        reference_spp,
        timings,
        peak_memory_bytes: peak_memory_bytes(),
        threads: rayon::current_num_threads(),
    }
}
