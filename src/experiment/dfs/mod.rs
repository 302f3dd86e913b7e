//! `fleetmap experiment dfs`: the runway paper's simulation study (§6, Fig. 7).
//!
//! Random connected grid ROIs ([`random_roi`]: Eden growth from a seed cell, a uniformly
//! random start cell), explored by Algorithm 1 ([`simulate`]) with a perfect sensor, unit
//! cells, robots at S_r = 1 cell per time unit and the ROI translating at S_p = S_r / ratio
//! towards one of north, south, east, west (drawn per trial, as in §6), or static. Three
//! sweeps like Fig. 7b–d: the number of cells, of robots, and the speed ratio, the others at
//! 120 cells, 20 robots and ratio 2.5. Per trial: the algorithm's cost (when the last robot
//! is back at the start), Lemma 1's upper bound (eq. 2, with d_max of the tree the run built,
//! ⌊log₂ R⌋), Lemma 2's lower bound (eq. 10) and the lawnmower baseline of §6.
//!
//! Trials are independent of scheduling: trial `t` of a sweep point with `C` cells uses an
//! ROI and direction seeded by (seed, C, t) only, so the robots and ratio sweeps compare the
//! same ROIs (common random numbers) and runs are reproducible across thread counts.

mod args;
mod output;
pub(crate) mod plot;

#[cfg(test)]
use args::{AllocationChoice, SharingChoice};
pub(crate) use args::{DfsArgs, SpeedRatio};
pub use output::{table, trials_csv, violation_lines, write_outputs};

use fleetmap_core::explore::ExploreError;
use fleetmap_core::explore::bounds::{
    eq8_single_robot_bound, lawnmower_baseline, lemma1_upper_bound, lemma2_lower_bound,
    opt_lower_bound, round_trip_time, theorem_bound_at, theorem1_ratio, theorem2_ratio,
};
use fleetmap_core::explore::dfs::{Allocation, Sharing};
use fleetmap_core::explore::simulate::{SimConfig, random_roi, simulate};
use fleetmap_core::geo::Cell;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Errors of the study.
#[derive(Debug, thiserror::Error)]
pub enum DfsStudyError {
    /// A bad parameter.
    #[error("{0}")]
    Invalid(String),
    /// A simulation failed.
    #[error("trial {trial} of {config}: {source}")]
    Trial {
        /// Which configuration.
        config: String,
        /// Which trial.
        trial: usize,
        /// Why.
        source: ExploreError,
    },
    /// Writing an output failed.
    #[error("cannot write {path}: {reason}")]
    Output {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// Which variable a configuration sweeps (Fig. 7b, c, d).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Sweep {
    /// Number of ROI cells (Fig. 7b).
    Cells,
    /// Number of robots (Fig. 7c).
    Robots,
    /// Speed ratio (Fig. 7d).
    Ratio,
}

impl fmt::Display for Sweep {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Sweep::Cells => "cells",
            Sweep::Robots => "robots",
            Sweep::Ratio => "ratio",
        })
    }
}

/// One point of a sweep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Configuration {
    /// The swept variable.
    pub sweep: Sweep,
    /// How robots share states.
    pub sharing: Sharing,
    /// How the robots at a vertex are allocated.
    pub allocation: Allocation,
    /// C.
    pub cells: usize,
    /// R.
    pub robots: usize,
    /// S_r / S_p.
    pub(crate) speed_ratio: SpeedRatio,
}

impl fmt::Display for Configuration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} sweep, {} sharing, C = {}, R = {}, ratio {}, {} allocation",
            self.sweep, self.sharing, self.cells, self.robots, self.speed_ratio, self.allocation
        )
    }
}

/// One trial's numbers.
#[derive(Clone, Debug, Serialize)]
pub struct TrialRecord {
    /// Index into the study's configurations.
    pub config: usize,
    /// Trial number.
    pub trial: usize,
    /// Direction the ROI moves ("static" when it does not).
    pub(crate) direction: &'static str,
    /// ALG: when the last robot was back at the start.
    pub cost: f64,
    /// Lemma 1 (eq. 2).
    pub(crate) lemma1_upper: f64,
    /// Lemma 2 (eq. 10).
    pub(crate) lemma2_lower: f64,
    /// §6's lawnmower baseline.
    pub(crate) lawnmower_lower: f64,
    /// d_max of the built tree.
    pub d_max: u32,
    /// Cells in the built tree (= C with the perfect sensor).
    pub tree_cells: usize,
    /// Whether cost ≤ Lemma 1.
    pub(crate) within_lemma1: bool,
    /// Eq. (8), the single-robot bound (`None` when R > 1, where it does not apply).
    pub(crate) eq8_upper: Option<f64>,
    /// The lower bound on OPT of the theorems' proofs: max(Lemma 2, d_max/(S_r + S_p)).
    pub(crate) opt_lower: f64,
    /// Theorem 1 (eq. 13) at OPT = `opt_lower`: an upper bound on ALG, ≥ Lemma 1.
    pub(crate) theorem1_upper: f64,
    /// Theorem 2 (eq. 18) at OPT = `opt_lower`.
    pub(crate) theorem2_upper: f64,
    /// The longest straight round trip from the start to a ROI cell (time units): a lower
    /// bound on any strategy, which the lawnmower baseline leaves out.
    pub(crate) reach_lower: f64,
    /// Unit tree edges flown, all robots together.
    pub(crate) moves: u64,
    /// Moves onto a cell no robot had reached before (C − 1): the rest is transit.
    pub(crate) opening_moves: u64,
    /// Σ flight time / (R · ALG): the share of the team's time spent flying (the rest is
    /// robots done early, waiting at home).
    pub(crate) flight_share: f64,
    /// Decisions made differently from a fully informed team (meeting sharing; 0 with GCS).
    pub uninformed_decisions: u64,
}

/// Mean, minimum and maximum over the trials.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Stats {
    /// Mean.
    pub mean: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
}

impl Stats {
    fn of(xs: impl IntoIterator<Item = f64>) -> Stats {
        let (mut n, mut sum, mut min, mut max) = (0usize, 0.0, f64::INFINITY, f64::NEG_INFINITY);
        for x in xs {
            n += 1;
            sum += x;
            min = min.min(x);
            max = max.max(x);
        }
        if n == 0 {
            return Stats {
                mean: f64::NAN,
                min: f64::NAN,
                max: f64::NAN,
            };
        }
        Stats {
            mean: sum / n as f64,
            min,
            max,
        }
    }
}

/// Per-configuration summary.
#[derive(Clone, Debug, Serialize)]
pub struct ConfigSummary {
    /// The configuration.
    #[serde(flatten)]
    pub config: Configuration,
    /// Trials run.
    pub trials: usize,
    /// ALG.
    pub cost: Stats,
    /// Lemma 1 upper bound.
    pub(crate) lemma1_upper: Stats,
    /// Lemma 2 lower bound.
    pub(crate) lemma2_lower: Stats,
    /// Lawnmower baseline.
    pub(crate) lawnmower_lower: Stats,
    /// d_max.
    pub d_max: Stats,
    /// Mean over trials of cost / lawnmower baseline.
    pub mean_ratio_to_lawnmower: f64,
    /// Mean over trials of cost / Lemma 2.
    pub(crate) mean_ratio_to_lemma2: f64,
    /// Largest cost / Lemma 1 over the trials (≤ 1 when the bound holds).
    pub(crate) max_ratio_to_lemma1: f64,
    /// Trials where the cost exceeded Lemma 1.
    pub violations: usize,
    /// Of those, the trials without any uninformed decision (0 in every run so far).
    pub(crate) informed_violations: usize,
    /// Trials with at least one uninformed decision.
    pub(crate) uninformed_trials: usize,
    /// Eq. (8) (only with R = 1; `null` otherwise).
    pub(crate) eq8_upper: Option<Stats>,
    /// Trials above eq. (8) (R = 1 only).
    pub(crate) eq8_violations: usize,
    /// Theorem 1 at OPT's lower bound.
    pub(crate) theorem1_upper: Stats,
    /// Theorem 2 at OPT's lower bound.
    pub(crate) theorem2_upper: Stats,
    /// The competitive ratio of Theorem 1 (the factor of OPT in eq. 13).
    pub(crate) theorem1_ratio: f64,
    /// The competitive ratio of Theorem 2 (the factor of OPT in eq. 18).
    pub(crate) theorem2_ratio: f64,
    /// Largest ALG / OPT's lower bound (≥ the true ALG/OPT), to set beside the ratios.
    pub(crate) max_ratio_to_opt_lower: f64,
    /// The longest round trip from the start (see [`TrialRecord::reach_lower`]).
    pub(crate) reach_lower: Stats,
    /// Mean over trials of cost / max(lawnmower, round trip).
    pub(crate) mean_ratio_to_lawnmower_or_reach: f64,
    /// Mean over trials of 2 d_max/(S_r − S_p) / cost: the share of the cost the Lemma 1
    /// proof charges to the depth (out to d_max and back at the slowest speed).
    pub(crate) mean_depth_share: f64,
    /// Mean share of all moves that are transit (onto already reached cells).
    pub(crate) mean_transit_share: f64,
    /// Mean share of the team's time spent flying (the rest: done early, at home).
    pub(crate) mean_flight_share: f64,
}

/// A finished study.
#[derive(Clone, Debug, Serialize)]
pub struct Study {
    /// Trials per configuration.
    pub trials: usize,
    /// The seed.
    pub seed: u64,
    /// S_r (cells per time unit).
    pub robot_speed: f64,
    /// Every configuration.
    pub(crate) configurations: Vec<Configuration>,
    /// Every trial.
    #[serde(skip)]
    pub records: Vec<TrialRecord>,
    /// Per configuration.
    pub summaries: Vec<ConfigSummary>,
    /// Total trials above Lemma 1.
    pub violations: usize,
    /// Over all trials, per (sharing, allocation): the allocation comparison.
    pub(crate) modes: Vec<ModeSummary>,
}

/// All trials of one (sharing, allocation) pair, pooled over every sweep point, and how they
/// compare with Algorithm 1's split on the same ROIs and directions (common random numbers).
#[derive(Clone, Debug, Serialize)]
pub(crate) struct ModeSummary {
    /// Sharing.
    pub sharing: Sharing,
    /// Allocation.
    pub allocation: Allocation,
    /// Trials.
    pub trials: usize,
    /// ALG over the trials (time units: cell lengths / S_r).
    pub cost: Stats,
    /// Mean over trials of ALG / lawnmower lower bound.
    pub mean_ratio_to_lawnmower: f64,
    /// Largest ALG / lawnmower lower bound.
    pub(crate) max_ratio_to_lawnmower: f64,
    /// Largest ALG / Lemma 1 (eq. 2).
    pub(crate) max_ratio_to_lemma1: f64,
    /// Trials above Lemma 1.
    pub violations: usize,
    /// Mean over trials of ALG / ALG of the paper's split on the same trial (1 for the
    /// paper's split itself; `None` when the study did not run the paper's split).
    pub(crate) mean_ratio_to_paper: Option<f64>,
    /// Trials cheaper than the paper's split on the same trial.
    pub(crate) cheaper_than_paper: usize,
    /// Trials dearer than the paper's split on the same trial.
    pub(crate) dearer_than_paper: usize,
}

fn mode_summaries(configs: &[Configuration], records: &[TrialRecord]) -> Vec<ModeSummary> {
    let mut modes: Vec<(Sharing, Allocation)> = Vec::new();
    for c in configs {
        if !modes.contains(&(c.sharing, c.allocation)) {
            modes.push((c.sharing, c.allocation));
        }
    }
    // The paper's split on the same sweep point, sharing and trial.
    let key = |r: &TrialRecord| {
        let c = &configs[r.config];
        (
            c.sweep,
            c.sharing,
            c.cells,
            c.robots,
            c.speed_ratio.to_string(),
            r.trial,
        )
    };
    let paper: std::collections::HashMap<_, f64> = records
        .iter()
        .filter(|r| configs[r.config].allocation == Allocation::Paper)
        .map(|r| (key(r), r.cost))
        .collect();
    modes
        .into_iter()
        .map(|(sharing, allocation)| {
            let rs: Vec<&TrialRecord> = records
                .iter()
                .filter(|r| {
                    let c = &configs[r.config];
                    c.sharing == sharing && c.allocation == allocation
                })
                .collect();
            let n = rs.len().max(1) as f64;
            let vs: Vec<(f64, f64)> = rs
                .iter()
                .filter_map(|r| paper.get(&key(r)).map(|&p| (r.cost, p)))
                .collect();
            let eps = 1e-9;
            ModeSummary {
                sharing,
                allocation,
                trials: rs.len(),
                cost: Stats::of(rs.iter().map(|r| r.cost)),
                mean_ratio_to_lawnmower: rs.iter().map(|r| r.cost / r.lawnmower_lower).sum::<f64>()
                    / n,
                max_ratio_to_lawnmower: rs
                    .iter()
                    .map(|r| r.cost / r.lawnmower_lower)
                    .fold(0.0, f64::max),
                max_ratio_to_lemma1: rs
                    .iter()
                    .map(|r| r.cost / r.lemma1_upper)
                    .fold(0.0, f64::max),
                violations: rs.iter().filter(|r| !r.within_lemma1).count(),
                mean_ratio_to_paper: (vs.len() == rs.len() && !vs.is_empty())
                    .then(|| vs.iter().map(|(a, p)| a / p).sum::<f64>() / vs.len() as f64),
                cheaper_than_paper: vs.iter().filter(|(a, p)| *a < p - eps).count(),
                dearer_than_paper: vs.iter().filter(|(a, p)| *a > p + eps).count(),
            }
        })
        .collect()
}

/// The allocation comparison (one line per sharing and allocation, over all trials): mean,
/// worst and best ALG, mean and worst ALG/lawnmower, worst ALG/Lemma 1, trials above
/// Lemma 1, and against the paper's split on the same trials.
pub(crate) fn modes_table(study: &Study) -> String {
    let mut s = format!(
        "{:<4} {:<16} {:>6} | {:>8} {:>8} {:>8} | {:>7} {:>7} | {:>6} {:>4} | {:>8} {:>7} {:>6}\n",
        "shr",
        "allocation",
        "trials",
        "ALG mean",
        "worst",
        "best",
        "ALG/LM",
        "worst",
        "max/UB",
        "viol",
        "/paper",
        "cheaper",
        "dearer"
    );
    for m in &study.modes {
        s.push_str(&format!(
            "{:<4} {:<16} {:>6} | {:>8.2} {:>8.1} {:>8.1} | {:>7.2} {:>7.2} | {:>6.3} {:>4} | {:>8} {:>7} {:>6}\n",
            m.sharing.to_string(),
            m.allocation.name(),
            m.trials,
            m.cost.mean,
            m.cost.max,
            m.cost.min,
            m.mean_ratio_to_lawnmower,
            m.max_ratio_to_lawnmower,
            m.max_ratio_to_lemma1,
            m.violations,
            m.mean_ratio_to_paper
                .map(|x| format!("{x:.4}"))
                .unwrap_or_else(|| "-".into()),
            m.cheaper_than_paper,
            m.dearer_than_paper
        ));
    }
    s
}

/// The configurations of the three sweeps, for every sharing mode.
pub(crate) fn configurations(args: &DfsArgs) -> Vec<Configuration> {
    let mut out = Vec::new();
    for (sharing, allocation) in args.sharing.modes().into_iter().flat_map(|sh| {
        args.allocation
            .allocations(sh)
            .into_iter()
            .map(move |a| (sh, a))
    }) {
        let base = |sweep| Configuration {
            sweep,
            sharing,
            allocation,
            cells: args.base_cells,
            robots: args.base_robots,
            speed_ratio: args.base_ratio,
        };
        let on = |s| args.sweeps.contains(&s);
        for &cells in args.cells.iter().filter(|_| on(Sweep::Cells)) {
            out.push(Configuration {
                cells,
                ..base(Sweep::Cells)
            });
        }
        for &robots in args.robots.iter().filter(|_| on(Sweep::Robots)) {
            out.push(Configuration {
                robots,
                ..base(Sweep::Robots)
            });
        }
        for &speed_ratio in args.ratios.iter().filter(|_| on(Sweep::Ratio)) {
            out.push(Configuration {
                speed_ratio,
                ..base(Sweep::Ratio)
            });
        }
    }
    out
}

/// SplitMix64 (Steele et al.): a well-mixed 64-bit seed from several numbers.
fn mix(parts: &[u64]) -> u64 {
    let mut z = 0x9E37_79B9_7F4A_7C15u64;
    for &p in parts {
        z = z.wrapping_add(p).wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
    }
    z
}

/// The ROI, start and direction of trial `trial` with `cells` cells.
pub(crate) fn trial_roi(seed: u64, cells: usize, trial: usize) -> (HashSet<Cell>, Cell, usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(mix(&[seed, cells as u64, trial as u64]));
    let (roi, start) = random_roi(&mut rng, cells);
    let dir = rng.random_range(0..4usize);
    (roi, start, dir)
}

const DIRECTIONS: [(&str, (f64, f64)); 4] = [
    ("north", (0.0, 1.0)),
    ("south", (0.0, -1.0)),
    ("east", (1.0, 0.0)),
    ("west", (-1.0, 0.0)),
];

/// Run one trial of configuration `conf` (index `ci`).
pub fn run_trial(
    seed: u64,
    ci: usize,
    conf: &Configuration,
    trial: usize,
) -> Result<TrialRecord, ExploreError> {
    let (roi, start, dir) = trial_roi(seed, conf.cells, trial);
    let sp = conf.speed_ratio.roi_speed();
    let (name, (ue, un)) = DIRECTIONS[dir];
    let v = (ue * sp, un * sp);
    let out = simulate(
        &roi,
        start,
        &SimConfig {
            robots: conf.robots,
            sharing: conf.sharing,
            allocation: conf.allocation,
            robot_speed: 1.0,
            roi_velocity: v,
            observe_time: 0.0,
            record_paths: false,
            direct_transit: false,
        },
    )?;
    let c = roi.len();
    let lemma1 = lemma1_upper_bound(c, out.d_max, conf.robots, 1.0, sp);
    let opt_lower = opt_lower_bound(c, out.d_max, conf.robots, 1.0, sp);
    let reach_lower = roi
        .iter()
        .map(|x| {
            let dx = f64::from(x.col - start.col);
            let dy = f64::from(x.row - start.row);
            round_trip_time(dx, dy, 1.0, v)
        })
        .fold(0.0, f64::max);
    let team_time = conf.robots as f64 * out.cost;
    Ok(TrialRecord {
        config: ci,
        trial,
        direction: if sp == 0.0 { "static" } else { name },
        cost: out.cost,
        lemma1_upper: lemma1,
        lemma2_lower: lemma2_lower_bound(c, conf.robots, 1.0, sp),
        lawnmower_lower: lawnmower_baseline(roi.iter().copied(), conf.robots, 1.0, v),
        d_max: out.d_max,
        tree_cells: out.tree_cells,
        // Exact arithmetic up to rounding in the relative-speed edge times.
        within_lemma1: out.cost <= lemma1 * (1.0 + 1e-9),
        eq8_upper: (conf.robots == 1).then(|| eq8_single_robot_bound(c, 1.0, sp)),
        opt_lower,
        theorem1_upper: theorem_bound_at(theorem1_ratio(conf.robots, 1.0, sp), opt_lower),
        theorem2_upper: theorem_bound_at(theorem2_ratio(conf.robots, 1.0, sp), opt_lower),
        reach_lower,
        moves: out.moves.iter().sum(),
        opening_moves: out.opening_moves.iter().sum(),
        uninformed_decisions: out.explorer.uninformed_decisions(),
        flight_share: if team_time > 0.0 {
            out.flight_time.iter().sum::<f64>() / team_time
        } else {
            1.0
        },
    })
}

/// Run the study (rayon across trials); `tick` is called after every trial.
pub fn run(args: &DfsArgs, tick: &(dyn Fn() + Sync)) -> Result<Study, DfsStudyError> {
    args.validate()?;
    let configs = configurations(args);
    let jobs: Vec<(usize, usize)> = (0..configs.len())
        .flat_map(|c| (0..args.trials).map(move |t| (c, t)))
        .collect();
    let records = jobs
        .par_iter()
        .map(|&(ci, t)| {
            let r =
                run_trial(args.seed, ci, &configs[ci], t).map_err(|source| DfsStudyError::Trial {
                    config: configs[ci].to_string(),
                    trial: t,
                    source,
                });
            tick();
            r
        })
        .collect::<Result<Vec<_>, _>>()?;
    let summaries: Vec<ConfigSummary> = configs
        .iter()
        .enumerate()
        .map(|(ci, conf)| {
            let rs: Vec<&TrialRecord> = records.iter().filter(|r| r.config == ci).collect();
            let ratio = |f: &dyn Fn(&TrialRecord) -> f64| {
                rs.iter().map(|r| r.cost / f(r)).sum::<f64>() / rs.len() as f64
            };
            let mean = |f: &dyn Fn(&TrialRecord) -> f64| {
                rs.iter().map(|r| f(r)).sum::<f64>() / rs.len() as f64
            };
            let sp = conf.speed_ratio.roi_speed();
            ConfigSummary {
                config: *conf,
                trials: rs.len(),
                cost: Stats::of(rs.iter().map(|r| r.cost)),
                lemma1_upper: Stats::of(rs.iter().map(|r| r.lemma1_upper)),
                lemma2_lower: Stats::of(rs.iter().map(|r| r.lemma2_lower)),
                lawnmower_lower: Stats::of(rs.iter().map(|r| r.lawnmower_lower)),
                d_max: Stats::of(rs.iter().map(|r| f64::from(r.d_max))),
                mean_ratio_to_lawnmower: ratio(&|r| r.lawnmower_lower),
                mean_ratio_to_lemma2: ratio(&|r| r.lemma2_lower),
                max_ratio_to_lemma1: rs
                    .iter()
                    .map(|r| r.cost / r.lemma1_upper)
                    .fold(0.0, f64::max),
                violations: rs.iter().filter(|r| !r.within_lemma1).count(),
                informed_violations: rs
                    .iter()
                    .filter(|r| !r.within_lemma1 && r.uninformed_decisions == 0)
                    .count(),
                uninformed_trials: rs.iter().filter(|r| r.uninformed_decisions > 0).count(),
                eq8_upper: (conf.robots == 1)
                    .then(|| Stats::of(rs.iter().filter_map(|r| r.eq8_upper))),
                eq8_violations: rs
                    .iter()
                    .filter(|r| r.eq8_upper.is_some_and(|b| r.cost > b * (1.0 + 1e-9)))
                    .count(),
                theorem1_upper: Stats::of(rs.iter().map(|r| r.theorem1_upper)),
                theorem2_upper: Stats::of(rs.iter().map(|r| r.theorem2_upper)),
                theorem1_ratio: theorem1_ratio(conf.robots, 1.0, sp).0,
                theorem2_ratio: theorem2_ratio(conf.robots, 1.0, sp).0,
                max_ratio_to_opt_lower: rs.iter().map(|r| r.cost / r.opt_lower).fold(0.0, f64::max),
                reach_lower: Stats::of(rs.iter().map(|r| r.reach_lower)),
                mean_ratio_to_lawnmower_or_reach: ratio(&|r| r.lawnmower_lower.max(r.reach_lower)),
                mean_depth_share: mean(&|r| 2.0 * f64::from(r.d_max) / (1.0 - sp) / r.cost),
                mean_transit_share: mean(&|r| {
                    1.0 - r.opening_moves as f64 / (r.moves as f64).max(1.0)
                }),
                mean_flight_share: mean(&|r| r.flight_share),
            }
        })
        .collect();
    let violations = records.iter().filter(|r| !r.within_lemma1).count();
    let modes = mode_summaries(&configs, &records);
    Ok(Study {
        trials: args.trials,
        seed: args.seed,
        robot_speed: 1.0,
        configurations: configs,
        records,
        summaries,
        violations,
        modes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(trials: usize) -> DfsArgs {
        DfsArgs {
            cells: vec![20, 40],
            robots: vec![1, 4],
            ratios: vec![SpeedRatio::Ratio(2.0), SpeedRatio::Static],
            base_cells: 30,
            base_robots: 3,
            sharing: SharingChoice::Both,
            ..DfsArgs::paper(trials, 7, PathBuf::from("unused"))
        }
    }

    #[test]
    fn ratios_parse() {
        assert_eq!("static".parse::<SpeedRatio>(), Ok(SpeedRatio::Static));
        assert_eq!("2.5".parse::<SpeedRatio>(), Ok(SpeedRatio::Ratio(2.5)));
        assert!("1".parse::<SpeedRatio>().is_err());
        assert!("fast".parse::<SpeedRatio>().is_err());
    }

    #[test]
    fn trials_are_reproducible_and_share_rois_across_sweeps() {
        let a = trial_roi(1, 50, 3);
        let b = trial_roi(1, 50, 3);
        assert_eq!(a, b);
        assert_ne!(trial_roi(1, 50, 4).0, a.0);
        let args = small(3);
        let s1 = run(&args, &|| {}).unwrap();
        let s2 = run(&args, &|| {}).unwrap();
        assert_eq!(trials_csv(&s1), trials_csv(&s2));
        // 2 sharing modes × (2 + 2 + 2) points.
        assert_eq!(s1.configurations.len(), 12);
        assert_eq!(s1.records.len(), 36);
        assert_eq!(s1.modes.len(), 2);
        // GCS never exceeds Lemma 1.
        for (c, x) in s1.configurations.iter().zip(&s1.summaries) {
            if c.sharing == Sharing::Gcs {
                assert_eq!(x.violations, 0, "{c}");
            }
            assert!(x.cost.min <= x.cost.mean && x.cost.mean <= x.cost.max);
        }
        let csv = trials_csv(&s1);
        assert_eq!(csv.lines().count(), 37);
        assert!(csv.starts_with("sweep,sharing,allocation,cells"));
        let t = table(&s1);
        // Header and 12 configurations, a blank line, header and 2 modes.
        assert_eq!(t.lines().count(), 13 + 1 + 3);
    }

    #[test]
    fn both_allocations_run_on_the_same_trials() {
        let args = DfsArgs {
            allocation: AllocationChoice::Both,
            ..small(3)
        };
        let s = run(&args, &|| {}).unwrap();
        // GCS × 2 allocations + meeting-only × the paper's split, 6 points each.
        assert_eq!(s.configurations.len(), 18);
        assert_eq!(s.modes.len(), 3);
        for m in &s.modes {
            assert_eq!(m.trials, 18);
            if m.allocation == Allocation::Paper {
                assert_eq!(m.mean_ratio_to_paper, Some(1.0));
                assert_eq!((m.cheaper_than_paper, m.dearer_than_paper), (0, 0));
            } else {
                assert_eq!(m.sharing, Sharing::Gcs);
                assert!(m.mean_ratio_to_paper.is_some());
            }
        }
        assert!(trials_csv(&s).contains(",gcs,nearest_frontier,"));
    }

    /// The trial of the 2 800 (seed 2019) where nearest-frontier gains most over the paper's
    /// split (C = 80, R = 20, ratio 2.5, trial 97), pinned with docs/results/dfs.md's numbers.
    #[test]
    fn nearest_frontier_gain_on_the_best_trial_is_pinned() {
        let conf = |allocation| Configuration {
            sweep: Sweep::Cells,
            sharing: Sharing::Gcs,
            allocation,
            cells: 80,
            robots: 20,
            speed_ratio: SpeedRatio::Ratio(2.5),
        };
        let p = run_trial(2019, 0, &conf(Allocation::Paper), 97).unwrap();
        let n = run_trial(2019, 0, &conf(Allocation::NearestFrontier), 97).unwrap();
        assert!((p.cost - 47.813).abs() < 1e-3, "{}", p.cost);
        assert!((n.cost - 27.975).abs() < 1e-3, "{}", n.cost);
        assert!(p.within_lemma1 && n.within_lemma1);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let mut a = small(0);
        assert!(run(&a, &|| {}).is_err());
        a.trials = 1;
        a.robots = vec![300];
        assert!(run(&a, &|| {}).is_err());
    }
}
