//! The spatial-classification run on a real fleet as a pure, serialisable state machine
//! (bandit paper Algorithm 1 with Algorithm 2 as the low-level planner): no I/O, no clock —
//! every time is a parameter, and the async shell (`kinds::bandit`) saves the state
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
//! * **Cells.** The state speaks mission cells (rows grow north, docs/grid.md); the IP
//!   speaks the scenario's top-left indexing (docs/ip-scenario.md): row r of a mission with
//!   `rows` rows is planner row `rows − 1 − r` (`Layout::to_planner`).
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

mod cycle;
mod epoch;
mod layout;
mod measure;
pub mod missions;
mod out;
mod records;

pub use layout::{Layout, Member, SortiePlan, TeamConfig};
pub use measure::ImageMismatch;
pub use out::Sidelined;
pub use records::*;

use crate::geo::{Cell, Grid as GeoGrid};
use crate::mission::definition::{MissionDef, MissionKind, Role};
use crate::mission::item::MissionItem;
use crate::planner::bandit::{self, BanditState, Label};
use crate::planner::grid::PlannerGrid;
use crate::planner::plan::IpPlan;
use crate::planner::scenario::{Instance, Pin};
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
pub(crate) const MAX_SOLVES: u32 = 4;

/// Epochs in a row whose capture visits brought no measurement after which a run stops: the
/// drones' pictures (or their cameras' on-board measurements) do not reach the GCS, and
/// flying on would only repeat the same goals (the bandit's choice does not change without a
/// sample). Seen on PX4 SIH drones whose camera never took a picture: twelve epochs, none
/// measured, the same three goals each time.
pub const MAX_EPOCHS_WITHOUT_MEASUREMENT: usize = 3;

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
    /// alternative to (7e), its ref. \[5\]): missions fly freely, the team waits only at the
    /// rendezvous.
    Altitude,
    /// The paper's mid-cycle separation (7e): drones at distinct cells at every time step,
    /// which needs them in step — the runner holds a drone that is a step ahead until every
    /// drone has reached that step.
    LockStep,
}

/// Side of the measured square of a picture as a fraction of the cell side
/// ([`SortieParams::crop_fraction`]).
pub const CROP_FRACTION: f64 = 0.6;

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
    pub(crate) capture_interval_s: f64,
    /// The measured part of an image: a centred square of this fraction of the cell side
    /// (on the ground), so that the measurement sees its cell and not the neighbours
    /// whatever the drone's altitude and heading (0.6: a rotated square of 0.6 cells stays
    /// inside the cell up to 0.08 cells of position error).
    pub crop_fraction: f64,
    /// An image counts for a cell when it was taken within this fraction of a cell of the
    /// cell's centre.
    pub(crate) capture_tolerance: f64,
    /// Drone battery endurance, minutes of hover.
    pub flight_time_min: f64,
    /// Charge kept in reserve, percent.
    pub rtl_reserve_pct: f64,
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
    /// Members out of the run for now, and why ([`Sidelined`]; `out.rs`); absent in runs
    /// saved before members could go out.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub out: BTreeMap<u8, Sidelined>,
    /// Failed sortie starts in a row, per vehicle (the back-off of [`Sidelined`]); cleared
    /// by a sortie it starts.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub start_failures: BTreeMap<u8, u32>,
}

/// The green-pixel measurement of `def` (`[classification.green]`, defaults when absent).
pub fn green_params(def: &MissionDef) -> GreenParams {
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
        let mut bandit = BanditState::new(def.candidate_cells(), c.theta, c.epsilon, c.delta)
            .map_err(|e| bad(e.to_string()))?;
        bandit.bound = c.bound;
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
            crop_fraction: CROP_FRACTION,
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
            out: BTreeMap::new(),
            start_failures: BTreeMap::new(),
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
    /// per station, everything inside G and off O — what (7a) needs of (X_0, Y_0). A drone
    /// out of the run may stand anywhere (it is not planned); on a station it takes a
    /// charger.
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
            if self.is_out(m.sysid) && !distinct.contains(&cell) {
                continue;
            }
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

    /// The capture visits of the current sortie short of their B images: (drone, cell,
    /// images counted), in the sortie's order.
    pub fn short_visits(&self) -> Vec<(u8, Cell, u32)> {
        let b = self.params.batch;
        self.cycle().map_or_else(Vec::new, |c| {
            c.drones
                .iter()
                .flat_map(|d| d.captures.iter().map(move |v| (d.sysid, v)))
                .filter(|(_, v)| v.counted < b)
                .map(|(sysid, v)| (sysid, v.cell, v.counted))
                .collect()
        })
    }

    /// How many of the last epochs, among those from index `since` of [`Self::epochs`] on,
    /// had capture visits and not one measurement, in a row up to the latest.
    pub fn epochs_without_measurement(&self, since: usize) -> usize {
        self.epochs
            .iter()
            .skip(since)
            .rev()
            .take_while(|e| e.visits > 0 && e.measurements == 0)
            .count()
    }

    /// The station leg a drone lands on in the current sortie.
    pub fn landing_station(&self, sysid: u8) -> Option<&StationLeg> {
        let c = self.cycle()?;
        let d = c.drones.iter().find(|d| d.sysid == sysid)?;
        c.stations.get(d.land_on)
    }

    /// Start the run clock of a resume: counts it. The operator's resume is the word to try
    /// again every member that is out: each is eligible at once ([`ClassificationState::
    /// eligible`]; it is taken back when its telemetry says it is ready).
    pub fn on_resume(&mut self) {
        self.resumes += 1;
        for o in self.out.values_mut() {
            o.wait_sorties = 0;
        }
    }
}

#[cfg(test)]
mod tests;
