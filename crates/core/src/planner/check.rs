//! An independent checker of plans: written from the problem statement (bandit paper §II and
//! eq. 7–10 as prose), sharing no code with the models of [`super::ip`] but the instance's grid
//! (its cell indexing and its obstacle and road flags) — moves are checked with cell arithmetic,
//! not with the grid's neighbour lists — so that a bug in a model or in the re-pairing cannot
//! hide itself.

use super::plan::IpPlan;
use super::scenario::Instance;
use crate::geo::Cell;
use std::collections::{BTreeMap, BTreeSet};

/// The list of violated rules of a plan.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the plan violates {} rule(s): {}", .violations.len(), .violations.join("; "))]
pub struct CheckError {
    /// One sentence per violation.
    pub violations: Vec<String>,
}

/// What to check besides the paper's constraints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CheckOptions {
    /// Also reject two drones (or two stations) swapping cells head-on between two steps,
    /// which the linear-assignment re-pairing of §III-C removes.
    pub no_head_on_swaps: bool,
}

fn show(c: Cell) -> String {
    format!("[{}, {}]", c.row, c.col)
}

#[cfg(test)]
/// Check `plan` against `inst` with the default options (the paper's constraints only).
pub(crate) fn check_plan(inst: &Instance, plan: &IpPlan) -> Result<(), CheckError> {
    check_plan_with(inst, plan, CheckOptions::default())
}

/// Check `plan` against `inst`: shapes (N_d drones and N_c stations, `cycles` ≤ K cycles of
/// T_d and T_c cells), start configuration (7a), continuity between cycles (9b, 9c), legal
/// moves (a king's move or a pass, 7b, 7c), obstacles (8b) and station-admissible cells (8c),
/// stations never sharing a cell (7d), drones never sharing a cell strictly inside a cycle
/// (7e), drones on a cell occupied by a station at the first and last step of every cycle (9d),
/// at most C drones there (10; fewer on a pinned station with chargers taken), pinned
/// stations that never leave their cell ([`super::scenario::Pin`]), and every goal visited
/// (8a).
pub fn check_plan_with(
    inst: &Instance,
    plan: &IpPlan,
    opts: CheckOptions,
) -> Result<(), CheckError> {
    let mut v: Vec<String> = Vec::new();
    let g = &inst.grid;
    let (td, tc, kc) = (inst.td, inst.tc, plan.cycles);
    if kc == 0 || kc > inst.k_max {
        v.push(format!("{kc} cycles, expected 1 to K = {}", inst.k_max));
    }
    if plan.drones.len() != inst.nd() || plan.stations.len() != inst.nc() {
        v.push(format!(
            "{} drone and {} station paths, expected {} and {}",
            plan.drones.len(),
            plan.stations.len(),
            inst.nd(),
            inst.nc()
        ));
        return Err(CheckError { violations: v });
    }
    let shape_ok = |paths: &Vec<Vec<Vec<Cell>>>, len: usize| {
        paths
            .iter()
            .all(|p| p.len() == kc && p.iter().all(|c| c.len() == len))
    };
    if !shape_ok(&plan.drones, td) || !shape_ok(&plan.stations, tc) {
        v.push(format!(
            "every drone needs {kc} cycles of Td = {td} cells and every station {kc} cycles of Tc = {tc} cells"
        ));
        return Err(CheckError { violations: v });
    }
    let inside = |c: Cell| {
        c.row >= 0 && c.col >= 0 && (c.row as usize) < g.rows() && (c.col as usize) < g.cols()
    };
    let blocked = |c: Cell| g.index(c).is_none_or(|i| g.is_blocked(i));
    let road = |c: Cell| g.index(c).is_some_and(|i| g.is_station_ok(i));
    let king = |a: Cell, b: Cell| a.row.abs_diff(b.row) <= 1 && a.col.abs_diff(b.col) <= 1;
    for (kind, paths, starts, len) in [
        ("drone", &plan.drones, &inst.drones, td),
        ("station", &plan.stations, &inst.stations, tc),
    ] {
        for (i, p) in paths.iter().enumerate() {
            let start = g.cell(starts[i]);
            if p[0][0] != start {
                v.push(format!(
                    "{kind} {i} starts at {} instead of {}",
                    show(p[0][0]),
                    show(start)
                ));
            }
            for k in 0..kc {
                if k > 0 && p[k][0] != p[k - 1][len - 1] {
                    v.push(format!(
                        "{kind} {i} starts cycle {k} at {} but ended cycle {} at {}",
                        show(p[k][0]),
                        k - 1,
                        show(p[k - 1][len - 1])
                    ));
                }
                for j in 0..len {
                    let c = p[k][j];
                    if !inside(c) {
                        v.push(format!("{kind} {i} leaves the grid at cycle {k} step {j}"));
                        continue;
                    }
                    if blocked(c) {
                        v.push(format!(
                            "{kind} {i} is on obstacle {} at cycle {k} step {j}",
                            show(c)
                        ));
                    }
                    if kind == "station" && !road(c) {
                        v.push(format!(
                            "station {i} leaves the station cells at {} (cycle {k} step {j})",
                            show(c)
                        ));
                    }
                    if j > 0 && !king(p[k][j - 1], c) {
                        v.push(format!(
                            "{kind} {i} jumps from {} to {} at cycle {k} step {j}",
                            show(p[k][j - 1]),
                            show(c)
                        ));
                    }
                }
            }
        }
    }
    for pin in &inst.pinned {
        let home = g.cell(inst.stations[pin.station]);
        if let Some(c) = plan.stations[pin.station]
            .iter()
            .flatten()
            .find(|&&c| c != home)
        {
            v.push(format!(
                "station {} is held at {} but moves to {}",
                pin.station,
                show(home),
                show(*c)
            ));
        }
    }
    for k in 0..kc {
        for b in 0..tc {
            let mut seen = BTreeSet::new();
            for (a, p) in plan.stations.iter().enumerate() {
                if !seen.insert(p[k][b]) {
                    v.push(format!(
                        "station {a} shares {} with another station at cycle {k} step {b}",
                        show(p[k][b])
                    ));
                }
            }
        }
        for j in 1..td.saturating_sub(1) {
            let mut seen = BTreeSet::new();
            for (i, p) in plan.drones.iter().enumerate() {
                if !seen.insert(p[k][j]) {
                    v.push(format!(
                        "drone {i} shares {} with another drone at cycle {k} step {j}",
                        show(p[k][j])
                    ));
                }
            }
        }
        for (j, b) in [(0, 0), (td - 1, tc - 1)] {
            let stations: BTreeSet<Cell> = plan.stations.iter().map(|p| p[k][b]).collect();
            let mut count: BTreeMap<Cell, usize> = BTreeMap::new();
            for (i, p) in plan.drones.iter().enumerate() {
                let c = p[k][j];
                *count.entry(c).or_default() += 1;
                if !stations.contains(&c) {
                    v.push(format!(
                        "drone {i} is at {} at cycle {k} step {j} where no station is",
                        show(c)
                    ));
                }
            }
            if let Some(cap) = inst.capacity {
                for (c, n) in count {
                    // A pinned station standing there has chargers taken already.
                    let taken = inst
                        .pinned
                        .iter()
                        .find(|p| g.cell(inst.stations[p.station]) == c)
                        .map_or(0, |p| p.taken);
                    if n + taken > cap {
                        v.push(format!(
                            "{n} drones on the station at {} at cycle {k} step {j}, capacity \
                             {cap}{}",
                            show(c),
                            if taken > 0 {
                                format!(" with {taken} charger(s) taken")
                            } else {
                                String::new()
                            }
                        ));
                    }
                }
            }
        }
    }
    let visited: BTreeSet<Cell> = plan
        .drones
        .iter()
        .flat_map(|p| p.iter().flatten().copied())
        .collect();
    for &goal in &inst.goals {
        let c = g.cell(goal);
        if !visited.contains(&c) {
            v.push(format!("goal {} is never visited", show(c)));
        }
    }
    if opts.no_head_on_swaps {
        for (kind, paths) in [("drones", &plan.drones), ("stations", &plan.stations)] {
            for k in 0..kc {
                let len = paths.first().map_or(0, |p| p[k].len());
                for j in 0..len.saturating_sub(1) {
                    for u in 0..paths.len() {
                        for w in u + 1..paths.len() {
                            let (a, b) = (&paths[u][k], &paths[w][k]);
                            if a[j] != a[j + 1] && a[j] == b[j + 1] && b[j] == a[j + 1] {
                                v.push(format!(
                                    "{kind} {u} and {w} swap {} and {} head-on at cycle {k} step {j}",
                                    show(a[j]),
                                    show(b[j])
                                ));
                            }
                        }
                    }
                }
            }
        }
    }
    if v.is_empty() {
        Ok(())
    } else {
        Err(CheckError { violations: v })
    }
}
