//! Links: one tokio task per connection string, owning its socket (or serial port) and its
//! [`Codec`]. Received frames go to the fleet on an mpsc channel; messages to send arrive
//! on the link's own channel and are encoded as MAVLink 2 (signed when a key is set).
//! Every frame in and out is copied to the `.tlog` when one is open.
//!
//! Behaviour per scheme: `udpout` talks to its fixed peer from a socket bound to loopback
//! when the peer is on this machine; `tcp` reconnects after the peer goes away (with a
//! backoff from 0.5 s doubling to 5 s; pymavlink's `mavtcp` retries every second with
//! `autoreconnect`); `serial` is opened once. `udpin` and `tcpin` serve every peer they
//! hear at once — every vehicle sending to one UDP port from its own address, every TCP
//! client — and answer each system at the address it speaks from ([`super::peers`]), as
//! QGroundControl's UDP link and mavlink-router do (pymavlink's `mavudp` answers only the
//! last sender, which loses every vehicle but one when several share the port).

use super::addr::ConnSpec;
use super::codec::{Codec, Frame, LinkStats};
use super::peers::{PeerKey, PeerTable};
use super::signing::Signing;
use super::tlog::TlogHandle;
use crate::proto::Endpoint;
use mavlink::Message;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tokio::sync::{mpsc, watch};

/// Receive buffer asked for on every UDP socket, bytes. The default (212 992 bytes on Linux)
/// holds only about 170 small datagrams, since the kernel counts each one's whole buffer:
/// five cameras pushing an image each at once (MAVLink image transmission, 30–40 packets of
/// 253 bytes) and the telemetry beside them overflowed it in our runs (672 datagrams dropped
/// by the kernel during one `demo --bandit`, 22 images lost). The kernel caps the request at
/// `net.core.rmem_max`.
pub const UDP_RECV_BUFFER: usize = 4 << 20;

/// Ask for [`UDP_RECV_BUFFER`] on `sock`; returns the size the kernel granted, bytes (it
/// may be less, and Linux reports twice the usable size), or `None` when it refused.
pub fn enlarge_recv_buffer(sock: &UdpSocket) -> Option<usize> {
    let s = socket2::SockRef::from(sock);
    match s.set_recv_buffer_size(UDP_RECV_BUFFER) {
        Ok(()) => s.recv_buffer_size().ok(),
        Err(e) => {
            tracing::debug!("UDP receive buffer stays at its default: {e}");
            None
        }
    }
}

/// Index of a link in the fleet (0, 1, … in `--connect` order).
pub type LinkId = usize;

/// Wall-clock time in µs since the Unix epoch (tlog timestamps, signing). 0 if the clock
/// is before 1970.
pub fn unix_now_us() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0)
}

/// Something that happened on a link.
#[derive(Debug)]
pub enum LinkEvent {
    /// A frame was received.
    Frame {
        /// Which link.
        link: LinkId,
        /// The frame.
        frame: Box<Frame>,
        /// Reception time, µs since the Unix epoch.
        unix_us: u64,
    },
    /// The link connected or disconnected (TCP), or got its first peer (UDP in).
    Status {
        /// Which link.
        link: LinkId,
        /// Connected / has a peer.
        up: bool,
        /// Human-readable detail (peer address or error).
        detail: String,
    },
}

/// Link state and statistics, published a few times per second.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LinkStatus {
    /// The connection string.
    pub name: String,
    /// Connected (TCP) / has a peer to send to (UDP).
    pub up: bool,
    /// The current peer address, if known (on a link that serves several, the one heard
    /// last).
    pub peer: Option<String>,
    /// Every peer a serving link (`udpin`, `tcpin`) hears now, most recent first.
    pub peers: Vec<String>,
    /// Codec statistics (frames, bytes, CRC errors, loss per source, signing drops).
    pub stats: LinkStats,
    /// Messages that could not be sent (no peer yet, disconnected, write error).
    pub tx_dropped: u64,
    /// TCP (re)connections made.
    pub connects: u64,
}

/// Errors opening a link.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// Binding, connecting or resolving failed.
    #[error("{spec}: {source}")]
    Io {
        /// The connection string.
        spec: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The serial port could not be opened.
    #[error("{spec}: cannot open serial port: {source}")]
    Serial {
        /// The connection string.
        spec: String,
        /// The error.
        source: tokio_serial::Error,
    },
}

/// Options shared by the links of a fleet.
#[derive(Clone, Debug, Default)]
pub struct LinkOptions {
    /// Sign outgoing frames and check incoming ones (each link gets its own stream
    /// state; the link id is the link's index).
    pub signing: Option<Signing>,
    /// Copy every frame to this tlog.
    pub tlog: Option<TlogHandle>,
}

enum LinkCmd {
    Send(Endpoint, Box<MavMessage>),
    Raw(Vec<u8>),
}

/// Handle to a running link (cheap to clone).
#[derive(Clone, Debug)]
pub struct LinkHandle {
    /// Index in the fleet.
    pub id: LinkId,
    /// The connection string.
    pub spec: ConnSpec,
    /// The local address of a UDP socket or TCP listener (what a port 0 in the connection
    /// string became).
    pub local: Option<SocketAddr>,
    tx: mpsc::Sender<LinkCmd>,
    status: watch::Receiver<LinkStatus>,
}

impl LinkHandle {
    /// Queue `msg` to be sent from `src`; `false` if the link's queue is full or closed.
    /// On a link that serves several peers it goes to the peer its target system was last
    /// heard from, or to every peer when it has no target ([`super::peers`]).
    pub fn send(&self, src: Endpoint, msg: MavMessage) -> bool {
        self.tx.try_send(LinkCmd::Send(src, Box::new(msg))).is_ok()
    }

    /// Queue already-encoded bytes (a third party's frame in tests, a forwarded frame); on
    /// a link with several peers they go to all of them.
    pub fn send_raw(&self, bytes: Vec<u8>) -> bool {
        self.tx.try_send(LinkCmd::Raw(bytes)).is_ok()
    }

    /// The latest published status.
    pub fn status(&self) -> LinkStatus {
        self.status.borrow().clone()
    }

    /// Whether the link task is still running.
    pub fn is_running(&self) -> bool {
        !self.tx.is_closed()
    }
}

/// What a TCP server's per-client reader task reports.
enum ClientRead {
    Data(u64, Vec<u8>),
    Closed(u64, String),
}

/// Aborts a task when dropped (a TCP client's reader, when the client or the link goes).
struct AbortOnDrop(tokio::task::AbortHandle);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

enum Reader {
    Udp(Arc<UdpSocket>),
    TcpClient {
        addr: String,
        half: Option<tokio::net::tcp::OwnedReadHalf>,
        backoff: Duration,
        /// The connection attempt in flight: a task of its own, so that the link's
        /// `select!` (which drops this future whenever a message is sent) cannot cancel a
        /// half-open connection.
        pending: Option<tokio::task::JoinHandle<std::io::Result<TcpStream>>>,
        /// Earliest time of the next attempt after a failure.
        retry_at: Option<tokio::time::Instant>,
    },
    TcpServer {
        listener: TcpListener,
        next_client: u64,
        /// Every client's reader task sends here.
        from_clients: mpsc::Receiver<ClientRead>,
        to_link: mpsc::Sender<ClientRead>,
    },
    Serial(tokio::io::ReadHalf<tokio_serial::SerialStream>),
    Memory(mpsc::UnboundedReceiver<Vec<u8>>),
}

enum Writer {
    /// `udpout`: one fixed peer.
    UdpOut {
        sock: Arc<UdpSocket>,
        peer: SocketAddr,
    },
    /// `udpin`: every sender heard is a peer ([`LinkTask::peers`]).
    UdpIn(Arc<UdpSocket>),
    /// `tcp`: the connection, while there is one.
    Tcp(Option<tokio::net::tcp::OwnedWriteHalf>),
    /// `tcpin`: every client connected ([`LinkTask::peers`] routes among them).
    TcpServer(HashMap<u64, (tokio::net::tcp::OwnedWriteHalf, AbortOnDrop)>),
    Serial(tokio::io::WriteHalf<tokio_serial::SerialStream>),
    Memory(mpsc::UnboundedSender<Vec<u8>>),
}

enum ReadOutcome {
    /// `n` bytes in the read buffer, from a UDP sender when the link serves several.
    Data(usize, Option<SocketAddr>),
    /// Bytes from a TCP server's client.
    ClientData(u64, Vec<u8>),
    /// The TCP client link connected.
    Connected(tokio::net::tcp::OwnedWriteHalf, String),
    /// The TCP server accepted a client.
    Accepted(
        u64,
        tokio::net::tcp::OwnedWriteHalf,
        AbortOnDrop,
        SocketAddr,
    ),
    /// A TCP server's client went away.
    ClientClosed(u64, String),
    Disconnected(String),
}

impl Reader {
    async fn read(&mut self, buf: &mut [u8]) -> ReadOutcome {
        match self {
            Reader::Udp(s) => match s.recv_from(buf).await {
                Ok((n, from)) => ReadOutcome::Data(n, Some(from)),
                // ICMP port unreachable surfaces as an error on some systems: keep going.
                Err(e) => ReadOutcome::Disconnected(e.to_string()),
            },
            Reader::TcpClient {
                addr,
                half,
                backoff,
                pending,
                retry_at,
            } => match half {
                Some(h) => match h.read(buf).await {
                    Ok(0) => {
                        *half = None;
                        ReadOutcome::Disconnected("peer closed the connection".into())
                    }
                    Ok(n) => ReadOutcome::Data(n, None),
                    Err(e) => {
                        *half = None;
                        ReadOutcome::Disconnected(e.to_string())
                    }
                },
                None => loop {
                    // Every await below is cancel-safe: state lives in `pending` and
                    // `retry_at`, so a dropped future resumes where it was.
                    if let Some(t) = *retry_at {
                        tokio::time::sleep_until(t).await;
                        *retry_at = None;
                    }
                    let task = pending.get_or_insert_with(|| {
                        let a = addr.clone();
                        tokio::spawn(async move { TcpStream::connect(a.as_str()).await })
                    });
                    let result = task.await;
                    *pending = None;
                    match result {
                        Ok(Ok(s)) => {
                            let _ = s.set_nodelay(true);
                            let peer = s.peer_addr().map(|a| a.to_string()).unwrap_or_default();
                            let (r, w) = s.into_split();
                            *half = Some(r);
                            *backoff = Duration::from_millis(500);
                            return ReadOutcome::Connected(w, peer);
                        }
                        _ => {
                            *retry_at = Some(tokio::time::Instant::now() + *backoff);
                            *backoff = (*backoff * 2).min(Duration::from_secs(5));
                        }
                    }
                },
            },
            Reader::TcpServer {
                listener,
                next_client,
                from_clients,
                to_link,
            } => {
                // Both branches are cancel-safe (`accept`, `recv`).
                tokio::select! {
                    accepted = listener.accept() => match accepted {
                        Ok((s, from)) => {
                            let _ = s.set_nodelay(true);
                            let (mut r, w) = s.into_split();
                            let id = *next_client;
                            *next_client += 1;
                            let tx = to_link.clone();
                            let task = tokio::spawn(async move {
                                let mut buf = vec![0u8; 8192];
                                let why = loop {
                                    match r.read(&mut buf).await {
                                        Ok(0) => break "client closed the connection".to_string(),
                                        Ok(n) => {
                                            if tx.send(ClientRead::Data(id, buf[..n].to_vec())).await.is_err() {
                                                return;
                                            }
                                        }
                                        Err(e) => break e.to_string(),
                                    }
                                };
                                let _ = tx.send(ClientRead::Closed(id, why)).await;
                            });
                            ReadOutcome::Accepted(id, w, AbortOnDrop(task.abort_handle()), from)
                        }
                        Err(e) => {
                            tokio::time::sleep(Duration::from_millis(200)).await;
                            ReadOutcome::Disconnected(e.to_string())
                        }
                    },
                    r = from_clients.recv() => match r {
                        Some(ClientRead::Data(id, bytes)) => ReadOutcome::ClientData(id, bytes),
                        Some(ClientRead::Closed(id, why)) => ReadOutcome::ClientClosed(id, why),
                        // `to_link` lives here too: never closed while the link runs.
                        None => std::future::pending().await,
                    },
                }
            }
            Reader::Memory(rx) => match rx.recv().await {
                Some(bytes) => {
                    let n = bytes.len().min(buf.len());
                    buf[..n].copy_from_slice(&bytes[..n]);
                    ReadOutcome::Data(n, None)
                }
                None => {
                    // The peer is gone: nothing will ever arrive again.
                    std::future::pending::<()>().await;
                    ReadOutcome::Data(0, None)
                }
            },
            Reader::Serial(r) => match r.read(buf).await {
                Ok(0) => {
                    tokio::time::sleep(Duration::from_millis(10)).await;
                    ReadOutcome::Data(0, None)
                }
                Ok(n) => ReadOutcome::Data(n, None),
                Err(e) => {
                    tokio::time::sleep(Duration::from_millis(200)).await;
                    ReadOutcome::Disconnected(e.to_string())
                }
            },
        }
    }
}

impl Writer {
    /// Whether the link can send now: connected (TCP), or with at least one peer.
    fn up(&self, peers: &PeerTable) -> bool {
        match self {
            Writer::UdpOut { .. } | Writer::Serial(_) => true,
            Writer::UdpIn(_) => !peers.is_empty(),
            Writer::Tcp(w) => w.is_some(),
            Writer::TcpServer(clients) => !clients.is_empty(),
            Writer::Memory(tx) => !tx.is_closed(),
        }
    }
}

/// The local address to send to `peer` from: loopback for a loopback peer (so that a link
/// to this machine is not reachable from the network), the unspecified address of the
/// peer's family otherwise (the kernel picks the interface), port chosen by the kernel.
pub fn local_for(peer: SocketAddr) -> SocketAddr {
    use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};
    let ip = match peer.ip() {
        IpAddr::V4(a) if a.is_loopback() => IpAddr::V4(Ipv4Addr::LOCALHOST),
        IpAddr::V4(_) => IpAddr::V4(Ipv4Addr::UNSPECIFIED),
        IpAddr::V6(a) if a.is_loopback() => IpAddr::V6(Ipv6Addr::LOCALHOST),
        IpAddr::V6(_) => IpAddr::V6(Ipv6Addr::UNSPECIFIED),
    };
    SocketAddr::new(ip, 0)
}

async fn resolve(spec: &ConnSpec, host: &str, port: u16) -> Result<SocketAddr, LinkError> {
    let mut addrs = tokio::net::lookup_host((host, port))
        .await
        .map_err(|source| LinkError::Io {
            spec: spec.to_string(),
            source,
        })?;
    addrs.next().ok_or_else(|| LinkError::Io {
        spec: spec.to_string(),
        source: std::io::Error::new(std::io::ErrorKind::NotFound, "host has no address"),
    })
}

/// Open the link described by `spec` (binding / opening happens now, so errors are
/// immediate) and start its task. Frames go to `events`.
pub async fn open_link(
    id: LinkId,
    spec: ConnSpec,
    opts: &LinkOptions,
    events: mpsc::Sender<LinkEvent>,
) -> Result<LinkHandle, LinkError> {
    let io_err = |source: std::io::Error| LinkError::Io {
        spec: spec.to_string(),
        source,
    };
    let mut local = None;
    let (reader, writer) = match &spec {
        ConnSpec::UdpIn { host, port } => {
            let addr = resolve(&spec, host, *port).await?;
            let s = Arc::new(UdpSocket::bind(addr).await.map_err(io_err)?);
            enlarge_recv_buffer(&s);
            local = s.local_addr().ok();
            (Reader::Udp(s.clone()), Writer::UdpIn(s))
        }
        ConnSpec::UdpOut { host, port } => {
            let peer = resolve(&spec, host, *port).await?;
            let s = Arc::new(UdpSocket::bind(local_for(peer)).await.map_err(io_err)?);
            enlarge_recv_buffer(&s);
            local = s.local_addr().ok();
            (Reader::Udp(s.clone()), Writer::UdpOut { sock: s, peer })
        }
        ConnSpec::Tcp { host, port } => (
            Reader::TcpClient {
                addr: format!("{host}:{port}"),
                half: None,
                backoff: Duration::from_millis(500),
                pending: None,
                retry_at: None,
            },
            Writer::Tcp(None),
        ),
        ConnSpec::TcpIn { host, port } => {
            let addr = resolve(&spec, host, *port).await?;
            let l = TcpListener::bind(addr).await.map_err(io_err)?;
            local = l.local_addr().ok();
            let (to_link, from_clients) = mpsc::channel(1024);
            (
                Reader::TcpServer {
                    listener: l,
                    next_client: 0,
                    from_clients,
                    to_link,
                },
                Writer::TcpServer(HashMap::new()),
            )
        }
        ConnSpec::Serial { path, baud } => {
            use tokio_serial::SerialPortBuilderExt;
            let port = tokio_serial::new(path.as_str(), *baud)
                .open_native_async()
                .map_err(|source| LinkError::Serial {
                    spec: spec.to_string(),
                    source,
                })?;
            let (r, w) = tokio::io::split(port);
            (Reader::Serial(r), Writer::Serial(w))
        }
        ConnSpec::Memory { .. } => {
            return Err(LinkError::Io {
                spec: spec.to_string(),
                source: std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "memory links are made with open_memory_link",
                ),
            });
        }
    };
    let mut h = start_link(id, spec, opts, events, reader, writer);
    h.local = local;
    Ok(h)
}

/// The peer's end of an in-process link (see [`open_memory_link`]).
#[derive(Debug)]
pub struct MemoryPort {
    /// Bytes the GCS sent (one encoded frame per item).
    pub from_gcs: mpsc::UnboundedReceiver<Vec<u8>>,
    /// Bytes to deliver to the GCS (any framing: the link's codec reassembles frames).
    pub to_gcs: mpsc::UnboundedSender<Vec<u8>>,
}

/// Open an in-process link named `name`: the fleet sees an ordinary link; the returned
/// [`MemoryPort`] is the other end (used with the embedded simulator on a virtual clock,
/// where no socket may take part).
pub fn open_memory_link(
    id: LinkId,
    name: &str,
    opts: &LinkOptions,
    events: mpsc::Sender<LinkEvent>,
) -> (LinkHandle, MemoryPort) {
    let (to_gcs, gcs_rx) = mpsc::unbounded_channel();
    let (gcs_tx, from_gcs) = mpsc::unbounded_channel();
    let spec = ConnSpec::Memory {
        name: name.to_string(),
    };
    let h = start_link(
        id,
        spec,
        opts,
        events,
        Reader::Memory(gcs_rx),
        Writer::Memory(gcs_tx),
    );
    (h, MemoryPort { from_gcs, to_gcs })
}

fn start_link(
    id: LinkId,
    spec: ConnSpec,
    opts: &LinkOptions,
    events: mpsc::Sender<LinkEvent>,
    reader: Reader,
    writer: Writer,
) -> LinkHandle {
    let codec = match &opts.signing {
        Some(s) => {
            let mut s = s.clone();
            s.link_id = id as u8;
            Codec::with_signing(s)
        }
        None => Codec::new(),
    };
    let (tx, rx) = mpsc::channel(1024);
    let peers = PeerTable::default();
    let initial = LinkStatus {
        name: spec.to_string(),
        up: writer.up(&peers),
        peer: match &writer {
            Writer::UdpOut { peer, .. } => Some(peer.to_string()),
            _ => None,
        },
        ..Default::default()
    };
    let (status_tx, status_rx) = watch::channel(initial.clone());
    let task = LinkTask {
        id,
        codec,
        reader,
        writer,
        peers,
        rx,
        events,
        tlog: opts.tlog.clone(),
        status: initial,
        status_tx,
    };
    tokio::spawn(task.run());
    LinkHandle {
        id,
        spec,
        local: None,
        tx,
        status: status_rx,
    }
}

struct LinkTask {
    id: LinkId,
    codec: Codec,
    reader: Reader,
    writer: Writer,
    /// The peers of a serving link (`udpin`, `tcpin`); empty for the others.
    peers: PeerTable,
    rx: mpsc::Receiver<LinkCmd>,
    events: mpsc::Sender<LinkEvent>,
    tlog: Option<TlogHandle>,
    status: LinkStatus,
    status_tx: watch::Sender<LinkStatus>,
}

impl LinkTask {
    async fn run(mut self) {
        let mut buf = vec![0u8; 65_536];
        let mut tick = tokio::time::interval(Duration::from_millis(200));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        loop {
            tokio::select! {
                cmd = self.rx.recv() => {
                    let Some(cmd) = cmd else { break };
                    let now = unix_now_us();
                    let (bytes, target) = match cmd {
                        LinkCmd::Send(src, msg) => (
                            self.codec.encode(src.sysid, src.compid, &msg, now),
                            msg.target_system_id(),
                        ),
                        LinkCmd::Raw(b) => (b, None),
                    };
                    if let Some(t) = &self.tlog {
                        t.record(now, &bytes);
                    }
                    if !self.write(&bytes, target).await {
                        self.status.tx_dropped += 1;
                    }
                }
                out = self.reader.read(&mut buf) => {
                    if !self.handle_read(out, &buf).await {
                        break;
                    }
                }
                _ = tick.tick() => {
                    for gone in self.peers.expire(tokio::time::Instant::now()) {
                        tracing::info!("link {}: peer {gone} silent, forgotten", self.status.name);
                    }
                    self.publish();
                }
            }
        }
        self.publish();
    }

    /// Send `bytes` (a frame to system `target`, if it has one) where they belong; false
    /// if they could not go anywhere.
    async fn write(&mut self, bytes: &[u8], target: Option<u8>) -> bool {
        match &mut self.writer {
            Writer::UdpOut { sock, peer } => sock.send_to(bytes, *peer).await.is_ok(),
            Writer::UdpIn(sock) => {
                let mut sent = false;
                for key in self.peers.destinations(target) {
                    if let PeerKey::Addr(a) = key {
                        sent |= sock.send_to(bytes, a).await.is_ok();
                    }
                }
                sent
            }
            Writer::Tcp(Some(w)) => {
                if w.write_all(bytes).await.is_err() {
                    self.writer = Writer::Tcp(None);
                    return false;
                }
                true
            }
            Writer::Tcp(None) => false,
            Writer::TcpServer(clients) => {
                let mut sent = false;
                let mut failed = Vec::new();
                for key in self.peers.destinations(target) {
                    if let PeerKey::Client(c) = key
                        && let Some((w, _)) = clients.get_mut(&c)
                    {
                        if w.write_all(bytes).await.is_ok() {
                            sent = true;
                        } else {
                            failed.push(c);
                        }
                    }
                }
                for c in failed {
                    clients.remove(&c);
                    self.peers.remove(PeerKey::Client(c));
                }
                sent
            }
            Writer::Serial(w) => w.write_all(bytes).await.is_ok(),
            Writer::Memory(tx) => tx.send(bytes.to_vec()).is_ok(),
        }
    }

    fn publish(&mut self) {
        self.status.stats = self.codec.stats().clone();
        self.status.up = self.writer.up(&self.peers);
        if matches!(self.writer, Writer::UdpIn(_) | Writer::TcpServer(_)) {
            self.status.peers = self.peers.names();
            if let Some(p) = self.status.peers.first() {
                self.status.peer = Some(p.clone());
            }
        }
        let _ = self.status_tx.send(self.status.clone());
    }

    async fn status_event(&self, up: bool, detail: String) -> bool {
        self.events
            .send(LinkEvent::Status {
                link: self.id,
                up,
                detail,
            })
            .await
            .is_ok()
    }

    /// Decode `data` (from `peer` when the link serves several) and hand the frames to the
    /// fleet. Returns false when the fleet is gone.
    async fn deliver(&mut self, data: &[u8], peer: Option<(PeerKey, String)>) -> bool {
        let now = unix_now_us();
        let frames = match &peer {
            Some((key, name)) => {
                let (stream, new) = self.peers.heard(*key, name, tokio::time::Instant::now());
                let frames = self.codec.decode_stream(stream, data, now);
                if new && !self.status_event(true, format!("peer {name}")).await {
                    return false;
                }
                for f in &frames {
                    self.peers.route(f.sysid(), *key);
                }
                frames
            }
            None => self.codec.decode(data, now),
        };
        for frame in frames {
            if let Some(t) = &self.tlog {
                t.record(now, &frame.raw);
            }
            let ev = LinkEvent::Frame {
                link: self.id,
                frame: Box::new(frame),
                unix_us: now,
            };
            if self.events.send(ev).await.is_err() {
                return false;
            }
        }
        true
    }

    /// Returns false when the fleet is gone.
    async fn handle_read(&mut self, out: ReadOutcome, buf: &[u8]) -> bool {
        match out {
            ReadOutcome::Data(n, from) => {
                let peer = match (&self.writer, from) {
                    (Writer::UdpIn(_), Some(a)) => Some((PeerKey::Addr(a), a.to_string())),
                    _ => None,
                };
                self.deliver(&buf[..n], peer).await
            }
            ReadOutcome::ClientData(c, bytes) => {
                // Known since it was accepted (the name is only used for a peer that is new).
                let name = format!("client {c}");
                self.deliver(&bytes, Some((PeerKey::Client(c), name))).await
            }
            ReadOutcome::Connected(w, peer) => {
                self.writer = Writer::Tcp(Some(w));
                self.status.connects += 1;
                self.status.peer = Some(peer.clone());
                self.publish();
                self.status_event(true, format!("connected to {peer}"))
                    .await
            }
            ReadOutcome::Accepted(c, w, reader, from) => {
                if let Writer::TcpServer(clients) = &mut self.writer {
                    clients.insert(c, (w, reader));
                }
                self.peers.heard(
                    PeerKey::Client(c),
                    &from.to_string(),
                    tokio::time::Instant::now(),
                );
                self.status.connects += 1;
                self.publish();
                self.status_event(true, format!("client {from} connected"))
                    .await
            }
            ReadOutcome::ClientClosed(c, why) => {
                if let Writer::TcpServer(clients) = &mut self.writer {
                    clients.remove(&c);
                }
                let name = self
                    .peers
                    .remove(PeerKey::Client(c))
                    .unwrap_or_else(|| format!("client {c}"));
                self.publish();
                self.status_event(false, format!("{name}: {why}")).await
            }
            ReadOutcome::Disconnected(why) => {
                if let Writer::Tcp(w) = &mut self.writer {
                    *w = None;
                    self.publish();
                    return self.status_event(false, why).await;
                }
                // UDP errors (e.g. ICMP unreachable) and serial hiccups: keep reading.
                tokio::time::sleep(Duration::from_millis(50)).await;
                true
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The links' UDP sockets get the receive buffer asked for, up to what the kernel allows
    /// (`net.core.rmem_max` on Linux).
    #[tokio::test]
    async fn udp_sockets_get_the_larger_receive_buffer() {
        let sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let before = socket2::SockRef::from(&sock).recv_buffer_size().unwrap();
        let granted = enlarge_recv_buffer(&sock).expect("SO_RCVBUF accepted");
        let cap = std::fs::read_to_string("/proc/sys/net/core/rmem_max")
            .ok()
            .and_then(|s| s.trim().parse::<usize>().ok());
        if let Some(cap) = cap {
            assert!(
                granted >= UDP_RECV_BUFFER.min(cap),
                "asked {UDP_RECV_BUFFER}, allowed {cap}, got {granted} (was {before})"
            );
        } else {
            assert!(granted > 0);
        }
    }
}
