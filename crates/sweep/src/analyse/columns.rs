//! The metric columns of `cells.csv`: each a key (used in plot specifications), a header
//! with its unit, and an extractor from a cell's record and its errors against the
//! reference. Add a metric here and it appears in the CSV, the plots and the report.

use crate::store::{CellRecord, ReferenceMetrics};

/// What a column's number is: read off the render, or a formula.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Measured by the render: its image, its photon map, its clock.
    Measured,
    /// A formula of other measured columns (the formula).
    Ratio(&'static str),
    /// A formula of the cell's settings and its volume: nothing rendered enters it (the
    /// formula). A document never presents it as a finding.
    Derived(&'static str),
}

/// A column of `cells.csv` computed from a record.
pub(crate) struct MetricColumn {
    /// Key used in plot specifications.
    pub(crate) key: &'static str,
    /// CSV header with unit.
    pub(crate) header: &'static str,
    /// Measured, or a formula.
    pub(crate) kind: Kind,
    /// Extractor.
    pub(crate) value: fn(&CellRecord, Option<&ReferenceMetrics>) -> Option<f64>,
}

fn ratio(a: f64, b: f64) -> Option<f64> {
    (b > 0.0).then(|| a / b)
}

/// A value that only exists where multiple scattering was rendered: the share of the
/// multiple layer, the disco-ball scores of that layer. Without it they are undefined, not 0
/// (a 0 averaged into a plot halved the share, issue #49).
fn with_multiple(r: &CellRecord, value: f64) -> Option<f64> {
    r.provenance.scene.integrator.multiple.then_some(value)
}

fn extent_pct(r: &CellRecord, d: f64) -> f64 {
    100.0 * d / r.provenance.sigma.largest_extent as f64
}

/// The column of photons stored from light `index` (from 0).
const fn stored_by_light(key: &'static str, header: &'static str, index: usize) -> MetricColumn {
    MetricColumn {
        key,
        header,
        kind: Kind::Measured,
        value: match index {
            0 => |r, _| stored_from(r, 0),
            1 => |r, _| stored_from(r, 1),
            2 => |r, _| stored_from(r, 2),
            _ => |r, _| stored_from(r, 3),
        },
    }
}

fn stored_from(r: &CellRecord, index: usize) -> Option<f64> {
    let photons = r.photons.as_ref()?;
    photons.stored_per_light.get(index).map(|&n| n as f64)
}

/// The metric columns, in CSV order.
pub(crate) const METRIC_COLUMNS: &[MetricColumn] = &[
    MetricColumn {
        key: "time_photons",
        header: "time_photons [s]",
        kind: Kind::Measured,
        value: |r, _| Some(r.timings.photon_tracing),
    },
    MetricColumn {
        key: "time_tree",
        header: "time_tree [s]",
        kind: Kind::Measured,
        value: |r, _| Some(r.timings.tree_build),
    },
    // A march shared by several cells (variants of nused, maxdist, … rendered in one pass)
    // is timed once: each cell is attributed an equal share, and the march's whole time is
    // its own column, so summing `time_render` over a study gives the time it took.
    MetricColumn {
        key: "time_render",
        header: "time_render [s]",
        kind: Kind::Ratio("time_march / march_shared_by"),
        value: |r, _| Some(r.timings.render / r.timings.march_shared_by.max(1) as f64),
    },
    MetricColumn {
        key: "time_march",
        header: "time_march [s]",
        kind: Kind::Measured,
        value: |r, _| Some(r.timings.render),
    },
    MetricColumn {
        key: "time_metrics",
        header: "time_metrics [s]",
        kind: Kind::Measured,
        value: |r, m| Some(r.timings.metrics + m.map_or(0.0, |m| m.seconds)),
    },
    MetricColumn {
        key: "march_shared_by",
        header: "march_shared_by [cells]",
        kind: Kind::Derived("the number of cells the plan renders from one march"),
        value: |r, _| Some(r.timings.march_shared_by as f64),
    },
    MetricColumn {
        key: "peak_memory",
        header: "peak_memory [MiB]",
        kind: Kind::Measured,
        value: |r, _| r.peak_memory_bytes.map(|b| b as f64 / 1048576.0),
    },
    MetricColumn {
        key: "photons_emitted",
        header: "photons_emitted [count]",
        kind: Kind::Derived(
            "volume_photons (photons_per_iteration for an iterating render; with stored_photons, the count whose map reached it)",
        ),
        value: |r, _| r.photons.as_ref().map(|p| p.emitted as f64),
    },
    MetricColumn {
        key: "photons_stored",
        header: "photons_stored [count]",
        kind: Kind::Measured,
        value: |r, _| r.photons.as_ref().map(|p| p.stored as f64),
    },
    // Stored photons per light, in the scene's light order (the three-point preset: key,
    // fill, rim; in the cinematic style: key, sky): whether every light's share of the map
    // is resolved, not only the sum. Empty for lights the scene does not have.
    stored_by_light("photons_stored_light1", "photons_stored_light1 [count]", 0),
    stored_by_light("photons_stored_light2", "photons_stored_light2 [count]", 1),
    stored_by_light("photons_stored_light3", "photons_stored_light3 [count]", 2),
    stored_by_light("photons_stored_light4", "photons_stored_light4 [count]", 3),
    MetricColumn {
        key: "empirical_mfp",
        header: "empirical_mfp [% extent]",
        kind: Kind::Measured,
        value: |r, _| {
            r.photons
                .as_ref()
                .map(|p| extent_pct(r, p.mean_flight_distance))
        },
    },
    // The measured median of the same flights (issue "Conclusions that hold up": the C2
    // table's median was `median_mfp`, a formula whose ratio to the mean is ln 2 exactly).
    MetricColumn {
        key: "median_flight",
        header: "median_flight [% extent]",
        kind: Kind::Measured,
        value: |r, _| {
            r.photons
                .as_ref()
                .filter(|p| p.median_flight_distance > 0.0)
                .map(|p| extent_pct(r, p.median_flight_distance))
        },
    },
    MetricColumn {
        key: "nominal_mfp",
        header: "nominal_mfp [% extent]",
        kind: Kind::Derived("100 / (σt(d_min) · largest extent)"),
        value: |r, _| Some(r.provenance.sigma.mean_free_path_percent as f64),
    },
    MetricColumn {
        key: "median_mfp",
        header: "median_mfp [% extent]",
        kind: Kind::Derived(
            "nominal_mfp · ln 2, the median of an exponential free path at σt(d_min)",
        ),
        value: |r, _| Some(r.provenance.sigma.median_free_path_percent as f64),
    },
    MetricColumn {
        key: "sigma_t_dmin",
        header: "sigma_t_dmin [1/world unit]",
        kind: Kind::Derived("the σ mapping at d_min"),
        value: |r, _| Some(r.provenance.sigma.sigma_t_at_dmin as f64),
    },
    MetricColumn {
        key: "d_min",
        header: "d_min [1]",
        kind: Kind::Derived("the smallest density above 0 after the transfer function"),
        value: |r, _| Some(r.provenance.sigma.d_min as f64),
    },
    MetricColumn {
        key: "mean_single",
        header: "mean_single [W/(m2 sr)]",
        kind: Kind::Measured,
        value: |r, _| Some(r.mean_single),
    },
    MetricColumn {
        key: "mean_multiple",
        header: "mean_multiple [W/(m2 sr)]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, r.mean_multiple),
    },
    MetricColumn {
        key: "mean_emission",
        header: "mean_emission [W/(m2 sr)]",
        kind: Kind::Measured,
        value: |r, _| Some(r.mean_emission),
    },
    MetricColumn {
        key: "ms_share",
        header: "ms_share [1]",
        kind: Kind::Ratio("mean_multiple / (mean_single + mean_multiple + mean_emission)"),
        value: |r, _| {
            let total = r.mean_single + r.mean_multiple + r.mean_emission;
            with_multiple(r, r.mean_multiple / total).filter(|_| total > 0.0)
        },
    },
    MetricColumn {
        key: "rmse",
        header: "rmse [W/(m2 sr)]",
        kind: Kind::Measured,
        value: |_, m| m.map(|m| m.rmse),
    },
    MetricColumn {
        key: "rmse_corrected",
        header: "rmse_corrected [W/(m2 sr)]",
        kind: Kind::Measured,
        value: |_, m| m.and_then(|m| m.rmse_corrected),
    },
    MetricColumn {
        key: "rel_mse",
        header: "rel_mse [1]",
        kind: Kind::Measured,
        value: |_, m| m.map(|m| m.rel_mse),
    },
    MetricColumn {
        key: "ssim",
        header: "ssim [1]",
        kind: Kind::Measured,
        value: |_, m| m.map(|m| m.ssim),
    },
    MetricColumn {
        key: "flip",
        header: "flip [1]",
        kind: Kind::Measured,
        value: |_, m| m.map(|m| m.flip),
    },
    MetricColumn {
        key: "gradient_single",
        header: "gradient_single [1/px]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.gradient_single),
    },
    MetricColumn {
        key: "gradient_total",
        header: "gradient_total [1/px]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.gradient_total),
    },
    MetricColumn {
        key: "detail_single",
        header: "detail_single [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.detail_single),
    },
    MetricColumn {
        key: "detail_total",
        header: "detail_total [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.detail_total),
    },
    MetricColumn {
        key: "lit_by_multiple",
        header: "lit_by_multiple [1]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, r.image.lit_by_multiple),
    },
    MetricColumn {
        key: "depth_corr_single",
        header: "depth_corr_single [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.depth_corr_single),
    },
    MetricColumn {
        key: "depth_corr_total",
        header: "depth_corr_total [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.depth_corr_total),
    },
    MetricColumn {
        key: "clipped_total",
        header: "clipped_total [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.clipped_total),
    },
    MetricColumn {
        key: "luma_single",
        header: "luma_single [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.luma_single),
    },
    MetricColumn {
        key: "luma_total",
        header: "luma_total [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.luma_total),
    },
    // Local contrast relative to brightness (Weber-like): whether multiple scattering adds
    // detail, or only makes the same detail brighter (thesis §1.1, C8 "not more detail").
    MetricColumn {
        key: "contrast_single",
        header: "contrast_single [1]",
        kind: Kind::Ratio("detail_single / luma_single"),
        value: |r, _| ratio(r.image.detail_single, r.image.luma_single),
    },
    MetricColumn {
        key: "contrast_total",
        header: "contrast_total [1]",
        kind: Kind::Ratio("detail_total / luma_total"),
        value: |r, _| ratio(r.image.detail_total, r.image.luma_total),
    },
    MetricColumn {
        key: "opaque_share",
        header: "opaque_share [1]",
        kind: Kind::Measured,
        value: |r, _| Some(r.image.opaque_share),
    },
    MetricColumn {
        key: "disco_excess",
        header: "disco_excess [1]",
        kind: Kind::Measured,
        value: |r, m| with_multiple(r, m?.disco_excess),
    },
    MetricColumn {
        key: "disco_excess_blobs",
        header: "disco_excess_blobs [count]",
        kind: Kind::Measured,
        value: |r, m| with_multiple(r, m?.disco_excess_blobs as f64),
    },
    MetricColumn {
        key: "disco_energy",
        header: "disco_energy [1]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, r.disco.energy),
    },
    MetricColumn {
        key: "disco_blobs",
        header: "disco_blobs [count]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, r.disco.blobs as f64),
    },
    MetricColumn {
        key: "disco_area",
        header: "disco_area [1]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, r.disco.area),
    },
    MetricColumn {
        key: "thinning_bias_single",
        header: "thinning_bias_single [1]",
        kind: Kind::Measured,
        value: |r, _| thinning(r, |t| t.single).map(|b| b.mean),
    },
    MetricColumn {
        key: "thinning_p99_single",
        header: "thinning_p99_single [1]",
        kind: Kind::Measured,
        value: |r, _| thinning(r, |t| t.single).map(|b| b.p99),
    },
    MetricColumn {
        key: "thinning_bias_multiple",
        header: "thinning_bias_multiple [1]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, thinning(r, |t| t.multiple)?.mean),
    },
    MetricColumn {
        key: "thinning_p99_multiple",
        header: "thinning_p99_multiple [1]",
        kind: Kind::Measured,
        value: |r, _| with_multiple(r, thinning(r, |t| t.multiple)?.p99),
    },
];

/// A layer's thinning error, measured by the render on its probe pixels (cells rendered
/// with `thin_below > 0`).
fn thinning(
    r: &CellRecord,
    layer: fn(&volphot::ThinningError) -> Option<volphot::ErrorBound>,
) -> Option<volphot::ErrorBound> {
    layer(r.cache_error.as_ref()?.thinning.as_ref()?)
}

/// The columns that are formulas of settings, with their formulas (for the documentation
/// of `cells.csv`, which a test holds to this list).
pub(crate) fn derived_columns() -> Vec<(&'static str, &'static str)> {
    METRIC_COLUMNS
        .iter()
        .filter_map(|m| match m.kind {
            Kind::Derived(f) => Some((m.key, f)),
            _ => None,
        })
        .collect()
}

/// Whether `key` names a metric column.
pub(crate) fn is_metric(key: &str) -> bool {
    METRIC_COLUMNS.iter().any(|m| m.key == key)
}

/// Every metric key, comma-separated (for error messages).
pub(crate) fn metric_keys() -> String {
    METRIC_COLUMNS
        .iter()
        .map(|m| m.key)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The documentation of `cells.csv` names exactly the derived columns, with their
    /// formulas: a formula must never pass for a measurement.
    #[test]
    fn the_documentation_lists_every_derived_column() {
        let doc = include_str!("../../../../docs/experiments.md");
        let table = doc
            .split("### Measured and derived columns")
            .nth(1)
            .expect("docs/experiments.md has the section");
        for (key, formula) in derived_columns() {
            let row = format!("| `{key}` |");
            let line = table
                .lines()
                .find(|l| l.starts_with(&row))
                .unwrap_or_else(|| panic!("`{key}` is derived but not listed"));
            let first_word = formula.split_whitespace().next().unwrap();
            assert!(
                line.contains(first_word.trim_matches('`')),
                "{line} / {formula}"
            );
        }
        let listed = table
            .lines()
            .take_while(|l| !l.starts_with("and these"))
            .filter(|l| l.starts_with("| `"))
            .count();
        assert_eq!(
            listed,
            derived_columns().len(),
            "a measured column is listed as derived"
        );
    }
}
