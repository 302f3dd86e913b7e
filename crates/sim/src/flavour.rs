//! Which autopilot and which airframe a simulated vehicle imitates, and the flight modes with
//! the numbers each autopilot puts on the wire.
//!
//! The simulator's [`SimMode`] is what a simulated vehicle does; which of its autopilot's modes
//! that is, and so the numbers and names on the wire, comes from the GCS's own table,
//! [`fleetmap_core::proto::mode`] (`SimFlavour::autopilot_mode`).
//!
//! What stays the simulator's own, and why: [`SimAutopilot`] and [`SimVehicleClass`] are the parts
//! of the core's [`Autopilot`] and [`VehicleClass`] that the simulator has a model of (no
//! `Other`, no plane), so the vehicle model matches on them without an impossible arm; both
//! convert into the core's types, and [`SimFlavour`] into the core's
//! [`fleetmap_core::proto::flavour::Flavour`], the flavour the GCS reads from the simulated
//! HEARTBEAT. [`SimMode`] is a behaviour (hold, go to, fly the mission), one value across
//! flavours whose autopilot modes differ (ArduCopter LOITER, ArduRover HOLD, PX4 AUTO_LOITER).

use fleetmap_core::proto::flavour::{self as proto_flavour, Autopilot, VehicleClass};
use fleetmap_core::proto::mode::{CopterMode, Mode as ProtoMode, Px4Mode, RoverMode};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The autopilot firmware a simulated vehicle behaves like: the [`Autopilot`]s the simulator
/// imitates, ArduPilot or PX4 (`Autopilot::Other` has no behaviour to imitate, so
/// `TryFrom<Autopilot>` refuses it). Serialized in lower case, `"ardupilot"` / `"px4"`, as
/// `--vehicles` spells them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SimAutopilot {
    /// [`Autopilot::ArduPilot`] (ArduCopter / ArduRover).
    ArduPilot,
    /// [`Autopilot::Px4`].
    Px4,
}

impl From<SimAutopilot> for Autopilot {
    fn from(a: SimAutopilot) -> Autopilot {
        match a {
            SimAutopilot::ArduPilot => Autopilot::ArduPilot,
            SimAutopilot::Px4 => Autopilot::Px4,
        }
    }
}

impl TryFrom<Autopilot> for SimAutopilot {
    /// The autopilot the simulator cannot imitate.
    type Error = Autopilot;
    fn try_from(a: Autopilot) -> Result<SimAutopilot, Autopilot> {
        match a {
            Autopilot::ArduPilot => Ok(SimAutopilot::ArduPilot),
            Autopilot::Px4 => Ok(SimAutopilot::Px4),
            other @ Autopilot::Other(_) => Err(other),
        }
    }
}

impl SimAutopilot {
    /// The lower-case name of `--vehicles` and of the serialized form.
    pub(crate) fn spec_name(self) -> &'static str {
        match self {
            SimAutopilot::ArduPilot => "ardupilot",
            SimAutopilot::Px4 => "px4",
        }
    }
}

/// The airframe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SimVehicleClass {
    /// A multicopter (MAV_TYPE_QUADROTOR).
    Copter,
    /// A ground rover (MAV_TYPE_GROUND_ROVER); it never leaves the ground.
    Rover,
}

impl From<SimVehicleClass> for VehicleClass {
    fn from(k: SimVehicleClass) -> VehicleClass {
        match k {
            SimVehicleClass::Copter => VehicleClass::Copter,
            SimVehicleClass::Rover => VehicleClass::Rover,
        }
    }
}

/// Autopilot + airframe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SimFlavour {
    /// The firmware.
    pub autopilot: SimAutopilot,
    /// The airframe.
    pub kind: SimVehicleClass,
}

impl SimFlavour {
    /// ArduCopter.
    pub const ARDU_COPTER: SimFlavour = SimFlavour {
        autopilot: SimAutopilot::ArduPilot,
        kind: SimVehicleClass::Copter,
    };
    /// ArduRover.
    pub const ARDU_ROVER: SimFlavour = SimFlavour {
        autopilot: SimAutopilot::ArduPilot,
        kind: SimVehicleClass::Rover,
    };
    /// PX4 multicopter.
    pub const PX4_COPTER: SimFlavour = SimFlavour {
        autopilot: SimAutopilot::Px4,
        kind: SimVehicleClass::Copter,
    };
    /// PX4 rover.
    pub const PX4_ROVER: SimFlavour = SimFlavour {
        autopilot: SimAutopilot::Px4,
        kind: SimVehicleClass::Rover,
    };

    /// Whether this is an ArduPilot vehicle.
    pub fn is_ardupilot(self) -> bool {
        self.autopilot == SimAutopilot::ArduPilot
    }

    /// Whether this vehicle flies.
    pub fn is_copter(self) -> bool {
        self.kind == SimVehicleClass::Copter
    }

    /// The flight mode a vehicle boots into: STABILIZE (ArduCopter), HOLD (ArduRover; real
    /// rovers boot in MANUAL, but without an RC transmitter HOLD is what field setups
    /// configure with INITIAL_MODE), AUTO_LOITER ("Hold") for PX4.
    pub(crate) fn boot_mode(self) -> SimMode {
        match (self.autopilot, self.kind) {
            (SimAutopilot::ArduPilot, SimVehicleClass::Copter) => SimMode::Stabilize,
            (SimAutopilot::ArduPilot, SimVehicleClass::Rover) => SimMode::Hold,
            (SimAutopilot::Px4, _) => SimMode::Hold,
        }
    }

    /// The autopilot's mode ([`fleetmap_core::proto::mode`], the one table of numbers and names)
    /// that behaves as `mode` for this flavour, or `None` when this flavour has no such mode.
    /// ArduCopter holds in LOITER; PX4 holds in AUTO_LOITER ("HOLD"), loiters under pilot
    /// control in POSCTL and is guided in OFFBOARD.
    pub(crate) fn autopilot_mode(self, mode: SimMode) -> Option<ProtoMode> {
        use ProtoMode::{Copter, Px4, Rover};
        Some(match (self.autopilot, self.kind) {
            (SimAutopilot::ArduPilot, SimVehicleClass::Copter) => Copter(match mode {
                SimMode::Stabilize => CopterMode::Stabilize,
                SimMode::AltHold => CopterMode::AltHold,
                SimMode::Auto => CopterMode::Auto,
                SimMode::Guided => CopterMode::Guided,
                SimMode::Hold => CopterMode::Loiter,
                SimMode::Rtl => CopterMode::Rtl,
                SimMode::Land => CopterMode::Land,
                SimMode::Brake => CopterMode::Brake,
                _ => return None,
            }),
            (SimAutopilot::ArduPilot, SimVehicleClass::Rover) => Rover(match mode {
                SimMode::Manual => RoverMode::Manual,
                SimMode::Hold => RoverMode::Hold,
                SimMode::Loiter => RoverMode::Loiter,
                SimMode::Auto => RoverMode::Auto,
                SimMode::Rtl => RoverMode::Rtl,
                SimMode::Guided => RoverMode::Guided,
                SimMode::Initialising => RoverMode::Initialising,
                _ => return None,
            }),
            (SimAutopilot::Px4, kind) => Px4(match mode {
                SimMode::Manual => Px4Mode::Manual,
                SimMode::AltHold if kind == SimVehicleClass::Copter => Px4Mode::AltCtl,
                SimMode::Stabilize => Px4Mode::Stabilized,
                SimMode::Loiter => Px4Mode::PosCtl,
                SimMode::Takeoff => Px4Mode::Takeoff,
                SimMode::Hold => Px4Mode::Hold,
                SimMode::Auto => Px4Mode::Mission,
                SimMode::Rtl => Px4Mode::Rtl,
                SimMode::Land if kind == SimVehicleClass::Copter => Px4Mode::Land,
                SimMode::Guided => Px4Mode::Offboard,
                _ => return None,
            }),
        })
    }

    /// The HEARTBEAT `custom_mode` of `mode` for this flavour, or `None` when this flavour
    /// has no such mode.
    pub fn custom_mode(self, mode: SimMode) -> Option<u32> {
        self.autopilot_mode(mode).map(ProtoMode::custom_mode)
    }

    /// The mode a HEARTBEAT/SET_MODE `custom_mode` names for this flavour.
    pub(crate) fn mode_from_custom(self, custom_mode: u32) -> Option<SimMode> {
        SimMode::ALL
            .iter()
            .copied()
            .find(|m| self.custom_mode(*m) == Some(custom_mode))
    }

    /// MAV_TYPE of the HEARTBEAT.
    pub fn mav_type(self) -> u8 {
        match self.kind {
            SimVehicleClass::Copter => 2, // MAV_TYPE_QUADROTOR
            SimVehicleClass::Rover => 10, // MAV_TYPE_GROUND_ROVER
        }
    }

    /// MAV_AUTOPILOT of the HEARTBEAT.
    pub fn mav_autopilot(self) -> u8 {
        Autopilot::from(self.autopilot).mav_autopilot()
    }

    /// The name this flavour gives `mode` (as the autopilot's GCS shows it): the table's
    /// name of `SimFlavour::autopilot_mode`, or a generic upper-case name for a mode this
    /// flavour does not have.
    pub fn mode_name(self, mode: SimMode) -> &'static str {
        self.autopilot_mode(mode)
            .map_or_else(|| mode.generic_name(), ProtoMode::name)
    }
}

impl From<SimFlavour> for proto_flavour::Flavour {
    /// The core's flavour of this simulated vehicle: what the GCS reads from its HEARTBEAT.
    fn from(f: SimFlavour) -> proto_flavour::Flavour {
        proto_flavour::Flavour {
            autopilot: f.autopilot.into(),
            class: f.kind.into(),
        }
    }
}

impl fmt::Display for SimFlavour {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let k = match self.kind {
            SimVehicleClass::Copter => "copter",
            SimVehicleClass::Rover => "rover",
        };
        write!(f, "{k}:{}", self.autopilot.spec_name())
    }
}

/// Why a `TYPE:AUTOPILOT` vehicle spec does not read ([`SimFlavour`]'s `FromStr`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FlavourSpecError {
    /// No `:` between the type and the autopilot.
    #[error("expected TYPE:AUTOPILOT (e.g. copter:ardupilot), got {0:?}")]
    Syntax(String),
    /// A vehicle type the simulator has no model of.
    #[error("unknown vehicle type {0:?} (copter or rover)")]
    VehicleType(String),
    /// An autopilot the simulator does not imitate.
    #[error("unknown autopilot {0:?} (ardupilot or px4)")]
    Autopilot(String),
}

impl FromStr for SimFlavour {
    type Err = FlavourSpecError;
    /// `copter:ardupilot`, `rover:px4`, … (the `--vehicles` syntax without the count).
    fn from_str(s: &str) -> Result<SimFlavour, FlavourSpecError> {
        let (k, a) = s
            .split_once(':')
            .ok_or_else(|| FlavourSpecError::Syntax(s.to_string()))?;
        let kind = match k.trim().to_ascii_lowercase().as_str() {
            "copter" | "quad" | "multicopter" => SimVehicleClass::Copter,
            "rover" => SimVehicleClass::Rover,
            other => return Err(FlavourSpecError::VehicleType(other.to_string())),
        };
        let autopilot = match a.trim().to_ascii_lowercase().as_str() {
            "ardupilot" | "apm" => SimAutopilot::ArduPilot,
            "px4" => SimAutopilot::Px4,
            other => return Err(FlavourSpecError::Autopilot(other.to_string())),
        };
        Ok(SimFlavour { autopilot, kind })
    }
}

/// A flight mode, independent of the numbers an autopilot gives it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SimMode {
    /// ArduCopter STABILIZE / PX4 STABILIZED: pilot-controlled; the simulator holds still.
    Stabilize,
    /// ArduCopter ALT_HOLD / PX4 ALTCTL.
    AltHold,
    /// ArduRover MANUAL / PX4 MANUAL.
    Manual,
    /// Hold position: ArduCopter LOITER, ArduRover HOLD, PX4 AUTO_LOITER ("Hold").
    Hold,
    /// ArduRover LOITER / PX4 POSCTL.
    Loiter,
    /// Fly the uploaded mission (ArduPilot AUTO, PX4 AUTO_MISSION).
    Auto,
    /// Go to positions given by the GCS (ArduPilot GUIDED, PX4 OFFBOARD).
    Guided,
    /// Return to launch.
    Rtl,
    /// Land here.
    Land,
    /// PX4 AUTO_TAKEOFF.
    Takeoff,
    /// ArduCopter BRAKE.
    Brake,
    /// ArduRover INITIALISING (boot).
    Initialising,
}

impl SimMode {
    /// Every mode.
    pub const ALL: [SimMode; 12] = [
        SimMode::Stabilize,
        SimMode::AltHold,
        SimMode::Manual,
        SimMode::Hold,
        SimMode::Loiter,
        SimMode::Auto,
        SimMode::Guided,
        SimMode::Rtl,
        SimMode::Land,
        SimMode::Takeoff,
        SimMode::Brake,
        SimMode::Initialising,
    ];

    fn generic_name(self) -> &'static str {
        match self {
            SimMode::Stabilize => "STABILIZE",
            SimMode::AltHold => "ALT_HOLD",
            SimMode::Manual => "MANUAL",
            SimMode::Hold => "HOLD",
            SimMode::Loiter => "LOITER",
            SimMode::Auto => "AUTO",
            SimMode::Guided => "GUIDED",
            SimMode::Rtl => "RTL",
            SimMode::Land => "LAND",
            SimMode::Takeoff => "TAKEOFF",
            SimMode::Brake => "BRAKE",
            SimMode::Initialising => "INITIALISING",
        }
    }

    /// Whether the autopilot needs a position estimate to enter this mode.
    pub(crate) fn requires_position(self) -> bool {
        matches!(
            self,
            SimMode::Hold
                | SimMode::Loiter
                | SimMode::Auto
                | SimMode::Guided
                | SimMode::Rtl
                | SimMode::Takeoff
                | SimMode::Brake
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_numbers_round_trip() {
        for f in [
            SimFlavour::ARDU_COPTER,
            SimFlavour::ARDU_ROVER,
            SimFlavour::PX4_COPTER,
            SimFlavour::PX4_ROVER,
        ] {
            for m in SimMode::ALL {
                if let Some(c) = f.custom_mode(m) {
                    assert_eq!(f.mode_from_custom(c), Some(m), "{f} {m:?}");
                }
            }
        }
        assert_eq!(
            SimFlavour::ARDU_COPTER.custom_mode(SimMode::Guided),
            Some(4)
        );
        assert_eq!(SimFlavour::ARDU_ROVER.custom_mode(SimMode::Auto), Some(10));
        assert_eq!(
            SimFlavour::PX4_COPTER.custom_mode(SimMode::Auto),
            Some((4 << 16) | (4 << 24))
        );
        assert_eq!(SimFlavour::PX4_ROVER.custom_mode(SimMode::Land), None);
    }

    /// The numbers and names the simulator put on the wire before it read them from
    /// `proto::mode`, for every flavour and mode.
    #[test]
    fn wire_numbers_and_names_unchanged() {
        let px4 = |main: u32, sub: u32| Some((main << 16) | (sub << 24));
        use SimMode::*;
        let expected: [(SimFlavour, SimMode, Option<u32>, &str); 48] = [
            (SimFlavour::ARDU_COPTER, Stabilize, Some(0), "STABILIZE"),
            (SimFlavour::ARDU_COPTER, AltHold, Some(2), "ALT_HOLD"),
            (SimFlavour::ARDU_COPTER, Manual, None, "MANUAL"),
            (SimFlavour::ARDU_COPTER, Hold, Some(5), "LOITER"),
            (SimFlavour::ARDU_COPTER, Loiter, None, "LOITER"),
            (SimFlavour::ARDU_COPTER, Auto, Some(3), "AUTO"),
            (SimFlavour::ARDU_COPTER, Guided, Some(4), "GUIDED"),
            (SimFlavour::ARDU_COPTER, Rtl, Some(6), "RTL"),
            (SimFlavour::ARDU_COPTER, Land, Some(9), "LAND"),
            (SimFlavour::ARDU_COPTER, Takeoff, None, "TAKEOFF"),
            (SimFlavour::ARDU_COPTER, Brake, Some(17), "BRAKE"),
            (SimFlavour::ARDU_COPTER, Initialising, None, "INITIALISING"),
            (SimFlavour::ARDU_ROVER, Stabilize, None, "STABILIZE"),
            (SimFlavour::ARDU_ROVER, AltHold, None, "ALT_HOLD"),
            (SimFlavour::ARDU_ROVER, Manual, Some(0), "MANUAL"),
            (SimFlavour::ARDU_ROVER, Hold, Some(4), "HOLD"),
            (SimFlavour::ARDU_ROVER, Loiter, Some(5), "LOITER"),
            (SimFlavour::ARDU_ROVER, Auto, Some(10), "AUTO"),
            (SimFlavour::ARDU_ROVER, Guided, Some(15), "GUIDED"),
            (SimFlavour::ARDU_ROVER, Rtl, Some(11), "RTL"),
            (SimFlavour::ARDU_ROVER, Land, None, "LAND"),
            (SimFlavour::ARDU_ROVER, Takeoff, None, "TAKEOFF"),
            (SimFlavour::ARDU_ROVER, Brake, None, "BRAKE"),
            (
                SimFlavour::ARDU_ROVER,
                Initialising,
                Some(16),
                "INITIALISING",
            ),
            (SimFlavour::PX4_COPTER, Stabilize, px4(7, 0), "STABILIZED"),
            (SimFlavour::PX4_COPTER, AltHold, px4(2, 0), "ALTCTL"),
            (SimFlavour::PX4_COPTER, Manual, px4(1, 0), "MANUAL"),
            (SimFlavour::PX4_COPTER, Hold, px4(4, 3), "HOLD"),
            (SimFlavour::PX4_COPTER, Loiter, px4(3, 0), "POSCTL"),
            (SimFlavour::PX4_COPTER, Auto, px4(4, 4), "MISSION"),
            (SimFlavour::PX4_COPTER, Guided, px4(6, 0), "OFFBOARD"),
            (SimFlavour::PX4_COPTER, Rtl, px4(4, 5), "RTL"),
            (SimFlavour::PX4_COPTER, Land, px4(4, 6), "LAND"),
            (SimFlavour::PX4_COPTER, Takeoff, px4(4, 2), "TAKEOFF"),
            (SimFlavour::PX4_COPTER, Brake, None, "BRAKE"),
            (SimFlavour::PX4_COPTER, Initialising, None, "INITIALISING"),
            (SimFlavour::PX4_ROVER, Stabilize, px4(7, 0), "STABILIZED"),
            (SimFlavour::PX4_ROVER, AltHold, None, "ALT_HOLD"),
            (SimFlavour::PX4_ROVER, Manual, px4(1, 0), "MANUAL"),
            (SimFlavour::PX4_ROVER, Hold, px4(4, 3), "HOLD"),
            (SimFlavour::PX4_ROVER, Loiter, px4(3, 0), "POSCTL"),
            (SimFlavour::PX4_ROVER, Auto, px4(4, 4), "MISSION"),
            (SimFlavour::PX4_ROVER, Guided, px4(6, 0), "OFFBOARD"),
            (SimFlavour::PX4_ROVER, Rtl, px4(4, 5), "RTL"),
            (SimFlavour::PX4_ROVER, Land, None, "LAND"),
            (SimFlavour::PX4_ROVER, Takeoff, px4(4, 2), "TAKEOFF"),
            (SimFlavour::PX4_ROVER, Brake, None, "BRAKE"),
            (SimFlavour::PX4_ROVER, Initialising, None, "INITIALISING"),
        ];
        for (f, m, number, name) in expected {
            assert_eq!(f.custom_mode(m), number, "{f} {m:?}");
            assert_eq!(f.mode_name(m), name, "{f} {m:?}");
        }
    }

    /// The serialized form stays the lower-case one of `--vehicles`.
    #[test]
    fn serializes_in_lower_case() {
        assert_eq!(
            serde_json::to_string(&SimFlavour::ARDU_COPTER).expect("serializes"),
            r#"{"autopilot":"ardupilot","kind":"copter"}"#
        );
        assert_eq!(
            serde_json::from_str::<SimFlavour>(r#"{"autopilot":"px4","kind":"rover"}"#)
                .expect("reads"),
            SimFlavour::PX4_ROVER
        );
        assert!(
            serde_json::from_str::<SimFlavour>(r#"{"autopilot":"other","kind":"rover"}"#).is_err()
        );
    }

    #[test]
    fn sim_autopilot_is_the_imitable_part_of_autopilot() {
        for a in [SimAutopilot::ArduPilot, SimAutopilot::Px4] {
            assert_eq!(SimAutopilot::try_from(Autopilot::from(a)), Ok(a));
        }
        assert_eq!(
            SimAutopilot::try_from(Autopilot::Other(8)),
            Err(Autopilot::Other(8))
        );
        assert_eq!(SimFlavour::ARDU_ROVER.mav_autopilot(), 3);
        assert_eq!(SimFlavour::PX4_COPTER.mav_autopilot(), 12);
    }

    /// The GCS reads each simulated flavour's HEARTBEAT (MAV_AUTOPILOT, MAV_TYPE) as the core
    /// flavour the simulated one converts into.
    #[test]
    fn heartbeat_reads_back_as_the_core_flavour() {
        for (f, core) in [
            (SimFlavour::ARDU_COPTER, proto_flavour::Flavour::ARDU_COPTER),
            (SimFlavour::ARDU_ROVER, proto_flavour::Flavour::ARDU_ROVER),
            (SimFlavour::PX4_COPTER, proto_flavour::Flavour::PX4_COPTER),
            (SimFlavour::PX4_ROVER, proto_flavour::Flavour::PX4_ROVER),
        ] {
            assert_eq!(proto_flavour::Flavour::from(f), core, "{f}");
            assert_eq!(
                proto_flavour::Flavour::from_heartbeat(f.mav_autopilot(), f.mav_type()),
                core,
                "{f}"
            );
        }
    }

    #[test]
    fn parses_vehicle_specs() {
        assert_eq!(
            "copter:ardupilot".parse::<SimFlavour>(),
            Ok(SimFlavour::ARDU_COPTER)
        );
        assert_eq!("Rover:PX4".parse::<SimFlavour>(), Ok(SimFlavour::PX4_ROVER));
        assert!("plane:px4".parse::<SimFlavour>().is_err());
        assert_eq!(
            "copter".parse::<SimFlavour>(),
            Err(FlavourSpecError::Syntax("copter".into()))
        );
        assert_eq!(
            "plane:px4".parse::<SimFlavour>().map_err(|e| e.to_string()),
            Err("unknown vehicle type \"plane\" (copter or rover)".into())
        );
    }
}
