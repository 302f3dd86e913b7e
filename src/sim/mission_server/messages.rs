//! The messages both autopilots answer with: targets, acknowledgements, requests, counts,
//! items (autopilot-specific details by `self.autopilot`).

use super::*;

impl MissionServer {
    /// Whether MISSION_ITEM's float x/y are degrees (scaled by 10⁷ into the INT form):
    /// ArduPilot scales all but the DIGICAM, NAV_ATTITUDE_TIME and GIMBAL_MANAGER_PITCHYAW
    /// commands (AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT); PX4 scales items in a
    /// global frame and keeps MISSION-frame parameters as they are.
    pub(super) fn float_xy_is_degrees(&self, command: u16, frame: u8) -> bool {
        match self.autopilot {
            Autopilot::ArduPilot => !matches!(command, 202 | 203 | 1000 | 42703),
            Autopilot::Px4 => frame != 2,
        }
    }

    pub(super) fn is_for_me(&self, sys: u8, comp: u8) -> bool {
        sys == self.sysid
            && (comp == self.compid
                || comp == 0
                || (self.autopilot == Autopilot::Px4 && comp == COMP_MISSIONPLANNER))
    }

    pub(super) fn accept_target(
        &self,
        sys: u8,
        comp: u8,
        t: mav::MavMissionType,
    ) -> Option<MissionType> {
        if self.is_for_me(sys, comp) {
            mtype(t)
        } else {
            None
        }
    }

    pub(super) fn ack_raw(
        &self,
        to: (u8, u8),
        t: mav::MavMissionType,
        result: mav::MavMissionResult,
        opaque_id: u32,
    ) -> MavMessage {
        MavMessage::MISSION_ACK(mav::MISSION_ACK_DATA {
            target_system: to.0,
            target_component: to.1,
            mavtype: result,
            mission_type: t,
            opaque_id,
        })
    }

    pub(super) fn ack_to(
        &self,
        to: (u8, u8),
        t: MissionType,
        result: mav::MavMissionResult,
        opaque_id: u32,
    ) -> MavMessage {
        self.ack_raw(to, wire_type(t), result, opaque_id)
    }

    pub(super) fn request_msg(
        &self,
        to: (u8, u8),
        seq: u16,
        t: MissionType,
        int: bool,
    ) -> MavMessage {
        if int {
            MavMessage::MISSION_REQUEST_INT(mav::MISSION_REQUEST_INT_DATA {
                seq,
                target_system: to.0,
                target_component: to.1,
                mission_type: wire_type(t),
            })
        } else {
            MavMessage::MISSION_REQUEST(mav::MISSION_REQUEST_DATA {
                seq,
                target_system: to.0,
                target_component: to.1,
                mission_type: wire_type(t),
            })
        }
    }

    pub(super) fn count_msg(
        &self,
        to: (u8, u8),
        t: MissionType,
        count: u16,
        opaque_id: u32,
    ) -> MavMessage {
        MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
            count,
            target_system: to.0,
            target_component: to.1,
            mission_type: wire_type(t),
            opaque_id,
        })
    }

    pub(super) fn item_msg(
        &self,
        to: (u8, u8),
        t: MissionType,
        seq: u16,
        item: &MissionItem,
        int: bool,
    ) -> MavMessage {
        let frame = mav::MavFrame::from_u8(item.frame).unwrap_or(mav::MavFrame::MAV_FRAME_MISSION);
        let command =
            mav::MavCmd::from_u16(item.command).unwrap_or(mav::MavCmd::MAV_CMD_NAV_WAYPOINT);
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
                target_system: to.0,
                target_component: to.1,
                frame,
                current: u8::from(item.current),
                autocontinue: u8::from(item.autocontinue),
                mission_type: wire_type(t),
            })
        } else {
            let scaled = self.float_xy_is_degrees(item.command, item.frame);
            let (x, y) = if scaled {
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
                target_system: to.0,
                target_component: to.1,
                frame,
                current: u8::from(item.current),
                autocontinue: u8::from(item.autocontinue),
                mission_type: wire_type(t),
            })
        }
    }
}
