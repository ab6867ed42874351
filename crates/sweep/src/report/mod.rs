//! Numbers → report: `cells.csv` and `cells.json`, contact sheets, difference images,
//! plots, `report.md` and a self-contained `report.html`. Works from the output folder
//! alone, so `sweep report DIR` regenerates everything without rendering.

mod chart;
mod collect;
mod diffs;
mod explorer;
mod figures;
mod html;
mod markdown;
mod plots;
mod sheets;
mod table;

use std::path::PathBuf;

use anyhow::{Context, Result};

pub(crate) use chart::{Plot, Series, write_plot};
use collect::collect;
use table::{CsvExporter, Exporter, JsonExporter, Table, cells_table};

use crate::plan::Experiment;
use crate::store::{OutputDir, clean_stale};

/// Everything a report links to.
#[derive(Default)]
pub(crate) struct Figures {
    sheets: Vec<(String, PathBuf)>,
    diffs: Vec<(String, PathBuf)>,
    plots: Vec<PlotFigure>,
    comparisons: Vec<(String, Table)>,
}

/// A plot whose points open their cells in the explorer.
pub(crate) struct PlotFigure {
    caption: String,
    /// The PNG (the SVG beside it has the same geometry).
    path: PathBuf,
    points: Vec<PlotPoint>,
}

/// A drawn point of a plot.
pub(crate) struct PlotPoint {
    /// Pixel position in the plot image.
    at: (i32, i32),
    /// Plan indices of the cells it stands for (several when it is a mean).
    cells: Vec<usize>,
    /// What it shows, for a tooltip.
    text: String,
}

/// Removes what a killed report left half-written (its files are written atomically through
/// temporaries) in the folder and its figure folders.
fn remove_stale_temporaries(out: &OutputDir) {
    clean_stale(out.root());
    clean_stale(&out.figures());
    if let Ok(entries) = std::fs::read_dir(out.figures()) {
        for dir in entries.flatten().filter(|e| e.path().is_dir()) {
            clean_stale(&dir.path());
        }
    }
}

/// Builds `cells.csv`, `cells.json`, figures, `report.md` and `report.html`.
pub(crate) fn build_report(out: &OutputDir) -> Result<PathBuf> {
    remove_stale_temporaries(out);
    let (plan, cells) = collect(out)?;
    let table = cells_table(&plan, &cells);
    volphot::write_atomic(
        &out.root().join("cells.csv"),
        &CsvExporter.serialize(&table)?,
    )?;
    volphot::write_atomic(
        &out.root().join("cells.json"),
        &JsonExporter.serialize(&table)?,
    )?;
    let experiment = Experiment::load(&out.root().join("experiment.toml"))
        .with_context(|| format!("{}: reading the experiment copy", out.root().display()))?;
    std::fs::create_dir_all(out.figures())?;
    let mut figures = Figures::default();
    sheets::contact_sheets(out, &plan, &cells, &experiment, &mut figures)?;
    diffs::layer_differences(out, &cells, &experiment, &mut figures)?;
    diffs::axis_comparisons(out, &plan, &cells, &experiment, &mut figures)?;
    diffs::remove_unlisted(out, &figures)?;
    plots::plots(out, &plan, &cells, &experiment, &mut figures)?;
    let markdown = markdown::Report {
        out,
        plan: &plan,
        cells: &cells,
        table: &table,
        experiment: &experiment,
        figures: &figures,
    }
    .markdown();
    volphot::write_atomic(&out.root().join("report.md"), markdown.as_bytes())?;
    let explorer = explorer::Explorer::build(out, &plan, &cells)?;
    let html = html::html(out.root(), &markdown, &explorer, &figures)?;
    let path = out.root().join("report.html");
    volphot::write_atomic(&path, html.as_bytes())?;
    Ok(path)
}
