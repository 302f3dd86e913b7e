//! The runway-mapping run as one serialisable state machine (runway paper §7), pure: no I/O,
//! no clock (every call that needs time takes `now`).
//!
//! The run has two modes, as in §7: **sweep** (each robot flies its strip of the bounding box
//! as an AUTO mission with image captures, [`super::lawnmower`]) until an image first shows
//! the region, then the **recursive DFS** of Algorithm 1 ([`Explorer`]) rooted at that cell.
//! Between the two sits a **confirmation**: a sweep image is taken wherever the vehicle
//! happens to be, so its 3×3 regions do not line up with grid cells and it cannot vote. The
//! robot that saw the region flies to the centre of the cell the positive region falls on
//! and takes the five images the DFS takes at every vertex; the DFS starts from that cell (or
//! a neighbour the votes found positive), and when the votes find nothing the sweep goes on
//! where it stopped (that cell is not tried again).
//!
//! Every image taken over a cell centre (confirmation and DFS) is counted in the
//! [`VoteBook`]: 3 of 5 make a positive, a positive is never reversed, a negative can become
//! positive (§7). The labels the DFS receives for a vertex's four neighbours are the book's
//! states after the vertex's five images, so a neighbour found positive by any earlier visit
//! is a child too.
//!
//! The runner (the async shell in `kinds::runway`) asks [`MappingState::directive`] what
//! each robot should do, carries it out with the fleet, reports back with the `on_*` methods,
//! and persists the whole state after every call. Robots are identified by MAVLink system id;
//! [`RobotId`] in the explorer is the same number.

mod battery;
mod cells;
mod onboard;
mod sweep;
mod times;
mod vehicle;

pub use self::battery::BatteryRules;
pub use self::onboard::OnboardTally;
pub use self::times::{
    Activity, CLOCK_SAMPLE_S, Milestone, MilestoneKind, MissionClock, RobotTimes, Share, Wait,
    WaitTimes,
};
pub use self::vehicle::Grounded;

use super::ExploreError;
use super::dfs::{Action, Allocation, Explorer, ExplorerConfig, RobotId, Sharing, VertexState};
use super::lawnmower::{self, HeadingPolicy, LawnmowerConfig, LocalBox, Sweep};
use super::motion::RoiMotion;
use super::reach::{self, BatteryModel, Leg, Reach, Unreachable};
use crate::geo::{Cell, Dir4, Grid, LatLon};
use crate::mission::definition::{MissionDef, MissionKind, runway::SweepBox};
use crate::time::Time;
use crate::vision::camera::CameraModel;
use crate::vision::regions::RegionFractions;
use crate::vision::runway::votes::{CellState, CellUpdate, Detection, VoteBook, VoteParams};
use crate::vision::runway::{NeighbourLabels, RunwayParams};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;

/// Version of the serialised [`MappingState`] (the run store's `state.json` payload).
pub(crate) const MAPPING_SCHEMA: u32 = 1;

/// Errors of the mapping state machine.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MappingError {
    /// The mission file is not a runway-mapping mission, or lacks what the run needs.
    #[error("mission: {0}")]
    Mission(String),
    /// A system id the run does not know.
    #[error("vehicle {0} is not a drone of this run")]
    UnknownRobot(u8),
    /// The explorer refused a call (a runner bug or a corrupted state).
    #[error(transparent)]
    Explore(#[from] ExploreError),
    /// A call that does not fit the current phase.
    #[error("vehicle {sysid}: {what} while the run is {phase}")]
    WrongPhase {
        /// The robot.
        sysid: u8,
        /// What was reported.
        what: &'static str,
        /// The phase, for the message.
        phase: String,
    },
}

/// The run's parameters, fixed when it starts (from the mission file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MappingParams {
    /// Images over every visited cell (paper: 5).
    pub images_per_cell: u32,
    /// The vote (paper: 3 of 5).
    pub votes: VoteParams,
    /// The classifier (paper: threshold 150, 7 dilations).
    pub runway: RunwayParams,
    /// The camera.
    pub camera: CameraModel,
    /// Altitude of the first drone, metres above home (paper: 12 m).
    pub base_altitude_m: f64,
    /// Cruise speed, m/s (paper: 1 m/s).
    pub speed_m_s: f64,
    /// Battery endurance, minutes (paper: ~12).
    pub flight_time_min: f64,
    /// Return home with at least this much charge left, percent.
    pub rtl_reserve_pct: f64,
    /// How the robots share vertex states.
    pub sharing: Sharing,
    /// How the DFS allocates the robots at a vertex (`runway.allocation`); a state saved
    /// before the choice existed ran the paper's split.
    #[serde(default = "Allocation::paper")]
    pub allocation: Allocation,
    /// The mission's return and swap rules (`[battery]`); a state saved before they were
    /// mission keys reads the values they had as constants (the keys' defaults).
    #[serde(default)]
    pub battery: BatteryRules,
    /// The region's velocity over the ground, `[north, east]` m/s (`runway.roi_velocity_ne_mps`;
    /// absent: static, as every state saved before the key existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roi_velocity_ne_mps: Option<[f64; 2]>,
}

impl MappingParams {
    /// The region's motion, its frame equal to the grid at ROI time zero (the run's epoch:
    /// [`MappingState::roi_epoch_unix_ms`]; times passed to it are seconds since then).
    pub fn motion(&self) -> RoiMotion {
        match self.roi_velocity_ne_mps {
            Some([n, e]) => RoiMotion::new(e, n, Time::ZERO),
            None => RoiMotion::STATIC,
        }
    }
}

/// Why a run ended before its map was complete (saved in the phase, so a resumed run keeps
/// it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum GaveUp {
    /// The region drifted beyond reach: not even a full battery from home could
    /// fly vehicle `sysid` out to region cell `cell` and bring it back, now or later
    /// ([`crate::explore::reach`]). Nothing was labelled for it: the visits then open were
    /// dropped undecided.
    BeyondReach {
        /// The vehicle whose flight was judged.
        sysid: u8,
        /// The region cell it was to fly to.
        cell: Cell,
        /// Why, with the figures.
        why: Unreachable,
    },
}

impl std::fmt::Display for GaveUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GaveUp::BeyondReach { sysid, cell, why } => {
                write!(f, "beyond reach (vehicle {sysid} to cell {cell}: {why})")
            }
        }
    }
}

/// How a finished run ended: what `fleetmap report` and the TUI say.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FinishReason {
    /// The DFS ran to its end: the region is mapped.
    Mapped,
    /// The sweep ended without finding the region.
    RegionNotFound,
    /// The region drifted beyond the drones' reach ([`GaveUp::BeyondReach`]).
    BeyondReach,
}

impl FinishReason {
    /// A short name for displays.
    pub fn name(self) -> &'static str {
        match self {
            FinishReason::Mapped => "mapped",
            FinishReason::RegionNotFound => "region not found",
            FinishReason::BeyondReach => "beyond reach",
        }
    }
}

/// Where the run is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "phase", rename_all = "snake_case")]
pub enum Phase {
    /// The lawnmower sweep of the bounding box.
    Sweep,
    /// Robot `sysid` checks `cell` with five images at its centre; the others hold.
    Confirm {
        /// The robot.
        sysid: u8,
        /// The candidate cell.
        cell: Cell,
    },
    /// The recursive DFS from `root`.
    Explore {
        /// The start vertex (first confirmed positive cell).
        root: Cell,
    },
    /// Nothing left to do; `found` says whether the region was found at all.
    Finished {
        /// Whether the DFS ran (false: the sweep ended without a detection).
        found: bool,
        /// Why the run stopped short of a complete map (absent: it ran to its end; states
        /// saved before this existed have none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gave_up: Option<GaveUp>,
    },
}

impl Phase {
    /// How the run ended (`None` while it goes on).
    pub fn finish_reason(&self) -> Option<FinishReason> {
        match self {
            Phase::Finished {
                gave_up: Some(GaveUp::BeyondReach { .. }),
                ..
            } => Some(FinishReason::BeyondReach),
            Phase::Finished { found: true, .. } => Some(FinishReason::Mapped),
            Phase::Finished { found: false, .. } => Some(FinishReason::RegionNotFound),
            _ => None,
        }
    }
}

impl std::fmt::Display for Phase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Phase::Sweep => write!(f, "sweeping"),
            Phase::Confirm { sysid, cell } => write!(f, "confirming {cell} (vehicle {sysid})"),
            Phase::Explore { root } => write!(f, "exploring from {root}"),
            Phase::Finished {
                gave_up: Some(g), ..
            } => write!(f, "finished: {g}"),
            Phase::Finished { found: true, .. } => write!(f, "finished"),
            Phase::Finished { found: false, .. } => write!(f, "finished (region not found)"),
        }
    }
}

/// What one robot is doing, as the run sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotStatus {
    /// Not started yet.
    Idle,
    /// Flying its sweep mission.
    Sweeping,
    /// Its sweep mission is complete; holding.
    SweepDone,
    /// Holding while another robot confirms a detection.
    Holding,
    /// Taking the confirmation images.
    Confirming,
    /// Taking part in the DFS.
    Exploring,
    /// Sent home to change its battery (its place in the tree is saved).
    ReturningForSwap,
    /// Landed at home, waiting for a fresh battery.
    AwaitingSwap,
    /// Done: flying home to land.
    ReturningHome,
    /// Done and landed.
    Landed,
}

impl RobotStatus {
    /// A short name for displays.
    pub fn name(self) -> &'static str {
        match self {
            RobotStatus::Idle => "idle",
            RobotStatus::Sweeping => "sweeping",
            RobotStatus::SweepDone => "sweep done",
            RobotStatus::Holding => "holding",
            RobotStatus::Confirming => "confirming",
            RobotStatus::Exploring => "exploring",
            RobotStatus::ReturningForSwap => "battery: returning",
            RobotStatus::AwaitingSwap => "battery: swap",
            RobotStatus::ReturningHome => "returning",
            RobotStatus::Landed => "landed",
        }
    }
}

/// One robot of the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotRecord {
    /// MAVLink system id (= the explorer's robot id).
    pub sysid: u8,
    /// Flight altitude, metres above home.
    pub altitude_m: f64,
    /// What it is doing.
    pub status: RobotStatus,
    /// Status before a battery swap, restored after it.
    pub(crate) status_before_swap: Option<RobotStatus>,
    /// Battery swaps so far.
    pub battery_swaps: u32,
    /// Reboot counter of the vehicle when it landed for a swap (a power cycle raises it).
    pub reboots_at_landing: Option<u32>,
    /// Images this robot took that were classified.
    pub images: u64,
    /// Airborne time, seconds (sum over flights).
    pub flight_s: f64,
    /// Distance flown, metres (from the positions reported).
    pub distance_m: f64,
    /// Its track, metres east/north of the grid origin (a point every ≥ 1 m).
    pub track: Vec<[f64; 2]>,
    /// The visit in progress: the cell it is imaging and the images counted so far (a
    /// visit interrupted by a crash keeps them; cleared when the visit ends).
    pub visit: Option<(Cell, u32)>,
    /// The sweep mission item (user numbering) it was flying to last; a sweep interrupted
    /// by a battery swap resumes there.
    pub sweep_item: Option<u16>,
    /// Its camera was found untrustworthy (why): it is out of the run until the operator
    /// confirms it is fixed ([`MappingState::on_swapped`] by the operator clears it); a
    /// fresh battery alone does not bring it back, also after a resume. Absent in runs saved
    /// before this field existed.
    #[serde(default)]
    pub camera_fault: Option<String>,
    /// Its camera fault is a camera that went silent — no answer to captures, no pictures —
    /// not one whose pictures were wrong ([`MappingState::on_camera_silent`]): when the camera
    /// is heard again (back from a reboot, its cable refitted) the vehicle may rejoin by
    /// itself; wrong pictures wait for a person. Absent (false) in runs saved before it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub camera_silent: bool,
    /// It could not take off, or its steps kept failing ([`Grounded`]): out of the run as for
    /// a battery swap, on the ground, until it is ready again or the operator says so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grounded: Option<Grounded>,
    /// Its time since the team's first take-off: flying, waiting, on the ground
    /// ([`MissionClock`]); zero in runs saved before it was measured.
    #[serde(default)]
    pub times: RobotTimes,
}

/// A sweep-phase image: classified, but not a vote (it was not taken over a cell centre).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepImage {
    /// Identifier (run-wide image number).
    pub image_id: String,
    /// The robot.
    pub sysid: u8,
    /// When it was classified.
    pub time: Time,
    /// The cell under the camera.
    pub cell: Cell,
    /// The heading, degrees.
    pub heading_deg: f64,
    /// Black fractions of the five regions (image coordinates).
    pub fractions: RegionFractions,
    /// Labels in grid directions.
    pub labels: NeighbourLabels,
}

/// What a robot should do now (see [`MappingState::directive`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Directive {
    /// Fly (or keep flying) its sweep mission, classifying every image.
    Sweep,
    /// Hold position until the state changes.
    Hold,
    /// Fly to the centre of this cell and take the confirmation images.
    Confirm(Cell),
    /// A step of the DFS.
    Dfs(Action),
    /// Go home, land and wait for a fresh battery (then [`MappingState::on_swapped`]).
    Swap,
    /// The run is over for this robot: fly home and land (then [`MappingState::on_landed`]).
    GoHome,
    /// Landed at the end: nothing more.
    Stop,
}

/// The persisted state of a runway-mapping run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MappingState {
    /// `MAPPING_SCHEMA`.
    pub schema: u32,
    /// The mission's name.
    pub mission: String,
    /// The mission grid.
    pub grid: Grid,
    /// Parameters.
    pub params: MappingParams,
    /// Where the run is.
    pub phase: Phase,
    /// The robots, in mission-file order.
    pub robots: Vec<RobotRecord>,
    /// The sweep plan (one per robot, same order).
    pub sweeps: Vec<Sweep>,
    /// Sweep-phase images.
    pub sweep_images: Vec<SweepImage>,
    /// Candidate cells the confirmation found negative (not tried again by the sweep).
    pub rejected: BTreeSet<Cell>,
    /// The DFS, once started.
    pub explorer: Option<Explorer>,
    /// Every vote.
    pub book: VoteBook,
    /// Images classified so far (run-wide; names images).
    pub images: u64,
    /// Images that were lost or could not be classified.
    pub image_failures: u64,
    /// Time of the first call after the start, and the latest call (fleet clock).
    pub started: Option<Time>,
    /// The latest time the state was updated.
    pub updated: Option<Time>,
    /// When the region was where the mission's geometry puts it, ms since the Unix epoch
    /// (wall clock, or the simulator's start scaled by its speed-up): the ROI frame equals
    /// the grid then. Set by the shell when a run with a moving region starts (the
    /// simulator's start in the demo); kept across resumes. `None`: not set yet, or static.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roi_epoch_unix_ms: Option<u64>,
    /// The mission clock: time to the DFS's start, to the complete map and to the last
    /// landing, fleet-clock seconds since the first take-off ([`MissionClock`]); empty in
    /// runs saved before it was measured.
    #[serde(default)]
    pub clock: MissionClock,
    /// Pictures the cameras classified on board and their audits (zeros before).
    #[serde(default)]
    pub onboard: OnboardTally,
}

/// Convert the mission's sweep box to the grid's local frame.
fn sweep_box(def: &MissionDef, grid: &Grid) -> Result<LocalBox, MappingError> {
    let rw = def
        .runway
        .as_ref()
        .ok_or_else(|| MappingError::Mission("no [runway] table".into()))?;
    Ok(match rw.sweep {
        SweepBox::Local { north_m, east_m } => LocalBox {
            east_min: east_m[0],
            east_max: east_m[1],
            north_min: north_m[0],
            north_max: north_m[1],
        },
        SweepBox::Corners {
            south_west,
            north_east,
        } => {
            let xy = |p: crate::geo::LatLon| {
                grid.to_xy(LatLon {
                    lat: p.lat,
                    lon: p.lon,
                })
                .map_err(|e| MappingError::Mission(format!("sweep corner: {e}")))
            };
            let (e0, n0) = xy(south_west)?;
            let (e1, n1) = xy(north_east)?;
            LocalBox {
                east_min: e0.min(e1),
                east_max: e0.max(e1),
                north_min: n0.min(n1),
                north_max: n0.max(n1),
            }
        }
    })
}

impl MappingState {
    /// A new run of `def` (a runway-mapping mission) on `grid` (whose origin the runner fixed:
    /// the file's, or the first vehicle's home). Plans the sweep for the mission's drones.
    pub fn new(
        def: &MissionDef,
        grid: Grid,
        sharing: Sharing,
    ) -> Result<MappingState, MappingError> {
        if def.kind != MissionKind::RunwayMapping {
            return Err(MappingError::Mission(format!(
                "{} is a {} mission, not runway mapping",
                def.name,
                def.kind.as_str()
            )));
        }
        let rw = def
            .runway
            .as_ref()
            .ok_or_else(|| MappingError::Mission("no [runway] table".into()))?;
        let robots: Vec<RobotRecord> = def
            .drones()
            .map(|v| RobotRecord {
                sysid: v.sysid,
                altitude_m: def.altitude_for(v.sysid).unwrap_or(def.flight.altitude_m),
                status: RobotStatus::Idle,
                status_before_swap: None,
                battery_swaps: 0,
                reboots_at_landing: None,
                images: 0,
                flight_s: 0.0,
                distance_m: 0.0,
                track: Vec::new(),
                camera_fault: None,
                camera_silent: false,
                grounded: None,
                visit: None,
                sweep_item: None,
                times: RobotTimes::default(),
            })
            .collect();
        if robots.is_empty() {
            return Err(MappingError::Mission("the mission has no drones".into()));
        }
        let votes = VoteParams {
            images_per_visit: rw.images_per_cell,
            positive_votes: rw.votes_required,
        };
        let book = VoteBook::new(votes).map_err(|e| MappingError::Mission(e.to_string()))?;
        let area = sweep_box(def, &grid)?;
        let cfg = LawnmowerConfig {
            area,
            camera: def.camera,
            altitudes_m: robots.iter().map(|r| r.altitude_m).collect(),
            speed_mps: def.flight.speed_m_s,
            heading: match rw.sweep_heading_error_deg {
                None => HeadingPolicy::Any,
                Some(max_error_deg) => HeadingPolicy::AlongTrack { max_error_deg },
            },
            position_tolerance_m: rw.sweep_position_tolerance_m,
            lane_spacing_m: rw.lane_spacing_m,
            hold_s: 0.0,
            return_to_launch: false,
        };
        let sweeps = lawnmower::plan(&cfg, |e, n| grid.from_xy(e, n).map(|p| (p.lat, p.lon)))?;
        Ok(MappingState {
            schema: MAPPING_SCHEMA,
            mission: def.name.clone(),
            grid,
            params: MappingParams {
                images_per_cell: rw.images_per_cell,
                votes,
                runway: RunwayParams {
                    intensity_threshold: rw.intensity_threshold,
                    dilation_iterations: rw.dilations,
                    black_fraction_threshold: rw.black_fraction,
                },
                camera: def.camera,
                base_altitude_m: def.flight.altitude_m,
                speed_m_s: def.flight.speed_m_s,
                flight_time_min: def.battery.flight_time_min,
                rtl_reserve_pct: def.battery.rtl_reserve_pct,
                sharing,
                allocation: rw.allocation,
                battery: BatteryRules::from(&def.battery),
                roi_velocity_ne_mps: rw.roi_velocity_ne_mps,
            },
            phase: Phase::Sweep,
            robots,
            sweeps,
            sweep_images: Vec::new(),
            rejected: BTreeSet::new(),
            explorer: None,
            book,
            images: 0,
            image_failures: 0,
            started: None,
            updated: None,
            roi_epoch_unix_ms: None,
            clock: MissionClock::default(),
            onboard: OnboardTally::default(),
        })
    }

    /// The robot `sysid`.
    pub fn robot(&self, sysid: u8) -> Result<&RobotRecord, MappingError> {
        self.robots
            .iter()
            .find(|r| r.sysid == sysid)
            .ok_or(MappingError::UnknownRobot(sysid))
    }

    fn robot_mut(&mut self, sysid: u8) -> Result<&mut RobotRecord, MappingError> {
        self.robots
            .iter_mut()
            .find(|r| r.sysid == sysid)
            .ok_or(MappingError::UnknownRobot(sysid))
    }

    /// The sweep plan of robot `sysid`.
    pub fn sweep_of(&self, sysid: u8) -> Result<&Sweep, MappingError> {
        let i = self
            .robots
            .iter()
            .position(|r| r.sysid == sysid)
            .ok_or(MappingError::UnknownRobot(sysid))?;
        self.sweeps.get(i).ok_or(MappingError::UnknownRobot(sysid))
    }

    fn touch(&mut self, now: Time) {
        self.started.get_or_insert(now);
        self.updated = Some(now);
    }

    /// Whether the run is over for every robot.
    pub fn is_finished(&self) -> bool {
        matches!(self.phase, Phase::Finished { .. })
            && self.robots.iter().all(|r| r.status == RobotStatus::Landed)
    }

    /// What robot `sysid` should do now. Advances the explorer for DFS robots (it may
    /// change the explorer's state, so persist afterwards).
    pub fn directive(&mut self, sysid: u8) -> Result<Directive, MappingError> {
        let status = self.robot(sysid)?.status;
        if let Phase::Finished { .. } = self.phase {
            // Over: robots waiting for a battery are already home; the others fly home.
            return Ok(match status {
                RobotStatus::Landed => Directive::Stop,
                _ => Directive::GoHome,
            });
        }
        match status {
            RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap => {
                return Ok(Directive::Swap);
            }
            RobotStatus::Landed => return Ok(Directive::Stop),
            RobotStatus::ReturningHome => return Ok(Directive::GoHome),
            _ => {}
        }
        match self.phase.clone() {
            Phase::Finished { .. } => Ok(Directive::GoHome),
            Phase::Sweep => Ok(match status {
                RobotStatus::SweepDone => Directive::Hold,
                _ => {
                    self.robot_mut(sysid)?.status = RobotStatus::Sweeping;
                    Directive::Sweep
                }
            }),
            Phase::Confirm { sysid: who, cell } => {
                if who == sysid {
                    self.robot_mut(sysid)?.status = RobotStatus::Confirming;
                    Ok(Directive::Confirm(cell))
                } else {
                    if status != RobotStatus::SweepDone {
                        self.robot_mut(sysid)?.status = RobotStatus::Holding;
                    }
                    Ok(Directive::Hold)
                }
            }
            Phase::Explore { .. } => {
                let complete = self.map_complete(); // then home, not back to the start
                let ex = self
                    .explorer
                    .as_mut()
                    .ok_or_else(|| MappingError::WrongPhase {
                        sysid,
                        what: "a DFS step",
                        phase: "exploring without an explorer".into(),
                    })?;
                if complete && ex.finish_where_it_is(RobotId(sysid))? {
                    return Ok(Directive::GoHome);
                }
                let action = ex.next_action(RobotId(sysid))?;
                self.robot_mut(sysid)?.status = RobotStatus::Exploring;
                match action {
                    Action::ReturnHome => Ok(Directive::Swap),
                    Action::Done => Ok(Directive::GoHome),
                    a => Ok(Directive::Dfs(a)),
                }
            }
        }
    }

    /// [`MappingState::directive`], and whether it changed the state (robot statuses or the
    /// explorer): a robot that is told to hold or wait again changes nothing, and the runner
    /// then need not save or wake the others.
    pub fn directive_changed(&mut self, sysid: u8) -> Result<(Directive, bool), MappingError> {
        let statuses: Vec<RobotStatus> = self.robots.iter().map(|r| r.status).collect();
        let explorer = self.explorer.clone();
        let d = self.directive(sysid)?;
        let changed = self
            .robots
            .iter()
            .map(|r| r.status)
            .ne(statuses.iter().copied())
            || explorer != self.explorer;
        Ok((d, changed))
    }

    /// The altitude at which `sysid` flies, metres above home.
    pub fn altitude_of(&self, sysid: u8) -> Result<f64, MappingError> {
        Ok(self.robot(sysid)?.altitude_m)
    }

    /// The DFS is over once the explorer says so (robots away for a battery count as home).
    fn check_finished(&mut self, now: Time) {
        if let Phase::Explore { .. } = self.phase
            && self.explorer.as_ref().is_some_and(Explorer::is_finished)
        {
            self.phase = Phase::Finished {
                found: true,
                gave_up: None,
            };
        }
        self.note_milestones(now);
    }

    /// Every cell the run knows something about and what: the vote book's state plus the DFS
    /// vertex state of positive cells in the tree.
    pub fn cell_map(&self) -> Vec<(Cell, CellState, Option<VertexState>)> {
        let ex = self.explorer.as_ref();
        self.book
            .cells()
            .map(|(c, r)| (c, r.state, ex.and_then(|e| e.vertex_state(c))))
            .collect()
    }

    /// Battery percentage `sysid` needs to get home from `distance_home_m` away at
    /// `altitude_m` and land, plus the reserve: flight time home at the cruise speed, the
    /// descent at `battery.descent_rate_m_s`, and `battery.landing_margin_s` (approach,
    /// landing, wind), as a share of the endurance.
    pub fn battery_needed_pct(&self, distance_home_m: f64, altitude_m: f64) -> f64 {
        self.battery_model().return_pct(distance_home_m, altitude_m)
    }

    /// How the run charges flights against a battery (the endurance, cruise speed, reserve
    /// and return rules of the mission).
    pub(crate) fn battery_model(&self) -> BatteryModel {
        let p = &self.params;
        BatteryModel {
            endurance_s: p.flight_time_min * 60.0,
            speed_m_s: p.speed_m_s,
            reserve_pct: p.rtl_reserve_pct,
            descent_rate_m_s: p.battery.descent_rate_m_s,
            landing_margin_s: p.battery.landing_margin_s,
        }
    }

    /// The charge a swapped battery is guaranteed to report, percent: the lower of the
    /// `[battery]` fresh thresholds (a drone takes off again with no less) — what the reach
    /// rule counts a full battery as.
    pub(crate) fn full_charge_pct(&self) -> f64 {
        let b = &self.params.battery;
        b.fresh_pct.min(b.fresh_after_reboot_pct)
    }

    /// Whether `sysid` may fly out to region cell `cell` now ([`crate::explore::reach`]): from
    /// `from` (ground metres of the grid) with `charge_pct`, home at `home`, staying `dwell_s`
    /// over the cell, at region time `roi_now`. Once the map is complete a flight to a cell is
    /// only the end of a step begun before: anything but [`Reach::Fly`] then sends the drone
    /// home ([`Reach::SwapFirst`], after which it lands for good), never ends the run.
    #[allow(clippy::too_many_arguments)]
    pub fn reach_of(
        &self,
        sysid: u8,
        cell: Cell,
        from: (f64, f64),
        home: (f64, f64),
        charge_pct: f64,
        dwell_s: f64,
        roi_now: Time,
    ) -> Result<Reach, MappingError> {
        let leg = Leg {
            from,
            home,
            altitude_m: self.altitude_of(sysid)?,
            charge_pct,
            dwell_s,
        };
        let r = reach::reach(
            &self.params.motion(),
            cell,
            self.grid.cell_size(),
            roi_now,
            &leg,
            &self.battery_model(),
            self.full_charge_pct(),
        );
        Ok(match r {
            Reach::Wait { .. } | Reach::BeyondReach(_) if self.map_complete() => Reach::SwapFirst {
                needed_pct: charge_pct,
            },
            r => r,
        })
    }

    /// The region is beyond reach: `sysid` could not fly to `cell` and back even on a full
    /// battery from home (`why`). The run finishes with [`GaveUp::BeyondReach`]; every robot
    /// goes home. Nothing is labelled for giving up: open visits are dropped undecided (the
    /// cells their pictures had not settled keep their state). Idempotent once finished.
    pub fn on_beyond_reach(
        &mut self,
        sysid: u8,
        cell: Cell,
        why: Unreachable,
        now: Time,
    ) -> Result<(), MappingError> {
        self.robot(sysid)?;
        self.touch(now);
        if matches!(self.phase, Phase::Finished { .. }) {
            return Ok(());
        }
        self.book.drop_open_visits();
        for r in &mut self.robots {
            r.visit = None;
        }
        self.phase = Phase::Finished {
            found: self.explorer.is_some(),
            gave_up: Some(GaveUp::BeyondReach { sysid, cell, why }),
        };
        self.note_milestones(now);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
