//! `fleetmap experiment …`: the papers' Monte Carlo studies (CSV, JSON summary, PNG plots).

use clap::{Args, Subcommand};
use std::process::ExitCode;

/// Arguments of `fleetmap experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Which study.
    #[command(subcommand)]
    pub which: ExperimentCommand,
}

/// The studies.
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// The bandit paper's Monte Carlo study (Tables I–IV, Fig. 5, Fig. 6).
    Bandit(super::bandit::ExperimentBanditArgs),
}

/// Run a study.
pub fn run(args: ExperimentArgs) -> anyhow::Result<ExitCode> {
    match args.which {
        ExperimentCommand::Bandit(a) => super::bandit::run_experiment(a),
    }
}
