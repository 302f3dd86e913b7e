//! Links: one tokio task per connection string, owning its socket (or serial port) and its
//! [`Codec`]. Received frames go to the fleet on an mpsc channel; messages to send arrive
//! on the link's own channel and are encoded as MAVLink 2 (signed when a key is set).
//! Every frame in and out is copied to the `.tlog` when one is open.
//!
//! Behaviour per scheme follows pymavlink `mavutil` (`mavudp`, `mavtcp`, `mavtcpin`,
//! `mavserial`): `udpin` answers the address it last heard from, `udpout` talks to its
//! fixed peer, `tcp` reconnects after the peer goes away (with a backoff from 0.5 s
//! doubling to 5 s; pymavlink retries every second with `autoreconnect`), `tcpin` serves
//! the latest client, `serial` is opened once.

use super::addr::ConnSpec;
use super::codec::{Codec, Frame, LinkStats};
use super::signing::Signing;
use super::tlog::TlogHandle;
use crate::proto::Endpoint;
use mavlink::dialects::ardupilotmega::MavMessage;
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
    /// The current peer address, if known.
    pub peer: Option<String>,
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
    tx: mpsc::Sender<LinkCmd>,
    status: watch::Receiver<LinkStatus>,
}

impl LinkHandle {
    /// Queue `msg` to be sent from `src`; `false` if the link's queue is full or closed.
    pub fn send(&self, src: Endpoint, msg: MavMessage) -> bool {
        self.tx.try_send(LinkCmd::Send(src, Box::new(msg))).is_ok()
    }

    /// Queue already-encoded bytes (a third party's frame in tests, a forwarded frame).
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
        half: Option<tokio::net::tcp::OwnedReadHalf>,
    },
    Serial(tokio::io::ReadHalf<tokio_serial::SerialStream>),
    Memory(mpsc::UnboundedReceiver<Vec<u8>>),
}

enum Writer {
    Udp {
        sock: Arc<UdpSocket>,
        peer: Option<SocketAddr>,
        fixed: bool,
    },
    Tcp(Option<tokio::net::tcp::OwnedWriteHalf>),
    Serial(tokio::io::WriteHalf<tokio_serial::SerialStream>),
    Memory(mpsc::UnboundedSender<Vec<u8>>),
}

enum ReadOutcome {
    Data(usize, Option<SocketAddr>),
    Connected(tokio::net::tcp::OwnedWriteHalf, String),
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
            Reader::TcpServer { listener, half } => match half {
                Some(h) => match h.read(buf).await {
                    Ok(0) => {
                        *half = None;
                        ReadOutcome::Disconnected("client closed the connection".into())
                    }
                    Ok(n) => ReadOutcome::Data(n, None),
                    Err(e) => {
                        *half = None;
                        ReadOutcome::Disconnected(e.to_string())
                    }
                },
                None => match listener.accept().await {
                    Ok((s, from)) => {
                        let _ = s.set_nodelay(true);
                        let (r, w) = s.into_split();
                        *half = Some(r);
                        ReadOutcome::Connected(w, from.to_string())
                    }
                    Err(e) => {
                        tokio::time::sleep(Duration::from_millis(200)).await;
                        ReadOutcome::Disconnected(e.to_string())
                    }
                },
            },
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
    async fn write(&mut self, bytes: &[u8]) -> bool {
        match self {
            Writer::Udp { sock, peer, .. } => match peer {
                Some(p) => sock.send_to(bytes, *p).await.is_ok(),
                None => false,
            },
            Writer::Tcp(Some(w)) => {
                if w.write_all(bytes).await.is_err() {
                    *self = Writer::Tcp(None);
                    return false;
                }
                true
            }
            Writer::Tcp(None) => false,
            Writer::Serial(w) => w.write_all(bytes).await.is_ok(),
            Writer::Memory(tx) => tx.send(bytes.to_vec()).is_ok(),
        }
    }

    fn up(&self) -> bool {
        match self {
            Writer::Udp { peer, .. } => peer.is_some(),
            Writer::Tcp(w) => w.is_some(),
            Writer::Serial(_) => true,
            Writer::Memory(tx) => !tx.is_closed(),
        }
    }

    fn peer(&self) -> Option<String> {
        match self {
            Writer::Udp { peer, .. } => peer.map(|p| p.to_string()),
            _ => None,
        }
    }
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
    let (reader, writer) = match &spec {
        ConnSpec::UdpIn { host, port } => {
            let addr = resolve(&spec, host, *port).await?;
            let s = Arc::new(UdpSocket::bind(addr).await.map_err(io_err)?);
            enlarge_recv_buffer(&s);
            (
                Reader::Udp(s.clone()),
                Writer::Udp {
                    sock: s,
                    peer: None,
                    fixed: false,
                },
            )
        }
        ConnSpec::UdpOut { host, port } => {
            let peer = resolve(&spec, host, *port).await?;
            let local: SocketAddr = if peer.is_ipv6() {
                "[::]:0"
                    .parse()
                    .map_err(|_| io_err(std::io::ErrorKind::InvalidInput.into()))?
            } else {
                "0.0.0.0:0"
                    .parse()
                    .map_err(|_| io_err(std::io::ErrorKind::InvalidInput.into()))?
            };
            let s = Arc::new(UdpSocket::bind(local).await.map_err(io_err)?);
            enlarge_recv_buffer(&s);
            (
                Reader::Udp(s.clone()),
                Writer::Udp {
                    sock: s,
                    peer: Some(peer),
                    fixed: true,
                },
            )
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
            (
                Reader::TcpServer {
                    listener: l,
                    half: None,
                },
                Writer::Tcp(None),
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
    Ok(start_link(id, spec, opts, events, reader, writer))
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
    let initial = LinkStatus {
        name: spec.to_string(),
        up: writer.up(),
        peer: writer.peer(),
        ..Default::default()
    };
    let (status_tx, status_rx) = watch::channel(initial.clone());
    let task = LinkTask {
        id,
        codec,
        reader,
        writer,
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
        tx,
        status: status_rx,
    }
}

struct LinkTask {
    id: LinkId,
    codec: Codec,
    reader: Reader,
    writer: Writer,
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
                    let bytes = match cmd {
                        LinkCmd::Send(src, msg) => self.codec.encode(src.sysid, src.compid, &msg, now),
                        LinkCmd::Raw(b) => b,
                    };
                    if let Some(t) = &self.tlog {
                        t.record(now, &bytes);
                    }
                    if !self.writer.write(&bytes).await {
                        self.status.tx_dropped += 1;
                    }
                }
                out = self.reader.read(&mut buf) => {
                    if !self.handle_read(out, &buf).await {
                        break;
                    }
                }
                _ = tick.tick() => self.publish(),
            }
        }
        self.publish();
    }

    fn publish(&mut self) {
        self.status.stats = self.codec.stats().clone();
        self.status.up = self.writer.up();
        if let Some(p) = self.writer.peer() {
            self.status.peer = Some(p);
        }
        let _ = self.status_tx.send(self.status.clone());
    }

    /// Returns false when the fleet is gone.
    async fn handle_read(&mut self, out: ReadOutcome, buf: &[u8]) -> bool {
        match out {
            ReadOutcome::Data(n, from) => {
                if let (
                    Some(from),
                    Writer::Udp {
                        peer, fixed: false, ..
                    },
                ) = (from, &mut self.writer)
                    && *peer != Some(from)
                {
                    let first = peer.is_none();
                    *peer = Some(from);
                    if first {
                        let ev = LinkEvent::Status {
                            link: self.id,
                            up: true,
                            detail: format!("peer {from}"),
                        };
                        if self.events.send(ev).await.is_err() {
                            return false;
                        }
                    }
                }
                let now = unix_now_us();
                for frame in self.codec.decode(&buf[..n], now) {
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
            ReadOutcome::Connected(w, peer) => {
                self.writer = Writer::Tcp(Some(w));
                self.status.connects += 1;
                self.status.peer = Some(peer.clone());
                self.publish();
                self.events
                    .send(LinkEvent::Status {
                        link: self.id,
                        up: true,
                        detail: format!("connected to {peer}"),
                    })
                    .await
                    .is_ok()
            }
            ReadOutcome::Disconnected(why) => {
                if let Writer::Tcp(w) = &mut self.writer {
                    *w = None;
                    self.publish();
                    return self
                        .events
                        .send(LinkEvent::Status {
                            link: self.id,
                            up: false,
                            detail: why,
                        })
                        .await
                        .is_ok();
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
