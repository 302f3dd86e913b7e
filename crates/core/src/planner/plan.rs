//! A plan of the integer program (11): every drone's and station's cells per sensing cycle,
//! as the paper states it ([`IpPlan`]) and as the models produce it ([`Timelines`], dense cell
//! indices on one timeline per vehicle). The result type shared by the models
//! ([`super::ip`]), the re-pairing (`super::assign`) and the independent checker
//! ([`super::check`]), kept apart from all three so that none imports another's internals.

use super::scenario::Instance;
use crate::geo::Cell;
use serde::{Deserialize, Serialize};

/// Drone and station paths per sensing cycle.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct IpPlan {
    /// The number of sensing cycles (Σ λ_k).
    pub cycles: usize,
    /// `drones[i][k][j]`: where drone i is at step j ∈ [0, T_d − 1] of cycle k. The last cell of
    /// cycle k is the first of cycle k + 1 (eq. 9b).
    pub drones: Vec<Vec<Vec<Cell>>>,
    /// `stations[a][k][b]`: where station a is at step b ∈ [0, T_c − 1] of cycle k.
    pub stations: Vec<Vec<Vec<Cell>>>,
}

/// Paths in dense cell indices, as the models produce them: `drones[i][t]` on the drone
/// timeline t = k(T_d − 1) + j, `stations[a][s]` on the station timeline s = k(T_c − 1) + b.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Timelines {
    /// Number of sensing cycles.
    pub cycles: usize,
    /// Drone positions, `cycles·(T_d − 1) + 1` per drone.
    pub drones: Vec<Vec<usize>>,
    /// Station positions, `cycles·(T_c − 1) + 1` per station.
    pub stations: Vec<Vec<usize>>,
}

impl Timelines {
    /// Cut the timelines into sensing cycles of T_d (T_c) cells each.
    pub(crate) fn to_plan(&self, inst: &Instance) -> IpPlan {
        let g = &inst.grid;
        let cut = |paths: &[Vec<usize>], len: usize| -> Vec<Vec<Vec<Cell>>> {
            paths
                .iter()
                .map(|p| {
                    (0..self.cycles)
                        .map(|k| {
                            (0..len)
                                .map(|j| g.cell(p[k * (len - 1) + j]))
                                .collect::<Vec<_>>()
                        })
                        .collect()
                })
                .collect()
        };
        IpPlan {
            cycles: self.cycles,
            drones: cut(&self.drones, inst.td),
            stations: cut(&self.stations, inst.tc),
        }
    }

    /// Timelines of a plan (`None` if a cell is outside the grid or the cycles do not chain).
    pub fn from_plan(plan: &IpPlan, inst: &Instance) -> Option<Timelines> {
        let g = &inst.grid;
        let join = |paths: &[Vec<Vec<Cell>>], len: usize| -> Option<Vec<Vec<usize>>> {
            paths
                .iter()
                .map(|cycles| {
                    let mut out: Vec<usize> = Vec::new();
                    for (k, steps) in cycles.iter().enumerate() {
                        if steps.len() != len {
                            return None;
                        }
                        for (j, &c) in steps.iter().enumerate() {
                            let i = g.index(c)?;
                            if k > 0 && j == 0 {
                                if out.last() != Some(&i) {
                                    return None;
                                }
                            } else {
                                out.push(i);
                            }
                        }
                    }
                    Some(out)
                })
                .collect()
        };
        Some(Timelines {
            cycles: plan.cycles,
            drones: join(&plan.drones, inst.td)?,
            stations: join(&plan.stations, inst.tc)?,
        })
    }
}
