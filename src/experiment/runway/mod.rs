//! `fleetmap experiment runway`: how much sooner a team maps the runway than one drone
//! (issue 26).
//!
//! Every trial flies the runway field-test mission (`missions/runway-field-test.toml`, the
//! world `assets/worlds/runway.toml`) with a team of simulated ArduPilot copters, as
//! `fleetmap demo` does: the embedded simulator on loopback UDP (`crate::sim::server`, one
//! socket per vehicle), the GCS in the same process on the simulator's own time
//! ([`crate::clock::MonotonicClock::following`]), 12-minute batteries swapped by the simulated
//! crew 30 s after a landing, the runner resuming by itself. The simulator runs in lock-step
//! at up to `--speedup` times real time (or as fast as it can with `max`); every figure is in
//! simulated seconds — the report's mission time ([`crate::app::runway::report::MissionTime`]).
//!
//! Trial `k` of every team size uses the simulator seed `seed + k`, so the team sizes are
//! compared on the same GPS noise and the same wind (common random numbers).
//!
//! Outputs in `--out`: `runway_trials.csv` (one row per trial: mission times, IoU, swaps, the
//! team's shares), `runway_drones.csv` (one row per drone of every trial: where its time
//! went), `runway_summary.json`, and `runway_team.png` (time to the complete map and to the
//! last landing against the team size, beside one drone's time divided by the team size and
//! the goals).

pub mod plot;

use crate::app::flight::Patience;
use crate::app::runway::report::{MappingReport, truth_coverage};
use crate::app::runway::{self, Outcome, RunOptions};
use crate::app::{demo, images};
use crate::clock::unix_ms;
use crate::explore::Sharing;
use crate::explore::mapping::{MappingState, WaitTimes};
use crate::sim::pace::Speed;
use crate::store::{RunDir, RunMeta};
use crate::world::World;
use anyhow::Context as _;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The goals: a team of this many drones maps in at most this share of one drone's
/// time (issue 26: 3 drones 0.45×, 6 drones 0.3×).
pub const GOALS: [(usize, f64); 2] = [(3, 0.45), (6, 0.3)];

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
    /// Most simulated seconds per wall second (the simulator runs in lock-step and slows down
    /// when the machine is busy), or `max`. Every figure is simulated time; a GCS that gets
    /// behind a fast simulator (classifying pictures on a busy machine) leaves the drones
    /// hovering longer than it would in real time, so keep it moderate (the demo flies at 10×).
    #[arg(long, default_value = "10")]
    pub speedup: Speed,
    /// Battery endurance of the simulated copters and of the mission, minutes.
    #[arg(long, default_value_t = 12.0)]
    pub battery_minutes: f64,
    /// Seconds after a landing until the simulated crew has swapped the battery.
    #[arg(long, default_value_t = 30.0)]
    pub swap_after: f64,
    /// Give a trial up after this many minutes of wall time (it is reported as unfinished).
    #[arg(long, default_value_t = 45.0)]
    pub trial_timeout_min: f64,
    /// Keep every trial's run directory under OUT/runs (`fleetmap report` and `export` work
    /// on them); otherwise they are removed once the trial is read.
    #[arg(long)]
    pub keep_runs: bool,
    /// Print the study as JSON on stdout instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// Directory for the CSVs, the JSON summary and the PNG (created if missing).
    #[arg(long, value_name = "DIR", default_value = "experiment-runway")]
    pub out: PathBuf,
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
    pub airborne_s: f64,
    /// Share of the team's time flying and working.
    pub flying_share: f64,
    /// Share airborne and holding.
    pub waiting_share: f64,
    /// Share on the ground.
    pub ground_share: f64,
    /// Wall time of the trial, seconds.
    pub wall_s: f64,
}

/// One drone of one trial: where its mission time went, simulated seconds
/// ([`crate::app::runway::report::RobotTimeReport`]).
#[derive(Clone, Debug, Serialize)]
pub struct DroneRow {
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
    /// Of flying: after the map was complete, back to the DFS's start.
    pub returning_s: f64,
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
pub struct PerDrone {
    /// Flying and working.
    pub flying_s: f64,
    /// Of flying: pictures.
    pub imaging_s: f64,
    /// Of flying: home (for a swap, or at the end).
    pub homing_s: f64,
    /// Of flying: after the map was complete, back to the DFS's start.
    pub returning_s: f64,
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
    pub map_ratio: Option<f64>,
    /// Mean time to the last landing over one drone's.
    pub landing_ratio: Option<f64>,
    /// The goal for this team size (a share of one drone's time), if it has one.
    pub goal: Option<f64>,
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
    pub per_drone: PerDrone,
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
    pub drone_rows: Vec<DroneRow>,
    /// Per team size.
    pub summaries: Vec<TeamSummary>,
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
            let watch = crate::clock::stopwatch();
            let rt = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .context("cannot start the async runtime")?;
            let limit = Duration::from_secs_f64(args.trial_timeout_min * 60.0);
            let flown = rt.block_on(async {
                match tokio::time::timeout(limit, fly(args, n, seed, &dir)).await {
                    Ok(r) => r,
                    Err(_) => Err(anyhow::anyhow!(
                        "no end after {} minutes of wall time",
                        args.trial_timeout_min
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
    Some(crate::app::runway::report::report(&state, Some(&cov)))
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
    let (text, def) = demo::runway_mission(&cfg)?;
    let spec = format!("{drones}xcopter:ardupilot");
    // the demo's team: the same simulator and fleet set-up, at the experiment's speed
    let team = demo::start_at(&spec, world, &cfg, args.speedup).await?;
    let (fleet, handle) = (team.fleet, team.sim);
    let result = async {
        let state =
            crate::app::new_mapping(&fleet, &def, Sharing::Gcs, Duration::from_secs(60)).await?;
        let mut meta = RunMeta::new(runway::KIND, unix_ms());
        meta.mission_path = Some("built-in runway-field-test.toml".into());
        meta.extra = serde_json::json!({"world": "world.toml"});
        let run_dir = RunDir::create(dir, meta, Some(&text))
            .with_context(|| format!("cannot create {}", dir.display()))?;
        crate::store::atomic_write(&dir.join("world.toml"), demo::RUNWAY_WORLD.as_bytes())?;
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
    let _ = handle.stop().await;
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
pub fn summarise(sizes: &[usize], trials: &[TrialRow], drones: &[DroneRow]) -> Vec<TeamSummary> {
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

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.3}")).unwrap_or_default()
}

/// `runway_trials.csv`: one row per trial (seconds of simulated time).
pub fn trials_csv(study: &Study) -> String {
    let mut s = String::from(
        "drones,trial,seed,finished,to_dfs_start_s,to_map_complete_s,to_last_landing_s,iou,\
         iou_best_possible,cells_mapped,images,battery_swaps,airborne_s,flying_share,\
         waiting_share,ground_share,wall_s,error\n",
    );
    for t in &study.trials {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{:.1},{:.4},{:.4},{:.4},{:.1},{}\n",
            t.drones,
            t.trial,
            t.seed,
            t.finished,
            opt(t.to_dfs_start_s),
            opt(t.to_map_complete_s),
            opt(t.to_last_landing_s),
            opt(t.iou),
            opt(t.iou_best_possible),
            t.cells_mapped,
            t.images,
            t.battery_swaps,
            t.airborne_s,
            t.flying_share,
            t.waiting_share,
            t.ground_share,
            t.wall_s,
            t.error
                .as_deref()
                .map(|e| format!("\"{}\"", e.replace('"', "'")))
                .unwrap_or_default()
        ));
    }
    s
}

/// `runway_drones.csv`: one row per drone of every trial (seconds of simulated time).
pub fn drones_csv(study: &Study) -> String {
    let mut s = String::from(
        "drones,trial,sysid,elapsed_s,flying_s,imaging_s,homing_s,returning_s,waiting_s,\
         wait_confirmation_s,wait_sweep_s,wait_pictures_s,wait_dfs_start_s,wait_vertex_s,\
         wait_operator_s,ground_s,ground_before_s,ground_swap_s,ground_done_s,distance_m,\
         battery_swaps,images\n",
    );
    for d in &study.drone_rows {
        let w = &d.waiting;
        s.push_str(&format!(
            "{},{},{},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.1},{},{}\n",
            d.drones,
            d.trial,
            d.sysid,
            d.elapsed_s,
            d.flying_s,
            d.imaging_s,
            d.homing_s,
            d.returning_s,
            d.waiting_s,
            w.confirmation_s,
            w.sweep_s,
            w.pictures_s,
            w.dfs_start_s,
            w.vertex_s,
            w.operator_s,
            d.ground_s,
            d.ground_before_s,
            d.ground_swap_s,
            d.ground_done_s,
            d.distance_m,
            d.battery_swaps,
            d.images
        ));
    }
    s
}

/// The summary tables: per team size the mission times (mean, and min–max with several
/// trials), their ratio to one drone's, the goal, IoU and swaps; then where a drone's time
/// went (mean seconds per drone).
pub fn table(study: &Study) -> String {
    let secs = |x: &Option<Stat>| match x {
        Some(s) if (s.max - s.min).abs() < 0.5 => format!("{:.0}", s.mean),
        Some(s) => format!("{:.0} ({:.0}–{:.0})", s.mean, s.min, s.max),
        None => "—".into(),
    };
    let ratio = |x: Option<f64>| x.map_or("—".into(), |r| format!("{r:.2}×"));
    let pct = |x: &Option<Stat>| x.map_or("—".into(), |s| format!("{:.1} %", 100.0 * s.mean));
    let mut s = format!(
        "{:>6} {:>7} | {:>16} {:>18} {:>6} {:>18} {:>6} {:>5} | {:>7} {:>7} {:>5} | {:>6} {:>6} {:>6}\n",
        "drones",
        "trials",
        "DFS start s",
        "map complete s",
        "×1",
        "last landing s",
        "×1",
        "goal",
        "IoU",
        "best",
        "swaps",
        "fly",
        "wait",
        "ground"
    );
    for x in &study.summaries {
        s.push_str(&format!(
            "{:>6} {:>7} | {:>16} {:>18} {:>6} {:>18} {:>6} {:>5} | {:>7} {:>7} {:>5} | {:>5.0}% {:>5.0}% {:>5.0}%\n",
            x.drones,
            format!("{}/{}", x.finished, x.trials),
            secs(&x.to_dfs_start_s),
            secs(&x.to_map_complete_s),
            ratio(x.map_ratio),
            secs(&x.to_last_landing_s),
            ratio(x.landing_ratio),
            x.goal.map_or("".into(), |g| format!("{g}×")),
            pct(&x.iou),
            pct(&x.iou_best_possible),
            x.battery_swaps.map_or("—".into(), |b| format!("{:.1}", b.mean)),
            100.0 * x.flying_share,
            100.0 * x.waiting_share,
            100.0 * x.ground_share
        ));
    }
    s.push_str(&format!(
        "\nper drone, mean seconds: {:>6} {:>7} {:>6} {:>6} {:>6} | {:>7} {:>7} {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7} | {:>6}\n",
        "drones",
        "flying",
        "(imag)",
        "(home)",
        "(back)",
        "confirm",
        "sweep",
        "DFSstart",
        "vertex",
        "other",
        "before",
        "swaps",
        "done",
        "metres"
    ));
    for x in &study.summaries {
        let p = &x.per_drone;
        let w = &p.waiting;
        s.push_str(&format!(
            "                         {:>6} {:>7.0} {:>6.0} {:>6.0} {:>6.0} | {:>7.0} {:>7.0} {:>7.0} {:>7.0} {:>7.0} | {:>7.0} {:>7.0} {:>7.0} | {:>6.0}\n",
            x.drones,
            p.flying_s,
            p.imaging_s,
            p.homing_s,
            p.returning_s,
            w.confirmation_s,
            w.sweep_s + w.pictures_s,
            w.dfs_start_s,
            w.vertex_s,
            w.operator_s,
            p.ground_before_s,
            p.ground_swap_s,
            p.ground_done_s,
            p.distance_m
        ));
    }
    s
}

/// One progress line per trial.
pub fn trial_line(t: &TrialRow) -> String {
    let secs = |x: Option<f64>| x.map_or("—".into(), |v| format!("{v:.0} s"));
    format!(
        "{} drone(s), trial {} (seed {}): {} — map complete {}, last landing {}, IoU {}, {} swap(s), \
         {:.0} % flying / {:.0} % waiting / {:.0} % ground, {:.0} s wall{}",
        t.drones,
        t.trial,
        t.seed,
        if t.finished {
            "finished"
        } else {
            "NOT FINISHED"
        },
        secs(t.to_map_complete_s),
        secs(t.to_last_landing_s),
        t.iou.map_or("—".into(), |i| format!("{:.1} %", 100.0 * i)),
        t.battery_swaps,
        100.0 * t.flying_share,
        100.0 * t.waiting_share,
        100.0 * t.ground_share,
        t.wall_s,
        t.error
            .as_deref()
            .map(|e| format!(" ({e})"))
            .unwrap_or_default()
    )
}

/// Write `runway_trials.csv`, `runway_drones.csv`, `runway_summary.json` and
/// `runway_team.png` into `dir`; returns the files written.
pub fn write_outputs(study: &Study, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut files = Vec::new();
    let mut write = |name: &str, bytes: &[u8]| -> anyhow::Result<()> {
        let path = dir.join(name);
        crate::store::atomic_write(&path, bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        files.push(path);
        Ok(())
    };
    write("runway_trials.csv", trials_csv(study).as_bytes())?;
    write("runway_drones.csv", drones_csv(study).as_bytes())?;
    write(
        "runway_summary.json",
        serde_json::to_string_pretty(study)?.as_bytes(),
    )?;
    write("runway_team.png", &plot::team_png(study)?)?;
    Ok(files)
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
            speedup: "10×".into(),
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
        assert_eq!(s[1].goal, Some(0.45));
        let csv = trials_csv(&study);
        assert_eq!(csv.lines().count(), 5);
        assert!(csv.lines().nth(4).unwrap().ends_with("\"stopped\""));
        let table = table(&study);
        assert!(table.contains("0.45×"), "{table}");
        let png = plot::team_png(&study).unwrap();
        assert_eq!(&png[1..4], b"PNG");
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
