//! Mission items on the wire: MISSION_ITEM(_INT) payloads ↔ [`MissionItem`], the frame
//! synonyms, ArduPilot's home item at seq 0 and the comparison of a list read back with the
//! one sent. Pure functions; the protocol machine (`crate::proto::mission`) uses them, and so
//! do the QGroundControl file formats (`plan`, `wpl`).

// The deprecated `_INT` frames and MISSION_ITEM are handled deliberately: deployed
// autopilots still send them.
#![allow(deprecated)]

use crate::mission::item::{MissionItem, MissionType};
use crate::mission::{item::cmd, item::frame};
use mavlink::dialects::ardupilotmega::{
    MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMissionType,
};
use num_traits::FromPrimitive;

/// Why an item cannot be put on the wire (the protocol machine reports these as the
/// `MissionError` variants of the same names).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WireError {
    /// An item's command is not a MAV_CMD of the dialects fleetmap is built with (common,
    /// ardupilotmega). It is refused before anything is sent, not carried as a raw number:
    /// the `mavlink` crate's MISSION_ITEM_INT holds a closed `MavCmd` enum (it can neither
    /// encode such an item nor parse one read back: `ParserError::InvalidEnum`), and both
    /// autopilots refuse a command they do not know with MAV_MISSION_UNSUPPORTED
    /// (`AP_Mission::mavlink_int_to_mission_cmd`, PX4 `MavlinkMissionManager::
    /// parse_mavlink_mission_item`) — ArduCopter 4.7 SITL then keeps the items before it as
    /// its mission, while refusing here leaves the vehicle's mission as it was.
    #[error(
        "mission item {index}: command {command} is not a MAV_CMD of MAVLink's common or \
         ardupilotmega dialect; not sent (ArduPilot and PX4 refuse a command they do not know: \
         MAV_MISSION_UNSUPPORTED)"
    )]
    UnknownCommand {
        /// User item index.
        index: usize,
        /// The command number.
        command: u16,
    },
    /// An item's frame is not a MAV_FRAME of the dialect.
    #[error("mission item {index}: frame {frame} is not a MAV_FRAME")]
    UnknownFrame {
        /// User item index.
        index: usize,
        /// The frame number.
        frame: u8,
    },
    /// More items than the protocol can count.
    #[error("mission has {count} items; the protocol counts at most 65535")]
    TooMany {
        /// Item count.
        count: usize,
    },
}

/// The MAV_MISSION_TYPE of a list (mission, fence or rally).
pub fn mav_type(kind: MissionType) -> MavMissionType {
    match kind {
        MissionType::Mission => MavMissionType::MAV_MISSION_TYPE_MISSION,
        MissionType::Fence => MavMissionType::MAV_MISSION_TYPE_FENCE,
        MissionType::Rally => MavMissionType::MAV_MISSION_TYPE_RALLY,
    }
}

/// Whether a frame carries latitude/longitude in x/y (degrees × 10⁷ in MISSION_ITEM_INT).
pub fn is_global_frame(f: u8) -> bool {
    matches!(f, 0 | 3 | 5 | 6 | 10 | 11)
}

/// The frame with the deprecated `_INT` variants folded onto their synonyms.
pub fn normalize_frame(f: u8) -> u8 {
    match f {
        5 => frame::GLOBAL,
        6 => frame::GLOBAL_RELATIVE_ALT,
        11 => frame::GLOBAL_TERRAIN_ALT,
        f => f,
    }
}

/// A MISSION_ITEM_INT payload → our item.
pub fn item_from_wire(d: &MISSION_ITEM_INT_DATA) -> MissionItem {
    MissionItem {
        frame: d.frame as u8,
        command: d.command as u16,
        current: d.current != 0,
        autocontinue: d.autocontinue != 0,
        param1: d.param1,
        param2: d.param2,
        param3: d.param3,
        param4: d.param4,
        x: d.x,
        y: d.y,
        z: d.z,
    }
}

/// A (float) MISSION_ITEM payload → MISSION_ITEM_INT payload (lat/lon scaled to 1e7 in
/// global frames, as ArduPilot's `convert_MISSION_ITEM_to_MISSION_ITEM_INT` does).
pub fn item_int_from_float(d: &MISSION_ITEM_DATA) -> MISSION_ITEM_INT_DATA {
    let global = is_global_frame(d.frame as u8);
    let conv = |v: f32| {
        if global {
            (f64::from(v) * 1e7).round() as i32
        } else {
            v as i32
        }
    };
    MISSION_ITEM_INT_DATA {
        param1: d.param1,
        param2: d.param2,
        param3: d.param3,
        param4: d.param4,
        x: conv(d.x),
        y: conv(d.y),
        z: d.z,
        seq: d.seq,
        command: d.command,
        target_system: d.target_system,
        target_component: d.target_component,
        frame: d.frame,
        current: d.current,
        autocontinue: d.autocontinue,
        mission_type: d.mission_type,
    }
}

/// Our item → a MISSION_ITEM_INT payload (seq and addressing filled by the caller).
pub(crate) fn item_to_wire(
    item: &MissionItem,
    index: usize,
) -> Result<MISSION_ITEM_INT_DATA, WireError> {
    let command = MavCmd::from_u16(item.command).ok_or(WireError::UnknownCommand {
        index,
        command: item.command,
    })?;
    let frame = MavFrame::from_u8(item.frame).ok_or(WireError::UnknownFrame {
        index,
        frame: item.frame,
    })?;
    Ok(MISSION_ITEM_INT_DATA {
        param1: item.param1,
        param2: item.param2,
        param3: item.param3,
        param4: item.param4,
        x: item.x,
        y: item.y,
        z: item.z,
        seq: 0,
        command,
        target_system: 0,
        target_component: 0,
        frame,
        current: u8::from(item.current),
        autocontinue: u8::from(item.autocontinue),
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    })
}

fn same_f32(a: f32, b: f32, tol: f32) -> bool {
    (a.is_nan() && b.is_nan()) || a == b || (a - b).abs() <= tol * a.abs().max(b.abs()).max(1.0)
}

/// Compare what was sent with what was read back, as far as the autopilot stores items
/// (`ardupilot`: ArduPilot's rules, else PX4's):
///
/// * the command must be the same;
/// * a position item (sent in a global frame) must come back in the same kind of frame
///   (absolute / relative to home / terrain, the `_INT` synonyms folded: PX4 answers in the
///   `_INT` frames, ArduPilot in the plain ones) with x and y exactly and z within 1 cm
///   (ArduPilot stores centimetres); for other commands the frame is not compared
///   (ArduPilot returns 0 for them, `AP_Mission::mission_cmd_to_mavlink_int`);
/// * ArduPilot stores no position for a command outside
///   [`cmd::ardupilot_stores_location`] (RTL, DO_ and CONDITION_ commands): its frame is not
///   compared, nor an x, y or z read back as 0 (Mission Planner writes such lines in frame 3,
///   some with the previous waypoint's position; ArduCopter reads them back as frame 0 and
///   zeros); where it keeps only a direction (NAV_LOITER_TIME param3, NAV_LAND param4) the
///   sign is compared;
/// * parameters must match within 1e-4 (relative), except that a NaN sent may come back
///   as 0 (neither autopilot stores NaN "unchanged" markers) and, for ArduPilot
///   (`AP_Mission` keeps only the parameters its packed 15-byte command has, e.g. a waypoint
///   keeps its delay but not its acceptance radius or yaw), a parameter may come back as 0;
/// * PX4 keeps, of an item sent in a global frame, only the parameters its `mission_item_s`
///   has for the command, some as flags or a wrapped yaw: what it reads back is expected
///   (`px4_position_param`);
/// * `current` and `autocontinue` are not compared (the vehicle sets them).
///
/// Returns the first difference: the item, the field, both values.
pub fn compare_items(
    sent: &[MissionItem],
    got: &[MissionItem],
    ardupilot: bool,
) -> Result<(), ItemsDiffer> {
    if sent.len() != got.len() {
        return Err(ItemsDiffer::Count {
            sent: sent.len(),
            got: got.len(),
        });
    }
    for (i, (a, b)) in sent.iter().zip(got).enumerate() {
        let diff = |what: &str, x: String, y: String| {
            Err(ItemsDiffer::Field {
                item: i,
                field: what.to_string(),
                sent: x,
                got: y,
            })
        };
        if a.command != b.command {
            return diff("command", a.command.to_string(), b.command.to_string());
        }
        let positioned = !ardupilot || cmd::ardupilot_stores_location(a.command);
        if positioned
            && is_global_frame(a.frame)
            && normalize_frame(a.frame) != normalize_frame(b.frame)
        {
            return diff("frame", a.frame.to_string(), b.frame.to_string());
        }
        // Outside stored_in_location ArduPilot keeps x, y, z only where the command has
        // a field for them (DO_DIGICAM_CONTROL's shooting command, NAV_ATTITUDE_TIME's climb
        // rate): a 0 read back is "not stored", any other value is compared.
        let kept = |got: f64| positioned || got != 0.0;
        if (kept(f64::from(b.x)) && a.x != b.x) || (kept(f64::from(b.y)) && a.y != b.y) {
            return diff(
                "x/y",
                format!("{}/{}", a.x, a.y),
                format!("{}/{}", b.x, b.y),
            );
        }
        if kept(f64::from(b.z)) && !(same_f32(a.z, b.z, 0.0) || (a.z - b.z).abs() <= 0.01) {
            return diff("z", a.z.to_string(), b.z.to_string());
        }
        for (k, (p, q)) in [
            (a.param1, b.param1),
            (a.param2, b.param2),
            (a.param3, b.param3),
            (a.param4, b.param4),
        ]
        .into_iter()
        .enumerate()
        {
            let dropped = q == 0.0 && (p.is_nan() || ardupilot);
            let p = if ardupilot {
                ardupilot_direction(a.command, k + 1, p)
            } else if is_global_frame(a.frame) {
                px4_position_param(a.command, k + 1, p)
            } else {
                p
            };
            if !same_f32(p, q, 1e-4) && !dropped {
                return diff(&format!("param{}", k + 1), p.to_string(), q.to_string());
            }
        }
    }
    Ok(())
}

/// The first difference [`compare_items`] finds between a list sent and the list read back.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ItemsDiffer {
    /// The lists have different lengths.
    #[error("{sent} items sent, {got} read back")]
    Count {
        /// Items sent.
        sent: usize,
        /// Items read back.
        got: usize,
    },
    /// An item differs in one field.
    #[error("item {item}: {field} sent {sent}, read back {got}")]
    Field {
        /// The item's index.
        item: usize,
        /// The field: "command", "frame", "x/y", "z", "param1" … "param4".
        field: String,
        /// The value sent.
        sent: String,
        /// The value read back.
        got: String,
    },
}

/// What ArduPilot reads back for parameter `n` (1–4) sent as `p` where it keeps only a
/// direction (`AP_Mission::mission_cmd_to_mavlink_int`: `loiter_ccw ? -1 : 1`): NAV_LOITER_TIME
/// param3 and NAV_LAND param4 come back as −1 when sent negative, else 1 (a 0 in a Mission
/// Planner file reads back as 1). Other parameters as sent.
fn ardupilot_direction(command: u16, n: usize, p: f32) -> f32 {
    match (command, n) {
        (cmd::NAV_LOITER_TIME, 3) | (cmd::NAV_LAND, 4) => {
            if p < 0.0 {
                -1.0
            } else {
                1.0
            }
        }
        _ => p,
    }
}

/// What PX4 reads back for parameter `n` (1–4) sent as `p` of a command sent in a global
/// frame. PX4 parses such an item into the fields its `mission_item_s` has for the command
/// and formats a download from those fields only (`MavlinkMissionManager::
/// parse_mavlink_mission_item` and `format_mavlink_mission_item`,
/// `src/modules/mavlink/mavlink_mission.cpp`), so:
///
/// * a yaw (waypoint, loiter, land, take-off, VTOL take-off and land param4) is stored in
///   radians wrapped to [0, 2π) and comes back in degrees in [0, 360) (NaN stays NaN);
/// * a flag comes back as 1 when sent positive, else 0 (NAV_LOITER_TIME param2 heading
///   required and param4 exit cross-track; NAV_LOITER_TO_ALT param1 and param4);
/// * a parameter the command has no field for comes back as 0: a take-off's param1 (the
///   pitch QGroundControl writes, 15 in PX4's own `MC_mission_box.plan`), a land's param1
///   and param3, a waypoint's param3, VTOL take-off and land param1–3;
/// * any other parameter (hold time, acceptance radius, loiter radius, precision landing)
///   as sent. Commands not listed here are returned as sent.
pub(crate) fn px4_position_param(command: u16, n: usize, p: f32) -> f32 {
    let yaw = |p: f32| if p.is_nan() { p } else { p.rem_euclid(360.0) };
    let flag = |p: f32| if p > 0.0 { 1.0 } else { 0.0 };
    match (command, n) {
        (cmd::NAV_WAYPOINT, 3) => 0.0,
        (cmd::NAV_WAYPOINT, 4) => yaw(p),
        (cmd::NAV_LOITER_UNLIM, 1 | 2) => 0.0,
        (cmd::NAV_LOITER_UNLIM, 4) => yaw(p),
        (cmd::NAV_LOITER_TIME, 2 | 4) => flag(p),
        (cmd::NAV_LAND, 1 | 3) => 0.0,
        (cmd::NAV_LAND, 4) => yaw(p),
        (cmd::NAV_TAKEOFF, 1..=3) => 0.0,
        (cmd::NAV_TAKEOFF, 4) => yaw(p),
        (cmd::NAV_LOITER_TO_ALT, 1 | 4) => flag(p),
        (cmd::NAV_LOITER_TO_ALT, 3) => 0.0,
        (cmd::NAV_VTOL_TAKEOFF | cmd::NAV_VTOL_LAND, 1..=3) => 0.0,
        (cmd::NAV_VTOL_TAKEOFF | cmd::NAV_VTOL_LAND, 4) => yaw(p),
        _ => p,
    }
}

/// The all-zero home placeholder sent at ArduPilot's seq 0 when no home is known.
pub fn home_placeholder() -> MissionItem {
    MissionItem {
        frame: frame::GLOBAL,
        ..MissionItem::command(cmd::NAV_WAYPOINT)
    }
}

/// User items → wire items for a list of `kind` (home prepended and DO_JUMP shifted when
/// `home_item`; seq, current and mission type set). The items are not addressed yet
/// (`target_system` and `target_component` 0): the mission client addresses them to its
/// vehicle's endpoint.
pub fn build_wire(
    kind: MissionType,
    items: &[MissionItem],
    home: Option<&MissionItem>,
    home_item: bool,
) -> Result<Vec<MISSION_ITEM_INT_DATA>, WireError> {
    let offset = home_item && kind == MissionType::Mission;
    let mut user: Vec<MissionItem> = Vec::with_capacity(items.len() + 1);
    if offset {
        user.push(home.copied().unwrap_or_else(home_placeholder));
    }
    for it in items {
        let mut it = *it;
        if offset && it.command == cmd::DO_JUMP {
            it.param1 += 1.0;
        }
        user.push(it);
    }
    if user.len() > usize::from(u16::MAX) {
        return Err(WireError::TooMany { count: items.len() });
    }
    let mut wire = Vec::with_capacity(user.len());
    for (i, it) in user.iter().enumerate() {
        let index = if offset { i.saturating_sub(1) } else { i };
        let mut w = item_to_wire(it, index)?;
        w.seq = i as u16;
        w.current = u8::from(i == 0);
        w.mission_type = mav_type(kind);
        wire.push(w);
    }
    Ok(wire)
}

/// Wire items → (user items, home) for a list of `kind` (inverse of `build_wire`).
pub(crate) fn from_wire_list(
    kind: MissionType,
    wire: &[MISSION_ITEM_INT_DATA],
    home_item: bool,
) -> (Vec<MissionItem>, Option<MissionItem>) {
    let offset = home_item && kind == MissionType::Mission;
    // The deprecated `_INT` frames (PX4 answers in them) are folded onto their synonyms,
    // as QGroundControl does on download (`PlanManager::_handleMissionItem`).
    let mut items: Vec<MissionItem> = wire
        .iter()
        .map(|w| {
            let mut it = item_from_wire(w);
            it.frame = normalize_frame(it.frame);
            it
        })
        .collect();
    let home = if offset && !items.is_empty() {
        Some(items.remove(0))
    } else {
        None
    };
    if offset {
        for it in &mut items {
            if it.command == cmd::DO_JUMP {
                it.param1 -= 1.0;
            }
        }
    }
    (items, home)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mission Planner's RTL line (frame 3, the last waypoint's position) against what
    /// ArduCopter reads back (frame 0, no position): equal by ArduPilot's storage rules, still
    /// different by PX4's; a waypoint's position is compared under both.
    #[test]
    fn a_frame_3_rtl_reads_back_as_arducopter_stores_it() {
        let mut rtl = MissionItem::return_to_launch();
        rtl.frame = frame::GLOBAL_RELATIVE_ALT;
        rtl.x = 371_968_000;
        rtl.y = -805_781_000;
        rtl.z = 6.0;
        let stored = MissionItem {
            frame: frame::GLOBAL,
            x: 0,
            y: 0,
            z: 0.0,
            ..rtl
        };
        let wp = MissionItem::waypoint(37.1968, -80.5781, 6.0);
        assert_eq!(compare_items(&[wp, rtl], &[wp, stored], true), Ok(()));
        assert_eq!(
            compare_items(&[rtl], &[stored], false).map_err(|e| e.to_string()),
            Err("item 0: frame sent 3, read back 0".to_string())
        );
        // NAV_LAND param4 and NAV_LOITER_TIME param3 come back as a direction, ±1
        let mut land = MissionItem::at(cmd::NAV_LAND, 37.1968, -80.5781, 0.0);
        let mut loiter = MissionItem::at(cmd::NAV_LOITER_TIME, 37.1968, -80.5781, 10.0);
        loiter.param1 = 5.0;
        let (mut land_back, mut loiter_back) = (land, loiter);
        land_back.param4 = 1.0;
        loiter_back.param3 = 1.0;
        assert_eq!(
            compare_items(&[land, loiter], &[land_back, loiter_back], true),
            Ok(())
        );
        land.param4 = -3.0;
        loiter.param3 = -1.0;
        assert!(compare_items(&[land], &[land_back], true).is_err());
        land_back.param4 = -1.0;
        loiter_back.param3 = -1.0;
        assert_eq!(
            compare_items(&[land, loiter], &[land_back, loiter_back], true),
            Ok(())
        );
        // a command with a field in x (DO_DIGICAM_CONTROL's shooting command) keeps it
        let mut shoot = MissionItem::command(cmd::DO_DIGICAM_CONTROL);
        shoot.x = 1;
        let mut not_shot = shoot;
        not_shot.x = 2;
        assert!(compare_items(&[shoot], &[not_shot], true).is_err());
        let mut moved = wp;
        moved.x += 10;
        assert_eq!(
            compare_items(&[wp], &[moved], true).map_err(|e| e.to_string()),
            Err("item 0: x/y sent 371968000/-805781000, read back 371968010/-805781000".into())
        );
    }

    /// PX4's `MC_mission_box.plan` (its integration tests) takes off with param1 15, QGroundControl's
    /// pitch: PX4 keeps no pitch for a take-off and reads it back as 0 — the same mission by
    /// PX4's storage rules, as are a waypoint's yaw of −90° read back as 270° and a loiter's
    /// "heading required" 5 read back as the flag 1. A waypoint's hold time or a take-off's yaw
    /// that changed is still a difference.
    #[test]
    fn px4_reads_back_what_its_mission_item_keeps() {
        let mut takeoff = MissionItem::at(cmd::NAV_TAKEOFF, 47.3977394, 8.5455904, 5.0);
        takeoff.param1 = 15.0;
        takeoff.param4 = f32::NAN;
        let mut wp = MissionItem::waypoint(47.3978729, 8.5455933, 10.0);
        wp.param4 = -90.0;
        let mut loiter = MissionItem::loiter_time(5.0, 47.3978729, 8.5453415, 10.0);
        loiter.param2 = 5.0;
        let (mut takeoff_back, mut wp_back, mut loiter_back) = (takeoff, wp, loiter);
        takeoff_back.frame = 6; // GLOBAL_RELATIVE_ALT_INT, as PX4 answers
        takeoff_back.param1 = 0.0;
        wp_back.param4 = 270.0;
        loiter_back.param2 = 1.0;
        let sent = [takeoff, wp, loiter];
        assert_eq!(
            compare_items(&sent, &[takeoff_back, wp_back, loiter_back], false),
            Ok(())
        );
        let mut held = wp_back;
        held.param1 = 3.0;
        assert_eq!(
            compare_items(&[wp], &[held], false).map_err(|e| e.to_string()),
            Err("item 0: param1 sent 0, read back 3".to_string())
        );
        let mut turned = takeoff_back;
        turned.param4 = 90.0;
        assert!(compare_items(&[takeoff], &[turned], false).is_err());
    }

    /// ArduCopter's `ConditionLocation` autotest mission has a command 116 between two
    /// waypoints, a number in no MAVLink dialect: refused before upload, with the item, the
    /// number and what an autopilot would answer.
    #[test]
    fn a_command_in_no_dialect_is_refused_before_upload_and_says_why() {
        let mut unknown = MissionItem::at(116, -35.362364, 149.165237, 20.0);
        unknown.frame = frame::GLOBAL_RELATIVE_ALT;
        let items = [
            MissionItem::takeoff(20.0),
            MissionItem::waypoint(-35.362993, 149.165237, 20.0),
            unknown,
        ];
        let e = build_wire(MissionType::Mission, &items, None, true)
            .expect_err("command 116 cannot be encoded");
        assert_eq!(
            e,
            WireError::UnknownCommand {
                index: 2,
                command: 116
            }
        );
        let text = e.to_string();
        assert!(text.starts_with("mission item 2: command 116 "), "{text}");
        assert!(text.contains("MAV_MISSION_UNSUPPORTED"), "{text}");
    }
}
