//! The records of a run in progress, saved with the state: the sortie in flight (its
//! legs, capture visits and phase), the epoch in progress, finished epochs' statistics and
//! the last counted measurement; plus what the shell should do next.

use super::*;

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
    /// Seconds the epoch's sorties had a drone in the air (fleet clock).
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
