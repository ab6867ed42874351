//! `sweep plan`: the cells of an experiment and what they are estimated to cost
//! ([`crate::cost`]), without rendering.

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::PlanArgs;
use crate::cost::{CostMethod, PlanEstimate};
use crate::plan::{CellSpec, Experiment};
use crate::store::ReferencePool;

/// Prints each cell's estimated cost and the total.
fn print_estimates(
    cells: &[CellSpec],
    hashes: &[String],
    estimate: &PlanEstimate,
    plan_seconds: f64,
    pool: Option<&ReferencePool>,
) {
    println!("{:>5}  {:<16}  {:>9}  cell", "index", "hash", "est. [s]");
    for ((c, hash), est) in cells.iter().zip(hashes).zip(&estimate.cells) {
        println!("{:>5}  {:<16}  {:>9.1}  {}", c.index, hash, est, c.label());
    }
    let (cells_total, total) = (estimate.cells_total(), estimate.total());
    let references = &estimate.references;
    println!(
        "estimated {total:.0} s of rendering ({:.1} h): {cells_total:.0} s for the cells in {} march group(s) and {:.0} s for {} reference(s){}. {}. Planned in {:.3} s.",
        total / 3600.0,
        estimate.groups.len(),
        references.seconds,
        references.count,
        references.pool_note(pool),
        estimate.how,
        plan_seconds + estimate.probe_seconds
    );
}

/// Prints the plan.
pub(crate) fn run(args: &PlanArgs) -> Result<ExitCode> {
    let start = std::time::Instant::now();
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
            "{} ({:?} quality): {size} cells, more than max_cells = {}; not expanded (pass --yes to list them; `sweep run` will ask for --yes too)",
            exp.name, quality, exp.max_cells
        );
        return Ok(ExitCode::SUCCESS);
    }
    let (cells, hashes) = exp.plan_with_hashes(quality, true)?;
    let plan_seconds = start.elapsed().as_secs_f64();
    println!(
        "{} ({:?} quality): {} cells",
        exp.name,
        quality,
        cells.len()
    );
    let pool = args.reference_pool.clone().map(ReferencePool::new);
    let method = if args.no_pilot {
        CostMethod::Model
    } else {
        CostMethod::Pilot
    };
    let estimate = crate::cost::estimate(&exp, &cells, pool.as_ref(), method)?;
    print_estimates(&cells, &hashes, &estimate, plan_seconds, pool.as_ref());
    if cells.len() > exp.max_cells {
        println!(
            "note: {} cells exceed the experiment's max_cells = {}; `sweep run` will ask for --yes",
            cells.len(),
            exp.max_cells
        );
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
