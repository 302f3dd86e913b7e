//! Each vehicle's link as the fleet actor manages it: the budget it plans for, the telemetry
//! it asks for (and stops), what the link's radio reports, and the bytes that cross it.
//!
//! * **Budget.** What the operator said (`FleetConfig::budget`, `FleetConfig::vehicle_budgets`:
//!   a mission file's `link`, `--link`), else unlimited — until a radio reports itself on the
//!   vehicle's link (RADIO_STATUS): a SiK radio carries ~2 kB/s, so the GCS then plans for
//!   [`LinkBudget::radio`] and says so.
//! * **Telemetry.** [`StreamPlan::for_link`] chooses the requests; on a radio, what the
//!   vehicle streams unasked is stopped message by message ([`Unwanted`]).
//! * **RADIO_STATUS.** A SiK radio with MAVLink framing writes its report into the serial side
//!   it is plugged into, as system 51 component 68 (SiK `MAVLink_report`); several radios
//!   may share one UDP port (each vehicle with its own radio, behind a router), so a report
//!   concerns the vehicles heard from the same link and peer.
//! * **Bytes.** Every frame from a system counts for its vehicle's downlink, every message the
//!   fleet addresses to it for its uplink (the MAVLink 2 frame it becomes: the payload with
//!   trailing zeros trimmed, 12 bytes of header and checksum).

use super::actor::Actor;
use super::vehicle_link::{STREAM_RETRY_MAX, priority, wire_len};
use fleetmap_core::budget::LinkBudget;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::Command;
use fleetmap_core::proto::telemetry::STREAMS_STALE;
use fleetmap_core::time::Time;
use fleetmap_io::link::peers::PeerKey;
use fleetmap_io::link::transport::LinkId;
#[allow(deprecated)]
use mavlink::dialects::ardupilotmega::REQUEST_DATA_STREAM_DATA;
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, RADIO_STATUS_DATA};

impl Actor {
    /// Telemetry went missing (position or SYS_STATUS older than [`STREAMS_STALE`]) on a
    /// vehicle that is up: ask again, with a back-off.
    pub(super) fn rerequest_streams(&mut self, now: Time) {
        if !self.cfg.request_streams {
            return;
        }
        let stale = |t: Option<Time>| t.is_none_or(|t| now.saturating_since(t) > STREAMS_STALE);
        let due: Vec<Endpoint> = self
            .vehicles
            .values_mut()
            .filter(|v| v.snap.alive && !v.snap.booting)
            .filter(|v| stale(v.snap.position_at) || stale(v.status_at))
            .filter(|v| now.saturating_since(v.link.streams_at) >= v.link.streams_backoff)
            .map(|v| {
                v.link.streams_backoff = (v.link.streams_backoff * 2).min(STREAM_RETRY_MAX);
                Endpoint::new(v.snap.sysid, v.snap.compid)
            })
            .collect();
        for ep in due {
            tracing::debug!(
                "vehicle {}: telemetry missing, asking for it again",
                ep.sysid
            );
            self.request_streams(ep, now);
        }
    }

    /// Ask for the telemetry that fits the vehicle's link ([`StreamPlan::for_link_terrain`];
    /// with terrain served, [`FleetConfig::terrain`](super::FleetConfig::terrain)).
    #[allow(deprecated)] // REQUEST_DATA_STREAM: still what ArduPilot's stream rates obey
    pub(super) fn request_streams(&mut self, ep: Endpoint, now: Time) {
        if !self.cfg.request_streams {
            return;
        }
        let Some(v) = self.vehicles.get_mut(&ep.sysid) else {
            return;
        };
        v.link.streams_at = now;
        let plan = v
            .link
            .replan(v.snap.flavour.autopilot, self.cfg.terrain)
            .clone();
        for (stream, hz) in plan.data_streams {
            self.route(&MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
                req_message_rate: hz,
                target_system: ep.sysid,
                target_component: ep.compid,
                req_stream_id: stream,
                start_stop: u8::from(hz > 0),
            }));
        }
        for (id, us) in plan.intervals {
            self.set_interval(ep, id, us, now);
        }
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL for message `id` at `interval_us` (−1 stops it). Its
    /// result is not awaited: a vehicle that refuses keeps its rate, and missing telemetry is
    /// asked for again.
    fn set_interval(&mut self, ep: Endpoint, id: u32, interval_us: f32, now: Time) {
        let cmd = Command::long(
            ep,
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [id as f32, interval_us, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        self.commands.start(cmd, now);
    }

    /// Ask the vehicles on a radio to stop what they stream unasked.
    pub(super) fn stop_unwanted(&mut self, now: Time) {
        let mut stops = Vec::new();
        for v in self.vehicles.values_mut() {
            while let Some(id) = v.link.poll_stop() {
                stops.push((Endpoint::new(v.snap.sysid, v.snap.compid), id));
            }
        }
        for (ep, id) in stops {
            tracing::debug!(
                "vehicle {}: message {id} streams unasked on a radio: asking it to stop",
                ep.sysid
            );
            self.set_interval(ep, id, -1.0, now);
        }
    }

    /// A RADIO_STATUS `r` arrived on `via` at `now`: it describes the link of every vehicle
    /// heard there. A vehicle the operator said nothing about is planned for a radio from
    /// now on, and its telemetry asked for again.
    pub(super) fn on_radio_status(
        &mut self,
        via: (LinkId, Option<PeerKey>),
        r: &RADIO_STATUS_DATA,
        now: Time,
    ) {
        let mut replan = Vec::new();
        for v in self.vehicles.values_mut().filter(|v| v.link.via == via) {
            if v.link.radio_status(r, now) {
                tracing::info!(
                    "vehicle {}: a telemetry radio reports itself on its link: planning its \
                     telemetry for {} (give --link or the mission's `link` to say otherwise)",
                    v.snap.sysid,
                    v.link.budget
                );
                replan.push(Endpoint::new(v.snap.sysid, v.snap.compid));
            }
        }
        for ep in replan {
            self.request_streams(ep, now);
        }
    }

    /// Queue `msg` for vehicle `sysid` (`to`: the system a message without a target field is
    /// for) in its uplink, at its priority.
    pub(super) fn queue_uplink(&mut self, sysid: u8, msg: MavMessage, to: Option<u8>) -> bool {
        let now = self.clock.now();
        let Some(v) = self.vehicles.get_mut(&sysid) else {
            return false;
        };
        let bytes = wire_len(&msg);
        v.link.sent(bytes);
        let p = priority(&msg);
        v.link.uplink.push((msg, to), bytes, p, now);
        true
    }

    /// Send what the vehicles' uplinks let out by `now`.
    pub(super) fn flush_uplinks(&mut self, now: Time) {
        let mut out = Vec::new();
        for v in self.vehicles.values_mut() {
            while let Some(m) = v.link.uplink.poll_transmit(now) {
                out.push((v.snap.sysid, m));
            }
        }
        for (sysid, (msg, to)) in out {
            self.send_now(sysid, &msg, to);
        }
    }

    /// The earliest time a vehicle's uplink has something to let out.
    pub(super) fn uplinks_timeout(&self) -> Option<Time> {
        self.vehicles
            .values()
            .filter_map(|v| v.link.uplink.poll_timeout())
            .min()
    }

    /// The budget the operator gave for vehicle `sysid`, if any.
    pub(super) fn configured_budget(&self, sysid: u8) -> Option<LinkBudget> {
        self.cfg
            .vehicle_budgets
            .get(&sysid)
            .copied()
            .or(self.cfg.budget)
    }
}
