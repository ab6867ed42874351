//! `sweep run` (and `sweep FILE.toml`).

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;

use crate::backend::{Outcome, Run};
use crate::cli::RunArgs;
use crate::plan::Experiment;
use crate::render::Selection;
use crate::store::{OutputDir, ReferencePool};

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
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| crate::plan::default_output(&exp, quality));
    crate::cli::check_output_folder("--output", &output)?;
    if let Some(pool) = &args.reference_pool {
        crate::cli::check_output_folder("--reference-pool", pool)?;
    }
    let (cells, hashes) = exp.plan_with_hashes(quality, args.yes)?;
    for warning in exp.ignored_settings(quality, &cells)? {
        eprintln!("warning: {}: {warning}", args.experiment.display());
    }
    let reference_pool = args
        .reference_pool
        .as_deref()
        .map(|pool| checked_pool(pool, &output))
        .transpose()?;
    let selection = filter.resolve(cells.len())?;
    let full = selection == Selection::All;
    let output = OutputDir::new(output);
    let outcome = backend.execute(&Run {
        experiment: &exp,
        cells: &cells,
        hashes: &hashes,
        quality,
        output: output.clone(),
        selection,
        quiet: args.quiet,
        cell_timeout: args.cell_timeout,
        reference_pool,
    })?;
    // A partial run (`--cells`) leaves the report to the run that finishes the study; a
    // cluster's collect job writes its own. A local run with failed cells still gets its
    // report, which lists them.
    if matches!(outcome, Outcome::Rendered { .. }) && full && !args.no_report {
        let report = crate::report::build_report(&output)?;
        eprintln!("report: {}", report.display());
    }
    Ok(outcome.exit_code())
}

/// A reference pool outside the output folder: inside it, writing the study's own copy of
/// a reference would replace the pool's folder of the same key.
fn checked_pool(pool: &Path, output: &Path) -> Result<ReferencePool> {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    anyhow::ensure!(
        !absolute(pool).starts_with(absolute(output)),
        "--reference-pool {}: inside the output folder {}; expected a folder of its own that several studies share (scripts/reproduce.sh uses reports/reference-pool)",
        pool.display(),
        output.display()
    );
    Ok(ReferencePool::new(pool))
}
