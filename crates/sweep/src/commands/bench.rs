//! `sweep bench`: the headline frame's configurations, or the peer and estimator
//! comparisons ([`crate::bench`]).

use std::process::ExitCode;

use anyhow::Result;

use crate::cli::BenchArgs;

/// Runs the benchmark.
pub(crate) fn run(args: &BenchArgs) -> Result<ExitCode> {
    crate::bench::run(&args.options()?)
}
