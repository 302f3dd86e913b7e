//! The one table of flight modes, per autopilot: each mode's name and the HEARTBEAT
//! `custom_mode` number the autopilot puts on the wire. The GCS ([`super::flavour::Flavour`])
//! and the simulator (its `sim::flavour`) both read their numbers and names from here.
//!
//! Sources:
//! * ArduCopter `enum class Number` (ArduPilot `ArduCopter/mode.h`).
//! * ArduRover `enum class Number` (ArduPilot `Rover/mode.h`).
//! * PX4 main / sub modes (PX4-Autopilot `src/modules/commander/px4_custom_mode.h`):
//!   `custom_mode = sub_mode << 24 | main_mode << 16`; names as QGroundControl shows them
//!   (`src/FirmwarePlugin/PX4/PX4FirmwarePlugin.cc`), upper-cased.

/// Declares one autopilot's mode enum: each variant with its upper-case name and its
/// `custom_mode`, the list of all of them, and the table of [`Mode`]s it makes.
macro_rules! mode_table {
    (
        $(#[$doc:meta])*
        $name:ident => $wrap:path {
            $( $(#[$vdoc:meta])* $variant:ident = $text:literal, $number:expr; )*
        }
    ) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum $name {
            $( $(#[$vdoc])* $variant, )*
        }

        impl $name {
            /// Every mode, in the order of the autopilot's numbering.
            pub const ALL: &'static [$name] = &[$($name::$variant),*];

            /// The table of [`Mode`]s (the same order as [`Self::ALL`]).
            pub(crate) const MODES: &'static [Mode] = &[$($wrap($name::$variant)),*];

            /// The upper-case name the autopilot's ground station shows.
            pub const fn name(self) -> &'static str {
                match self {
                    $( $name::$variant => $text, )*
                }
            }

            /// The HEARTBEAT `custom_mode` (and DO_SET_MODE's encoding of it).
            pub const fn custom_mode(self) -> u32 {
                match self {
                    $( $name::$variant => $number, )*
                }
            }
        }
    };
}

/// PX4's `custom_mode` of (`main`, `sub`) mode.
const fn px4(main: u32, sub: u32) -> u32 {
    (sub << 24) | (main << 16)
}

mode_table! {
    /// ArduCopter modes (`ArduCopter/mode.h`); ArduPilot planes and other frames use this
    /// table too.
    CopterMode => Mode::Copter {
        /// Manual attitude control.
        Stabilize = "STABILIZE", 0;
        /// Manual rate control.
        Acro = "ACRO", 1;
        /// Altitude hold, manual horizontal control.
        AltHold = "ALT_HOLD", 2;
        /// Flies the uploaded mission.
        Auto = "AUTO", 3;
        /// Goes where the GCS says.
        Guided = "GUIDED", 4;
        /// Holds position (pilot can nudge).
        Loiter = "LOITER", 5;
        /// Return to launch.
        Rtl = "RTL", 6;
        /// Circles a point.
        Circle = "CIRCLE", 7;
        /// Lands where it is.
        Land = "LAND", 9;
        /// Drift.
        Drift = "DRIFT", 11;
        /// Sport.
        Sport = "SPORT", 13;
        /// Flip.
        Flip = "FLIP", 14;
        /// Autotune.
        Autotune = "AUTOTUNE", 15;
        /// Position hold.
        PosHold = "POSHOLD", 16;
        /// Stops at once and holds, ignoring the sticks.
        Brake = "BRAKE", 17;
        /// Throw to launch.
        Throw = "THROW", 18;
        /// ADS-B avoidance.
        AvoidAdsb = "AVOID_ADSB", 19;
        /// Guided without GPS.
        GuidedNoGps = "GUIDED_NOGPS", 20;
        /// Returns along the path flown.
        SmartRtl = "SMART_RTL", 21;
        /// Optical-flow hold.
        FlowHold = "FLOWHOLD", 22;
        /// Follows another vehicle.
        Follow = "FOLLOW", 23;
        /// Zigzag.
        ZigZag = "ZIGZAG", 24;
        /// System identification.
        SystemId = "SYSTEMID", 25;
        /// Helicopter autorotation.
        Autorotate = "AUTOROTATE", 26;
        /// Return by the mission's landing sequence.
        AutoRtl = "AUTO_RTL", 27;
        /// Turtle (flip over after a crash).
        Turtle = "TURTLE", 28;
    }
}

mode_table! {
    /// ArduRover modes (`Rover/mode.h`).
    RoverMode => Mode::Rover {
        /// Manual.
        Manual = "MANUAL", 0;
        /// Rate control.
        Acro = "ACRO", 1;
        /// Steering.
        Steering = "STEERING", 3;
        /// Stops and stays stopped.
        Hold = "HOLD", 4;
        /// Holds position, correcting drift.
        Loiter = "LOITER", 5;
        /// Follows another vehicle.
        Follow = "FOLLOW", 6;
        /// Simple.
        Simple = "SIMPLE", 7;
        /// Docks.
        Dock = "DOCK", 8;
        /// Circles a point.
        Circle = "CIRCLE", 9;
        /// Drives the uploaded mission.
        Auto = "AUTO", 10;
        /// Return to launch.
        Rtl = "RTL", 11;
        /// Returns along the path driven.
        SmartRtl = "SMART_RTL", 12;
        /// Goes where the GCS says.
        Guided = "GUIDED", 15;
        /// Booting.
        Initialising = "INITIALISING", 16;
    }
}

mode_table! {
    /// PX4 modes (`px4_custom_mode.h`), one per main mode or AUTO sub mode.
    Px4Mode => Mode::Px4 {
        /// MANUAL.
        Manual = "MANUAL", px4(1, 0);
        /// ALTCTL (altitude).
        AltCtl = "ALTCTL", px4(2, 0);
        /// POSCTL (position).
        PosCtl = "POSCTL", px4(3, 0);
        /// POSCTL / ORBIT.
        Orbit = "ORBIT", px4(3, 1);
        /// AUTO / READY.
        Ready = "READY", px4(4, 1);
        /// AUTO / TAKEOFF.
        Takeoff = "TAKEOFF", px4(4, 2);
        /// AUTO / LOITER ("Hold"): holds where it is; DO_REPOSITION flies in it.
        Hold = "HOLD", px4(4, 3);
        /// AUTO / MISSION.
        Mission = "MISSION", px4(4, 4);
        /// AUTO / RTL.
        Rtl = "RTL", px4(4, 5);
        /// AUTO / LAND.
        Land = "LAND", px4(4, 6);
        /// AUTO / FOLLOW_TARGET.
        FollowMe = "FOLLOW_ME", px4(4, 8);
        /// AUTO / PRECLAND.
        PrecLand = "PRECLAND", px4(4, 9);
        /// ACRO.
        Acro = "ACRO", px4(5, 0);
        /// OFFBOARD: setpoints streamed by a companion or the GCS.
        Offboard = "OFFBOARD", px4(6, 0);
        /// STABILIZED.
        Stabilized = "STABILIZED", px4(7, 0);
    }
}

/// A flight mode of one autopilot (and, for ArduPilot, one vehicle class).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// An ArduCopter mode.
    Copter(CopterMode),
    /// An ArduRover mode.
    Rover(RoverMode),
    /// A PX4 mode.
    Px4(Px4Mode),
}

impl Mode {
    /// Upper-case name, as the autopilot's ground station shows it.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Copter(m) => m.name(),
            Mode::Rover(m) => m.name(),
            Mode::Px4(m) => m.name(),
        }
    }

    /// HEARTBEAT `custom_mode`.
    pub const fn custom_mode(self) -> u32 {
        match self {
            Mode::Copter(m) => m.custom_mode(),
            Mode::Rover(m) => m.custom_mode(),
            Mode::Px4(m) => m.custom_mode(),
        }
    }

    /// Whether this is a mode an autopilot's own failsafe switches to: a return to launch
    /// (RTL, SMART_RTL) or a landing (LAND).
    pub const fn is_failsafe_return_or_land(self) -> bool {
        matches!(
            self,
            Mode::Copter(CopterMode::Rtl | CopterMode::Land | CopterMode::SmartRtl)
                | Mode::Rover(RoverMode::Rtl | RoverMode::SmartRtl)
                | Mode::Px4(Px4Mode::Rtl | Px4Mode::Land)
        )
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names and numbers are unique within each table, and each table lists its enum.
    #[test]
    fn tables_are_one_to_one() {
        for table in [CopterMode::MODES, RoverMode::MODES, Px4Mode::MODES] {
            for (i, a) in table.iter().enumerate() {
                for b in &table[i + 1..] {
                    assert_ne!(a.name(), b.name());
                    assert_ne!(a.custom_mode(), b.custom_mode());
                }
            }
        }
        assert_eq!(CopterMode::ALL.len(), CopterMode::MODES.len());
        assert_eq!(Px4Mode::Mission.custom_mode(), (4 << 24) | (4 << 16));
        assert_eq!(Mode::Rover(RoverMode::Guided).custom_mode(), 15);
        assert_eq!(Mode::Copter(CopterMode::SmartRtl).name(), "SMART_RTL");
    }
}
