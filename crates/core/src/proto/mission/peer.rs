//! What the client and its transfer sub-machines share: the two endpoints, whether home is
//! item 0, the configuration, the outgoing queue, the events and the count of ignored
//! messages, and the builders of the protocol's messages. The upload and download machines
//! take it by `&mut`; the client ([`super::MissionClient`]) owns it and them.

use super::types::{MissionConfig, MissionEvent};
use crate::mission::item::MissionType;
use crate::mission::wire::mav_type;
use crate::proto::Endpoint;
use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_REQUEST_INT_DATA, MISSION_REQUEST_LIST_DATA,
    MavMessage, MavMissionResult,
};
use std::collections::VecDeque;

/// The GCS's side of one vehicle's mission link.
#[derive(Debug)]
pub(super) struct Peer {
    /// Us: answers must be addressed here (or broadcast).
    pub(super) gcs: Endpoint,
    /// The autopilot.
    pub(super) target: Endpoint,
    /// The autopilot keeps home as mission item 0 (ArduPilot).
    pub(super) home_item: bool,
    pub(super) cfg: MissionConfig,
    /// Messages to send, in order.
    pub(super) out: VecDeque<MavMessage>,
    /// Events for the client's owner, in order.
    pub(super) events: VecDeque<MissionEvent>,
    /// Mission messages dropped because they matched no operation (late duplicates).
    pub(super) ignored: u64,
}

impl Peer {
    pub(super) fn new(
        gcs: Endpoint,
        target: Endpoint,
        home_item: bool,
        cfg: MissionConfig,
    ) -> Peer {
        Peer {
            gcs,
            target,
            home_item,
            cfg,
            out: VecDeque::new(),
            events: VecDeque::new(),
            ignored: 0,
        }
    }

    pub(super) fn count_msg(&self, kind: MissionType, count: u16) -> MavMessage {
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count,
            target_system: self.target.sysid,
            target_component: self.target.compid,
            mission_type: mav_type(kind),
            opaque_id: 0,
        })
    }

    pub(super) fn request_list_msg(&self, kind: MissionType) -> MavMessage {
        MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
            target_system: self.target.sysid,
            target_component: self.target.compid,
            mission_type: mav_type(kind),
        })
    }

    pub(super) fn request_item_msg(&self, kind: MissionType, seq: u16) -> MavMessage {
        MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq,
            target_system: self.target.sysid,
            target_component: self.target.compid,
            mission_type: mav_type(kind),
        })
    }

    pub(super) fn send_ack(&mut self, kind: MissionType, result: MavMissionResult) {
        self.out
            .push_back(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: self.target.sysid,
                target_component: self.target.compid,
                mavtype: result,
                mission_type: mav_type(kind),
                opaque_id: 0,
            }));
    }
}
