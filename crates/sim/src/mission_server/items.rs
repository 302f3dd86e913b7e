//! Item storage and validation: how ArduPilot stores mission, fence and rally items
//! (lossy AP_Mission format) and how PX4 parses, formats and checksums them.

use super::*;

fn check_nan_params(item: &MissionItem, nan_ok_mask: u8) -> Result<(), mav::MavMissionResult> {
    use mav::MavMissionResult as R;
    let ps = [item.param1, item.param2, item.param3, item.param4];
    let errs = [
        R::MAV_MISSION_INVALID_PARAM1,
        R::MAV_MISSION_INVALID_PARAM2,
        R::MAV_MISSION_INVALID_PARAM3,
        R::MAV_MISSION_INVALID_PARAM4,
    ];
    for i in 0..4 {
        let nan_allowed = nan_ok_mask & (1 << i) != 0;
        if ps[i].is_infinite() || (ps[i].is_nan() && !nan_allowed) {
            return Err(errs[i]);
        }
    }
    Ok(())
}

/// Store a mission item the way ArduCopter/ArduRover do (AP_Mission::mavlink_int_to_mission_cmd
/// then mission_cmd_to_mavlink_int) and return what a later download gives back, or the
/// MAV_MISSION_RESULT the upload is rejected with.
pub fn ardupilot_store_mission_item(
    item: &MissionItem,
) -> Result<MissionItem, mav::MavMissionResult> {
    use mav::MavMissionResult as R;
    // sanity_check_params: param4 may be NaN for WAYPOINT, LAND, TAKEOFF.
    let nan_mask = match item.command {
        16 | 21 | 22 | 84 => 1 << 3,
        85 => (1 << 2) | (1 << 3),
        _ => 0,
    };
    check_nan_params(item, nan_mask)?;
    let u16p = |v: f32| -> f32 { f32::from(v as u16) };
    let u8p = |v: f32| -> f32 { f32::from(v as u8) };
    let i8p = |v: f32| -> f32 { f32::from(v as i8) };
    let mut out = MissionItem {
        frame: 0,
        command: item.command,
        current: false,
        autocontinue: true,
        param1: 0.0,
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        x: 0,
        y: 0,
        z: 0.0,
    };
    match item.command {
        0 | 1 => return Err(R::MAV_MISSION_INVALID),
        16 => out.param1 = u16p(item.param1), // delay, whole seconds (Copter/Rover)
        17 => {
            out.param3 = u16p(item.param3.abs()) * if item.param3 < 0.0 { -1.0 } else { 1.0 };
        }
        19 => {
            out.param1 = u16p(item.param1);
            out.param3 = if item.param3 < 0.0 { -1.0 } else { 1.0 };
            out.param4 = if item.param4 > 0.0 { 1.0 } else { 0.0 };
        }
        20 => {}
        21 => {
            out.param1 = u16p(item.param1);
            out.param4 = if !item.param4.is_nan() && item.param4 < 0.0 {
                -1.0
            } else {
                1.0
            };
        }
        22 => out.param1 = u16p(item.param1),
        93 => {
            // nav_delay: seconds (float), hour, min, sec (int8)
            out.param1 = item.param1;
            out.param2 = i8p(item.param2);
            out.param3 = i8p(item.param3);
            out.param4 = i8p(item.param4);
        }
        112 => out.param1 = item.param1.trunc(), // delay.seconds is a float in newer builds
        115 => {
            out.param1 = item.param1;
            out.param2 = item.param2;
            out.param3 = i8p(item.param3);
            out.param4 = u8p(item.param4);
        }
        177 => {
            out.param1 = u16p(item.param1);
            out.param2 = f32::from(item.param2 as i16);
        }
        178 => {
            out.param1 = u8p(item.param1);
            out.param2 = item.param2;
            out.param3 = i8p(item.param3);
        }
        179 => out.param1 = u16p(item.param1),
        201 => out.param1 = u16p(item.param1),
        203 => {
            out.param1 = u8p(item.param1);
            out.param2 = u8p(item.param2);
            out.param3 = i8p(item.param3);
            out.param4 = u8p(item.param4);
            out.x = i32::from(item.x as u8);
            out.y = i32::from(item.y as u8);
        }
        206 => {
            out.param1 = item.param1;
            out.param3 = u8p(item.param3);
        }
        2000 => {
            // image_start_capture: instance (u8), interval_s (float), total_num_images (u16),
            // start_seq_number (u16)
            out.param1 = u8p(item.param1);
            out.param2 = item.param2;
            out.param3 = u16p(item.param3);
            out.param4 = u16p(item.param4);
        }
        2001 => out.param1 = u16p(item.param1),
        _ => return Err(R::MAV_MISSION_UNSUPPORTED),
    }
    if fleetmap_core::mission::item::cmd::ardupilot_stores_location(item.command) {
        if !(-900_000_000..=900_000_000).contains(&item.x) {
            return Err(R::MAV_MISSION_INVALID_PARAM5_X);
        }
        if !(-1_800_000_000..=1_800_000_000).contains(&item.y) {
            return Err(R::MAV_MISSION_INVALID_PARAM6_Y);
        }
        // LOCATION_ALT_MAX_M: the 24-bit centimetre altitude.
        if item.z.is_nan() || item.z.abs() >= 83_000.0 {
            return Err(R::MAV_MISSION_INVALID_PARAM7);
        }
        out.x = item.x;
        out.y = item.y;
        let alt_cm = (item.z * 100.0) as i32;
        out.z = alt_cm as f32 * 0.01;
        out.frame = match item.frame {
            0 | 2 | 5 => 0,
            3 | 6 => 3,
            10 | 11 => 10,
            _ => return Err(R::MAV_MISSION_UNSUPPORTED_FRAME),
        };
    }
    Ok(out)
}

/// Store a fence item the way ArduPilot's fence loader does: vertices and circles keep their
/// position and parameter 1 (vertex count / radius).
pub fn ardupilot_store_fence_item(
    item: &MissionItem,
) -> Result<MissionItem, mav::MavMissionResult> {
    match item.command {
        5000..=5004 => {}
        _ => return Err(mav::MavMissionResult::MAV_MISSION_UNSUPPORTED),
    }
    check_nan_params(item, 0)?;
    Ok(MissionItem {
        frame: 0,
        command: item.command,
        current: false,
        autocontinue: true,
        param1: if item.command == 5000 {
            0.0
        } else {
            item.param1
        },
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        x: item.x,
        y: item.y,
        z: 0.0,
    })
}

/// Store a rally point as ArduPilot's `RallyLocation` does (altitude in whole metres relative
/// to home).
pub fn ardupilot_store_rally_item(
    item: &MissionItem,
) -> Result<MissionItem, mav::MavMissionResult> {
    if item.command != fleetmap_core::mission::item::cmd::NAV_RALLY_POINT {
        return Err(mav::MavMissionResult::MAV_MISSION_UNSUPPORTED);
    }
    Ok(MissionItem {
        frame: 3,
        command: item.command,
        current: false,
        autocontinue: true,
        param1: 0.0,
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        x: item.x,
        y: item.y,
        z: f32::from(item.z as i16),
    })
}

/// PX4 `parse_mavlink_mission_item`: the stored form (frames kept as received, position
/// commands keep only the parameters `mission_item_s` has), or the MAV_MISSION_RESULT.
pub fn px4_parse_item(
    item: &MissionItem,
    t: MissionType,
    int_mode: bool,
) -> Result<MissionItem, mav::MavMissionResult> {
    use mav::MavMissionResult as R;
    let mut out = *item;
    out.current = false;
    let wrap_yaw = |deg: f32| -> f32 {
        if deg.is_nan() {
            deg
        } else {
            deg.rem_euclid(360.0)
        }
    };
    let global = matches!(item.frame, 0 | 3) || (int_mode && matches!(item.frame, 5 | 6));
    if global {
        out.frame = match item.frame {
            5 => 0,
            6 => 3,
            f => f,
        };
        let (p1, p2, p3, p4) = (item.param1, item.param2, item.param3, item.param4);
        match item.command {
            16 => (out.param1, out.param2, out.param3, out.param4) = (p1, p2, 0.0, wrap_yaw(p4)),
            17 => (out.param1, out.param2, out.param3, out.param4) = (0.0, 0.0, p3, wrap_yaw(p4)),
            19 => {
                (out.param1, out.param2, out.param3, out.param4) = (
                    p1,
                    if p2 > 0.0 { 1.0 } else { 0.0 },
                    p3,
                    if p4 > 0.0 { 1.0 } else { 0.0 },
                )
            }
            21 => (out.param1, out.param2, out.param3, out.param4) = (0.0, p2, 0.0, wrap_yaw(p4)),
            22 => (out.param1, out.param2, out.param3, out.param4) = (0.0, 0.0, 0.0, wrap_yaw(p4)),
            5001 | 5002 => {
                (out.param1, out.param2, out.param3, out.param4) =
                    (((p1 + 0.5) as u16) as f32, 0.0, 0.0, 0.0)
            }
            5003 | 5004 => (out.param1, out.param2, out.param3, out.param4) = (p1, 0.0, 0.0, 0.0),
            5000 | 5100 => (out.param1, out.param2, out.param3, out.param4) = (0.0, 0.0, 0.0, 0.0),
            _ => return Err(R::MAV_MISSION_UNSUPPORTED),
        }
        if t == MissionType::Fence && matches!(item.command, 5001 | 5002) && out.param1 < 3.0 {
            return Err(R::MAV_MISSION_ERROR); // "Fence: too few vertices"
        }
        if t == MissionType::Mission && matches!(item.command, 5000..=5004 | 5100) {
            return Err(R::MAV_MISSION_ERROR);
        }
        Ok(out)
    } else if item.frame == 2 {
        match item.command {
            177 => {
                out.param1 = f32::from(item.param1 as u16);
                out.param2 = f32::from(item.param2 as u16);
            }
            178 | 179 | 189 | 2003 | 203 | 204 | 205 | 2000 | 2001 | 2500 | 2501 | 200 | 206
            | 260 | 214 | 530 | 534 | 3000 | 93 | 20 | 195 | 197 | 112 | 114 | 187 | 211 | 400
            | 1000 | 1001 | 42600 | 531 | 532 => {}
            201 => {
                let roi = item.param1 as i32;
                if !(0..=2).contains(&roi) {
                    return Err(R::MAV_MISSION_INVALID_PARAM1);
                }
            }
            _ => return Err(R::MAV_MISSION_UNSUPPORTED),
        }
        Ok(out)
    } else {
        Err(R::MAV_MISSION_UNSUPPORTED_FRAME)
    }
}

/// PX4 `format_mavlink_mission_item`: what a download returns for a stored item.
pub fn px4_format_item(stored: &MissionItem, t: MissionType, int_mode: bool) -> MissionItem {
    let _ = t;
    let mut out = *stored;
    if stored.frame != 2 {
        out.frame = match (stored.frame, int_mode) {
            (3, true) => 6,
            (3, false) => 3,
            (_, true) => 5,
            (_, false) => 0,
        };
    }
    out
}

/// CRC-32 (IEEE, reflected, as PX4's `crc32part`) over an item's frame, command,
/// autocontinue and parameters, continuing from `prev` — the `opaque_id` of a PX4 list.
pub fn crc32_item(item: &MissionItem, prev: u32) -> u32 {
    let mut bytes = Vec::with_capacity(32);
    bytes.push(item.frame);
    bytes.extend_from_slice(&item.command.to_le_bytes());
    bytes.push(u8::from(item.autocontinue));
    for p in [item.param1, item.param2, item.param3, item.param4] {
        bytes.extend_from_slice(&p.to_le_bytes());
    }
    bytes.extend_from_slice(&(item.x as f32).to_le_bytes());
    bytes.extend_from_slice(&(item.y as f32).to_le_bytes());
    bytes.extend_from_slice(&item.z.to_le_bytes());
    let mut crc = !prev;
    for b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}
