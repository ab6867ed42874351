//! One module per verb.

mod bench;
mod datasets;
mod plan;
mod render;
mod report;
mod run;
mod status;

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::{Cli, Command};

/// Runs the chosen verb.
pub fn dispatch(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Datasets(a) => datasets::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Plan(a) => plan::run(&a),
        Command::Run(a) => run::run(&a),
        Command::Report(a) => report::run(&a),
        Command::Status(a) => status::run(&a),
        Command::Bench(a) => bench::run(&a),
    }
}

/// Builds a rayon pool with `threads` workers (all cores when `None`).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        anyhow::ensure!(n >= 1, "--threads must be at least 1");
        builder = builder.num_threads(n);
    }
    Ok(builder.build()?)
}
