//! `report.md`: what was run, the grid, provenance, figures, comparison tables, the cells
//! table and failures — readable on a code host as it is.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::Figures;
use super::collect::{Collected, distinct_values, value_label};
use super::escape::{md_code, md_prose, md_text};
use super::table::{Exporter, Field, MarkdownExporter, Table};
use crate::analyse::METRIC_COLUMNS;
use crate::plan::{Experiment, Quality};
use crate::store::{OutputDir, PlanRecord, read_reference_record};

/// The fast-and-exact issue's bounds on the default's error against the uncached marcher,
/// in percent: the bias of a layer's mean and the 99th percentile of the per-pixel error.
const BIAS_BOUND: f64 = 0.5;
const P99_BOUND: f64 = 2.0;

/// The metrics shown in the report's cells table (when any cell has them).
const TABLE_METRICS: [&str; 12] = [
    "empirical_mfp",
    "nominal_mfp",
    "mean_single",
    "mean_multiple",
    "ms_share",
    "rmse",
    "rmse_corrected",
    "flip",
    "ssim",
    "disco_energy",
    "disco_blobs",
    "time_render",
];

/// Everything `report.md` is made of.
pub(crate) struct Report<'a> {
    pub(crate) out: &'a OutputDir,
    pub(crate) plan: &'a PlanRecord,
    pub(crate) cells: &'a [Collected],
    pub(crate) table: &'a Table,
    pub(crate) experiment: &'a Experiment,
    pub(crate) figures: &'a Figures,
}

/// `path` relative to the report's folder, as the report links it.
pub(super) fn rel(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .display()
        .to_string()
}

impl Report<'_> {
    /// The whole Markdown text.
    pub(crate) fn markdown(&self) -> String {
        let mut s = String::new();
        self.header(&mut s);
        // A tune's cells are scattered configurations, not a grid to read along an axis.
        if self.experiment.tune.is_none() {
            s.push_str(&super::summary::what_changed(&self.plan.axes, self.cells));
        }
        self.grid(&mut s);
        self.provenance(&mut s);
        self.caches(&mut s);
        self.thinning(&mut s);
        self.figures(&mut s);
        self.cells_table(&mut s);
        self.failures(&mut s);
        s
    }

    fn failed(&self) -> Vec<&Collected> {
        self.cells
            .iter()
            .filter(|c| c.status() == "failed")
            .collect()
    }

    fn done(&self) -> usize {
        self.cells.iter().filter(|c| c.record.is_some()).count()
    }

    fn header(&self, s: &mut String) {
        let (plan, root) = (self.plan, self.out.root());
        let done = self.done();
        let failed = self.failed().len();
        let _ = writeln!(s, "# {}\n", md_text(&plan.experiment));
        if !self.experiment.description.is_empty() {
            let _ = writeln!(s, "{}\n", md_prose(self.experiment.description.trim()));
        }
        let damaged = self.cells.iter().filter(|c| c.damaged.is_some()).count();
        let _ = writeln!(
            s,
            "- cells: {} planned, {done} done, {failed} failed, {} pending{}",
            self.cells.len(),
            self.cells.len() - done - failed - damaged,
            if damaged > 0 {
                format!(", {damaged} damaged (`sweep run` renders them again)")
            } else {
                String::new()
            }
        );
        let _ = writeln!(
            s,
            "- quality preset: `{}`; program version {}",
            plan.quality, plan.version
        );
        let _ = writeln!(
            s,
            "- experiment file: {} (sha256 `{}`)",
            md_code(&plan.experiment_file.display().to_string()),
            plan.experiment_sha256
        );
        let _ = writeln!(s, "- command: {}", md_code(&plan.command.join(" ")));
        if root.join("tune").join("report.md").is_file() {
            let _ = writeln!(
                s,
                "- tune: [tune/report.md](tune/report.md): best settings per time budget, the Pareto front of error against render time, sensitivity per parameter"
            );
        }
        let _ = writeln!(
            s,
            "- rerun: {} (finished cells are skipped); regenerate this report: {}\n",
            md_code(&format!(
                "sweep {} {}{} --output {}",
                if self.experiment.tune.is_some() {
                    "tune"
                } else {
                    "run"
                },
                plan.experiment_file.display(),
                Quality::from_name(&plan.quality).map_or("", Quality::flag),
                root.display(),
            )),
            md_code(&format!("sweep report {}", root.display()))
        );
    }

    /// The axes and their values, and how much work sharing saved.
    fn grid(&self, s: &mut String) {
        let cells = self.cells;
        let _ = writeln!(s, "## Grid\n");
        for axis in &self.plan.axes {
            let values: Vec<String> = distinct_values(cells, axis)
                .iter()
                .map(|v| md_text(&value_label(v)))
                .collect();
            let _ = writeln!(s, "- {}: {}", md_code(axis), values.join(", "));
        }
        // What the renders did, not what the plan allowed: an experiment with
        // `share = false` marches every cell alone though its cells share march keys.
        let marches = cells
            .iter()
            .filter_map(|c| c.record.as_ref())
            .map(|r| 1.0 / r.timings.march_shared_by.max(1) as f64)
            .sum::<f64>()
            .round() as usize;
        let with_maps = || {
            cells
                .iter()
                .filter_map(|c| c.record.as_ref())
                .filter(|r| r.timings.map_shared_by > 0)
        };
        let maps = with_maps()
            .map(|r| 1.0 / r.timings.map_shared_by as f64)
            .sum::<f64>()
            .round() as usize;
        let _ = writeln!(
            s,
            "\nShared work: {done} finished cells came from about {marches} march(es) (one eye-ray pass each) and about {maps} photon map(s) for the {} cells with multiple scattering; rendered one by one they would need {done} marches and {} maps.\n",
            with_maps().count(),
            with_maps().count(),
            done = self.done(),
        );
    }

    /// Cells rendered with a cache, and what the cache was measured to err by (nothing
    /// when no cell used one).
    fn caches(&self, s: &mut String) {
        let cached: Vec<_> = self
            .cells
            .iter()
            .filter_map(|c| Some((c, c.record.as_ref()?.cache_error.as_ref()?)))
            .filter(|(_, e)| e.has_cache())
            .collect();
        if cached.is_empty() {
            return;
        }
        let _ = writeln!(
            s,
            "## Caches
"
        );
        let _ = writeln!(
            s,
            "{} cell(s) were rendered with a cache, which is not exact. At the marching samples of 32 × 32 eye rays each cache was compared with the value it stands for (direct light with exact transmittance; a photon gather): bias of the mean, and the 99th percentile and maximum of the per-point relative error.\n",
            cached.len()
        );
        let _ = writeln!(
            s,
            "| cell | probes | shadow cache: bias, p99, max | scattering cache: bias, p99, max |"
        );
        let _ = writeln!(s, "|---|---:|---|---|");
        let bound = |b: &Option<volphot::ErrorBound>| match b {
            Some(b) => format!(
                "{:+.2} %, {:.2} %, {:.1} %",
                100.0 * b.mean,
                100.0 * b.p99,
                100.0 * b.max
            ),
            None => "—".into(),
        };
        for (c, e) in cached {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                md_text(&c.planned.label),
                e.probes,
                bound(&e.shadow),
                bound(&e.multiple)
            );
        }
        let _ = writeln!(s);
    }

    /// Cells rendered with thinning by eye transmittance, and the largest error it was
    /// measured to make (nothing when no cell thinned).
    fn thinning(&self, s: &mut String) {
        let thinned: Vec<_> = self
            .cells
            .iter()
            .filter_map(|c| {
                let t = c.record.as_ref()?.cache_error.as_ref()?.thinning?;
                Some((md_text(&c.planned.label), t))
            })
            .collect();
        if thinned.is_empty() {
            return;
        }
        let _ = writeln!(s, "## Thinning\n");
        let mut levels: Vec<String> = thinned
            .iter()
            .map(|(_, t)| t.thin_below.to_string())
            .collect();
        levels.sort();
        levels.dedup();
        let _ = writeln!(
            s,
            "{} of {} finished cell(s) thinned their evaluations behind the front (`thin_below` {}, default {}: gathers and shadow fills spaced out where the eye transmittance is below it). Each measured what that cost on its own 32 × 32 probe pixels, traced again with every sample evaluated (a gather and an exact optical depth at each): bias of the mean and 99th percentile of the per-pixel relative error (where a pixel is at least 1 % of the brightest). The default is meant to stay within {BIAS_BOUND} % and {P99_BOUND} %; the last column counts the cells that did not.\n",
            thinned.len(),
            self.done(),
            levels.join(", "),
            volphot::DEFAULT_THIN_BELOW,
        );
        let _ = writeln!(
            s,
            "| layer | cells | largest bias | cell | largest p99 | cell | cells over: bias, p99 |"
        );
        let _ = writeln!(s, "|---|---:|---:|---|---:|---|---:|");
        type Pick = fn(&volphot::ThinningError) -> Option<volphot::ErrorBound>;
        let layers: [(&str, Pick); 2] = [("single", |t| t.single), ("multiple", |t| t.multiple)];
        for (layer, pick) in layers {
            let bounds: Vec<_> = thinned
                .iter()
                .filter_map(|(label, t)| Some((label.as_str(), pick(t)?)))
                .collect();
            let worst = |key: fn(&volphot::ErrorBound) -> f64| {
                bounds
                    .iter()
                    .max_by(|a, b| key(&a.1).total_cmp(&key(&b.1)))
                    .copied()
            };
            let (Some(bias), Some(p99)) = (worst(|b| b.mean.abs()), worst(|b| b.p99)) else {
                continue;
            };
            let over = |key: fn(&volphot::ErrorBound) -> f64, bound: f64| {
                bounds.iter().filter(|b| 100.0 * key(&b.1) > bound).count()
            };
            let _ = writeln!(
                s,
                "| {layer} | {} | {:+.2} % | {} | {:.2} % | {} | {}, {} |",
                bounds.len(),
                100.0 * bias.1.mean,
                bias.0,
                100.0 * p99.1.p99,
                p99.0,
                over(|b| b.mean.abs(), BIAS_BOUND),
                over(|b| b.p99, P99_BOUND),
            );
        }
        let _ = writeln!(
            s,
            "\nEach cell's own figures are the `thinning_*` columns of `cells.csv`.\n"
        );
    }

    /// Volumes and references.
    fn provenance(&self, s: &mut String) {
        let _ = writeln!(s, "## Provenance\n");
        let mut volumes: Vec<String> = self
            .cells
            .iter()
            .filter_map(|c| c.record.as_ref())
            .map(|r| r.provenance.volume.describe())
            .collect();
        volumes.sort();
        volumes.dedup();
        for v in volumes {
            let _ = writeln!(s, "- volume: {}", md_text(&v));
        }
        let mut refs: Vec<&String> = self
            .cells
            .iter()
            .filter_map(|c| c.planned.reference.as_ref())
            .collect();
        refs.sort();
        refs.dedup();
        for key in refs {
            if let Ok(r) = read_reference_record(&self.out.reference(key)) {
                let _ = writeln!(
                    s,
                    "- reference `{key}`: {} with {} samples per pixel ({:.1} s)",
                    r.method.name(),
                    r.passes,
                    r.seconds
                );
            } else {
                let _ = writeln!(s, "- reference `{key}`: not rendered");
            }
        }
    }

    /// Contact sheets, plots, difference images and comparison tables.
    fn figures(&self, s: &mut String) {
        let root = self.out.root();
        let mut section = |title: &str, items: &[(String, PathBuf)]| {
            if items.is_empty() {
                return;
            }
            let _ = writeln!(s, "\n## {title}\n");
            for (caption, path) in items {
                let caption = md_text(caption);
                let _ = writeln!(s, "![{caption}]({})\n\n*{caption}*\n", rel(root, path));
            }
        };
        section("Contact sheets", &self.figures.sheets);
        let plots: Vec<(String, PathBuf)> = self
            .figures
            .plots
            .iter()
            .map(|p| (p.caption.clone(), p.path.clone()))
            .collect();
        section("Plots", &plots);
        section("Difference images", &self.figures.diffs);
        if !self.figures.diff_images.is_empty() {
            let _ = writeln!(s, "{}\n", md_text(&self.figures.diff_legend));
            for (label, links) in &self.figures.diff_images {
                let links: Vec<String> = links
                    .iter()
                    .map(|(text, path)| format!("[{}]({})", md_text(text), rel(root, path)))
                    .collect();
                let _ = writeln!(s, "- {}: {}", md_text(label), links.join(" · "));
            }
            let _ = writeln!(s);
        }
        for (title, t) in &self.figures.comparisons {
            let _ = writeln!(s, "\n### Comparison {}\n", md_text(title));
            let _ = writeln!(s, "{}", markdown_table(t, vec![]));
        }
    }

    /// The cells with their axes and the main metrics.
    fn cells_table(&self, s: &mut String) {
        let table = self.table;
        let _ = writeln!(s, "\n## Cells\n");
        let mut columns: Vec<usize> = vec![0, 2];
        columns.extend(3..3 + self.plan.axes.len());
        for key in TABLE_METRICS {
            if let Some(i) = METRIC_COLUMNS.iter().position(|m| m.key == key) {
                let col = table.headers.len() - METRIC_COLUMNS.len() + i;
                if table.rows.iter().any(|r| r[col] != Field::Empty) {
                    columns.push(col);
                }
            }
        }
        let _ = writeln!(s, "{}", markdown_table(table, columns));
        let derived: Vec<String> = crate::analyse::derived_columns()
            .iter()
            .map(|(key, _)| md_code(key))
            .collect();
        let _ = writeln!(
            s,
            "All columns, with units: [cells.csv](cells.csv) ([cells.json](cells.json)). Every metric is measured by the render except {}, formulas of the settings (docs/experiments.md gives each).\n",
            derived.join(", ")
        );
    }

    fn failures(&self, s: &mut String) {
        let failed = self.failed();
        if failed.is_empty() {
            return;
        }
        let _ = writeln!(s, "## Failures\n");
        for c in failed {
            let first = c
                .failure
                .as_deref()
                .unwrap_or("")
                .lines()
                .take(6)
                .collect::<Vec<_>>()
                .join("\n    ");
            let _ = writeln!(
                s,
                "- cell {} ({}): see `{}`\n\n    {first}\n",
                c.planned.index,
                md_text(&c.planned.label),
                rel(self.out.root(), &self.out.failure(&c.planned.hash))
            );
        }
    }
}

fn markdown_table(table: &Table, columns: Vec<usize>) -> String {
    String::from_utf8_lossy(
        &MarkdownExporter { columns }
            .serialize(table)
            .unwrap_or_default(),
    )
    .into_owned()
}
