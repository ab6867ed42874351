//! `sweep status`: done / running / failed / pending cells of an output folder.

use std::process::ExitCode;

use anyhow::Result;

use crate::backend::{compress_ranges, print_jobs};
use crate::cli::StatusArgs;
use crate::store::{OutputDir, cell_is_locked, is_done, read_plan};

/// Cell states as seen in the output folder (and by Slurm when a job was submitted).
pub(crate) fn run(args: &StatusArgs) -> Result<ExitCode> {
    let out = OutputDir::new(&args.dir);
    let plan = read_plan(&out)?;
    let (mut done, mut running, mut failed, mut pending) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for c in &plan.cells {
        if is_done(&out.cell(&c.hash)) {
            done.push(c.index);
            continue;
        }
        if cell_is_locked(&out, &c.hash) {
            running.push(c.index);
        } else if out.failure(&c.hash).is_file() {
            failed.push(c.index);
        } else {
            pending.push(c.index);
        }
    }
    let list = |v: &[usize]| compress_ranges(v);
    println!(
        "{} ({}): {} cells",
        plan.experiment,
        args.dir.display(),
        plan.cells.len()
    );
    println!("  done     {:>5}  {}", done.len(), list(&done));
    println!("  running  {:>5}  {}", running.len(), list(&running));
    println!("  failed   {:>5}  {}", failed.len(), list(&failed));
    println!("  pending  {:>5}  {}", pending.len(), list(&pending));
    for index in &failed {
        let c = &plan.cells[*index];
        println!("  cell {index}: {}", out.failure(&c.hash).display());
    }
    print_jobs(&out);
    Ok(ExitCode::SUCCESS)
}
