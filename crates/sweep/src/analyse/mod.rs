//! Films → numbers: what a finished cell's image says (disco-ball score, detail, lit
//! regions, depth cues), its errors against the reference (RMSE, also with the reference's
//! noise removed, relMSE, SSIM, FLIP, disco excess), the metric column schema that turns records into `cells.csv`,
//! and the one rule for an effect over seeds ([`Verdict`]) that the report and `sweep claims` share.

mod agreement;
mod columns;
mod disco;
mod images;
mod verdict;

use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use volphot::{Film, Layer, SceneParams};

pub(crate) use agreement::{Agreement, agreement, mse_against_noisy_reference};
pub(crate) use columns::{METRIC_COLUMNS, MetricColumn, derived_columns, is_metric, metric_keys};
pub(crate) use images::{
    compare, disco, disco_excess, displayed, flip_map, image_stats, luminance,
};
pub(crate) use verdict::{MIN_SEEDS, Paired, Verdict};

use crate::store::{
    DiscoScore, ImageStats, OutputDir, read_reference_record, write_reference_metrics,
};

/// What a cell's own film says, without a reference.
pub(crate) struct CellAnalysis {
    /// The image the cell displays (its layers summed).
    pub(crate) shown: Vec<Vec3>,
    /// Disco-ball score of the multiple layer.
    pub(crate) disco: DiscoScore,
    /// Detail, lit regions and depth cues.
    pub(crate) image: ImageStats,
    /// Seconds spent.
    pub(crate) seconds: f64,
}

/// Analyses a cell's film as its scene displays it.
pub(crate) fn analyse_cell(film: &Film, params: &SceneParams) -> CellAnalysis {
    let start = Instant::now();
    let disco = disco(film);
    let shown = displayed(film, params.integrator.multiple, params.integrator.emission);
    let image = image_stats(film, &shown, params.film.exposure);
    CellAnalysis {
        shown,
        disco,
        image,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Computes and stores `vs-<reference>.json` for a cell, if the reference exists. The
/// reference shows the same layers as the cell (single only for `multiple = false`).
pub(crate) fn compare_with_reference(
    out: &OutputDir,
    hash: &str,
    key: &str,
    params: &SceneParams,
    film: &Film,
) -> Result<()> {
    let ref_dir = out.reference(key);
    let Ok(record) = read_reference_record(&ref_dir) else {
        return Ok(());
    };
    let reference = Film::read_exr(&ref_dir.join("reference.exr"))?;
    let [w, h] = params.camera.resolution.map(|n| n as usize);
    anyhow::ensure!(
        reference.width() == w && reference.height() == h,
        "reference {key} is {}×{}, cell is {w}×{h}",
        reference.width(),
        reference.height()
    );
    let layers = Layer::shown(params.integrator.multiple, params.integrator.emission);
    let ref_img = reference.combine(&layers);
    let shown = film.combine(&layers);
    let variance = reference.variance_of_sum(&layers);
    let mut m = compare(
        &shown,
        &ref_img,
        variance.as_deref(),
        [w, h],
        params.film.exposure,
        key,
    );
    m.reference_passes = record.passes;
    if params.integrator.multiple {
        // Counted in `seconds` with the other errors (it costs about as much as they do).
        let start = Instant::now();
        let excess = disco_excess(film, &reference);
        m.disco_excess = excess.energy;
        m.disco_excess_blobs = excess.blobs;
        m.seconds += start.elapsed().as_secs_f64();
    }
    write_reference_metrics(&out.cell(hash), key, &m)
}
