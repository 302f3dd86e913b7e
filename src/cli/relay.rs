//! `fleetmap relay --gcs CONN --vehicle CONN [--rate B/S] [--loss P] [--dup P] …`: relay
//! MAVLink between a GCS and a vehicle at a radio's byte rate, losing, duplicating, delaying
//! or corrupting frames on the way ([`fleetmap_io::link::relay`]); e.g. between `fleetmap` and a
//! real SITL to judge mission transfers over a poor radio. Also home of the fault options
//! that `fleetmap sim` shares.

use clap::Args;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::faults::{LinkFaults, parse_blackouts};
use fleetmap_io::link::relay::{self, RateLimiter, RelayOptions, RelayStats};
use std::process::ExitCode;
use std::time::Duration;

/// Link faults, each way (`fleetmap sim`, `fleetmap relay`).
#[derive(Debug, Clone, Args)]
pub struct FaultArgs {
    /// Probability of losing a frame, each way.
    #[arg(long, default_value_t = 0.0)]
    pub loss: f64,
    /// Probability of duplicating a frame.
    #[arg(long, default_value_t = 0.0)]
    pub dup: f64,
    /// Probability of delaying a frame behind later ones.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) reorder: f64,
    /// One-way latency, milliseconds.
    #[arg(long, default_value_t = 0.0)]
    pub latency_ms: f64,
    /// Uniform latency jitter, milliseconds.
    #[arg(long, default_value_t = 0.0)]
    pub jitter_ms: f64,
    /// Probability of corrupting a frame (one byte flipped: bad CRC).
    #[arg(long, default_value_t = 0.0)]
    pub corrupt: f64,
    /// Link blackouts as START+DURATION seconds (of simulated time for `sim`, since the
    /// start for `relay`), comma separated.
    #[arg(long, value_name = "S+D,…")]
    pub(crate) blackout: Option<String>,
}

impl FaultArgs {
    /// The faults, checked.
    pub fn faults(&self) -> anyhow::Result<LinkFaults> {
        let faults = LinkFaults {
            loss: self.loss,
            duplicate: self.dup,
            reorder: self.reorder,
            latency_ms: self.latency_ms,
            jitter_ms: self.jitter_ms,
            corrupt: self.corrupt,
            blackouts: match &self.blackout {
                Some(b) => parse_blackouts(b)?,
                None => Vec::new(),
            },
        };
        faults.validate()?;
        Ok(faults)
    }
}

/// Arguments of `fleetmap relay`.
#[derive(Debug, Args)]
pub struct RelayArgs {
    /// The GCS's side, e.g. `udpin:127.0.0.1:14600` (point the GCS at it with
    /// `--connect udpout:127.0.0.1:14600`).
    #[arg(long, value_name = "CONN")]
    pub gcs: ConnSpec,
    /// The vehicle's side, e.g. `tcp:127.0.0.1:5762` (a SITL's SERIAL1).
    #[arg(long, value_name = "CONN")]
    pub vehicle: ConnSpec,
    /// Byte rate each way, bytes per second (0: unlimited), as a telemetry radio carries:
    /// about 5000 for a 57,600-baud SiK radio. Frames wait in a queue of 1850 bytes (a SiK
    /// radio's serial buffer) and one that would overflow it is dropped.
    #[arg(long, value_name = "BYTES_PER_S", default_value_t = 0)]
    pub rate: u32,
    /// Faults, each way (on the air: after the rate limit).
    #[command(flatten)]
    pub faults: FaultArgs,
    /// Seed of the faults (same seed and traffic, same losses).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the counts every this many seconds (0: only at the end).
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub(crate) report_every: f64,
    /// Stop after this many seconds (default: until interrupted).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Print the counts as JSON lines.
    #[arg(long)]
    pub json: bool,
}

/// Print the counts: JSON (every field of [`RelayStats`]) or a line per direction, with the
/// rate limit's drops and queue peak when `opts.rate` is set.
fn print(stats: &RelayStats, json: bool, opts: &RelayOptions) {
    if json {
        if let Ok(s) = serde_json::to_string(stats) {
            println!("{s}");
        }
        return;
    }
    for (name, d) in [("gcs→vehicle", &stats.up), ("vehicle→gcs", &stats.down)] {
        let limit = if opts.rate > 0 {
            format!(
                "; rate {} B/s: {} dropped on a full queue, queue peak {} of {} bytes",
                opts.rate,
                d.rate_dropped,
                d.peak_queue_bytes,
                opts.queue_bytes.max(RateLimiter::MAX_FRAME_BYTES)
            )
        } else {
            String::new()
        };
        println!(
            "{name}: {} frames in ({} bytes), {} out ({} bytes), {} dropped, {} duplicated, \
             {} corrupted{limit}",
            d.frames_in,
            d.bytes_in,
            d.frames_out,
            d.bytes_out,
            d.dropped,
            d.duplicated,
            d.corrupted
        );
    }
}

/// Run `fleetmap relay`.
pub fn run(args: RelayArgs) -> anyhow::Result<ExitCode> {
    let faults = args.faults.faults()?;
    if !(args.report_every.is_finite() && args.report_every >= 0.0) {
        anyhow::bail!("--report-every must be ≥ 0");
    }
    if let Some(d) = args.duration
        && !(d.is_finite() && d >= 0.0)
    {
        anyhow::bail!("--duration must be ≥ 0");
    }
    let every = if args.report_every > 0.0 {
        Duration::from_secs_f64(args.report_every)
    } else {
        Duration::from_secs(365 * 86_400)
    };
    let json = args.json;
    let duration = args.duration;
    let opts = RelayOptions {
        faults,
        seed: args.seed,
        rate: args.rate,
        ..RelayOptions::default()
    };
    let shown = opts.clone();
    let stats = crate::cli::vehicles::block_on(async {
        let stop = async {
            match duration {
                Some(d) => {
                    tokio::select! {
                        _ = tokio::time::sleep(Duration::from_secs_f64(d)) => {}
                        _ = tokio::signal::ctrl_c() => {}
                    }
                }
                None => {
                    let _ = tokio::signal::ctrl_c().await;
                }
            }
        };
        relay::run(
            args.gcs,
            args.vehicle,
            opts,
            every,
            |s| print(s, json, &shown),
            stop,
        )
        .await
    })??;
    print(&stats, json, &shown);
    Ok(ExitCode::SUCCESS)
}
