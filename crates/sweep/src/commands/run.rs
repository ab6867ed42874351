//! `sweep run` (and `sweep FILE.toml`).

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;

use crate::backend::Run;
use crate::cli::RunArgs;
use crate::plan::{Experiment, Quality};
use crate::store::OutputDir;

/// Plans the experiment and hands it to the chosen backend.
pub(crate) fn run(args: &RunArgs) -> Result<ExitCode> {
    let filter = args.cell_filter()?;
    let backend = args.backend()?;
    let quality = args.quality.quality();
    let exp = Experiment::load(&args.experiment)?;
    anyhow::ensure!(
        exp.tune.is_none(),
        "{}: has a [tune] section, whose cells `sweep tune {}` plans; `sweep run` would replace that plan with the base grid",
        args.experiment.display(),
        args.experiment.display()
    );
    let (cells, hashes) = exp.plan_with_hashes(quality, args.yes)?;
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&exp, quality));
    let outcome = backend.execute(&Run {
        experiment: &exp,
        cells: &cells,
        hashes: &hashes,
        quality,
        output: OutputDir::new(output),
        selection: filter.resolve(cells.len())?,
        quiet: args.quiet,
        report: !args.no_report,
        cell_timeout: args.cell_timeout,
    })?;
    Ok(outcome.exit_code())
}

/// The default output folder: `reports/<experiment name>/` (with a quality suffix).
pub(crate) fn default_output(exp: &Experiment, quality: Quality) -> std::path::PathBuf {
    let name = match quality {
        Quality::Default => exp.name.clone(),
        Quality::Quick => format!("{}-quick", exp.name),
        Quality::Paper => format!("{}-paper", exp.name),
    };
    Path::new("reports").join(name)
}
