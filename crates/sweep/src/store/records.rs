//! The records an output folder holds: `plan.json` (the plan of a run), `cells/<hash>/
//! cell.json` (a finished cell: provenance, timings, layer means and image statistics),
//! `cells/<hash>/vs-<reference>.json` (its errors against a reference) and
//! `references/<key>/reference.json`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use volphot::{PhotonStats, Provenance, SceneParams, VolumeSource};

use super::OutputDir;
use super::checksum::FileCheck;

/// Version of the reference metrics; stored metrics of another version are recomputed.
pub(crate) const REFERENCE_METRICS_VERSION: u32 = 3;

/// Version of [`ImageStats`]; records with an older one are recomputed from the cell's
/// `film.exr` when a report is collected (version 2 added the mean display luminance).
pub(crate) const IMAGE_STATS_VERSION: u32 = 2;

/// Image-error metrics against the reference.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct ReferenceMetrics {
    /// [`REFERENCE_METRICS_VERSION`] when computed.
    #[serde(default)]
    pub(crate) version: u32,
    /// Which reference (its content address).
    pub(crate) reference: String,
    /// Samples per pixel the reference had (a refined reference makes these stale).
    #[serde(default)]
    pub(crate) reference_passes: u32,
    /// Root-mean-square error of linear radiance.
    pub(crate) rmse: f64,
    /// The same with the reference's own noise removed: `sqrt(max(0, MSE − mean
    /// variance of the reference's mean))` — the error against the true image. `None`
    /// when the reference carries no variance (a photon-mapping reference).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) rmse_corrected: Option<f64>,
    /// Mean of `(x − y)² / (y² + 0.01·mean(y)²)` (relative MSE, robust near black).
    pub(crate) rel_mse: f64,
    /// SSIM of the tone-mapped images (image-compare's MSSIM on luma, 1 = identical).
    pub(crate) ssim: f64,
    /// Mean FLIP error of the tone-mapped images (nv-flip, 0 = identical).
    pub(crate) flip: f64,
    /// Disco score of the multiple layer relative to the reference's (blobs the truth
    /// lacks); see `disco::relative_disco_score`.
    #[serde(default)]
    pub(crate) disco_excess: f64,
    /// Blobs counted by that score.
    #[serde(default)]
    pub(crate) disco_excess_blobs: u64,
    /// Seconds to compute these.
    pub(crate) seconds: f64,
}

/// The disco-ball artifact score of the multiple-scattering layer (see `disco`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct DiscoScore {
    /// Fraction of the layer's energy inside detected blobs.
    pub(crate) energy: f64,
    /// Number of blobs.
    pub(crate) blobs: u64,
    /// Fraction of the object's area covered by blobs.
    pub(crate) area: f64,
}

/// What multiple scattering changes in the displayed image (thesis §1.1): detail, regions
/// lit only by it, depth cues. All on tone-mapped (sRGB) luminance in [0, 1] over the
/// object's pixels; `single` = the cell's single-scattering layer alone, `total` = what the
/// cell displays.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct ImageStats {
    /// [`IMAGE_STATS_VERSION`] when computed (0 in records written before versioning).
    #[serde(default)]
    pub(crate) version: u32,
    /// Mean display luminance, single scattering only.
    #[serde(default)]
    pub(crate) luma_single: f64,
    /// Mean display luminance of the displayed image.
    #[serde(default)]
    pub(crate) luma_total: f64,
    /// Mean Sobel gradient magnitude, single scattering only.
    pub(crate) gradient_single: f64,
    /// Mean Sobel gradient magnitude, displayed image.
    pub(crate) gradient_total: f64,
    /// Mean |L − G₂∗L| (fine local contrast, Gaussian σ = 2 px), single only.
    pub(crate) detail_single: f64,
    /// The same for the displayed image.
    pub(crate) detail_total: f64,
    /// Share of object pixels darker than 0.05 with single scattering but not in the
    /// displayed image.
    pub(crate) lit_by_multiple: f64,
    /// Pearson correlation of luminance and depth (negative: farther is darker), single.
    pub(crate) depth_corr_single: f64,
    /// The same for the displayed image.
    pub(crate) depth_corr_total: f64,
    /// Share of object pixels clipped to white in the displayed image ("over-brightening").
    pub(crate) clipped_total: f64,
    /// Share of object pixels whose eye ray reached transmittance ½ (an opaque look);
    /// low values mean a transparent rendering (thesis C6).
    pub(crate) opaque_share: f64,
}

/// Timings of one cell, seconds.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct CellTimings {
    /// Photon tracing of the cell's photon map (shared maps count fully for each cell).
    pub(crate) photon_tracing: f64,
    /// kd-tree build of the cell's photon map.
    pub(crate) tree_build: f64,
    /// The march that produced the cell (shared by `march_shared_by` cells).
    pub(crate) render: f64,
    /// Metrics of this cell.
    pub(crate) metrics: f64,
    /// Cells produced by the same march.
    pub(crate) march_shared_by: usize,
    /// Cells using the same photon map.
    pub(crate) map_shared_by: usize,
}

/// Everything recorded about a finished cell (`cell.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct CellRecord {
    /// Index in the plan that produced it.
    pub(crate) index: usize,
    /// Content address.
    pub(crate) hash: String,
    /// `key = value, …`.
    pub(crate) label: String,
    /// Axis values (JSON).
    pub(crate) axes: Vec<(String, serde_json::Value)>,
    /// Effective parameters and sources (flattened: `scene`, `volume`, `transfer`,
    /// `sigma_mapping`, `sigma` in the JSON).
    #[serde(flatten)]
    pub(crate) provenance: Provenance,
    /// Photon statistics (when the cell used a photon map).
    pub(crate) photons: Option<PhotonStats>,
    /// What the caches were measured to err by, when the cell was rendered with one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) cache_error: Option<volphot::CacheError>,
    /// What the iterations did (progressive and beam estimators): radii, the error against
    /// the reference after each, and why they stopped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) progressive: Option<volphot::ProgressiveStats>,
    /// Timings.
    pub(crate) timings: CellTimings,
    /// Peak resident memory of the process after the cell, bytes.
    pub(crate) peak_memory_bytes: Option<u64>,
    /// Mean radiance of the single-scattering layer.
    pub(crate) mean_single: f64,
    /// Mean radiance of the multiple-scattering layer.
    pub(crate) mean_multiple: f64,
    /// Mean radiance of the emission layer.
    pub(crate) mean_emission: f64,
    /// Disco-ball score of the multiple layer.
    pub(crate) disco: DiscoScore,
    /// Detail, lit regions and depth cues of single vs displayed image.
    pub(crate) image: ImageStats,
    /// Program version.
    pub(crate) version: String,
    /// Worker threads.
    pub(crate) threads: usize,
    /// Host that rendered it.
    pub(crate) host: String,
    /// Size and sha256 of every file of the cell, to tell a finished cell from a damaged
    /// one (empty in records written before files were checked).
    #[serde(default)]
    pub(crate) files: Vec<FileCheck>,
    /// What the cell's settings cannot resolve (`volphot::render_warnings`), as sentences.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(crate) warnings: Vec<String>,
}

/// The largest record read (`plan.json` of a large grid, a cell's record): 64 MiB.
const RECORD_CAP: u64 = 64 << 20;

/// Reads a record of an output folder through the capped regular-file reader: a FIFO, a
/// device or a huge file where a record should be fails at once, naming it.
fn read_record_text(path: &Path, what: &str) -> Result<String> {
    Ok(volphot::read_text_capped(path, RECORD_CAP, what)?)
}

/// Reads a finished cell's record.
pub(crate) fn read_record(dir: &Path) -> Result<CellRecord> {
    let path = dir.join("cell.json");
    let text = read_record_text(&path, "cell record")?;
    let mut value: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    fill_in_old_settings(&mut value);
    serde_json::from_value(value).with_context(|| format!("parsing {}", path.display()))
}

/// Fills in the integrator settings a record written before they were written leaves out,
/// as they were when it was rendered — read with today's defaults, such a record would
/// claim a render it was not: `shadow_tolerance` did not exist before it was a setting
/// (the fill's tolerance was 0.05; the default is 0.025 since), and `thin_below` was not
/// written while it was 0 (the default is 0.5 since).
fn fill_in_old_settings(record: &mut serde_json::Value) {
    let integrator = record
        .pointer_mut("/scene/integrator")
        .and_then(|v| v.as_object_mut());
    if let Some(integrator) = integrator {
        integrator
            .entry("shadow_tolerance")
            .or_insert(serde_json::json!(super::address::ADDRESS_SHADOW_TOLERANCE));
        integrator
            .entry("thin_below")
            .or_insert(serde_json::json!(0.0));
    }
}

/// Writes a cell's record (`cell.json`) atomically.
pub(crate) fn write_record(dir: &Path, record: &CellRecord) -> Result<()> {
    volphot::write_atomic(
        &dir.join("cell.json"),
        serde_json::to_string_pretty(record)?.as_bytes(),
    )?;
    Ok(())
}

/// Reads the reference metrics of a cell for one reference, if computed by this version
/// against the reference as it is now (`passes`, when its record is at hand: metrics of a
/// reference refined since are stale).
pub(crate) fn read_reference_metrics(
    dir: &Path,
    reference: &str,
    passes: Option<u32>,
) -> Option<ReferenceMetrics> {
    let text = read_record_text(
        &dir.join(format!("vs-{reference}.json")),
        "reference metrics",
    )
    .ok()?;
    serde_json::from_str::<ReferenceMetrics>(&text)
        .ok()
        .filter(|m| m.version == REFERENCE_METRICS_VERSION)
        .filter(|m| passes.is_none_or(|n| n == m.reference_passes))
}

/// One planned cell as recorded in `plan.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct PlannedCell {
    /// Index in the plan.
    pub(crate) index: usize,
    /// Content address.
    pub(crate) hash: String,
    /// `key = value, …`.
    pub(crate) label: String,
    /// Axis values.
    pub(crate) axes: Vec<(String, serde_json::Value)>,
    /// Reference key, when the experiment has a reference.
    pub(crate) reference: Option<String>,
    /// Key of the march this cell shares (cells with equal keys render together).
    pub(crate) march_key: String,
    /// Rendering method.
    pub(crate) method: String,
}

/// `plan.json`: everything `sweep report` and `sweep status` need to know about a run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct PlanRecord {
    /// Experiment name.
    pub(crate) experiment: String,
    /// The experiment file as given.
    pub(crate) experiment_file: PathBuf,
    /// Its sha256.
    pub(crate) experiment_sha256: String,
    /// Quality preset.
    pub(crate) quality: String,
    /// The command line.
    pub(crate) command: Vec<String>,
    /// Program version.
    pub(crate) version: String,
    /// Axis keys in grid order.
    pub(crate) axes: Vec<String>,
    /// The cells.
    pub(crate) cells: Vec<PlannedCell>,
}

/// Reads `plan.json` of an output folder.
pub(crate) fn read_plan(out: &OutputDir) -> Result<PlanRecord> {
    if !out.plan().exists() {
        anyhow::bail!(
            "{}: no plan.json (is this the output folder of a sweep run?)",
            out.root().display()
        );
    }
    let text = read_record_text(&out.plan(), "plan record (plan.json)")?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", out.plan().display()))
}

/// How a reference is made (`[reference] method` in an experiment).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum ReferenceMethod {
    /// The unbiased reference path tracer, refined progressively.
    #[default]
    Path,
    /// A photon-mapping render with many photons.
    Photon,
}

impl ReferenceMethod {
    /// The name as written in experiment files and records.
    pub(crate) fn name(self) -> &'static str {
        match self {
            ReferenceMethod::Path => "path",
            ReferenceMethod::Photon => "photon",
        }
    }
}

/// `references/<key>/reference.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct ReferenceRecord {
    /// Content address.
    pub(crate) key: String,
    /// How it was made.
    pub(crate) method: ReferenceMethod,
    /// Path-tracer samples per pixel accumulated.
    pub(crate) passes: u32,
    /// Seconds spent on it in total.
    pub(crate) seconds: f64,
    /// The scene it rendered.
    pub(crate) scene: SceneParams,
    /// Volume provenance.
    pub(crate) volume: VolumeSource,
    /// Program version.
    pub(crate) version: String,
    /// Size and sha256 of `reference.exr` and `reference.png` (empty in older records).
    #[serde(default)]
    pub(crate) files: Vec<FileCheck>,
}

/// Reads a reference's record.
pub(crate) fn read_reference_record(dir: &Path) -> Result<ReferenceRecord> {
    let path = dir.join("reference.json");
    let text = read_record_text(&path, "reference record")?;
    Ok(serde_json::from_str(&text)?)
}

/// Writes `plan.json` and the experiment's source beside it (idempotent: the same plan
/// writes the same content).
pub(crate) fn write_plan(
    out: &OutputDir,
    plan: &PlanRecord,
    experiment_source: &str,
) -> Result<()> {
    volphot::write_atomic(
        &out.root().join("experiment.toml"),
        experiment_source.as_bytes(),
    )?;
    volphot::write_atomic(&out.plan(), serde_json::to_string_pretty(plan)?.as_bytes())?;
    Ok(())
}

/// Writes a cell's errors against reference `key` (`vs-<key>.json`).
pub(crate) fn write_reference_metrics(
    dir: &Path,
    key: &str,
    metrics: &ReferenceMetrics,
) -> Result<()> {
    volphot::write_atomic(
        &dir.join(format!("vs-{key}.json")),
        serde_json::to_string_pretty(metrics)?.as_bytes(),
    )?;
    Ok(())
}

/// Writes a reference's record (`reference.json`) into `dir`.
pub(crate) fn write_reference_record(dir: &Path, record: &ReferenceRecord) -> Result<()> {
    volphot::write_atomic(
        &dir.join("reference.json"),
        serde_json::to_string_pretty(record)?.as_bytes(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::fill_in_old_settings;

    #[test]
    fn old_records_read_back_with_the_settings_they_were_rendered_with() {
        let mut old = serde_json::json!({ "scene": { "integrator": { "nused": 150 } } });
        fill_in_old_settings(&mut old);
        let integrator = &old["scene"]["integrator"];
        assert_eq!(
            integrator["shadow_tolerance"].as_f64(),
            Some(0.05f32 as f64)
        );
        assert_eq!(integrator["thin_below"].as_f64(), Some(0.0));
        assert_eq!(integrator["nused"].as_u64(), Some(150));
        // A record that writes them keeps what it wrote.
        let written = serde_json::json!({
            "scene": { "integrator": { "shadow_tolerance": 0.025, "thin_below": 0.5 } }
        });
        let mut read = written.clone();
        fill_in_old_settings(&mut read);
        assert_eq!(read, written);
    }
}
