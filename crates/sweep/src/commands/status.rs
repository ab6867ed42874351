//! `sweep status`: done / running / failed / pending cells of an output folder.

use std::process::ExitCode;

use anyhow::Result;

use crate::backend::print_jobs;
use crate::cli::StatusArgs;
use crate::ranges::compress_ranges;
use crate::store::{
    CellState, OutputDir, cell_is_locked, cell_state, read_plan, recorded_but_absent,
};

/// Cell states as seen in the output folder (and by Slurm when a job was submitted).
pub(crate) fn run(args: &StatusArgs) -> Result<ExitCode> {
    let out = OutputDir::new(&args.dir);
    let plan = read_plan(&out)?;
    // Finished elsewhere: the tables record them, their data are not here (a clone).
    let recorded = recorded_but_absent(&out, &plan);
    let (mut done, mut running, mut failed, mut pending, mut damaged) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for c in &plan.cells {
        match cell_state(&out.cell(&c.hash)) {
            CellState::Done(_) => {
                done.push(c.index);
                continue;
            }
            CellState::Damaged(why) => damaged.push((c.index, why)),
            CellState::Missing => {}
        }
        if cell_is_locked(&out, &c.hash) {
            running.push(c.index);
        } else if recorded.contains(&c.index) {
            continue;
        } else if out.failure(&c.hash).is_file() {
            failed.push(c.index);
        } else if !damaged.iter().any(|(i, _)| *i == c.index) {
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
    if !recorded.is_empty() {
        println!(
            "  recorded {:>5}  {}  (done in cells.json; their data are not in this folder: `sweep run` renders them again, with the same images)",
            recorded.len(),
            list(&recorded)
        );
    }
    println!("  running  {:>5}  {}", running.len(), list(&running));
    println!("  failed   {:>5}  {}", failed.len(), list(&failed));
    println!("  pending  {:>5}  {}", pending.len(), list(&pending));
    let damaged_indices: Vec<usize> = damaged.iter().map(|(i, _)| *i).collect();
    println!(
        "  damaged  {:>5}  {}",
        damaged.len(),
        list(&damaged_indices)
    );
    for (index, why) in &damaged {
        println!("  cell {index}: damaged: {why} (`sweep run` renders it again)");
    }
    for index in &failed {
        let c = &plan.cells[*index];
        println!("  cell {index}: {}", out.failure(&c.hash).display());
    }
    print_jobs(&out);
    Ok(ExitCode::SUCCESS)
}
