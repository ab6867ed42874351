//! Where cells are rendered: behind one [`Backend`] trait (after hyperfine's `Executor`),
//! chosen once per run. [`local::Local`] renders on this machine; [`slurm::Slurm`] submits a
//! job array over the cells plus a collect job. Both write the same cells into the same
//! output folder, so a report cannot tell them apart.

mod local;
mod slurm;

use std::process::ExitCode;

use anyhow::Result;

pub(crate) use local::Local;
pub(crate) use slurm::{Slurm, SlurmOptions, plan_submission, print_jobs};

use crate::plan::{CellSpec, Experiment, Quality};
use crate::render::Selection;
use crate::store::{OutputDir, ReferencePool};

/// One run of an experiment: the plan and what to do with it.
pub(crate) struct Run<'a> {
    /// The experiment.
    pub(crate) experiment: &'a Experiment,
    /// Its cells for the chosen quality.
    pub(crate) cells: &'a [CellSpec],
    /// Their content addresses.
    pub(crate) hashes: &'a [String],
    /// The quality preset.
    pub(crate) quality: Quality,
    /// The output folder.
    pub(crate) output: OutputDir,
    /// The cells to render.
    pub(crate) selection: Selection,
    /// Hide progress bars.
    pub(crate) quiet: bool,
    /// Time limit per render (a march group or a reference).
    pub(crate) cell_timeout: Option<std::time::Duration>,
    /// References shared with other output folders.
    pub(crate) reference_pool: Option<ReferencePool>,
}

/// How a run ended. The `run` verb builds the report from it; a backend never does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// The selected cells were rendered (or found finished) here; `failed` of them failed
    /// (their errors are in `failed/`). The caller builds the report, which lists them.
    Rendered {
        /// Cells that failed.
        failed: usize,
    },
    /// The cells went to a cluster, whose collect job builds the report; `failed` counts
    /// the cells (or the collect job) that failed when the caller waited.
    Submitted {
        /// Cells, or the collect job, that failed.
        failed: usize,
    },
}

impl Outcome {
    /// The process exit code: 0, or 1 when cells failed.
    pub(crate) fn exit_code(self) -> ExitCode {
        match self {
            Outcome::Rendered { failed: 0 } | Outcome::Submitted { failed: 0 } => ExitCode::SUCCESS,
            _ => ExitCode::from(1),
        }
    }
}

/// Renders the cells of a run, here or elsewhere.
pub(crate) trait Backend {
    /// Renders (or submits) the run's selected, unfinished cells.
    fn execute(&self, run: &Run<'_>) -> Result<Outcome>;
}
