//! The map pane's data: the mission grid rectangle, the state of each cell and recent tracks,
//! with the glyph-per-cell JSON form replay files use.

use fleetmap_core::geo::Cell;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// What a kind's map is, as the kind describes it: its name at the foot of the map pane and
/// the cell states its cells take (the legend).
///
/// In replay files only the label is recorded (`"kind"`); the UI takes the legend from the
/// kind this build registers under that label.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct MapKind {
    /// The map's name in the pane's title ("… · north up").
    pub label: Cow<'static, str>,
    /// The cell states of its legend, in legend order; the first is a new cell's state.
    pub legend: Cow<'static, [CellState]>,
}

impl MapKind {
    /// A kind's map: `label` and the states of its legend (the first: a new cell's).
    pub const fn new(label: &'static str, legend: &'static [CellState]) -> MapKind {
        MapKind {
            label: Cow::Borrowed(label),
            legend: Cow::Borrowed(legend),
        }
    }

    /// A new cell's state: the legend's first (unknown when the legend is empty).
    pub(crate) fn initial(&self) -> CellState {
        self.legend.first().copied().unwrap_or_default()
    }
}

/// The state of one map cell. Runway mapping uses the first five, spatial classification
/// the last five.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CellState {
    /// Runway: not yet imaged.
    #[default]
    Unknown,
    /// Runway: classified negative (may still become positive).
    Negative,
    /// Runway: positive, DFS vertex not yet explored.
    PositiveUnexplored,
    /// Runway: positive, DFS vertex under exploration by a robot.
    UnderExploration,
    /// Runway: positive, DFS vertex explored.
    Explored,
    /// Classification: not yet classified.
    Unclassified,
    /// Classification: in the keep set.
    Keep,
    /// Classification: in the reject set.
    Reject,
    /// Classification: obstacle (no-fly).
    Obstacle,
    /// Classification: station-admissible (road).
    Road,
}

impl CellState {
    /// Every state, in legend order.
    pub const ALL: [CellState; 10] = [
        CellState::Unknown,
        CellState::Negative,
        CellState::PositiveUnexplored,
        CellState::UnderExploration,
        CellState::Explored,
        CellState::Unclassified,
        CellState::Keep,
        CellState::Reject,
        CellState::Obstacle,
        CellState::Road,
    ];

    /// The character that stands for this state on screen and in replay files.
    pub(crate) fn glyph(self) -> char {
        match self {
            CellState::Unknown => '.',
            CellState::Negative => '-',
            CellState::PositiveUnexplored => '+',
            CellState::UnderExploration => '*',
            CellState::Explored => '#',
            CellState::Unclassified => '?',
            CellState::Keep => 'K',
            CellState::Reject => 'x',
            CellState::Obstacle => '@',
            CellState::Road => '=',
        }
    }

    /// The state a glyph stands for.
    pub(crate) fn from_glyph(c: char) -> Option<CellState> {
        CellState::ALL.into_iter().find(|s| s.glyph() == c)
    }

    /// Legend text.
    pub fn name(self) -> &'static str {
        match self {
            CellState::Unknown => "unknown",
            CellState::Negative => "negative",
            CellState::PositiveUnexplored => "positive, unexplored",
            CellState::UnderExploration => "under exploration",
            CellState::Explored => "explored",
            CellState::Unclassified => "unclassified",
            CellState::Keep => "keep",
            CellState::Reject => "reject",
            CellState::Obstacle => "obstacle",
            CellState::Road => "road (station)",
        }
    }

    /// One-word legend text for narrow screens.
    pub(crate) fn short_name(self) -> &'static str {
        match self {
            CellState::Unknown => "unknown",
            CellState::Negative => "negative",
            CellState::PositiveUnexplored => "positive",
            CellState::UnderExploration => "exploring",
            CellState::Explored => "explored",
            CellState::Unclassified => "unclassified",
            CellState::Keep => "keep",
            CellState::Reject => "reject",
            CellState::Obstacle => "obstacle",
            CellState::Road => "road",
        }
    }

    /// When one screen character covers several cells, the one with the highest priority
    /// is shown (a positive is never hidden behind negatives).
    pub(crate) fn priority(self) -> u8 {
        match self {
            CellState::Unknown | CellState::Unclassified => 0,
            CellState::Negative => 1,
            CellState::Reject => 2,
            CellState::Road => 3,
            CellState::Explored => 4,
            CellState::Keep => 5,
            CellState::PositiveUnexplored => 6,
            CellState::UnderExploration => 7,
            CellState::Obstacle => 8,
        }
    }
}

/// The mission grid as the map pane shows it: a rectangle of cells.
///
/// In JSON, `rows` is a list of strings of `CellState::glyph`s, **northernmost row
/// first** (the way the map looks, north up); `south_west` is the cell of the first
/// character of the last string.
#[derive(Clone, Debug, PartialEq)]
pub struct MapModel {
    /// Which legend applies.
    pub kind: MapKind,
    /// Cell edge length, metres.
    pub cell_size_m: f64,
    /// The south-west corner cell (smallest row and column) of the rectangle.
    pub south_west: Cell,
    /// Number of rows (northward extent).
    pub rows: u32,
    /// Number of columns (eastward extent).
    pub cols: u32,
    /// `rows * cols` states, row-major from the south-west corner: index
    /// `(row - south_west.row) * cols + (col - south_west.col)`.
    cells: Vec<CellState>,
    /// Optional recent tracks (cells visited, oldest first), per vehicle.
    pub(crate) tracks: Vec<Track>,
    /// The cell where the vehicles started (grid origin), when known.
    pub home: Option<Cell>,
}

impl Default for MapModel {
    /// No map: no mission loaded.
    fn default() -> Self {
        MapModel::new(MapKind::default(), 4.0, Cell::new(0, 0), 0, 0)
    }
}

/// Cells a vehicle passed through.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Track {
    /// The vehicle.
    pub sysid: u8,
    /// Cells, oldest first.
    pub cells: Vec<Cell>,
}

/// A map rectangle whose rows do not agree with its declared size or contain an unknown glyph.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum MapError {
    /// A row has a different length from the first.
    #[error("map row {row} has {got} cells, expected {expected}")]
    RaggedRow {
        /// Index in the list (0 = northernmost).
        row: usize,
        /// Its length.
        got: usize,
        /// The first row's length.
        expected: usize,
    },
    /// A character is not a cell glyph.
    #[error("map row {row}: {glyph:?} is not a cell state (expected one of . - + * # ? K x @ =)")]
    BadGlyph {
        /// Index in the list (0 = northernmost).
        row: usize,
        /// The character.
        glyph: char,
    },
}

impl MapModel {
    /// A `rows × cols` map of `kind` with its south-west corner at `south_west`, every cell
    /// in the kind's initial state (its legend's first).
    pub fn new(kind: MapKind, cell_size_m: f64, south_west: Cell, rows: u32, cols: u32) -> Self {
        let init = kind.initial();
        MapModel {
            kind,
            cell_size_m,
            south_west,
            rows,
            cols,
            cells: vec![init; rows as usize * cols as usize],
            tracks: Vec::new(),
            home: None,
        }
    }

    /// Build a map from glyph rows, northernmost first (the layout of the JSON form).
    pub(crate) fn from_rows<S: AsRef<str>>(
        kind: MapKind,
        cell_size_m: f64,
        south_west: Cell,
        rows: &[S],
    ) -> Result<Self, MapError> {
        let n_rows = rows.len();
        let n_cols = rows
            .first()
            .map(|r| r.as_ref().chars().count())
            .unwrap_or(0);
        let mut cells = vec![CellState::Unknown; n_rows * n_cols];
        for (i, line) in rows.iter().enumerate() {
            let line = line.as_ref();
            let got = line.chars().count();
            if got != n_cols {
                return Err(MapError::RaggedRow {
                    row: i,
                    got,
                    expected: n_cols,
                });
            }
            let r = n_rows - 1 - i; // northernmost first in the list, south-west origin in memory
            for (c, ch) in line.chars().enumerate() {
                let state =
                    CellState::from_glyph(ch).ok_or(MapError::BadGlyph { row: i, glyph: ch })?;
                cells[r * n_cols + c] = state;
            }
        }
        Ok(MapModel {
            kind,
            cell_size_m,
            south_west,
            rows: n_rows as u32,
            cols: n_cols as u32,
            cells,
            tracks: Vec::new(),
            home: None,
        })
    }

    /// The glyph rows, northernmost first.
    pub(crate) fn to_rows(&self) -> Vec<String> {
        (0..self.rows as usize)
            .rev()
            .map(|r| {
                let start = r * self.cols as usize;
                self.cells[start..start + self.cols as usize]
                    .iter()
                    .map(|s| s.glyph())
                    .collect()
            })
            .collect()
    }

    /// Whether `cell` lies in the rectangle.
    pub fn contains(&self, cell: Cell) -> bool {
        self.index(cell).is_some()
    }

    fn index(&self, cell: Cell) -> Option<usize> {
        let r = i64::from(cell.row) - i64::from(self.south_west.row);
        let c = i64::from(cell.col) - i64::from(self.south_west.col);
        if r < 0 || c < 0 || r >= i64::from(self.rows) || c >= i64::from(self.cols) {
            return None;
        }
        Some(r as usize * self.cols as usize + c as usize)
    }

    /// The state of `cell`, or `None` outside the rectangle.
    pub fn get(&self, cell: Cell) -> Option<CellState> {
        self.index(cell).map(|i| self.cells[i])
    }

    /// Set the state of `cell`; returns false (and changes nothing) outside the rectangle.
    pub fn set(&mut self, cell: Cell, state: CellState) -> bool {
        match self.index(cell) {
            Some(i) => {
                self.cells[i] = state;
                true
            }
            None => false,
        }
    }

    /// The north-east corner cell (largest row and column); equals `south_west` for a 1×1
    /// map and is meaningless for an empty one.
    pub fn north_east(&self) -> Cell {
        Cell::new(
            self.south_west.row + self.rows as i32 - 1,
            self.south_west.col + self.cols as i32 - 1,
        )
    }

    /// Whether the map has no cells.
    pub fn is_empty(&self) -> bool {
        self.rows == 0 || self.cols == 0
    }

    /// How many cells are in each state, in [`CellState::ALL`] order.
    pub fn counts(&self) -> [u32; 10] {
        let mut n = [0u32; 10];
        for s in &self.cells {
            if let Some(i) = CellState::ALL.iter().position(|x| x == s) {
                n[i] += 1;
            }
        }
        n
    }
}

/// The JSON form of [`MapModel`].
#[derive(Serialize, Deserialize)]
struct MapModelRepr {
    /// The kind's label ([`MapKind::label`]); absent for a map of no kind (no mission), which
    /// the UI draws with the default kind's legend.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    kind: String,
    #[serde(default = "default_cell_size")]
    cell_size_m: f64,
    #[serde(default)]
    south_west: Cell,
    #[serde(default)]
    rows: Vec<String>,
    #[serde(default)]
    tracks: Vec<Track>,
    #[serde(default)]
    home: Option<Cell>,
}

fn default_cell_size() -> f64 {
    4.0
}

impl Serialize for MapModel {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        MapModelRepr {
            kind: self.kind.label.to_string(),
            cell_size_m: self.cell_size_m,
            south_west: self.south_west,
            rows: self.to_rows(),
            tracks: self.tracks.clone(),
            home: self.home,
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for MapModel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let r = MapModelRepr::deserialize(d)?;
        let kind = MapKind {
            label: Cow::Owned(r.kind),
            legend: Cow::Borrowed(&[]),
        };
        let mut m = MapModel::from_rows(kind, r.cell_size_m, r.south_west, &r.rows)
            .map_err(serde::de::Error::custom)?;
        m.tracks = r.tracks;
        m.home = r.home;
        Ok(m)
    }
}
