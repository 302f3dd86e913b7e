//! The peers of a serving link: a `udpin` port that several vehicles send to (each from its
//! own address, as several SITL instances or Wi-Fi drones do), or a `tcpin` server with
//! several clients. Sans-IO: time is a parameter.
//!
//! What it does is what QGroundControl's UDP link (`UDPLink`, one session target per
//! sender, every write goes to all of them) and mavlink-router (routing by the system ids
//! seen on each endpoint) do, combined:
//!
//! * every peer heard is remembered with the time it was last heard and the system ids that
//!   spoke from it, and keeps its own reassembly buffer (`StreamBuffer`);
//! * a message addressed to a system goes to the peer that system was last heard from — a
//!   vehicle that comes back from another address (a reboot, another radio) is followed at
//!   its first frame;
//! * a broadcast (no target system, or target 0) and a message to a system never heard go
//!   to every peer;
//! * a UDP peer silent for `FORGET_AFTER` is forgotten with its routes (the sender of a
//!   vehicle that is switched off, an old ephemeral port after a restart); a TCP client is
//!   forgotten when it disconnects.

use super::codec::StreamBuffer;
use fleetmap_core::time::Time;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::time::Duration;

/// A peer that stays silent this long is forgotten (and no longer sent to). Long enough
/// for a vehicle's battery swap or reboot to come back from the same address without a
/// gap, short enough that a dead port does not collect traffic for the whole run.
pub(crate) const FORGET_AFTER: Duration = Duration::from_secs(60);

/// Who a serving link talks to: a UDP sender's address or a TCP client's number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PeerKey {
    /// A UDP sender.
    Addr(SocketAddr),
    /// A TCP client, numbered in the order of acceptance.
    Client(u64),
}

#[derive(Debug)]
struct Peer {
    /// The address, for display.
    name: String,
    /// When it was last heard, on the link's clock.
    last_heard: Time,
    stream: StreamBuffer,
}

/// The peers heard and the route of each system id (see the module docs).
#[derive(Debug)]
pub(crate) struct PeerTable {
    peers: HashMap<PeerKey, Peer>,
    routes: HashMap<u8, PeerKey>,
    forget_after: Duration,
}

impl Default for PeerTable {
    fn default() -> Self {
        PeerTable::new(FORGET_AFTER)
    }
}

impl PeerTable {
    /// A table that forgets peers silent for `forget_after`.
    pub(crate) fn new(forget_after: Duration) -> PeerTable {
        PeerTable {
            peers: HashMap::new(),
            routes: HashMap::new(),
            forget_after,
        }
    }

    /// Bytes arrived from `key` (named `name` for display); returns its reassembly buffer
    /// and whether the peer is new.
    pub(crate) fn heard(
        &mut self,
        key: PeerKey,
        name: &str,
        now: Time,
    ) -> (&mut StreamBuffer, bool) {
        let mut new = false;
        let p = self.peers.entry(key).or_insert_with(|| {
            new = true;
            Peer {
                name: name.to_string(),
                last_heard: now,
                stream: StreamBuffer::default(),
            }
        });
        p.last_heard = now;
        (&mut p.stream, new)
    }

    /// System `sysid` spoke from `key`: messages to it go there from now on.
    pub(crate) fn route(&mut self, sysid: u8, key: PeerKey) {
        self.routes.insert(sysid, key);
    }

    /// Where a message to `target` (its target system; `None` or 0 for a broadcast) goes.
    pub(crate) fn destinations(&self, target: Option<u8>) -> Vec<PeerKey> {
        match target.filter(|s| *s != 0).and_then(|s| self.routes.get(&s)) {
            Some(k) => vec![*k],
            None => self.peers.keys().copied().collect(),
        }
    }

    /// Forget UDP peers silent for longer than the table's limit; returns their names. A
    /// TCP client stays while its connection is open, however quiet ([`PeerTable::remove`]
    /// forgets it when it disconnects).
    pub(crate) fn expire(&mut self, now: Time) -> Vec<String> {
        let limit = self.forget_after;
        let gone: Vec<PeerKey> = self
            .peers
            .iter()
            .filter(|(k, _)| matches!(k, PeerKey::Addr(_)))
            .filter(|(_, p)| now.saturating_since(p.last_heard) > limit)
            .map(|(k, _)| *k)
            .collect();
        gone.iter().filter_map(|k| self.remove(*k)).collect()
    }

    /// Forget `key` (a TCP client that disconnected); returns its name if it was known.
    pub(crate) fn remove(&mut self, key: PeerKey) -> Option<String> {
        self.routes.retain(|_, k| *k != key);
        self.peers.remove(&key).map(|p| p.name)
    }

    /// Whether any peer is known.
    pub(crate) fn is_empty(&self) -> bool {
        self.peers.is_empty()
    }

    /// The peers' names, most recently heard first.
    pub(crate) fn names(&self) -> Vec<String> {
        let mut v: Vec<&Peer> = self.peers.values().collect();
        v.sort_by(|a, b| b.last_heard.cmp(&a.last_heard).then(a.name.cmp(&b.name)));
        v.into_iter().map(|p| p.name.clone()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(port: u16) -> PeerKey {
        PeerKey::Addr(SocketAddr::from(([127, 0, 0, 1], port)))
    }

    #[test]
    fn routes_follow_systems_and_broadcasts_reach_everyone() {
        let t0 = Time::ZERO;
        let mut t = PeerTable::default();
        let (a, b) = (addr(1000), addr(1001));
        assert!(t.heard(a, "a", t0).1);
        t.route(1, a);
        assert!(t.heard(b, "b", t0).1);
        t.route(2, b);
        assert!(!t.heard(a, "a", t0).1);
        assert_eq!(t.destinations(Some(1)), vec![a]);
        assert_eq!(t.destinations(Some(2)), vec![b]);
        let mut all = t.destinations(None);
        all.sort_by_key(|k| format!("{k:?}"));
        assert_eq!(all.len(), 2);
        assert_eq!(t.destinations(Some(0)).len(), 2);
        // A system never heard: everyone.
        assert_eq!(t.destinations(Some(9)).len(), 2);
        // Vehicle 1 reboots and comes back from another port: followed.
        let c = addr(1002);
        t.heard(c, "c", t0);
        t.route(1, c);
        assert_eq!(t.destinations(Some(1)), vec![c]);
    }

    #[test]
    fn silent_peers_are_forgotten_with_their_routes() {
        let t0 = Time::ZERO;
        let mut t = PeerTable::new(Duration::from_secs(10));
        let (a, b) = (addr(1000), addr(1001));
        t.heard(a, "a", t0);
        t.route(1, a);
        t.heard(b, "b", t0 + Duration::from_secs(8));
        t.route(2, b);
        assert!(t.expire(t0 + Duration::from_secs(10)).is_empty());
        assert_eq!(
            t.expire(t0 + Duration::from_secs(11)),
            vec!["a".to_string()]
        );
        assert_eq!(t.destinations(Some(1)), vec![b], "unknown again: broadcast");
        assert_eq!(t.names(), vec!["b".to_string()]);
        assert_eq!(t.remove(b), Some("b".into()));
        assert!(t.is_empty());
        assert!(t.destinations(None).is_empty());
        // A quiet TCP client is not forgotten while connected.
        t.heard(PeerKey::Client(0), "tcp", t0);
        assert!(t.expire(t0 + Duration::from_secs(3600)).is_empty());
        assert_eq!(t.destinations(None), vec![PeerKey::Client(0)]);
    }
}
