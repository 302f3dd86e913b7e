//! The mission protocol, GCS side: upload, download, clear and set-current for the mission,
//! fence and rally lists (<https://mavlink.io/en/services/mission.html>).
//!
//! What this follows, and where it deliberately differs:
//!
//! * The step structure and the resend timeouts are the specification's (MISSION_COUNT /
//!   MISSION_REQUEST_LIST / MISSION_CLEAR_ALL answered within [`MissionConfig::timeout`],
//!   1500 ms; each item requested during a download within
//!   [`MissionConfig::item_timeout`], 250 ms), as in MAVSDK (`mavlink/MAVSDK`,
//!   `src/mavsdk/core/mavlink_mission_transfer_client.cpp`) and QGroundControl
//!   (`mavlink/qgroundcontrol`, `src/MissionManager/PlanManager.cc`:
//!   `_retryTimeoutMilliseconds` for items, `_ackTimeoutMilliseconds` otherwise).
//! * Transfers that do not give up while the vehicle is alive. Both references count
//!   retries: QGroundControl fails a step after `_maxRetryCount` resends, an upload at once
//!   when the vehicle stops requesting items ("Vehicle did not request all items") or the
//!   final ACK is lost ("vehicle failed to send final ack"), and MAVSDK's
//!   `UploadWorkItem::process_timeout` gives up after `retries` timeouts and takes a
//!   MAV_MISSION_OPERATION_CANCELLED as the end. Against a real ArduCopter through a relay
//!   losing 30 % of the frames each way, 100-item round trips with such rules succeeded 3
//!   times in 5 (1 in 5 with SITL at 5× speed): a download needs about 200 exchanges, each
//!   lost with probability 0.51, so six losses in a row happen somewhere in most transfers.
//!   Here a step is resent on its timeout for as long as the vehicle answers at all: the
//!   operation fails only after [`MissionConfig::silence`] (30 s) without any mission
//!   message from the vehicle, or at its overall deadline, which grows with the number of
//!   items ([`MissionClient::budget`]). When the vehicle ends its side — ArduPilot cancels
//!   an upload after 8 s without an item (`MissionItemProtocol::update`,
//!   `upload_timeout_ms`) and answers later items with MAV_MISSION_ERROR; PX4 drops a
//!   transfer after 5 s without a message (`MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT`) and
//!   then ignores requests (`handle_mission_request_both`, "no transfer") — or after
//!   [`MissionConfig::stall`] without an answer in the middle of a list, the transfer starts
//!   over from scratch, at most [`MissionConfig::restarts`] times ([`MissionEvent::Restarted`]
//!   says why). The vehicle being reported lost (no heartbeat) does not end a transfer.
//! * Both MISSION_REQUEST and MISSION_REQUEST_INT are accepted and always answered with
//!   MISSION_ITEM_INT (ArduPilot ≤ 3.6 requests with MISSION_REQUEST but accepts the INT
//!   answer — MAVSDK's `process_mission_request` does the same).
//! * Duplicated and out-of-order requests are answered (the vehicle drives the upload;
//!   answering an old request again is harmless). ArduPilot answers a duplicated item with
//!   MAV_MISSION_INVALID_SEQUENCE (`ArduPilot/ardupilot`,
//!   `libraries/GCS_MAVLink/MissionItemProtocol.cpp` `handle_mission_item`) and keeps going,
//!   so that NACK is not fatal during an upload.
//! * A lost final MISSION_ACK: MAVSDK and QGroundControl give up ("vehicle failed to send
//!   final ack") although the vehicle may well have the mission. We resend the last item:
//!   PX4 then repeats its ACK (`PX4/PX4-Autopilot`, `src/modules/mavlink/mavlink_mission.cpp`
//!   `handle_mission_item_both`, "the GCS did not receive the last ack"), while ArduPilot,
//!   no longer receiving, answers MAV_MISSION_ERROR (`GCS_Common.cpp`
//!   `GCS_MAVLINK::handle_mission_item`). When the answer is ambiguous (no ACK, or a NACK
//!   after every item was sent) we read the list back and compare it with what we sent:
//!   success only if it matches exactly, otherwise a precise error. Never success with
//!   wrong items. An ACCEPTED after a restart, before this attempt has sent every item,
//!   is ambiguous too (the vehicle may have completed an earlier attempt's transfer) and is
//!   read back when every item went out in some attempt; one that cannot be ours is
//!   ignored a bounded number of times, then the upload starts over.
//! * A lost request: when no request or ACK follows an item within the timeout, the
//!   highest item requested so far is sent again *and the next one is offered unrequested*.
//!   The first covers a lost item, the second a lost request. Both autopilots store an
//!   item whose seq is the one they expect whether or not they asked for it, and answer a
//!   wrong one harmlessly (ArduPilot MAV_MISSION_INVALID_SEQUENCE, PX4 silence). Without
//!   this, a lost request is only recovered by the vehicle's own re-request, and ArduPilot
//!   re-requests once a second but cancels the upload after 8 s without an item
//!   (`MissionItemProtocol::update`: `wp_recv_timeout_ms` 1000, `upload_timeout_ms`
//!   8000): on a link that loses 30 % each way that leaves 8 tries at 49 % success, so a
//!   200-item upload would be cancelled more often than not. QGroundControl and MAVSDK
//!   only wait (they do not resend items on their own at all). When the offered item was
//!   taken and the vehicle's request for the one after it is lost too, offering the same
//!   item again does not help (the vehicle now waits for the next one): each further
//!   timeout without progress therefore offers one more item ahead (h + 1 …, up to
//!   [`MAX_OFFERED`] items), and items arriving in order are all stored. Otherwise only
//!   the vehicle's own re-request (ArduPilot: after 1 s) would end such a stall, which on
//!   loopback with 40 ms timeouts and 30 % loss happened about ten times per 200-item
//!   upload and sometimes outlasted every retry.
//! * ArduPilot keeps the home position as item 0 of the *mission* list (not of fence or
//!   rally). On upload we send a home placeholder at seq 0 (QGroundControl sends its planned
//!   home there, `PlanManager::writeMissionItems`, `sendHomePositionToVehicle()` is true for
//!   ArduPilot), on download we strip it and return it separately, and DO_JUMP targets are
//!   shifted by one both ways (`PlanManager::writeMissionItems` adjusts `param1`). PX4 has
//!   no home item.
//! * One operation at a time per vehicle (ArduPilot and PX4 handle one transfer at a time);
//!   later ones queue. Between two operations the machine waits [`MissionConfig::settle`]
//!   and drops mission messages meanwhile, so that a late duplicate ACK or item of the
//!   previous operation cannot be mistaken for an answer to the next one.
//! * Every operation also has an overall deadline ([`MissionClient::budget`]), so nothing
//!   can wait forever whatever a vehicle does.

// Deliberately handles deprecated messages and frames (MISSION_REQUEST, MISSION_ITEM,
// MISSION_SET_CURRENT, *_INT frames) because deployed autopilots still send or need them.
#![allow(deprecated)]

use super::Endpoint;
use crate::mission::{MissionItem, MissionType, item::cmd, item::frame};
use crate::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_CLEAR_ALL_DATA, MISSION_COUNT_DATA, MISSION_ITEM_DATA,
    MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA, MISSION_REQUEST_LIST_DATA,
    MISSION_SET_CURRENT_DATA, MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType,
};
use num_traits::FromPrimitive;
use std::collections::VecDeque;
use std::time::Duration;

/// Timeouts of the mission protocol (see "Transfers that do not give up" in the module
/// docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MissionConfig {
    /// Resend MISSION_COUNT, MISSION_REQUEST_LIST, MISSION_CLEAR_ALL or MISSION_SET_CURRENT,
    /// or the last item of an upload, after this long without an answer (spec: 1500 ms).
    pub timeout: Duration,
    /// Request an item of a download again after this long (spec: 250 ms).
    pub item_timeout: Duration,
    /// No answer for this long in the middle of a transfer: the vehicle has given up its
    /// side (PX4 after 5 s, `MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT`; ArduPilot cancels an
    /// upload after 8 s without an item), so the transfer starts over from scratch, or an
    /// upload whose items were all sent is read back.
    pub stall: Duration,
    /// No answer at all for this long: the operation fails. As long as the vehicle answers
    /// within it, a transfer goes on, however lossy the link.
    pub silence: Duration,
    /// Quiet time between two operations (late messages of the previous one are dropped).
    pub settle: Duration,
    /// How many times a transfer starts over from scratch after the vehicle cancelled it
    /// (ArduPilot's MAV_MISSION_OPERATION_CANCELLED, MAV_MISSION_ERROR from a vehicle that
    /// is no longer in the transfer; PX4 aborts a download when a duplicated request arrives
    /// late, `handle_mission_request_both`: "Unexpected waypoint index, aborting transfer")
    /// or after a stall.
    pub restarts: u32,
    /// PX4 only: the pause before requesting the next item of a download. PX4 aborts a
    /// download when a request older than the one before last arrives
    /// (`handle_mission_request_both`, "Req. WP was unexpected"); a duplicate of request k
    /// that trails its original (what a radio's link-layer retransmission or a duplicating
    /// relay produces, about a millisecond later) then arrives after request k + 1 whenever
    /// the round trip is shorter than that — on a fast link, nearly always. Seen against PX4
    /// 1.16 SITL through a relay duplicating 5 % of the frames: 3 of 3 100-item downloads
    /// aborted until the restarts ran out. A few milliseconds per item let the duplicate
    /// arrive first, where PX4 takes it as a repeat.
    pub px4_request_gap: Duration,
}

impl Default for MissionConfig {
    fn default() -> Self {
        MissionConfig {
            timeout: Duration::from_millis(1500),
            item_timeout: Duration::from_millis(250),
            stall: Duration::from_secs(6),
            silence: Duration::from_secs(30),
            settle: Duration::from_millis(250),
            restarts: 3,
            px4_request_gap: Duration::from_millis(10),
        }
    }
}

/// The most items offered unrequested after one upload timeout (see "A lost request" in
/// the module docs): the n-th consecutive timeout without progress offers n items after
/// the highest one requested, up to this many.
pub const MAX_OFFERED: usize = 8;

/// Identifies an operation started with [`MissionClient::start`].
pub type OpId = u64;

/// A mission-protocol operation.
#[derive(Clone, Debug, PartialEq)]
pub enum MissionOp {
    /// Replace the vehicle's list of `kind` with `items` (user numbering, no home item).
    /// `home` is what to send at seq 0 when the autopilot keeps home there (ArduPilot
    /// missions); `None` sends an all-zero placeholder.
    Upload {
        /// Which list.
        kind: MissionType,
        /// The items.
        items: Vec<MissionItem>,
        /// Home placeholder for ArduPilot missions.
        home: Option<MissionItem>,
    },
    /// Read the vehicle's list of `kind`.
    Download {
        /// Which list.
        kind: MissionType,
    },
    /// Clear the vehicle's list of `kind`.
    Clear {
        /// Which list.
        kind: MissionType,
    },
    /// Make user item `seq` (0-based, no home item) the current mission item with
    /// MISSION_SET_CURRENT, confirmed by MISSION_CURRENT.
    SetCurrent {
        /// User item index.
        seq: u16,
    },
}

impl MissionOp {
    fn name(&self) -> &'static str {
        match self {
            MissionOp::Upload { .. } => "upload",
            MissionOp::Download { .. } => "download",
            MissionOp::Clear { .. } => "clear",
            MissionOp::SetCurrent { .. } => "set current",
        }
    }
}

/// What a successful operation produced.
#[derive(Clone, Debug, PartialEq)]
pub enum MissionOutcome {
    /// Uploaded `count` user items. `verified_by_download` is set when the final ACK was
    /// lost or ambiguous and success was established by reading the list back.
    Uploaded {
        /// Number of user items.
        count: usize,
        /// Success established by reading the list back.
        verified_by_download: bool,
    },
    /// The downloaded list (user numbering) and, for ArduPilot missions, its home item.
    Downloaded {
        /// The items.
        items: Vec<MissionItem>,
        /// ArduPilot's item 0 (home), if the list had one.
        home: Option<MissionItem>,
    },
    /// The list was cleared.
    Cleared,
    /// The current item is now `seq` (user numbering).
    CurrentSet {
        /// User item index.
        seq: u16,
    },
}

/// A MAV_MISSION_RESULT, with the meaning the specification gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MissionResultCode(pub MavMissionResult);

impl std::fmt::Display for MissionResultCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use MavMissionResult::*;
        let text = match self.0 {
            MAV_MISSION_ACCEPTED => "accepted",
            MAV_MISSION_ERROR => "generic error / not accepting mission commands right now",
            MAV_MISSION_UNSUPPORTED_FRAME => "coordinate frame not supported",
            MAV_MISSION_UNSUPPORTED => "command not supported",
            MAV_MISSION_NO_SPACE => "mission items exceed storage space",
            MAV_MISSION_INVALID => "one of the parameters has an invalid value",
            MAV_MISSION_INVALID_PARAM1 => "param1 has an invalid value",
            MAV_MISSION_INVALID_PARAM2 => "param2 has an invalid value",
            MAV_MISSION_INVALID_PARAM3 => "param3 has an invalid value",
            MAV_MISSION_INVALID_PARAM4 => "param4 has an invalid value",
            MAV_MISSION_INVALID_PARAM5_X => "x / param5 has an invalid value",
            MAV_MISSION_INVALID_PARAM6_Y => "y / param6 has an invalid value",
            MAV_MISSION_INVALID_PARAM7 => "z / param7 has an invalid value",
            MAV_MISSION_INVALID_SEQUENCE => "item received out of sequence",
            MAV_MISSION_DENIED => "not accepting any mission commands from this system",
            MAV_MISSION_OPERATION_CANCELLED => "the vehicle cancelled the operation",
        };
        write!(f, "{:?} ({text})", self.0)
    }
}

/// Why an operation failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MissionError {
    /// The vehicle answered with a MISSION_ACK error.
    #[error("mission {op}: the vehicle refused{}: {result}", seq.map(|s| format!(" at wire item {s}")).unwrap_or_default())]
    Rejected {
        /// Operation name.
        op: &'static str,
        /// The result code.
        result: MissionResultCode,
        /// The wire seq of the last item sent, when relevant.
        seq: Option<u16>,
    },
    /// The vehicle stopped answering for [`MissionConfig::silence`].
    #[error(
        "mission {op}: no answer from the vehicle for {:.1} s while waiting for {waiting_for}", *silent_ms as f64 / 1000.0
    )]
    Timeout {
        /// Operation name.
        op: &'static str,
        /// What was awaited.
        waiting_for: String,
        /// How long the vehicle was silent, ms.
        silent_ms: u64,
    },
    /// The operation exceeded its overall time budget.
    #[error("mission {op}: not finished within its time budget of {budget_ms} ms")]
    OverBudget {
        /// Operation name.
        op: &'static str,
        /// The budget, ms.
        budget_ms: u64,
    },
    /// The final ACK was lost or ambiguous and the list read back differs.
    #[error("mission upload: the vehicle did not confirm and the list read back differs: {detail}")]
    Unconfirmed {
        /// What differs, or why it could not be read.
        detail: String,
    },
    /// An item's command is not a MAV_CMD of the dialect (cannot be encoded).
    #[error(
        "mission item {index}: command {command} is not a MAV_CMD known to the MAVLink dialect"
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
    /// A downloaded item could not be decoded (e.g. a command unknown to our dialect).
    #[error("mission download: item {seq} could not be decoded: {detail}")]
    Undecodable {
        /// Wire seq.
        seq: u16,
        /// Why.
        detail: String,
    },
    /// Cancelled by the caller.
    #[error("mission {op}: cancelled")]
    Cancelled {
        /// Operation name.
        op: &'static str,
    },
}

/// What the machine reports.
#[derive(Clone, Debug, PartialEq)]
pub enum MissionEvent {
    /// Progress of a transfer: `done` of `total` wire items.
    Progress {
        /// The operation.
        id: OpId,
        /// Items transferred.
        done: usize,
        /// Items in the transfer.
        total: usize,
    },
    /// A transfer starts over from scratch (the vehicle cancelled it, or stalled).
    Restarted {
        /// The operation.
        id: OpId,
        /// Why.
        reason: String,
        /// Restarts still allowed.
        left: u32,
    },
    /// The operation finished.
    Done {
        /// The operation.
        id: OpId,
        /// Its result.
        result: Result<MissionOutcome, MissionError>,
    },
}

fn mav_type(kind: MissionType) -> MavMissionType {
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
pub fn item_to_wire(
    item: &MissionItem,
    index: usize,
) -> Result<MISSION_ITEM_INT_DATA, MissionError> {
    let command = MavCmd::from_u16(item.command).ok_or(MissionError::UnknownCommand {
        index,
        command: item.command,
    })?;
    let frame = MavFrame::from_u8(item.frame).ok_or(MissionError::UnknownFrame {
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

/// Compare what was sent with what was read back, as far as autopilots store items:
///
/// * the command must be the same;
/// * a position item (sent in a global frame) must come back in the same kind of frame
///   (absolute / relative to home / terrain, the `_INT` synonyms folded: PX4 answers in the
///   `_INT` frames, ArduPilot in the plain ones) with x and y exactly and z within 1 cm
///   (ArduPilot stores centimetres); for other commands the frame is not compared
///   (ArduPilot returns 0 for them, `AP_Mission::mission_cmd_to_mavlink_int`);
/// * parameters must match within 1e-4 (relative), except that a NaN sent may come back
///   as 0 (neither autopilot stores NaN "unchanged" markers) and, when `drops_params`
///   (ArduPilot: `AP_Mission` keeps only the parameters its packed 15-byte command has,
///   e.g. a waypoint keeps its delay but not its acceptance radius or yaw), a parameter
///   may come back as 0;
/// * `current` and `autocontinue` are not compared (the vehicle sets them).
///
/// Returns a description of the first difference.
pub fn compare_items(
    sent: &[MissionItem],
    got: &[MissionItem],
    drops_params: bool,
) -> Result<(), String> {
    if sent.len() != got.len() {
        return Err(format!(
            "{} items sent, {} read back",
            sent.len(),
            got.len()
        ));
    }
    for (i, (a, b)) in sent.iter().zip(got).enumerate() {
        let diff = |what: &str, x: String, y: String| {
            Err(format!("item {i}: {what} sent {x}, read back {y}"))
        };
        if a.command != b.command {
            return diff("command", a.command.to_string(), b.command.to_string());
        }
        if is_global_frame(a.frame) && normalize_frame(a.frame) != normalize_frame(b.frame) {
            return diff("frame", a.frame.to_string(), b.frame.to_string());
        }
        if a.x != b.x || a.y != b.y {
            return diff(
                "x/y",
                format!("{}/{}", a.x, a.y),
                format!("{}/{}", b.x, b.y),
            );
        }
        if !(same_f32(a.z, b.z, 0.0) || (a.z - b.z).abs() <= 0.01) {
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
            let dropped = q == 0.0 && (p.is_nan() || drops_params);
            if !same_f32(p, q, 1e-4) && !dropped {
                return diff(&format!("param{}", k + 1), p.to_string(), q.to_string());
            }
        }
    }
    Ok(())
}

/// The all-zero home placeholder sent at ArduPilot's seq 0 when no home is known.
pub fn home_placeholder() -> MissionItem {
    MissionItem {
        frame: frame::GLOBAL,
        ..MissionItem::command(cmd::NAV_WAYPOINT)
    }
}

/// User items → wire items for a list of `kind` (home prepended and DO_JUMP shifted when
/// `home_item`; seq, current, addressing and mission type set).
fn build_wire(
    kind: MissionType,
    items: &[MissionItem],
    home: Option<&MissionItem>,
    home_item: bool,
    target: Endpoint,
) -> Result<Vec<MISSION_ITEM_INT_DATA>, MissionError> {
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
        return Err(MissionError::TooMany { count: items.len() });
    }
    let mut wire = Vec::with_capacity(user.len());
    for (i, it) in user.iter().enumerate() {
        let index = if offset { i.saturating_sub(1) } else { i };
        let mut w = item_to_wire(it, index)?;
        w.seq = i as u16;
        w.current = u8::from(i == 0);
        w.target_system = target.sysid;
        w.target_component = target.compid;
        w.mission_type = mav_type(kind);
        wire.push(w);
    }
    Ok(wire)
}

/// Wire items → (user items, home) for a list of `kind` (inverse of `build_wire`).
fn from_wire_list(
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

/// The download sub-machine (also used to verify an upload).
#[derive(Debug)]
struct Download {
    kind: MissionType,
    count: Option<u16>,
    items: Vec<MISSION_ITEM_INT_DATA>,
    /// When the current request is sent again.
    deadline: Time,
    /// In verification mode, stale upload NACKs (ERROR / INVALID_SEQUENCE) are ignored.
    verify: bool,
    /// Restarts left after the vehicle aborted or stalled.
    restarts_left: u32,
    /// The next request waits for the end of [`MissionConfig::px4_request_gap`] (the
    /// deadline), not for a timeout.
    gap: bool,
}

enum DlStep {
    Continue,
    /// Started over with MISSION_REQUEST_LIST (why).
    Restarted(String),
    Done(Vec<MISSION_ITEM_INT_DATA>),
    Failed(MissionError),
}

/// What a step of an upload led to.
enum UpStep {
    Continue,
    /// Started over with MISSION_COUNT, or the read-back started over (why).
    Restarted(String),
    Finish(Result<MissionOutcome, MissionError>),
}

#[derive(Debug)]
enum UpPhase {
    /// MISSION_COUNT sent, waiting for the first request.
    Count,
    /// Items being requested.
    Items,
    /// Final ACK lost or ambiguous: reading the list back.
    Verify(Box<Download>),
}

#[derive(Debug)]
struct Upload {
    kind: MissionType,
    user: Vec<MissionItem>,
    wire: Vec<MISSION_ITEM_INT_DATA>,
    requested: Vec<bool>,
    n_requested: usize,
    /// Items sent at least once (requested or offered) in this attempt.
    sent: Vec<bool>,
    n_sent: usize,
    /// Items sent at least once in any attempt of this operation. After a restart the
    /// vehicle may still be in (and complete) the transfer of an earlier attempt, whose
    /// items are the same wire list.
    ever_sent: Vec<bool>,
    n_ever_sent: usize,
    /// MAV_MISSION_ACCEPTED answers that could not be for this operation (not every item
    /// was ever sent): stale ACKs of an earlier operation, or a vehicle whose transfer
    /// state is not ours.
    stale_accepts: u32,
    last_sent: Option<u16>,
    phase: UpPhase,
    /// When the last item (or MISSION_COUNT) is sent again.
    deadline: Time,
    /// Timeouts since the last new request (how many items to offer ahead).
    idle_timeouts: u32,
    nack: Option<MavMissionResult>,
    verify_returns: u32,
    /// MAV_MISSION_ERROR answers to MISSION_COUNT in a row (PX4: busy with a transfer).
    busy_answers: u32,
    /// Restarts from scratch left.
    restarts_left: u32,
}

#[derive(Debug)]
enum ActiveKind {
    Upload(Upload),
    Download(Download),
    Clear {
        kind: MissionType,
        deadline: Time,
    },
    SetCurrent {
        user_seq: u16,
        wire_seq: u16,
        deadline: Time,
    },
}

#[derive(Debug)]
struct Active {
    id: OpId,
    name: &'static str,
    /// The overall deadline (a download's grows when the vehicle tells its count).
    overall: Time,
    budget: Duration,
    /// The last mission-protocol message from the vehicle for this operation.
    last_answer: Time,
    /// The last answer or restart: a stall is measured from here.
    quiet_since: Time,
    kind: ActiveKind,
}

impl Active {
    /// What the operation is waiting for, for a timeout's message.
    fn waiting_for(&self) -> String {
        let dl = |d: &Download| match d.count {
            None => "MISSION_COUNT after MISSION_REQUEST_LIST".to_string(),
            Some(_) => format!("MISSION_ITEM_INT {}", d.items.len()),
        };
        match &self.kind {
            ActiveKind::Upload(u) => match &u.phase {
                UpPhase::Count => "MISSION_REQUEST for item 0 after MISSION_COUNT".to_string(),
                UpPhase::Items if u.n_sent == u.wire.len() => "the final MISSION_ACK".to_string(),
                UpPhase::Items => format!(
                    "MISSION_REQUEST for item {} (after item {})",
                    u.requested.iter().position(|r| !r).unwrap_or(0),
                    u.last_sent.map(|s| s.to_string()).unwrap_or_default()
                ),
                UpPhase::Verify(d) => format!("{} (reading the list back)", dl(d)),
            },
            ActiveKind::Download(d) => dl(d),
            ActiveKind::Clear { .. } => "MISSION_ACK after MISSION_CLEAR_ALL".to_string(),
            ActiveKind::SetCurrent { .. } => {
                "MISSION_CURRENT after MISSION_SET_CURRENT".to_string()
            }
        }
    }
}

/// The GCS side of the mission protocol for one vehicle.
#[derive(Debug)]
pub struct MissionClient {
    gcs: Endpoint,
    target: Endpoint,
    home_item: bool,
    cfg: MissionConfig,
    queue: VecDeque<(OpId, MissionOp)>,
    active: Option<Active>,
    settle_until: Time,
    next_id: OpId,
    out: VecDeque<MavMessage>,
    events: VecDeque<MissionEvent>,
    /// Mission messages dropped because they matched no operation (late duplicates).
    pub ignored: u64,
}

/// The longest a download of `count` items may take, all restarts included: each attempt
/// may wait [`MissionConfig::silence`] and four item timeouts per item.
fn download_budget(cfg: &MissionConfig, count: usize) -> Duration {
    let per_attempt = cfg.silence + cfg.item_timeout * 4 * count as u32;
    per_attempt * (cfg.restarts + 1)
}

impl MissionClient {
    /// A client speaking as `gcs` to the autopilot `target`. `home_item`: the autopilot
    /// keeps home as mission item 0 (ArduPilot; see [`super::flavour::Flavour`]).
    pub fn new(gcs: Endpoint, target: Endpoint, home_item: bool, cfg: MissionConfig) -> Self {
        MissionClient {
            gcs,
            target,
            home_item,
            cfg,
            queue: VecDeque::new(),
            active: None,
            settle_until: Time::ZERO,
            next_id: 1,
            out: VecDeque::new(),
            events: VecDeque::new(),
            ignored: 0,
        }
    }

    /// Change whether home is item 0 (when the flavour becomes known).
    pub fn set_home_item(&mut self, home_item: bool) {
        self.home_item = home_item;
    }

    /// Whether home is mission item 0 for this vehicle.
    pub fn home_item(&self) -> bool {
        self.home_item
    }

    /// The configuration.
    pub fn config(&self) -> &MissionConfig {
        &self.cfg
    }

    /// No operation active or queued.
    pub fn is_idle(&self) -> bool {
        self.active.is_none() && self.queue.is_empty()
    }

    /// The longest an operation may take before it fails with
    /// [`MissionError::OverBudget`]; it grows with the number of items. Each attempt of a
    /// transfer may wait [`MissionConfig::silence`], plus two answer timeouts per item of an
    /// upload (and a read-back), four item timeouts per item of a download; a download's
    /// deadline is set from the count the vehicle gives (this bound assumes the most a list
    /// can hold).
    pub fn budget(cfg: &MissionConfig, op: &MissionOp) -> Duration {
        match op {
            MissionOp::Upload { items, .. } => {
                let n = items.len() + 1;
                let per_attempt = cfg.silence + cfg.timeout * 2 * n as u32;
                per_attempt * (cfg.restarts + 1) + download_budget(cfg, n)
            }
            MissionOp::Download { .. } => download_budget(cfg, usize::from(u16::MAX)),
            MissionOp::Clear { .. } | MissionOp::SetCurrent { .. } => cfg.silence + cfg.timeout,
        }
    }

    /// Queue an operation; returns its id. It starts when the previous one has finished
    /// and the settle time has passed.
    pub fn start(&mut self, op: MissionOp, now: Time) -> OpId {
        let id = self.next_id;
        self.next_id += 1;
        self.queue.push_back((id, op));
        self.maybe_begin(now);
        id
    }

    /// Cancel an operation (queued or active). An active upload or download is ended
    /// with MAV_MISSION_OPERATION_CANCELLED sent to the vehicle, as MAVSDK does.
    pub fn cancel(&mut self, id: OpId, now: Time) {
        if let Some(pos) = self.queue.iter().position(|(i, _)| *i == id) {
            if let Some((_, op)) = self.queue.remove(pos) {
                self.events.push_back(MissionEvent::Done {
                    id,
                    result: Err(MissionError::Cancelled { op: op.name() }),
                });
            }
            return;
        }
        if self.active.as_ref().is_some_and(|a| a.id == id) {
            let kind = match &self.active.as_ref().map(|a| &a.kind) {
                Some(ActiveKind::Upload(u)) => Some(u.kind),
                Some(ActiveKind::Download(d)) => Some(d.kind),
                _ => None,
            };
            if let Some(kind) = kind {
                self.send_ack(kind, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED);
            }
            let name = self.active.as_ref().map(|a| a.name).unwrap_or("operation");
            self.finish(Err(MissionError::Cancelled { op: name }), now);
        }
    }

    /// The next message to send.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.out.pop_front()
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<MissionEvent> {
        self.events.pop_front()
    }

    /// When [`MissionClient::handle_timeout`] must be called next.
    pub fn poll_timeout(&self) -> Option<Time> {
        match &self.active {
            Some(a) => {
                let step = match &a.kind {
                    ActiveKind::Upload(u) => match &u.phase {
                        UpPhase::Verify(d) => d.deadline,
                        _ => u.deadline,
                    },
                    ActiveKind::Download(d) => d.deadline,
                    ActiveKind::Clear { deadline, .. } => *deadline,
                    ActiveKind::SetCurrent { deadline, .. } => *deadline,
                };
                Some(step.min(a.overall).min(a.last_answer + self.cfg.silence))
            }
            None if !self.queue.is_empty() => Some(self.settle_until),
            None => None,
        }
    }

    fn maybe_begin(&mut self, now: Time) {
        if self.active.is_some() || now < self.settle_until {
            return;
        }
        let Some((id, op)) = self.queue.pop_front() else {
            return;
        };
        let budget = match op {
            // Set from the count (see `download_item`'s caller); until then the silence
            // budget ends a download that never gets one.
            MissionOp::Download { .. } => self.cfg.silence + self.cfg.timeout,
            _ => MissionClient::budget(&self.cfg, &op),
        };
        let name = op.name();
        let kind = match op {
            MissionOp::Upload { kind, items, home } => {
                match build_wire(kind, &items, home.as_ref(), self.home_item, self.target) {
                    Ok(wire) => {
                        let n = wire.len();
                        ActiveKind::Upload(Upload {
                            kind,
                            user: items,
                            requested: vec![false; n],
                            wire,
                            n_requested: 0,
                            sent: vec![false; n],
                            n_sent: 0,
                            ever_sent: vec![false; n],
                            n_ever_sent: 0,
                            stale_accepts: 0,
                            last_sent: None,
                            phase: UpPhase::Count,
                            deadline: now + self.cfg.timeout,
                            idle_timeouts: 0,
                            nack: None,
                            verify_returns: 0,
                            busy_answers: 0,
                            restarts_left: self.cfg.restarts,
                        })
                    }
                    Err(e) => {
                        self.events
                            .push_back(MissionEvent::Done { id, result: Err(e) });
                        return self.maybe_begin(now);
                    }
                }
            }
            MissionOp::Download { kind } => ActiveKind::Download(Download::new(
                kind,
                now + self.cfg.timeout,
                false,
                self.cfg.restarts,
            )),
            MissionOp::Clear { kind } => ActiveKind::Clear {
                kind,
                deadline: now + self.cfg.timeout,
            },
            MissionOp::SetCurrent { seq } => {
                let wire_seq = if self.home_item {
                    seq.saturating_add(1)
                } else {
                    seq
                };
                ActiveKind::SetCurrent {
                    user_seq: seq,
                    wire_seq,
                    deadline: now + self.cfg.timeout,
                }
            }
        };
        self.active = Some(Active {
            id,
            name,
            overall: now + budget,
            budget,
            last_answer: now,
            quiet_since: now,
            kind,
        });
        self.send_initial();
    }

    /// Send the first message of the active operation (also used for resends).
    fn send_initial(&mut self) {
        let Some(a) = &self.active else { return };
        let msg = match &a.kind {
            ActiveKind::Upload(u) => self.count_msg(u.kind, u.wire.len() as u16),
            ActiveKind::Download(d) => self.request_list_msg(d.kind),
            ActiveKind::Clear { kind, .. } => {
                MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
                    target_system: self.target.sysid,
                    target_component: self.target.compid,
                    mission_type: mav_type(*kind),
                })
            }
            ActiveKind::SetCurrent { wire_seq, .. } => {
                MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
                    seq: *wire_seq,
                    target_system: self.target.sysid,
                    target_component: self.target.compid,
                })
            }
        };
        self.out.push_back(msg);
    }

    fn count_msg(&self, kind: MissionType, count: u16) -> MavMessage {
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count,
            target_system: self.target.sysid,
            target_component: self.target.compid,
            mission_type: mav_type(kind),
            opaque_id: 0,
        })
    }

    fn request_list_msg(&self, kind: MissionType) -> MavMessage {
        MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
            target_system: self.target.sysid,
            target_component: self.target.compid,
            mission_type: mav_type(kind),
        })
    }

    fn request_item_msg(&self, kind: MissionType, seq: u16) -> MavMessage {
        MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq,
            target_system: self.target.sysid,
            target_component: self.target.compid,
            mission_type: mav_type(kind),
        })
    }

    fn send_ack(&mut self, kind: MissionType, result: MavMissionResult) {
        self.out
            .push_back(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: self.target.sysid,
                target_component: self.target.compid,
                mavtype: result,
                mission_type: mav_type(kind),
                opaque_id: 0,
            }));
    }

    fn finish(&mut self, result: Result<MissionOutcome, MissionError>, now: Time) {
        if let Some(a) = self.active.take() {
            self.events
                .push_back(MissionEvent::Done { id: a.id, result });
            self.settle_until = now + self.cfg.settle;
        }
        self.maybe_begin(now);
    }

    /// A received message. Messages not from the target autopilot, not addressed to us,
    /// or not part of the mission protocol are ignored.
    pub fn handle_message(&mut self, header: &MavHeader, msg: &MavMessage, now: Time) {
        if Endpoint::of(header) != self.target {
            return;
        }
        let for_us = |ts: u8, tc: u8| self.gcs.is_addressed_by(ts, tc);
        let relevant = match msg {
            MavMessage::MISSION_REQUEST(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_REQUEST_INT(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_ACK(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_COUNT(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_ITEM_INT(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_ITEM(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_CURRENT(_) => true,
            _ => false,
        };
        if !relevant {
            return;
        }
        if self.active.is_none() {
            if !matches!(msg, MavMessage::MISSION_CURRENT(_)) {
                self.ignored += 1;
            }
            return;
        }
        let Some(mut active) = self.active.take() else {
            return;
        };
        // MISSION_CURRENT is telemetry, streamed whatever we do: not an answer.
        if !matches!(msg, MavMessage::MISSION_CURRENT(_)) {
            active.last_answer = now;
            active.quiet_since = now;
        }
        let id = active.id;
        let outcome = match &mut active.kind {
            ActiveKind::Upload(u) => self.upload_message(id, u, msg, now),
            ActiveKind::Download(d) => {
                let had_count = d.count.is_some();
                let step = self.download_message(id, d, msg, now);
                if !had_count && let Some(c) = d.count {
                    // The vehicle told its count: the deadline now follows the list's size.
                    let budget = download_budget(&self.cfg, usize::from(c));
                    active.budget = active.budget.max(budget);
                    active.overall = active.overall.max(now + budget);
                }
                match step {
                    DlStep::Continue => UpStep::Continue,
                    DlStep::Restarted(why) => UpStep::Restarted(why),
                    DlStep::Done(wire) => {
                        let (items, home) = from_wire_list(d.kind, &wire, self.home_item);
                        UpStep::Finish(Ok(MissionOutcome::Downloaded { items, home }))
                    }
                    DlStep::Failed(e) => UpStep::Finish(Err(e)),
                }
            }
            ActiveKind::Clear { kind, .. } => match msg {
                MavMessage::MISSION_ACK(a) if a.mission_type == mav_type(*kind) => {
                    match a.mavtype {
                        MavMissionResult::MAV_MISSION_ACCEPTED => {
                            UpStep::Finish(Ok(MissionOutcome::Cleared))
                        }
                        MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => UpStep::Continue,
                        r => UpStep::Finish(Err(MissionError::Rejected {
                            op: "clear",
                            result: MissionResultCode(r),
                            seq: None,
                        })),
                    }
                }
                _ => UpStep::Continue,
            },
            ActiveKind::SetCurrent {
                user_seq, wire_seq, ..
            } => match msg {
                MavMessage::MISSION_CURRENT(c) if c.seq == *wire_seq => {
                    UpStep::Finish(Ok(MissionOutcome::CurrentSet { seq: *user_seq }))
                }
                _ => UpStep::Continue,
            },
        };
        self.active = Some(active);
        self.after_step(outcome, now);
    }

    /// Report a restart or finish the operation, as a step decided.
    fn after_step(&mut self, step: UpStep, now: Time) {
        match step {
            UpStep::Continue => {}
            UpStep::Restarted(reason) => {
                if let Some(a) = self.active.as_mut() {
                    a.quiet_since = now;
                    let left = match &a.kind {
                        ActiveKind::Upload(u) => match &u.phase {
                            UpPhase::Verify(d) => d.restarts_left,
                            _ => u.restarts_left,
                        },
                        ActiveKind::Download(d) => d.restarts_left,
                        _ => 0,
                    };
                    self.events.push_back(MissionEvent::Restarted {
                        id: a.id,
                        reason,
                        left,
                    });
                }
            }
            UpStep::Finish(result) => self.finish(result, now),
        }
    }

    /// A MISSION_ITEM(_INT) from the target that did not decode (e.g. a command number our
    /// dialect lacks): fails a download waiting for that item with a precise error instead
    /// of timing out.
    pub fn handle_unparsed_item(&mut self, from: Endpoint, seq: u16, detail: &str, now: Time) {
        if from != self.target {
            return;
        }
        let waiting = match self.active.as_ref().map(|a| &a.kind) {
            Some(ActiveKind::Download(d)) => d.count.is_some() && d.items.len() == usize::from(seq),
            Some(ActiveKind::Upload(Upload {
                phase: UpPhase::Verify(d),
                ..
            })) => d.count.is_some() && d.items.len() == usize::from(seq),
            _ => false,
        };
        if waiting {
            self.finish(
                Err(MissionError::Undecodable {
                    seq,
                    detail: detail.to_string(),
                }),
                now,
            );
        }
    }

    fn upload_message(&mut self, id: OpId, u: &mut Upload, msg: &MavMessage, now: Time) -> UpStep {
        let kind = mav_type(u.kind);
        let request = match msg {
            MavMessage::MISSION_REQUEST(r) if r.mission_type == kind => Some(r.seq),
            MavMessage::MISSION_REQUEST_INT(r) if r.mission_type == kind => Some(r.seq),
            _ => None,
        };
        if let Some(seq) = request {
            if usize::from(seq) >= u.wire.len() {
                self.ignored += 1;
                return UpStep::Continue;
            }
            if matches!(u.phase, UpPhase::Verify(_)) {
                // The vehicle is still receiving: back to answering requests.
                if u.verify_returns >= 2 {
                    return UpStep::Finish(Err(MissionError::Unconfirmed {
                        detail:
                            "the vehicle keeps requesting items after the transfer looked complete"
                                .into(),
                    }));
                }
                u.verify_returns += 1;
                u.nack = None;
            }
            u.phase = UpPhase::Items;
            u.busy_answers = 0;
            let i = usize::from(seq);
            if !u.requested[i] {
                u.requested[i] = true;
                u.n_requested += 1;
                u.idle_timeouts = 0;
                u.deadline = now + self.cfg.timeout;
                self.events.push_back(MissionEvent::Progress {
                    id,
                    done: u.n_requested,
                    total: u.wire.len(),
                });
            }
            u.last_sent = Some(seq);
            u.mark_sent(i);
            self.out
                .push_back(MavMessage::MISSION_ITEM_INT(u.wire[i].clone()));
            return UpStep::Continue;
        }
        if let UpPhase::Verify(d) = &mut u.phase {
            return match self.download_message(id, d, msg, now) {
                DlStep::Continue => UpStep::Continue,
                DlStep::Restarted(why) => UpStep::Restarted(why),
                DlStep::Done(wire) => UpStep::Finish(self.verify_result(u, &wire)),
                DlStep::Failed(e) => UpStep::Finish(self.verify_failed(u, e)),
            };
        }
        let MavMessage::MISSION_ACK(ack) = msg else {
            return UpStep::Continue;
        };
        if ack.mission_type != kind {
            return UpStep::Continue;
        }
        // Every item reached the vehicle at least once as far as we know: requested ones
        // were answered, offered ones may have been taken.
        let all_sent = u.n_sent == u.wire.len();
        let rejected = |r| {
            UpStep::Finish(Err(MissionError::Rejected {
                op: "upload",
                result: MissionResultCode(r),
                seq: u.last_sent,
            }))
        };
        match ack.mavtype {
            MavMissionResult::MAV_MISSION_ACCEPTED if all_sent => {
                UpStep::Finish(Ok(MissionOutcome::Uploaded {
                    count: u.user.len(),
                    verified_by_download: false,
                }))
            }
            MavMissionResult::MAV_MISSION_ACCEPTED if u.n_ever_sent == u.wire.len() => {
                // Every item went out in some attempt, but not in this one: after a restart
                // the vehicle may have gone on with an earlier attempt's transfer (PX4 keeps
                // requesting the next item of the transfer it is in) and accepted the list.
                // Ambiguous: read the list back (seen in the property test: a restart on a
                // PX4 "busy" ERROR, then ACCEPTED for the earlier transfer, ignored, and the
                // last item resent and ACCEPTED again until the overall deadline).
                self.begin_verify(u, now);
                UpStep::Continue
            }
            MavMissionResult::MAV_MISSION_ACCEPTED => {
                // Premature or stale: keep waiting for requests, a bounded number of times.
                self.ignored += 1;
                u.stale_accepts += 1;
                if u.stale_accepts <= self.cfg.restarts + 1 {
                    return UpStep::Continue;
                }
                u.stale_accepts = 0;
                if u.restarts_left == 0 {
                    return UpStep::Finish(Err(MissionError::Unconfirmed {
                        detail: "the vehicle keeps accepting a transfer that did not carry all \
                                 our items"
                            .into(),
                    }));
                }
                self.restart_upload(u, now);
                UpStep::Restarted("the vehicle accepted a transfer we did not complete".into())
            }
            MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => {
                // ArduPilot's answer to a duplicated item; the transfer goes on.
                UpStep::Continue
            }
            MavMissionResult::MAV_MISSION_ERROR if matches!(u.phase, UpPhase::Count) => {
                // PX4 answers a MISSION_COUNT with ERROR while it is still in a transfer
                // (`handle_mission_count`: "busy, already receiving"); it ends that one
                // after 5 s of silence. Resent at the next timeout, a bounded number of times.
                u.busy_answers += 1;
                if u.busy_answers > self.cfg.restarts + 1 {
                    return rejected(ack.mavtype);
                }
                UpStep::Continue
            }
            r @ (MavMissionResult::MAV_MISSION_OPERATION_CANCELLED
            | MavMissionResult::MAV_MISSION_ERROR)
                if !all_sent =>
            {
                // The vehicle ended its side: ArduPilot cancels after 8 s without an item
                // and answers items after that with ERROR. Start over.
                if u.restarts_left == 0 {
                    return rejected(r);
                }
                self.restart_upload(u, now);
                UpStep::Restarted(format!("the vehicle answered {r:?}"))
            }
            MavMissionResult::MAV_MISSION_OPERATION_CANCELLED => rejected(ack.mavtype),
            r if all_sent => {
                // Could be a real refusal of the last item, or ArduPilot's "not receiving"
                // answer to a repeated last item after its ACK was lost: read back.
                u.nack = Some(r);
                self.begin_verify(u, now);
                UpStep::Continue
            }
            r => rejected(r),
        }
    }

    /// Start an upload over from MISSION_COUNT (the vehicle cancelled or stalled).
    fn restart_upload(&mut self, u: &mut Upload, now: Time) {
        u.restarts_left = u.restarts_left.saturating_sub(1);
        u.requested.fill(false);
        u.sent.fill(false);
        u.n_requested = 0;
        u.n_sent = 0;
        u.last_sent = None;
        u.phase = UpPhase::Count;
        u.idle_timeouts = 0;
        u.nack = None;
        u.busy_answers = 0;
        u.deadline = now + self.cfg.timeout;
        self.out
            .push_back(self.count_msg(u.kind, u.wire.len() as u16));
    }

    fn begin_verify(&mut self, u: &mut Upload, now: Time) {
        let d = Download::new(u.kind, now + self.cfg.timeout, true, self.cfg.restarts);
        self.out.push_back(self.request_list_msg(u.kind));
        u.phase = UpPhase::Verify(Box::new(d));
    }

    fn verify_result(
        &mut self,
        u: &Upload,
        wire: &[MISSION_ITEM_INT_DATA],
    ) -> Result<MissionOutcome, MissionError> {
        let (items, _home) = from_wire_list(u.kind, wire, self.home_item);
        match compare_items(&u.user, &items, self.home_item) {
            Ok(()) => Ok(MissionOutcome::Uploaded {
                count: u.user.len(),
                verified_by_download: true,
            }),
            Err(detail) => match u.nack {
                Some(r) => Err(MissionError::Rejected {
                    op: "upload",
                    result: MissionResultCode(r),
                    seq: u.last_sent,
                }),
                None => Err(MissionError::Unconfirmed { detail }),
            },
        }
    }

    fn verify_failed(
        &mut self,
        u: &Upload,
        e: MissionError,
    ) -> Result<MissionOutcome, MissionError> {
        match u.nack {
            Some(r) => Err(MissionError::Rejected {
                op: "upload",
                result: MissionResultCode(r),
                seq: u.last_sent,
            }),
            None => Err(MissionError::Unconfirmed {
                detail: format!("could not read the list back: {e}"),
            }),
        }
    }

    fn download_message(
        &mut self,
        id: OpId,
        d: &mut Download,
        msg: &MavMessage,
        now: Time,
    ) -> DlStep {
        let kind = mav_type(d.kind);
        match msg {
            MavMessage::MISSION_COUNT(c) if c.mission_type == kind => {
                if d.count.is_some() {
                    return DlStep::Continue; // duplicate
                }
                d.count = Some(c.count);
                if c.count == 0 {
                    self.send_ack(d.kind, MavMissionResult::MAV_MISSION_ACCEPTED);
                    return DlStep::Done(Vec::new());
                }
                d.deadline = now + self.cfg.item_timeout;
                self.out.push_back(self.request_item_msg(d.kind, 0));
                DlStep::Continue
            }
            MavMessage::MISSION_ITEM_INT(it) if it.mission_type == kind => {
                self.download_item(id, d, it.clone(), now)
            }
            MavMessage::MISSION_ITEM(it) if it.mission_type == kind => {
                self.download_item(id, d, item_int_from_float(it), now)
            }
            MavMessage::MISSION_ACK(a) if a.mission_type == kind => match a.mavtype {
                MavMissionResult::MAV_MISSION_ACCEPTED
                | MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => DlStep::Continue,
                MavMissionResult::MAV_MISSION_ERROR if d.verify && d.count.is_none() => {
                    // A stale NACK of the upload being verified.
                    DlStep::Continue
                }
                MavMissionResult::MAV_MISSION_ERROR if d.restarts_left > 0 => {
                    self.restart_download(d, now);
                    DlStep::Restarted("the vehicle aborted the download (MAV_MISSION_ERROR)".into())
                }
                r => DlStep::Failed(MissionError::Rejected {
                    op: "download",
                    result: MissionResultCode(r),
                    seq: Some(d.items.len() as u16),
                }),
            },
            _ => DlStep::Continue,
        }
    }

    fn download_item(
        &mut self,
        id: OpId,
        d: &mut Download,
        it: MISSION_ITEM_INT_DATA,
        now: Time,
    ) -> DlStep {
        let Some(count) = d.count else {
            return DlStep::Continue;
        };
        if usize::from(it.seq) != d.items.len() {
            return DlStep::Continue; // duplicate or stale
        }
        d.items.push(it);
        if d.items.len() == usize::from(count) {
            self.send_ack(d.kind, MavMissionResult::MAV_MISSION_ACCEPTED);
            return DlStep::Done(std::mem::take(&mut d.items));
        }
        if !d.verify {
            self.events.push_back(MissionEvent::Progress {
                id,
                done: d.items.len(),
                total: usize::from(count),
            });
        }
        if !self.home_item && !self.cfg.px4_request_gap.is_zero() {
            // PX4: the next request goes out after the gap (see `px4_request_gap`).
            d.gap = true;
            d.deadline = now + self.cfg.px4_request_gap;
            return DlStep::Continue;
        }
        d.deadline = now + self.cfg.item_timeout;
        self.out
            .push_back(self.request_item_msg(d.kind, d.items.len() as u16));
        DlStep::Continue
    }

    /// Start a download over (the vehicle aborted it, or stalled).
    fn restart_download(&mut self, d: &mut Download, now: Time) {
        d.restarts_left = d.restarts_left.saturating_sub(1);
        d.gap = false;
        d.count = None;
        d.items.clear();
        d.deadline = now + self.cfg.timeout;
        self.out.push_back(self.request_list_msg(d.kind));
    }

    /// A download's timer: request again, or start over after a stall in the middle of
    /// the list (PX4 has then left its side of the transfer and ignores requests).
    fn download_timeout(&mut self, d: &mut Download, stalled: bool, now: Time) -> DlStep {
        if now < d.deadline {
            return DlStep::Continue;
        }
        if d.gap {
            d.gap = false;
            d.deadline = now + self.cfg.item_timeout;
            self.out
                .push_back(self.request_item_msg(d.kind, d.items.len() as u16));
            return DlStep::Continue;
        }
        if stalled && d.count.is_some() && d.restarts_left > 0 {
            self.restart_download(d, now);
            return DlStep::Restarted(format!("no item for {:.0} s", self.cfg.stall.as_secs_f64()));
        }
        match d.count {
            None => {
                d.deadline = now + self.cfg.timeout;
                self.out.push_back(self.request_list_msg(d.kind));
            }
            Some(_) => {
                d.deadline = now + self.cfg.item_timeout;
                self.out
                    .push_back(self.request_item_msg(d.kind, d.items.len() as u16));
            }
        }
        DlStep::Continue
    }

    /// Advance timers: resend, start over, give up, or start the next queued operation.
    pub fn handle_timeout(&mut self, now: Time) {
        let Some(mut active) = self.active.take() else {
            self.maybe_begin(now);
            return;
        };
        if now >= active.overall {
            let (name, budget) = (active.name, active.budget);
            self.active = Some(active);
            self.finish(
                Err(MissionError::OverBudget {
                    op: name,
                    budget_ms: budget.as_millis() as u64,
                }),
                now,
            );
            return;
        }
        let silent = now.saturating_since(active.last_answer);
        if silent >= self.cfg.silence {
            let err = MissionError::Timeout {
                op: active.name,
                waiting_for: active.waiting_for(),
                silent_ms: silent.as_millis() as u64,
            };
            self.active = Some(active);
            self.finish(Err(err), now);
            return;
        }
        let stalled = now.saturating_since(active.quiet_since) >= self.cfg.stall;
        let timeout = self.cfg.timeout;
        let step = match &mut active.kind {
            ActiveKind::Upload(u) => self.upload_timeout(u, stalled, now),
            ActiveKind::Download(d) => match self.download_timeout(d, stalled, now) {
                DlStep::Continue | DlStep::Done(_) => UpStep::Continue,
                DlStep::Restarted(why) => UpStep::Restarted(why),
                DlStep::Failed(e) => UpStep::Finish(Err(e)),
            },
            ActiveKind::Clear { deadline, .. } | ActiveKind::SetCurrent { deadline, .. } => {
                if now >= *deadline {
                    *deadline = now + timeout;
                    self.active = Some(active);
                    self.send_initial();
                    return;
                }
                UpStep::Continue
            }
        };
        self.active = Some(active);
        self.after_step(step, now);
    }

    fn upload_timeout(&mut self, u: &mut Upload, stalled: bool, now: Time) -> UpStep {
        if let UpPhase::Verify(d) = &mut u.phase {
            return match self.download_timeout(d, stalled, now) {
                DlStep::Continue | DlStep::Done(_) => UpStep::Continue,
                DlStep::Restarted(why) => UpStep::Restarted(format!("read-back: {why}")),
                DlStep::Failed(e) => UpStep::Finish(self.verify_failed(u, e)),
            };
        }
        if now < u.deadline {
            return UpStep::Continue;
        }
        let all_sent = u.n_sent == u.wire.len();
        if stalled && matches!(u.phase, UpPhase::Items) {
            if all_sent {
                // Everything went out and the final ACK never came: read the list back.
                self.begin_verify(u, now);
                return UpStep::Continue;
            }
            if u.restarts_left > 0 {
                self.restart_upload(u, now);
                return UpStep::Restarted(format!(
                    "no request for {:.0} s",
                    self.cfg.stall.as_secs_f64()
                ));
            }
        }
        u.idle_timeouts += 1;
        u.deadline = now + self.cfg.timeout;
        let highest = u.requested.iter().rposition(|r| *r);
        match (&u.phase, highest) {
            (UpPhase::Items, Some(h)) => {
                // Resend the highest item requested (our answer may have been lost) and,
                // if the vehicle's request for the next one may have been lost instead,
                // offer that one too — and one more for every further timeout without
                // progress. See "A lost request" in the module docs.
                self.out
                    .push_back(MavMessage::MISSION_ITEM_INT(u.wire[h].clone()));
                let ahead = (u.idle_timeouts as usize).clamp(1, MAX_OFFERED);
                for i in (h + 1..u.wire.len()).take(ahead) {
                    u.mark_sent(i);
                    self.out
                        .push_back(MavMessage::MISSION_ITEM_INT(u.wire[i].clone()));
                }
            }
            _ => {
                self.out
                    .push_back(self.count_msg(u.kind, u.wire.len() as u16));
            }
        }
        UpStep::Continue
    }
}

impl Upload {
    fn mark_sent(&mut self, i: usize) {
        if !self.sent[i] {
            self.sent[i] = true;
            self.n_sent += 1;
        }
        if !self.ever_sent[i] {
            self.ever_sent[i] = true;
            self.n_ever_sent += 1;
        }
    }
}

impl Download {
    fn new(kind: MissionType, deadline: Time, verify: bool, restarts: u32) -> Download {
        Download {
            kind,
            count: None,
            items: Vec::new(),
            deadline,
            verify,
            restarts_left: restarts,
            gap: false,
        }
    }
}
