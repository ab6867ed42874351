//! Numbers → report: `cells.csv` and `cells.json`, contact sheets, difference images,
//! plots, `report.md` and a self-contained `report.html`. Works from the output folder
//! alone, so `sweep report DIR` regenerates everything without rendering.

mod chart;
mod collect;
mod diffs;
mod escape;
mod explorer;
mod figures;
mod html;
mod index;
mod markdown;
mod plots;
mod sheets;
mod summary;
mod table;

use std::path::PathBuf;

use anyhow::{Context, Result};

pub(crate) use chart::{Panel, Plot, Point, Series, write_plot};
use collect::collect;
pub(crate) use index::write_index;
use table::{CsvExporter, Exporter, JsonExporter, Table, cells_table};

use crate::plan::{Experiment, Quality};
use crate::store::{OutputDir, clean_stale, read_plan, recorded_but_absent};

/// Everything a report links to.
#[derive(Default)]
pub(crate) struct Figures {
    sheets: Vec<(String, PathBuf)>,
    diffs: Vec<(String, PathBuf)>,
    /// The full-size images behind the layer-difference sheets, per cell: its label and
    /// the links (text, image), listed in the report's "Difference images" section.
    diff_images: Vec<(String, Vec<(String, PathBuf)>)>,
    /// What the linked differences show (their gain and scale), said once above the list.
    diff_legend: String,
    plots: Vec<PlotFigure>,
    comparisons: Vec<(String, Table)>,
}

/// A plot whose points open their cells in the explorer.
pub(crate) struct PlotFigure {
    caption: String,
    /// The PNG (the SVG beside it has the same geometry, the CSV its numbers).
    path: PathBuf,
    /// The image's width and height in pixels.
    size: (u32, u32),
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

/// A report is rebuilt from the cells' data in the folder. A study committed to git has its
/// tables but not its `cells/`; rebuilding it there would turn every recorded result into
/// "pending" and overwrite the tables, sheets and report (issue #45, case 1). So when the
/// tables record a finished cell that has no data here, nothing is written and the error
/// says how to get the data back.
pub(crate) fn refuse_to_lose_recorded_cells(out: &OutputDir) -> Result<()> {
    let plan = read_plan(out)?;
    let absent = recorded_but_absent(out, &plan);
    if absent.is_empty() {
        return Ok(());
    }
    // A tune's cells are rendered again from its plan (`--cells`): a new search would
    // propose other settings.
    let command = if out.root().join("tune").is_dir() {
        format!(
            "sweep tune {} --cells 0-{} --output {}",
            plan.experiment_file.display(),
            plan.cells.len().saturating_sub(1),
            out.root().display()
        )
    } else {
        format!(
            "sweep run {}{} --output {}",
            plan.experiment_file.display(),
            Quality::from_name(&plan.quality).map_or("", Quality::flag),
            out.root().display()
        )
    };
    anyhow::bail!(
        "{root}: {n} of {total} cells are recorded as done in cells.json, but their data \
         (cells/<hash>/) are not in this folder (cells {ranges}); a clone of the repository \
         holds only the tables. Nothing was written. To rebuild this report, render them \
         again: `{command}` (the same seeds give the same images); or, to drop those \
         results, delete cells.csv and cells.json first.",
        root = out.root().display(),
        n = absent.len(),
        total = plan.cells.len(),
        ranges = crate::ranges::compress_ranges(&absent),
    )
}

/// The axis a study is about, for the explorer's first pair where it names none
/// (`[report] pair`): the columns of its first
/// contact sheet, else the series or the x axis of its first plot, else its first axis —
/// never a seed (two seeds of one setting look alike).
fn study_axis(experiment: &Experiment, plan: &crate::store::PlanRecord) -> Option<String> {
    let seedless = |k: &String| !plots::is_seed_axis(k) && plan.axes.contains(k);
    let sheets = experiment.sheets.iter().filter_map(|s| s.cols.clone());
    let plotted = experiment
        .plots
        .iter()
        .flat_map(|p| p.series.clone().into_iter().chain([p.x.clone()]));
    sheets
        .chain(plotted)
        .chain(plan.axes.iter().cloned())
        .find(seedless)
}

/// Rewrites `report.html`'s explorer to open on the pair its experiment copy names
/// (`[report] pair`), changing nothing else: the one part of a committed study's report a
/// clone can rebuild without the cells' data.
pub(crate) fn reopen_explorer(out: &OutputDir) -> Result<PathBuf> {
    let experiment = Experiment::load(&out.root().join("experiment.toml"))
        .with_context(|| format!("{}: reading the experiment copy", out.root().display()))?;
    let pair = experiment.report.pair.as_ref().ok_or_else(|| {
        anyhow::anyhow!(
            "{}: experiment.toml names no [report] pair to open the explorer on (e.g. pair = {{ a = {{ \"integrator.nused\" = 25 }}, b = {{ \"integrator.nused\" = 150 }} }})",
            out.root().display()
        )
    })?;
    let path = out.root().join("report.html");
    let html = volphot::read_text_capped(&path, 1 << 30, "report page")?;
    let html = explorer::reopen_page(&html, pair)
        .with_context(|| format!("{}: opening the explorer on its pair", path.display()))?;
    volphot::write_atomic(&path, html.as_bytes())?;
    Ok(path)
}

/// Builds `cells.csv`, `cells.json`, figures, `report.md` and `report.html`. Refuses, writing
/// nothing, when the folder's tables record finished cells whose data are not here.
pub(crate) fn build_report(out: &OutputDir) -> Result<PathBuf> {
    refuse_to_lose_recorded_cells(out)?;
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
    let axis = study_axis(&experiment, &plan);
    let opening = match (&experiment.report.pair, &axis) {
        (Some(pair), _) => Some(explorer::Opening::Named(pair)),
        (None, Some(axis)) => Some(explorer::Opening::Axis(axis)),
        (None, None) => None,
    };
    let explorer = explorer::Explorer::build(
        out,
        &plan,
        &cells,
        experiment.report.explorer_max_side,
        opening,
    )?;
    let html = html::html(out.root(), &markdown, &explorer, &figures)?;
    let path = out.root().join("report.html");
    volphot::write_atomic(&path, html.as_bytes())?;
    Ok(path)
}
