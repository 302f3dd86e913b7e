//! One simulated vehicle: an ArduPilot or PX4 copter or rover, as pure logic stepped by time.
//!
//! ```text
//!   handle_message(header, msg, now)   ──►  ┌────────────┐ ──► poll_transmit() → (header, msg)
//!   step(now)                          ──►  │ SimVehicle │ ──► poll_event()    → VehicleEvent
//!   swap_battery(now) (the operator)   ──►  └────────────┘ ──► poll_image()    → CapturedImage
//! ```
//!
//! The vehicle integrates its motion at a fixed 20 Hz on the given timeline; it never reads a
//! clock. What it sends carries a [`MavHeader`] with its system id, the component (1 for the
//! autopilot, 100 for the camera) and per-component sequence numbers that restart when it
//! reboots. Drain [`SimVehicle::poll_image`] (write the files) before sending what
//! [`SimVehicle::poll_transmit`] returns, so a CAMERA_IMAGE_CAPTURED's file exists when the
//! GCS reads its URL.
//!
//! Behaviour followed from the autopilots' sources (see also `mission_server` and `flavour`):
//! - commands: ArduPilot `libraries/GCS_MAVLink/GCS_Common.cpp` (arm/disarm: MAV_RESULT_FAILED
//!   when the pre-arm checks fail, disarm in flight refused unless forced with 21196),
//!   `ArduCopter/GCS_Mavlink.cpp` (NAV_TAKEOFF needs frame GLOBAL_RELATIVE_ALT and a
//!   landed, armed vehicle in a takeoff-capable mode → FAILED otherwise; DO_REPOSITION is
//!   DENIED outside GUIDED without MAV_DO_REPOSITION_FLAGS_CHANGE_MODE; MISSION_START switches
//!   to AUTO and starts the mission; SET_POSITION_TARGET_GLOBAL_INT is ignored outside
//!   GUIDED); PX4 `src/modules/commander/Commander.cpp` (arm denied → TEMPORARILY_REJECTED
//!   with "Arming denied: Resolve system health failures first", "Disarming denied: not
//!   landed", DO_REPOSITION needs the change-mode bit (else UNSUPPORTED) and switches to Hold,
//!   MISSION_START also arms, mode changes refused → TEMPORARILY_REJECTED);
//! - arming checks: a 3D GPS fix and a position estimate some seconds after boot (ArduCopter
//!   "PreArm: Need Position Estimate", PX4 "Preflight Fail: …"), PX4 also a GCS heartbeat
//!   (NAV_DLL_ACT > 0 in the SITL airframes: "Preflight Fail: No connection to the GCS",
//!   `src/modules/commander/HealthAndArmingChecks/checks/rcAndDataLinkCheck.cpp`; the
//!   connection counts as lost until the first GCS heartbeat and after COM_DL_LOSS_T = 10 s
//!   without one, `Commander::dataLinkCheck`, the same timeout as the data-link-loss
//!   failsafe; scaled by [`VehicleConfig::gcs_time_scale`]);
//!   home is set when the estimate is ready and again at arming;
//! - mission execution: ArduPilot `libraries/AP_Mission/AP_Mission.cpp` (do-commands between
//!   two nav commands run when the first completes; DO_JUMP counts; MISSION_ITEM_REACHED from
//!   `ArduCopter/mode_auto.cpp` verify_command for every completed nav command and
//!   DO_CHANGE_SPEED; AUTO on the ground needs a mission starting with a takeoff), PX4
//!   navigator (items in order, do-items reached at once, a vertical takeoff inserted when a
//!   mission starts on the ground, MISSION_ITEM_REACHED repeated 10 times at 1 Hz as
//!   `mavlink_mission.cpp` does);
//! - auto-disarm: ArduCopter after 10 s armed on the ground (DISARM_DELAY) and at once after
//!   landing in LAND/RTL/AUTO; PX4 after 10 s without takeoff (COM_DISARM_PRFLT) and 2 s after
//!   landing (COM_DISARM_LAND); rovers never;
//! - streams: ArduCopter sends only HEARTBEAT until the GCS asks (REQUEST_DATA_STREAM or
//!   SET_MESSAGE_INTERVAL), ArduRover streams at 1 Hz by default, PX4 uses the rates of its
//!   NORMAL MAVLink mode (`mavlink_main.cpp` configure_streams).

// MISSION_SET_CURRENT etc. are deprecated in the dialect but still what autopilots accept.
#![allow(deprecated)]

use crate::geo::local;
use crate::mission::{MissionItem, MissionType};
use crate::sim::battery::{Battery, BatteryConfig};
use crate::sim::camera::{CAMERA_COMPID, CameraConfig, CaptureContext, CapturedImage, SimCamera};
use crate::sim::fence::Fence;
use crate::sim::flavour::{Autopilot, Flavour, Mode, VehicleKind};
use crate::sim::mission_server::{HomeItem, MissionEvent, MissionServer};
use crate::sim::motion::{self, Command, Limits};
use crate::sim::render::CameraPose;
use crate::sim::world::{Wind, World};
use crate::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

/// Physics and logic step, seconds (20 Hz).
pub const DT: f64 = 0.05;

/// PX4's COM_DL_LOSS_T default: seconds without a GCS heartbeat after which the data link
/// counts as lost (`src/modules/commander/commander_params.c`).
pub const PX4_DL_LOSS_S: f64 = 10.0;
/// Time constant of each of the two first-order lags through which the position estimate
/// follows the GPS, seconds. An autopilot's estimator (ArduPilot's EKF3, PX4's EKF2) fuses
/// the 5–10 Hz GPS fixes with the IMU, so its position drifts with the GPS error but is
/// smooth; steering by the raw error process instead (white increments every tick) made a
/// hovering copter in calm air tilt by 3–8° from one image to the next, 0.6–1.7 m of
/// footprint at 12 m.
pub const ESTIMATE_LAG_S: f64 = 1.0;
/// The autopilot's component id (MAV_COMP_ID_AUTOPILOT1).
pub const AUTOPILOT_COMPID: u8 = 1;
/// The command that stands for "the operator swapped the battery" (MAV_CMD_USER_1): accepted
/// when the vehicle is landed and disarmed, it power-cycles the vehicle with a full battery.
pub const CMD_BATTERY_SWAP: u16 = 31010;

/// Battery failsafe levels (percent of charge left).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryFailsafe {
    /// At or below this level: return to launch (ArduPilot BATT_LOW_MAH with
    /// BATT_FS_LOW_ACT = RTL; PX4 BAT_CRIT_THR with COM_LOW_BAT_ACT = 3).
    pub rtl_pct: f64,
    /// At or below this level: land where it is (ArduPilot BATT_CRT_MAH with
    /// BATT_FS_CRT_ACT = Land; PX4 BAT_EMERGEN_THR).
    pub land_pct: f64,
}

/// Seconds an ArduPilot vehicle spends in MAV_STATE_BOOT after power-up (ArduCopter SITL
/// 4.7: about 2 s, until `Copter::init_ardupilot` sets `ap.initialised`).
pub const ARDUPILOT_BOOT_S: f64 = 2.0;

/// Everything that defines one simulated vehicle.
#[derive(Clone, Debug)]
pub struct VehicleConfig {
    /// MAVLink system id.
    pub sysid: u8,
    /// Autopilot and airframe.
    pub flavour: Flavour,
    /// Where it is powered up (lat, lon degrees), on the ground.
    pub start: (f64, f64),
    /// The local frame's reference point shared by all vehicles of a simulation.
    pub reference: (f64, f64),
    /// Ground elevation AMSL, metres.
    pub ground_alt_amsl_m: f64,
    /// Battery.
    pub battery: BatteryConfig,
    /// Battery failsafe.
    pub failsafe: BatteryFailsafe,
    /// Motion limits.
    pub limits: Limits,
    /// Seconds after boot until a 3D GPS fix.
    pub gps_fix_after_s: f64,
    /// Seconds after boot until the position estimate is ready (EKF origin / global position).
    pub position_ready_after_s: f64,
    /// Standard deviation of the slowly varying GPS position error that every receiver of
    /// the simulation shares (satellite clock and orbit, ionosphere, troposphere: the part
    /// that differential GPS removes), metres per axis.
    pub gps_error_sigma_m: f64,
    /// Standard deviation of this receiver's own error (noise, multipath), metres per axis.
    /// Two vehicles side by side disagree only by this much, which is what lets a drone land
    /// on a rover's charging pad by GPS.
    pub gps_own_sigma_m: f64,
    /// Seed of the shared GPS error: equal for every vehicle of one simulation (the harness
    /// sets it), so that their common-mode errors are the same process.
    pub gps_common_seed: u64,
    /// Wind (None = calm).
    pub wind: Option<Wind>,
    /// Seed of every random process of this vehicle.
    pub seed: u64,
    /// The camera (None = no camera component).
    pub camera: Option<CameraConfig>,
    /// Swap the battery automatically this long after the vehicle is landed and disarmed
    /// with a used battery (the field crew's turnaround), seconds.
    pub swap_after_s: Option<f64>,
    /// PX4: arming needs a GCS heartbeat and losing it for 10 s while armed triggers RTL
    /// (NAV_DLL_ACT > 0, COM_DL_LOSS_T 10 s, as in PX4's SITL airframes).
    pub px4_datalink_required: bool,
    /// Simulated seconds per second of the GCS's clock (1 by default: the GCS runs on the
    /// simulation's clock, as in-process). The GCS-link timeouts (PX4's COM_DL_LOSS_T, for
    /// arming and for the data-link-loss failsafe) are this many times longer in simulated
    /// time: a GCS on the wall clock heartbeats at 1 Hz of *its* time, so a simulator
    /// running 10× faster than wall time must judge it over 10× as many simulated seconds,
    /// or it would see 0.1 heartbeats per simulated second and declare the link lost. The
    /// socket server sets it ([`crate::sim::server::ServeOptions::gcs_speedup`]).
    pub gcs_time_scale: f64,
    /// Power-off time of a battery swap, seconds (the vehicle is silent meanwhile).
    pub power_off_s: f64,
}

impl VehicleConfig {
    /// A vehicle with the defaults of its flavour: 12-minute copter batteries, failsafe RTL at
    /// 20 % / land at 10 % (ArduPilot) or 7 % / 5 % (PX4 BAT_CRIT_THR / BAT_EMERGEN_THR),
    /// position estimate after 15 s (ArduPilot EKF3 in SITL) or 8 s (PX4), a 0.4 m GPS error
    /// (0.37 m shared by every receiver, 0.15 m its own)
    /// and, for copters, the paper's camera.
    pub fn new(sysid: u8, flavour: Flavour, start: (f64, f64)) -> VehicleConfig {
        let copter = flavour.kind == VehicleKind::Copter;
        let ardupilot = flavour.autopilot == Autopilot::ArduPilot;
        VehicleConfig {
            sysid,
            flavour,
            start,
            reference: start,
            ground_alt_amsl_m: 0.0,
            battery: if copter {
                BatteryConfig::copter(12.0)
            } else {
                BatteryConfig::rover()
            },
            failsafe: if ardupilot {
                BatteryFailsafe {
                    rtl_pct: 20.0,
                    land_pct: 10.0,
                }
            } else {
                BatteryFailsafe {
                    rtl_pct: 7.0,
                    land_pct: 5.0,
                }
            },
            limits: match (flavour.autopilot, flavour.kind) {
                (_, VehicleKind::Rover) => Limits::ROVER,
                (Autopilot::ArduPilot, _) => Limits::ARDUCOPTER,
                (Autopilot::Px4, _) => Limits::PX4_COPTER,
            },
            gps_fix_after_s: 3.0,
            position_ready_after_s: if ardupilot { 15.0 } else { 8.0 },
            gps_error_sigma_m: 0.37,
            gps_own_sigma_m: 0.15,
            gps_common_seed: 0,
            wind: None,
            seed: u64::from(sysid),
            camera: if copter {
                Some(CameraConfig::default())
            } else {
                None
            },
            swap_after_s: None,
            px4_datalink_required: true,
            gcs_time_scale: 1.0,
            power_off_s: 3.0,
        }
    }
}

/// Something the shell or a test may want to know.
#[derive(Clone, Debug, PartialEq)]
pub enum VehicleEvent {
    /// The vehicle finished booting (boot counter, 1 for the first power-up).
    Booted {
        /// Boots so far.
        boot: u32,
    },
    /// The battery was swapped and the vehicle power-cycled.
    BatterySwapped,
    /// Armed state changed.
    Armed(bool),
    /// The vehicle touched down.
    Landed,
    /// A battery failsafe triggered (RTL or LAND).
    BatteryFailsafe(Mode),
    /// The vehicle breached its geofence (the moment it crossed into a breach).
    FenceBreached {
        /// True position, local metres (east, north, up) from the world's reference.
        truth: (f64, f64, f64),
        /// The position the autopilot's estimate gave, local metres (east, north): what the
        /// fence was checked against.
        estimate: (f64, f64),
        /// The flight mode at the breach.
        mode: Mode,
    },
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Point {
    e: f64,
    n: f64,
    u: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum RtlPhase {
    Climb,
    Return,
    Descend,
    Loiter(Time),
    Land,
    Done,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Nav {
    /// On the ground, motors off or idle.
    Idle,
    /// Hold a point.
    Hold(Point),
    /// Climb vertically to `u` at (e, n).
    Takeoff(Point),
    /// Fly to a point and stay there (guided / reposition / waypoint travel).
    Goto { p: Point, speed: Option<f64> },
    /// Land at (e, n): fly there first at the current height, then descend.
    Land { p: Point, descending: bool },
    /// Return to launch.
    Rtl { phase: RtlPhase, ret_u: f64 },
}

/// Mission execution state (items in the autopilot's numbering).
#[derive(Clone, Debug, Default)]
struct Exec {
    running: bool,
    complete: bool,
    nav_index: Option<u16>,
    nav_started: bool,
    nav_arrived: Option<Time>,
    nav_point: Option<Point>,
    /// PX4: takeoff inserted before the current item.
    px4_takeoff: Option<f64>,
    /// PX4: the position a take-off item is flown to after the climb (`None` inside: the
    /// item has none, latitude/longitude 0, 0, and is never reached).
    px4_takeoff_target: Option<Option<Point>>,
    /// ArduPilot: the mission is waiting for MISSION_START (auto_armed false on the ground).
    waiting_auto_armed: bool,
    jumps: HashMap<u16, i32>,
    reached: Option<(u16, u8, Time)>, // PX4: last reached seq, times resent, next resend
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Home {
    lat: f64,
    lon: f64,
    alt_amsl: f64,
    e: f64,
    n: f64,
}

/// One simulated vehicle. See the module documentation.
#[derive(Debug)]
pub struct SimVehicle {
    cfg: VehicleConfig,
    world: Option<Arc<World>>,
    // power and time
    powered: bool,
    power_on_at: Option<Time>,
    boot_time: Time,
    boots: u32,
    last_tick: Time,
    seq: [u8; 2],
    // state
    m: motion::State,
    /// The error of the position estimate (what the autopilot reports and steers by), metres
    /// east and north: the GPS error ([`SimVehicle::gps_raw_err`]) through the estimator's
    /// smoothing, two first-order lags of [`ESTIMATE_LAG_S`].
    gps_err: (f64, f64),
    /// The first of those two lags.
    gps_lag: (f64, f64),
    rng: ChaCha8Rng,
    /// The shared GPS error process (same seed in every vehicle of a simulation).
    gps_rng: ChaCha8Rng,
    /// The common-mode part of `gps_err`, and this receiver's own part.
    gps_common: (f64, f64),
    gps_own: (f64, f64),
    battery: Battery,
    armed: bool,
    armed_at: Time,
    took_off: bool,
    mode: Mode,
    landed: bool,
    landed_at: Option<Time>,
    disarmed_landed_since: Option<Time>,
    home: Option<Home>,
    position_ok_announced: bool,
    nav: Nav,
    speed_override: Option<f64>,
    /// A fixed heading for guided flight (degrees clockwise from north): ArduPilot's
    /// CONDITION_YAW, PX4's DO_REPOSITION yaw. `None`: face the direction of travel.
    yaw_target_deg: Option<f64>,
    exec: Exec,
    mission: MissionServer,
    guided_target_at: Option<Time>,
    failsafe_level: u8,
    last_gcs_heartbeat: Option<Time>,
    datalink_lost: bool,
    last_prearm_report: Option<Time>,
    streams: BTreeMap<u32, (Duration, Time)>,
    outbox: VecDeque<(u8, MavMessage)>,
    events: VecDeque<VehicleEvent>,
    camera: Option<SimCamera>,
    charging: bool,
    fence: Fence,
    fence_enabled: bool,
    fence_breached: bool,
    mission_valid: bool,
}

fn header(sysid: u8, compid: u8, seq: u8) -> MavHeader {
    MavHeader {
        system_id: u32::from(sysid),
        component_id: compid,
        sequence: seq,
    }
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-12);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

impl SimVehicle {
    /// A vehicle that powers up at `now` over `world` (None: no camera images, flat ground at
    /// the configured elevation).
    pub fn new(cfg: VehicleConfig, world: Option<Arc<World>>, now: Time) -> SimVehicle {
        let (n, e) = local::delta(cfg.reference.0, cfg.reference.1, cfg.start.0, cfg.start.1);
        let camera = cfg
            .camera
            .clone()
            .map(|c| SimCamera::new(cfg.sysid, c, cfg.seed ^ 0xCA3E_5A11));
        let mut v = SimVehicle {
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            gps_rng: ChaCha8Rng::seed_from_u64(cfg.gps_common_seed),
            gps_common: (0.0, 0.0),
            gps_own: (0.0, 0.0),
            battery: Battery::full(cfg.battery),
            mission: MissionServer::new(cfg.flavour.autopilot, cfg.sysid, AUTOPILOT_COMPID),
            mode: cfg.flavour.boot_mode(),
            cfg,
            world,
            powered: false,
            power_on_at: Some(now),
            boot_time: now,
            boots: 0,
            last_tick: now,
            seq: [0; 2],
            m: motion::State {
                e,
                n,
                ..motion::State::default()
            },
            gps_err: (0.0, 0.0),
            gps_lag: (0.0, 0.0),
            armed: false,
            armed_at: now,
            took_off: false,
            landed: true,
            landed_at: Some(now),
            disarmed_landed_since: Some(now),
            home: None,
            position_ok_announced: false,
            nav: Nav::Idle,
            speed_override: None,
            yaw_target_deg: None,
            exec: Exec::default(),
            guided_target_at: None,
            failsafe_level: 0,
            last_gcs_heartbeat: None,
            datalink_lost: false,
            last_prearm_report: None,
            streams: BTreeMap::new(),
            outbox: VecDeque::new(),
            events: VecDeque::new(),
            camera,
            charging: false,
            fence: Fence::default(),
            fence_enabled: false,
            fence_breached: false,
            mission_valid: true,
        };
        let (s, o) = (v.cfg.gps_error_sigma_m, v.cfg.gps_own_sigma_m);
        v.gps_common = (gauss(&mut v.gps_rng) * s, gauss(&mut v.gps_rng) * s);
        v.gps_own = (gauss(&mut v.rng) * o, gauss(&mut v.rng) * o);
        v.gps_err = v.gps_raw_err();
        v.gps_lag = v.gps_err;
        v.boot(now);
        v
    }

    // ------------------------------------------------------------------ public API

    /// Set [`VehicleConfig::gcs_time_scale`] (simulated seconds per second of the GCS's
    /// clock), e.g. when the simulation is served faster than wall time to a GCS that runs
    /// on the wall clock.
    pub fn set_gcs_time_scale(&mut self, scale: f64) {
        self.cfg.gcs_time_scale = scale;
    }

    /// The configuration.
    pub fn config(&self) -> &VehicleConfig {
        &self.cfg
    }

    /// MAVLink system id.
    pub fn sysid(&self) -> u8 {
        self.cfg.sysid
    }

    /// Whether the vehicle is powered (false during a battery swap).
    pub fn powered(&self) -> bool {
        self.powered
    }

    /// Boots so far (1 after the first power-up).
    pub fn boots(&self) -> u32 {
        self.boots
    }

    /// Whether it is armed.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// The flight mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Whether it is on the ground.
    pub fn landed(&self) -> bool {
        self.landed
    }

    /// True position: local (east, north, up) metres in the shared frame.
    pub fn true_local(&self) -> (f64, f64, f64) {
        (self.m.e, self.m.n, self.m.u)
    }

    /// True position (lat, lon) degrees and height above ground, metres.
    pub fn true_position(&self) -> (f64, f64, f64) {
        let (lat, lon) = local::offset(
            self.cfg.reference.0,
            self.cfg.reference.1,
            self.m.n,
            self.m.e,
        );
        (lat, lon, self.m.u)
    }

    /// The position the autopilot believes and reports (lat, lon, height above ground).
    pub fn reported_position(&self) -> (f64, f64, f64) {
        let (e, n) = self.est();
        let (lat, lon) = local::offset(self.cfg.reference.0, self.cfg.reference.1, n, e);
        (lat, lon, self.m.u)
    }

    /// Heading, degrees.
    pub fn heading_deg(&self) -> f64 {
        self.m.heading_deg
    }

    /// The battery.
    pub fn battery(&self) -> &Battery {
        &self.battery
    }

    /// Home (lat, lon, AMSL altitude), when set.
    pub fn home(&self) -> Option<(f64, f64, f64)> {
        self.home.map(|h| (h.lat, h.lon, h.alt_amsl))
    }

    /// The mission server (stored lists).
    pub fn mission(&self) -> &MissionServer {
        &self.mission
    }

    /// The mission server, to change its storage limits
    /// ([`MissionServer::set_capacity`]: a vehicle that refuses long missions).
    pub fn mission_mut(&mut self) -> &mut MissionServer {
        &mut self.mission
    }

    /// Move the vehicle by (de, dn) metres without flying (riding on a rover).
    pub fn carry(&mut self, de: f64, dn: f64) {
        self.m.e += de;
        self.m.n += dn;
    }

    /// Charge the battery for `dt` seconds (standing on a charging station); only while
    /// landed.
    pub fn charge(&mut self, dt: f64) {
        if self.landed && self.powered {
            self.battery.charge(dt);
            self.charging = true;
        }
    }

    /// The operator swaps the battery (in-process equivalent of [`CMD_BATTERY_SWAP`]):
    /// accepted when landed and disarmed; the vehicle powers off for
    /// `VehicleConfig::power_off_s` and boots again with a full battery.
    pub fn swap_battery(&mut self, now: Time) -> bool {
        self.advance(now);
        if !self.landed || self.armed {
            return false;
        }
        self.power_cycle(now, true);
        true
    }

    /// The next message to send and its header.
    pub fn poll_transmit(&mut self) -> Option<(MavHeader, MavMessage)> {
        if let Some(m) = self.mission.poll_transmit() {
            self.outbox.push_back((AUTOPILOT_COMPID, m));
        }
        let cam_msg = self.camera.as_mut().and_then(|c| c.poll_transmit());
        if let Some(m) = cam_msg {
            self.outbox.push_back((CAMERA_COMPID, m));
        }
        let (comp, msg) = self.outbox.pop_front()?;
        let i = usize::from(comp == CAMERA_COMPID);
        let s = self.seq[i];
        self.seq[i] = s.wrapping_add(1);
        Some((header(self.cfg.sysid, comp, s), msg))
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<VehicleEvent> {
        self.events.pop_front()
    }

    /// The next captured image (write its file before sending the messages that follow).
    pub fn poll_image(&mut self) -> Option<CapturedImage> {
        self.camera.as_mut().and_then(|c| c.poll_image())
    }

    /// When the vehicle next needs [`SimVehicle::step`]: its next 20 Hz tick.
    pub fn poll_timeout(&self) -> Time {
        self.last_tick + Duration::from_secs_f64(DT)
    }

    /// Advance the simulation to `now`.
    pub fn step(&mut self, now: Time) {
        self.advance(now);
    }

    /// Handle a message the vehicle received at `now` (after simulating up to `now`).
    pub fn handle_message(&mut self, h: &MavHeader, msg: &MavMessage, now: Time) {
        self.advance(now);
        if !self.powered {
            return;
        }
        let from = (u8::try_from(h.system_id).unwrap_or(u8::MAX), h.component_id);
        if let MavMessage::HEARTBEAT(hb) = msg
            && hb.mavtype == mav::MavType::MAV_TYPE_GCS
        {
            self.last_gcs_heartbeat = Some(now);
            if self.datalink_lost {
                self.datalink_lost = false;
                self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Data link regained");
            }
            return;
        }
        self.mission.set_loaded(!self.ardupilot_booting(now));
        if self.mission.handle_message(h, msg, now) {
            self.drain_mission_events(now);
            return;
        }
        match msg {
            MavMessage::COMMAND_LONG(c) => {
                if c.target_system != self.cfg.sysid && c.target_system != 0 {
                    return;
                }
                self.command_long(from, c, now);
            }
            MavMessage::COMMAND_INT(c) => {
                if c.target_system != self.cfg.sysid && c.target_system != 0 {
                    return;
                }
                self.command_int(from, c, now);
            }
            MavMessage::SET_MODE(s) => {
                if s.target_system != self.cfg.sysid {
                    return;
                }
                let result = self.set_mode_request(s.base_mode.bits(), s.custom_mode, now);
                // PX4 turns SET_MODE into VEHICLE_CMD_DO_SET_MODE and acknowledges that
                // command; ArduPilot acknowledges with command = 11 (the SET_MODE message id),
                // which is not a MAV_CMD the mavlink crate can encode, so it is left out.
                if self.cfg.flavour.autopilot == Autopilot::Px4 {
                    self.ack(from, mav::MavCmd::MAV_CMD_DO_SET_MODE, result);
                }
            }
            MavMessage::REQUEST_DATA_STREAM(r)
                if r.target_system == self.cfg.sysid && self.cfg.flavour.is_ardupilot() =>
            {
                self.request_data_stream(
                    r.req_stream_id as u8,
                    r.req_message_rate,
                    r.start_stop != 0,
                    now,
                );
            }
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(p) if p.target_system == self.cfg.sysid => {
                self.position_target(p, now);
            }
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => {
                if let Some(c) = self.camera.as_mut() {
                    c.handle_handshake_request(h.size);
                }
            }
            _ => {}
        }
    }

    // ------------------------------------------------------------------ time and power

    fn advance(&mut self, now: Time) {
        let dt = Duration::from_secs_f64(DT);
        while self.last_tick + dt <= now {
            let t = self.last_tick + dt;
            self.last_tick = t;
            self.tick(t);
        }
    }

    fn time_boot_ms(&self, now: Time) -> u32 {
        now.saturating_since(self.boot_time).as_millis() as u32
    }

    fn boot_s(&self, now: Time) -> f64 {
        now.saturating_since(self.boot_time).as_secs_f64()
    }

    /// ArduPilot's first [`ARDUPILOT_BOOT_S`] after power-up: its heartbeat says
    /// MAV_STATE_BOOT and its mission lists are not loaded yet (see
    /// [`crate::sim::mission_server::MissionServer::set_loaded`]).
    fn ardupilot_booting(&self, now: Time) -> bool {
        self.cfg.flavour.is_ardupilot() && self.boot_s(now) < ARDUPILOT_BOOT_S
    }

    fn boot(&mut self, now: Time) {
        self.powered = true;
        self.power_on_at = None;
        self.boots += 1;
        self.boot_time = now;
        self.seq = [0; 2];
        self.armed = false;
        self.took_off = false;
        self.mode = self.cfg.flavour.boot_mode();
        self.home = None;
        self.position_ok_announced = false;
        self.nav = Nav::Idle;
        self.speed_override = None;
        self.yaw_target_deg = None;
        self.exec = Exec::default();
        self.failsafe_level = 0;
        self.last_gcs_heartbeat = None;
        self.datalink_lost = false;
        self.last_prearm_report = None;
        self.outbox.clear();
        self.mission.reboot();
        self.mission.set_home(None);
        if let Some(c) = self.camera.as_mut()
            && self.boots > 1
        {
            c.reboot();
        }
        self.streams.clear();
        self.default_streams(now);
        // ArduPilot: FENCE_ENABLE 0 until the GCS enables it; PX4: any uploaded fence applies
        self.fence_enabled = !self.cfg.flavour.is_ardupilot();
        self.fence_breached = false;
        self.rebuild_fence(false);
        self.disarmed_landed_since = Some(now);
        match self.cfg.flavour.autopilot {
            Autopilot::ArduPilot => {
                let name = if self.cfg.flavour.is_copter() {
                    "ArduCopter V4.5.7 (fleetmap sim)"
                } else {
                    "ArduRover V4.5.7 (fleetmap sim)"
                };
                self.text(mav::MavSeverity::MAV_SEVERITY_INFO, name);
                if self.cfg.flavour.is_copter() {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Frame: QUAD/X");
                }
            }
            Autopilot::Px4 => {}
        }
        self.events
            .push_back(VehicleEvent::Booted { boot: self.boots });
    }

    fn power_cycle(&mut self, now: Time, new_battery: bool) {
        self.powered = false;
        self.power_on_at = Some(now + Duration::from_secs_f64(self.cfg.power_off_s.max(0.0)));
        // what was already queued (e.g. the ACK of the command that cut the power) still
        // leaves; nothing else does
        while self.mission.poll_transmit().is_some() {}
        if let Some(c) = self.camera.as_mut() {
            while c.poll_transmit().is_some() {}
        }
        if new_battery {
            self.battery = Battery::full(self.cfg.battery);
            self.events.push_back(VehicleEvent::BatterySwapped);
        }
    }

    fn position_ok(&self, now: Time) -> bool {
        self.boot_s(now) >= self.cfg.position_ready_after_s
    }

    fn gps_fix(&self, now: Time) -> bool {
        self.boot_s(now) >= self.cfg.gps_fix_after_s
    }

    /// The GPS receiver's error now (shared part + own part), metres east and north.
    fn gps_raw_err(&self) -> (f64, f64) {
        (
            self.gps_common.0 + self.gps_own.0,
            self.gps_common.1 + self.gps_own.1,
        )
    }

    fn est(&self) -> (f64, f64) {
        (self.m.e + self.gps_err.0, self.m.n + self.gps_err.1)
    }

    fn wind_ne(&self) -> (f64, f64) {
        self.cfg.wind.map(|w| w.velocity_ne()).unwrap_or((0.0, 0.0))
    }

    fn ground_amsl(&self) -> f64 {
        self.cfg.ground_alt_amsl_m
    }

    // ------------------------------------------------------------------ the 20 Hz tick

    fn tick(&mut self, now: Time) {
        // GPS error: first-order Gauss–Markov processes, 60 s correlation time. The shared
        // one advances also while this vehicle is off, to stay the same as the others'.
        let a = (-DT / 60.0f64).exp();
        let k = (1.0 - a * a).sqrt();
        let (b, bo) = (self.cfg.gps_error_sigma_m * k, self.cfg.gps_own_sigma_m * k);
        self.gps_common.0 = self.gps_common.0 * a + b * gauss(&mut self.gps_rng);
        self.gps_common.1 = self.gps_common.1 * a + b * gauss(&mut self.gps_rng);
        if !self.powered {
            if let Some(t) = self.power_on_at
                && now >= t
            {
                self.boot(now);
            }
            return;
        }
        self.gps_own.0 = self.gps_own.0 * a + bo * gauss(&mut self.rng);
        self.gps_own.1 = self.gps_own.1 * a + bo * gauss(&mut self.rng);
        // The mission protocol's own timers (see `mission_server`): ArduPilot re-requests an
        // item after 1 s and cancels an upload after 8 s without one, PX4 re-requests every
        // 250 ms and abandons a transfer after 5 s of silence.
        if self.mission.poll_timeout().is_some_and(|t| t <= now) {
            self.mission.handle_timeout(now);
            self.drain_mission_events(now);
        }
        // The estimator smooths the GPS: the controller steers by a position whose error
        // drifts, but has no jumps from one 20 Hz tick to the next.
        let raw = self.gps_raw_err();
        let f = 1.0 - (-DT / ESTIMATE_LAG_S).exp();
        self.gps_lag.0 += f * (raw.0 - self.gps_lag.0);
        self.gps_lag.1 += f * (raw.1 - self.gps_lag.1);
        self.gps_err.0 += f * (self.gps_lag.0 - self.gps_err.0);
        self.gps_err.1 += f * (self.gps_lag.1 - self.gps_err.1);

        if !self.position_ok_announced && self.position_ok(now) {
            self.position_ok_announced = true;
            self.set_home_here(now);
            match self.cfg.flavour.autopilot {
                Autopilot::ArduPilot => {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_INFO,
                        "EKF3 IMU0 is using GPS",
                    );
                }
                Autopilot::Px4 => {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Ready for takeoff!");
                }
            }
        }
        self.charging = false;
        self.run_mode(now);
        self.move_vehicle(now);
        self.drain_battery();
        self.check_failsafes(now);
        self.check_fence(now);
        self.check_auto_disarm(now);
        self.update_camera(now);
        self.update_mission_reached(now);
        self.emit_streams(now);
        self.check_swap(now);
    }

    fn move_vehicle(&mut self, now: Time) {
        let rover = self.cfg.flavour.kind == VehicleKind::Rover;
        let was_landed = self.landed;
        let cmd = self.motion_command();
        let (ee, en) = (self.gps_err.0, self.gps_err.1);
        // the controller acts on the estimate: shift the target by the estimation error
        let cmd = match cmd {
            Command::Goto {
                e,
                n,
                u,
                speed,
                yaw_deg,
            } => Command::Goto {
                e: e - ee,
                n: n - en,
                u,
                speed,
                yaw_deg,
            },
            Command::Descend { e, n, rate } => Command::Descend {
                e: e - ee,
                n: n - en,
                rate,
            },
            Command::Ground => Command::Ground,
        };
        let wind = self.wind_ne();
        motion::step(&mut self.m, &cmd, &self.cfg.limits, wind, rover, DT);
        if rover {
            self.landed = true;
            return;
        }
        if self.m.u > 0.05 {
            if self.landed {
                self.landed = false;
                self.took_off = true;
                self.landed_at = None;
            }
        } else if !was_landed && matches!(cmd, Command::Descend { .. }) && self.m.u <= 0.0 {
            self.landed = true;
            self.landed_at = Some(now);
            self.m.vu = 0.0;
            self.events.push_back(VehicleEvent::Landed);
            self.on_touchdown(now);
        }
    }

    fn motion_command(&self) -> Command {
        if !self.armed {
            return Command::Ground;
        }
        let speed = self.speed_override.unwrap_or(self.cfg.limits.speed_mps);
        let lim = &self.cfg.limits;
        match self.nav {
            Nav::Idle => Command::Ground,
            Nav::Hold(p) => {
                if self.landed && p.u <= 0.0 {
                    Command::Ground
                } else {
                    Command::Goto {
                        e: p.e,
                        n: p.n,
                        u: p.u,
                        speed,
                        yaw_deg: Some(self.m.heading_deg),
                    }
                }
            }
            Nav::Takeoff(p) => Command::Goto {
                e: p.e,
                n: p.n,
                u: p.u,
                speed,
                yaw_deg: Some(self.m.heading_deg),
            },
            Nav::Goto { p, speed: s } => {
                if self.landed && self.cfg.flavour.is_copter() && p.u <= 0.0 {
                    return Command::Ground;
                }
                Command::Goto {
                    e: p.e,
                    n: p.n,
                    u: p.u,
                    speed: s.unwrap_or(speed),
                    yaw_deg: self.yaw_target_deg,
                }
            }
            Nav::Land { p, descending } => {
                if self.landed {
                    Command::Ground
                } else if descending {
                    let rate = if self.m.u > 10.0 {
                        lim.descent_mps
                    } else if self.m.u > 5.0 {
                        lim.land_mps + (lim.descent_mps - lim.land_mps) * (self.m.u - 5.0) / 5.0
                    } else {
                        lim.land_mps
                    };
                    Command::Descend {
                        e: p.e,
                        n: p.n,
                        rate,
                    }
                } else {
                    Command::Goto {
                        e: p.e,
                        n: p.n,
                        u: self.m.u,
                        speed,
                        yaw_deg: None,
                    }
                }
            }
            Nav::Rtl { phase, ret_u } => {
                let h = self.home_local();
                let (ee, en) = self.est();
                match phase {
                    RtlPhase::Climb => Command::Goto {
                        e: ee,
                        n: en,
                        u: ret_u,
                        speed,
                        yaw_deg: Some(self.m.heading_deg),
                    },
                    RtlPhase::Done if self.cfg.flavour.is_copter() => Command::Ground,
                    RtlPhase::Return | RtlPhase::Descend | RtlPhase::Loiter(_) | RtlPhase::Done => {
                        Command::Goto {
                            e: h.0,
                            n: h.1,
                            u: if self.cfg.flavour.is_copter() {
                                ret_u
                            } else {
                                0.0
                            },
                            speed: self.rtl_speed(),
                            yaw_deg: None,
                        }
                    }
                    RtlPhase::Land => {
                        if self.landed {
                            Command::Ground
                        } else {
                            let rate = if self.m.u > 10.0 {
                                lim.descent_mps
                            } else {
                                lim.land_mps
                            };
                            Command::Descend {
                                e: h.0,
                                n: h.1,
                                rate,
                            }
                        }
                    }
                }
            }
        }
    }

    fn rtl_speed(&self) -> f64 {
        // ArduCopter RTL_SPEED 0 = WPNAV_SPEED; PX4 RTL uses the cruise speed; rovers WP_SPEED
        self.cfg.limits.speed_mps
    }

    fn home_local(&self) -> (f64, f64) {
        self.home.map(|h| (h.e, h.n)).unwrap_or_else(|| self.est())
    }

    fn here(&self) -> Point {
        let (e, n) = self.est();
        Point { e, n, u: self.m.u }
    }

    fn drain_battery(&mut self) {
        let load = if !self.armed {
            0.01
        } else if self.cfg.flavour.kind == VehicleKind::Rover {
            0.05 + 0.95 * (self.m.ground_speed() / 1.0).min(2.0)
        } else if self.landed {
            0.1
        } else {
            let (wn, we) = self.wind_ne();
            let air = (self.m.ve - we).hypot(self.m.vn - wn);
            1.0 + 0.008 * air * air + 0.12 * self.m.vu.max(0.0) - 0.08 * (-self.m.vu).max(0.0)
        };
        if !self.charging {
            self.battery.drain(load, DT);
        }
        if self.battery.empty() && self.armed && !self.landed {
            // an empty pack: the vehicle comes down
            self.nav = Nav::Land {
                p: self.here(),
                descending: true,
            };
        }
    }

    // ------------------------------------------------------------------ modes

    fn run_mode(&mut self, now: Time) {
        match self.mode {
            Mode::Auto => self.run_mission(now),
            Mode::Takeoff => {
                if let Nav::Takeoff(p) = self.nav
                    && self.armed
                    && (self.m.u - p.u).abs() < 0.8
                {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Takeoff detected");
                    self.enter_mode(Mode::Hold, now);
                }
            }
            Mode::Rtl => self.run_rtl(now),
            Mode::Land => {
                if let Nav::Land { p, descending } = self.nav
                    && !descending
                {
                    let (e, n) = self.est();
                    if (p.e - e).hypot(p.n - n) < 1.0 {
                        self.nav = Nav::Land {
                            p,
                            descending: true,
                        };
                    }
                }
            }
            // PX4 offboard needs a setpoint stream (COM_OF_LOSS_T 1 s)
            Mode::Guided
                if self.cfg.flavour.autopilot == Autopilot::Px4
                    && self
                        .guided_target_at
                        .is_none_or(|t| now.saturating_since(t) > Duration::from_secs(1)) =>
            {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Failsafe activated: offboard control lost",
                );
                self.enter_mode(Mode::Hold, now);
            }
            _ => {}
        }
    }

    fn run_rtl(&mut self, now: Time) {
        let Nav::Rtl { phase, ret_u } = self.nav else {
            return;
        };
        let h = self.home_local();
        let (e, n) = self.est();
        let dist = (h.0 - e).hypot(h.1 - n);
        let copter = self.cfg.flavour.is_copter();
        let ap = self.cfg.flavour.is_ardupilot();
        let next = match phase {
            RtlPhase::Climb if !copter || self.m.u >= ret_u - 0.5 => Some(RtlPhase::Return),
            RtlPhase::Return
                if dist < if copter { 0.5 } else { 2.0 } && self.m.ground_speed() < 0.3 =>
            {
                if !copter {
                    if ap {
                        self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Reached destination");
                    }
                    Some(RtlPhase::Done)
                } else if ap {
                    // RTL_LOIT_TIME 5 s at RTL_ALT_FINAL 0 → land
                    Some(RtlPhase::Loiter(now + Duration::from_secs(5)))
                } else if self.m.u > 30.5 {
                    Some(RtlPhase::Descend)
                } else {
                    Some(RtlPhase::Land)
                }
            }
            RtlPhase::Descend if self.m.u <= 30.5 => Some(RtlPhase::Land),
            RtlPhase::Loiter(t) if now >= t => Some(RtlPhase::Land),
            _ => None,
        };
        if let Some(p) = next {
            let ret_u = if p == RtlPhase::Descend { 30.0 } else { ret_u };
            self.nav = Nav::Rtl { phase: p, ret_u };
        }
    }

    fn on_touchdown(&mut self, now: Time) {
        let ap = self.cfg.flavour.is_ardupilot();
        match self.mode {
            Mode::Land | Mode::Rtl => {
                if let Nav::Rtl { ret_u, .. } = self.nav {
                    self.nav = Nav::Rtl {
                        phase: RtlPhase::Done,
                        ret_u,
                    };
                }
                if ap {
                    self.disarm(now, "landed");
                }
            }
            Mode::Auto => {
                // the mission's LAND / RTL completes on touchdown (handled in run_mission)
            }
            _ => {}
        }
    }

    fn check_auto_disarm(&mut self, now: Time) {
        if !self.armed || self.cfg.flavour.kind == VehicleKind::Rover {
            return;
        }
        let ap = self.cfg.flavour.is_ardupilot();
        if self.landed {
            let since = self
                .landed_at
                .map(|t| t.max(self.armed_at))
                .unwrap_or(self.armed_at);
            let taking_off = matches!(self.nav, Nav::Takeoff(_))
                || (self.mode == Mode::Auto && self.exec.px4_takeoff.is_some())
                || (self.mode == Mode::Auto
                    && !self.exec.waiting_auto_armed
                    && self.exec.running
                    && self.current_item_is_takeoff());
            let limit = if self.took_off {
                // after a landing: ArduCopter disarms at once in LAND/RTL/AUTO (done on
                // touchdown), else after DISARM_DELAY; PX4 COM_DISARM_LAND 2 s
                if ap { 10.0 } else { 2.0 }
            } else {
                10.0 // DISARM_DELAY / COM_DISARM_PRFLT
            };
            if !taking_off && now.saturating_since(since).as_secs_f64() >= limit {
                let reason = if self.took_off {
                    "landing"
                } else {
                    "auto preflight disarming"
                };
                self.disarm(now, reason);
            }
        }
    }

    fn current_item_is_takeoff(&self) -> bool {
        self.exec
            .nav_index
            .and_then(|i| self.mission.items(MissionType::Mission).get(i as usize))
            .is_some_and(|it| it.command == 22)
    }

    fn check_failsafes(&mut self, now: Time) {
        let pct = self.battery.fraction() * 100.0;
        let fs = self.cfg.failsafe;
        let ap = self.cfg.flavour.is_ardupilot();
        if self.failsafe_level < 1 && pct <= fs.rtl_pct {
            self.failsafe_level = 1;
            if ap {
                let msg = format!(
                    "Battery 1 is low {:.2}V used {:.0} mAh",
                    self.battery.voltage(),
                    self.battery.consumed_mah
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_WARNING, &msg);
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Critical battery level! Executing RTL",
                );
            }
            if self.armed && !self.landed {
                if self.home.is_some() && self.enter_mode(Mode::Rtl, now) {
                    self.events
                        .push_back(VehicleEvent::BatteryFailsafe(Mode::Rtl));
                } else if self.cfg.flavour.is_copter() {
                    self.enter_mode(Mode::Land, now);
                    self.events
                        .push_back(VehicleEvent::BatteryFailsafe(Mode::Land));
                }
            }
        }
        if self.failsafe_level < 2 && pct <= fs.land_pct {
            self.failsafe_level = 2;
            if ap {
                let msg = format!(
                    "Battery 1 is critical {:.2}V used {:.0} mAh",
                    self.battery.voltage(),
                    self.battery.consumed_mah
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_EMERGENCY,
                    "Emergency battery level! Landing immediately",
                );
            }
            if self.armed && !self.landed && self.cfg.flavour.is_copter() && self.mode != Mode::Land
            {
                // already descending at home in RTL's landing phase: keep it
                let landing_home = matches!(
                    self.nav,
                    Nav::Rtl {
                        phase: RtlPhase::Land,
                        ..
                    }
                );
                if !landing_home {
                    self.enter_mode(Mode::Land, now);
                    self.events
                        .push_back(VehicleEvent::BatteryFailsafe(Mode::Land));
                }
            }
        }
        // PX4 data link loss (NAV_DLL_ACT = RTL after COM_DL_LOSS_T 10 s)
        if self.cfg.flavour.autopilot == Autopilot::Px4
            && self.cfg.px4_datalink_required
            && self.armed
            && !self.datalink_lost
            && self
                .last_gcs_heartbeat
                .is_some_and(|t| now.saturating_since(t) > self.gcs_link_loss_timeout())
        {
            self.datalink_lost = true;
            self.text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "Connection to ground station lost",
            );
            if !self.landed && self.mode != Mode::Rtl && self.mode != Mode::Land {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Failsafe activated: Return",
                );
                self.enter_mode(Mode::Rtl, now);
            }
        }
    }

    fn check_swap(&mut self, now: Time) {
        if self.armed || !self.landed {
            self.disarmed_landed_since = None;
            return;
        }
        let since = *self.disarmed_landed_since.get_or_insert(now);
        if let Some(s) = self.cfg.swap_after_s
            && self.battery.fraction() < 0.95
            && now.saturating_since(since).as_secs_f64() >= s
        {
            self.power_cycle(now, true);
        }
    }

    /// Switch mode as the autopilot would for an internal reason or a GCS request; returns
    /// whether the mode changed (or already was `mode`).
    fn enter_mode(&mut self, mode: Mode, now: Time) -> bool {
        let here = self.here();
        let copter = self.cfg.flavour.is_copter();
        match mode {
            Mode::Hold
            | Mode::Loiter
            | Mode::Brake
            | Mode::Stabilize
            | Mode::AltHold
            | Mode::Manual => {
                self.nav = if self.landed && copter {
                    Nav::Idle
                } else {
                    Nav::Hold(here)
                };
            }
            Mode::Guided => {
                self.nav = if self.landed && copter {
                    Nav::Idle
                } else {
                    Nav::Hold(here)
                };
            }
            Mode::Land => {
                self.nav = Nav::Land {
                    p: here,
                    descending: true,
                };
            }
            Mode::Rtl => {
                let ret_u = if !copter {
                    0.0
                } else if self.cfg.flavour.is_ardupilot() {
                    self.m.u.max(15.0) // RTL_ALT 15 m is a minimum
                } else {
                    let h = self.home_local();
                    let dist = (h.0 - here.e).hypot(h.1 - here.n);
                    // RTL_RETURN_ALT 60 m, RTL_DESCEND_ALT 30 m, RTL_CONE_ANG 45°
                    self.m.u.max(dist.clamp(30.0, 60.0))
                };
                let phase = if copter {
                    RtlPhase::Climb
                } else {
                    RtlPhase::Return
                };
                self.nav = Nav::Rtl { phase, ret_u };
            }
            Mode::Takeoff => {
                let alt = 2.5; // MIS_TAKEOFF_ALT
                self.nav = Nav::Takeoff(Point { u: alt, ..here });
            }
            Mode::Auto => {
                self.start_or_resume_mission(now);
            }
            Mode::Initialising => {}
        }
        if self.mode != mode {
            self.mode = mode;
            // entering a mode re-initialises the navigation speed (ArduCopter
            // wp_and_spline_init → WPNAV_SPEED; PX4 navigator reset_cruising_speed)
            self.speed_override = None;
            self.yaw_target_deg = None;
            if mode != Mode::Auto {
                self.exec.running = false;
                self.mission.set_mission_running(false);
            }
            let name = self.cfg.flavour.mode_name(mode);
            if self.cfg.flavour.is_ardupilot() {
                // ArduPilot announces mode changes only through the HEARTBEAT
                let _ = name;
            }
            self.send_heartbeat(now);
        }
        true
    }

    /// A GCS mode request (DO_SET_MODE / SET_MODE): MAV_RESULT as the autopilot gives it.
    fn set_mode_request(&mut self, base_mode: u8, custom_mode: u32, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let f = self.cfg.flavour;
        if base_mode & 1 == 0 {
            // only custom modes are supported by the simulator (PX4 maps a few base modes)
            return if f.is_ardupilot() {
                R::MAV_RESULT_FAILED
            } else {
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        }
        let Some(mode) = f.mode_from_custom(custom_mode) else {
            return if f.is_ardupilot() {
                R::MAV_RESULT_FAILED
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Unsupported auto mode",
                );
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        };
        match self.check_mode_allowed(mode, now) {
            Ok(()) => {
                if self.mode == mode && mode != Mode::Auto {
                    return R::MAV_RESULT_ACCEPTED;
                }
                self.enter_mode(mode, now);
                R::MAV_RESULT_ACCEPTED
            }
            Err(reason) => {
                if f.is_ardupilot() {
                    let msg = format!("Mode change to {} failed: {reason}", f.mode_name(mode));
                    self.text(mav::MavSeverity::MAV_SEVERITY_WARNING, &msg);
                    R::MAV_RESULT_FAILED
                } else {
                    let msg = format!(
                        "Switching to {} is currently not possible",
                        f.mode_name(mode)
                    );
                    self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                    R::MAV_RESULT_TEMPORARILY_REJECTED
                }
            }
        }
    }

    fn check_mode_allowed(&mut self, mode: Mode, now: Time) -> Result<(), &'static str> {
        let f = self.cfg.flavour;
        // ArduPilot checks a mode's position requirement only when armed ("allow switching to
        // any mode if disarmed. We rely on the arming check": `ignore_checks =
        // !motors->armed()` in Copter::set_mode, the same in Rover's Mode::enter); PX4's
        // commander refuses such a mode disarmed too.
        let ignore_checks = f.is_ardupilot() && !self.armed;
        if mode.requires_position() && !ignore_checks && !self.position_ok(now) {
            return Err("requires position");
        }
        match (f.autopilot, mode) {
            (Autopilot::ArduPilot, Mode::Auto) => {
                let n = self.mission.items(MissionType::Mission).len();
                if n <= 1 {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_WARNING,
                        "AutoMode: Mission is empty",
                    );
                    return Err("init failed");
                }
                if f.is_copter() && self.armed && self.landed && !self.mission_starts_with_takeoff()
                {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_WARNING,
                        "Auto: Missing Takeoff Cmd",
                    );
                    return Err("init failed");
                }
                Ok(())
            }
            (Autopilot::ArduPilot, Mode::Rtl | Mode::Land) if self.landed && !self.armed => Ok(()),
            (Autopilot::Px4, Mode::Auto) => {
                if self.mission.items(MissionType::Mission).is_empty() || !self.mission_valid {
                    return Err("no valid mission");
                }
                Ok(())
            }
            (Autopilot::Px4, Mode::Guided) => {
                if self
                    .guided_target_at
                    .is_none_or(|t| now.saturating_since(t) > Duration::from_millis(500))
                {
                    return Err("no offboard signal");
                }
                Ok(())
            }
            (Autopilot::Px4, Mode::Rtl) if self.home.is_none() => Err("no home"),
            _ => Ok(()),
        }
    }

    fn mission_starts_with_takeoff(&self) -> bool {
        // AP_Mission::starts_with_takeoff_cmd: next nav command from the resume point (or 1)
        let items = self.mission.items(MissionType::Mission);
        let start = self
            .exec
            .nav_index
            .filter(|_| !self.exec.complete)
            .unwrap_or(1) as usize;
        for it in items.iter().skip(start).take(16) {
            match it.command {
                22 | 84 => return true,
                93 | 218 => continue,
                c if c <= 95 => return false,
                _ => continue,
            }
        }
        false
    }

    // ------------------------------------------------------------------ arming

    /// PX4's COM_DL_LOSS_T (10 s) in simulated time: how long without a GCS heartbeat the
    /// connection counts as lost (arming refused, data-link-loss failsafe), scaled by
    /// [`VehicleConfig::gcs_time_scale`] (non-finite or non-positive scales count as 1).
    fn gcs_link_loss_timeout(&self) -> Duration {
        let k = self.cfg.gcs_time_scale;
        let k = if k.is_finite() && k > 0.0 { k } else { 1.0 };
        Duration::from_secs_f64((PX4_DL_LOSS_S * k).min(1.0e9))
    }

    fn prearm_failure(&self, now: Time) -> Option<&'static str> {
        let f = self.cfg.flavour;
        match f.autopilot {
            Autopilot::ArduPilot => {
                if !self.gps_fix(now) {
                    Some("PreArm: GPS 1: Bad fix")
                } else if !self.position_ok(now) {
                    if f.is_copter() {
                        Some("PreArm: Need Position Estimate")
                    } else {
                        Some("PreArm: AHRS: waiting for home")
                    }
                } else if self.battery.fraction() * 100.0 <= self.cfg.failsafe.rtl_pct {
                    Some("PreArm: Battery 1 below minimum arming capacity")
                } else {
                    None
                }
            }
            Autopilot::Px4 => {
                if self.cfg.px4_datalink_required
                    && self
                        .last_gcs_heartbeat
                        .is_none_or(|t| now.saturating_since(t) > self.gcs_link_loss_timeout())
                {
                    Some("Preflight Fail: No connection to the GCS")
                } else if !self.gps_fix(now) || !self.position_ok(now) {
                    Some("Preflight Fail: No valid global position estimate")
                } else if self.battery.fraction() * 100.0 <= self.cfg.failsafe.rtl_pct {
                    Some("Preflight Fail: low battery")
                } else {
                    None
                }
            }
        }
    }

    /// Try to arm; Err(result) with the MAV_RESULT the autopilot gives.
    fn arm(&mut self, now: Time, forced: bool) -> Result<(), mav::MavResult> {
        let ap = self.cfg.flavour.is_ardupilot();
        if self.armed {
            return Ok(());
        }
        if !forced && let Some(msg) = self.prearm_failure(now) {
            self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, msg);
            if !ap {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Arming denied: Resolve system health failures first",
                );
            }
            return Err(if ap {
                mav::MavResult::MAV_RESULT_FAILED
            } else {
                mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED
            });
        }
        if self.cfg.flavour.is_copter() && ap && !self.mode_can_arm(self.mode) {
            self.text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "Arm: Mode not armable",
            );
            return Err(mav::MavResult::MAV_RESULT_FAILED);
        }
        self.armed = true;
        self.armed_at = now;
        self.took_off = false;
        // a battery failsafe stays latched until the next boot (as ArduPilot's and PX4's do)
        self.disarmed_landed_since = None;
        // home moves to where the vehicle arms (ArduPilot unless locked; PX4 COM_HOME_EN)
        if self.position_ok(now) {
            self.set_home_here(now);
        }
        if ap {
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Arming motors");
        } else {
            self.text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Armed by external command",
            );
        }
        self.events.push_back(VehicleEvent::Armed(true));
        // modes that start moving when armed
        match self.mode {
            Mode::Auto if !ap => self.start_or_resume_mission(now),
            Mode::Takeoff => {
                let h = self.here();
                if let Nav::Takeoff(p) = self.nav {
                    self.nav = Nav::Takeoff(Point {
                        e: h.e,
                        n: h.n,
                        u: p.u,
                    });
                } else {
                    self.nav = Nav::Takeoff(Point { u: 2.5, ..h });
                }
            }
            Mode::Auto if !self.cfg.flavour.is_copter() => self.start_or_resume_mission(now),
            Mode::Auto => {
                // ArduCopter: armed in AUTO on the ground waits for MISSION_START (no throttle)
                self.exec.waiting_auto_armed = true;
            }
            Mode::Hold | Mode::Guided | Mode::Loiter if !self.cfg.flavour.is_copter() => {
                self.nav = Nav::Hold(self.here());
            }
            _ => {}
        }
        self.send_heartbeat(now);
        Ok(())
    }

    fn mode_can_arm(&self, mode: Mode) -> bool {
        !matches!(mode, Mode::Rtl | Mode::Land | Mode::Brake)
    }

    fn disarm(&mut self, now: Time, reason: &str) {
        if !self.armed {
            return;
        }
        self.armed = false;
        self.nav = Nav::Idle;
        self.exec.waiting_auto_armed = false;
        self.disarmed_landed_since = Some(now);
        if self.cfg.flavour.is_ardupilot() {
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Disarming motors");
        } else {
            let msg = format!("Disarmed by {reason}");
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
        }
        if self.mode == Mode::Auto {
            self.exec.running = false;
            self.mission.set_mission_running(false);
        }
        self.events.push_back(VehicleEvent::Armed(false));
        self.send_heartbeat(now);
    }

    fn set_home_here(&mut self, now: Time) {
        let (lat, lon, _) = self.reported_position();
        let (e, n) = self.est();
        let alt = self.ground_amsl() + self.m.u;
        self.home = Some(Home {
            lat,
            lon,
            alt_amsl: alt,
            e,
            n,
        });
        self.mission.set_home(Some(HomeItem {
            lat_e7: (lat * 1e7).round() as i32,
            lon_e7: (lon * 1e7).round() as i32,
            alt_amsl_m: alt as f32,
        }));
        self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
    }

    // ------------------------------------------------------------------ mission execution

    /// Rebuild the geofence from the stored fence list; PX4 also re-checks the mission
    /// against it (MissionFeasibilityChecker::checkGeofence) and says which item violates it.
    fn rebuild_fence(&mut self, report: bool) {
        self.fence = Fence::from_items(self.mission.items(MissionType::Fence), self.cfg.reference);
        self.mission_valid = true;
        if self.cfg.flavour.autopilot == Autopilot::Px4 && !self.fence.is_empty() {
            let bad = self
                .mission
                .items(MissionType::Mission)
                .iter()
                .position(|it| {
                    matches!(it.frame, 0 | 3 | 5 | 6)
                        && it.has_position()
                        && (it.x != 0 || it.y != 0)
                        && {
                            let (n, e) = local::delta(
                                self.cfg.reference.0,
                                self.cfg.reference.1,
                                it.lat(),
                                it.lon(),
                            );
                            self.fence.breached(e, n)
                        }
                });
            if let Some(i) = bad {
                self.mission_valid = false;
                if report {
                    let msg = format!("Geofence violation for waypoint {}", i + 1);
                    self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                }
            }
        }
    }

    fn check_fence(&mut self, now: Time) {
        if !self.fence_enabled || self.fence.is_empty() || !self.armed || self.landed {
            self.fence_breached = false;
            return;
        }
        let (e, n) = self.est();
        let breached = self.fence.breached(e, n);
        if breached && !self.fence_breached {
            self.events.push_back(VehicleEvent::FenceBreached {
                truth: (self.m.e, self.m.n, self.m.u),
                estimate: (e, n),
                mode: self.mode,
            });
            if self.cfg.flavour.is_ardupilot() {
                // FENCE_ACTION 1: RTL, or land when RTL is impossible
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, "Fence Breached");
                if !matches!(self.mode, Mode::Rtl | Mode::Land) {
                    if self.home.is_some() {
                        self.enter_mode(Mode::Rtl, now);
                    } else if self.cfg.flavour.is_copter() {
                        self.enter_mode(Mode::Land, now);
                    }
                }
            } else {
                // GF_ACTION 2: Hold
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Geofence breached, holding",
                );
                if !matches!(self.mode, Mode::Rtl | Mode::Land | Mode::Hold) {
                    self.enter_mode(Mode::Hold, now);
                }
            }
        }
        self.fence_breached = breached;
    }

    fn drain_mission_events(&mut self, now: Time) {
        while let Some(ev) = self.mission.poll_event() {
            match ev {
                MissionEvent::Uploaded {
                    mission_type: MissionType::Fence,
                    ..
                }
                | MissionEvent::Cleared {
                    mission_type: MissionType::Fence,
                } => self.rebuild_fence(true),
                MissionEvent::SetCurrent { seq } => self.set_current_item(seq, now),
                MissionEvent::Uploaded {
                    mission_type: MissionType::Mission,
                    ..
                }
                | MissionEvent::Cleared {
                    mission_type: MissionType::Mission,
                } => {
                    self.rebuild_fence(true);
                    if self.cfg.flavour.autopilot == Autopilot::Px4 {
                        // navigator reloads the new mission from its current item
                        self.exec.nav_index = None;
                        self.exec.nav_started = false;
                        self.exec.complete = false;
                        self.exec.jumps.clear();
                        if self.mode == Mode::Auto && self.armed {
                            self.start_or_resume_mission(now);
                        }
                    }
                    self.send_mission_current(now);
                }
                _ => {}
            }
        }
    }

    fn set_current_item(&mut self, seq: u16, now: Time) {
        self.exec.nav_index = Some(seq);
        self.exec.nav_started = false;
        self.exec.nav_arrived = None;
        self.exec.complete = false;
        if seq <= 1 {
            self.exec.jumps.clear();
        }
        self.mission.set_current(seq);
        self.send_mission_current(now);
    }

    fn start_or_resume_mission(&mut self, now: Time) {
        let first = match self.cfg.flavour.autopilot {
            Autopilot::ArduPilot => 1,
            Autopilot::Px4 => 0,
        };
        if self.exec.complete || self.exec.nav_index.is_none() {
            self.exec.nav_index = Some(self.mission.current().max(first));
            if self.exec.complete {
                self.exec.nav_index = Some(first);
                self.exec.jumps.clear();
            }
            self.exec.complete = false;
        }
        self.exec.running = true;
        self.exec.nav_started = false;
        self.exec.nav_arrived = None;
        self.exec.waiting_auto_armed = false;
        self.exec.px4_takeoff = None;
        self.exec.px4_takeoff_target = None;
        self.mission.set_mission_running(true);
        if let Some(i) = self.exec.nav_index {
            self.mission.set_current(i);
        }
        self.send_mission_current(now);
    }

    fn item_point(&self, it: &MissionItem) -> Point {
        let (mut e, mut n) = self.est();
        if it.x != 0 || it.y != 0 {
            let (dn, de) = local::delta(
                self.cfg.reference.0,
                self.cfg.reference.1,
                f64::from(it.x) * 1e-7,
                f64::from(it.y) * 1e-7,
            );
            e = de;
            n = dn;
        }
        let u = match it.frame {
            0 | 5 => f64::from(it.z) - self.ground_amsl(),
            _ => f64::from(it.z),
        };
        let u = if self.cfg.flavour.is_copter() {
            u.max(0.0)
        } else {
            0.0
        };
        Point { e, n, u }
    }

    fn run_mission(&mut self, now: Time) {
        if !self.exec.running || self.exec.complete || !self.armed || self.exec.waiting_auto_armed {
            if self.exec.complete && !self.armed && self.landed {
                self.nav = Nav::Idle;
            }
            return;
        }
        let mut guard = 0;
        loop {
            guard += 1;
            if guard > 300 {
                // a loop of items that never navigate (e.g. jumps only)
                self.mission_complete(now);
                return;
            }
            let Some(idx) = self.exec.nav_index else {
                self.mission_complete(now);
                return;
            };
            let items = self.mission.items(MissionType::Mission);
            let Some(item) = items.get(idx as usize).copied() else {
                self.mission_complete(now);
                return;
            };
            if is_nav(item.command) {
                if !self.exec.nav_started {
                    if !self.start_nav(idx, &item, now) {
                        // unsupported: skip (AP_Mission advances; PX4 skips)
                        self.advance_item(idx, &item, false, now);
                        continue;
                    }
                    self.exec.nav_started = true;
                }
                if self.verify_nav(&item, now) {
                    self.nav_done(idx, &item, now);
                    continue;
                }
                return;
            }
            // do-commands
            if item.command == 177 {
                // DO_JUMP
                self.do_jump(idx, &item, now);
                continue;
            }
            self.do_command(&item, now);
            let reached = match self.cfg.flavour.autopilot {
                // ArduCopter verify_command acknowledges DO_CHANGE_SPEED / DO_SET_HOME; the
                // camera commands are verified inside AP_Mission without a message
                Autopilot::ArduPilot => matches!(item.command, 178 | 179),
                Autopilot::Px4 => true,
            };
            self.advance_item(idx, &item, reached, now);
        }
    }

    fn advance_item(&mut self, idx: u16, _item: &MissionItem, reached: bool, now: Time) {
        if reached {
            self.item_reached(idx, now);
        }
        self.exec.nav_index = Some(idx + 1);
        self.exec.nav_started = false;
        self.exec.nav_arrived = None;
        let n = self.mission.items(MissionType::Mission).len() as u16;
        if idx + 1 < n {
            self.mission.set_current(idx + 1);
            // MISSION_CURRENT follows the nav command (ArduPilot) / every item (PX4)
            let next_is_nav = self
                .mission
                .items(MissionType::Mission)
                .get(usize::from(idx + 1))
                .is_some_and(|it| is_nav(it.command));
            if next_is_nav || self.cfg.flavour.autopilot == Autopilot::Px4 {
                self.send_mission_current(now);
            }
        }
    }

    fn do_jump(&mut self, idx: u16, item: &MissionItem, now: Time) {
        let target = item.param1 as i64;
        let repeat = item.param2 as i32;
        let n = self.mission.items(MissionType::Mission).len() as i64;
        let first = if self.cfg.flavour.is_ardupilot() {
            1
        } else {
            0
        };
        if target < first || target >= n {
            self.advance_item(idx, item, false, now);
            return;
        }
        // Jumps are followed while looking for the next item and are never "reached"
        // themselves: AP_Mission::get_next_cmd, PX4 Mission::read_mission_item (which instead
        // re-sends the DO_JUMP item with its new counter when it changes).
        let done = self.exec.jumps.entry(idx).or_insert(0);
        if repeat < 0 || *done < repeat {
            *done += 1;
            self.exec.nav_index = Some(target as u16);
            self.exec.nav_started = false;
            self.exec.nav_arrived = None;
            self.mission.set_current(target as u16);
            self.send_mission_current(now);
        } else {
            self.advance_item(idx, item, false, now);
        }
    }

    fn do_command(&mut self, item: &MissionItem, now: Time) {
        match item.command {
            178 => {
                // DO_CHANGE_SPEED: param2 speed m/s (≤ 0 keeps), -2 = default (PX4)
                if item.param2 > 0.0 {
                    self.speed_override = Some(f64::from(item.param2));
                } else if item.param2 <= -2.0 {
                    self.speed_override = None;
                }
            }
            // DO_DIGICAM_CONTROL: shooting command in param5 (x)
            203 if item.x == 1 => {
                if let Some(c) = self.camera.as_mut() {
                    c.trigger();
                }
            }
            206 => {
                let pos = (self.m.e, self.m.n);
                if let Some(c) = self.camera.as_mut() {
                    c.set_trigger_distance(f64::from(item.param1), pos);
                    if item.param3 >= 1.0 {
                        c.trigger();
                    }
                }
            }
            2000 => {
                if let Some(c) = self.camera.as_mut() {
                    c.start_capture(f64::from(item.param2), item.param3.max(0.0) as u32, now);
                }
            }
            2001 => {
                if let Some(c) = self.camera.as_mut() {
                    c.stop_capture();
                }
            }
            179 if item.param1 >= 0.5 => self.set_home_here(now),
            _ => {}
        }
    }

    fn start_nav(&mut self, idx: u16, item: &MissionItem, now: Time) -> bool {
        let copter = self.cfg.flavour.is_copter();
        let px4 = self.cfg.flavour.autopilot == Autopilot::Px4;
        let p = self.item_point(item);
        self.exec.nav_arrived = None;
        if self.cfg.flavour.is_ardupilot() {
            let msg = format!("Mission: {} {}", idx, cmd_name(item.command));
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
        }
        match item.command {
            22 => {
                if !copter {
                    // rovers: a takeoff is a no-op (ArduRover skips it)
                    return false;
                }
                let here = self.here();
                let u = if px4 && !matches!(item.frame, 3 | 6 | 10 | 11) {
                    p.u
                } else {
                    f64::from(item.z).max(0.0)
                };
                if px4 {
                    // PX4 (navigator/mission.cpp): a take-off item is flown as a waypoint to its
                    // own position — at once when the copter is already in the air ("treat it
                    // as waypoint"), after the climb from the ground. An item without a
                    // position means latitude/longitude 0, 0: PX4 1.16 SITL never reached it
                    // and hovered at the take-off altitude, the mission stuck at item 0.
                    let target = (item.x != 0 || item.y != 0).then_some(Point { u, ..p });
                    self.exec.px4_takeoff_target = Some(target);
                    self.exec.nav_point = target;
                    self.nav = if self.landed {
                        Nav::Takeoff(Point { u, ..here })
                    } else {
                        match target {
                            Some(p) => Nav::Goto { p, speed: None },
                            None => Nav::Hold(Point { u, ..here }),
                        }
                    };
                    return true;
                }
                self.nav = Nav::Takeoff(Point { u, ..here });
                self.exec.nav_point = Some(Point { u, ..here });
            }
            16 | 19 | 17 | 82 => {
                if px4 && self.landed && copter && !matches!(self.nav, Nav::Takeoff(_)) {
                    // PX4 navigator: vertical takeoff to the item's altitude first
                    self.exec.px4_takeoff = Some(p.u.max(2.5));
                    let here = self.here();
                    self.nav = Nav::Takeoff(Point {
                        u: p.u.max(2.5),
                        ..here
                    });
                } else {
                    self.nav = Nav::Goto { p, speed: None };
                }
                self.exec.nav_point = Some(p);
            }
            21 => {
                if !copter {
                    return false;
                }
                let p = if item.x == 0 && item.y == 0 {
                    self.here()
                } else {
                    p
                };
                self.nav = Nav::Land {
                    p,
                    descending: false,
                };
                self.exec.nav_point = Some(p);
            }
            20 => {
                let ret_u = if copter {
                    if px4 {
                        self.m.u.max(30.0)
                    } else {
                        self.m.u.max(15.0)
                    }
                } else {
                    0.0
                };
                self.nav = Nav::Rtl {
                    phase: if copter {
                        RtlPhase::Climb
                    } else {
                        RtlPhase::Return
                    },
                    ret_u,
                };
            }
            93 => {
                // NAV_DELAY: hold here for param1 seconds
                self.nav = Nav::Hold(self.here());
                self.exec.nav_arrived = Some(now);
            }
            _ => return false,
        }
        true
    }

    fn verify_nav(&mut self, item: &MissionItem, now: Time) -> bool {
        let copter = self.cfg.flavour.is_copter();
        let px4 = self.cfg.flavour.autopilot == Autopilot::Px4;
        match item.command {
            22 if px4 && copter => {
                let Some(target) = self.exec.px4_takeoff_target else {
                    return true;
                };
                if let Nav::Takeoff(p) = self.nav {
                    if self.m.u < p.u - 0.8 {
                        return false;
                    }
                    // Climbed: on to the item's position (or hover, without one).
                    self.nav = match target {
                        Some(t) => Nav::Goto { p: t, speed: None },
                        None => Nav::Hold(p),
                    };
                }
                let Some(t) = target else {
                    return false;
                };
                let (e, n) = self.est();
                (t.e - e).hypot(t.n - n) <= 2.0 && (self.m.u - t.u).abs() < 0.8
            }
            22 => match self.nav {
                Nav::Takeoff(p) => self.m.u >= p.u - 0.3,
                _ => true,
            },
            16 | 19 | 17 | 82 => {
                if let Some(alt) = self.exec.px4_takeoff {
                    if self.m.u >= alt - 0.8 {
                        self.exec.px4_takeoff = None;
                        if let Some(p) = self.exec.nav_point {
                            self.nav = Nav::Goto { p, speed: None };
                        }
                    }
                    return false;
                }
                let Some(p) = self.exec.nav_point else {
                    return true;
                };
                let (e, n) = self.est();
                let dist = (p.e - e).hypot(p.n - n);
                let radius = if px4 {
                    if item.command == 16 && item.param2 > 0.0 {
                        f64::from(item.param2)
                    } else {
                        2.0 // NAV_ACC_RAD
                    }
                } else if copter {
                    // ArduCopter SCurves: reached when the target is reached and the vehicle
                    // is close (WPNAV_RADIUS 2 m is the blend radius, not the acceptance)
                    0.3
                } else {
                    2.0 // WP_RADIUS
                };
                let vert_ok = !copter || (self.m.u - p.u).abs() < if px4 { 0.8 } else { 0.3 };
                let arrived =
                    dist <= radius && vert_ok && (px4 || !copter || self.m.ground_speed() < 0.5);
                if self.exec.nav_arrived.is_none() {
                    if !arrived {
                        return false;
                    }
                    self.exec.nav_arrived = Some(now);
                    let hold = self.hold_time(item);
                    if self.cfg.flavour.is_ardupilot() && hold > 0.0 {
                        // verify_nav_wp sends the reached message on arrival when there is a delay
                        if let Some(i) = self.exec.nav_index {
                            self.send_item_reached_msg(i);
                        }
                    }
                    // hold at the waypoint during the delay
                    self.nav = Nav::Hold(p);
                }
                let hold = self.hold_time(item);
                now.saturating_since(self.exec.nav_arrived.unwrap_or(now))
                    .as_secs_f64()
                    >= hold
            }
            21 => {
                if let Nav::Land { p, descending } = self.nav
                    && !descending
                {
                    let (e, n) = self.est();
                    if (p.e - e).hypot(p.n - n) < 1.0 {
                        self.nav = Nav::Land {
                            p,
                            descending: true,
                        };
                    }
                }
                self.landed && self.took_off
            }
            20 => {
                self.run_rtl(now);
                if !copter {
                    return matches!(
                        self.nav,
                        Nav::Rtl {
                            phase: RtlPhase::Done,
                            ..
                        }
                    );
                }
                self.landed && self.took_off
            }
            93 => {
                now.saturating_since(self.exec.nav_arrived.unwrap_or(now))
                    .as_secs_f64()
                    >= f64::from(item.param1.max(0.0))
            }
            _ => true,
        }
    }

    fn hold_time(&self, item: &MissionItem) -> f64 {
        match item.command {
            16 => f64::from(item.param1.max(0.0)),
            19 => f64::from(item.param1.max(0.0)),
            17 => f64::INFINITY,
            _ => 0.0,
        }
    }

    fn nav_done(&mut self, idx: u16, item: &MissionItem, now: Time) {
        let ap = self.cfg.flavour.is_ardupilot();
        let arrived_msg_already = ap && item.command == 16 && self.hold_time(item) > 0.0;
        if ap && item.command == 16 {
            let msg = format!("Reached command #{idx}");
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
        }
        if !arrived_msg_already {
            self.item_reached(idx, now);
        }
        // keep holding where the item ended until the next nav command starts
        if !self.landed {
            self.nav = Nav::Hold(
                self.exec
                    .nav_point
                    .filter(|_| item.command != 20)
                    .unwrap_or(self.here()),
            );
        }
        if (item.command == 21 || item.command == 20) && self.landed {
            self.advance_item(idx, item, false, now);
            self.mission_complete(now);
            return;
        }
        self.advance_item(idx, item, false, now);
    }

    fn item_reached(&mut self, idx: u16, now: Time) {
        self.send_item_reached_msg(idx);
        if self.cfg.flavour.autopilot == Autopilot::Px4 {
            self.exec.reached = Some((idx, 0, now + Duration::from_secs(1)));
        }
    }

    fn send_item_reached_msg(&mut self, idx: u16) {
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::MISSION_ITEM_REACHED(mav::MISSION_ITEM_REACHED_DATA { seq: idx }),
        );
    }

    fn update_mission_reached(&mut self, now: Time) {
        // PX4 mavlink_mission.cpp: resend the last reached item 10 times at 1 Hz
        if let Some((idx, count, next)) = self.exec.reached
            && now >= next
        {
            if count >= 10 {
                self.exec.reached = None;
            } else {
                self.send_item_reached_msg(idx);
                self.exec.reached = Some((idx, count + 1, next + Duration::from_secs(1)));
            }
        }
    }

    fn mission_complete(&mut self, now: Time) {
        self.exec.complete = true;
        self.exec.running = false;
        self.mission.set_mission_running(false);
        let px4 = self.cfg.flavour.autopilot == Autopilot::Px4;
        if self.landed {
            if self.armed {
                if px4 {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_INFO,
                        "Mission finished, landed",
                    );
                }
                if self.cfg.flavour.is_copter() {
                    self.disarm(now, "landing");
                } else {
                    self.nav = Nav::Hold(self.here());
                }
            }
        } else {
            if px4 {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_INFO,
                    "Mission finished, loitering",
                );
            }
            self.nav = Nav::Hold(self.here());
        }
        self.send_mission_current(now);
    }

    // ------------------------------------------------------------------ camera

    fn update_camera(&mut self, now: Time) {
        if self.camera.is_none() {
            return;
        }
        let (lat, lon, u) = self.true_position();
        let (rlat, rlon, ru) = self.reported_position();
        let ctx = CaptureContext {
            true_pose: CameraPose {
                lat,
                lon,
                alt_agl_m: u,
                heading_deg: self.m.heading_deg,
                roll_deg: self.m.roll_deg,
                pitch_deg: self.m.pitch_deg,
            },
            reported: (rlat, rlon, ru),
            alt_amsl_m: self.ground_amsl() + ru,
            time_boot_ms: self.time_boot_ms(now),
            now,
            world_t_s: now.as_secs_f64(),
        };
        let pos = (self.m.e, self.m.n);
        if self.world.is_none() {
            // no world file: the camera sees plain grass
            self.world = Some(Arc::new(World::flat(
                crate::sim::world::Surface::Grass,
                self.cfg.reference,
                self.cfg.ground_alt_amsl_m,
            )));
        }
        let world = self.world.clone();
        if let Some(c) = self.camera.as_mut() {
            c.update(&ctx, pos, world.as_deref());
        }
    }

    // ------------------------------------------------------------------ commands

    fn ack(&mut self, to: (u8, u8), command: mav::MavCmd, result: mav::MavResult) {
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
                command,
                result,
                progress: 0,
                result_param2: 0,
                target_system: to.0,
                target_component: to.1,
            }),
        );
    }

    fn command_long(&mut self, from: (u8, u8), c: &mav::COMMAND_LONG_DATA, now: Time) {
        // COMMAND_LONG → COMMAND_INT the way ArduPilot converts it
        // (GCS_Common.cpp convert_COMMAND_LONG_to_COMMAND_INT / command_long_stores_location)
        let cmd = c.command as u16;
        let stores_location = matches!(cmd, 179 | 201 | 195 | 192 | 43003);
        let (x, y) = if stores_location {
            (
                (f64::from(c.param5) * 1e7) as i32,
                (f64::from(c.param6) * 1e7) as i32,
            )
        } else {
            (
                if c.param5.is_nan() {
                    0
                } else {
                    c.param5 as i32
                },
                if c.param6.is_nan() {
                    0
                } else {
                    c.param6 as i32
                },
            )
        };
        // ArduPilot: mav_frame_for_command_long (takeoff altitudes are relative); PX4 reads
        // COMMAND_LONG position altitudes (takeoff, reposition) as AMSL
        let frame = match (self.cfg.flavour.autopilot, cmd) {
            (Autopilot::ArduPilot, 22 | 84 | 195 | 201) => {
                mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            }
            _ => mav::MavFrame::MAV_FRAME_GLOBAL,
        };
        let ci = mav::COMMAND_INT_DATA {
            param1: c.param1,
            param2: c.param2,
            param3: c.param3,
            param4: c.param4,
            x,
            y,
            z: c.param7,
            command: c.command,
            target_system: c.target_system,
            target_component: c.target_component,
            frame,
            current: 0,
            autocontinue: 0,
        };
        // PX4 keeps COMMAND_LONG's float lat/lon (NaN = current position)
        let nan_pos = c.param5.is_nan() || c.param6.is_nan();
        self.command(from, &ci, true, nan_pos, now);
    }

    fn command_int(&mut self, from: (u8, u8), c: &mav::COMMAND_INT_DATA, now: Time) {
        self.command(from, c, false, false, now);
    }

    fn command(
        &mut self,
        from: (u8, u8),
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
        now: Time,
    ) {
        use mav::MavResult as R;
        let cmd = c.command as u16;
        let to_camera = c.target_component == CAMERA_COMPID;
        if to_camera {
            self.camera_command(from, c, now);
            return;
        }
        if c.target_component != AUTOPILOT_COMPID && c.target_component != 0 {
            return;
        }
        let ap = self.cfg.flavour.is_ardupilot();
        let copter = self.cfg.flavour.is_copter();
        let result = match cmd {
            400 => {
                // COMPONENT_ARM_DISARM; 21196 in param2 forces
                let forced = (c.param2 - 21196.0).abs() < 0.5;
                if c.param1 > 0.5 {
                    match self.arm(now, forced) {
                        Ok(()) => R::MAV_RESULT_ACCEPTED,
                        Err(r) => r,
                    }
                } else if !self.armed {
                    R::MAV_RESULT_ACCEPTED
                } else if !self.landed && !forced && copter {
                    if ap {
                        R::MAV_RESULT_FAILED
                    } else {
                        self.text(
                            mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                            "Disarming denied: not landed",
                        );
                        R::MAV_RESULT_TEMPORARILY_REJECTED
                    }
                } else {
                    self.disarm(now, "external command");
                    R::MAV_RESULT_ACCEPTED
                }
            }
            176 => {
                // DO_SET_MODE: ArduPilot custom_mode = param2; PX4 main = param2, sub = param3
                let custom = if ap {
                    c.param2 as u32
                } else {
                    ((c.param2 as u32) << 16) | ((c.param3 as u32) << 24)
                };
                let custom = if !ap && (c.param2 as u32) == 4 && (c.param3 as u32) == 0 {
                    (4 << 16) | (4 << 24) // AUTO without sub mode = mission
                } else {
                    custom
                };
                self.set_mode_request(c.param1 as u8, custom, now)
            }
            22 => self.cmd_takeoff(c, now),
            21 => {
                if !copter {
                    R::MAV_RESULT_UNSUPPORTED
                } else if ap {
                    if self.check_mode_allowed(Mode::Land, now).is_ok() {
                        self.enter_mode(Mode::Land, now);
                        R::MAV_RESULT_ACCEPTED
                    } else {
                        R::MAV_RESULT_FAILED
                    }
                } else {
                    self.enter_mode(Mode::Land, now);
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_INFO,
                        "Landing at current position",
                    );
                    R::MAV_RESULT_ACCEPTED
                }
            }
            20 => match self.check_mode_allowed(Mode::Rtl, now) {
                Ok(()) => {
                    self.enter_mode(Mode::Rtl, now);
                    if !ap {
                        self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Returning to launch");
                    }
                    R::MAV_RESULT_ACCEPTED
                }
                Err(_) => {
                    if ap {
                        R::MAV_RESULT_FAILED
                    } else {
                        R::MAV_RESULT_TEMPORARILY_REJECTED
                    }
                }
            },
            17 if ap => {
                let m = if copter { Mode::Hold } else { Mode::Loiter };
                match self.check_mode_allowed(m, now) {
                    Ok(()) => {
                        self.enter_mode(m, now);
                        R::MAV_RESULT_ACCEPTED
                    }
                    Err(_) => R::MAV_RESULT_FAILED,
                }
            }
            300 => self.cmd_mission_start(c, now),
            192 => self.cmd_reposition(c, long, nan_pos, now),
            115 if ap && copter => self.cmd_condition_yaw(c),
            178 => {
                if c.param2 <= 0.0 {
                    if ap {
                        R::MAV_RESULT_DENIED
                    } else {
                        R::MAV_RESULT_ACCEPTED
                    }
                } else {
                    self.speed_override = Some(f64::from(c.param2));
                    R::MAV_RESULT_ACCEPTED
                }
            }
            224 => {
                // DO_SET_MISSION_CURRENT
                let seq = c.param1 as i64;
                let n = self.mission.items(MissionType::Mission).len() as i64;
                if seq >= 0 && seq < n {
                    self.set_current_item(seq.max(if ap { 1 } else { 0 }) as u16, now);
                    if c.param2 > 0.5 {
                        self.exec.jumps.clear();
                    }
                    R::MAV_RESULT_ACCEPTED
                } else if ap {
                    R::MAV_RESULT_FAILED
                } else {
                    R::MAV_RESULT_DENIED
                }
            }
            207 if ap => {
                // DO_FENCE_ENABLE: 0 disable, 1 enable, 2 disable the floor only
                match c.param1 as i32 {
                    0 => {
                        self.fence_enabled = false;
                        R::MAV_RESULT_ACCEPTED
                    }
                    1 => {
                        self.fence_enabled = true;
                        R::MAV_RESULT_ACCEPTED
                    }
                    2 => R::MAV_RESULT_ACCEPTED,
                    _ => R::MAV_RESULT_FAILED,
                }
            }
            511 => self.cmd_message_interval(c.param1 as u32, c.param2, now),
            512 => self.cmd_request_message(c.param1 as u32, now),
            410 => {
                if self.home.is_some() {
                    self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
                    R::MAV_RESULT_ACCEPTED
                } else {
                    R::MAV_RESULT_FAILED
                }
            }
            520 => {
                self.queue(AUTOPILOT_COMPID, self.autopilot_version_msg());
                R::MAV_RESULT_ACCEPTED
            }
            179 => {
                // DO_SET_HOME: param1 = 1 current position
                if c.param1 > 0.5 {
                    if self.position_ok(now) {
                        self.set_home_here(now);
                        R::MAV_RESULT_ACCEPTED
                    } else {
                        R::MAV_RESULT_FAILED
                    }
                } else {
                    let lat = f64::from(c.x) * 1e-7;
                    let lon = f64::from(c.y) * 1e-7;
                    if !(-90.0..=90.0).contains(&lat)
                        || !(-180.0..=180.0).contains(&lon)
                        || (c.x == 0 && c.y == 0)
                    {
                        R::MAV_RESULT_DENIED
                    } else {
                        let (n, e) =
                            local::delta(self.cfg.reference.0, self.cfg.reference.1, lat, lon);
                        let alt = match c.frame as u8 {
                            3 | 6 => {
                                self.home.map(|h| h.alt_amsl).unwrap_or(self.ground_amsl())
                                    + f64::from(c.z)
                            }
                            _ => f64::from(c.z),
                        };
                        self.home = Some(Home {
                            lat,
                            lon,
                            alt_amsl: alt,
                            e,
                            n,
                        });
                        self.mission.set_home(Some(HomeItem {
                            lat_e7: c.x,
                            lon_e7: c.y,
                            alt_amsl_m: alt as f32,
                        }));
                        self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
                        R::MAV_RESULT_ACCEPTED
                    }
                }
            }
            203 | 206 | 2000 | 2001 => {
                if self.camera.is_none() {
                    R::MAV_RESULT_UNSUPPORTED
                } else if !ap && matches!(cmd, 2000 | 2001) {
                    // PX4 forwards image capture to the camera component, which answers
                    self.camera_command(from, c, now);
                    return;
                } else {
                    let mut item = MissionItem::command(cmd);
                    item.param1 = c.param1;
                    item.param2 = c.param2;
                    item.param3 = c.param3;
                    item.param4 = c.param4;
                    item.x = c.x;
                    item.y = c.y;
                    item.z = c.z;
                    if cmd == 203 && long {
                        item.x = c.x; // param5 shooting command, cast by the conversion
                    }
                    self.do_command(&item, now);
                    R::MAV_RESULT_ACCEPTED
                }
            }
            246 => {
                // PREFLIGHT_REBOOT_SHUTDOWN: 1 = reboot autopilot
                if c.param1 as i32 == 1 && !self.armed {
                    self.ack(from, c.command, R::MAV_RESULT_ACCEPTED);
                    self.power_cycle(now, false);
                    return;
                } else if ap {
                    R::MAV_RESULT_FAILED
                } else {
                    R::MAV_RESULT_DENIED
                }
            }
            CMD_BATTERY_SWAP => {
                if self.landed && !self.armed {
                    self.ack(from, c.command, R::MAV_RESULT_ACCEPTED);
                    self.power_cycle(now, true);
                    return;
                }
                R::MAV_RESULT_DENIED
            }
            193 if ap && copter => {
                // DO_PAUSE_CONTINUE: 0 pause (hold here), 1 resume
                if self.mode == Mode::Auto && !self.landed {
                    if c.param1 < 0.5 {
                        self.exec.running = false;
                        self.nav = Nav::Hold(self.here());
                    } else {
                        self.exec.running = true;
                        self.exec.nav_started = false;
                    }
                    R::MAV_RESULT_ACCEPTED
                } else {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Failed to pause");
                    R::MAV_RESULT_FAILED
                }
            }
            _ => R::MAV_RESULT_UNSUPPORTED,
        };
        self.ack(from, c.command, result);
    }

    fn cmd_takeoff(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        if !self.cfg.flavour.is_copter() {
            return if ap {
                R::MAV_RESULT_UNSUPPORTED
            } else {
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        }
        if ap {
            // GCS_MAVLINK_Copter::handle_MAV_CMD_NAV_TAKEOFF / Mode::do_user_takeoff
            if c.frame != mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT {
                return R::MAV_RESULT_DENIED;
            }
            let alt = f64::from(c.z);
            let user_takeoff = matches!(self.mode, Mode::Guided | Mode::Hold | Mode::AltHold);
            if !self.armed || !self.landed || !user_takeoff || alt <= self.m.u {
                return R::MAV_RESULT_FAILED;
            }
            let here = self.here();
            self.nav = Nav::Takeoff(Point { u: alt, ..here });
            R::MAV_RESULT_ACCEPTED
        } else {
            if self.check_mode_allowed(Mode::Takeoff, now).is_err() || !self.landed {
                let msg = format!(
                    "Switching to {} is currently not possible",
                    self.cfg.flavour.mode_name(Mode::Takeoff)
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            // param7 is an AMSL altitude; NaN → MIS_TAKEOFF_ALT
            let alt = if c.z.is_finite() {
                match c.frame as u8 {
                    3 | 6 => f64::from(c.z),
                    _ => {
                        f64::from(c.z) - self.home.map(|h| h.alt_amsl).unwrap_or(self.ground_amsl())
                    }
                }
            } else {
                2.5
            };
            self.enter_mode(Mode::Takeoff, now);
            let here = self.here();
            self.nav = Nav::Takeoff(Point {
                u: alt.max(1.0),
                ..here
            });
            R::MAV_RESULT_ACCEPTED
        }
    }

    fn cmd_mission_start(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        if self.cfg.flavour.is_ardupilot() {
            if c.param1 != 0.0 || c.param2 != 0.0 {
                return R::MAV_RESULT_DENIED;
            }
            if self.set_mode_request(
                1,
                self.cfg.flavour.custom_mode(Mode::Auto).unwrap_or(3),
                now,
            ) != R::MAV_RESULT_ACCEPTED
            {
                return R::MAV_RESULT_FAILED;
            }
            if !self.exec.running || self.exec.waiting_auto_armed {
                self.start_or_resume_mission(now);
            }
            R::MAV_RESULT_ACCEPTED
        } else {
            if self.mission.items(MissionType::Mission).is_empty() || !self.mission_valid {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Mission start denied! No valid mission",
                );
                return R::MAV_RESULT_DENIED;
            }
            if self.check_mode_allowed(Mode::Auto, now).is_err() {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Switching to Mission is currently not possible",
                );
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            if !self.armed && self.arm(now, false).is_err() {
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            if self.mode != Mode::Auto {
                self.enter_mode(Mode::Auto, now);
            } else {
                self.start_or_resume_mission(now);
            }
            R::MAV_RESULT_ACCEPTED
        }
    }

    fn target_from_command(&self, c: &mav::COMMAND_INT_DATA, long: bool, nan_pos: bool) -> Point {
        let here = self.here();
        let px4 = !self.cfg.flavour.is_ardupilot();
        let (e, n) = if nan_pos || (c.x == 0 && c.y == 0) {
            (here.e, here.n)
        } else {
            let (dn, de) = local::delta(
                self.cfg.reference.0,
                self.cfg.reference.1,
                f64::from(c.x) * 1e-7,
                f64::from(c.y) * 1e-7,
            );
            (de, dn)
        };
        let u = if !c.z.is_finite() {
            here.u
        } else {
            match c.frame as u8 {
                3 | 6 => f64::from(c.z),
                10 | 11 => f64::from(c.z),
                _ => {
                    // AMSL (COMMAND_LONG to ArduPilot is converted with frame GLOBAL; PX4's
                    // reposition altitude is AMSL)
                    let _ = (long, px4);
                    f64::from(c.z) - self.ground_amsl()
                }
            }
        };
        let u = if self.cfg.flavour.is_copter() {
            u.max(0.0)
        } else {
            0.0
        };
        Point { e, n, u }
    }

    fn cmd_reposition(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        let change_mode = (c.param2 as i32) & 1 == 1;
        // PX4's navigator flies a reposition at param1 (ground speed) when positive;
        // ArduCopter ignores it (GUIDED keeps WPNAV_SPEED or the last DO_CHANGE_SPEED)
        let speed = if c.param1 > 0.0 && !self.cfg.flavour.is_ardupilot() {
            Some(f64::from(c.param1))
        } else {
            None
        };
        if self.cfg.flavour.is_ardupilot() {
            // GCS_MAVLINK_Copter::handle_command_int_do_reposition
            if self.mode != Mode::Guided && !change_mode {
                return R::MAV_RESULT_DENIED;
            }
            if !nan_pos && (c.x.abs() > 900_000_000 || c.y.abs() > 1_800_000_000) {
                return R::MAV_RESULT_DENIED;
            }
            if !self.position_ok(now) {
                return R::MAV_RESULT_FAILED;
            }
            let p = self.target_from_command(c, long, nan_pos);
            if self.mode != Mode::Guided
                && self.set_mode_request(
                    1,
                    self.cfg.flavour.custom_mode(Mode::Guided).unwrap_or(4),
                    now,
                ) != R::MAV_RESULT_ACCEPTED
            {
                return R::MAV_RESULT_FAILED;
            }
            self.guided_target_at = Some(now);
            // A new destination returns the yaw to WP_YAW_BEHAVIOR (ModeGuided::set_destination
            // without a yaw): a CONDITION_YAW must come after it.
            self.yaw_target_deg = None;
            if !(self.landed && self.cfg.flavour.is_copter()) {
                self.nav = Nav::Goto { p, speed };
            }
            R::MAV_RESULT_ACCEPTED
        } else {
            // Commander: only the change-mode bit is supported; the navigator flies there in Hold
            if !change_mode || (c.param2 as i32) & !1 != 0 {
                return R::MAV_RESULT_UNSUPPORTED;
            }
            if self.check_mode_allowed(Mode::Hold, now).is_err() {
                let msg = format!(
                    "Switching to {} is currently not possible",
                    self.cfg.flavour.mode_name(Mode::Hold)
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            let p = self.target_from_command(c, long, nan_pos);
            self.enter_mode(Mode::Hold, now);
            // navigator_main.cpp: a finite param4 is the yaw setpoint, in radians.
            self.yaw_target_deg = c
                .param4
                .is_finite()
                .then(|| f64::from(c.param4).to_degrees().rem_euclid(360.0));
            if !(self.landed && self.cfg.flavour.is_copter()) {
                self.nav = Nav::Goto { p, speed };
            }
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// ArduCopter's MAV_CMD_CONDITION_YAW outside a mission (GCS_MAVLINK_Copter): param1
    /// the angle (0..360), param2 the rate (0 = default), param3 the direction, param4 1 =
    /// relative to the current heading, 0 = absolute; anything else FAILED. It sets a fixed
    /// yaw for the guided flight; in other modes the yaw is accepted and soon forgotten.
    fn cmd_condition_yaw(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        use mav::MavResult as R;
        let relative = c.param4 == 1.0;
        if !(0.0..=360.0).contains(&c.param1) || !(c.param4 == 0.0 || relative) {
            return R::MAV_RESULT_FAILED;
        }
        let angle = f64::from(c.param1);
        let target = if relative {
            let dir = if c.param3 < 0.0 { -1.0 } else { 1.0 };
            self.m.heading_deg + dir * angle
        } else {
            angle
        };
        if self.mode == Mode::Guided {
            self.yaw_target_deg = Some(target.rem_euclid(360.0));
        }
        R::MAV_RESULT_ACCEPTED
    }

    fn position_target(&mut self, p: &mav::SET_POSITION_TARGET_GLOBAL_INT_DATA, now: Time) {
        let mask = p.type_mask.bits();
        let pos_ignore = mask & 0b111 == 0b111;
        let ap = self.cfg.flavour.is_ardupilot();
        if ap && self.mode != Mode::Guided {
            return; // ignored outside GUIDED
        }
        if pos_ignore {
            return; // velocity/acceleration targets are not simulated
        }
        let frame = p.coordinate_frame as u8;
        let c = mav::COMMAND_INT_DATA {
            x: p.lat_int,
            y: p.lon_int,
            z: p.alt,
            frame: mav::MavFrame::from_u8(frame).unwrap_or(mav::MavFrame::MAV_FRAME_GLOBAL),
            ..mav::COMMAND_INT_DATA::default()
        };
        if !matches!(frame, 0 | 3 | 5 | 6 | 10 | 11) {
            return;
        }
        let target = self.target_from_command(&c, false, false);
        self.guided_target_at = Some(now);
        self.yaw_target_deg = None;
        // ArduCopter does not take off for a position target; PX4 offboard does
        if self.mode == Mode::Guided && !(ap && self.landed && self.cfg.flavour.is_copter()) {
            self.nav = Nav::Goto {
                p: target,
                speed: None,
            };
        }
    }

    fn camera_command(&mut self, from: (u8, u8), c: &mav::COMMAND_INT_DATA, now: Time) {
        use mav::MavResult as R;
        let tb = self.time_boot_ms(now);
        let Some(cam) = self.camera.as_mut() else {
            return; // no camera component: nobody answers
        };
        let cmd = c.command as u16;
        let mut extra = None;
        let result = match cmd {
            2000 => {
                // param2 interval s, param3 total images (0 = until stopped)
                let count = c.param3.max(0.0) as u32;
                cam.start_capture(f64::from(c.param2), count, now);
                R::MAV_RESULT_ACCEPTED
            }
            2001 => {
                cam.stop_capture();
                R::MAV_RESULT_ACCEPTED
            }
            512 => match c.param1 as u32 {
                259 => {
                    extra = Some(cam.information(tb));
                    R::MAV_RESULT_ACCEPTED
                }
                262 => {
                    extra = Some(cam.capture_status(tb));
                    R::MAV_RESULT_ACCEPTED
                }
                _ => R::MAV_RESULT_UNSUPPORTED,
            },
            521 => {
                extra = Some(cam.information(tb));
                R::MAV_RESULT_ACCEPTED
            }
            527 => {
                extra = Some(cam.capture_status(tb));
                R::MAV_RESULT_ACCEPTED
            }
            203 => {
                if c.x == 1 {
                    cam.trigger();
                }
                R::MAV_RESULT_ACCEPTED
            }
            _ => R::MAV_RESULT_UNSUPPORTED,
        };
        self.queue(
            CAMERA_COMPID,
            MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
                command: c.command,
                result,
                progress: 0,
                result_param2: 0,
                target_system: from.0,
                target_component: from.1,
            }),
        );
        if let Some(m) = extra {
            self.queue(CAMERA_COMPID, m);
        }
    }

    // ------------------------------------------------------------------ telemetry

    fn queue(&mut self, comp: u8, msg: MavMessage) {
        if self.powered {
            self.outbox.push_back((comp, msg));
        }
    }

    /// ArduPilot's answer to SETUP_SIGNING while armed (`GCS_MAVLINK::handle_setup_signing`
    /// ignores it): the warning it sends. The signing itself lives in the harness.
    pub fn refuse_signing_setup(&mut self) {
        self.text(
            mav::MavSeverity::MAV_SEVERITY_WARNING,
            "ERROR: Won't setup signing when armed",
        );
    }

    fn text(&mut self, severity: mav::MavSeverity, s: &str) {
        let t: String = s.chars().take(50).collect();
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::STATUSTEXT(mav::STATUSTEXT_DATA {
                severity,
                text: t.as_str().into(),
                id: 0,
                chunk_seq: 0,
            }),
        );
    }

    fn default_streams(&mut self, now: Time) {
        let f = self.cfg.flavour;
        let mut set = |id: u32, hz: f64| {
            if hz > 0.0 {
                self.streams
                    .insert(id, (Duration::from_secs_f64(1.0 / hz), now));
            }
        };
        set(0, 1.0); // HEARTBEAT
        match (f.autopilot, f.kind) {
            (Autopilot::ArduPilot, VehicleKind::Copter) => {}
            (Autopilot::ArduPilot, VehicleKind::Rover) => {
                for id in [1, 24, 42, 33, 30, 74, 147, 245] {
                    set(id, 1.0);
                }
            }
            (Autopilot::Px4, _) => {
                set(1, 1.0); // SYS_STATUS
                set(24, 1.0); // GPS_RAW_INT
                set(30, 15.0); // ATTITUDE
                set(33, 5.0); // GLOBAL_POSITION_INT
                set(42, 1.0); // MISSION_CURRENT (mission manager, 1 Hz)
                set(74, 4.0); // VFR_HUD
                set(147, 0.5); // BATTERY_STATUS
                set(242, 0.5); // HOME_POSITION
                set(245, 1.0); // EXTENDED_SYS_STATE
            }
        }
        if let Some(c) = self.camera.as_ref() {
            let _ = c;
        }
    }

    /// REQUEST_DATA_STREAM (ArduPilot): set a stream group's rate (Hz; 0 stops).
    fn request_data_stream(&mut self, stream: u8, rate: u16, start: bool, now: Time) {
        // GCS_MAVLink stream groups (ArduCopter GCS_Mavlink.cpp STREAM_* lists)
        let ids: &[u32] = match stream {
            0 => &[1, 24, 42, 245, 33, 30, 74, 2, 147],
            2 => &[1, 24, 42, 245], // EXTENDED_STATUS (+ EXTENDED_SYS_STATE)
            6 => &[33],             // POSITION
            10 => &[30],            // EXTRA1
            11 => &[74],            // EXTRA2
            12 => &[2, 147],        // EXTRA3: SYSTEM_TIME, BATTERY_STATUS
            _ => &[],
        };
        for &id in ids {
            if start && rate > 0 {
                self.streams
                    .insert(id, (Duration::from_secs_f64(1.0 / f64::from(rate)), now));
            } else {
                self.streams.remove(&id);
            }
        }
    }

    fn cmd_message_interval(&mut self, id: u32, interval_us: f32, now: Time) -> mav::MavResult {
        if !self.message_supported(id) {
            if self.cfg.flavour.is_ardupilot() {
                let msg = format!("No ap_message for mavlink id ({id})");
                self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
            }
            return mav::MavResult::MAV_RESULT_DENIED;
        }
        if interval_us < 0.0 {
            self.streams.remove(&id);
        } else if interval_us == 0.0 {
            // default rate: restore the boot default (or stop when there is none)
            self.streams.remove(&id);
            let mut probe = BTreeMap::new();
            std::mem::swap(&mut probe, &mut self.streams);
            self.default_streams(now);
            let default = self.streams.get(&id).copied();
            std::mem::swap(&mut probe, &mut self.streams);
            if let Some(d) = default {
                self.streams.insert(id, d);
            }
        } else {
            let us = f64::from(interval_us).max(10_000.0); // at most 100 Hz
            self.streams
                .insert(id, (Duration::from_secs_f64(us / 1e6), now));
        }
        mav::MavResult::MAV_RESULT_ACCEPTED
    }

    fn message_supported(&self, id: u32) -> bool {
        matches!(
            id,
            0 | 1 | 2 | 24 | 30 | 33 | 42 | 74 | 147 | 148 | 242 | 245
        )
    }

    fn cmd_request_message(&mut self, id: u32, now: Time) -> mav::MavResult {
        if id == 242 && self.home.is_none() {
            return mav::MavResult::MAV_RESULT_FAILED;
        }
        match self.telemetry(id, now) {
            Some(m) => {
                self.queue(AUTOPILOT_COMPID, m);
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            None => mav::MavResult::MAV_RESULT_DENIED,
        }
    }

    fn emit_streams(&mut self, now: Time) {
        let due: Vec<u32> = self
            .streams
            .iter()
            .filter(|(_, (_, next))| *next <= now)
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            if let Some((period, next)) = self.streams.get_mut(&id) {
                let mut n = *next + *period;
                if n <= now {
                    n = now + *period;
                }
                *next = n;
            }
            if id == 242 && self.home.is_none() {
                continue;
            }
            if let Some(m) = self.telemetry(id, now) {
                self.queue(AUTOPILOT_COMPID, m);
            }
            if id == 0
                && let Some(c) = self.camera.as_ref()
            {
                let _ = c;
                self.queue(
                    CAMERA_COMPID,
                    MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                        custom_mode: 0,
                        mavtype: mav::MavType::MAV_TYPE_CAMERA,
                        autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
                        base_mode: mav::MavModeFlag::empty(),
                        system_status: mav::MavState::MAV_STATE_ACTIVE,
                        mavlink_version: 3,
                    }),
                );
            }
        }
        // ArduPilot prints the failing pre-arm check every 30 s while disarmed
        if self.cfg.flavour.is_ardupilot()
            && !self.armed
            && self
                .last_prearm_report
                .is_none_or(|t| now.saturating_since(t) >= Duration::from_secs(30))
            && self.boot_s(now) > 1.0
        {
            self.last_prearm_report = Some(now);
            if let Some(m) = self.prearm_failure(now) {
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, m);
            }
        }
    }

    fn send_heartbeat(&mut self, now: Time) {
        if let Some(m) = self.telemetry(0, now) {
            self.queue(AUTOPILOT_COMPID, m);
        }
    }

    fn send_mission_current(&mut self, now: Time) {
        if let Some(m) = self.telemetry(42, now) {
            self.queue(AUTOPILOT_COMPID, m);
        }
    }

    fn home_position_msg(&self, _now: Time) -> MavMessage {
        let h = self.home.unwrap_or(Home {
            lat: 0.0,
            lon: 0.0,
            alt_amsl: 0.0,
            e: 0.0,
            n: 0.0,
        });
        let (ee, en) = self.est();
        MavMessage::HOME_POSITION(mav::HOME_POSITION_DATA {
            latitude: (h.lat * 1e7).round() as i32,
            longitude: (h.lon * 1e7).round() as i32,
            altitude: (h.alt_amsl * 1000.0).round() as i32,
            x: (h.n - en) as f32,
            y: (h.e - ee) as f32,
            z: 0.0,
            q: [1.0, 0.0, 0.0, 0.0],
            approach_x: 0.0,
            approach_y: 0.0,
            approach_z: 0.0,
            time_usec: 0,
        })
    }

    fn autopilot_version_msg(&self) -> MavMessage {
        let caps = mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_RALLY;
        let version = match self.cfg.flavour.autopilot {
            Autopilot::ArduPilot => (4 << 24) | (5 << 16) | (7 << 8) | 255,
            Autopilot::Px4 => (1 << 24) | (15 << 16) | (4 << 8) | 255,
        };
        MavMessage::AUTOPILOT_VERSION(mav::AUTOPILOT_VERSION_DATA {
            capabilities: caps,
            uid: u64::from(self.cfg.sysid),
            flight_sw_version: version,
            middleware_sw_version: 0,
            os_sw_version: 0,
            board_version: 0,
            vendor_id: 0,
            product_id: 0,
            flight_custom_version: [0; 8],
            middleware_custom_version: [0; 8],
            os_custom_version: [0; 8],
            uid2: [0; 18],
        })
    }

    fn landed_state(&self) -> mav::MavLandedState {
        use mav::MavLandedState as L;
        if self.cfg.flavour.kind == VehicleKind::Rover || self.landed {
            L::MAV_LANDED_STATE_ON_GROUND
        } else if matches!(self.nav, Nav::Takeoff(_)) || self.exec.px4_takeoff.is_some() {
            L::MAV_LANDED_STATE_TAKEOFF
        } else if matches!(
            self.nav,
            Nav::Land {
                descending: true,
                ..
            }
        ) || matches!(
            self.nav,
            Nav::Rtl {
                phase: RtlPhase::Land,
                ..
            }
        ) {
            L::MAV_LANDED_STATE_LANDING
        } else {
            L::MAV_LANDED_STATE_IN_AIR
        }
    }

    fn telemetry(&self, id: u32, now: Time) -> Option<MavMessage> {
        let f = self.cfg.flavour;
        let tb = self.time_boot_ms(now);
        let (lat, lon, u) = self.reported_position();
        let amsl = self.ground_amsl() + u;
        let home_amsl = self.home.map(|h| h.alt_amsl).unwrap_or(self.ground_amsl());
        Some(match id {
            0 => {
                let mut base = mav::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
                match f.autopilot {
                    Autopilot::ArduPilot => {
                        base |= mav::MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED
                            | mav::MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED;
                        if self.mode.requires_position() && !self.landed {
                            base |= mav::MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
                        }
                    }
                    Autopilot::Px4 => {
                        base |= mav::MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED;
                        if self.mode.requires_position() {
                            base |= mav::MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
                        }
                        if matches!(
                            self.mode,
                            Mode::Auto | Mode::Rtl | Mode::Land | Mode::Takeoff | Mode::Hold
                        ) {
                            base |= mav::MavModeFlag::MAV_MODE_FLAG_AUTO_ENABLED;
                        }
                    }
                }
                if self.armed {
                    base |= mav::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
                }
                let status = if self.failsafe_level > 0 && self.armed {
                    mav::MavState::MAV_STATE_CRITICAL
                } else if f.is_ardupilot() {
                    if self.landed && !(self.armed && f.kind == VehicleKind::Rover) {
                        if self.ardupilot_booting(now) {
                            mav::MavState::MAV_STATE_BOOT
                        } else {
                            mav::MavState::MAV_STATE_STANDBY
                        }
                    } else {
                        mav::MavState::MAV_STATE_ACTIVE
                    }
                } else if self.armed {
                    mav::MavState::MAV_STATE_ACTIVE
                } else if self.position_ok(now) {
                    mav::MavState::MAV_STATE_STANDBY
                } else {
                    mav::MavState::MAV_STATE_UNINIT
                };
                MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                    custom_mode: f.custom_mode(self.mode).unwrap_or(0),
                    mavtype: mav::MavType::from_u8(f.mav_type())
                        .unwrap_or(mav::MavType::MAV_TYPE_QUADROTOR),
                    autopilot: mav::MavAutopilot::from_u8(f.mav_autopilot())
                        .unwrap_or(mav::MavAutopilot::MAV_AUTOPILOT_GENERIC),
                    base_mode: base,
                    system_status: status,
                    mavlink_version: 3,
                })
            }
            1 => {
                use mav::MavSysStatusSensor as S;
                let present = S::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | S::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | S::MAV_SYS_STATUS_SENSOR_3D_MAG
                    | S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                    | S::MAV_SYS_STATUS_SENSOR_GPS
                    | S::MAV_SYS_STATUS_AHRS
                    | S::MAV_SYS_STATUS_SENSOR_BATTERY;
                let mut health = present;
                if !self.gps_fix(now) {
                    health.remove(S::MAV_SYS_STATUS_SENSOR_GPS);
                }
                if !self.position_ok(now) {
                    health.remove(S::MAV_SYS_STATUS_AHRS);
                }
                if self.failsafe_level > 0 {
                    health.remove(S::MAV_SYS_STATUS_SENSOR_BATTERY);
                }
                MavMessage::SYS_STATUS(mav::SYS_STATUS_DATA {
                    onboard_control_sensors_present: present,
                    onboard_control_sensors_enabled: present,
                    onboard_control_sensors_health: health,
                    load: 250,
                    voltage_battery: (self.battery.voltage() * 1000.0)
                        .round()
                        .clamp(0.0, 65534.0) as u16,
                    current_battery: (self.battery.current_a * 100.0)
                        .round()
                        .clamp(-32767.0, 32767.0) as i16,
                    drop_rate_comm: 0,
                    errors_comm: 0,
                    errors_count1: 0,
                    errors_count2: 0,
                    errors_count3: 0,
                    errors_count4: 0,
                    battery_remaining: self.battery.percent(),
                    onboard_control_sensors_present_extended:
                        mav::MavSysStatusSensorExtended::empty(),
                    onboard_control_sensors_enabled_extended:
                        mav::MavSysStatusSensorExtended::empty(),
                    onboard_control_sensors_health_extended: mav::MavSysStatusSensorExtended::empty(
                    ),
                })
            }
            2 => MavMessage::SYSTEM_TIME(mav::SYSTEM_TIME_DATA {
                time_unix_usec: 0,
                time_boot_ms: tb,
            }),
            24 => {
                let fix = self.gps_fix(now);
                MavMessage::GPS_RAW_INT(mav::GPS_RAW_INT_DATA {
                    time_usec: u64::from(tb) * 1000,
                    lat: if fix { (lat * 1e7).round() as i32 } else { 0 },
                    lon: if fix { (lon * 1e7).round() as i32 } else { 0 },
                    alt: if fix {
                        (amsl * 1000.0).round() as i32
                    } else {
                        0
                    },
                    eph: if fix { 80 } else { u16::MAX },
                    epv: if fix { 120 } else { u16::MAX },
                    vel: (self.m.ground_speed() * 100.0).round() as u16,
                    cog: (self.m.ve.atan2(self.m.vn).to_degrees().rem_euclid(360.0) * 100.0) as u16,
                    fix_type: if fix {
                        mav::GpsFixType::GPS_FIX_TYPE_3D_FIX
                    } else {
                        mav::GpsFixType::GPS_FIX_TYPE_NO_FIX
                    },
                    satellites_visible: if fix { 14 } else { 3 },
                    alt_ellipsoid: 0,
                    h_acc: if fix { 600 } else { 0 },
                    v_acc: if fix { 900 } else { 0 },
                    vel_acc: if fix { 200 } else { 0 },
                    hdg_acc: 0,
                    yaw: 0,
                })
            }
            30 => MavMessage::ATTITUDE(mav::ATTITUDE_DATA {
                time_boot_ms: tb,
                roll: self.m.roll_deg.to_radians() as f32,
                pitch: self.m.pitch_deg.to_radians() as f32,
                yaw: {
                    let y = self.m.heading_deg.to_radians();
                    (if y > std::f64::consts::PI {
                        y - 2.0 * std::f64::consts::PI
                    } else {
                        y
                    }) as f32
                },
                rollspeed: 0.0,
                pitchspeed: 0.0,
                yawspeed: 0.0,
            }),
            33 => {
                if !self.position_ok(now) && f.is_ardupilot() {
                    // no global position before the EKF origin is set
                    return None;
                }
                MavMessage::GLOBAL_POSITION_INT(mav::GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: tb,
                    lat: (lat * 1e7).round() as i32,
                    lon: (lon * 1e7).round() as i32,
                    alt: (amsl * 1000.0).round() as i32,
                    relative_alt: ((amsl - home_amsl) * 1000.0).round() as i32,
                    vx: (self.m.vn * 100.0).round() as i16,
                    vy: (self.m.ve * 100.0).round() as i16,
                    vz: (-self.m.vu * 100.0).round() as i16,
                    hdg: (self.m.heading_deg * 100.0).round() as u16 % 36000,
                })
            }
            42 => {
                let n = self.mission.items(MissionType::Mission).len() as u16;
                let ap = f.is_ardupilot();
                let total = if ap {
                    n.saturating_sub(1)
                } else if n == 0 {
                    u16::MAX
                } else {
                    n
                };
                let state = if (ap && n <= 1) || (!ap && n == 0) {
                    mav::MissionState::MISSION_STATE_NO_MISSION
                } else if self.exec.complete {
                    mav::MissionState::MISSION_STATE_COMPLETE
                } else if self.exec.running {
                    mav::MissionState::MISSION_STATE_ACTIVE
                } else if self.exec.nav_index.is_some() && self.mode == Mode::Auto {
                    mav::MissionState::MISSION_STATE_PAUSED
                } else {
                    mav::MissionState::MISSION_STATE_NOT_STARTED
                };
                MavMessage::MISSION_CURRENT(mav::MISSION_CURRENT_DATA {
                    seq: self.mission.current(),
                    total,
                    mission_state: state,
                    mission_mode: u8::from(self.mode == Mode::Auto),
                    mission_id: self.mission.opaque_id(MissionType::Mission),
                    fence_id: self.mission.opaque_id(MissionType::Fence),
                    rally_points_id: self.mission.opaque_id(MissionType::Rally),
                })
            }
            74 => MavMessage::VFR_HUD(mav::VFR_HUD_DATA {
                airspeed: self.m.ground_speed() as f32,
                groundspeed: self.m.ground_speed() as f32,
                alt: amsl as f32,
                climb: self.m.vu as f32,
                heading: self.m.heading_deg.round() as i16 % 360,
                throttle: if self.armed && !self.landed { 50 } else { 0 },
            }),
            147 => {
                let mut voltages = [u16::MAX; 10];
                let cells = self.cfg.battery.cells.clamp(1, 10) as usize;
                let cell_mv = (self.battery.voltage() * 1000.0 / cells as f64).round() as u16;
                for v in voltages.iter_mut().take(cells) {
                    *v = cell_mv;
                }
                let rate = self.battery.current_a.max(0.1);
                let remaining_s =
                    (self.cfg.battery.capacity_mah - self.battery.consumed_mah) / 1000.0 / rate
                        * 3600.0;
                MavMessage::BATTERY_STATUS(mav::BATTERY_STATUS_DATA {
                    current_consumed: self.battery.consumed_mah.round() as i32,
                    energy_consumed: -1,
                    temperature: i16::MAX,
                    voltages,
                    current_battery: (self.battery.current_a * 100.0)
                        .round()
                        .clamp(-32767.0, 32767.0) as i16,
                    id: 0,
                    battery_function: mav::MavBatteryFunction::MAV_BATTERY_FUNCTION_ALL,
                    mavtype: mav::MavBatteryType::MAV_BATTERY_TYPE_LIPO,
                    battery_remaining: self.battery.percent(),
                    time_remaining: remaining_s.round() as i32,
                    charge_state: if self.charging {
                        mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CHARGING
                    } else {
                        match self.failsafe_level {
                            0 => mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK,
                            1 => mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_LOW,
                            _ => mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CRITICAL,
                        }
                    },
                    voltages_ext: [0; 4],
                    mode: mav::MavBatteryMode::MAV_BATTERY_MODE_UNKNOWN,
                    fault_bitmask: mav::MavBatteryFault::empty(),
                })
            }
            148 => self.autopilot_version_msg(),
            242 => self.home_position_msg(now),
            245 => MavMessage::EXTENDED_SYS_STATE(mav::EXTENDED_SYS_STATE_DATA {
                vtol_state: mav::MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                landed_state: self.landed_state(),
            }),
            _ => return None,
        })
    }
}

/// Whether a MAV_CMD is a navigation command (AP_Mission::is_nav_cmd: ids up to
/// MAV_CMD_NAV_LAST = 95).
fn is_nav(cmd: u16) -> bool {
    cmd <= 95
}

fn cmd_name(cmd: u16) -> &'static str {
    match cmd {
        16 => "WP",
        17 => "LoitUnlim",
        19 => "LoitTime",
        20 => "RTL",
        21 => "Land",
        22 => "Takeoff",
        93 => "Delay",
        _ => "Cmd",
    }
}
