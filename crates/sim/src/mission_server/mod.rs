//! The vehicle side of the MAVLink mission protocol (mission, fence and rally lists), as
//! ArduPilot and PX4 implement it — a sans-IO state machine.
//!
//! It speaks `mavlink::ardupilotmega::MavMessage` values: feed it what the vehicle receives
//! with [`MissionServer::handle_message`], call [`MissionServer::handle_timeout`] when
//! [`MissionServer::poll_timeout`] is due, and send what [`MissionServer::poll_transmit`]
//! returns. Lists and protocol state survive [`MissionServer::reboot`] the way each
//! autopilot keeps them (ArduPilot: EEPROM/flash; PX4: dataman on the SD card).
//!
//! # ArduPilot
//! Followed from ArduPilot `libraries/GCS_MAVLink/MissionItemProtocol.cpp`,
//! `MissionItemProtocol_Waypoints.cpp` and `libraries/AP_Mission/AP_Mission.cpp`:
//! - item 0 of the mission is home: a download of seq 0 always returns the current home
//!   (frame GLOBAL, AMSL altitude), whatever was uploaded there;
//! - MISSION_COUNT truncates the stored mission (and rally list) *at once*; items are then
//!   written in place as they arrive, so an aborted upload leaves a mix of old and new items;
//!   a second MISSION_COUNT from the same GCS restarts the upload, one from another GCS gets
//!   MAV_MISSION_DENIED; more items than fit get MAV_MISSION_NO_SPACE and a STATUSTEXT;
//! - the vehicle requests items with MISSION_REQUEST (not `_INT`), re-requests after 1 s of
//!   silence and cancels the upload after 8 s without an item (MISSION_ACK
//!   OPERATION_CANCELLED, "Mission upload timeout");
//! - an item with the wrong seq gets MAV_MISSION_INVALID_SEQUENCE and the upload goes on; an
//!   item when no upload is running gets MAV_MISSION_ERROR (also a repeated last item whose
//!   ACK was lost); an invalid item aborts the upload with its specific result;
//! - items are stored in AP_Mission's packed 15-byte format, so a round trip is lossy: a
//!   waypoint keeps only its delay (whole seconds) and position, altitudes are kept in
//!   centimetres, unsupported commands are rejected with MAV_MISSION_UNSUPPORTED;
//! - downloads are stateless: MISSION_REQUEST_LIST → MISSION_COUNT, each MISSION_REQUEST_INT
//!   → MISSION_ITEM_INT; MISSION_REQUEST is answered with MISSION_ITEM and the warning
//!   "got MISSION_REQUEST; use MISSION_REQUEST_INT!"; during an upload both are DENIED;
//! - MISSION_CLEAR_ALL fails (MAV_MISSION_ERROR) during an upload or while the mission runs.
//! - while it boots (about 2 s after power-up, heartbeat MAV_STATE_BOOT; see
//!   `MissionServer::set_loaded`) the lists are not loaded: every MISSION_COUNT gets
//!   MAV_MISSION_NO_SPACE with "Only 0 items are supported", MISSION_REQUEST_LIST a count of 0
//!   (both seen on ArduCopter 4.7 SITL).
//!
//! # PX4
//! Followed from PX4 `src/modules/mavlink/mavlink_mission.cpp` and `mavlink_mission.h`:
//! - no home item: seq 0 is the first user item;
//! - one transfer at a time over all list types (IDLE / GETLIST / SENDLIST);
//! - the vehicle requests with MISSION_REQUEST until the GCS shows it speaks the INT variants
//!   (`_int_mode` starts false and follows the last MISSION_ITEM(_INT)/MISSION_REQUEST(_INT)
//!   received), re-requests every 250 ms and gives up after 5 s of silence ("Operation
//!   timeout", no ACK);
//! - an item with an unexpected seq is ignored; a repeated last item after the final ACK is
//!   re-acknowledged with MAV_MISSION_ACCEPTED; the new list replaces the old one only when
//!   the last item arrived (double-buffered in dataman);
//! - positions come back in the INT frames (GLOBAL_INT / GLOBAL_RELATIVE_ALT_INT) in int mode;
//!   NAV_RETURN_TO_LAUNCH must use frame MISSION; MISSION_ACK and MISSION_COUNT carry an
//!   `opaque_id` (a CRC-32 of the items).

// The deprecated MISSION_ITEM / MISSION_REQUEST / MISSION_SET_CURRENT are what the real
// autopilots still send and accept.
#![allow(deprecated)]

use crate::flavour::SimAutopilot;
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use std::collections::VecDeque;
use std::time::Duration;

/// MAV_COMP_ID_MISSIONPLANNER: PX4 accepts mission messages addressed to it.
const COMP_MISSIONPLANNER: u8 = mav::MavComponent::MAV_COMP_ID_MISSIONPLANNER as u8;

/// ArduPilot: re-request an item after this much silence (`wp_recv_timeout_ms`, without the
/// link's stream slowdown).
pub(crate) const ARDUPILOT_RESEND: Duration = Duration::from_millis(1000);
/// ArduPilot: cancel an upload after this long without an item (`upload_timeout_ms`).
pub(crate) const ARDUPILOT_UPLOAD_TIMEOUT: Duration = Duration::from_millis(8000);
/// PX4: re-request an item after this long (`MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT`).
pub(crate) const PX4_RETRY: Duration = Duration::from_millis(250);
/// PX4: abandon a transfer after this long without a message
/// (`MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT`).
pub(crate) const PX4_PROTOCOL_TIMEOUT: Duration = Duration::from_millis(5000);

/// Storage limits per list (mission, fence, rally).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capacity {
    /// Mission items (ArduPilot: including the home slot).
    pub mission: u16,
    /// Fence items.
    pub fence: u16,
    /// Rally points.
    pub rally: u16,
}

impl Capacity {
    /// ArduPilot on a 16 KiB storage board (AP_Mission stores 15 bytes per item).
    pub const ARDUPILOT: Capacity = Capacity {
        mission: 724,
        fence: 84,
        rally: 10,
    };
    /// PX4 defaults (`DM_KEY_WAYPOINTS_OFFBOARD_0_MAX`, `DM_KEY_FENCE_POINTS_MAX`,
    /// `DM_KEY_SAFE_POINTS_MAX` on boards with an SD card).
    pub const PX4: Capacity = Capacity {
        mission: 2000,
        fence: 64,
        rally: 8,
    };

    fn of(&self, t: MissionType) -> u16 {
        match t {
            MissionType::Mission => self.mission,
            MissionType::Fence => self.fence,
            MissionType::Rally => self.rally,
        }
    }
}

/// Home as ArduPilot reports it in mission slot 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomeItem {
    /// Latitude, degrees × 10⁷.
    pub lat_e7: i32,
    /// Longitude, degrees × 10⁷.
    pub lon_e7: i32,
    /// Altitude above mean sea level, metres.
    pub alt_amsl_m: f32,
}

/// What happened to the stored lists (for the vehicle logic).
#[derive(Clone, Debug, PartialEq)]
pub enum MissionEvent {
    /// An upload started; for ArduPilot the mission/rally list is already truncated.
    UploadStarted {
        /// Which list.
        mission_type: MissionType,
        /// Items announced by MISSION_COUNT.
        count: u16,
    },
    /// An upload completed and the list now holds the new items.
    Uploaded {
        /// Which list.
        mission_type: MissionType,
        /// Items in the list (ArduPilot mission: including home).
        count: u16,
    },
    /// An upload was abandoned (timeout, invalid item).
    UploadFailed {
        /// Which list.
        mission_type: MissionType,
    },
    /// A list was cleared.
    Cleared {
        /// Which list.
        mission_type: MissionType,
    },
    /// The GCS asked to make `seq` the current mission item (MISSION_SET_CURRENT, already
    /// checked against the list length).
    SetCurrent {
        /// Item in the autopilot's numbering.
        seq: u16,
    },
}

/// What both autopilots keep the same way: who the vehicle is, the stored lists and what is
/// waiting to be sent. The per-autopilot transfer state is in [`Transfer`].
#[derive(Clone, Debug)]
struct Core {
    sysid: u8,
    compid: u8,
    capacity: Capacity,
    /// Mission, fence, rally (indexed by [`idx`]) in the autopilot's numbering.
    lists: [Vec<MissionItem>; 3],
    /// The current mission item (autopilot numbering).
    current: u16,
    outbox: VecDeque<MavMessage>,
    events: VecDeque<MissionEvent>,
}

/// The transfer state of the autopilot imitated: each variant owns only its own fields.
#[derive(Clone, Debug)]
enum Transfer {
    /// ArduPilot: one upload slot per list, stateless downloads.
    ArduPilot(ArduPilotState),
    /// PX4: one transfer at a time over all lists.
    Px4(Px4State),
}

/// ArduPilot's side: per-list uploads and what survives in its storage.
#[derive(Clone, Debug)]
struct ArduPilotState {
    /// The lists are loaded from storage (`AP_Mission::init`, before the vehicle leaves
    /// MAV_STATE_BOOT); until then every list is empty and holds nothing.
    loaded: bool,
    /// Home, reported as mission item 0.
    home: Option<HomeItem>,
    /// The mission is being executed (MISSION_CLEAR_ALL is refused meanwhile).
    mission_running: bool,
    /// The upload in progress per list (mission, fence, rally).
    uploads: [Option<ApUpload>; 3],
    /// "got MISSION_REQUEST; use MISSION_REQUEST_INT!" was sent (once per upload).
    warned_request: bool,
    /// "got MISSION_ITEM; GCS should send MISSION_ITEM_INT" was sent (once per upload).
    warned_item: bool,
}

#[derive(Clone, Debug)]
struct ApUpload {
    partner: Endpoint,
    request_i: u16,
    request_last: u16,
    last_receive: Time,
    last_request: Time,
    /// Fence uploads are buffered and replace the fence at the end.
    buffer: Vec<MissionItem>,
}

/// PX4's `MavlinkMissionManager::_state` (`mavlink_mission.h`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Px4Phase {
    Idle,
    GetList,
    SendList,
}

/// PX4's side: the one transfer (`mavlink_mission.cpp`), the GCS's int mode and the lists'
/// opaque ids.
#[derive(Clone, Debug)]
struct Px4State {
    phase: Px4Phase,
    mission_type: MissionType,
    partner: Endpoint,
    transfer_seq: u16,
    transfer_count: u16,
    transfer_items: Vec<MissionItem>,
    transfer_current_seq: Option<u16>,
    transfer_crc: u32,
    last_sent: Option<Time>,
    last_recv: Option<Time>,
    int_mode: bool,
    /// The opaque id (CRC-32 of the items) of each stored list.
    crc: [u32; 3],
}

/// The vehicle side of the mission protocol. See the module documentation.
#[derive(Clone, Debug)]
pub struct MissionServer {
    core: Core,
    transfer: Transfer,
}

fn idx(t: MissionType) -> usize {
    t.as_u8() as usize
}

fn mtype(t: mav::MavMissionType) -> Option<MissionType> {
    MissionType::from_u8(t as u8)
}

fn wire_type(t: MissionType) -> mav::MavMissionType {
    mav::MavMissionType::from_u8(t.as_u8()).unwrap_or(mav::MavMissionType::MAV_MISSION_TYPE_MISSION)
}

fn text(severity: mav::MavSeverity, s: &str) -> MavMessage {
    MavMessage::STATUSTEXT(mav::STATUSTEXT_DATA {
        severity,
        text: s.into(),
        id: 0,
        chunk_seq: 0,
    })
}

/// The raw fields of a MISSION_ITEM / MISSION_ITEM_INT as received.
#[derive(Clone, Copy, Debug)]
struct RxItem {
    seq: u16,
    target: Endpoint,
    mission_type: MissionType,
    item: MissionItem,
    /// Lat/lon were floats (MISSION_ITEM).
    float: bool,
}

impl MissionServer {
    /// A server for the vehicle `sysid`/`compid` with empty lists and the autopilot's default
    /// capacity.
    pub fn new(autopilot: SimAutopilot, sysid: u8, compid: u8) -> MissionServer {
        let (capacity, transfer) = match autopilot {
            SimAutopilot::ArduPilot => (
                Capacity::ARDUPILOT,
                Transfer::ArduPilot(ArduPilotState::new()),
            ),
            SimAutopilot::Px4 => (Capacity::PX4, Transfer::Px4(Px4State::new())),
        };
        MissionServer {
            core: Core {
                sysid,
                compid,
                capacity,
                lists: [Vec::new(), Vec::new(), Vec::new()],
                current: 0,
                outbox: VecDeque::new(),
                events: VecDeque::new(),
            },
            transfer,
        }
    }

    /// Change the storage limits.
    pub fn set_capacity(&mut self, capacity: Capacity) {
        self.core.capacity = capacity;
    }

    /// The autopilot this server imitates.
    pub fn autopilot(&self) -> SimAutopilot {
        match self.transfer {
            Transfer::ArduPilot(_) => SimAutopilot::ArduPilot,
            Transfer::Px4(_) => SimAutopilot::Px4,
        }
    }

    /// ArduPilot while it boots: the lists are not loaded yet, so an upload is refused
    /// with MAV_MISSION_NO_SPACE and a download finds an empty list (`loaded` false) —
    /// what a real ArduCopter does for about 2 s after power-up. PX4 answers as soon as its
    /// MAVLink instance runs (dataman is up before it), so this applies to ArduPilot only.
    pub(crate) fn set_loaded(&mut self, loaded: bool) {
        if let Transfer::ArduPilot(ap) = &mut self.transfer {
            ap.loaded = loaded;
        }
    }

    /// A power cycle: the stored lists survive (ArduPilot EEPROM, PX4 dataman), transfers in
    /// progress are lost, the current item goes back to the start (ArduPilot: 1 after home,
    /// PX4: 0 — PX4 does persist `current_seq` in dataman, but the navigator resets it when
    /// the mission is loaded after boot) and PX4 forgets the GCS's int mode.
    pub fn reboot(&mut self) {
        match &mut self.transfer {
            Transfer::ArduPilot(ap) => ap.reboot(),
            Transfer::Px4(p) => p.reboot(),
        }
        self.core.outbox.clear();
        self.core.events.clear();
        self.core.current = self.first_item();
    }

    fn first_item(&self) -> u16 {
        match self.transfer {
            Transfer::ArduPilot(_) => 1,
            Transfer::Px4(_) => 0,
        }
    }

    /// Set the home position that ArduPilot reports as mission item 0 (PX4 has no home
    /// item: ignored).
    pub fn set_home(&mut self, home: Option<HomeItem>) {
        if let Transfer::ArduPilot(ap) = &mut self.transfer {
            ap.home = home;
        }
    }

    /// Tell the server whether the mission is being executed (ArduPilot refuses
    /// MISSION_CLEAR_ALL while it runs; PX4 does not look).
    pub(crate) fn set_mission_running(&mut self, running: bool) {
        if let Transfer::ArduPilot(ap) = &mut self.transfer {
            ap.mission_running = running;
        }
    }

    /// Set the current mission item (autopilot numbering), as the vehicle's mission logic
    /// advances; used for the `current` field of downloaded items.
    pub(crate) fn set_current(&mut self, seq: u16) {
        self.core.current = seq;
    }

    /// The current mission item (autopilot numbering).
    pub fn current(&self) -> u16 {
        self.core.current
    }

    /// The stored items of `t` in the autopilot's numbering (ArduPilot mission: index 0 is
    /// the home slot, as stored).
    pub fn items(&self, t: MissionType) -> &[MissionItem] {
        &self.core.lists[idx(t)]
    }

    /// The stored mission without ArduPilot's home slot (the user's items).
    pub fn user_items(&self) -> &[MissionItem] {
        let m = &self.core.lists[0];
        match self.transfer {
            Transfer::ArduPilot(_) if !m.is_empty() => &m[1..],
            _ => m,
        }
    }

    /// The PX4 opaque id (CRC-32) of list `t`; 0 for ArduPilot.
    pub fn opaque_id(&self, t: MissionType) -> u32 {
        match &self.transfer {
            Transfer::ArduPilot(_) => 0,
            Transfer::Px4(p) => p.crc[idx(t)],
        }
    }

    /// Whether an upload is in progress for any list (ArduPilot slows its streams down
    /// meanwhile).
    pub(crate) fn receiving(&self) -> bool {
        match &self.transfer {
            Transfer::ArduPilot(ap) => ap.uploads.iter().any(|r| r.is_some()),
            Transfer::Px4(p) => p.phase == Px4Phase::GetList,
        }
    }

    /// The next message to send, if any (from the autopilot component).
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.core.outbox.pop_front()
    }

    /// The next event for the vehicle logic, if any.
    pub fn poll_event(&mut self) -> Option<MissionEvent> {
        self.core.events.pop_front()
    }

    /// When [`MissionServer::handle_timeout`] should be called next.
    pub fn poll_timeout(&self) -> Option<Time> {
        match &self.transfer {
            Transfer::ArduPilot(ap) => ap.poll_timeout(),
            Transfer::Px4(p) => p.poll_timeout(),
        }
    }

    /// Run the protocol's timers.
    pub fn handle_timeout(&mut self, now: Time) {
        match &mut self.transfer {
            Transfer::ArduPilot(ap) => ap.handle_timeout(&mut self.core, now),
            Transfer::Px4(p) => p.handle_timeout(&mut self.core, now),
        }
    }

    /// Handle one received message. Returns `true` when it belonged to the mission protocol
    /// (whether or not it was addressed to this vehicle).
    pub fn handle_message(&mut self, header: &MavHeader, msg: &MavMessage, now: Time) -> bool {
        let from = Endpoint::of(header);
        let core = &mut self.core;
        match msg {
            MavMessage::MISSION_COUNT(m) => {
                if let Some(t) = self.transfer.accept_target(
                    core,
                    m.target_system,
                    m.target_component,
                    m.mission_type,
                ) {
                    match &mut self.transfer {
                        Transfer::ArduPilot(ap) => ap.count(core, from, t, m.count, now),
                        Transfer::Px4(p) => p.count(core, from, t, m.count, now),
                    }
                }
            }
            MavMessage::MISSION_ITEM_INT(m) => {
                let rx = RxItem {
                    seq: m.seq,
                    target: Endpoint::new(m.target_system, m.target_component),
                    mission_type: mtype(m.mission_type).unwrap_or(MissionType::Mission),
                    item: MissionItem {
                        frame: m.frame as u8,
                        command: m.command as u16,
                        current: m.current != 0,
                        autocontinue: m.autocontinue != 0,
                        param1: m.param1,
                        param2: m.param2,
                        param3: m.param3,
                        param4: m.param4,
                        x: m.x,
                        y: m.y,
                        z: m.z,
                    },
                    float: false,
                };
                if mtype(m.mission_type).is_some() {
                    self.handle_item(from, rx, m.current, now);
                } else if self
                    .transfer
                    .is_for_me(core, m.target_system, m.target_component)
                {
                    core.outbox.push_back(ack_raw(
                        from,
                        m.mission_type,
                        mav::MavMissionResult::MAV_MISSION_UNSUPPORTED,
                        0,
                    ));
                }
            }
            MavMessage::MISSION_ITEM(m) => {
                // MISSION_ITEM carries lat/lon as float degrees for position frames, as
                // parameters 5/6 otherwise (ArduPilot convert_MISSION_ITEM_to_MISSION_ITEM_INT
                // scales all but DIGICAM commands; PX4 treats x/y as doubles in float mode).
                let cmd = m.command as u16;
                let scaled = self.transfer.float_xy_is_degrees(cmd, m.frame as u8);
                let (x, y) = if scaled {
                    (
                        (f64::from(m.x) * 1e7).round() as i32,
                        (f64::from(m.y) * 1e7).round() as i32,
                    )
                } else {
                    (m.x.round() as i32, m.y.round() as i32)
                };
                let rx = RxItem {
                    seq: m.seq,
                    target: Endpoint::new(m.target_system, m.target_component),
                    mission_type: mtype(m.mission_type).unwrap_or(MissionType::Mission),
                    item: MissionItem {
                        frame: m.frame as u8,
                        command: cmd,
                        current: m.current != 0,
                        autocontinue: m.autocontinue != 0,
                        param1: m.param1,
                        param2: m.param2,
                        param3: m.param3,
                        param4: m.param4,
                        x,
                        y,
                        z: m.z,
                    },
                    float: true,
                };
                if mtype(m.mission_type).is_some() {
                    self.handle_item(from, rx, m.current, now);
                }
            }
            MavMessage::MISSION_REQUEST_LIST(m) => {
                if let Some(t) = self.transfer.accept_target(
                    core,
                    m.target_system,
                    m.target_component,
                    m.mission_type,
                ) {
                    match &mut self.transfer {
                        Transfer::ArduPilot(ap) => ap.request_list(core, from, t),
                        Transfer::Px4(p) => p.request_list(core, from, t, now),
                    }
                }
            }
            MavMessage::MISSION_REQUEST_INT(m) => {
                let target = Endpoint::new(m.target_system, m.target_component);
                self.transfer
                    .on_request(core, from, target, m.mission_type, m.seq, true, now);
            }
            MavMessage::MISSION_REQUEST(m) => {
                let target = Endpoint::new(m.target_system, m.target_component);
                self.transfer
                    .on_request(core, from, target, m.mission_type, m.seq, false, now);
            }
            MavMessage::MISSION_CLEAR_ALL(m) => {
                if self
                    .transfer
                    .is_for_me(core, m.target_system, m.target_component)
                {
                    match &mut self.transfer {
                        Transfer::ArduPilot(ap) => ap.clear_all(core, from, m.mission_type),
                        Transfer::Px4(p) => p.clear_all(core, from, m.mission_type, now),
                    }
                }
            }
            MavMessage::MISSION_ACK(m) => {
                // ArduPilot ignores MISSION_ACK (its uploads end with its own ACK).
                if let Transfer::Px4(p) = &mut self.transfer
                    && is_for_me(core, true, m.target_system, m.target_component)
                {
                    p.ack(core, from, m, now);
                }
            }
            MavMessage::MISSION_SET_CURRENT(m) => {
                if self
                    .transfer
                    .is_for_me(core, m.target_system, m.target_component)
                {
                    match &mut self.transfer {
                        Transfer::ArduPilot(_) => ArduPilotState::set_current(core, m.seq),
                        Transfer::Px4(p) => p.set_current(core, m.seq, now),
                    }
                }
            }
            _ => return false,
        }
        true
    }

    fn handle_item(&mut self, from: Endpoint, rx: RxItem, current: u8, now: Time) {
        let core = &mut self.core;
        if !self
            .transfer
            .is_for_me(core, rx.target.sysid, rx.target.compid)
        {
            return;
        }
        match &mut self.transfer {
            Transfer::ArduPilot(ap) => ap.item(core, from, rx, current, now),
            Transfer::Px4(p) => {
                p.int_mode = !rx.float;
                p.item(core, from, rx, now);
            }
        }
    }
}

mod ardupilot;
mod items;
mod messages;
mod px4;
#[cfg(test)]
mod tests;

use messages::{ack_raw, ack_to, count_msg, is_for_me, item_msg, request_msg};

pub use items::{
    ardupilot_store_fence_item, ardupilot_store_mission_item, ardupilot_store_rally_item,
    crc32_item, px4_format_item, px4_parse_item,
};
