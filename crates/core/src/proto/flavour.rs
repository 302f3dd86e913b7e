//! Autopilot flavours: everything that differs between ArduPilot Copter, ArduPilot Rover
//! and PX4, in one place.
//!
//! Sources (cited per item below):
//! * ArduCopter modes: `ArduPilot/ardupilot` `ArduCopter/mode.h` (`enum class Number`);
//!   ArduRover modes: `Rover/mode.h`; PX4 modes: `PX4/PX4-Autopilot`
//!   `src/modules/commander/px4_custom_mode.h` (custom_mode = sub_mode << 24 |
//!   main_mode << 16), names as QGroundControl shows them
//!   (`src/FirmwarePlugin/PX4/PX4FirmwarePlugin.cc`).
//! * Changing mode: MAV_CMD_DO_SET_MODE with param1 = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
//!   param2 = custom mode (ArduPilot) or main mode, param3 = sub mode (PX4), as pymavlink's
//!   `mavutil.set_mode_apm` / `set_mode_px4` and QGroundControl do; confirmed by the
//!   heartbeat's custom_mode.
//! * Take-off: ArduCopter only takes off with MAV_CMD_NAV_TAKEOFF in GUIDED, armed, with
//!   param7 the altitude *above home* (`ArduCopter/GCS_Mavlink.cpp`
//!   `handle_command_long_packet` → `do_user_takeoff`, refused outside guided-capable
//!   modes); PX4 takes off with MAV_CMD_NAV_TAKEOFF in any mode once armed, param7 being
//!   the *AMSL* altitude (QGroundControl `PX4FirmwarePlugin::guidedModeTakeoff` adds the
//!   vehicle's AMSL altitude; commander switches to AUTO_TAKEOFF). Rovers do not take off.
//!   When it is done: see `TAKEOFF_ALT_ACCEPTANCE_M`.
//! * Starting a mission: MAV_CMD_MISSION_START. ArduCopter switches to AUTO and sets
//!   `auto_armed` so the mission runs without throttle input (`GCS_Mavlink.cpp`
//!   `MAV_CMD_MISSION_START`); Rover switches to AUTO; PX4 commander switches to
//!   AUTO_MISSION (needs to be armed).
//! * Going somewhere now: MAV_CMD_DO_REPOSITION as COMMAND_INT (ArduPilot only accepts it
//!   as COMMAND_INT, `handle_command_int_do_reposition`; flag
//!   MAV_DO_REPOSITION_FLAGS_CHANGE_MODE switches to GUIDED); PX4 wants AMSL altitude in
//!   MAV_FRAME_GLOBAL (QGroundControl `PX4FirmwarePlugin::guidedModeGotoLocation`).
//!   Fallback for ArduPilot builds without it: GUIDED + SET_POSITION_TARGET_GLOBAL_INT
//!   (position-only type mask, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT).
//! * Return and land: ArduPilot by mode (RTL, LAND; Rover has no LAND, HOLD is its stop),
//!   PX4 by MAV_CMD_NAV_RETURN_TO_LAUNCH / MAV_CMD_NAV_LAND (commander switches to
//!   AUTO_RTL / AUTO_LAND).
//! * Mission numbering: ArduPilot's mission item 0 is home (`AP_Mission`), so MISSION_CURRENT
//!   and MISSION_ITEM_REACHED count from 1 for the user's first item; PX4 from 0.
//! * Arming for real: see [`super::arming`].

// Deliberately handles deprecated messages and frames (MISSION_REQUEST, MISSION_ITEM,
// MISSION_SET_CURRENT, *_INT frames) because deployed autopilots still send or need them.
#![allow(deprecated)]

use super::Endpoint;
use super::command::Command;
use super::mode::{CopterMode, Mode, Px4Mode, RoverMode};
use mavlink::dialects::ardupilotmega::{
    MavAutopilot, MavCmd, MavFrame, MavMessage, MavType, PositionTargetTypemask,
    SET_POSITION_TARGET_GLOBAL_INT_DATA,
};
use num_traits::FromPrimitive;

/// How far below the requested altitude a take-off counts as done, metres (0.8).
///
/// PX4 ends a multicopter take-off as soon as the vehicle is within its altitude acceptance
/// radius `NAV_MC_ALT_RAD` (0.8 m by default) of the target and then holds the altitude it
/// has (`PX4/PX4-Autopilot` `src/modules/navigator/navigator_main.cpp`
/// `get_default_altitude_acceptance_radius`, `mission_block.cpp`
/// `is_mission_item_reached_or_completed` for NAV_CMD_TAKEOFF: global altitude >
/// take-off altitude − acceptance radius), so a vehicle sent to 5 m may stay at 4.3 m and
/// a GCS that waits for 90 % of the altitude waits for ever. ArduCopter's GUIDED take-off
/// raises the position target to the altitude and keeps holding it
/// (`ArduCopter/takeoff.cpp`), so it ends closer and passes this tolerance as well.
pub(crate) const TAKEOFF_ALT_ACCEPTANCE_M: f32 = 0.8;

/// Whether a vehicle `alt_rel` metres above home has finished a take-off to `target`
/// metres above home: no lower than `TAKEOFF_ALT_ACCEPTANCE_M` below it, less 5 cm for
/// the millimetre rounding of the reported relative altitude (PX4 compares AMSL
/// altitudes, the GCS sees `relative_alt`).
pub fn takeoff_reached(alt_rel: f32, target: f32) -> bool {
    alt_rel >= target - TAKEOFF_ALT_ACCEPTANCE_M - 0.05
}

/// Which autopilot firmware, from HEARTBEAT.autopilot (MAV_AUTOPILOT): the one vocabulary of
/// the fleet, the simulator (`sim::flavour::SimAutopilot` is the part of it the
/// simulator imitates) and the TUI.
///
/// Serialized (fleet snapshots in JSON) as `"ArduPilot"`, `"Px4"`, `{"Other": n}`; the TUI's
/// replay files use their own spelling (the TUI model's `VehicleRow::autopilot`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Autopilot {
    /// ArduPilot (MAV_AUTOPILOT_ARDUPILOTMEGA = 3).
    ArduPilot,
    /// PX4 (MAV_AUTOPILOT_PX4 = 12).
    Px4,
    /// Anything else (MAV_AUTOPILOT number).
    Other(u8),
}

/// MAV_AUTOPILOT_ARDUPILOTMEGA (common.xml).
const MAV_AUTOPILOT_ARDUPILOTMEGA: u8 = MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA as u8;
/// MAV_AUTOPILOT_INVALID (common.xml): not a flight controller (a GCS, a camera…).
const MAV_AUTOPILOT_INVALID: u8 = MavAutopilot::MAV_AUTOPILOT_INVALID as u8;
/// MAV_AUTOPILOT_PX4 (common.xml).
const MAV_AUTOPILOT_PX4: u8 = MavAutopilot::MAV_AUTOPILOT_PX4 as u8;

impl Autopilot {
    /// The autopilot a HEARTBEAT.autopilot (MAV_AUTOPILOT) number names.
    pub(crate) const fn from_mav(mav_autopilot: u8) -> Autopilot {
        match mav_autopilot {
            MAV_AUTOPILOT_ARDUPILOTMEGA => Autopilot::ArduPilot,
            MAV_AUTOPILOT_PX4 => Autopilot::Px4,
            n => Autopilot::Other(n),
        }
    }

    /// The HEARTBEAT.autopilot (MAV_AUTOPILOT) number.
    pub const fn mav_autopilot(self) -> u8 {
        match self {
            Autopilot::ArduPilot => MAV_AUTOPILOT_ARDUPILOTMEGA,
            Autopilot::Px4 => MAV_AUTOPILOT_PX4,
            Autopilot::Other(n) => n,
        }
    }

    /// Display name: "ArduPilot", "PX4", "other".
    pub fn name(self) -> &'static str {
        match self {
            Autopilot::ArduPilot => "ArduPilot",
            Autopilot::Px4 => "PX4",
            Autopilot::Other(_) => "other",
        }
    }

    /// Short name for narrow tables: "AP", "PX4", "?".
    pub fn short(self) -> &'static str {
        match self {
            Autopilot::ArduPilot => "AP",
            Autopilot::Px4 => "PX4",
            Autopilot::Other(_) => "?",
        }
    }
}

impl Default for Autopilot {
    /// Not known (yet): `Other(MAV_AUTOPILOT_INVALID)`, what a view shows before a heartbeat.
    fn default() -> Autopilot {
        Autopilot::Other(MAV_AUTOPILOT_INVALID)
    }
}

/// What kind of vehicle, from HEARTBEAT.type (MAV_TYPE, [`Flavour::from_heartbeat`]): the
/// one vocabulary of the fleet and the TUI.
///
/// Serialized (fleet snapshots in JSON) as `"Copter"`, `"Rover"`, …; the TUI's replay files
/// use their own spelling (the TUI model's `VehicleRow::vehicle_type`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
pub enum VehicleClass {
    /// Multirotor or helicopter.
    Copter,
    /// Ground rover or boat.
    Rover,
    /// Fixed wing (modes not mapped; protocol only).
    Plane,
    /// Anything else (and not known yet, before a heartbeat).
    #[default]
    Other,
}

impl VehicleClass {
    /// Full name: "copter", "rover", "plane", "other".
    pub fn name(self) -> &'static str {
        match self {
            VehicleClass::Copter => "copter",
            VehicleClass::Rover => "rover",
            VehicleClass::Plane => "plane",
            VehicleClass::Other => "other",
        }
    }

    /// Three-letter name for narrow tables: "cop", "rov", "pln", "oth".
    pub fn short(self) -> &'static str {
        match self {
            VehicleClass::Copter => "cop",
            VehicleClass::Rover => "rov",
            VehicleClass::Plane => "pln",
            VehicleClass::Other => "oth",
        }
    }
}

/// Autopilot + vehicle class: decides modes and how actions are done.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct Flavour {
    /// The firmware.
    pub autopilot: Autopilot,
    /// The vehicle class.
    pub class: VehicleClass,
}

/// Errors of flavour-dependent actions.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FlavourError {
    /// The mode name is not one of this autopilot's modes.
    #[error("unknown mode {name:?} for {flavour}; known modes: {known}")]
    UnknownMode {
        /// The name asked for.
        name: String,
        /// The flavour.
        flavour: String,
        /// Comma-separated list of known names.
        known: String,
    },
    /// The action does not exist for this vehicle (e.g. a rover taking off).
    #[error("{action} is not possible for {flavour}")]
    NotApplicable {
        /// The action.
        action: &'static str,
        /// The flavour.
        flavour: String,
    },
    /// A position is needed but unknown (e.g. home altitude for a PX4 take-off).
    #[error("{action}: {what} is not known yet")]
    Unknown {
        /// The action.
        action: &'static str,
        /// What is missing.
        what: &'static str,
    },
}

/// Accepted alternative names → canonical names (QGroundControl / MAVProxy spellings).
const ALIASES: &[(&str, &str)] = &[
    ("POSITION", "POSCTL"),
    ("ALTITUDE", "ALTCTL"),
    ("RETURN", "RTL"),
    ("LOITER", "HOLD"),
    ("AUTO.MISSION", "MISSION"),
    ("AUTO.LOITER", "HOLD"),
    ("AUTO.RTL", "RTL"),
    ("AUTO.LAND", "LAND"),
    ("AUTO.TAKEOFF", "TAKEOFF"),
    ("FOLLOWME", "FOLLOW_ME"),
    ("ALTHOLD", "ALT_HOLD"),
];

/// One thing to do to carry out an action (executed in order by the fleet).
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Switch to this mode (if not in it already) and wait for the heartbeat to show it.
    SetMode(Mode),
    /// Arm (after the readiness checks) and wait for the heartbeat to show it.
    Arm,
    /// Send a command and wait for its ACK.
    Command(Command),
    /// Send a message without acknowledgement.
    Send(Box<MavMessage>),
}

impl Flavour {
    /// The flavour of a heartbeat's (MAV_AUTOPILOT, MAV_TYPE).
    pub fn from_heartbeat(autopilot: u8, mav_type: u8) -> Flavour {
        let autopilot = Autopilot::from_mav(autopilot);
        use MavType::*;
        let class = match MavType::from_u8(mav_type) {
            Some(
                MAV_TYPE_QUADROTOR | MAV_TYPE_COAXIAL | MAV_TYPE_HELICOPTER | MAV_TYPE_HEXAROTOR
                | MAV_TYPE_OCTOROTOR | MAV_TYPE_TRICOPTER | MAV_TYPE_DODECAROTOR
                | MAV_TYPE_DECAROTOR,
            ) => VehicleClass::Copter,
            Some(MAV_TYPE_GROUND_ROVER | MAV_TYPE_SURFACE_BOAT) => VehicleClass::Rover,
            // fixed wing and the VTOLs (MAV_TYPE 19 to 25)
            Some(
                MAV_TYPE_FIXED_WING
                | MAV_TYPE_VTOL_TAILSITTER_DUOROTOR
                | MAV_TYPE_VTOL_TAILSITTER_QUADROTOR
                | MAV_TYPE_VTOL_TILTROTOR
                | MAV_TYPE_VTOL_FIXEDROTOR
                | MAV_TYPE_VTOL_TAILSITTER
                | MAV_TYPE_VTOL_TILTWING
                | MAV_TYPE_VTOL_RESERVED5,
            ) => VehicleClass::Plane,
            _ => VehicleClass::Other,
        };
        Flavour { autopilot, class }
    }

    /// ArduPilot Copter.
    pub const ARDU_COPTER: Flavour = Flavour {
        autopilot: Autopilot::ArduPilot,
        class: VehicleClass::Copter,
    };
    /// ArduPilot Rover.
    pub const ARDU_ROVER: Flavour = Flavour {
        autopilot: Autopilot::ArduPilot,
        class: VehicleClass::Rover,
    };
    /// PX4 multicopter.
    pub const PX4_COPTER: Flavour = Flavour {
        autopilot: Autopilot::Px4,
        class: VehicleClass::Copter,
    };
    /// PX4 rover.
    pub const PX4_ROVER: Flavour = Flavour {
        autopilot: Autopilot::Px4,
        class: VehicleClass::Rover,
    };

    /// Whether mission item 0 is home (ArduPilot).
    pub fn home_item(&self) -> bool {
        self.autopilot == Autopilot::ArduPilot
    }

    /// The mode table ([`super::mode`]): PX4's, ArduRover's for ArduPilot rovers,
    /// ArduCopter's for other ArduPilot vehicles, none for other autopilots.
    pub fn modes(&self) -> &'static [Mode] {
        match (self.autopilot, self.class) {
            (Autopilot::Px4, _) => Px4Mode::MODES,
            (Autopilot::ArduPilot, VehicleClass::Rover) => RoverMode::MODES,
            (Autopilot::ArduPilot, _) => CopterMode::MODES,
            _ => &[],
        }
    }

    /// The mode a heartbeat's `custom_mode` is in, if this flavour's table has it (PX4's
    /// reserved low 16 bits ignored).
    pub fn mode_of(&self, custom_mode: u32) -> Option<Mode> {
        let cm = match self.autopilot {
            Autopilot::Px4 => custom_mode & 0xFFFF_0000,
            _ => custom_mode,
        };
        self.modes().iter().copied().find(|m| m.custom_mode() == cm)
    }

    /// The name of the mode in a heartbeat (`custom_mode`), or `MODE(n)` if unknown.
    pub fn mode_name(&self, custom_mode: u32) -> String {
        if let Some(m) = self.mode_of(custom_mode) {
            return m.name().to_string();
        }
        if self.autopilot == Autopilot::Px4 {
            // PX4 reports AUTO sub modes it has no name for; show main.sub (the low 16 bits
            // are reserved).
            let cm = custom_mode & 0xFFFF_0000;
            return format!("MODE({}.{})", (cm >> 16) & 0xFF, cm >> 24);
        }
        format!("MODE({custom_mode})")
    }

    /// The mode called `name` (case-insensitive, QGroundControl / MAVProxy aliases).
    pub fn mode(&self, name: &str) -> Result<Mode, FlavourError> {
        let up = name.trim().to_ascii_uppercase().replace(' ', "_");
        let modes = self.modes();
        let find = |n: &str| modes.iter().find(|m| m.name() == n).copied();
        if let Some(m) = find(&up) {
            return Ok(m);
        }
        if let Some((_, canon)) = ALIASES.iter().find(|(a, _)| *a == up)
            && let Some(m) = find(canon)
        {
            return Ok(m);
        }
        Err(self.unknown_mode(name))
    }

    /// The MAV_CMD_DO_SET_MODE command for `mode`.
    pub fn set_mode_command(&self, target: Endpoint, mode: Mode) -> Command {
        // MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1.
        let custom_mode = mode.custom_mode();
        let (p2, p3) = match self.autopilot {
            Autopilot::Px4 => (
                ((custom_mode >> 16) & 0xFF) as f32,
                (custom_mode >> 24) as f32,
            ),
            _ => (custom_mode as f32, 0.0),
        };
        Command::long(
            target,
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, p2, p3, 0.0, 0.0, 0.0, 0.0],
        )
    }

    /// Whether the heartbeat's `custom_mode` is `mode`.
    pub fn is_mode(&self, custom_mode: u32, mode: Mode) -> bool {
        match self.autopilot {
            Autopilot::Px4 => custom_mode & 0xFFFF_0000 == mode.custom_mode(),
            _ => custom_mode == mode.custom_mode(),
        }
    }

    /// This flavour's mode among ArduCopter's, ArduRover's and PX4's choice of it: the
    /// table [`Flavour::modes`] picks. `Err` for an autopilot without a table.
    fn pick(
        &self,
        copter: CopterMode,
        rover: RoverMode,
        px4: Px4Mode,
    ) -> Result<Mode, FlavourError> {
        match (self.autopilot, self.class) {
            (Autopilot::Px4, _) => Ok(Mode::Px4(px4)),
            (Autopilot::ArduPilot, VehicleClass::Rover) => Ok(Mode::Rover(rover)),
            (Autopilot::ArduPilot, _) => Ok(Mode::Copter(copter)),
            (Autopilot::Other(_), _) => Err(self.unknown_mode(copter.name())),
        }
    }

    /// [`FlavourError::UnknownMode`] for `name`, listing this flavour's modes.
    fn unknown_mode(&self, name: &str) -> FlavourError {
        FlavourError::UnknownMode {
            name: name.to_string(),
            flavour: self.to_string(),
            known: self
                .modes()
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(", "),
        }
    }

    /// The mode in which a mission runs (AUTO / MISSION).
    pub fn mission_mode(&self) -> Result<Mode, FlavourError> {
        self.pick(CopterMode::Auto, RoverMode::Auto, Px4Mode::Mission)
    }

    /// The mode for commanded positions (GUIDED; PX4 HOLD, which DO_REPOSITION uses).
    pub fn guided_mode(&self) -> Result<Mode, FlavourError> {
        self.pick(CopterMode::Guided, RoverMode::Guided, Px4Mode::Hold)
    }

    /// The return-to-launch mode.
    pub(crate) fn rtl_mode(&self) -> Result<Mode, FlavourError> {
        self.pick(CopterMode::Rtl, RoverMode::Rtl, Px4Mode::Rtl)
    }

    /// The mode that stops the vehicle where it is and holds there: ArduCopter BRAKE (stops
    /// at once with the loiter controller, ignores the sticks — QGroundControl's "Pause" for
    /// ArduCopter, `ArduCopterFirmwarePlugin::pauseVehicle`), ArduRover HOLD, PX4 HOLD
    /// (AUTO_LOITER, which loiters where it is entered). ArduCopter disarms a copter that is
    /// landed in BRAKE: pause only vehicles that are in the air.
    pub fn hold_mode(&self) -> Result<Mode, FlavourError> {
        match (self.autopilot, self.class) {
            (Autopilot::ArduPilot, VehicleClass::Copter) => Ok(Mode::Copter(CopterMode::Brake)),
            (Autopilot::ArduPilot, VehicleClass::Rover) => Ok(Mode::Rover(RoverMode::Hold)),
            (Autopilot::Px4, _) => Ok(Mode::Px4(Px4Mode::Hold)),
            // ArduPilot planes and other frames use ArduCopter's table, which has no HOLD.
            _ => Err(self.unknown_mode("HOLD")),
        }
    }

    /// How to stop and hold where the vehicle is now ([`Flavour::hold_mode`]). The autopilot
    /// stops at its own, current position: a go-to to the position the GCS last heard would
    /// fly a vehicle that has moved on since (a late command, a slow link) back along a chord,
    /// which can cut a corner through a no-fly cell.
    pub fn pause(&self) -> Result<Vec<Step>, FlavourError> {
        Ok(vec![Step::SetMode(self.hold_mode()?)])
    }

    /// Whether this vehicle flies (takes off and lands).
    pub fn flies(&self) -> bool {
        matches!(self.class, VehicleClass::Copter | VehicleClass::Plane)
    }

    /// Whether MAV_CMD_MISSION_START does nothing while the vehicle is in its mission mode
    /// already, so that a mission is started again only by leaving AUTO first. ArduRover:
    /// its MISSION_START handler only asks for AUTO (`GCS_MAVLINK_Rover::
    /// handle_command_int_packet`, Rover/GCS_MAVLink_Rover.cpp) and `Rover::set_mode`
    /// returns at once for the mode it is in, so `ModeAuto::_enter` (which calls
    /// `mission.start_or_resume()`) does not run; a finished mission leaves the rover in AUTO
    /// (MIS_DONE_BEHAVE 0). Seen on ArduRover SITL V4.7.0-dev (90700977): a second
    /// MISSION_START is ACCEPTED, and no item runs, no MISSION_ITEM_REACHED comes,
    /// MISSION_CURRENT stays NOT_STARTED. ArduCopter's handler also calls
    /// `start_or_resume()` when the mission is not running; PX4 restarts it.
    pub fn mission_start_needs_leaving_auto(&self) -> bool {
        self.autopilot == Autopilot::ArduPilot && self.class == VehicleClass::Rover
    }

    /// MISSION_CURRENT / MISSION_ITEM_REACHED seq → user item index (None for ArduPilot's
    /// home, seq 0).
    pub fn user_seq(&self, wire_seq: u16) -> Option<u16> {
        if self.home_item() {
            wire_seq.checked_sub(1)
        } else {
            Some(wire_seq)
        }
    }

    /// User item index → wire seq.
    pub fn wire_seq(&self, user_seq: u16) -> u16 {
        if self.home_item() {
            user_seq.saturating_add(1)
        } else {
            user_seq
        }
    }

    fn not_applicable(&self, action: &'static str) -> FlavourError {
        FlavourError::NotApplicable {
            action,
            flavour: self.to_string(),
        }
    }

    /// How to arm and take off to `alt_rel` metres above home. `home_amsl` is home's
    /// altitude above mean sea level (needed by PX4).
    pub fn takeoff(
        &self,
        target: Endpoint,
        alt_rel: f32,
        home_amsl: Option<f32>,
    ) -> Result<Vec<Step>, FlavourError> {
        if !self.flies() {
            return Err(self.not_applicable("take-off"));
        }
        let nan = f32::NAN;
        match self.autopilot {
            Autopilot::ArduPilot => Ok(vec![
                Step::SetMode(self.guided_mode()?),
                Step::Arm,
                Step::Command(Command::long(
                    target,
                    MavCmd::MAV_CMD_NAV_TAKEOFF,
                    [0.0, 0.0, 0.0, nan, 0.0, 0.0, alt_rel],
                )),
            ]),
            Autopilot::Px4 => {
                let home = home_amsl.ok_or(FlavourError::Unknown {
                    action: "take-off",
                    what: "the home altitude (HOME_POSITION)",
                })?;
                Ok(vec![
                    Step::Arm,
                    Step::Command(Command::long(
                        target,
                        MavCmd::MAV_CMD_NAV_TAKEOFF,
                        [nan, 0.0, 0.0, nan, nan, nan, home + alt_rel],
                    )),
                ])
            }
            Autopilot::Other(_) => Err(self.not_applicable("take-off")),
        }
    }

    /// How to start the uploaded mission (the vehicle is armed, and airborne if it flies).
    pub fn start_mission(&self, target: Endpoint) -> Result<Vec<Step>, FlavourError> {
        match self.autopilot {
            Autopilot::ArduPilot | Autopilot::Px4 => Ok(vec![Step::Command(Command::long(
                target,
                MavCmd::MAV_CMD_MISSION_START,
                [0.0; 7],
            ))]),
            Autopilot::Other(_) => Err(self.not_applicable("starting a mission")),
        }
    }

    /// How to go to (`lat_e7`, `lon_e7`) at `alt_rel` m above home now.
    pub fn goto(
        &self,
        target: Endpoint,
        lat_e7: i32,
        lon_e7: i32,
        alt_rel: f32,
        home_amsl: Option<f32>,
    ) -> Result<Vec<Step>, FlavourError> {
        self.goto_facing(target, lat_e7, lon_e7, alt_rel, home_amsl, None)
    }

    /// [`Flavour::goto`], and with `yaw_deg` (degrees clockwise from north) PX4 also turns to
    /// that heading there: DO_REPOSITION param4 is the yaw setpoint, in radians as PX4's
    /// navigator copies it into the position setpoint (`rep->current.yaw = cmd.param4`,
    /// navigator_main.cpp; MAVSDK's `goto_location` converts degrees to radians likewise).
    /// ArduPilot turns with [`Flavour::set_yaw`] instead, so its param4 stays NaN.
    pub fn goto_facing(
        &self,
        target: Endpoint,
        lat_e7: i32,
        lon_e7: i32,
        alt_rel: f32,
        home_amsl: Option<f32>,
        yaw_deg: Option<f32>,
    ) -> Result<Vec<Step>, FlavourError> {
        // MAV_DO_REPOSITION_FLAGS_CHANGE_MODE = 1; param1 speed -1 = default; param4 yaw NaN
        // = keep the autopilot's yaw behaviour.
        let yaw = match (self.autopilot, yaw_deg) {
            (Autopilot::Px4, Some(y)) if y.is_finite() => y.to_radians(),
            _ => f32::NAN,
        };
        let params = [-1.0, 1.0, 0.0, yaw];
        match self.autopilot {
            Autopilot::ArduPilot => Ok(vec![Step::Command(Command::int(
                target,
                MavCmd::MAV_CMD_DO_REPOSITION,
                MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                params,
                lat_e7,
                lon_e7,
                alt_rel,
            ))]),
            Autopilot::Px4 => {
                let home = home_amsl.ok_or(FlavourError::Unknown {
                    action: "go to",
                    what: "the home altitude (HOME_POSITION)",
                })?;
                Ok(vec![Step::Command(Command::int(
                    target,
                    MavCmd::MAV_CMD_DO_REPOSITION,
                    MavFrame::MAV_FRAME_GLOBAL,
                    params,
                    lat_e7,
                    lon_e7,
                    home + alt_rel,
                ))])
            }
            Autopilot::Other(_) => Err(self.not_applicable("go to")),
        }
    }

    /// How to turn to the absolute heading `yaw_deg` (degrees clockwise from north, 0..360)
    /// where the vehicle is, in GUIDED: ArduPilot's MAV_CMD_CONDITION_YAW (param1 the angle,
    /// param2 0 = the default rate, param3 0 = the shorter way, param4 0 = absolute; Copter's
    /// GCS_MAVLINK handler sets a fixed yaw and answers FAILED for an angle outside 0..360).
    /// PX4 does not execute CONDITION_YAW outside missions: give the yaw to
    /// [`Flavour::goto_facing`].
    pub fn set_yaw(&self, target: Endpoint, yaw_deg: f32) -> Result<Vec<Step>, FlavourError> {
        match self.autopilot {
            Autopilot::ArduPilot if self.class == VehicleClass::Copter => {
                Ok(vec![Step::Command(Command::long(
                    target,
                    MavCmd::MAV_CMD_CONDITION_YAW,
                    [yaw_deg.rem_euclid(360.0), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                ))])
            }
            _ => Err(self.not_applicable("turning to a heading with CONDITION_YAW")),
        }
    }

    /// The ArduPilot fallback for [`Flavour::goto`] when DO_REPOSITION is unsupported:
    /// GUIDED, then SET_POSITION_TARGET_GLOBAL_INT (position only).
    pub fn goto_fallback(
        &self,
        target: Endpoint,
        lat_e7: i32,
        lon_e7: i32,
        alt_rel: f32,
    ) -> Result<Vec<Step>, FlavourError> {
        if self.autopilot != Autopilot::ArduPilot {
            return Err(self.not_applicable("SET_POSITION_TARGET_GLOBAL_INT go to"));
        }
        // Ignore velocity, acceleration, yaw and yaw rate: bits 3..=11 (0x0FF8).
        let mask = PositionTargetTypemask::from_bits_retain(0x0FF8);
        Ok(vec![
            Step::SetMode(self.guided_mode()?),
            Step::Send(Box::new(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
                SET_POSITION_TARGET_GLOBAL_INT_DATA {
                    time_boot_ms: 0,
                    lat_int: lat_e7,
                    lon_int: lon_e7,
                    alt: alt_rel,
                    vx: 0.0,
                    vy: 0.0,
                    vz: 0.0,
                    afx: 0.0,
                    afy: 0.0,
                    afz: 0.0,
                    yaw: 0.0,
                    yaw_rate: 0.0,
                    type_mask: mask,
                    target_system: target.sysid,
                    target_component: target.compid,
                    coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                },
            ))),
        ])
    }

    /// How to return to launch.
    pub fn rtl(&self, target: Endpoint) -> Result<Vec<Step>, FlavourError> {
        match self.autopilot {
            Autopilot::ArduPilot => Ok(vec![Step::SetMode(self.rtl_mode()?)]),
            Autopilot::Px4 => Ok(vec![Step::Command(Command::long(
                target,
                MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
                [0.0; 7],
            ))]),
            Autopilot::Other(_) => Err(self.not_applicable("return to launch")),
        }
    }

    /// How to land here.
    pub fn land(&self, target: Endpoint) -> Result<Vec<Step>, FlavourError> {
        if !self.flies() {
            return Err(self.not_applicable("landing"));
        }
        match self.autopilot {
            Autopilot::ArduPilot => Ok(vec![Step::SetMode(Mode::Copter(CopterMode::Land))]),
            Autopilot::Px4 => {
                let nan = f32::NAN;
                Ok(vec![Step::Command(Command::long(
                    target,
                    MavCmd::MAV_CMD_NAV_LAND,
                    [0.0, 0.0, 0.0, nan, nan, nan, nan],
                ))])
            }
            Autopilot::Other(_) => Err(self.not_applicable("landing")),
        }
    }
}

impl std::fmt::Display for Flavour {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ap = match self.autopilot {
            Autopilot::Other(n) => format!("autopilot {n}"),
            known => known.name().to_string(),
        };
        let class = match self.class {
            VehicleClass::Copter => "copter",
            VehicleClass::Rover => "rover",
            VehicleClass::Plane => "plane",
            VehicleClass::Other => "vehicle",
        };
        write!(f, "{ap} {class}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fleet snapshots (JSON, read by `hitl/conformance.py`) spell the autopilot this way.
    #[test]
    fn autopilot_snapshot_spelling_and_numbers() {
        let json = |a: Autopilot| serde_json::to_string(&a).expect("serializes");
        assert_eq!(json(Autopilot::ArduPilot), r#""ArduPilot""#);
        assert_eq!(json(Autopilot::Px4), r#""Px4""#);
        assert_eq!(json(Autopilot::Other(7)), r#"{"Other":7}"#);
        for n in [0, 3, 8, 12, 255] {
            assert_eq!(Autopilot::from_mav(n).mav_autopilot(), n);
        }
        assert_eq!(Autopilot::from_mav(3), Autopilot::ArduPilot);
        assert_eq!(Autopilot::from_mav(12), Autopilot::Px4);
    }

    #[test]
    fn mode_tables_round_trip() {
        let c = Flavour::ARDU_COPTER;
        assert_eq!(c.mode("guided").unwrap().custom_mode(), 4);
        assert_eq!(c.mode_name(6), "RTL");
        assert_eq!(c.mode_name(99), "MODE(99)");
        let r = Flavour::ARDU_ROVER;
        assert_eq!(r.mode("auto").unwrap().custom_mode(), 10);
        assert_eq!(r.mode_name(15), "GUIDED");
        let p = Flavour::PX4_COPTER;
        let mission = p.mode("Mission").unwrap();
        assert_eq!(mission.custom_mode(), (4 << 24) | (4 << 16));
        assert_eq!(p.mode("auto.rtl").unwrap().name(), "RTL");
        assert_eq!(p.mode_name(mission.custom_mode() | 0x1234), "MISSION");
        assert_eq!(p.mode("position").unwrap().custom_mode(), 3 << 16);
        assert!(matches!(
            c.mode("MISSION"),
            Err(FlavourError::UnknownMode { .. })
        ));
        // DO_SET_MODE encodes main and sub mode for PX4.
        let cmd = p.set_mode_command(Endpoint::new(1, crate::proto::AUTOPILOT_COMPID), mission);
        match cmd.args {
            super::super::command::CommandArgs::Long(p) => {
                assert_eq!((p[0], p[1], p[2]), (1.0, 4.0, 4.0))
            }
            _ => panic!(),
        }
    }

    #[test]
    fn flavours_from_heartbeat_and_seq_offsets() {
        assert_eq!(Flavour::from_heartbeat(3, 2), Flavour::ARDU_COPTER);
        assert_eq!(Flavour::from_heartbeat(3, 10), Flavour::ARDU_ROVER);
        assert_eq!(Flavour::from_heartbeat(12, 13), Flavour::PX4_COPTER);
        assert_eq!(Flavour::ARDU_COPTER.user_seq(0), None);
        assert_eq!(Flavour::ARDU_COPTER.user_seq(3), Some(2));
        assert_eq!(Flavour::PX4_COPTER.user_seq(3), Some(3));
    }

    #[test]
    fn takeoff_plans_follow_each_autopilot() {
        let t = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let ap = Flavour::ARDU_COPTER.takeoff(t, 12.0, Some(100.0)).unwrap();
        assert_eq!(
            ap[0],
            Step::SetMode(Flavour::ARDU_COPTER.mode("GUIDED").unwrap())
        );
        assert_eq!(ap[1], Step::Arm);
        let px = Flavour::PX4_COPTER.takeoff(t, 12.0, Some(100.0)).unwrap();
        match &px[1] {
            Step::Command(c) => match c.args {
                super::super::command::CommandArgs::Long(p) => assert_eq!(p[6], 112.0),
                _ => panic!(),
            },
            s => panic!("{s:?}"),
        }
        assert!(Flavour::PX4_COPTER.takeoff(t, 12.0, None).is_err());
        assert!(Flavour::ARDU_ROVER.takeoff(t, 12.0, None).is_err());
        assert!(Flavour::ARDU_ROVER.land(t).is_err());
    }

    #[test]
    fn turning_to_a_heading() {
        use super::super::command::CommandArgs;
        let t = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        // ArduCopter: CONDITION_YAW, absolute, shorter way, default rate.
        let ap = Flavour::ARDU_COPTER.set_yaw(t, -90.0).unwrap();
        match &ap[0] {
            Step::Command(c) => {
                assert_eq!(c.command, MavCmd::MAV_CMD_CONDITION_YAW);
                assert_eq!(
                    c.args,
                    CommandArgs::Long([270.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
                );
            }
            s => panic!("{s:?}"),
        }
        assert!(Flavour::PX4_COPTER.set_yaw(t, 0.0).is_err());
        assert!(Flavour::ARDU_ROVER.set_yaw(t, 0.0).is_err());
        // PX4: the yaw rides in DO_REPOSITION param4, in radians; ArduPilot's stays NaN.
        let yaw4 = |f: Flavour| match &f
            .goto_facing(t, 1, 2, 10.0, Some(100.0), Some(180.0))
            .unwrap()[0]
        {
            Step::Command(Command {
                args: CommandArgs::Int { params, .. },
                ..
            }) => params[3],
            s => panic!("{s:?}"),
        };
        assert!((yaw4(Flavour::PX4_COPTER) - std::f32::consts::PI).abs() < 1e-6);
        assert!(yaw4(Flavour::ARDU_COPTER).is_nan());
    }

    #[test]
    fn takeoff_is_done_within_px4s_altitude_acceptance() {
        // PX4 stops a take-off to 5 m as soon as it is above 4.2 m.
        assert!(takeoff_reached(4.21, 5.0));
        assert!(takeoff_reached(5.3, 5.0));
        assert!(!takeoff_reached(4.0, 5.0));
        assert!(!takeoff_reached(0.0, 1.0));
    }
}
