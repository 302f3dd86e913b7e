//! The mission protocol's vocabulary: its timeouts, the operations a caller starts, what
//! they produce, why they fail, and the events the machine reports.

use crate::mission::item::{MissionItem, MissionType};
use crate::mission::wire::WireError;
use mavlink::dialects::ardupilotmega::MavMissionResult;
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

/// Identifies an operation started with [`super::MissionClient::start`].
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
    /// The operation's name in messages ("upload", "download", …).
    pub(super) fn name(&self) -> &'static str {
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
    /// An item cannot be put on the wire (command or frame unknown to the dialect, too many
    /// items); the message is the [`WireError`]'s.
    #[error(transparent)]
    Wire(#[from] WireError),
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

impl MissionError {
    /// Whether trying the operation again may succeed because the vehicle did not answer
    /// (a lost frame, a busy link), as opposed to the vehicle saying no: only
    /// [`MissionError::Timeout`] (silent for [`MissionConfig::silence`]) and
    /// [`MissionError::OverBudget`] (not finished within its overall deadline). A refusal
    /// (`Rejected`), a list that reads back different (`Unconfirmed`), an item that cannot be
    /// encoded or decoded, and a cancel are final.
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            MissionError::Timeout { .. } | MissionError::OverBudget { .. }
        )
    }
}
