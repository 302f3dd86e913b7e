//! The fleet actor: one task owning every vehicle's state and protocol machines, and a
//! cloneable [`FleetHandle`] that the CLI, the TUI and the mission runners use.
//!
//! Shape (mini-redis style, docs/architecture.md, "Layers"): the task owns its state; requests arrive on an
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
//! * Telemetry rates are requested when a vehicle appears and after a reboot, chosen to fit
//!   the vehicle's link (`telemetry.rs`, [`fleetmap_core::proto::telemetry`]):
//!   MAV_CMD_SET_MESSAGE_INTERVAL for the messages we display (as QGroundControl's
//!   `Vehicle::_setMessageInterval` and MAVSDK do), plus REQUEST_DATA_STREAM for ArduPilot,
//!   whose serial links stream only what SRn_* parameters or this request ask for
//!   (QGroundControl `APMFirmwarePlugin::initializeStreamRates`, MAVProxy `--streamrate`);
//!   on a telemetry radio only the messages shown, within the radio's budget, and what the
//!   vehicle streams unasked is stopped.
//! * Operations that take several steps (arm after the readiness checks, take off in the
//!   right mode, go to, return, land, fly a mission) are composed on the handle from the
//!   actor's primitives (command with ACK, mission operation, snapshot waits), each step
//!   with its own timeout and typed error.
//!
//! Files: `actor.rs` (the task, its state and event loop), `vehicle_link.rs` (each vehicle's
//! link: budget, telemetry plan, radio report, bytes, the uplink queue), `telemetry.rs` (the
//! actor's telemetry requests, radio reports and uplinks), `handle.rs` ([`FleetHandle`]: the
//! async API and the actor's primitives), `ops.rs` (the composed operations), `error.rs`
//! ([`FleetError`] and `FleetError::is_transient`), `state.rs` (snapshots).

mod actor;
mod error;
mod handle;
mod ops;
pub(crate) use ops::capture_command;
mod state;
mod telemetry;
mod vehicle_link;

pub use error::{FleetError, StateSeen};
pub use handle::FleetHandle;
pub use state::{
    FleetSnapshot, GeoPoint, LinkQuality, RadioReport, StatusText, SysidConflict, VehicleSnapshot,
};

use self::actor::Actor;
use fleetmap_core::budget::LinkBudget;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::CommandConfig;
use fleetmap_core::proto::command::CommandSender;
use fleetmap_core::proto::heartbeat::Liveness;
use fleetmap_core::proto::heartbeat::LivenessConfig;
use fleetmap_core::proto::mission::MissionConfig;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::codec::Frame;
use fleetmap_io::link::transport::LinkError;
use fleetmap_io::link::transport::LinkEvent;
use fleetmap_io::link::transport::LinkHandle;
use fleetmap_io::link::transport::LinkId;
use fleetmap_io::link::transport::LinkOptions;
use fleetmap_io::link::transport::open_link;
use fleetmap_io::watch;
use std::collections::BTreeMap;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::broadcast;
use tokio::sync::mpsc;

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
    /// What every vehicle's link carries, when the operator said (`--link`, a mission
    /// file's `link`); `None`: unlimited until a radio reports itself on a vehicle's link
    /// (`fleet::telemetry`).
    pub budget: Option<LinkBudget>,
    /// What one vehicle's link carries, when said for that vehicle (a mission file's
    /// `[[vehicles]] link`); over `budget`.
    pub vehicle_budgets: BTreeMap<u8, LinkBudget>,
    /// The GCS answers the vehicles' TERRAIN_REQUESTs (`--terrain DIR`, `app::terrain`):
    /// an ArduPilot vehicle on a radio is asked for them, and they are never stopped
    /// ([`StreamPlan::for_link_terrain`](fleetmap_core::proto::telemetry::StreamPlan::for_link_terrain)).
    pub terrain: bool,
    /// Snapshot publication period.
    pub snapshot_period: Duration,
    /// Timeouts of the composed operations.
    pub ops: OpsConfig,
}

impl FleetConfig {
    /// The configuration for a GCS clock running `speedup` times faster than real time (a
    /// simulator at `--speedup`, whose time the fleet follows): every protocol timeout and
    /// the liveness window stretched by the whole speed-up, at most 25×, so that they keep
    /// their real-time length in wall time. Stretched less, they shrink to a few tens of wall
    /// milliseconds, which a loaded machine cannot keep: the runway demo at 20× with
    /// timeouts stretched only 4× saw 184 image captures time out and swapped batteries five
    /// times as often (docs/results/runway.md, "The demo's wall time"). The GCS heartbeat
    /// keeps its 1 Hz in the fleet's (simulated) time, which is what the autopilots check.
    /// A speed-up of 1 or less is [`FleetConfig::default`].
    pub fn at_speedup(speedup: f64) -> FleetConfig {
        let k = speedup.clamp(1.0, 25.0);
        let mut c = FleetConfig::default();
        c.command.timeout = c.command.timeout.mul_f64(k);
        c.command.in_progress_timeout = c.command.in_progress_timeout.mul_f64(k);
        c.mission.timeout = c.mission.timeout.mul_f64(k);
        c.mission.item_timeout = c.mission.item_timeout.mul_f64(k);
        c.liveness.lost_after = c.liveness.lost_after.mul_f64(k);
        c
    }
}

impl Default for FleetConfig {
    fn default() -> Self {
        FleetConfig {
            gcs: Endpoint::gcs(),
            mission: MissionConfig::default(),
            command: CommandConfig::default(),
            liveness: LivenessConfig::default(),
            request_streams: true,
            budget: None,
            vehicle_budgets: BTreeMap::new(),
            terrain: false,
            snapshot_period: Duration::from_millis(200),
            ops: OpsConfig::default(),
        }
    }
}

/// Timeouts of the composed operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OpsConfig {
    /// Wait for the heartbeat to show a new mode.
    pub(crate) mode_confirm: Duration,
    /// Wait for the vehicle to become ready to arm (GPS, EKF, home, pre-arm checks) before
    /// arming or taking off.
    pub(crate) arm_ready: Duration,
    /// Wait for the heartbeat to show armed / disarmed.
    pub(crate) arm_confirm: Duration,
    /// Wait for a vehicle that is still booting ([`VehicleSnapshot::booting`]) before an
    /// operation, and retry an operation it refused while booting, for at most this long.
    pub(crate) boot_wait: Duration,
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

/// A refusal this soon after a vehicle left boot still counts as a boot-time refusal (the
/// heartbeat that says it is up may be older than a reboot the fleet has not seen yet).
pub(crate) const BOOT_GRACE: Duration = Duration::from_secs(5);

/// Pause before an operation refused while booting is tried again.
const BOOT_RETRY: Duration = Duration::from_millis(500);

/// A received frame, as broadcast to subscribers.
#[derive(Clone, Debug)]
pub struct Incoming {
    /// The link it came on.
    pub link: LinkId,
    /// When its link received it, on the runtime's clock (virtual when the clock is paused).
    pub(crate) received: tokio::time::Instant,
    /// The frame (header, raw bytes, parsed message or why not).
    pub frame: Arc<Frame>,
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
        sysids: fleetmap_core::proto::sysid_conflict::SysidWatch::new(Default::default()),
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
