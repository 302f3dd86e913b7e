//! The IP (11) written exactly as in the bandit paper (§III-B, eq. 6–10): the reference model.
//!
//! Variables (6): x_{ijkl}, y_{abkl}, λ_k ∈ {0, 1} for every drone i, station a, step
//! j ∈ [0, T_d − 1], b ∈ [0, T_c − 1], cycle k ∈ [0, K − 1] and **every** cell l ∈ G, so the
//! model has K(1 + |G|(N_d T_d + N_c T_c)) binaries, as the paper counts them. Obstacles and
//! cells outside R are excluded by the constraints (8b), (8c), not by omitting variables.
//!
//! Interpretations of the paper's notation (each one is the only reading under which the
//! constraint is well defined and matches the prose next to it):
//!
//! * (7a) "x_{i00l} = 1 ∀ l ∈ X_0" is read per vehicle: drone i starts on its own cell
//!   X_0(i) (likewise y_{a00d} = 1 for station a's cell Y_0(a)); several drones may share a cell.
//! * (7b), (7c): N(l) includes l itself (a pass is a move, docs/ip-scenario.md) and is empty
//!   for an obstacle l (N is only defined on G \ O); N_c(l) = R ∩ N(l), empty for l ∉ R.
//! * (7d) holds for every (b, k, l), cycle boundaries included (no index is excluded in the
//!   paper, unlike (7e)).
//! * (7e) holds for j ∈ [1, T_d − 2] only, as written: several drones may share a (station)
//!   cell at the first and last step of a cycle.
//! * (7f) holds for every i, j, k (drones) and a, b, k (stations).
//! * (7g) λ_k ≥ λ_{k+1} for k ∈ [0, K − 2] (for k = K − 1, λ_K does not exist).
//! * (9a) is kept although (7f) already implies it (exactly λ_k ≤ 1 cell per step).
//! * (9b), (9c): the paper writes ∀k ∈ N_[1, K−1], which would index cycle K (nonexistent) and
//!   leave the boundary between cycles 0 and 1 unconstrained; we use k ∈ [0, K − 2], i.e. every
//!   pair of consecutive cycles, as the prose says ("positions remain unchanged between sensing
//!   cycles"). |u − v| ≤ 2(1 − λ_{k+1}) is written as the two rows u − v ≤ 2(1 − λ_{k+1}) and
//!   v − u ≤ 2(1 − λ_{k+1}).
//! * (10): the paper writes x_{iT_d kl}, but j only goes to T_d − 1; the end of a cycle is
//!   j = T_d − 1 (the index used by (9d) for the same rendezvous).
//! * (11) sums λ_k over k ∈ N_[1, K]; the cycles are indexed [0, K − 1] by (6), so the
//!   objective is Σ_{k=0}^{K−1} λ_k.

use super::{Attempt, PlanOptions, PlanStatus, RawResult, classify, configure};
use crate::planner::plan::Timelines;
use crate::planner::scenario::Instance;
use good_lp::{Expression, ProblemVariables, Solution, SolverModel, Variable, highs, variable};

/// Solve the paper's model with K = `inst.k_max` cycles. `elapsed` is the caller's clock
/// (seconds), read for the attempt's statistics only.
pub(crate) fn solve(
    inst: &Instance,
    opts: &PlanOptions,
    elapsed: &dyn Fn() -> f64,
) -> (PlanStatus, Option<Timelines>, Vec<Attempt>, String) {
    let t0 = elapsed();
    let g = &inst.grid;
    let (nd, nc, td, tc, kk, ng) = (inst.nd(), inst.nc(), inst.td, inst.tc, inst.k_max, g.len());
    let mut vars = ProblemVariables::new();
    let xs: Vec<Variable> = vars.add_vector(variable().binary(), nd * td * kk * ng);
    let ys: Vec<Variable> = vars.add_vector(variable().binary(), nc * tc * kk * ng);
    let lam: Vec<Variable> = vars.add_vector(variable().binary(), kk);
    let x = |i: usize, j: usize, k: usize, l: usize| xs[((i * td + j) * kk + k) * ng + l];
    let y = |a: usize, b: usize, k: usize, l: usize| ys[((a * tc + b) * kk + k) * ng + l];
    let n_vars = xs.len() + ys.len() + lam.len();
    let objective: Expression = lam.iter().copied().map(Expression::from).sum();
    let mut p = configure(vars.minimise(objective).using(highs), opts, opts.time_limit);
    let mut rows = 0usize;
    let mut add = |p: &mut good_lp::solvers::highs::HighsProblem, c: good_lp::Constraint| {
        p.add_constraint(c);
        rows += 1;
    };
    let sum = |it: &mut dyn Iterator<Item = Variable>| -> Expression {
        let mut e = Expression::with_capacity(16);
        for v in it {
            e.add_mul(1.0, v);
        }
        e
    };
    // (7a)
    for (i, &l) in inst.drones.iter().enumerate() {
        add(&mut p, Expression::from(x(i, 0, 0, l)).eq(1.0));
    }
    for (a, &d) in inst.stations.iter().enumerate() {
        add(&mut p, Expression::from(y(a, 0, 0, d)).eq(1.0));
    }
    let dn = |l: usize| -> &[usize] { if g.is_free(l) { g.moves(l) } else { &[] } };
    let sn = |l: usize| -> &[usize] {
        if g.is_station_ok(l) {
            g.station_moves(l)
        } else {
            &[]
        }
    };
    for k in 0..kk {
        for l in 0..ng {
            // (7b)
            for i in 0..nd {
                for j in 1..td {
                    let e = sum(&mut dn(l).iter().map(|&m| x(i, j - 1, k, m)));
                    add(&mut p, e.geq(x(i, j, k, l)));
                }
            }
            // (7c)
            for a in 0..nc {
                for b in 1..tc {
                    let e = sum(&mut sn(l).iter().map(|&m| y(a, b - 1, k, m)));
                    add(&mut p, e.geq(y(a, b, k, l)));
                }
            }
            // (7d)
            for b in 0..tc {
                let e = sum(&mut (0..nc).map(|a| y(a, b, k, l)));
                add(&mut p, e.leq(1.0));
            }
            // (7e)
            for j in 1..td.saturating_sub(1) {
                let e = sum(&mut (0..nd).map(|i| x(i, j, k, l)));
                add(&mut p, e.leq(1.0));
            }
        }
        // (7f)
        for i in 0..nd {
            for j in 0..td {
                let e = sum(&mut (0..ng).map(|l| x(i, j, k, l)));
                add(&mut p, e.eq(lam[k]));
            }
        }
        for a in 0..nc {
            for b in 0..tc {
                let e = sum(&mut (0..ng).map(|l| y(a, b, k, l)));
                add(&mut p, e.eq(lam[k]));
            }
        }
        // (7g)
        if k + 1 < kk {
            add(&mut p, Expression::from(lam[k]).geq(lam[k + 1]));
        }
    }
    // Pinned stations stay on their start cell in every active cycle.
    for pin in &inst.pinned {
        let (a, l) = (pin.station, inst.stations[pin.station]);
        for (k, &on) in lam.iter().enumerate() {
            for b in 0..tc {
                add(&mut p, (Expression::from(y(a, b, k, l)) - on).eq(0.0));
            }
        }
    }
    // (8a)
    for &l in &inst.goals {
        let mut e = Expression::with_capacity(nd * td * kk);
        for i in 0..nd {
            for j in 0..td {
                for k in 0..kk {
                    e.add_mul(1.0, x(i, j, k, l));
                }
            }
        }
        add(&mut p, e.geq(1.0));
    }
    // (8b), (8c)
    for l in 0..ng {
        for k in 0..kk {
            if g.is_blocked(l) {
                for i in 0..nd {
                    for j in 0..td {
                        add(&mut p, Expression::from(x(i, j, k, l)).eq(0.0));
                    }
                }
            }
            if g.is_blocked(l) || !g.is_station_ok(l) {
                for a in 0..nc {
                    for b in 0..tc {
                        add(&mut p, Expression::from(y(a, b, k, l)).eq(0.0));
                    }
                }
            }
        }
    }
    for k in 0..kk {
        // (9a)
        for i in 0..nd {
            let mut e = Expression::with_capacity(td * ng);
            for j in 0..td {
                for l in 0..ng {
                    e.add_mul(1.0, x(i, j, k, l));
                }
            }
            add(&mut p, e.leq(td as f64));
        }
        for a in 0..nc {
            let mut e = Expression::with_capacity(tc * ng);
            for b in 0..tc {
                for l in 0..ng {
                    e.add_mul(1.0, y(a, b, k, l));
                }
            }
            add(&mut p, e.leq(tc as f64));
        }
        for l in 0..ng {
            // (9b), (9c) for k ∈ [0, K − 2]
            if k + 1 < kk {
                let slack = 2.0 - 2.0 * Expression::from(lam[k + 1]);
                for i in 0..nd {
                    let d = Expression::from(x(i, 0, k + 1, l)) - x(i, td - 1, k, l);
                    add(&mut p, d.clone().leq(slack.clone()));
                    add(&mut p, (-d).leq(slack.clone()));
                }
                for a in 0..nc {
                    let d = Expression::from(y(a, 0, k + 1, l)) - y(a, tc - 1, k, l);
                    add(&mut p, d.clone().leq(slack.clone()));
                    add(&mut p, (-d).leq(slack.clone()));
                }
            }
            // (9d)
            let s0 = sum(&mut (0..nc).map(|a| y(a, 0, k, l)));
            let s1 = sum(&mut (0..nc).map(|a| y(a, tc - 1, k, l)));
            for i in 0..nd {
                add(&mut p, s0.clone().geq(x(i, 0, k, l)));
                add(&mut p, s1.clone().geq(x(i, td - 1, k, l)));
            }
            // (10), less the chargers taken on a pinned station standing on l
            if let Some(c) = inst.capacity_at(l) {
                let e0 = sum(&mut (0..nd).map(|i| x(i, 0, k, l)));
                let e1 = sum(&mut (0..nd).map(|i| x(i, td - 1, k, l)));
                add(&mut p, e0.leq(c as f64));
                add(&mut p, e1.leq(c as f64));
            }
        }
    }
    let result = classify(p.solve());
    let mut attempt = Attempt {
        cycles: kk,
        status: PlanStatus::Error,
        seconds: 0.0,
        variables: n_vars,
        constraints: rows,
        presolved: false,
    };
    let raw = match result {
        Err(raw) => raw,
        Ok((sol, optimal)) => {
            let on = |v: Variable| sol.value(v) > 0.5;
            let cycles = lam.iter().take_while(|&&v| on(v)).count();
            let pos = |found: Option<usize>| found.unwrap_or(0);
            let drones = (0..nd)
                .map(|i| {
                    let mut t = Vec::with_capacity(cycles * (td - 1) + 1);
                    for k in 0..cycles {
                        for j in usize::from(k > 0)..td {
                            t.push(pos((0..ng).find(|&l| on(x(i, j, k, l)))));
                        }
                    }
                    t
                })
                .collect();
            let stations = (0..nc)
                .map(|a| {
                    let mut t = Vec::with_capacity(cycles * (tc - 1) + 1);
                    for k in 0..cycles {
                        for b in usize::from(k > 0)..tc {
                            t.push(pos((0..ng).find(|&l| on(y(a, b, k, l)))));
                        }
                    }
                    t
                })
                .collect();
            RawResult::Solved {
                optimal,
                timelines: Timelines {
                    cycles,
                    drones,
                    stations,
                },
            }
        }
    };
    attempt.seconds = elapsed() - t0;
    let (status, tl, msg) = match raw {
        RawResult::Solved { optimal, timelines } => (
            if optimal {
                PlanStatus::Optimal
            } else {
                PlanStatus::TimeLimit
            },
            Some(timelines),
            String::new(),
        ),
        RawResult::Infeasible => (PlanStatus::Infeasible, None, String::new()),
        RawResult::TimeLimit => (PlanStatus::TimeLimit, None, String::new()),
        RawResult::Error(m) => (PlanStatus::Error, None, m),
    };
    attempt.status = status;
    (status, tl, vec![attempt], msg)
}
