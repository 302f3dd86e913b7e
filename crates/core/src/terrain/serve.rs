//! Answering the vehicles' TERRAIN_REQUESTs from tiles: which squares to send, in what
//! order and how fast, and what a vehicle waits for when no tile has it. Pure: fed with the
//! requests, the time and a height lookup; the shell (`fleetmap::app::terrain`) reads the
//! tiles and sends.
//!
//! ArduPilot asks for the squares it still lacks at most every 2 s per channel
//! (`AP_Terrain::send_request`, `TerrainGCS.cpp`), so an answer still on its way is asked
//! for again. A square sent less than [`Server::RESEND_AFTER`] ago is not sent again (MAVProxy
//! keeps the same `sent_mask` for the request it serves, `mavproxy_terrain.py`); one the
//! vehicle still asks for after that is sent again, as lost. A newer request from a vehicle
//! replaces what was left of its older one (MAVProxy serves the latest request). Squares go
//! out at most [`Server::blocks_per_s`] a second over all vehicles (Mission Planner paces at
//! 12 a second, MAVProxy at 5), round robin between vehicles.

use super::grid::{Request, Square};
use super::hgt::TileId;
use crate::time::Time;
use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

/// Why a height is unknown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Missing {
    /// No tile covers the point.
    NoTile(TileId),
    /// The tile has a void there.
    Void(TileId),
}

/// What the server has for the shell.
#[derive(Clone, Debug, PartialEq)]
pub enum Out {
    /// Send TERRAIN_DATA to vehicle `sysid`.
    Data {
        /// The vehicle.
        sysid: u8,
        /// The request answered (its corner and spacing go into the message).
        request: Request,
        /// The square.
        square: Square,
    },
    /// A square vehicle `sysid` asked for that no tile answers (reported once per tile and
    /// vehicle until a tile answers for it).
    Waiting {
        /// The vehicle.
        sysid: u8,
        /// The point without a height, degrees.
        at: (f64, f64),
        /// Why.
        missing: Missing,
    },
}

#[derive(Clone, Debug, Default)]
struct Vehicle {
    /// The request being served and the bits of it still to send.
    queue: VecDeque<(Request, u8)>,
    /// When each square was last sent: (lat_e7, lon_e7, spacing, bit).
    sent: BTreeMap<(i32, i32, u16, u8), Time>,
    /// What it waits for, last seen (cleared when a square is sent).
    waiting: Option<((f64, f64), Missing)>,
    /// Squares sent to it.
    squares_sent: u64,
}

/// The terrain server of a whole fleet (see the module documentation).
#[derive(Clone, Debug)]
pub struct Server {
    vehicles: BTreeMap<u8, Vehicle>,
    blocks_per_s: f64,
    next_at: Option<Time>,
    /// The vehicle served last (round robin).
    last: Option<u8>,
}

impl Server {
    /// A square sent is not sent again for this long.
    pub const RESEND_AFTER: Duration = Duration::from_secs(6);

    /// A server that sends at most `blocks_per_s` squares a second (each a 55-byte
    /// TERRAIN_DATA on the wire).
    pub fn new(blocks_per_s: f64) -> Server {
        Server {
            vehicles: BTreeMap::new(),
            blocks_per_s: if blocks_per_s.is_finite() && blocks_per_s > 0.0 {
                blocks_per_s
            } else {
                10.0
            },
            next_at: None,
            last: None,
        }
    }

    /// How many squares a second it sends at most.
    pub fn blocks_per_s(&self) -> f64 {
        self.blocks_per_s
    }

    /// Send at most `blocks_per_s` squares a second from now on (ignored unless positive).
    pub fn set_blocks_per_s(&mut self, blocks_per_s: f64) {
        if blocks_per_s.is_finite() && blocks_per_s > 0.0 {
            self.blocks_per_s = blocks_per_s;
        }
    }

    /// Vehicle `sysid` asked for `request` at `now`.
    pub fn handle_request(&mut self, sysid: u8, request: Request, now: Time) {
        let v = self.vehicles.entry(sysid).or_default();
        v.sent
            .retain(|_, at| now.saturating_since(*at) < Self::RESEND_AFTER);
        v.queue.clear();
        for bit in request.gridbits() {
            let key = (request.lat_e7, request.lon_e7, request.spacing_m, bit);
            if !v.sent.contains_key(&key) {
                v.queue.push_back((request, bit));
            }
        }
    }

    /// The next thing to do at `now`, heights from `height` (metres AMSL, or why unknown):
    /// a square to send (paced), or a report of what a vehicle waits for (not paced).
    pub fn poll(
        &mut self,
        now: Time,
        mut height: impl FnMut(f64, f64) -> Result<f64, Missing>,
    ) -> Option<Out> {
        if self.next_at.is_some_and(|t| now < t) {
            return None;
        }
        // round robin: the first vehicle after the last one served that has work
        let ids: Vec<u8> = self
            .vehicles
            .iter()
            .filter(|(_, v)| !v.queue.is_empty())
            .map(|(id, _)| *id)
            .collect();
        let sysid = *ids
            .iter()
            .find(|id| self.last.is_some_and(|l| **id > l))
            .or(ids.first())?;
        let v = self.vehicles.get_mut(&sysid)?;
        while let Some((request, bit)) = v.queue.pop_front() {
            match request.answer(bit, &mut height) {
                Ok(square) => {
                    v.sent.insert(
                        (request.lat_e7, request.lon_e7, request.spacing_m, bit),
                        now,
                    );
                    v.waiting = None;
                    v.squares_sent += 1;
                    self.last = Some(sysid);
                    self.next_at = Some(now + Duration::from_secs_f64(1.0 / self.blocks_per_s));
                    return Some(Out::Data {
                        sysid,
                        request,
                        square,
                    });
                }
                Err((at, missing)) => {
                    let again = v.waiting.is_some_and(|(_, m)| m == missing);
                    v.waiting = Some((at, missing));
                    if !again {
                        return Some(Out::Waiting { sysid, at, missing });
                    }
                }
            }
        }
        self.last = Some(sysid);
        None
    }

    /// When [`Server::poll`] may have something next (`None`: nothing queued).
    pub fn poll_timeout(&self) -> Option<Time> {
        if self.vehicles.values().all(|v| v.queue.is_empty()) {
            return None;
        }
        Some(self.next_at.unwrap_or(Time::ZERO))
    }

    /// What vehicle `sysid` waits for: the last point no tile answered and why (cleared when
    /// a square is sent to it).
    pub fn waiting(&self, sysid: u8) -> Option<((f64, f64), Missing)> {
        self.vehicles.get(&sysid).and_then(|v| v.waiting)
    }

    /// Squares sent to vehicle `sysid` so far.
    pub fn squares_sent(&self, sysid: u8) -> u64 {
        self.vehicles.get(&sysid).map_or(0, |v| v.squares_sent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(mask: u64) -> Request {
        Request {
            lat_e7: 470_000_000,
            lon_e7: 80_000_000,
            spacing_m: 100,
            mask,
        }
    }

    fn drain(
        s: &mut Server,
        mut now: Time,
        h: impl Fn(f64, f64) -> Result<f64, Missing>,
    ) -> Vec<Out> {
        let mut out = Vec::new();
        while let Some(t) = s.poll_timeout() {
            now = now.max(t);
            match s.poll(now, &h) {
                Some(o) => out.push(o),
                None if s.poll_timeout().is_some_and(|t| t <= now) => break,
                None => {}
            }
        }
        out
    }

    #[test]
    fn requests_are_answered_once_paced_and_again_when_still_wanted() {
        let mut s = Server::new(10.0);
        let t0 = Time::from_millis(1000);
        s.handle_request(1, req(0b1011), t0);
        let out = drain(&mut s, t0, |_, _| Ok(500.0));
        let bits: Vec<u8> = out
            .iter()
            .map(|o| match o {
                Out::Data { square, .. } => square.gridbit,
                o => panic!("{o:?}"),
            })
            .collect();
        assert_eq!(bits, vec![0, 1, 3]);
        assert_eq!(s.squares_sent(1), 3);
        // asked again 2 s later (the answers still on their way): nothing new
        s.handle_request(1, req(0b1011), t0 + Duration::from_secs(2));
        assert!(drain(&mut s, t0 + Duration::from_secs(2), |_, _| Ok(500.0)).is_empty());
        // still asked after RESEND_AFTER: lost, sent again
        let later = t0 + Server::RESEND_AFTER + Duration::from_secs(1);
        s.handle_request(1, req(0b0010), later);
        assert_eq!(drain(&mut s, later, |_, _| Ok(500.0)).len(), 1);
        // pacing: 10 a second
        s.handle_request(2, req((1 << 56) - 1), later);
        let mut now = later + Duration::from_secs(1);
        let mut sent = 0;
        let end = now + Duration::from_secs(2);
        while now < end {
            if let Some(Out::Data { .. }) = s.poll(now, |_, _| Ok(1.0)) {
                sent += 1;
            }
            now += Duration::from_millis(10);
        }
        assert!((19..=21).contains(&sent), "{sent}");
    }

    #[test]
    fn missing_tiles_are_reported_once_per_vehicle() {
        let mut s = Server::new(100.0);
        let t0 = Time::from_millis(0);
        let none = |lat: f64, lon: f64| Err(Missing::NoTile(TileId::containing(lat, lon)));
        s.handle_request(3, req(0b111), t0);
        let out = drain(&mut s, t0, none);
        assert_eq!(out.len(), 1, "{out:?}");
        let Out::Waiting { sysid, missing, .. } = &out[0] else {
            panic!()
        };
        assert_eq!(*sysid, 3);
        assert_eq!(*missing, Missing::NoTile(TileId { lat: 47, lon: 8 }));
        assert!(s.waiting(3).is_some());
        // a tile arrives: answered, and the wait is over
        s.handle_request(3, req(0b111), t0 + Duration::from_secs(2));
        assert_eq!(
            drain(&mut s, t0 + Duration::from_secs(2), |_, _| Ok(3.0)).len(),
            3
        );
        assert_eq!(s.waiting(3), None);
    }

    #[test]
    fn vehicles_take_turns() {
        let mut s = Server::new(1000.0);
        let t0 = Time::from_millis(0);
        s.handle_request(1, req(0xF), t0);
        s.handle_request(2, req(0xF), t0);
        let order: Vec<u8> = drain(&mut s, t0, |_, _| Ok(0.0))
            .iter()
            .map(|o| match o {
                Out::Data { sysid, .. } => *sysid,
                _ => 0,
            })
            .collect();
        assert_eq!(order, vec![1, 2, 1, 2, 1, 2, 1, 2]);
    }
}
