//! The low-level planner of the bandit paper: the integer program (11) — minimise the number of
//! sensing cycles subject to the motion constraints (7a)–(7g), the visit constraints (8a)–(8c),
//! the battery constraints (9a)–(9d) and the optional charger capacity (10) — solved with
//! good_lp on HiGHS (Algorithm 2).
//!
//! Two models of the same problem are offered:
//!
//! * [`Model::Plain`] ([`plain`]): the IP exactly as written in the paper, one model with K
//!   cycles and all K(1 + |G|(N_d T_d + N_c T_c)) binaries. It is the reference.
//! * [`Model::Fast`] ([`fast`]): the same optimum, reformulated (each step argued in
//!   [`fast`]'s documentation): drones and stations aggregated into flows on a time-expanded
//!   graph (which removes every symmetry between interchangeable vehicles), variables only where
//!   a vehicle can be (forward reachability from the starts, backward reachability to a cell a
//!   station can occupy at the end of each cycle), and K = 1, 2, … solved in turn as
//!   feasibility problems, the first feasible one being optimal.
//!
//! After the solve, the plan is re-paired by linear assignment (§III-C, `super::assign`).
//!
//! Clock reads: none. The caller passes `elapsed`, a clock closure giving the seconds since
//! the solve began (`clock::stopwatch` at the edge, a fixed value in tests); it feeds
//! the solve statistics (`solve_seconds`, each attempt's `seconds`) and the time left of
//! [`PlanOptions::time_limit`] between attempts. The plan never depends on it except through
//! that budget and HiGHS's own time limit, which is a clock by nature. It is a CPU-bound batch computation, to be run on
//! `spawn_blocking` or rayon by async callers (docs/architecture.md, "Layers").

pub mod fast;
pub mod plain;

use super::plan::{IpPlan, Timelines};
use super::scenario::{Instance, Scenario, ScenarioError};

use crate::geo::Cell;
use serde::{Deserialize, Serialize};

/// Which formulation of (11) to solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Model {
    /// The reformulated model of [`fast`] (same optimum, much smaller).
    #[default]
    Fast,
    /// The paper's model, written exactly as in eq. (6)–(11).
    Plain,
}

/// Solver settings.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// The formulation.
    pub model: Model,
    /// HiGHS `threads` (1 for one solve per core when many run in parallel). HiGHS keeps one
    /// scheduler per process, so the first value used in a process wins.
    pub threads: u32,
    /// HiGHS `time_limit` in seconds for the whole solve (all K tried), `None` = no limit.
    pub time_limit: Option<f64>,
    /// Re-pair drones (and stations) between consecutive steps by linear assignment (§III-C).
    pub repair: bool,
    /// HiGHS log on the console.
    pub verbose: bool,
    /// *Informative paths* (an improvement, not in the paper; fast model only): reward
    /// `visit_weights[l]` (per dense cell index) for every drone arrival at cell l. Among the
    /// plans with the fewest sensing cycles — that number is still decided exactly first, see
    /// [`fast`] — the solver then prefers plans whose drones fly over valuable (e.g.
    /// unclassified) cells instead of arbitrary ones. `None`: the paper's IP, any optimal plan.
    pub visit_weights: Option<Vec<f64>>,
    /// Relative MIP gap accepted for the informative-paths objective (the cycle count is exact
    /// regardless).
    pub secondary_gap: f64,
    /// Seconds HiGHS may spend improving informative paths before it keeps its best plan.
    pub secondary_time_limit: f64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            model: Model::Fast,
            threads: 1,
            time_limit: None,
            repair: true,
            verbose: false,
            visit_weights: None,
            secondary_gap: 0.02,
            secondary_time_limit: 2.0,
        }
    }
}

/// The result class of a solve (the spec's `status`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlanStatus {
    /// A plan with the fewest sensing cycles (proven).
    Optimal,
    /// No plan exists within K sensing cycles (proven).
    Infeasible,
    /// The time limit stopped the solver; a plan may be attached but is not proven optimal.
    TimeLimit,
    /// The solver failed (message in [`PlanOutcome::message`]).
    Error,
}

impl PlanStatus {
    /// The spec's string for this status.
    pub fn as_str(self) -> &'static str {
        match self {
            PlanStatus::Optimal => "optimal",
            PlanStatus::Infeasible => "infeasible",
            PlanStatus::TimeLimit => "time_limit",
            PlanStatus::Error => "error",
        }
    }
}

/// Statistics of one model handed to HiGHS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Attempt {
    /// The number of sensing cycles the model allows (K for the plain model, the fixed cycle
    /// count for the fast model).
    pub cycles: usize,
    /// What the solver said.
    pub status: PlanStatus,
    /// Wall time of this model, building included, in seconds.
    pub seconds: f64,
    /// Integer (binary, or bounded general integer for boundary arcs of the fast model when
    /// T_d = 2) variables in the model.
    pub variables: usize,
    /// Constraints (rows) in the model.
    pub constraints: usize,
    /// Whether the model was decided without calling HiGHS (reachability showed a goal out of
    /// reach within this many cycles).
    pub presolved: bool,
}

/// The result of [`solve`]: status, the plan when one was found, and solve statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanOutcome {
    /// Optimal, infeasible within K, time limit, or error.
    pub status: PlanStatus,
    /// The plan (with `Optimal`, and with `TimeLimit` when an incumbent exists).
    pub plan: Option<IpPlan>,
    /// Wall time of the whole solve, every model and the re-pairing included, in seconds.
    pub solve_seconds: f64,
    /// Integer variables of the model that decided the answer (the last one solved).
    pub variables: usize,
    /// Constraints of that model.
    pub constraints: usize,
    /// Every model tried, in order.
    pub attempts: Vec<Attempt>,
    /// The solver's message for `Error`, why no plan can exist for a scenario that is
    /// infeasible whatever K ([`PlanOutcome::never`]), empty otherwise.
    pub message: String,
}

/// The `--json` output of `fleetmap plan` (docs/ip-scenario.md), with exactly its keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanOutput {
    /// "optimal" | "infeasible" | "time_limit" | "error".
    pub status: String,
    /// Σ λ_k of the returned plan; 0 when there is no plan.
    pub cycles: usize,
    /// `drones[i][k][j] = [r, c]`; empty when there is no plan.
    pub drones: Vec<Vec<Vec<[i32; 2]>>>,
    /// `stations[a][k][b] = [r, c]`; empty when there is no plan.
    pub stations: Vec<Vec<Vec<[i32; 2]>>>,
    /// Wall time of the whole solve, model building included, in seconds.
    pub solve_seconds: f64,
    /// Integer variables in the model actually solved (after pruning).
    pub variables: usize,
    /// Constraints in that model.
    pub constraints: usize,
}

impl PlanOutcome {
    /// The outcome of a scenario that no plan can satisfy whatever K (no model was solved).
    pub fn never(reason: String) -> PlanOutcome {
        PlanOutcome {
            status: PlanStatus::Infeasible,
            plan: None,
            solve_seconds: 0.0,
            variables: 0,
            constraints: 0,
            attempts: Vec::new(),
            message: reason,
        }
    }

    /// The spec's output object.
    pub fn output(&self) -> PlanOutput {
        let conv = |v: &Vec<Vec<Vec<Cell>>>| -> Vec<Vec<Vec<[i32; 2]>>> {
            v.iter()
                .map(|cycles| {
                    cycles
                        .iter()
                        .map(|steps| steps.iter().map(|c| [c.row, c.col]).collect())
                        .collect()
                })
                .collect()
        };
        PlanOutput {
            status: self.status.as_str().to_string(),
            cycles: self.plan.as_ref().map_or(0, |p| p.cycles),
            drones: self
                .plan
                .as_ref()
                .map_or_else(Vec::new, |p| conv(&p.drones)),
            stations: self
                .plan
                .as_ref()
                .map_or_else(Vec::new, |p| conv(&p.stations)),
            solve_seconds: self.solve_seconds,
            variables: self.variables,
            constraints: self.constraints,
        }
    }
}

/// HiGHS settings shared by both models: `threads`, `time_limit`, `mip_rel_gap = 0` (the
/// objective is a small integer, so any positive gap could accept a non-optimal cycle count),
/// and `mip_abs_gap = 0`.
pub(crate) fn configure(
    mut p: good_lp::solvers::highs::HighsProblem,
    opts: &PlanOptions,
    time_left: Option<f64>,
) -> good_lp::solvers::highs::HighsProblem {
    p.set_verbose(opts.verbose);
    let mut p = p
        .set_threads(opts.threads.max(1))
        .set_option("mip_rel_gap", 0.0)
        .set_option("mip_abs_gap", 0.0);
    if let Some(t) = time_left {
        p = p.set_time_limit(t.max(0.0));
    }
    p
}

/// What one HiGHS model returned.
#[derive(Debug)]
pub(crate) enum RawResult {
    /// A solution (proven optimal or feasible at the time limit).
    Solved { optimal: bool, timelines: Timelines },
    /// Proven infeasible.
    Infeasible,
    /// Time limit without any solution.
    TimeLimit,
    /// Solver failure.
    Error(String),
}

/// Map good_lp's result of a HiGHS solve.
pub(crate) fn classify<S: good_lp::Solution>(
    r: Result<S, good_lp::ResolutionError>,
) -> Result<(S, bool), RawResult> {
    use good_lp::solvers::SolutionStatus;
    match r {
        Ok(s) => {
            let optimal = matches!(s.status(), SolutionStatus::Optimal);
            Ok((s, optimal))
        }
        Err(good_lp::ResolutionError::Infeasible) => Err(RawResult::Infeasible),
        // good_lp reports a time limit without an incumbent as "NoSolutionFound".
        Err(good_lp::ResolutionError::Other("NoSolutionFound")) => Err(RawResult::TimeLimit),
        Err(e) => Err(RawResult::Error(e.to_string())),
    }
}

/// Solve one epoch given as a scenario: validate it, then [`solve_instance`]. A well-formed
/// scenario that no plan can satisfy whatever K ([`ScenarioError::Infeasible`]) is the outcome
/// `Infeasible`, with the reason as its message, as the spec wants; malformed input is an error.
/// `elapsed` is the caller's clock, as for [`solve_instance`].
pub fn solve(
    scenario: &Scenario,
    opts: &PlanOptions,
    elapsed: &dyn Fn() -> f64,
) -> Result<PlanOutcome, ScenarioError> {
    match scenario.instance() {
        Ok(inst) => Ok(solve_instance(&inst, opts, elapsed)),
        Err(ScenarioError::Infeasible(reason)) => Ok(PlanOutcome::never(reason)),
        Err(e) => Err(e),
    }
}

/// Solve one epoch: the fewest sensing cycles (≤ K) in which the team visits every goal, with
/// the paths; infeasibility within K is a normal outcome, not an error. Every plan returned has
/// passed the independent checker ([`crate::planner::check`]; no head-on swaps when re-paired).
///
/// `elapsed` is the caller's clock: seconds since the solve began (read when the solve starts,
/// between attempts and at the end; the planner reads no clock itself).
pub fn solve_instance(
    inst: &Instance,
    opts: &PlanOptions,
    elapsed: &dyn Fn() -> f64,
) -> PlanOutcome {
    let start = elapsed();
    let (status, timelines, attempts, message) = match opts.model {
        Model::Plain => plain::solve(inst, opts, elapsed),
        Model::Fast => fast::solve(inst, opts, &|| elapsed() - start),
    };
    let mut plan = timelines.map(|mut t| {
        if opts.repair {
            super::assign::repair(inst, &mut t);
        }
        t.to_plan(inst)
    });
    // Every plan goes through the independent checker before anyone sees it (the field
    // runner uploads it to vehicles): one that fails is an error, never a plan.
    let (mut status, mut message) = (status, message);
    if let Some(p) = &plan
        && let Err(e) = super::check::check_plan_with(
            inst,
            p,
            super::check::CheckOptions {
                no_head_on_swaps: opts.repair,
            },
        )
    {
        status = PlanStatus::Error;
        message = format!("internal error: the plan fails the independent checker: {e}");
        plan = None;
    }
    let last = attempts.last();
    PlanOutcome {
        status,
        plan,
        solve_seconds: elapsed() - start,
        variables: last.map_or(0, |a| a.variables),
        constraints: last.map_or(0, |a| a.constraints),
        attempts,
        message,
    }
}
