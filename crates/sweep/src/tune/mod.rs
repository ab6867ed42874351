//! `sweep tune`: the best settings for a dataset and a time budget, found by Hyperband
//! (successive halving over resolution and photon count) with tree-Parzen proposals.
//!
//! Every evaluation is an ordinary cell of the output folder: its scene is the experiment's
//! base scene (one per context, i.e. per cell of the experiment's `[axes]` grid) with the
//! configuration's values and the level's resolution and photon count set, stored under
//! its content address. Each rung is one call of the run's [`Backend`] (a Slurm job array
//! when `--backend slurm`), so `sweep report` shows the cells and a rerun renders nothing
//! that is finished. Proposals are seeded per bracket and fitted on evaluations sorted by
//! id, so the same file and seed make the same decisions.
//!
//! Output in `OUTPUT/tune/`: `observations.csv`, `pareto.csv` + `pareto.png`/`.svg`,
//! `best*.toml` (ready-to-use scenes per time budget), `sensitivity.csv` and `report.md`
//! (linked from the experiment's report).
//!
//! Dependencies run one way: this module dispatches the modes to `search` (the Hyperband
//! loop and the Slurm array task) and `output` (the files and the dry run); `search` hands
//! its [`evaluation::Evaluation`]s to `output`, and both take that type from the leaf
//! `evaluation`.

mod analysis;
mod cells;
mod evaluation;
mod hyperband;
mod output;
mod propose;
mod search;
mod space;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;

use crate::backend::Backend;
use crate::plan::{Experiment, Quality, default_output};
use crate::render::CellFilter;
use crate::store::OutputDir;

/// What `sweep tune` does.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum TuneMode {
    /// Search, then write the tune outputs and the report.
    Search,
    /// Check and print the plan; render nothing.
    DryRun,
    /// Render these cells of the output folder's `plan.json` (a Slurm array task).
    Cells(CellFilter),
}

/// The validated options of `sweep tune`.
pub(crate) struct TuneOptions {
    /// The experiment file.
    pub(crate) experiment: PathBuf,
    /// Output folder (default `out/<name>/`).
    pub(crate) output: Option<PathBuf>,
    /// What to do.
    pub(crate) mode: TuneMode,
    /// Where rungs are rendered.
    pub(crate) backend: Box<dyn Backend>,
    /// Hide progress bars.
    pub(crate) quiet: bool,
    /// Build the reports at the end.
    pub(crate) report: bool,
    /// Time limit per render.
    pub(crate) cell_timeout: Option<Duration>,
}

/// `sweep tune`.
pub(crate) fn run(opts: &TuneOptions) -> Result<ExitCode> {
    let exp = Experiment::load(&opts.experiment)?;
    let spec = exp.tune.as_ref().ok_or_else(|| {
        anyhow::anyhow!(
            "{}: no [tune] section; `sweep tune` needs one (objective, budget, fidelity, space; see `sweep tune --help`), and a grid runs with `sweep run`",
            opts.experiment.display()
        )
    })?;
    let out = OutputDir::new(
        opts.output
            .clone()
            .unwrap_or_else(|| default_output(&exp, Quality::Default)),
    );
    match &opts.mode {
        TuneMode::DryRun => output::dry_run(&exp, spec, &out),
        TuneMode::Cells(filter) => search::render_planned(&exp, &out, filter, opts),
        TuneMode::Search => search::search(&exp, spec, out, opts),
    }
}
