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
    #[command(flatten)]
    #[allow(missing_docs)]
    Kind(crate::kinds::KindBenchCommands),
    /// Terminal UI: full-frame redraws of a generated fleet, frames per second.
    Tui(super::tui::TuiBenchArgs),
    #[cfg(feature = "sim")]
    #[command(flatten)]
    #[allow(missing_docs)]
    KindStudy(crate::experiment::KindBenches),
    /// Mission round trips (upload + download) against the simulator's ArduPilot and PX4
    /// mission protocol at several losses each way, in virtual seconds.
    #[cfg(feature = "sim")]
    Transfer(super::bench_transfer::BenchTransferArgs),
    /// GCS CPU time per vehicle, and the terminal UI's frame rate, with N simulated copters
    /// (a child process) streaming telemetry to one UDP port.
    #[cfg(feature = "sim")]
    Fleet(super::bench_fleet::BenchFleetArgs),
}

/// Run a benchmark.
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.what {
        BenchCommand::Kind(b) => b.run(),
        BenchCommand::Tui(a) => super::tui::bench(a),
        #[cfg(feature = "sim")]
        BenchCommand::KindStudy(b) => b.run(crate::kinds::emit),
        #[cfg(feature = "sim")]
        BenchCommand::Transfer(a) => super::bench_transfer::run(a),
        #[cfg(feature = "sim")]
        BenchCommand::Fleet(a) => super::bench_fleet::run(a),
    }
}
