//! Spatial classification's own subcommands of `fleetmap` (`plan`), which the command line
//! takes from the registry (`crate::kinds`). Its benchmarks need the simulator: they are
//! studies' (`crate::experiment`), none here.

use super::plan;
use clap::Subcommand;
use std::process::ExitCode;

/// Subcommands of `fleetmap`.
#[derive(Debug, Subcommand)]
pub enum Commands {
    /// Solve one epoch of the bandit planner's integer program for a scenario file.
    Plan(plan::PlanArgs),
}

impl Commands {
    /// Run the command.
    pub(crate) fn run(self) -> anyhow::Result<ExitCode> {
        match self {
            Commands::Plan(args) => plan::run(args),
        }
    }
}

/// Subcommands of `fleetmap bench` without the simulator: none.
#[derive(Debug, Subcommand)]
pub enum BenchCommands {}

impl BenchCommands {
    /// Run the benchmark.
    pub(crate) fn run(self) -> anyhow::Result<ExitCode> {
        match self {}
    }
}
