//! Link faults: loss, duplication, reordering, latency (with jitter), corruption and blackout
//! windows, applied to whole frames on one direction of one vehicle's link. Pure and seeded:
//! the same seed and the same frames at the same times give the same deliveries.

use fleetmap_core::time::Time;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Duration;
use thiserror::Error;

/// What can go wrong on a link.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkFaults {
    /// Probability that a frame is lost, 0–1.
    pub loss: f64,
    /// Probability that a frame is delivered twice, 0–1.
    pub duplicate: f64,
    /// Probability that a frame is held back behind later ones, 0–1.
    pub reorder: f64,
    /// One-way latency, milliseconds.
    pub latency_ms: f64,
    /// Uniform latency jitter added to each frame, milliseconds.
    pub jitter_ms: f64,
    /// Probability that a frame has one byte flipped (its CRC then fails), 0–1.
    pub corrupt: f64,
    /// Windows (start, end) of simulation time in which nothing gets through.
    pub blackouts: Vec<(Time, Time)>,
}

/// A fault specification is out of range.
#[derive(Debug, Error, PartialEq)]
#[error("invalid link faults: {0}")]
pub struct FaultError(pub String);

impl LinkFaults {
    /// A perfect link.
    pub fn none() -> LinkFaults {
        LinkFaults::default()
    }

    /// Check that probabilities are in [0, 1] and times are sane.
    pub fn validate(&self) -> Result<(), FaultError> {
        for (name, p) in [
            ("loss", self.loss),
            ("duplicate", self.duplicate),
            ("reorder", self.reorder),
            ("corrupt", self.corrupt),
        ] {
            if !(0.0..=1.0).contains(&p) {
                return Err(FaultError(format!(
                    "{name} must be between 0 and 1, got {p}"
                )));
            }
        }
        for (name, v) in [
            ("latency_ms", self.latency_ms),
            ("jitter_ms", self.jitter_ms),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(FaultError(format!("{name} must be ≥ 0, got {v}")));
            }
        }
        if self.blackouts.iter().any(|(a, b)| b < a) {
            return Err(FaultError("a blackout window ends before it starts".into()));
        }
        Ok(())
    }

    /// Whether this link has no fault at all.
    pub(crate) fn is_perfect(&self) -> bool {
        self == &LinkFaults::default()
    }
}

/// Parse a blackout list `START+DURATION,…` in seconds, e.g. `120+15,600+30`.
pub fn parse_blackouts(s: &str) -> Result<Vec<(Time, Time)>, FaultError> {
    let mut out = Vec::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, d) = part.split_once('+').ok_or_else(|| {
            FaultError(format!(
                "blackout {part:?}: expected START+DURATION seconds"
            ))
        })?;
        let a: f64 = a
            .trim()
            .parse()
            .map_err(|_| FaultError(format!("blackout {part:?}: bad start")))?;
        let d: f64 = d
            .trim()
            .parse()
            .map_err(|_| FaultError(format!("blackout {part:?}: bad duration")))?;
        if !(a.is_finite() && a >= 0.0 && d.is_finite() && d >= 0.0) {
            return Err(FaultError(format!(
                "blackout {part:?}: negative or not a number"
            )));
        }
        out.push((Time::from_secs_f64(a), Time::from_secs_f64(a + d)));
    }
    Ok(out)
}

/// One direction of a faulty link.
#[derive(Debug)]
pub struct FaultyChannel {
    faults: LinkFaults,
    rng: ChaCha8Rng,
    queue: BinaryHeap<Reverse<(Time, u64, Vec<u8>)>>,
    counter: u64,
    /// Frames dropped (loss or blackout).
    pub dropped: u64,
    /// Frames duplicated.
    pub duplicated: u64,
    /// Frames corrupted.
    pub corrupted: u64,
    /// Frames held back (reordered).
    pub reordered: u64,
}

impl FaultyChannel {
    /// A channel with `faults`, seeded.
    pub fn new(faults: LinkFaults, seed: u64) -> FaultyChannel {
        FaultyChannel {
            faults,
            rng: ChaCha8Rng::seed_from_u64(seed),
            queue: BinaryHeap::new(),
            counter: 0,
            dropped: 0,
            duplicated: 0,
            corrupted: 0,
            reordered: 0,
        }
    }

    /// The faults of this channel.
    pub fn faults(&self) -> &LinkFaults {
        &self.faults
    }

    fn in_blackout(&self, t: Time) -> bool {
        self.faults.blackouts.iter().any(|(a, b)| t >= *a && t < *b)
    }

    fn delay(&mut self) -> Duration {
        let mut ms = self.faults.latency_ms;
        if self.faults.jitter_ms > 0.0 {
            ms += self.rng.random::<f64>() * self.faults.jitter_ms;
        }
        Duration::from_secs_f64(ms.max(0.0) / 1000.0)
    }

    fn enqueue(&mut self, at: Time, frame: Vec<u8>) {
        self.counter += 1;
        self.queue.push(Reverse((at, self.counter, frame)));
    }

    /// A frame enters the channel at `now`.
    pub fn push(&mut self, mut frame: Vec<u8>, now: Time) {
        if self.faults.is_perfect() {
            self.enqueue(now, frame);
            return;
        }
        // draw every random number in the same order whatever happens, for determinism
        let lost = self.rng.random::<f64>() < self.faults.loss;
        let dup = self.rng.random::<f64>() < self.faults.duplicate;
        let reorder = self.rng.random::<f64>() < self.faults.reorder;
        let corrupt = self.rng.random::<f64>() < self.faults.corrupt;
        let pos = self.rng.random::<u64>();
        let flip = self.rng.random::<u8>() | 1;
        let extra = self.rng.random::<f64>();
        if lost || self.in_blackout(now) {
            self.dropped += 1;
            return;
        }
        if corrupt && !frame.is_empty() {
            // never the start byte: the receiver must see a frame with a bad CRC
            let i = 1 + (pos as usize) % frame.len().saturating_sub(1).max(1);
            if i < frame.len() {
                frame[i] ^= flip;
                self.corrupted += 1;
            }
        }
        let mut at = now + self.delay();
        if reorder {
            // held back 20–200 ms: later frames overtake it
            at += Duration::from_secs_f64(0.02 + 0.18 * extra);
            self.reordered += 1;
        }
        if dup {
            self.duplicated += 1;
            let d = self.delay();
            self.enqueue(now + d + Duration::from_millis(1), frame.clone());
        }
        self.enqueue(at, frame);
    }

    /// The next frame delivered by `now`, if any.
    pub fn poll(&mut self, now: Time) -> Option<Vec<u8>> {
        loop {
            let Reverse((at, _, _)) = self.queue.peek()?;
            if *at > now {
                return None;
            }
            let Reverse((at, _, frame)) = self.queue.pop()?;
            // a frame in flight when a blackout starts is lost too
            if self.in_blackout(at) {
                self.dropped += 1;
                continue;
            }
            return Some(frame);
        }
    }

    /// When the next frame is due.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.queue.peek().map(|Reverse((t, _, _))| *t)
    }

    /// Frames in flight.
    pub fn in_flight(&self) -> usize {
        self.queue.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(faults: LinkFaults, seed: u64) -> (Vec<Vec<u8>>, FaultyChannel) {
        let mut c = FaultyChannel::new(faults, seed);
        let mut out = Vec::new();
        for i in 0..1000u32 {
            let t = Time::from_millis(u64::from(i) * 10);
            c.push(i.to_le_bytes().to_vec(), t);
            while let Some(f) = c.poll(t) {
                out.push(f);
            }
        }
        while let Some(f) = c.poll(Time::from_secs(100)) {
            out.push(f);
        }
        (out, c)
    }

    #[test]
    fn perfect_link_delivers_in_order() {
        let (out, _) = run(LinkFaults::none(), 1);
        assert_eq!(out.len(), 1000);
        assert!(out.windows(2).all(|w| w[0] < w[1] || w[0].len() != 4 || {
            u32::from_le_bytes(w[0][..4].try_into().unwrap())
                < u32::from_le_bytes(w[1][..4].try_into().unwrap())
        }));
    }

    #[test]
    fn faults_happen_at_their_rates_and_are_seeded() {
        let f = LinkFaults {
            loss: 0.3,
            duplicate: 0.1,
            reorder: 0.1,
            latency_ms: 40.0,
            jitter_ms: 10.0,
            corrupt: 0.05,
            blackouts: vec![(Time::from_secs(2), Time::from_secs(3))],
        };
        let (a, ca) = run(f.clone(), 7);
        let (b, _) = run(f.clone(), 7);
        assert_eq!(a, b, "same seed, same deliveries");
        let (c, _) = run(f, 8);
        assert_ne!(a, c);
        assert!(ca.dropped > 300 && ca.dropped < 420, "{}", ca.dropped);
        assert!(
            ca.duplicated > 40 && ca.duplicated < 110,
            "{}",
            ca.duplicated
        );
        assert!(ca.corrupted > 15 && ca.corrupted < 60, "{}", ca.corrupted);
        // some frames overtook others
        let ids: Vec<u32> = a
            .iter()
            .filter(|v| v.len() == 4)
            .map(|v| u32::from_le_bytes([v[0], v[1], v[2], v[3]]))
            .collect();
        assert!(ids.windows(2).any(|w| w[1] < w[0]));
    }

    #[test]
    fn blackout_drops_everything_inside_the_window() {
        let f = LinkFaults {
            blackouts: vec![(Time::from_secs(2), Time::from_secs(3))],
            ..LinkFaults::none()
        };
        let (out, c) = run(f, 3);
        let ids: Vec<u32> = out
            .iter()
            .map(|v| u32::from_le_bytes([v[0], v[1], v[2], v[3]]))
            .collect();
        assert_eq!(c.dropped, 100);
        assert!(ids.iter().all(|i| !(200..300).contains(i)));
        assert_eq!(ids.len(), 900);
    }

    #[test]
    fn blackout_parsing() {
        let b = parse_blackouts("120+15, 600+30").unwrap();
        assert_eq!(b[0], (Time::from_secs(120), Time::from_secs(135)));
        assert_eq!(b.len(), 2);
        assert!(parse_blackouts("12").is_err());
        assert!(parse_blackouts("-1+2").is_err());
        assert!(
            LinkFaults {
                loss: 1.5,
                ..LinkFaults::none()
            }
            .validate()
            .is_err()
        );
    }
}
