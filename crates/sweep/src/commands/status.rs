//! `sweep status`: done / running / failed / pending cells of an output folder.

use std::fs::File;
use std::process::ExitCode;

use anyhow::Result;

use crate::cells::{OutputDir, is_done};
use crate::cli::StatusArgs;
use crate::runner::read_plan;

/// Cell states as seen in the output folder (and by Slurm when a job was submitted).
pub fn run(args: &StatusArgs) -> Result<ExitCode> {
    let out = OutputDir::new(&args.dir);
    let plan = read_plan(&out)?;
    let (mut done, mut running, mut failed, mut pending) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for c in &plan.cells {
        if is_done(&out.cell(&c.hash)) {
            done.push(c.index);
            continue;
        }
        let lock_path = out.root().join("cells").join(format!(".{}.lock", c.hash));
        let busy = File::options()
            .write(true)
            .open(&lock_path)
            .ok()
            .is_some_and(|f| f.try_lock().is_err());
        if busy {
            running.push(c.index);
        } else if out.failure(&c.hash).is_file() {
            failed.push(c.index);
        } else {
            pending.push(c.index);
        }
    }
    let list = |v: &[usize]| crate::slurm::compress_ranges(v);
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
    crate::slurm::print_jobs(&out);
    Ok(ExitCode::SUCCESS)
}
