//! `fleetmap experiment runway`: how much sooner a team maps the runway than one drone.
//!
//! Every trial flies the runway field-test mission (`missions/runway-field-test.toml`, the
//! world `assets/worlds/runway.toml`) with a team of simulated ArduPilot copters, the GCS in
//! the same process: 12-minute batteries swapped by the simulated crew 30 s after a landing,
//! the runner resuming by itself. Every figure is in simulated seconds — the report's mission
//! time ([`crate::kinds::runway::report::MissionTime`]).
//!
//! **The clock** (`--speedup`). By default (`virtual`) a trial runs in virtual time, as the
//! end-to-end tests do: the simulator behind in-process links
//! ([`crate::kinds::runway::demo::start_virtual`]) on a current-thread runtime whose clock is paused,
//! so time moves only when every task waits, and the GCS's own work (decoding and
//! classifying ~600 pictures) takes no simulated time — as at 1× in the field, where it is a
//! few milliseconds a picture against seconds of flight. The figures then describe the
//! algorithm and the vehicles, not this machine's load. With a number (or `max`) the trial
//! runs as `fleetmap demo` does, on loopback UDP in lock-step at up to that many times real
//! time: the GCS's work then costs simulated time (×N), and a team whose pictures arrive
//! faster than the GCS classifies them hovers while it catches up. Measured (2026-12-04, six
//! drones at 10×): the same seed mapped in 393–412 s on a quiet machine and 651–745 s beside
//! a build, where the drones' time over their cells rose from 0.3 s to 0.9 s a picture and
//! every drone needed a swap.
//!
//! Trial `k` of every team size uses the simulator seed `seed + k`, so the team sizes are
//! compared on the same GPS noise and the same wind (common random numbers).
//!
//! Outputs in `--out`: `runway_trials.csv` (one row per trial: mission times, IoU, swaps, the
//! team's shares), `runway_drones.csv` (one row per drone of every trial: where its time
//! went), `runway_summary.json`, and `runway_team.png` (time to the complete map and to the
//! last landing against the team size, beside one drone's time divided by the team size and
//! the goals).

pub mod cli;
pub mod output;
pub(crate) mod plot;

use crate::app::flight::Patience;
use crate::app::images;
use crate::app::kind::Outcome;
use crate::kinds::runway::demo;
use crate::kinds::runway::report::{MappingReport, truth_coverage};
use crate::kinds::runway::{self, RunOptions};
use crate::store::{RunDir, RunMeta};
use anyhow::Context as _;
use fleetmap_core::explore::dfs::{Allocation, Sharing};
use fleetmap_core::explore::mapping::{MappingState, WaitTimes};
use fleetmap_core::world::World;
use fleetmap_io::clock::unix_ms;
use fleetmap_sim::pace::Speed;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The goals: a team of this many drones completes the map in at most this share of one
/// drone's time (3 drones 0.36×, 6 drones 0.20×: near one drone's time divided by the team,
/// 0.33× and 0.17×).
pub(crate) const GOALS: [(usize, f64); 2] = [(3, 0.36), (6, 0.2)];

/// Parameters of `fleetmap experiment runway`.
#[derive(Clone, Debug, clap::Args)]
pub struct RunwayArgs {
    /// Team sizes, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2,3,6")]
    pub drones: Vec<usize>,
    /// Trials per team size.
    #[arg(long, default_value_t = 1)]
    pub trials: usize,
    /// Simulator seed of trial 0 (trial k uses seed + k, for every team size).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// `virtual` (the default): in-process links on a paused clock, the GCS's work taking no
    /// simulated time, figures independent of the machine's load. Or the most simulated
    /// seconds per wall second over loopback UDP, as the demo flies (lock-step, slower when the
    /// machine is busy), or `max`: the GCS's work then costs simulated time, more the busier
    /// the machine.
    #[arg(long, default_value = "virtual")]
    pub speedup: StudyClock,
    /// How the DFS allocates the drones at a vertex: `paper` (Algorithm 1's split),
    /// `nearest-frontier` or `spread`; default: the mission file's (`runway.allocation`,
    /// unset there: `spread`).
    #[arg(long, value_parser = parse_allocation)]
    pub allocation: Option<Allocation>,
    /// Battery endurance of the simulated copters and of the mission, minutes.
    #[arg(long, default_value_t = 12.0)]
    pub battery_minutes: f64,
    /// Seconds after a landing until the simulated crew has swapped the battery.
    #[arg(long, default_value_t = 30.0)]
    pub(crate) swap_after: f64,
    /// Give a trial up after this many minutes (it is reported as unfinished): of simulated
    /// time with the virtual clock, of wall time otherwise.
    #[arg(long, default_value_t = 120.0)]
    pub(crate) trial_timeout_min: f64,
    /// Keep every trial's run directory under OUT/runs (`fleetmap report` and `export` work
    /// on them); otherwise they are removed once the trial is read.
    #[arg(long)]
    pub(crate) keep_runs: bool,
    /// Print the study as JSON on stdout instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// Directory for the CSVs, the JSON summary and the PNG (created if missing).
    #[arg(long, value_name = "DIR", default_value = "experiment-runway")]
    pub out: PathBuf,
}

/// How a trial's time runs (`--speedup`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StudyClock {
    /// In-process links on a paused current-thread runtime: simulated time moves only while
    /// every task waits.
    Virtual,
    /// Loopback UDP, the simulator in lock-step at this speed (as `fleetmap demo`).
    Paced(Speed),
}

impl std::str::FromStr for StudyClock {
    type Err = <Speed as std::str::FromStr>::Err;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.trim().eq_ignore_ascii_case("virtual") {
            Ok(StudyClock::Virtual)
        } else {
            s.parse().map(StudyClock::Paced)
        }
    }
}

impl std::fmt::Display for StudyClock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StudyClock::Virtual => write!(f, "virtual time"),
            StudyClock::Paced(s) => write!(f, "lock-step at {s} over loopback UDP"),
        }
    }
}

/// One trial: a team flying the field test to its end.
#[derive(Clone, Debug, Serialize)]
pub struct TrialRow {
    /// Team size.
    pub drones: usize,
    /// Trial number (0-based) within the team size.
    pub trial: usize,
    /// Simulator seed.
    pub seed: u64,
    /// Every drone landed with the map complete.
    pub finished: bool,
    /// Why it did not finish, if it did not.
    pub error: Option<String>,
    /// First take-off to the DFS's start, simulated seconds.
    pub to_dfs_start_s: Option<f64>,
    /// First take-off to the complete map (every cell decided), simulated seconds.
    pub to_map_complete_s: Option<f64>,
    /// First take-off to the last landing, simulated seconds.
    pub to_last_landing_s: Option<f64>,
    /// IoU of the map with the runway.
    pub iou: Option<f64>,
    /// IoU of the best labelling of the grid.
    pub iou_best_possible: Option<f64>,
    /// Runway cells mapped.
    pub cells_mapped: usize,
    /// Cell-centre pictures counted as votes.
    pub images: usize,
    /// Battery swaps of the team.
    pub battery_swaps: u32,
    /// Airborne time of the team (the position tracker's), simulated seconds.
    pub(crate) airborne_s: f64,
    /// Share of the team's time flying and working.
    pub flying_share: f64,
    /// Share airborne and holding.
    pub waiting_share: f64,
    /// Share on the ground.
    pub ground_share: f64,
    /// Wall time of the trial, seconds.
    pub(crate) wall_s: f64,
}

/// One drone of one trial: where its mission time went, simulated seconds
/// ([`crate::kinds::runway::report::RobotTimeReport`]).
#[derive(Clone, Debug, Serialize)]
pub(crate) struct DroneRow {
    /// Team size.
    pub drones: usize,
    /// Trial number.
    pub trial: usize,
    /// The drone's system id.
    pub sysid: u8,
    /// First take-off to the last landing (its shares added up).
    pub elapsed_s: f64,
    /// Airborne, working.
    pub flying_s: f64,
    /// Of flying: taking a cell's pictures.
    pub imaging_s: f64,
    /// Of flying: home (for a swap, or at the end).
    pub homing_s: f64,
    /// Of flying: after the map was complete, before homing (the step in progress then).
    pub(crate) returning_s: f64,
    /// Airborne, holding.
    pub waiting_s: f64,
    /// Holding, by reason.
    pub waiting: WaitTimes,
    /// On the ground.
    pub ground_s: f64,
    /// Of ground: before its first take-off.
    pub ground_before_s: f64,
    /// Of ground: battery swaps (landed until airborne again).
    pub ground_swap_s: f64,
    /// Of ground: landed for good while others flew.
    pub ground_done_s: f64,
    /// Distance it flew, metres.
    pub distance_m: f64,
    /// Its battery swaps.
    pub battery_swaps: u32,
    /// Its cell-centre and sweep pictures.
    pub images: u64,
}

/// Mean, min and max over the finished trials.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
}

impl Stat {
    fn of(xs: impl IntoIterator<Item = f64>) -> Option<Stat> {
        let xs: Vec<f64> = xs.into_iter().filter(|x| x.is_finite()).collect();
        if xs.is_empty() {
            return None;
        }
        Some(Stat {
            mean: xs.iter().sum::<f64>() / xs.len() as f64,
            min: xs.iter().copied().fold(f64::INFINITY, f64::min),
            max: xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// Where a drone's time went, mean seconds per drone over a team size's finished trials.
#[derive(Clone, Debug, Default, Serialize)]
pub(crate) struct PerDrone {
    /// Flying and working.
    pub flying_s: f64,
    /// Of flying: pictures.
    pub imaging_s: f64,
    /// Of flying: home (for a swap, or at the end).
    pub homing_s: f64,
    /// Of flying: after the map was complete, before homing (the step in progress then).
    pub(crate) returning_s: f64,
    /// Holding, by reason.
    pub waiting: WaitTimes,
    /// On the ground before its first take-off.
    pub ground_before_s: f64,
    /// On the ground for swaps.
    pub ground_swap_s: f64,
    /// Landed for good while others flew.
    pub ground_done_s: f64,
    /// Distance flown, metres.
    pub distance_m: f64,
}

/// One team size over its trials.
#[derive(Clone, Debug, Serialize)]
pub struct TeamSummary {
    /// Team size.
    pub drones: usize,
    /// Trials run.
    pub trials: usize,
    /// Trials that finished.
    pub finished: usize,
    /// Time to the DFS's start.
    pub to_dfs_start_s: Option<Stat>,
    /// Time to the complete map.
    pub to_map_complete_s: Option<Stat>,
    /// Time to the last landing.
    pub to_last_landing_s: Option<Stat>,
    /// Mean time to the complete map over one drone's (when one drone was flown).
    pub(crate) map_ratio: Option<f64>,
    /// Mean time to the last landing over one drone's.
    pub(crate) landing_ratio: Option<f64>,
    /// The goal for this team size (a share of one drone's time), if it has one.
    pub(crate) goal: Option<f64>,
    /// IoU.
    pub iou: Option<Stat>,
    /// Best possible IoU.
    pub iou_best_possible: Option<Stat>,
    /// Battery swaps of the team.
    pub battery_swaps: Option<Stat>,
    /// Team shares, means.
    pub flying_share: f64,
    /// Holding.
    pub waiting_share: f64,
    /// On the ground.
    pub ground_share: f64,
    /// Where a drone's time went (means over drones and trials).
    pub(crate) per_drone: PerDrone,
}

/// The whole study.
#[derive(Clone, Debug, Serialize)]
pub struct Study {
    /// The simulator's speed (`10×`: at most ten times real time; `max`).
    pub speedup: String,
    /// Battery endurance, minutes.
    pub battery_minutes: f64,
    /// Swap turnaround, seconds.
    pub swap_after_s: f64,
    /// Per trial.
    pub trials: Vec<TrialRow>,
    /// Per drone of every trial.
    pub(crate) drone_rows: Vec<DroneRow>,
    /// Per team size.
    pub summaries: Vec<TeamSummary>,
}

/// `--allocation`: the mission key's values, with `-` for `_`.
fn parse_allocation(s: &str) -> Result<Allocation, String> {
    let want = s.trim().replace('-', "_");
    Allocation::ALL
        .into_iter()
        .find(|a| a.name() == want)
        .ok_or_else(|| {
            let names: Vec<String> = Allocation::ALL
                .iter()
                .map(|a| a.name().replace('_', "-"))
                .collect();
            format!("unknown allocation {s:?}: one of {}", names.join(", "))
        })
}

/// Check the parameters.
pub fn validate(args: &RunwayArgs) -> anyhow::Result<()> {
    if args.drones.is_empty() || args.drones.iter().any(|&n| n == 0 || n > 20) {
        anyhow::bail!("--drones: team sizes from 1 to 20");
    }
    if args.trials == 0 {
        anyhow::bail!("--trials must be at least 1");
    }
    if !(args.battery_minutes.is_finite() && args.battery_minutes >= 3.0) {
        anyhow::bail!("--battery-minutes must be at least 3");
    }
    if !(args.swap_after.is_finite() && args.swap_after >= 0.0) {
        anyhow::bail!("--swap-after must be a number of seconds");
    }
    if !(args.trial_timeout_min.is_finite() && args.trial_timeout_min > 0.0) {
        anyhow::bail!("--trial-timeout-min must be positive");
    }
    Ok(())
}

/// Run the study: every team size, every trial, one after the other (the simulator and the
/// GCS share the machine's cores), each on a fresh runtime. `progress` hears of every trial
/// as it ends.
pub fn run(args: &RunwayArgs, progress: &mut dyn FnMut(&TrialRow)) -> anyhow::Result<Study> {
    validate(args)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut trials = Vec::new();
    let mut drone_rows = Vec::new();
    for &n in &args.drones {
        for k in 0..args.trials {
            let seed = args.seed + k as u64;
            let dir = args.out.join("runs").join(format!("d{n}-t{k}"));
            if dir.exists() {
                std::fs::remove_dir_all(&dir)
                    .with_context(|| format!("cannot remove the old {}", dir.display()))?;
            }
            let watch = fleetmap_io::clock::stopwatch();
            let rt = match args.speedup {
                // Paused: tokio advances the clock only when every task waits, and the
                // classifier runs inline on the one thread (app::blocking::run_blocking).
                StudyClock::Virtual => tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .start_paused(true)
                    .build(),
                StudyClock::Paced(_) => tokio::runtime::Builder::new_multi_thread()
                    .worker_threads(2)
                    .enable_all()
                    .build(),
            }
            .context("cannot start the async runtime")?;
            let limit = Duration::from_secs_f64(args.trial_timeout_min * 60.0);
            let flown = rt.block_on(async {
                match tokio::time::timeout(limit, fly(args, n, seed, &dir)).await {
                    Ok(r) => r,
                    Err(_) => Err(anyhow::anyhow!(
                        "no end after {} minutes of {}",
                        args.trial_timeout_min,
                        match args.speedup {
                            StudyClock::Virtual => "simulated time",
                            StudyClock::Paced(_) => "wall time",
                        }
                    )),
                }
            });
            rt.shutdown_timeout(Duration::from_secs(5));
            let wall_s = watch();
            // What the run saved, also after a failure or a timeout.
            let report = match &flown {
                Ok(r) => Some(r.clone()),
                Err(_) => saved_report(&dir),
            };
            let row = trial_row(n, k, seed, report.as_ref(), flown.as_ref().err(), wall_s);
            if let Some(r) = &report {
                drone_rows.extend(drone_rows_of(n, k, r));
            }
            progress(&row);
            trials.push(row);
            if !args.keep_runs {
                let _ = std::fs::remove_dir_all(&dir);
            }
        }
    }
    if !args.keep_runs {
        let _ = std::fs::remove_dir(args.out.join("runs"));
    }
    let summaries = summarise(&args.drones, &trials, &drone_rows);
    Ok(Study {
        speedup: args.speedup.to_string(),
        battery_minutes: args.battery_minutes,
        swap_after_s: args.swap_after,
        trials,
        drone_rows,
        summaries,
    })
}

/// The report of the run saved in `dir`, if any.
fn saved_report(dir: &Path) -> Option<MappingReport> {
    let state: MappingState = RunDir::open(dir).ok()?.load_state().ok()??;
    let world = World::from_toml(demo::RUNWAY_WORLD).ok()?;
    let cov = truth_coverage(&state.grid, &world, 0.0).ok()?;
    Some(crate::kinds::runway::report::report(&state, Some(&cov)))
}

/// Fly one trial: `drones` copters, simulator seed `seed`, the run directory `dir`.
async fn fly(
    args: &RunwayArgs,
    drones: usize,
    seed: u64,
    dir: &Path,
) -> anyhow::Result<MappingReport> {
    let world = World::from_toml(demo::RUNWAY_WORLD).context("the runway world")?;
    let cfg = demo::DemoConfig {
        drones,
        seed,
        battery_minutes: args.battery_minutes,
        swap_after_s: args.swap_after,
        ..demo::DemoConfig::default()
    };
    let (mut text, mut def) = demo::runway_mission(&cfg)?;
    if let Some(a) = args.allocation {
        // The built-in file names the key in a comment of its [runway] table.
        const KEY: &str = "# allocation = \"spread\"";
        if !text.contains(KEY) {
            anyhow::bail!("the built-in mission has no {KEY} line to set --allocation");
        }
        text = text.replacen(KEY, &format!("allocation = \"{}\"", a.name()), 1);
        def = fleetmap_core::mission::definition::MissionDef::parse(
            &text,
            "built-in runway-field-test.toml",
        )
        .context("the mission with --allocation")?;
    }
    let spec = format!("{drones}xcopter:ardupilot");
    // the demo's team: the same simulator, in virtual time or at the experiment's speed
    let (fleet, sim) = match args.speedup {
        StudyClock::Virtual => demo::start_virtual(&spec, world, &cfg).await?,
        StudyClock::Paced(speed) => {
            let team = demo::start_at(&spec, world, &cfg, speed).await?;
            (team.fleet, team.sim.task)
        }
    };
    let result = async {
        let state =
            crate::kinds::runway::new_mapping(&fleet, &def, Sharing::Gcs, Duration::from_secs(60))
                .await?;
        let mut meta = RunMeta::new(runway::KIND, unix_ms());
        meta.mission_path = Some("built-in runway-field-test.toml".into());
        meta.extra = serde_json::json!({"world": "world.toml"});
        let run_dir = RunDir::create(dir, meta, Some(&text))
            .with_context(|| format!("cannot create {}", dir.display()))?;
        fleetmap_io::files::atomic_write(&dir.join("world.toml"), demo::RUNWAY_WORLD.as_bytes())?;
        let hub = images::spawn(&fleet);
        let opts = RunOptions {
            auto_resume: true,
            patience: Patience { factor: 1.0 },
            ..RunOptions::default()
        };
        let outcome = runway::run(fleet.clone(), &hub, run_dir, state, opts).await?;
        if outcome != Outcome::Finished {
            anyhow::bail!("the run stopped: {outcome:?}");
        }
        saved_report(dir).context("the run saved no state")
    }
    .await;
    fleet.shutdown().await;
    let _ = sim.stop().await;
    result
}

fn trial_row(
    drones: usize,
    trial: usize,
    seed: u64,
    r: Option<&MappingReport>,
    error: Option<&anyhow::Error>,
    wall_s: f64,
) -> TrialRow {
    let m = r.map(|r| &r.mission_time);
    TrialRow {
        drones,
        trial,
        seed,
        finished: error.is_none() && r.is_some_and(|r| r.finished),
        error: error.map(|e| format!("{e:#}")),
        to_dfs_start_s: m.and_then(|m| m.to_dfs_start_s),
        to_map_complete_s: m.and_then(|m| m.to_map_complete_s),
        to_last_landing_s: m.and_then(|m| m.to_last_landing_s),
        iou: r.and_then(|r| r.iou),
        iou_best_possible: r.and_then(|r| r.iou_best_possible),
        cells_mapped: r.map_or(0, |r| r.cells_mapped),
        images: r.map_or(0, |r| r.images),
        battery_swaps: r.map_or(0, |r| r.battery_swaps),
        airborne_s: r.map_or(0.0, |r| r.flight_time_s),
        flying_share: m.map_or(0.0, |m| m.flying_share),
        waiting_share: m.map_or(0.0, |m| m.waiting_share),
        ground_share: m.map_or(0.0, |m| m.ground_share),
        wall_s,
    }
}

fn drone_rows_of(drones: usize, trial: usize, r: &MappingReport) -> Vec<DroneRow> {
    r.robots
        .iter()
        .map(|rb| {
            let t = &rb.time;
            DroneRow {
                drones,
                trial,
                sysid: rb.sysid,
                elapsed_s: t.elapsed_s,
                flying_s: t.flying_s,
                imaging_s: t.imaging_s,
                homing_s: t.homing_s,
                returning_s: t.returning_s,
                waiting_s: t.waiting_s,
                waiting: t.waiting,
                ground_s: t.ground_s,
                ground_before_s: t.ground_before_s,
                ground_swap_s: t.ground_swap_s,
                ground_done_s: t.ground_done_s,
                distance_m: rb.distance_m,
                battery_swaps: rb.battery_swaps,
                images: rb.images,
            }
        })
        .collect()
}

/// One summary per team size (in the order asked), over the finished trials.
pub(crate) fn summarise(
    sizes: &[usize],
    trials: &[TrialRow],
    drones: &[DroneRow],
) -> Vec<TeamSummary> {
    let mut out: Vec<TeamSummary> = Vec::new();
    for &n in sizes {
        if out.iter().any(|s| s.drones == n) {
            continue;
        }
        let all: Vec<&TrialRow> = trials.iter().filter(|t| t.drones == n).collect();
        let done: Vec<&TrialRow> = all.iter().copied().filter(|t| t.finished).collect();
        let stat = |f: fn(&TrialRow) -> Option<f64>| Stat::of(done.iter().filter_map(|t| f(t)));
        let mean = |f: fn(&TrialRow) -> f64| {
            if done.is_empty() {
                0.0
            } else {
                done.iter().map(|t| f(t)).sum::<f64>() / done.len() as f64
            }
        };
        let finished_trials: Vec<usize> = done.iter().map(|t| t.trial).collect();
        let rows: Vec<&DroneRow> = drones
            .iter()
            .filter(|d| d.drones == n && finished_trials.contains(&d.trial))
            .collect();
        let k = rows.len().max(1) as f64;
        let avg = |f: fn(&DroneRow) -> f64| rows.iter().map(|d| f(d)).sum::<f64>() / k;
        let per_drone = PerDrone {
            flying_s: avg(|d| d.flying_s),
            imaging_s: avg(|d| d.imaging_s),
            homing_s: avg(|d| d.homing_s),
            returning_s: avg(|d| d.returning_s),
            waiting: WaitTimes {
                confirmation_s: avg(|d| d.waiting.confirmation_s),
                sweep_s: avg(|d| d.waiting.sweep_s),
                pictures_s: avg(|d| d.waiting.pictures_s),
                dfs_start_s: avg(|d| d.waiting.dfs_start_s),
                vertex_s: avg(|d| d.waiting.vertex_s),
                operator_s: avg(|d| d.waiting.operator_s),
            },
            ground_before_s: avg(|d| d.ground_before_s),
            ground_swap_s: avg(|d| d.ground_swap_s),
            ground_done_s: avg(|d| d.ground_done_s),
            distance_m: avg(|d| d.distance_m),
        };
        out.push(TeamSummary {
            drones: n,
            trials: all.len(),
            finished: done.len(),
            to_dfs_start_s: stat(|t| t.to_dfs_start_s),
            to_map_complete_s: stat(|t| t.to_map_complete_s),
            to_last_landing_s: stat(|t| t.to_last_landing_s),
            map_ratio: None,
            landing_ratio: None,
            goal: GOALS.iter().find(|g| g.0 == n).map(|g| g.1),
            iou: stat(|t| t.iou),
            iou_best_possible: stat(|t| t.iou_best_possible),
            battery_swaps: stat(|t| Some(f64::from(t.battery_swaps))),
            flying_share: mean(|t| t.flying_share),
            waiting_share: mean(|t| t.waiting_share),
            ground_share: mean(|t| t.ground_share),
            per_drone,
        });
    }
    let one = out.iter().find(|s| s.drones == 1).map(|s| {
        (
            s.to_map_complete_s.map(|x| x.mean),
            s.to_last_landing_s.map(|x| x.mean),
        )
    });
    if let Some((map1, land1)) = one {
        for s in &mut out {
            s.map_ratio = s.to_map_complete_s.zip(map1).map(|(x, one)| x.mean / one);
            s.landing_ratio = s.to_last_landing_s.zip(land1).map(|(x, one)| x.mean / one);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(drones: usize, trial: usize, map: f64, land: f64) -> TrialRow {
        TrialRow {
            drones,
            trial,
            seed: 1 + trial as u64,
            finished: true,
            error: None,
            to_dfs_start_s: Some(100.0),
            to_map_complete_s: Some(map),
            to_last_landing_s: Some(land),
            iou: Some(0.89),
            iou_best_possible: Some(0.894),
            cells_mapped: 120,
            images: 600,
            battery_swaps: 2,
            airborne_s: 1500.0,
            flying_share: 0.8,
            waiting_share: 0.1,
            ground_share: 0.1,
            wall_s: 60.0,
        }
    }

    #[test]
    fn summaries_compare_every_team_with_one_drone() {
        let trials = vec![
            row(1, 0, 1000.0, 1100.0),
            row(1, 1, 1200.0, 1300.0),
            row(3, 0, 500.0, 600.0),
            TrialRow {
                finished: false,
                error: Some("stopped".into()),
                ..row(3, 1, 9000.0, 9000.0)
            },
        ];
        let study = Study {
            speedup: "virtual time".into(),
            battery_minutes: 12.0,
            swap_after_s: 30.0,
            summaries: summarise(&[1, 3], &trials, &[]),
            trials,
            drone_rows: Vec::new(),
        };
        let s = &study.summaries;
        assert_eq!((s[0].drones, s[0].finished, s[0].trials), (1, 2, 2));
        assert_eq!(s[0].to_map_complete_s.unwrap().mean, 1100.0);
        assert_eq!(s[0].map_ratio, Some(1.0));
        // The unfinished trial is left out of the figures, not of the count.
        assert_eq!((s[1].finished, s[1].trials), (1, 2));
        assert!((s[1].map_ratio.unwrap() - 500.0 / 1100.0).abs() < 1e-12);
        assert!((s[1].landing_ratio.unwrap() - 600.0 / 1200.0).abs() < 1e-12);
        assert_eq!(s[1].goal, Some(0.36));
        let csv = output::trials_csv(&study);
        assert_eq!(csv.lines().count(), 5);
        assert!(csv.lines().nth(4).unwrap().ends_with("\"stopped\""));
        let table = output::table(&study);
        assert!(table.contains("0.36×"), "{table}");
        let png = plot::team_png(&study).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }

    #[test]
    fn the_clock_is_virtual_unless_a_speed_is_given() {
        use clap::Parser as _;
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: RunwayArgs,
        }
        let parse = |extra: &[&str]| {
            let argv = std::iter::once("study").chain(extra.iter().copied());
            Cli::try_parse_from(argv).map(|c| c.args.speedup)
        };
        assert_eq!(parse(&[]).unwrap(), StudyClock::Virtual);
        assert_eq!(
            parse(&["--speedup", "VIRTUAL"]).unwrap(),
            StudyClock::Virtual
        );
        assert_eq!(
            parse(&["--speedup", "10"]).unwrap(),
            StudyClock::Paced(Speed::times(10.0).unwrap())
        );
        assert_eq!(
            parse(&["--speedup", "max"]).unwrap(),
            StudyClock::Paced(Speed::Max)
        );
        assert!(parse(&["--speedup", "soon"]).is_err());
    }

    #[test]
    fn the_missions_fly_on_the_simulated_batteries() {
        let cfg = demo::DemoConfig {
            battery_minutes: 6.0,
            ..demo::DemoConfig::default()
        };
        let (text, def) = demo::runway_mission(&cfg).unwrap();
        assert!(text.contains("flight_time_min = 6.0"));
        assert_eq!(def.battery.flight_time_min, 6.0);
        let plume = World::from_toml(include_str!("../../../assets/worlds/plume.toml")).unwrap();
        let (_, def, _) = demo::mission_for(&plume, &cfg).unwrap();
        assert_eq!(def.battery.flight_time_min, 6.0);
    }
}
