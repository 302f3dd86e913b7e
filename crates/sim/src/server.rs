//! The simulator's thin async shell: serves each simulated vehicle on its own MAVLink
//! endpoint over UDP or TCP, on a clock that may run faster than wall time.
//!
//! Endpoints, connection strings as MAVProxy writes them ([`fleetmap_io::link::ConnSpec`],
//! read by [`parse_connection`]):
//! - `udpout:HOST:PORT` (or `udp:HOST:PORT`, as a vehicle's `--out`) — every vehicle sends
//!   to HOST:PORT from its own socket (an ephemeral port, on loopback when HOST is this
//!   machine), as several SITL instances would, and listens for replies on it;
//! - `udpin:HOST:PORT` — vehicle k listens on HOST:(PORT + k − 1) and answers whoever spoke
//!   to it last;
//! - `tcpin:HOST:PORT` — vehicle k accepts TCP clients on HOST:(PORT + k − 1) and sends to
//!   all of them.
//!
//! One endpoint is shared out this way; or give one endpoint per vehicle. Captured images
//! are written (atomically, on tokio's blocking pool) to the image directory before the
//! frames that announce them are sent.
//!
//! The parts: this module's lock-step serve loop for simulated vehicles ([`serve`],
//! [`spawn`]); the sockets it opens (`sockets`); the in-process server ([`spawn_memory`]).
//! The camera for a real autopilot (`fleetmap camera`) has its own loop, in the camera crate
//! (`fleetmap_camera::serve`).

mod memory;
mod sockets;

pub use memory::spawn_memory;

use crate::harness::Sim;
use crate::pace::{Pacer, Speed, SpeedMeter};
use crate::tx_queue::{Expired, TxQueue};
use fleetmap_camera::serve::write_images;
use fleetmap_core::time::Time;
use fleetmap_io::clock::{MonotonicClock, SimTime};
use fleetmap_io::link::{ConnSpec, ConnSpecError};
use sockets::{Io, Received, io_err, open};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;
use thiserror::Error;
use tokio::sync::mpsc;

/// Errors of the socket server.
#[derive(Debug, Error)]
pub enum ServerError {
    /// A connection string is malformed.
    #[error(transparent)]
    Connection(#[from] ConnSpecError),
    /// A connection the simulator cannot serve (a TCP client, a serial port).
    #[error("the simulator serves udpin, udpout and tcpin connections, not {0:?}")]
    NotServed(String),
    /// A connection shared among vehicles runs out of ports.
    #[error("{connection}: vehicle {vehicle} would need a port above 65535")]
    PortRange {
        /// The shared connection string.
        connection: String,
        /// The vehicle (1-based) that has no port.
        vehicle: usize,
    },
    /// The number of endpoints does not match the vehicles.
    #[error("{endpoints} endpoints for {vehicles} vehicles: give one, or one per vehicle")]
    Count {
        /// Endpoints given.
        endpoints: usize,
        /// Vehicles.
        vehicles: usize,
    },
    /// A socket could not be opened.
    #[error("cannot open {what}")]
    Io {
        /// Which socket.
        what: String,
        /// Why.
        source: std::io::Error,
    },
}

/// Parse a connection string to serve vehicles on: `udpout:HOST:PORT`, `udpin:HOST:PORT` or
/// `tcpin:HOST:PORT` ([`ConnSpec`]). As a vehicle's `--out` (SITL, MAVProxy), `udp:HOST:PORT`
/// sends out: it is `udpout:`, where a GCS's `udp:` listens ([`ConnSpec`]'s `udpin:`).
/// A TCP client or a serial port is refused ([`ServerError::NotServed`]).
pub fn parse_connection(s: &str) -> Result<ConnSpec, ServerError> {
    let spec: ConnSpec = s.parse()?;
    let vehicle_out = s
        .split_once(':')
        .is_some_and(|(scheme, _)| scheme.eq_ignore_ascii_case("udp"));
    let spec = match spec {
        ConnSpec::UdpIn { host, port } if vehicle_out => {
            if port == 0 {
                return Err(ConnSpecError {
                    input: s.to_string(),
                    why: "udp (udpout) needs a non-zero port".into(),
                }
                .into());
            }
            ConnSpec::UdpOut { host, port }
        }
        other => other,
    };
    servable(&spec)?;
    Ok(spec)
}

/// Refuse the connections the simulator cannot serve: a TCP client, a serial port, an
/// in-process channel.
fn servable(spec: &ConnSpec) -> Result<(), ServerError> {
    match spec {
        ConnSpec::UdpIn { .. } | ConnSpec::UdpOut { .. } | ConnSpec::TcpIn { .. } => Ok(()),
        ConnSpec::Tcp { .. } | ConnSpec::Serial { .. } | ConnSpec::Memory { .. } => {
            Err(ServerError::NotServed(spec.to_string()))
        }
    }
}

/// The connection of vehicle number `k` (0-based) when `spec` is shared among vehicles:
/// `udpin:` and `tcpin:` on PORT + k (port 0: an ephemeral port for every vehicle), `udpout:`
/// the same peer for all. Refuses what the simulator cannot serve.
pub(crate) fn for_vehicle(spec: &ConnSpec, k: usize) -> Result<ConnSpec, ServerError> {
    servable(spec)?;
    let shift = |port: u16| -> Result<u16, ServerError> {
        if port == 0 {
            return Ok(0); // ephemeral ports for everyone
        }
        u16::try_from(k)
            .ok()
            .and_then(|k| port.checked_add(k))
            .ok_or_else(|| ServerError::PortRange {
                connection: spec.to_string(),
                vehicle: k + 1,
            })
    };
    Ok(match spec {
        ConnSpec::UdpIn { host, port } => ConnSpec::UdpIn {
            host: host.clone(),
            port: shift(*port)?,
        },
        ConnSpec::TcpIn { host, port } => ConnSpec::TcpIn {
            host: host.clone(),
            port: shift(*port)?,
        },
        other => other.clone(),
    })
}

/// Whose clock the GCS keeps, which decides how the simulated vehicles judge its link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GcsClock {
    /// Another process on the wall clock (`fleetmap run`, QGroundControl, MAVProxy): it
    /// heartbeats at 1 Hz of wall time, so the vehicles judge its link (PX4's COM_DL_LOSS_T)
    /// over as many more simulated seconds as the simulator achieves per wall second
    /// ([`crate::vehicle::VehicleConfig::gcs_time_scale`], updated as the speed changes).
    Wall,
    /// A fleet in this process on the simulator's own time
    /// ([`fleetmap_io::clock::MonotonicClock::following`] the [`SimTime`] of [`SimHandle::time`]):
    /// its heartbeats are 1 Hz of simulated time.
    Simulator,
}

/// Serving options.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// One endpoint shared by all vehicles, or one per vehicle.
    pub endpoints: Vec<ConnSpec>,
    /// The most simulated seconds per wall second (lock-step: slower when the machine cannot
    /// keep up, [`crate::pace`]), or as fast as it can.
    pub speed: Speed,
    /// Whose clock the GCS keeps.
    pub gcs: GcsClock,
    /// Directory the camera images are written to (None: images only over MAVLink).
    pub image_dir: Option<PathBuf>,
    /// Stop after this much simulated time (None: until shut down).
    pub duration_s: Option<f64>,
}

/// A bound vehicle endpoint, as reported when serving starts.
#[derive(Clone, Debug)]
pub struct Bound {
    /// Vehicle system id.
    pub sysid: u8,
    /// Its connection.
    pub endpoint: ConnSpec,
    /// The local address of its socket / listener.
    pub local: SocketAddr,
}

/// Shortest wait between two turns of sending while a vehicle's link has a backlog (its
/// bandwidth and age limit: [`TxQueue`]).
pub(crate) const UDP_PACE: Duration = Duration::from_millis(5);

/// How often the shell checks the speed it achieves (reports a shortfall, rescales the
/// vehicles' judgement of a wall-clock GCS), wall time.
pub(crate) const SPEED_CHECK: Duration = Duration::from_secs(5);

/// A speed below this share of the ceiling is reported as a shortfall.
const SHORTFALL: f64 = 0.9;

/// Simulated seconds per second of the GCS's clock: 1 for a GCS on the simulator's time,
/// the speed achieved (`achieved`, else the ceiling, else 1) for one on the wall clock.
pub fn gcs_time_scale(gcs: GcsClock, speed: Speed, achieved: Option<f64>) -> f64 {
    match gcs {
        GcsClock::Simulator => 1.0,
        GcsClock::Wall => achieved.or(speed.ceiling()).unwrap_or(1.0).max(1e-3),
    }
}

/// The lock-step core the socket and in-memory shells share: the simulation, its schedule,
/// the speed it achieves and the time it publishes. Simulated time advances in whole physics
/// steps ([`Sim::poll_timeout`]), never ahead of the schedule ([`Pacer`]); what the GCS sends
/// acts at the simulated time it arrives at.
struct Stepper {
    sim: Sim,
    start: Time,
    pacer: Pacer,
    meter: SpeedMeter,
    time: SimTime,
    end: Option<Time>,
}

impl Stepper {
    fn new(sim: Sim, speed: Speed, duration_s: Option<f64>) -> Stepper {
        let start = sim.now();
        Stepper {
            end: duration_s.map(|d| start + Duration::from_secs_f64(d.max(0.0))),
            start,
            pacer: Pacer::new(speed),
            meter: SpeedMeter::new(),
            time: SimTime::new(speed.ceiling()),
            sim,
        }
    }

    /// What the endpoint of vehicle `k` (index in [`Sim::sysids`]) received: it acts now,
    /// in simulated time.
    fn receive(&mut self, k: usize, bytes: &[u8]) {
        self.sim.send_bytes_at(k, bytes);
    }

    /// Let the vehicles answer what they received, at the current simulated time (a mission
    /// request or an ACK does not wait for the next physics step).
    fn deliver(&mut self) {
        let now = self.sim.now();
        self.sim.advance_to(now);
    }

    /// Step as far as the schedule allows at wall time `wall`: whole physics steps, not past
    /// the end.
    fn step(&mut self, wall: Time) {
        let mut limit = self.pacer.allowed(wall, self.sim.now());
        if let Some(e) = self.end {
            limit = limit.min(e);
        }
        while self.sim.poll_timeout() <= limit {
            let t = self.sim.poll_timeout();
            self.sim.advance_to(t);
        }
        if self.end.is_some_and(|e| e <= limit) {
            self.sim.advance_to(limit);
        }
    }

    /// Measure and publish where the simulation stands at wall time `wall`.
    fn record(&mut self, wall: Time) {
        self.meter.record(wall, self.sim.now());
        self.time.publish(
            Time::ZERO + self.sim.now().saturating_since(self.start),
            self.meter.current(),
        );
    }

    fn finished(&self) -> bool {
        self.end.is_some_and(|e| self.sim.now() >= e)
    }

    /// Wall time from `wall` until the next physics step is on the schedule (zero: now).
    fn wait(&self, wall: Time) -> Duration {
        self.pacer
            .wall_at(self.sim.poll_timeout())
            .map_or(Duration::ZERO, |w| w.saturating_since(wall))
    }
}

/// Sleep `d`, or with nothing to wait for, let the runtime's other tasks (the sockets, an
/// in-process GCS) run once.
async fn pause(d: Duration) {
    if d.is_zero() {
        tokio::task::yield_now().await;
    } else {
        tokio::time::sleep(d).await;
    }
}

/// Tells the log when the simulator runs short of its ceiling, once per episode, and keeps a
/// wall-clock GCS's link judged at the speed achieved.
#[derive(Debug, Default)]
struct SpeedWatch {
    checked_at: Option<Time>,
    short: bool,
}

impl SpeedWatch {
    fn check(&mut self, wall: Time, stepper: &mut Stepper, gcs: GcsClock) {
        if self
            .checked_at
            .is_some_and(|t| wall.saturating_since(t) < SPEED_CHECK)
        {
            return;
        }
        self.checked_at = Some(wall);
        let Some(now) = stepper.meter.current() else {
            return;
        };
        let speed = stepper.pacer.speed();
        stepper
            .sim
            .set_gcs_time_scale(gcs_time_scale(gcs, speed, Some(now)));
        let Some(ceiling) = speed.ceiling() else {
            return;
        };
        let short = now < SHORTFALL * ceiling;
        if short && !self.short {
            tracing::warn!(
                "simulator: running at {now:.1}× of the {ceiling}× asked: this machine cannot \
                 keep up, so simulated time runs slower (lock-step, as SITL; nothing is skipped)"
            );
        } else if !short && self.short {
            tracing::info!("simulator: back at {now:.1}× ({ceiling}× asked)");
        }
        self.short = short;
    }
}

/// What the simulator achieved over its whole run, for the log at its end.
fn log_totals(stepper: &Stepper) {
    let (sim, wall) = stepper.meter.totals();
    if let Some(x) = stepper.meter.overall() {
        tracing::info!(
            "simulator: {:.1} s simulated in {:.1} s, {x:.2}× ({} asked)",
            sim.as_secs_f64(),
            wall.as_secs_f64(),
            stepper.pacer.speed()
        );
    }
}

/// Serve `sim` until `shutdown` resolves (or the configured duration passes). `on_bound`
/// is called once every endpoint is open, with the simulator's published time (what a GCS in
/// this process follows, and where the speed achieved is read).
///
/// Lock-step: simulated time advances in whole physics steps, at most at `opts.speed`, and
/// not while a vehicle's outgoing link is backed up (`TxQueue::backlogged`) — on a busy
/// machine the simulator runs slower, as SITL does, rather than producing moments nobody
/// hears.
pub async fn serve<F>(
    sim: Sim,
    opts: ServeOptions,
    on_bound: impl FnOnce(&[Bound], &SimTime),
    shutdown: F,
) -> Result<Sim, ServerError>
where
    F: std::future::Future<Output = ()>,
{
    let sysids = sim.sysids();
    let (tx, mut rx) = mpsc::channel::<Received>(4096);
    let (bound, ios) = open(&sysids, &opts.endpoints, tx).await?;
    if let Some(dir) = &opts.image_dir {
        create_image_dir(dir).await?;
    }
    let mut stepper = Stepper::new(sim, opts.speed, opts.duration_s);
    stepper
        .sim
        .set_gcs_time_scale(gcs_time_scale(opts.gcs, opts.speed, None));
    on_bound(&bound, &stepper.time);
    tokio::pin!(shutdown);
    // the outgoing links are paced and aged on the wall clock (see `TxQueue`)
    let wall = MonotonicClock::new();
    let mut pending: Vec<TxQueue> = sysids.iter().map(|_| TxQueue::new()).collect();
    let mut watch = SpeedWatch::default();
    loop {
        // what arrived since the last turn acts at the current simulated time
        let mut got = false;
        while let Ok((k, bytes, _)) = rx.try_recv() {
            stepper.receive(k, &bytes);
            got = true;
        }
        if got {
            stepper.deliver();
        }
        let wall_now = wall.now();
        // a link that cannot carry what was produced holds the simulation back
        let held = pending.iter().any(TxQueue::backlogged);
        if !held {
            stepper.step(wall_now);
        }
        stepper.record(wall_now);
        watch.check(wall_now, &mut stepper, opts.gcs);
        // files first, so a CAMERA_IMAGE_CAPTURED never names a missing file
        let mut images = Vec::new();
        while let Some((_, img)) = stepper.sim.poll_image() {
            images.push(img);
        }
        if let Some(dir) = &opts.image_dir {
            write_images(dir, images).await;
        }
        while let Some((sysid, ev)) = stepper.sim.poll_event() {
            log_event(sysid, &ev);
        }
        let mut next_send: Option<Time> = None;
        let wall_now = wall.now();
        for (k, &sysid) in sysids.iter().enumerate() {
            let q = &mut pending[k];
            while let Some(d) = stepper.sim.recv_bytes_at(k) {
                q.push(wall_now, d);
            }
            match q.expire(wall_now) {
                Expired::None => {}
                Expired::Began(n) => tracing::warn!(
                    "simulator: vehicle {sysid}'s link is dropping datagrams older than {} ms \
                     ({n} now, {} in all)",
                    TxQueue::MAX_AGE.as_millis(),
                    q.dropped(),
                ),
                Expired::More(_) => {}
            }
            match &ios[k] {
                Io::Udp { sock, peer } => {
                    // Paced: a burst of images (hundreds of ENCAPSULATED_DATA datagrams)
                    // would overflow the receiver's socket buffer at once, which no real
                    // link does (a Wi-Fi camera link carries ~1–2 MB/s).
                    let to = peer.lock().ok().and_then(|p| *p);
                    q.refill(wall_now);
                    while let Some(d) = q.ready() {
                        if let Some(to) = to {
                            let _ = sock.try_send_to(d, to);
                        }
                        q.sent();
                    }
                    if let Some(t) = q.next_send(wall_now) {
                        next_send = Some(next_send.map_or(t, |n| n.min(t)));
                    }
                }
                Io::Tcp { out } => {
                    for d in q.take_all() {
                        let _ = out.send(d);
                    }
                }
            }
        }
        if stepper.finished() {
            log_totals(&stepper);
            return Ok(stepper.sim);
        }
        let wall_now = wall.now();
        let held = pending.iter().any(TxQueue::backlogged);
        let mut wait = if held {
            UDP_PACE
        } else {
            stepper.wait(wall_now)
        };
        if let Some(t) = next_send {
            wait = wait.min(t.saturating_since(wall_now).max(UDP_PACE));
        }
        tokio::select! {
            r = rx.recv() => {
                if let Some((k, bytes, _)) = r {
                    stepper.receive(k, &bytes);
                }
            }
            _ = pause(wait) => {}
            _ = &mut shutdown => {
                log_totals(&stepper);
                return Ok(stepper.sim);
            }
        }
    }
}

/// A simulation served on a background task, by either server: on sockets ([`spawn`], inside
/// a [`SimHandle`]) or over in-process links ([`spawn_memory`]). Whoever started it stops it
/// the same way whichever server it is.
#[derive(Debug)]
pub struct SimTask {
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<Sim, ServerError>>,
}

impl SimTask {
    fn new(
        stop: tokio::sync::oneshot::Sender<()>,
        task: tokio::task::JoinHandle<Result<Sim, ServerError>>,
    ) -> SimTask {
        SimTask {
            stop: Some(stop),
            task,
        }
    }

    /// Stop serving, wait for the task to end and get the simulation back (for
    /// inspection); an error if the serve loop failed or its task panicked.
    pub async fn stop(mut self) -> Result<Sim, ServerError> {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        match self.task.await {
            Ok(r) => r,
            Err(e) => Err(ServerError::Io {
                what: "simulator task".into(),
                source: std::io::Error::other(e.to_string()),
            }),
        }
    }
}

/// A simulation served on sockets in the background (see [`spawn`]).
#[derive(Debug)]
pub struct SimHandle {
    /// Where each vehicle can be reached.
    pub bound: Vec<Bound>,
    /// The simulator's time and speed as it publishes them.
    pub time: SimTime,
    /// The serving task (stopped by [`SimHandle::stop`], or on its own once the rest of the
    /// handle is not needed).
    pub task: SimTask,
}

impl SimHandle {
    /// A clock on the simulator's time, for a fleet in this process
    /// ([`GcsClock::Simulator`]).
    pub fn clock(&self) -> MonotonicClock {
        MonotonicClock::following(&self.time)
    }

    /// Stop serving and get the simulation back (for inspection): [`SimTask::stop`].
    pub async fn stop(self) -> Result<Sim, ServerError> {
        self.task.stop().await
    }
}

/// Serve `sim` on a background task of the current tokio runtime; returns once every
/// endpoint is open. This is how `fleetmap demo` and end-to-end tests run the simulator
/// in-process: e.g. `udpin:127.0.0.1:0` gives each vehicle an ephemeral port (read them from
/// [`SimHandle::bound`]) that a GCS link reaches with `udpout:` to that address.
pub async fn spawn(sim: Sim, opts: ServeOptions) -> Result<SimHandle, ServerError> {
    let (bound_tx, bound_rx) = tokio::sync::oneshot::channel();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let task = tokio::spawn(async move {
        serve(
            sim,
            opts,
            move |b, time| {
                let _ = bound_tx.send((b.to_vec(), time.clone()));
            },
            async move {
                let _ = stop_rx.await;
            },
        )
        .await
    });
    match bound_rx.await {
        Ok((bound, time)) => Ok(SimHandle {
            bound,
            time,
            task: SimTask::new(stop_tx, task),
        }),
        Err(_) => match task.await {
            Ok(Err(e)) => Err(e),
            _ => Err(ServerError::Io {
                what: "simulator task".into(),
                source: std::io::Error::other("the simulator stopped before serving"),
            }),
        },
    }
}

/// Create the image directory `dir` (and its parents) on tokio's blocking pool.
async fn create_image_dir(dir: &Path) -> Result<(), ServerError> {
    let d = dir.to_path_buf();
    let made = tokio::task::spawn_blocking(move || std::fs::create_dir_all(&d))
        .await
        .unwrap_or_else(|e| Err(std::io::Error::other(e)));
    made.map_err(io_err(dir.display().to_string()))
}

/// Log a vehicle event: failsafes and fence breaches as warnings (what a field team must hear
/// of), the rest (boots, arming, landings) at info.
fn log_event(sysid: u8, ev: &crate::vehicle::VehicleEvent) {
    use crate::vehicle::VehicleEvent as E;
    match ev {
        E::FaultStarted(f) => {
            tracing::warn!("simulated vehicle {sysid}: scheduled fault {f} starts")
        }
        E::FaultEnded(f) => tracing::warn!("simulated vehicle {sysid}: scheduled fault {f} ends"),
        E::FenceBreached { .. } | E::BatteryFailsafe(_) => {
            tracing::warn!("simulated vehicle {sysid}: {ev:?}")
        }
        _ => tracing::info!("simulated vehicle {sysid}: {ev:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn connections() {
        let p = |s: &str| parse_connection(s).unwrap();
        let hp = |h: &str, port| (h.to_string(), port);
        assert_eq!(
            p("udpout:127.0.0.1:14550"),
            ConnSpec::UdpOut {
                host: "127.0.0.1".into(),
                port: 14550
            }
        );
        // a vehicle's `udp:` sends out, as SITL's and MAVProxy's `--out udp:`
        assert_eq!(p("udp:127.0.0.1:14550"), p("udpout:127.0.0.1:14550"));
        assert_eq!(
            p("UDP:127.0.0.1:14550").to_string(),
            "udpout:127.0.0.1:14550"
        );
        assert_eq!(
            for_vehicle(&p("tcpin:0.0.0.0:5760"), 2).unwrap(),
            ConnSpec::TcpIn {
                host: "0.0.0.0".into(),
                port: 5762
            }
        );
        let ConnSpec::UdpIn { host, port } = for_vehicle(&p("udpin:[::1]:14550"), 1).unwrap()
        else {
            panic!("not udpin")
        };
        assert_eq!((host, port), hp("::1", 14551));
        assert_eq!(
            for_vehicle(&p("udpin:127.0.0.1:0"), 5).unwrap(),
            p("udpin:127.0.0.1:0")
        );
        assert_eq!(
            for_vehicle(&p("udpout:localhost:14550"), 3).unwrap(),
            ConnSpec::UdpOut {
                host: "localhost".into(),
                port: 14550
            }
        );
        assert!(matches!(
            for_vehicle(&p("udpin:127.0.0.1:65535"), 1),
            Err(ServerError::PortRange { vehicle: 2, .. })
        ));
        // malformed
        for bad in [
            "udpin:14550",
            "udpin::x",
            "udp:host:0",
            "udpout:host:0",
            "carrier:pigeon:1",
        ] {
            let e = parse_connection(bad).unwrap_err();
            assert!(matches!(e, ServerError::Connection(_)), "{bad}: {e}");
        }
        // well-formed, but not served by the simulator
        for refused in ["serial:/dev/ttyUSB0:57600", "tcp:localhost:5760"] {
            let e = parse_connection(refused).unwrap_err();
            assert!(matches!(e, ServerError::NotServed(_)), "{refused}: {e}");
            let msg = e.to_string();
            assert!(
                msg.contains("serves udpin, udpout and tcpin") && msg.contains(refused),
                "{msg}"
            );
        }
        let tcp = ConnSpec::Tcp {
            host: "localhost".into(),
            port: 5760,
        };
        assert!(matches!(
            for_vehicle(&tcp, 0),
            Err(ServerError::NotServed(_))
        ));
    }
}
