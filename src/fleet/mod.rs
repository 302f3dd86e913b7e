//! The fleet actor: one task owning every vehicle's state and protocol machines, and a
//! cloneable [`FleetHandle`] that the CLI, the TUI and the mission runners use.
//!
//! Shape (mini-redis style, DESIGN.md §2): the task owns its state; requests arrive on an
//! mpsc channel and are answered on oneshot channels; link tasks send it received frames.
//! It publishes a [`FleetSnapshot`] on a `watch` channel five times per second and every
//! received frame on a `broadcast` channel ([`FleetHandle::subscribe`]) so other services
//! (image transfer, runners) can be built on top; [`FleetHandle::send`] sends any message.
//!
//! * Vehicles appear by heartbeat: an autopilot heartbeat (MAV_AUTOPILOT ≠ INVALID, not a
//!   GCS) from (sysid, compid) creates the vehicle `sysid`; cameras (MAV_TYPE_CAMERA or
//!   component 100–105) are attached to their system.
//! * Routing: each (sysid, compid) is sent to over the link it was last heard on; a
//!   message without a target, or to an unknown system, goes out on every link
//!   (MAVProxy and ArduPilot's `MAVLink_routing.cpp` do the same).
//! * Telemetry rates are requested when a vehicle appears and after a reboot:
//!   MAV_CMD_SET_MESSAGE_INTERVAL for the messages we display (as QGroundControl's
//!   `Vehicle::_setMessageInterval` and MAVSDK do), plus REQUEST_DATA_STREAM for ArduPilot,
//!   whose serial links stream only what SRn_* parameters or this request ask for
//!   (QGroundControl `APMFirmwarePlugin::initializeStreamRates`, MAVProxy `--streamrate`).
//! * Operations that take several steps (arm after the readiness checks, take off in the
//!   right mode, go to, return, land, fly a mission) are composed on the handle from the
//!   actor's primitives (command with ACK, mission operation, snapshot waits), each step
//!   with its own timeout and typed error.

pub mod state;

pub use state::{FleetSnapshot, GeoPoint, LinkQuality, StatusText, VehicleSnapshot};

use crate::clock::MonotonicClock;
use crate::link::codec::Frame;
use crate::link::transport::{LinkEvent, LinkHandle, LinkId, LinkOptions, open_link};
use crate::link::{addr::ConnSpec, transport::LinkError};
use crate::mission::{MissionItem, MissionType};
use crate::proto::command::{
    CmdId, Command, CommandAck, CommandConfig, CommandError, CommandEvent, CommandSender,
};
use crate::proto::flavour::{Autopilot, Flavour, FlavourError, Step, VehicleClass};
use crate::proto::heartbeat::{Beat, Liveness, LivenessConfig, LivenessEvent};
use crate::proto::mission::{
    MissionClient, MissionConfig, MissionError, MissionEvent, MissionOp, MissionOutcome, OpId,
};
use crate::proto::{CAMERA_COMPID, Endpoint};
use crate::time::Time;
#[allow(deprecated)]
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavDataStream, MavMessage, REQUEST_DATA_STREAM_DATA,
};
use mavlink::{MavHeader, Message};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{broadcast, mpsc, oneshot, watch};

/// Fleet configuration.
#[derive(Clone, Debug)]
pub struct FleetConfig {
    /// Our identity (255, 190).
    pub gcs: Endpoint,
    /// Mission protocol timeouts and retries.
    pub mission: MissionConfig,
    /// Command protocol timeouts and retries.
    pub command: CommandConfig,
    /// Heartbeat period and liveness window.
    pub liveness: LivenessConfig,
    /// Ask vehicles for telemetry rates when they appear.
    pub request_streams: bool,
    /// Snapshot publication period.
    pub snapshot_period: Duration,
    /// Timeouts of the composed operations.
    pub ops: OpsConfig,
}

impl Default for FleetConfig {
    fn default() -> Self {
        FleetConfig {
            gcs: Endpoint::gcs(),
            mission: MissionConfig::default(),
            command: CommandConfig::default(),
            liveness: LivenessConfig::default(),
            request_streams: true,
            snapshot_period: Duration::from_millis(200),
            ops: OpsConfig::default(),
        }
    }
}

/// Timeouts of the composed operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OpsConfig {
    /// Wait for the heartbeat to show a new mode.
    pub mode_confirm: Duration,
    /// Wait for the vehicle to become ready to arm (GPS, EKF, home, pre-arm checks) before
    /// arming or taking off.
    pub arm_ready: Duration,
    /// Wait for the heartbeat to show armed / disarmed.
    pub arm_confirm: Duration,
    /// Wait for a vehicle that is still booting ([`VehicleSnapshot::booting`]) before an
    /// operation, and retry an operation it refused while booting, for at most this long.
    pub boot_wait: Duration,
}

impl Default for OpsConfig {
    fn default() -> Self {
        OpsConfig {
            mode_confirm: Duration::from_secs(5),
            arm_ready: Duration::from_secs(60),
            arm_confirm: Duration::from_secs(5),
            boot_wait: Duration::from_secs(60),
        }
    }
}

/// Why a fleet operation failed.
///
/// Each message is whole: the protocol error a variant wraps is part of it and is not also
/// returned by `Error::source`, so that printing the chain of causes (`{:#}`, or the
/// binary's one-line report) does not repeat it ("vehicle 1: X: X").
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// No heartbeat from that system (yet).
    #[error("vehicle {sysid}: no heartbeat received from system {sysid}")]
    NoVehicle {
        /// System id.
        sysid: u8,
    },
    /// A command was refused or not acknowledged.
    #[error("vehicle {sysid}: {error}")]
    Command {
        /// System id.
        sysid: u8,
        /// The command error.
        error: CommandError,
    },
    /// A mission operation failed.
    #[error("vehicle {sysid}: {error}")]
    Mission {
        /// System id.
        sysid: u8,
        /// The mission error.
        error: MissionError,
    },
    /// The action does not apply to this vehicle, or a mode name is unknown.
    #[error("vehicle {sysid}: {error}")]
    Flavour {
        /// System id.
        sysid: u8,
        /// The flavour error.
        error: FlavourError,
    },
    /// The vehicle did not become ready to arm in time.
    #[error("vehicle {sysid}: not ready to arm after {waited_s:.0} s: {}", reasons.join("; "))]
    NotReady {
        /// System id.
        sysid: u8,
        /// Seconds waited.
        waited_s: f64,
        /// Why.
        reasons: Vec<String>,
    },
    /// The arm command was refused.
    #[error("vehicle {sysid}: arming refused: {error}{}", prearm.as_ref().map(|t| format!(" (autopilot says: {t})")).unwrap_or_default())]
    ArmRefused {
        /// System id.
        sysid: u8,
        /// The command error.
        error: CommandError,
        /// The last pre-arm failure text, if any.
        prearm: Option<String>,
    },
    /// A state the vehicle should reach did not show up in its telemetry in time.
    #[error("vehicle {sysid}: {what} not seen within {waited_s:.1} s (now: {now})")]
    NotConfirmed {
        /// System id.
        sysid: u8,
        /// What was awaited.
        what: String,
        /// Seconds waited.
        waited_s: f64,
        /// The current state, for the message.
        now: String,
    },
    /// The vehicle did not finish booting in time.
    #[error("vehicle {sysid}: still booting after {waited_s:.0} s ({why})")]
    Booting {
        /// System id.
        sysid: u8,
        /// Seconds waited.
        waited_s: f64,
        /// What showed it booting.
        why: String,
    },
    /// The fleet task has stopped.
    #[error("the fleet task has stopped")]
    Stopped,
}

/// A refusal this soon after a vehicle left boot still counts as a boot-time refusal (the
/// heartbeat that says it is up may be older than a reboot the fleet has not seen yet).
pub const BOOT_GRACE: Duration = Duration::from_secs(5);

/// Pause before an operation refused while booting is tried again.
const BOOT_RETRY: Duration = Duration::from_millis(500);

/// A received frame, as broadcast to subscribers.
#[derive(Clone, Debug)]
pub struct Incoming {
    /// The link it came on.
    pub link: LinkId,
    /// Reception time, µs since the Unix epoch.
    pub unix_us: u64,
    /// The frame (header, raw bytes, parsed message or why not).
    pub frame: Arc<Frame>,
}

type Reply<T> = oneshot::Sender<T>;

enum Request {
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
type PendingMission = (
    Reply<Result<MissionOutcome, FleetError>>,
    Option<mpsc::UnboundedSender<(usize, usize)>>,
);

struct VehicleEntry {
    snap: VehicleSnapshot,
    mission: MissionClient,
    pending: HashMap<OpId, PendingMission>,
    rate_frames: u64,
    rate_at: Time,
    rate_hz: f64,
    /// The last SYS_STATUS (battery, health) from the autopilot.
    status_at: Option<Time>,
    /// When telemetry rates were last requested, and the wait before asking again if the
    /// telemetry does not come (doubling up to [`STREAM_RETRY_MAX`]).
    streams_at: Time,
    streams_backoff: Duration,
}

/// Telemetry older than this counts as missing: its rates are requested again.
const STREAM_STALE: Duration = Duration::from_secs(5);
/// The longest wait between two requests for telemetry that does not come.
const STREAM_RETRY_MAX: Duration = Duration::from_secs(60);

struct Actor {
    cfg: FleetConfig,
    clock: MonotonicClock,
    links: Vec<LinkHandle>,
    routes: HashMap<Endpoint, LinkId>,
    sys_routes: HashMap<u8, LinkId>,
    liveness: Liveness,
    commands: CommandSender,
    pending_cmds: HashMap<CmdId, Reply<Result<CommandAck, CommandError>>>,
    vehicles: BTreeMap<u8, VehicleEntry>,
    cameras: HashMap<u8, u8>,
    snapshot_tx: watch::Sender<FleetSnapshot>,
    incoming: broadcast::Sender<Incoming>,
    next_snapshot: Time,
}

/// Handle to the fleet task (cheap to clone).
#[derive(Clone)]
pub struct FleetHandle {
    tx: mpsc::Sender<Request>,
    snapshot: watch::Receiver<FleetSnapshot>,
    incoming: broadcast::Sender<Incoming>,
    links: Vec<LinkHandle>,
    clock: MonotonicClock,
    cfg: FleetConfig,
}

/// Open every connection string and start the fleet.
pub async fn start(
    specs: &[ConnSpec],
    opts: &LinkOptions,
    cfg: FleetConfig,
) -> Result<FleetHandle, LinkError> {
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let mut links = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        links.push(open_link(i, s.clone(), opts, ev_tx.clone()).await?);
    }
    drop(ev_tx);
    Ok(spawn(links, ev_rx, cfg, MonotonicClock::new()))
}

/// Start the fleet on links that are already open (`events` is their event channel) with
/// the given clock.
pub fn spawn(
    links: Vec<LinkHandle>,
    events: mpsc::Receiver<LinkEvent>,
    cfg: FleetConfig,
    clock: MonotonicClock,
) -> FleetHandle {
    let now = clock.now();
    let (tx, rx) = mpsc::channel(256);
    let (snapshot_tx, snapshot_rx) = watch::channel(FleetSnapshot::default());
    let (incoming, _) = broadcast::channel(4096);
    let actor = Actor {
        liveness: Liveness::new(cfg.gcs, cfg.liveness, now),
        commands: CommandSender::new(cfg.gcs, cfg.command),
        cfg: cfg.clone(),
        clock: clock.clone(),
        links: links.clone(),
        routes: HashMap::new(),
        sys_routes: HashMap::new(),
        pending_cmds: HashMap::new(),
        vehicles: BTreeMap::new(),
        cameras: HashMap::new(),
        snapshot_tx,
        incoming: incoming.clone(),
        next_snapshot: now,
    };
    tokio::spawn(actor.run(rx, events));
    FleetHandle {
        tx,
        snapshot: snapshot_rx,
        incoming,
        links,
        clock,
        cfg,
    }
}

/// MISSION_ITEM (39) and MISSION_ITEM_INT (73) carry `seq` at payload offset 28.
fn unparsed_item_seq(frame: &Frame) -> Option<u16> {
    if frame.msg_id != 39 && frame.msg_id != 73 {
        return None;
    }
    let p = frame.payload();
    let lo = p.get(28).copied().unwrap_or(0);
    let hi = p.get(29).copied().unwrap_or(0);
    Some(u16::from_le_bytes([lo, hi]))
}

impl Actor {
    async fn run(
        mut self,
        mut req_rx: mpsc::Receiver<Request>,
        mut ev_rx: mpsc::Receiver<LinkEvent>,
    ) {
        let mut links_open = true;
        loop {
            let now = self.clock.now();
            let wake = self.next_wake(now);
            let sleep = tokio::time::sleep(self.clock.wall_until(wake));
            tokio::select! {
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
        t.max(now)
    }

    /// Ask again for the telemetry of vehicles whose position or status does not arrive:
    /// REQUEST_DATA_STREAM is not acknowledged, so one lost frame (a lossy radio, a vehicle
    /// still booting) would otherwise leave it silent for the whole session.
    fn rerequest_streams(&mut self, now: Time) {
        if !self.cfg.request_streams {
            return;
        }
        let stale = |t: Option<Time>| t.is_none_or(|t| now.saturating_since(t) > STREAM_STALE);
        let due: Vec<Endpoint> = self
            .vehicles
            .values_mut()
            .filter(|v| v.snap.alive && !v.snap.booting)
            .filter(|v| stale(v.snap.position_at) || stale(v.status_at))
            .filter(|v| now.saturating_since(v.streams_at) >= v.streams_backoff)
            .map(|v| {
                v.streams_backoff = (v.streams_backoff * 2).min(STREAM_RETRY_MAX);
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

    /// Send `msg` over the right link(s); returns how many links it went to.
    fn route(&self, msg: &MavMessage) -> usize {
        let target = msg.target_system_id().filter(|s| *s != 0);
        let comp = msg.target_component_id().unwrap_or(0);
        let link = target.and_then(|s| {
            self.routes
                .get(&Endpoint::new(s, comp))
                .or_else(|| self.sys_routes.get(&s))
                .copied()
        });
        match link {
            Some(l) => usize::from(
                self.links
                    .get(l)
                    .is_some_and(|h| h.send(self.cfg.gcs, msg.clone())),
            ),
            None => self
                .links
                .iter()
                .filter(|h| h.send(self.cfg.gcs, msg.clone()))
                .count(),
        }
    }

    fn handle_link_event(&mut self, ev: LinkEvent) {
        let LinkEvent::Frame {
            link,
            frame,
            unix_us,
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
        let frame: Arc<Frame> = Arc::from(frame);
        let _ = self.incoming.send(Incoming {
            link,
            unix_us,
            frame: frame.clone(),
        });
        if frame.msg_id == 0 {
            let beat = match &frame.message {
                Ok(MavMessage::HEARTBEAT(h)) => Beat::from_data(h),
                _ => Beat::from_payload(frame.payload()),
            };
            self.liveness.handle_heartbeat(from, &beat, now);
            self.on_heartbeat(from, &beat, link, now);
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

    fn on_heartbeat(&mut self, from: Endpoint, beat: &Beat, link: LinkId, now: Time) {
        // MAV_TYPE_CAMERA = 30; camera components 100..=105.
        if beat.mav_type == 30 || (100..=105).contains(&from.compid) && !beat.is_autopilot() {
            self.cameras.insert(from.sysid, from.compid);
            if let Some(v) = self.vehicles.get_mut(&from.sysid) {
                v.snap.camera_compid = Some(from.compid);
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
                        streams_at: now,
                        streams_backoff: STREAM_STALE,
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

    /// Ask for the telemetry we display (see the module docs).
    #[allow(deprecated)] // REQUEST_DATA_STREAM: still what ArduPilot's SRn_* streams obey
    fn request_streams(&mut self, ep: Endpoint, now: Time) {
        if !self.cfg.request_streams {
            return;
        }
        let Some(v) = self.vehicles.get_mut(&ep.sysid) else {
            return;
        };
        v.streams_at = now;
        let ardupilot = v.snap.flavour.home_item();
        if ardupilot {
            for (stream, hz) in [
                (MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS, 2),
                (MavDataStream::MAV_DATA_STREAM_POSITION, 5),
                (MavDataStream::MAV_DATA_STREAM_EXTRA1, 4),
                (MavDataStream::MAV_DATA_STREAM_EXTRA2, 4),
                (MavDataStream::MAV_DATA_STREAM_EXTRA3, 2),
            ] {
                self.route(&MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
                    req_message_rate: hz,
                    target_system: ep.sysid,
                    target_component: ep.compid,
                    req_stream_id: stream,
                    start_stop: 1,
                }));
            }
        }
        // (message id, interval µs)
        for (id, us) in [
            (33u32, 200_000f32), // GLOBAL_POSITION_INT
            (24, 500_000.0),     // GPS_RAW_INT
            (1, 1_000_000.0),    // SYS_STATUS
            (42, 1_000_000.0),   // MISSION_CURRENT
            (245, 1_000_000.0),  // EXTENDED_SYS_STATE
            (242, 2_000_000.0),  // HOME_POSITION
            (147, 1_000_000.0),  // BATTERY_STATUS
            (74, 500_000.0),     // VFR_HUD
        ] {
            let cmd = Command::long(
                ep,
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                [id as f32, us, 0.0, 0.0, 0.0, 0.0, 0.0],
            );
            // Results are not awaited: a vehicle that refuses keeps its default rates.
            self.commands.start(cmd, now);
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
                    if let Some(v) = self.vehicles.get_mut(&who.sysid)
                        && v.snap.compid == who.compid
                    {
                        tracing::warn!("vehicle {} rebooted", who.sysid);
                        v.snap.reboots += 1;
                        v.snap.rebooted();
                        v.snap.reset_progress();
                        v.streams_backoff = STREAM_STALE;
                        rerequest = true;
                    }
                    if rerequest {
                        self.request_streams(who, now);
                    }
                }
                LivenessEvent::Discovered { .. } => {}
            }
        }
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
                .and_then(|l| l.stats.sources.get(&(ep.sysid, ep.compid)))
                .copied();
            v.snap.refresh(
                self.liveness.is_alive(ep),
                self.liveness.last_heartbeat(ep),
                src.as_ref(),
                v.rate_hz,
                now,
            );
            snap.vehicles.insert(*sysid, v.snap.clone());
        }
        let _ = self.snapshot_tx.send(snap);
    }
}

impl FleetHandle {
    /// The fleet's clock (the `now` of snapshots).
    pub fn clock(&self) -> &MonotonicClock {
        &self.clock
    }

    /// The configuration the fleet was started with.
    pub fn config(&self) -> &FleetConfig {
        &self.cfg
    }

    /// The links, in `--connect` order.
    pub fn links(&self) -> &[LinkHandle] {
        &self.links
    }

    /// The latest snapshot.
    pub fn snapshot(&self) -> FleetSnapshot {
        self.snapshot.borrow().clone()
    }

    /// A watch receiver of snapshots (published every `snapshot_period`).
    pub fn watch(&self) -> watch::Receiver<FleetSnapshot> {
        self.snapshot.clone()
    }

    /// Every received frame, from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Incoming> {
        self.incoming.subscribe()
    }

    /// The vehicle `sysid`, if heard.
    pub fn vehicle(&self, sysid: u8) -> Option<VehicleSnapshot> {
        self.snapshot.borrow().vehicles.get(&sysid).cloned()
    }

    fn require(&self, sysid: u8) -> Result<VehicleSnapshot, FleetError> {
        self.vehicle(sysid).ok_or(FleetError::NoVehicle { sysid })
    }

    /// Wait until `pred` holds for vehicle `sysid` (checked on every snapshot).
    pub async fn wait_until(
        &self,
        sysid: u8,
        timeout: Duration,
        mut pred: impl FnMut(&VehicleSnapshot) -> bool,
    ) -> Result<VehicleSnapshot, Option<VehicleSnapshot>> {
        let mut rx = self.snapshot.clone();
        let fut = async {
            loop {
                {
                    let s = rx.borrow_and_update();
                    if let Some(v) = s.vehicles.get(&sysid)
                        && pred(v)
                    {
                        return Ok(v.clone());
                    }
                }
                if rx.changed().await.is_err() {
                    return Err(());
                }
            }
        };
        match tokio::time::timeout(timeout, fut).await {
            Ok(Ok(v)) => Ok(v),
            _ => Err(self.vehicle(sysid)),
        }
    }

    /// Wait for the first heartbeat of `sysid`.
    pub async fn wait_vehicle(
        &self,
        sysid: u8,
        timeout: Duration,
    ) -> Result<VehicleSnapshot, FleetError> {
        self.wait_until(sysid, timeout, |_| true)
            .await
            .map_err(|_| FleetError::NoVehicle { sysid })
    }

    async fn request<T>(&self, make: impl FnOnce(Reply<T>) -> Request) -> Result<T, FleetError> {
        let (tx, rx) = oneshot::channel();
        self.tx
            .send(make(tx))
            .await
            .map_err(|_| FleetError::Stopped)?;
        rx.await.map_err(|_| FleetError::Stopped)
    }

    /// Send a command and wait for its final ACK. A vehicle that is booting is waited for
    /// first, and a command it refuses as temporarily rejected or denied while it boots (or
    /// just after) is sent again once it is up ([`FleetHandle::wait_booted`]).
    pub async fn command(&self, cmd: Command) -> Result<CommandAck, FleetError> {
        let sysid = cmd.target.sysid;
        let give_up = tokio::time::Instant::now() + self.cfg.ops.boot_wait;
        loop {
            // A system not heard yet (a camera, a command sent blind) is not waited for.
            if self.vehicle(sysid).is_some() {
                self.wait_booted(sysid).await?;
            }
            let c = cmd.clone();
            let r = self
                .request(|reply| Request::Command { cmd: c, reply })
                .await?
                .map_err(|error| FleetError::Command { sysid, error });
            let boot_refusal = matches!(
                &r,
                Err(FleetError::Command {
                    error: CommandError::TemporarilyRejected { .. } | CommandError::Denied { .. },
                    ..
                })
            );
            if !(boot_refusal && self.refused_while_booting(sysid, give_up).await) {
                return r;
            }
        }
    }

    /// Whether a refusal from `sysid` came while it boots or just after (within
    /// [`BOOT_GRACE`] of leaving boot) and may be tried again before `give_up`; if so, waits
    /// a moment first.
    async fn refused_while_booting(&self, sysid: u8, give_up: tokio::time::Instant) -> bool {
        let Some(v) = self.vehicle(sysid) else {
            return false;
        };
        let now = self.clock.now();
        let recent = v.booting
            || v.ready_since
                .is_some_and(|t| now.saturating_since(t) <= BOOT_GRACE);
        if !recent || tokio::time::Instant::now() + BOOT_RETRY > give_up {
            return false;
        }
        tracing::info!("vehicle {sysid}: refused while booting; trying again");
        tokio::time::sleep(BOOT_RETRY).await;
        true
    }

    /// Wait until vehicle `sysid` has finished booting ([`VehicleSnapshot::booting`]), at
    /// most [`OpsConfig::boot_wait`]; returns its snapshot then.
    pub async fn wait_booted(&self, sysid: u8) -> Result<VehicleSnapshot, FleetError> {
        let v = self.require(sysid)?;
        if !v.booting {
            return Ok(v);
        }
        let wait = self.cfg.ops.boot_wait;
        tracing::info!("vehicle {sysid} is booting: waiting for it");
        self.wait_until(sysid, wait, |s| !s.booting)
            .await
            .map_err(|last| FleetError::Booting {
                sysid,
                waited_s: wait.as_secs_f64(),
                why: match last {
                    Some(v) if v.system_status == 1 => "its heartbeat says MAV_STATE_BOOT".into(),
                    Some(_) => "no heartbeat since it rebooted".into(),
                    None => "vehicle gone".into(),
                },
            })
    }

    /// Send any message (routed by its target); returns the number of links it went out on.
    pub async fn send(&self, msg: MavMessage) -> Result<usize, FleetError> {
        self.request(|reply| Request::Send {
            msg: Box::new(msg),
            reply,
        })
        .await
    }

    /// Run a mission operation; `progress` receives (done, total) as items move. A vehicle
    /// that is booting is waited for first (a download would read an empty list from an
    /// ArduPilot that has not loaded its mission yet), and an operation it refuses with
    /// MAV_MISSION_NO_SPACE, MAV_MISSION_DENIED or MAV_MISSION_ERROR while it boots or just
    /// after is run again once it is up.
    pub async fn mission_op(
        &self,
        sysid: u8,
        op: MissionOp,
        progress: Option<mpsc::UnboundedSender<(usize, usize)>>,
    ) -> Result<MissionOutcome, FleetError> {
        use mavlink::dialects::ardupilotmega::MavMissionResult as R;
        let give_up = tokio::time::Instant::now() + self.cfg.ops.boot_wait;
        loop {
            self.wait_booted(sysid).await?;
            let (o, p) = (op.clone(), progress.clone());
            let r = self
                .request(|reply| Request::Mission {
                    sysid,
                    op: o,
                    reply,
                    progress: p,
                })
                .await?;
            let boot_refusal = matches!(
                &r,
                Err(FleetError::Mission {
                    error: MissionError::Rejected { result, .. },
                    ..
                }) if matches!(result.0, R::MAV_MISSION_NO_SPACE | R::MAV_MISSION_DENIED | R::MAV_MISSION_ERROR)
            );
            if !(boot_refusal && self.refused_while_booting(sysid, give_up).await) {
                return r;
            }
        }
    }

    /// Upload a mission, fence or rally list. For ArduPilot missions the known home is
    /// sent as item 0.
    pub async fn upload_mission(
        &self,
        sysid: u8,
        kind: MissionType,
        items: Vec<MissionItem>,
    ) -> Result<MissionOutcome, FleetError> {
        let v = self.require(sysid)?;
        let home = v.home.map(|h| MissionItem {
            frame: crate::mission::item::frame::GLOBAL,
            x: crate::mission::item::deg_to_e7(h.lat),
            y: crate::mission::item::deg_to_e7(h.lon),
            z: h.alt_amsl,
            ..MissionItem::command(crate::mission::item::cmd::NAV_WAYPOINT)
        });
        self.mission_op(sysid, MissionOp::Upload { kind, items, home }, None)
            .await
    }

    /// Download a list: (items in user numbering, ArduPilot's home item).
    pub async fn download_mission(
        &self,
        sysid: u8,
        kind: MissionType,
    ) -> Result<(Vec<MissionItem>, Option<MissionItem>), FleetError> {
        match self
            .mission_op(sysid, MissionOp::Download { kind }, None)
            .await?
        {
            MissionOutcome::Downloaded { items, home } => Ok((items, home)),
            other => Err(FleetError::NotConfirmed {
                sysid,
                what: "a downloaded list".into(),
                waited_s: 0.0,
                now: format!("{other:?}"),
            }),
        }
    }

    /// Clear a list.
    pub async fn clear_mission(&self, sysid: u8, kind: MissionType) -> Result<(), FleetError> {
        self.mission_op(sysid, MissionOp::Clear { kind }, None)
            .await
            .map(|_| ())
    }

    /// Make user item `seq` current: MAV_CMD_DO_SET_MISSION_CURRENT, or MISSION_SET_CURRENT
    /// when the autopilot does not support the command (ArduPilot < 4.3, PX4 < 1.14).
    pub async fn set_mission_current(&self, sysid: u8, seq: u16) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let wire = v.flavour.wire_seq(seq);
        let cmd = Command::long(
            Endpoint::new(sysid, v.compid),
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
            [f32::from(wire), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        match self.command(cmd).await {
            Ok(_) => Ok(()),
            Err(FleetError::Command {
                error: CommandError::Unsupported { .. },
                ..
            }) => self
                .mission_op(sysid, MissionOp::SetCurrent { seq }, None)
                .await
                .map(|_| ()),
            Err(e) => Err(e),
        }
    }

    /// Publish snapshots every `period` of the fleet's clock from now on (instead of
    /// [`FleetConfig::snapshot_period`]; [`FleetHandle::config`] still shows the period the
    /// fleet started with). The terminal UI asks for 100 ms of wall time so that its 10 frames
    /// a second each show fresh telemetry. A zero period is taken as 1 ms.
    pub async fn set_snapshot_period(&self, period: Duration) -> Result<(), FleetError> {
        let period = period.max(Duration::from_millis(1));
        self.tx
            .send(Request::SnapshotPeriod { period })
            .await
            .map_err(|_| FleetError::Stopped)
    }

    /// Forget the mission progress recorded for `sysid` (reached items).
    pub async fn reset_progress(&self, sysid: u8) -> Result<(), FleetError> {
        self.tx
            .send(Request::ResetProgress { sysid })
            .await
            .map_err(|_| FleetError::Stopped)
    }

    fn flavour_err(sysid: u8) -> impl Fn(FlavourError) -> FleetError {
        move |error| FleetError::Flavour { sysid, error }
    }

    /// Switch to mode `name` and wait until the heartbeat shows it.
    pub async fn set_mode(&self, sysid: u8, name: &str) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let mode = v.flavour.mode(name).map_err(Self::flavour_err(sysid))?;
        self.set_mode_to(&v, mode).await
    }

    async fn set_mode_to(
        &self,
        v: &VehicleSnapshot,
        mode: crate::proto::flavour::Mode,
    ) -> Result<(), FleetError> {
        let sysid = v.sysid;
        let current = self.require(sysid)?;
        if current.flavour.is_mode(current.custom_mode, mode) {
            return Ok(());
        }
        let ep = Endpoint::new(sysid, v.compid);
        self.command(v.flavour.set_mode_command(ep, mode)).await?;
        let timeout = self.cfg.ops.mode_confirm;
        let flavour = v.flavour;
        self.wait_until(sysid, timeout, |s| flavour.is_mode(s.custom_mode, mode))
            .await
            .map(|_| ())
            .map_err(|now| FleetError::NotConfirmed {
                sysid,
                what: format!("mode {}", mode.name),
                waited_s: timeout.as_secs_f64(),
                now: now.map(|v| format!("mode {}", v.mode)).unwrap_or_default(),
            })
    }

    /// Wait until vehicle `sysid` is really ready to arm (GPS fix, position estimate, home,
    /// pre-arm checks: see [`Flavour::arm_blockers`]), at most [`OpsConfig::arm_ready`];
    /// returns its snapshot at that moment, or [`FleetError::NotReady`] with what still
    /// blocks it.
    pub async fn wait_ready(&self, sysid: u8) -> Result<VehicleSnapshot, FleetError> {
        self.require(sysid)?;
        let wait = self.cfg.ops.arm_ready;
        let clock = self.clock.clone();
        match self
            .wait_until(sysid, wait, |s| s.arm_blockers(clock.now()).is_empty())
            .await
        {
            Ok(v) => Ok(v),
            Err(last) => Err(FleetError::NotReady {
                sysid,
                waited_s: wait.as_secs_f64(),
                reasons: last
                    .map(|s| s.arm_blockers(self.clock.now()))
                    .unwrap_or_else(|| vec!["vehicle lost".into()]),
            }),
        }
    }

    /// Arm: wait until the vehicle is really ready ([`FleetHandle::wait_ready`]), send
    /// the arm command, and wait for the heartbeat to show armed.
    pub async fn arm(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if v.armed {
            return Ok(());
        }
        self.wait_ready(sysid).await?;
        let ep = Endpoint::new(sysid, v.compid);
        match self.command(v.flavour.arm_command(ep, true)).await {
            Ok(_) => {}
            Err(FleetError::Command { error, .. }) => {
                let prearm = self
                    .vehicle(sysid)
                    .and_then(|s| s.prearm_text)
                    .map(|t| t.text);
                return Err(FleetError::ArmRefused {
                    sysid,
                    error,
                    prearm,
                });
            }
            Err(e) => return Err(e),
        }
        let timeout = self.cfg.ops.arm_confirm;
        self.wait_until(sysid, timeout, |s| s.armed)
            .await
            .map(|_| ())
            .map_err(|_| FleetError::NotConfirmed {
                sysid,
                what: "armed".into(),
                waited_s: timeout.as_secs_f64(),
                now: "disarmed".into(),
            })
    }

    /// Disarm and wait for the heartbeat to show it.
    pub async fn disarm(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if !v.armed {
            return Ok(());
        }
        let ep = Endpoint::new(sysid, v.compid);
        self.command(v.flavour.arm_command(ep, false)).await?;
        let timeout = self.cfg.ops.arm_confirm;
        self.wait_until(sysid, timeout, |s| !s.armed)
            .await
            .map(|_| ())
            .map_err(|_| FleetError::NotConfirmed {
                sysid,
                what: "disarmed".into(),
                waited_s: timeout.as_secs_f64(),
                now: "armed".into(),
            })
    }

    /// Carry out flavour steps in order.
    pub async fn run_steps(&self, sysid: u8, steps: Vec<Step>) -> Result<(), FleetError> {
        for step in steps {
            match step {
                Step::SetMode(mode) => {
                    let v = self.require(sysid)?;
                    self.set_mode_to(&v, mode).await?;
                }
                Step::Arm => self.arm(sysid).await?,
                Step::Command(c) => {
                    self.command(c).await?;
                }
                Step::Send(m) => {
                    self.send(*m).await?;
                }
            }
        }
        Ok(())
    }

    /// Arm and take off to `alt` metres above home, in the way this autopilot wants
    /// (ArduCopter: GUIDED, arm, NAV_TAKEOFF; PX4: arm, NAV_TAKEOFF with AMSL altitude).
    /// Returns when the take-off command is accepted.
    ///
    /// A disarmed vehicle is first waited for until it is ready to arm
    /// ([`FleetHandle::wait_ready`]), before the first step and not only before arming
    /// (for the first 15–30 s after boot and after every battery swap it is not): a mode
    /// that needs a position may be refused until the estimate is good (PX4's mode
    /// requirements apply disarmed too; ArduCopter's `Copter::set_mode` takes GUIDED
    /// disarmed but the arming that follows fails), and PX4's take-off altitude is AMSL, so
    /// home must be known before the steps are built.
    pub async fn takeoff(&self, sysid: u8, alt: f32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let v = if v.armed {
            v
        } else {
            self.wait_ready(sysid).await?
        };
        let ep = Endpoint::new(sysid, v.compid);
        let steps = v
            .flavour
            .takeoff(ep, alt, v.home.map(|h| h.alt_amsl))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Go to (`lat`, `lon`) degrees at `alt` metres above home now (DO_REPOSITION; for
    /// ArduPilot builds without it, GUIDED + SET_POSITION_TARGET_GLOBAL_INT).
    pub async fn goto(&self, sysid: u8, lat: f64, lon: f64, alt: f32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let ep = Endpoint::new(sysid, v.compid);
        let (lat_e7, lon_e7) = (
            crate::mission::item::deg_to_e7(lat),
            crate::mission::item::deg_to_e7(lon),
        );
        let steps = v
            .flavour
            .goto(ep, lat_e7, lon_e7, alt, v.home.map(|h| h.alt_amsl))
            .map_err(Self::flavour_err(sysid))?;
        match self.run_steps(sysid, steps).await {
            Err(FleetError::Command {
                error: CommandError::Unsupported { .. } | CommandError::IntOnly { .. },
                ..
            }) if v.flavour.home_item() => {
                let steps = v
                    .flavour
                    .goto_fallback(ep, lat_e7, lon_e7, alt)
                    .map_err(Self::flavour_err(sysid))?;
                self.run_steps(sysid, steps).await
            }
            r => r,
        }
    }

    /// Turn vehicle `sysid` to the absolute heading `yaw_deg` (degrees clockwise from north)
    /// while it holds (`lat`, `lon`) at `alt` m above home: PX4 with a DO_REPOSITION that
    /// carries the yaw, ArduPilot with CONDITION_YAW (after the go-to that put it there).
    pub async fn face(
        &self,
        sysid: u8,
        lat: f64,
        lon: f64,
        alt: f32,
        yaw_deg: f32,
    ) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let ep = Endpoint::new(sysid, v.compid);
        let steps = if v.flavour.autopilot == Autopilot::ArduPilot {
            v.flavour.set_yaw(ep, yaw_deg)
        } else {
            v.flavour.goto_facing(
                ep,
                crate::mission::item::deg_to_e7(lat),
                crate::mission::item::deg_to_e7(lon),
                alt,
                v.home.map(|h| h.alt_amsl),
                Some(yaw_deg),
            )
        }
        .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Stop and hold where the vehicle is now (its autopilot's hold mode,
    /// [`crate::proto::flavour::Flavour::pause`]).
    pub async fn pause(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let steps = v.flavour.pause().map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Return to launch.
    pub async fn rtl(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let steps = v
            .flavour
            .rtl(Endpoint::new(sysid, v.compid))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Land where the vehicle is.
    pub async fn land(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let steps = v
            .flavour
            .land(Endpoint::new(sysid, v.compid))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Reboot the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, param1 = 1; both autopilots
    /// refuse it armed) and wait until it has rebooted and finished booting: its heartbeat
    /// or boot clock shows the reboot ([`VehicleSnapshot::reboots`]), then
    /// [`FleetHandle::wait_booted`]. Returns how long that took on the fleet's clock. Real
    /// vehicles may answer the command or go silent before the ACK gets out (ArduPilot
    /// SITL re-executes itself at once): a missing ACK is not an error when the reboot is
    /// then seen.
    pub async fn reboot(&self, sysid: u8) -> Result<Duration, FleetError> {
        let t0 = self.clock.now();
        let before = self.require(sysid)?.reboots;
        self.send_reboot(sysid).await?;
        let wait = self.cfg.ops.boot_wait;
        self.wait_until(sysid, wait, |s| s.reboots > before)
            .await
            .map_err(|_| FleetError::NotConfirmed {
                sysid,
                what: "a reboot".into(),
                waited_s: wait.as_secs_f64(),
                now: "the same boot".into(),
            })?;
        self.wait_booted(sysid).await?;
        Ok(self.clock.now().saturating_since(t0))
    }

    /// Send MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (reboot the autopilot) and return once it is
    /// acknowledged — or not answered, as when the autopilot goes down before its ACK gets
    /// out ([`FleetHandle::reboot`] also waits for it to come back).
    pub async fn send_reboot(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let cmd = Command::long(
            Endpoint::new(sysid, v.compid),
            MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        match self.command(cmd).await {
            Ok(_)
            | Err(FleetError::Command {
                error: CommandError::Timeout { .. },
                ..
            }) => Ok(()),
            Err(e) => Err(e),
        }
    }

    /// Start the uploaded mission (MAV_CMD_MISSION_START; the vehicle must be armed, and
    /// airborne if it flies — see [`FleetHandle::takeoff`]).
    pub async fn start_mission(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        self.reset_progress(sysid).await?;
        let steps = v
            .flavour
            .start_mission(Endpoint::new(sysid, v.compid))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Take one picture: MAV_CMD_IMAGE_START_CAPTURE to the vehicle's camera component when
    /// one was heard (the MAVLink camera protocol), otherwise MAV_CMD_DO_DIGICAM_CONTROL to
    /// the autopilot (param5 = 1: shoot), which ArduPilot's AP_Camera and PX4's
    /// camera_trigger handle. `seq` numbers the image (IMAGE_START_CAPTURE param4).
    pub async fn capture_image(&self, sysid: u8, seq: u32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let cmd = match v.camera_compid {
            Some(c) => Command::long(
                Endpoint::new(sysid, c),
                MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                [0.0, 0.0, 1.0, seq as f32, f32::NAN, f32::NAN, f32::NAN],
            ),
            None => Command::long(
                Endpoint::new(sysid, v.compid),
                MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
                [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            ),
        };
        self.command(cmd).await.map(|_| ())
    }

    /// The default camera component id, for callers building their own camera commands.
    pub const CAMERA_COMPID: u8 = CAMERA_COMPID;

    /// Whether vehicle `sysid` flies (copter) rather than drives.
    pub fn flies(&self, sysid: u8) -> bool {
        self.vehicle(sysid)
            .is_some_and(|v| v.flavour.flies() && v.flavour.class != VehicleClass::Other)
    }

    /// Stop the fleet task (links stop when the last handle is dropped).
    pub async fn shutdown(&self) {
        let (tx, rx) = oneshot::channel();
        if self.tx.send(Request::Shutdown { reply: tx }).await.is_ok() {
            let _ = rx.await;
        }
    }

    /// Send raw bytes on link `link` (tests: a third party's frame).
    pub fn send_raw(&self, link: LinkId, bytes: Vec<u8>) -> bool {
        self.links.get(link).is_some_and(|l| l.send_raw(bytes))
    }

    /// The header a frame from this GCS carries (sequence 0).
    pub fn gcs_header(&self) -> MavHeader {
        MavHeader {
            system_id: u32::from(self.cfg.gcs.sysid),
            component_id: self.cfg.gcs.compid,
            sequence: 0,
        }
    }
}
