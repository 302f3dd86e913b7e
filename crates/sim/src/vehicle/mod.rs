//! One simulated vehicle: an ArduPilot or PX4 copter or rover, as pure logic stepped by time.
//!
//! ```text
//!   handle_message(header, msg, now)   ──►  ┌────────────┐ ──► poll_transmit() → (header, msg)
//!   step(now)                          ──►  │ SimVehicle │ ──► poll_event()    → VehicleEvent
//!   (the crew: swap_after_s)           ──►  └────────────┘ ──► poll_image()    → CapturedImage
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
//!   landing in LAND/RTL/AUTO; PX4 about 11 s after arming without takeoff (COM_DISARM_PRFLT
//!   from the land detector's "landed") and 2 s after landing (COM_DISARM_LAND); rovers never;
//! - take-off: ArduCopter answers NAV_TAKEOFF FAILED when disarmed, not landed or not in a
//!   user-take-off mode (a repeated take-off once off the ground fails); PX4 accepts it
//!   disarmed (AUTO_TAKEOFF, waiting for the arming) and in the air;
//! - streams (`streams`): ArduPilot's stream groups with the messages SITL sends, its
//!   buckets, SET_MESSAGE_INTERVAL / REQUEST_DATA_STREAM / GET_MESSAGE_INTERVAL, the slowdown
//!   under RADIO_STATUS and ×4 while receiving waypoints (ArduCopter sends only HEARTBEAT until
//!   asked, ArduRover every group at 1 Hz); PX4's Normal-mode streams with its rate
//!   multiplier ([`Px4Link`]); the contents (`messages`) sized as the real ones on the wire.

// MISSION_SET_CURRENT etc. are deprecated in the dialect but still what autopilots accept.
#![allow(deprecated)]

use crate::battery::{Battery, BatteryConfig};
use crate::fence::Fence;
use crate::flavour::{SimAutopilot, SimFlavour, SimMode, SimVehicleClass};
use crate::mission_server::{HomeItem, MissionEvent, MissionServer};
use crate::motion::{self, Command, Limits};
use fleetmap_camera::camera::{CameraConfig, CaptureContext, CapturedImage, SimCamera};
use fleetmap_camera::pose::CameraPose;
use fleetmap_core::geo::local;
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::proto::{CAMERA_COMPID, Endpoint};
use fleetmap_core::time::Time;
use fleetmap_core::world::{Wind, World};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

mod arming;
mod camera;
mod commands;
mod estimator;
mod faults;
mod flight;
mod geofence;
mod messages;
mod mission;
mod modes;
mod params;
mod power;
mod streams;
mod telemetry;
mod terrain;

pub use streams::Px4Link;

/// Mission item command and frame numbers, named from the dialect's MAV_CMD and MAV_FRAME
/// ([`MissionItem`] keeps them as the plain integers the wire carries).
mod mi {
    use mavlink::dialects::ardupilotmega::{MavCmd, MavFrame};
    /// MAV_CMD_NAV_WAYPOINT (16).
    pub(super) const NAV_WAYPOINT: u16 = MavCmd::MAV_CMD_NAV_WAYPOINT as u16;
    /// MAV_CMD_NAV_LOITER_UNLIM (17).
    pub(super) const NAV_LOITER_UNLIM: u16 = MavCmd::MAV_CMD_NAV_LOITER_UNLIM as u16;
    /// MAV_CMD_NAV_LOITER_TIME (19).
    pub(super) const NAV_LOITER_TIME: u16 = MavCmd::MAV_CMD_NAV_LOITER_TIME as u16;
    /// MAV_CMD_NAV_RETURN_TO_LAUNCH (20).
    pub(super) const NAV_RETURN_TO_LAUNCH: u16 = MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH as u16;
    /// MAV_CMD_NAV_LAND (21).
    pub(super) const NAV_LAND: u16 = MavCmd::MAV_CMD_NAV_LAND as u16;
    /// MAV_CMD_NAV_TAKEOFF (22).
    pub(super) const NAV_TAKEOFF: u16 = MavCmd::MAV_CMD_NAV_TAKEOFF as u16;
    /// MAV_CMD_NAV_SPLINE_WAYPOINT (82).
    pub(super) const NAV_SPLINE_WAYPOINT: u16 = MavCmd::MAV_CMD_NAV_SPLINE_WAYPOINT as u16;
    /// MAV_CMD_NAV_VTOL_TAKEOFF (84).
    pub(super) const NAV_VTOL_TAKEOFF: u16 = MavCmd::MAV_CMD_NAV_VTOL_TAKEOFF as u16;
    /// MAV_CMD_NAV_DELAY (93).
    pub(super) const NAV_DELAY: u16 = MavCmd::MAV_CMD_NAV_DELAY as u16;
    /// MAV_CMD_DO_AUX_FUNCTION (218).
    pub(super) const DO_AUX_FUNCTION: u16 = MavCmd::MAV_CMD_DO_AUX_FUNCTION as u16;
    /// MAV_CMD_DO_JUMP (177).
    pub(super) const DO_JUMP: u16 = MavCmd::MAV_CMD_DO_JUMP as u16;
    /// MAV_CMD_DO_CHANGE_SPEED (178).
    pub(super) const DO_CHANGE_SPEED: u16 = MavCmd::MAV_CMD_DO_CHANGE_SPEED as u16;
    /// MAV_CMD_DO_SET_HOME (179).
    pub(super) const DO_SET_HOME: u16 = MavCmd::MAV_CMD_DO_SET_HOME as u16;
    /// MAV_CMD_DO_DIGICAM_CONTROL (203).
    pub(super) const DO_DIGICAM_CONTROL: u16 = MavCmd::MAV_CMD_DO_DIGICAM_CONTROL as u16;
    /// MAV_CMD_DO_SET_CAM_TRIGG_DIST (206).
    pub(super) const DO_SET_CAM_TRIGG_DIST: u16 = MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_DIST as u16;
    /// MAV_CMD_IMAGE_START_CAPTURE (2000).
    pub(super) const IMAGE_START_CAPTURE: u16 = MavCmd::MAV_CMD_IMAGE_START_CAPTURE as u16;
    /// MAV_CMD_IMAGE_STOP_CAPTURE (2001).
    pub(super) const IMAGE_STOP_CAPTURE: u16 = MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE as u16;
    /// MAV_FRAME_GLOBAL (0).
    pub(super) const FRAME_GLOBAL: u8 = MavFrame::MAV_FRAME_GLOBAL as u8;
    /// MAV_FRAME_GLOBAL_RELATIVE_ALT (3).
    pub(super) const FRAME_GLOBAL_RELATIVE_ALT: u8 = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT as u8;
    /// MAV_FRAME_GLOBAL_INT (5).
    pub(super) const FRAME_GLOBAL_INT: u8 = MavFrame::MAV_FRAME_GLOBAL_INT as u8;
    /// MAV_FRAME_GLOBAL_RELATIVE_ALT_INT (6).
    pub(super) const FRAME_GLOBAL_RELATIVE_ALT_INT: u8 =
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT as u8;
    /// MAV_FRAME_GLOBAL_TERRAIN_ALT (10).
    pub(super) const FRAME_GLOBAL_TERRAIN_ALT: u8 = MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT as u8;
    /// MAV_FRAME_GLOBAL_TERRAIN_ALT_INT (11).
    pub(super) const FRAME_GLOBAL_TERRAIN_ALT_INT: u8 =
        MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT as u8;
}

use arming::Arming;
use estimator::Estimator;
use faults::Faults;
use flight::{Flight, Home, Nav, Point, RtlPhase};
use geofence::Geofence;
use mission::{Exec, Missions};
use modes::Modes;
use power::Power;
use telemetry::{Schedule, Telemetry};

/// Physics and logic step, seconds (20 Hz).
pub(crate) const DT: f64 = 0.05;

/// PX4's COM_DL_LOSS_T default: seconds without a GCS heartbeat after which the data link
/// counts as lost (`src/modules/commander/commander_params.c`).
pub(crate) const PX4_DL_LOSS_S: f64 = 10.0;
/// Time constant of each of the two first-order lags through which the position estimate
/// follows the GPS, seconds. An autopilot's estimator (ArduPilot's EKF3, PX4's EKF2) fuses
/// the 5–10 Hz GPS fixes with the IMU, so its position drifts with the GPS error but is
/// smooth; steering by the raw error process instead (white increments every tick) made a
/// hovering copter in calm air tilt by 3–8° from one image to the next, 0.6–1.7 m of
/// footprint at 12 m.
pub(crate) const ESTIMATE_LAG_S: f64 = 1.0;
/// The autopilot's component id (MAV_COMP_ID_AUTOPILOT1), the core's.
pub(crate) use fleetmap_core::proto::AUTOPILOT_COMPID;

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
pub(crate) const ARDUPILOT_BOOT_S: f64 = 2.0;

/// Everything that defines one simulated vehicle.
#[derive(Clone, Debug)]
pub struct VehicleConfig {
    /// MAVLink system id.
    pub sysid: u8,
    /// Autopilot and airframe.
    pub flavour: SimFlavour,
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
    pub(crate) gps_fix_after_s: f64,
    /// Seconds after boot until the position estimate is ready (EKF origin / global position).
    pub(crate) position_ready_after_s: f64,
    /// Standard deviation of the slowly varying GPS position error that every receiver of
    /// the simulation shares (satellite clock and orbit, ionosphere, troposphere: the part
    /// that differential GPS removes), metres per axis.
    pub(crate) gps_error_sigma_m: f64,
    /// Standard deviation of this receiver's own error (noise, multipath), metres per axis.
    /// Two vehicles side by side disagree only by this much, which is what lets a drone land
    /// on a rover's charging pad by GPS.
    pub(crate) gps_own_sigma_m: f64,
    /// Seed of the shared GPS error: equal for every vehicle of one simulation (the harness
    /// sets it), so that their common-mode errors are the same process.
    pub(crate) gps_common_seed: u64,
    /// Wind (None = calm).
    pub wind: Option<Wind>,
    /// Seed of every random process of this vehicle.
    pub seed: u64,
    /// The camera (None = no camera component).
    pub camera: Option<CameraConfig>,
    /// The field crew: swap the battery this long after the vehicle is landed and disarmed
    /// with a used battery (below 95 %), seconds — a power cycle of
    /// `VehicleConfig::power_off_s`, then a boot with a full battery, as a real autopilot
    /// sees its battery changed. `None`: nobody swaps it. No GCS command swaps a battery
    /// (a real autopilot has none).
    pub swap_after_s: Option<f64>,
    /// PX4: arming needs a GCS heartbeat and losing it for 10 s while armed triggers RTL
    /// (NAV_DLL_ACT > 0, COM_DL_LOSS_T 10 s, as in PX4's SITL airframes).
    pub(crate) px4_datalink_required: bool,
    /// Simulated seconds per second of the GCS's clock (1 by default: the GCS runs on the
    /// simulation's clock, as in-process). The GCS-link timeouts (PX4's COM_DL_LOSS_T, for
    /// arming and for the data-link-loss failsafe) are this many times longer in simulated
    /// time: a GCS on the wall clock heartbeats at 1 Hz of *its* time, so a simulator
    /// running 10× faster than wall time must judge it over 10× as many simulated seconds,
    /// or it would see 0.1 heartbeats per simulated second and declare the link lost. The
    /// socket server sets it from whose clock the GCS keeps ([`crate::server::GcsClock`]).
    pub gcs_time_scale: f64,
    /// Power-off time of a battery swap, seconds (the vehicle is silent meanwhile).
    pub(crate) power_off_s: f64,
    /// PX4: the MAVLink instance the GCS talks to (its data rate, whether RADIO_STATUS
    /// throttles it, the SITL's extra streams): [`Px4Link::NETWORK`] by default,
    /// [`Px4Link::TELEM1`] for a telemetry radio on TELEM1 as in the field,
    /// [`Px4Link::SITL_UDP`] to compare with PX4 SITL. ArduPilot ignores it.
    pub px4_link: Px4Link,
    /// A pre-arm check that fails until this simulated time, seconds (ArduPilot "PreArm:
    /// Compass not calibrated", PX4 "Preflight Fail: Compass Sensor 0 missing"; infinite:
    /// until a person fixes it; `None`: it passes): a vehicle that refuses to arm, for the
    /// ground station's handling of one that cannot start.
    pub compass_fault_until_s: Option<f64>,
    /// Parameters set over the autopilot's defaults (name, value), as a person would have
    /// set them before the flight: what a ground station reads with PARAM_REQUEST_READ
    /// (`params`). Empty: the defaults of ArduPilot 4.7 SITL / PX4 1.16.
    pub params: Vec<(String, f32)>,
}

impl VehicleConfig {
    /// A vehicle with the defaults of its flavour: 12-minute copter batteries, failsafe RTL at
    /// 20 % / land at 10 % (ArduPilot) or 7 % / 5 % (PX4 BAT_CRIT_THR / BAT_EMERGEN_THR),
    /// position estimate after 15 s (ArduPilot EKF3 in SITL) or 8 s (PX4), a 0.4 m GPS error
    /// (0.37 m shared by every receiver, 0.15 m its own)
    /// and, for copters, the paper's camera.
    pub fn new(sysid: u8, flavour: SimFlavour, start: (f64, f64)) -> VehicleConfig {
        let copter = flavour.kind == SimVehicleClass::Copter;
        let ardupilot = flavour.autopilot == SimAutopilot::ArduPilot;
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
                (_, SimVehicleClass::Rover) => Limits::ROVER,
                (SimAutopilot::ArduPilot, _) => Limits::ARDUCOPTER,
                (SimAutopilot::Px4, _) => Limits::PX4_COPTER,
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
            px4_link: Px4Link::NETWORK,
            compass_fault_until_s: None,
            params: Vec::new(),
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
    BatteryFailsafe(SimMode),
    /// A scheduled fault began ([`crate::fault`]; the harness announces it).
    FaultStarted(crate::fault::Fault),
    /// A scheduled fault ended.
    FaultEnded(crate::fault::Fault),
    /// The vehicle breached its geofence (the moment it crossed into a breach).
    FenceBreached {
        /// True position, local metres (east, north, up) from the world's reference.
        truth: (f64, f64, f64),
        /// The position the autopilot's estimate gave, local metres (east, north): what the
        /// fence was checked against.
        estimate: (f64, f64),
        /// The flight mode at the breach.
        mode: SimMode,
    },
}

/// One simulated vehicle. See the module documentation.
///
/// Its state is split by responsibility; each part lives with the methods that change it,
/// including the handlers of the commands that change it: `power` (power, boot, battery),
/// `estimator` (GPS error and position estimate), `flight` (motion, navigation target, home),
/// `arming`, `modes` (flight mode and failsafes), `geofence`, `mission` (the mission protocol
/// server and execution) and `telemetry` (streams, outbox); `commands` converts
/// COMMAND_LONG/COMMAND_INT, dispatches them to the parts and acknowledges.
#[derive(Debug)]
pub struct SimVehicle {
    cfg: VehicleConfig,
    world: Option<Arc<World>>,
    power: Power,
    estimator: Estimator,
    flight: Flight,
    arming: Arming,
    modes: Modes,
    geofence: Geofence,
    missions: Missions,
    telemetry: Telemetry,
    camera: Option<SimCamera>,
    faults: Faults,
    /// The parameters it answers for (`params`).
    params: Vec<params::Param>,
}

/// The header of a frame `from` sends with sequence number `seq`.
fn header(from: Endpoint, seq: u8) -> MavHeader {
    MavHeader {
        system_id: u32::from(from.sysid),
        component_id: from.compid,
        sequence: seq,
    }
}

/// One standard normal sample (Box–Muller) from `rng`.
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
            estimator: Estimator::new(&cfg),
            power: Power {
                powered: false,
                power_on_at: Some(now),
                boot_time: now,
                boots: 0,
                last_tick: now,
                battery: Battery::full(cfg.battery),
                charging: false,
            },
            missions: Missions {
                server: MissionServer::new(cfg.flavour.autopilot, cfg.sysid, AUTOPILOT_COMPID),
                exec: Exec::default(),
                valid: true,
            },
            modes: Modes {
                mode: cfg.flavour.boot_mode(),
                failsafe_level: 0,
                last_gcs_heartbeat: None,
                datalink_lost: false,
            },
            flight: Flight {
                m: motion::State {
                    e,
                    n,
                    ..motion::State::default()
                },
                nav: Nav::Idle,
                speed_override: None,
                yaw_target_deg: None,
                guided_target_at: None,
                home: None,
            },
            arming: Arming {
                armed: false,
                armed_at: now,
                took_off: false,
                landed: true,
                landed_at: Some(now),
                disarmed_landed_since: Some(now),
                last_prearm_report: None,
            },
            geofence: Geofence {
                fence: Fence::default(),
                enabled: false,
                breached: false,
            },
            telemetry: Telemetry {
                seq: [0; 2],
                schedule: Schedule::at_boot(&cfg, now),
                due: Vec::new(),
                outbox: VecDeque::new(),
                events: VecDeque::new(),
                ping_seq: 0,
                link_counts: Default::default(),
                terrain_request_at: None,
                terrain: Default::default(),
            },
            params: params::table(&cfg),
            cfg,
            world,
            camera,
            faults: Faults::default(),
        };
        v.estimator.gps_err = v.gps_raw_err();
        v.estimator.gps_lag = v.estimator.gps_err;
        v.boot(now);
        v
    }

    // ------------------------------------------------------------------ public API

    /// Set [`VehicleConfig::gcs_time_scale`] (simulated seconds per second of the GCS's
    /// clock), e.g. when the simulation is served faster than wall time to a GCS that runs
    /// on the wall clock.
    pub(crate) fn set_gcs_time_scale(&mut self, scale: f64) {
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
        self.power.powered
    }

    /// Boots so far (1 after the first power-up).
    pub fn boots(&self) -> u32 {
        self.power.boots
    }

    /// Whether it is armed.
    pub fn armed(&self) -> bool {
        self.arming.armed
    }

    /// The flight mode.
    pub fn mode(&self) -> SimMode {
        self.modes.mode
    }

    /// Whether it is on the ground.
    pub fn landed(&self) -> bool {
        self.arming.landed
    }

    /// True position: local (east, north, up) metres in the shared frame.
    pub fn true_local(&self) -> (f64, f64, f64) {
        (self.flight.m.e, self.flight.m.n, self.flight.m.u)
    }

    /// True position (lat, lon) degrees and height above ground, metres.
    pub fn true_position(&self) -> (f64, f64, f64) {
        let (lat, lon) = local::offset(
            self.cfg.reference.0,
            self.cfg.reference.1,
            self.flight.m.n,
            self.flight.m.e,
        );
        (lat, lon, self.flight.m.u)
    }

    /// The position the autopilot believes and reports (lat, lon, height above ground).
    pub fn reported_position(&self) -> (f64, f64, f64) {
        let (e, n) = self.est();
        let (lat, lon) = local::offset(self.cfg.reference.0, self.cfg.reference.1, n, e);
        (lat, lon, self.flight.m.u)
    }

    /// Heading, degrees.
    pub fn heading_deg(&self) -> f64 {
        self.flight.m.heading_deg
    }

    /// The battery.
    pub fn battery(&self) -> &Battery {
        &self.power.battery
    }

    /// Home (lat, lon, AMSL altitude), when set.
    pub fn home(&self) -> Option<(f64, f64, f64)> {
        self.flight.home.map(|h| (h.lat, h.lon, h.alt_amsl))
    }

    /// The mission server (stored lists).
    pub fn mission(&self) -> &MissionServer {
        &self.missions.server
    }

    /// The mission server, to change its storage limits
    /// ([`MissionServer::set_capacity`]: a vehicle that refuses long missions).
    pub fn mission_mut(&mut self) -> &mut MissionServer {
        &mut self.missions.server
    }

    /// Move the vehicle by (de, dn) metres without flying (riding on a rover).
    pub(crate) fn carry(&mut self, de: f64, dn: f64) {
        self.flight.m.e += de;
        self.flight.m.n += dn;
    }

    /// Charge the battery for `dt` seconds (standing on a charging station); only while
    /// landed.
    pub fn charge(&mut self, dt: f64) {
        if self.arming.landed && self.power.powered {
            self.power.battery.charge(dt);
            self.power.charging = true;
        }
    }

    /// The next message to send and its header.
    pub fn poll_transmit(&mut self) -> Option<(MavHeader, MavMessage)> {
        if let Some(m) = self.missions.server.poll_transmit() {
            self.telemetry.outbox.push_back((AUTOPILOT_COMPID, m));
        }
        let cam_msg = self.live_camera().and_then(|c| c.poll_transmit());
        if let Some(m) = cam_msg {
            self.telemetry.outbox.push_back((CAMERA_COMPID, m));
        }
        let (comp, msg) = self.telemetry.outbox.pop_front()?;
        self.telemetry.link_counts.sent = self.telemetry.link_counts.sent.wrapping_add(1);
        let i = usize::from(comp == CAMERA_COMPID);
        let s = self.telemetry.seq[i];
        self.telemetry.seq[i] = s.wrapping_add(1);
        Some((header(Endpoint::new(self.cfg.sysid, comp), s), msg))
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<VehicleEvent> {
        self.telemetry.events.pop_front()
    }

    /// The next captured image (write its file before sending the messages that follow).
    pub fn poll_image(&mut self) -> Option<CapturedImage> {
        self.live_camera().and_then(|c| c.poll_image())
    }

    /// When the vehicle next needs [`SimVehicle::step`]: its next 20 Hz tick.
    pub fn poll_timeout(&self) -> Time {
        self.power.last_tick + Duration::from_secs_f64(DT)
    }

    /// Advance the simulation to `now`.
    pub fn step(&mut self, now: Time) {
        self.advance(now);
    }

    /// Handle a message the vehicle received at `now` (after simulating up to `now`).
    pub fn handle_message(&mut self, h: &MavHeader, msg: &MavMessage, now: Time) {
        self.advance(now);
        if !self.power.powered {
            return;
        }
        self.telemetry.link_counts.received = self.telemetry.link_counts.received.wrapping_add(1);
        let from = Endpoint::of(h);
        if self.refuses_sender(from.sysid, msg) {
            return;
        }
        if self.handle_param_message(msg) {
            return;
        }
        if let MavMessage::HEARTBEAT(hb) = msg
            && hb.mavtype == mav::MavType::MAV_TYPE_GCS
        {
            self.modes.last_gcs_heartbeat = Some(now);
            if self.modes.datalink_lost {
                self.modes.datalink_lost = false;
                self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Data link regained");
            }
            return;
        }
        self.missions
            .server
            .set_loaded(!self.ardupilot_booting(now));
        if self.missions.server.handle_message(h, msg, now) {
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
                if self.cfg.flavour.autopilot == SimAutopilot::Px4 {
                    self.ack(from, mav::MavCmd::MAV_CMD_DO_SET_MODE, result);
                }
            }
            MavMessage::REQUEST_DATA_STREAM(r)
                if r.target_system == self.cfg.sysid && self.cfg.flavour.is_ardupilot() =>
            {
                self.request_data_stream(
                    r.req_stream_id as u8,
                    r.req_message_rate,
                    r.start_stop,
                    now,
                );
            }
            // from whichever system: a SiK radio speaks as 51/68, and ArduPilot and PX4 take
            // any RADIO_STATUS on the link as their radio's
            MavMessage::RADIO_STATUS(r) => self.radio_status(r.txbuf, now),
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(p) if p.target_system == self.cfg.sysid => {
                self.position_target(p, now);
            }
            MavMessage::TERRAIN_DATA(d) if self.cfg.flavour.is_ardupilot() => {
                self.telemetry.terrain.data(d);
            }
            // a request for a picture, or the runway run's grid: the camera's
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) | MavMessage::DEBUG_FLOAT_ARRAY(_) => {
                if let Some(c) = self.live_camera() {
                    c.handle_gcs_message(msg);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod test_probe;
