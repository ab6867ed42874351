//! One module per verb.

mod bench;
mod claims;
mod datasets;
mod estimators;
mod export;
mod import;
mod index;
mod peer;
mod pilot;
mod plan;
mod render;
mod report;
mod run;
mod status;

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::{Cli, Command};
pub(crate) use crate::render::thread_pool;

/// Runs the chosen verb.
pub(crate) fn dispatch(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Datasets(a) => datasets::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Plan(a) => plan::run(&a),
        Command::Run(a) => run::run(&a),
        Command::Report(a) => report::run(&a),
        Command::Status(a) => status::run(&a),
        Command::Claims(a) => claims::run(&a),
        Command::Index(a) => index::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Export(a) => export::run(&a),
        Command::Import(a) => import::run(&a),
        Command::Tune(a) => crate::tune::run(&a.options()?),
    }
}
