//! Item storage and validation: how ArduPilot stores mission, fence and rally items
//! (lossy AP_Mission format) and how PX4 parses, formats and checksums them.

use super::*;
use mav::MavCmd;

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
    let nan_mask = match MavCmd::from_u16(item.command) {
        Some(
            MavCmd::MAV_CMD_NAV_WAYPOINT
            | MavCmd::MAV_CMD_NAV_LAND
            | MavCmd::MAV_CMD_NAV_TAKEOFF
            | MavCmd::MAV_CMD_NAV_VTOL_TAKEOFF,
        ) => 1 << 3,
        Some(MavCmd::MAV_CMD_NAV_VTOL_LAND) => (1 << 2) | (1 << 3),
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
    match MavCmd::from_u16(item.command) {
        // 0 and 1 name no command: AP_Mission refuses them as invalid, not unsupported
        None if item.command <= 1 => return Err(R::MAV_MISSION_INVALID),
        // delay, whole seconds (Copter/Rover)
        Some(MavCmd::MAV_CMD_NAV_WAYPOINT) => out.param1 = u16p(item.param1),
        Some(MavCmd::MAV_CMD_NAV_LOITER_UNLIM) => {
            out.param3 = u16p(item.param3.abs()) * if item.param3 < 0.0 { -1.0 } else { 1.0 };
        }
        Some(MavCmd::MAV_CMD_NAV_LOITER_TIME) => {
            out.param1 = u16p(item.param1);
            out.param3 = if item.param3 < 0.0 { -1.0 } else { 1.0 };
            out.param4 = if item.param4 > 0.0 { 1.0 } else { 0.0 };
        }
        Some(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH) => {}
        Some(MavCmd::MAV_CMD_NAV_LAND) => {
            out.param1 = u16p(item.param1);
            out.param4 = if !item.param4.is_nan() && item.param4 < 0.0 {
                -1.0
            } else {
                1.0
            };
        }
        Some(MavCmd::MAV_CMD_NAV_TAKEOFF) => out.param1 = u16p(item.param1),
        Some(MavCmd::MAV_CMD_NAV_DELAY) => {
            // nav_delay: seconds (float), hour, min, sec (int8)
            out.param1 = item.param1;
            out.param2 = i8p(item.param2);
            out.param3 = i8p(item.param3);
            out.param4 = i8p(item.param4);
        }
        // delay.seconds is a float in newer builds
        Some(MavCmd::MAV_CMD_CONDITION_DELAY) => out.param1 = item.param1.trunc(),
        Some(MavCmd::MAV_CMD_CONDITION_YAW) => {
            out.param1 = item.param1;
            out.param2 = item.param2;
            out.param3 = i8p(item.param3);
            out.param4 = u8p(item.param4);
        }
        Some(MavCmd::MAV_CMD_DO_JUMP) => {
            out.param1 = u16p(item.param1);
            out.param2 = f32::from(item.param2 as i16);
        }
        Some(MavCmd::MAV_CMD_DO_CHANGE_SPEED) => {
            out.param1 = u8p(item.param1);
            out.param2 = item.param2;
            out.param3 = i8p(item.param3);
        }
        Some(MavCmd::MAV_CMD_DO_SET_HOME) => out.param1 = u16p(item.param1),
        Some(MavCmd::MAV_CMD_DO_SET_ROI) => out.param1 = u16p(item.param1),
        Some(MavCmd::MAV_CMD_DO_DIGICAM_CONTROL) => {
            out.param1 = u8p(item.param1);
            out.param2 = u8p(item.param2);
            out.param3 = i8p(item.param3);
            out.param4 = u8p(item.param4);
            out.x = i32::from(item.x as u8);
            out.y = i32::from(item.y as u8);
        }
        Some(MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_DIST) => {
            out.param1 = item.param1;
            out.param3 = u8p(item.param3);
        }
        Some(MavCmd::MAV_CMD_IMAGE_START_CAPTURE) => {
            // image_start_capture: instance (u8), interval_s (float), total_num_images (u16),
            // start_seq_number (u16)
            out.param1 = u8p(item.param1);
            out.param2 = item.param2;
            out.param3 = u16p(item.param3);
            out.param4 = u16p(item.param4);
        }
        Some(MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE) => out.param1 = u16p(item.param1),
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
    match MavCmd::from_u16(item.command) {
        Some(
            MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT
            | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
            | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
            | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
            | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
        ) => {}
        _ => return Err(mav::MavMissionResult::MAV_MISSION_UNSUPPORTED),
    }
    check_nan_params(item, 0)?;
    Ok(MissionItem {
        frame: 0,
        command: item.command,
        current: false,
        autocontinue: true,
        param1: if item.command == MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT as u16 {
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
        match MavCmd::from_u16(item.command) {
            Some(MavCmd::MAV_CMD_NAV_WAYPOINT) => {
                (out.param1, out.param2, out.param3, out.param4) = (p1, p2, 0.0, wrap_yaw(p4))
            }
            Some(MavCmd::MAV_CMD_NAV_LOITER_UNLIM) => {
                (out.param1, out.param2, out.param3, out.param4) = (0.0, 0.0, p3, wrap_yaw(p4))
            }
            Some(MavCmd::MAV_CMD_NAV_LOITER_TIME) => {
                (out.param1, out.param2, out.param3, out.param4) = (
                    p1,
                    if p2 > 0.0 { 1.0 } else { 0.0 },
                    p3,
                    if p4 > 0.0 { 1.0 } else { 0.0 },
                )
            }
            Some(MavCmd::MAV_CMD_NAV_LAND) => {
                (out.param1, out.param2, out.param3, out.param4) = (0.0, p2, 0.0, wrap_yaw(p4))
            }
            Some(MavCmd::MAV_CMD_NAV_TAKEOFF) => {
                (out.param1, out.param2, out.param3, out.param4) = (0.0, 0.0, 0.0, wrap_yaw(p4))
            }
            Some(
                MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
                | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
            ) => {
                (out.param1, out.param2, out.param3, out.param4) =
                    (((p1 + 0.5) as u16) as f32, 0.0, 0.0, 0.0)
            }
            Some(
                MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
                | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
            ) => (out.param1, out.param2, out.param3, out.param4) = (p1, 0.0, 0.0, 0.0),
            Some(MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT | MavCmd::MAV_CMD_NAV_RALLY_POINT) => {
                (out.param1, out.param2, out.param3, out.param4) = (0.0, 0.0, 0.0, 0.0)
            }
            _ => return Err(R::MAV_MISSION_UNSUPPORTED),
        }
        if t == MissionType::Fence
            && matches!(
                MavCmd::from_u16(item.command),
                Some(
                    MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
                        | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
                )
            )
            && out.param1 < 3.0
        {
            return Err(R::MAV_MISSION_ERROR); // "Fence: too few vertices"
        }
        if t == MissionType::Mission
            && matches!(
                MavCmd::from_u16(item.command),
                Some(
                    MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT
                        | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
                        | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
                        | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
                        | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
                        | MavCmd::MAV_CMD_NAV_RALLY_POINT
                )
            )
        {
            return Err(R::MAV_MISSION_ERROR);
        }
        Ok(out)
    } else if item.frame == 2 {
        match MavCmd::from_u16(item.command) {
            Some(MavCmd::MAV_CMD_DO_JUMP) => {
                out.param1 = f32::from(item.param1 as u16);
                out.param2 = f32::from(item.param2 as u16);
            }
            Some(
                MavCmd::MAV_CMD_DO_CHANGE_SPEED
                | MavCmd::MAV_CMD_DO_SET_HOME
                | MavCmd::MAV_CMD_DO_LAND_START
                | MavCmd::MAV_CMD_DO_TRIGGER_CONTROL
                | MavCmd::MAV_CMD_DO_DIGICAM_CONTROL
                | MavCmd::MAV_CMD_DO_MOUNT_CONFIGURE
                | MavCmd::MAV_CMD_DO_MOUNT_CONTROL
                | MavCmd::MAV_CMD_IMAGE_START_CAPTURE
                | MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE
                | MavCmd::MAV_CMD_VIDEO_START_CAPTURE
                | MavCmd::MAV_CMD_VIDEO_STOP_CAPTURE
                | MavCmd::MAV_CMD_DO_CONTROL_VIDEO
                | MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_DIST
                | MavCmd::MAV_CMD_OBLIQUE_SURVEY
                | MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL
                | MavCmd::MAV_CMD_SET_CAMERA_MODE
                | MavCmd::MAV_CMD_SET_CAMERA_SOURCE
                | MavCmd::MAV_CMD_DO_VTOL_TRANSITION
                | MavCmd::MAV_CMD_NAV_DELAY
                | MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH
                | MavCmd::MAV_CMD_DO_SET_ROI_LOCATION
                | MavCmd::MAV_CMD_DO_SET_ROI_NONE
                | MavCmd::MAV_CMD_CONDITION_DELAY
                | MavCmd::MAV_CMD_CONDITION_DISTANCE
                | MavCmd::MAV_CMD_DO_SET_ACTUATOR
                | MavCmd::MAV_CMD_DO_GRIPPER
                | MavCmd::MAV_CMD_COMPONENT_ARM_DISARM
                | MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW
                | MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE
                | MavCmd::MAV_CMD_DO_WINCH
                | MavCmd::MAV_CMD_SET_CAMERA_ZOOM
                | MavCmd::MAV_CMD_SET_CAMERA_FOCUS,
            ) => {}
            Some(MavCmd::MAV_CMD_DO_SET_ROI) => {
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
