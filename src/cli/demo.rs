//! `fleetmap demo [--headless] [--run-dir DIR]`: the embedded default — the simulator
//! in-process (three ArduPilot copters over the runway world) and the runway field-test
//! mission flown to the end (battery swaps included when `--battery-minutes` is short enough),
//! sped up to finish within minutes.

use crate::app::demo::{self, DemoConfig};
use crate::app::kind::{Outcome, RunKind, RunSettings};
use crate::app::launch::{NewRun, Start, finish_exports, prepare};
use crate::app::preflight::OnBlocker;
use crate::app::runway::Runway;
use crate::app::runway::report::MappingReport;
use crate::cli::vehicles::block_on;
use anyhow::{Context as _, bail};
use clap::Args;
use fleetmap_core::world::World;
use fleetmap_io::clock::unix_ms;
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
    /// The operator drives: the mission waits for START (`s`), and after a battery swap a
    /// vehicle waits for "battery swapped — resume" (`b`). Default: both by themselves.
    #[arg(long)]
    pub manual: bool,
    /// Start even when the fleet check before take-off finds a blocker (docs/fleet-check.md).
    #[arg(long)]
    pub ignore_check: bool,
    /// Fly over this world instead of the built-in runway (its default homes must put the
    /// region inside the mission's sweep box).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
    /// The spatial-classification demo instead: the bandit paper's 6×6 hardware mission
    /// with 4 ArduPilot copters and 2 ArduPilot rovers as charging stations.
    #[arg(long)]
    pub bandit: bool,
    /// With --bandit: side of the simulated camera images, pixels. The measurement is the
    /// green share of the part of the image over the cell, so a smaller image with the same
    /// field of view measures the same; 480 (the runway camera's) renders, sends and
    /// measures 9 times the pixels and made the demo 6 times slower on 2 cores.
    #[arg(long, value_name = "PX", default_value_t = 160)]
    pub camera_px: u32,
    /// With --bandit: the confidence bound (`classification.bound`; default the mission's,
    /// the KL bound). `paper` flies the paper's (3b), which needs about four times the
    /// samples (and epochs) before every cell is labelled.
    #[arg(long, value_enum)]
    pub bound: Option<crate::cli::bandit::BoundArg>,
    /// With --bandit: the simulated cameras' sensor (the bandit paper's degraded sensor, §V).
    #[command(flatten)]
    pub sensor: fleetmap_camera::cli::SensorArgs,
    /// Every vehicle behind its own simulated telemetry radio. On a radio the runway
    /// cameras classify their pictures on board, as the spatial-classification cameras
    /// always do.
    #[command(flatten)]
    pub radio: RadioArgs,
    /// A scheduled fault in the simulator, `TARGET:FAULT[@START[..END]]` (repeatable): e.g.
    /// `2:battery=20@300s`, `1:camera=off@200s..400s`, `all:outage@120s..420s`, `5:stuck@100s`
    /// (as `fleetmap sim --fault`; docs/simulator.md, "Scheduled faults").
    #[arg(long = "fault", value_name = "SPEC")]
    pub faults: Vec<String>,
}

/// The schedule `--fault` gives (each occurrence one or more comma-separated entries).
pub(crate) fn fault_schedule(
    specs: &[String],
) -> anyhow::Result<Vec<fleetmap_sim::fault::ScheduledFault>> {
    let mut all = Vec::new();
    for s in specs {
        all.extend(fleetmap_sim::fault::parse_faults(s).context("--fault")?);
    }
    Ok(all)
}

/// `--radio` and `--radio-loss`: every simulated vehicle behind its own radio (`fleetmap demo`,
/// `fleetmap sim`).
#[derive(Debug, Args)]
pub struct RadioArgs {
    /// Every vehicle behind its own simulated telemetry radio carrying this many bytes a
    /// second of simulated time, both directions together (a SiK pair: half duplex, 4 kB
    /// buffers, RADIO_STATUS); a GCS should plan for it as fleetmap does with
    /// `--link radio:BYTES`.
    #[arg(long = "radio", value_name = "BYTES_PER_S")]
    pub radio_bytes_per_s: Option<u32>,
    /// With --radio: the share of frames each radio loses on the air, 0–1.
    #[arg(
        long = "radio-loss",
        value_name = "P",
        default_value_t = 0.0,
        requires = "radio_bytes_per_s"
    )]
    pub radio_loss: f64,
}

impl RadioArgs {
    /// The radio these arguments describe, if any.
    pub(crate) fn config(&self) -> anyhow::Result<Option<fleetmap_io::link::radio::RadioConfig>> {
        let Some(b) = self.radio_bytes_per_s else {
            return Ok(None);
        };
        let min = fleetmap_core::budget::LinkBudget::MIN_RADIO;
        let max = fleetmap_core::budget::LinkBudget::MAX_RADIO;
        if !(min..=max).contains(&b) {
            bail!("--radio must be between {min} and {max} bytes a second");
        }
        let cfg = fleetmap_io::link::radio::RadioConfig {
            loss: self.radio_loss,
            ..fleetmap_io::link::radio::RadioConfig::radio(b)
        };
        cfg.validate()
            .map_err(|e| anyhow::anyhow!("--radio-loss: {e}"))?;
        Ok(Some(cfg))
    }
}

/// Run `fleetmap demo`.
pub fn run(args: DemoArgs) -> anyhow::Result<ExitCode> {
    if args.bandit {
        return run_bandit(&args);
    }
    if args.sensor.flip != 0.0 {
        bail!("--sensor-flip is for the spatial-classification demo (--bandit)");
    }
    if !(1..=8).contains(&args.drones) {
        bail!("--drones must be between 1 and 8");
    }
    if !(args.speedup.is_finite() && args.speedup > 0.0 && args.speedup <= 50.0) {
        bail!("--speedup must be in (0, 50]");
    }
    if !(args.battery_minutes.is_finite() && args.battery_minutes >= 3.0) {
        bail!("--battery-minutes must be at least 3");
    }
    let mut cfg = DemoConfig {
        drones: args.drones,
        speedup: args.speedup,
        seed: args.seed,
        battery_minutes: args.battery_minutes,
        altitude_separation_m: args.separation,
        radio: args.radio.config()?,
        faults: fault_schedule(&args.faults)?,
        ..DemoConfig::default()
    };
    let (world_text, world) = match &args.world {
        Some(p) => fleetmap_io::files::read_world(p)?,
        None => {
            let text = demo::RUNWAY_WORLD.to_string();
            let world = World::from_toml(&text).context("the demo world")?;
            (text, world)
        }
    };
    let (text, def, mission_file) = demo::mission_for(&world, &cfg)?;
    if cfg.radio.is_some() {
        // pictures do not fit a radio: the cameras classify them on board
        cfg.onboard = crate::app::runway::runway_definition_of(&def);
    }
    let tui = !args.headless
        && std::io::IsTerminal::is_terminal(&std::io::stdin())
        && std::io::IsTerminal::is_terminal(&std::io::stdout());
    let dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(format!("demo-{}", unix_ms() / 1000)));
    block_on(async move {
        let spec = format!("{}xcopter:ardupilot", cfg.drones);
        let d = demo::start(&spec, world.clone(), &cfg).await?;
        if !tui {
            println!(
                "demo: simulator with {} ArduPilot copter(s) over the {} world, {}x real time",
                cfg.drones, world.name, cfg.speedup
            );
        }
        let demo = Demo {
            new: NewRun {
                def,
                text,
                mission_path: format!("built-in {mission_file}"),
                run_dir: Some(dir),
                world_toml: Some(world_text),
                extra: serde_json::Value::Null,
            },
            tui,
            auto_start: !args.manual,
            json: args.json,
            label: format!(
                "DEMO: {} simulated ArduPilot copter(s), {}x real time",
                cfg.drones, cfg.speedup
            ),
        };
        // A moving region is where the world file draws it at the simulator's start.
        let settings = RunSettings {
            auto_resume: !args.manual,
            roi_epoch_unix_ms: Some(d.started_unix_ms),
            on_blocker: OnBlocker::unless_ignored(args.ignore_check, OnBlocker::Stop),
            ..RunSettings::default()
        };
        let succeeded = |outcome: &Outcome, r: &MappingReport| {
            matches!(outcome, Outcome::Finished) && r.finished
        };
        demo.fly::<Runway>(d.fleet, d.sim, &settings, summary, succeeded)
            .await
    })?
}

/// What the demos share once their simulator is up and their state is made: the run
/// directory (with the world beside the state, so `fleetmap report DIR` scores it later),
/// then the run in the terminal UI or headless with the report.
struct Demo {
    /// The run to start (with the world, so `fleetmap report DIR` scores it later).
    new: NewRun,
    tui: bool,
    auto_start: bool,
    json: bool,
    label: String,
}

impl Demo {
    /// Start the run on the simulated fleet ([`crate::app::launch`], as `fleetmap run` does)
    /// and fly it to its end. Headless, the report's `summary` lines (or its JSON) are
    /// printed, and `succeeded` says whether the exit status is 0.
    async fn fly<K: RunKind>(
        self,
        fleet: crate::fleet::FleetHandle,
        sim: fleetmap_sim::server::SimHandle,
        settings: &RunSettings,
        summary: impl FnOnce(&K::Report) -> Vec<String>,
        succeeded: impl FnOnce(&Outcome, &K::Report) -> bool,
    ) -> anyhow::Result<ExitCode> {
        let connections: Vec<String> = sim
            .bound
            .iter()
            .map(|b| format!("udpout:{}", b.local))
            .collect();
        let wait = Duration::from_secs(60);
        let ready = prepare::<K>(
            &fleet,
            &connections,
            Start::New(Box::new(self.new)),
            settings,
            wait,
        )
        .await;
        let ready = match ready {
            Ok(r) => r,
            Err(e) => {
                fleet.shutdown().await;
                let _ = sim.stop().await;
                return Err(e.into());
            }
        };
        let path = ready.run_dir.path().to_path_buf();
        if self.tui {
            let config = crate::cli::run::flow::ui_session(crate::tui::Source::new(
                crate::tui::SourceKind::Demo,
                self.label,
            ));
            let end = crate::tui::session::fly(ready, &fleet, config, self.auto_start).await;
            fleet.shutdown().await;
            let _ = sim.stop().await;
            let finished = end?;
            println!(
                "demo {}: run directory {} (`fleetmap report {}`)",
                if finished {
                    "finished"
                } else {
                    "stopped before the end"
                },
                path.display(),
                path.display()
            );
            return Ok(ExitCode::SUCCESS);
        }
        println!("demo: run directory {}", path.display());
        let (tx, printer) = crate::cli::run::flow::print_progress();
        let result = ready.fly_headless(&fleet, Some(tx)).await;
        let _ = tokio::time::timeout(Duration::from_secs(1), printer).await;
        fleet.shutdown().await;
        let _ = sim.stop().await;
        let (outcome, state) = result?;
        let (exports, r) = finish_exports::<K>(&path, &state).await?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            for l in summary(&r) {
                println!("{l}");
            }
            for e in &exports {
                println!("  wrote {}", e.display());
            }
            println!(
                "  `fleetmap report {}` and `fleetmap export {} --format {}` work on this run",
                path.display(),
                path.display(),
                match K::EXPORTS[0] {
                    crate::app::kind::ExportFormat::Png => "png",
                    _ => "kml",
                }
            );
        }
        Ok(if succeeded(&outcome, &r) {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        })
    }
}

/// The runway demo's report, as lines.
fn summary(r: &MappingReport) -> Vec<String> {
    let mut lines = vec![
        format!("demo finished: {}", r.phase),
        format!(
            "  map: {} runway cells; tree {} vertices ({} explored); {} images at cell centres, {} decisions",
            r.cells_mapped, r.tree_vertices, r.explored_vertices, r.images, r.detections
        ),
        format!(
            "  flight: {:.0} s airborne in all, {:.0} m, {} battery swap(s)",
            r.flight_time_s, r.distance_m, r.battery_swaps
        ),
        crate::app::runway::kind::mission_time_line(&r.mission_time),
    ];
    if let Some([n, e]) = r.roi_velocity_ne_mps {
        lines.push(format!(
            "  the region moved at {:.2} m/s (north {n:.2}, east {e:.2}): mapped in its own frame, \
             scored against where it was at the simulator's start",
            n.hypot(e)
        ));
    }
    if let Some(t) = &r.truth {
        lines.push(format!(
            "  IoU with the ground truth {:.1} % (best possible on this grid {:.1} %; the paper's field test {:.1} %); \
             {} false positive and {} false negative decision(s)",
            100.0 * t.iou,
            100.0 * t.iou_best_possible,
            100.0 * t.paper_iou,
            t.false_positives,
            t.false_negatives
        ));
    }
    lines
}

/// `fleetmap demo --bandit [--headless]`: the simulator in-process (4 ArduPilot copters and 2
/// ArduPilot rovers over the hardware field `assets/worlds/hardware-6x6.toml`) and the
/// hardware mission `missions/hardware-6x6.toml` flown to the end — in the terminal UI when
/// there is a terminal, otherwise (or with `--headless`) progress lines, then the report with
/// the keep set (scored against the world's green tiles). Headless, the exit status is 0
/// when every cell is classified and the keep set is the green tiles.
pub(crate) fn run_bandit(args: &DemoArgs) -> anyhow::Result<ExitCode> {
    use crate::app::bandit::{self, Classification, report::ClassificationReport};
    use crate::app::bandit_sim::{self, SimSetup};
    if !(args.speedup.is_finite() && args.speedup > 0.0 && args.speedup <= 50.0) {
        bail!("--speedup must be in (0, 50]");
    }
    if !(args.battery_minutes.is_finite() && args.battery_minutes >= 3.0) {
        bail!("--battery-minutes must be at least 3");
    }
    if !(16..=1920).contains(&args.camera_px) {
        bail!("--camera-px must be between 16 and 1920");
    }
    let sensor_flip = args.sensor.probability()?;
    // How the run's settings name the sensor: in the progress lines, the UI title and
    // run.json.
    let sensor = if sensor_flip > 0.0 {
        format!(", degraded sensor (flip {sensor_flip})")
    } else {
        String::new()
    };
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).context("the built-in 6x6 world")?;
    let text = match args.bound {
        None => bandit_sim::HARDWARE_MISSION.to_string(),
        Some(b) => bandit_sim::HARDWARE_MISSION.replacen(
            "[classification]",
            &format!("[classification]\nbound = \"{}\"", b.bound().name()),
            1,
        ),
    };
    let def = fleetmap_core::mission::definition::MissionDef::parse(
        &text,
        "hardware-6x6.toml (built in)",
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(format!("demo-bandit-{}", unix_ms() / 1000)));
    let setup = SimSetup {
        speedup: args.speedup,
        seed: args.seed,
        camera_px: args.camera_px,
        battery_minutes: args.battery_minutes,
        sensor_flip,
        // a field camera measures on board: the green share, not the picture, on the link
        onboard: bandit::green_spec_of(&def),
        radio: args.radio.config()?,
        faults: fault_schedule(&args.faults)?,
        ..SimSetup::default()
    };
    let json = args.json;
    let tui = !args.headless && crate::cli::tui::interactive();
    block_on(async move {
        let d = bandit_sim::start_team(bandit_sim::HARDWARE_TEAM, &world, &setup).await?;
        if !tui {
            println!(
                "demo: simulator with 4 ArduPilot copters and 2 ArduPilot rovers (charging \
                 stations) over the bandit paper's 6x6 field, {}x real time{sensor}",
                setup.speedup
            );
        }
        let demo = Demo {
            new: NewRun {
                def,
                text,
                mission_path: "built-in hardware-6x6.toml".into(),
                run_dir: Some(dir),
                world_toml: Some(bandit_sim::HARDWARE_WORLD.to_string()),
                extra: serde_json::json!({ "sensor_flip": sensor_flip }),
            },
            tui,
            auto_start: true,
            json,
            label: format!(
                "DEMO: 4 simulated ArduPilot copters, 2 rovers, {}x real time{sensor}",
                setup.speedup
            ),
        };
        let summary = |r: &ClassificationReport| {
            let mut lines = vec!["demo finished".to_string()];
            lines.extend(Classification::report_lines(r));
            lines
        };
        let succeeded = |_: &Outcome, r: &ClassificationReport| {
            r.finished && r.interesting_truth.as_ref() == Some(&r.keep)
        };
        let settings = RunSettings {
            on_blocker: OnBlocker::unless_ignored(args.ignore_check, OnBlocker::Stop),
            ..RunSettings::default()
        };
        demo.fly::<Classification>(d.fleet, d.sim, &settings, summary, succeeded)
            .await
    })?
}
