//! One fleet-pane row per vehicle: identity (role, firmware, airframe), battery, GPS, link,
//! camera and mission progress, as the adapter reads them from the vehicle's telemetry.

use fleetmap_core::geo::Cell;
use serde::{Deserialize, Serialize};

/// A vehicle's role in the mission, the mission file's: replay files spell it as the
/// mission file does, `"drone"` or `"station"`, and a row without one reads as a drone
/// ([`VehicleRow::default`]).
pub(crate) use fleetmap_core::mission::definition::Role;

/// The autopilot firmware, from HEARTBEAT.autopilot: the protocol layer's vocabulary.
pub(crate) use fleetmap_core::proto::flavour::Autopilot;

/// How replay files spell [`VehicleRow::autopilot`]: `"ardu_pilot"`, `"px4"`, `"other"` (the
/// MAV_AUTOPILOT number of `Other` is not recorded; it reads back as [`Autopilot::default`]).
mod autopilot_replay {
    use super::Autopilot;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// The recorded form (snake_case unit variants).
    #[derive(Serialize, Deserialize)]
    #[serde(rename_all = "snake_case")]
    enum Recorded {
        ArduPilot,
        Px4,
        Other,
    }

    pub(super) fn serialize<S: Serializer>(a: &Autopilot, s: S) -> Result<S::Ok, S::Error> {
        match a {
            Autopilot::ArduPilot => Recorded::ArduPilot,
            Autopilot::Px4 => Recorded::Px4,
            Autopilot::Other(_) => Recorded::Other,
        }
        .serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Autopilot, D::Error> {
        Ok(match Recorded::deserialize(d)? {
            Recorded::ArduPilot => Autopilot::ArduPilot,
            Recorded::Px4 => Autopilot::Px4,
            Recorded::Other => Autopilot::default(),
        })
    }
}

/// The airframe class, from HEARTBEAT.type: the protocol layer's vocabulary.
pub(crate) use fleetmap_core::proto::flavour::VehicleClass;

/// How replay files spell [`VehicleRow::vehicle_type`]: `"copter"`, `"plane"`, `"rover"`,
/// `"other"`.
mod class_replay {
    use super::VehicleClass;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// The recorded form (snake_case unit variants).
    #[derive(Serialize, Deserialize)]
    #[serde(rename_all = "snake_case")]
    enum Recorded {
        Copter,
        Plane,
        Rover,
        Other,
    }

    pub(super) fn serialize<S: Serializer>(c: &VehicleClass, s: S) -> Result<S::Ok, S::Error> {
        match c {
            VehicleClass::Copter => Recorded::Copter,
            VehicleClass::Plane => Recorded::Plane,
            VehicleClass::Rover => Recorded::Rover,
            VehicleClass::Other => Recorded::Other,
        }
        .serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<VehicleClass, D::Error> {
        Ok(match Recorded::deserialize(d)? {
            Recorded::Copter => VehicleClass::Copter,
            Recorded::Plane => VehicleClass::Plane,
            Recorded::Rover => VehicleClass::Rover,
            Recorded::Other => VehicleClass::Other,
        })
    }
}

/// Battery state (BATTERY_STATUS / SYS_STATUS).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Battery {
    /// Remaining charge, percent (0–100), when the autopilot estimates it.
    pub remaining_pct: Option<u8>,
    /// Pack voltage, volts.
    pub(crate) voltage_v: Option<f32>,
    /// Number of cells in series, when known: the voltage thresholds are per cell.
    pub cells: Option<u8>,
}

/// GPS fix type (GPS_RAW_INT.fix_type).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum GpsFix {
    /// No GPS connected.
    #[default]
    NoGps,
    /// GPS present, no fix.
    NoFix,
    /// 2D fix.
    Fix2d,
    /// 3D fix.
    Fix3d,
    /// DGPS/SBAS-aided 3D fix.
    Dgps,
    /// RTK float.
    RtkFloat,
    /// RTK fixed.
    RtkFixed,
}

impl GpsFix {
    /// Short label for the fleet table.
    pub fn label(self) -> &'static str {
        match self {
            GpsFix::NoGps => "none",
            GpsFix::NoFix => "nofix",
            GpsFix::Fix2d => "2D",
            GpsFix::Fix3d => "3D",
            GpsFix::Dgps => "DGPS",
            GpsFix::RtkFloat => "RTKfl",
            GpsFix::RtkFixed => "RTKfx",
        }
    }

    /// Whether the fix is good enough to fly a mission (3D or better).
    pub(crate) fn is_3d(self) -> bool {
        self >= GpsFix::Fix3d
    }
}

/// GPS state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Gps {
    /// Fix type.
    pub fix: GpsFix,
    /// Satellites visible, when reported.
    pub satellites: Option<u8>,
}

/// Link state for one vehicle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LinkState {
    /// Share of expected messages received recently, percent (0–100), when measured.
    pub(crate) quality_pct: Option<u8>,
    /// True when no heartbeat arrived within the liveness timeout.
    pub lost: bool,
    /// Seconds since the last message from this vehicle, when known.
    pub(crate) last_heard_s: Option<f32>,
    /// Bytes per second the link carries for this vehicle, both directions together, when
    /// measured.
    #[serde(default)]
    pub(crate) bytes_per_s: Option<f32>,
    /// What the link is planned for, bytes per second both directions together (`None`:
    /// unlimited).
    #[serde(default)]
    pub(crate) budget_bytes_per_s: Option<u32>,
    /// The telemetry radio's signal strength at the GCS's end and at the vehicle's
    /// (RADIO_STATUS rssi, remrssi), when a radio reports itself.
    #[serde(default)]
    pub(crate) rssi: Option<(u8, u8)>,
}

/// The vehicle's camera component, as its own messages tell it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CameraHealth {
    /// Seconds since its last heartbeat (1 Hz in the MAVLink camera protocol).
    pub heard_s: f32,
    /// It has gone silent: no heartbeat for three beats (the fleet's window for a camera).
    pub silent: bool,
    /// Pictures it took (CAMERA_IMAGE_CAPTURED, each counted once).
    pub pictures: u32,
    /// Measurements it made on board and sent (green shares, runway regions).
    pub measurements: u32,
}

/// Position in the uploaded mission.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MissionProgress {
    /// Current item (MISSION_CURRENT.seq).
    pub current: u16,
    /// Number of items (MISSION_CURRENT.total or the uploaded count).
    pub total: u16,
}

/// One row of the fleet pane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct VehicleRow {
    /// MAVLink system id.
    pub sysid: u8,
    /// Drone or charging station.
    pub role: Role,
    /// Firmware.
    #[serde(with = "autopilot_replay")]
    pub autopilot: Autopilot,
    /// Airframe class.
    #[serde(with = "class_replay")]
    pub(crate) vehicle_type: VehicleClass,
    /// Flight mode name as the autopilot flavour names it ("AUTO", "GUIDED", "Mission", …).
    pub mode: String,
    /// Motors armed.
    pub armed: bool,
    /// Battery.
    pub battery: Battery,
    /// GPS.
    pub gps: Gps,
    /// Altitude above home, metres.
    pub alt_m: Option<f32>,
    /// Ground speed, metres per second.
    pub speed_mps: Option<f32>,
    /// Mission item / total.
    pub mission: Option<MissionProgress>,
    /// Link state.
    pub link: LinkState,
    /// The grid cell the vehicle is over, when its position is known and on the grid.
    pub cell: Option<Cell>,
    /// What the mission runner has it doing ("sweep lane 3", "DFS (4, 2)", "battery swap").
    pub activity: Option<String>,
    /// Its camera; `None` when no camera component was ever heard on this system.
    pub camera: Option<CameraHealth>,
}

/// A row of nothing heard yet: a drone (the role a replay's row without one reads as).
impl Default for VehicleRow {
    fn default() -> Self {
        VehicleRow {
            sysid: 0,
            role: Role::Drone,
            autopilot: Autopilot::default(),
            vehicle_type: VehicleClass::default(),
            mode: String::new(),
            armed: false,
            battery: Battery::default(),
            gps: Gps::default(),
            alt_m: None,
            speed_mps: None,
            mission: None,
            link: LinkState::default(),
            cell: None,
            activity: None,
            camera: None,
        }
    }
}
