//! A simulated vehicle's outgoing link: the datagrams it has produced and not yet sent,
//! paced to a bandwidth and bounded in age, as a real link is.
//!
//! Why both (found under load, 2026-12-03): the shell used to send a fixed burst per turn of
//! its loop. On a busy machine the loop turns rarely; the simulator, whose clock keeps pace
//! with the wall, then produces a simulated second of telemetry per turn (20× speed-up: 20
//! seconds' worth per wall second, from every vehicle) while only one burst leaves. The queue
//! grew to ten thousand datagrams per vehicle and a COMMAND_ACK waited behind seconds of stale
//! telemetry, so the GCS gave up after its four attempts — a backlog no real link has.
//! * Pacing is a token bucket on the wall clock: `TxQueue::RATE` datagrams per second
//!   however rarely the shell gets to send, at most `TxQueue::BURST` at once (about what a
//!   Linux UDP receive buffer of 208 KiB holds of small MAVLink frames).
//! * Nothing older than `TxQueue::MAX_AGE` is sent: it is dropped and counted, as a real
//!   link under overload loses frames rather than delivering them late (ArduPilot writes a
//!   message only when the port's transmit buffer has room for it, `comm_get_txspace`; a
//!   telemetry radio's buffer holds a fraction of a second). What arrives is then fresh, and
//!   an acknowledgement is late by at most that age.
//!
//! Pure: the caller passes the wall-clock `now`.

use fleetmap_core::time::Time;
use std::collections::VecDeque;
use std::time::Duration;

/// One vehicle's outgoing datagrams (see the module documentation).
#[derive(Debug)]
pub(crate) struct TxQueue {
    queue: VecDeque<(Time, Vec<u8>)>,
    /// Datagrams that may leave now (token bucket, at most [`TxQueue::BURST`]).
    tokens: f64,
    /// When the bucket was last refilled.
    refilled_at: Option<Time>,
    /// Datagrams dropped for age, in all.
    dropped: u64,
    /// Datagrams dropped for age since the queue was last empty.
    dropped_in_episode: u64,
}

impl Default for TxQueue {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`TxQueue::expire`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Expired {
    /// Nothing was too old.
    None,
    /// The first drops since the queue was last empty: this many.
    Began(u64),
    /// More drops in an episode already under way.
    More(u64),
}

impl TxQueue {
    /// Nominal bandwidth, datagrams per wall second (32 per 5 ms: about 1.8 MB/s of full
    /// MAVLink 2 frames, a Wi-Fi link; telemetry radios carry far less).
    pub(crate) const RATE: f64 = 6400.0;
    /// Most datagrams sent at once after a pause.
    pub(crate) const BURST: f64 = 256.0;
    /// Oldest datagram still worth sending, wall time: half the GCS's command timeout (1 s,
    /// as QGroundControl's), so a resend's acknowledgement is never the one thrown away.
    pub(crate) const MAX_AGE: Duration = Duration::from_millis(500);

    /// Backlog, datagrams, beyond which the simulator stops stepping until the link has
    /// carried it (about 100 ms of [`TxQueue::RATE`]): in lock-step (`crate::pace`) a
    /// link that cannot keep up slows the simulation down, as a starved SITL slows down,
    /// instead of ageing out what it produced.
    pub(crate) const HOLD: usize = 640;

    /// An empty queue with a full bucket.
    pub(crate) fn new() -> Self {
        TxQueue {
            queue: VecDeque::new(),
            tokens: Self::BURST,
            refilled_at: None,
            dropped: 0,
            dropped_in_episode: 0,
        }
    }

    /// Queue `datagram`, produced at wall time `now`.
    pub(crate) fn push(&mut self, now: Time, datagram: Vec<u8>) {
        self.queue.push_back((now, datagram));
    }

    /// Drop what is older than [`TxQueue::MAX_AGE`] at `now`.
    pub(crate) fn expire(&mut self, now: Time) -> Expired {
        let mut n = 0;
        while self
            .queue
            .front()
            .is_some_and(|(at, _)| now.saturating_since(*at) > Self::MAX_AGE)
        {
            self.queue.pop_front();
            n += 1;
        }
        self.dropped += n;
        let before = self.dropped_in_episode;
        self.dropped_in_episode += n;
        if self.queue.is_empty() {
            self.dropped_in_episode = 0;
        }
        match (n, before) {
            (0, _) => Expired::None,
            (n, 0) => Expired::Began(n),
            (n, _) => Expired::More(n),
        }
    }

    /// Refill the bucket for the wall time passed since the last call.
    pub(crate) fn refill(&mut self, now: Time) {
        let dt = self
            .refilled_at
            .map_or(Duration::ZERO, |t| now.saturating_since(t));
        self.refilled_at = Some(now);
        self.tokens = (self.tokens + dt.as_secs_f64() * Self::RATE).min(Self::BURST);
    }

    /// The next datagram the bucket lets out now, if any ([`TxQueue::refill`] first). It
    /// stays queued until [`TxQueue::sent`] (a socket that cannot take it yet keeps it).
    pub(crate) fn ready(&self) -> Option<&[u8]> {
        if self.tokens >= 1.0 {
            self.queue.front().map(|(_, d)| d.as_slice())
        } else {
            None
        }
    }

    /// The datagram [`TxQueue::ready`] gave left (or can never leave): take it off.
    pub(crate) fn sent(&mut self) {
        if self.queue.pop_front().is_some() {
            self.tokens -= 1.0;
        }
        if self.queue.is_empty() {
            self.dropped_in_episode = 0;
        }
    }

    /// Everything waiting, unpaced (a TCP client: the stream paces itself).
    pub(crate) fn take_all(&mut self) -> impl Iterator<Item = Vec<u8>> + '_ {
        self.dropped_in_episode = 0;
        self.queue.drain(..).map(|(_, d)| d)
    }

    #[cfg(test)]
    /// Datagrams waiting.
    pub(crate) fn len(&self) -> usize {
        self.queue.len()
    }

    /// More waiting than [`TxQueue::HOLD`].
    pub(crate) fn backlogged(&self) -> bool {
        self.queue.len() > Self::HOLD
    }

    #[cfg(test)]
    /// Nothing waiting.
    pub(crate) fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Datagrams dropped for age, in all.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
    }

    /// When the next datagram may leave (now if one may), given the queue is not empty.
    pub(crate) fn next_send(&self, now: Time) -> Option<Time> {
        if self.queue.is_empty() {
            None
        } else if self.tokens >= 1.0 {
            Some(now)
        } else {
            Some(now + Duration::from_secs_f64((1.0 - self.tokens) / Self::RATE))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(ms: u64) -> Time {
        Time::ZERO + Duration::from_millis(ms)
    }

    /// Send what the bucket lets out at `now`; how many left.
    fn turn(q: &mut TxQueue, now: Time) -> usize {
        q.refill(now);
        let mut n = 0;
        while q.ready().is_some() {
            q.sent();
            n += 1;
        }
        n
    }

    #[test]
    fn a_burst_then_the_rate_however_often_the_shell_turns() {
        let mut q = TxQueue::new();
        for i in 0..2000u32 {
            q.push(at(0), i.to_le_bytes().to_vec());
        }
        assert_eq!(turn(&mut q, at(0)), 256);
        // every 5 ms: 32 (6400 per second)
        assert_eq!(turn(&mut q, at(5)), 32);
        assert_eq!(turn(&mut q, at(10)), 32);
        // a shell that turns every 100 ms still moves the full burst, not one turn's share
        assert_eq!(turn(&mut q, at(110)), 256);
        assert_eq!(turn(&mut q, at(210)), 256);
        // in order, nothing lost
        q.refill(at(211));
        let first = q.ready().map(|d| d.to_vec());
        assert_eq!(first, Some(832u32.to_le_bytes().to_vec()));
        assert_eq!(q.dropped(), 0);
    }

    #[test]
    fn the_next_send_is_when_one_token_is_back() {
        let mut q = TxQueue::new();
        for _ in 0..300 {
            q.push(at(0), vec![0]);
        }
        turn(&mut q, at(0));
        let t = q.next_send(at(0)).unwrap();
        assert!(t > at(0) && t <= at(1), "{t:?}");
        turn(&mut q, at(1000));
        assert_eq!(q.next_send(at(1000)), None);
    }

    #[test]
    fn what_waited_longer_than_max_age_is_dropped_in_episodes() {
        let mut q = TxQueue::new();
        for _ in 0..10 {
            q.push(at(0), vec![1]);
        }
        q.push(at(300), vec![2]);
        assert_eq!(q.expire(at(500)), Expired::None);
        q.push(at(600), vec![3]);
        assert_eq!(q.expire(at(501)), Expired::Began(10));
        assert_eq!(q.ready(), Some(&[2u8][..]));
        assert_eq!(q.expire(at(801)), Expired::More(1));
        assert_eq!(q.dropped(), 11);
        assert_eq!(q.len(), 1);
        // the queue empties: the next drop is a new episode
        turn(&mut q, at(802));
        assert!(q.is_empty());
        q.push(at(900), vec![4]);
        assert_eq!(q.expire(at(1500)), Expired::Began(1));
        assert_eq!(q.dropped(), 12);
    }

    #[test]
    fn a_datagram_the_socket_refuses_stays_first() {
        let mut q = TxQueue::new();
        q.push(at(0), vec![1]);
        q.push(at(0), vec![2]);
        q.refill(at(0));
        assert_eq!(q.ready(), Some(&[1u8][..]));
        // not sent (WouldBlock): still there, still first
        assert_eq!(q.ready(), Some(&[1u8][..]));
        q.sent();
        assert_eq!(q.ready(), Some(&[2u8][..]));
        assert_eq!(q.take_all().collect::<Vec<_>>(), vec![vec![2u8]]);
        assert!(q.is_empty());
    }
}
