//! The local backend: renders the run's cells on this machine with a rayon pool.

use anyhow::Result;

use super::{Backend, Outcome, Run};
use crate::render::{RenderOptions, RunSummary, Selection, render_cells};
use crate::store::{check_owner, lock_folder, write_plan};

/// Renders on this machine.
pub(crate) struct Local {
    /// March groups rendered at once (each uses every thread).
    pub(crate) jobs: usize,
    /// Worker threads (all cores when `None`).
    pub(crate) threads: Option<usize>,
}

impl Backend for Local {
    fn execute(&self, run: &Run<'_>) -> Result<Outcome> {
        let exp = run.experiment;
        let full = run.selection == Selection::All;
        let _lock = lock_folder(&run.output, full)?;
        check_owner(&run.output, &exp.owner())?;
        let plan = exp.plan_record(run.cells, run.hashes, run.quality)?;
        write_plan(&run.output, &plan, &exp.source.text)?;
        let pool = crate::render::thread_pool(self.threads)?;
        let options = RenderOptions {
            output: run.output.clone(),
            selection: run.selection.clone(),
            jobs: self.jobs,
            quiet: run.quiet,
            time_limit: run.cell_timeout,
            reference_pool: run.reference_pool.clone(),
        };
        let summary = pool.install(|| render_cells(exp, run.cells, &plan, &options))?;
        print_summary(&exp.name, &summary);
        Ok(Outcome::Rendered {
            failed: summary.failed.len(),
        })
    }
}

/// What the summary line adds when it happened: damaged cells, cells left to another run.
fn notes(summary: &RunSummary) -> String {
    let mut notes = Vec::new();
    if summary.damaged > 0 {
        notes.push(format!(
            "{} damaged cell(s) rendered again",
            summary.damaged
        ));
    }
    if summary.busy > 0 {
        notes.push(format!(
            "{} cell(s) left to another run that is rendering them",
            summary.busy
        ));
    }
    if notes.is_empty() {
        String::new()
    } else {
        format!(" ({})", notes.join("; "))
    }
}

fn print_summary(name: &str, summary: &RunSummary) {
    eprintln!(
        "{}: {} of {} cells selected; {} already done, {} rendered by {} march(es) with {} photon map(s), {} reference(s) rendered, {} failed, in {:.1} s{}",
        name,
        summary.selected,
        summary.planned,
        summary.skipped,
        summary.rendered,
        summary.marches,
        summary.photon_maps,
        summary.references,
        summary.failed.len(),
        summary.seconds,
        notes(summary)
    );
    for (index, message) in &summary.failed {
        eprintln!(
            "  cell {index} failed: {}",
            message.lines().next().unwrap_or("")
        );
    }
}
