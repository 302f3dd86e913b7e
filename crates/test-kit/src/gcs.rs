//! A test's own GCS, without the ground station's fleet behind it: one UDP socket speaking to a
//! vehicle, a relay or a camera as QGroundControl would ([`Gcs`]), or the headers and messages
//! a test hands to a simulation it steps itself ([`Headers`], [`heartbeat`], [`command_long`]).

use fleetmap_core::proto::Endpoint;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::codec::{Codec, Frame};
use fleetmap_io::link::transport::{LinkEvent, LinkHandle, LinkOptions, open_link};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;
use tokio::sync::mpsc;

/// A UDP socket on 127.0.0.1 that sends as the GCS ([`Endpoint::gcs`]: system 255, component
/// 190, as QGroundControl and MAVProxy) and decodes what it receives. Blocking: a test on
/// tokio's multi-threaded runtime calls it inside `tokio::task::block_in_place`.
pub struct Gcs {
    sock: UdpSocket,
    codec: Codec,
    buf: Vec<u8>,
}

impl Gcs {
    /// A GCS on an ephemeral port of 127.0.0.1.
    pub fn bind() -> Gcs {
        Gcs {
            sock: UdpSocket::bind("127.0.0.1:0").expect("the GCS's socket"),
            codec: Codec::new(),
            buf: vec![0u8; 65536],
        }
    }

    /// The address the GCS listens on (where a `udpout:` vehicle or relay sends).
    pub fn addr(&self) -> SocketAddr {
        self.sock.local_addr().expect("the GCS's address")
    }

    /// Send `msg` as the GCS to `to`, one frame in one datagram.
    pub fn send(&mut self, msg: &MavMessage, to: SocketAddr) {
        let gcs = Endpoint::gcs();
        let frame = self.codec.encode(gcs.sysid, gcs.compid, msg, 0);
        self.sock.send_to(&frame, to).expect("the GCS sends");
    }

    /// The next datagram to arrive within `wait`: its sender and the frames in it (those
    /// that decode; a partial frame waits for the next datagram). `None` if nothing came.
    pub fn recv(&mut self, wait: Duration) -> Option<(SocketAddr, Vec<Frame>)> {
        self.sock
            .set_read_timeout(Some(wait))
            .expect("the GCS's read timeout");
        let (n, from) = self.sock.recv_from(&mut self.buf).ok()?;
        Some((from, self.codec.decode(&self.buf[..n], 0)))
    }
}

/// The headers a GCS sends with: system 255, component 190 ([`Endpoint::gcs`]) and a sequence
/// number that counts up from 0 and wraps, for a test that hands messages to a simulation
/// stepped in its own thread ([`fleetmap_sim::harness::Sim::send`]).
#[derive(Debug, Default)]
pub struct Headers {
    seq: u8,
}

impl Headers {
    /// The header of the next message.
    pub fn next_header(&mut self) -> MavHeader {
        let gcs = Endpoint::gcs();
        let h = MavHeader {
            system_id: u32::from(gcs.sysid),
            component_id: gcs.compid,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        h
    }
}

/// The HEARTBEAT a GCS sends once a second (MAV_TYPE_GCS, no autopilot, active), by which the
/// autopilots judge its link.
pub fn heartbeat() -> MavMessage {
    fleetmap_core::proto::heartbeat::gcs_heartbeat()
}

/// COMMAND_LONG `cmd` (a MAV_CMD number, panics on one the dialect lacks) with its seven
/// parameters, to component `target.1` of system `target.0`, first transmission.
pub fn command_long(target: (u8, u8), cmd: u16, p: [f32; 7]) -> MavMessage {
    let command = mav::MavCmd::from_u16(cmd).expect("a MAV_CMD of the dialect");
    let (sysid, compid) = target;
    let target = fleetmap_core::proto::Endpoint::new(sysid, compid);
    fleetmap_core::proto::command::Command::long(target, command, p).message(0)
}

/// The text of a STATUSTEXT (without its NUL padding), `None` for any other message.
pub fn status_text(m: &MavMessage) -> Option<String> {
    match m {
        MavMessage::STATUSTEXT(t) => Some(
            t.text
                .to_str()
                .unwrap_or("")
                .trim_end_matches('\0')
                .to_string(),
        ),
        _ => None,
    }
}

/// The ground station's one UDP port for a fleet under test (`udpin:` on an ephemeral port of
/// 127.0.0.1, default link options): the link, the receiver of its events (4,096 deep) for
/// the fleet, and the address vehicles send to (`udpout:`).
pub async fn listening_link() -> (LinkHandle, mpsc::Receiver<LinkEvent>, SocketAddr) {
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let spec: ConnSpec = "udpin:127.0.0.1:0".parse().expect("a udpin spec");
    let link = open_link(0, spec, &LinkOptions::default(), ev_tx)
        .await
        .expect("the GCS's UDP port");
    let addr = link.local.expect("the port the GCS listens on");
    (link, ev_rx, addr)
}
