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
//!   [`MissionServer::set_loaded`]) the lists are not loaded: every MISSION_COUNT gets
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

use crate::mission::{MissionItem, MissionType};
use crate::sim::flavour::Autopilot;
use crate::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use std::collections::VecDeque;
use std::time::Duration;

/// MAV_COMP_ID_MISSIONPLANNER: PX4 accepts mission messages addressed to it.
const COMP_MISSIONPLANNER: u8 = 190;

/// ArduPilot: re-request an item after this much silence (`wp_recv_timeout_ms`, without the
/// link's stream slowdown).
pub const ARDUPILOT_RESEND: Duration = Duration::from_millis(1000);
/// ArduPilot: cancel an upload after this long without an item (`upload_timeout_ms`).
pub const ARDUPILOT_UPLOAD_TIMEOUT: Duration = Duration::from_millis(8000);
/// PX4: re-request an item after this long (`MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT`).
pub const PX4_RETRY: Duration = Duration::from_millis(250);
/// PX4: abandon a transfer after this long without a message
/// (`MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT`).
pub const PX4_PROTOCOL_TIMEOUT: Duration = Duration::from_millis(5000);

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

#[derive(Clone, Debug)]
struct ApUpload {
    partner: (u8, u8),
    request_i: u16,
    request_last: u16,
    last_receive: Time,
    last_request: Time,
    /// Fence uploads are buffered and replace the fence at the end.
    buffer: Vec<MissionItem>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Px4State {
    Idle,
    GetList,
    SendList,
}

#[derive(Clone, Debug)]
struct Px4 {
    state: Px4State,
    mission_type: MissionType,
    partner: (u8, u8),
    transfer_seq: u16,
    transfer_count: u16,
    transfer_items: Vec<MissionItem>,
    transfer_current_seq: Option<u16>,
    transfer_crc: u32,
    last_sent: Option<Time>,
    last_recv: Option<Time>,
    int_mode: bool,
}

/// The vehicle side of the mission protocol. See the module documentation.
#[derive(Clone, Debug)]
pub struct MissionServer {
    autopilot: Autopilot,
    sysid: u8,
    compid: u8,
    capacity: Capacity,
    lists: [Vec<MissionItem>; 3],
    crc: [u32; 3],
    current: u16,
    home: Option<HomeItem>,
    mission_running: bool,
    /// ArduPilot: the lists are loaded from storage (`AP_Mission::init`, before the vehicle
    /// leaves MAV_STATE_BOOT); until then every list is empty and holds nothing.
    loaded: bool,
    ap_rx: [Option<ApUpload>; 3],
    ap_warned_request: bool,
    ap_warned_item: bool,
    px4: Px4,
    outbox: VecDeque<MavMessage>,
    events: VecDeque<MissionEvent>,
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
    target: (u8, u8),
    mission_type: MissionType,
    item: MissionItem,
    /// Lat/lon were floats (MISSION_ITEM).
    float: bool,
}

impl MissionServer {
    /// A server for the vehicle `sysid`/`compid` with empty lists and the autopilot's default
    /// capacity.
    pub fn new(autopilot: Autopilot, sysid: u8, compid: u8) -> MissionServer {
        let capacity = match autopilot {
            Autopilot::ArduPilot => Capacity::ARDUPILOT,
            Autopilot::Px4 => Capacity::PX4,
        };
        MissionServer {
            autopilot,
            sysid,
            compid,
            capacity,
            lists: [Vec::new(), Vec::new(), Vec::new()],
            crc: [0; 3],
            current: 0,
            home: None,
            mission_running: false,
            loaded: true,
            ap_rx: [None, None, None],
            ap_warned_request: false,
            ap_warned_item: false,
            px4: Px4 {
                state: Px4State::Idle,
                mission_type: MissionType::Mission,
                partner: (0, 0),
                transfer_seq: 0,
                transfer_count: 0,
                transfer_items: Vec::new(),
                transfer_current_seq: None,
                transfer_crc: 0,
                last_sent: None,
                last_recv: None,
                int_mode: false,
            },
            outbox: VecDeque::new(),
            events: VecDeque::new(),
        }
    }

    /// Change the storage limits.
    pub fn set_capacity(&mut self, capacity: Capacity) {
        self.capacity = capacity;
    }

    /// The autopilot this server imitates.
    pub fn autopilot(&self) -> Autopilot {
        self.autopilot
    }

    /// ArduPilot while it boots: the lists are not loaded yet, so an upload is refused
    /// with MAV_MISSION_NO_SPACE and a download finds an empty list (`loaded` false) —
    /// what a real ArduCopter does for about 2 s after power-up. PX4 answers as soon as its
    /// MAVLink instance runs (dataman is up before it), so this applies to ArduPilot only.
    pub fn set_loaded(&mut self, loaded: bool) {
        self.loaded = loaded || self.autopilot == Autopilot::Px4;
    }

    /// A power cycle: the stored lists survive (ArduPilot EEPROM, PX4 dataman), transfers in
    /// progress are lost, the current item goes back to the start (ArduPilot: 1 after home,
    /// PX4: 0 — PX4 does persist `current_seq` in dataman, but the navigator resets it when
    /// the mission is loaded after boot) and PX4 forgets the GCS's int mode.
    pub fn reboot(&mut self) {
        self.loaded = true;
        self.ap_rx = [None, None, None];
        self.ap_warned_request = false;
        self.ap_warned_item = false;
        self.px4.state = Px4State::Idle;
        self.px4.transfer_seq = 0;
        self.px4.transfer_count = 0;
        self.px4.last_sent = None;
        self.px4.last_recv = None;
        self.px4.int_mode = false;
        self.outbox.clear();
        self.events.clear();
        self.current = self.first_item();
        self.mission_running = false;
    }

    fn first_item(&self) -> u16 {
        match self.autopilot {
            Autopilot::ArduPilot => 1,
            Autopilot::Px4 => 0,
        }
    }

    /// Set the home position that ArduPilot reports as mission item 0.
    pub fn set_home(&mut self, home: Option<HomeItem>) {
        self.home = home;
    }

    /// Tell the server whether the mission is being executed (ArduPilot refuses
    /// MISSION_CLEAR_ALL while it runs).
    pub fn set_mission_running(&mut self, running: bool) {
        self.mission_running = running;
    }

    /// Set the current mission item (autopilot numbering), as the vehicle's mission logic
    /// advances; used for the `current` field of downloaded items.
    pub fn set_current(&mut self, seq: u16) {
        self.current = seq;
    }

    /// The current mission item (autopilot numbering).
    pub fn current(&self) -> u16 {
        self.current
    }

    /// The stored items of `t` in the autopilot's numbering (ArduPilot mission: index 0 is
    /// the home slot, as stored).
    pub fn items(&self, t: MissionType) -> &[MissionItem] {
        &self.lists[idx(t)]
    }

    /// The stored mission without ArduPilot's home slot (the user's items).
    pub fn user_items(&self) -> &[MissionItem] {
        let m = &self.lists[0];
        match self.autopilot {
            Autopilot::ArduPilot if !m.is_empty() => &m[1..],
            _ => m,
        }
    }

    /// The PX4 opaque id (CRC-32) of list `t`; 0 for ArduPilot.
    pub fn opaque_id(&self, t: MissionType) -> u32 {
        self.crc[idx(t)]
    }

    /// Whether an upload is in progress for any list.
    pub fn receiving(&self) -> bool {
        match self.autopilot {
            Autopilot::ArduPilot => self.ap_rx.iter().any(|r| r.is_some()),
            Autopilot::Px4 => self.px4.state == Px4State::GetList,
        }
    }

    /// The next message to send, if any (from the autopilot component).
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.outbox.pop_front()
    }

    /// The next event for the vehicle logic, if any.
    pub fn poll_event(&mut self) -> Option<MissionEvent> {
        self.events.pop_front()
    }

    /// When [`MissionServer::handle_timeout`] should be called next.
    pub fn poll_timeout(&self) -> Option<Time> {
        match self.autopilot {
            Autopilot::ArduPilot => self
                .ap_rx
                .iter()
                .flatten()
                .map(|r| {
                    (r.last_request + ARDUPILOT_RESEND + Duration::from_millis(1))
                        .min(r.last_receive + ARDUPILOT_UPLOAD_TIMEOUT + Duration::from_millis(1))
                })
                .min(),
            Autopilot::Px4 => {
                if self.px4.state == Px4State::Idle {
                    return None;
                }
                let mut t = self
                    .px4
                    .last_recv
                    .map(|r| r + PX4_PROTOCOL_TIMEOUT + Duration::from_micros(1));
                if self.px4.state == Px4State::GetList
                    && let Some(s) = self.px4.last_sent
                {
                    let retry = s + PX4_RETRY + Duration::from_micros(1);
                    t = Some(t.map_or(retry, |t| t.min(retry)));
                }
                t
            }
        }
    }

    /// Run the protocol's timers.
    pub fn handle_timeout(&mut self, now: Time) {
        match self.autopilot {
            Autopilot::ArduPilot => {
                for t in [MissionType::Mission, MissionType::Fence, MissionType::Rally] {
                    let Some(rx) = self.ap_rx[idx(t)].as_mut() else {
                        continue;
                    };
                    if now.saturating_since(rx.last_receive) > ARDUPILOT_UPLOAD_TIMEOUT {
                        let partner = rx.partner;
                        self.ap_rx[idx(t)] = None;
                        if t == MissionType::Mission {
                            self.outbox.push_back(text(
                                mav::MavSeverity::MAV_SEVERITY_WARNING,
                                "Mission upload timeout",
                            ));
                        }
                        self.outbox.push_back(self.ack_to(
                            partner,
                            t,
                            mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                            0,
                        ));
                        self.events
                            .push_back(MissionEvent::UploadFailed { mission_type: t });
                    } else if now.saturating_since(rx.last_request) > ARDUPILOT_RESEND {
                        rx.last_request = now;
                        let (partner, seq) = (rx.partner, rx.request_i);
                        self.outbox
                            .push_back(self.request_msg(partner, seq, t, false));
                    }
                }
            }
            Autopilot::Px4 => {
                let p = &self.px4;
                if p.state == Px4State::GetList
                    && p.last_sent
                        .is_some_and(|s| now.saturating_since(s) > PX4_RETRY)
                {
                    let (partner, seq, t, int) =
                        (p.partner, p.transfer_seq, p.mission_type, p.int_mode);
                    self.px4_send_request(partner, seq, t, int, now);
                } else if p.state != Px4State::Idle
                    && p.last_recv
                        .is_some_and(|r| now.saturating_since(r) > PX4_PROTOCOL_TIMEOUT)
                {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "Operation timeout",
                    ));
                    if self.px4.state == Px4State::GetList {
                        self.events.push_back(MissionEvent::UploadFailed {
                            mission_type: self.px4.mission_type,
                        });
                    }
                    self.px4.state = Px4State::Idle;
                    self.px4.last_sent = None;
                    self.px4.last_recv = None;
                }
            }
        }
    }

    /// Handle one received message. Returns `true` when it belonged to the mission protocol
    /// (whether or not it was addressed to this vehicle).
    pub fn handle_message(&mut self, header: &MavHeader, msg: &MavMessage, now: Time) -> bool {
        let from = (
            u8::try_from(header.system_id).unwrap_or(u8::MAX),
            header.component_id,
        );
        match msg {
            MavMessage::MISSION_COUNT(m) => {
                if let Some(t) =
                    self.accept_target(m.target_system, m.target_component, m.mission_type)
                {
                    match self.autopilot {
                        Autopilot::ArduPilot => self.ap_count(from, t, m.count, now),
                        Autopilot::Px4 => self.px4_count(from, t, m.count, now),
                    }
                }
            }
            MavMessage::MISSION_ITEM_INT(m) => {
                let rx = RxItem {
                    seq: m.seq,
                    target: (m.target_system, m.target_component),
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
                } else if self.is_for_me(m.target_system, m.target_component) {
                    self.outbox.push_back(self.ack_raw(
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
                let scaled = self.float_xy_is_degrees(cmd, m.frame as u8);
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
                    target: (m.target_system, m.target_component),
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
                if let Some(t) =
                    self.accept_target(m.target_system, m.target_component, m.mission_type)
                {
                    match self.autopilot {
                        Autopilot::ArduPilot => self.ap_request_list(from, t),
                        Autopilot::Px4 => self.px4_request_list(from, t, now),
                    }
                }
            }
            MavMessage::MISSION_REQUEST_INT(m) => {
                if let Some(t) =
                    self.accept_target(m.target_system, m.target_component, m.mission_type)
                {
                    match self.autopilot {
                        Autopilot::ArduPilot => self.ap_request(from, t, m.seq, true),
                        Autopilot::Px4 => {
                            self.px4.int_mode = true;
                            self.px4_request(from, t, m.seq, now);
                        }
                    }
                }
            }
            MavMessage::MISSION_REQUEST(m) => {
                if let Some(t) =
                    self.accept_target(m.target_system, m.target_component, m.mission_type)
                {
                    match self.autopilot {
                        Autopilot::ArduPilot => self.ap_request(from, t, m.seq, false),
                        Autopilot::Px4 => {
                            self.px4.int_mode = false;
                            self.px4_request(from, t, m.seq, now);
                        }
                    }
                }
            }
            MavMessage::MISSION_CLEAR_ALL(m) => {
                if self.is_for_me(m.target_system, m.target_component) {
                    self.clear_all(from, m.mission_type, now);
                }
            }
            MavMessage::MISSION_ACK(m) => {
                if self.autopilot == Autopilot::Px4
                    && self.is_for_me(m.target_system, m.target_component)
                {
                    self.px4_ack(from, m, now);
                }
            }
            MavMessage::MISSION_SET_CURRENT(m) => {
                if self.is_for_me(m.target_system, m.target_component) {
                    self.set_current_request(m.seq, now);
                }
            }
            _ => return false,
        }
        true
    }

    /// Whether MISSION_ITEM's float x/y are degrees (scaled by 10⁷ into the INT form):
    /// ArduPilot scales all but the DIGICAM, NAV_ATTITUDE_TIME and GIMBAL_MANAGER_PITCHYAW
    /// commands (AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT); PX4 scales items in a
    /// global frame and keeps MISSION-frame parameters as they are.
    fn float_xy_is_degrees(&self, command: u16, frame: u8) -> bool {
        match self.autopilot {
            Autopilot::ArduPilot => !matches!(command, 202 | 203 | 1000 | 42703),
            Autopilot::Px4 => frame != 2,
        }
    }

    fn is_for_me(&self, sys: u8, comp: u8) -> bool {
        sys == self.sysid
            && (comp == self.compid
                || comp == 0
                || (self.autopilot == Autopilot::Px4 && comp == COMP_MISSIONPLANNER))
    }

    fn accept_target(&self, sys: u8, comp: u8, t: mav::MavMissionType) -> Option<MissionType> {
        if self.is_for_me(sys, comp) {
            mtype(t)
        } else {
            None
        }
    }

    fn ack_raw(
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

    fn ack_to(
        &self,
        to: (u8, u8),
        t: MissionType,
        result: mav::MavMissionResult,
        opaque_id: u32,
    ) -> MavMessage {
        self.ack_raw(to, wire_type(t), result, opaque_id)
    }

    fn request_msg(&self, to: (u8, u8), seq: u16, t: MissionType, int: bool) -> MavMessage {
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

    fn count_msg(&self, to: (u8, u8), t: MissionType, count: u16, opaque_id: u32) -> MavMessage {
        MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
            count,
            target_system: to.0,
            target_component: to.1,
            mission_type: wire_type(t),
            opaque_id,
        })
    }

    fn item_msg(
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

    // ------------------------------------------------------------------ ArduPilot

    fn ap_count(&mut self, from: (u8, u8), t: MissionType, count: u16, now: Time) {
        if let Some(rx) = &self.ap_rx[idx(t)]
            && rx.partner != from
        {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        // `MissionItemProtocol::handle_mission_count`: count > max_items(), which is 0 until
        // the mission library is initialised (ArduCopter 4.7 SITL, seen: NO_SPACE and "Only 0
        // items are supported" for every MISSION_COUNT of its first 2 s).
        let max = if self.loaded { self.capacity.of(t) } else { 0 };
        if count > max {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_NO_SPACE,
                0,
            ));
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Only {max} items are supported"),
            ));
            self.ap_rx[idx(t)] = None;
            return;
        }
        // truncate(): mission and rally lists shrink at once; the fence is replaced at the end.
        if t != MissionType::Fence {
            self.lists[idx(t)].truncate(count as usize);
        }
        self.events.push_back(MissionEvent::UploadStarted {
            mission_type: t,
            count,
        });
        if count == 0 {
            self.ap_rx[idx(t)] = None;
            if t == MissionType::Fence {
                self.lists[idx(t)].clear();
            }
            self.ap_complete(from, t);
            return;
        }
        self.ap_rx[idx(t)] = Some(ApUpload {
            partner: from,
            request_i: 0,
            request_last: count - 1,
            last_receive: now,
            last_request: now,
            buffer: Vec::new(),
        });
        self.ap_warned_item = false;
        self.ap_warned_request = false;
        self.outbox.push_back(self.request_msg(from, 0, t, false));
    }

    fn ap_complete(&mut self, to: (u8, u8), t: MissionType) {
        if t == MissionType::Mission {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Flight plan received",
            ));
        }
        self.outbox
            .push_back(self.ack_to(to, t, mav::MavMissionResult::MAV_MISSION_ACCEPTED, 0));
        self.events.push_back(MissionEvent::Uploaded {
            mission_type: t,
            count: self.lists[idx(t)].len() as u16,
        });
    }

    fn ap_item(&mut self, from: (u8, u8), rx: RxItem, now: Time) {
        let t = rx.mission_type;
        let Some(up) = self.ap_rx[idx(t)].as_ref() else {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ERROR,
                0,
            ));
            return;
        };
        if rx.seq != up.request_i {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                0,
            ));
            return;
        }
        if from != up.partner {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        let request_last = up.request_last;
        let stored = match t {
            MissionType::Mission => ardupilot_store_mission_item(&rx.item).and_then(|it| {
                if it.command == crate::mission::item::cmd::DO_JUMP {
                    let target = it.param1 as u16;
                    let count = self.lists[0].len() as u16;
                    if (target >= count && target > request_last) || target == 0 {
                        return Err(mav::MavMissionResult::MAV_MISSION_ERROR);
                    }
                }
                Ok(it)
            }),
            MissionType::Fence => ardupilot_store_fence_item(&rx.item),
            MissionType::Rally => ardupilot_store_rally_item(&rx.item),
        };
        let stored = match stored {
            Ok(s) => s,
            Err(result) => {
                self.outbox.push_back(self.ack_to(from, t, result, 0));
                self.ap_rx[idx(t)] = None;
                self.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        };
        if t == MissionType::Fence {
            if let Some(up) = self.ap_rx[idx(t)].as_mut() {
                up.buffer.push(stored);
            }
        } else {
            let list = &mut self.lists[idx(t)];
            let seq = rx.seq as usize;
            if seq < list.len() {
                list[seq] = stored;
            } else if seq == list.len() {
                list.push(stored);
            } else {
                self.outbox.push_back(self.ack_to(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                    0,
                ));
                self.ap_rx[idx(t)] = None;
                self.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        }
        if rx.float && !self.ap_warned_item {
            self.ap_warned_item = true;
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_ITEM; GCS should send MISSION_ITEM_INT",
            ));
        }
        let done = {
            let Some(up) = self.ap_rx[idx(t)].as_mut() else {
                return;
            };
            up.last_receive = now;
            up.request_i += 1;
            up.request_i > up.request_last
        };
        if done {
            if let Some(up) = self.ap_rx[idx(t)].take()
                && t == MissionType::Fence
            {
                self.lists[idx(t)] = up.buffer;
            }
            self.ap_complete(from, t);
        } else if let Some(up) = self.ap_rx[idx(t)].as_mut() {
            up.last_request = now;
            let (partner, seq) = (up.partner, up.request_i);
            self.outbox
                .push_back(self.request_msg(partner, seq, t, false));
        }
    }

    fn ap_request_list(&mut self, from: (u8, u8), t: MissionType) {
        if self.ap_rx[idx(t)].is_some() {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        // Before the lists are loaded, the count is 0 (`AP_Mission::num_commands`).
        let n = if self.loaded {
            self.lists[idx(t)].len() as u16
        } else {
            0
        };
        self.outbox.push_back(self.count_msg(from, t, n, 0));
    }

    fn ap_request(&mut self, from: (u8, u8), t: MissionType, seq: u16, int: bool) {
        if self.ap_rx[idx(t)].is_some() && int {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        let n = self.lists[idx(t)].len() as u16;
        let item = if t == MissionType::Mission && seq == 0 {
            // AP_Mission::read_cmd_from_storage: slot 0 is always the AHRS home.
            let h = self.home.unwrap_or(HomeItem {
                lat_e7: 0,
                lon_e7: 0,
                alt_amsl_m: 0.0,
            });
            Some(MissionItem {
                frame: 0,
                command: crate::mission::item::cmd::NAV_WAYPOINT,
                current: false,
                autocontinue: true,
                param1: 0.0,
                param2: 0.0,
                param3: 0.0,
                param4: 0.0,
                x: h.lat_e7,
                y: h.lon_e7,
                z: (h.alt_amsl_m * 100.0).trunc() * 0.01,
            })
        } else if seq < n {
            Some(self.lists[idx(t)][seq as usize])
        } else {
            None
        };
        let Some(mut item) = item else {
            if t == MissionType::Mission {
                // "try to educate the GCS on the actual size of the mission"
                self.outbox.push_back(self.count_msg(from, t, n, 0));
            }
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ERROR,
                0,
            ));
            return;
        };
        // MissionItemProtocol_Waypoints::get_item compares the command *id* with the current
        // nav command *index* to set `current` (sic); autocontinue is always 1.
        item.current = t == MissionType::Mission && item.command == self.current;
        item.autocontinue = true;
        if !int && !self.ap_warned_request {
            self.ap_warned_request = true;
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_REQUEST; use MISSION_REQUEST_INT!",
            ));
        }
        self.outbox
            .push_back(self.item_msg(from, t, seq, &item, int));
    }

    // ------------------------------------------------------------------ PX4

    fn px4_send_request(&mut self, to: (u8, u8), seq: u16, t: MissionType, int: bool, now: Time) {
        self.px4.last_sent = Some(now);
        self.outbox.push_back(self.request_msg(to, seq, t, int));
    }

    fn px4_count(&mut self, from: (u8, u8), t: MissionType, count: u16, now: Time) {
        match self.px4.state {
            Px4State::Idle => {
                self.px4.last_recv = Some(now);
                self.px4.partner = from;
                self.px4.mission_type = t;
                if count > self.capacity.of(t) {
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_NO_SPACE,
                        0,
                    ));
                    return;
                }
                if count == 0 {
                    self.lists[idx(t)].clear();
                    self.crc[idx(t)] = 0;
                    if t == MissionType::Mission {
                        self.current = 0;
                    }
                    self.events
                        .push_back(MissionEvent::Cleared { mission_type: t });
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                        0,
                    ));
                    return;
                }
                self.px4.state = Px4State::GetList;
                self.px4.transfer_seq = 0;
                self.px4.transfer_count = count;
                self.px4.transfer_items.clear();
                self.px4.transfer_current_seq = None;
                self.px4.transfer_crc = 0;
                self.events.push_back(MissionEvent::UploadStarted {
                    mission_type: t,
                    count,
                });
            }
            Px4State::GetList => {
                self.px4.last_recv = Some(now);
                if from != self.px4.partner {
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    return;
                }
                if self.px4.transfer_seq != 0 {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: REJ. CMD: Busy",
                    ));
                    let mt = self.px4.mission_type;
                    self.outbox.push_back(self.ack_to(
                        self.px4.partner,
                        mt,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    return;
                }
                // "looks like our MISSION_REQUEST was lost, try again"
            }
            Px4State::SendList => {
                self.outbox.push_back(text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "WPM: IGN MISSION_COUNT: Busy",
                ));
                self.outbox.push_back(self.ack_to(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                    0,
                ));
                return;
            }
        }
        let (partner, seq, mt, int) = (
            self.px4.partner,
            self.px4.transfer_seq,
            self.px4.mission_type,
            self.px4.int_mode,
        );
        self.px4_send_request(partner, seq, mt, int, now);
    }

    fn px4_item(&mut self, from: (u8, u8), rx: RxItem, now: Time) {
        if from != self.px4.partner {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "REJ. MIS ITEM: partner id mismatch",
            ));
            return;
        }
        let t = self.px4.mission_type;
        if rx.mission_type != t {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ERROR,
                0,
            ));
            return;
        }
        match self.px4.state {
            Px4State::GetList => {
                self.px4.last_recv = Some(now);
                if rx.seq != self.px4.transfer_seq {
                    return; // "Item sequence not expected, ignore item"
                }
            }
            Px4State::Idle => {
                if self.px4.transfer_seq == rx.seq.wrapping_add(1) {
                    let crc = self.px4.transfer_crc;
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                        crc,
                    ));
                } else {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "IGN MISSION_ITEM: No transfer",
                    ));
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                }
                return;
            }
            Px4State::SendList => {
                self.outbox.push_back(text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "IGN MISSION_ITEM: Busy",
                ));
                self.outbox.push_back(self.ack_to(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                    0,
                ));
                return;
            }
        }
        let stored = match px4_parse_item(&rx.item, t, self.px4.int_mode) {
            Ok(s) => s,
            Err(result) => {
                self.outbox.push_back(text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "IGN MISSION_ITEM: Invalid item",
                ));
                self.outbox.push_back(self.ack_to(from, t, result, 0));
                self.px4.state = Px4State::Idle;
                self.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        };
        self.px4.transfer_crc = crc32_item(&rx.item, self.px4.transfer_crc);
        if rx.item.current {
            self.px4.transfer_current_seq = Some(rx.seq);
        }
        self.px4.transfer_items.push(stored);
        self.px4.transfer_seq = rx.seq + 1;
        if self.px4.transfer_seq == self.px4.transfer_count {
            let items = std::mem::take(&mut self.px4.transfer_items);
            let n = items.len() as u16;
            self.lists[idx(t)] = items;
            self.crc[idx(t)] = self.px4.transfer_crc;
            if t == MissionType::Mission {
                self.current = self.px4.transfer_current_seq.unwrap_or(0);
            }
            self.px4.state = Px4State::Idle;
            let crc = self.px4.transfer_crc;
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                crc,
            ));
            self.events.push_back(MissionEvent::Uploaded {
                mission_type: t,
                count: n,
            });
        } else {
            let (seq, int) = (self.px4.transfer_seq, self.px4.int_mode);
            self.px4_send_request(from, seq, t, int, now);
        }
    }

    fn px4_request_list(&mut self, from: (u8, u8), t: MissionType, now: Time) {
        let count = self.lists[idx(t)].len() as u16;
        if self.px4.state == Px4State::SendList
            && self.px4.transfer_seq == self.lists[idx(self.px4.mission_type)].len() as u16
        {
            self.px4.state = Px4State::Idle;
        }
        let same = self.px4.state == Px4State::SendList
            && self.px4.mission_type == t
            && self.px4.partner == from;
        if self.px4.state == Px4State::Idle || same {
            self.px4.last_recv = Some(now);
            self.px4.state = Px4State::SendList;
            self.px4.mission_type = t;
            self.px4.transfer_seq = 0;
            self.px4.transfer_count = count;
            self.px4.partner = from;
            self.px4.last_sent = Some(now);
            let crc = self.crc[idx(t)];
            self.outbox.push_back(self.count_msg(from, t, count, crc));
        } else {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Mission download request ignored, already active",
            ));
        }
    }

    fn px4_request(&mut self, from: (u8, u8), t: MissionType, seq: u16, now: Time) {
        if from != self.px4.partner {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: REJ. CMD: partner id mismatch",
            ));
            return;
        }
        match self.px4.state {
            Px4State::Idle => {} // silently ignored
            Px4State::GetList => self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: REJ. CMD: Busy",
            )),
            Px4State::SendList => {
                if t != self.px4.mission_type {
                    return;
                }
                self.px4.last_recv = Some(now);
                let p = &mut self.px4;
                if seq == p.transfer_seq && p.transfer_seq < p.transfer_count {
                    p.transfer_seq += 1;
                } else if seq.wrapping_add(1) == p.transfer_seq {
                    // a repeated request
                } else {
                    p.state = Px4State::Idle;
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: REJ. CMD: Req. WP was unexpected",
                    ));
                    return;
                }
                let list = &self.lists[idx(t)];
                if let Some(stored) = list.get(seq as usize) {
                    let mut item = px4_format_item(stored, t, self.px4.int_mode);
                    item.current = t == MissionType::Mission && self.current == seq;
                    let int = self.px4.int_mode;
                    self.px4.last_sent = Some(now);
                    self.outbox
                        .push_back(self.item_msg(from, t, seq, &item, int));
                } else {
                    self.px4.state = Px4State::Idle;
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: REJ. CMD: Req. WP was unexpected",
                    ));
                }
            }
        }
    }

    fn px4_ack(&mut self, from: (u8, u8), m: &mav::MISSION_ACK_DATA, now: Time) {
        if from != self.px4.partner {
            return;
        }
        match self.px4.state {
            Px4State::SendList if mtype(m.mission_type) == Some(self.px4.mission_type) => {
                self.px4.last_recv = Some(now);
                self.px4.state = Px4State::Idle;
            }
            Px4State::GetList => match m.mavtype {
                mav::MavMissionResult::MAV_MISSION_UNSUPPORTED => {
                    self.px4.int_mode = !self.px4.int_mode;
                    let (seq, t, int) = (
                        self.px4.transfer_seq,
                        self.px4.mission_type,
                        self.px4.int_mode,
                    );
                    self.px4_send_request(from, seq, t, int, now);
                }
                mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED => {
                    self.px4.state = Px4State::Idle;
                    self.events.push_back(MissionEvent::UploadFailed {
                        mission_type: self.px4.mission_type,
                    });
                }
                _ => {}
            },
            _ => {}
        }
    }

    // ------------------------------------------------------------------ shared

    fn handle_item(&mut self, from: (u8, u8), rx: RxItem, current: u8, now: Time) {
        if !self.is_for_me(rx.target.0, rx.target.1) {
            return;
        }
        if self.autopilot == Autopilot::ArduPilot
            && rx.mission_type == MissionType::Mission
            && (current == 2 || current == 3)
        {
            // Guided-mode waypoint requests through MISSION_ITEM (GCS_Common.cpp
            // handle_mission_item) are not supported by the simulator: DO_REPOSITION and
            // SET_POSITION_TARGET_GLOBAL_INT are.
            self.outbox.push_back(self.ack_to(
                from,
                MissionType::Mission,
                mav::MavMissionResult::MAV_MISSION_UNSUPPORTED,
                0,
            ));
            return;
        }
        if rx.float && self.autopilot == Autopilot::Px4 {
            self.px4.int_mode = false;
        } else if self.autopilot == Autopilot::Px4 {
            self.px4.int_mode = true;
        }
        match self.autopilot {
            Autopilot::ArduPilot => self.ap_item(from, rx, now),
            Autopilot::Px4 => self.px4_item(from, rx, now),
        }
    }

    fn clear_all(&mut self, from: (u8, u8), t: mav::MavMissionType, now: Time) {
        let types: Vec<MissionType> = match mtype(t) {
            Some(x) => vec![x],
            None if t == mav::MavMissionType::MAV_MISSION_TYPE_ALL
                && self.autopilot == Autopilot::Px4 =>
            {
                vec![MissionType::Mission, MissionType::Fence, MissionType::Rally]
            }
            None => {
                self.outbox.push_back(self.ack_raw(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_UNSUPPORTED,
                    0,
                ));
                return;
            }
        };
        match self.autopilot {
            Autopilot::ArduPilot => {
                let mt = types[0];
                let ok = self.ap_rx[idx(mt)].is_none()
                    && !(mt == MissionType::Mission && self.mission_running);
                if ok {
                    self.lists[idx(mt)].clear();
                    if mt == MissionType::Mission {
                        self.current = 1;
                    }
                    self.events
                        .push_back(MissionEvent::Cleared { mission_type: mt });
                }
                let r = if ok {
                    mav::MavMissionResult::MAV_MISSION_ACCEPTED
                } else {
                    mav::MavMissionResult::MAV_MISSION_ERROR
                };
                self.outbox.push_back(self.ack_to(from, mt, r, 0));
            }
            Autopilot::Px4 => {
                if self.px4.state != Px4State::Idle {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: IGN CLEAR CMD: Busy",
                    ));
                    return;
                }
                self.px4.last_recv = Some(now);
                for mt in &types {
                    self.lists[idx(*mt)].clear();
                    self.crc[idx(*mt)] = 0;
                    if *mt == MissionType::Mission {
                        self.current = 0;
                    }
                    self.events
                        .push_back(MissionEvent::Cleared { mission_type: *mt });
                }
                self.outbox.push_back(self.ack_raw(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                    0,
                ));
            }
        }
    }

    fn set_current_request(&mut self, seq: u16, now: Time) {
        let n = self.lists[0].len() as u16;
        match self.autopilot {
            Autopilot::ArduPilot => {
                // AP_Mission::set_current_cmd: index 0 restarts at 1; needs a mission.
                if seq < n && n > 1 {
                    self.events
                        .push_back(MissionEvent::SetCurrent { seq: seq.max(1) });
                }
            }
            Autopilot::Px4 => {
                if self.px4.state != Px4State::Idle {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: IGN WP CURR CMD: Busy",
                    ));
                    return;
                }
                self.px4.last_recv = Some(now);
                if seq < n {
                    self.current = seq;
                    self.events.push_back(MissionEvent::SetCurrent { seq });
                } else {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: WP CURR CMD: Not in list",
                    ));
                }
            }
        }
    }
}

/// Commands whose position AP_Mission stores in a `Location` (AP_Mission::stored_in_location).
fn ardupilot_stored_in_location(cmd: u16) -> bool {
    matches!(
        cmd,
        16 | 17 | 18 | 19 | 21 | 22 | 30 | 31 | 82 | 92 | 179 | 189 | 191 | 201 | 84 | 85 | 94
    )
}

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
    if ardupilot_stored_in_location(item.command) {
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
    if item.command != crate::mission::item::cmd::NAV_RALLY_POINT {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::item::{cmd, frame};

    const GCS: MavHeader = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };

    fn drain(s: &mut MissionServer) -> Vec<MavMessage> {
        std::iter::from_fn(|| s.poll_transmit()).collect()
    }

    fn count(n: u16, t: mav::MavMissionType) -> MavMessage {
        MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
            count: n,
            target_system: 1,
            target_component: 1,
            mission_type: t,
            opaque_id: 0,
        })
    }

    fn item_int(seq: u16, it: &MissionItem, t: mav::MavMissionType) -> MavMessage {
        MavMessage::MISSION_ITEM_INT(mav::MISSION_ITEM_INT_DATA {
            param1: it.param1,
            param2: it.param2,
            param3: it.param3,
            param4: it.param4,
            x: it.x,
            y: it.y,
            z: it.z,
            seq,
            command: mav::MavCmd::from_u16(it.command).unwrap(),
            target_system: 1,
            target_component: 1,
            frame: mav::MavFrame::from_u8(it.frame).unwrap(),
            current: 0,
            autocontinue: 1,
            mission_type: t,
        })
    }

    fn upload(s: &mut MissionServer, items: &[MissionItem], now: Time) -> Vec<MavMessage> {
        let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        let mut out = Vec::new();
        s.handle_message(&GCS, &count(items.len() as u16, mt), now);
        out.extend(drain(s));
        for (i, it) in items.iter().enumerate() {
            s.handle_message(&GCS, &item_int(i as u16, it, mt), now);
            out.extend(drain(s));
        }
        out
    }

    fn sample() -> Vec<MissionItem> {
        let mut wp = MissionItem::waypoint(37.1968, -80.5781, 12.345);
        wp.param2 = 2.0; // acceptance radius: not kept by ArduCopter
        wp.param1 = 3.7;
        vec![
            MissionItem::waypoint(37.19, -80.57, 0.0), // home slot (ArduPilot)
            MissionItem::takeoff(12.0),
            wp,
            MissionItem::image_start_capture(1.0, 5),
            MissionItem::jump(2, 1),
            MissionItem::return_to_launch(),
        ]
    }

    #[test]
    fn ardupilot_upload_uses_mission_request_and_is_lossy() {
        let mut s = MissionServer::new(Autopilot::ArduPilot, 1, 1);
        s.set_home(Some(HomeItem {
            lat_e7: 371_960_000,
            lon_e7: -805_800_000,
            alt_amsl_m: 610.5,
        }));
        let out = upload(&mut s, &sample(), Time::ZERO);
        let requests = out
            .iter()
            .filter(|m| matches!(m, MavMessage::MISSION_REQUEST(_)))
            .count();
        assert_eq!(requests, 6);
        assert!(
            !out.iter()
                .any(|m| matches!(m, MavMessage::MISSION_REQUEST_INT(_)))
        );
        assert!(
            matches!(out.last(), Some(MavMessage::MISSION_ACK(a)) if a.mavtype == mav::MavMissionResult::MAV_MISSION_ACCEPTED)
        );
        let stored = s.items(MissionType::Mission);
        assert_eq!(stored.len(), 6);
        // the waypoint kept its delay (whole seconds) and position only
        assert_eq!(stored[2].param1, 3.0);
        assert_eq!(stored[2].param2, 0.0);
        assert!((stored[2].z - 12.34).abs() < 1e-4);
        assert_eq!(stored[2].frame, frame::GLOBAL_RELATIVE_ALT);
        // download of seq 0 returns the live home, frame GLOBAL
        s.handle_message(
            &GCS,
            &MavMessage::MISSION_REQUEST_INT(mav::MISSION_REQUEST_INT_DATA {
                seq: 0,
                target_system: 1,
                target_component: 1,
                mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
            }),
            Time::ZERO,
        );
        match drain(&mut s).as_slice() {
            [MavMessage::MISSION_ITEM_INT(h)] => {
                assert_eq!((h.x, h.y), (371_960_000, -805_800_000));
                assert_eq!(h.frame, mav::MavFrame::MAV_FRAME_GLOBAL);
                assert!((h.z - 610.5).abs() < 1e-3);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn ardupilot_count_truncates_at_once_and_times_out() {
        let mut s = MissionServer::new(Autopilot::ArduPilot, 1, 1);
        upload(&mut s, &sample(), Time::ZERO);
        let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        s.handle_message(&GCS, &count(3, mt), Time::from_secs(1));
        assert_eq!(s.items(MissionType::Mission).len(), 3);
        drain(&mut s);
        // another GCS is denied
        let other = MavHeader {
            system_id: 254,
            ..GCS
        };
        s.handle_message(&other, &count(2, mt), Time::from_secs(1));
        assert!(
            matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_DENIED)
        );
        // resend after 1 s, cancel after 8 s
        let t = s.poll_timeout().unwrap();
        assert!(t > Time::from_secs(2) && t <= Time::from_millis(2002));
        s.handle_timeout(t);
        assert!(matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_REQUEST(r)] if r.seq == 0));
        s.handle_timeout(Time::from_millis(9002));
        let out = drain(&mut s);
        assert!(out.iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED)));
        assert!(!s.receiving());
        // the old items past 3 are gone even though the upload failed
        assert_eq!(s.items(MissionType::Mission).len(), 3);
    }

    #[test]
    fn ardupilot_wrong_seq_and_item_without_transfer() {
        let mut s = MissionServer::new(Autopilot::ArduPilot, 1, 1);
        let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        let it = MissionItem::waypoint(1.0, 2.0, 3.0);
        s.handle_message(&GCS, &item_int(0, &it, mt), Time::ZERO);
        assert!(
            matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_ERROR)
        );
        s.handle_message(&GCS, &count(2, mt), Time::ZERO);
        drain(&mut s);
        s.handle_message(&GCS, &item_int(1, &it, mt), Time::ZERO);
        assert!(
            matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)
        );
        assert!(s.receiving());
        // an unsupported command aborts
        let mut bad = it;
        bad.command = 31000; // MAV_CMD_USER_1
        s.handle_message(&GCS, &item_int(0, &bad, mt), Time::ZERO);
        assert!(
            matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_UNSUPPORTED)
        );
        assert!(!s.receiving());
    }

    #[test]
    fn px4_upload_switches_to_int_mode_and_reacks_duplicates() {
        let mut s = MissionServer::new(Autopilot::Px4, 1, 1);
        let items = &sample()[1..];
        let out = upload(&mut s, items, Time::ZERO);
        // first request is the float variant, then INT once the GCS sent MISSION_ITEM_INT
        assert!(matches!(out[0], MavMessage::MISSION_REQUEST(_)));
        assert!(matches!(out[1], MavMessage::MISSION_REQUEST_INT(_)));
        let ack = match out.last() {
            Some(MavMessage::MISSION_ACK(a)) => a.clone(),
            other => panic!("{other:?}"),
        };
        assert_eq!(ack.mavtype, mav::MavMissionResult::MAV_MISSION_ACCEPTED);
        assert_ne!(ack.opaque_id, 0);
        let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        let last = items.len() as u16 - 1;
        s.handle_message(&GCS, &item_int(last, &items[last as usize], mt), Time::ZERO);
        assert!(
            matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_ACCEPTED)
        );
        assert_eq!(s.items(MissionType::Mission).len(), items.len());
        // download: INT frames
        s.handle_message(
            &GCS,
            &MavMessage::MISSION_REQUEST_LIST(mav::MISSION_REQUEST_LIST_DATA {
                target_system: 1,
                target_component: 1,
                mission_type: mt,
            }),
            Time::ZERO,
        );
        assert!(matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_COUNT(c)] if c.count == 5));
        s.handle_message(
            &GCS,
            &MavMessage::MISSION_REQUEST_INT(mav::MISSION_REQUEST_INT_DATA {
                seq: 1,
                target_system: 1,
                target_component: 1,
                mission_type: mt,
            }),
            Time::ZERO,
        );
        // seq 1 while 0 is expected: PX4 aborts the transfer
        assert!(drain(&mut s).iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == mav::MavMissionResult::MAV_MISSION_ERROR)));
    }

    #[test]
    fn px4_rejects_rtl_in_a_global_frame_and_retries() {
        let mut s = MissionServer::new(Autopilot::Px4, 1, 1);
        let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        s.handle_message(&GCS, &count(1, mt), Time::ZERO);
        drain(&mut s);
        assert_eq!(s.poll_timeout(), Some(Time::from_micros(250_001)));
        s.handle_timeout(Time::from_micros(250_001));
        assert!(matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_REQUEST(r)] if r.seq == 0));
        let mut rtl = MissionItem::return_to_launch();
        rtl.frame = frame::GLOBAL_RELATIVE_ALT;
        s.handle_message(&GCS, &item_int(0, &rtl, mt), Time::from_millis(300));
        assert!(drain(&mut s).iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == mav::MavMissionResult::MAV_MISSION_UNSUPPORTED)));
        assert!(!s.receiving());
        let _ = cmd::NAV_RETURN_TO_LAUNCH;
    }

    #[test]
    fn reboot_keeps_lists() {
        for ap in [Autopilot::ArduPilot, Autopilot::Px4] {
            let mut s = MissionServer::new(ap, 1, 1);
            upload(&mut s, &sample(), Time::ZERO);
            s.set_current(3);
            s.reboot();
            assert_eq!(s.items(MissionType::Mission).len(), 6);
            assert_eq!(s.current(), if ap == Autopilot::ArduPilot { 1 } else { 0 });
        }
    }

    /// ArduCopter 4.7 SITL in its first 2 s (seen with pymavlink): MISSION_COUNT gets
    /// MAV_MISSION_NO_SPACE and "Only 0 items are supported", MISSION_REQUEST_LIST a count
    /// of 0 whatever is stored; once loaded, both work. PX4 is never "not loaded".
    #[test]
    fn ardupilot_refuses_uploads_and_reads_empty_while_booting() {
        let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        let mut s = MissionServer::new(Autopilot::ArduPilot, 1, 1);
        upload(&mut s, &sample(), Time::ZERO);
        s.reboot();
        s.set_loaded(false);
        let out = upload(&mut s, &sample(), Time::from_secs(1));
        assert!(out.iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a)
            if a.mavtype == mav::MavMissionResult::MAV_MISSION_NO_SPACE)));
        assert!(out.iter().any(|m| matches!(m, MavMessage::STATUSTEXT(t)
            if t.text.to_str().is_ok_and(|x| x.starts_with("Only 0 items")))));
        let list = MavMessage::MISSION_REQUEST_LIST(mav::MISSION_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: 1,
            mission_type: mt,
        });
        s.handle_message(&GCS, &list, Time::from_secs(1));
        assert!(
            drain(&mut s)
                .iter()
                .any(|m| matches!(m, MavMessage::MISSION_COUNT(c) if c.count == 0))
        );
        assert_eq!(
            s.items(MissionType::Mission).len(),
            6,
            "nothing lost meanwhile"
        );
        s.set_loaded(true);
        s.handle_message(&GCS, &list, Time::from_secs(3));
        assert!(
            drain(&mut s)
                .iter()
                .any(|m| matches!(m, MavMessage::MISSION_COUNT(c) if c.count == 6))
        );
        let mut p = MissionServer::new(Autopilot::Px4, 1, 1);
        p.set_loaded(false);
        let out = upload(&mut p, &sample()[1..], Time::ZERO);
        assert!(out.iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a)
            if a.mavtype == mav::MavMissionResult::MAV_MISSION_ACCEPTED)));
    }
}
