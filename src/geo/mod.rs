//! The mission grid: square cells anchored at a UTM origin, and conversions between cells,
//! UTM coordinates and WGS84 latitude/longitude.
//!
//! Conventions (DESIGN.md §4): the origin is the centre of cell (0, 0); rows grow north and
//! columns grow east; cell (row, col) has its centre at origin + (col·s, row·s) in
//! (easting, northing); indices may be negative.

pub mod local;

use serde::{Deserialize, Serialize};
use std::fmt;

/// A grid cell index: `row` grows north, `col` grows east; both may be negative.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Cell {
    /// Row index (northward).
    pub row: i32,
    /// Column index (eastward).
    pub col: i32,
}

impl Cell {
    /// The cell at (`row`, `col`).
    pub const fn new(row: i32, col: i32) -> Cell {
        Cell { row, col }
    }

    /// The neighbour one step in direction `d`.
    pub const fn step(self, d: Dir4) -> Cell {
        let (dr, dc) = d.delta();
        Cell {
            row: self.row + dr,
            col: self.col + dc,
        }
    }

    /// The four edge neighbours in the order north, west, south, east.
    pub fn neighbours4(self) -> [Cell; 4] {
        Dir4::ALL.map(|d| self.step(d))
    }

    /// The eight king's-move neighbours (edge and corner), clockwise from north.
    pub fn neighbours8(self) -> [Cell; 8] {
        const D: [(i32, i32); 8] = [
            (1, 0),
            (1, 1),
            (0, 1),
            (-1, 1),
            (-1, 0),
            (-1, -1),
            (0, -1),
            (1, -1),
        ];
        D.map(|(dr, dc)| Cell::new(self.row + dr, self.col + dc))
    }

    /// Manhattan (4-neighbour) distance in cells.
    pub fn manhattan(self, other: Cell) -> u32 {
        self.row.abs_diff(other.row) + self.col.abs_diff(other.col)
    }

    /// Chebyshev (king's move) distance in cells.
    pub fn chebyshev(self, other: Cell) -> u32 {
        self.row
            .abs_diff(other.row)
            .max(self.col.abs_diff(other.col))
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}, {})", self.row, self.col)
    }
}

/// A grid direction: one of the four edge neighbours of a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dir4 {
    /// Row + 1.
    North,
    /// Column − 1.
    West,
    /// Row − 1.
    South,
    /// Column + 1.
    East,
}

impl Dir4 {
    /// North, west, south, east: counter-clockwise from north.
    pub const ALL: [Dir4; 4] = [Dir4::North, Dir4::West, Dir4::South, Dir4::East];

    /// (Δrow, Δcol) of one step in this direction.
    pub const fn delta(self) -> (i32, i32) {
        match self {
            Dir4::North => (1, 0),
            Dir4::West => (0, -1),
            Dir4::South => (-1, 0),
            Dir4::East => (0, 1),
        }
    }

    /// The opposite direction.
    pub const fn opposite(self) -> Dir4 {
        match self {
            Dir4::North => Dir4::South,
            Dir4::West => Dir4::East,
            Dir4::South => Dir4::North,
            Dir4::East => Dir4::West,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_and_distances() {
        let c = Cell::new(-1, 2);
        assert_eq!(
            c.neighbours4(),
            [
                Cell::new(0, 2),
                Cell::new(-1, 1),
                Cell::new(-2, 2),
                Cell::new(-1, 3)
            ]
        );
        for d in Dir4::ALL {
            assert_eq!(c.step(d).step(d.opposite()), c);
        }
        assert_eq!(c.manhattan(Cell::new(2, 0)), 5);
        assert_eq!(c.chebyshev(Cell::new(2, 0)), 3);
        assert!(c.neighbours8().iter().all(|n| c.chebyshev(*n) == 1));
    }
}
