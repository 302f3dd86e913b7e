//! Linear-assignment re-pairing of the vehicles between consecutive time steps (bandit paper
//! §III-C, after Michael et al. \[25\]).
//!
//! For each step t → t + 1 of the plan, the cells the team occupies at t + 1 (a multiset
//! 𝒯_{t+1}) are re-assigned to the vehicles at t by a bijection f minimising
//! Σ C(l, f(l)) with C the Euclidean distance between cell centres — solved with the
//! Hungarian algorithm of the `pathfinding` crate (`kuhn_munkres`). The vehicles then continue
//! from their new cells, and the next step is re-paired from there. Pairs that are not one legal
//! move (a king's move or a pass between free cells; within R for stations) are forbidden, so
//! the re-paired plan is made of legal moves.
//!
//! **Every constraint still holds.** The multiset of occupied cells at every step is the
//! plan's, so every occupancy constraint — goals covered (8a), mid-cycle and station
//! separation (7d)/(7e), drones on station cells at cycle boundaries (9d), capacity (10) — is
//! unchanged; moves are legal by the restriction above; and because every drone still has one
//! cell per step, it still starts and ends every sensing cycle on a station cell and flies
//! exactly T_d cells per cycle, so the battery accounting (9a) holds per drone and per cycle
//! (a drone that takes over another's path suffix mid-cycle has also flown exactly the same
//! number of steps since its last recharge). A legal bijection always exists: the plan's own
//! pairing of 𝒯_t with 𝒯_{t+1}.
//!
//! **No head-on swaps.** If an optimal f sent a vehicle p → q and another q → p (p ≠ q), the
//! pairing p → p, q → q (both passes, legal, and both p and q are in 𝒯_{t+1}) would cost
//! 2·C(p, q) less; so an optimal f has no swap. The same argument removes the crossing of two
//! diagonal moves inside one 2×2 block ((0,0)→(1,1) with (0,1)→(1,0) costs 2√2, the
//! uncrossed pairing 2).
//!
//! **Integer weights and exactness.** `kuhn_munkres` needs integers. A legal move costs 0, 1 or
//! √2 cell widths; we use the weights 0, M and R = round(√2·M) with M = 2³⁰. Two assignments
//! with a and b unit moves, and a' and b' diagonal ones, differ in real cost by
//! Δ = p + q√2 (p = a − a', q = b − b', |p|, |q| ≤ N for N vehicles) and in scaled cost by
//! M·Δ + q·(R − √2·M), where |R − √2·M| ≤ 1/2. As √2 is irrational, Δ = 0 only if p = q = 0
//! (and then the scaled costs agree too). Otherwise |p + q√2|·|p − q√2| = |p² − 2q²| ≥ 1, so
//! |Δ| ≥ 1/|p − q√2| ≥ 1/((1 + √2)N), while the rounding term is at most N/2. For
//! M > (1 + √2)N²/2 — with M = 2³⁰, up to N = 29,000 vehicles — the scaled comparison
//! therefore orders assignments exactly as the Euclidean one: the integer optimum is a
//! Euclidean optimum. Forbidden pairs weigh more than any legal assignment can.

use super::grid::PlannerGrid;
use super::plan::Timelines;
use super::scenario::Instance;
use pathfinding::prelude::{Matrix, kuhn_munkres_min};

/// The scale M of the integer weights (see the module documentation).
const SCALE: i64 = 1 << 30;

/// Most vehicles for which the scaled weights are provably exact.
pub(crate) const MAX_VEHICLES: usize = 29_000;

/// Re-pair drones and stations of `timelines` step by step (drones: legal drone moves;
/// stations: legal station moves). Teams larger than [`MAX_VEHICLES`] are left unchanged.
pub(crate) fn repair(inst: &Instance, timelines: &mut Timelines) {
    let g = &inst.grid;
    repair_paths(g, &mut timelines.drones, |a, b| g.is_move(a, b));
    repair_paths(g, &mut timelines.stations, |a, b| g.is_station_move(a, b));
}

/// Re-pair one team's paths (all the same length) in place; `legal(a, b)` says whether a → b
/// is one move.
pub(crate) fn repair_paths(
    g: &PlannerGrid,
    paths: &mut [Vec<usize>],
    legal: impl Fn(usize, usize) -> bool,
) {
    let n = paths.len();
    if !(2..=MAX_VEHICLES).contains(&n) {
        return;
    }
    let len = paths[0].len();
    if paths.iter().any(|p| p.len() != len) {
        return;
    }
    let weight = |a: usize, b: usize| -> i64 {
        let dr = g.cell(a).row.abs_diff(g.cell(b).row);
        let dc = g.cell(a).col.abs_diff(g.cell(b).col);
        match dr + dc {
            0 => 0,
            1 => SCALE,
            _ => (std::f64::consts::SQRT_2 * SCALE as f64).round() as i64,
        }
    };
    let forbidden = 2 * SCALE * (n as i64 + 1);
    for t in 0..len.saturating_sub(1) {
        let here: Vec<usize> = paths.iter().map(|p| p[t]).collect();
        let next: Vec<usize> = paths.iter().map(|p| p[t + 1]).collect();
        let m = Matrix::from_fn(n, n, |(i, q)| {
            if legal(here[i], next[q]) {
                weight(here[i], next[q])
            } else {
                forbidden
            }
        });
        let (_, f) = kuhn_munkres_min(&m);
        if f.iter().enumerate().any(|(i, &q)| !legal(here[i], next[q])) {
            // Cannot happen (the plan's own pairing is legal); keep the plan as it is.
            continue;
        }
        for (i, &q) in f.iter().enumerate() {
            paths[i][t + 1] = next[q];
        }
    }
}

#[cfg(test)]
/// Pairs of vehicles that swap cells head-on between steps t and t + 1: `(t, u, v)`.
pub(crate) fn head_on_swaps(paths: &[Vec<usize>]) -> Vec<(usize, usize, usize)> {
    let mut out = Vec::new();
    let len = paths.iter().map(Vec::len).min().unwrap_or(0);
    for t in 0..len.saturating_sub(1) {
        for u in 0..paths.len() {
            for v in u + 1..paths.len() {
                let (a, b) = (&paths[u], &paths[v]);
                if a[t] != a[t + 1] && a[t] == b[t + 1] && b[t] == a[t + 1] {
                    out.push((t, u, v));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::Cell;

    #[test]
    fn swaps_and_diagonal_crossings_are_removed_with_the_same_occupancy() {
        let g = PlannerGrid::new(3, 3, &[], None).unwrap();
        let i = |r, c| g.index(Cell::new(r, c)).unwrap();
        // Drone 0: (0,0)→(0,1)→(1,1); drone 1: (0,1)→(0,0)→(1,0) (head-on at step 0→1),
        // then a diagonal crossing at step 1→2 after the swap: (0,1)→(1,0) and (0,0)→(1,1).
        let mut paths = vec![
            vec![i(0, 0), i(0, 1), i(1, 0)],
            vec![i(0, 1), i(0, 0), i(1, 1)],
        ];
        assert_eq!(head_on_swaps(&paths).len(), 1);
        let occupancy = |p: &[Vec<usize>]| {
            (0..3)
                .map(|t| {
                    let mut v: Vec<usize> = p.iter().map(|x| x[t]).collect();
                    v.sort();
                    v
                })
                .collect::<Vec<_>>()
        };
        let before = occupancy(&paths);
        repair_paths(&g, &mut paths, |a, b| g.is_move(a, b));
        assert_eq!(occupancy(&paths), before);
        assert!(head_on_swaps(&paths).is_empty());
        assert_eq!(paths[0], vec![i(0, 0), i(0, 0), i(1, 0)]);
        assert_eq!(paths[1], vec![i(0, 1), i(0, 1), i(1, 1)]);
    }

    #[test]
    fn illegal_pairs_are_never_used() {
        // A 1×4 corridor: the cheapest bijection by distance alone is illegal here.
        let g = PlannerGrid::new(1, 4, &[], None).unwrap();
        let mut paths = vec![vec![0, 1], vec![2, 3]];
        repair_paths(&g, &mut paths, |a, b| g.is_move(a, b));
        assert!(paths.iter().all(|p| g.is_move(p[0], p[1])));
    }
}
