//! `fleetmap bench transfer`: round-trip times (upload then download) of an N-item mission
//! between the GCS's mission client and the embedded simulator's ArduPilot and PX4 mission
//! protocol, over a network that loses and duplicates messages each way, in virtual time
//! ([`fleetmap_sim::transfer_bench`]). Virtual seconds are what an operator waits on a radio
//! with those faults; computing them takes a fraction of that.

use anyhow::bail;
use clap::Args;
use fleetmap_core::proto::flavour::Autopilot;
use fleetmap_sim::flavour::SimAutopilot;
use fleetmap_sim::transfer_bench::{NetFaults, TrialSummary, run_trials};
use serde::Serialize;
use std::process::ExitCode;

/// Arguments of `fleetmap bench transfer`.
#[derive(Debug, Args)]
pub struct BenchTransferArgs {
    /// Items in the mission (takeoff, waypoints, captures, speed changes, a DO_JUMP last).
    #[arg(long, default_value_t = 100)]
    pub items: usize,
    /// Loss levels to measure, percent of the messages lost in each direction,
    /// comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "0,10,30,50")]
    pub loss: Vec<f64>,
    /// Percent of the messages that are not lost delivered twice, in each direction.
    #[arg(long, default_value_t = 5.0)]
    pub dup: f64,
    /// Round trips per autopilot and loss level.
    #[arg(long, default_value_t = 20)]
    pub trials: u32,
    /// One-way latency of every message, milliseconds.
    #[arg(long, default_value_t = 20)]
    pub latency_ms: u64,
    /// Extra one-way delay of each message, uniform from 0 to this many milliseconds (makes
    /// messages overtake each other).
    #[arg(long, default_value_t = 0)]
    pub jitter_ms: u64,
    /// Seed of the first round trip's network (round trip k uses SEED + k).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// One line of the result: an autopilot at one loss level.
#[derive(Debug, Serialize)]
struct Row {
    autopilot: &'static str,
    loss_pct: f64,
    #[serde(flatten)]
    summary: TrialSummary,
}

fn name(a: SimAutopilot) -> &'static str {
    Autopilot::from(a).name()
}

fn secs(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |s| format!("{s:.1}"))
}

/// Run `fleetmap bench transfer` and print the figures.
pub(crate) fn run(args: BenchTransferArgs) -> anyhow::Result<ExitCode> {
    if args.items == 0 || args.items > usize::from(u16::MAX) - 1 {
        bail!("--items must be between 1 and 65534");
    }
    if args.trials == 0 {
        bail!("--trials must be at least 1");
    }
    if args.loss.is_empty() {
        bail!("--loss needs at least one level");
    }
    for l in &args.loss {
        if !(0.0..=100.0).contains(l) {
            bail!("--loss: {l} is not a percentage between 0 and 100");
        }
    }
    if !(0.0..=100.0).contains(&args.dup) {
        bail!("--dup: {} is not a percentage between 0 and 100", args.dup);
    }
    if !args.json {
        println!(
            "mission round trips (upload + download, {} items) against the embedded simulator's \
             mission protocol, {} trials each",
            args.items, args.trials
        );
        println!(
            "link each way: loss as listed, {} % duplicates, {} ms latency + 0–{} ms jitter; \
             GCS timeouts: default MissionConfig",
            args.dup, args.latency_ms, args.jitter_ms
        );
        println!(
            "times are VIRTUAL seconds: what an operator waits on a radio with these losses \
             (median / p90 / max over the successful round trips; up/down: medians of each half)"
        );
        println!(
            "{:<10} {:>6} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "autopilot",
            "loss%",
            "ok",
            "median_s",
            "p90_s",
            "max_s",
            "restarts",
            "up_med_s",
            "down_med_s"
        );
    }
    let mut rows = Vec::new();
    for autopilot in [SimAutopilot::ArduPilot, SimAutopilot::Px4] {
        for &loss in &args.loss {
            let faults = NetFaults {
                loss: loss / 100.0,
                dup: args.dup / 100.0,
                latency_ms: args.latency_ms,
                jitter_ms: args.jitter_ms,
            };
            let summary = run_trials(autopilot, faults, args.items, args.trials, args.seed)?;
            if !args.json {
                println!(
                    "{:<10} {:>6} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
                    name(autopilot),
                    loss,
                    format!("{}/{}", summary.successes, summary.trials),
                    secs(summary.median_s),
                    secs(summary.p90_s),
                    secs(summary.max_s),
                    summary.restarts,
                    secs(summary.upload_median_s),
                    secs(summary.download_median_s)
                );
                for f in &summary.failures {
                    println!("    failed: {f}");
                }
            }
            rows.push(Row {
                autopilot: name(autopilot),
                loss_pct: loss,
                summary,
            });
        }
    }
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "bench": "mission_transfer",
                "time": "virtual",
                "items": args.items,
                "trials": args.trials,
                "dup_pct": args.dup,
                "latency_ms": args.latency_ms,
                "jitter_ms": args.jitter_ms,
                "seed": args.seed,
                "results": rows,
            })
        );
    }
    Ok(ExitCode::SUCCESS)
}
