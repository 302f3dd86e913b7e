//! The messages both autopilots answer with: targets, acknowledgements, requests, counts,
//! items (autopilot-specific details by the [`Transfer`] variant).

use super::*;

impl Transfer {
    /// Whether MISSION_ITEM's float x/y are degrees (scaled by 10⁷ into the INT form):
    /// ArduPilot scales all but the DIGICAM, NAV_ATTITUDE_TIME and GIMBAL_MANAGER_PITCHYAW
    /// commands (AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT); PX4 scales items in a
    /// global frame and keeps MISSION-frame parameters as they are.
    pub(super) fn float_xy_is_degrees(&self, command: u16, frame: u8) -> bool {
        match self {
            Transfer::ArduPilot(_) => ArduPilotState::float_xy_is_degrees(command),
            Transfer::Px4(_) => Px4State::float_xy_is_degrees(frame),
        }
    }

    /// Whether a message to `sys`/`comp` is for this vehicle (PX4 also answers as the
    /// mission planner component).
    pub(super) fn is_for_me(&self, core: &Core, sys: u8, comp: u8) -> bool {
        is_for_me(core, matches!(self, Transfer::Px4(_)), sys, comp)
    }

    /// The list a message to `sys`/`comp` is about, if it is for this vehicle and names one.
    /// A MISSION_REQUEST (`int` false) or MISSION_REQUEST_INT (`int` true) for item `seq`
    /// from `from`, addressed to `target` (system, component): answered when it is for this
    /// vehicle (PX4 answers in the form it was asked in: `int_mode`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn on_request(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        target: Endpoint,
        mission_type: mav::MavMissionType,
        seq: u16,
        int: bool,
        now: Time,
    ) {
        let Some(t) = self.accept_target(core, target.sysid, target.compid, mission_type) else {
            return;
        };
        match self {
            Transfer::ArduPilot(ap) => ap.request(core, from, t, seq, int),
            Transfer::Px4(p) => {
                p.int_mode = int;
                p.request(core, from, t, seq, now);
            }
        }
    }

    pub(super) fn accept_target(
        &self,
        core: &Core,
        sys: u8,
        comp: u8,
        t: mav::MavMissionType,
    ) -> Option<MissionType> {
        if self.is_for_me(core, sys, comp) {
            mtype(t)
        } else {
            None
        }
    }
}

impl ArduPilotState {
    /// See [`Transfer::float_xy_is_degrees`].
    pub(super) fn float_xy_is_degrees(command: u16) -> bool {
        !matches!(
            mav::MavCmd::from_u16(command),
            Some(
                mav::MavCmd::MAV_CMD_DO_DIGICAM_CONFIGURE
                    | mav::MavCmd::MAV_CMD_DO_DIGICAM_CONTROL
                    | mav::MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW
                    | mav::MavCmd::MAV_CMD_NAV_ATTITUDE_TIME
            )
        )
    }
}

impl Px4State {
    /// See [`Transfer::float_xy_is_degrees`].
    pub(super) fn float_xy_is_degrees(frame: u8) -> bool {
        frame != 2
    }
}

/// Whether a message to `sys`/`comp` is for the vehicle `core` (component 0 is everyone;
/// `mission_planner`: also MAV_COMP_ID_MISSIONPLANNER).
pub(super) fn is_for_me(core: &Core, mission_planner: bool, sys: u8, comp: u8) -> bool {
    sys == core.sysid
        && (comp == core.compid || comp == 0 || (mission_planner && comp == COMP_MISSIONPLANNER))
}

/// MISSION_ACK with `result` to `to` for the wire mission type `t` (also the ones
/// [`MissionType`] does not name, such as MAV_MISSION_TYPE_ALL).
pub(super) fn ack_raw(
    to: Endpoint,
    t: mav::MavMissionType,
    result: mav::MavMissionResult,
    opaque_id: u32,
) -> MavMessage {
    MavMessage::MISSION_ACK(mav::MISSION_ACK_DATA {
        target_system: to.sysid,
        target_component: to.compid,
        mavtype: result,
        mission_type: t,
        opaque_id,
    })
}

/// MISSION_ACK with `result` to `to` for list `t`; `opaque_id` is PX4's CRC-32 (0 otherwise).
pub(super) fn ack_to(
    to: Endpoint,
    t: MissionType,
    result: mav::MavMissionResult,
    opaque_id: u32,
) -> MavMessage {
    ack_raw(to, wire_type(t), result, opaque_id)
}

/// MISSION_REQUEST_INT (`int`) or MISSION_REQUEST for item `seq` of list `t`.
pub(super) fn request_msg(to: Endpoint, seq: u16, t: MissionType, int: bool) -> MavMessage {
    if int {
        MavMessage::MISSION_REQUEST_INT(mav::MISSION_REQUEST_INT_DATA {
            seq,
            target_system: to.sysid,
            target_component: to.compid,
            mission_type: wire_type(t),
        })
    } else {
        MavMessage::MISSION_REQUEST(mav::MISSION_REQUEST_DATA {
            seq,
            target_system: to.sysid,
            target_component: to.compid,
            mission_type: wire_type(t),
        })
    }
}

/// MISSION_COUNT of list `t` (the answer to MISSION_REQUEST_LIST).
pub(super) fn count_msg(to: Endpoint, t: MissionType, count: u16, opaque_id: u32) -> MavMessage {
    MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
        count,
        target_system: to.sysid,
        target_component: to.compid,
        mission_type: wire_type(t),
        opaque_id,
    })
}

/// MISSION_ITEM_INT (`int`) or MISSION_ITEM for item `seq` of list `t`; in MISSION_ITEM,
/// x/y are degrees when `xy_degrees` (the autopilot's `float_xy_is_degrees`), else as stored.
pub(super) fn item_msg(
    to: Endpoint,
    t: MissionType,
    seq: u16,
    item: &MissionItem,
    int: bool,
    xy_degrees: bool,
) -> MavMessage {
    let frame = mav::MavFrame::from_u8(item.frame).unwrap_or(mav::MavFrame::MAV_FRAME_MISSION);
    let command = mav::MavCmd::from_u16(item.command).unwrap_or(mav::MavCmd::MAV_CMD_NAV_WAYPOINT);
    if int {
        MavMessage::MISSION_ITEM_INT(mav::MISSION_ITEM_INT_DATA {
            param1: item.param1,
            param2: item.param2,
            param3: item.param3,
            param4: item.param4,
            x: item.x,
            y: item.y,
            z: item.z,
            seq,
            command,
            target_system: to.sysid,
            target_component: to.compid,
            frame,
            current: u8::from(item.current),
            autocontinue: u8::from(item.autocontinue),
            mission_type: wire_type(t),
        })
    } else {
        let (x, y) = if xy_degrees {
            (
                (f64::from(item.x) * 1e-7) as f32,
                (f64::from(item.y) * 1e-7) as f32,
            )
        } else {
            (item.x as f32, item.y as f32)
        };
        MavMessage::MISSION_ITEM(mav::MISSION_ITEM_DATA {
            param1: item.param1,
            param2: item.param2,
            param3: item.param3,
            param4: item.param4,
            x,
            y,
            z: item.z,
            seq,
            command,
            target_system: to.sysid,
            target_component: to.compid,
            frame,
            current: u8::from(item.current),
            autocontinue: u8::from(item.autocontinue),
            mission_type: wire_type(t),
        })
    }
}
