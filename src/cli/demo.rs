//! `fleetmap demo [--headless] [--run-dir DIR]`: the embedded default — the simulator
//! in-process (three ArduPilot copters over the runway world) and the runway field-test
//! mission flown to the end, battery swaps included, sped up to finish within minutes.

use crate::app::demo::{self, DemoConfig};
use crate::app::flight::Patience;
use crate::app::report::{self, truth_coverage};
use crate::app::runway::{self, Outcome, RunOptions};
use crate::cli::run::{drive_mapping, write_exports};
use crate::cli::vehicles::block_on;
use crate::explore::Sharing;
use crate::sim::world::World;
use crate::store::{RunDir, RunMeta};
use anyhow::{Context as _, bail};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of `fleetmap demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// No terminal UI: progress lines and the final report on stdout.
    #[arg(long)]
    pub headless: bool,
    /// Keep the run here (default: a new directory under runs/).
    #[arg(long, value_name = "DIR")]
    pub run_dir: Option<PathBuf>,
    /// Number of drones.
    #[arg(long, value_name = "N", default_value_t = 3)]
    pub drones: usize,
    /// Simulated seconds per wall second.
    #[arg(long, value_name = "X", default_value_t = 10.0)]
    pub speedup: f64,
    /// Seed of the simulator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Battery endurance, minutes of hover.
    #[arg(long, value_name = "MIN", default_value_t = 12.0)]
    pub battery_minutes: f64,
    /// Altitude separation between the drones, metres.
    #[arg(long, value_name = "M", default_value_t = 0.0)]
    pub separation: f64,
    /// Print the final report as JSON.
    #[arg(long)]
    pub json: bool,
}

fn unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as u64)
        .unwrap_or(0)
}

/// Run `fleetmap demo`.
pub fn run(args: DemoArgs) -> anyhow::Result<ExitCode> {
    if !(1..=8).contains(&args.drones) {
        bail!("--drones must be between 1 and 8");
    }
    if !(args.speedup.is_finite() && args.speedup > 0.0 && args.speedup <= 50.0) {
        bail!("--speedup must be in (0, 50]");
    }
    if !(args.battery_minutes.is_finite() && args.battery_minutes >= 3.0) {
        bail!("--battery-minutes must be at least 3");
    }
    let cfg = DemoConfig {
        drones: args.drones,
        speedup: args.speedup,
        seed: args.seed,
        battery_minutes: args.battery_minutes,
        altitude_separation_m: args.separation,
        ..DemoConfig::default()
    };
    let (text, def) = demo::runway_mission(&cfg)?;
    let world = World::from_toml(demo::RUNWAY_WORLD).context("the built-in runway world")?;
    let dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(format!("demo-{}", unix_ms() / 1000)));
    block_on(async move {
        let spec = format!("{}xcopter:ardupilot", cfg.drones);
        let d = demo::start(&spec, world.clone(), &cfg).await?;
        println!(
            "demo: simulator with {} ArduPilot copter(s) over the runway world (92 m x 21 m), {}x real time",
            cfg.drones, cfg.speedup
        );
        let state =
            crate::app::new_mapping(&d.fleet, &def, Sharing::Gcs, Duration::from_secs(60)).await?;
        let mut meta = RunMeta::new(runway::KIND, unix_ms());
        meta.mission_path = Some("built-in runway-field-test.toml".into());
        meta.connections = d
            .sim
            .bound
            .iter()
            .map(|b| format!("udpout:{}", b.local))
            .collect();
        // The world goes with the run (resolved relative to it) so `fleetmap report DIR`
        // scores it later.
        meta.extra = serde_json::json!({"world": "world.toml"});
        let run_dir = RunDir::create(&dir, meta, Some(&text))
            .with_context(|| format!("cannot create the run directory {}", dir.display()))?;
        crate::store::atomic_write(
            &run_dir.path().join("world.toml"),
            demo::RUNWAY_WORLD.as_bytes(),
        )?;
        println!("demo: run directory {}", dir.display());
        let opts = RunOptions {
            auto_resume: true,
            patience: Patience { factor: 1.0 },
            ..RunOptions::default()
        };
        let (outcome, path) = drive_mapping(&d.fleet, run_dir, state, opts, true).await?;
        d.fleet.shutdown().await;
        let _ = d.sim.stop().await;
        let run_dir = RunDir::open(&path)?;
        let state: crate::explore::mapping::MappingState =
            run_dir.load_state()?.context("the demo saved no state")?;
        let exports = write_exports(&run_dir, &state, Some(&world))?;
        let cov = truth_coverage(&state.grid, &world, 0.0)?;
        let r = report::report(&state, Some(&cov));
        if args.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            print_summary(&r);
            for e in &exports {
                println!("  wrote {}", e.display());
            }
            println!(
                "  `fleetmap report {}` and `fleetmap export {} --format kml` work on this run",
                path.display(),
                path.display()
            );
        }
        Ok(match outcome {
            Outcome::Finished if r.finished => ExitCode::SUCCESS,
            _ => ExitCode::FAILURE,
        })
    })?
}

fn print_summary(r: &report::MappingReport) {
    println!("demo finished: {}", r.phase);
    println!(
        "  map: {} runway cells; tree {} vertices ({} explored); {} images at cell centres, {} decisions",
        r.cells_mapped, r.tree_vertices, r.explored_vertices, r.images, r.detections
    );
    println!(
        "  flight: {:.0} s airborne in all, {:.0} m, {} battery swap(s)",
        r.flight_time_s, r.distance_m, r.battery_swaps
    );
    if let Some(t) = &r.truth {
        println!(
            "  IoU with the ground truth {:.1} % (best possible on this grid {:.1} %; the paper's field test {:.1} %); \
             {} false positive and {} false negative decision(s)",
            100.0 * t.iou,
            100.0 * t.iou_best_possible,
            100.0 * t.paper_iou,
            t.false_positives,
            t.false_negatives
        );
    }
}
