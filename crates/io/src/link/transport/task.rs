//! The task that runs one link: it owns the codec, the socket halves and the peer table,
//! encodes and writes what the fleet sends, decodes what arrives and publishes the link's
//! status.

use super::io::{ReadOutcome, Reader, Writer};
use super::{LinkCmd, LinkEvent, LinkId, LinkStatus};
use crate::clock::{MonotonicClock, unix_us};
use crate::link::codec::Codec;
use crate::link::peers::{PeerKey, PeerTable};
use crate::link::tlog::TlogHandle;
use crate::watch;
use mavlink::Message;
use std::time::Duration;
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;

pub(super) struct LinkTask {
    pub(super) id: LinkId,
    pub(super) codec: Codec,
    pub(super) reader: Reader,
    pub(super) writer: Writer,
    /// The peers of a serving link (`udpin`, `tcpin`); empty for the others.
    pub(super) peers: PeerTable,
    pub(super) rx: mpsc::Receiver<LinkCmd>,
    pub(super) events: mpsc::Sender<LinkEvent>,
    pub(super) tlog: Option<TlogHandle>,
    pub(super) status: LinkStatus,
    pub(super) status_tx: watch::Sender<LinkStatus>,
    /// The link's clock (wall time: when peers were last heard).
    pub(super) clock: MonotonicClock,
}

impl LinkTask {
    pub(super) async fn run(mut self) {
        let mut buf = vec![0u8; 65_536];
        let mut tick = tokio::time::interval(Duration::from_millis(200));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        loop {
            // `biased`: in this order, not tokio's random one, so that a run on a paused
            // clock is the same every time. The tick first: it is ready once a period, so it
            // cannot starve the others, nor they it.
            tokio::select! {
                biased;
                _ = tick.tick() => {
                    for gone in self.peers.expire(self.clock.now()) {
                        tracing::info!("link {}: peer {gone} silent, forgotten", self.status.name);
                    }
                    self.publish();
                }
                cmd = self.rx.recv() => {
                    let Some(cmd) = cmd else { break };
                    let now = unix_us();
                    let (bytes, target) = match cmd {
                        LinkCmd::Send(src, msg, to) => (
                            self.codec.encode(src.sysid, src.compid, &msg, now),
                            msg.target_system_id().filter(|t| *t != 0).or(to),
                        ),
                        LinkCmd::Via(src, msg, via) => (
                            self.codec.encode(src.sysid, src.compid, &msg, now),
                            Some(via),
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
        let now = unix_us();
        let received = tokio::time::Instant::now();
        let key = peer.as_ref().map(|(k, _)| *k);
        let frames = match &peer {
            Some((key, name)) => {
                let (stream, new) = self.peers.heard(*key, name, self.clock.now());
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
                received,
                peer: key,
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
                self.peers
                    .heard(PeerKey::Client(c), &from.to_string(), self.clock.now());
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
