//! Fast = plain at the bandit paper's scale: the reformulated integer
//! program of [`fleetmap_core::planner::ip::fast`] against the paper's model as printed
//! ([`fleetmap_core::planner::ip::plain`]) on random epochs of Algorithm 1.
//!
//! The small random scenarios of `tests/suite/planner.rs` cannot show an over-pruned fast model at
//! the scale the paper flies: 10 × 10 cells, N_d = 10 drones, N_c = 5 stations,
//! (T_d, T_c) = (8, 4) and a charger capacity C ≥ 2 that lets drones share a station. A fast
//! model that removed a feasible plan would not produce an invalid plan — it would need more
//! cycles than the optimum, or call a feasible epoch infeasible. So both models solve the same
//! instances and the comparison is on the status and the optimal number of cycles, with every
//! plan of both through the independent checker ([`fleetmap_core::planner::check`]).
//!
//! **Instances** (`generate`): the problems Algorithm 1 actually hands to the IP, not fresh
//! starts only. Instance n draws a world of the §VI study ([`Field::random`]: obstacles, μ,
//! stations, drone i on station i mod N_c), runs Algorithm 1 on it with capacity C for a random
//! number of epochs p (the fast model plans those epochs, so the team stands wherever p epochs
//! of sorties left it, drones stacked on stations up to C) and takes epoch p's instance. Two
//! goal sets alternate:
//! * [`GoalSet::Epoch`]: epoch p's UCB goals (3), as Algorithm 1 chose them;
//! * [`GoalSet::Far`]: D goals placed greedily as far as possible from the team and from each
//!   other (farthest-point order on king's-move distance) — the epochs that need several
//!   cycles, where pruning by "can still get back to a station" matters most.
//!
//! The bound K on the cycles cycles through the configured values (default 1, 2, 3), so the
//! sample holds epochs feasible within K and epochs proven infeasible within K.
//!
//! **Verdicts** ([`Verdict`]): the same status and, with a plan, the same number of cycles —
//! for (11) the objective Σλ_k *is* the number of cycles, so "same objective" and "same
//! cycles" are one test — and every plan accepted by the checker: [`Verdict::Same`]. A solve
//! stopped by its time limit is [`Verdict::Unknown`], not a difference (a time-limited plain
//! solve proves nothing either way). Anything else, including a solver error or a plan the
//! checker rejects, is a [`Verdict::Difference`].
//!
//! C = 1 cannot hold 10 drones on 5 stations (eq. (10) at the start of every cycle: at most
//! C · N_c drones can stand on chargers), so for C · N_c < N_d the team is cut to C · N_c drones
//! (`effective_drones`); the row records the team that ran.
//!
//! No file, and no clock read of its own: the caller passes the clock that times each
//! compared solve (as [`solve_instance`] wants) and receives each row as it is decided. (The
//! epochs before an instance are planned by the study's [`run_trial`], which times them with
//! its own stopwatch; those times are discarded and never change a plan.)

use super::{Field, Spread, StudyConfig, mix, run_trial};
use fleetmap_core::planner::check::{CheckOptions, check_plan_with};
use fleetmap_core::planner::ip::{Model, PlanOptions, PlanOutcome, PlanStatus, solve_instance};
use fleetmap_core::planner::scenario::Instance;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The parameters of a comparison (defaults: the paper's §VI setting).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FastPlainConfig {
    /// Instances per capacity.
    pub instances: usize,
    /// The charger capacities C of eq. (10) to compare at.
    pub capacities: Vec<usize>,
    /// Seed of everything random (worlds, epochs, sensing).
    pub seed: u64,
    /// HiGHS time limit per solve, seconds (each model separately); `None` = none.
    pub time_limit: Option<f64>,
    /// Grid rows and columns.
    pub size: usize,
    /// Obstacles per world.
    pub obstacles: usize,
    /// N_d (cut to C · N_c when C is too small to hold them, `effective_drones`).
    pub drones: usize,
    /// N_c.
    pub stations: usize,
    /// D, goals per epoch.
    pub goals: usize,
    /// T_d, drone steps per sensing cycle.
    pub td: usize,
    /// T_c, station steps per sensing cycle.
    pub tc: usize,
    /// The bounds K given to both models; instance n uses `cycles[n mod len]`.
    pub cycles: Vec<usize>,
    /// Epoch p of instance n is drawn uniformly from 0 ..= `max_epoch`.
    pub max_epoch: usize,
}

impl Default for FastPlainConfig {
    fn default() -> Self {
        FastPlainConfig {
            instances: 50,
            capacities: vec![1, 2, 3],
            seed: 1,
            time_limit: Some(120.0),
            size: 10,
            obstacles: 16,
            drones: 10,
            stations: 5,
            goals: 8,
            td: 8,
            tc: 4,
            cycles: vec![1, 2, 3],
            max_epoch: 12,
        }
    }
}

/// Why a comparison could not run.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FastPlainError {
    /// The configuration cannot produce instances.
    #[error("impossible fast-plain configuration: {0}")]
    Config(String),
    /// Algorithm 1 failed while producing an instance's epoch.
    #[error("instance {index} (C = {capacity}): {reason}")]
    Generate {
        /// Instance number.
        index: usize,
        /// Capacity.
        capacity: usize,
        /// What failed.
        reason: String,
    },
}

/// Which goals an instance asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GoalSet {
    /// Algorithm 1's UCB goals of the epoch.
    Epoch,
    /// D cells as far as possible from the team and from each other.
    Far,
}

impl GoalSet {
    /// The name in tables and CSV.
    pub fn name(self) -> &'static str {
        match self {
            GoalSet::Epoch => "epoch",
            GoalSet::Far => "far",
        }
    }
}

/// One generated instance and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Generated {
    /// Instance number within its capacity.
    pub index: usize,
    /// C.
    pub capacity: usize,
    /// The goal set.
    pub goal_set: GoalSet,
    /// The epoch p of Algorithm 1 whose team (and, for [`GoalSet::Epoch`], goals) it is.
    pub epoch: usize,
    /// Seed of the world.
    pub world_seed: u64,
    /// The instance both models solve.
    pub instance: Instance,
}

/// The drones that fit: N_d, or C · N_c when fewer drones than N_d can stand on the chargers
/// at a cycle boundary (eq. (9d) with (10)).
pub(crate) fn effective_drones(drones: usize, stations: usize, capacity: usize) -> usize {
    drones.min(capacity.saturating_mul(stations))
}

fn study_config(cfg: &FastPlainConfig, capacity: usize) -> StudyConfig {
    let cells = cfg.size * cfg.size;
    StudyConfig {
        label: format!("fast-plain C={capacity}"),
        rows: cfg.size,
        cols: cfg.size,
        n_obstacles: cfg.obstacles,
        // The §VI share of interesting cells (10 of 100), at least one.
        n_interesting: (cells / 10).max(1),
        nd: effective_drones(cfg.drones, cfg.stations, capacity),
        nc: cfg.stations,
        d: cfg.goals,
        td: cfg.td,
        tc: cfg.tc,
        capacity: Some(capacity),
        ..StudyConfig::default()
    }
}

/// Check what the generator relies on.
pub fn validate(cfg: &FastPlainConfig) -> Result<(), FastPlainError> {
    let bad = |m: String| Err(FastPlainError::Config(m));
    if cfg.capacities.is_empty() || cfg.capacities.contains(&0) {
        return bad("capacities must be a non-empty list of values ≥ 1".into());
    }
    if cfg.cycles.is_empty() || cfg.cycles.contains(&0) {
        return bad("cycles (K) must be a non-empty list of values ≥ 1".into());
    }
    if cfg.drones == 0 || cfg.stations == 0 || cfg.goals == 0 {
        return bad("drones, stations and goals must be at least 1".into());
    }
    if cfg.td < 2 || cfg.tc < 2 || !cfg.td.is_multiple_of(cfg.tc) {
        return bad(format!(
            "Td = {} and Tc = {}: both at least 2, Td a multiple of Tc",
            cfg.td, cfg.tc
        ));
    }
    let cells = cfg.size * cfg.size;
    if cfg.obstacles + cfg.stations.max(cfg.goals).max(cells / 10) > cells {
        return bad(format!(
            "{} obstacles, {} stations and {} goals do not fit a {}×{} grid",
            cfg.obstacles, cfg.stations, cfg.goals, cfg.size, cfg.size
        ));
    }
    if let Some(t) = cfg.time_limit
        && !(t > 0.0 && t.is_finite())
    {
        return bad(format!("time limit {t} s: must be a positive number"));
    }
    Ok(())
}

/// Up to `d` free cells in farthest-point order: each next goal is the free cell farthest
/// (king's moves through free cells) from the team and the goals chosen so far; ties go to
/// the lowest cell index. Cells the team cannot reach are never chosen.
pub(crate) fn far_goals(inst: &Instance, d: usize) -> Vec<usize> {
    let g = &inst.grid;
    let mut sources: Vec<usize> = inst.drones.iter().chain(&inst.stations).copied().collect();
    let reachable = g.distances(&sources, false);
    let mut goals = Vec::with_capacity(d);
    while goals.len() < d {
        let dist = g.distances(&sources, false);
        let best = g
            .free_cells()
            .into_iter()
            .filter(|&i| reachable[i] != u32::MAX && dist[i] > 0 && dist[i] != u32::MAX)
            .max_by_key(|&i| (dist[i], std::cmp::Reverse(i)));
        match best {
            Some(i) => {
                goals.push(i);
                sources.push(i);
            }
            None => break,
        }
    }
    goals.sort_unstable();
    goals
}

/// Instance `index` at capacity `capacity` (see the module documentation). Deterministic in
/// (`cfg.seed`, `capacity`, `index`): the plans of the epochs before it are the fast model's
/// optimal plans, which depend on no clock (only a time limit could make them, and
/// Algorithm 1 runs without one here).
pub(crate) fn generate(
    cfg: &FastPlainConfig,
    capacity: usize,
    index: usize,
) -> Result<Generated, FastPlainError> {
    let err = |reason: String| FastPlainError::Generate {
        index,
        capacity,
        reason,
    };
    let world_seed = mix(cfg.seed ^ mix(((capacity as u64) << 32) ^ index as u64));
    let mut rng = ChaCha8Rng::seed_from_u64(world_seed);
    let mut study = study_config(cfg, capacity);
    let world = Field::random(&study, &mut rng).map_err(|e| err(e.to_string()))?;
    let epoch = rng.random_range(0..=cfg.max_epoch);
    study.max_epochs = epoch + 1;
    // The first attempt of every epoch is the one with K = k_max (run_trial doubles K only
    // after an infeasible attempt); the last such attempt is epoch p's instance.
    let mut last: Option<Instance> = None;
    let k_first = study.k_max;
    let trial = run_trial(
        &study,
        &world,
        &study.label,
        index,
        world_seed,
        mix(world_seed ^ 0xFA57),
        |inst, _| {
            if inst.k_max == k_first {
                last = Some(inst.clone());
            }
        },
    );
    if let Some(f) = trial.failure {
        return Err(err(format!("Algorithm 1 before the instance: {f}")));
    }
    let mut instance = last.ok_or_else(|| err("Algorithm 1 planned no epoch".into()))?;
    let epoch = trial.epochs.len().saturating_sub(1);
    let goal_set = if index.is_multiple_of(2) {
        GoalSet::Epoch
    } else {
        GoalSet::Far
    };
    if goal_set == GoalSet::Far {
        let goals = far_goals(&instance, cfg.goals);
        instance = Instance::new(
            instance.grid.clone(),
            instance.drones.clone(),
            instance.stations.clone(),
            goals,
            instance.td,
            instance.tc,
            instance.k_max,
            instance.capacity,
        )
        .map_err(|e| err(e.to_string()))?;
    }
    instance.k_max = cfg.cycles[index % cfg.cycles.len()];
    Ok(Generated {
        index,
        capacity,
        goal_set,
        epoch,
        world_seed,
        instance,
    })
}

/// One model's answer on one instance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Solved {
    /// The status ("optimal", "infeasible", "time_limit", "error").
    pub status: PlanStatus,
    /// Sensing cycles of the plan = the objective of (11); `None` without a plan.
    pub cycles: Option<usize>,
    /// Wall time of the solve (every K' the fast model tried, model building included), s.
    pub seconds: f64,
    /// Integer variables of the deciding model.
    pub variables: usize,
    /// `Some(true)` if the plan passed the independent checker, `Some(false)` if it failed
    /// (or the solver's own check rejected it), `None` without a plan.
    pub checker: Option<bool>,
    /// The solver's message (errors, checker violations), empty otherwise.
    pub message: String,
}

impl Solved {
    fn of(inst: &Instance, out: &PlanOutcome) -> Solved {
        // solve_instance already refuses a plan the checker rejects (status Error): count it
        // as a checker failure; otherwise check the returned plan again here, with the
        // head-on-swap rule the re-paired plans must also satisfy.
        let (checker, message) = match &out.plan {
            Some(plan) => match check_plan_with(
                inst,
                plan,
                CheckOptions {
                    no_head_on_swaps: true,
                },
            ) {
                Ok(()) => (Some(true), out.message.clone()),
                Err(e) => (Some(false), e.to_string()),
            },
            None if out.message.contains("checker") => (Some(false), out.message.clone()),
            None => (None, out.message.clone()),
        };
        Solved {
            status: out.status,
            cycles: out.plan.as_ref().map(|p| p.cycles),
            seconds: out.solve_seconds,
            variables: out.variables,
            checker,
            message,
        }
    }
}

/// How the two models compare on one instance.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "verdict", content = "reason", rename_all = "lowercase")]
pub enum Verdict {
    /// Same status, same cycles, every plan valid.
    Same,
    /// A time limit stopped a solve: no conclusion (which model, in the reason).
    Unknown(String),
    /// The models disagree or a plan is invalid (what, in the reason).
    Difference(String),
}

/// Compare two answers (see the module documentation for the rules).
pub fn verdict(fast: &Solved, plain: &Solved) -> Verdict {
    let mut bad = Vec::new();
    for (name, s) in [("fast", fast), ("plain", plain)] {
        if s.checker == Some(false) {
            bad.push(format!("the {name} plan fails the checker: {}", s.message));
        }
        if s.status == PlanStatus::Error {
            bad.push(format!("the {name} solver failed: {}", s.message));
        }
    }
    if !bad.is_empty() {
        return Verdict::Difference(bad.join("; "));
    }
    let limited: Vec<&str> = [("fast", fast), ("plain", plain)]
        .iter()
        .filter(|(_, s)| s.status == PlanStatus::TimeLimit)
        .map(|(n, _)| *n)
        .collect();
    if !limited.is_empty() {
        return Verdict::Unknown(format!("time limit: {}", limited.join(", ")));
    }
    if fast.status != plain.status {
        return Verdict::Difference(format!(
            "status: fast {}, plain {}",
            fast.status.as_str(),
            plain.status.as_str()
        ));
    }
    if fast.cycles != plain.cycles {
        let show = |c: Option<usize>| c.map_or("-".to_string(), |c| c.to_string());
        return Verdict::Difference(format!(
            "cycles: fast {}, plain {}",
            show(fast.cycles),
            show(plain.cycles)
        ));
    }
    Verdict::Same
}

/// One instance of the comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Instance number within its capacity.
    pub index: usize,
    /// C.
    pub capacity: usize,
    /// The goal set.
    pub goal_set: GoalSet,
    /// Algorithm 1's epoch p the team comes from.
    pub epoch: usize,
    /// Seed of the world.
    pub world_seed: u64,
    /// N_d of the instance.
    pub drones: usize,
    /// |E_p| of the instance.
    pub goals: usize,
    /// The bound K both models were given.
    pub k_max: usize,
    /// The fast model's answer.
    pub fast: Solved,
    /// The plain model's answer.
    pub plain: Solved,
    /// The comparison.
    pub verdict: Verdict,
    /// The instance as a scenario file (docs/ip-scenario.md) when the verdict is a
    /// difference or unknown, so it can be replayed with `fleetmap plan --scenario` (e.g. the
    /// plain model with a longer `--time-limit`).
    pub scenario: Option<String>,
}

/// Solve `generated` with both models and compare. `clock` is the solve-time clock (seconds on a
/// monotonic timeline, as [`solve_instance`] takes it).
pub fn compare(generated: &Generated, time_limit: Option<f64>, clock: &dyn Fn() -> f64) -> Row {
    let inst = &generated.instance;
    let base = PlanOptions {
        time_limit,
        ..PlanOptions::default()
    };
    let fast_out = solve_instance(inst, &base, clock);
    let plain_out = solve_instance(
        inst,
        &PlanOptions {
            model: Model::Plain,
            ..base
        },
        clock,
    );
    let fast = Solved::of(inst, &fast_out);
    let plain = Solved::of(inst, &plain_out);
    let verdict = verdict(&fast, &plain);
    let scenario = (verdict != Verdict::Same).then(|| {
        inst.to_scenario(&format!(
            "fast-plain: C={}, instance {}, world seed {}",
            generated.capacity, generated.index, generated.world_seed
        ))
        .to_json()
    });
    Row {
        index: generated.index,
        capacity: generated.capacity,
        goal_set: generated.goal_set,
        epoch: generated.epoch,
        world_seed: generated.world_seed,
        drones: inst.nd(),
        goals: inst.goals.len(),
        k_max: inst.k_max,
        fast,
        plain,
        verdict,
        scenario,
    }
}

/// Totals of a comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Instances compared.
    pub instances: usize,
    /// Instances with a difference.
    pub differences: usize,
    /// Instances with a time-limited solve.
    pub unknown: usize,
    /// Instances both models solved to optimality (same cycles).
    pub optimal: usize,
    /// Instances both models proved infeasible within K.
    pub infeasible: usize,
    /// Of `optimal`, those needing ≥ 2 cycles.
    pub(crate) multi_cycle: usize,
    /// Plans that went through the checker (both models), and how many failed.
    pub plans_checked: usize,
    /// Plans the checker rejected.
    pub plans_rejected: usize,
    /// Fast-model solve time per instance, seconds.
    pub(crate) fast_seconds: Option<Spread>,
    /// Plain-model solve time per instance, seconds.
    pub(crate) plain_seconds: Option<Spread>,
    /// Longest fast and plain solve, seconds.
    pub(crate) max_seconds: (f64, f64),
    /// plain ÷ fast solve time per instance (decided instances only).
    pub speedup: Option<Spread>,
}

/// Summarise rows.
pub(crate) fn summarise(rows: &[Row]) -> Summary {
    let count = |f: &dyn Fn(&Row) -> bool| rows.iter().filter(|r| f(r)).count();
    let same = |r: &Row| r.verdict == Verdict::Same;
    let fast: Vec<f64> = rows.iter().map(|r| r.fast.seconds).collect();
    let plain: Vec<f64> = rows.iter().map(|r| r.plain.seconds).collect();
    let ratio: Vec<f64> = rows
        .iter()
        .filter(|r| same(r) && r.fast.seconds > 0.0)
        .map(|r| r.plain.seconds / r.fast.seconds)
        .collect();
    let checks = rows
        .iter()
        .flat_map(|r| [r.fast.checker, r.plain.checker])
        .flatten();
    let (mut checked, mut rejected) = (0, 0);
    for ok in checks {
        checked += 1;
        if !ok {
            rejected += 1;
        }
    }
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    Summary {
        instances: rows.len(),
        differences: count(&|r| matches!(r.verdict, Verdict::Difference(_))),
        unknown: count(&|r| matches!(r.verdict, Verdict::Unknown(_))),
        optimal: count(&|r| same(r) && r.fast.status == PlanStatus::Optimal),
        infeasible: count(&|r| same(r) && r.fast.status == PlanStatus::Infeasible),
        multi_cycle: count(&|r| same(r) && r.fast.cycles.is_some_and(|c| c >= 2)),
        plans_checked: checked,
        plans_rejected: rejected,
        fast_seconds: Spread::of(&fast),
        plain_seconds: Spread::of(&plain),
        max_seconds: (max(&fast), max(&plain)),
        speedup: Spread::of(&ratio),
    }
}

/// A whole comparison: the configuration, every row, the totals overall and per capacity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Study {
    /// What ran.
    pub config: FastPlainConfig,
    /// One per instance, capacity by capacity.
    pub rows: Vec<Row>,
    /// Totals over every row.
    pub summary: Summary,
    /// Totals per capacity, in `config.capacities` order.
    pub(crate) per_capacity: Vec<(usize, Summary)>,
}

/// Run the comparison: for each capacity, `cfg.instances` instances generated and compared in
/// turn (one at a time, so the solve times are not inflated by each other). `on_row` sees each
/// row as soon as it is decided (progress output).
pub fn run(
    cfg: &FastPlainConfig,
    clock: &dyn Fn() -> f64,
    on_row: &mut dyn FnMut(&Row),
) -> Result<Study, FastPlainError> {
    validate(cfg)?;
    let mut rows = Vec::new();
    for &c in &cfg.capacities {
        for n in 0..cfg.instances {
            let generated = generate(cfg, c, n)?;
            let row = compare(&generated, cfg.time_limit, clock);
            on_row(&row);
            rows.push(row);
        }
    }
    let per_capacity = cfg
        .capacities
        .iter()
        .map(|&c| {
            let r: Vec<Row> = rows.iter().filter(|r| r.capacity == c).cloned().collect();
            (c, summarise(&r))
        })
        .collect();
    Ok(Study {
        config: cfg.clone(),
        summary: summarise(&rows),
        rows,
        per_capacity,
    })
}

fn show_cycles(s: &Solved) -> String {
    s.cycles.map_or("-".into(), |c| c.to_string())
}

fn show_checker(s: &Solved) -> &'static str {
    match s.checker {
        Some(true) => "ok",
        Some(false) => "FAIL",
        None => "-",
    }
}

/// The column titles of [`row_line`].
pub fn header() -> String {
    format!(
        "{:>3} {:>4} {:<5} {:>5} {:>3} {:>3} {:>2} | {:<10} {:>3} {:>8} {:>4} | {:<10} {:>3} {:>8} {:>4} | verdict",
        "C",
        "inst",
        "goals",
        "epoch",
        "Nd",
        "|E|",
        "K",
        "fast",
        "cyc",
        "s",
        "chk",
        "plain",
        "cyc",
        "s",
        "chk"
    )
}

/// One instance as a table line: C, instance, goal set, epoch, N_d, |E_p|, K, then per model
/// the status, cycles (= objective of (11)), solve seconds and checker result, then the verdict.
pub fn row_line(r: &Row) -> String {
    let verdict = match &r.verdict {
        Verdict::Same => "same".to_string(),
        Verdict::Unknown(w) => format!("unknown ({w})"),
        Verdict::Difference(w) => format!("DIFFERENCE ({w})"),
    };
    format!(
        "{:>3} {:>4} {:<5} {:>5} {:>3} {:>3} {:>2} | {:<10} {:>3} {:>8.3} {:>4} | {:<10} {:>3} {:>8.3} {:>4} | {}",
        r.capacity,
        r.index,
        r.goal_set.name(),
        r.epoch,
        r.drones,
        r.goals,
        r.k_max,
        r.fast.status.as_str(),
        show_cycles(&r.fast),
        r.fast.seconds,
        show_checker(&r.fast),
        r.plain.status.as_str(),
        show_cycles(&r.plain),
        r.plain.seconds,
        show_checker(&r.plain),
        verdict
    )
}

fn summary_text(label: &str, s: &Summary) -> String {
    let spread = |x: &Option<Spread>| {
        x.map_or("-".into(), |x| {
            format!("{:.3} ({:.3}, {:.3})", x.median, x.q10, x.q90)
        })
    };
    format!(
        "{label}: {} instances, {} differences, {} unknown; both optimal {} ({} with ≥ 2 cycles), both infeasible {}; {} plans checked, {} rejected; solve s median (q10, q90): fast {} max {:.3}, plain {} max {:.3}; plain/fast {}",
        s.instances,
        s.differences,
        s.unknown,
        s.optimal,
        s.multi_cycle,
        s.infeasible,
        s.plans_checked,
        s.plans_rejected,
        spread(&s.fast_seconds),
        s.max_seconds.0,
        spread(&s.plain_seconds),
        s.max_seconds.1,
        s.speedup
            .map_or("-".into(), |x| format!("{:.1}× median", x.median)),
    )
}

/// The summary lines: one per capacity, then the total, ending with the line
/// "N instances, D differences" (and the unknown count).
pub fn summary_lines(study: &Study) -> String {
    let mut out = String::new();
    for (c, s) in &study.per_capacity {
        out.push_str(&summary_text(&format!("C = {c}"), s));
        out.push('\n');
    }
    out.push_str(&summary_text("all", &study.summary));
    out.push('\n');
    out.push_str(&format!(
        "{} instances, {} differences ({} unknown: a solve hit the time limit)\n",
        study.summary.instances, study.summary.differences, study.summary.unknown
    ));
    out
}

/// The rows as CSV (one line per instance, a header first).
pub(crate) fn rows_csv(study: &Study) -> String {
    let mut s = String::from(
        "capacity,instance,goal_set,epoch,world_seed,drones,goals,K,fast_status,fast_cycles,fast_seconds,fast_variables,fast_checker,plain_status,plain_cycles,plain_seconds,plain_variables,plain_checker,verdict\n",
    );
    let cyc = |c: Option<usize>| c.map_or(String::new(), |c| c.to_string());
    let chk = |c: Option<bool>| c.map_or(String::new(), |c| c.to_string());
    for r in &study.rows {
        let verdict = match &r.verdict {
            Verdict::Same => "same",
            Verdict::Unknown(_) => "unknown",
            Verdict::Difference(_) => "difference",
        };
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{:.4},{},{},{},{},{:.4},{},{},{}\n",
            r.capacity,
            r.index,
            r.goal_set.name(),
            r.epoch,
            r.world_seed,
            r.drones,
            r.goals,
            r.k_max,
            r.fast.status.as_str(),
            cyc(r.fast.cycles),
            r.fast.seconds,
            r.fast.variables,
            chk(r.fast.checker),
            r.plain.status.as_str(),
            cyc(r.plain.cycles),
            r.plain.seconds,
            r.plain.variables,
            chk(r.plain.checker),
            verdict
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solved(status: PlanStatus, cycles: Option<usize>) -> Solved {
        Solved {
            status,
            cycles,
            seconds: 0.1,
            variables: 10,
            checker: cycles.map(|_| true),
            message: String::new(),
        }
    }

    #[test]
    fn verdicts_follow_the_rules() {
        let opt = |c| solved(PlanStatus::Optimal, Some(c));
        let inf = solved(PlanStatus::Infeasible, None);
        let lim = solved(PlanStatus::TimeLimit, None);
        assert_eq!(verdict(&opt(2), &opt(2)), Verdict::Same);
        assert_eq!(verdict(&inf, &inf), Verdict::Same);
        assert!(matches!(verdict(&opt(3), &opt(2)), Verdict::Difference(_)));
        assert!(matches!(verdict(&inf, &opt(1)), Verdict::Difference(_)));
        assert!(matches!(verdict(&opt(1), &lim), Verdict::Unknown(_)));
        let mut broken = opt(1);
        broken.checker = Some(false);
        assert!(matches!(verdict(&broken, &opt(1)), Verdict::Difference(_)));
        // A rejected plan is a difference even when the other model was stopped.
        assert!(matches!(verdict(&broken, &lim), Verdict::Difference(_)));
    }

    #[test]
    fn c_one_holds_one_drone_per_station() {
        assert_eq!(effective_drones(10, 5, 1), 5);
        assert_eq!(effective_drones(10, 5, 2), 10);
        assert_eq!(effective_drones(10, 5, 3), 10);
    }

    #[test]
    fn far_goals_are_spread_and_away_from_the_team() {
        let cfg = FastPlainConfig {
            size: 6,
            obstacles: 3,
            drones: 4,
            stations: 2,
            goals: 4,
            ..FastPlainConfig::default()
        };
        let study = study_config(&cfg, 2);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let w = Field::random(&study, &mut rng).unwrap();
        let inst = Instance::new(
            w.grid.clone(),
            w.drones.clone(),
            w.stations.clone(),
            vec![],
            8,
            4,
            1,
            Some(2),
        )
        .unwrap();
        let goals = far_goals(&inst, 4);
        assert_eq!(goals.len(), 4);
        let team: Vec<usize> = inst.drones.iter().chain(&inst.stations).copied().collect();
        let d = w.grid.distances(&team, false);
        let farthest = w.grid.free_cells().iter().map(|&i| d[i]).max().unwrap();
        assert!(goals.iter().any(|&g| d[g] == farthest));
        assert!(goals.iter().all(|&g| w.grid.is_free(g) && d[g] > 0));
    }

    #[test]
    fn bad_configurations_are_refused() {
        let bad = |f: &dyn Fn(&mut FastPlainConfig)| {
            let mut c = FastPlainConfig::default();
            f(&mut c);
            validate(&c).is_err()
        };
        assert!(validate(&FastPlainConfig::default()).is_ok());
        assert!(bad(&|c| c.capacities = vec![0]));
        assert!(bad(&|c| c.cycles = vec![]));
        assert!(bad(&|c| c.tc = 3));
        assert!(bad(&|c| c.obstacles = 99));
        assert!(bad(&|c| c.time_limit = Some(-1.0)));
    }
}
