//! One MAVLink mission item, independent of the wire message that carries it.
//!
//! This is the payload of MISSION_ITEM_INT without the addressing and sequence fields: the
//! position of an item in its `Vec` is its sequence number in the *user's* numbering (no
//! ArduPilot home item at seq 0: the protocol layer adds and strips it). Latitude and
//! longitude are integers in degrees × 10⁷ exactly as on the wire, so a mission survives an
//! upload/download round trip bit for bit.

use serde::{Deserialize, Serialize};

/// MAV_CMD values used by fleetmap, as the `u16` a mission item carries: each is the dialect's
/// `MavCmd` (MAVLink common.xml), named here once so that a `match` on an item's command can use
/// them as patterns.
pub mod cmd {
    use mavlink::dialects::ardupilotmega::MavCmd;
    use num_traits::FromPrimitive;

    /// Fly to a position (param1 hold time s, param2 acceptance radius m, param4 yaw deg).
    pub const NAV_WAYPOINT: u16 = MavCmd::MAV_CMD_NAV_WAYPOINT as u16;
    /// The highest navigation command id (MAV_CMD_NAV_LAST).
    pub(crate) const NAV_LAST: u16 = MavCmd::MAV_CMD_NAV_LAST as u16;

    /// Whether a MAV_CMD is a navigation command: one that is flown and "reached" (take-off,
    /// waypoint, loiter, land, return…), as opposed to DO_ and CONDITION_ commands, which run
    /// beside the navigation command before them. ArduPilot's rule (`AP_Mission::is_nav_cmd`,
    /// `libraries/AP_Mission/AP_Mission.cpp`): ids up to MAV_CMD_NAV_LAST. The simulator's
    /// mission execution and the command line's reached-item report both use it.
    pub fn is_nav(cmd: u16) -> bool {
        cmd <= NAV_LAST
    }

    /// Whether ArduPilot stores a command's position (frame, latitude, longitude, altitude)
    /// with it (`AP_Mission::stored_in_location`, `libraries/AP_Mission/AP_Mission.cpp`):
    /// waypoints, loiters, land and take-off, spline waypoints, guided enable, set home, land
    /// start, go-around, set ROI, VTOL take-off and land, payload place. For every other
    /// command it keeps only the command's own fields: a download returns frame 0 and no
    /// position, whatever was uploaded (Mission Planner writes frame 3 on an RTL line).
    #[allow(deprecated)] // MAV_CMD_DO_SET_ROI: superseded in common.xml, still one ArduPilot takes
    pub fn ardupilot_stores_location(cmd: u16) -> bool {
        use MavCmd::*;
        matches!(
            MavCmd::from_u16(cmd),
            Some(
                MAV_CMD_NAV_WAYPOINT
                    | MAV_CMD_NAV_LOITER_UNLIM
                    | MAV_CMD_NAV_LOITER_TURNS
                    | MAV_CMD_NAV_LOITER_TIME
                    | MAV_CMD_NAV_LAND
                    | MAV_CMD_NAV_TAKEOFF
                    | MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT
                    | MAV_CMD_NAV_LOITER_TO_ALT
                    | MAV_CMD_NAV_SPLINE_WAYPOINT
                    | MAV_CMD_NAV_GUIDED_ENABLE
                    | MAV_CMD_DO_SET_HOME
                    | MAV_CMD_DO_LAND_START
                    | MAV_CMD_DO_GO_AROUND
                    | MAV_CMD_DO_SET_ROI
                    | MAV_CMD_NAV_VTOL_TAKEOFF
                    | MAV_CMD_NAV_VTOL_LAND
                    | MAV_CMD_NAV_PAYLOAD_PLACE
            )
        )
    }
    /// Loiter at a position until told otherwise.
    pub const NAV_LOITER_UNLIM: u16 = MavCmd::MAV_CMD_NAV_LOITER_UNLIM as u16;
    /// Loiter at a position for param1 seconds.
    pub const NAV_LOITER_TIME: u16 = MavCmd::MAV_CMD_NAV_LOITER_TIME as u16;
    /// Return to the launch position.
    pub const NAV_RETURN_TO_LAUNCH: u16 = MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH as u16;
    /// Land at a position (or here when lat/lon are 0).
    pub const NAV_LAND: u16 = MavCmd::MAV_CMD_NAV_LAND as u16;
    /// Take off to the item's altitude.
    pub const NAV_TAKEOFF: u16 = MavCmd::MAV_CMD_NAV_TAKEOFF as u16;
    /// Climb or descend while loitering until the item's altitude is reached.
    pub(crate) const NAV_LOITER_TO_ALT: u16 = MavCmd::MAV_CMD_NAV_LOITER_TO_ALT as u16;
    /// VTOL take-off: rise vertically, then transition to forward flight.
    pub(crate) const NAV_VTOL_TAKEOFF: u16 = MavCmd::MAV_CMD_NAV_VTOL_TAKEOFF as u16;
    /// VTOL landing: transition to hover, then land vertically.
    pub(crate) const NAV_VTOL_LAND: u16 = MavCmd::MAV_CMD_NAV_VTOL_LAND as u16;
    /// Jump to item param1, param2 times (−1 = forever).
    pub const DO_JUMP: u16 = MavCmd::MAV_CMD_DO_JUMP as u16;
    /// Change speed: param1 speed type, param2 speed m/s.
    pub const DO_CHANGE_SPEED: u16 = MavCmd::MAV_CMD_DO_CHANGE_SPEED as u16;
    /// Set home: param1 = 1 uses the current position, 0 the item's position.
    pub const DO_SET_HOME: u16 = MavCmd::MAV_CMD_DO_SET_HOME as u16;
    /// Legacy camera trigger (param5 = 1 takes one picture).
    pub const DO_DIGICAM_CONTROL: u16 = MavCmd::MAV_CMD_DO_DIGICAM_CONTROL as u16;
    /// Trigger the camera every param1 metres travelled (0 stops).
    pub const DO_SET_CAM_TRIGG_DIST: u16 = MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_DIST as u16;
    /// Start capturing images: param2 interval s, param3 count, param4 sequence number.
    pub const IMAGE_START_CAPTURE: u16 = MavCmd::MAV_CMD_IMAGE_START_CAPTURE as u16;
    /// Stop capturing images.
    pub const IMAGE_STOP_CAPTURE: u16 = MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE as u16;
    /// Fence polygon vertex, inclusion (param1 = vertex count).
    pub(crate) const NAV_FENCE_POLYGON_VERTEX_INCLUSION: u16 =
        MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION as u16;
    /// Fence polygon vertex, exclusion (param1 = vertex count).
    pub(crate) const NAV_FENCE_POLYGON_VERTEX_EXCLUSION: u16 =
        MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION as u16;
    /// Rally point.
    pub const NAV_RALLY_POINT: u16 = MavCmd::MAV_CMD_NAV_RALLY_POINT as u16;
}

/// MAV_FRAME values used by fleetmap, as the `u8` a mission item carries (the dialect's
/// `MavFrame`).
pub mod frame {
    use mavlink::dialects::ardupilotmega::MavFrame;

    /// Global frame, altitude AMSL (lat/lon as float degrees in MISSION_ITEM).
    pub const GLOBAL: u8 = MavFrame::MAV_FRAME_GLOBAL as u8;
    /// Not a position (commands without coordinates).
    pub const MISSION: u8 = MavFrame::MAV_FRAME_MISSION as u8;
    /// Global frame, altitude relative to home.
    pub const GLOBAL_RELATIVE_ALT: u8 = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT as u8;
    /// Global frame, altitude above terrain.
    pub const GLOBAL_TERRAIN_ALT: u8 = MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT as u8;
    /// Global frame (lat/lon 1e-7 degrees in MISSION_ITEM), altitude above terrain.
    #[allow(deprecated)] // superseded in common.xml, still what QGroundControl plans carry
    pub const GLOBAL_TERRAIN_ALT_INT: u8 = MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT as u8;

    /// Whether an item's altitude is above the terrain: the vehicle needs terrain data to
    /// fly it (ArduPilot: `TERRAIN_ENABLE` and the GCS's TERRAIN_DATA or its own cache).
    pub fn is_terrain(frame: u8) -> bool {
        frame == GLOBAL_TERRAIN_ALT || frame == GLOBAL_TERRAIN_ALT_INT
    }
}

/// MAV_MISSION_TYPE: which of the autopilot's lists an item belongs to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MissionType {
    /// The flight plan (MAV_MISSION_TYPE_MISSION = 0).
    #[default]
    Mission,
    /// The geofence (MAV_MISSION_TYPE_FENCE = 1).
    Fence,
    /// Rally points (MAV_MISSION_TYPE_RALLY = 2).
    Rally,
}

impl MissionType {
    /// The MAV_MISSION_TYPE number.
    pub const fn as_u8(self) -> u8 {
        match self {
            MissionType::Mission => 0,
            MissionType::Fence => 1,
            MissionType::Rally => 2,
        }
    }

    /// The mission type for a MAV_MISSION_TYPE number (255 = ALL is not a list).
    pub const fn from_u8(v: u8) -> Option<MissionType> {
        match v {
            0 => Some(MissionType::Mission),
            1 => Some(MissionType::Fence),
            2 => Some(MissionType::Rally),
            _ => None,
        }
    }
}

/// One mission item (the payload of MISSION_ITEM_INT without addressing and sequence).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MissionItem {
    /// MAV_FRAME of the coordinates.
    pub frame: u8,
    /// MAV_CMD.
    pub command: u16,
    /// Whether this is the current item (only meaningful on download).
    pub current: bool,
    /// Continue to the next item when this one completes.
    pub autocontinue: bool,
    /// Command parameter 1 (meaning depends on `command`).
    pub param1: f32,
    /// Command parameter 2.
    pub param2: f32,
    /// Command parameter 3.
    pub param3: f32,
    /// Command parameter 4.
    pub param4: f32,
    /// Latitude in degrees × 10⁷ (or parameter 5 for non-position commands).
    pub x: i32,
    /// Longitude in degrees × 10⁷ (or parameter 6).
    pub y: i32,
    /// Altitude in metres in `frame` (or parameter 7).
    pub z: f32,
}

/// Degrees → the wire's degrees × 10⁷ (rounded to nearest, as QGroundControl does).
pub fn deg_to_e7(deg: f64) -> i32 {
    (deg * 1e7).round() as i32
}

/// The wire's degrees × 10⁷ → degrees.
pub(crate) fn e7_to_deg(e7: i32) -> f64 {
    f64::from(e7) / 1e7
}

impl MissionItem {
    /// A command item without coordinates (frame MISSION), all parameters zero.
    pub fn command(command: u16) -> MissionItem {
        MissionItem {
            frame: frame::MISSION,
            command,
            current: false,
            autocontinue: true,
            param1: 0.0,
            param2: 0.0,
            param3: 0.0,
            param4: 0.0,
            x: 0,
            y: 0,
            z: 0.0,
        }
    }

    /// A position item at (`lat`, `lon`) degrees, `alt` metres relative to home.
    pub fn at(command: u16, lat: f64, lon: f64, alt: f32) -> MissionItem {
        MissionItem {
            frame: frame::GLOBAL_RELATIVE_ALT,
            x: deg_to_e7(lat),
            y: deg_to_e7(lon),
            z: alt,
            ..MissionItem::command(command)
        }
    }

    /// NAV_WAYPOINT at (`lat`, `lon`) degrees, `alt` metres relative to home, no hold.
    pub fn waypoint(lat: f64, lon: f64, alt: f32) -> MissionItem {
        MissionItem::at(cmd::NAV_WAYPOINT, lat, lon, alt)
    }

    /// NAV_TAKEOFF to `alt` metres relative to home, without a position (0, 0): what
    /// ArduCopter takes as "here". Not for PX4 missions (see [`MissionItem::takeoff_at`]).
    pub fn takeoff(alt: f32) -> MissionItem {
        MissionItem {
            frame: frame::GLOBAL_RELATIVE_ALT,
            z: alt,
            ..MissionItem::command(cmd::NAV_TAKEOFF)
        }
    }

    /// NAV_TAKEOFF to `alt` metres above home, with (`lat`, `lon`) degrees as its position.
    /// Missions for PX4 need it: a copter that starts a mission in the air (or has finished
    /// the climb) flies a take-off item as a waypoint to its position (PX4
    /// `src/modules/navigator/mission.cpp`, "treat it as waypoint"), so an item without one
    /// (0, 0) is never reached — PX4 1.16 SITL hovered at the take-off altitude for good.
    /// ArduCopter takes off vertically whatever the position.
    pub fn takeoff_at(lat: f64, lon: f64, alt: f32) -> MissionItem {
        MissionItem {
            x: deg_to_e7(lat),
            y: deg_to_e7(lon),
            ..MissionItem::takeoff(alt)
        }
    }

    /// NAV_LAND at (`lat`, `lon`) degrees.
    pub fn land(lat: f64, lon: f64) -> MissionItem {
        MissionItem::at(cmd::NAV_LAND, lat, lon, 0.0)
    }

    /// NAV_RETURN_TO_LAUNCH.
    pub fn return_to_launch() -> MissionItem {
        MissionItem::command(cmd::NAV_RETURN_TO_LAUNCH)
    }

    /// NAV_LOITER_TIME for `seconds` at (`lat`, `lon`, `alt` relative to home).
    pub(crate) fn loiter_time(seconds: f32, lat: f64, lon: f64, alt: f32) -> MissionItem {
        MissionItem {
            param1: seconds,
            ..MissionItem::at(cmd::NAV_LOITER_TIME, lat, lon, alt)
        }
    }

    /// DO_CHANGE_SPEED to `speed` m/s ground speed (speed type 1).
    pub fn change_speed(speed: f32) -> MissionItem {
        MissionItem {
            param1: 1.0,
            param2: speed,
            param3: -1.0,
            ..MissionItem::command(cmd::DO_CHANGE_SPEED)
        }
    }

    /// IMAGE_START_CAPTURE: `count` images `interval` seconds apart (count 1 = one image).
    pub fn image_start_capture(interval: f32, count: u32) -> MissionItem {
        MissionItem {
            param2: interval,
            param3: count as f32,
            ..MissionItem::command(cmd::IMAGE_START_CAPTURE)
        }
    }

    /// DO_JUMP to user item `target` (0-based, no home item), `repeat` times.
    pub fn jump(target: u16, repeat: i16) -> MissionItem {
        MissionItem {
            param1: f32::from(target),
            param2: f32::from(repeat),
            ..MissionItem::command(cmd::DO_JUMP)
        }
    }

    /// Latitude in degrees.
    pub fn lat(&self) -> f64 {
        e7_to_deg(self.x)
    }

    /// Longitude in degrees.
    pub fn lon(&self) -> f64 {
        e7_to_deg(self.y)
    }

    /// Whether this command carries a position in x/y/z.
    pub fn has_position(&self) -> bool {
        matches!(
            self.command,
            cmd::NAV_WAYPOINT
                | cmd::NAV_LOITER_TIME
                | cmd::NAV_LAND
                | cmd::NAV_TAKEOFF
                | cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION
                | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION
                | cmd::NAV_RALLY_POINT
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e7_round_trip() {
        for deg in [0.0, 38.9807312, -77.0366456, 179.9999999, -89.9999999] {
            let e7 = deg_to_e7(deg);
            assert!((e7_to_deg(e7) - deg).abs() < 0.6e-7);
            assert_eq!(deg_to_e7(e7_to_deg(e7)), e7);
        }
    }

    #[test]
    fn builders() {
        let w = MissionItem::waypoint(1.5, -2.25, 12.0);
        assert_eq!((w.x, w.y, w.z), (15_000_000, -22_500_000, 12.0));
        assert_eq!(w.frame, frame::GLOBAL_RELATIVE_ALT);
        assert!(w.has_position());
        assert!(!MissionItem::image_start_capture(0.0, 5).has_position());
        assert_eq!(MissionType::from_u8(1), Some(MissionType::Fence));
        assert_eq!(MissionType::from_u8(255), None);
    }
}
