//! `sweep`: parameter studies of volume photon mapping.
//!
//! See `sweep --help` and the README for the experiment format.
#![warn(missing_docs)]

mod analyse;
mod backend;
mod bench;
mod claims;
mod cli;
mod commands;
mod confine;
mod cost;
#[cfg(test)]
mod fuzz;
mod plan;
mod progress;
mod ranges;
mod render;
mod report;
mod spans;
mod store;
mod tune;

fn main() -> std::process::ExitCode {
    let cli = cli::parse(std::env::args_os().collect());
    match commands::dispatch(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::from(2)
        }
    }
}
