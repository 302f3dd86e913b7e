//! The simulator's thin async shell: serves each simulated vehicle on its own MAVLink
//! endpoint over UDP or TCP, on a clock that may run faster than wall time.
//!
//! Endpoints, as MAVProxy writes them:
//! - `udpout:HOST:PORT` — every vehicle sends to HOST:PORT from its own socket (an ephemeral
//!   port, on loopback when HOST is this machine), as several SITL instances would, and
//!   listens for replies on it;
//! - `udpin:HOST:PORT` — vehicle k listens on HOST:(PORT + k − 1) and answers whoever spoke
//!   to it last;
//! - `tcpin:HOST:PORT` — vehicle k accepts TCP clients on HOST:(PORT + k − 1) and sends to
//!   all of them.
//!
//! One endpoint is shared out this way; or give one endpoint per vehicle. Captured images
//! are written (atomically) to the image directory before the frames that announce them are
//! sent.

use crate::clock::{MonotonicClock, SimTime};
use crate::sim::harness::Sim;
use crate::sim::pace::{Pacer, Speed, SpeedMeter};
use crate::sim::tx_queue::{Expired, TxQueue};
use crate::time::Time;
use std::collections::{BTreeMap, HashMap};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use thiserror::Error;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, UdpSocket};
use tokio::sync::mpsc;

/// Errors of the socket server.
#[derive(Debug, Error)]
pub enum ServerError {
    /// A connection string is malformed.
    #[error(
        "invalid endpoint {0:?}: expected udpout:HOST:PORT, udpin:HOST:PORT or tcpin:HOST:PORT"
    )]
    Endpoint(String),
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

/// How one vehicle is reached.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Endpoint {
    /// Send to this address from an own socket.
    UdpOut(String),
    /// Listen on this address.
    UdpIn(String),
    /// Accept TCP clients on this address.
    TcpIn(String),
}

impl Endpoint {
    /// Parse `udpout:HOST:PORT`, `udpin:HOST:PORT` or `tcpin:HOST:PORT`.
    pub fn parse(s: &str) -> Result<Endpoint, ServerError> {
        let (kind, addr) = s
            .split_once(':')
            .ok_or_else(|| ServerError::Endpoint(s.to_string()))?;
        let (host, port) = addr
            .rsplit_once(':')
            .ok_or_else(|| ServerError::Endpoint(s.to_string()))?;
        if host.is_empty() || port.parse::<u16>().is_err() {
            return Err(ServerError::Endpoint(s.to_string()));
        }
        match kind {
            "udpout" | "udp" => Ok(Endpoint::UdpOut(addr.to_string())),
            "udpin" => Ok(Endpoint::UdpIn(addr.to_string())),
            "tcpin" => Ok(Endpoint::TcpIn(addr.to_string())),
            _ => Err(ServerError::Endpoint(s.to_string())),
        }
    }

    /// The endpoint of vehicle number `k` (0-based) when this one is shared among vehicles.
    pub fn for_vehicle(&self, k: usize) -> Result<Endpoint, ServerError> {
        let shift = |a: &str| -> Result<String, ServerError> {
            let (h, p) = a
                .rsplit_once(':')
                .ok_or_else(|| ServerError::Endpoint(a.to_string()))?;
            let p: u16 = p
                .parse()
                .map_err(|_| ServerError::Endpoint(a.to_string()))?;
            if p == 0 {
                return Ok(a.to_string()); // ephemeral ports for everyone
            }
            let p = p
                .checked_add(k as u16)
                .ok_or_else(|| ServerError::Endpoint(a.to_string()))?;
            Ok(format!("{h}:{p}"))
        };
        Ok(match self {
            Endpoint::UdpOut(a) => Endpoint::UdpOut(a.clone()),
            Endpoint::UdpIn(a) => Endpoint::UdpIn(shift(a)?),
            Endpoint::TcpIn(a) => Endpoint::TcpIn(shift(a)?),
        })
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Endpoint::UdpOut(a) => write!(f, "udpout:{a}"),
            Endpoint::UdpIn(a) => write!(f, "udpin:{a}"),
            Endpoint::TcpIn(a) => write!(f, "tcpin:{a}"),
        }
    }
}

/// Whose clock the GCS keeps, which decides how the simulated vehicles judge its link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GcsClock {
    /// Another process on the wall clock (`fleetmap run`, QGroundControl, MAVProxy): it
    /// heartbeats at 1 Hz of wall time, so the vehicles judge its link (PX4's COM_DL_LOSS_T)
    /// over as many more simulated seconds as the simulator achieves per wall second
    /// ([`crate::sim::vehicle::VehicleConfig::gcs_time_scale`], updated as the speed changes).
    Wall,
    /// A fleet in this process on the simulator's own time
    /// ([`crate::clock::MonotonicClock::following`] the [`SimTime`] of [`SimHandle::time`]):
    /// its heartbeats are 1 Hz of simulated time.
    Simulator,
}

/// Serving options.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// One endpoint shared by all vehicles, or one per vehicle.
    pub endpoints: Vec<Endpoint>,
    /// The most simulated seconds per wall second (lock-step: slower when the machine cannot
    /// keep up, [`crate::sim::pace`]), or as fast as it can.
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
    /// Its endpoint.
    pub endpoint: Endpoint,
    /// The local address of its socket / listener.
    pub local: SocketAddr,
}

enum Io {
    Udp {
        sock: Arc<UdpSocket>,
        peer: Arc<Mutex<Option<SocketAddr>>>,
    },
    Tcp {
        out: mpsc::UnboundedSender<Vec<u8>>,
    },
}

fn io_err(what: String) -> impl FnOnce(std::io::Error) -> ServerError {
    move |source| ServerError::Io { what, source }
}

async fn resolve(a: &str) -> Result<SocketAddr, ServerError> {
    tokio::net::lookup_host(a)
        .await
        .map_err(io_err(a.to_string()))?
        .next()
        .ok_or_else(|| ServerError::Endpoint(a.to_string()))
}

/// What an endpoint received: (vehicle index, bytes, the UDP sender's address; None for TCP).
type Received = (usize, Vec<u8>, Option<SocketAddr>);

/// Open every vehicle's endpoint. Returns the bound sockets (for printing) and the I/O
/// plumbing; received datagrams / TCP bytes arrive on `rx` as [`Received`].
async fn open(
    sysids: &[u8],
    endpoints: &[Endpoint],
    tx: mpsc::Sender<Received>,
) -> Result<(Vec<Bound>, Vec<Io>), ServerError> {
    let n = sysids.len();
    if endpoints.len() != 1 && endpoints.len() != n {
        return Err(ServerError::Count {
            endpoints: endpoints.len(),
            vehicles: n,
        });
    }
    let mut bound = Vec::new();
    let mut ios = Vec::new();
    for (k, &sysid) in sysids.iter().enumerate() {
        let ep = if endpoints.len() == 1 {
            endpoints[0].for_vehicle(k)?
        } else {
            endpoints[k].clone()
        };
        match &ep {
            Endpoint::UdpOut(a) | Endpoint::UdpIn(a) => {
                let target = resolve(a).await?;
                let (bind, peer) = match &ep {
                    Endpoint::UdpOut(_) => {
                        (crate::link::transport::local_for(target), Some(target))
                    }
                    _ => (target, None),
                };
                let sock = Arc::new(
                    UdpSocket::bind(bind)
                        .await
                        .map_err(io_err(ep.to_string()))?,
                );
                crate::link::transport::enlarge_recv_buffer(&sock);
                let local = sock.local_addr().map_err(io_err(ep.to_string()))?;
                let peer = Arc::new(Mutex::new(peer));
                let fixed = matches!(ep, Endpoint::UdpOut(_));
                let (s2, p2, tx2) = (sock.clone(), peer.clone(), tx.clone());
                tokio::spawn(async move {
                    let mut buf = vec![0u8; 65536];
                    loop {
                        match s2.recv_from(&mut buf).await {
                            Ok((len, from)) => {
                                if !fixed && let Ok(mut p) = p2.lock() {
                                    *p = Some(from);
                                }
                                if tx2
                                    .send((k, buf[..len].to_vec(), Some(from)))
                                    .await
                                    .is_err()
                                {
                                    return;
                                }
                            }
                            // ICMP port unreachable on Linux surfaces here; keep listening
                            Err(_) => tokio::task::yield_now().await,
                        }
                    }
                });
                bound.push(Bound {
                    sysid,
                    endpoint: ep.clone(),
                    local,
                });
                ios.push(Io::Udp { sock, peer });
            }
            Endpoint::TcpIn(a) => {
                let addr = resolve(a).await?;
                let listener = TcpListener::bind(addr)
                    .await
                    .map_err(io_err(ep.to_string()))?;
                let local = listener.local_addr().map_err(io_err(ep.to_string()))?;
                let (out_tx, mut out_rx) = mpsc::unbounded_channel::<Vec<u8>>();
                let (client_tx, mut client_rx) = mpsc::unbounded_channel();
                let tx2 = tx.clone();
                tokio::spawn(async move {
                    loop {
                        let Ok((stream, _)) = listener.accept().await else {
                            continue;
                        };
                        let _ = stream.set_nodelay(true);
                        let (mut r, w) = stream.into_split();
                        if client_tx.send(w).is_err() {
                            return;
                        }
                        let tx3 = tx2.clone();
                        tokio::spawn(async move {
                            let mut buf = vec![0u8; 8192];
                            loop {
                                match r.read(&mut buf).await {
                                    Ok(0) | Err(_) => return,
                                    Ok(n) => {
                                        if tx3.send((k, buf[..n].to_vec(), None)).await.is_err() {
                                            return;
                                        }
                                    }
                                }
                            }
                        });
                    }
                });
                tokio::spawn(async move {
                    let mut clients: Vec<tokio::net::tcp::OwnedWriteHalf> = Vec::new();
                    loop {
                        tokio::select! {
                            c = client_rx.recv() => match c {
                                Some(c) => clients.push(c),
                                None => return,
                            },
                            d = out_rx.recv() => {
                                let Some(d) = d else { return };
                                let mut alive = Vec::new();
                                for mut c in clients.drain(..) {
                                    if c.write_all(&d).await.is_ok() {
                                        alive.push(c);
                                    }
                                }
                                clients = alive;
                            }
                        }
                    }
                });
                bound.push(Bound {
                    sysid,
                    endpoint: ep.clone(),
                    local,
                });
                ios.push(Io::Tcp { out: out_tx });
            }
        }
    }
    Ok((bound, ios))
}

/// Shortest wait between two turns of sending while a vehicle's link has a backlog (its
/// bandwidth and age limit: [`TxQueue`]).
pub const UDP_PACE: Duration = Duration::from_millis(5);

/// How often the shell checks the speed it achieves (reports a shortfall, rescales the
/// vehicles' judgement of a wall-clock GCS), wall time.
pub const SPEED_CHECK: Duration = Duration::from_secs(5);

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

    /// What vehicle `sysid`'s endpoint received: it acts now, in simulated time.
    fn receive(&mut self, sysid: u8, bytes: &[u8]) {
        self.sim.send_bytes(sysid, bytes);
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
/// not while a vehicle's outgoing link is backed up ([`TxQueue::backlogged`]) — on a busy
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
        std::fs::create_dir_all(dir).map_err(io_err(dir.display().to_string()))?;
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
            stepper.receive(sysids[k], &bytes);
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
        while let Some((_, img)) = stepper.sim.poll_image() {
            if let Some(dir) = &opts.image_dir {
                let path = dir.join(&img.file_name);
                if let Err(e) = crate::store::atomic_write(&path, &img.jpeg) {
                    tracing::warn!("cannot write image {}: {e}", path.display());
                }
            }
        }
        while let Some((sysid, ev)) = stepper.sim.poll_event() {
            log_event(sysid, &ev);
        }
        let mut next_send: Option<Time> = None;
        let wall_now = wall.now();
        for (k, &sysid) in sysids.iter().enumerate() {
            let q = &mut pending[k];
            while let Some(d) = stepper.sim.recv_bytes(sysid) {
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
                    stepper.receive(sysids[k], &bytes);
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

/// A simulation served in the background (see [`spawn`]).
#[derive(Debug)]
pub struct SimHandle {
    /// Where each vehicle can be reached.
    pub bound: Vec<Bound>,
    /// The simulator's time and speed as it publishes them.
    pub time: SimTime,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<Sim, ServerError>>,
}

impl SimHandle {
    /// A clock on the simulator's time, for a fleet in this process
    /// ([`GcsClock::Simulator`]).
    pub fn clock(&self) -> MonotonicClock {
        MonotonicClock::following(&self.time)
    }

    /// Stop serving and get the simulation back (for inspection).
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
            stop: Some(stop_tx),
            task,
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

/// Serve simulated cameras for real autopilots (see [`crate::sim::paired`]): listen on
/// `endpoint` (typically `udpin:` where a SITL or MAVProxy sends its telemetry), render an
/// image for every picture the autopilots take and answer as their camera components, on
/// the wall clock. Images go to `image_dir` (and over MAVLink if the camera config says so,
/// paced by the cameras themselves when [`crate::sim::camera::CameraConfig::transfer_rate_bps`]
/// is set). UDP datagrams are paced and aged as in [`serve`] ([`TxQueue`]); a datagram the
/// socket cannot take yet waits for the next turn.
/// What the cameras report ([`crate::sim::paired::PairedEvent`]) is logged: a stale pose
/// warns once per episode of refused captures, not once per capture.
pub async fn serve_paired<F>(
    mut cams: crate::sim::paired::PairedCameras,
    mut source: Option<crate::app::pictures::FolderSource>,
    endpoint: Endpoint,
    image_dir: Option<PathBuf>,
    duration_s: Option<f64>,
    on_bound: impl FnOnce(&[Bound]),
    shutdown: F,
) -> Result<crate::sim::paired::PairedCameras, ServerError>
where
    F: std::future::Future<Output = ()>,
{
    use crate::link::codec::Codec;
    /// Longest sleep between two camera steps (heartbeats, interval captures, requests for
    /// telemetry are due on this grid at worst).
    const STEP: std::time::Duration = std::time::Duration::from_millis(20);
    let (tx, mut rx) = mpsc::channel::<Received>(4096);
    let (bound, ios) = open(&[0], std::slice::from_ref(&endpoint), tx).await?;
    on_bound(&bound);
    if let Some(dir) = &image_dir {
        std::fs::create_dir_all(dir).map_err(io_err(dir.display().to_string()))?;
    }
    let clock = MonotonicClock::with_speedup(1.0);
    let unix0 = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let mut codec = Codec::new();
    let end = duration_s.map(|d| Time::ZERO + std::time::Duration::from_secs_f64(d.max(0.0)));
    // One outgoing queue per camera, each sent to the address its own autopilot was last
    // heard from (see `routes` below).
    let mut pending: BTreeMap<u8, TxQueue> = BTreeMap::new();
    // Where each vehicle's autopilot (component 1) was last heard from. Several autopilots
    // send to one `udpin` port (each copter's SERIAL1 in a SITL fleet): camera k's frames go
    // back to autopilot k, as a camera wired to its own autopilot's serial port would send
    // them. Sending everything to the last sender (as before) spread one camera's packets
    // over every autopilot: their paths differ in delay, so packets arrived out of order —
    // 29 reorderings in 120 pictures through four ArduCopter SITLs, and a packet that crossed
    // an image's DATA_TRANSMISSION_HANDSHAKE counted for the wrong image (pictures short of
    // packet 0, 1 or the last ones) — and requests for one autopilot's telemetry went to
    // another, which does not forward them back to the port they came from
    // (MAVLink_routing::check_and_forward), so a camera could wait minutes for a position.
    let mut routes: HashMap<u8, SocketAddr> = HashMap::new();
    tokio::pin!(shutdown);
    let result = loop {
        let now = Time::ZERO + std::time::Duration::from_micros(clock.now().as_micros());
        cams.step(now);
        while let Some(ev) = cams.poll_event() {
            log_paired_event(&ev);
        }
        // Pictures from outside: read on a blocking thread, one shot at a time.
        while let Some((sysid, shot)) = cams.poll_shot() {
            let picture = match source.take() {
                Some(mut src) => {
                    let r = tokio::task::spawn_blocking(move || {
                        let p = src.next_picture();
                        (src, p)
                    })
                    .await;
                    match r {
                        Ok((mut src, p)) => {
                            for s in src.skipped.drain(..) {
                                tracing::warn!("camera: picture skipped: {s}");
                            }
                            source = Some(src);
                            match p {
                                Ok(Some(p)) => Some(p.image),
                                Ok(None) => {
                                    tracing::warn!(
                                        "camera {sysid}: no new picture in the folder: capture {} failed",
                                        shot.index
                                    );
                                    None
                                }
                                Err(e) => {
                                    tracing::warn!("camera {sysid}: {e:#}");
                                    None
                                }
                            }
                        }
                        Err(e) => {
                            tracing::warn!("camera {sysid}: picture source stopped: {e}");
                            None
                        }
                    }
                }
                None => None,
            };
            let now = Time::ZERO + std::time::Duration::from_micros(clock.now().as_micros());
            cams.deliver(sysid, shot, picture.as_ref(), now);
        }
        while let Some((_, img)) = cams.poll_image() {
            if let Some(dir) = &image_dir {
                let path = dir.join(&img.file_name);
                if let Err(e) = crate::store::atomic_write(&path, &img.jpeg) {
                    tracing::warn!("cannot write image {}: {e}", path.display());
                }
            }
        }
        while let Some((h, m)) = cams.poll_transmit() {
            let unix = unix0 + now.as_micros();
            let frame = codec.encode_with_header(&h, &m, mavlink::MavlinkVersion::V2, unix);
            let sysid = u8::try_from(h.system_id).unwrap_or(0);
            pending.entry(sysid).or_default().push(now, frame);
        }
        for (sysid, q) in pending.iter_mut() {
            if let Expired::Began(n) = q.expire(now) {
                tracing::warn!(
                    "simulated camera {sysid}: the link is dropping datagrams older than {} ms \
                     ({n} now, {} in all)",
                    TxQueue::MAX_AGE.as_millis(),
                    q.dropped()
                );
            }
        }
        let mut backlog = false;
        match &ios[0] {
            Io::Udp { sock, peer } => {
                let last = peer.lock().ok().and_then(|p| *p);
                for (sysid, q) in pending.iter_mut() {
                    match routes.get(sysid).copied().or(last) {
                        Some(to) => {
                            q.refill(now);
                            while let Some(d) = q.ready() {
                                match sock.try_send_to(d, to) {
                                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                                        break;
                                    }
                                    // sent, or an error a retry would not mend (e.g. ICMP
                                    // port unreachable reported on this send)
                                    _ => q.sent(),
                                }
                            }
                        }
                        // nobody has spoken to us yet: nowhere to send
                        None => q.clear(),
                    }
                    backlog |= !q.is_empty();
                }
            }
            Io::Tcp { out } => {
                for q in pending.values_mut() {
                    for d in q.take_all() {
                        let _ = out.send(d);
                    }
                }
            }
        }
        if end.is_some_and(|e| now >= e) {
            break cams;
        }
        let mut wait = STEP;
        if let Some(t) = cams.poll_timeout() {
            wait = wait.min(
                t.saturating_since(now)
                    .max(std::time::Duration::from_millis(1)),
            );
        }
        if backlog {
            wait = wait.min(UDP_PACE);
        }
        tokio::select! {
            r = rx.recv() => {
                if let Some((_, bytes, from)) = r {
                    let now = Time::ZERO + std::time::Duration::from_micros(clock.now().as_micros());
                    for f in codec.decode(&bytes, unix0 + now.as_micros()) {
                        if let (Some(a), 1) = (from, f.header.component_id)
                            && let Ok(sysid) = u8::try_from(f.header.system_id)
                        {
                            routes.insert(sysid, a);
                        }
                        if let Ok(m) = f.message {
                            cams.handle_message(&f.header, &m, now);
                        }
                    }
                }
            }
            _ = tokio::time::sleep(wait) => {}
            _ = &mut shutdown => break cams,
        }
    };
    if result.refused() > 0 {
        tracing::warn!(
            "simulated cameras: {} captures refused in all for want of a fresh position",
            result.refused()
        );
    }
    Ok(result)
}

/// Log what the paired cameras report: stale poses as warnings (once per episode), the rest
/// at info.
fn log_paired_event(ev: &crate::sim::paired::PairedEvent) {
    use crate::sim::paired::PairedEvent as E;
    match ev {
        E::Discovered { sysid, autopilot } => tracing::info!(
            "camera for vehicle {sysid} ({autopilot:?}): asked for GLOBAL_POSITION_INT and \
             ATTITUDE at {} Hz",
            crate::sim::paired::TELEMETRY_HZ
        ),
        E::Rebooted { sysid } => {
            tracing::info!("vehicle {sysid} rebooted: camera asked for its telemetry again")
        }
        E::PoseStale {
            sysid,
            age,
            refused_total,
        } => match age {
            Some(a) => tracing::warn!(
                "camera for vehicle {sysid}: no position for {:.1} s, refusing captures \
                 ({refused_total} refused so far)",
                a.as_secs_f64()
            ),
            None => tracing::warn!(
                "camera for vehicle {sysid}: never had a position, refusing captures \
                 ({refused_total} refused so far)"
            ),
        },
        E::PoseRestored { sysid, refused } => tracing::info!(
            "camera for vehicle {sysid}: position again after {refused} refused captures"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints() {
        assert_eq!(
            Endpoint::parse("udpout:127.0.0.1:14550").unwrap(),
            Endpoint::UdpOut("127.0.0.1:14550".into())
        );
        assert_eq!(
            Endpoint::parse("tcpin:0.0.0.0:5760")
                .unwrap()
                .for_vehicle(2)
                .unwrap(),
            Endpoint::TcpIn("0.0.0.0:5762".into())
        );
        assert_eq!(
            Endpoint::parse("udpout:localhost:14550")
                .unwrap()
                .for_vehicle(3)
                .unwrap(),
            Endpoint::UdpOut("localhost:14550".into())
        );
        assert!(Endpoint::parse("serial:/dev/ttyUSB0:57600").is_err());
        assert!(Endpoint::parse("udpin:14550").is_err());
        assert!(Endpoint::parse("udpin::x").is_err());
    }
}

/// A simulation served over in-process links (see [`spawn_memory`]).
#[derive(Debug)]
pub struct MemorySimHandle {
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Sim>,
}

impl MemorySimHandle {
    /// Stop serving and get the simulation back (for inspection).
    pub async fn stop(mut self) -> Result<Sim, ServerError> {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        self.task.await.map_err(|e| ServerError::Io {
            what: "simulator task".into(),
            source: std::io::Error::other(e.to_string()),
        })
    }
}

/// Serve `sim` over in-process links, one [`crate::link::transport::MemoryPort`] per vehicle
/// in system-id order, on the runtime's clock at real speed. With tokio's clock paused
/// (tests with `start_paused`) this is a fully virtual run: the simulator, the links and the
/// fleet share tokio's virtual time, which jumps to the next timer whenever every task
/// waits, so simulated minutes cost only the CPU time of the work done.
pub fn spawn_memory(sim: Sim, ports: Vec<crate::link::transport::MemoryPort>) -> MemorySimHandle {
    let (stop_tx, mut stop_rx) = tokio::sync::oneshot::channel::<()>();
    let sysids = sim.sysids();
    let (tx, mut rx) = mpsc::unbounded_channel::<(usize, Vec<u8>)>();
    let mut outs = Vec::new();
    for (k, p) in ports.into_iter().enumerate() {
        let crate::link::transport::MemoryPort {
            mut from_gcs,
            to_gcs,
        } = p;
        outs.push(to_gcs);
        let tx = tx.clone();
        tokio::spawn(async move {
            while let Some(b) = from_gcs.recv().await {
                if tx.send((k, b)).is_err() {
                    return;
                }
            }
        });
    }
    drop(tx);
    let task = tokio::spawn(async move {
        let clock = MonotonicClock::new();
        let mut stepper = Stepper::new(sim, Speed::REAL_TIME, None);
        let mut open = true;
        loop {
            let wall = clock.now();
            stepper.step(wall);
            stepper.record(wall);
            while stepper.sim.poll_image().is_some() {}
            while let Some((sysid, ev)) = stepper.sim.poll_event() {
                log_event(sysid, &ev);
            }
            for (k, &sysid) in sysids.iter().enumerate() {
                while let Some(d) = stepper.sim.recv_bytes(sysid) {
                    if let Some(o) = outs.get(k) {
                        let _ = o.send(d);
                    }
                }
            }
            let wait = stepper.wait(clock.now());
            tokio::select! {
                r = rx.recv(), if open => {
                    if r.is_none() {
                        open = false;
                    }
                    let mut next = r;
                    while let Some((k, bytes)) = next {
                        if let Some(&s) = sysids.get(k) {
                            stepper.receive(s, &bytes);
                        }
                        next = rx.try_recv().ok();
                    }
                    stepper.deliver();
                }
                _ = pause(wait) => {}
                _ = &mut stop_rx => return stepper.sim,
            }
        }
    });
    MemorySimHandle {
        stop: Some(stop_tx),
        task,
    }
}

/// Log a vehicle event: failsafes and fence breaches as warnings (what a field team must hear
/// of), the rest (boots, arming, landings) at info.
fn log_event(sysid: u8, ev: &crate::sim::vehicle::VehicleEvent) {
    use crate::sim::vehicle::VehicleEvent as E;
    match ev {
        E::FenceBreached { .. } | E::BatteryFailsafe(_) => {
            tracing::warn!("simulated vehicle {sysid}: {ev:?}")
        }
        _ => tracing::info!("simulated vehicle {sysid}: {ev:?}"),
    }
}
