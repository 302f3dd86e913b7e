use super::*;
use crate::link::codec::Codec;
use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MavMessage};
use mavlink::{MavHeader, MavlinkVersion};
use proptest::prelude::*;

/// A MAVLink 2 frame of `len` bytes (16–267) with message id `id` whose payload starts with
/// `tag` (the radio reads only the header; the CRC is not checked).
fn frame(id: u32, tag: u32, len: usize) -> Vec<u8> {
    let len = len.clamp(16, 267);
    let mut f = vec![0xABu8; len];
    f[..10].copy_from_slice(&[STX_V2, (len - 12) as u8, 0, 0, 0, 1, 1, 0, 0, 0]);
    f[7..10].copy_from_slice(&id.to_le_bytes()[..3]);
    f[10..14].copy_from_slice(&tag.to_le_bytes());
    f
}

fn tag(f: &[u8]) -> u32 {
    u32::from_le_bytes([f[10], f[11], f[12], f[13]])
}

fn ms(t: u64) -> Time {
    Time::from_millis(t)
}

/// A real HEARTBEAT from (1, 1) in MAVLink 2 (`v2`) or 1.
fn heartbeat(v2: bool) -> Vec<u8> {
    let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
    let header = MavHeader {
        system_id: 1,
        component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
        sequence: 0,
    };
    let version = if v2 {
        MavlinkVersion::V2
    } else {
        MavlinkVersion::V1
    };
    Codec::new().encode_with_header(&header, &msg, version, 0)
}

/// Everything out of `pair` by `now`.
fn drain(pair: &mut RadioPair, now: Time) -> Vec<Delivery> {
    std::iter::from_fn(|| pair.poll(now)).collect()
}

/// A pseudo-random stream (a 64-bit LCG) for floods.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self, n: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % n
    }
}

// ---- one direction at a time (full duplex: the relay's `--rate`) ----

/// Ten minutes of a flood (a frame of 16–267 bytes every 5 ms, about six times the rate)
/// through a 5,000 B/s full-duplex radio: the bytes out by any moment never exceed the rate
/// times the time since the first arrival, over the run they carry 5,000 B/s within 1 %,
/// frames leave in order one after the other, and every frame is out, dropped or waiting.
#[test]
fn full_duplex_rate_is_respected_over_a_long_run() {
    let mut r = RadioPair::new(RadioConfig::per_direction(5000), 1);
    let mut rng = Lcg(12345);
    let mut out: Vec<Delivery> = Vec::new();
    let end = 600_000u64; // ms
    for (i, t) in (0..end).step_by(5).enumerate() {
        let len = 16 + rng.next(252) as usize;
        r.push(End::Gcs, frame(30, i as u32, len), ms(t));
        out.extend(drain(&mut r, ms(t)));
        assert!(r.buffered_bytes(End::Gcs) <= u64::from(RadioConfig::SIK_BUFFER_BYTES));
    }
    let mut bytes = 0u64;
    for (k, d) in out.iter().enumerate() {
        assert_eq!((d.to, d.carried), (End::Vehicle, Carried::Air));
        bytes += d.frame.len() as u64;
        // a byte leaves no earlier than 200 µs after the one before it
        assert!(
            bytes * 200 <= d.at.as_micros() + 1,
            "frame {k}: {bytes} B by {}",
            d.at
        );
        if k > 0 {
            assert!(
                tag(&d.frame) > tag(&out[k - 1].frame),
                "out of order at {k}"
            );
            assert!(d.at >= out[k - 1].at);
        }
    }
    let rate = bytes as f64 / (end as f64 / 1000.0);
    assert!((rate - 5000.0).abs() < 50.0, "{rate:.1} B/s");
    let left = drain(&mut r, Time::from_secs(10_000)).len() as u64;
    let s = r.stats();
    assert!(s.up.dropped > 0);
    assert_eq!(s.up.frames_out, out.len() as u64 + left);
    assert_eq!(s.up.frames_out + s.up.dropped, s.up.frames_in);
    assert_eq!(s.up.frames_in, end / 5);
    assert_eq!(s.down, DirectionCounts::default());
}

/// A burst that fits the buffer is taken whole at once, then leaves at the rate, each
/// frame when its last byte has gone; a frame leaves the buffer as it goes on the air.
#[test]
fn a_burst_queues_then_drains() {
    let mut r = RadioPair::new(
        RadioConfig {
            buffer_bytes: 1850,
            ..RadioConfig::per_direction(1000)
        },
        1,
    );
    for i in 0..6 {
        assert!(r.push(End::Gcs, frame(30, i, 250), Time::ZERO));
    }
    // the first went on the air at once: 5 wait
    assert_eq!(r.buffered_bytes(End::Gcs), 1250);
    assert_eq!(r.stats().up.peak_buffer_bytes, 1250);
    assert_eq!(r.poll_timeout(), Some(ms(250)));
    assert_eq!(r.poll(ms(249)), None);
    let d = r.poll(ms(400)).unwrap();
    assert_eq!((d.at, tag(&d.frame)), (ms(250), 0));
    assert_eq!(r.buffered_bytes(End::Gcs), 1000);
    assert_eq!(r.poll(ms(400)), None);
    assert_eq!(r.poll_timeout(), Some(ms(500)));
    let rest: Vec<(Time, u32)> = drain(&mut r, ms(5000))
        .iter()
        .map(|d| (d.at, tag(&d.frame)))
        .collect();
    assert_eq!(
        rest,
        vec![
            (ms(500), 1),
            (ms(750), 2),
            (ms(1000), 3),
            (ms(1250), 4),
            (ms(1500), 5)
        ]
    );
    assert_eq!(r.buffered_bytes(End::Gcs), 0);
    assert_eq!(r.stats().up.dropped, 0);
    assert_eq!(r.poll_timeout(), None);
}

/// A frame that would overflow the buffer is dropped and counted; the frames before it
/// still leave on time, a smaller one that fits is taken, and room comes back as frames
/// go on the air.
#[test]
fn overflow_drops_the_tail_and_counts() {
    let mut r = RadioPair::new(
        RadioConfig {
            buffer_bytes: 1000,
            ..RadioConfig::per_direction(1000)
        },
        1,
    );
    let t0 = Time::ZERO;
    assert!(r.push(End::Gcs, frame(1, 0, 250), t0)); // on the air at once
    assert!(r.push(End::Gcs, frame(1, 1, 250), t0));
    assert!(r.push(End::Gcs, frame(1, 2, 250), t0));
    assert!(r.push(End::Gcs, frame(1, 3, 250), t0));
    assert!(!r.push(End::Gcs, frame(1, 4, 260), t0), "1010 B > 1000 B");
    assert!(r.push(End::Gcs, frame(1, 5, 250), t0), "exactly full");
    assert!(!r.push(End::Gcs, frame(1, 6, 16), t0));
    assert_eq!(r.stats().up.peak_buffer_bytes, 1000);
    // 200 ms later frame 0 is still on the air: still full
    assert!(!r.push(End::Gcs, frame(1, 7, 20), ms(200)));
    // at 250 ms frame 1 goes on the air: 250 bytes free
    assert!(!r.push(End::Gcs, frame(1, 8, 251), ms(250)));
    assert!(r.push(End::Gcs, frame(1, 9, 250), ms(250)));
    let s = r.stats();
    assert_eq!((s.up.dropped, s.up.bytes_dropped), (4, 260 + 16 + 20 + 251));
    let got: Vec<(Time, u32)> = drain(&mut r, ms(10_000))
        .iter()
        .map(|d| (d.at, tag(&d.frame)))
        .collect();
    assert_eq!(
        got,
        vec![
            (ms(250), 0),
            (ms(500), 1),
            (ms(750), 2),
            (ms(1000), 3),
            (ms(1250), 5),
            (ms(1500), 9)
        ]
    );
}

/// Rate 0 is no limit: every frame comes out when it arrives, in order, nothing is
/// dropped, and nothing uses airtime.
#[test]
fn unlimited_passes_through_at_once() {
    let mut r = RadioPair::new(RadioConfig::unlimited(), 1);
    let t = ms(5);
    for i in 0..10_000 {
        assert!(r.push(End::Vehicle, frame(33, i, 267), t));
    }
    let out = drain(&mut r, t);
    assert_eq!(out.len(), 10_000);
    assert!(
        out.iter()
            .enumerate()
            .all(|(i, d)| d.at == t && tag(&d.frame) == i as u32 && d.to == End::Gcs)
    );
    let s = r.stats();
    assert_eq!(
        (s.down.dropped, s.down.air_us, s.gcs.radio_status),
        (0, 0, 0)
    );
    assert_eq!(r.poll_timeout(), None);
}

/// An idle radio banks no credit: after a pause a frame still takes its length over the
/// rate, and a buffer smaller than a frame is raised to the longest frame.
#[test]
fn idle_time_gives_no_burst_credit() {
    let mut r = RadioPair::new(
        RadioConfig {
            buffer_bytes: 10,
            ..RadioConfig::per_direction(1000)
        },
        1,
    );
    assert!(r.push(End::Gcs, frame(1, 0, 100), Time::ZERO));
    assert_eq!(r.poll(ms(100)).map(|d| d.at), Some(ms(100)));
    assert!(r.push(End::Gcs, frame(1, 1, 267), Time::from_secs(10)));
    assert!(r.push(End::Gcs, frame(1, 2, 267), Time::from_secs(10)));
    assert!(!r.push(End::Gcs, frame(1, 3, 16), Time::from_secs(10)));
    assert_eq!(r.poll_timeout(), Some(ms(10_267)));
}

/// Full duplex: a flood one way does not slow the other.
#[test]
fn full_duplex_directions_are_independent() {
    let mut r = RadioPair::new(RadioConfig::per_direction(1000), 1);
    let mut out = Vec::new();
    for i in 0..100 {
        let t = ms(u64::from(i) * 10);
        r.push(End::Gcs, frame(1, i, 250), t);
        if i == 50 {
            r.push(End::Vehicle, frame(2, 0, 100), t);
        }
        out.extend(drain(&mut r, t));
    }
    out.extend(drain(&mut r, ms(1000)));
    let down: Vec<Time> = out
        .iter()
        .filter(|d| d.to == End::Gcs)
        .map(|d| d.at)
        .collect();
    assert_eq!(down, vec![ms(600)]);
}

// ---- half duplex: one air for both ----

/// Both radios flooded for two minutes, the GCS with small frames and the vehicle with
/// large ones, each at three times the whole budget: the air carries the budget, each
/// direction half of it in bytes within 1 %.
#[test]
fn half_duplex_shares_the_air_fairly_under_load_both_ways() {
    let mut r = RadioPair::new(RadioConfig::radio(2000), 9);
    let secs = 120u64;
    let mut up = 0u64;
    let mut down = 0u64;
    for t in (0..secs * 1000).step_by(10) {
        // 6 kB/s each way: a 30-byte frame every 5 ms, a 240-byte frame every 40 ms
        r.push(End::Gcs, frame(76, 0, 30), ms(t));
        r.push(End::Gcs, frame(76, 0, 30), ms(t + 5));
        if t % 40 == 0 {
            r.push(End::Vehicle, frame(33, 0, 240), ms(t));
        }
        for d in drain(&mut r, ms(t + 5)) {
            match d.to {
                End::Vehicle => up += d.frame.len() as u64,
                End::Gcs => down += d.frame.len() as u64,
            }
        }
    }
    let (up, down) = (up as f64 / secs as f64, down as f64 / secs as f64);
    eprintln!("up {up:.1} B/s, down {down:.1} B/s");
    assert!((up + down - 2000.0).abs() < 20.0, "{up} + {down}");
    assert!((up - 1000.0).abs() < 10.0, "up {up}");
    assert!((down - 1000.0).abs() < 10.0, "down {down}");
    let s = r.stats();
    assert!(s.up.dropped > 0 && s.down.dropped > 0);
    // each direction held the air half the time
    let (a, b) = (s.up.air_us as f64 / 1e6, s.down.air_us as f64 / 1e6);
    assert!(
        (a - 60.0).abs() < 1.0 && (b - 60.0).abs() < 1.0,
        "{a} s, {b} s"
    );
}

/// The vehicle floods while the GCS sends only a heartbeat a second: the GCS's direction
/// gives its time away, the vehicle's gets the whole budget but those heartbeats, and a
/// heartbeat waits at most for the frame on the air.
#[test]
fn half_duplex_an_idle_direction_gives_its_time() {
    let mut r = RadioPair::new(
        RadioConfig {
            radio_status: false,
            ..RadioConfig::radio(2000)
        },
        3,
    );
    let secs = 60u64;
    let mut down = 0u64;
    let mut beats = Vec::new();
    let mut sent = Vec::new();
    for t in (0..secs * 1000).step_by(20) {
        r.push(End::Vehicle, frame(33, 0, 200), ms(t)); // 10 kB/s offered
        if t % 1000 == 0 {
            r.push(End::Gcs, heartbeat(true), ms(t + 7));
            sent.push(ms(t + 7));
        }
        for d in drain(&mut r, ms(t + 19)) {
            match d.to {
                End::Gcs => down += d.frame.len() as u64,
                End::Vehicle => beats.push(d.at),
            }
        }
    }
    let hb = heartbeat(true).len() as u64;
    let rate = down as f64 / secs as f64;
    assert!(
        rate > 2000.0 - hb as f64 - 10.0 && rate <= 2000.0,
        "{rate:.1} B/s down"
    );
    assert_eq!(beats.len(), sent.len());
    let most = Duration::from_micros((200 + hb) * 1_000_000 / 2000 + 1);
    for (s, b) in sent.iter().zip(&beats) {
        assert!(*b > *s && *b - *s <= most, "sent {s}, arrived {b}");
    }
}

/// Each radio has its own buffer: the GCS's flood overflows the GCS's radio, never the
/// vehicle's, whose frames all cross (at their fair share).
#[test]
fn half_duplex_each_radio_has_its_own_buffer() {
    let mut r = RadioPair::new(
        RadioConfig {
            buffer_bytes: 1000,
            radio_status: false,
            ..RadioConfig::radio(1000)
        },
        1,
    );
    for t in (0..30_000u64).step_by(10) {
        r.push(End::Gcs, frame(20, 0, 100), ms(t)); // 10 kB/s offered
        if t % 500 == 0 {
            r.push(End::Vehicle, frame(22, 0, 60), ms(t));
        }
        let _ = drain(&mut r, ms(t));
    }
    let _ = drain(&mut r, ms(60_000));
    let s = r.stats();
    assert!(s.up.dropped > 2000, "{}", s.up.dropped);
    assert!(s.up.peak_buffer_bytes <= 1000);
    assert_eq!((s.down.dropped, s.down.frames_out), (0, 60));
}

/// Over 20,000 frames a 10 % loss loses 10 % within one point; lost frames used their
/// airtime, each is one receive error at the other radio, the counts add up, and the same
/// seed loses the same frames.
#[test]
fn loss_is_close_to_the_configured_fraction() {
    let run = |seed: u64| {
        let mut r = RadioPair::new(
            RadioConfig {
                loss: 0.1,
                radio_status: false,
                ..RadioConfig::radio(10_000)
            },
            seed,
        );
        let mut got = Vec::new();
        for i in 0..20_000u32 {
            let t = ms(u64::from(i) * 10);
            r.push(End::Vehicle, frame(30, i, 50), t);
            got.extend(drain(&mut r, t).into_iter().map(|d| tag(&d.frame)));
        }
        got.extend(
            drain(&mut r, Time::from_secs(1000))
                .into_iter()
                .map(|d| tag(&d.frame)),
        );
        (got, r)
    };
    let (got, r) = run(5);
    let s = r.stats();
    let lost = s.down.lost as f64 / 20_000.0;
    assert!((lost - 0.1).abs() < 0.01, "{lost}");
    assert_eq!(s.down.frames_out + s.down.lost, 20_000);
    assert_eq!(got.len() as u64, s.down.frames_out);
    assert_eq!(s.down.bytes_lost, 50 * s.down.lost);
    // every frame took 5 ms of air, lost or not
    assert_eq!(s.down.air_us, 20_000 * 5_000);
    assert_eq!(u64::from(r.rx_errors(End::Gcs)), s.down.lost);
    assert_eq!(r.rx_errors(End::Vehicle), 0);
    assert_eq!(run(5).0, got);
    assert_ne!(run(6).0, got);
}

/// SiK's receive error count stops at 65,535 instead of wrapping.
#[test]
fn receive_errors_stop_at_their_maximum() {
    let mut r = RadioPair::new(
        RadioConfig {
            loss: 1.0,
            ..RadioConfig::unlimited()
        },
        1,
    );
    for i in 0..70_000 {
        r.push(End::Gcs, frame(1, i, 16), ms(1));
        assert_eq!(r.poll(ms(1)), None);
    }
    assert_eq!(r.rx_errors(End::Vehicle), u16::MAX);
    assert_eq!(r.stats().up.lost, 70_000);
}

/// Bytes and frames per message id add up to the totals, each in its direction.
#[test]
fn counts_per_message_id() {
    let mut r = RadioPair::new(
        RadioConfig {
            buffer_bytes: 300,
            loss: 0.2,
            ..RadioConfig::radio(1000)
        },
        2,
    );
    for i in 0..3000u32 {
        let t = ms(u64::from(i) * 20);
        let (id, len) = [(0, 21), (30, 40), (33, 40), (253, 200)][(i % 4) as usize];
        r.push(End::Vehicle, frame(id, i, len), t);
        if i % 50 == 0 {
            r.push(End::Gcs, frame(66, i, 18), t);
        }
        let _ = drain(&mut r, t);
    }
    let _ = drain(&mut r, Time::from_secs(1000));
    let s = r.stats();
    for d in [&s.up, &s.down] {
        let sum = |f: fn(&MessageCounts) -> u64| d.by_message.values().map(f).sum::<u64>();
        assert_eq!(sum(|m| m.frames_in), d.frames_in);
        assert_eq!(sum(|m| m.bytes_in), d.bytes_in);
        assert_eq!(sum(|m| m.frames_out), d.frames_out);
        assert_eq!(sum(|m| m.bytes_out), d.bytes_out);
        assert_eq!(sum(|m| m.dropped), d.dropped);
        assert_eq!(sum(|m| m.lost), d.lost);
        assert_eq!(d.frames_in, d.frames_out + d.dropped + d.lost);
    }
    assert_eq!(
        s.down.by_message.keys().copied().collect::<Vec<_>>(),
        vec![0, 30, 33, 253]
    );
    assert_eq!(s.down.by_message[&253].bytes_in, 750 * 200);
    assert!(s.down.by_message[&253].dropped > 0);
    assert_eq!(
        s.up.by_message.keys().copied().collect::<Vec<_>>(),
        vec![66]
    );
    assert_eq!(s.up.by_message[&66].frames_in, 60);
}

// ---- RADIO_STATUS ----

/// Decode one frame with the project's codec: (version, sysid, compid, message).
fn decode(f: &[u8]) -> (MavlinkVersion, u8, u8, MavMessage) {
    let frames = Codec::new().decode(f, 0);
    assert_eq!(frames.len(), 1, "{f:?} is not one frame");
    let fr = &frames[0];
    assert_eq!(fr.raw, f);
    (
        fr.version,
        fr.sysid(),
        fr.compid(),
        fr.message.clone().expect("a known message"),
    )
}

/// The vehicle's radio reports when the autopilot's heartbeat leaves its buffer for the
/// air: system 51, component 68, the heartbeat's MAVLink version, what it hears and what
/// the GCS's radio hears, its buffer's free space then (SiK's integer percent), and no
/// airtime used.
#[test]
fn radio_status_reports_what_the_radio_sees() {
    let cfg = RadioConfig {
        gcs_levels: SignalLevels {
            rssi: 120,
            noise: 30,
        },
        vehicle_levels: SignalLevels {
            rssi: 90,
            noise: 50,
        },
        ..RadioConfig::radio(1000)
    };
    let mut r = RadioPair::new(cfg.clone(), 1);
    // a second of frames ahead of the heartbeat, then 2,000 bytes behind it
    for i in 0..4 {
        r.push(End::Vehicle, frame(33, i, 250), Time::ZERO);
    }
    let hb = heartbeat(true);
    r.push(End::Vehicle, hb.clone(), ms(1));
    for i in 0..8 {
        r.push(End::Vehicle, frame(33, 10 + i, 250), ms(500));
    }
    let out = drain(&mut r, ms(999));
    assert!(out.iter().all(|d| d.carried == Carried::Air));
    let out = drain(&mut r, ms(1000));
    let status: Vec<&Delivery> = out
        .iter()
        .filter(|d| d.carried == Carried::Status)
        .collect();
    assert_eq!(status.len(), 1);
    let d = status[0];
    assert_eq!((d.to, d.at, d.frame.len()), (End::Vehicle, ms(1000), 21));
    let (version, sys, comp, msg) = decode(&d.frame);
    assert_eq!((sys, comp), (51, 68));
    assert!(matches!(version, MavlinkVersion::V2));
    let MavMessage::RADIO_STATUS(st) = msg else {
        panic!("{msg:?}")
    };
    // (4096 − 2000) / 8 = 262 of 512 units
    assert_eq!(
        (
            st.rssi,
            st.remrssi,
            st.noise,
            st.remnoise,
            st.txbuf,
            st.rxerrors,
            st.fixed
        ),
        (90, 120, 50, 30, 51, 0, 0)
    );
    assert_eq!(r.stats().vehicle.radio_status, 1);
    assert_eq!(r.stats().gcs.radio_status, 0);
    // the heartbeat crossed at its own time: reports cost no air
    let rest = drain(&mut r, Time::from_secs(100));
    let beat = rest.iter().find(|d| d.frame == hb).unwrap();
    assert_eq!(
        beat.at,
        Time::from_micros(1_000_000 + hb.len() as u64 * 1000)
    );
    assert_eq!(beat.to, End::Gcs);
}

/// A MAVLink 1 heartbeat gets a MAVLink 1 report (17 bytes); the receive errors count the
/// frames this radio missed; each radio numbers its own reports; reports stop when turned
/// off, and a heartbeat dropped on a full buffer brings none.
#[test]
fn radio_status_version_errors_and_triggers() {
    let mut r = RadioPair::new(
        RadioConfig {
            loss: 1.0,
            ..RadioConfig::radio(1000)
        },
        1,
    );
    for i in 0..5 {
        r.push(End::Vehicle, frame(33, i, 100), Time::ZERO);
    }
    // the GCS's heartbeats: 5 frames lost on the way to it before the first goes out
    let mut reports = Vec::new();
    for k in 0..3u64 {
        r.push(End::Gcs, heartbeat(false), Time::from_secs(10 + k));
        reports.extend(drain(&mut r, Time::from_secs(10 + k)));
    }
    assert_eq!(reports.len(), 3);
    for (k, d) in reports.iter().enumerate() {
        assert_eq!(
            (d.to, d.carried, d.frame.len()),
            (End::Gcs, Carried::Status, 17)
        );
        assert_eq!(d.frame[2], k as u8, "sequence");
        let (version, sys, comp, msg) = decode(&d.frame);
        assert!(matches!(version, MavlinkVersion::V1));
        assert_eq!((sys, comp), (51, 68));
        let MavMessage::RADIO_STATUS(st) = msg else {
            panic!()
        };
        assert_eq!((st.rxerrors, st.txbuf), (5, 100));
    }
    // not a heartbeat: no report
    r.push(End::Gcs, frame(76, 0, 40), Time::from_secs(20));
    assert!(drain(&mut r, Time::from_secs(21)).is_empty());
    assert_eq!(r.rx_errors(End::Vehicle), 4);
    // a heartbeat that finds the buffer full is dropped, and brings no report
    let mut full = RadioPair::new(
        RadioConfig {
            buffer_bytes: 300,
            ..RadioConfig::radio(100)
        },
        1,
    );
    full.push(End::Gcs, frame(1, 0, 267), Time::ZERO);
    full.push(End::Gcs, frame(1, 1, 267), Time::ZERO);
    full.push(End::Gcs, frame(1, 2, 30), Time::ZERO);
    assert!(!full.push(End::Gcs, heartbeat(true), Time::ZERO));
    assert!(
        drain(&mut full, Time::from_secs(60))
            .iter()
            .all(|d| d.carried == Carried::Air)
    );
    assert_eq!(full.stats().gcs.radio_status, 0);
    // off: no report at all, and the air frames are the same
    let run = |on: bool| {
        let mut p = RadioPair::new(
            RadioConfig {
                radio_status: on,
                loss: 0.3,
                ..RadioConfig::radio(1000)
            },
            4,
        );
        let mut out = Vec::new();
        for i in 0..200u32 {
            let t = ms(u64::from(i) * 100);
            p.push(End::Vehicle, heartbeat(true), t);
            p.push(End::Vehicle, frame(33, i, 40), t);
            p.push(End::Gcs, heartbeat(false), t);
            out.extend(drain(&mut p, t));
        }
        out.extend(drain(&mut p, Time::from_secs(100)));
        out
    };
    let (on, off) = (run(true), run(false));
    let air = |v: &[Delivery]| -> Vec<Delivery> {
        v.iter()
            .filter(|d| d.carried == Carried::Air)
            .cloned()
            .collect()
    };
    assert_eq!(air(&on), off);
    assert_eq!(on.len() - off.len(), 400);
}

proptest! {
    /// Whatever the arrivals at either radio and the rate, half duplex: nothing crosses
    /// before it arrived, the air carries one frame at a time (each takes its length over
    /// the rate after the one before), so both directions together never carry more than
    /// the rate times the time since the first arrival; each direction keeps its order,
    /// each buffer its bound, and every frame is out or dropped.
    #[test]
    fn half_duplex_never_exceeds_the_budget(
        rate in 100u32..50_000,
        buffer in 0u32..5000,
        arrivals in proptest::collection::vec((0u64..50_000, 16usize..268, any::<bool>()), 1..200),
    ) {
        let cfg = RadioConfig {
            buffer_bytes: buffer,
            radio_status: false,
            ..RadioConfig::radio(rate)
        };
        let cap = cfg.capacity();
        let mut r = RadioPair::new(cfg, 1);
        let mut t = 0u64;
        let mut accepted = Vec::new();
        let mut out = Vec::new();
        for (i, (gap, len, gcs)) in arrivals.iter().enumerate() {
            t += gap;
            let now = Time::from_micros(t);
            let from = if *gcs { End::Gcs } else { End::Vehicle };
            if r.push(from, frame(1, i as u32, *len), now) {
                accepted.push((i as u32, from, now));
            }
            prop_assert!(r.buffered_bytes(End::Gcs) <= cap && r.buffered_bytes(End::Vehicle) <= cap);
            while let Some(d) = r.poll(now) {
                prop_assert!(d.at <= now);
                out.push(d);
            }
        }
        out.extend(drain(&mut r, Time::from_micros(u64::MAX)));
        let s = r.stats();
        prop_assert_eq!(out.len() as u64 + s.up.dropped + s.down.dropped, arrivals.len() as u64);
        prop_assert_eq!(out.len(), accepted.len());
        let first = accepted.first().map(|a| a.2.as_micros()).unwrap_or(0);
        let mut bytes = 0u128;
        for (k, d) in out.iter().enumerate() {
            let len = d.frame.len() as u128;
            let cost = (len * 1_000_000).div_ceil(u128::from(rate));
            let at = u128::from(d.at.as_micros());
            let (i, from, arrived) = accepted.iter().find(|a| a.0 == tag(&d.frame)).unwrap();
            prop_assert_eq!(d.to, from.other());
            prop_assert!(at >= u128::from(arrived.as_micros()) + cost);
            if k > 0 {
                prop_assert!(at + 1 >= u128::from(out[k - 1].at.as_micros()) + cost);
                if let Some(before) = out[..k].iter().rev().find(|b| b.to == d.to) {
                    prop_assert!(tag(&before.frame) < *i);
                }
            }
            bytes += len;
            prop_assert!(bytes * 1_000_000 <= (at - u128::from(first)) * u128::from(rate) + 1_000_000);
        }
    }

    /// Full duplex: per direction, frames leave in order, never before they arrived and
    /// their bytes could have crossed, each after the one before, within the buffer.
    #[test]
    fn full_duplex_releases_keep_order_rate_and_buffer(
        rate in 1u32..200_000,
        buffer in 0u32..5000,
        arrivals in proptest::collection::vec((0u64..50_000, 16usize..268), 1..200),
    ) {
        let cfg = RadioConfig { buffer_bytes: buffer, ..RadioConfig::per_direction(rate) };
        let cap = cfg.capacity();
        let mut r = RadioPair::new(cfg, 1);
        let mut t = 0u64;
        let mut pushed = Vec::new();
        let mut out = Vec::new();
        for (i, (gap, len)) in arrivals.iter().enumerate() {
            t += gap;
            let now = Time::from_micros(t);
            if r.push(End::Vehicle, frame(1, i as u32, *len), now) {
                pushed.push((i as u32, now));
            }
            prop_assert!(r.buffered_bytes(End::Vehicle) <= cap);
            out.extend(drain(&mut r, now));
        }
        out.extend(drain(&mut r, Time::from_micros(u64::MAX)));
        prop_assert_eq!(out.len() as u64 + r.stats().down.dropped, arrivals.len() as u64);
        prop_assert_eq!(out.len(), pushed.len());
        for (k, (d, (i, arrived))) in out.iter().zip(&pushed).enumerate() {
            prop_assert_eq!(tag(&d.frame), *i);
            let cost = (d.frame.len() as u128 * 1_000_000).div_ceil(u128::from(rate));
            prop_assert!(u128::from(d.at.as_micros()) >= u128::from(arrived.as_micros()) + cost);
            if k > 0 {
                prop_assert!(u128::from(d.at.as_micros()) + 1 >= u128::from(out[k - 1].at.as_micros()) + cost);
            }
        }
    }
}
