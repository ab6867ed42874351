//! `sweep index`: the page that links every study, the paper and the benchmarks.

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::IndexArgs;

/// Writes `DIR/index.html`.
pub(crate) fn run(args: &IndexArgs) -> Result<ExitCode> {
    let path = crate::report::write_index(&args.dir)?;
    eprintln!("index: {}", path.display());
    Ok(ExitCode::SUCCESS)
}
