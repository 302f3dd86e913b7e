//! The `fleetmap` command line: one subcommand per user task.
//!
//! Each subcommand's arguments and entry point live in a file of this module
//! (`src/cli/<task>.rs`), except a mission kind's own commands, which are in the kind's folder
//! (`fleetmap classify`: `src/kinds/runway/classify.rs`; `fleetmap plan`:
//! `src/kinds/bandit/plan.rs`); this file only declares the command tree and dispatches.
//! Commands return an [`ExitCode`]; an `Err` is printed by `main` as one line on stderr
//! and exits with status 1.

pub mod bench;
#[cfg(feature = "sim")]
pub(crate) mod bench_fleet;
#[cfg(feature = "sim")]
pub(crate) mod bench_transfer;
pub mod check;
pub mod command;
#[cfg(feature = "sim")]
pub mod demo;
#[cfg(feature = "sim")]
pub mod experiment;
pub mod grid;
pub mod mission;
pub mod relay;
pub mod run;
pub mod signing;
#[cfg(feature = "sim")]
pub mod sim;
pub mod tui;
pub mod vehicles;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// fleetmap: map regions of interest with fleets of PX4 and ArduPilot vehicles over MAVLink.
#[derive(Debug, Parser)]
#[command(name = "fleetmap", version, about, long_about = None)]
pub struct Cli {
    /// More log output on stderr (-v info, -vv debug, -vvv trace). `RUST_LOG` overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub(crate) verbose: u8,
    /// Write logs to this file instead of stderr.
    #[arg(long, global = true, value_name = "FILE")]
    pub(crate) log_file: Option<PathBuf>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Measure speed and print the figures.
    Bench(bench::BenchArgs),
    /// Validate a mission definition file and print a summary (or every error).
    Check(check::CheckArgs),
    /// Run one of the papers' Monte Carlo studies.
    #[cfg(feature = "sim")]
    Experiment(experiment::ExperimentArgs),
    /// Serve simulated ArduPilot / PX4 copters and rovers over MAVLink.
    #[cfg(feature = "sim")]
    Sim(Box<sim::SimArgs>),
    /// A MAVLink camera on a companion computer next to an autopilot: pictures from a folder
    /// (or rendered, for SITL), measured on board, sent as small measurements.
    Camera(Box<fleetmap_camera::cli::CameraArgs>),
    /// Convert between mission-grid cells and GPS/UTM coordinates; export cells as GeoJSON/KML.
    Grid(grid::GridArgs),
    #[command(flatten)]
    #[allow(missing_docs)]
    Kind(crate::kinds::KindCommands),
    /// The operator's terminal UI: live on MAVLink connections (`--connect`), with a mission to
    /// start (`--mission`) or a run to continue (`--resume`); or a built-in sample or a replay file.
    Tui(tui::TuiArgs),
    /// List the vehicles heard on MAVLink connections and their state.
    Vehicles(vehicles::VehiclesArgs),
    /// Upload, download, clear or fly a mission (also fence and rally lists).
    Mission(mission::MissionArgs),
    /// Arm, disarm, change mode, take off, go to, return, land.
    Command(command::CommandArgs),
    /// Relay MAVLink between a GCS and a vehicle, losing, duplicating or delaying frames on
    /// the way and carrying at most a radio's bytes per second (to try a real autopilot over
    /// a poor radio).
    Relay(relay::RelayArgs),
    /// MAVLink 2 signing keys: make one, install one on a vehicle.
    Signing(signing::SigningArgs),
    /// The embedded default: the simulator and the runway mission in one process.
    #[cfg(feature = "sim")]
    Demo(demo::DemoArgs),
    /// Fly a mission file with the vehicles: runway mapping (sweep, then the recursive DFS) or
    /// spatial classification (bandit epochs, sorties with charging rovers).
    Run(Box<run::RunArgs>),
    /// Continue a run after a battery swap or a crash.
    Resume(Box<run::ResumeArgs>),
    /// What a run produced: map / keep and reject sets, per-epoch figures, scores against a
    /// simulated world.
    Report(run::ReportArgs),
    /// Write a run's map as GeoJSON, KML (Google Earth) or PNG.
    Export(run::ExportArgs),
}

/// Set up `tracing` as the command line asks: stderr by default, a file with `--log-file`.
pub(crate) fn init_logging(verbose: u8, log_file: Option<&std::path::Path>) -> anyhow::Result<()> {
    use tracing_subscriber::EnvFilter;
    let default = match verbose {
        // HiGHS logs every time-limited solve as a warning; the planner reports those itself.
        0 => "warn,highs=error",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default));
    let builder = tracing_subscriber::fmt().with_env_filter(filter);
    let result = match log_file {
        Some(path) => {
            let file = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .map_err(|e| anyhow::anyhow!("cannot open log file {}: {e}", path.display()))?;
            builder
                .with_ansi(false)
                .with_writer(std::sync::Mutex::new(file))
                .try_init()
        }
        None => builder.with_writer(std::io::stderr).try_init(),
    };
    // A second initialisation (tests calling `run` twice) keeps the first subscriber.
    let _ = result;
    Ok(())
}

/// An error and its causes on one line, outermost first, separated by ": " — how `main`
/// reports a failed command. A cause whose text the line already ends with is left out:
/// several error types print their source in their own message and also return it from
/// `Error::source` (an I/O error after a path, for instance), which would otherwise show
/// the same words twice ("X: X").
pub fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Run the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    // The terminal UI owns the screen: its default log goes to a file, not stderr.
    let log_file = match &cli.command {
        Command::Tui(args) if cli.log_file.is_none() => tui::default_log_file(args),
        #[cfg(feature = "sim")]
        Command::Demo(args)
            if cli.log_file.is_none() && !args.options.headless && tui::interactive() =>
        {
            tui::ui_log_file()
        }
        Command::Run(args)
            if cli.log_file.is_none() && !args.runner.headless && tui::interactive() =>
        {
            tui::ui_log_file()
        }
        Command::Resume(args)
            if cli.log_file.is_none() && !args.runner.headless && tui::interactive() =>
        {
            tui::ui_log_file()
        }
        _ => cli.log_file.clone(),
    };
    init_logging(cli.verbose, log_file.as_deref())?;
    match cli.command {
        Command::Bench(args) => bench::run(args),
        Command::Check(args) => check::run(args),
        #[cfg(feature = "sim")]
        Command::Experiment(args) => experiment::run(args),
        #[cfg(feature = "sim")]
        Command::Sim(args) => sim::run(*args),
        Command::Camera(args) => fleetmap_camera::cli::run(*args),
        Command::Grid(args) => grid::run(args),
        Command::Kind(c) => c.run(),
        Command::Tui(args) => tui::run(args, log_file.as_deref()),
        Command::Vehicles(args) => vehicles::run(args),
        Command::Mission(args) => mission::run(args),
        Command::Command(args) => command::run(args),
        Command::Relay(args) => relay::run(args),
        Command::Signing(args) => signing::run(args),
        #[cfg(feature = "sim")]
        Command::Demo(args) => demo::run(args),
        Command::Run(args) => run::run(*args),
        Command::Resume(args) => run::resume(*args),
        Command::Report(args) => run::report_cmd(args),
        Command::Export(args) => run::export(args),
    }
}

#[cfg(test)]
mod tests {
    use super::error_line;

    #[derive(Debug, thiserror::Error)]
    #[error("state.json: {source}")]
    struct WithSourceInMessage {
        source: std::io::Error,
    }

    #[test]
    fn error_line_says_each_cause_once() {
        // A message that already ends with its source's text: the source is not repeated.
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = anyhow::Error::new(WithSourceInMessage { source: io }).context("cannot resume");
        assert_eq!(error_line(&e), "cannot resume: state.json: no such file");
        // Contexts that add words keep every part.
        let e = anyhow::anyhow!("timed out")
            .context("vehicle 1")
            .context("upload");
        assert_eq!(error_line(&e), "upload: vehicle 1: timed out");
        // A fleet error carries its protocol error in its message only, so `{:#}` (which
        // does not deduplicate) says it once too.
        let fe = crate::fleet::FleetError::Command {
            sysid: 1,
            error: fleetmap_core::proto::command::CommandError::Timeout {
                command: mavlink::dialects::ardupilotmega::MavCmd::MAV_CMD_DO_SET_MODE,
                attempts: 5,
                timeout_ms: 1500,
            },
        };
        assert!(std::error::Error::source(&fe).is_none());
        let e = anyhow::Error::new(fe).context("cannot take off");
        let line = error_line(&e);
        assert_eq!(line, format!("{e:#}"));
        assert!(line.starts_with("cannot take off: vehicle 1: "), "{line}");
        assert_eq!(line.matches("MAV_CMD_DO_SET_MODE").count(), 1, "{line}");
    }
}
