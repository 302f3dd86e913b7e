//! The bandit paper's Monte Carlo study (§VI, Tables I–IV, Fig. 5 and Fig. 6): Algorithm 1
//! with the IP planner of Algorithm 2, Bernoulli sensing and no vehicles.
//!
//! One trial:
//! 1. **Field** ([`Field::random`]): a `rows × cols` grid with `n_obstacles` obstacles drawn
//!    uniformly; layouts whose free cells are not all connected by drone moves are rejected and
//!    redrawn (the paper rejects layouts with an inaccessible interesting cell; we reject any
//!    inaccessible cell, since an unreachable uninteresting cell would never be classified and
//!    the trial would never end). No road restriction (R = G \ O, §VI). `n_interesting`
//!    interesting cells drawn uniformly from C; μ_l ~ U[μ_worst, 1] for interesting cells and
//!    U[0, 1 − μ_worst] for the others (§VI). N_c stations on distinct random free cells, drone
//!    i on station i mod N_c.
//! 2. **Epochs** ([`run_trial`]): goals by the chosen rule (UCB (3) for the paper's
//!    Algorithm 1); the fast IP (K up to `k_max`; if no plan exists within it, K is doubled, up
//!    to 64); each drone measures every unclassified cell along its path: its epoch path with
//!    consecutive repeats collapsed (a hover or a recharge at the same cell is one visit, also
//!    across epochs: an epoch's first cell is where the drone ended the previous epoch, the
//!    same visit, measured once), each visit giving B Bernoulli(μ_l) samples, for cells
//!    unclassified at the start of the epoch
//!    (§V: "at each unclassified cell along a sensor's path"); then (4); the team's final
//!    configuration is the next epoch's start (Algorithm 1's (X_0, Y_0) at epoch p + 1).
//! 3. **Outcome** ([`TrialResult`]): epochs until every truly interesting cell (μ ≥ θ) is
//!    classified, until every cell is, solve time per epoch (every attempt of the epoch, the
//!    infeasible ones at smaller K included), and labelling errors.
//!
//! Randomness: trial t of a study uses world seed = f(seed, t) for every variant, so variants
//! are compared on the same worlds; the sensing stream is seeded separately per variant (its
//! position in the preset's list, [`Study::streams`]) and trial.
//!
//! A study can be split into parts that run anywhere and join again ([`shard`]); what it writes
//! and prints, with the paper's row under each of ours, is in [`table`] and [`paper`].

pub mod bench;
pub mod cli;
pub mod fastplain;
mod field;
pub mod paper;
pub(crate) mod plot;
pub mod shard;
mod summary;
pub mod table;

pub use field::{Field, StudyError};
pub(crate) use summary::{Spread, VariantSummary, quantile, summarise};

use fleetmap_core::geo::Cell;
use fleetmap_core::planner::bandit::{BanditState, ConfidenceBound, Label, LogBase, p_max};
use fleetmap_core::planner::baselines::{GoalRule, choose_goals};
use fleetmap_core::planner::ip::{PlanOptions, PlanStatus, solve_instance};
use fleetmap_core::planner::plan::Timelines;
use fleetmap_core::planner::scenario::Instance;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Parameters of one variant of the study (defaults: the paper's §VI setup).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyConfig {
    /// Row label in the output (e.g. "mu_worst=0.8").
    pub label: String,
    /// Grid rows.
    pub rows: usize,
    /// Grid columns.
    pub cols: usize,
    /// |O|.
    pub n_obstacles: usize,
    /// Interesting cells per world.
    pub n_interesting: usize,
    /// μ^worst_{l,interest}.
    pub mu_worst: f64,
    /// N_d.
    pub nd: usize,
    /// N_c.
    pub nc: usize,
    /// D, epoch goals per epoch.
    pub d: usize,
    /// B, samples per cell visit.
    pub batch: u32,
    /// T_d.
    pub td: usize,
    /// T_c.
    pub tc: usize,
    /// θ.
    pub theta: f64,
    /// ε.
    pub epsilon: f64,
    /// δ.
    pub delta: f64,
    /// K given to the IP (doubled on infeasibility, up to 64).
    pub k_max: usize,
    /// Charger capacity C (none in §VI).
    pub capacity: Option<usize>,
    /// Give up a trial after this many epochs (reported as censored).
    pub max_epochs: usize,
    /// How epoch goals are chosen.
    pub rule: GoalRule,
    /// What counts as a visit that yields B measurements.
    pub sensing: Sensing,
    /// The base of `log` in (3b) (natural = the paper as written).
    pub log_base: LogBase,
    /// The confidence interval behind (3) and (4): the paper's (3b) by default (the study
    /// reproduces the paper), or the KL bound (`--bound kl`). Summaries written before the
    /// choice existed ran (3b).
    #[serde(default = "ConfidenceBound::paper")]
    pub bound: ConfidenceBound,
    /// Informative paths (improvement, not in the paper): among the plans with the fewest
    /// cycles, prefer those whose drones arrive often at unclassified cells
    /// ([`PlanOptions::visit_weights`] = 1 on unclassified cells).
    pub informative: bool,
}

/// What counts as one cell visit (B measurements) along a drone's path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sensing {
    /// Each arrival at a cell: the path with consecutive repeats collapsed, so hovering or
    /// recharging in place is one visit (the default: "each cell visit generates B
    /// realizations", §II).
    #[default]
    Visits,
    /// Each time step: a drone staying k steps on a cell measures it k times (sensitivity option).
    Steps,
}

impl Default for StudyConfig {
    fn default() -> Self {
        StudyConfig {
            label: "default".into(),
            rows: 10,
            cols: 10,
            n_obstacles: 16,
            n_interesting: 10,
            mu_worst: 0.8,
            nd: 10,
            nc: 5,
            d: 8,
            batch: 10,
            td: 8,
            tc: 4,
            theta: 0.5,
            epsilon: 0.05,
            delta: 1e-4,
            k_max: 8,
            capacity: None,
            max_epochs: 1000,
            rule: GoalRule::Ucb,
            sensing: Sensing::Visits,
            log_base: LogBase::Natural,
            bound: ConfidenceBound::Paper,
            informative: false,
        }
    }
}

/// The paper's tables and figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// Table I / Fig. 5: μ_worst ∈ {0.6, 0.8, 1.0}.
    Table1,
    /// Table II: D ∈ {5, 8, 10, 15}.
    Table2,
    /// Table III: (T_d, T_c) over 9 agility settings.
    Table3,
    /// Table IV: (N_d, N_c) ∈ {(5,5), (7,7), (10,5), (10,10), (14,7)}.
    Table4,
    /// Fig. 6: D = N_d = 10; UCB against Random, GreedyCov, GreedyTrav, and the improved APT.
    Fig6,
    /// The improvements next to the faithful planner at Table I's default row: UCB (the
    /// paper), APT goals, informative paths, and both.
    Compare,
}

impl Preset {
    /// The variants (rows) of the preset, in the paper's order.
    pub fn variants(self) -> Vec<StudyConfig> {
        let base = StudyConfig::default();
        let with = |label: String, f: &dyn Fn(&mut StudyConfig)| {
            let mut c = base.clone();
            c.label = label;
            f(&mut c);
            c
        };
        match self {
            Preset::Table1 => [0.6, 0.8, 1.0]
                .iter()
                .map(|&m| with(format!("mu_worst={m}"), &|c| c.mu_worst = m))
                .collect(),
            Preset::Table2 => [5, 8, 10, 15]
                .iter()
                .map(|&d| with(format!("D={d}"), &|c| c.d = d))
                .collect(),
            Preset::Table3 => [
                (8, 4),
                (12, 4),
                (16, 4),
                (12, 6),
                (18, 6),
                (24, 6),
                (16, 8),
                (24, 8),
                (32, 8),
            ]
            .iter()
            .map(|&(td, tc)| {
                with(format!("Td={td},Tc={tc}"), &|c| {
                    c.td = td;
                    c.tc = tc
                })
            })
            .collect(),
            Preset::Table4 => [(5, 5), (7, 7), (10, 5), (10, 10), (14, 7)]
                .iter()
                .map(|&(nd, nc)| {
                    with(format!("Nd={nd},Nc={nc}"), &|c| {
                        c.nd = nd;
                        c.nc = nc
                    })
                })
                .collect(),
            Preset::Fig6 => [
                GoalRule::Ucb,
                GoalRule::Random,
                GoalRule::GreedyCov,
                GoalRule::GreedyTrav,
                GoalRule::Apt,
            ]
            .iter()
            .map(|&r| {
                with(r.name().to_string(), &|c| {
                    c.d = 10;
                    c.rule = r
                })
            })
            .collect(),
            Preset::Compare => [
                (GoalRule::Ucb, false),
                (GoalRule::Apt, false),
                (GoalRule::Ucb, true),
                (GoalRule::Apt, true),
            ]
            .iter()
            .map(|&(r, info)| {
                let label = if info {
                    format!("{}+informative", r.name())
                } else {
                    r.name().to_string()
                };
                with(label, &|c| {
                    c.rule = r;
                    c.informative = info
                })
            })
            .collect(),
        }
    }

    /// The preset's name (`table1`, …).
    pub fn name(self) -> &'static str {
        match self {
            Preset::Table1 => "table1",
            Preset::Table2 => "table2",
            Preset::Table3 => "table3",
            Preset::Table4 => "table4",
            Preset::Fig6 => "fig6",
            Preset::Compare => "compare",
        }
    }
}

/// One epoch of a trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpochRecord {
    /// Epoch p (0-based).
    pub epoch: usize,
    /// Wall time of the IP solve, in seconds (all K tried, re-pairing included).
    pub solve_seconds: f64,
    /// Sensing cycles of the plan.
    pub cycles: usize,
    /// Epoch goals.
    pub goals: usize,
    /// Integer variables of the deciding model.
    pub variables: usize,
    /// Truly interesting cells classified after this epoch (in K or R).
    pub(crate) interesting_classified: usize,
    /// Truly uninteresting cells classified after this epoch.
    pub(crate) uninteresting_classified: usize,
    /// Batches of B measurements taken this epoch (at unclassified cells).
    pub batches: usize,
}

/// The outcome of one trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialResult {
    /// Variant label.
    pub label: String,
    /// Trial number.
    pub trial: usize,
    /// Field seed.
    pub world_seed: u64,
    /// Epochs until every interesting cell was classified (`None`: censored).
    pub epochs_interesting: Option<usize>,
    /// Epochs until every cell was classified (`None`: censored at `max_epochs`).
    pub epochs_all: Option<usize>,
    /// Interesting cells (μ ≥ θ + ε) put in R, and uninteresting ones (μ ≤ θ − ε) put in K.
    pub label_errors: usize,
    /// Number of interesting cells (μ ≥ θ) in the world.
    pub n_interesting: usize,
    /// Number of candidate cells |C|.
    pub(crate) n_cells: usize,
    /// Per-epoch records.
    pub epochs: Vec<EpochRecord>,
    /// Set when the trial stopped on a planner failure (message).
    pub failure: Option<String>,
    /// P_max of Proposition 2 ((12)–(14)) for this world's μ: the epochs within which
    /// Algorithm 1 terminates with probability ≥ 1 − δ. Only for the bound it is proved for,
    /// (3b) with natural logarithms; `None` otherwise (and in results written before it).
    #[serde(default)]
    pub p_max: Option<f64>,
}

/// A stable 64-bit mix (SplitMix64 finaliser) to derive per-trial seeds.
pub fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The cells a drone path visits in an epoch: consecutive repeats collapsed.
pub fn visits(path: &[usize]) -> Vec<usize> {
    let mut v: Vec<usize> = Vec::with_capacity(path.len());
    for &c in path {
        if v.last() != Some(&c) {
            v.push(c);
        }
    }
    v
}

/// The cells a drone measures along its epoch `path` (one B-sample batch each): every visit
/// (`Sensing::Visits`) or every step (`Sensing::Steps`). With `continues`, the path's first
/// cell is where the drone ended the previous epoch, at the same instant: that visit was
/// measured then, so it is not measured again.
pub(crate) fn sensed_cells(path: &[usize], sensing: Sensing, continues: bool) -> Vec<usize> {
    let mut cells = match sensing {
        Sensing::Visits => visits(path),
        Sensing::Steps => path.to_vec(),
    };
    if continues && !cells.is_empty() {
        cells.remove(0);
    }
    cells
}

/// Run Algorithm 1 on `world` until every cell is classified or `cfg.max_epochs`.
/// `on_epoch` sees every epoch's instance and outcome (for benchmarks and scenario dumps).
pub fn run_trial(
    cfg: &StudyConfig,
    world: &Field,
    label: &str,
    trial: usize,
    world_seed: u64,
    sensing_seed: u64,
    mut on_epoch: impl FnMut(&Instance, &fleetmap_core::planner::ip::PlanOutcome),
) -> TrialResult {
    let g = &world.grid;
    let mut rng = ChaCha8Rng::seed_from_u64(sensing_seed);
    let cells: Vec<Cell> = g.free_cells().into_iter().map(|i| g.cell(i)).collect();
    let mut result = TrialResult {
        label: label.to_string(),
        trial,
        world_seed,
        epochs_interesting: None,
        epochs_all: None,
        label_errors: 0,
        n_interesting: world.interesting.iter().filter(|&&b| b).count(),
        n_cells: cells.len(),
        epochs: Vec::new(),
        failure: None,
        p_max: None,
    };
    let mut state = match BanditState::new(cells, cfg.theta, cfg.epsilon, cfg.delta) {
        Ok(mut s) => {
            s.log_base = cfg.log_base;
            s.bound = cfg.bound;
            s
        }
        Err(e) => {
            result.failure = Some(e.to_string());
            return result;
        }
    };
    // Candidate index → dense grid index.
    let dense: Vec<usize> = state
        .cells
        .iter()
        .map(|&c| g.index(c).unwrap_or(0))
        .collect();
    let mut cand_of = vec![usize::MAX; g.len()];
    for (l, &i) in dense.iter().enumerate() {
        cand_of[i] = l;
    }
    if cfg.bound == ConfidenceBound::Paper && cfg.log_base == LogBase::Natural {
        let mu: Vec<f64> = dense.iter().map(|&i| world.mu[i]).collect();
        result.p_max = Some(p_max(
            &mu,
            cfg.theta,
            cfg.epsilon,
            cfg.delta,
            cfg.batch,
            cfg.d,
        ));
    }
    let (mut drones, mut stations) = (world.drones.clone(), world.stations.clone());
    let mut opts = PlanOptions::default();
    // Whether each drone's cell at the start of this epoch was already measured, as the end
    // of the previous epoch's path: the same visit (the same instant), not a second one.
    let mut measured_start = vec![false; drones.len()];
    for epoch in 0..cfg.max_epochs {
        if state.is_done() {
            break;
        }
        if cfg.informative {
            let mut w = vec![0.0; g.len()];
            for (l, &i) in dense.iter().enumerate() {
                if state.is_unclassified(l) {
                    w[i] = 1.0;
                }
            }
            opts.visit_weights = Some(w);
        }
        let team: Vec<usize> = drones.iter().chain(&stations).copied().collect();
        let goals: Vec<usize> = choose_goals(cfg.rule, &state, cfg.d, g, &team, &mut rng)
            .into_iter()
            .map(|l| dense[l])
            .collect();
        let mut k = cfg.k_max;
        // Solve time of the epoch: every attempt, the infeasible ones at smaller K included.
        let mut secs = 0.0;
        let (outcome, timelines, n_goals) = loop {
            let inst = match Instance::new(
                g.clone(),
                drones.clone(),
                stations.clone(),
                goals.clone(),
                cfg.td,
                cfg.tc,
                k,
                cfg.capacity,
            ) {
                Ok(i) => i,
                Err(e) => {
                    result.failure = Some(e.to_string());
                    return result;
                }
            };
            let out = solve_instance(&inst, &opts, &fleetmap_io::clock::stopwatch());
            secs += out.solve_seconds;
            on_epoch(&inst, &out);
            match (&out.status, &out.plan) {
                (PlanStatus::Optimal, Some(plan)) => {
                    let Some(t) = Timelines::from_plan(plan, &inst) else {
                        result.failure = Some("plan does not chain".into());
                        return result;
                    };
                    break (out.clone(), t, inst.goals.len());
                }
                (PlanStatus::Infeasible, _) if k < 64 => k *= 2,
                _ => {
                    result.failure = Some(format!(
                        "epoch {epoch}: planner {} ({})",
                        out.status.as_str(),
                        out.message
                    ));
                    return result;
                }
            }
        };
        // Measurements along every drone's path, for cells unclassified at the epoch start.
        let mut measured = 0usize;
        for (i, path) in timelines.drones.iter().enumerate() {
            let continues = measured_start.get(i).copied().unwrap_or(false);
            for c in sensed_cells(path, cfg.sensing, continues) {
                let l = cand_of[c];
                if l == usize::MAX || !state.is_unclassified(l) {
                    continue;
                }
                let mu = world.mu[c];
                let ones = (0..cfg.batch).filter(|_| rng.random_bool(mu)).count() as u64;
                state.record(l, ones, cfg.batch as u64);
                measured += 1;
            }
        }
        state.update();
        measured_start = vec![true; timelines.drones.len()];
        drones = timelines.drones.iter().map(|p| p[p.len() - 1]).collect();
        stations = timelines.stations.iter().map(|p| p[p.len() - 1]).collect();
        let (mut ci, mut cu) = (0, 0);
        for (l, &i) in dense.iter().enumerate() {
            if !state.is_unclassified(l) {
                if world.interesting[i] {
                    ci += 1
                } else {
                    cu += 1
                }
            }
        }
        result.epochs.push(EpochRecord {
            epoch,
            solve_seconds: secs,
            cycles: outcome.plan.as_ref().map_or(0, |p| p.cycles),
            goals: n_goals,
            variables: outcome.variables,
            interesting_classified: ci,
            uninteresting_classified: cu,
            batches: measured,
        });
        if result.epochs_interesting.is_none() && ci == result.n_interesting {
            result.epochs_interesting = Some(epoch + 1);
        }
    }
    if state.is_done() {
        result.epochs_all = Some(result.epochs.len());
        if result.epochs_interesting.is_none() {
            result.epochs_interesting = Some(result.epochs.len());
        }
    }
    for (l, &i) in dense.iter().enumerate() {
        let mu = world.mu[i];
        match state.labels[l] {
            Label::Reject if mu >= cfg.theta + cfg.epsilon => result.label_errors += 1,
            Label::Keep if mu <= cfg.theta - cfg.epsilon => result.label_errors += 1,
            _ => {}
        }
    }
    result
}

/// A study: the variants of a preset, the trials per variant and the seed. Trial t of every
/// variant runs on the same world ([`run_seeded`]), so any subset of the trials can run
/// anywhere (a [`shard::Shard`]) and the parts join into the same study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Study {
    /// The table or figure.
    pub preset: Preset,
    /// Study seed.
    pub seed: u64,
    /// Trials per variant.
    pub trials: usize,
    /// The variants (rows), in order.
    pub variants: Vec<StudyConfig>,
    /// Each variant's sensing stream ([`run_seeded`]'s `variant`): its position in the
    /// preset's full list, so that a row picked alone (`--only`) measures exactly as it does
    /// in the whole table. Empty: the variants' positions in `variants`.
    #[serde(default)]
    pub streams: Vec<usize>,
}

impl Study {
    /// The (variant, trial) pairs of `shard`, variant-major.
    pub fn tasks(&self, shard: shard::Shard) -> Vec<(usize, usize)> {
        (0..self.variants.len())
            .flat_map(|v| {
                (0..self.trials)
                    .filter(move |&t| shard.holds(t))
                    .map(move |t| (v, t))
            })
            .collect()
    }

    /// The same study with [`Study::streams`] spelled out (empty: the positions), so parts
    /// written either way compare equal.
    pub(crate) fn normalized(mut self) -> Study {
        if self.streams.is_empty() {
            self.streams = (0..self.variants.len()).collect();
        }
        self
    }

    /// Run trial `trial` of variant `variant`.
    pub fn run(&self, variant: usize, trial: usize) -> TrialResult {
        let stream = self.streams.get(variant).copied().unwrap_or(variant);
        run_seeded(&self.variants[variant], self.seed, trial, stream)
    }

    /// One summary per variant, with the paper's row beside it.
    pub(crate) fn summarise(&self, results: &[TrialResult]) -> Vec<VariantSummary> {
        self.variants
            .iter()
            .map(|cfg| {
                let mine: Vec<TrialResult> = results
                    .iter()
                    .filter(|r| r.label == cfg.label)
                    .cloned()
                    .collect();
                let mut s = summarise(cfg, &mine);
                s.paper = paper::row_for(self.preset, cfg);
                s
            })
            .collect()
    }
}

/// Run trial `trial` of `cfg` for a study seeded with `seed` (world seed shared by variants).
pub fn run_seeded(cfg: &StudyConfig, seed: u64, trial: usize, variant: usize) -> TrialResult {
    let world_seed = mix(seed ^ mix(trial as u64));
    let sensing_seed = mix(world_seed ^ mix(0x5EED ^ variant as u64));
    let mut rng = ChaCha8Rng::seed_from_u64(world_seed);
    match Field::random(cfg, &mut rng) {
        Ok(world) => run_trial(
            cfg,
            &world,
            &cfg.label,
            trial,
            world_seed,
            sensing_seed,
            |_, _| {},
        ),
        Err(e) => TrialResult {
            label: cfg.label.clone(),
            trial,
            world_seed,
            epochs_interesting: None,
            epochs_all: None,
            label_errors: 0,
            n_interesting: 0,
            n_cells: 0,
            epochs: Vec::new(),
            failure: Some(e.to_string()),
            p_max: None,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_like_numpy() {
        let v = [1.0, 2.0, 3.0, 4.0, 10.0];
        assert_eq!(quantile(&v, 0.5), Some(3.0));
        assert!((quantile(&v, 0.9).unwrap() - 7.6).abs() < 1e-12);
        assert!((quantile(&v, 0.1).unwrap() - 1.4).abs() < 1e-12);
        assert_eq!(quantile(&[], 0.5), None);
    }

    #[test]
    fn worlds_follow_section_vi() {
        let cfg = StudyConfig::default();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let w = Field::random(&cfg, &mut rng).unwrap();
        assert_eq!((0..100).filter(|&i| w.grid.is_blocked(i)).count(), 16);
        assert!(w.grid.free_cells_connected());
        assert_eq!(w.interesting.iter().filter(|&&b| b).count(), 10);
        for i in w.grid.free_cells() {
            let m = w.mu[i];
            assert!(if w.interesting[i] {
                m >= 0.8
            } else {
                m <= 0.2 + 1e-12
            });
        }
        assert_eq!(w.drones.len(), 10);
        assert!(w.drones.iter().all(|d| w.stations.contains(d)));
        let d = Field::default_10x10(0.8, 0.5, &mut rng);
        assert_eq!(d.interesting.iter().filter(|&&b| b).count(), 10);
        assert!(d.grid.free_cells_connected());
    }

    #[test]
    fn visits_collapse_hovers() {
        assert_eq!(visits(&[1, 1, 2, 2, 1, 3, 3]), vec![1, 2, 1, 3]);
    }

    #[test]
    fn a_drone_parked_across_two_epochs_is_one_visit() {
        // Epoch p ends on station cell 3; epoch p + 1 starts there (the same instant).
        let (end_of_p, next) = ([1, 2, 3, 3], [3, 3, 4, 3]);
        assert_eq!(
            sensed_cells(&end_of_p, Sensing::Visits, false),
            vec![1, 2, 3]
        );
        assert_eq!(sensed_cells(&next, Sensing::Visits, true), vec![4, 3]);
        assert_eq!(sensed_cells(&next, Sensing::Steps, true), vec![3, 4, 3]);
        assert_eq!(sensed_cells(&[5], Sensing::Visits, false), vec![5]);
    }
}
