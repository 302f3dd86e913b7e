//! The team and its area: the search area in mission cells (and its mapping to the
//! planner's top-left indexing), the vehicles, a team configuration and a plan cut into
//! sorties.

use super::*;

/// The search area in mission cells.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Layout {
    /// Rows of G (0 … rows − 1, northward).
    pub rows: u32,
    /// Columns of G (0 … cols − 1, eastward).
    pub cols: u32,
    /// O: no-fly cells.
    pub obstacles: Vec<Cell>,
    /// R: station-admissible cells.
    pub roads: Vec<Cell>,
}

impl Layout {
    /// Mission cell → the planner's top-left cell.
    pub(crate) fn to_planner(&self, c: Cell) -> Cell {
        Cell::new(self.rows as i32 - 1 - c.row, c.col)
    }

    /// The planner's top-left cell → mission cell (the same flip).
    pub(crate) fn planner_to_mission(&self, c: Cell) -> Cell {
        self.to_planner(c)
    }

    /// The planner's grid (G, O, R in top-left indexing).
    pub(crate) fn planner_grid(&self) -> Result<PlannerGrid, SortieError> {
        let flip = |v: &[Cell]| v.iter().map(|&c| self.to_planner(c)).collect::<Vec<_>>();
        PlannerGrid::new(
            i64::from(self.rows),
            i64::from(self.cols),
            &flip(&self.obstacles),
            Some(&flip(&self.roads)),
        )
        .map_err(|e| SortieError::Mission(e.to_string()))
    }

    /// Whether `c` is inside G.
    pub fn contains(&self, c: Cell) -> bool {
        c.row >= 0 && c.col >= 0 && (c.row as u32) < self.rows && (c.col as u32) < self.cols
    }
}

/// One vehicle of the team.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Member {
    /// MAVLink system id.
    pub sysid: u8,
    /// Display name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Flight altitude above home, metres (0 for stations).
    pub altitude_m: f64,
}

/// Where the team is at a rendezvous: (X_0, Y_0) of (7a), mission cells, in team order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TeamConfig {
    /// Cell of each drone.
    pub drones: Vec<Cell>,
    /// Cell of each station.
    pub stations: Vec<Cell>,
}

/// Paths of the rest of an epoch, mission cells: `drones[i][k][j]`, `stations[a][k][b]`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SortiePlan {
    /// Sensing cycles.
    pub cycles: usize,
    /// Drone paths per cycle (T_d cells each).
    pub drones: Vec<Vec<Vec<Cell>>>,
    /// Station paths per cycle (T_c cells each).
    pub stations: Vec<Vec<Vec<Cell>>>,
}

impl SortiePlan {}
