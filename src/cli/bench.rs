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
    /// Images per second of the runway classifier (`--width 1920 --height 1080 --images N`).
    Classify(crate::cli::classify::BenchClassifyArgs),
    /// Terminal UI: full-frame redraws of a generated fleet, frames per second.
    Tui(super::tui::TuiBenchArgs),
}

/// Run a benchmark.
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.what {
        BenchCommand::Classify(a) => crate::cli::classify::bench(a),
        BenchCommand::Tui(a) => super::tui::bench(a),
    }
}
