//! A MAVLink relay between two links that loses, duplicates, delays and corrupts frames on
//! the way ([`super::faults`]): `fleetmap relay --gcs CONN --vehicle CONN --loss 0.3`. It
//! puts a field radio's faults between any GCS and any autopilot — a real SITL, a
//! flight controller on a serial port — so that transfers can be judged under loss against
//! the real thing and not only against the embedded simulator.
//!
//! Frames are relayed whole and unchanged (their bytes, signature included); what does not
//! decode as a frame (garbage, a bad CRC) is not relayed. Each direction has its own
//! [`FaultyChannel`], seeded, on the wall clock. Both ends are ordinary links, so every
//! connection string works on either side, and a `udpin` or `tcpin` side serves several
//! peers at once.

use super::addr::ConnSpec;
use super::faults::{FaultyChannel, LinkFaults};
use super::transport::{LinkError, LinkEvent, LinkOptions, open_link};
use crate::clock::MonotonicClock;
use crate::time::Time;
use serde::Serialize;
use std::time::Duration;
use tokio::sync::mpsc;

/// Counts of one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DirectionStats {
    /// Frames that arrived.
    pub frames_in: u64,
    /// Frames sent on (duplicates included).
    pub frames_out: u64,
    /// Frames dropped (loss or blackout).
    pub dropped: u64,
    /// Frames duplicated.
    pub duplicated: u64,
    /// Frames corrupted.
    pub corrupted: u64,
}

/// What a relay did, per direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RelayStats {
    /// From the GCS side to the vehicle side.
    pub up: DirectionStats,
    /// From the vehicle side to the GCS side.
    pub down: DirectionStats,
}

struct Direction {
    channel: FaultyChannel,
    stats: DirectionStats,
}

impl Direction {
    fn new(faults: LinkFaults, seed: u64) -> Direction {
        Direction {
            channel: FaultyChannel::new(faults, seed),
            stats: DirectionStats::default(),
        }
    }

    fn snapshot(&self) -> DirectionStats {
        DirectionStats {
            dropped: self.channel.dropped,
            duplicated: self.channel.duplicated,
            corrupted: self.channel.corrupted,
            ..self.stats
        }
    }
}

/// Relay frames between `gcs` and `vehicle` with `faults` each way (seeded with `seed` and
/// `seed + 1`) until `stop` resolves; `report` gets the counts every `every`. Returns the
/// final counts.
pub async fn run<F>(
    gcs: ConnSpec,
    vehicle: ConnSpec,
    faults: LinkFaults,
    seed: u64,
    every: Duration,
    mut report: impl FnMut(&RelayStats),
    stop: F,
) -> Result<RelayStats, LinkError>
where
    F: std::future::Future<Output = ()>,
{
    let opts = LinkOptions::default();
    let (g_tx, mut g_rx) = mpsc::channel(4096);
    let (v_tx, mut v_rx) = mpsc::channel(4096);
    let g = open_link(0, gcs, &opts, g_tx).await?;
    let v = open_link(1, vehicle, &opts, v_tx).await?;
    let clock = MonotonicClock::new();
    let mut up = Direction::new(faults.clone(), seed);
    let mut down = Direction::new(faults, seed.wrapping_add(1));
    let stats = |up: &Direction, down: &Direction| RelayStats {
        up: up.snapshot(),
        down: down.snapshot(),
    };
    let mut next_report = clock.now() + every;
    tokio::pin!(stop);
    loop {
        let now = clock.now();
        for (d, out) in [(&mut up, &v), (&mut down, &g)] {
            while let Some(frame) = d.channel.poll(now) {
                d.stats.frames_out += 1;
                out.send_raw(frame);
            }
        }
        if now >= next_report {
            report(&stats(&up, &down));
            next_report = now + every;
        }
        let mut wake: Time = next_report;
        for t in [up.channel.poll_timeout(), down.channel.poll_timeout()]
            .into_iter()
            .flatten()
        {
            wake = wake.min(t);
        }
        tokio::select! {
            ev = g_rx.recv() => match ev {
                Some(LinkEvent::Frame { frame, .. }) => {
                    up.stats.frames_in += 1;
                    up.channel.push(frame.raw, clock.now());
                }
                Some(LinkEvent::Status { .. }) => {}
                None => break,
            },
            ev = v_rx.recv() => match ev {
                Some(LinkEvent::Frame { frame, .. }) => {
                    down.stats.frames_in += 1;
                    down.channel.push(frame.raw, clock.now());
                }
                Some(LinkEvent::Status { .. }) => {}
                None => break,
            },
            _ = tokio::time::sleep(clock.wall_until(wake)) => {}
            _ = &mut stop => break,
        }
    }
    Ok(stats(&up, &down))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::codec::Codec;
    use mavlink::dialects::ardupilotmega::{MavMessage, SYSTEM_TIME_DATA};
    use tokio::net::UdpSocket;

    fn free_port() -> u16 {
        std::net::UdpSocket::bind("127.0.0.1:0")
            .and_then(|s| s.local_addr())
            .map(|a| a.port())
            .unwrap_or(0)
    }

    /// 500 frames each way through a relay that loses 30 %: about 350 arrive on each side,
    /// whole (they decode), and the counts add up.
    #[tokio::test]
    async fn relays_frames_both_ways_losing_some() {
        let (gp, vp) = (free_port(), free_port());
        let gcs: ConnSpec = format!("udpin:127.0.0.1:{gp}").parse().unwrap();
        let veh: ConnSpec = format!("udpin:127.0.0.1:{vp}").parse().unwrap();
        let faults = LinkFaults {
            loss: 0.3,
            ..LinkFaults::default()
        };
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
        let relay = tokio::spawn(run(
            gcs,
            veh,
            faults,
            7,
            Duration::from_secs(60),
            |_| {},
            async move {
                let _ = stop_rx.await;
            },
        ));
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
        let stats = relay.await.unwrap().unwrap();
        assert_eq!(stats.up.frames_in, 500);
        assert_eq!(stats.up.frames_out + stats.up.dropped, 500);
        assert_eq!(got as u64, stats.up.frames_out);
        assert!((300..=400).contains(&got), "{got} of 500 arrived");
        assert_eq!(stats.down.frames_in, 1);
    }
}
