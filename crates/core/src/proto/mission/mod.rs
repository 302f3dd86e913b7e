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
//!
//! The machine is split along its state: `types.rs` (configuration, operations, outcomes,
//! errors, events), `peer.rs` (what every machine shares: endpoints, configuration, the
//! outgoing queue, events, ignored messages, and the message builders), `upload.rs` and
//! `download.rs` (the two transfer sub-machines, which take the peer), and `client.rs`
//! ([`MissionClient`]: owns the peer and the active machine; the queue, the settle time, and
//! the dispatch of messages and timers to the sub-machines). The wire conversions of
//! items live in [`crate::mission::wire`] and are re-exported here.

// Deliberately handles deprecated messages and frames (MISSION_REQUEST, MISSION_ITEM,
// MISSION_SET_CURRENT, *_INT frames) because deployed autopilots still send or need them.
#![allow(deprecated)]

mod client;
mod download;
mod peer;
mod types;
mod upload;

pub use client::MissionClient;
pub use types::{
    MAX_OFFERED, MissionConfig, MissionError, MissionEvent, MissionOp, MissionOutcome,
    MissionResultCode, OpId,
};
