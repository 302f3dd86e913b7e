//! The view-model: what the operator's screen shows, as plain data.
//!
//! The UI never reads the fleet actor or the mission runners directly. An adapter (in the
//! shell) fills a [`Model`] from fleet snapshots and runner progress and publishes it on a
//! `tokio::sync::watch` channel; a replay file or a test constructs one the same way. Every
//! type here is `serde`, so a [`Model`] round-trips through JSON (replay files are JSON Lines
//! of [`crate::tui::replay::ReplayFrame`]).
//!
//! Units are in the field names: metres (`_m`), metres per second (`_mps`), volts (`_v`),
//! seconds (`_s`), percent (`_pct`). Times are [`Time`] (µs on the clock of whoever made
//! the model; the UI shows them as elapsed `h:mm:ss`).

use crate::geo::Cell;
use crate::time::Time;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Everything the screen shows that comes from outside the UI.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Model {
    /// When the adapter made this snapshot (on its clock).
    pub time: Time,
    /// One row per known vehicle, in display order.
    pub vehicles: Vec<VehicleRow>,
    /// The mission grid and its cell states.
    pub map: MapModel,
    /// Mission phase and progress.
    pub mission: MissionModel,
    /// Recent messages, oldest first (the adapter keeps it bounded).
    pub log: Vec<LogEntry>,
}

impl Model {
    /// The row of the vehicle with system id `sysid`.
    pub fn vehicle(&self, sysid: u8) -> Option<&VehicleRow> {
        self.vehicles.iter().find(|v| v.sysid == sysid)
    }
}

/// A vehicle's role in the mission.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// A drone that takes images.
    #[default]
    Drone,
    /// A mobile charging station (a rover).
    Station,
}

impl Role {
    /// Lower-case name shown in the fleet table.
    pub fn name(self) -> &'static str {
        match self {
            Role::Drone => "drone",
            Role::Station => "station",
        }
    }
}

/// The autopilot firmware, from HEARTBEAT.autopilot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Autopilot {
    /// MAV_AUTOPILOT_ARDUPILOTMEGA.
    ArduPilot,
    /// MAV_AUTOPILOT_PX4.
    Px4,
    /// Anything else (including the built-in simulator when it does not impersonate one).
    #[default]
    Other,
}

impl Autopilot {
    /// Full name.
    pub fn name(self) -> &'static str {
        match self {
            Autopilot::ArduPilot => "ArduPilot",
            Autopilot::Px4 => "PX4",
            Autopilot::Other => "other",
        }
    }

    /// Short name for narrow tables.
    pub fn short(self) -> &'static str {
        match self {
            Autopilot::ArduPilot => "AP",
            Autopilot::Px4 => "PX4",
            Autopilot::Other => "?",
        }
    }
}

/// The airframe class, from HEARTBEAT.type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VehicleType {
    /// Multirotor.
    Copter,
    /// Fixed wing.
    Plane,
    /// Ground rover.
    Rover,
    /// Anything else.
    #[default]
    Other,
}

impl VehicleType {
    /// Full name.
    pub fn name(self) -> &'static str {
        match self {
            VehicleType::Copter => "copter",
            VehicleType::Plane => "plane",
            VehicleType::Rover => "rover",
            VehicleType::Other => "other",
        }
    }

    /// Three-letter name for narrow tables.
    pub fn short(self) -> &'static str {
        match self {
            VehicleType::Copter => "cop",
            VehicleType::Plane => "pln",
            VehicleType::Rover => "rov",
            VehicleType::Other => "oth",
        }
    }
}

/// Battery state (BATTERY_STATUS / SYS_STATUS).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Battery {
    /// Remaining charge, percent (0–100), when the autopilot estimates it.
    pub remaining_pct: Option<u8>,
    /// Pack voltage, volts.
    pub voltage_v: Option<f32>,
    /// Number of cells in series, when known: the voltage thresholds are per cell.
    pub cells: Option<u8>,
}

/// GPS fix type (GPS_RAW_INT.fix_type).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum GpsFix {
    /// No GPS connected.
    #[default]
    NoGps,
    /// GPS present, no fix.
    NoFix,
    /// 2D fix.
    Fix2d,
    /// 3D fix.
    Fix3d,
    /// DGPS/SBAS-aided 3D fix.
    Dgps,
    /// RTK float.
    RtkFloat,
    /// RTK fixed.
    RtkFixed,
}

impl GpsFix {
    /// Short label for the fleet table.
    pub fn label(self) -> &'static str {
        match self {
            GpsFix::NoGps => "none",
            GpsFix::NoFix => "nofix",
            GpsFix::Fix2d => "2D",
            GpsFix::Fix3d => "3D",
            GpsFix::Dgps => "DGPS",
            GpsFix::RtkFloat => "RTKfl",
            GpsFix::RtkFixed => "RTKfx",
        }
    }

    /// Whether the fix is good enough to fly a mission (3D or better).
    pub fn is_3d(self) -> bool {
        self >= GpsFix::Fix3d
    }
}

/// GPS state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Gps {
    /// Fix type.
    pub fix: GpsFix,
    /// Satellites visible, when reported.
    pub satellites: Option<u8>,
}

/// Link state for one vehicle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LinkState {
    /// Share of expected messages received recently, percent (0–100), when measured.
    pub quality_pct: Option<u8>,
    /// True when no heartbeat arrived within the liveness timeout.
    pub lost: bool,
    /// Seconds since the last message from this vehicle, when known.
    pub last_heard_s: Option<f32>,
}

/// Position in the uploaded mission.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MissionProgress {
    /// Current item (MISSION_CURRENT.seq).
    pub current: u16,
    /// Number of items (MISSION_CURRENT.total or the uploaded count).
    pub total: u16,
}

/// One row of the fleet pane.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct VehicleRow {
    /// MAVLink system id.
    pub sysid: u8,
    /// Drone or charging station.
    pub role: Role,
    /// Firmware.
    pub autopilot: Autopilot,
    /// Airframe class.
    pub vehicle_type: VehicleType,
    /// Flight mode name as the autopilot flavour names it ("AUTO", "GUIDED", "Mission", …).
    pub mode: String,
    /// Motors armed.
    pub armed: bool,
    /// Battery.
    pub battery: Battery,
    /// GPS.
    pub gps: Gps,
    /// Altitude above home, metres.
    pub alt_m: Option<f32>,
    /// Ground speed, metres per second.
    pub speed_mps: Option<f32>,
    /// Mission item / total.
    pub mission: Option<MissionProgress>,
    /// Link state.
    pub link: LinkState,
    /// The grid cell the vehicle is over, when its position is known and on the grid.
    pub cell: Option<Cell>,
    /// What the mission runner has it doing ("sweep lane 3", "DFS (4, 2)", "battery swap").
    pub activity: Option<String>,
}

/// Which kind of mission map the cells describe (selects the legend).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MapKind {
    /// Runway mapping (sweep + DFS).
    #[default]
    Runway,
    /// Spatial classification (bandit + IP).
    Classification,
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
    pub fn glyph(self) -> char {
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
    pub fn from_glyph(c: char) -> Option<CellState> {
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
    pub fn short_name(self) -> &'static str {
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

    /// The states a map of `kind` uses, in legend order.
    pub fn for_kind(kind: MapKind) -> &'static [CellState] {
        match kind {
            MapKind::Runway => &CellState::ALL[0..5],
            MapKind::Classification => &CellState::ALL[5..10],
        }
    }

    /// When one screen character covers several cells, the one with the highest priority
    /// is shown (a positive is never hidden behind negatives).
    pub fn priority(self) -> u8 {
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
/// In JSON, `rows` is a list of strings of [`CellState::glyph`]s, **northernmost row
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
    pub tracks: Vec<Track>,
    /// The cell where the vehicles started (grid origin), when known.
    pub home: Option<Cell>,
}

impl Default for MapModel {
    fn default() -> Self {
        MapModel::new(MapKind::Runway, 4.0, Cell::new(0, 0), 0, 0)
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
    /// in the kind's initial state (unknown / unclassified).
    pub fn new(kind: MapKind, cell_size_m: f64, south_west: Cell, rows: u32, cols: u32) -> Self {
        let init = match kind {
            MapKind::Runway => CellState::Unknown,
            MapKind::Classification => CellState::Unclassified,
        };
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
    pub fn from_rows<S: AsRef<str>>(
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
    pub fn to_rows(&self) -> Vec<String> {
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
    #[serde(default)]
    kind: MapKind,
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
            kind: self.kind,
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
        let mut m = MapModel::from_rows(r.kind, r.cell_size_m, r.south_west, &r.rows)
            .map_err(serde::de::Error::custom)?;
        m.tracks = r.tracks;
        m.home = r.home;
        Ok(m)
    }
}

/// The mission being flown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissionKind {
    /// No mission loaded.
    #[default]
    None,
    /// Runway mapping (sweep, then the multi-robot DFS).
    RunwayMapping,
    /// Spatial classification (bandit + IP epochs).
    SpatialClassification,
}

/// The mission's phase.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "phase")]
pub enum Phase {
    /// Loaded, not started.
    #[default]
    Idle,
    /// Runway mapping phase 1: the lawnmower sweep of the bounding box.
    Sweep,
    /// Runway mapping phase 2: the multi-robot recursive DFS.
    Dfs,
    /// Spatial classification epoch `p` (1-based).
    Epoch {
        /// The epoch number.
        p: u32,
    },
    /// Returning to the start.
    Return,
    /// Finished.
    Done,
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Phase::Idle => write!(f, "idle"),
            Phase::Sweep => write!(f, "sweep"),
            Phase::Dfs => write!(f, "DFS"),
            Phase::Epoch { p } => write!(f, "epoch {p}"),
            Phase::Return => write!(f, "return"),
            Phase::Done => write!(f, "done"),
        }
    }
}

/// Whether the run is moving.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// Not started yet.
    #[default]
    NotStarted,
    /// Flying.
    Running,
    /// Paused by the operator (vehicles holding).
    Paused,
    /// Waiting for the operator to swap a battery.
    BatterySwap,
    /// Completed.
    Done,
    /// Stopped on an error.
    Failed,
}

impl RunStatus {
    /// Upper-case label for the status bar.
    pub fn label(self) -> &'static str {
        match self {
            RunStatus::NotStarted => "NOT STARTED",
            RunStatus::Running => "RUNNING",
            RunStatus::Paused => "PAUSED",
            RunStatus::BatterySwap => "BATTERY SWAP",
            RunStatus::Done => "DONE",
            RunStatus::Failed => "FAILED",
        }
    }
}

/// DFS vertex counts (runway mapping phase 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DfsProgress {
    /// Vertices fully explored.
    pub explored: u32,
    /// Vertices a robot is exploring now.
    pub under_exploration: u32,
    /// Known vertices not yet visited.
    pub unexplored: u32,
}

/// A labelled figure the runner wants shown (IoU, false positives, …).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stat {
    /// Label.
    pub label: String,
    /// Value, already formatted with its unit.
    pub value: String,
}

/// The mission pane.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MissionModel {
    /// Human name of the mission (from its definition file).
    pub name: String,
    /// Kind.
    pub kind: MissionKind,
    /// Phase.
    pub phase: Phase,
    /// Running, paused, …
    pub status: RunStatus,
    /// Cells classified so far.
    pub cells_classified: u32,
    /// Cells to classify in total, when known.
    pub cells_total: Option<u32>,
    /// DFS vertex counts, in phase 2 of runway mapping.
    pub dfs: Option<DfsProgress>,
    /// Epochs completed (spatial classification).
    pub epochs_done: u32,
    /// Flight time so far (summed over the fleet's airborne time), seconds.
    pub flight_time_s: f64,
    /// Battery swaps so far.
    pub battery_swaps: u32,
    /// Time spent in the planner (IP solves, DFS updates), seconds.
    pub planner_time_s: f64,
    /// Extra figures.
    pub stats: Vec<Stat>,
}

/// Message severity, as MAV_SEVERITY (0 = emergency … 7 = debug).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// MAV_SEVERITY_EMERGENCY.
    Emergency,
    /// MAV_SEVERITY_ALERT.
    Alert,
    /// MAV_SEVERITY_CRITICAL.
    Critical,
    /// MAV_SEVERITY_ERROR.
    Error,
    /// MAV_SEVERITY_WARNING.
    Warning,
    /// MAV_SEVERITY_NOTICE.
    Notice,
    /// MAV_SEVERITY_INFO.
    #[default]
    Info,
    /// MAV_SEVERITY_DEBUG.
    Debug,
}

impl Severity {
    /// From the MAVLink wire value (values above 7 count as debug).
    pub fn from_mav(v: u8) -> Severity {
        match v {
            0 => Severity::Emergency,
            1 => Severity::Alert,
            2 => Severity::Critical,
            3 => Severity::Error,
            4 => Severity::Warning,
            5 => Severity::Notice,
            6 => Severity::Info,
            _ => Severity::Debug,
        }
    }

    /// Four-letter tag shown in the log.
    pub fn tag(self) -> &'static str {
        match self {
            Severity::Emergency => "EMRG",
            Severity::Alert => "ALRT",
            Severity::Critical => "CRIT",
            Severity::Error => "ERR ",
            Severity::Warning => "WARN",
            Severity::Notice => "NOTE",
            Severity::Info => "INFO",
            Severity::Debug => "DBG ",
        }
    }
}

/// One log line: a STATUSTEXT from a vehicle, or a message from the GCS itself.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct LogEntry {
    /// When it was received.
    pub time: Time,
    /// Severity.
    pub severity: Severity,
    /// The vehicle that sent it; `None` for the GCS.
    pub sysid: Option<u8>,
    /// The text.
    pub text: String,
}

/// `h:mm:ss` (or `mm:ss` under an hour) of a duration in seconds; negative and NaN show as 0.
pub fn format_hms(secs: f64) -> String {
    let s = if secs.is_finite() && secs > 0.0 {
        secs as u64
    } else {
        0
    };
    let (h, m, s) = (s / 3600, (s / 60) % 60, s % 60);
    if h > 0 {
        format!("{h}:{m:02}:{s:02}")
    } else {
        format!("{m:02}:{s:02}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_rows_are_north_up() {
        let m = MapModel::from_rows(MapKind::Runway, 4.0, Cell::new(-1, 2), &["+.", "-#"])
            .expect("valid rows");
        assert_eq!((m.rows, m.cols), (2, 2));
        // The last string is the southern row (row -1).
        assert_eq!(m.get(Cell::new(-1, 2)), Some(CellState::Negative));
        assert_eq!(m.get(Cell::new(-1, 3)), Some(CellState::Explored));
        assert_eq!(m.get(Cell::new(0, 2)), Some(CellState::PositiveUnexplored));
        assert_eq!(m.get(Cell::new(0, 3)), Some(CellState::Unknown));
        assert_eq!(m.get(Cell::new(1, 2)), None);
        assert_eq!(m.north_east(), Cell::new(0, 3));
        assert_eq!(m.to_rows(), vec!["+.", "-#"]);
    }

    #[test]
    fn map_json_round_trips_and_rejects_bad_rows() {
        let mut m = MapModel::new(MapKind::Classification, 10.0, Cell::new(0, 0), 3, 4);
        assert!(m.set(Cell::new(2, 3), CellState::Keep));
        assert!(!m.set(Cell::new(3, 0), CellState::Keep));
        m.home = Some(Cell::new(0, 0));
        let json = serde_json::to_string(&m).expect("serialise");
        assert!(json.contains(r#""rows":["???K","????","????"]"#), "{json}");
        let back: MapModel = serde_json::from_str(&json).expect("parse");
        assert_eq!(back, m);

        let ragged = r#"{"rows":["..","..."]}"#;
        let err = serde_json::from_str::<MapModel>(ragged).unwrap_err();
        assert!(err.to_string().contains("map row 1 has 3 cells"), "{err}");
        let bad = r#"{"rows":["..Z"]}"#;
        let err = serde_json::from_str::<MapModel>(bad).unwrap_err();
        assert!(err.to_string().contains("'Z' is not a cell state"), "{err}");
    }

    #[test]
    fn glyphs_are_unique_and_kinds_partition_the_states() {
        for a in CellState::ALL {
            assert_eq!(CellState::from_glyph(a.glyph()), Some(a));
        }
        let runway = CellState::for_kind(MapKind::Runway);
        let class = CellState::for_kind(MapKind::Classification);
        assert_eq!(runway.len() + class.len(), CellState::ALL.len());
        assert!(runway.iter().all(|s| !class.contains(s)));
    }

    #[test]
    fn hms_formats() {
        assert_eq!(format_hms(0.0), "00:00");
        assert_eq!(format_hms(75.9), "01:15");
        assert_eq!(format_hms(3725.0), "1:02:05");
        assert_eq!(format_hms(f64::NAN), "00:00");
        assert_eq!(format_hms(-5.0), "00:00");
    }

    #[test]
    fn severity_from_wire() {
        assert_eq!(Severity::from_mav(0), Severity::Emergency);
        assert_eq!(Severity::from_mav(4), Severity::Warning);
        assert_eq!(Severity::from_mav(200), Severity::Debug);
    }
}
