//! The spatial-classification run on a real fleet as a pure, serialisable state machine
//! (bandit paper Algorithm 1 with Algorithm 2 as the low-level planner): no I/O, no clock —
//! every time is a parameter, and the async shell ([`crate::app::bandit`]) saves the state
//! after every change, so a run killed at any moment resumes from its last acknowledged
//! measurement.
//!
//! ```text
//!   ┌─────────────┐ goals (3)  ┌──────────┐ IP (11)  ┌──────────────┐ missions ┌────────────┐
//!   │ begin_epoch │──────────► │ instance │────────► │ accept_plan  │────────► │ prepare_   │
//!   └─────────────┘            └──────────┘          └──────────────┘          │ cycle      │
//!          ▲                        ▲ re-plan from where the vehicles are      └─────┬──────┘
//!          │ epoch done (4), p+1    │ (resume, or a team that ended elsewhere)       │ fly
//!          └──────────────── finish_cycle ◄── record (images → H → (4)) ◄───────────┘
//! ```
//!
//! * **Cells.** The state speaks mission cells (rows grow north, DESIGN.md §4); the IP
//!   speaks the scenario's top-left indexing (specs/ip-scenario.md): row r of a mission with
//!   `rows` rows is planner row `rows − 1 − r` ([`Layout::to_planner`]).
//! * **Epochs** (Algorithm 1): goals E_p = the top-D unclassified cells by J (3)
//!   ([`crate::planner::bandit::epoch_goals`]); the IP (11) with K from the mission, doubled
//!   when infeasible (up to 64, as in the study); the plan re-paired by linear assignment
//!   (§III-C) inside [`crate::planner::ip::solve_instance`]. Each sensing cycle of the plan is
//!   one *sortie*: every vehicle that moves gets a mission ([`missions`]), all of them are
//!   flown together, and the cycle ends at the rendezvous (9d) with every drone landed on a
//!   station.
//! * **Measurements.** Each image is one Bernoulli realisation of ν_l (§V). It is counted
//!   for the capture cell its position falls in (at most B per visit), added to H_l, and (4)
//!   is applied at once ([`BanditState::classify`], a documented deviation: Algorithm 1
//!   applies it at the epoch's end, which the epoch's end still does). Images of a cell that
//!   got classified meanwhile are journalled but not added (Algorithm 1 measures only
//!   unclassified cells).
//! * **Resume.** A cycle that was flying when the GCS died is followed to its end (the
//!   vehicles fly their uploaded missions on their own), then the rest of the epoch — the
//!   goals not yet measured and still unclassified — is re-planned from where the vehicles
//!   actually are ([`ClassificationState::finish_cycle`] with `replan = true`). A cycle that
//!   had not started is dropped and re-planned the same way.

pub mod missions;

use crate::geo::{Cell, Grid as GeoGrid};
use crate::mission::MissionItem;
use crate::mission::definition::{MissionDef, MissionKind};
use crate::planner::bandit::{self, BanditState, Label};
use crate::planner::grid::Grid as PlannerGrid;
use crate::planner::ip::{Instance, Plan};
use crate::vision::camera::CameraModel;
use crate::vision::green::GreenParams;
use missions::{CycleMission, DroneMissionSpec};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// The run kind in `run.json` / `state.json`.
pub const KIND: &str = "spatial-classification";

/// Largest K tried when the IP is infeasible within the mission's K (doubling, as the study).
pub const MAX_K: usize = 64;

/// Plans per epoch (the first and the re-plans) after which the epoch ends once its plan is
/// flown, even if a goal is still unmeasured.
pub const MAX_SOLVES: u32 = 4;

/// Why the classification state refuses something.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SortieError {
    /// The mission cannot be run by this runner.
    #[error("{0}")]
    Mission(String),
    /// A vehicle is not part of the mission or of the current cycle.
    #[error("vehicle {0} is not part of this sortie")]
    UnknownVehicle(u8),
    /// The operation does not fit the run's current phase.
    #[error("{0}")]
    Phase(String),
    /// The team configuration or the plan is invalid.
    #[error("{0}")]
    Plan(String),
}

/// How drones keep apart in the air.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Separation {
    /// Each drone at its own altitude (`flight.altitude_separation_m > 0`; the paper's
    /// alternative to (7e), its ref. [5]): missions fly freely, the team waits only at the
    /// rendezvous.
    Altitude,
    /// The paper's mid-cycle separation (7e): drones at distinct cells at every time step,
    /// which needs them in step — the runner holds a drone that is a step ahead until every
    /// drone has reached that step.
    LockStep,
}

/// The run's parameters (from the mission file; see [`crate::mission::definition`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SortieParams {
    /// θ (1).
    pub theta: f64,
    /// ε (Assumption 1).
    pub epsilon: f64,
    /// δ (2), (3b).
    pub delta: f64,
    /// D: epoch goals per epoch.
    pub epoch_goals: usize,
    /// B: images per visit of an unclassified cell.
    pub batch: u32,
    /// T_d: drone cells per sensing cycle.
    pub td: usize,
    /// T_c: station cells per sensing cycle.
    pub tc: usize,
    /// K: most sensing cycles per epoch (doubled up to [`MAX_K`] when infeasible).
    pub k_max: usize,
    /// C (10): most drones per station at a rendezvous.
    pub capacity: Option<usize>,
    /// Drone ground speed v_d, m/s.
    pub speed_m_s: f64,
    /// Station speed v_c = v_d·T_c/T_d, m/s.
    pub station_speed_m_s: f64,
    /// How drones keep apart.
    pub separation: Separation,
    /// The green-pixel measurement (§V).
    pub green: GreenParams,
    /// The drones' camera.
    pub camera: CameraModel,
    /// Seconds between two images of a visit.
    pub capture_interval_s: f64,
    /// The measured part of an image: a centred square of this fraction of the cell side
    /// (on the ground), so that the measurement sees its cell and not the neighbours
    /// whatever the drone's altitude and heading (0.6: a rotated square of 0.6 cells stays
    /// inside the cell up to 0.08 cells of position error).
    pub crop_fraction: f64,
    /// An image counts for a cell when it was taken within this fraction of a cell of the
    /// cell's centre.
    pub capture_tolerance: f64,
    /// Drone battery endurance, minutes of hover.
    pub flight_time_min: f64,
    /// Charge kept in reserve, percent.
    pub rtl_reserve_pct: f64,
}

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
    pub fn to_planner(&self, c: Cell) -> Cell {
        Cell::new(self.rows as i32 - 1 - c.row, c.col)
    }

    /// The planner's top-left cell → mission cell (the same flip).
    pub fn from_planner(&self, c: Cell) -> Cell {
        self.to_planner(c)
    }

    /// The planner's grid (G, O, R in top-left indexing).
    pub fn planner_grid(&self) -> Result<PlannerGrid, SortieError> {
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

impl SortiePlan {
    /// The team configuration at the end of cycle `k`.
    pub fn end_of(&self, k: usize) -> Option<TeamConfig> {
        let last = |p: &Vec<Vec<Cell>>| p.get(k).and_then(|c| c.last()).copied();
        Some(TeamConfig {
            drones: self.drones.iter().map(last).collect::<Option<Vec<_>>>()?,
            stations: self.stations.iter().map(last).collect::<Option<Vec<_>>>()?,
        })
    }
}

/// Where a sortie is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CyclePhase {
    /// Missions built, not yet on the vehicles.
    Prepared,
    /// Every mission uploaded and read back identical.
    Verified,
    /// The vehicles were started: the sortie is flying.
    Started,
}

/// One capture visit of a drone in a cycle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaptureVisit {
    /// Step j of the cycle.
    pub step: usize,
    /// The cell.
    pub cell: Cell,
    /// Images counted for this visit so far (≤ B).
    pub counted: u32,
}

/// A drone's part of a sortie.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DroneLeg {
    /// System id.
    pub sysid: u8,
    /// Its T_d cells.
    pub path: Vec<Cell>,
    /// Whether it flies this cycle (a drone that stays on a station that stays does not).
    pub flies: bool,
    /// Its mission (empty when it does not fly).
    pub items: Vec<MissionItem>,
    /// Per step, the item completing the step (see [`CycleMission::step_done`]).
    pub step_done: Vec<Option<u16>>,
    /// Per step, the item reached on arrival (see [`CycleMission::step_arrive`]).
    pub step_arrive: Vec<Option<u16>>,
    /// Its capture visits, in flight order.
    pub captures: Vec<CaptureVisit>,
    /// The station (team index) it lands on at the end of the cycle.
    pub land_on: usize,
    /// Its charger slot on that station, and how many drones land there.
    pub slot: (usize, usize),
    /// The last step done (0: not yet flying).
    pub step: usize,
    /// Landed on its station at the end of the cycle.
    pub landed: bool,
}

/// A station's part of a sortie.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StationLeg {
    /// System id.
    pub sysid: u8,
    /// Its T_c cells.
    pub path: Vec<Cell>,
    /// Whether it moves this cycle.
    pub drives: bool,
    /// Its mission (empty when it stays).
    pub items: Vec<MissionItem>,
    /// Per step, the waypoint of the step.
    pub step_done: Vec<Option<u16>>,
    /// The last step done.
    pub step: usize,
    /// At its last cell.
    pub arrived: bool,
}

/// A capture counted already: (system id, time_boot_ms, image_index).
pub type CaptureKey = (u8, u32, i32);

/// The sortie being flown (one sensing cycle of the plan).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CycleRun {
    /// Index of the cycle in the current plan.
    pub k: usize,
    /// Where it is.
    pub phase: CyclePhase,
    /// The drones' legs, in team order.
    pub drones: Vec<DroneLeg>,
    /// The stations' legs, in team order.
    pub stations: Vec<StationLeg>,
    /// Captures already counted (so a re-sent image is not counted twice).
    pub seen: Vec<CaptureKey>,
    /// Seconds flown so far (fleet clock).
    pub elapsed_s: f64,
    /// Measurements counted in this cycle.
    pub measurements: u64,
}

impl CycleRun {
    /// The team configuration the cycle ends in, as planned.
    pub fn planned_end(&self) -> TeamConfig {
        TeamConfig {
            drones: self
                .drones
                .iter()
                .map(|d| d.path.last().copied().unwrap_or_default())
                .collect(),
            stations: self
                .stations
                .iter()
                .map(|s| s.path.last().copied().unwrap_or_default())
                .collect(),
        }
    }

    /// Whether every drone landed and every station arrived.
    pub fn complete(&self) -> bool {
        self.drones.iter().all(|d| d.landed) && self.stations.iter().all(|s| s.arrived)
    }
}

/// The epoch being run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpochRun {
    /// Epoch p (0-based).
    pub p: u64,
    /// E_p, the epoch goals (3).
    pub goals: Vec<Cell>,
    /// The plan for the rest of the epoch (`None`: to be planned from `config`).
    pub plan: Option<SortiePlan>,
    /// The next cycle of the plan to fly.
    pub next_cycle: usize,
    /// The cycle in flight.
    pub cycle: Option<CycleRun>,
    /// Sensing cycles flown so far.
    pub cycles_flown: usize,
    /// IP solves (the first plan and every re-plan).
    pub solves: u32,
    /// Planner wall time, seconds, every solve of the epoch included.
    pub planner_s: f64,
    /// Seconds the epoch's sorties took (fleet clock).
    pub flight_s: f64,
    /// Cells measured in this epoch (at least one counted image).
    pub measured: BTreeSet<Cell>,
    /// Measurements counted in this epoch.
    pub measurements: u64,
    /// Capture visits flown in this epoch.
    pub visits: u64,
}

/// What one epoch did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpochStats {
    /// Epoch p.
    pub epoch: u64,
    /// E_p.
    pub goals: Vec<Cell>,
    /// Sensing cycles flown.
    pub cycles: usize,
    /// IP solves.
    pub solves: u32,
    /// Planner wall time, seconds.
    pub planner_s: f64,
    /// Sortie time, seconds.
    pub flight_s: f64,
    /// Measurements counted.
    pub measurements: u64,
    /// Capture visits.
    pub visits: u64,
    /// Cells classified during the epoch.
    pub classified: Vec<(Cell, Label)>,
    /// |K| after the epoch.
    pub keep: usize,
    /// |R| after the epoch.
    pub reject: usize,
    /// Unclassified cells after the epoch.
    pub unclassified: usize,
}

/// One counted (or refused) image measurement, as journalled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Running number of counted measurements in the run (1, 2, …; 0 = not counted).
    pub n: u64,
    /// Epoch p.
    pub epoch: u64,
    /// Cycle index in the plan.
    pub cycle: usize,
    /// Drone.
    pub sysid: u8,
    /// The cell measured.
    pub cell: Cell,
    /// Green share of the measured part of the image (0–1).
    pub green_fraction: f64,
    /// The Bernoulli realisation: green share ≥ the threshold.
    pub positive: bool,
    /// Whether it went into H (false: the cell was classified meanwhile).
    pub counted: bool,
}

/// What recording a measurement did.
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded {
    /// The journal record.
    pub measurement: Measurement,
    /// Cells classified by (4) right after it.
    pub classified: Vec<(Cell, Label)>,
}

/// What ends a sortie.
#[derive(Clone, Debug, PartialEq)]
pub enum CycleEnd {
    /// The next cycle of the plan follows.
    NextCycle,
    /// The rest of the epoch must be planned again from where the team is.
    Replan,
    /// The epoch is over (4) and p advanced.
    EpochDone(EpochStats),
}

/// What the runner should do next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Next {
    /// Every cell is classified.
    Finished,
    /// Choose the next epoch's goals.
    BeginEpoch,
    /// Solve the IP for the rest of the epoch.
    Plan,
    /// Build the next cycle's missions.
    Prepare,
    /// Upload and verify the prepared missions.
    Upload,
    /// Start the verified sortie.
    Start,
    /// Follow the sortie in flight.
    Follow,
}

/// The whole run (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClassificationState {
    /// Mission name.
    pub mission: String,
    /// The mission grid (origin, cell size, UTM zone).
    pub grid: GeoGrid,
    /// Parameters.
    pub params: SortieParams,
    /// G, O, R.
    pub layout: Layout,
    /// The drones, in mission-file order.
    pub drones: Vec<Member>,
    /// The stations, in mission-file order.
    pub stations: Vec<Member>,
    /// H (as counts per cell), K, R and p: the bandit (3)–(4) over the candidate cells C.
    pub bandit: BanditState,
    /// The team configuration at the last rendezvous.
    pub config: TeamConfig,
    /// The epoch in progress.
    pub epoch: Option<EpochRun>,
    /// Finished epochs.
    pub epochs: Vec<EpochStats>,
    /// Measurements counted into H so far.
    pub measurements: u64,
    /// Images received but not counted (classified cell, taken off a capture cell, or
    /// beyond B for the visit).
    pub ignored_images: u64,
    /// Images that could not be decoded or were lost.
    pub image_failures: u64,
    /// The last counted measurement (written to the journal after the state: on resume,
    /// the runner appends it when the journal lacks it).
    pub last_measurement: Option<Measurement>,
    /// Airborne seconds per drone (fleet clock).
    pub airborne_s: BTreeMap<u8, f64>,
    /// Times the run was resumed.
    pub resumes: u32,
}

fn green_params(def: &MissionDef) -> GreenParams {
    let g = def
        .classification
        .as_ref()
        .map(|c| c.green.clone())
        .unwrap_or_default();
    GreenParams {
        lower: g.hsv_min,
        upper: g.hsv_max,
        min_fraction: g.fraction_threshold,
    }
}

impl ClassificationState {
    /// A fresh run of `def` (a validated spatial-classification mission) on `grid`. The team
    /// configuration is the mission's `start` cells; `lock_step` overrides the separation
    /// the mission implies (lock-step when `altitude_separation_m` is 0).
    pub fn new(
        def: &MissionDef,
        grid: GeoGrid,
        lock_step: Option<bool>,
    ) -> Result<ClassificationState, SortieError> {
        let bad = |m: String| SortieError::Mission(m);
        if def.kind != MissionKind::SpatialClassification {
            return Err(bad(format!(
                "{} is a {} mission, not spatial-classification",
                def.name, def.kind
            )));
        }
        let c = def
            .classification
            .clone()
            .ok_or_else(|| bad("the mission has no [classification] table".into()))?;
        let (Some(rows), Some(cols)) = (def.area.rows, def.area.cols) else {
            return Err(bad("the mission needs area.rows and area.cols".into()));
        };
        let layout = Layout {
            rows,
            cols,
            obstacles: def.area.obstacles.clone(),
            roads: def.station_cells(),
        };
        layout.planner_grid()?;
        let start = |v: &crate::mission::definition::VehicleDef| {
            v.start
                .ok_or_else(|| bad(format!("vehicle {} has no start cell", v.sysid)))
        };
        let drones: Vec<Member> = def
            .drones()
            .map(|v| Member {
                sysid: v.sysid,
                name: v.name.clone(),
                altitude_m: def.altitude_for(v.sysid).unwrap_or(def.flight.altitude_m),
            })
            .collect();
        let stations: Vec<Member> = def
            .stations()
            .map(|v| Member {
                sysid: v.sysid,
                name: v.name.clone(),
                altitude_m: 0.0,
            })
            .collect();
        let config = TeamConfig {
            drones: def.drones().map(start).collect::<Result<_, _>>()?,
            stations: def.stations().map(start).collect::<Result<_, _>>()?,
        };
        let bandit = BanditState::new(def.candidate_cells(), c.theta, c.epsilon, c.delta)
            .map_err(|e| bad(e.to_string()))?;
        let separation = match lock_step {
            Some(true) => Separation::LockStep,
            Some(false) => Separation::Altitude,
            None if def.flight.altitude_separation_m > 0.0 => Separation::Altitude,
            None => Separation::LockStep,
        };
        let params = SortieParams {
            theta: c.theta,
            epsilon: c.epsilon,
            delta: c.delta,
            epoch_goals: c.epoch_goals as usize,
            batch: c.batch_size,
            td: c.drone_cycle_steps as usize,
            tc: c.station_cycle_steps as usize,
            k_max: c.max_cycles as usize,
            capacity: c.charger_capacity.map(|x| x as usize),
            speed_m_s: def.flight.speed_m_s,
            station_speed_m_s: def.station_speed_m_s().unwrap_or(def.flight.speed_m_s),
            separation,
            green: green_params(def),
            camera: def.camera,
            capture_interval_s: 0.5,
            crop_fraction: 0.6,
            capture_tolerance: 0.3,
            flight_time_min: def.battery.flight_time_min,
            rtl_reserve_pct: def.battery.rtl_reserve_pct,
        };
        let s = ClassificationState {
            mission: def.name.clone(),
            grid,
            params,
            layout,
            airborne_s: drones.iter().map(|d| (d.sysid, 0.0)).collect(),
            drones,
            stations,
            bandit,
            config,
            epoch: None,
            epochs: Vec::new(),
            measurements: 0,
            ignored_images: 0,
            image_failures: 0,
            last_measurement: None,
            resumes: 0,
        };
        s.validate_config(&s.config)?;
        Ok(s)
    }

    /// Every vehicle of the team: drones then stations.
    pub fn sysids(&self) -> Vec<u8> {
        self.drones
            .iter()
            .chain(&self.stations)
            .map(|m| m.sysid)
            .collect()
    }

    /// Whether Algorithm 1 has terminated (K ∪ R = C) and no epoch is open.
    pub fn is_finished(&self) -> bool {
        self.epoch.is_none() && self.bandit.is_done()
    }

    /// What to do next.
    pub fn next(&self) -> Next {
        match &self.epoch {
            None if self.bandit.is_done() => Next::Finished,
            None => Next::BeginEpoch,
            Some(e) => match &e.cycle {
                Some(c) => match c.phase {
                    CyclePhase::Prepared => Next::Upload,
                    CyclePhase::Verified => Next::Start,
                    CyclePhase::Started => Next::Follow,
                },
                None if e.plan.is_none() => Next::Plan,
                None => Next::Prepare,
            },
        }
    }

    /// Check that drones are on station cells, stations on roads and apart, at most C drones
    /// per station, everything inside G and off O — what (7a) needs of (X_0, Y_0).
    pub fn validate_config(&self, c: &TeamConfig) -> Result<(), SortieError> {
        let bad = |m: String| Err(SortieError::Plan(m));
        if c.drones.len() != self.drones.len() || c.stations.len() != self.stations.len() {
            return bad("the team configuration does not match the team".into());
        }
        let roads: BTreeSet<Cell> = self.layout.roads.iter().copied().collect();
        let obstacles: BTreeSet<Cell> = self.layout.obstacles.iter().copied().collect();
        for (m, &cell) in self.stations.iter().zip(&c.stations) {
            if !self.layout.contains(cell) || obstacles.contains(&cell) || !roads.contains(&cell) {
                return bad(format!(
                    "station {} is at cell {cell}, which is not a road cell of the area",
                    m.sysid
                ));
            }
        }
        let distinct: BTreeSet<Cell> = c.stations.iter().copied().collect();
        if distinct.len() != c.stations.len() {
            return bad("two stations are on the same cell (7d)".into());
        }
        let mut per: BTreeMap<Cell, usize> = BTreeMap::new();
        for (m, &cell) in self.drones.iter().zip(&c.drones) {
            if !distinct.contains(&cell) {
                return bad(format!(
                    "drone {} is at cell {cell}, where no station is (9d): a drone must start \
                     every sensing cycle on a station",
                    m.sysid
                ));
            }
            *per.entry(cell).or_default() += 1;
        }
        if let Some(cap) = self.params.capacity
            && let Some((cell, n)) = per.iter().find(|(_, n)| **n > cap)
        {
            return bad(format!(
                "{n} drones on the station at {cell}, charger capacity {cap} (10)"
            ));
        }
        Ok(())
    }

    /// Step 3 of Algorithm 1: open epoch p with the top-D unclassified cells by J (3).
    /// Returns the goals (empty when everything is classified; no epoch is opened then).
    pub fn begin_epoch(&mut self) -> Result<Vec<Cell>, SortieError> {
        if self.epoch.is_some() {
            return Err(SortieError::Phase("an epoch is already open".into()));
        }
        let goals = bandit::epoch_goals(&self.bandit, self.params.epoch_goals);
        if goals.is_empty() {
            return Ok(goals);
        }
        self.epoch = Some(EpochRun {
            p: self.bandit.epoch,
            goals: goals.clone(),
            plan: None,
            next_cycle: 0,
            cycle: None,
            cycles_flown: 0,
            solves: 0,
            planner_s: 0.0,
            flight_s: 0.0,
            measured: BTreeSet::new(),
            measurements: 0,
            visits: 0,
        });
        Ok(goals)
    }

    /// The epoch's goals still to visit: not measured in this epoch and still unclassified.
    pub fn remaining_goals(&self) -> Vec<Cell> {
        let Some(e) = &self.epoch else {
            return Vec::new();
        };
        e.goals
            .iter()
            .copied()
            .filter(|c| !e.measured.contains(c))
            .filter(|c| {
                self.bandit
                    .index_of(*c)
                    .is_some_and(|l| self.bandit.is_unclassified(l))
            })
            .collect()
    }

    /// The IP instance (Algorithm 2's input) for the rest of the epoch: the remaining goals
    /// from the current team configuration, at most `k_max` cycles.
    pub fn instance(&self, k_max: usize) -> Result<Instance, SortieError> {
        let grid = self.layout.planner_grid()?;
        let idx = |c: Cell| -> Result<usize, SortieError> {
            grid.index(self.layout.to_planner(c))
                .ok_or_else(|| SortieError::Plan(format!("cell {c} is outside the area")))
        };
        let drones = self
            .config
            .drones
            .iter()
            .map(|&c| idx(c))
            .collect::<Result<_, _>>()?;
        let stations = self
            .config
            .stations
            .iter()
            .map(|&c| idx(c))
            .collect::<Result<_, _>>()?;
        let goals = self
            .remaining_goals()
            .into_iter()
            .map(idx)
            .collect::<Result<_, _>>()?;
        Instance::new(
            grid,
            drones,
            stations,
            goals,
            self.params.td,
            self.params.tc,
            k_max.max(1),
            self.params.capacity,
        )
        .map_err(|e| SortieError::Plan(e.to_string()))
    }

    /// Count a solve that found no plan (its time still counts as planner time).
    pub fn note_solve(&mut self, seconds: f64) {
        if let Some(e) = &mut self.epoch {
            e.solves += 1;
            e.planner_s += seconds.max(0.0);
        }
    }

    /// Take the IP's plan (planner cells, re-paired) for the rest of the epoch.
    pub fn accept_plan(&mut self, plan: &Plan, seconds: f64) -> Result<(), SortieError> {
        let layout = self.layout.clone();
        let conv = |v: &Vec<Vec<Vec<Cell>>>| -> Vec<Vec<Vec<Cell>>> {
            v.iter()
                .map(|cycles| {
                    cycles
                        .iter()
                        .map(|steps| steps.iter().map(|&c| layout.from_planner(c)).collect())
                        .collect()
                })
                .collect()
        };
        let sp = SortiePlan {
            cycles: plan.cycles,
            drones: conv(&plan.drones),
            stations: conv(&plan.stations),
        };
        if sp.drones.len() != self.drones.len() || sp.stations.len() != self.stations.len() {
            return Err(SortieError::Plan("the plan does not match the team".into()));
        }
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        e.solves += 1;
        e.planner_s += seconds.max(0.0);
        e.plan = Some(sp);
        e.next_cycle = 0;
        Ok(())
    }

    /// Build the missions of the plan's next cycle (capture at every unclassified candidate
    /// cell a drone arrives at).
    pub fn prepare_cycle(&mut self) -> Result<&CycleRun, SortieError> {
        let e = self
            .epoch
            .as_ref()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        if e.cycle.is_some() {
            return Err(SortieError::Phase("a sortie is already prepared".into()));
        }
        let plan = e
            .plan
            .as_ref()
            .ok_or_else(|| SortieError::Phase("the epoch has no plan".into()))?;
        let k = e.next_cycle;
        if k >= plan.cycles {
            return Err(SortieError::Phase("the plan has no cycle left".into()));
        }
        let p = &self.params;
        let lock = p.separation == Separation::LockStep;
        let step_s = self.grid.cell_size() / p.speed_m_s.max(0.1);
        let station_paths: Vec<Vec<Cell>> = plan.stations.iter().map(|s| s[k].clone()).collect();
        let mut stations = Vec::new();
        for (m, path) in self.stations.iter().zip(&station_paths) {
            let drives = path.windows(2).any(|w| w[0] != w[1]);
            let cm = if drives {
                missions::station_mission(&self.grid, path, p.station_speed_m_s)
            } else {
                CycleMission {
                    items: Vec::new(),
                    step_done: vec![None; path.len()],
                    step_arrive: vec![None; path.len()],
                    capture_steps: Vec::new(),
                }
            };
            stations.push(StationLeg {
                sysid: m.sysid,
                path: path.clone(),
                drives,
                items: cm.items,
                step_done: cm.step_done,
                step: 0,
                arrived: !drives,
            });
        }
        let mut landing: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        let mut drones = Vec::new();
        for (i, m) in self.drones.iter().enumerate() {
            let path = plan.drones[i][k].clone();
            let last = path.last().copied().unwrap_or_default();
            let first = path.first().copied().unwrap_or_default();
            let land_on = station_paths
                .iter()
                .position(|s| s.last() == Some(&last))
                .ok_or_else(|| {
                    SortieError::Plan(format!(
                        "drone {} ends cycle {k} at {last}, where no station ends it (9d)",
                        m.sysid
                    ))
                })?;
            landing.entry(land_on).or_default().push(i);
            // The station it stands on at the start: if that station drives away, the drone
            // must be in the air even when its own path stays (a landed drone rides along).
            let under = station_paths.iter().position(|s| s.first() == Some(&first));
            let station_moves = under.is_none_or(|a| stations[a].drives);
            let moves = path.windows(2).any(|w| w[0] != w[1]);
            let flies = moves || station_moves || under != Some(land_on);
            let capture: Vec<bool> = path
                .iter()
                .enumerate()
                .map(|(j, &c)| {
                    j > 0
                        && c != path[j - 1]
                        && self
                            .bandit
                            .index_of(c)
                            .is_some_and(|l| self.bandit.is_unclassified(l))
                })
                .collect();
            let cm = if flies {
                missions::drone_mission(
                    &self.grid,
                    &DroneMissionSpec {
                        path: &path,
                        capture: &capture,
                        altitude_m: m.altitude_m,
                        speed_m_s: p.speed_m_s,
                        batch: p.batch,
                        capture_interval_s: p.capture_interval_s,
                        lock_step: lock,
                        step_s,
                        settle_s: 2.0,
                    },
                )
            } else {
                CycleMission {
                    items: Vec::new(),
                    step_done: vec![None; path.len()],
                    step_arrive: vec![None; path.len()],
                    capture_steps: Vec::new(),
                }
            };
            drones.push(DroneLeg {
                sysid: m.sysid,
                captures: cm
                    .capture_steps
                    .iter()
                    .map(|&j| CaptureVisit {
                        step: j,
                        cell: path[j],
                        counted: 0,
                    })
                    .collect(),
                path,
                flies,
                items: cm.items,
                step_done: cm.step_done,
                step_arrive: cm.step_arrive,
                land_on,
                slot: (0, 1),
                step: 0,
                landed: !flies,
            });
        }
        for list in landing.values() {
            for (s, &i) in list.iter().enumerate() {
                drones[i].slot = (s, list.len());
            }
        }
        let run = CycleRun {
            k,
            phase: CyclePhase::Prepared,
            drones,
            stations,
            seen: Vec::new(),
            elapsed_s: 0.0,
            measurements: 0,
        };
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        e.visits += run
            .drones
            .iter()
            .map(|d| d.captures.len() as u64)
            .sum::<u64>();
        Ok(e.cycle.insert(run))
    }

    /// The sortie in flight (or prepared).
    pub fn cycle(&self) -> Option<&CycleRun> {
        self.epoch.as_ref().and_then(|e| e.cycle.as_ref())
    }

    fn cycle_mut(&mut self) -> Result<&mut CycleRun, SortieError> {
        self.epoch
            .as_mut()
            .and_then(|e| e.cycle.as_mut())
            .ok_or_else(|| SortieError::Phase("no sortie is prepared".into()))
    }

    /// Every mission of the sortie is on its vehicle and read back identical.
    pub fn on_verified(&mut self) -> Result<(), SortieError> {
        let c = self.cycle_mut()?;
        if c.phase == CyclePhase::Prepared {
            c.phase = CyclePhase::Verified;
        }
        Ok(())
    }

    /// The vehicles were started.
    pub fn on_started(&mut self) -> Result<(), SortieError> {
        self.cycle_mut()?.phase = CyclePhase::Started;
        Ok(())
    }

    /// The capture visit an image taken by `sysid` at (`east_m`, `north_m`) (grid metres)
    /// belongs to: `(visit index, cell)`, or why it does not count.
    pub fn match_image(
        &self,
        sysid: u8,
        east_m: f64,
        north_m: f64,
    ) -> Result<(usize, Cell), String> {
        let c = self.cycle().ok_or("no sortie is flying")?;
        let leg = c
            .drones
            .iter()
            .find(|d| d.sysid == sysid)
            .ok_or_else(|| format!("vehicle {sysid} is not a drone of this sortie"))?;
        let cell = self.grid.cell_of_xy(east_m, north_m);
        let s = self.grid.cell_size();
        let (dx, dy) = (
            east_m - f64::from(cell.col) * s,
            north_m - f64::from(cell.row) * s,
        );
        let off = dx.hypot(dy) / s;
        if off > self.params.capture_tolerance {
            return Err(format!(
                "taken {:.1} m from the centre of cell {cell} (more than {:.1} m)",
                off * s,
                self.params.capture_tolerance * s
            ));
        }
        let batch = self.params.batch;
        leg.captures
            .iter()
            .position(|v| v.cell == cell && v.counted < batch)
            .map(|i| (i, cell))
            .ok_or_else(|| {
                if leg.captures.iter().any(|v| v.cell == cell) {
                    format!("cell {cell} already has its {batch} images for this visit")
                } else {
                    format!("cell {cell} is not a capture cell of this sortie")
                }
            })
    }

    /// Whether this capture was counted already.
    pub fn seen(&self, key: CaptureKey) -> bool {
        self.cycle().is_some_and(|c| c.seen.contains(&key))
    }

    /// Count one measurement of visit `visit` of drone `sysid` (see the module
    /// documentation): H_l grows by one, then (4) is applied.
    pub fn record(
        &mut self,
        sysid: u8,
        visit: usize,
        key: CaptureKey,
        green_fraction: f64,
        positive: bool,
    ) -> Result<Recorded, SortieError> {
        let p_epoch = self.bandit.epoch;
        let n_next = self.measurements + 1;
        let (cell, k) = {
            let c = self.cycle_mut()?;
            let k = c.k;
            let leg = c
                .drones
                .iter_mut()
                .find(|d| d.sysid == sysid)
                .ok_or(SortieError::UnknownVehicle(sysid))?;
            let v = leg
                .captures
                .get_mut(visit)
                .ok_or_else(|| SortieError::Phase(format!("no capture visit {visit}")))?;
            v.counted += 1;
            let cell = v.cell;
            c.seen.push(key);
            (cell, k)
        };
        let l = self.bandit.index_of(cell);
        let counted = l.is_some_and(|l| self.bandit.record(l, u64::from(positive), 1));
        let m = Measurement {
            n: if counted { n_next } else { 0 },
            epoch: p_epoch,
            cycle: k,
            sysid,
            cell,
            green_fraction,
            positive,
            counted,
        };
        let mut classified = Vec::new();
        if counted {
            self.measurements = n_next;
            if let Some(e) = &mut self.epoch {
                e.measured.insert(cell);
                e.measurements += 1;
                if let Some(c) = &mut e.cycle {
                    c.measurements += 1;
                }
            }
            classified = self
                .bandit
                .classify()
                .into_iter()
                .map(|l| (self.bandit.cells[l], self.bandit.labels[l]))
                .collect();
            self.last_measurement = Some(m.clone());
        } else {
            self.ignored_images += 1;
        }
        Ok(Recorded {
            measurement: m,
            classified,
        })
    }

    /// Progress of a drone: the items it has reached. Returns whether its step changed.
    pub fn on_drone_progress(&mut self, sysid: u8, reached: &[u16]) -> Result<bool, SortieError> {
        let c = self.cycle_mut()?;
        let leg = c
            .drones
            .iter_mut()
            .find(|d| d.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        let step = missions::steps_done(&leg.step_done, reached).max(leg.step);
        let changed = step != leg.step;
        leg.step = step;
        Ok(changed)
    }

    /// Progress of a station; `complete` when its mission has ended. Returns whether it
    /// changed.
    pub fn on_station_progress(
        &mut self,
        sysid: u8,
        reached: &[u16],
        complete: bool,
    ) -> Result<bool, SortieError> {
        let c = self.cycle_mut()?;
        let leg = c
            .stations
            .iter_mut()
            .find(|s| s.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        let last = leg.path.len().saturating_sub(1);
        let mut step = missions::steps_done(&leg.step_done, reached).max(leg.step);
        if complete {
            step = last;
        }
        let arrived = leg.arrived || step >= last;
        let changed = step != leg.step || arrived != leg.arrived;
        leg.step = step;
        leg.arrived = arrived;
        Ok(changed)
    }

    /// A drone landed on its station.
    pub fn on_landed(&mut self, sysid: u8) -> Result<(), SortieError> {
        let c = self.cycle_mut()?;
        let leg = c
            .drones
            .iter_mut()
            .find(|d| d.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        leg.landed = true;
        leg.step = leg.path.len().saturating_sub(1);
        Ok(())
    }

    /// Lock-step (7e): the drones that must hold because they are a step ahead of a drone
    /// that has not yet arrived at the step they are on, given each flying drone's last
    /// step *arrived at* (`arrived`, by system id).
    pub fn ahead(&self, arrived: &BTreeMap<u8, usize>) -> Vec<u8> {
        if self.params.separation != Separation::LockStep {
            return Vec::new();
        }
        let Some(c) = self.cycle() else {
            return Vec::new();
        };
        let flying: Vec<(u8, usize)> = c
            .drones
            .iter()
            .filter(|d| d.flies && !d.landed)
            .map(|d| (d.sysid, arrived.get(&d.sysid).copied().unwrap_or(0)))
            .collect();
        let Some(min) = flying.iter().map(|(_, a)| *a).min() else {
            return Vec::new();
        };
        flying
            .into_iter()
            .filter(|&(_, a)| a > min)
            .map(|(s, _)| s)
            .collect()
    }

    /// Add airborne time to a drone and flight time to the sortie in flight, seconds.
    pub fn on_tick(&mut self, airborne: &[u8], dt_s: f64) {
        let dt = dt_s.max(0.0);
        for s in airborne {
            *self.airborne_s.entry(*s).or_insert(0.0) += dt;
        }
        if let Some(e) = &mut self.epoch
            && let Some(c) = &mut e.cycle
            && c.phase == CyclePhase::Started
        {
            c.elapsed_s += dt;
        }
    }

    /// End the sortie with the team at `actual` (the planned end, or where telemetry puts
    /// the vehicles). `replan` forces the rest of the epoch to be planned again (a resumed
    /// run); a team that ended elsewhere than planned forces it too. Ends the epoch — (4),
    /// p ← p + 1 — after the plan's last cycle or when no goal is left to visit.
    pub fn finish_cycle(
        &mut self,
        actual: TeamConfig,
        replan: bool,
    ) -> Result<CycleEnd, SortieError> {
        self.validate_config(&actual)?;
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        let c = e
            .cycle
            .take()
            .ok_or_else(|| SortieError::Phase("no sortie is flying".into()))?;
        let started = c.phase == CyclePhase::Started;
        if started {
            e.cycles_flown += 1;
            e.flight_s += c.elapsed_s;
            e.next_cycle = c.k + 1;
        }
        let as_planned = actual == c.planned_end();
        self.config = actual;
        let plan_cycles = e.plan.as_ref().map_or(0, |p| p.cycles);
        let plan_done = e.next_cycle >= plan_cycles;
        // A goal that cannot be measured (its images keep failing) must not hold the epoch
        // forever: after MAX_SOLVES plans the epoch ends with what it has.
        let exhausted = e.solves >= MAX_SOLVES && plan_done;
        if (plan_done && started && as_planned && !replan)
            || exhausted
            || self.remaining_goals().is_empty()
        {
            return Ok(CycleEnd::EpochDone(self.end_epoch()));
        }
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        if replan || !as_planned || !started || plan_done {
            e.plan = None;
            e.next_cycle = 0;
            return Ok(CycleEnd::Replan);
        }
        Ok(CycleEnd::NextCycle)
    }

    /// Drop the prepared sortie (nothing flew) and plan the rest of the epoch again from
    /// `actual`.
    pub fn abandon_cycle(&mut self, actual: TeamConfig) -> Result<(), SortieError> {
        self.validate_config(&actual)?;
        if let Some(e) = &mut self.epoch {
            if let Some(c) = e.cycle.take() {
                e.visits = e
                    .visits
                    .saturating_sub(c.drones.iter().map(|d| d.captures.len() as u64).sum());
            }
            e.plan = None;
            e.next_cycle = 0;
        }
        self.config = actual;
        Ok(())
    }

    fn end_epoch(&mut self) -> EpochStats {
        let p = self.bandit.epoch;
        self.bandit.update();
        let e = self.epoch.take();
        let classified: Vec<(Cell, Label)> = self
            .bandit
            .cells
            .iter()
            .enumerate()
            .filter(|(l, _)| self.bandit.classified_at[*l] == Some(p))
            .map(|(l, c)| (*c, self.bandit.labels[l]))
            .collect();
        let stats = EpochStats {
            epoch: p,
            goals: e.as_ref().map(|e| e.goals.clone()).unwrap_or_default(),
            cycles: e.as_ref().map_or(0, |e| e.cycles_flown),
            solves: e.as_ref().map_or(0, |e| e.solves),
            planner_s: e.as_ref().map_or(0.0, |e| e.planner_s),
            flight_s: e.as_ref().map_or(0.0, |e| e.flight_s),
            measurements: e.as_ref().map_or(0, |e| e.measurements),
            visits: e.as_ref().map_or(0, |e| e.visits),
            classified,
            keep: self.bandit.keep().len(),
            reject: self.bandit.reject().len(),
            unclassified: self.bandit.unclassified().len(),
        };
        self.epochs.push(stats.clone());
        stats
    }

    /// The capture cells still expected in the sortie (for progress lines).
    pub fn captures_left(&self) -> usize {
        let b = self.params.batch;
        self.cycle().map_or(0, |c| {
            c.drones
                .iter()
                .flat_map(|d| &d.captures)
                .filter(|v| v.counted < b)
                .count()
        })
    }

    /// The station leg a drone lands on in the current sortie.
    pub fn landing_station(&self, sysid: u8) -> Option<&StationLeg> {
        let c = self.cycle()?;
        let d = c.drones.iter().find(|d| d.sysid == sysid)?;
        c.stations.get(d.land_on)
    }

    /// Start the run clock of a resume: counts it.
    pub fn on_resume(&mut self) {
        self.resumes += 1;
    }
}

#[cfg(test)]
mod tests;
