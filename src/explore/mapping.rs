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
//! The runner (the async shell in `crate::app::runway`) asks [`MappingState::directive`] what
//! each robot should do, carries it out with the fleet, reports back with the `on_*` methods,
//! and persists the whole state after every call. Robots are identified by MAVLink system id;
//! [`RobotId`] in the explorer is the same number.

use super::ExploreError;
use super::dfs::{Action, Explorer, ExplorerConfig, RobotId, Sharing, VertexState};
use super::lawnmower::{self, HeadingPolicy, LawnmowerConfig, LocalBox, Sweep};
use crate::geo::{Cell, Dir4, Grid, LatLon};
use crate::mission::definition::{MissionDef, MissionKind, SweepBox};
use crate::time::Time;
use crate::vision::camera::CameraModel;
use crate::vision::runway::{NeighbourLabels, RegionFractions, RunwayParams};
use crate::vision::votes::{CellState, CellUpdate, Detection, VoteBook, VoteParams};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;

/// Version of the serialised [`MappingState`] (the run store's `state.json` payload).
pub const MAPPING_SCHEMA: u32 = 1;

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
}

/// Where the run is.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
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
    },
}

impl std::fmt::Display for Phase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Phase::Sweep => write!(f, "sweeping"),
            Phase::Confirm { sysid, cell } => write!(f, "confirming {cell} (vehicle {sysid})"),
            Phase::Explore { root } => write!(f, "exploring from {root}"),
            Phase::Finished { found: true } => write!(f, "finished"),
            Phase::Finished { found: false } => write!(f, "finished (region not found)"),
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
    pub status_before_swap: Option<RobotStatus>,
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
    /// [`MAPPING_SCHEMA`].
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
            let xy = |p: crate::mission::definition::LatLon| {
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
                visit: None,
                sweep_item: None,
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
            heading: HeadingPolicy::Any,
            position_tolerance_m: 1.0,
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
                let ex = self
                    .explorer
                    .as_mut()
                    .ok_or_else(|| MappingError::WrongPhase {
                        sysid,
                        what: "a DFS step",
                        phase: "exploring without an explorer".into(),
                    })?;
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

    /// Record the position of `sysid` (metres east/north of the grid origin) for its track
    /// and distance, and `dt_air_s` seconds of airborne time since the last call.
    pub fn on_position(
        &mut self,
        sysid: u8,
        east: f64,
        north: f64,
        dt_air_s: f64,
    ) -> Result<(), MappingError> {
        let r = self.robot_mut(sysid)?;
        if dt_air_s.is_finite() && dt_air_s > 0.0 {
            r.flight_s += dt_air_s;
        }
        if !(east.is_finite() && north.is_finite()) {
            return Ok(());
        }
        match r.track.last().copied() {
            Some([e, n]) => {
                let d = ((east - e).powi(2) + (north - n).powi(2)).sqrt();
                if d >= 1.0 {
                    r.distance_m += d;
                    r.track.push([east, north]);
                }
            }
            None => r.track.push([east, north]),
        }
        Ok(())
    }

    /// A sweep image of `sysid` taken over `cell` was classified. Returns the candidate cell
    /// when it starts a confirmation (the first positive region of the run that is not a
    /// rejected candidate).
    #[allow(clippy::too_many_arguments)]
    pub fn on_sweep_image(
        &mut self,
        sysid: u8,
        cell: Cell,
        heading_deg: f64,
        fractions: RegionFractions,
        labels: NeighbourLabels,
        now: Time,
    ) -> Result<Option<Cell>, MappingError> {
        self.touch(now);
        self.images += 1;
        self.robot_mut(sysid)?.images += 1;
        self.sweep_images.push(SweepImage {
            image_id: format!("img{:06}", self.images),
            sysid,
            time: now,
            cell,
            heading_deg,
            fractions,
            labels,
        });
        if self.phase != Phase::Sweep {
            return Ok(None);
        }
        // The centre first, then north, west, south, east.
        let mut candidates = vec![(cell, labels.center)];
        candidates.extend(Dir4::ALL.into_iter().map(|d| (cell.step(d), labels.get(d))));
        let pick = candidates
            .into_iter()
            .find(|(c, positive)| *positive && !self.rejected.contains(c))
            .map(|(c, _)| c);
        if let Some(c) = pick {
            self.phase = Phase::Confirm { sysid, cell: c };
        }
        Ok(pick)
    }

    /// `sysid` is flying to sweep item `item` (user numbering).
    pub fn on_sweep_progress(&mut self, sysid: u8, item: u16) -> Result<(), MappingError> {
        self.robot_mut(sysid)?.sweep_item = Some(item);
        Ok(())
    }

    /// The sweep mission of `sysid` is complete. When every robot's is, and the run is still
    /// sweeping, the run ends without a detection.
    pub fn on_sweep_complete(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.robot_mut(sysid)?.status = RobotStatus::SweepDone;
        if self.phase == Phase::Sweep
            && self.robots.iter().all(|r| {
                matches!(
                    r.status,
                    RobotStatus::SweepDone | RobotStatus::Landed | RobotStatus::AwaitingSwap
                )
            })
        {
            self.phase = Phase::Finished { found: false };
        }
        Ok(())
    }

    /// A cell-centre image (confirmation or DFS) of `sysid` was classified: count its votes.
    /// Returns the cells whose state changed.
    pub fn on_cell_image(&mut self, det: Detection) -> Result<Vec<CellUpdate>, MappingError> {
        let sysid = det.vehicle;
        let cell = det.cell;
        self.touch(det.time);
        self.images += 1;
        let r = self.robot_mut(sysid)?;
        r.images += 1;
        r.visit = match r.visit {
            Some((c, k)) if c == cell => Some((c, k + 1)),
            _ => Some((cell, 1)),
        };
        Ok(self.book.record(det))
    }

    /// The next image name (run-wide).
    pub fn next_image_id(&self) -> String {
        format!("img{:06}", self.images + 1)
    }

    /// Images `sysid` still has to take over `cell` for its current visit (a visit interrupted
    /// by a crash or a swap keeps the images already counted).
    pub fn images_missing(&self, sysid: u8, cell: Cell) -> u32 {
        let n = self.params.images_per_cell;
        match self.robot(sysid).ok().and_then(|r| r.visit) {
            Some((c, k)) if c == cell => n.saturating_sub(k),
            _ => n,
        }
    }

    /// The confirmation visit of `sysid` over `cell` is complete. Starts the DFS from the
    /// first positive cell among the candidate and its neighbours, or goes back to the sweep.
    /// Returns the DFS root if it started.
    pub fn on_confirmed(
        &mut self,
        sysid: u8,
        cell: Cell,
        now: Time,
    ) -> Result<Option<Cell>, MappingError> {
        self.touch(now);
        if self.phase != (Phase::Confirm { sysid, cell }) {
            return Err(MappingError::WrongPhase {
                sysid,
                what: "a confirmation",
                phase: self.phase.to_string(),
            });
        }
        self.book.close_visit(sysid, now);
        self.robot_mut(sysid)?.visit = None;
        let mut order = vec![cell];
        order.extend(cell.neighbours4());
        let root = order
            .into_iter()
            .find(|c| self.book.state(*c) == CellState::Positive);
        match root {
            Some(root) => {
                let ids: Vec<RobotId> = self.robots.iter().map(|r| RobotId(r.sysid)).collect();
                let mut ex = Explorer::new(
                    ExplorerConfig {
                        sharing: self.params.sharing,
                    },
                    root,
                    &ids,
                )?;
                for r in &self.robots {
                    if matches!(
                        r.status,
                        RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap
                    ) {
                        ex.pause(RobotId(r.sysid))?;
                    }
                }
                self.explorer = Some(ex);
                self.phase = Phase::Explore { root };
                for r in &mut self.robots {
                    match r.status {
                        RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap => {
                            r.status_before_swap = Some(RobotStatus::Exploring);
                        }
                        _ => r.status = RobotStatus::Exploring,
                    }
                }
                Ok(Some(root))
            }
            None => {
                self.rejected.insert(cell);
                self.phase = Phase::Sweep;
                for r in &mut self.robots {
                    if matches!(r.status, RobotStatus::Holding | RobotStatus::Confirming) {
                        r.status = RobotStatus::Sweeping;
                    }
                }
                Ok(None)
            }
        }
    }

    /// `sysid` reached `cell` (after `Dfs(MoveTo)` / `Dfs(Rejoin)`).
    pub fn on_arrived(&mut self, sysid: u8, cell: Cell, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        let ex = self.explorer_mut(sysid, "an arrival")?;
        ex.arrived(RobotId(sysid), cell)?;
        Ok(())
    }

    fn explorer_mut(
        &mut self,
        sysid: u8,
        what: &'static str,
    ) -> Result<&mut Explorer, MappingError> {
        let phase = self.phase.to_string();
        self.explorer
            .as_mut()
            .ok_or(MappingError::WrongPhase { sysid, what, phase })
    }

    /// `sysid` finished imaging vertex `cell` (its visit is complete): the neighbours' labels
    /// are the vote book's states. Returns the cells added to the tree.
    pub fn on_observed(
        &mut self,
        sysid: u8,
        cell: Cell,
        now: Time,
    ) -> Result<Vec<Cell>, MappingError> {
        self.touch(now);
        self.book.close_visit(sysid, now);
        self.robot_mut(sysid)?.visit = None;
        let labels = Dir4::ALL.map(|d| self.book.state(cell.step(d)) == CellState::Positive);
        let ex = self.explorer_mut(sysid, "an observation")?;
        Ok(ex.observe(RobotId(sysid), cell, labels)?)
    }

    /// `sysid` must change its battery: it leaves the exploration (its vertex is kept) and
    /// flies home. Idempotent.
    pub fn on_battery_low(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.book.close_visit(sysid, now);
        self.robot_mut(sysid)?.visit = None;
        if let Some(ex) = self.explorer.as_mut() {
            ex.pause(RobotId(sysid))?;
        }
        let r = self.robot_mut(sysid)?;
        if !matches!(
            r.status,
            RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap
        ) {
            r.status_before_swap = Some(r.status);
            r.status = RobotStatus::ReturningForSwap;
        }
        // A robot out of the sweep cannot finish its strip now: the others carry on.
        Ok(())
    }

    /// `sysid`'s camera cannot be trusted (`reason`): it leaves the run as for a battery swap
    /// ([`MappingState::on_battery_low`]) and stays out until the operator confirms a fix.
    pub fn on_camera_fault(
        &mut self,
        sysid: u8,
        reason: String,
        now: Time,
    ) -> Result<(), MappingError> {
        self.abandon_confirmation(sysid);
        self.on_battery_low(sysid, now)?;
        self.robot_mut(sysid)?.camera_fault = Some(reason);
        Ok(())
    }

    /// `sysid` landed for its swap; `reboots` is the vehicle's reboot counter then.
    pub fn on_landed_for_swap(
        &mut self,
        sysid: u8,
        reboots: u32,
        now: Time,
    ) -> Result<(), MappingError> {
        self.touch(now);
        let r = self.robot_mut(sysid)?;
        r.status = RobotStatus::AwaitingSwap;
        r.reboots_at_landing = Some(reboots);
        self.check_finished();
        Ok(())
    }

    /// `sysid` has a fresh battery: it goes back to what it was doing (the DFS from its saved
    /// vertex).
    pub fn on_swapped(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        let exploring = matches!(self.phase, Phase::Explore { .. });
        let r = self.robot_mut(sysid)?;
        if !matches!(
            r.status,
            RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap
        ) {
            return Ok(());
        }
        r.battery_swaps += 1;
        r.reboots_at_landing = None;
        r.camera_fault = None;
        let before = r.status_before_swap.take().unwrap_or(RobotStatus::Idle);
        r.status = match before {
            RobotStatus::Sweeping | RobotStatus::Holding | RobotStatus::Confirming => {
                RobotStatus::Sweeping
            }
            RobotStatus::SweepDone => RobotStatus::SweepDone,
            RobotStatus::Exploring => RobotStatus::Exploring,
            _ => RobotStatus::Idle,
        };
        if exploring {
            r.status = RobotStatus::Exploring;
            if let Some(ex) = self.explorer.as_mut()
                && ex.robot(RobotId(sysid))?.phase == super::dfs::Phase::Paused
            {
                ex.resume(RobotId(sysid))?;
            }
        }
        // A confirmation interrupted by the swap: the confirming robot's visit was closed, so
        // give the confirmation up and sweep on (the candidate may be seen again).
        if let Phase::Confirm { sysid: who, .. } = self.phase
            && who == sysid
        {
            self.phase = Phase::Sweep;
        }
        Ok(())
    }

    /// `sysid` has a low battery during a confirmation: the confirmation is abandoned (the
    /// sweep resumes without rejecting the cell).
    pub fn abandon_confirmation(&mut self, sysid: u8) {
        if let Phase::Confirm { sysid: who, .. } = self.phase
            && who == sysid
        {
            self.phase = Phase::Sweep;
            for r in &mut self.robots {
                if r.status == RobotStatus::Holding {
                    r.status = RobotStatus::Sweeping;
                }
            }
        }
    }

    /// `sysid` is flying home at the end.
    pub fn on_going_home(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.book.close_visit(sysid, now);
        let r = self.robot_mut(sysid)?;
        r.visit = None;
        r.status = RobotStatus::ReturningHome;
        Ok(())
    }

    /// `sysid` landed at the end. When the DFS is complete and every robot is down, the run
    /// is finished.
    pub fn on_landed(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.robot_mut(sysid)?.status = RobotStatus::Landed;
        self.check_finished();
        Ok(())
    }

    /// The DFS is over once the explorer says so (robots away for a battery count as home).
    fn check_finished(&mut self) {
        if let Phase::Explore { .. } = self.phase
            && self.explorer.as_ref().is_some_and(Explorer::is_finished)
        {
            self.phase = Phase::Finished { found: true };
        }
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
    /// `altitude_m` and land, plus the reserve: flight time home at the cruise speed, a
    /// descent at 1 m/s, and 30 s of margin (approach, landing, wind), as a share of the
    /// endurance.
    pub fn battery_needed_pct(&self, distance_home_m: f64, altitude_m: f64) -> f64 {
        let p = &self.params;
        let endurance_s = (p.flight_time_min * 60.0).max(1.0);
        let home_s = distance_home_m.max(0.0) / p.speed_m_s.max(0.1) + altitude_m.max(0.0) + 30.0;
        p.rtl_reserve_pct + 100.0 * home_s / endurance_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::votes::Detection;

    fn def(drones: usize) -> MissionDef {
        let mut text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/missions/runway-field-test.toml"
        ))
        .unwrap();
        for k in 2..=drones {
            text.push_str(&format!("\n[[vehicles]]\nsysid = {k}\nrole = \"drone\"\n"));
        }
        MissionDef::parse(&text, "test.toml").unwrap()
    }

    fn grid() -> Grid {
        Grid::new(
            LatLon {
                lat: 37.1965,
                lon: -80.5785,
            },
            4.0,
        )
        .unwrap()
    }

    fn det(sysid: u8, cell: Cell, k: u64, all: bool) -> Detection {
        Detection {
            image_id: format!("i{k}"),
            vehicle: sysid,
            time: Time::from_secs(k),
            cell,
            position: None,
            heading_deg: 0.0,
            fractions: RegionFractions::default(),
            labels: NeighbourLabels {
                center: true,
                north: all,
                west: false,
                south: false,
                east: false,
            },
        }
    }

    #[test]
    fn sweep_detection_confirmation_and_dfs_to_the_end() {
        let mut s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
        assert_eq!(s.directive(1).unwrap(), Directive::Sweep);
        assert!(!s.sweeps[0].items.is_empty());
        // A sweep image with the centre positive starts a confirmation of that cell.
        let c = Cell::new(3, 2);
        let labels = NeighbourLabels {
            center: true,
            ..NeighbourLabels::default()
        };
        let got = s
            .on_sweep_image(1, c, 0.0, RegionFractions::default(), labels, Time::ZERO)
            .unwrap();
        assert_eq!(got, Some(c));
        assert_eq!(s.directive(1).unwrap(), Directive::Confirm(c));
        assert_eq!(s.images_missing(1, c), 5);
        for k in 0..3 {
            s.on_cell_image(det(1, c, k, true)).unwrap();
        }
        assert_eq!(s.images_missing(1, c), 2);
        for k in 3..5 {
            s.on_cell_image(det(1, c, k, true)).unwrap();
        }
        assert_eq!(s.images_missing(1, c), 0);
        assert_eq!(s.on_confirmed(1, c, Time::from_secs(5)).unwrap(), Some(c));
        // DFS: rejoin the root, observe (north is positive), move north, observe, come back.
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Rejoin(c)));
        s.on_arrived(1, c, Time::from_secs(6)).unwrap();
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Observe));
        for k in 5..10 {
            s.on_cell_image(det(1, c, k, true)).unwrap();
        }
        let n = c.step(Dir4::North);
        assert_eq!(s.on_observed(1, c, Time::from_secs(10)).unwrap(), vec![n]);
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::MoveTo(n)));
        // battery swap in the middle: the vertex is kept
        s.on_battery_low(1, Time::from_secs(11)).unwrap();
        assert_eq!(s.directive(1).unwrap(), Directive::Swap);
        s.on_landed_for_swap(1, 0, Time::from_secs(12)).unwrap();
        s.on_swapped(1, Time::from_secs(13)).unwrap();
        assert_eq!(s.robot(1).unwrap().battery_swaps, 1);
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Rejoin(c)));
        s.on_arrived(1, c, Time::from_secs(14)).unwrap();
        let next = s.directive(1).unwrap();
        assert_eq!(next, Directive::Dfs(Action::MoveTo(n)));
        s.on_arrived(1, n, Time::from_secs(15)).unwrap();
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Observe));
        for k in 15..20 {
            s.on_cell_image(det(1, n, k, false)).unwrap();
        }
        assert!(s.on_observed(1, n, Time::from_secs(20)).unwrap().is_empty());
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::MoveTo(c)));
        s.on_arrived(1, c, Time::from_secs(24)).unwrap();
        assert_eq!(s.directive(1).unwrap(), Directive::GoHome);
        s.on_going_home(1, Time::from_secs(25)).unwrap();
        assert!(!s.is_finished());
        s.on_landed(1, Time::from_secs(40)).unwrap();
        assert!(s.is_finished());
        assert_eq!(s.phase, Phase::Finished { found: true });
        assert_eq!(s.book.positive_cells(), vec![c, n]);
        // the whole state survives a JSON round trip
        let back: MappingState = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back.book, s.book);
        assert_eq!(back.phase, s.phase);
    }

    #[test]
    fn a_negative_confirmation_rejects_the_cell_and_sweeps_on() {
        let mut s = MappingState::new(&def(2), grid(), Sharing::Gcs).unwrap();
        let c = Cell::new(0, 0);
        let pos = NeighbourLabels {
            center: true,
            ..NeighbourLabels::default()
        };
        assert_eq!(
            s.on_sweep_image(2, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
                .unwrap(),
            Some(c)
        );
        assert_eq!(s.directive(1).unwrap(), Directive::Hold);
        for k in 0..5 {
            let mut d = det(2, c, k, false);
            d.labels.center = false;
            s.on_cell_image(d).unwrap();
        }
        assert_eq!(s.on_confirmed(2, c, Time::from_secs(5)).unwrap(), None);
        assert_eq!(s.phase, Phase::Sweep);
        assert!(s.rejected.contains(&c));
        assert_eq!(s.directive(1).unwrap(), Directive::Sweep);
        // the same cell seen again does not start another confirmation
        assert_eq!(
            s.on_sweep_image(1, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
                .unwrap(),
            None
        );
        s.on_sweep_complete(1, Time::from_secs(9)).unwrap();
        assert_eq!(s.phase, Phase::Sweep);
        s.on_sweep_complete(2, Time::from_secs(9)).unwrap();
        assert_eq!(s.phase, Phase::Finished { found: false });
        assert_eq!(s.directive(1).unwrap(), Directive::GoHome);
    }

    /// A camera fault takes the robot out like a battery swap, is saved with the state (a
    /// resumed run reads it back) and only the operator's confirmation clears it.
    #[test]
    fn a_camera_fault_is_saved_and_cleared_by_the_operator() {
        let mut s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
        let t = Time::from_secs(10);
        s.on_camera_fault(1, "pictures 300 m from their cell".into(), t)
            .unwrap();
        assert_eq!(s.robot(1).unwrap().status, RobotStatus::ReturningForSwap);
        let json = serde_json::to_string(&s).unwrap();
        let mut back: MappingState = serde_json::from_str(&json).unwrap();
        assert_eq!(
            back.robot(1).unwrap().camera_fault.as_deref(),
            Some("pictures 300 m from their cell")
        );
        back.on_landed_for_swap(1, 0, t).unwrap();
        back.on_swapped(1, t).unwrap();
        assert_eq!(back.robot(1).unwrap().camera_fault, None);
        // Runs saved before the field existed load without it.
        let old = json.replace(",\"camera_fault\":\"pictures 300 m from their cell\"", "");
        assert_ne!(old, json);
        let old: MappingState = serde_json::from_str(&old).unwrap();
        assert_eq!(old.robot(1).unwrap().camera_fault, None);
    }

    #[test]
    fn battery_need_grows_with_distance() {
        let s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
        let near = s.battery_needed_pct(0.0, 12.0);
        let far = s.battery_needed_pct(100.0, 12.0);
        // 12-minute battery: 100 m at 1 m/s is 100 s ≈ 13.9 %
        assert!((far - near - 100.0 * 100.0 / 720.0).abs() < 1e-9);
        assert!(near > s.params.rtl_reserve_pct);
    }

    #[test]
    fn not_a_runway_mission() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/missions/hardware-6x6.toml"
        ))
        .unwrap();
        let d = MissionDef::parse(&text, "h.toml").unwrap();
        assert!(matches!(
            MappingState::new(&d, grid(), Sharing::Gcs),
            Err(MappingError::Mission(_))
        ));
    }
}
