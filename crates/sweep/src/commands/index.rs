//! `sweep index`: the page that links every study, the paper and the benchmarks.

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::IndexArgs;

/// Writes `DIR/index.html`; names every study folder it had to skip.
pub(crate) fn run(args: &IndexArgs) -> Result<ExitCode> {
    let index = crate::report::write_index(&args.dir)?;
    for (folder, why) in &index.skipped {
        eprintln!("warning: index: skipped {folder}: {why}");
    }
    eprintln!(
        "index: {}{}",
        index.path.display(),
        if index.skipped.is_empty() {
            String::new()
        } else {
            format!(" ({} folders skipped)", index.skipped.len())
        }
    );
    Ok(ExitCode::SUCCESS)
}
