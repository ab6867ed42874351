//! Metric-vs-axis plots: the experiment's `[[plots]]`, or by default every numeric axis
//! against the errors, the disco score, the multiple-scattering share and the render time,
//! one line per value of another axis, averaged over the remaining axes.

use std::collections::BTreeMap;

use anyhow::Result;

use super::chart::{Hotspot, Plot, Series, write_plot};
use super::collect::{Collected, axis_value, distinct_values, matches, numeric, value_label};
use super::{Figures, PlotFigure, PlotPoint};
use crate::analyse::{METRIC_COLUMNS, MetricColumn};
use crate::plan::{Experiment, PlotSpec, short_key, value_text};
use crate::store::{OutputDir, PlanRecord};

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
    for x in &plan.axes {
        let values = distinct_values(cells, x);
        if values.len() < 2 || !values.iter().all(|v| numeric(v).is_some()) {
            continue;
        }
        let positive = values.iter().all(|v| numeric(v).is_some_and(|n| n > 0.0));
        let spread = values
            .iter()
            .filter_map(numeric)
            .fold(f64::NEG_INFINITY, f64::max)
            / values
                .iter()
                .filter_map(numeric)
                .fold(f64::INFINITY, f64::min);
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
            series: plan.axes.iter().find(|a| *a != x).cloned(),
            log_x: positive && spread > 20.0,
            log_y: false,
            filter: Default::default(),
        });
    }
    specs
}

/// Writes every plot (PNG and SVG) into `figures/plots/`.
pub(crate) fn plots(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let dir = out.figures().join("plots");
    std::fs::create_dir_all(&dir)?;
    for (pi, spec) in plot_specs(plan, cells, experiment).iter().enumerate() {
        let selected: Vec<&Collected> = cells
            .iter()
            .filter(|c| matches(&c.planned, &spec.filter))
            .collect();
        for metric in &spec.y {
            let Some(column) = METRIC_COLUMNS.iter().find(|m| m.key == metric) else {
                continue;
            };
            let series = series(spec, column, &selected);
            if series.is_empty() {
                continue;
            }
            let plot = Plot {
                title: title(plan, spec, metric),
                x_label: spec.x.clone(),
                y_label: column.header.to_string(),
                series,
                log_x: spec.log_x,
                log_y: spec.log_y,
            };
            let stem = dir.join(format!("p{pi}_{}_vs_{}", metric, spec.x.replace('.', "_")));
            let hotspots = write_plot(&stem, &plot)?;
            figures.plots.push(PlotFigure {
                points: linked_points(&plot, &hotspots, metric),
                caption: plot.title,
                path: stem.with_extension("png"),
            });
        }
    }
    Ok(())
}

/// The drawn points with the cells behind them and a tooltip.
fn linked_points(plot: &Plot, hotspots: &[Hotspot], metric: &str) -> Vec<PlotPoint> {
    hotspots
        .iter()
        .map(|h| {
            let series = &plot.series[h.series];
            let (x, y) = series.points[h.point];
            let cells = series.cells[h.point].clone();
            let mut text = format!("{} = {x}: {metric} = {y:.4e}", plot.x_label);
            if !series.name.is_empty() {
                text = format!("{}, {text}", series.name);
            }
            if cells.len() > 1 {
                text += &format!(" (mean of {} cells)", cells.len());
            }
            PlotPoint {
                at: h.at,
                cells,
                text,
            }
        })
        .collect()
}

/// Ys of one x: the x value, the metric per cell and the cells' plan indices.
type Column = (f64, Vec<f64>, Vec<usize>);

/// One line per value of the series axis (in plan order): x → mean of the metric over the
/// remaining axes.
fn series(spec: &PlotSpec, column: &MetricColumn, cells: &[&Collected]) -> Vec<Series> {
    let mut lines: BTreeMap<String, BTreeMap<i64, Column>> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    for c in cells {
        let (Some(r), Some(x)) = (
            &c.record,
            axis_value(&c.planned, &spec.x).as_ref().and_then(numeric),
        ) else {
            continue;
        };
        let Some(y) = (column.value)(r, c.reference.as_ref()) else {
            continue;
        };
        let name = spec
            .series
            .as_ref()
            .and_then(|s| {
                axis_value(&c.planned, s).map(|v| format!("{} = {}", short_key(s), value_label(&v)))
            })
            .unwrap_or_default();
        let key = (x * 1e6).round() as i64;
        if !order.contains(&name) {
            order.push(name.clone());
        }
        let column =
            lines
                .entry(name)
                .or_default()
                .entry(key)
                .or_insert((x, Vec::new(), Vec::new()));
        column.1.push(y);
        column.2.push(c.planned.index);
    }
    order
        .into_iter()
        .filter_map(|name| lines.remove(&name).map(|pts| (name, pts)))
        .map(|(name, pts)| {
            let (points, cells) = pts
                .into_values()
                .map(|(x, ys, cells)| ((x, ys.iter().sum::<f64>() / ys.len() as f64), cells))
                .unzip();
            Series {
                name,
                points,
                cells,
                points_only: false,
            }
        })
        .collect()
}

/// `metric vs x (fixed axes), mean over other axes`.
fn title(plan: &PlanRecord, spec: &PlotSpec, metric: &str) -> String {
    let averaged = plan.axes.len() > 1 + usize::from(spec.series.is_some()) + spec.filter.len();
    let fixed = spec
        .filter
        .iter()
        .map(|(k, v)| format!("{} = {}", short_key(k), value_text(v)))
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "{metric} vs {}{}{}",
        short_key(&spec.x),
        if fixed.is_empty() {
            String::new()
        } else {
            format!(" ({fixed})")
        },
        if averaged {
            ", mean over other axes"
        } else {
            ""
        }
    )
}
