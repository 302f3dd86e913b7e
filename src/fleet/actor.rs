//! The fleet actor: the task that owns every vehicle's state and protocol machines, its
//! requests, and its event loop (link events, timers, requests, snapshot publication).

use super::FleetConfig;
use super::Incoming;
use super::error::FleetError;
use super::state::FleetSnapshot;
use super::state::VehicleSnapshot;
use super::vehicle_link::{VehicleLink, wire_len};
use fleetmap_core::mission::item::MissionType;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::camera_tally::CameraTally;
use fleetmap_core::proto::command::CmdId;
use fleetmap_core::proto::command::Command;
use fleetmap_core::proto::command::CommandAck;
use fleetmap_core::proto::command::CommandError;
use fleetmap_core::proto::command::CommandEvent;
use fleetmap_core::proto::command::CommandSender;
use fleetmap_core::proto::flavour::Flavour;
use fleetmap_core::proto::heartbeat::Beat;
use fleetmap_core::proto::heartbeat::Liveness;
use fleetmap_core::proto::heartbeat::LivenessEvent;
use fleetmap_core::proto::mission::MissionClient;
use fleetmap_core::proto::mission::MissionEvent;
use fleetmap_core::proto::mission::MissionOp;
use fleetmap_core::proto::mission::MissionOutcome;
use fleetmap_core::proto::mission::OpId;
use fleetmap_core::proto::sysid_conflict::SysidWatch;
use fleetmap_core::proto::telemetry::STREAMS_STALE;
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::codec::Frame;
use fleetmap_io::link::peers::PeerKey;
use fleetmap_io::link::transport::LinkEvent;
use fleetmap_io::link::transport::LinkHandle;
use fleetmap_io::link::transport::LinkId;
use fleetmap_io::watch;
use mavlink::Message;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MISSION_ITEM_INT_DATA};
use mavlink::dialects::ardupilotmega::{MavComponent, MavType};
use std::collections::BTreeMap;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::broadcast;
use tokio::sync::mpsc;
use tokio::sync::oneshot;

pub(super) type Reply<T> = oneshot::Sender<T>;

pub(super) enum Request {
    Command {
        cmd: Command,
        reply: Reply<Result<CommandAck, CommandError>>,
    },
    Mission {
        sysid: u8,
        op: MissionOp,
        reply: Reply<Result<MissionOutcome, FleetError>>,
        progress: Option<mpsc::UnboundedSender<(usize, usize)>>,
    },
    Send {
        msg: Box<MavMessage>,
        reply: Reply<usize>,
    },
    SendTo {
        to: u8,
        msg: Box<MavMessage>,
        reply: Reply<usize>,
    },
    ResetProgress {
        sysid: u8,
    },
    SnapshotPeriod {
        period: Duration,
    },
    Shutdown {
        reply: Reply<()>,
    },
}

/// A mission operation's reply channel and optional progress channel.
pub(super) type PendingMission = (
    Reply<Result<MissionOutcome, FleetError>>,
    Option<mpsc::UnboundedSender<(usize, usize)>>,
);

pub(super) struct VehicleEntry {
    pub(super) snap: VehicleSnapshot,
    pub(super) mission: MissionClient,
    pub(super) pending: HashMap<OpId, PendingMission>,
    pub(super) rate_frames: u64,
    pub(super) rate_at: Time,
    pub(super) rate_hz: f64,
    /// The last SYS_STATUS (battery, health) from the autopilot.
    pub(super) status_at: Option<Time>,
    /// Its link: budget, telemetry requests, radio, bytes ([`super::telemetry`]).
    pub(super) link: VehicleLink,
    /// What its camera component did (pictures, measurements).
    pub(super) camera: CameraTally,
}

pub(super) struct Actor {
    pub(super) cfg: FleetConfig,
    pub(super) clock: MonotonicClock,
    pub(super) links: Vec<LinkHandle>,
    pub(super) routes: HashMap<Endpoint, LinkId>,
    pub(super) sys_routes: HashMap<u8, LinkId>,
    pub(super) liveness: Liveness,
    pub(super) commands: CommandSender,
    pub(super) pending_cmds: HashMap<CmdId, Reply<Result<CommandAck, CommandError>>>,
    pub(super) vehicles: BTreeMap<u8, VehicleEntry>,
    pub(super) cameras: HashMap<u8, u8>,
    pub(super) snapshot_tx: watch::Sender<FleetSnapshot>,
    pub(super) incoming: broadcast::Sender<Incoming>,
    pub(super) next_snapshot: Time,
    /// Two autopilots behind one system id ([`fleetmap_core::proto::sysid_conflict`]).
    pub(super) sysids: SysidWatch,
}

/// The CRC of a frame (its content check for [`SysidWatch`]): the two bytes after the
/// payload; 0 for a frame too short to hold them (the codec never yields one).
fn frame_check(frame: &Frame) -> u16 {
    let hdr = match frame.version {
        mavlink::MavlinkVersion::V1 => 6,
        mavlink::MavlinkVersion::V2 => 10,
    };
    let at = hdr + usize::from(frame.raw.get(1).copied().unwrap_or(0));
    match (frame.raw.get(at), frame.raw.get(at + 1)) {
        (Some(lo), Some(hi)) => u16::from_le_bytes([*lo, *hi]),
        _ => 0,
    }
}

/// MISSION_ITEM (39) and MISSION_ITEM_INT (73) carry `seq` at payload offset 28.
#[allow(deprecated)] // MISSION_ITEM: deprecated, still what some autopilots send
pub(super) fn unparsed_item_seq(frame: &Frame) -> Option<u16> {
    use mavlink::dialects::ardupilotmega::MISSION_ITEM_DATA;
    if frame.msg_id != MISSION_ITEM_DATA::ID && frame.msg_id != MISSION_ITEM_INT_DATA::ID {
        return None;
    }
    let p = frame.payload();
    let lo = p.get(28).copied().unwrap_or(0);
    let hi = p.get(29).copied().unwrap_or(0);
    Some(u16::from_le_bytes([lo, hi]))
}

impl Actor {
    pub(super) async fn run(
        mut self,
        mut req_rx: mpsc::Receiver<Request>,
        mut ev_rx: mpsc::Receiver<LinkEvent>,
    ) {
        let mut links_open = true;
        loop {
            let now = self.clock.now();
            let wake = self.next_wake(now);
            let sleep = tokio::time::sleep(self.clock.wall_until(wake));
            // `biased`: the branches in this order, not tokio's random one, so that a run on
            // a paused clock is the same every time (each branch drains a finite queue; the
            // timers are run below on every pass, whichever branch woke).
            tokio::select! {
                biased;
                req = req_rx.recv() => match req {
                    Some(Request::Shutdown { reply }) => {
                        let _ = reply.send(());
                        break;
                    }
                    Some(r) => self.handle_request(r),
                    None => break,
                },
                ev = ev_rx.recv(), if links_open => match ev {
                    Some(ev) => self.handle_link_event(ev),
                    None => links_open = false,
                },
                _ = sleep => {}
            }
            let now = self.clock.now();
            self.handle_timeouts(now);
            self.flush(now);
            if now >= self.next_snapshot {
                self.rerequest_streams(now);
                self.publish(now);
                self.next_snapshot = now + self.cfg.snapshot_period;
            }
        }
    }

    fn next_wake(&self, now: Time) -> Time {
        let mut t = self.next_snapshot;
        for c in [self.liveness.poll_timeout(), self.commands.poll_timeout()]
            .into_iter()
            .flatten()
        {
            t = t.min(c);
        }
        for v in self.vehicles.values() {
            if let Some(c) = v.mission.poll_timeout() {
                t = t.min(c);
            }
        }
        if let Some(c) = self.uplinks_timeout() {
            t = t.min(c);
        }
        t.max(now)
    }

    fn handle_timeouts(&mut self, now: Time) {
        if self.liveness.poll_timeout().is_some_and(|t| t <= now) {
            self.liveness.handle_timeout(now);
        }
        if self.commands.poll_timeout().is_some_and(|t| t <= now) {
            self.commands.handle_timeout(now);
        }
        for v in self.vehicles.values_mut() {
            if v.mission.poll_timeout().is_some_and(|t| t <= now) {
                v.mission.handle_timeout(now);
            }
        }
    }

    fn handle_request(&mut self, r: Request) {
        let now = self.clock.now();
        match r {
            Request::Command { cmd, reply } => {
                let id = self.commands.start(cmd, now);
                self.pending_cmds.insert(id, reply);
            }
            Request::Mission {
                sysid,
                op,
                reply,
                progress,
            } => match self.vehicles.get_mut(&sysid) {
                Some(v) => {
                    if matches!(
                        op,
                        MissionOp::Upload {
                            kind: MissionType::Mission,
                            ..
                        }
                    ) {
                        v.snap.reset_progress();
                    }
                    let id = v.mission.start(op, now);
                    v.pending.insert(id, (reply, progress));
                }
                None => {
                    let _ = reply.send(Err(FleetError::NoVehicle { sysid }));
                }
            },
            Request::Send { msg, reply } => {
                let n = self.route(&msg);
                let _ = reply.send(n);
            }
            Request::SendTo { to, msg, reply } => {
                let limited = self
                    .vehicles
                    .get(&to)
                    .is_some_and(|v| v.link.budget.is_limited());
                let n = if limited {
                    usize::from(self.queue_uplink(to, *msg, Some(to)))
                } else {
                    if let Some(v) = self.vehicles.get_mut(&to) {
                        v.link.sent(wire_len(&msg));
                    }
                    self.send_now(to, &msg, Some(to))
                };
                let _ = reply.send(n);
            }
            Request::ResetProgress { sysid } => {
                if let Some(v) = self.vehicles.get_mut(&sysid) {
                    v.snap.reset_progress();
                }
            }
            Request::SnapshotPeriod { period } => {
                self.cfg.snapshot_period = period;
                self.next_snapshot = self.next_snapshot.min(now + period);
            }
            Request::Shutdown { .. } => {}
        }
    }

    /// Send `msg` over the right link(s); returns how many links it went to (or, for a
    /// vehicle whose uplink holds it back, 1: it is queued there). A message to a vehicle
    /// counts for its link's uplink bytes; on a radio it waits its turn in the vehicle's
    /// uplink ([`super::telemetry`]).
    pub(super) fn route(&mut self, msg: &MavMessage) -> usize {
        let target = msg.target_system_id().filter(|s| *s != 0);
        if let Some(sysid) = target
            && self
                .vehicles
                .get(&sysid)
                .is_some_and(|v| v.link.budget.is_limited())
        {
            return usize::from(self.queue_uplink(sysid, msg.clone(), None));
        }
        if let Some(v) = target.and_then(|s| self.vehicles.get_mut(&s)) {
            v.link.sent(wire_len(msg));
        }
        self.send_now(target.unwrap_or(0), msg, None)
    }

    /// Send `msg` to system `sysid` (0: to everyone) now: over the link the system was last
    /// heard on, else over every link. `to` names the system a message without a target
    /// field is for. Returns how many links it went to.
    pub(super) fn send_now(&self, sysid: u8, msg: &MavMessage, to: Option<u8>) -> usize {
        let comp = msg.target_component_id().unwrap_or(0);
        let link = (sysid != 0)
            .then(|| {
                self.routes
                    .get(&Endpoint::new(sysid, comp))
                    .or_else(|| self.sys_routes.get(&sysid))
                    .copied()
            })
            .flatten();
        let send = |h: &LinkHandle| match to {
            Some(to) => h.send_to_system(self.cfg.gcs, to, msg.clone()),
            None => h.send(self.cfg.gcs, msg.clone()),
        };
        match link {
            Some(l) => usize::from(self.links.get(l).is_some_and(send)),
            None => self.links.iter().filter(|h| send(h)).count(),
        }
    }

    fn handle_link_event(&mut self, ev: LinkEvent) {
        let LinkEvent::Frame {
            link,
            frame,
            received,
            peer,
            ..
        } = ev
        else {
            return;
        };
        let now = self.clock.now();
        let from = Endpoint::of(&frame.header);
        if from == self.cfg.gcs {
            return; // our own frames echoed back (e.g. a broadcast UDP setup)
        }
        self.routes.insert(from, link);
        self.sys_routes.insert(from.sysid, link);
        // The sequence counters of the autopilot component only: an autopilot sends its
        // own frames in order on a link, but forwards another component's (a camera behind
        // it) from per-route queues, reordered by more than loss explains (PX4's payload
        // link queues a camera's image data behind its messages; a false conflict then
        // stopped the runway run of tests/suite/image_sanity.rs).
        if from.compid == fleetmap_core::proto::AUTOPILOT_COMPID {
            self.sysids
                .handle_frame(link, from, frame.header.sequence, frame_check(&frame), now);
        }
        if let Some(v) = self.vehicles.get_mut(&from.sysid) {
            v.link.received(frame.raw.len());
            if v.snap.compid == from.compid {
                v.link.via = (link, peer);
                v.link.autopilot_message(frame.msg_id, now);
            }
        }
        if let Ok(MavMessage::RADIO_STATUS(r)) = &frame.message {
            self.on_radio_status((link, peer), r, now);
        }
        let frame: Arc<Frame> = Arc::from(frame);
        let _ = self.incoming.send(Incoming {
            link,
            received,
            frame: frame.clone(),
        });
        if frame.msg_id == HEARTBEAT_DATA::ID {
            let beat = match &frame.message {
                Ok(MavMessage::HEARTBEAT(h)) => Beat::from_data(h),
                _ => Beat::from_payload(frame.payload()),
            };
            self.liveness.handle_heartbeat(from, &beat, now);
            self.sysids.handle_heartbeat(link, from, &beat, now);
            self.on_heartbeat(from, &beat, (link, peer), now);
        }
        match &frame.message {
            Ok(msg) => {
                self.liveness.handle_message(from, msg, now);
                self.commands.handle_message(&frame.header, msg, now);
                if let Some(v) = self.vehicles.get_mut(&from.sysid)
                    && v.snap.compid == from.compid
                {
                    v.snap.apply(msg, now);
                    v.rate_frames += 1;
                    if matches!(msg, MavMessage::SYS_STATUS(_)) {
                        v.status_at = Some(now);
                    }
                    v.mission.handle_message(&frame.header, msg, now);
                }
                if self.cameras.get(&from.sysid) == Some(&from.compid)
                    && let Some(v) = self.vehicles.get_mut(&from.sysid)
                {
                    v.camera.handle_message(msg);
                    v.snap.camera_pictures = v.camera.pictures();
                    v.snap.camera_measurements = v.camera.measurements();
                }
            }
            Err(e) => {
                if let Some(seq) = unparsed_item_seq(&frame)
                    && let Some(v) = self.vehicles.get_mut(&from.sysid)
                {
                    v.mission
                        .handle_unparsed_item(from, seq, &format!("{e:?}"), now);
                }
            }
        }
    }

    fn on_heartbeat(
        &mut self,
        from: Endpoint,
        beat: &Beat,
        (link, peer): (LinkId, Option<PeerKey>),
        now: Time,
    ) {
        // MAV_TYPE_CAMERA = 30; camera components 100..=105.
        let cameras =
            MavComponent::MAV_COMP_ID_CAMERA as u8..=MavComponent::MAV_COMP_ID_CAMERA6 as u8;
        if beat.mav_type == MavType::MAV_TYPE_CAMERA as u8
            || cameras.contains(&from.compid) && !beat.is_autopilot()
        {
            self.cameras.insert(from.sysid, from.compid);
            if let Some(v) = self.vehicles.get_mut(&from.sysid) {
                v.snap.camera_heard(from.compid, now);
            }
            return;
        }
        if !beat.is_autopilot() {
            return;
        }
        match self.vehicles.get_mut(&from.sysid) {
            Some(v) if v.snap.compid == from.compid => {
                v.snap.apply_heartbeat(beat, now);
                v.snap.link = link;
                let home_item = v.snap.flavour.home_item();
                if v.mission.home_item() != home_item && v.mission.is_idle() {
                    v.mission.set_home_item(home_item);
                }
            }
            Some(_) => {} // a second autopilot component on the same system: ignored
            None => {
                let mut snap = VehicleSnapshot::new(from.sysid, from.compid, beat, link, now);
                snap.sysid_conflict = self.sysids.conflict_of(from.sysid).map(conflict_seen);
                let budget = self.configured_budget(from.sysid);
                snap.camera_compid = self.cameras.get(&from.sysid).copied();
                let mission = MissionClient::new(
                    self.cfg.gcs,
                    from,
                    snap.flavour.home_item(),
                    self.cfg.mission,
                );
                self.vehicles.insert(
                    from.sysid,
                    VehicleEntry {
                        snap,
                        mission,
                        pending: HashMap::new(),
                        rate_frames: 0,
                        rate_at: now,
                        rate_hz: 0.0,
                        status_at: None,
                        link: VehicleLink::new(budget, (link, peer), now),
                        camera: CameraTally::default(),
                    },
                );
                tracing::info!(
                    "vehicle {} appeared ({})",
                    from.sysid,
                    Flavour::from_heartbeat(beat.autopilot, beat.mav_type)
                );
                self.request_streams(from, now);
            }
        }
    }

    /// Move everything the machines want to send to the links, and their events to the
    /// waiting callers.
    fn flush(&mut self, now: Time) {
        while let Some(m) = self.liveness.poll_transmit() {
            // The GCS heartbeat goes out on every link.
            for l in &self.links {
                l.send(self.cfg.gcs, m.clone());
            }
        }
        while let Some(ev) = self.liveness.poll_event() {
            match ev {
                LivenessEvent::Lost { who } => {
                    if let Some(v) = self.vehicles.get_mut(&who.sysid)
                        && v.snap.compid == who.compid
                    {
                        tracing::warn!("vehicle {} lost", who.sysid);
                        v.snap.alive = false;
                    }
                }
                LivenessEvent::Regained { who } => {
                    if let Some(v) = self.vehicles.get_mut(&who.sysid)
                        && v.snap.compid == who.compid
                    {
                        tracing::info!("vehicle {} back", who.sysid);
                        v.snap.alive = true;
                    }
                }
                LivenessEvent::Rebooted { who } => {
                    let mut rerequest = false;
                    // Two autopilots behind one id look like one that reboots all the time.
                    if let Some(v) = self.vehicles.get_mut(&who.sysid)
                        && v.snap.compid == who.compid
                        && v.snap.sysid_conflict.is_none()
                    {
                        tracing::warn!("vehicle {} rebooted", who.sysid);
                        v.snap.reboots += 1;
                        v.snap.rebooted();
                        v.snap.reset_progress();
                        v.link.streams_backoff = STREAMS_STALE;
                        rerequest = true;
                    }
                    if rerequest {
                        self.request_streams(who, now);
                    }
                }
                LivenessEvent::Discovered { .. } => {}
            }
        }
        self.sysid_conflicts(now);
        self.stop_unwanted(now);
        while let Some(m) = self.commands.poll_transmit() {
            self.route(&m);
        }
        while let Some(ev) = self.commands.poll_event() {
            if let CommandEvent::Done { id, result } = ev
                && let Some(reply) = self.pending_cmds.remove(&id)
            {
                let _ = reply.send(result);
            }
        }
        let mut out = Vec::new();
        for v in self.vehicles.values_mut() {
            while let Some(m) = v.mission.poll_transmit() {
                out.push(m);
            }
            let sysid = v.snap.sysid;
            while let Some(ev) = v.mission.poll_event() {
                match ev {
                    MissionEvent::Progress { id, done, total } => {
                        if let Some((_, Some(p))) = v.pending.get(&id) {
                            let _ = p.send((done, total));
                        }
                    }
                    MissionEvent::Restarted { reason, left, .. } => {
                        tracing::warn!(
                            "vehicle {sysid}: mission transfer starts over ({reason}; {left} more restarts allowed)"
                        );
                    }
                    MissionEvent::Done { id, result } => {
                        if let Some((reply, _)) = v.pending.remove(&id) {
                            let _ = reply
                                .send(result.map_err(|error| FleetError::Mission { sysid, error }));
                        }
                    }
                }
            }
        }
        for m in out {
            self.route(&m);
        }
        self.flush_uplinks(now);
    }

    /// Mark the vehicles behind which the watch found two autopilots, say so loudly, and
    /// publish at once (operations refuse them from the next snapshot on).
    fn sysid_conflicts(&mut self, now: Time) {
        while let Some(c) = self.sysids.poll_event() {
            let seen = conflict_seen(&c);
            tracing::error!(
                "SYSTEM ID CONFLICT: two or more autopilots answer as system id {} on link {} \
                 ({}; found after {:.1} s): fleetmap will send nothing more to vehicle {} — \
                 {}",
                c.who.sysid,
                c.link,
                seen.evidence,
                seen.detect_s,
                c.who.sysid,
                crate::fleet::SysidConflict::FIX
            );
            if let Some(v) = self.vehicles.get_mut(&c.who.sysid) {
                v.snap.sysid_conflict = Some(seen);
                self.next_snapshot = now;
            }
        }
    }

    fn publish(&mut self, now: Time) {
        let statuses: Vec<_> = self.links.iter().map(|l| l.status()).collect();
        let mut snap = FleetSnapshot {
            time: now,
            vehicles: BTreeMap::new(),
            links: statuses,
        };
        for (sysid, v) in self.vehicles.iter_mut() {
            let ep = Endpoint::new(*sysid, v.snap.compid);
            let dt = now.saturating_since(v.rate_at).as_secs_f64();
            if dt >= 0.5 {
                let inst = v.rate_frames as f64 / dt;
                v.rate_hz = if v.rate_hz == 0.0 {
                    inst
                } else {
                    0.5 * v.rate_hz + 0.5 * inst
                };
                v.rate_frames = 0;
                v.rate_at = now;
            }
            let src = snap
                .links
                .get(v.snap.link)
                .and_then(|l| l.stats.sources.get(&ep))
                .copied();
            v.snap.refresh(
                self.liveness.is_alive(ep),
                self.liveness.last_heartbeat(ep),
                src.as_ref(),
                v.rate_hz,
                now,
            );
            v.snap.sysid_checked = self.sysids.checked(*sysid, now);
            v.link.sample_rates(now);
            v.link.describe(&mut v.snap.link_quality, now);
            snap.vehicles.insert(*sysid, v.snap.clone());
        }
        let _ = self.snapshot_tx.send(snap);
    }
}

/// How the operator is told of `c`.
fn conflict_seen(
    c: &fleetmap_core::proto::sysid_conflict::Conflict,
) -> crate::fleet::SysidConflict {
    crate::fleet::SysidConflict {
        evidence: c.evidence.to_string(),
        link: c.link,
        detect_s: c.at.saturating_since(c.since).as_secs_f64(),
    }
}
