//! IP scenario files and plan output (`docs/ip-scenario.md`): one epoch of the low-level
//! planner (bandit paper Algorithm 2), read from JSON, validated into an [`Instance`], and
//! the solved plan written back as JSON with exactly the spec's keys.

use super::grid::{GridError, PlannerGrid};
use crate::geo::Cell;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Why a scenario is malformed. Every message names the offending key and value.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScenarioError {
    /// The file is not valid JSON or a key has the wrong type.
    #[error("malformed scenario JSON: {0}")]
    Json(String),
    /// The grid, obstacles or station cells are malformed.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// A vehicle, goal or parameter is malformed.
    #[error("{0}")]
    Invalid(String),
    /// Well formed, but no plan can satisfy (7)–(10) whatever K: a goal on an obstacle, a
    /// drone that does not start on a station's cell (9d), more than C drones on one station
    /// at the start (10). The spec does not count these as malformed, so a scenario file gets
    /// the status `"infeasible"` for them ([`crate::planner::ip::solve`]); the field runner and
    /// the study, which never build such a team, treat them as errors.
    #[error("no plan can exist whatever K: {0}")]
    Infeasible(String),
}

/// One epoch's planning problem as in the scenario file: cells are `[row, col]`, 0-based, row 0
/// at the top. Field names map to the spec's JSON keys (`Td`, `Tc`, `K` keep their spelling).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Scenario {
    /// Free text.
    #[serde(default)]
    pub name: String,
    /// Grid rows (≥ 1).
    pub rows: i64,
    /// Grid columns (≥ 1).
    pub cols: i64,
    /// O: cells no vehicle may ever occupy.
    #[serde(with = "cell_list")]
    pub obstacles: Vec<Cell>,
    /// R: the station-admissible cells; `None` (JSON `null`) = every cell not in O.
    #[serde(with = "opt_cell_list", default)]
    pub station_cells: Option<Vec<Cell>>,
    /// Start cell of each drone i (Nd entries; several may share a cell).
    #[serde(with = "cell_list")]
    pub drones: Vec<Cell>,
    /// Start cell of each station a (Nc entries, pairwise distinct).
    #[serde(with = "cell_list")]
    pub stations: Vec<Cell>,
    /// E_p: the epoch goals; each must be visited by some drone at some step of some cycle.
    #[serde(with = "cell_list")]
    pub goals: Vec<Cell>,
    /// T_d: drone time steps (cells) per sensing cycle (≥ 2, a multiple of T_c).
    #[serde(rename = "Td")]
    pub td: i64,
    /// T_c: station time steps (cells) per sensing cycle (≥ 2).
    #[serde(rename = "Tc")]
    pub tc: i64,
    /// K: the upper bound on the number of sensing cycles (≥ 1).
    #[serde(rename = "K")]
    pub k: i64,
    /// C of eq. (10): most drones on one station cell at a cycle's start and end; `None` = no limit.
    #[serde(default)]
    pub capacity: Option<i64>,
}

mod cell_list {
    use crate::geo::Cell;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub(super) fn serialize<S: Serializer>(cells: &[Cell], s: S) -> Result<S::Ok, S::Error> {
        let v: Vec<[i32; 2]> = cells.iter().map(|c| [c.row, c.col]).collect();
        v.serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Cell>, D::Error> {
        let v: Vec<[i32; 2]> = Vec::deserialize(d)?;
        Ok(v.into_iter().map(|[r, c]| Cell::new(r, c)).collect())
    }
}

mod opt_cell_list {
    use crate::geo::Cell;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub(super) fn serialize<S: Serializer>(
        cells: &Option<Vec<Cell>>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let v: Option<Vec<[i32; 2]>> = cells
            .as_ref()
            .map(|c| c.iter().map(|c| [c.row, c.col]).collect());
        v.serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<Vec<Cell>>, D::Error> {
        let v: Option<Vec<[i32; 2]>> = Option::deserialize(d)?;
        Ok(v.map(|v| v.into_iter().map(|[r, c]| Cell::new(r, c)).collect()))
    }
}

/// A validated planning instance in dense cell indices (see [`PlannerGrid`]): what the IP solves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Instance {
    /// G, O and R.
    pub grid: PlannerGrid,
    /// X_0: the start cell (dense index) of each drone.
    pub drones: Vec<usize>,
    /// Y_0: the start cell (dense index) of each station; pairwise distinct.
    pub stations: Vec<usize>,
    /// E_p (dense indices, sorted, without duplicates).
    pub goals: Vec<usize>,
    /// T_d: drone cells per sensing cycle.
    pub td: usize,
    /// T_c: station cells per sensing cycle.
    pub tc: usize,
    /// K: the most sensing cycles a plan may use.
    pub k_max: usize,
    /// C of eq. (10), or `None` for no limit.
    pub capacity: Option<usize>,
    /// Stations that stay on their start cell for the whole plan, with the chargers taken
    /// there by drones that do not fly ([`Pin`]); empty in the paper's problem, and in every
    /// scenario file (a field run sets them: [`Instance::with_pins`]).
    pub pinned: Vec<Pin>,
}

/// A station held on its start cell for the whole plan — a rover that cannot drive, or one
/// carrying a drone that is out of the run — with `taken` of its C chargers taken by drones
/// that stay on it (not in the instance's drones): at most C − `taken` drones of the plan on
/// it at a cycle boundary (10).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pin {
    /// The station (index into [`Instance::stations`]).
    pub station: usize,
    /// Chargers on it taken by drones outside the plan.
    pub taken: usize,
}

impl Instance {
    /// Validate a team configuration on `grid` (the checks of [`Scenario::instance`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        grid: PlannerGrid,
        drones: Vec<usize>,
        stations: Vec<usize>,
        goals: Vec<usize>,
        td: usize,
        tc: usize,
        k_max: usize,
        capacity: Option<usize>,
    ) -> Result<Instance, ScenarioError> {
        let bad = |m: String| Err(ScenarioError::Invalid(m));
        let never = |m: String| Err(ScenarioError::Infeasible(m));
        let show = |i: usize| {
            let c = grid.cell(i);
            format!("[{}, {}]", c.row, c.col)
        };
        if td < 2 || tc < 2 {
            return bad(format!(
                "Td and Tc must be at least 2, got Td={td}, Tc={tc}"
            ));
        }
        if !td.is_multiple_of(tc) {
            return bad(format!(
                "Td must be a multiple of Tc (Td = γ·Tc with an integer speed ratio γ), got Td={td}, Tc={tc}"
            ));
        }
        if k_max < 1 {
            return bad("K must be at least 1".into());
        }
        if capacity == Some(0) {
            return bad("capacity must be at least 1 or null".into());
        }
        if drones.is_empty() {
            return bad("drones: at least one drone is needed".into());
        }
        if stations.is_empty() {
            return bad("stations: at least one station is needed".into());
        }
        for (list, what) in [
            (&drones, "drones"),
            (&stations, "stations"),
            (&goals, "goals"),
        ] {
            for (n, &i) in list.iter().enumerate() {
                if i >= grid.len() {
                    return bad(format!("{what}[{n}] is outside the grid"));
                }
            }
        }
        for (list, what) in [(&drones, "drones"), (&stations, "stations")] {
            for (n, &i) in list.iter().enumerate() {
                if grid.is_blocked(i) {
                    return bad(format!("{what}[{n}] at {} is on an obstacle", show(i)));
                }
            }
        }
        for (a, &s) in stations.iter().enumerate() {
            if !grid.is_station_ok(s) {
                return bad(format!(
                    "stations[{a}] at {} is outside station_cells",
                    show(s)
                ));
            }
            if let Some(b) = stations[..a].iter().position(|&t| t == s) {
                return bad(format!(
                    "stations[{b}] and stations[{a}] both start at {}; stations must be pairwise distinct (eq. 7d)",
                    show(s)
                ));
            }
        }
        if let Some((n, &i)) = goals.iter().enumerate().find(|(_, i)| grid.is_blocked(**i)) {
            return never(format!(
                "goals[{n}] at {} is on an obstacle, where no drone may be (7b)",
                show(i)
            ));
        }
        let mut per_cell: BTreeMap<usize, usize> = BTreeMap::new();
        for (i, &d) in drones.iter().enumerate() {
            if !stations.contains(&d) {
                return never(format!(
                    "drones[{i}] at {} is not on a station's cell; every sensing cycle starts on a station (eq. 9d)",
                    show(d)
                ));
            }
            *per_cell.entry(d).or_default() += 1;
        }
        if let Some(c) = capacity {
            for (&cell, &n) in &per_cell {
                if n > c {
                    return never(format!(
                        "{n} drones start on {} but the charger capacity is {c} (eq. 10)",
                        show(cell)
                    ));
                }
            }
        }
        let mut goals = goals;
        goals.sort_unstable();
        goals.dedup();
        Ok(Instance {
            grid,
            drones,
            stations,
            goals,
            td,
            tc,
            k_max,
            capacity,
            pinned: Vec::new(),
        })
    }

    /// This instance with stations held on their start cells ([`Pin`]). Malformed: a station
    /// index out of range, a station pinned twice. Infeasible whatever K: a pinned station
    /// with more chargers taken than C, or the drones starting on it and the chargers taken
    /// there together above C (10).
    pub fn with_pins(mut self, pins: Vec<Pin>) -> Result<Instance, ScenarioError> {
        for (n, p) in pins.iter().enumerate() {
            if p.station >= self.stations.len() {
                return Err(ScenarioError::Invalid(format!(
                    "pinned station {} does not exist",
                    p.station
                )));
            }
            if pins[..n].iter().any(|q| q.station == p.station) {
                return Err(ScenarioError::Invalid(format!(
                    "station {} is pinned twice",
                    p.station
                )));
            }
            if let Some(c) = self.capacity {
                let cell = self.stations[p.station];
                let on = self.drones.iter().filter(|&&d| d == cell).count();
                if on + p.taken > c {
                    let rc = self.grid.cell(cell);
                    return Err(ScenarioError::Infeasible(format!(
                        "the station held at [{}, {}] has {} charger(s) taken and {on} drone(s) \
                         on it, capacity {c} (eq. 10)",
                        rc.row, rc.col, p.taken
                    )));
                }
            }
        }
        self.pinned = pins;
        Ok(self)
    }

    /// The pin of the station held on cell `l` (dense index), if one is.
    pub(crate) fn pin_at(&self, l: usize) -> Option<&Pin> {
        self.pinned
            .iter()
            .find(|p| self.stations.get(p.station) == Some(&l))
    }

    /// Drones of the plan allowed on the station at cell `l` at a cycle boundary: C (10),
    /// less the chargers taken there when a pinned station stands on `l`; `None`: no limit.
    pub(crate) fn capacity_at(&self, l: usize) -> Option<usize> {
        let c = self.capacity?;
        Some(c.saturating_sub(self.pin_at(l).map_or(0, |p| p.taken)))
    }

    /// Nd, the number of drones.
    pub fn nd(&self) -> usize {
        self.drones.len()
    }

    /// Nc, the number of stations.
    pub fn nc(&self) -> usize {
        self.stations.len()
    }

    /// Back to a scenario (cells as `[row, col]`), e.g. to write an epoch to a file.
    pub fn to_scenario(&self, name: &str) -> Scenario {
        let g = &self.grid;
        let cells = |v: &[usize]| v.iter().map(|&i| g.cell(i)).collect::<Vec<_>>();
        let obstacles: Vec<usize> = (0..g.len()).filter(|&i| g.is_blocked(i)).collect();
        let all_free = (0..g.len()).all(|i| g.is_blocked(i) || g.is_station_ok(i));
        let station_cells = if all_free {
            None
        } else {
            let r: Vec<usize> = (0..g.len()).filter(|&i| g.is_station_ok(i)).collect();
            Some(cells(&r))
        };
        Scenario {
            name: name.to_string(),
            rows: g.rows() as i64,
            cols: g.cols() as i64,
            obstacles: cells(&obstacles),
            station_cells,
            drones: cells(&self.drones),
            stations: cells(&self.stations),
            goals: cells(&self.goals),
            td: self.td as i64,
            tc: self.tc as i64,
            k: self.k_max as i64,
            capacity: self.capacity.map(|c| c as i64),
        }
    }
}

impl Scenario {
    /// Parse a scenario from JSON text (unknown keys are ignored).
    pub fn from_json(text: &str) -> Result<Scenario, ScenarioError> {
        serde_json::from_str(text).map_err(|e| ScenarioError::Json(e.to_string()))
    }

    /// The scenario as pretty JSON with the spec's keys.
    pub fn to_json(&self) -> String {
        // Serialising plain integers and strings cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Validate the scenario. Malformed, as the spec lists ([`ScenarioError::Invalid`]): a
    /// cell outside the grid, a vehicle on an obstacle, a station outside `station_cells`, Td
    /// not a multiple of Tc, and what the key table rules out (stations not pairwise distinct,
    /// Td or Tc < 2, K < 1, capacity < 1). Well formed but infeasible whatever K
    /// ([`ScenarioError::Infeasible`], the status `"infeasible"` in `fleetmap plan`): a goal on
    /// an obstacle, a drone off the stations' cells (9d at the first cycle), more than
    /// `capacity` drones on one start cell (10).
    pub fn instance(&self) -> Result<Instance, ScenarioError> {
        let grid = PlannerGrid::new(
            self.rows,
            self.cols,
            &self.obstacles,
            self.station_cells.as_deref(),
        )?;
        let idx = |what: &str, list: &[Cell]| -> Result<Vec<usize>, ScenarioError> {
            list.iter()
                .enumerate()
                .map(|(n, &c)| {
                    grid.index(c).ok_or_else(|| {
                        ScenarioError::Invalid(format!(
                            "{what}[{n}] = [{}, {}] is outside the {}×{} grid",
                            c.row, c.col, self.rows, self.cols
                        ))
                    })
                })
                .collect()
        };
        let drones = idx("drones", &self.drones)?;
        let stations = idx("stations", &self.stations)?;
        let goals = idx("goals", &self.goals)?;
        let pos = |name: &str, v: i64| -> Result<usize, ScenarioError> {
            if !(1..=1_000_000).contains(&v) {
                Err(ScenarioError::Invalid(format!(
                    "{name} must be an integer from 1 to 1000000, got {v}"
                )))
            } else {
                Ok(v as usize)
            }
        };
        let td = pos("Td", self.td)?;
        let tc = pos("Tc", self.tc)?;
        let k = pos("K", self.k)?;
        let capacity = match self.capacity {
            None => None,
            Some(c) => Some(pos("capacity", c)?),
        };
        Instance::new(grid, drones, stations, goals, td, tc, k, capacity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"{
        "name": "t", "rows": 3, "cols": 4, "obstacles": [[1, 1]], "station_cells": null,
        "drones": [[0, 0], [0, 0]], "stations": [[0, 0], [2, 3]], "goals": [[2, 0], [2, 0]],
        "Td": 4, "Tc": 2, "K": 2, "capacity": null, "extra": "ignored"
    }"#;

    #[test]
    fn parses_validates_and_round_trips() {
        let s = Scenario::from_json(SMALL).unwrap();
        assert_eq!(s.drones, vec![Cell::new(0, 0); 2]);
        let inst = s.instance().unwrap();
        assert_eq!(
            inst.goals,
            vec![8],
            "duplicates removed, row-major index 2·4+0"
        );
        assert_eq!((inst.td, inst.tc, inst.k_max), (4, 2, 2));
        let back = Scenario::from_json(&inst.to_scenario("t").to_json()).unwrap();
        assert_eq!(back.instance().unwrap(), inst);
    }

    fn err(edit: impl Fn(&mut Scenario)) -> String {
        let mut s = Scenario::from_json(SMALL).unwrap();
        edit(&mut s);
        s.instance().unwrap_err().to_string()
    }

    #[test]
    fn malformed_scenarios_are_clear_errors() {
        assert!(err(|s| s.goals.push(Cell::new(3, 0))).contains("goals[2] = [3, 0] is outside"));
        assert!(
            err(|s| s.drones.push(Cell::new(1, 1)))
                .contains("drones[2] at [1, 1] is on an obstacle")
        );
        assert!(err(|s| s.td = 5).contains("multiple of Tc"));
        assert!(err(|s| s.k = 0).contains("K must be"));
        assert!(err(|s| s.stations[1] = Cell::new(0, 0)).contains("pairwise distinct"));
        // Well formed, but no plan can exist: not malformed in the spec's sense.
        let never = |edit: &dyn Fn(&mut Scenario)| {
            let mut s = Scenario::from_json(SMALL).unwrap();
            edit(&mut s);
            match s.instance() {
                Err(ScenarioError::Infeasible(m)) => m,
                other => panic!("expected Infeasible, got {other:?}"),
            }
        };
        assert!(never(&|s| s.goals.push(Cell::new(1, 1))).contains("on an obstacle"));
        assert!(never(&|s| s.drones[1] = Cell::new(0, 1)).contains("not on a station"));
        assert!(never(&|s| s.capacity = Some(1)).contains("capacity is 1"));
        assert!(
            err(|s| s.station_cells = Some(vec![Cell::new(0, 0)]))
                .contains("outside station_cells")
        );
        assert!(err(|s| s.obstacles.push(Cell::new(0, 9))).contains("outside the 3×4 grid"));
        let e = Scenario::from_json(r#"{"rows": 2}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing field"), "{e}");
    }
}
