//! The planner's grid G (bandit paper §II): a `rows × cols` rectangle of cells, the obstacle set
//! O, the station-admissible set R, and the king's-move neighbourhoods N(l) and N_c(l).
//!
//! Cells are addressed by [`Cell`] (`row`, `col`, 0-based, the IP scenario's indexing of
//! `docs/ip-scenario.md`) at the API and by a dense row-major index `row·cols + col`
//! internally. A move is one of the 8 king's moves or a pass (staying in place), so N(l)
//! contains l itself: the spec's "a move goes to any of the 8 neighbours or stays in place".

use crate::geo::Cell;
use std::collections::VecDeque;

/// Why a grid could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GridError {
    /// `rows` or `cols` is zero or the grid is unreasonably large.
    #[error(
        "the grid must have 1 to 1,000,000 cells in 1 to 10,000 rows and columns, got {rows}×{cols}"
    )]
    BadSize {
        /// Requested rows.
        rows: i64,
        /// Requested columns.
        cols: i64,
    },
    /// A cell lies outside the grid.
    #[error("{what} cell [{row}, {col}] is outside the {rows}×{cols} grid")]
    OutOfGrid {
        /// Which list the cell came from.
        what: String,
        /// Row index.
        row: i64,
        /// Column index.
        col: i64,
        /// Grid rows.
        rows: usize,
        /// Grid columns.
        cols: usize,
    },
    /// A station-admissible cell is an obstacle (the paper requires R ⊆ G \ O).
    #[error(
        "station cell [{row}, {col}] is an obstacle (the station-admissible set must avoid obstacles)"
    )]
    StationCellOnObstacle {
        /// Row index.
        row: i32,
        /// Column index.
        col: i32,
    },
}

/// The grid with its obstacles and station-admissible cells.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlannerGrid {
    rows: usize,
    cols: usize,
    blocked: Vec<bool>,
    station_ok: Vec<bool>,
    /// N(l) for free cells (l itself first, then free king neighbours); empty for obstacles.
    nbrs: Vec<Vec<usize>>,
    /// N_c(l) = R ∩ N(l) for station-admissible cells; empty elsewhere.
    station_nbrs: Vec<Vec<usize>>,
}

impl PlannerGrid {
    /// Build a grid of `rows × cols` cells with `obstacles` (O) and the station-admissible set
    /// (`None`: every free cell, i.e. R = G \ O as in the paper's §VI simulations).
    pub fn new(
        rows: i64,
        cols: i64,
        obstacles: &[Cell],
        station_cells: Option<&[Cell]>,
    ) -> Result<PlannerGrid, GridError> {
        if rows < 1 || cols < 1 || rows > 10_000 || cols > 10_000 || rows * cols > 1_000_000 {
            return Err(GridError::BadSize { rows, cols });
        }
        let (r, c) = (rows as usize, cols as usize);
        let n = r * c;
        let mut blocked = vec![false; n];
        let check = |what: &str, cell: Cell| -> Result<usize, GridError> {
            if cell.row < 0 || cell.col < 0 || cell.row as i64 >= rows || cell.col as i64 >= cols {
                Err(GridError::OutOfGrid {
                    what: what.to_string(),
                    row: cell.row as i64,
                    col: cell.col as i64,
                    rows: r,
                    cols: c,
                })
            } else {
                Ok(cell.row as usize * c + cell.col as usize)
            }
        };
        for &o in obstacles {
            blocked[check("obstacle", o)?] = true;
        }
        let station_ok = match station_cells {
            None => blocked.iter().map(|b| !b).collect(),
            Some(list) => {
                let mut ok = vec![false; n];
                for &s in list {
                    let i = check("station_cells", s)?;
                    if blocked[i] {
                        return Err(GridError::StationCellOnObstacle {
                            row: s.row,
                            col: s.col,
                        });
                    }
                    ok[i] = true;
                }
                ok
            }
        };
        let mut nbrs = vec![Vec::new(); n];
        let mut station_nbrs = vec![Vec::new(); n];
        for i in 0..n {
            if blocked[i] {
                continue;
            }
            let (ri, ci) = ((i / c) as i64, (i % c) as i64);
            let mut list = vec![i];
            for dr in -1..=1i64 {
                for dc in -1..=1i64 {
                    if dr == 0 && dc == 0 {
                        continue;
                    }
                    let (rr, cc) = (ri + dr, ci + dc);
                    if rr < 0 || cc < 0 || rr >= rows || cc >= cols {
                        continue;
                    }
                    let j = rr as usize * c + cc as usize;
                    if !blocked[j] {
                        list.push(j);
                    }
                }
            }
            if station_ok[i] {
                station_nbrs[i] = list.iter().copied().filter(|&j| station_ok[j]).collect();
            }
            nbrs[i] = list;
        }
        Ok(PlannerGrid {
            rows: r,
            cols: c,
            blocked,
            station_ok,
            nbrs,
            station_nbrs,
        })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// |G|, the number of cells.
    pub fn len(&self) -> usize {
        self.rows * self.cols
    }

    /// Whether the grid has no cells (never true for a built grid).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The dense index of `cell`, or `None` outside the grid.
    pub fn index(&self, cell: Cell) -> Option<usize> {
        if cell.row < 0 || cell.col < 0 {
            return None;
        }
        let (r, c) = (cell.row as usize, cell.col as usize);
        (r < self.rows && c < self.cols).then_some(r * self.cols + c)
    }

    /// The cell of dense index `i` (`i < len()`).
    pub fn cell(&self, i: usize) -> Cell {
        Cell::new((i / self.cols) as i32, (i % self.cols) as i32)
    }

    /// Whether cell `i` is an obstacle (in O).
    pub fn is_blocked(&self, i: usize) -> bool {
        self.blocked[i]
    }

    /// Whether cell `i` is free (in C = G \ O).
    pub fn is_free(&self, i: usize) -> bool {
        !self.blocked[i]
    }

    /// Whether cell `i` is station-admissible (in R).
    pub fn is_station_ok(&self, i: usize) -> bool {
        self.station_ok[i]
    }

    /// N(l): the cells a drone at free cell `i` may occupy one step later (itself included).
    pub fn moves(&self, i: usize) -> &[usize] {
        &self.nbrs[i]
    }

    /// N_c(l) = R ∩ N(l): the cells a station at `i` may occupy one step later.
    pub(crate) fn station_moves(&self, i: usize) -> &[usize] {
        &self.station_nbrs[i]
    }

    /// The free cells, in index order.
    pub fn free_cells(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.is_free(i)).collect()
    }

    /// Whether `a → b` is one legal drone step (a king's move or a pass between free cells).
    pub(crate) fn is_move(&self, a: usize, b: usize) -> bool {
        self.nbrs[a].contains(&b)
    }

    /// Whether `a → b` is one legal station step (within R).
    pub(crate) fn is_station_move(&self, a: usize, b: usize) -> bool {
        self.station_nbrs[a].contains(&b)
    }

    /// Breadth-first king's-move distances (in steps) from the nearest of `sources` through
    /// free cells (`stations == false`) or through R (`stations == true`). Unreachable cells
    /// and obstacles get `u32::MAX`.
    pub fn distances(&self, sources: &[usize], stations: bool) -> Vec<u32> {
        let mut dist = vec![u32::MAX; self.len()];
        let mut queue = VecDeque::new();
        for &s in sources {
            let ok = if stations {
                self.station_ok[s]
            } else {
                !self.blocked[s]
            };
            if ok && dist[s] == u32::MAX {
                dist[s] = 0;
                queue.push_back(s);
            }
        }
        while let Some(u) = queue.pop_front() {
            let next = if stations {
                &self.station_nbrs[u]
            } else {
                &self.nbrs[u]
            };
            for &v in next {
                if dist[v] == u32::MAX {
                    dist[v] = dist[u] + 1;
                    queue.push_back(v);
                }
            }
        }
        dist
    }

    /// Whether every free cell can be reached from every other by drone moves.
    pub fn free_cells_connected(&self) -> bool {
        let free = self.free_cells();
        match free.first() {
            None => true,
            Some(&s) => {
                let d = self.distances(&[s], false);
                free.iter().all(|&i| d[i] != u32::MAX)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbourhoods_respect_obstacles_roads_and_borders() {
        let g = PlannerGrid::new(
            3,
            3,
            &[Cell::new(1, 1)],
            Some(&[Cell::new(0, 0), Cell::new(0, 1), Cell::new(2, 2)]),
        )
        .unwrap();
        // Corner (0,0): itself, (0,1), (1,0); (1,1) is an obstacle.
        let m: Vec<Cell> = g.moves(0).iter().map(|&i| g.cell(i)).collect();
        assert_eq!(m, vec![Cell::new(0, 0), Cell::new(0, 1), Cell::new(1, 0)]);
        assert!(g.moves(4).is_empty());
        let s: Vec<Cell> = g.station_moves(0).iter().map(|&i| g.cell(i)).collect();
        assert_eq!(s, vec![Cell::new(0, 0), Cell::new(0, 1)]);
        assert!(g.station_moves(3).is_empty());
        assert!(g.is_move(0, 1) && !g.is_move(0, 4) && !g.is_move(0, 2));
        let d = g.distances(&[0], false);
        assert_eq!(
            d[8], 3,
            "around the centre obstacle: (0,0)→(0,1)→(1,2)→(2,2)"
        );
        let ds = g.distances(&[0], true);
        assert_eq!(ds[1], 1);
        assert_eq!(
            ds[8],
            u32::MAX,
            "(2,2) is a road cell but not connected by roads"
        );
        assert!(g.free_cells_connected());
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(matches!(
            PlannerGrid::new(0, 3, &[], None),
            Err(GridError::BadSize { .. })
        ));
        assert!(matches!(
            PlannerGrid::new(2, 2, &[Cell::new(2, 0)], None),
            Err(GridError::OutOfGrid { .. })
        ));
        assert!(matches!(
            PlannerGrid::new(2, 2, &[Cell::new(1, 1)], Some(&[Cell::new(1, 1)])),
            Err(GridError::StationCellOnObstacle { .. })
        ));
    }
}
