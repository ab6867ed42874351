//! Cells on disk: content addresses, records, and the metric columns of `cells.csv`.
//!
//! Every cell lives in `OUTPUT/cells/<hash>/` where `<hash>` is the first 16 hex digits of
//! the sha256 of the program version, the cell's effective scene parameters and the identity
//! of its volume (sha256 of the file, or the phantom's parameters). A cell is finished when
//! its `cell.json` exists: the folder is filled under a temporary name and renamed into
//! place, so an interrupted run leaves no half-written cell.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use volphot::photon::PhotonStats;
use volphot::render::Provenance;
use volphot::scene::SceneParams;

use crate::experiment::CellSpec;

/// Program version recorded in every output.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Version of the reference metrics; stored metrics of another version are recomputed.
pub const REFERENCE_METRICS_VERSION: u32 = 2;

/// Version of [`ImageStats`]; records with an older one are recomputed from the cell's
/// `film.exr` when a report is collected (version 2 added the mean display luminance).
pub const IMAGE_STATS_VERSION: u32 = 2;

/// Image-error metrics against the reference.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ReferenceMetrics {
    /// [`REFERENCE_METRICS_VERSION`] when computed.
    #[serde(default)]
    pub version: u32,
    /// Which reference (its content address).
    pub reference: String,
    /// Root-mean-square error of linear radiance.
    pub rmse: f64,
    /// Mean of `(x − y)² / (y² + 0.01·mean(y)²)` (relative MSE, robust near black).
    pub rel_mse: f64,
    /// SSIM of the tone-mapped images (image-compare's MSSIM on luma, 1 = identical).
    pub ssim: f64,
    /// Mean FLIP error of the tone-mapped images (nv-flip, 0 = identical).
    pub flip: f64,
    /// Disco score of the multiple layer relative to the reference's (blobs the truth
    /// lacks); see `disco::relative_disco_score`.
    #[serde(default)]
    pub disco_excess: f64,
    /// Blobs counted by that score.
    #[serde(default)]
    pub disco_excess_blobs: u64,
    /// Seconds to compute these.
    pub seconds: f64,
}

/// The disco-ball artifact score of the multiple-scattering layer (see `disco`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiscoScore {
    /// Fraction of the layer's energy inside detected blobs.
    pub energy: f64,
    /// Number of blobs.
    pub blobs: u64,
    /// Fraction of the object's area covered by blobs.
    pub area: f64,
}

/// What multiple scattering changes in the displayed image (thesis §1.1): detail, regions
/// lit only by it, depth cues. All on tone-mapped (sRGB) luminance in [0, 1] over the
/// object's pixels; `single` = the cell's single-scattering layer alone, `total` = what the
/// cell displays.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImageStats {
    /// [`IMAGE_STATS_VERSION`] when computed (0 in records written before versioning).
    #[serde(default)]
    pub version: u32,
    /// Mean display luminance, single scattering only.
    #[serde(default)]
    pub luma_single: f64,
    /// Mean display luminance of the displayed image.
    #[serde(default)]
    pub luma_total: f64,
    /// Mean Sobel gradient magnitude, single scattering only.
    pub gradient_single: f64,
    /// Mean Sobel gradient magnitude, displayed image.
    pub gradient_total: f64,
    /// Mean |L − G₂∗L| (fine local contrast, Gaussian σ = 2 px), single only.
    pub detail_single: f64,
    /// The same for the displayed image.
    pub detail_total: f64,
    /// Share of object pixels darker than 0.05 with single scattering but not in the
    /// displayed image.
    pub lit_by_multiple: f64,
    /// Pearson correlation of luminance and depth (negative: farther is darker), single.
    pub depth_corr_single: f64,
    /// The same for the displayed image.
    pub depth_corr_total: f64,
    /// Share of object pixels clipped to white in the displayed image ("over-brightening").
    pub clipped_total: f64,
    /// Share of object pixels whose eye ray reached transmittance ½ (an opaque look);
    /// low values mean a transparent rendering (thesis C6).
    pub opaque_share: f64,
}

/// Timings of one cell, seconds.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CellTimings {
    /// Photon tracing of the cell's photon map (shared maps count fully for each cell).
    pub photon_tracing: f64,
    /// kd-tree build of the cell's photon map.
    pub tree_build: f64,
    /// The march that produced the cell (shared by `march_shared_by` cells).
    pub render: f64,
    /// Metrics of this cell.
    pub metrics: f64,
    /// Cells produced by the same march.
    pub march_shared_by: usize,
    /// Cells using the same photon map.
    pub map_shared_by: usize,
}

/// Everything recorded about a finished cell (`cell.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CellRecord {
    /// Index in the plan that produced it.
    pub index: usize,
    /// Content address.
    pub hash: String,
    /// `key = value, …`.
    pub label: String,
    /// Axis values (JSON).
    pub axes: Vec<(String, serde_json::Value)>,
    /// Effective parameters and sources (flattened: `scene`, `volume`, `transfer`,
    /// `sigma_mapping`, `sigma` in the JSON).
    #[serde(flatten)]
    pub provenance: Provenance,
    /// Photon statistics (when the cell used a photon map).
    pub photons: Option<PhotonStats>,
    /// Timings.
    pub timings: CellTimings,
    /// Peak resident memory of the process after the cell, bytes.
    pub peak_memory_bytes: Option<u64>,
    /// Mean radiance of the single-scattering layer.
    pub mean_single: f64,
    /// Mean radiance of the multiple-scattering layer.
    pub mean_multiple: f64,
    /// Mean radiance of the emission layer.
    pub mean_emission: f64,
    /// Disco-ball score of the multiple layer.
    pub disco: DiscoScore,
    /// Detail, lit regions and depth cues of single vs displayed image.
    pub image: ImageStats,
    /// Program version.
    pub version: String,
    /// Worker threads.
    pub threads: usize,
    /// Host that rendered it.
    pub host: String,
}

/// A column of `cells.csv` computed from a record.
pub struct MetricColumn {
    /// Key used in plot specifications.
    pub key: &'static str,
    /// CSV header with unit.
    pub header: &'static str,
    /// Extractor.
    pub value: fn(&CellRecord, Option<&ReferenceMetrics>) -> Option<f64>,
}

fn ratio(a: f64, b: f64) -> Option<f64> {
    (b > 0.0).then(|| a / b)
}

fn extent_pct(r: &CellRecord, d: f64) -> f64 {
    100.0 * d / r.provenance.sigma.largest_extent as f64
}

/// The metric columns, in CSV order.
pub const METRIC_COLUMNS: &[MetricColumn] = &[
    MetricColumn {
        key: "time_photons",
        header: "time_photons [s]",
        value: |r, _| Some(r.timings.photon_tracing),
    },
    MetricColumn {
        key: "time_tree",
        header: "time_tree [s]",
        value: |r, _| Some(r.timings.tree_build),
    },
    MetricColumn {
        key: "time_render",
        header: "time_render [s]",
        value: |r, _| Some(r.timings.render),
    },
    MetricColumn {
        key: "time_metrics",
        header: "time_metrics [s]",
        value: |r, m| Some(r.timings.metrics + m.map_or(0.0, |m| m.seconds)),
    },
    MetricColumn {
        key: "march_shared_by",
        header: "march_shared_by [cells]",
        value: |r, _| Some(r.timings.march_shared_by as f64),
    },
    MetricColumn {
        key: "peak_memory",
        header: "peak_memory [MiB]",
        value: |r, _| r.peak_memory_bytes.map(|b| b as f64 / 1048576.0),
    },
    MetricColumn {
        key: "photons_emitted",
        header: "photons_emitted [count]",
        value: |r, _| r.photons.as_ref().map(|p| p.emitted as f64),
    },
    MetricColumn {
        key: "photons_stored",
        header: "photons_stored [count]",
        value: |r, _| r.photons.as_ref().map(|p| p.stored as f64),
    },
    MetricColumn {
        key: "empirical_mfp",
        header: "empirical_mfp [% extent]",
        value: |r, _| {
            r.photons
                .as_ref()
                .map(|p| extent_pct(r, p.mean_flight_distance))
        },
    },
    MetricColumn {
        key: "nominal_mfp",
        header: "nominal_mfp [% extent]",
        value: |r, _| Some(r.provenance.sigma.mean_free_path_percent as f64),
    },
    MetricColumn {
        key: "median_mfp",
        header: "median_mfp [% extent]",
        value: |r, _| Some(r.provenance.sigma.median_free_path_percent as f64),
    },
    MetricColumn {
        key: "sigma_t_dmin",
        header: "sigma_t_dmin [1/world unit]",
        value: |r, _| Some(r.provenance.sigma.sigma_t_at_dmin as f64),
    },
    MetricColumn {
        key: "d_min",
        header: "d_min [1]",
        value: |r, _| Some(r.provenance.sigma.d_min as f64),
    },
    MetricColumn {
        key: "mean_single",
        header: "mean_single [W/(m2 sr)]",
        value: |r, _| Some(r.mean_single),
    },
    MetricColumn {
        key: "mean_multiple",
        header: "mean_multiple [W/(m2 sr)]",
        value: |r, _| Some(r.mean_multiple),
    },
    MetricColumn {
        key: "mean_emission",
        header: "mean_emission [W/(m2 sr)]",
        value: |r, _| Some(r.mean_emission),
    },
    MetricColumn {
        key: "ms_share",
        header: "ms_share [1]",
        value: |r, _| {
            let total = r.mean_single + r.mean_multiple + r.mean_emission;
            (total > 0.0).then(|| r.mean_multiple / total)
        },
    },
    MetricColumn {
        key: "rmse",
        header: "rmse [W/(m2 sr)]",
        value: |_, m| m.map(|m| m.rmse),
    },
    MetricColumn {
        key: "rel_mse",
        header: "rel_mse [1]",
        value: |_, m| m.map(|m| m.rel_mse),
    },
    MetricColumn {
        key: "ssim",
        header: "ssim [1]",
        value: |_, m| m.map(|m| m.ssim),
    },
    MetricColumn {
        key: "flip",
        header: "flip [1]",
        value: |_, m| m.map(|m| m.flip),
    },
    MetricColumn {
        key: "gradient_single",
        header: "gradient_single [1/px]",
        value: |r, _| Some(r.image.gradient_single),
    },
    MetricColumn {
        key: "gradient_total",
        header: "gradient_total [1/px]",
        value: |r, _| Some(r.image.gradient_total),
    },
    MetricColumn {
        key: "detail_single",
        header: "detail_single [1]",
        value: |r, _| Some(r.image.detail_single),
    },
    MetricColumn {
        key: "detail_total",
        header: "detail_total [1]",
        value: |r, _| Some(r.image.detail_total),
    },
    MetricColumn {
        key: "lit_by_multiple",
        header: "lit_by_multiple [1]",
        value: |r, _| Some(r.image.lit_by_multiple),
    },
    MetricColumn {
        key: "depth_corr_single",
        header: "depth_corr_single [1]",
        value: |r, _| Some(r.image.depth_corr_single),
    },
    MetricColumn {
        key: "depth_corr_total",
        header: "depth_corr_total [1]",
        value: |r, _| Some(r.image.depth_corr_total),
    },
    MetricColumn {
        key: "clipped_total",
        header: "clipped_total [1]",
        value: |r, _| Some(r.image.clipped_total),
    },
    MetricColumn {
        key: "luma_single",
        header: "luma_single [1]",
        value: |r, _| Some(r.image.luma_single),
    },
    MetricColumn {
        key: "luma_total",
        header: "luma_total [1]",
        value: |r, _| Some(r.image.luma_total),
    },
    // Local contrast relative to brightness (Weber-like): whether multiple scattering adds
    // detail, or only makes the same detail brighter (thesis §1.1, C8 "not more detail").
    MetricColumn {
        key: "contrast_single",
        header: "contrast_single [1]",
        value: |r, _| ratio(r.image.detail_single, r.image.luma_single),
    },
    MetricColumn {
        key: "contrast_total",
        header: "contrast_total [1]",
        value: |r, _| ratio(r.image.detail_total, r.image.luma_total),
    },
    MetricColumn {
        key: "opaque_share",
        header: "opaque_share [1]",
        value: |r, _| Some(r.image.opaque_share),
    },
    MetricColumn {
        key: "disco_excess",
        header: "disco_excess [1]",
        value: |_, m| m.map(|m| m.disco_excess),
    },
    MetricColumn {
        key: "disco_excess_blobs",
        header: "disco_excess_blobs [count]",
        value: |_, m| m.map(|m| m.disco_excess_blobs as f64),
    },
    MetricColumn {
        key: "disco_energy",
        header: "disco_energy [1]",
        value: |r, _| Some(r.disco.energy),
    },
    MetricColumn {
        key: "disco_blobs",
        header: "disco_blobs [count]",
        value: |r, _| Some(r.disco.blobs as f64),
    },
    MetricColumn {
        key: "disco_area",
        header: "disco_area [1]",
        value: |r, _| Some(r.disco.area),
    },
];

/// The identity of a cell's volume without loading it.
pub fn volume_identity(params: &SceneParams, base: &Path) -> Result<String> {
    let v = &params.volume;
    if let Some(d) = &v.dataset {
        let info = volphot::volume::registry::find(d)?;
        return Ok(info.sha256.to_string());
    }
    if let Some(p) = &v.phantom {
        return Ok(format!("phantom:{}:{}", p.name, p.describe()));
    }
    if let Some(f) = &v.file {
        let path = base.join(f);
        return volphot::checksum::sha256_cached(&path)
            .with_context(|| format!("hashing volume file {}", path.display()));
    }
    Ok(String::new())
}

/// The content address of a cell: version, effective parameters, volume (and transfer
/// function file) identity.
pub fn cell_hash(spec: &CellSpec) -> Result<String> {
    let mut text = format!("volphot-sweep {VERSION}\n");
    text += &serde_json::to_string(&spec.params)?;
    text += "\n";
    text += &volume_identity(&spec.params, &spec.base_dir)?;
    if let Some(f) = &spec.params.transfer.file {
        let path = spec.base_dir.join(f);
        text += "\n";
        text +=
            &volphot::checksum::sha256_cached(&path).unwrap_or_else(|_| path.display().to_string());
    }
    Ok(volphot::checksum::sha256_bytes(text.as_bytes())[..16].to_string())
}

/// Paths inside an output folder.
#[derive(Debug, Clone)]
pub struct OutputDir {
    root: PathBuf,
}

impl OutputDir {
    /// The output folder.
    pub fn new(root: impl Into<PathBuf>) -> Self {
        OutputDir { root: root.into() }
    }

    /// The folder itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `cells/<hash>`.
    pub fn cell(&self, hash: &str) -> PathBuf {
        self.root.join("cells").join(hash)
    }

    /// `references/<key>`.
    pub fn reference(&self, key: &str) -> PathBuf {
        self.root.join("references").join(key)
    }

    /// `failed/<hash>.txt`: the error of a failed cell.
    pub fn failure(&self, hash: &str) -> PathBuf {
        self.root.join("failed").join(format!("{hash}.txt"))
    }

    /// `figures/`.
    pub fn figures(&self) -> PathBuf {
        self.root.join("figures")
    }

    /// The plan written by `run` (`plan.json`).
    pub fn plan(&self) -> PathBuf {
        self.root.join("plan.json")
    }
}

/// Whether a cell has finished (its record exists).
pub fn is_done(dir: &Path) -> bool {
    dir.join("cell.json").is_file()
}

/// Reads a finished cell's record.
pub fn read_record(dir: &Path) -> Result<CellRecord> {
    let path = dir.join("cell.json");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

/// Writes a cell's record (`cell.json`) atomically.
pub fn write_record(dir: &Path, record: &CellRecord) -> Result<()> {
    volphot::fsutil::write_atomic(
        &dir.join("cell.json"),
        serde_json::to_string_pretty(record)?.as_bytes(),
    )?;
    Ok(())
}

/// Reads the reference metrics of a cell for one reference, if computed.
pub fn read_reference_metrics(dir: &Path, reference: &str) -> Option<ReferenceMetrics> {
    let text = std::fs::read_to_string(dir.join(format!("vs-{reference}.json"))).ok()?;
    serde_json::from_str::<ReferenceMetrics>(&text)
        .ok()
        .filter(|m| m.version == REFERENCE_METRICS_VERSION)
}

/// A cell folder being filled: a temporary sibling renamed into place by [`StagedDir::commit`].
pub struct StagedDir {
    tmp: PathBuf,
    target: PathBuf,
}

impl StagedDir {
    /// Creates `.<target>.tmp-<host>-<pid>` (removing a stale one).
    pub fn new(target: &Path) -> Result<Self> {
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp =
            target.with_file_name(format!(".{name}.tmp-{}-{}", hostname(), std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        Ok(StagedDir {
            tmp,
            target: target.to_path_buf(),
        })
    }

    /// Where to write files.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Renames the folder into place (replacing an unfinished one).
    pub fn commit(self) -> Result<()> {
        if self.target.exists() && !is_done(&self.target) {
            let _ = std::fs::remove_dir_all(&self.target);
        }
        std::fs::rename(&self.tmp, &self.target)
            .with_context(|| format!("moving {} to {}", self.tmp.display(), self.target.display()))
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        // Not committed (error or panic): leave nothing half-written behind.
        let _ = std::fs::remove_dir_all(&self.tmp);
    }
}

/// This machine's host name (cells rendered on a cluster record where they ran).
pub fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .ok()
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "localhost".into())
}

/// Removes temporary folders left by processes of this host that no longer run. Folders
/// of other hosts (a shared file system on a cluster) are left alone.
pub fn clean_stale(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let host = hostname();
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some((_, owner)) = name.rsplit_once(".tmp-") else {
            continue;
        };
        let Some((owner_host, pid)) = owner.rsplit_once('-') else {
            continue;
        };
        if owner_host == host
            && let Ok(pid) = pid.parse::<u32>()
            && !Path::new(&format!("/proc/{pid}")).exists()
        {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}
