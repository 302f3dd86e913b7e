//! One vehicle's link as the fleet actor keeps it: the budget it plans for, the telemetry it
//! asked for and what it stops, the radio's last report, the bytes each way, and the GCS's
//! queue towards it ([`Uplink`]). The actor's side of it is `telemetry.rs`.

use super::state::RadioReport;
use fleetmap_core::budget::LinkBudget;
use fleetmap_core::proto::telemetry::{STREAMS_STALE, StreamPlan, Unwanted};
use fleetmap_core::proto::uplink::{Priority, Uplink};
use fleetmap_core::time::Time;
use fleetmap_io::link::peers::PeerKey;
use fleetmap_io::link::transport::LinkId;
use mavlink::MavlinkVersion;
use mavlink::Message;
use mavlink::dialects::ardupilotmega::{MavMessage, RADIO_STATUS_DATA};
use std::time::Duration;

/// The longest wait between two requests for telemetry that does not come.
pub(super) const STREAM_RETRY_MAX: Duration = Duration::from_secs(60);

/// A radio report older than this no longer describes the link (SiK sends one about every
/// second while MAVLink flows).
const RADIO_STALE: Duration = Duration::from_secs(10);

/// The bytes of `msg` on the wire, unsigned MAVLink 2.
pub(super) fn wire_len(msg: &MavMessage) -> usize {
    let mut payload = [0u8; 255];
    msg.ser(MavlinkVersion::V2, &mut payload) + 12
}

/// How urgent a message the GCS sends is ([`Uplink`]).
#[allow(deprecated)] // the deprecated messages that deployed autopilots still take
pub(super) fn priority(msg: &MavMessage) -> Priority {
    match msg {
        MavMessage::HEARTBEAT(_) => Priority::Heartbeat,
        MavMessage::COMMAND_LONG(_)
        | MavMessage::COMMAND_INT(_)
        | MavMessage::SET_MODE(_)
        | MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)
        | MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)
        | MavMessage::REQUEST_DATA_STREAM(_)
        | MavMessage::PARAM_SET(_)
        | MavMessage::PARAM_REQUEST_READ(_) => Priority::Command,
        MavMessage::MISSION_COUNT(_)
        | MavMessage::MISSION_ITEM(_)
        | MavMessage::MISSION_ITEM_INT(_)
        | MavMessage::MISSION_REQUEST(_)
        | MavMessage::MISSION_REQUEST_INT(_)
        | MavMessage::MISSION_REQUEST_LIST(_)
        | MavMessage::MISSION_ACK(_)
        | MavMessage::MISSION_CLEAR_ALL(_)
        | MavMessage::MISSION_SET_CURRENT(_) => Priority::Mission,
        _ => Priority::Bulk,
    }
}

/// One vehicle's link, as the actor manages it (see the module documentation).
#[derive(Debug)]
pub(super) struct VehicleLink {
    /// What the link is planned for.
    pub(super) budget: LinkBudget,
    /// The operator gave the budget (it is not replaced by a radio's report).
    configured: bool,
    /// The budget was assumed from a radio's report.
    assumed: bool,
    /// The requests last sent.
    plan: StreamPlan,
    /// What the vehicle streams unasked (on a radio).
    unwanted: Unwanted,
    /// Where the autopilot was last heard from: the link and, on a link serving several,
    /// the peer.
    pub(super) via: (LinkId, Option<PeerKey>),
    /// The radio's last report on that link and peer, and when it came.
    radio: Option<(RADIO_STATUS_DATA, Time)>,
    /// Bytes received from the system / sent to it since `bytes_at`.
    rx_bytes: u64,
    tx_bytes: u64,
    bytes_at: Time,
    /// Smoothed bytes per second each way.
    down_bps: f64,
    up_bps: f64,
    /// When telemetry was last requested, and the wait before asking again if it does not
    /// come (doubling up to [`STREAM_RETRY_MAX`]).
    pub(super) streams_at: Time,
    pub(super) streams_backoff: Duration,
    /// What the GCS sends the vehicle on a radio, most urgent first and paced: (the message,
    /// the system a targetless message is for).
    pub(super) uplink: Uplink<(MavMessage, Option<u8>)>,
}

impl VehicleLink {
    /// The link of a vehicle first heard on `via` at `now`, planned for `configured` (what
    /// the operator said) or unlimited.
    pub(super) fn new(
        configured: Option<LinkBudget>,
        via: (LinkId, Option<PeerKey>),
        now: Time,
    ) -> VehicleLink {
        VehicleLink {
            budget: configured.unwrap_or_default(),
            configured: configured.is_some(),
            assumed: false,
            plan: StreamPlan {
                data_streams: Vec::new(),
                intervals: Vec::new(),
                expected_bytes_per_s: None,
            },
            unwanted: Unwanted::default(),
            via,
            radio: None,
            rx_bytes: 0,
            tx_bytes: 0,
            bytes_at: now,
            down_bps: 0.0,
            up_bps: 0.0,
            streams_at: now,
            streams_backoff: STREAMS_STALE,
            uplink: Uplink::new(configured.and_then(LinkBudget::uplink_bytes_per_s), now),
        }
    }

    /// A frame of `len` bytes from the system arrived.
    pub(super) fn received(&mut self, len: usize) {
        self.rx_bytes += len as u64;
    }

    /// A message of `len` bytes went to the system.
    pub(super) fn sent(&mut self, len: usize) {
        self.tx_bytes += len as u64;
    }

    /// The autopilot sent message `id` at `now`: on a radio, an unasked periodic message is
    /// to be stopped.
    pub(super) fn autopilot_message(&mut self, id: u32, now: Time) {
        if self.budget.is_limited() {
            self.unwanted.handle_message(id, now);
        }
    }

    /// The next message to ask the vehicle to stop.
    pub(super) fn poll_stop(&mut self) -> Option<u32> {
        self.unwanted.poll_stop()
    }

    /// A radio on this vehicle's link and peer reported `r` at `now`. Returns true when the
    /// budget changed (the GCS had been told nothing and now plans for a radio).
    pub(super) fn radio_status(&mut self, r: &RADIO_STATUS_DATA, now: Time) -> bool {
        self.radio = Some((r.clone(), now));
        self.uplink.handle_radio_status(r.txbuf);
        if self.configured || self.budget.is_limited() {
            return false;
        }
        self.budget = LinkBudget::radio();
        self.assumed = true;
        self.uplink.set_rate(self.budget.uplink_bytes_per_s());
        true
    }

    /// The plan for a vehicle of this flavour on this link, made the current one.
    pub(super) fn replan(
        &mut self,
        autopilot: fleetmap_core::proto::flavour::Autopilot,
        terrain: bool,
    ) -> &StreamPlan {
        self.plan = StreamPlan::for_link_terrain(autopilot, self.budget, terrain);
        self.unwanted.replan(self.plan.asked());
        &self.plan
    }

    /// Update the smoothed byte rates at `now` (every half second or more).
    pub(super) fn sample_rates(&mut self, now: Time) {
        let dt = now.saturating_since(self.bytes_at).as_secs_f64();
        if dt < 0.5 {
            return;
        }
        let (down, up) = (self.rx_bytes as f64 / dt, self.tx_bytes as f64 / dt);
        let first = self.down_bps == 0.0 && self.up_bps == 0.0;
        let k = if first { 1.0 } else { 0.5 };
        self.down_bps += k * (down - self.down_bps);
        self.up_bps += k * (up - self.up_bps);
        self.rx_bytes = 0;
        self.tx_bytes = 0;
        self.bytes_at = now;
    }

    /// Copy what the snapshot shows of the link into `q`.
    pub(super) fn describe(&self, q: &mut super::state::LinkQuality, now: Time) {
        q.down_bytes_per_s = self.down_bps;
        q.up_bytes_per_s = self.up_bps;
        q.budget = self.budget;
        q.budget_assumed = self.assumed;
        q.radio = self
            .radio
            .as_ref()
            .filter(|(_, at)| now.saturating_since(*at) <= RADIO_STALE)
            .map(|(r, at)| RadioReport {
                status: r.into(),
                age_s: now.saturating_since(*at).as_secs_f64(),
            });
    }
}
