//! `sweep plan`: the cells of an experiment and what they are estimated to cost
//! ([`crate::cost`]), without rendering. The summary comes first; the cells follow with
//! `--list`.

use std::process::ExitCode;
use std::time::Instant;

use anyhow::Result;

use crate::cli::PlanArgs;
use crate::cost::{CostMethod, PlanEstimate};
use crate::plan::{CellSpec, Experiment, Quality};
use crate::store::ReferencePool;

/// Seconds as a person reads them: seconds, minutes or hours.
fn readable(seconds: f64) -> String {
    match seconds {
        s if s < 90.0 => format!("{s:.0} s"),
        s if s < 5400.0 => format!("{:.1} min", s / 60.0),
        s => format!("{:.1} h", s / 3600.0),
    }
}

/// How many of `jobs` march groups render side by side without sharing cores: each job
/// uses `threads` (all cores when `None`), and jobs beyond the cores share them.
fn side_by_side(jobs: usize, threads: Option<usize>) -> (usize, usize) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let per_job = threads.unwrap_or(cores).max(1);
    ((cores / per_job).clamp(1, jobs.max(1)), cores)
}

/// The estimated wall time, what it is made of and how it was found.
fn print_estimate(args: &PlanArgs, estimate: &PlanEstimate, pool: Option<&ReferencePool>) {
    let (parallel, cores) = side_by_side(args.jobs, args.threads);
    let shared = if parallel < args.jobs {
        format!(
            " ({} job(s) share this machine's {cores} core(s), so {parallel} render side by side; `--threads` sets each job's share)",
            args.jobs
        )
    } else {
        String::new()
    };
    let references = &estimate.references;
    println!(
        "estimated wall time {} at --jobs {}{shared}: {:.0} s for the cells and {:.0} s for the references{} ({:.0} s of rendering in all). {}.",
        readable(estimate.wall_seconds(parallel)),
        args.jobs,
        estimate.cells_total(),
        references.seconds,
        references.pool_note(pool),
        estimate.total(),
        estimate.how,
    );
}

/// How long planning took, and how much of it went to pilot renders and probes.
fn print_planning_time(estimate: &PlanEstimate, seconds: f64) {
    let secs = |s: f64| {
        if s < 10.0 {
            format!("{s:.2} s")
        } else {
            format!("{s:.1} s")
        }
    };
    let probes = (estimate.probe_seconds > 0.0).then(|| {
        format!(
            "{} probing eye-march lengths for the model",
            secs(estimate.probe_seconds)
        )
    });
    let line = if estimate.pilot_renders > 0 {
        let pilots = format!(
            "{} pilot renders ({} of them, their volumes' loading included)",
            secs(estimate.pilot_seconds),
            estimate.pilot_renders
        );
        let parts: Vec<String> = [Some(pilots), probes].into_iter().flatten().collect();
        format!(", of which {}", parts.join(" and "))
    } else {
        format!(
            " without pilot renders (--no-pilot){}",
            probes.map_or(String::new(), |p| format!(", {p}"))
        )
    };
    println!("planned in {}{line}", secs(seconds));
}

/// Each cell's estimated cost.
fn print_cells(cells: &[CellSpec], hashes: &[String], estimate: &PlanEstimate) {
    println!("{:>5}  {:<16}  {:>9}  cell", "index", "hash", "est. [s]");
    for ((c, hash), est) in cells.iter().zip(hashes).zip(&estimate.cells) {
        println!("{:>5}  {:<16}  {:>9.1}  {}", c.index, hash, est, c.label());
    }
}

/// Prints the plan: the summary, then the cells with `--list`.
pub(crate) fn run(args: &PlanArgs) -> Result<ExitCode> {
    let start = Instant::now();
    let exp = Experiment::load(&args.experiment)?;
    let quality = args.quality.quality();
    if exp.tune.is_some() {
        println!(
            "{}: has a [tune] section; these are the contexts every configuration is rendered on, and `sweep tune {} --dry-run` shows the search",
            exp.name,
            args.experiment.display()
        );
    }
    let size = exp.grid_size(quality)?;
    if size > exp.max_cells && !args.yes {
        println!(
            "{} (`{}` quality): {size} cells, more than max_cells = {}; not expanded (pass --yes to plan them; `sweep run` will ask for --yes too)",
            exp.name,
            quality.name(),
            exp.max_cells
        );
        return Ok(ExitCode::SUCCESS);
    }
    let (cells, hashes) = exp.plan_with_hashes(quality, true)?;
    for warning in exp.ignored_settings(quality, &cells)? {
        eprintln!("warning: {}: {warning}", args.experiment.display());
    }
    let pool = args.reference_pool.clone().map(ReferencePool::new);
    let method = if args.no_pilot {
        CostMethod::Model
    } else {
        CostMethod::Pilot
    };
    let threads = args.threads;
    let estimate = crate::render::thread_pool(threads)?
        .install(|| crate::cost::estimate(&exp, &cells, pool.as_ref(), method))?;
    print_summary(&exp, quality, &cells, &estimate);
    print_estimate(args, &estimate, pool.as_ref());
    print_planning_time(&estimate, start.elapsed().as_secs_f64());
    if cells.len() > exp.max_cells {
        println!(
            "note: {} cells exceed the experiment's max_cells = {}; `sweep run` will ask for --yes",
            cells.len(),
            exp.max_cells
        );
    }
    if args.list {
        print_cells(&cells, &hashes, &estimate);
    } else {
        println!("each cell's estimate: add --list");
    }
    if args.slurm {
        let out = crate::plan::default_output(&exp, quality);
        let script = crate::backend::plan_submission(
            &exp,
            &cells,
            &out,
            &crate::backend::SlurmOptions::default(),
            quality,
            None,
        )?;
        println!("\n{}", script.describe());
    }
    Ok(ExitCode::SUCCESS)
}

/// The first line: what the plan holds and where `sweep run` writes it.
fn print_summary(exp: &Experiment, quality: Quality, cells: &[CellSpec], estimate: &PlanEstimate) {
    println!(
        "{} (`{}` quality): {} cells in {} march group(s) and {} reference(s); `sweep run` writes them to {}",
        exp.name,
        quality.name(),
        cells.len(),
        estimate.groups.len(),
        estimate.references.count,
        crate::plan::default_output(exp, quality).display()
    );
}
