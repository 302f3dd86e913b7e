//! The runway-mapping run (runway paper §7) on real or simulated vehicles: the async shell
//! around [`MappingState`].
//!
//! One **pilot** task per drone asks the state what to do ([`MappingState::directive`]),
//! does it through the fleet ([`crate::app::flight`]) and reports back; every report is saved
//! before the pilot goes on (`state.json` replaced atomically, then one journal record in
//! `events.jsonl`), so a GCS killed at any moment resumes from the last acknowledged step
//! (`fleetmap resume RUN_DIR`) with every counted image kept. The vehicles need nothing
//! from us to stay safe meanwhile: they hold position in GUIDED / Hold, or carry on with the
//! sweep mission, and their own failsafes bring them home.
//!
//! * **Sweep**: the robot's strip ([`fleetmap_core::explore::lawnmower`]) is uploaded, verified by
//!   download, and flown in AUTO with a capture at every waypoint. Each image is classified
//!   (cell = the one under the camera); the first positive region stops every sweep (the
//!   robots hold) and the robot that saw it **confirms** the cell with five images at its
//!   centre. Positive: the DFS starts there; negative: the sweeps go on.
//! * **DFS**: Algorithm 1 ([`fleetmap_core::explore::dfs::Explorer`]): go to the next cell centre
//!   (DO_REPOSITION at the robot's altitude and the mission speed), wait until there and
//!   steady, take five images, count their votes, give the explorer the neighbours' labels.
//! * **Image sanity** ([`fleetmap_core::vision::sanity`]): a picture counts for a cell only when it
//!   was taken there — its position (the camera's CAMERA_IMAGE_CAPTURED / JPEG metadata, else
//!   the telemetry at the shutter) within [`RunOptions::capture_limits`] of the cell centre
//!   (default: the arrival tolerance + 0.5 m), its altitude within 1.5 m of the planned one,
//!   the camera within 10° of level and of the vehicle's heading. Otherwise it is dropped
//!   (journalled as [`MappingEvent::ImageRejected`]) and taken again; a picture that never
//!   arrives or cannot be read is retried the same way. A sweep picture must have been taken
//!   where the vehicle is (within one cell more than the cell limit), at the planned altitude
//!   and within [`fleetmap_core::vision::sanity::SWEEP_MAX_TILT_DEG`] (20°: sweep pictures are taken
//!   while the copter brakes at a waypoint). After [`RunOptions::max_retakes`] retakes in
//!   one visit (or that many rejected sweep pictures in a row) the camera is declared faulty
//!   ([`MappingEvent::CameraFault`], a warning): nothing more of it is credited, the vehicle
//!   leaves the tree (its vertex is kept, as for a battery swap), returns home, lands and
//!   **waits for the operator** — a fresh battery does not repair a camera — who fixes the
//!   camera and resumes (`fleetmap resume`, or `b` in the UI). A camera that went **silent**
//!   instead (its captures unanswered, its pictures never arriving, while the autopilot is
//!   heard) is a camera that may come back: with auto-resume its vehicle rejoins by itself
//!   once the camera is heard again ([`MappingEvent::CameraBack`], see `camera`).
//! * **Where the camera looked**: when the picture's attitude is known (CAMERA_IMAGE_CAPTURED
//!   `q`), the 3 × 3 cells are cut from it as a north-up orthophoto around the cell centre
//!   ([`fleetmap_core::vision::geometry::orthophoto`]: pinhole camera rotated by the attitude,
//!   intersected with flat ground at the capture altitude), so tilt, heading and the offset
//!   from the centre no longer move the regions; without it the centre crop
//!   ([`crop_to_cells`]) turned by the heading is used, as before.
//! * **Batteries**: before every step the pilot compares the charge with what the flight
//!   home needs ([`MappingState::battery_needed_pct`]); below it the robot leaves the tree
//!   (its vertex is saved), returns, lands and waits for a fresh battery — detected by
//!   itself with `auto_resume` (the vehicle power-cycles and reports a full battery), or
//!   announced by the operator ([`Operator::BatterySwapped`]). It then takes off again and
//!   resumes from its vertex.
//! * **End**: every robot back at the start (Algorithm 1), then home and landed; the run's
//!   outputs are written by [`report`].

use crate::app::error::RunnerResult;
use crate::app::flight::{self, FlightError, Patience};
use crate::app::images::{ImageHub, ReceivedImage};
use crate::app::run::{Progress, RunCore};
use crate::fleet::{FleetHandle, GeoPoint, VehicleSnapshot};
use crate::store::RunDir;
use fleetmap_core::explore::dfs::Action;
use fleetmap_core::explore::mapping::{
    Activity, Directive, MappingError, MappingState, Phase, RobotStatus, Wait,
};
use fleetmap_core::explore::motion::RoiMotion;
use fleetmap_core::geo::{Cell, Grid, LatLon, local};
use fleetmap_core::mission::item::MissionType;
use fleetmap_core::time::Time;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::vision::crop::crop_to_cells;
use fleetmap_core::vision::geometry::{self, OrthoRequest};
use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use fleetmap_core::vision::runway::votes::{Detection, GeoPosition};
use fleetmap_core::vision::runway::{RegionReading, RunwayParams, classify};
use fleetmap_core::vision::sanity::{
    CaptureClaim, CaptureLimits, SWEEP_MAX_TILT_DEG, check_capture,
};
use fleetmap_io::watch;
use mavlink::dialects::ardupilotmega::MavMessage;
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{broadcast, mpsc};

mod camera;
pub mod classify;
pub mod commands;
#[cfg(feature = "sim")]
pub mod demo;
pub mod error;
mod events;
mod grounded;
pub(crate) mod kind;
pub mod report;
pub use self::kind::Runway;
mod intake;
mod panes;
mod pilot;
mod runner;
pub mod sample;
mod summary;
mod sweep;
mod visit_captures;

pub use self::events::*;
pub(crate) use self::intake::*;
pub use self::intake::{onboard_accept, runway_definition_of};
pub use self::runner::*;

/// The run kind in `run.json`.
pub const KIND: &str = "runway-mapping";

/// Seconds of wall-clock time (scaled by the clock's speed-up) without any image data from a
/// sweeping vehicle after which the pictures its camera announced and did not deliver count
/// as missing. The receiver asks for a picture missing packets five times over 14 s
/// (`fleetmap_core::proto::image_transfer::ReceiverConfig`); 20 s covers that with room to spare.
const SWEEP_IMAGE_STALL_S: f64 = 20.0;

/// How many announced sweep pictures' reference positions a pilot keeps (a sweep's worth).
const ANNOUNCED_KEPT: usize = 512;

/// What the operator can ask of a running mission (the TUI's keys).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Operator {
    /// Every robot holds where it is until [`Operator::Resume`].
    Pause,
    /// Carry on after a pause.
    Resume,
    /// The battery of this vehicle was swapped: it may take off again.
    BatterySwapped(u8),
    /// Send this vehicle home now for a battery swap (its vertex is kept).
    Recall(u8),
    /// Land this vehicle where it is (its vertex is kept; it waits on the ground as for a
    /// battery swap, until [`Operator::BatterySwapped`]).
    Land(u8),
}

use crate::app::kind::Outcome;

/// Options of a run.
pub struct RunOptions {
    /// Resume by itself after a battery swap (the vehicle power-cycles and reports a full
    /// battery) instead of waiting for the operator.
    pub auto_resume: bool,
    /// Operator commands (the TUI); `None` in headless runs.
    pub operator: Option<mpsc::UnboundedReceiver<Operator>>,
    /// Progress lines for a headless run's stdout / the TUI's log.
    pub progress: Option<mpsc::UnboundedSender<Progress>>,
    /// The state after every step (the TUI's map and mission panes).
    pub view: Option<watch::Sender<Arc<MappingState>>>,
    /// Timeout scaling.
    pub patience: Patience,
    /// A vehicle is "there" within this horizontal distance of a cell centre, metres.
    pub tolerance_m: f64,
    /// Consecutive failed steps after which a pilot grounds its drone (it leaves the tree as
    /// for a battery swap and waits: `Pilot::ground`); the others go on.
    pub max_failures: u32,
    /// Failed pictures (dropped by the sanity check, lost, unreadable) retaken per cell
    /// visit, and rejected sweep pictures in a row, before the camera is declared faulty.
    /// 5 = as many as a visit's own images: a healthy camera fails a picture rarely (a late
    /// image, a gust), so more than half a visit's captures failing is no transient.
    pub max_retakes: u32,
    /// Limits of the image sanity check (`None`: [`CaptureLimits::hover`] of
    /// `tolerance_m`, i.e. 1.0 m, 1.5 m, 10°, 10°).
    pub capture_limits: Option<CaptureLimits>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            auto_resume: false,
            operator: None,
            progress: None,
            view: None,
            patience: Patience::default(),
            tolerance_m: 0.5,
            max_failures: 20,
            max_retakes: 5,
            capture_limits: None,
        }
    }
}

/// The runway run's shared part: the run core (state, store, progress, view) and the
/// operator's requests and settings every pilot reads.
struct Shared {
    run: Arc<RunCore<MappingState>>,
    paused: watch::Sender<bool>,
    swapped: std::sync::Mutex<HashSet<u8>>,
    recalled: std::sync::Mutex<HashSet<u8>>,
    /// Vehicles the operator asked to land where they are (then they wait like a swap).
    land_here: std::sync::Mutex<HashSet<u8>>,
    fleet: FleetHandle,
    auto_resume: bool,
    interactive: bool,
    patience: Patience,
    tolerance_m: f64,
    max_failures: u32,
    max_retakes: u32,
    limits: CaptureLimits,
    /// Where a moving region is (static: the grid itself).
    roi: RoiClock,
    /// What each pilot is doing now, for the mission clock's samples (absent: working).
    doing: std::sync::Mutex<HashMap<u8, Activity>>,
    /// The cameras' on-board classification: the definition accepted, the audits.
    onboard: Onboard,
}

/// The region's frame against the fleet clock: a moving region
/// ([`MappingParams::motion`](fleetmap_core::explore::mapping::MappingParams::motion)) has moved
/// `v · s` since its epoch, where `s` is the region's time. The shell reads the fleet clock
/// once, when the run starts: `s = since_epoch_s + (t − at)` for fleet-clock time `t`
/// (`MonotonicClock::secs_since_unix_ms`: on a fleet following the demo's simulator the
/// region's time is the simulated time, however fast the simulator runs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RoiClock {
    motion: RoiMotion,
    /// Fleet-clock time of the reading.
    at: Time,
    /// The region's time then, seconds since its epoch.
    since_epoch_s: f64,
}

impl RoiClock {
    /// The clock of `motion` read at fleet time `at`, when `since_epoch_s` seconds of the
    /// fleet clock had passed since its epoch (an epoch in the future counts as now).
    pub(crate) fn new(motion: RoiMotion, at: Time, since_epoch_s: f64) -> RoiClock {
        RoiClock {
            motion,
            at,
            since_epoch_s: since_epoch_s.max(0.0),
        }
    }

    /// A region that does not move.
    pub(crate) fn fixed() -> RoiClock {
        RoiClock {
            motion: RoiMotion::STATIC,
            at: Time::ZERO,
            since_epoch_s: 0.0,
        }
    }

    pub(crate) fn is_static(&self) -> bool {
        self.motion.speed() == 0.0
    }

    /// The region's time at fleet time `t`.
    pub(crate) fn roi_time(&self, t: Time) -> Time {
        let s = self.since_epoch_s + t.as_secs_f64() - self.at.as_secs_f64();
        Time::from_secs_f64(s.max(0.0))
    }

    /// Grid metres (east, north) on the ground at fleet time `t` → the region's frame.
    pub(crate) fn in_region(&self, east: f64, north: f64, t: Time) -> (f64, f64) {
        self.motion.ground_to_roi(east, north, self.roi_time(t))
    }

    /// Where the centre of region cell `cell` is on the ground at fleet time `t`, grid metres.
    pub(crate) fn cell_centre(&self, cell: Cell, t: Time, cell_m: f64) -> (f64, f64) {
        self.motion.cell_centre(cell, self.roi_time(t), cell_m)
    }

    /// Where a vehicle at grid metres (`east`, `north`) at fleet time `t`, flying straight at
    /// `speed` m/s, meets the centre of region cell `cell` (the runway paper's visit of a
    /// translating ROI: [`RoiMotion::intercept`]), moved on by the region's drift over
    /// `lead_s` more seconds; grid metres.
    pub(crate) fn intercept(
        &self,
        (east, north): (f64, f64),
        t: Time,
        cell: Cell,
        cell_m: f64,
        speed: f64,
        lead_s: f64,
    ) -> Result<(f64, f64), fleetmap_core::explore::ExploreError> {
        let (_, (e, n)) =
            self.motion
                .intercept(east, north, self.roi_time(t), cell, cell_m, speed)?;
        Ok((
            e + self.motion.velocity_east * lead_s,
            n + self.motion.velocity_north * lead_s,
        ))
    }
}

impl Shared {
    fn say(&self, event: Progress) {
        self.run.say(event);
    }

    fn now(&self) -> Time {
        self.run.now()
    }

    /// The fleet-clock time at which a frame its link received at `received` (the runtime's
    /// clock) arrived: now, less the time since on the runtime's clock, scaled like the fleet
    /// clock. A task that runs late on a busy machine still dates what it reads by its
    /// arrival; on a paused clock (virtual time) the lateness is virtual, so the date is the
    /// same on every run.
    fn received_at(&self, received: tokio::time::Instant) -> Time {
        let late = received.elapsed();
        let speedup = self.fleet.clock().speedup();
        self.now() - Duration::try_from_secs_f64(late.as_secs_f64() * speedup).unwrap_or_default()
    }

    /// Mutate the state, save it, then journal `event` and after it the mission clock's
    /// milestones reached since the last step; notify everyone ([`RunCore::commit`] with the
    /// runway's types).
    async fn commit<T>(
        &self,
        f: impl FnOnce(&mut MappingState) -> Result<(T, Option<MappingEvent>), MappingError>,
    ) -> RunnerResult<T> {
        self.run
            .commit(|s| {
                f(s).map(|(out, ev)| {
                    let mut events = Vec::from_iter(ev);
                    events.extend(milestone_events(s));
                    (out, events)
                })
            })
            .await
    }

    /// The next directive of `sysid`; saved (and the others woken) only when deciding it
    /// changed the state or a milestone waits for the journal.
    async fn decide(&self, sysid: u8) -> RunnerResult<Directive> {
        self.run
            .update(|s| {
                s.directive_changed(sysid)
                    .map(|(d, changed)| (d, milestone_events(s), changed))
            })
            .await
    }

    /// What the pilot of `sysid` is doing now (the mission clock's next samples).
    fn doing(&self, sysid: u8, activity: Activity) {
        if let Ok(mut m) = self.doing.lock() {
            m.insert(sysid, activity);
        }
    }

    /// What the pilot of `sysid` is doing, as last told.
    fn activity(&self, sysid: u8) -> Activity {
        self.doing
            .lock()
            .ok()
            .and_then(|m| m.get(&sysid).copied())
            .unwrap_or(Activity::Working)
    }

    async fn read<T>(&self, f: impl FnOnce(&MappingState) -> T) -> T {
        self.run.read(f).await
    }

    /// What judging a picture of `sysid` needs from the state: the classifier's and the
    /// camera's parameters, the altitude it flies at (the run's base altitude if it has none)
    /// and the grid.
    async fn picture_setting(&self, sysid: u8) -> (RunwayParams, CameraModel, f64, Grid) {
        self.read(|s| {
            (
                s.params.runway,
                s.params.camera,
                s.altitude_of(sysid).unwrap_or(s.params.base_altitude_m),
                s.grid.clone(),
            )
        })
        .await
    }
}

/// The journal records of the milestones `state` reached since they were last taken.
fn milestone_events(state: &mut MappingState) -> Vec<MappingEvent> {
    state
        .take_milestones()
        .into_iter()
        .map(|m| MappingEvent::Milestone {
            what: m.what,
            mission_s: m.mission_s,
        })
        .collect()
}

/// Where and how a picture was taken, as far as the GCS knows.
#[derive(Clone, Debug)]
struct ShotPose {
    /// Latitude, degrees.
    lat: f64,
    /// Longitude, degrees.
    lon: f64,
    /// Altitude above home, metres (`None`: unknown).
    alt_m: Option<f64>,
    /// Heading of the image's top, degrees (the camera's, else the vehicle's, else 0).
    heading_deg: f64,
    /// The heading the camera itself reported, degrees.
    camera_heading_deg: Option<f64>,
    /// Attitude at the shutter, body → NED, its yaw the picture's heading (`None`: unknown).
    attitude: Option<UnitQuaternion<f64>>,
    /// The position came from the camera (not from the telemetry).
    from_camera: bool,
}

/// What became of a cell-centre picture that does not count.
enum PictureFailure {
    /// It never arrived.
    Lost(String),
    /// It arrived but could not be decoded or classified.
    Unreadable(String),
    /// It was not taken where it would be credited.
    Rejected(String),
}

struct Pilot {
    sysid: u8,
    shared: Arc<Shared>,
    images: broadcast::Receiver<Arc<ReceivedImage>>,
    capture_seq: u32,
    /// The image index of this vehicle's last picture that arrived (what its camera is asked
    /// for after when a capture goes unheard: [`flight::capture`]).
    last_image: Option<i32>,
    /// Whether its last picture came announced with its index and measured on board: a
    /// visit may then take its pictures several at a time ([`visit_captures`]).
    in_flight_ok: bool,
    /// The round trips of its camera's link (the timeout of a visit's captures).
    round_trip: fleetmap_core::proto::captures::RoundTrip,
    held: bool,
    /// No sweep entered yet by this process (a restart may have missed images).
    first_sweep: bool,
    /// Sweep pictures rejected in a row.
    sweep_rejects: u32,
    /// Where the vehicle's home was last known, grid metres (east, north): the reach rule's
    /// home while the autopilot reports none.
    home_xy: Option<(f64, f64)>,
    /// Groundings in a row without a step flown in between, and when the last one was
    /// (runtime clock): the back-off of a grounded drone's retries ([`Pilot::ground`]).
    grounded: (u32, Option<tokio::time::Instant>),
    /// Its camera's silences ([`camera`]).
    camera: camera::CameraWatch,
}

enum PilotEnd {
    Done,
    /// On the ground until a person does the task.
    WaitingForOperator(crate::app::kind::OperatorTask),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_region_clock_follows_the_fleet_clock_from_its_epoch() {
        // Moving east at 0.3 m/s; the epoch 20 s of fleet time before the reading at fleet
        // time 5 s: 20 s of region time, 6 m.
        let m = RoiMotion::new(0.3, 0.0, Time::ZERO);
        let roi = RoiClock::new(m, Time::from_secs(5), 20.0);
        assert!(!roi.is_static() && RoiClock::fixed().is_static());
        assert_eq!(roi.roi_time(Time::from_secs(5)), Time::from_secs(20));
        assert_eq!(roi.roi_time(Time::from_secs(15)), Time::from_secs(30));
        let (e, n) = roi.in_region(10.0, 4.0, Time::from_secs(5));
        assert!((e - 4.0).abs() < 1e-9 && (n - 4.0).abs() < 1e-9, "{e} {n}");
        // The ground centre of a region cell, taken back to the region, is that cell's centre.
        let cell = Cell::new(2, -1);
        let (ce, cn) = roi.cell_centre(cell, Time::from_secs(8), 4.0);
        assert!((ce - (-4.0 + 0.3 * 23.0)).abs() < 1e-9 && (cn - 8.0).abs() < 1e-9);
        let (re, rn) = roi.in_region(ce, cn, Time::from_secs(8));
        assert!((re + 4.0).abs() < 1e-9 && (rn - 8.0).abs() < 1e-9);
        // The intercept is where the cell is when a 2 m/s flight from the origin gets there,
        // then the drift over the lead.
        let (ie, in_) = roi
            .intercept((0.0, 0.0), Time::from_secs(5), cell, 4.0, 2.0, 0.5)
            .unwrap();
        let (me, mn) = (ie - 0.3 * 0.5, in_);
        let tau = me.hypot(mn) / 2.0;
        let (we, wn) = roi.cell_centre(cell, Time::from_secs_f64(5.0 + tau), 4.0);
        assert!((me - we).abs() < 1e-6 && (mn - wn).abs() < 1e-6);
        // A static region is the grid.
        let fixed = RoiClock::fixed();
        assert_eq!(fixed.in_region(3.0, -2.0, Time::from_secs(99)), (3.0, -2.0));
        // A reading before the epoch (a wall clock set back) counts from the epoch.
        let early = RoiClock::new(m, Time::ZERO, -4.0);
        assert_eq!(early.roi_time(Time::ZERO), Time::ZERO);
    }
}
