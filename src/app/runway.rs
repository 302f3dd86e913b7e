//! The runway-mapping run (runway paper §7) on real or simulated vehicles: the async shell
//! around [`MappingState`].
//!
//! One **pilot** task per drone asks the state what to do ([`MappingState::directive`]),
//! does it through the fleet ([`super::flight`]) and reports back; every report is saved
//! before the pilot goes on (`state.json` replaced atomically, then one journal record in
//! `events.jsonl`), so a GCS killed at any moment resumes from the last acknowledged step
//! (`fleetmap resume RUN_DIR`) with every counted image kept. The vehicles need nothing
//! from us to stay safe meanwhile: they hold position in GUIDED / Hold, or carry on with the
//! sweep mission, and their own failsafes bring them home.
//!
//! * **Sweep**: the robot's strip ([`crate::explore::lawnmower`]) is uploaded, verified by
//!   download, and flown in AUTO with a capture at every waypoint. Each image is classified
//!   (cell = the one under the camera); the first positive region stops every sweep (the
//!   robots hold) and the robot that saw it **confirms** the cell with five images at its
//!   centre. Positive: the DFS starts there; negative: the sweeps go on.
//! * **DFS**: Algorithm 1 ([`crate::explore::Explorer`]): go to the next cell centre
//!   (DO_REPOSITION at the robot's altitude and the mission speed), wait until there and
//!   steady, take five images, count their votes, give the explorer the neighbours' labels.
//! * **Image sanity** ([`crate::vision::sanity`]): a picture counts for a cell only when it
//!   was taken there — its position (the camera's CAMERA_IMAGE_CAPTURED / JPEG metadata, else
//!   the telemetry at the shutter) within [`RunOptions::capture_limits`] of the cell centre
//!   (default: the arrival tolerance + 0.5 m), its altitude within 1.5 m of the planned one,
//!   the camera within 10° of level and of the vehicle's heading. Otherwise it is dropped
//!   (journalled as [`MappingEvent::ImageRejected`]) and taken again; a picture that never
//!   arrives or cannot be read is retried the same way. A sweep picture must have been taken
//!   where the vehicle is (within one cell more than the cell limit), at the planned altitude
//!   and within [`crate::vision::sanity::SWEEP_MAX_TILT_DEG`] (20°: sweep pictures are taken
//!   while the copter brakes at a waypoint). After [`RunOptions::max_retakes`] retakes in
//!   one visit (or that many rejected sweep pictures in a row) the camera is declared faulty
//!   ([`MappingEvent::CameraFault`], a warning): nothing more of it is credited, the vehicle
//!   leaves the tree (its vertex is kept, as for a battery swap), returns home, lands and
//!   **waits for the operator** — never resuming by itself, since a fresh battery does not
//!   repair a camera — who fixes the camera and resumes (`fleetmap resume`, or `b` in the UI).
//! * **Where the camera looked**: when the picture's attitude is known (CAMERA_IMAGE_CAPTURED
//!   `q`), the 3 × 3 cells are cut from it as a north-up orthophoto around the cell centre
//!   ([`crate::vision::geometry::orthophoto`]: pinhole camera rotated by the attitude,
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
//!   outputs are written by [`crate::app::report`].

use crate::app::flight::{self, FlightError, Patience};
use crate::app::images::{ImageHub, ReceivedImage};
use crate::explore::dfs::Action;
use crate::explore::mapping::{Directive, MappingError, MappingState, Phase, RobotStatus};
use crate::fleet::{FleetHandle, GeoPoint, VehicleSnapshot};
use crate::geo::{Cell, LatLon, local};
use crate::mission::MissionType;
use crate::store::RunDir;
use crate::time::Time;
use crate::vision::camera::CameraModel;
use crate::vision::geometry::{self, OrthoRequest};
use crate::vision::load::{LoadLimits, load_image_bytes};
use crate::vision::runway::{Classification, RunwayParams, classify};
use crate::vision::sanity::{CaptureClaim, CaptureLimits, SWEEP_MAX_TILT_DEG, check_capture};
use crate::vision::votes::{Detection, GeoPosition};
use anyhow::Context as _;
use image::RgbImage;
use mavlink::dialects::ardupilotmega::MavMessage;
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{Mutex, broadcast, mpsc, watch};

/// The run kind in `run.json`.
pub const KIND: &str = "runway-mapping";

/// Seconds of wall-clock time (scaled by the clock's speed-up) without any image data from a
/// sweeping vehicle after which the pictures its camera announced and did not deliver count
/// as missing. The receiver asks for a picture missing packets five times over 14 s
/// (`imagery::transfer::ReceiverConfig`); 20 s covers that with room to spare.
const SWEEP_IMAGE_STALL_S: f64 = 20.0;

/// How many announced sweep pictures' reference positions a pilot keeps (a sweep's worth).
const ANNOUNCED_KEPT: usize = 512;

/// A journal record of the run (`events.jsonl`), one per acknowledged step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum MappingEvent {
    /// The runner started (or resumed) with these drones.
    Started {
        /// Drones.
        robots: Vec<u8>,
        /// Whether this continues an earlier start.
        resumed: bool,
    },
    /// A sweep image was classified.
    SweepImage {
        /// Vehicle.
        sysid: u8,
        /// Image name.
        image_id: String,
        /// Cell under the camera.
        cell: Cell,
        /// Labels (centre, north, west, south, east).
        labels: [bool; 5],
    },
    /// A sweep image showed the region: confirmation of `cell` starts.
    Candidate {
        /// Vehicle.
        sysid: u8,
        /// The cell to confirm.
        cell: Cell,
    },
    /// A cell-centre image was classified and its votes counted.
    Image {
        /// Vehicle.
        sysid: u8,
        /// Image name.
        image_id: String,
        /// The cell it was taken over.
        cell: Cell,
        /// Labels (centre, north, west, south, east).
        labels: [bool; 5],
        /// Black fractions (centre, top, left, bottom, right; image coordinates).
        fractions: [f64; 5],
        /// Cells whose state changed.
        changed: Vec<(Cell, String)>,
    },
    /// The confirmation ended; `root` is where the DFS starts (`None`: back to sweeping).
    Confirmed {
        /// Vehicle.
        sysid: u8,
        /// The candidate.
        cell: Cell,
        /// The DFS root.
        root: Option<Cell>,
    },
    /// A robot reached a vertex.
    Arrived {
        /// Vehicle.
        sysid: u8,
        /// The vertex.
        cell: Cell,
    },
    /// A vertex was imaged; `added` are its new children.
    Observed {
        /// Vehicle.
        sysid: u8,
        /// The vertex.
        cell: Cell,
        /// Cells added to the tree.
        added: Vec<Cell>,
    },
    /// A robot's sweep mission ended.
    SweepComplete {
        /// Vehicle.
        sysid: u8,
    },
    /// A robot's battery is low: it goes home for a swap.
    BatteryLow {
        /// Vehicle.
        sysid: u8,
        /// Charge, percent.
        pct: f64,
        /// Charge the flight home needs, percent.
        needed_pct: f64,
    },
    /// A robot landed for a battery swap.
    LandedForSwap {
        /// Vehicle.
        sysid: u8,
    },
    /// A robot has a fresh battery.
    Swapped {
        /// Vehicle.
        sysid: u8,
        /// How it was noticed: "auto" or "operator".
        by: String,
    },
    /// A robot flies home at the end.
    GoingHome {
        /// Vehicle.
        sysid: u8,
    },
    /// A robot landed at the end.
    Landed {
        /// Vehicle.
        sysid: u8,
    },
    /// A picture was dropped because it was not taken where it would be credited
    /// ([`crate::vision::sanity::check_capture`]: position, altitude, tilt or heading out of
    /// limits); a cell-centre picture is taken again.
    ImageRejected {
        /// Vehicle.
        sysid: u8,
        /// The cell it was taken for (`None`: a sweep picture, checked against the vehicle's
        /// position).
        cell: Option<Cell>,
        /// Why, with the figures.
        reason: String,
        /// Failed pictures so far in this visit (a cell), or rejected in a row (the sweep).
        retakes: u32,
    },
    /// The camera failed too often ([`RunOptions::max_retakes`]): nothing more of it is
    /// credited; the vehicle leaves the tree, lands at home and waits for the operator.
    CameraFault {
        /// Vehicle.
        sysid: u8,
        /// The cell being imaged (`None`: in the sweep).
        cell: Option<Cell>,
        /// The last failure.
        reason: String,
    },
    /// An image was lost or unreadable.
    ImageFailed {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// A step failed and will be retried.
    StepFailed {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// The run is over.
    Finished {
        /// Whether the region was found.
        found: bool,
    },
}

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

/// How a run ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The map is complete and every robot landed.
    Finished,
    /// Robots are on the ground waiting for the operator (battery swaps without
    /// `auto_resume`): run `fleetmap resume` after the swaps.
    WaitingForOperator {
        /// The vehicles waiting.
        sysids: Vec<u8>,
    },
}

/// Options of a run.
pub struct RunOptions {
    /// Resume by itself after a battery swap (the vehicle power-cycles and reports a full
    /// battery) instead of waiting for the operator.
    pub auto_resume: bool,
    /// Operator commands (the TUI); `None` in headless runs.
    pub operator: Option<mpsc::UnboundedReceiver<Operator>>,
    /// Progress lines for a headless run's stdout / the TUI's log.
    pub progress: Option<mpsc::UnboundedSender<String>>,
    /// The state after every step (the TUI's map and mission panes).
    pub view: Option<watch::Sender<Arc<MappingState>>>,
    /// Timeout scaling.
    pub patience: Patience,
    /// A vehicle is "there" within this horizontal distance of a cell centre, metres.
    pub tolerance_m: f64,
    /// Consecutive failed steps after which a pilot gives up (the run stops; resume later).
    pub max_failures: u32,
    /// Send MAV_CMD_USER_1 (the simulator's swap request) when a robot lands for a battery
    /// swap — the in-process demo's stand-in for the operator.
    pub sim_swap: bool,
    /// Failed pictures (dropped by the sanity check, lost, unreadable) retaken per cell
    /// visit, and rejected sweep pictures in a row, before the camera is declared faulty.
    /// 5 = as many as a visit's own images: a healthy camera fails a picture rarely (a late
    /// image, a gust), so more than half a visit's captures failing is no transient.
    pub max_retakes: u32,
    /// Limits of the image sanity check (`None`: [`CaptureLimits::runway`] of
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
            sim_swap: false,
            max_retakes: 5,
            capture_limits: None,
        }
    }
}

struct Core {
    state: MappingState,
    run: RunDir,
}

struct Shared {
    core: Mutex<Core>,
    changed: watch::Sender<u64>,
    paused: watch::Sender<bool>,
    swapped: std::sync::Mutex<HashSet<u8>>,
    recalled: std::sync::Mutex<HashSet<u8>>,
    /// Vehicles the operator asked to land where they are (then they wait like a swap).
    land_here: std::sync::Mutex<HashSet<u8>>,
    progress: Option<mpsc::UnboundedSender<String>>,
    view: Option<watch::Sender<Arc<MappingState>>>,
    fleet: FleetHandle,
    auto_resume: bool,
    interactive: bool,
    patience: Patience,
    tolerance_m: f64,
    sim_swap: bool,
    max_failures: u32,
    max_retakes: u32,
    limits: CaptureLimits,
}

impl Shared {
    fn say(&self, line: String) {
        tracing::info!("{line}");
        if let Some(p) = &self.progress {
            let _ = p.send(line);
        }
    }

    fn now(&self) -> Time {
        self.fleet.clock().now()
    }

    /// Mutate the state, save it, then journal `event`; notify everyone.
    async fn commit<T>(
        &self,
        f: impl FnOnce(&mut MappingState) -> Result<(T, Option<MappingEvent>), MappingError>,
    ) -> anyhow::Result<T> {
        let mut core = self.core.lock().await;
        let (out, event) = f(&mut core.state)?;
        let Core { state, run } = &mut *core;
        run.save_state(state).context("saving the run state")?;
        if let Some(ev) = &event {
            run.append_event(ev).context("writing the run journal")?;
        }
        if let Some(v) = &self.view {
            let _ = v.send(Arc::new(core.state.clone()));
        }
        drop(core);
        self.changed.send_modify(|n| *n += 1);
        Ok(out)
    }

    /// The next directive of `sysid`; saved (and the others woken) only when deciding it
    /// changed the state.
    async fn decide(&self, sysid: u8) -> anyhow::Result<Directive> {
        let mut core = self.core.lock().await;
        let (d, changed) = core.state.directive_changed(sysid)?;
        if changed {
            let Core { state, run } = &mut *core;
            run.save_state(state).context("saving the run state")?;
            if let Some(v) = &self.view {
                let _ = v.send(Arc::new(core.state.clone()));
            }
            drop(core);
            self.changed.send_modify(|n| *n += 1);
        }
        Ok(d)
    }

    async fn read<T>(&self, f: impl FnOnce(&MappingState) -> T) -> T {
        f(&self.core.lock().await.state)
    }
}

fn labels5(c: &Classification) -> [bool; 5] {
    let l = c.labels;
    [l.center, l.north, l.west, l.south, l.east]
}

fn fractions5(c: &Classification) -> [f64; 5] {
    let f = c.fractions;
    [f.center, f.top, f.left, f.bottom, f.right]
}

/// The part of an image taken at `altitude_m` that covers the 3 × 3 cells around its centre
/// (the runway paper's sensing model assumes the footprint is exactly 3 × 3 cells, true at
/// 12 m for 4 m cells; a drone flying higher for separation sees more, so its image is
/// cropped to the same ground area). Lower than that the whole image is used.
pub fn crop_to_cells(
    img: RgbImage,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
) -> RgbImage {
    let (fw, fh) = camera.footprint(altitude_m);
    let want = 3.0 * cell_m;
    if !(fw.is_finite() && fh.is_finite()) || fw <= want * 1.001 || fh <= want * 1.001 {
        return img;
    }
    let (w, h) = img.dimensions();
    let cw = ((f64::from(w) * want / fw).round() as u32).clamp(3, w);
    let ch = ((f64::from(h) * want / fh).round() as u32).clamp(3, h);
    image::imageops::crop_imm(&img, (w - cw) / 2, (h - ch) / 2, cw, ch).to_image()
}

/// Decode and classify one received image (blocking work: call it on a blocking thread).
pub fn classify_received(
    bytes: &[u8],
    heading_deg: f64,
    params: &RunwayParams,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
) -> Result<Classification, String> {
    classify_cut(
        bytes,
        &Cut::Centre {
            heading_deg,
            altitude_m,
        },
        params,
        camera,
        cell_m,
    )
}

/// How the 3 × 3 cells are cut out of a picture before it is classified.
#[derive(Clone, Debug, PartialEq)]
pub enum Cut {
    /// The attitude is unknown: the centre crop of [`crop_to_cells`] at `altitude_m`, its
    /// regions turned by `heading_deg` (the image's top, degrees clockwise from north).
    Centre {
        /// Heading of the image's top, degrees.
        heading_deg: f64,
        /// Altitude the footprint is computed for, metres.
        altitude_m: f64,
    },
    /// The attitude is known: the north-up, grid-aligned orthophoto of
    /// [`geometry::orthophoto`] (whose regions need no turning).
    Ortho {
        /// Attitude at the shutter, body → NED.
        attitude: UnitQuaternion<f64>,
        /// Capture altitude above home (flat ground at home's elevation), metres.
        altitude_m: f64,
        /// Where the orthophoto is centred and how the grid is oriented.
        request: OrthoRequest,
    },
}

/// Decode a received image, cut it as `cut` says and classify it (blocking work).
pub fn classify_cut(
    bytes: &[u8],
    cut: &Cut,
    params: &RunwayParams,
    camera: &CameraModel,
    cell_m: f64,
) -> Result<Classification, String> {
    let img = load_image_bytes(bytes, &LoadLimits::default()).map_err(|e| e.to_string())?;
    match cut {
        Cut::Centre {
            heading_deg,
            altitude_m,
        } => {
            let img = crop_to_cells(img, camera, *altitude_m, cell_m);
            classify(&img, *heading_deg, params).map_err(|e| e.to_string())
        }
        Cut::Ortho {
            attitude,
            altitude_m,
            request,
        } => {
            let o = geometry::orthophoto(&img, camera, attitude, *altitude_m, request)
                .map_err(|e| e.to_string())?;
            classify(&o.image, 0.0, params).map_err(|e| e.to_string())
        }
    }
}

/// Run CPU-heavy work (decoding and classifying an image, a few milliseconds) off the
/// reactor: on a blocking thread in a multi-threaded runtime; inline in a current-thread one
/// (the virtual-clock tests, where a blocking thread would let virtual time run on while it
/// works).
pub async fn cpu<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> anyhow::Result<T> {
    match tokio::runtime::Handle::current().runtime_flavor() {
        tokio::runtime::RuntimeFlavor::CurrentThread => Ok(f()),
        _ => tokio::task::spawn_blocking(f)
            .await
            .context("classifier task"),
    }
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

/// Where a picture was taken: what the camera said, else the vehicle's telemetry `v` (at
/// the shutter when known).
fn shot_pose(img: &ReceivedImage, v: Option<&VehicleSnapshot>) -> Option<ShotPose> {
    let heading_now = v.and_then(|v| v.heading_deg).map(f64::from);
    if let Some(p) = &img.pose {
        let heading = p.heading_deg.or(heading_now).unwrap_or(0.0);
        let attitude =
            p.q.and_then(geometry::attitude_of_quaternion)
                .map(|a| geometry::with_yaw_deg(&a, heading));
        return Some(ShotPose {
            lat: p.lat,
            lon: p.lon,
            alt_m: Some(p.alt_rel_m),
            heading_deg: heading,
            camera_heading_deg: p.heading_deg,
            attitude,
            from_camera: true,
        });
    }
    let v = v?;
    let p = v.position?;
    Some(ShotPose {
        lat: p.lat,
        lon: p.lon,
        alt_m: v.alt_rel.map(f64::from),
        heading_deg: heading_now.unwrap_or(0.0),
        camera_heading_deg: None,
        attitude: None,
        from_camera: false,
    })
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
    held: bool,
    /// No sweep entered yet by this process (a restart may have missed images).
    first_sweep: bool,
    /// Sweep pictures rejected in a row.
    sweep_rejects: u32,
}

enum PilotEnd {
    Done,
    WaitingForOperator,
}

impl Pilot {
    fn fleet(&self) -> &FleetHandle {
        &self.shared.fleet
    }

    fn vehicle(&self) -> Option<VehicleSnapshot> {
        self.fleet().vehicle(self.sysid)
    }

    /// Wait until the state changes, or `timeout`.
    async fn wait_change(&self, timeout: Duration) {
        let mut rx = self.shared.changed.subscribe();
        rx.borrow_and_update();
        let _ = tokio::time::timeout(timeout, rx.changed()).await;
    }

    async fn wait_unpaused(&self) {
        let mut rx = self.shared.paused.subscribe();
        let mut told = false;
        while *rx.borrow_and_update() {
            if !told && !self.held {
                let _ = flight::hold_here(self.fleet(), self.sysid).await;
                told = true;
            }
            if rx.changed().await.is_err() {
                return;
            }
        }
    }

    async fn run(mut self) -> anyhow::Result<PilotEnd> {
        let mut failures = 0u32;
        loop {
            self.wait_unpaused().await;
            match self.step().await {
                Ok(Some(end)) => return Ok(end),
                Ok(None) => failures = 0,
                Err(e) => {
                    failures += 1;
                    let reason = format!("{e:#}");
                    self.shared
                        .say(format!("vehicle {}: {reason} (retrying)", self.sysid));
                    let sysid = self.sysid;
                    let max = self.shared.patience.secs(2.0);
                    let _ = self
                        .shared
                        .commit(|_| Ok(((), Some(MappingEvent::StepFailed { sysid, reason }))))
                        .await;
                    if failures >= self.shared.max_failures.max(1) {
                        return Err(e.context(format!(
                            "vehicle {sysid}: giving up after {failures} failed steps"
                        )));
                    }
                    tokio::time::sleep(max).await;
                }
            }
        }
    }

    /// One directive. `Some` ends the pilot.
    async fn step(&mut self) -> anyhow::Result<Option<PilotEnd>> {
        let sysid = self.sysid;
        // A recall from the operator, or a low battery, comes first.
        if self.check_battery().await? {
            return Ok(None);
        }
        let d = self.shared.decide(sysid).await?;
        match d {
            Directive::Sweep => {
                self.held = false;
                self.sweep().await?;
            }
            Directive::Hold => {
                if !self.held
                    && let Some(v) = self.vehicle()
                    && flight::airborne(&v)
                {
                    flight::hold_here(self.fleet(), sysid).await?;
                    self.held = true;
                }
                self.wait_change(Duration::from_millis(500)).await;
            }
            Directive::Confirm(cell) => {
                self.held = false;
                self.fly_to_cell(cell).await?;
                if self.take_images(cell).await? {
                    let now = self.shared.now();
                    let root = self
                        .shared
                        .commit(|s| {
                            let root = s.on_confirmed(sysid, cell, now)?;
                            Ok((root, Some(MappingEvent::Confirmed { sysid, cell, root })))
                        })
                        .await?;
                    match root {
                        Some(r) => self.shared.say(format!(
                            "vehicle {sysid}: cell {cell} confirmed: the recursive DFS starts at {r}"
                        )),
                        None => self.shared.say(format!(
                            "vehicle {sysid}: cell {cell} is not runway after all: sweeping on"
                        )),
                    }
                }
            }
            Directive::Dfs(Action::MoveTo(cell) | Action::Rejoin(cell)) => {
                self.held = false;
                self.fly_to_cell(cell).await?;
                let now = self.shared.now();
                self.shared
                    .commit(|s| {
                        s.on_arrived(sysid, cell, now)?;
                        Ok(((), Some(MappingEvent::Arrived { sysid, cell })))
                    })
                    .await?;
            }
            Directive::Dfs(Action::Observe) => {
                let cell = self
                    .shared
                    .read(|s| {
                        s.explorer
                            .as_ref()
                            .map(|e| e.robot_cell(crate::explore::RobotId(sysid)))
                    })
                    .await
                    .context("observing without an explorer")??;
                if self.take_images(cell).await? {
                    let now = self.shared.now();
                    let added = self
                        .shared
                        .commit(|s| {
                            let added = s.on_observed(sysid, cell, now)?;
                            let ev = MappingEvent::Observed {
                                sysid,
                                cell,
                                added: added.clone(),
                            };
                            Ok((added, Some(ev)))
                        })
                        .await?;
                    let (explored, vertices) = self
                        .shared
                        .read(|s| {
                            let e = s.explorer.as_ref();
                            (
                                e.map(|e| {
                                    e.vertex_states()
                                        .iter()
                                        .filter(|(_, v)| {
                                            *v == crate::explore::VertexState::Explored
                                        })
                                        .count()
                                })
                                .unwrap_or(0),
                                e.map(|e| e.tree().real_count()).unwrap_or(0),
                            )
                        })
                        .await;
                    self.shared.say(format!(
                        "vehicle {sysid}: vertex {cell} imaged, {} new ({} of {} vertices explored)",
                        added.len(),
                        explored,
                        vertices
                    ));
                }
            }
            Directive::Dfs(Action::Wait) => {
                if !self.held
                    && let Some(v) = self.vehicle()
                    && flight::airborne(&v)
                {
                    flight::hold_here(self.fleet(), sysid).await?;
                    self.held = true;
                }
                self.wait_change(Duration::from_millis(500)).await;
            }
            Directive::Dfs(Action::ReturnHome) | Directive::Swap => {
                self.held = false;
                if let Some(end) = self.swap().await? {
                    return Ok(Some(end));
                }
            }
            Directive::Dfs(Action::Done) | Directive::GoHome => {
                self.held = false;
                self.go_home().await?;
            }
            Directive::Stop => return Ok(Some(PilotEnd::Done)),
        }
        Ok(None)
    }

    /// Low battery or an operator recall: leave the tree and fly home. Returns whether it
    /// did.
    async fn check_battery(&mut self) -> anyhow::Result<bool> {
        let sysid = self.sysid;
        let recalled = self
            .shared
            .recalled
            .lock()
            .map(|mut r| r.remove(&sysid))
            .unwrap_or(false);
        let Some(v) = self.vehicle() else {
            return Ok(false);
        };
        let status = self
            .shared
            .read(|s| s.robot(sysid).map(|r| r.status))
            .await?;
        if matches!(
            status,
            RobotStatus::ReturningForSwap
                | RobotStatus::AwaitingSwap
                | RobotStatus::ReturningHome
                | RobotStatus::Landed
        ) {
            return Ok(false);
        }
        if self
            .shared
            .read(|s| matches!(s.phase, Phase::Finished { .. }))
            .await
        {
            return Ok(false);
        }
        let alt = f64::from(v.alt_rel.unwrap_or(0.0));
        let needed = self
            .shared
            .read(|s| s.battery_needed_pct(flight::distance_home(&v), alt))
            .await;
        let pct = v.battery_pct.map(f64::from).filter(|p| *p >= 0.0);
        // The autopilot's own failsafe took over (RTL / LAND we did not ask for).
        let failsafe = flight::airborne(&v)
            && matches!(v.mode.as_str(), "RTL" | "LAND" | "SMART_RTL")
            && status != RobotStatus::Idle;
        let low = pct.is_some_and(|p| p <= needed) && flight::airborne(&v);
        if !(recalled || low || failsafe) {
            return Ok(false);
        }
        let now = self.shared.now();
        let pct_v = pct.unwrap_or(-1.0);
        self.shared
            .commit(|s| {
                s.abandon_confirmation(sysid);
                s.on_battery_low(sysid, now)?;
                Ok((
                    (),
                    Some(MappingEvent::BatteryLow {
                        sysid,
                        pct: pct_v,
                        needed_pct: needed,
                    }),
                ))
            })
            .await?;
        let why = if recalled {
            "recalled by the operator".to_string()
        } else if failsafe {
            format!("the autopilot's failsafe took over ({})", v.mode)
        } else {
            format!("battery {pct_v:.0} % (home needs {needed:.0} %)")
        };
        self.shared.say(format!(
            "vehicle {sysid}: {why}: returning home for a battery swap"
        ));
        Ok(true)
    }

    async fn fly_to_cell(&mut self, cell: Cell) -> anyhow::Result<()> {
        let sysid = self.sysid;
        let (centre, alt, speed) = self
            .shared
            .read(|s| {
                (
                    s.grid.cell_center(cell),
                    s.altitude_of(sysid),
                    s.params.speed_m_s,
                )
            })
            .await;
        let alt = alt? as f32;
        flight::ensure_airborne(self.fleet(), sysid, alt, self.shared.patience).await?;
        let target = (centre.lat, centre.lon, alt);
        flight::fly_to(
            self.fleet(),
            sysid,
            target,
            speed as f32,
            self.shared.tolerance_m,
            self.shared.patience,
        )
        .await?;
        // The images are read as the cell and its four neighbours: camera aligned with the
        // grid (the classifier then turns the regions by whole quarter turns).
        flight::face_grid(self.fleet(), sysid, target, 3.0, self.shared.patience).await?;
        Ok(())
    }

    /// Take the images still missing for this visit of `cell`, counting each one's votes.
    /// A picture counts only when it was taken over the cell ([`check_capture`]); one that
    /// does not, never arrives or cannot be read is taken again, up to
    /// [`RunOptions::max_retakes`] times in this visit, after which the camera is declared
    /// faulty ([`Pilot::camera_fault`]). Returns false when the visit was cut short (battery,
    /// camera fault).
    async fn take_images(&mut self, cell: Cell) -> anyhow::Result<bool> {
        let sysid = self.sysid;
        let mut retakes = 0u32;
        loop {
            let missing = self.shared.read(|s| s.images_missing(sysid, cell)).await;
            if missing == 0 {
                return Ok(true);
            }
            if let Some(v) = self.vehicle() {
                let alt = f64::from(v.alt_rel.unwrap_or(0.0));
                let needed = self
                    .shared
                    .read(|s| s.battery_needed_pct(flight::distance_home(&v), alt))
                    .await;
                if v.battery_pct.is_some_and(|p| f64::from(p) <= needed) {
                    return Ok(false);
                }
            }
            self.capture_seq += 1;
            let fleet = self.shared.fleet.clone();
            let shot = match flight::capture(
                &fleet,
                &mut self.images,
                sysid,
                self.capture_seq,
                self.shared.patience,
            )
            .await
            {
                Ok(shot) => shot,
                Err(FlightError::NoImage { seq, waited_s, .. }) => {
                    retakes += 1;
                    let reason = format!(
                        "cell {cell}: no image arrived within {waited_s:.0} s of capture {seq}"
                    );
                    if self
                        .picture_failed(cell, retakes, PictureFailure::Lost(reason))
                        .await?
                    {
                        return Ok(false);
                    }
                    continue;
                }
                Err(e) => return Err(e.into()),
            };
            let v_now = self.vehicle();
            let at_shutter = shot.at_trigger.as_ref().or(v_now.as_ref());
            let pose = shot_pose(&shot.image, at_shutter);
            let (params, camera, planned, grid) = self
                .shared
                .read(|s| {
                    (
                        s.params.runway,
                        s.params.camera,
                        s.altitude_of(sysid).unwrap_or(s.params.base_altitude_m),
                        s.grid.clone(),
                    )
                })
                .await;
            let cell_m = grid.cell_size();
            let centre = (f64::from(cell.col) * cell_m, f64::from(cell.row) * cell_m);
            let xy = pose.as_ref().and_then(|p| {
                grid.to_xy(LatLon {
                    lat: p.lat,
                    lon: p.lon,
                })
                .ok()
            });
            let verdict = match (&pose, xy) {
                (Some(p), Some((e, n))) => check_capture(
                    &CaptureClaim {
                        horizontal_offset_m: Some((centre.0 - e).hypot(centre.1 - n)),
                        altitude_m: p.alt_m,
                        attitude: p.attitude,
                        heading_deg: p.camera_heading_deg,
                        expected_heading_deg: at_shutter.and_then(|v| v.heading_deg).map(f64::from),
                    },
                    planned,
                    &self.shared.limits,
                )
                .map_err(|r| {
                    format!(
                        "cell {cell}: {} picture {r}",
                        if p.from_camera {
                            "the camera's"
                        } else {
                            "the telemetry's"
                        }
                    )
                }),
                (Some(p), None) => Err(format!(
                    "cell {cell}: the picture's position ({:.7}, {:.7}) is not on the grid",
                    p.lat, p.lon
                )),
                (None, _) => Err(format!(
                    "cell {cell}: neither the camera nor the telemetry says where the picture was taken"
                )),
            };
            if let Err(reason) = verdict {
                retakes += 1;
                if self
                    .picture_failed(cell, retakes, PictureFailure::Rejected(reason))
                    .await?
                {
                    return Ok(false);
                }
                continue;
            }
            // Checked above: a pose with a grid position.
            let (Some(pose), Some((e, n))) = (pose, xy) else {
                continue;
            };
            let cut = match pose.attitude {
                Some(attitude) => Cut::Ortho {
                    attitude,
                    altitude_m: pose.alt_m.unwrap_or(planned),
                    request: OrthoRequest {
                        cell_m,
                        centre_east_north_m: (centre.0 - e, centre.1 - n),
                        grid_north_deg: grid
                            .convergence_and_scale(LatLon {
                                lat: pose.lat,
                                lon: pose.lon,
                            })
                            .map(|(g, _)| g)
                            .unwrap_or(0.0),
                    },
                },
                None => Cut::Centre {
                    heading_deg: pose.heading_deg,
                    altitude_m: planned,
                },
            };
            let bytes = shot.image.bytes.clone();
            let result = cpu(move || classify_cut(&bytes, &cut, &params, &camera, cell_m)).await?;
            let c = match result {
                Ok(c) => c,
                Err(reason) => {
                    retakes += 1;
                    let reason = format!("cell {cell}: {reason}");
                    if self
                        .picture_failed(cell, retakes, PictureFailure::Unreadable(reason))
                        .await?
                    {
                        return Ok(false);
                    }
                    continue;
                }
            };
            let now = self.shared.now();
            let (lat, lon, heading) = (pose.lat, pose.lon, pose.heading_deg);
            let alt_m = pose.alt_m.unwrap_or(planned);
            self.shared
                .commit(|s| {
                    let image_id = s.next_image_id();
                    let det = Detection {
                        image_id: image_id.clone(),
                        vehicle: sysid,
                        time: now,
                        cell,
                        position: Some(GeoPosition {
                            lat_deg: lat,
                            lon_deg: lon,
                            alt_m,
                        }),
                        heading_deg: heading,
                        fractions: c.fractions,
                        labels: c.labels,
                    };
                    let changed = s
                        .on_cell_image(det)?
                        .into_iter()
                        .map(|u| (u.cell, format!("{:?}", u.to).to_lowercase()))
                        .collect();
                    let ev = MappingEvent::Image {
                        sysid,
                        image_id,
                        cell,
                        labels: labels5(&c),
                        fractions: fractions5(&c),
                        changed,
                    };
                    Ok(((), Some(ev)))
                })
                .await?;
        }
    }

    /// A picture of this visit of `cell` did not count (the `retakes`-th): journal why, and
    /// declare the camera faulty when that is more than [`RunOptions::max_retakes`]. Returns
    /// whether it did (the visit is over).
    async fn picture_failed(
        &mut self,
        cell: Cell,
        retakes: u32,
        failure: PictureFailure,
    ) -> anyhow::Result<bool> {
        let sysid = self.sysid;
        let max = self.shared.max_retakes;
        let (reason, ev) = match failure {
            PictureFailure::Lost(r) | PictureFailure::Unreadable(r) => (
                r.clone(),
                MappingEvent::ImageFailed {
                    sysid,
                    reason: format!("{r} (failed picture {retakes}, at most {max} retaken)"),
                },
            ),
            PictureFailure::Rejected(r) => (
                r.clone(),
                MappingEvent::ImageRejected {
                    sysid,
                    cell: Some(cell),
                    reason: r,
                    retakes,
                },
            ),
        };
        let lost = matches!(ev, MappingEvent::ImageFailed { .. });
        tracing::info!("vehicle {sysid}: picture dropped: {reason}");
        self.shared
            .commit(|s| {
                if lost {
                    s.image_failures += 1;
                }
                Ok(((), Some(ev)))
            })
            .await?;
        if retakes > max {
            self.camera_fault(
                Some(cell),
                format!("{retakes} pictures in one visit did not count; the last: {reason}"),
            )
            .await?;
            return Ok(true);
        }
        self.shared.say(format!(
            "vehicle {sysid}: picture dropped ({reason}); taking it again ({retakes} of {max})"
        ));
        Ok(false)
    }

    /// Why this vehicle's camera is out of the run, if it is (saved in the run state, so a
    /// resumed run keeps it on the ground too).
    async fn camera_fault_now(&self) -> Option<String> {
        let sysid = self.sysid;
        self.shared
            .read(|s| s.robot(sysid).ok().and_then(|r| r.camera_fault.clone()))
            .await
    }

    /// The camera cannot be trusted (`reason`): warn, journal [`MappingEvent::CameraFault`]
    /// and take the vehicle out of the run as for a battery swap (its vertex is kept, a
    /// confirmation it was making is given up), so that [`Pilot::swap`] brings it home and
    /// waits for the operator. Nothing of this camera is credited after this.
    async fn camera_fault(&mut self, cell: Option<Cell>, reason: String) -> anyhow::Result<()> {
        let sysid = self.sysid;
        let now = self.shared.now();
        let line = format!(
            "vehicle {sysid}: CAMERA FAULT: {reason}. No more of its pictures are counted; it \
             returns home, lands and waits for the operator (check where the camera gets its \
             position and attitude from, then `fleetmap resume` or `b`)"
        );
        tracing::warn!("{line}");
        self.shared.say(line);
        self.shared
            .commit(|s| {
                s.on_camera_fault(sysid, reason.clone(), now)?;
                Ok((
                    (),
                    Some(MappingEvent::CameraFault {
                        sysid,
                        cell,
                        reason,
                    }),
                ))
            })
            .await?;
        Ok(())
    }

    /// Fly (or keep flying) the sweep, classifying its images, until the phase changes, the
    /// sweep ends or the battery runs low.
    async fn sweep(&mut self) -> anyhow::Result<()> {
        let sysid = self.sysid;
        let fleet = self.fleet().clone();
        let (items, alt, speed, resume_item) = self
            .shared
            .read(|s| {
                let sw = s.sweep_of(sysid).ok().cloned();
                let r = s.robot(sysid).ok().cloned();
                (
                    sw.map(|w| w.items).unwrap_or_default(),
                    r.as_ref().map(|r| r.altitude_m).unwrap_or(12.0),
                    s.params.speed_m_s,
                    r.and_then(|r| r.sweep_item),
                )
            })
            .await;
        let v = self
            .vehicle()
            .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
        let mission_mode = v.flavour.mission_mode().ok();
        let in_mission = mission_mode.is_some_and(|m| v.flavour.is_mode(v.custom_mode, m));
        let holds_mission = v
            .mission_total
            .is_some_and(|t| usize::from(t) == items.len());
        if !(flight::airborne(&v) && holds_mission) {
            // Upload, verify by download, take off, start (or continue where it stopped).
            fleet
                .upload_mission(sysid, MissionType::Mission, items.clone())
                .await?;
            let (back, _) = fleet.download_mission(sysid, MissionType::Mission).await?;
            crate::proto::mission::compare_items(&items, &back, v.flavour.home_item()).map_err(
                |d| anyhow::anyhow!("vehicle {sysid}: the sweep read back differs: {d}"),
            )?;
            self.shared.say(format!(
                "vehicle {sysid}: sweep mission uploaded and verified ({} items)",
                items.len()
            ));
            flight::ensure_airborne(&fleet, sysid, alt as f32, self.shared.patience).await?;
            if let Some(item) = resume_item.filter(|&i| i > 0) {
                fleet.set_mission_current(sysid, item).await?;
                let m = mission_mode.context("no mission mode")?;
                fleet.set_mode(sysid, m.name).await?;
            } else {
                fleet.start_mission(sysid).await?;
            }
            let _ = flight::set_speed(&fleet, sysid, speed as f32).await;
            self.shared.say(format!("vehicle {sysid}: sweeping"));
        } else if self.first_sweep || !in_mission {
            // Back after a GCS restart (or a hold): the vehicle may have flown on while no one
            // classified its images, so go back to the last capture we may have missed — the
            // waypoint before the one it was heading for when we last saw it.
            if self.first_sweep
                && let Some(item) = resume_item
            {
                let back = items
                    .iter()
                    .enumerate()
                    .take(usize::from(item))
                    .rev()
                    .find(|(_, it)| it.command == crate::mission::item::cmd::NAV_WAYPOINT)
                    .map(|(j, _)| j as u16);
                if let Some(j) = back {
                    fleet.set_mission_current(sysid, j).await?;
                }
            }
            let m = mission_mode.context("no mission mode")?;
            fleet.set_mode(sysid, m.name).await?;
            let _ = flight::set_speed(&fleet, sysid, speed as f32).await;
        }
        self.first_sweep = false;
        let last_nav = items
            .iter()
            .rposition(|it| it.command == crate::mission::item::cmd::NAV_WAYPOINT)
            .unwrap_or(0) as u16;
        let mut snaps = fleet.watch();
        let mut changed = self.shared.changed.subscribe();
        changed.borrow_and_update();
        let mut tick = tokio::time::interval(Duration::from_millis(500));
        // Pictures the sweep's capture items should have produced and did not: an autopilot
        // that cannot take pictures (ArduPilot without a camera backend, CAM1_TYPE = 0) or a
        // camera that is not connected sends nothing at all — no rejected picture to count.
        let captures_before = |c: u16| {
            items
                .iter()
                .take(usize::from(c))
                .filter(|it| it.command == crate::mission::item::cmd::IMAGE_START_CAPTURE)
                .count()
        };
        let mut captures_at_start = None;
        // Pictures that arrived, and pictures the camera announced (CAMERA_IMAGE_CAPTURED): an
        // announced picture exists while its transmission is queued behind others (a slow
        // payload link: PX4 SITL's carries 4 kB/s), so it is missing only once no image data
        // at all has been heard from the vehicle for `SWEEP_IMAGE_STALL_S`.
        let mut arrived = 0usize;
        let mut announced = 0usize;
        let mut progress = self.shared.now();
        let stall = Duration::from_secs_f64(SWEEP_IMAGE_STALL_S * fleet.clock().speedup());
        let mut frames = fleet.subscribe();
        // Where the vehicle was when each picture was announced, by (time_boot_ms,
        // image_index): the reference for a picture that arrives later, queued on a slow link.
        let mut where_announced = std::collections::VecDeque::new();
        // The vehicle has flown the whole sweep (its pictures may still be in transfer).
        let mut flown = false;
        loop {
            tokio::select! {
                f = frames.recv() => {
                    match f {
                        Ok(inc) if inc.frame.sysid() == sysid => match &inc.frame.message {
                            Ok(MavMessage::CAMERA_IMAGE_CAPTURED(c)) => {
                                if announced <= arrived {
                                    progress = self.shared.now();
                                }
                                announced += 1;
                                if let Some(p) = self.vehicle().and_then(|v| v.position) {
                                    if where_announced.len() >= ANNOUNCED_KEPT {
                                        where_announced.pop_front();
                                    }
                                    where_announced.push_back(((c.time_boot_ms, c.image_index), p));
                                }
                            }
                            Ok(MavMessage::ENCAPSULATED_DATA(_) | MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)) => {
                                progress = self.shared.now();
                            }
                            _ => {}
                        },
                        Ok(_) | Err(broadcast::error::RecvError::Lagged(_)) => {}
                        Err(broadcast::error::RecvError::Closed) => anyhow::bail!("the fleet stopped"),
                    }
                }
                r = self.images.recv() => {
                    let img = match r {
                        Ok(img) => img,
                        Err(broadcast::error::RecvError::Lagged(_)) => continue,
                        Err(broadcast::error::RecvError::Closed) => return Err(FlightError::ImagesClosed.into()),
                    };
                    if img.sysid != sysid {
                        continue;
                    }
                    arrived += 1;
                    progress = self.shared.now();
                    let key = img.pose.as_ref().map(|p| (p.time_boot_ms, p.image_index));
                    let announced_at = where_announced
                        .iter()
                        .find(|(k, _)| Some(*k) == key)
                        .map(|&(_, p)| p);
                    if self.sweep_image(&img, announced_at).await? {
                        return Ok(());
                    }
                }
                r = snaps.changed() => {
                    if r.is_err() {
                        anyhow::bail!("the fleet stopped");
                    }
                    let s = snaps.borrow_and_update().vehicles.get(&sysid).cloned();
                    let Some(s) = s else { continue };
                    if let Some(c) = s.mission_current {
                        let passed = captures_before(c);
                        let start = *captures_at_start.get_or_insert(passed);
                        let pending = announced.saturating_sub(arrived);
                        let stalled = self.shared.now().saturating_since(progress) > stall;
                        let missing = passed
                            .saturating_sub(start)
                            .saturating_sub(arrived.max(announced))
                            + if stalled { pending } else { 0 };
                        if missing > self.shared.max_retakes as usize {
                            let reason = format!(
                                "{missing} sweep pictures did not arrive (the vehicle passed their \
                                 capture points): check that the autopilot can take pictures \
                                 (ArduPilot: a camera backend, CAM1_TYPE) and that the camera is \
                                 connected"
                            );
                            self.camera_fault(None, reason).await?;
                            return Ok(());
                        }
                    }
                    if let Some(c) = s.mission_current
                        && self.shared.read(|st| st.robot(sysid).ok().and_then(|r| r.sweep_item)).await != Some(c)
                    {
                        self.shared.commit(|st| Ok((st.on_sweep_progress(sysid, c)?, None))).await?;
                    }
                    let complete = s.mission_state == Some(5)
                        || s.reached.contains(&last_nav)
                        || s.mission_current.is_some_and(|c| c > last_nav);
                    if complete && !flown {
                        flown = true;
                        let pending = announced.saturating_sub(arrived);
                        if pending > 0 {
                            self.shared.say(format!(
                                "vehicle {sysid}: sweep flown; waiting for {pending} pictures still in transfer"
                            ));
                        }
                    }
                }
                _ = changed.changed() => {
                    // A new phase, or the operator's pause (the step loop holds the vehicle).
                    if *self.shared.paused.borrow()
                        || self.shared.read(|s| s.phase != Phase::Sweep).await
                    {
                        return Ok(());
                    }
                }
                _ = tick.tick() => {
                    if self.check_battery().await? {
                        return Ok(());
                    }
                }
            }
            // The sweep is complete once flown and its announced pictures are in (or their
            // transfer stalled: those were counted as missing above).
            let stalled = self.shared.now().saturating_since(progress) > stall;
            if flown && (announced <= arrived || stalled) {
                let now = self.shared.now();
                self.shared
                    .commit(|st| {
                        st.on_sweep_complete(sysid, now)?;
                        Ok(((), Some(MappingEvent::SweepComplete { sysid })))
                    })
                    .await?;
                self.shared.say(format!("vehicle {sysid}: sweep complete"));
                return Ok(());
            }
        }
    }

    /// Classify a sweep image; returns true when the sweep must stop (it started a
    /// confirmation, or the camera was declared faulty). The picture must have been taken
    /// where the vehicle was: the camera's position within one cell more than the cell limit
    /// of `announced_at`, the vehicle's position when the camera announced the picture (else
    /// when it arrives: the vehicle flies on while it is transferred),
    /// its altitude within the limit and its tilt within
    /// [`crate::vision::sanity::SWEEP_MAX_TILT_DEG`]; otherwise it is dropped, and
    /// [`RunOptions::max_retakes`] + 1 dropped in a row are a camera fault. With the attitude
    /// known, the picture stands for the cell its optical axis met, cut as an orthophoto
    /// around that point; without, for the cell under the vehicle, centre-cropped.
    async fn sweep_image(
        &mut self,
        img: &ReceivedImage,
        announced_at: Option<GeoPoint>,
    ) -> anyhow::Result<bool> {
        let sysid = self.sysid;
        let v = self.vehicle();
        let Some(pose) = shot_pose(img, v.as_ref()) else {
            return Ok(false);
        };
        let (params, camera, altitude, grid) = self
            .shared
            .read(|s| {
                (
                    s.params.runway,
                    s.params.camera,
                    s.altitude_of(sysid).unwrap_or(s.params.base_altitude_m),
                    s.grid.clone(),
                )
            })
            .await;
        let cell_m = grid.cell_size();
        let here = LatLon {
            lat: pose.lat,
            lon: pose.lon,
        };
        // The camera's position against the vehicle's (the telemetry's own is not checked).
        let reference = announced_at.or_else(|| v.as_ref().and_then(|v| v.position));
        let offset = match (reference, pose.from_camera) {
            (Some(r), true) => Some(local::distance(r.lat, r.lon, pose.lat, pose.lon)),
            // a vehicle that reports no position cannot vouch for its camera
            (None, true) => v.as_ref().map(|_| f64::INFINITY),
            (_, false) => None,
        };
        let limits = CaptureLimits {
            horizontal_m: self.shared.limits.horizontal_m + cell_m,
            max_tilt_deg: self.shared.limits.max_tilt_deg.max(SWEEP_MAX_TILT_DEG),
            ..self.shared.limits
        };
        let claim = CaptureClaim {
            horizontal_offset_m: offset,
            altitude_m: pose.alt_m,
            attitude: pose.attitude,
            heading_deg: None,
            expected_heading_deg: None,
        };
        let alt_m = pose.alt_m.unwrap_or(altitude);
        // With the attitude known, the picture is of the cell its optical axis met: the
        // orthophoto is centred there (grid metres from the point under the camera).
        let gamma = grid
            .convergence_and_scale(here)
            .map(|(g, _)| g)
            .unwrap_or(0.0);
        let looked = pose.attitude.as_ref().and_then(|a| {
            geometry::view_centre_offset(a, alt_m).map(|(n, e)| geometry::true_to_grid(n, e, gamma))
        });
        let cell = grid.to_xy(here).map(|(e, n)| {
            let (de, dn) = looked.unwrap_or((0.0, 0.0));
            grid.cell_of_xy(e + de, n + dn)
        });
        let verdict = match (check_capture(&claim, altitude, &limits), &cell) {
            (Err(r), _) => Err(format!(
                "sweep picture {r}; reference: where the vehicle was when it {}",
                if announced_at.is_some() {
                    "was announced"
                } else {
                    "arrived"
                }
            )),
            (Ok(()), Err(e)) => Err(format!("sweep: the picture's position: {e}")),
            (Ok(()), Ok(_)) => Ok(()),
        };
        if let Err(reason) = verdict {
            self.sweep_rejects += 1;
            let retakes = self.sweep_rejects;
            tracing::info!("vehicle {sysid}: picture dropped: {reason}");
            let r = reason.clone();
            self.shared
                .commit(|_| {
                    Ok((
                        (),
                        Some(MappingEvent::ImageRejected {
                            sysid,
                            cell: None,
                            reason: r,
                            retakes,
                        }),
                    ))
                })
                .await?;
            if retakes > self.shared.max_retakes {
                self.camera_fault(
                    None,
                    format!("{retakes} sweep pictures in a row did not count; the last: {reason}"),
                )
                .await?;
                return Ok(true);
            }
            return Ok(false);
        }
        self.sweep_rejects = 0;
        let Ok(cell) = cell else {
            return Ok(false);
        };
        let heading = pose.heading_deg;
        let cut = match (pose.attitude, looked) {
            (Some(attitude), Some(centre)) => Cut::Ortho {
                attitude,
                altitude_m: alt_m,
                request: OrthoRequest {
                    cell_m,
                    centre_east_north_m: centre,
                    grid_north_deg: gamma,
                },
            },
            _ => Cut::Centre {
                heading_deg: heading,
                altitude_m: altitude,
            },
        };
        let bytes = img.bytes.clone();
        let result = cpu(move || classify_cut(&bytes, &cut, &params, &camera, cell_m)).await?;
        let c = match result {
            Ok(c) => c,
            Err(reason) => {
                self.shared
                    .commit(|s| {
                        s.image_failures += 1;
                        Ok(((), Some(MappingEvent::ImageFailed { sysid, reason })))
                    })
                    .await?;
                return Ok(false);
            }
        };
        let now = self.shared.now();
        let candidate = self
            .shared
            .commit(|s| {
                let image_id = s.next_image_id();
                let cand = s.on_sweep_image(sysid, cell, heading, c.fractions, c.labels, now)?;
                let ev = match cand {
                    Some(cell) => MappingEvent::Candidate { sysid, cell },
                    None => MappingEvent::SweepImage {
                        sysid,
                        image_id,
                        cell,
                        labels: labels5(&c),
                    },
                };
                Ok((cand, Some(ev)))
            })
            .await?;
        if let Some(cand) = candidate {
            self.shared.say(format!(
                "vehicle {sysid}: runway seen near cell {cand}: stopping the sweep to confirm it"
            ));
            flight::hold_here(self.fleet(), sysid).await?;
            return Ok(true);
        }
        Ok(false)
    }

    /// Battery swap: home, land, wait for the fresh battery, then carry on.
    async fn swap(&mut self) -> anyhow::Result<Option<PilotEnd>> {
        let sysid = self.sysid;
        let fleet = self.fleet().clone();
        let status = self
            .shared
            .read(|s| s.robot(sysid).map(|r| r.status))
            .await?;
        if status != RobotStatus::AwaitingSwap {
            let (dist, speed) = match self.vehicle() {
                Some(v) => (
                    flight::distance_home(&v),
                    self.shared.read(|s| s.params.speed_m_s).await,
                ),
                None => (100.0, 1.0),
            };
            let here = self
                .shared
                .land_here
                .lock()
                .map(|s| s.contains(&sysid))
                .unwrap_or(false);
            if here {
                flight::land_here(&fleet, sysid, self.shared.patience).await?;
            } else {
                flight::return_and_land(&fleet, sysid, dist, speed, self.shared.patience).await?;
            }
            let reboots = self.vehicle().map(|v| v.reboots).unwrap_or(0);
            let now = self.shared.now();
            self.shared
                .commit(|s| {
                    s.on_landed_for_swap(sysid, reboots, now)?;
                    Ok(((), Some(MappingEvent::LandedForSwap { sysid })))
                })
                .await?;
            let fault = self.camera_fault_now().await;
            if let Some(why) = &fault {
                self.shared.say(format!(
                    "vehicle {sysid}: landed: waiting for the operator to fix the camera ({why}); \
                     it will not resume by itself"
                ));
            } else {
                self.shared.say(format!(
                    "vehicle {sysid}: landed: waiting for a battery swap{}",
                    if self.shared.auto_resume {
                        " (resumes by itself when a fresh battery is in)"
                    } else {
                        ""
                    }
                ));
            }
            if self.shared.sim_swap && fault.is_none() {
                // The demo's operator: ask the simulated vehicle to swap its battery.
                let _ = flight::request_sim_swap(&fleet, sysid).await;
            }
        }
        if self
            .shared
            .read(|s| matches!(s.phase, Phase::Finished { .. }))
            .await
        {
            return Ok(None);
        }
        let reboots_at = self
            .shared
            .read(|s| s.robot(sysid).ok().and_then(|r| r.reboots_at_landing))
            .await;
        loop {
            let by_operator = self
                .shared
                .swapped
                .lock()
                .map(|mut s| s.remove(&sysid))
                .unwrap_or(false);
            let fresh = self.vehicle().is_some_and(|v| {
                let rebooted = reboots_at.is_none_or(|r| v.reboots > r);
                v.alive
                    && v.battery_pct
                        .is_some_and(|p| p >= 95 || (rebooted && p >= 90))
                    && (rebooted || v.battery_pct.is_some_and(|p| p >= 95))
            });
            // A faulty camera waits for the operator: a fresh battery does not repair it.
            let auto = self.shared.auto_resume && self.camera_fault_now().await.is_none();
            if by_operator || (auto && fresh) {
                let now = self.shared.now();
                if let Ok(mut set) = self.shared.land_here.lock() {
                    set.remove(&sysid);
                }
                let by = if by_operator { "operator" } else { "auto" }.to_string();
                self.shared
                    .commit(|s| {
                        s.on_swapped(sysid, now)?;
                        Ok(((), Some(MappingEvent::Swapped { sysid, by })))
                    })
                    .await?;
                self.shared.say(format!(
                    "vehicle {sysid}: fresh battery: taking off to resume"
                ));
                return Ok(None);
            }
            if !auto && !self.shared.interactive {
                return Ok(Some(PilotEnd::WaitingForOperator));
            }
            if self
                .shared
                .read(|s| matches!(s.phase, Phase::Finished { .. }))
                .await
            {
                return Ok(None);
            }
            self.wait_change(Duration::from_millis(500)).await;
        }
    }

    async fn go_home(&mut self) -> anyhow::Result<()> {
        let sysid = self.sysid;
        let now = self.shared.now();
        self.shared
            .commit(|s| {
                s.on_going_home(sysid, now)?;
                Ok(((), Some(MappingEvent::GoingHome { sysid })))
            })
            .await?;
        let (dist, speed) = match self.vehicle() {
            Some(v) => (
                flight::distance_home(&v),
                self.shared.read(|s| s.params.speed_m_s).await,
            ),
            None => (100.0, 1.0),
        };
        flight::return_and_land(self.fleet(), sysid, dist, speed, self.shared.patience).await?;
        let now = self.shared.now();
        self.shared
            .commit(|s| {
                s.on_landed(sysid, now)?;
                Ok(((), Some(MappingEvent::Landed { sysid })))
            })
            .await?;
        self.shared.say(format!("vehicle {sysid}: landed at home"));
        Ok(())
    }
}

/// Follow every robot's position for its track, distance and airborne time (in memory; saved
/// with the next step).
async fn track(shared: Arc<Shared>, sysids: Vec<u8>) {
    let mut last = shared.now();
    let mut tick = tokio::time::interval(Duration::from_millis(500));
    loop {
        tick.tick().await;
        let now = shared.now();
        let dt = (now - last).as_secs_f64();
        last = now;
        let mut core = shared.core.lock().await;
        for &sysid in &sysids {
            let Some(v) = shared.fleet.vehicle(sysid) else {
                continue;
            };
            let Some(p) = v.position else { continue };
            let Ok((e, n)) = core.state.grid.to_xy(LatLon {
                lat: p.lat,
                lon: p.lon,
            }) else {
                continue;
            };
            let air = if flight::airborne(&v) { dt } else { 0.0 };
            let _ = core.state.on_position(sysid, e, n, air);
        }
        if let Some(view) = &shared.view {
            let _ = view.send(Arc::new(core.state.clone()));
        }
    }
}

/// Run (or resume) a runway-mapping run with `fleet` until it finishes, or until robots wait
/// for the operator. `run` holds the state; the vehicles must already be heard.
pub async fn run(
    fleet: FleetHandle,
    hub: &ImageHub,
    mut run_dir: RunDir,
    state: MappingState,
    mut opts: RunOptions,
) -> anyhow::Result<Outcome> {
    let sysids: Vec<u8> = state.robots.iter().map(|r| r.sysid).collect();
    let resumed = state.started.is_some();
    run_dir.save_state(&state).context("saving the run state")?;
    run_dir
        .append_event(&MappingEvent::Started {
            robots: sysids.clone(),
            resumed,
        })
        .context("writing the run journal")?;
    let (changed, _) = watch::channel(0u64);
    let (paused, _) = watch::channel(false);
    let interactive = opts.operator.is_some();
    let shared = Arc::new(Shared {
        core: Mutex::new(Core {
            state,
            run: run_dir,
        }),
        changed,
        paused,
        swapped: std::sync::Mutex::new(HashSet::new()),
        recalled: std::sync::Mutex::new(HashSet::new()),
        land_here: std::sync::Mutex::new(HashSet::new()),
        progress: opts.progress.take(),
        view: opts.view.take(),
        fleet: fleet.clone(),
        auto_resume: opts.auto_resume,
        interactive,
        patience: opts.patience,
        tolerance_m: opts.tolerance_m,
        sim_swap: opts.sim_swap,
        max_failures: opts.max_failures,
        max_retakes: opts.max_retakes,
        limits: opts
            .capture_limits
            .unwrap_or_else(|| CaptureLimits::runway(opts.tolerance_m)),
    });
    if let Some(v) = &shared.view {
        let _ = v.send(Arc::new(shared.core.lock().await.state.clone()));
    }
    let tracker = tokio::spawn(track(shared.clone(), sysids.clone()));
    let operator = opts.operator.take().map(|mut rx| {
        let shared = shared.clone();
        tokio::spawn(async move {
            while let Some(cmd) = rx.recv().await {
                match cmd {
                    Operator::Pause => {
                        shared.paused.send_replace(true);
                        shared.say("operator: pause — every vehicle holds".into());
                    }
                    Operator::Resume => {
                        shared.paused.send_replace(false);
                        shared.say("operator: resume".into());
                    }
                    Operator::BatterySwapped(s) => {
                        if let Ok(mut set) = shared.swapped.lock() {
                            set.insert(s);
                        }
                        shared.say(format!("operator: vehicle {s} has a fresh battery"));
                    }
                    Operator::Land(s) => {
                        if let Ok(mut set) = shared.land_here.lock() {
                            set.insert(s);
                        }
                        if let Ok(mut set) = shared.recalled.lock() {
                            set.insert(s);
                        }
                        shared.say(format!("operator: vehicle {s} lands where it is"));
                    }
                    Operator::Recall(s) => {
                        if let Ok(mut set) = shared.recalled.lock() {
                            set.insert(s);
                        }
                        shared.say(format!("operator: vehicle {s} recalled for a battery swap"));
                    }
                }
                shared.changed.send_modify(|n| *n += 1);
            }
        })
    });
    let mut tasks = Vec::new();
    for &sysid in &sysids {
        let pilot = Pilot {
            sysid,
            shared: shared.clone(),
            images: hub.subscribe(),
            capture_seq: 0,
            held: false,
            first_sweep: true,
            sweep_rejects: 0,
        };
        tasks.push((sysid, tokio::spawn(pilot.run())));
    }
    let mut waiting = Vec::new();
    let mut first_err = None;
    for (sysid, t) in tasks {
        match t.await {
            Ok(Ok(PilotEnd::Done)) => {}
            Ok(Ok(PilotEnd::WaitingForOperator)) => waiting.push(sysid),
            Ok(Err(e)) => {
                if first_err.is_none() {
                    first_err = Some(e);
                }
            }
            Err(e) => {
                if first_err.is_none() {
                    first_err = Some(anyhow::anyhow!("vehicle {sysid}: pilot task failed: {e}"));
                }
            }
        }
    }
    tracker.abort();
    if let Some(op) = operator {
        op.abort();
    }
    // Save the final track and times.
    let mut core = shared.core.lock().await;
    let Core { state, run } = &mut *core;
    if state.is_finished() {
        let found = matches!(state.phase, Phase::Finished { found: true });
        let now = fleet.clock().now();
        state.book.close_all(now);
        run.save_state(state).context("saving the run state")?;
        run.append_event(&MappingEvent::Finished { found })
            .context("writing the run journal")?;
    } else {
        run.save_state(state).context("saving the run state")?;
    }
    if let Some(v) = &shared.view {
        let _ = v.send(Arc::new(state.clone()));
    }
    if let Some(e) = first_err {
        return Err(e);
    }
    if waiting.is_empty() {
        Ok(Outcome::Finished)
    } else {
        Ok(Outcome::WaitingForOperator { sysids: waiting })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn higher_drones_crop_to_the_three_cells_around_the_centre() {
        let cam = CameraModel::paper();
        let img = RgbImage::new(480, 480);
        // at 12 m the footprint is exactly 3 cells: unchanged
        assert_eq!(
            crop_to_cells(img.clone(), &cam, 12.0, 4.0).dimensions(),
            (480, 480)
        );
        // at 24 m it is 6 cells wide: the centre half
        assert_eq!(
            crop_to_cells(img.clone(), &cam, 24.0, 4.0).dimensions(),
            (240, 240)
        );
        // lower: the whole image
        assert_eq!(crop_to_cells(img, &cam, 8.0, 4.0).dimensions(), (480, 480));
    }
}
