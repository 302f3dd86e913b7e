//! The runway's own subcommands of `fleetmap` (`classify`) and of `fleetmap bench`
//! (`classify`), which the command line takes from the registry (`crate::kinds`).

use super::classify;
use clap::Subcommand;
use std::process::ExitCode;

/// Subcommands of `fleetmap`.
#[derive(Debug, Subcommand)]
pub enum Commands {
    /// Classify images with the runway sensing model (and the green-pixel measurement).
    Classify(classify::ClassifyArgs),
}

impl Commands {
    /// Run the command.
    pub(crate) fn run(self) -> anyhow::Result<ExitCode> {
        match self {
            Commands::Classify(args) => classify::run(args),
        }
    }
}

/// Subcommands of `fleetmap bench` (with or without the simulator).
#[derive(Debug, Subcommand)]
pub enum BenchCommands {
    /// Images per second of the runway classifier (`--width 1920 --height 1080 --images N`).
    Classify(classify::BenchClassifyArgs),
}

impl BenchCommands {
    /// Run the benchmark.
    pub(crate) fn run(self) -> anyhow::Result<ExitCode> {
        match self {
            BenchCommands::Classify(args) => classify::bench(args),
        }
    }
}
