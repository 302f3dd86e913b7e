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
//!
//! The socket halves live in `io` (`Reader`, `Writer`), the running task in `task`.

mod io;
mod task;

use super::addr::ConnSpec;
use super::codec::{Codec, Frame, LinkStats};
use super::peers::{PeerKey, PeerTable};
use super::signing::Signing;
use super::tlog::TlogHandle;
use crate::clock::MonotonicClock;
use crate::watch;
use fleetmap_core::proto::Endpoint;
use io::{Reader, Writer};
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use task::LinkTask;
use tokio::net::{TcpListener, UdpSocket};
use tokio::sync::mpsc;

/// Receive buffer asked for on every UDP socket, bytes. The default (212 992 bytes on Linux)
/// holds only about 170 small datagrams, since the kernel counts each one's whole buffer:
/// five cameras pushing an image each at once (MAVLink image transmission, 30–40 packets of
/// 253 bytes) and the telemetry beside them overflowed it in our runs (672 datagrams dropped
/// by the kernel during one `demo --bandit`, 22 images lost). The kernel caps the request at
/// `net.core.rmem_max`.
pub(crate) const UDP_RECV_BUFFER: usize = 4 << 20;

/// Ask for `UDP_RECV_BUFFER` on `sock`; returns the size the kernel granted, bytes (it
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

/// Something that happened on a link.
#[derive(Debug)]
pub enum LinkEvent {
    /// A frame was received.
    Frame {
        /// Which link.
        link: LinkId,
        /// The frame.
        frame: Box<Frame>,
        /// Reception time, µs since the Unix epoch (wall clock: for logs and recordings).
        unix_us: u64,
        /// Reception time on the runtime's clock: the wall clock's monotonic time, or the
        /// virtual time of a runtime whose clock is paused — what a reader's lateness is
        /// measured against, the same on every run of a virtual-time test.
        received: tokio::time::Instant,
        /// Which of a serving link's peers (`udpin`, `tcpin`) sent it; `None` on a link with
        /// one peer. Several radios, each with its own vehicle, can send to one UDP port: what
        /// a radio reports about itself (RADIO_STATUS) concerns the vehicles behind it only.
        peer: Option<PeerKey>,
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
    pub(crate) tx_dropped: u64,
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
    /// A message from the endpoint, to the peer of the system it is addressed to (or to
    /// system `to`, for a message without a target field), else to every peer.
    Send(Endpoint, Box<MavMessage>, Option<u8>),
    /// A message from the endpoint, to the peer system `via` was last heard from whatever
    /// its target (else to every peer).
    Via(Endpoint, Box<MavMessage>, u8),
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
        self.tx
            .try_send(LinkCmd::Send(src, Box::new(msg), None))
            .is_ok()
    }

    /// Queue `msg`, which has no target field (DATA_TRANSMISSION_HANDSHAKE to a vehicle's
    /// camera, say), for system `to`: on a link that serves several peers it goes only to the
    /// peer `to` was last heard from (to every peer while `to` has not been heard).
    pub fn send_to_system(&self, src: Endpoint, to: u8, msg: MavMessage) -> bool {
        self.tx
            .try_send(LinkCmd::Send(src, Box::new(msg), Some(to)))
            .is_ok()
    }

    /// Queue `msg` for the peer system `via` was last heard from, whatever the message's own
    /// target (to every peer while `via` has not been heard): a component behind an
    /// autopilot (a companion computer's camera on a port several autopilots share) answers
    /// through its own autopilot, which routes the message on, rather than through every
    /// autopilot at once.
    pub fn send_via(&self, src: Endpoint, via: u8, msg: MavMessage) -> bool {
        self.tx
            .try_send(LinkCmd::Via(src, Box::new(msg), via))
            .is_ok()
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
                clock: MonotonicClock::new(),
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
        clock: MonotonicClock::new(),
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

#[cfg(test)]
mod tests;
