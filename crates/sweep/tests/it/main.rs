//! The sweep binary's integration tests, one test binary with a module per file.

mod architecture;
mod cli;
mod tune;
