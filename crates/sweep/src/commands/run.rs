//! `sweep run` (and `sweep FILE.toml`).

use std::process::ExitCode;

use anyhow::Result;

use crate::cells::OutputDir;
use crate::cli::{Backend, RunArgs};
use crate::experiment::Experiment;
use crate::runner::{
    RunOptions, default_output, lock_folder, parse_selection, parse_shard, plan_with_hashes,
    render_cells, write_plan,
};

/// Plans, renders and reports.
pub fn run(args: &RunArgs) -> Result<ExitCode> {
    let exp = Experiment::load(&args.experiment)?;
    let quality = args.quality.quality();
    let (cells, hashes) = plan_with_hashes(&exp, quality)?;
    anyhow::ensure!(
        cells.len() <= exp.max_cells || args.yes,
        "{}: the grid has {} cells, more than max_cells = {}; check it with `sweep plan {}` and pass --yes to run it",
        exp.path.display(),
        cells.len(),
        exp.max_cells,
        exp.path.display()
    );
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&exp, quality));
    let out = OutputDir::new(&output);
    let selection = match (&args.cells, &args.shard) {
        (Some(c), _) => Some(parse_selection(c, cells.len())?),
        (None, Some(s)) => Some(parse_shard(s, cells.len())?),
        (None, None) => None,
    };
    if args.backend == Backend::Slurm {
        return crate::slurm::run(args, &exp, &cells, &hashes, &out, quality);
    }
    let _lock = lock_folder(&out, selection.is_none())?;
    let plan = write_plan(&exp, &cells, &hashes, &out, quality)?;
    let pool = super::thread_pool(args.threads)?;
    let options = RunOptions {
        output: output.clone(),
        selection: selection.clone(),
        jobs: args.jobs,
        quiet: args.quiet,
    };
    let summary = pool.install(|| render_cells(&exp, &cells, &hashes, &plan, &options))?;
    eprintln!(
        "{}: {} of {} cells selected; {} already done, {} rendered by {} march(es) with {} photon map(s), {} reference(s) rendered, {} failed, in {:.1} s",
        exp.name,
        summary.selected,
        summary.planned,
        summary.skipped,
        summary.rendered,
        summary.marches,
        summary.photon_maps,
        summary.references,
        summary.failed.len(),
        summary.seconds
    );
    for (index, message) in &summary.failed {
        eprintln!(
            "  cell {index} failed: {}",
            message.lines().next().unwrap_or("")
        );
    }
    if !args.no_report && selection.is_none() {
        let report = crate::report::build_report(&out)?;
        eprintln!("report: {}", report.display());
    }
    Ok(if summary.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
