//! The fast model: the same optimum as the paper's IP (11) ([`super::plain`]) with a far smaller
//! model. Each reformulation, and why it keeps the optimal number of sensing cycles:
//!
//! 1. **K = 1, 2, … in turn.** The plain model's optimum is the least K' ≤ K for which a plan
//!    with exactly K' active cycles exists (λ_k = 1 for k < K' by (7g), and a cycle with
//!    λ_k = 0 has no positions by (7f)). So we decide, for K' = 1, 2, …, K, whether a plan with
//!    exactly K' cycles exists — a feasibility problem with a zero objective, so HiGHS stops at
//!    the first integer solution — and the first feasible K' is optimal. If every K' ≤ K is
//!    infeasible, the plain model is infeasible too. Each model is proven feasible or infeasible
//!    exactly (no gap: there is no objective).
//!
//! 2. **Vehicles aggregated into flows on a time-expanded graph.** Drones are interchangeable
//!    (identical battery T_d, identical moves), and so are stations. Instead of x_{ijkl} per
//!    drone we use arc variables f_{t,m→l} = number of drones moving from cell m at drone time
//!    t − 1 to cell l at time t, where t = k(T_d − 1) + j runs over the whole plan (the last
//!    step of cycle k *is* the first of cycle k + 1, which is (9b) with λ_{k+1} = 1); likewise
//!    g_{s,m→l} for stations with s = k(T_c − 1) + b. Constraints:
//!    * flow conservation at every cell and time, with supply = the number of drones (stations)
//!      starting on a cell (7a) — this replaces (7b), (7c), (7f), (9a), (9b), (9c);
//!    * occupancy ≤ 1 at mid-cycle drone times j ∈ [1, T_d − 2] (7e) and at every station time
//!      (7d);
//!    * at a cycle boundary t = k(T_d − 1), k ≥ 1: drones on l ≤ cap_l · (stations on l at
//!      s = k(T_c − 1)), with cap_l = min(C, N_d, number of arcs entering (t, l)) — this is
//!      (9d) and (10) together, with the smallest valid big-M (station occupancy is 0/1 by
//!      (7d), each arc entering from a mid-cycle time carries at most one drone by (7e)). At
//!      k = 0 it holds by validation of the start configuration;
//!    * every goal has positive inflow at some time, or is a start cell (8a).
//!
//!    A plain-model plan maps to such flows by counting drones per arc; conversely integral
//!    flows decompose into N_d drone paths and N_c station paths (follow any arc with remaining
//!    flow out of the current cell: conservation guarantees one exists), and those paths satisfy
//!    every plain constraint, because every constraint of the plain model depends only on how
//!    many drones (stations) are on each cell at each step, except (7b)/(7c)/(9a)–(9c), which
//!    hold for each path by construction. Hence the two models are feasible for exactly the
//!    same K'. This also removes *all* symmetry between drones (not just between drones sharing
//!    a start cell): a flow stands for N_d! labelled plans.
//!
//! 3. **Variables only where a vehicle can be.** Station cells at time s: those reachable in R
//!    from a station start within s moves. Drone cells at time t: forward, reachable from a
//!    drone start within t moves through free cells while standing, at every cycle boundary
//!    t' ≤ t, on a cell some station can reach by then (9d); backward, able to reach within the
//!    remaining steps, again through such boundary cells, a cell a station can reach by the end
//!    of the last cycle. Every position of every feasible plan satisfies both (it is where a
//!    feasible path passes), so removing the other variables removes no feasible plan. Obstacles
//!    (8b) and cells outside R (8c) are never given variables.
//!
//! 4. **Cheap infeasibility.** If after pruning a goal has no variable (no drone can reach it
//!    and get back to a station within K' cycles), or a drone's start cell has none, the K'
//!    model is infeasible without calling HiGHS.
//!
//! 5. **Informative paths (optional, not in the paper).** With
//!    [`PlanOptions::visit_weights`], each K' model gets the objective "maximise the weighted
//!    number of drone arrivals", with a relative gap and a time limit of its own. The cycle count
//!    is unaffected: K' is still the first K for which a plan exists (infeasibility is proven
//!    whatever the objective, and any plan found for K' has K' cycles); only *which* K'-cycle
//!    plan is returned changes. If the objective's time limit passes before any plan is found,
//!    the K' model is solved again without objective.

use super::{Attempt, PlanOptions, PlanStatus, RawResult, classify, configure};
use crate::planner::plan::Timelines;
use crate::planner::scenario::Instance;
use good_lp::{Expression, ProblemVariables, Solution, SolverModel, Variable, highs, variable};
use std::collections::HashMap;

/// Decide K' = 1, 2, …, K in turn (see the module documentation). `elapsed` gives the
/// seconds since the solve began (the caller's clock).
pub(crate) fn solve(
    inst: &Instance,
    opts: &PlanOptions,
    elapsed: &dyn Fn() -> f64,
) -> (PlanStatus, Option<Timelines>, Vec<Attempt>, String) {
    let mut attempts = Vec::new();
    for kc in 1..=inst.k_max {
        let time_left = opts.time_limit.map(|t| t - elapsed());
        if time_left.is_some_and(|t| t <= 0.0) {
            return (PlanStatus::TimeLimit, None, attempts, String::new());
        }
        let (mut raw, attempt) = solve_cycles(
            inst,
            kc,
            opts,
            time_left,
            opts.visit_weights.as_deref(),
            elapsed,
        );
        attempts.push(attempt);
        if opts.visit_weights.is_some() && matches!(raw, RawResult::TimeLimit | RawResult::Error(_))
        {
            // The informative objective ran out of time before any plan: decide feasibility
            // without it (item 5).
            let time_left = opts.time_limit.map(|t| t - elapsed());
            let (r, a) = solve_cycles(inst, kc, opts, time_left, None, elapsed);
            attempts.push(a);
            raw = r;
        }
        match raw {
            // All K' < kc are infeasible, so a kc-cycle plan is optimal even if HiGHS hit
            // its time limit after finding it (the model has no objective).
            RawResult::Solved { timelines, .. } => {
                return (
                    PlanStatus::Optimal,
                    Some(timelines),
                    attempts,
                    String::new(),
                );
            }
            RawResult::Infeasible => continue,
            RawResult::TimeLimit => return (PlanStatus::TimeLimit, None, attempts, String::new()),
            RawResult::Error(m) => return (PlanStatus::Error, None, attempts, m),
        }
    }
    (PlanStatus::Infeasible, None, attempts, String::new())
}

/// Cells each vehicle kind may occupy at each time of a `kc`-cycle plan (item 3).
#[derive(Debug, Clone)]
pub struct Reach {
    /// `drone[t][l]`: drone time t ∈ [0, kc(T_d − 1)].
    pub drone: Vec<Vec<bool>>,
    /// `station[s][l]`: station time s ∈ [0, kc(T_c − 1)].
    pub station: Vec<Vec<bool>>,
}

/// Forward/backward reachability of item 3 for a plan of `kc` cycles.
// Cell loops index several parallel per-layer arrays at once.
#[allow(clippy::needless_range_loop)]
pub fn reach(inst: &Instance, kc: usize) -> Reach {
    let g = &inst.grid;
    let ng = g.len();
    let (dt, ct) = (inst.td - 1, inst.tc - 1);
    let (tmax, smax) = (kc * dt, kc * ct);
    let mut station = vec![vec![false; ng]; smax + 1];
    for &s in &inst.stations {
        station[0][s] = true;
    }
    for s in 1..=smax {
        let (prev, cur) = station.split_at_mut(s);
        for l in 0..ng {
            if prev[s - 1][l] {
                for &m in g.station_moves(l) {
                    cur[0][m] = true;
                }
            }
        }
    }
    let boundary_ok = |t: usize, l: usize| !t.is_multiple_of(dt) || station[t / dt * ct][l];
    let mut fwd = vec![vec![false; ng]; tmax + 1];
    for &d in &inst.drones {
        fwd[0][d] = true;
    }
    for t in 1..=tmax {
        let (prev, cur) = fwd.split_at_mut(t);
        for l in 0..ng {
            if prev[t - 1][l] {
                for &m in g.moves(l) {
                    if boundary_ok(t, m) {
                        cur[0][m] = true;
                    }
                }
            }
        }
    }
    // Backward: keep cells from which the end of the plan is reachable.
    for t in (0..tmax).rev() {
        let (cur, next) = fwd.split_at_mut(t + 1);
        for l in 0..ng {
            if cur[t][l] && !g.moves(l).iter().any(|&m| next[0][m]) {
                cur[t][l] = false;
            }
        }
    }
    Reach {
        drone: fwd,
        station,
    }
}

/// One arc of the time-expanded graph.
#[derive(Debug, Clone, Copy)]
struct Arc {
    from: usize,
    to: usize,
    var: Variable,
}

/// Build and solve the feasibility model with exactly `kc` cycles.
// Cell and time loops index several parallel arrays at once.
#[allow(clippy::needless_range_loop)]
pub(crate) fn solve_cycles(
    inst: &Instance,
    kc: usize,
    opts: &PlanOptions,
    time_left: Option<f64>,
    weights: Option<&[f64]>,
    elapsed: &dyn Fn() -> f64,
) -> (RawResult, Attempt) {
    let t0 = elapsed();
    let g = &inst.grid;
    let ng = g.len();
    let (dt, ct) = (inst.td - 1, inst.tc - 1);
    let (tmax, smax) = (kc * dt, kc * ct);
    let nd = inst.nd();
    let r = reach(inst, kc);
    let mut attempt = Attempt {
        cycles: kc,
        status: PlanStatus::Infeasible,
        seconds: 0.0,
        variables: 0,
        constraints: 0,
        presolved: true,
    };
    // Item 4: cheap infeasibility.
    let covered_at_start = |l: usize| inst.drones.contains(&l);
    let start_ok = inst.drones.iter().all(|&d| r.drone[0][d]);
    let goals_ok = inst
        .goals
        .iter()
        .all(|&l| covered_at_start(l) || (1..=tmax).any(|t| r.drone[t][l]));
    if !start_ok || !goals_ok {
        attempt.seconds = elapsed() - t0;
        return (RawResult::Infeasible, attempt);
    }
    let boundary = |t: usize| t.is_multiple_of(dt);
    let cap = inst.capacity.unwrap_or(nd).min(nd);
    let mut vars = ProblemVariables::new();
    // Drone arcs per time t ∈ [1, tmax] (arc from time t − 1 to t).
    let mut darcs: Vec<Vec<Arc>> = vec![Vec::new(); tmax + 1];
    for t in 1..=tmax {
        for from in 0..ng {
            if !r.drone[t - 1][from] {
                continue;
            }
            for &to in g.moves(from) {
                if !r.drone[t][to] {
                    continue;
                }
                // At most one drone on an arc touching a mid-cycle time (7e); boundary to
                // boundary arcs (T_d = 2) carry up to min(C, N_d).
                let def = if boundary(t - 1) && boundary(t) {
                    variable().integer().min(0).max(cap as f64)
                } else {
                    variable().binary()
                };
                darcs[t].push(Arc {
                    from,
                    to,
                    var: vars.add(def),
                });
            }
        }
    }
    let mut sarcs: Vec<Vec<Arc>> = vec![Vec::new(); smax + 1];
    for s in 1..=smax {
        for from in 0..ng {
            if !r.station[s - 1][from] {
                continue;
            }
            for &to in g.station_moves(from) {
                if r.station[s][to] {
                    sarcs[s].push(Arc {
                        from,
                        to,
                        var: vars.add(variable().binary()),
                    });
                }
            }
        }
    }
    let n_vars =
        darcs.iter().map(Vec::len).sum::<usize>() + sarcs.iter().map(Vec::len).sum::<usize>();
    // Item 5 (optional): reward drone arrivals at valuable cells (moves, not passes).
    let mut objective = Expression::with_capacity(if weights.is_some() { n_vars } else { 0 });
    if let Some(w) = weights {
        for layer in &darcs {
            for a in layer {
                let wl = w.get(a.to).copied().unwrap_or(0.0);
                if a.from != a.to && wl != 0.0 {
                    objective.add_mul(-wl, a.var);
                }
            }
        }
    }
    let limit = match (weights.is_some(), time_left) {
        (true, Some(t)) => Some(t.min(opts.secondary_time_limit)),
        (true, None) => Some(opts.secondary_time_limit),
        (false, t) => t,
    };
    let mut p = configure(vars.minimise(objective).using(highs), opts, limit);
    if weights.is_some() {
        p = p.set_option("mip_rel_gap", opts.secondary_gap.max(0.0));
    }
    let mut rows = 0usize;
    let mut add = |p: &mut good_lp::solvers::highs::HighsProblem, c: good_lp::Constraint| {
        p.add_constraint(c);
        rows += 1;
    };
    // In/out arc lists per (time, cell).
    let index = |arcs: &[Vec<Arc>]| {
        let mut inn: HashMap<(usize, usize), Vec<Variable>> = HashMap::new();
        let mut out: HashMap<(usize, usize), Vec<Variable>> = HashMap::new();
        for (t, layer) in arcs.iter().enumerate() {
            for a in layer {
                inn.entry((t, a.to)).or_default().push(a.var);
                out.entry((t - 1, a.from)).or_default().push(a.var);
            }
        }
        (inn, out)
    };
    let (din, dout) = index(&darcs);
    let (sin, sout) = index(&sarcs);
    let sum = |v: Option<&Vec<Variable>>| -> Expression {
        let mut e = Expression::with_capacity(v.map_or(0, Vec::len));
        for &x in v.into_iter().flatten() {
            e.add_mul(1.0, x);
        }
        e
    };
    let mut supply = vec![0usize; ng];
    for &d in &inst.drones {
        supply[d] += 1;
    }
    // Drone conservation and occupancy.
    for l in 0..ng {
        if supply[l] > 0 && tmax > 0 {
            add(&mut p, sum(dout.get(&(0, l))).eq(supply[l] as f64));
        }
    }
    for t in 1..=tmax {
        for l in 0..ng {
            if !r.drone[t][l] {
                continue;
            }
            let inflow = din.get(&(t, l));
            if t < tmax {
                add(&mut p, (sum(inflow) - sum(dout.get(&(t, l)))).eq(0.0));
            }
            let n_in = inflow.map_or(0, Vec::len);
            if !boundary(t) {
                if n_in >= 2 {
                    add(&mut p, sum(inflow).leq(1.0));
                }
            } else {
                // (9d) + (10): drones only where a station is, at most cap_l of them (fewer
                // on a pinned station with chargers taken: it is always the station on l).
                let per_arc = if boundary(t - 1) { cap } else { 1 };
                let cap_here = inst.capacity_at(l).map_or(cap, |c| c.min(cap));
                let cap_l = cap_here.min(n_in * per_arc);
                let s = t / dt * ct;
                let stations_here = sum(sin.get(&(s, l)));
                add(&mut p, sum(inflow).leq(cap_l as f64 * stations_here));
            }
        }
    }
    // Station conservation and occupancy (7d).
    let mut is_station_start = vec![false; ng];
    for &s in &inst.stations {
        is_station_start[s] = true;
    }
    for l in 0..ng {
        if is_station_start[l] && smax > 0 {
            add(&mut p, sum(sout.get(&(0, l))).eq(1.0));
        }
    }
    for s in 1..=smax {
        for l in 0..ng {
            if !r.station[s][l] {
                continue;
            }
            let inflow = sin.get(&(s, l));
            if s < smax {
                add(&mut p, (sum(inflow) - sum(sout.get(&(s, l)))).eq(0.0));
            }
            if inflow.map_or(0, Vec::len) >= 2 {
                add(&mut p, sum(inflow).leq(1.0));
            }
        }
    }
    // Pinned stations stay on their cell: the arc l → l carries one station at every
    // station time (no other station can enter l then, 7d).
    for pin in &inst.pinned {
        let l = inst.stations[pin.station];
        for layer in sarcs.iter().skip(1) {
            match layer.iter().find(|a| a.from == l && a.to == l) {
                Some(a) => add(&mut p, Expression::from(a.var).eq(1.0)),
                None => {
                    attempt.seconds = elapsed() - t0;
                    return (RawResult::Infeasible, attempt);
                }
            }
        }
    }
    // (8a)
    for &l in &inst.goals {
        if covered_at_start(l) {
            continue;
        }
        let mut e = Expression::with_capacity(16);
        for t in 1..=tmax {
            for &v in din.get(&(t, l)).into_iter().flatten() {
                e.add_mul(1.0, v);
            }
        }
        add(&mut p, e.geq(1.0));
    }
    attempt.variables = n_vars;
    attempt.constraints = rows;
    attempt.presolved = false;
    let raw = match classify(p.solve()) {
        Err(raw) => raw,
        Ok((sol, optimal)) => {
            let flow = |v: Variable| sol.value(v).round().max(0.0) as usize;
            let drones = decompose(&inst.drones, &darcs, flow);
            let stations = decompose(&inst.stations, &sarcs, flow);
            match (drones, stations) {
                (Some(drones), Some(stations)) => RawResult::Solved {
                    optimal,
                    timelines: Timelines {
                        cycles: kc,
                        drones,
                        stations,
                    },
                },
                _ => RawResult::Error(
                    "the solver's flows do not decompose into paths (numerical trouble)".into(),
                ),
            }
        }
    };
    attempt.status = match &raw {
        RawResult::Solved { .. } => PlanStatus::Optimal,
        RawResult::Infeasible => PlanStatus::Infeasible,
        RawResult::TimeLimit => PlanStatus::TimeLimit,
        RawResult::Error(_) => PlanStatus::Error,
    };
    attempt.seconds = elapsed() - t0;
    (raw, attempt)
}

/// Split integral arc flows into one path per vehicle: each vehicle, in order, follows an arc
/// with remaining flow out of its current cell. Conservation makes this always succeed.
fn decompose(
    starts: &[usize],
    arcs: &[Vec<Arc>],
    flow: impl Fn(Variable) -> usize,
) -> Option<Vec<Vec<usize>>> {
    let mut paths: Vec<Vec<usize>> = starts.iter().map(|&s| vec![s]).collect();
    for layer in arcs.iter().skip(1) {
        let mut left: HashMap<usize, Vec<(usize, usize)>> = HashMap::new();
        for a in layer {
            let f = flow(a.var);
            if f > 0 {
                left.entry(a.from).or_default().push((a.to, f));
            }
        }
        for path in paths.iter_mut() {
            let here = *path.last()?;
            let options = left.get_mut(&here)?;
            let slot = options.iter_mut().find(|(_, f)| *f > 0)?;
            slot.1 -= 1;
            path.push(slot.0);
        }
    }
    Some(paths)
}
