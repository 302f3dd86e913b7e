//! `fleetmap-camera`: the MAVLink camera for a drone's companion computer (a Raspberry Pi
//! wired to the autopilot's TELEM2). See [`fleetmap_camera::cli`] and docs/companion.md.

use clap::Parser;
use std::process::ExitCode;

/// A MAVLink camera component for a companion computer next to a PX4 or ArduPilot autopilot:
/// takes a picture whenever the autopilot fires its shutter or a GCS asks, stamps it with the
/// autopilot's pose, and sends it (or its on-board measurement) to the ground station.
#[derive(Debug, Parser)]
#[command(name = "fleetmap-camera", version)]
struct Cli {
    /// Log more (-v: debug, -vv: trace); RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(flatten)]
    camera: fleetmap_camera::cli::CameraArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "info",
        1 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    match fleetmap_camera::cli::run(cli.camera) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("fleetmap-camera: {e:#}");
            ExitCode::FAILURE
        }
    }
}
