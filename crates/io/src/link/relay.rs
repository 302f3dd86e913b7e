//! A MAVLink relay between two links that models a telemetry radio: a byte rate each way
//! with a bounded queue ([`RateLimiter`]), then the faults of the air — loss, duplication,
//! delay, corruption ([`super::faults`]): `fleetmap relay --gcs CONN --vehicle CONN --rate
//! 5000 --loss 0.3`. It puts a field radio between any GCS and any autopilot — a real SITL, a
//! flight controller on a serial port — so that transfers can be judged under a radio's
//! budget and its losses against the real thing and not only against the embedded simulator.
//!
//! Frames are relayed whole and unchanged (their bytes, signature included); what does not
//! decode as a frame (garbage, a bad CRC) is not relayed. Each direction has its own
//! [`RateLimiter`] and its own [`FaultyChannel`], seeded, on the relay's clock
//! ([`MonotonicClock`]: the wall clock, or tokio's paused clock in tests). Both ends are
//! ordinary links, so every connection string works on either side, and a `udpin` or `tcpin`
//! side serves several peers at once; [`Relay::memory`] makes both ends in-process links.
//!
//! In a test: `let relay = Relay::open(gcs, vehicle, RelayOptions { rate: 5000,
//! ..RelayOptions::default() }).await?;` (port 0 is fine: [`Relay::gcs_local`] and
//! [`Relay::vehicle_local`] say where it listens), then `tokio::spawn(relay.run(every,
//! report, stop))`.

use super::addr::ConnSpec;
use super::faults::{FaultyChannel, LinkFaults};
use super::transport::{
    LinkError, LinkEvent, LinkHandle, LinkOptions, MemoryPort, open_link, open_memory_link,
};
use crate::clock::MonotonicClock;
use fleetmap_core::time::Time;
use serde::Serialize;
use std::collections::VecDeque;
use std::net::SocketAddr;
use std::time::Duration;
use tokio::sync::mpsc;

/// A telemetry radio's transmit queue, one direction, as a SiK radio behaves: frames wait in
/// a FIFO of `queue_bytes` and leave one after the other at `bytes_per_s`; a frame that would
/// overflow the queue is dropped whole (tail drop) and counted. Pure: no clock, no tokio —
/// every call takes `now` (the relay's clock, µs), so the same arrivals give the same
/// departures.
///
/// A frame costs its full length on the wire (header, payload, CRC and signature) and is
/// released when its last byte has left: at `start + bytes / bytes_per_s`, where `start` is
/// when the radio last went from idle to busy and `bytes` counts every byte accepted since
/// (exact integer arithmetic, rounded up to the µs, so a long run keeps the rate without
/// drift). An idle radio banks no credit: a frame arriving on an empty queue still takes its
/// length over the rate. The queue is counted in bytes not yet sent (the partly sent frame's
/// remainder included), as SiK's serial FIFO frees each byte as it goes on the air.
///
/// Not modelled: SiK's time-division duplex (its air rate is shared by both directions; here
/// each direction has its own `bytes_per_s`), its air-packet framing, and the RADIO_STATUS
/// reports an autopilot uses to slow its streams.
#[derive(Debug)]
pub struct RateLimiter {
    /// Bytes per second; 0: unlimited.
    bytes_per_s: u32,
    /// Capacity of the queue, bytes.
    queue_bytes: u64,
    /// When the current busy period started.
    start: Time,
    /// Bytes accepted since `start`.
    accepted: u64,
    /// Frames waiting, with the time each is released.
    frames: VecDeque<(Time, Vec<u8>)>,
    /// Frames dropped because the queue had no room for them.
    pub dropped: u64,
    /// Most bytes ever waiting at once (the frame just accepted included), bytes.
    pub peak_queue_bytes: u64,
}

impl RateLimiter {
    /// Default queue, bytes: the serial receive FIFO of a SiK radio on an Si1000 (3DR,
    /// Holybro, HM-TRP radios), where bytes from the autopilot or the GCS wait for the air
    /// (`RX_BUFF_MAX` = 1850 in ArduPilot/SiK `Firmware/radio/serial.c`; 1024 on the Si1030
    /// build). About 0.37 s at 5,000 B/s, the most a 57,600-baud radio carries each way.
    pub const SIK_QUEUE_BYTES: u32 = 1850;

    /// The longest MAVLink frame, bytes: a MAVLink 2 frame with a 255-byte payload and a
    /// signature (10 header + 255 + 2 CRC + 13 signature). A queue is never smaller.
    pub const MAX_FRAME_BYTES: u32 = 280;

    /// A radio sending `bytes_per_s` bytes per second (0: unlimited, every frame passes at
    /// once) with a queue of `queue_bytes` bytes (raised to [`Self::MAX_FRAME_BYTES`] if
    /// smaller, so that any frame fits an empty queue).
    pub fn new(bytes_per_s: u32, queue_bytes: u32) -> RateLimiter {
        RateLimiter {
            bytes_per_s,
            queue_bytes: u64::from(queue_bytes.max(Self::MAX_FRAME_BYTES)),
            start: Time::ZERO,
            accepted: 0,
            frames: VecDeque::new(),
            dropped: 0,
            peak_queue_bytes: 0,
        }
    }

    /// No limit: every frame is released when it arrives.
    pub fn unlimited() -> RateLimiter {
        RateLimiter::new(0, Self::SIK_QUEUE_BYTES)
    }

    /// When the last of `bytes` bytes accepted since `start` has left.
    fn sent_at(&self, bytes: u64) -> Time {
        let rate = u128::from(self.bytes_per_s.max(1));
        let us = (u128::from(bytes) * 1_000_000).div_ceil(rate);
        self.start + Duration::from_micros(u64::try_from(us).unwrap_or(u64::MAX))
    }

    /// Bytes waiting at `now`: accepted but not yet sent (0 when unlimited).
    pub(crate) fn queued_bytes(&self, now: Time) -> u64 {
        if self.bytes_per_s == 0 {
            return 0;
        }
        let elapsed = now.saturating_since(self.start).as_micros();
        let sent = elapsed * u128::from(self.bytes_per_s) / 1_000_000;
        u64::try_from(u128::from(self.accepted).saturating_sub(sent)).unwrap_or(u64::MAX)
    }

    /// A frame arrives at `now`: queued and `true`, or dropped (counted) and `false` when the
    /// bytes waiting plus its length would exceed the queue.
    pub fn push(&mut self, frame: Vec<u8>, now: Time) -> bool {
        if self.bytes_per_s == 0 {
            self.frames.push_back((now, frame));
            return true;
        }
        if now >= self.sent_at(self.accepted) {
            // idle: a new busy period starts now (no credit for the idle time)
            self.start = now;
            self.accepted = 0;
        }
        let len = frame.len() as u64;
        let waiting = self.queued_bytes(now) + len;
        if waiting > self.queue_bytes {
            self.dropped += 1;
            return false;
        }
        self.peak_queue_bytes = self.peak_queue_bytes.max(waiting);
        self.accepted += len;
        let at = self.sent_at(self.accepted);
        self.frames.push_back((at, frame));
        true
    }

    /// The next frame whose last byte has left by `now`, with the time it left (at or before
    /// `now`: a caller that polls late still gets the exact time). Frames come out in the
    /// order they were accepted.
    pub fn poll(&mut self, now: Time) -> Option<(Time, Vec<u8>)> {
        match self.frames.front() {
            Some((at, _)) if *at <= now => self.frames.pop_front(),
            _ => None,
        }
    }

    /// When the next frame leaves, if one is waiting.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.frames.front().map(|(at, _)| *at)
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame is waiting.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }
}

/// Counts of one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DirectionStats {
    /// Frames that arrived.
    pub frames_in: u64,
    /// Frames sent on (duplicates included).
    pub frames_out: u64,
    /// Bytes that arrived (whole frames, signatures included).
    pub bytes_in: u64,
    /// Bytes sent on (duplicates included).
    pub bytes_out: u64,
    /// Frames dropped (loss or blackout).
    pub dropped: u64,
    /// Frames duplicated.
    pub duplicated: u64,
    /// Frames corrupted.
    pub corrupted: u64,
    /// Frames dropped because the rate limit's queue was full (tail drop; 0 when unlimited).
    pub rate_dropped: u64,
    /// Most bytes waiting at once in the rate limit's queue, bytes (0 when unlimited).
    pub peak_queue_bytes: u64,
}

/// What a relay did, per direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RelayStats {
    /// From the GCS side to the vehicle side.
    pub up: DirectionStats,
    /// From the vehicle side to the GCS side.
    pub down: DirectionStats,
}

/// What a relay does to what it carries, each way (the same in both directions, separately).
#[derive(Clone, Debug, PartialEq)]
pub struct RelayOptions {
    /// Faults of the air, applied to the frames the rate limit lets out.
    pub faults: LinkFaults,
    /// Seed of the faults: the GCS→vehicle direction uses `seed`, the other `seed + 1`.
    pub seed: u64,
    /// Byte rate each way, bytes per second on the relay's clock; 0: unlimited. A
    /// 57,600-baud SiK radio carries about 5,000.
    pub rate: u32,
    /// Queue of each direction when `rate` is set, bytes (default
    /// [`RateLimiter::SIK_QUEUE_BYTES`]; never less than [`RateLimiter::MAX_FRAME_BYTES`]).
    pub queue_bytes: u32,
}

impl Default for RelayOptions {
    /// A perfect, unlimited relay, seed 1 (`fleetmap relay`'s defaults).
    fn default() -> RelayOptions {
        RelayOptions {
            faults: LinkFaults::none(),
            seed: 1,
            rate: 0,
            queue_bytes: RateLimiter::SIK_QUEUE_BYTES,
        }
    }
}

/// One direction: the radio's queue, then the air.
struct Direction {
    radio: RateLimiter,
    channel: FaultyChannel,
    stats: DirectionStats,
}

impl Direction {
    fn new(opts: &RelayOptions, seed: u64) -> Direction {
        Direction {
            radio: RateLimiter::new(opts.rate, opts.queue_bytes),
            channel: FaultyChannel::new(opts.faults.clone(), seed),
            stats: DirectionStats::default(),
        }
    }

    fn arrive(&mut self, raw: Vec<u8>, now: Time) {
        self.stats.frames_in += 1;
        self.stats.bytes_in += raw.len() as u64;
        self.radio.push(raw, now);
    }

    /// Send on `out` everything due by `now`.
    fn deliver(&mut self, now: Time, out: &LinkHandle) {
        while let Some((left, frame)) = self.radio.poll(now) {
            self.channel.push(frame, left);
        }
        while let Some(frame) = self.channel.poll(now) {
            self.stats.frames_out += 1;
            self.stats.bytes_out += frame.len() as u64;
            out.send_raw(frame);
        }
    }

    fn poll_timeout(&self) -> Option<Time> {
        match (self.radio.poll_timeout(), self.channel.poll_timeout()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn snapshot(&self) -> DirectionStats {
        DirectionStats {
            dropped: self.channel.dropped,
            duplicated: self.channel.duplicated,
            corrupted: self.channel.corrupted,
            rate_dropped: self.radio.dropped,
            peak_queue_bytes: self.radio.peak_queue_bytes,
            ..self.stats
        }
    }
}

/// A relay whose two links are open (bound, listening or connecting), ready to [`Relay::run`].
#[derive(Debug)]
pub struct Relay {
    gcs: LinkHandle,
    gcs_rx: mpsc::Receiver<LinkEvent>,
    vehicle: LinkHandle,
    vehicle_rx: mpsc::Receiver<LinkEvent>,
    opts: RelayOptions,
    /// The clock the rate and the faults run on (`None`: the wall clock, or tokio's paused
    /// one).
    clock: Option<MonotonicClock>,
}

impl Relay {
    /// The local address of the GCS's side when it is a UDP socket or a TCP listener (what a
    /// port 0 became).
    #[cfg(test)]
    pub(crate) fn gcs_local(&self) -> Option<SocketAddr> {
        self.gcs.local
    }

    /// The same relay on `clock`: a radio beside a simulator that runs faster or slower than
    /// real time (a `MonotonicClock::following` its time) carries its bytes per second of
    /// simulated time, as a radio in the simulated world would.
    pub fn with_clock(mut self, clock: MonotonicClock) -> Relay {
        self.clock = Some(clock);
        self
    }

    /// Open the GCS's side `gcs` and the vehicle's side `vehicle` (any connection strings but
    /// `memory:`; binding happens now, so errors are immediate and a port 0 is known at once).
    pub async fn open(
        gcs: ConnSpec,
        vehicle: ConnSpec,
        opts: RelayOptions,
    ) -> Result<Relay, LinkError> {
        let link_opts = LinkOptions::default();
        let (g_tx, gcs_rx) = mpsc::channel(4096);
        let (v_tx, vehicle_rx) = mpsc::channel(4096);
        let gcs = open_link(0, gcs, &link_opts, g_tx).await?;
        let vehicle = open_link(1, vehicle, &link_opts, v_tx).await?;
        Ok(Relay {
            gcs,
            gcs_rx,
            vehicle,
            vehicle_rx,
            opts,
            clock: None,
        })
    }

    /// A relay between two in-process links (`link::transport::open_memory_link`, named
    /// `NAME-gcs` and `NAME-vehicle`), for tests on a paused clock; must be called inside a
    /// tokio runtime. Returns the relay, the GCS's end and the vehicle's end. On each end,
    /// `to_gcs` takes the bytes that side sends into the relay and `from_gcs` yields the frames
    /// the relay passes to it, one per item; the vehicle's end can be handed as it is to
    /// `sim::server::spawn_memory`.
    pub fn memory(name: &str, opts: RelayOptions) -> (Relay, MemoryPort, MemoryPort) {
        let link_opts = LinkOptions::default();
        let (g_tx, gcs_rx) = mpsc::channel(4096);
        let (v_tx, vehicle_rx) = mpsc::channel(4096);
        let (gcs, gcs_end) = open_memory_link(0, &format!("{name}-gcs"), &link_opts, g_tx);
        let (vehicle, vehicle_end) =
            open_memory_link(1, &format!("{name}-vehicle"), &link_opts, v_tx);
        let relay = Relay {
            gcs,
            gcs_rx,
            vehicle,
            vehicle_rx,
            opts,
            clock: None,
        };
        (relay, gcs_end, vehicle_end)
    }

    /// The local address of the vehicle's side when it is a UDP socket or a TCP listener.
    pub fn vehicle_local(&self) -> Option<SocketAddr> {
        self.vehicle.local
    }

    /// Relay until `stop` resolves or a link's task ends; `report` gets the counts every
    /// `every`. Returns the final counts (frames still queued then are not counted as sent).
    pub async fn run<F>(
        self,
        every: Duration,
        mut report: impl FnMut(&RelayStats),
        stop: F,
    ) -> RelayStats
    where
        F: std::future::Future<Output = ()>,
    {
        let Relay {
            gcs: g,
            mut gcs_rx,
            vehicle: v,
            mut vehicle_rx,
            opts,
            clock,
        } = self;
        let clock = clock.unwrap_or_default();
        let mut up = Direction::new(&opts, opts.seed);
        let mut down = Direction::new(&opts, opts.seed.wrapping_add(1));
        let stats = |up: &Direction, down: &Direction| RelayStats {
            up: up.snapshot(),
            down: down.snapshot(),
        };
        let mut next_report = clock.now() + every;
        tokio::pin!(stop);
        loop {
            let now = clock.now();
            up.deliver(now, &v);
            down.deliver(now, &g);
            if now >= next_report {
                report(&stats(&up, &down));
                next_report = now + every;
            }
            let mut wake: Time = next_report;
            for t in [up.poll_timeout(), down.poll_timeout()]
                .into_iter()
                .flatten()
            {
                wake = wake.min(t);
            }
            tokio::select! {
                ev = gcs_rx.recv() => match ev {
                    Some(LinkEvent::Frame { frame, .. }) => up.arrive(frame.raw, clock.now()),
                    Some(LinkEvent::Status { .. }) => {}
                    None => break,
                },
                ev = vehicle_rx.recv() => match ev {
                    Some(LinkEvent::Frame { frame, .. }) => down.arrive(frame.raw, clock.now()),
                    Some(LinkEvent::Status { .. }) => {}
                    None => break,
                },
                _ = tokio::time::sleep(clock.wall_until(wake)) => {}
                _ = &mut stop => break,
            }
        }
        stats(&up, &down)
    }
}

/// Relay frames between `gcs` and `vehicle` as `opts` says (rate limit, faults, seed) until
/// `stop` resolves; `report` gets the counts every `every`. Returns the final counts, or the
/// error opening a side. [`Relay::open`] then [`Relay::run`] in one call (`fleetmap relay`).
pub async fn run<F>(
    gcs: ConnSpec,
    vehicle: ConnSpec,
    opts: RelayOptions,
    every: Duration,
    report: impl FnMut(&RelayStats),
    stop: F,
) -> Result<RelayStats, LinkError>
where
    F: std::future::Future<Output = ()>,
{
    Ok(Relay::open(gcs, vehicle, opts)
        .await?
        .run(every, report, stop)
        .await)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::codec::Codec;
    use mavlink::dialects::ardupilotmega::{MavMessage, SYSTEM_TIME_DATA};
    use proptest::prelude::*;
    use tokio::net::UdpSocket;

    /// A frame of `len` bytes whose first four bytes are `id`.
    fn frame(id: u32, len: usize) -> Vec<u8> {
        let mut f = vec![0xAB; len.max(4)];
        f[..4].copy_from_slice(&id.to_le_bytes());
        f
    }

    fn id(f: &[u8]) -> u32 {
        u32::from_le_bytes([f[0], f[1], f[2], f[3]])
    }

    fn ms(t: u64) -> Time {
        Time::from_millis(t)
    }

    /// Ten minutes of a flood (a frame of 20–280 bytes every 5 ms, about six times the rate)
    /// through a 5,000 B/s radio: the bytes that leave in any prefix of the run never exceed
    /// the rate times the time since the first arrival, and over the run they carry 5,000 B/s
    /// within 1 %; frames leave in order, one after the other.
    #[test]
    fn rate_is_respected_over_a_long_run() {
        let mut r = RateLimiter::new(5000, RateLimiter::SIK_QUEUE_BYTES);
        let mut lcg = 12345u64;
        let mut out: Vec<(Time, Vec<u8>)> = Vec::new();
        let end = 600_000u64; // ms
        for (i, t) in (0..end).step_by(5).enumerate() {
            lcg = lcg
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let len = 20 + ((lcg >> 33) % 261) as usize;
            r.push(frame(i as u32, len), ms(t));
            while let Some(f) = r.poll(ms(t)) {
                out.push(f);
            }
            assert!(r.queued_bytes(ms(t)) <= u64::from(RateLimiter::SIK_QUEUE_BYTES));
        }
        let mut bytes = 0u64;
        for (k, (at, f)) in out.iter().enumerate() {
            bytes += f.len() as u64;
            // a byte leaves no earlier than 200 µs after the one before it
            assert!(
                bytes * 200 <= at.as_micros() + 1,
                "frame {k}: {bytes} B by {at}"
            );
            if k > 0 {
                assert!(id(f) > id(&out[k - 1].1), "out of order at {k}");
                assert!(*at >= out[k - 1].0);
            }
        }
        let secs = end as f64 / 1000.0;
        let rate = bytes as f64 / secs;
        eprintln!(
            "{bytes} B in {secs} s: {rate:.2} B/s, {} frames dropped",
            r.dropped
        );
        assert!((rate - 5000.0).abs() < 50.0, "{rate:.1} B/s");
        assert!(r.dropped > 0);
        assert_eq!(out.len() as u64 + r.dropped + r.len() as u64, end / 5);
    }

    /// A burst that fits the queue is accepted whole at once, then leaves at the rate: each
    /// frame when its last byte has gone, and what waits shrinks byte by byte.
    #[test]
    fn a_burst_queues_then_drains() {
        let mut r = RateLimiter::new(1000, 1850);
        for i in 0..6 {
            assert!(r.push(frame(i, 300), Time::ZERO));
        }
        assert_eq!(r.peak_queue_bytes, 1800);
        assert_eq!(r.queued_bytes(Time::ZERO), 1800);
        assert_eq!(r.poll_timeout(), Some(ms(300)));
        assert_eq!(r.poll(ms(299)), None);
        assert_eq!(r.queued_bytes(ms(450)), 1350);
        let (at, f) = r.poll(ms(450)).unwrap();
        assert_eq!((at, id(&f)), (ms(300), 0));
        assert_eq!(r.poll(ms(450)), None);
        assert_eq!(r.poll_timeout(), Some(ms(600)));
        let rest: Vec<(Time, u32)> = std::iter::from_fn(|| r.poll(ms(5000)))
            .map(|(t, f)| (t, id(&f)))
            .collect();
        assert_eq!(
            rest,
            vec![
                (ms(600), 1),
                (ms(900), 2),
                (ms(1200), 3),
                (ms(1500), 4),
                (ms(1800), 5)
            ]
        );
        assert_eq!(r.queued_bytes(ms(1800)), 0);
        assert_eq!(r.dropped, 0);
        assert!(r.is_empty());
    }

    /// A frame that would overflow the queue is dropped and counted; the frames before it
    /// still leave on time, a smaller frame that fits is still taken, and room comes back as
    /// bytes leave.
    #[test]
    fn overflow_drops_the_tail_and_counts() {
        let mut r = RateLimiter::new(1000, 1000);
        assert!(r.push(frame(0, 300), Time::ZERO));
        assert!(r.push(frame(1, 300), Time::ZERO));
        assert!(r.push(frame(2, 300), Time::ZERO));
        assert!(!r.push(frame(3, 300), Time::ZERO), "1200 B > 1000 B");
        assert_eq!(r.dropped, 1);
        assert!(r.push(frame(4, 100), Time::ZERO), "exactly full");
        assert!(!r.push(frame(5, 4), Time::ZERO));
        assert_eq!(r.peak_queue_bytes, 1000);
        // 250 ms later 250 bytes have left: room for 250, not 300
        assert!(!r.push(frame(6, 300), ms(250)));
        assert!(r.push(frame(7, 250), ms(250)));
        assert_eq!(r.dropped, 3);
        let got: Vec<(Time, u32)> = std::iter::from_fn(|| r.poll(ms(10_000)))
            .map(|(t, f)| (t, id(&f)))
            .collect();
        assert_eq!(
            got,
            vec![
                (ms(300), 0),
                (ms(600), 1),
                (ms(900), 2),
                (ms(1000), 4),
                (ms(1250), 7)
            ]
        );
    }

    /// Rate 0 is no limit: every frame is released at its arrival, in order, nothing waits
    /// and nothing is dropped.
    #[test]
    fn unlimited_passes_through_at_once() {
        let mut r = RateLimiter::unlimited();
        let t = ms(5);
        for i in 0..10_000 {
            assert!(r.push(frame(i, 280), t));
        }
        assert_eq!(r.queued_bytes(t), 0);
        assert_eq!(r.poll_timeout(), Some(t));
        let out: Vec<(Time, Vec<u8>)> = std::iter::from_fn(|| r.poll(t)).collect();
        assert_eq!(out.len(), 10_000);
        assert!(
            out.iter()
                .enumerate()
                .all(|(i, (at, f))| *at == t && id(f) == i as u32)
        );
        assert_eq!((r.dropped, r.peak_queue_bytes), (0, 0));
        assert_eq!(r.poll_timeout(), None);
    }

    /// An idle radio banks no credit: after a pause, a frame still takes its length over
    /// the rate, and a queue smaller than a frame is raised to the longest frame.
    #[test]
    fn idle_time_gives_no_burst_credit() {
        let mut r = RateLimiter::new(1000, 10);
        assert!(r.push(frame(0, 100), Time::ZERO));
        assert_eq!(r.poll(ms(100)).map(|(t, _)| t), Some(ms(100)));
        assert!(r.push(frame(1, 280), Time::from_secs(10)));
        assert!(!r.push(frame(2, 4), Time::from_secs(10)));
        assert_eq!(r.poll_timeout(), Some(ms(10_280)));
    }

    proptest! {
        /// Whatever the arrivals and the rate: frames leave in order, never before they
        /// arrived nor before their bytes could have left since the radio went busy, what
        /// waits never exceeds the queue, and every frame is either released or dropped.
        #[test]
        fn releases_keep_order_rate_and_queue(
            rate in 1u32..200_000,
            queue in 0u32..5000,
            arrivals in proptest::collection::vec((0u64..50_000, 1usize..300), 1..200),
        ) {
            let mut r = RateLimiter::new(rate, queue);
            let cap = u64::from(queue.max(RateLimiter::MAX_FRAME_BYTES));
            let mut t = 0u64;
            let mut pushed = Vec::new();
            let mut out = Vec::new();
            for (i, (gap, len)) in arrivals.iter().enumerate() {
                t += gap;
                let now = Time::from_micros(t);
                if r.push(frame(i as u32, *len), now) {
                    pushed.push((i as u32, now));
                }
                prop_assert!(r.queued_bytes(now) <= cap);
                while let Some((at, f)) = r.poll(now) {
                    prop_assert!(at <= now);
                    out.push((at, f));
                }
            }
            out.extend(std::iter::from_fn(|| r.poll(Time::from_micros(u64::MAX))));
            prop_assert_eq!(out.len() + r.dropped as usize, arrivals.len());
            prop_assert_eq!(out.len(), pushed.len());
            for (k, ((at, f), (i, arrived))) in out.iter().zip(&pushed).enumerate() {
                prop_assert_eq!(id(f), *i);
                let cost_us = (f.len() as u128 * 1_000_000).div_ceil(u128::from(rate));
                prop_assert!(u128::from(at.as_micros()) >= u128::from(arrived.as_micros()) + cost_us);
                if k > 0 {
                    let (before, _) = &out[k - 1];
                    prop_assert!(u128::from(at.as_micros()) >= u128::from(before.as_micros()) + cost_us - 1);
                }
            }
        }
    }

    /// 500 frames each way through a relay that loses 30 %: about 350 arrive on each side,
    /// whole (they decode), and the counts add up.
    #[tokio::test]
    async fn relays_frames_both_ways_losing_some() {
        let gcs: ConnSpec = "udpin:127.0.0.1:0".parse().unwrap();
        let veh: ConnSpec = "udpin:127.0.0.1:0".parse().unwrap();
        let opts = RelayOptions {
            faults: LinkFaults {
                loss: 0.3,
                ..LinkFaults::default()
            },
            seed: 7,
            ..RelayOptions::default()
        };
        let relay = Relay::open(gcs, veh, opts).await.unwrap();
        let (gp, vp) = (
            relay.gcs_local().unwrap().port(),
            relay.vehicle_local().unwrap().port(),
        );
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
        let relay = tokio::spawn(relay.run(Duration::from_secs(60), |_| {}, async move {
            let _ = stop_rx.await;
        }));
        let g = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let v = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        // Read only after everything is sent: the default buffer holds ~170 datagrams.
        crate::link::transport::enlarge_recv_buffer(&v);
        let mut c = Codec::new();
        let ping = |seq| {
            MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: 0,
                time_boot_ms: seq,
            })
        };
        // The vehicle side learns the vehicle's address from its first frame.
        v.send_to(&c.encode(1, 1, &ping(0), 0), ("127.0.0.1", vp))
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
        for i in 0..500 {
            g.send_to(&c.encode(255, 190, &ping(i), 0), ("127.0.0.1", gp))
                .await
                .unwrap();
            if i % 50 == 0 {
                tokio::time::sleep(Duration::from_millis(5)).await;
            }
        }
        let mut got = 0;
        let mut buf = [0u8; 512];
        let mut rx = Codec::new();
        while let Ok(Ok((n, _))) =
            tokio::time::timeout(Duration::from_millis(500), v.recv_from(&mut buf)).await
        {
            got += rx.decode(&buf[..n], 0).len();
        }
        let _ = stop_tx.send(());
        let stats = relay.await.unwrap();
        assert_eq!(stats.up.frames_in, 500);
        assert_eq!(stats.up.frames_out + stats.up.dropped, 500);
        assert_eq!(got as u64, stats.up.frames_out);
        assert!((300..=400).contains(&got), "{got} of 500 arrived");
        assert_eq!(stats.down.frames_in, 1);
        assert_eq!((stats.up.rate_dropped, stats.up.peak_queue_bytes), (0, 0));
    }
}
