//! `sweep report`: regenerate CSV, figures and report from an output folder.

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::ReportArgs;
use crate::store::{OutputDir, lock_folder, read_plan};

/// Rebuilds the report without rendering.
pub(crate) fn run(args: &ReportArgs) -> Result<ExitCode> {
    let out = OutputDir::new(&args.dir);
    // Only an output folder: nothing (not even a lock file) is written anywhere else.
    read_plan(&out)?;
    if args.explorer_opening {
        let _lock = lock_folder(&out, false)?;
        let path = crate::report::reopen_explorer(&out)?;
        eprintln!("report: {} opens on the study's pair", path.display());
        return Ok(ExitCode::SUCCESS);
    }
    // Before the lock file: a folder that would lose results is left exactly as it was.
    crate::report::refuse_to_lose_recorded_cells(&out)?;
    // Hold a shared lock: a full run writing this folder would conflict.
    let _lock = lock_folder(&out, false)?;
    let path = crate::report::build_report(&out)?;
    eprintln!("report: {}", path.display());
    Ok(ExitCode::SUCCESS)
}
