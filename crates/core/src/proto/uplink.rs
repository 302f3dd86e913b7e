//! What the GCS sends one vehicle over a telemetry radio, in priority order and within the
//! radio's budget.
//!
//! A SiK radio's serial buffer is a FIFO: once a mission transfer or a burst of picture
//! requests is in it, a command sent after them waits for all of them to go on the air. So
//! the GCS keeps its own queue per vehicle and lets into the radio, in this order:
//! heartbeats, then commands (arming, modes, take-off: a pilot waits on each), then the
//! mission transfer, then bulk traffic (requests for pictures). Heartbeats and commands are
//! never held back — they are small and the vehicle's safety and the run depend on them —
//! but they use up the budget; the mission transfer and bulk traffic are paced to
//! [`LinkBudget::uplink_bytes_per_s`](crate::budget::LinkBudget::uplink_bytes_per_s)
//! (a token bucket) and slowed further while the GCS's radio says its transmit buffer is
//! filling (RADIO_STATUS `txbuf`, percent free), with the thresholds ArduPilot applies to its
//! own streams (`GCS_MAVLINK::handle_radio_status`: below 20 % slow down a lot, below 50 % a
//! little, above 90 % and 95 % speed up again). Bulk messages that waited longer than
//! [`Uplink::BULK_PATIENCE`] are dropped (their senders ask again: a picture's receiver
//! re-requests what is missing). Pure: every call takes `now`.

use crate::time::Time;
use std::collections::VecDeque;
use std::time::Duration;

/// How urgent something the GCS sends is; the lower, the sooner.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Priority {
    /// The GCS heartbeat (the vehicles' GCS failsafe counts on it).
    Heartbeat = 0,
    /// Commands and mode changes.
    Command = 1,
    /// Mission, fence and rally transfers.
    Mission = 2,
    /// Everything else: requests for pictures, the grid for the cameras.
    Bulk = 3,
}

/// The GCS's queue towards one vehicle (see the module documentation). Generic over what is
/// queued (a MAVLink message in the fleet).
#[derive(Debug)]
pub struct Uplink<M> {
    /// Paced bytes per second (`None`: no pacing, everything passes at once).
    rate: Option<f64>,
    /// Bytes that may be sent now (may go below zero: heartbeats and commands are never
    /// held back).
    tokens: f64,
    /// When `tokens` was last brought up to date.
    at: Time,
    /// The radio's back-pressure: the share of `rate` in use, 0.1 ..= 1.
    factor: f64,
    /// Waiting messages per priority, with their size and when they were queued.
    queues: [VecDeque<(M, usize, Time)>; 4],
    /// Bulk messages dropped after waiting too long.
    pub dropped: u64,
}

impl<M> Uplink<M> {
    /// The most bytes the bucket holds: a couple of mission items' worth, so that an idle
    /// queue does not release a burst the radio's buffer would have to hold.
    pub const BURST: f64 = 300.0;
    /// How long a bulk message may wait before it is dropped.
    pub const BULK_PATIENCE: Duration = Duration::from_secs(10);
    /// The slowest share of the paced rate the back-pressure goes down to.
    const MIN_FACTOR: f64 = 0.1;

    /// A queue pacing at `rate` bytes per second (`None`: no pacing).
    pub fn new(rate: Option<f64>, now: Time) -> Uplink<M> {
        Uplink {
            rate: rate.filter(|r| r.is_finite() && *r > 0.0),
            tokens: Self::BURST,
            at: now,
            factor: 1.0,
            queues: Default::default(),
            dropped: 0,
        }
    }

    /// Pace at `rate` from now on (the vehicle's budget changed).
    pub fn set_rate(&mut self, rate: Option<f64>) {
        self.rate = rate.filter(|r| r.is_finite() && *r > 0.0);
    }

    /// The share of the paced rate in use now (1: none held back by the radio).
    pub fn factor(&self) -> f64 {
        self.factor
    }

    fn refill(&mut self, now: Time) {
        if let Some(rate) = self.rate {
            let dt = now.saturating_since(self.at).as_secs_f64();
            self.tokens = (self.tokens + dt * rate * self.factor).min(Self::BURST);
        }
        self.at = self.at.max(now);
    }

    /// Queue `msg`, `bytes` long on the wire, at `priority`.
    pub fn push(&mut self, msg: M, bytes: usize, priority: Priority, now: Time) {
        self.queues[priority as usize].push_back((msg, bytes, now));
    }

    /// The GCS's radio reported `txbuf` percent of its transmit buffer free.
    pub fn handle_radio_status(&mut self, txbuf: u8) {
        self.factor = match txbuf {
            0..20 => self.factor * 0.5,
            20..50 => self.factor * 0.8,
            91..=95 => self.factor * 1.1,
            96..=100 => self.factor * 1.25,
            _ => self.factor,
        }
        .clamp(Self::MIN_FACTOR, 1.0);
    }

    /// The next message to send at `now`, most urgent first.
    pub fn poll_transmit(&mut self, now: Time) -> Option<M> {
        self.refill(now);
        // Bulk that waited too long is given up.
        let bulk = &mut self.queues[Priority::Bulk as usize];
        while bulk
            .front()
            .is_some_and(|(_, _, t)| now.saturating_since(*t) > Self::BULK_PATIENCE)
        {
            bulk.pop_front();
            self.dropped += 1;
        }
        for p in [Priority::Heartbeat, Priority::Command] {
            if let Some((m, bytes, _)) = self.queues[p as usize].pop_front() {
                self.tokens -= bytes as f64;
                return Some(m);
            }
        }
        for p in [Priority::Mission, Priority::Bulk] {
            let q = &mut self.queues[p as usize];
            let Some((_, bytes, _)) = q.front() else {
                continue;
            };
            if self.rate.is_some() && self.tokens < *bytes as f64 {
                // The most urgent waiting message goes first: nothing overtakes it.
                return None;
            }
            let (m, bytes, _) = q.pop_front()?;
            self.tokens -= bytes as f64;
            return Some(m);
        }
        None
    }

    /// When [`Uplink::poll_transmit`] will have something to give, if anything waits.
    pub fn poll_timeout(&self) -> Option<Time> {
        if self.queues[..2].iter().any(|q| !q.is_empty()) {
            return Some(self.at);
        }
        let (_, bytes, _) = self.queues[2..].iter().find_map(|q| q.front())?;
        let Some(rate) = self.rate else {
            return Some(self.at);
        };
        let short = (*bytes as f64 - self.tokens).max(0.0);
        let wait = Duration::from_secs_f64(short / (rate * self.factor));
        let due = self.at + wait;
        // A bulk message that will be dropped is due then at the latest.
        let expires = self.queues[Priority::Bulk as usize]
            .front()
            .map(|(_, _, t)| *t + Self::BULK_PATIENCE + Duration::from_millis(1));
        Some(expires.map_or(due, |e| due.min(e)))
    }

    /// Messages waiting.
    pub fn len(&self) -> usize {
        self.queues.iter().map(VecDeque::len).sum()
    }

    /// Whether nothing waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t: u64) -> Time {
        Time::from_millis(t)
    }

    /// Everything given out by `now`.
    fn drain(u: &mut Uplink<&'static str>, now: Time) -> Vec<&'static str> {
        std::iter::from_fn(|| u.poll_transmit(now)).collect()
    }

    #[test]
    fn without_a_rate_everything_passes_in_priority_order() {
        let mut u = Uplink::new(None, ms(0));
        u.push("item", 50, Priority::Mission, ms(0));
        u.push("picture request", 30, Priority::Bulk, ms(0));
        u.push("arm", 45, Priority::Command, ms(0));
        u.push("heartbeat", 21, Priority::Heartbeat, ms(0));
        assert_eq!(
            drain(&mut u, ms(0)),
            ["heartbeat", "arm", "item", "picture request"]
        );
        assert!(u.is_empty() && u.poll_timeout().is_none());
    }

    #[test]
    fn mission_items_are_paced_and_commands_overtake_them() {
        // 500 B/s: 50-byte items every 100 ms once the 300-byte burst is spent.
        let mut u = Uplink::new(Some(500.0), ms(0));
        for _ in 0..20 {
            u.push("item", 50, Priority::Mission, ms(0));
        }
        assert_eq!(drain(&mut u, ms(0)).len(), 6, "the burst");
        assert_eq!(u.poll_timeout(), Some(ms(100)));
        u.push("takeoff", 45, Priority::Command, ms(10));
        assert_eq!(drain(&mut u, ms(10)), ["takeoff"]);
        // The command used the bucket: the next item waits for it to refill.
        assert!(drain(&mut u, ms(100)).is_empty());
        let mut sent = 0;
        let mut last = ms(0);
        for t in (100..=3000).step_by(10) {
            let n = drain(&mut u, ms(t)).len();
            if n > 0 {
                last = ms(t);
            }
            sent += n;
        }
        // From 10 ms on the bucket owes 40 bytes for the command; the 14th item needs 50
        // more after 13 × 50 sent: 740 bytes at 500 B/s, 1.48 s later.
        assert_eq!(sent, 14);
        assert_eq!(last, ms(1490));
        assert!(u.is_empty());
    }

    #[test]
    fn a_filling_radio_slows_the_pace_and_an_empty_one_restores_it() {
        let mut u: Uplink<&str> = Uplink::new(Some(500.0), ms(0));
        u.handle_radio_status(10);
        assert!((u.factor() - 0.5).abs() < 1e-9);
        u.handle_radio_status(40);
        assert!((u.factor() - 0.4).abs() < 1e-9);
        for _ in 0..10 {
            u.handle_radio_status(5);
        }
        assert!((u.factor() - 0.1).abs() < 1e-9, "floor");
        u.handle_radio_status(70);
        assert!((u.factor() - 0.1).abs() < 1e-9, "70 % free: no change");
        for _ in 0..20 {
            u.handle_radio_status(100);
        }
        assert!((u.factor() - 1.0).abs() < 1e-9);
        // Heartbeats are never held back, whatever the radio says.
        for _ in 0..10 {
            u.handle_radio_status(0);
        }
        for _ in 0..50 {
            u.push("heartbeat", 21, Priority::Heartbeat, ms(0));
        }
        assert_eq!(drain(&mut u, ms(0)).len(), 50);
    }

    #[test]
    fn bulk_that_waits_too_long_is_dropped() {
        let mut u = Uplink::new(Some(10.0), ms(0));
        u.push("big", 290, Priority::Bulk, ms(0));
        u.push("request 1", 100, Priority::Bulk, ms(0));
        u.push("request 2", 100, Priority::Bulk, ms(5_000));
        assert_eq!(drain(&mut u, ms(0)), ["big"]);
        // 10 B/s: request 1 needs 9 s more; it is due before it expires.
        let due = u.poll_timeout().unwrap();
        assert_eq!(due, ms(9_000));
        assert_eq!(drain(&mut u, ms(9_000)), ["request 1"]);
        // request 2 would need 10 s more, beyond its patience: dropped then.
        let due = u.poll_timeout().unwrap();
        assert_eq!(due, ms(15_001));
        assert!(drain(&mut u, due).is_empty());
        assert_eq!(u.dropped, 1);
        assert!(u.is_empty());
    }
}
