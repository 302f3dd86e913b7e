//! Mission definition files: the human-edited TOML file that describes one field mission,
//! for both mission kinds (runway mapping, runway paper §7; spatial classification, bandit
//! paper §II–§VI). The annotated reference is `missions/runway-field-test.toml` (every key,
//! with its default) and docs/mission-files.md.
//!
//! ```text
//! name, kind ("runway-mapping" | "spatial-classification"), description?
//! [grid]            origin = "vehicle" | { lat, lon }, cell_size_m
//! [flight]          altitude_m, altitude_separation_m = 0, speed_m_s
//! [camera]          hfov_deg = 53.13, width_px = 480, height_px = 480
//! [battery]         flight_time_min = 12, rtl_reserve_pct = 20
//! [[vehicles]]      sysid, role ("drone" | "station"), name?, start? = [row, col]
//! [area]            rows?, cols?, obstacles = [], roads?, roads_are_candidates = true
//! [runway]          images_per_cell = 5, votes_required = 3, intensity_threshold = 150,
//!                   dilations = 7, black_fraction = 0.5, lane_spacing_m?
//! [runway.sweep]    north_m = [min, max], east_m = [min, max]
//!                   | south_west = { lat, lon }, north_east = { lat, lon }
//! [classification]  theta = 0.5, epsilon = 0.05, delta = 0.0001, epoch_goals = 8,
//!                   batch_size = 10, drone_cycle_steps = 8, station_cycle_steps = 4,
//!                   max_cycles = 4, charger_capacity?
//! [classification.green] hsv_min = [35, 60, 40], hsv_max = [85, 255, 255],
//!                   fraction_threshold = 0.2
//! ```
//!
//! Cells are `[row, col]` in the grid convention (docs/grid.md): rows grow north, columns
//! east, the origin is the centre of cell (0, 0), indices may be negative.
//!
//! # How errors are found and located
//!
//! [`MissionDef::parse`] does not stop at the first problem; [`DefErrors`] lists every one,
//! each as `file:line:column: key.path: what was expected, what was found`:
//!
//! 1. **Syntax**: the document is parsed with `toml::de::DeTable::parse_recoverable`, which
//!    keeps going after an error and gives each error a byte span. If there are syntax errors
//!    they are reported (sorted, the first per line) and nothing else is checked, because the
//!    rest of the tree is a guess.
//! 2. **Structure and types** (`reader`; each kind's table by the kind's module, listed in
//!    `kinds`): the spanned tree (`DeTable`, whose every key and value is a
//!    `serde_spanned::Spanned`) is walked against the schema by hand, rather than with
//!    `toml::from_str`, because serde stops at the first error. Unknown keys (with a "did you
//!    mean" suggestion), missing required keys, wrong types and integers that do not fit
//!    their type are all reported. Every value's span is recorded under its key path
//!    (`vehicles[2].sysid`, `area.obstacles[4]`).
//! 3. **Values and semantics** (`validate`, then the kind's module): ranges and cross-field
//!    rules on the typed [`MissionDef`] (duplicate system ids, an obstacle that is also a
//!    road, Td not a multiple of Tc, drones without a station, ε outside (0, min(θ, 1−θ)) …).
//!    Each problem names the key path of the offending value, which the span table turns
//!    into a line and column. Values that already failed step 2 are replaced by placeholders
//!    and *poisoned*: problems involving them are not reported twice.
//!
//! The same [`MissionDef`] also derives serde (`deny_unknown_fields`, the same key names and
//! defaults) so that it round-trips through TOML and JSON (`fleetmap check --json`, the copy
//! in a run directory); a test checks that the serde path and the reader agree on every
//! example file. [`MissionDef::validate`] runs step 3 on a definition built in code.

mod errors;
mod kinds;
mod reader;
mod validate;

pub use errors::{DefError, DefErrors};
pub use kinds::MissionKind;

use crate::budget::LinkBudget;
use crate::geo::Cell;
use crate::vision::camera::CameraModel;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::HashSet;
use std::fmt;

/// The most cells a mission's search area or sweep box may hold (validation limits the
/// area to 1000 × 1000).
pub(crate) const MAX_CELLS: u64 = 10_000_000;

// Positions are the grid's own `LatLon` (WGS84 degrees); a definition's must lie in the UTM
// range (latitude −80 … 84), checked by `validate`.
use crate::geo::LatLon;

/// Where the grid's origin (the centre of cell (0, 0)) is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Origin {
    /// The home position of the first vehicle listed (`origin = "vehicle"`), known once it
    /// is connected — the runway paper's choice (§7: "the origin of the grid is placed at the
    /// starting location of the UAV").
    Vehicle,
    /// A fixed position (`origin = { lat = …, lon = … }`).
    Coordinates(LatLon),
}

impl Serialize for Origin {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Origin::Vehicle => s.serialize_str("vehicle"),
            Origin::Coordinates(p) => p.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Origin {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Word(String),
            At(LatLon),
        }
        match Raw::deserialize(d)? {
            Raw::Word(w) if w == "vehicle" => Ok(Origin::Vehicle),
            Raw::Word(w) => Err(serde::de::Error::custom(format!(
                "expected \"vehicle\" or {{ lat = …, lon = … }}, found {w:?}"
            ))),
            Raw::At(p) => Ok(Origin::Coordinates(p)),
        }
    }
}

/// `[grid]`: how cells are laid on the ground.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridDef {
    /// The centre of cell (0, 0).
    pub origin: Origin,
    /// Side of a (square) cell, metres. Runway paper: 4 m.
    pub cell_size_m: f64,
}

/// `[flight]`: altitudes (relative to home) and speeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlightDef {
    /// Altitude of the first drone, metres above home. Runway paper: 12 m (the centre ninth
    /// of the image then covers one 4 m cell).
    pub altitude_m: f64,
    /// Extra altitude per drone, metres: the k-th drone listed (k = 0, 1, …) flies at
    /// `altitude_m + k · altitude_separation_m` (bandit paper §III-B, collision avoidance by
    /// altitude as in its ref. \[5\]). 0 = all at the same altitude.
    #[serde(default)]
    pub altitude_separation_m: f64,
    /// Drone ground speed, m/s. Runway paper: 1 m/s. Stations drive at
    /// `speed_m_s · station_cycle_steps / drone_cycle_steps` (γ = Td/Tc = v_d/v_c).
    pub speed_m_s: f64,
}

/// `[battery]`: drone endurance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatteryDef {
    /// Flight time on one battery, minutes. Runway paper: about 12 minutes.
    #[serde(default = "default_flight_time_min")]
    pub flight_time_min: f64,
    /// Return home when the remaining charge falls to this percentage (0 ≤ x < 100).
    /// Our choice (20 %); the papers do not give one.
    #[serde(default = "default_rtl_reserve_pct")]
    pub rtl_reserve_pct: f64,
    /// Descent rate assumed when estimating the charge a drone needs to get home and land,
    /// m/s. 1 m/s lies between the autopilots' defaults: ArduCopter descends at
    /// `WPNAV_SPEED_DN` = 1.5 m/s to `LAND_ALT_LOW` and at `LAND_SPEED` = 0.5 m/s below it;
    /// PX4 lands at `MPC_LAND_SPEED` = 0.7 m/s.
    #[serde(default = "default_descent_rate_m_s")]
    pub descent_rate_m_s: f64,
    /// Seconds added to that estimate for the approach, the landing and wind. Our choice
    /// (30 s); the runway paper does not give one.
    #[serde(default = "default_landing_margin_s")]
    pub landing_margin_s: f64,
    /// After a battery swap, a drone resumes by itself (with `--auto-resume`) once it
    /// reports at least this charge, percent. Our choice (95 %): a freshly charged LiPo
    /// reads 95–100 %, one that flew a leg reads less.
    #[serde(default = "default_fresh_pct")]
    pub fresh_pct: f64,
    /// The same once the autopilot has rebooted since it landed (the battery was
    /// unplugged, so it is another pack), percent. Our choice (90 %): a fresh pack's
    /// voltage-based estimate can start a few percent low.
    #[serde(default = "default_fresh_after_reboot_pct")]
    pub fresh_after_reboot_pct: f64,
}

fn default_flight_time_min() -> f64 {
    12.0
}
fn default_rtl_reserve_pct() -> f64 {
    20.0
}
fn default_descent_rate_m_s() -> f64 {
    1.0
}
fn default_landing_margin_s() -> f64 {
    30.0
}
fn default_fresh_pct() -> f64 {
    95.0
}
fn default_fresh_after_reboot_pct() -> f64 {
    90.0
}

impl Default for BatteryDef {
    fn default() -> Self {
        BatteryDef {
            flight_time_min: default_flight_time_min(),
            rtl_reserve_pct: default_rtl_reserve_pct(),
            descent_rate_m_s: default_descent_rate_m_s(),
            landing_margin_s: default_landing_margin_s(),
            fresh_pct: default_fresh_pct(),
            fresh_after_reboot_pct: default_fresh_after_reboot_pct(),
        }
    }
}

/// What a vehicle does in the mission.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// A sensing aerial vehicle (copter) with a downward camera.
    Drone,
    /// A mobile charging station (rover) that drones rendezvous with (bandit paper).
    Station,
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Role::Drone => "drone",
            Role::Station => "station",
        })
    }
}

/// `[[vehicles]]`: one vehicle of the team, in the order of `fleetmap sim --vehicles`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleDef {
    /// MAVLink system id, 1–254 (255 is the ground station), unique in the mission.
    pub sysid: u8,
    /// Drone or charging station.
    pub role: Role,
    /// A name for displays and logs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Start cell (spatial classification: required, the initial team configuration X0, Y0
    /// of eq. 7a; a drone starts on a station's cell).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "cell_serde::option"
    )]
    pub start: Option<Cell>,
    /// What this vehicle's link carries, over the mission's [`MissionDef::link`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub link: Option<LinkBudget>,
}

/// `[area]`: which cells exist, which are forbidden, where stations may drive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaDef {
    /// Spatial classification: the search area G is rows 0 … rows−1 (northward).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows: Option<u32>,
    /// Spatial classification: the search area G is columns 0 … cols−1 (eastward).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cols: Option<u32>,
    /// No-fly / obstacle cells O: no vehicle ever enters them.
    #[serde(default, with = "cell_serde::list")]
    pub obstacles: Vec<Cell>,
    /// Station-admissible cells R (roads). Absent = every cell of G that is not an obstacle
    /// (bandit paper §VI).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "cell_serde::option_list"
    )]
    pub roads: Option<Vec<Cell>>,
    /// Whether road cells are candidates C for classification. The hardware test of the
    /// bandit paper (§V) excluded R from C (`false`); with no road restriction (§VI) they
    /// must be candidates (`true`, the default).
    #[serde(default = "default_true")]
    pub roads_are_candidates: bool,
}

fn default_true() -> bool {
    true
}

impl Default for AreaDef {
    fn default() -> Self {
        AreaDef {
            rows: None,
            cols: None,
            obstacles: Vec::new(),
            roads: None,
            roads_are_candidates: true,
        }
    }
}

/// Every kind's module (its table and how it is read and checked, `Section`), and the
/// definition with each kind's table as a field, from the list of kinds
/// ([`crate::for_each_kind!`]).
macro_rules! tables {
    ($([$(#[$doc:meta])*] [$variant:ident $name:literal $module:ident $def:ident])+) => {
        $(pub mod $module;)+

        /// A mission definition file, parsed and validated (see the module documentation).
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct MissionDef {
            /// Free-text name, shown in the UI and stored with runs.
            pub name: String,
            /// Which mission.
            pub kind: MissionKind,
            /// Longer free text.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub description: Option<String>,
            /// The grid.
            pub grid: GridDef,
            /// Altitudes and speeds.
            pub flight: FlightDef,
            /// The drones' camera (default: [`CameraModel::paper`], 53.13° square, 480 px).
            #[serde(default = "CameraModel::paper")]
            pub camera: CameraModel,
            /// Battery limits.
            #[serde(default)]
            pub battery: BatteryDef,
            /// The team, in order (the first one is the grid origin with `origin = "vehicle"`).
            pub vehicles: Vec<VehicleDef>,
            /// Cells: search area, obstacles, roads.
            #[serde(default)]
            pub area: AreaDef,
            $(
                #[doc = concat!("The `[", stringify!($module), "]` table: present exactly in a ", $name, " mission ([`", stringify!($module), "::", stringify!($def), "`]).")]
                #[serde(default, skip_serializing_if = "Option::is_none")]
                pub $module: Option<$module::$def>,
            )+
            /// What every vehicle's link carries (`link = "radio:2000"`), unless a vehicle says
            /// otherwise; `None`: not said (unlimited until a radio reports itself).
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub link: Option<LinkBudget>,
        }
    };
}

crate::for_each_kind!(file => tables);

impl MissionDef {
    /// What the link of vehicle `sysid` carries, as the mission says: its own `link`, else
    /// the mission's.
    pub fn link_of(&self, sysid: u8) -> Option<LinkBudget> {
        self.vehicles
            .iter()
            .find(|v| v.sysid == sysid)
            .and_then(|v| v.link)
            .or(self.link)
    }
}

impl MissionDef {
    /// Parse and validate the raw bytes of a mission file named `file_name` (used in error
    /// messages): bytes that are not UTF-8 are an error at the line and column of the first
    /// bad byte, not a panic. Reading the file is the edge's job
    /// (`files::load_mission`).
    pub fn from_bytes(bytes: &[u8], file_name: &str) -> Result<MissionDef, DefErrors> {
        match std::str::from_utf8(bytes) {
            Ok(text) => MissionDef::parse(text, file_name),
            Err(e) => {
                let valid = &bytes[..e.valid_up_to()];
                // The valid prefix is UTF-8 by construction.
                let prefix = String::from_utf8_lossy(valid);
                let (line, column) = reader::line_col(&prefix, prefix.len());
                Err(DefErrors {
                    errors: vec![DefError {
                        file: file_name.to_string(),
                        line,
                        column,
                        path: String::new(),
                        message: "the file is not UTF-8 text (TOML files must be UTF-8)".into(),
                    }],
                })
            }
        }
    }

    /// The error of a mission file that could not be read at all (`reason` is the I/O
    /// error), in the form of every other mission-file error: the file as given, no line.
    pub fn unreadable(file_name: &str, reason: &dyn fmt::Display) -> DefErrors {
        DefErrors {
            errors: vec![DefError {
                file: file_name.to_string(),
                line: 0,
                column: 0,
                path: String::new(),
                message: format!("cannot read the file: {reason}"),
            }],
        }
    }

    /// Parse and validate mission-file `text`; `file_name` is used in error messages.
    pub fn parse(text: &str, file_name: &str) -> Result<MissionDef, DefErrors> {
        let (mut def, mut ctx) = reader::read(text, file_name)?;
        def.fill_defaults();
        let issues = validate::check(&def);
        ctx.report(issues);
        ctx.finish().map(|()| def)
    }

    /// Check the values and cross-field rules of a definition built in code or read with
    /// serde (errors have no line numbers; `file` is `"<mission>"`).
    pub fn validate(&self) -> Result<(), DefErrors> {
        let mut ctx = reader::Ctx::detached("<mission>");
        ctx.report(validate::check(self));
        ctx.finish()
    }

    /// Give the mission kind's parameter table its defaults when it is absent (what
    /// [`MissionDef::parse`] does; call it after deserialising with serde).
    pub fn fill_defaults(&mut self) {
        self.kind.section().fill_default(self);
    }

    /// The drones, in file order.
    pub fn drones(&self) -> impl Iterator<Item = &VehicleDef> {
        self.vehicles.iter().filter(|v| v.role == Role::Drone)
    }

    /// The charging stations, in file order.
    pub fn stations(&self) -> impl Iterator<Item = &VehicleDef> {
        self.vehicles.iter().filter(|v| v.role == Role::Station)
    }

    /// Flight altitude (metres above home) of the drone with system id `sysid`:
    /// `altitude_m + k · altitude_separation_m` for the k-th drone listed; `None` if
    /// `sysid` is not a drone of this mission.
    pub fn altitude_for(&self, sysid: u8) -> Option<f64> {
        let k = self.drones().position(|v| v.sysid == sysid)?;
        Some(self.flight.altitude_m + k as f64 * self.flight.altitude_separation_m)
    }

    /// The search area G (spatial classification): every cell of rows × cols, row-major
    /// from (0, 0); empty when the mission has no bounded area, or one larger than
    /// [`MAX_CELLS`] (which validation rejects).
    pub(crate) fn area_cells(&self) -> Vec<Cell> {
        let (Some(rows), Some(cols)) = (self.area.rows, self.area.cols) else {
            return Vec::new();
        };
        if u64::from(rows) * u64::from(cols) > MAX_CELLS {
            return Vec::new();
        }
        let (rows, cols) = (rows as i32, cols as i32); // ≤ MAX_CELLS, so they fit
        (0..rows)
            .flat_map(|r| (0..cols).map(move |c| Cell::new(r, c)))
            .collect()
    }

    /// Whether `cell` is inside the bounded search area (always true without one).
    pub(crate) fn in_area(&self, cell: Cell) -> bool {
        match (self.area.rows, self.area.cols) {
            (Some(rows), Some(cols)) => {
                cell.row >= 0
                    && cell.col >= 0
                    && (cell.row as u32) < rows
                    && (cell.col as u32) < cols
            }
            _ => true,
        }
    }

    /// The station-admissible set R: the roads, or G \ O when no roads are given.
    pub fn station_cells(&self) -> Vec<Cell> {
        match &self.area.roads {
            Some(r) => r.clone(),
            None => {
                let obstacles: HashSet<Cell> = self.area.obstacles.iter().copied().collect();
                self.area_cells()
                    .into_iter()
                    .filter(|c| !obstacles.contains(c))
                    .collect()
            }
        }
    }

    /// The candidate cells C to classify: G \ O, minus the roads when
    /// `roads_are_candidates = false`.
    pub fn candidate_cells(&self) -> Vec<Cell> {
        let obstacles: HashSet<Cell> = self.area.obstacles.iter().copied().collect();
        let roads: HashSet<Cell> = match (&self.area.roads, self.area.roads_are_candidates) {
            (Some(r), false) => r.iter().copied().collect(),
            _ => HashSet::new(),
        };
        self.area_cells()
            .into_iter()
            .filter(|c| !obstacles.contains(c) && !roads.contains(c))
            .collect()
    }
}

/// Serde helpers writing cells as `[row, col]` arrays (the mission-file form).
mod cell_serde {
    use crate::geo::Cell;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    fn pair(c: &Cell) -> [i32; 2] {
        [c.row, c.col]
    }
    fn cell(p: [i32; 2]) -> Cell {
        Cell::new(p[0], p[1])
    }

    pub(super) mod list {
        use super::*;
        pub(crate) fn serialize<S: Serializer>(v: &[Cell], s: S) -> Result<S::Ok, S::Error> {
            v.iter().map(pair).collect::<Vec<_>>().serialize(s)
        }
        pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Cell>, D::Error> {
            Ok(Vec::<[i32; 2]>::deserialize(d)?
                .into_iter()
                .map(cell)
                .collect())
        }
    }

    pub(crate) mod option {
        use super::*;
        pub(crate) fn serialize<S: Serializer>(v: &Option<Cell>, s: S) -> Result<S::Ok, S::Error> {
            v.as_ref().map(pair).serialize(s)
        }
        pub(crate) fn deserialize<'de, D: Deserializer<'de>>(
            d: D,
        ) -> Result<Option<Cell>, D::Error> {
            Ok(Option::<[i32; 2]>::deserialize(d)?.map(cell))
        }
    }

    pub(crate) mod option_list {
        use super::*;
        pub(crate) fn serialize<S: Serializer>(
            v: &Option<Vec<Cell>>,
            s: S,
        ) -> Result<S::Ok, S::Error> {
            v.as_ref()
                .map(|v| v.iter().map(pair).collect::<Vec<_>>())
                .serialize(s)
        }
        pub(crate) fn deserialize<'de, D: Deserializer<'de>>(
            d: D,
        ) -> Result<Option<Vec<Cell>>, D::Error> {
            Ok(Option::<Vec<[i32; 2]>>::deserialize(d)?.map(|v| v.into_iter().map(cell).collect()))
        }
    }
}
