//! A MAVLink relay between two links that models a pair of telemetry radios
//! ([`super::radio`]: a byte budget on the air, shared by both directions or one each way, a
//! buffer in each radio, loss on the air, RADIO_STATUS reports), then the other faults of a
//! link — duplication, delay, corruption, blackouts ([`super::faults`]): `fleetmap relay --gcs
//! CONN --vehicle CONN --radio 2000 --loss 0.1`. It puts a field radio between any GCS and
//! any autopilot — a real SITL, a flight controller on a serial port — so that transfers
//! and telemetry can be judged under a radio's budget and its losses against the real thing
//! and not only against the embedded simulator.
//!
//! Frames are relayed whole and unchanged (their bytes, signature included); what does not
//! decode as a frame (garbage, a bad CRC) is not relayed. The radio pair and each
//! direction's [`FaultyChannel`] are seeded and run on the relay's clock
//! ([`MonotonicClock`]): the wall clock (or tokio's paused clock in tests), a simulator's
//! time in the same process ([`Relay::with_clock`] with `MonotonicClock::following`), or the
//! vehicles' own time as their messages tell it (`MonotonicClock::vehicles`: the relay
//! feeds it the `time_boot_ms` of what the vehicle side sends, [`vehicle_boot_time`]) — so
//! that a radio beside a simulator at ×5 carries its bytes per second of the vehicles' time,
//! five times as many per wall second. Both ends are ordinary links, so every connection
//! string works on either side, and a `udpin` or `tcpin` side serves several peers at once;
//! [`Relay::memory`] and [`Relay::for_fleet`] make both ends in-process links.
//!
//! In a test over sockets: `let relay = Relay::open(gcs, vehicle, RelayOptions { radio:
//! RadioConfig::radio(2000), ..RelayOptions::default() }).await?;` (port 0 is fine:
//! [`Relay::vehicle_local`] says where it listens), then `tokio::spawn(relay.run(every,
//! report, stop))`.
//!
//! In process, every simulated vehicle behind its own radio to one fleet (the fleet sees
//! one in-process link per vehicle; `tests/suite/radio_fleet.rs` runs exactly this):
//!
//! ```text
//! let (ev_tx, ev_rx) = tokio::sync::mpsc::channel(4096);
//! let (mut links, mut ports, mut radios) = (Vec::new(), Vec::new(), Vec::new());
//! for (i, sysid) in sim.sysids().into_iter().enumerate() {
//!     let opts = RelayOptions { radio: RadioConfig { loss: 0.1, ..RadioConfig::radio(2000) },
//!                               seed: u64::from(sysid), ..RelayOptions::default() };
//!     let (relay, link, port) = Relay::for_fleet(&format!("radio-{sysid}"), opts, i, ev_tx.clone());
//!     links.push(link);            // the fleet's link to this vehicle
//!     ports.push(port);            // the vehicle's side, for the simulator
//!     radios.push(tokio::spawn(relay.run(every, |_| {}, stop.clone())));
//! }
//! let sim = fleetmap_sim::server::spawn_memory(sim, ports);   // on the runtime's clock
//! let fleet = fleet::spawn(links, ev_rx, FleetConfig::default(), MonotonicClock::new());
//! ```
//!
//! `spawn_memory` runs the vehicles on the runtime's clock, which is the relay's default
//! clock too. A simulator served over sockets at a speed-up (`fleetmap_sim::server::spawn`)
//! publishes its time: give each relay `.with_clock(handle.clock())` so that its budget is
//! counted in that time (`tests/suite/bandit_radio.rs`).

use super::addr::ConnSpec;
use super::codec::Frame;
use super::faults::{FaultyChannel, LinkFaults};
use super::radio::{Carried, End, EndCounts, MessageCounts, RadioConfig, RadioPair, message_id};
use super::transport::{
    LinkError, LinkEvent, LinkHandle, LinkId, LinkOptions, MemoryPort, open_link, open_memory_link,
};
use crate::clock::MonotonicClock;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::MavMessage;
use serde::Serialize;
use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::time::Duration;
use tokio::sync::mpsc;

/// Counts of one direction.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DirectionStats {
    /// Frames that arrived.
    pub frames_in: u64,
    /// Frames sent on (duplicates included).
    pub frames_out: u64,
    /// Bytes that arrived (whole frames, signatures included).
    pub bytes_in: u64,
    /// Bytes sent on (duplicates included).
    pub bytes_out: u64,
    /// Frames lost on the radio's air (they used their airtime).
    pub lost: u64,
    /// Frames dropped by the link faults after the air (their loss, or a blackout).
    pub dropped: u64,
    /// Frames duplicated.
    pub duplicated: u64,
    /// Frames corrupted.
    pub corrupted: u64,
    /// Frames dropped because the sending radio's buffer was full (tail drop; 0 when
    /// unlimited).
    pub rate_dropped: u64,
    /// Most bytes waiting at once in the sending radio's buffer, bytes.
    pub peak_queue_bytes: u64,
    /// Time this direction held the air, µs of the relay's clock (0 when unlimited).
    pub air_us: u64,
    /// Per MAVLink message id: what arrived, was dropped on a full buffer, was lost on the
    /// air, and was sent on (`frames_out`/`bytes_out`: after the link faults, by the id in
    /// the bytes sent).
    pub by_message: BTreeMap<u32, MessageCounts>,
}

/// What a relay did.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RelayStats {
    /// From the GCS side to the vehicle side.
    pub up: DirectionStats,
    /// From the vehicle side to the GCS side.
    pub down: DirectionStats,
    /// The GCS's radio: RADIO_STATUS written into the GCS side, its receive errors.
    pub gcs_radio: EndCounts,
    /// The vehicle's radio: RADIO_STATUS written into the vehicle side, its receive errors.
    pub vehicle_radio: EndCounts,
    /// Time on the relay's clock since the relay started, µs (the vehicles' time with
    /// `MonotonicClock::vehicles`): divide bytes by it for bytes per second of that time.
    pub clock_us: u64,
    /// Wall time since the relay started, µs.
    pub wall_us: u64,
}

/// What a relay does to what it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct RelayOptions {
    /// The radio pair between the two sides (default: unlimited, lossless, no reports).
    pub radio: RadioConfig,
    /// Faults applied to the frames the radio delivers, each way.
    pub faults: LinkFaults,
    /// Seed: the faults GCS→vehicle use `seed`, vehicle→GCS `seed + 1`; the radios'
    /// losses `seed + 2` (GCS's radio) and `seed + 3`.
    pub seed: u64,
}

impl Default for RelayOptions {
    /// A perfect, unlimited relay, seed 1 (`fleetmap relay`'s defaults).
    fn default() -> RelayOptions {
        RelayOptions {
            radio: RadioConfig::unlimited(),
            faults: LinkFaults::none(),
            seed: 1,
        }
    }
}

/// The time since boot a vehicle's autopilot (component 1) stamped on `frame`, with its
/// system id: the `time_boot_ms` of SYSTEM_TIME, ATTITUDE, ATTITUDE_QUATERNION,
/// LOCAL_POSITION_NED, GLOBAL_POSITION_INT, SCALED_IMU/2/3, SCALED_PRESSURE/2/3 or
/// RC_CHANNELS (ArduPilot and PX4 fill it from their boot clock; messages stamped with
/// `time_usec` are left out: some carry Unix time or wrap). 0 is left out too (a field never
/// filled).
pub fn vehicle_boot_time(frame: &Frame) -> Option<(u8, Duration)> {
    if frame.compid() != fleetmap_core::proto::AUTOPILOT_COMPID {
        return None;
    }
    let ms = match frame.message.as_ref().ok()? {
        MavMessage::SYSTEM_TIME(d) => d.time_boot_ms,
        MavMessage::ATTITUDE(d) => d.time_boot_ms,
        MavMessage::ATTITUDE_QUATERNION(d) => d.time_boot_ms,
        MavMessage::LOCAL_POSITION_NED(d) => d.time_boot_ms,
        MavMessage::GLOBAL_POSITION_INT(d) => d.time_boot_ms,
        MavMessage::SCALED_IMU(d) => d.time_boot_ms,
        MavMessage::SCALED_IMU2(d) => d.time_boot_ms,
        MavMessage::SCALED_IMU3(d) => d.time_boot_ms,
        MavMessage::SCALED_PRESSURE(d) => d.time_boot_ms,
        MavMessage::SCALED_PRESSURE2(d) => d.time_boot_ms,
        MavMessage::SCALED_PRESSURE3(d) => d.time_boot_ms,
        MavMessage::RC_CHANNELS(d) => d.time_boot_ms,
        _ => return None,
    };
    (ms > 0).then(|| (frame.sysid(), Duration::from_millis(u64::from(ms))))
}

/// One direction after the air: its faults, and what it sent on.
struct Outbound {
    channel: FaultyChannel,
    frames: u64,
    bytes: u64,
    by_message: BTreeMap<u32, (u64, u64)>,
}

impl Outbound {
    fn new(faults: &LinkFaults, seed: u64) -> Outbound {
        Outbound {
            channel: FaultyChannel::new(faults.clone(), seed),
            frames: 0,
            bytes: 0,
            by_message: BTreeMap::new(),
        }
    }

    /// Send on `out` everything the faults let through by `now`.
    fn deliver(&mut self, now: Time, out: &LinkHandle) {
        while let Some(frame) = self.channel.poll(now) {
            let len = frame.len() as u64;
            self.frames += 1;
            self.bytes += len;
            if let Some(id) = message_id(&frame) {
                let e = self.by_message.entry(id).or_default();
                e.0 += 1;
                e.1 += len;
            }
            out.send_raw(frame);
        }
    }

    /// The relay's counts of this direction, from the radio's and this side's.
    fn stats(&self, radio: &super::radio::DirectionCounts) -> DirectionStats {
        let mut by_message = radio.by_message.clone();
        for m in by_message.values_mut() {
            m.frames_out = 0;
            m.bytes_out = 0;
        }
        for (id, (frames, bytes)) in &self.by_message {
            let m = by_message.entry(*id).or_default();
            m.frames_out = *frames;
            m.bytes_out = *bytes;
        }
        DirectionStats {
            frames_in: radio.frames_in,
            frames_out: self.frames,
            bytes_in: radio.bytes_in,
            bytes_out: self.bytes,
            lost: radio.lost,
            dropped: self.channel.dropped,
            duplicated: self.channel.duplicated,
            corrupted: self.channel.corrupted,
            rate_dropped: radio.dropped,
            peak_queue_bytes: radio.peak_buffer_bytes,
            air_us: radio.air_us,
            by_message,
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
    /// The clock the radio and the faults run on (`None`: the wall clock, or tokio's
    /// paused one).
    clock: Option<MonotonicClock>,
}

impl Relay {
    /// The local address of the GCS's side when it is a UDP socket or a TCP listener (what a
    /// port 0 became).
    pub fn gcs_local(&self) -> Option<SocketAddr> {
        self.gcs.local
    }

    /// The local address of the vehicle's side when it is a UDP socket or a TCP listener.
    pub fn vehicle_local(&self) -> Option<SocketAddr> {
        self.vehicle.local
    }

    /// The same relay on `clock`: beside a simulator that runs faster or slower than real
    /// time (`MonotonicClock::following` its time), or on the vehicles' own time
    /// (`MonotonicClock::vehicles`, which the relay then feeds from what the vehicle side
    /// sends), the radio carries its bytes per second of the vehicles' time, as a radio in
    /// their world would.
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

    /// A relay whose GCS side is a fleet's in-process link: returns the relay, the link to
    /// give the fleet (id `link`, its events on `events`, named `NAME`) and the vehicle's end
    /// to give the simulator (`sim::server::spawn_memory`). [`Relay::memory`] with the GCS's
    /// end joined to the fleet's link by two forwarding tasks (which end when either side
    /// closes); must be called inside a tokio runtime.
    pub fn for_fleet(
        name: &str,
        opts: RelayOptions,
        link: LinkId,
        events: mpsc::Sender<LinkEvent>,
    ) -> (Relay, LinkHandle, MemoryPort) {
        let (relay, relay_gcs, vehicle_end) = Relay::memory(name, opts);
        let (handle, fleet_end) = open_memory_link(link, name, &LinkOptions::default(), events);
        let forward = |mut from: mpsc::UnboundedReceiver<Vec<u8>>,
                       to: mpsc::UnboundedSender<Vec<u8>>| {
            tokio::spawn(async move {
                while let Some(bytes) = from.recv().await {
                    if to.send(bytes).is_err() {
                        return;
                    }
                }
            })
        };
        // what the fleet sends goes into the relay's GCS side, and back
        forward(fleet_end.from_gcs, relay_gcs.to_gcs);
        forward(relay_gcs.from_gcs, fleet_end.to_gcs);
        (relay, handle, vehicle_end)
    }

    /// Relay until `stop` resolves or a link's task ends; `report` gets the counts every
    /// `every` of the relay's clock. Returns the final counts (frames still in a radio or on
    /// the air then are not counted as sent).
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
        let wall = MonotonicClock::new();
        let start = clock.now();
        let mut pair = RadioPair::new(opts.radio.clone(), opts.seed.wrapping_add(2));
        let mut up = Outbound::new(&opts.faults, opts.seed);
        let mut down = Outbound::new(&opts.faults, opts.seed.wrapping_add(1));
        let stats = |pair: &RadioPair, up: &Outbound, down: &Outbound, now: Time| {
            let r = pair.stats();
            RelayStats {
                up: up.stats(&r.up),
                down: down.stats(&r.down),
                gcs_radio: r.gcs,
                vehicle_radio: r.vehicle,
                clock_us: now.saturating_since(start).as_micros() as u64,
                wall_us: wall.now().as_micros(),
            }
        };
        let mut next_report = start + every;
        tokio::pin!(stop);
        loop {
            let now = clock.now();
            while let Some(d) = pair.poll(now) {
                match (d.carried, d.to) {
                    (Carried::Status, End::Gcs) => {
                        g.send_raw(d.frame);
                    }
                    (Carried::Status, End::Vehicle) => {
                        v.send_raw(d.frame);
                    }
                    (Carried::Air, End::Vehicle) => up.channel.push(d.frame, d.at),
                    (Carried::Air, End::Gcs) => down.channel.push(d.frame, d.at),
                }
            }
            up.deliver(now, &v);
            down.deliver(now, &g);
            if now >= next_report {
                report(&stats(&pair, &up, &down, now));
                next_report = now + every;
            }
            let mut wake: Time = next_report;
            for t in [
                pair.poll_timeout(),
                up.channel.poll_timeout(),
                down.channel.poll_timeout(),
            ]
            .into_iter()
            .flatten()
            {
                wake = wake.min(t);
            }
            tokio::select! {
                ev = gcs_rx.recv() => match ev {
                    Some(LinkEvent::Frame { frame, .. }) => {
                        pair.push(End::Gcs, frame.raw, clock.now());
                    }
                    Some(LinkEvent::Status { .. }) => {}
                    None => break,
                },
                ev = vehicle_rx.recv() => match ev {
                    Some(LinkEvent::Frame { frame, .. }) => {
                        if let (Some(vt), Some((sys, boot))) =
                            (clock.vehicle_time(), vehicle_boot_time(&frame))
                        {
                            vt.observe(sys, boot);
                        }
                        pair.push(End::Vehicle, frame.raw, clock.now());
                    }
                    Some(LinkEvent::Status { .. }) => {}
                    None => break,
                },
                _ = tokio::time::sleep(clock.wall_until(wake)) => {}
                _ = &mut stop => break,
            }
        }
        stats(&pair, &up, &down, clock.now())
    }
}

/// Relay frames between `gcs` and `vehicle` as `opts` says (radio, faults, seed) on `clock`
/// (`None`: the wall clock) until `stop` resolves; `report` gets the counts every `every`.
/// Returns the final counts, or the error opening a side. [`Relay::open`] then
/// [`Relay::run`] in one call (`fleetmap relay`).
pub async fn run<F>(
    gcs: ConnSpec,
    vehicle: ConnSpec,
    opts: RelayOptions,
    clock: Option<MonotonicClock>,
    every: Duration,
    report: impl FnMut(&RelayStats),
    stop: F,
) -> Result<RelayStats, LinkError>
where
    F: std::future::Future<Output = ()>,
{
    let mut relay = Relay::open(gcs, vehicle, opts).await?;
    if let Some(c) = clock {
        relay = relay.with_clock(c);
    }
    Ok(relay.run(every, report, stop).await)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::codec::Codec;
    use mavlink::dialects::ardupilotmega::{
        ATTITUDE_DATA, GLOBAL_POSITION_INT_DATA, HEARTBEAT_DATA, SYSTEM_TIME_DATA,
    };
    use tokio::net::UdpSocket;

    fn decoded(sys: u8, comp: u8, msg: &MavMessage) -> Frame {
        let bytes = Codec::new().encode(sys, comp, msg, 0);
        Codec::new().decode(&bytes, 0).remove(0)
    }

    /// The autopilot's boot time is read from its time-stamped messages, not from other
    /// components, messages without a time, or a time of 0.
    #[test]
    fn boot_time_of_the_autopilots_messages() {
        let att = MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: 12_345,
            ..ATTITUDE_DATA::default()
        });
        assert_eq!(
            vehicle_boot_time(&decoded(3, 1, &att)),
            Some((3, Duration::from_millis(12_345)))
        );
        let pos = MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            time_boot_ms: 7,
            ..GLOBAL_POSITION_INT_DATA::default()
        });
        assert_eq!(
            vehicle_boot_time(&decoded(1, 1, &pos)),
            Some((1, Duration::from_millis(7)))
        );
        let st = MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
            time_unix_usec: 0,
            time_boot_ms: 99,
        });
        assert_eq!(
            vehicle_boot_time(&decoded(2, 1, &st)),
            Some((2, Duration::from_millis(99)))
        );
        // a camera's time is not the autopilot's
        assert_eq!(vehicle_boot_time(&decoded(1, 100, &att)), None);
        let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
        assert_eq!(vehicle_boot_time(&decoded(1, 1, &hb)), None);
        let zero = MavMessage::ATTITUDE(ATTITUDE_DATA::default());
        assert_eq!(vehicle_boot_time(&decoded(1, 1, &zero)), None);
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
            g.send_to(
                &c.encode(
                    fleetmap_core::proto::GCS_SYSID,
                    fleetmap_core::proto::GCS_COMPID,
                    &ping(i),
                    0,
                ),
                ("127.0.0.1", gp),
            )
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
