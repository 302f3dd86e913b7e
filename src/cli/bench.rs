//! `fleetmap bench …`: measure speed and print the figures (performance is measured by
//! commands and criterion benches, never asserted in tests).

use clap::{Args, Subcommand};
use std::process::ExitCode;

/// Arguments of `fleetmap bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What to measure.
    #[command(subcommand)]
    pub what: BenchCommand,
}

/// The benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Terminal UI: full-frame redraws of a generated fleet, frames per second.
    Tui(super::tui::TuiBenchArgs),
}

/// Run a benchmark.
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.what {
        BenchCommand::Tui(a) => super::tui::bench(a),
    }
}
