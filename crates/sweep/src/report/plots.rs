//! Metric-vs-axis plots: the experiment's `[[plots]]`, or by default every numeric axis
//! against the errors, the disco score, the multiple-scattering share and the render time.
//!
//! A plot never averages across an axis that changes what its metric means or measures
//! (`integrator.multiple`, `method`, `integrator.estimator`, `scene`, σt, …): every axis
//! that varies among a plot's cells is its x axis, its series (one line per value) or a
//! facet (one panel per value, small multiples sharing their axes). Only seeds are
//! averaged, and then each point shows their min–max. A metric that is undefined for a cell
//! (the multiple-scattering share without multiple scattering, an error without a
//! reference) is absent from its data, so it draws nothing rather than a 0. Each figure
//! writes the numbers it draws beside it (`<plot>.csv`), so a plotted number is as
//! checkable as a cited one.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};

use super::chart::{Drawn, Panel, Plot, Point, Series, write_plot};
use super::collect::{Collected, axis_value, distinct_values, matches, numeric, value_label};
use super::{Figures, PlotFigure, PlotPoint};
use crate::analyse::{METRIC_COLUMNS, MetricColumn};
use crate::plan::{Experiment, PlotSpec, short_key, value_text};
use crate::store::{OutputDir, PlanRecord};

/// Panels in one figure at most; more are split over several figures.
const MAX_PANELS: usize = 12;

/// Whether an axis only repeats a render with another seed: the one kind of axis a plot
/// averages over (the spread is then the noise the study is about).
pub(crate) fn is_seed_axis(key: &str) -> bool {
    key == "seed" || key.ends_with(".seed")
}

/// An axis as the documents name it, without unit (`σt(d_min)`, `nused`, `photons`).
pub(crate) fn axis_name(key: &str) -> &str {
    match key {
        "sigma.t" => "σt(d_min)",
        "integrator.volume_photons" => "photons",
        "integrator.alpha" => "α",
        "sigma.albedo" => "albedo Λ",
        "sigma.scale" => "extinction scale",
        other => short_key(other),
    }
}

/// An axis with its unit, for an axis description.
fn axis_label(key: &str) -> String {
    let unit = match key {
        "sigma.t" => " [1/world unit]",
        "integrator.nused" => " [photons per estimate]",
        "integrator.volume_photons" => " [emitted]",
        "integrator.maxdist" | "integrator.stepsize" => " [world units]",
        "sigma.albedo" | "sigma.scale" => " [1]",
        _ => "",
    };
    format!("{}{unit}", axis_name(key))
}

/// A value as a legend or panel shows it: a scene by its file's name.
pub(crate) fn value_name(key: &str, v: &serde_json::Value) -> String {
    let text = value_label(v);
    if key == "scene" {
        Path::new(&text)
            .file_stem()
            .map_or(text.clone(), |s| s.to_string_lossy().into_owned())
    } else {
        text
    }
}

fn plot_specs(plan: &PlanRecord, cells: &[Collected], experiment: &Experiment) -> Vec<PlotSpec> {
    if !experiment.plots.is_empty() {
        return experiment.plots.clone();
    }
    if experiment.tune.is_some() {
        // A tune's cells are scattered, not a grid: its own report plots the front.
        return Vec::new();
    }
    let has_reference = cells.iter().any(|c| c.reference.is_some());
    let mut specs = Vec::new();
    for x in plan.axes.iter().filter(|a| !is_seed_axis(a)) {
        let values = distinct_values(cells, x);
        if values.len() < 2 || !values.iter().all(|v| numeric(v).is_some()) {
            continue;
        }
        let mut y = vec![
            "disco_energy".to_string(),
            "ms_share".into(),
            "time_render".into(),
        ];
        if has_reference {
            y.insert(0, "rmse".into());
            y.insert(1, "flip".into());
        }
        specs.push(PlotSpec {
            x: x.clone(),
            y,
            series: plan
                .axes
                .iter()
                .find(|a| *a != x && !is_seed_axis(a))
                .cloned(),
            log_x: geometric(&values),
            log_y: false,
            filter: Default::default(),
        });
    }
    specs
}

/// Whether an axis's values are positive and span an order of magnitude (σt 6 … 290,
/// photon counts): drawn on a log axis, where a geometric grid is evenly spaced.
fn geometric(values: &[serde_json::Value]) -> bool {
    let v: Vec<f64> = values.iter().filter_map(numeric).collect();
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    v.iter().all(|&x| x > 0.0) && hi / lo >= 8.0
}

/// Writes every plot (PNG, SVG and the CSV of its points) into `figures/plots/`.
pub(crate) fn plots(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let dir = out.figures().join("plots");
    std::fs::create_dir_all(&dir)?;
    let mut written = std::collections::BTreeSet::new();
    for (pi, spec) in plot_specs(plan, cells, experiment).iter().enumerate() {
        let selected: Vec<&Collected> = cells
            .iter()
            .filter(|c| matches(&c.planned, &spec.filter))
            .collect();
        for metric in &spec.y {
            let Some(column) = METRIC_COLUMNS.iter().find(|m| m.key == metric) else {
                continue;
            };
            let observed = observations(plan, spec, column, &selected);
            let grouped = Grouped::of(plan, &observed);
            let chunks = grouped.panels.chunks(MAX_PANELS).collect::<Vec<_>>();
            for (k, panels) in chunks.iter().enumerate() {
                let suffix = if chunks.len() > 1 {
                    format!("_{}", k + 1)
                } else {
                    String::new()
                };
                let name = format!("p{pi}_{metric}_vs_{}{suffix}", spec.x.replace('.', "_"));
                let plot = Plot {
                    title: title(spec, column, &grouped),
                    x_label: axis_label(&spec.x),
                    y_label: column.header.to_string(),
                    panels: panels.to_vec(),
                    log_x: spec.log_x,
                    log_y: spec.log_y,
                };
                let stem = dir.join(name);
                let drawn = write_plot(&stem, &plot)?;
                volphot::write_atomic(&stem.with_extension("csv"), plot_csv(&plot).as_bytes())?;
                written.insert(stem.clone());
                figures.plots.push(PlotFigure {
                    points: linked_points(&plot, &drawn, metric),
                    caption: plot.title,
                    path: stem.with_extension("png"),
                    size: drawn.size,
                });
            }
        }
    }
    remove_stale_plots(&dir, &written)
}

/// Removes the plots an earlier report wrote that this one did not (a plot spec changed or
/// was dropped, a facet was split): a stale figure would sit beside the report as if it
/// were one of its own.
fn remove_stale_plots(
    dir: &std::path::Path,
    written: &std::collections::BTreeSet<std::path::PathBuf>,
) -> Result<()> {
    for file in std::fs::read_dir(dir)?.flatten().map(|e| e.path()) {
        let ours = file
            .extension()
            .is_some_and(|e| e == "png" || e == "svg" || e == "csv");
        let hidden = file
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'));
        if ours && !hidden && !written.contains(&file.with_extension("")) {
            std::fs::remove_file(&file)
                .with_context(|| format!("removing the stale plot {}", file.display()))?;
        }
    }
    Ok(())
}

/// One cell's value of the plotted metric, with where it goes.
struct Observation {
    /// The facet axes' values (empty when nothing is faceted).
    facet: Vec<(String, serde_json::Value)>,
    /// The series axis's value, as a legend names it.
    series: String,
    x: f64,
    y: f64,
    cell: usize,
}

/// Every selected cell with a numeric x and a defined metric. `facet` holds the values of
/// every axis that is not x, the series, fixed by the spec's `where`, or a seed.
fn observations(
    plan: &PlanRecord,
    spec: &PlotSpec,
    column: &MetricColumn,
    cells: &[&Collected],
) -> Vec<Observation> {
    let others: Vec<&String> = plan
        .axes
        .iter()
        .filter(|a| **a != spec.x && Some(*a) != spec.series.as_ref())
        .filter(|a| !spec.filter.contains_key(a.as_str()) && !is_seed_axis(a))
        .collect();
    cells
        .iter()
        .filter_map(|c| {
            let r = c.record.as_ref()?;
            let x = axis_value(&c.planned, &spec.x).as_ref().and_then(numeric)?;
            let y = (column.value)(r, c.reference.as_ref())?;
            let series = spec
                .series
                .as_ref()
                .and_then(|s| {
                    let v = axis_value(&c.planned, s)?;
                    Some(format!("{} = {}", axis_name(s), value_name(s, &v)))
                })
                .unwrap_or_default();
            let facet = others
                .iter()
                .filter_map(|a| Some(((*a).clone(), axis_value(&c.planned, a)?)))
                .collect();
            Some(Observation {
                facet,
                series,
                x,
                y,
                cell: c.planned.index,
            })
        })
        .collect()
}

/// Observations grouped into panels, series and points.
struct Grouped {
    panels: Vec<Panel>,
    /// Axes not fixed by the spec but with one value among the observations (`multiple =
    /// true` where the metric needs multiple scattering), as `axis = value`.
    constant: Vec<String>,
    /// The most cells averaged into one point (1 when nothing is averaged).
    most_averaged: usize,
}

impl Grouped {
    fn of(plan: &PlanRecord, observed: &[Observation]) -> Grouped {
        // <<Which of the other axes vary among the observations>>
        let mut facet_axes: Vec<&String> = Vec::new();
        let mut constant = Vec::new();
        for axis in plan.axes.iter() {
            let values: Vec<&serde_json::Value> = distinct(
                observed
                    .iter()
                    .filter_map(|o| o.facet.iter().find(|(k, _)| k == axis).map(|(_, v)| v)),
            );
            match values.len() {
                0 => {}
                1 => constant.push(format!(
                    "{} = {}",
                    axis_name(axis),
                    value_name(axis, values[0])
                )),
                _ => facet_axes.push(axis),
            }
        }
        // <<Panels by the varying axes' values, series and x within each, in plan order>>
        type Key = Vec<String>;
        let mut order: Vec<Key> = Vec::new();
        let mut by_panel: BTreeMap<Key, Vec<&Observation>> = BTreeMap::new();
        for o in observed {
            let key: Key = facet_axes
                .iter()
                .map(|a| {
                    let v = o.facet.iter().find(|(k, _)| k == *a).map(|(_, v)| v);
                    v.map_or("—".into(), |v| {
                        format!("{} = {}", axis_name(a), value_name(a, v))
                    })
                })
                .collect();
            if !by_panel.contains_key(&key) {
                order.push(key.clone());
            }
            by_panel.entry(key).or_default().push(o);
        }
        // A series axis with one value left is held fixed too: the title says so.
        let series_names = observed
            .iter()
            .map(|o| o.series.as_str())
            .collect::<Vec<_>>();
        if let [first, rest @ ..] = series_names.as_slice()
            && !first.is_empty()
            && rest.iter().all(|n| n == first)
        {
            constant.push(first.to_string());
        }
        let mut most_averaged = 1;
        let panels = order
            .into_iter()
            .map(|key| {
                let series = series_of(&by_panel[&key], &mut most_averaged);
                Panel {
                    title: key.join(", "),
                    series,
                }
            })
            .collect();
        Grouped {
            panels,
            constant,
            most_averaged,
        }
    }
}

/// The distinct items, in order of first appearance.
fn distinct<'a>(values: impl Iterator<Item = &'a serde_json::Value>) -> Vec<&'a serde_json::Value> {
    let mut out: Vec<&serde_json::Value> = Vec::new();
    for v in values {
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

/// The x value of a point, the values it averages and their cells.
type Gathered = (f64, Vec<f64>, Vec<usize>);

/// One line per series value (in order of appearance): x → mean over the seeds, with their
/// min–max when there are several.
fn series_of(observed: &[&Observation], most_averaged: &mut usize) -> Vec<Series> {
    let mut order: Vec<&str> = Vec::new();
    let mut lines: BTreeMap<&str, BTreeMap<i64, Gathered>> = BTreeMap::new();
    for o in observed {
        if !order.contains(&o.series.as_str()) {
            order.push(&o.series);
        }
        // x values as keys: equal to a millionth are the same grid value.
        let key = (o.x * 1e6).round() as i64;
        let point =
            lines
                .entry(&o.series)
                .or_default()
                .entry(key)
                .or_insert((o.x, Vec::new(), Vec::new()));
        point.1.push(o.y);
        point.2.push(o.cell);
    }
    order
        .into_iter()
        .map(|name| {
            let points = lines
                .remove(name)
                .unwrap_or_default()
                .into_values()
                .map(|(x, ys, cells)| {
                    *most_averaged = (*most_averaged).max(ys.len());
                    let mean = ys.iter().sum::<f64>() / ys.len() as f64;
                    let lo = ys.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    Point {
                        x,
                        y: mean,
                        spread: (ys.len() > 1).then_some((lo, hi)),
                        cells,
                    }
                })
                .collect();
            Series {
                name: name.to_string(),
                points,
                points_only: false,
            }
        })
        .collect()
}

/// `ms_share vs σt(d_min) — scene = foot, multiple = true; mean of 2 seeds`: the metric,
/// the x axis, everything held fixed, and what a point averages.
fn title(spec: &PlotSpec, column: &MetricColumn, grouped: &Grouped) -> String {
    let mut fixed: Vec<String> = spec
        .filter
        .iter()
        .map(|(k, v)| {
            let json = crate::plan::toml_to_json(v);
            let text = if k == "scene" {
                value_name(k, &json)
            } else {
                value_text(v)
            };
            format!("{} = {text}", axis_name(k))
        })
        .collect();
    fixed.extend(grouped.constant.iter().cloned());
    let mut title = format!("{} vs {}", column.key, axis_name(&spec.x));
    if !fixed.is_empty() {
        let _ = write!(title, " — {}", fixed.join(", "));
    }
    if grouped.most_averaged > 1 {
        let _ = write!(title, "; mean of {} seeds", grouped.most_averaged);
    }
    title
}

/// The plotted numbers: one row per drawn point.
fn plot_csv(plot: &Plot) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let _ = w.write_record([
        "panel", "series", "x", "y", "y_min", "y_max", "n_cells", "cells",
    ]);
    for panel in &plot.panels {
        for s in &panel.series {
            for p in &s.points {
                let (lo, hi) = p.spread.unwrap_or((p.y, p.y));
                let cells: Vec<String> = p.cells.iter().map(usize::to_string).collect();
                let _ = w.write_record([
                    panel.title.clone(),
                    s.name.clone(),
                    format!("{}", p.x),
                    format!("{}", p.y),
                    format!("{lo}"),
                    format!("{hi}"),
                    p.cells.len().to_string(),
                    cells.join(" "),
                ]);
            }
        }
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// The drawn points with the cells behind them and a tooltip.
fn linked_points(plot: &Plot, drawn: &Drawn, metric: &str) -> Vec<PlotPoint> {
    drawn
        .hotspots
        .iter()
        .map(|h| {
            let panel = &plot.panels[h.panel];
            let series = &panel.series[h.series];
            let p = &series.points[h.point];
            let mut text = format!("{} = {}: {metric} = {:.4e}", plot.x_label, p.x, p.y);
            for context in [&series.name, &panel.title] {
                if !context.is_empty() {
                    text = format!("{context}, {text}");
                }
            }
            if let Some((lo, hi)) = p.spread {
                let _ = write!(
                    text,
                    " (mean of {} cells, {lo:.4e} – {hi:.4e})",
                    p.cells.len()
                );
            }
            PlotPoint {
                at: h.at,
                cells: p.cells.clone(),
                text,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_an_earlier_report_wrote_are_removed_and_others_kept() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for f in [
            "p0_rmse_vs_sigma_t.png",
            "p0_rmse_vs_sigma_t.svg",
            "p0_rmse_vs_sigma_t.csv",
            "p1_rmse_vs_integrator_seed.png",
            "p1_rmse_vs_integrator_seed.svg",
            ".p2.png.tmp",
            "notes.txt",
        ] {
            std::fs::write(d.join(f), b"x").unwrap();
        }
        let written = [d.join("p0_rmse_vs_sigma_t")].into_iter().collect();
        remove_stale_plots(d, &written).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(
            left,
            [
                ".p2.png.tmp",
                "notes.txt",
                "p0_rmse_vs_sigma_t.csv",
                "p0_rmse_vs_sigma_t.png",
                "p0_rmse_vs_sigma_t.svg"
            ]
        );
    }
}
