//! The autopilot parameters the fleet check reads, by autopilot, with where each is defined.
//!
//! ArduPilot 4.7 (names and SITL defaults read from ArduCopter and ArduRover 4.7.0-dev SITL
//! with PARAM_REQUEST_LIST; definitions in ArduPilot master):
//! * `MAV_SYSID`, `MAV_GCS_SYSID` (255), `MAV_GCS_SYSID_HI` (0), `MAV_OPTIONS` (bit 0:
//!   "Accept MAVLink only from system IDs given by MAV_GCS_SYSID and MAV_GCS_SYSID_HI") —
//!   `libraries/GCS_MAVLink/GCS.cpp`, `GCS::var_info`. Before 4.7 the same settings were
//!   `SYSID_THISMAV`, `SYSID_MYGCS` and `SYSID_ENFORCE` (1: only `SYSID_MYGCS`), in each
//!   vehicle's `Parameters.cpp`. `MAV_GCS_SYSID_HI` is newer than some 4.7-dev builds.
//! * `FS_GCS_ENABLE` (0: off; ArduCopter 1 = RTL, ArduRover 1 = the `FS_ACTION`) —
//!   `ArduCopter/Parameters.cpp`, `Rover/Parameters.cpp`.
//! * `BATT_FS_LOW_ACT`, `BATT_FS_CRT_ACT` (0: none; ArduCopter 2 = RTL, ArduRover 1 = RTL) —
//!   `libraries/AP_BattMonitor/AP_BattMonitor_Params.cpp`.
//! * `RTL_ALT` (ArduCopter, centimetres; 0 = return at the current altitude) —
//!   `ArduCopter/Parameters.cpp`.
//! * `FENCE_ENABLE` (0 in SITL), `FENCE_ACTION` (0 = report only, 1 = RTL or land) —
//!   `libraries/AC_Fence/AC_Fence.cpp`.
//!
//! PX4 1.16 (names, types, defaults and parameter groups from the `parameters.json` a
//! `px4_sitl_default` build of v1.16 generates from its modules' parameter definitions):
//! * `NAV_DLL_ACT` (group Commander; GCS connection loss: 0 disabled, 1 hold, 2 return,
//!   3 land, 5 terminate, 6 disarm; default 0, which PX4's SITL airframes raise);
//! * `COM_LOW_BAT_ACT` (group Commander; 0 warning only, 2 land, 3 return at critical and
//!   land at emergency; default 0);
//! * `RTL_RETURN_ALT` (group Return Mode; metres above home, default 60);
//! * `GF_ACTION` (group Geofence; 0 none, 1 warning, 2 hold, 3 return, 4 terminate, 5 land;
//!   default 2).
//! * PX4 has no parameter that restricts which ground station it obeys: `MAV_SYS_ID` and
//!   `MAV_COMP_ID` are its own ids, and any heartbeat of MAV_TYPE_GCS counts as a GCS
//!   (`src/modules/mavlink/mavlink_receiver.cpp`, heartbeat handling), so the GCS-id check
//!   has nothing to read on PX4.

use crate::proto::flavour::{Autopilot, Flavour, VehicleClass};
use std::collections::BTreeMap;

/// ArduPilot 4.7: the GCS's system id (`libraries/GCS_MAVLink/GCS.cpp`).
pub const MAV_GCS_SYSID: &str = "MAV_GCS_SYSID";
/// ArduPilot 4.7: the top of a range of GCS system ids (0: no range).
pub const MAV_GCS_SYSID_HI: &str = "MAV_GCS_SYSID_HI";
/// ArduPilot 4.7: MAVLink options; bit 0 accepts MAVLink only from the GCS ids.
pub const MAV_OPTIONS: &str = "MAV_OPTIONS";
/// ArduPilot before 4.7: the GCS's system id.
pub const SYSID_MYGCS: &str = "SYSID_MYGCS";
/// ArduPilot before 4.7: 1 = accept MAVLink only from `SYSID_MYGCS`.
pub const SYSID_ENFORCE: &str = "SYSID_ENFORCE";
/// ArduPilot: GCS-loss failsafe.
pub const FS_GCS_ENABLE: &str = "FS_GCS_ENABLE";
/// ArduPilot: action at the low battery level.
pub const BATT_FS_LOW_ACT: &str = "BATT_FS_LOW_ACT";
/// ArduPilot: action at the critical battery level.
pub const BATT_FS_CRT_ACT: &str = "BATT_FS_CRT_ACT";
/// ArduCopter: return altitude, centimetres.
pub const RTL_ALT: &str = "RTL_ALT";
/// ArduPilot: geofence on.
pub const FENCE_ENABLE: &str = "FENCE_ENABLE";
/// ArduPilot: what a fence breach does.
pub const FENCE_ACTION: &str = "FENCE_ACTION";
/// PX4: GCS connection loss action.
pub const NAV_DLL_ACT: &str = "NAV_DLL_ACT";
/// PX4: battery failsafe action.
pub const COM_LOW_BAT_ACT: &str = "COM_LOW_BAT_ACT";
/// PX4: return altitude above home, metres.
pub const RTL_RETURN_ALT: &str = "RTL_RETURN_ALT";
/// PX4: geofence breach action.
pub const GF_ACTION: &str = "GF_ACTION";

/// What to read first from a vehicle of `flavour` (ArduPilot 4.7's names; PX4 1.16's).
pub fn first_read(flavour: Flavour) -> Vec<&'static str> {
    match flavour.autopilot {
        Autopilot::ArduPilot => {
            let mut v = vec![
                MAV_GCS_SYSID,
                MAV_OPTIONS,
                FS_GCS_ENABLE,
                BATT_FS_LOW_ACT,
                BATT_FS_CRT_ACT,
                FENCE_ENABLE,
                FENCE_ACTION,
            ];
            if flavour.class == VehicleClass::Copter {
                v.push(RTL_ALT);
            }
            v
        }
        Autopilot::Px4 => {
            let mut v = vec![NAV_DLL_ACT, COM_LOW_BAT_ACT, GF_ACTION];
            if flavour.class == VehicleClass::Copter {
                v.push(RTL_RETURN_ALT);
            }
            v
        }
        Autopilot::Other(_) => Vec::new(),
    }
}

/// What to read next, given what was read (`values`) and what was asked but not answered
/// (`missing`): the pre-4.7 names when `MAV_GCS_SYSID` is missing, `MAV_GCS_SYSID_HI` when
/// the GCS id is not fleetmap's `gcs` (only then can a range matter). Empty: done. Each name is
/// asked at most once (names already in `values` or `missing` are never returned).
pub fn next_read(
    flavour: Flavour,
    values: &BTreeMap<String, f32>,
    missing: &[String],
    gcs: u8,
) -> Vec<&'static str> {
    if flavour.autopilot != Autopilot::ArduPilot {
        return Vec::new();
    }
    let asked = |n: &str| values.contains_key(n) || missing.iter().any(|m| m == n);
    let mut v = Vec::new();
    match values.get(MAV_GCS_SYSID) {
        None if missing.iter().any(|m| m == MAV_GCS_SYSID) => {
            v.extend([SYSID_MYGCS, SYSID_ENFORCE]);
        }
        Some(&g) if g.round() as i64 != i64::from(gcs) => {
            v.push(MAV_GCS_SYSID_HI);
        }
        _ => {}
    }
    v.retain(|n| !asked(n));
    v
}
