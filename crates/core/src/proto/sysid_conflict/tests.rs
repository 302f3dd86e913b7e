//! The watch against senders and links as they are: loss (single frames and bursts),
//! duplicates, frames reordered within a few places, reboots that restart the counter, one
//! vehicle over two links — none of them a conflict — and two autopilots on one id, found
//! within a few seconds of traffic.

use super::*;
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// One frame as sent: (seq, content check, time).
type Sent = (u8, u16, Time);

/// One frame as a link delivers it: (link, seq, content check, arrival time).
type Delivered = (usize, u8, u16, Time);

/// A sender's frames: its counter, from `start` every `period` for `n` frames; the counter
/// restarts at 0 (after `reboot_gap` of silence) at the frame indices in `reboots`. The
/// check is its content: distinct per sender and per boot.
fn sender(
    id: u16,
    start: Time,
    period: Duration,
    n: usize,
    seq0: u8,
    reboots: &[(usize, Duration)],
) -> Vec<(u8, u16, Time)> {
    let mut out = Vec::with_capacity(n);
    let (mut seq, mut t, mut boot) = (seq0, start, 0u16);
    for i in 0..n {
        if let Some((_, gap)) = reboots.iter().find(|(at, _)| *at == i) {
            seq = 0;
            boot += 1;
            t += *gap;
        }
        let check = id
            .wrapping_mul(40503)
            .wrapping_add(boot.wrapping_mul(7919))
            .wrapping_add(u16::from(seq).wrapping_mul(257))
            ^ (i as u16);
        out.push((seq, check, t));
        seq = seq.wrapping_add(1);
        t += period;
    }
    out
}

/// What a faulty link makes of `frames`: each moved up to `reorder` places later with
/// `p_reorder` (as sent: a frame overtaken by at most `reorder` frames sent after it), then
/// each lost with `loss` (and bursts of up to `burst` frames starting with `loss / 10`),
/// and duplicated with `dup`. Arrival times stay in order: a late frame arrives when the
/// one it let pass would have.
fn link(
    frames: &[(u8, u16, Time)],
    rng: &mut ChaCha8Rng,
    loss: f64,
    burst: usize,
    dup: f64,
    p_reorder: f64,
    reorder: usize,
) -> Vec<(u8, u16, Time)> {
    let mut keyed: Vec<(usize, (u8, u16, Time))> = frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let late = if reorder > 0 && rng.random_bool(p_reorder) {
                rng.random_range(1..=reorder)
            } else {
                0
            };
            (2 * (i + late) + usize::from(late > 0), *f)
        })
        .collect();
    keyed.sort_by_key(|k| k.0);
    let times: Vec<Time> = frames.iter().map(|f| f.2).collect();
    let sent: Vec<(u8, u16, Time)> = keyed
        .into_iter()
        .zip(times)
        .map(|((_, f), t)| (f.0, f.1, t))
        .collect();
    let mut out = Vec::new();
    let mut skip = 0usize;
    for f in sent {
        if skip > 0 {
            skip -= 1;
            continue;
        }
        if burst > 0 && rng.random_bool(loss / 10.0) {
            skip = rng.random_range(1..=burst);
            continue;
        }
        if rng.random_bool(loss) {
            continue;
        }
        out.push(f);
        if rng.random_bool(dup) {
            out.push(f);
        }
    }
    out
}

/// Merge deliveries of several links / senders into arrival order.
fn merge(parts: Vec<(usize, Vec<Sent>)>) -> Vec<Delivered> {
    let mut all: Vec<Delivered> = parts
        .into_iter()
        .flat_map(|(l, fs)| fs.into_iter().map(move |(s, c, t)| (l, s, c, t)))
        .collect();
    all.sort_by_key(|d| d.3);
    all
}

const WHO: Endpoint = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);

/// Feed the deliveries; the first conflict, if any.
fn watch(frames: &[Delivered]) -> (SysidWatch, Option<Conflict>) {
    let mut w = SysidWatch::new(SysidWatchConfig::default());
    let mut first = None;
    for &(l, seq, check, t) in frames {
        w.handle_frame(l, WHO, seq, check, t);
        if first.is_none() {
            first = w.poll_event();
        }
    }
    (w, first)
}

fn hz(f: f64) -> Duration {
    Duration::from_secs_f64(1.0 / f)
}

#[test]
fn a_clean_stream_is_checked_and_not_a_conflict() {
    let f = sender(1, Time::ZERO, hz(50.0), 500, 17, &[]);
    let (w, c) = watch(&merge(vec![(0, f)]));
    assert_eq!(c, None);
    assert!(w.checked(1, Time::from_secs(10)));
    assert!(!w.checked(2, Time::from_secs(10)), "never heard");
}

#[test]
fn a_stream_heard_briefly_is_not_checked_yet() {
    let f = sender(1, Time::ZERO, hz(50.0), 20, 0, &[]);
    let (w, c) = watch(&merge(vec![(0, f)]));
    assert_eq!(c, None);
    assert!(!w.checked(1, Time::from_millis(400)));
}

#[test]
fn two_sitls_on_one_port_are_found_within_a_second() {
    // Two ArduCopter SITLs at SYSID_THISMAV 1, counters at unrelated places.
    let a = sender(1, Time::ZERO, hz(60.0), 600, 12, &[]);
    let b = sender(2, Time::from_millis(7), hz(45.0), 450, 200, &[]);
    let (w, c) = watch(&merge(vec![(0, a), (0, b)]));
    let c = c.expect("a conflict");
    assert_eq!(c.who, WHO);
    assert_eq!(c.link, 0);
    assert!(matches!(c.evidence, Evidence::Sequence { .. }), "{c:?}");
    assert!(c.at <= Time::from_secs(1), "found at {}", c.at);
    assert!(w.checked(1, Time::from_millis(1)), "a conflict is a result");
    assert!(c.evidence.to_string().contains("sequence counters"));
}

#[test]
fn counters_a_few_apart_are_found_too() {
    // The second counter just ahead of the first: its frames first look like the first's
    // after a small loss, then the two part.
    for d in [0u8, 1, 3, 9, 31, 250] {
        let a = sender(1, Time::ZERO, hz(50.0), 500, 100, &[]);
        let b = sender(
            2,
            Time::from_millis(3),
            hz(50.0),
            500,
            100u8.wrapping_add(d),
            &[],
        );
        let (_, c) = watch(&merge(vec![(0, a), (0, b)]));
        let c = c.unwrap_or_else(|| panic!("offset {d}: no conflict"));
        assert!(c.at <= Time::from_secs(3), "offset {d}: found at {}", c.at);
    }
}

#[test]
fn one_vehicle_over_two_links_is_not_a_conflict() {
    // ArduPilot counts per channel: two links, two counters of one vehicle.
    let radio = sender(1, Time::ZERO, hz(10.0), 300, 5, &[]);
    let wifi = sender(1, Time::from_millis(2), hz(50.0), 1500, 90, &[]);
    let (w, c) = watch(&merge(vec![(0, radio), (1, wifi)]));
    assert_eq!(c, None);
    assert!(w.checked(1, Time::from_secs(30)));
}

#[test]
fn a_reboot_is_not_a_conflict() {
    // An autopilot is silent for seconds while it boots (ArduCopter SITL ~1 s, boards more);
    // behind a radio's buffer the frames before the reboot come right before those after it
    // (0 ms: ArduCopter SITL at ×5 behind a SiK radio showed 0.3 s).
    for gap_ms in [0u64, 50, 300, 600, 1000, 2500, 8000] {
        let f = sender(
            1,
            Time::ZERO,
            hz(50.0),
            2000,
            140,
            &[
                (400, Duration::from_millis(gap_ms)),
                (1300, Duration::from_millis(gap_ms)),
            ],
        );
        let (_, c) = watch(&merge(vec![(0, f)]));
        assert_eq!(c, None, "reboot after {gap_ms} ms");
    }
}

#[test]
fn heartbeats_flipping_identity_are_a_conflict_and_a_changed_frame_is_not() {
    let copter = Beat {
        mav_type: mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_QUADROTOR as u8,
        autopilot: 3,
        ..Beat::default()
    };
    let rover = Beat {
        mav_type: mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_GROUND_ROVER as u8,
        autopilot: 3,
        ..Beat::default()
    };
    let mut w = SysidWatch::new(SysidWatchConfig::default());
    // A vehicle whose frame class was changed and rebooted: once.
    w.handle_heartbeat(0, WHO, &copter, Time::ZERO);
    w.handle_heartbeat(0, WHO, &rover, Time::from_secs(1));
    for s in 2..30 {
        w.handle_heartbeat(0, WHO, &rover, Time::from_secs(s));
    }
    assert_eq!(w.poll_event(), None);
    // A copter and a rover both at id 1.
    let other = Endpoint::new(3, crate::proto::AUTOPILOT_COMPID);
    let mut t = Time::ZERO;
    for k in 0..4 {
        for b in [&copter, &rover] {
            w.handle_heartbeat(0, other, b, t);
            t += Duration::from_millis(500);
        }
        if k < 1 {
            assert_eq!(w.poll_event(), None);
        }
    }
    let c = w.poll_event().expect("a conflict");
    assert_eq!(c.who, other);
    assert!(matches!(c.evidence, Evidence::Identity { .. }));
    assert!(w.conflict_of(3).is_some());
    assert!(w.conflict_of(1).is_none());
    assert_eq!(w.poll_event(), None, "reported once");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// One autopilot over a faulty link — loss, bursts, duplicates, reordering within a few
    /// frames, reboots — is never taken for two; and with enough traffic it is checked.
    #[test]
    fn one_sender_through_faults_is_never_a_conflict(
        seed in any::<u64>(),
        rate in 2.0f64..200.0,
        seq0 in any::<u8>(),
        loss in 0.0f64..0.4,
        burst in 0usize..120,
        dup in 0.0f64..0.3,
        p_reorder in 0.0f64..0.3,
        reorder in 0usize..5,
        reboots in proptest::collection::vec((0usize..3000, 0u64..4000), 0..3),
        links in 1usize..3,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let reboots: Vec<(usize, Duration)> =
            reboots.into_iter().map(|(i, ms)| (i, Duration::from_millis(ms))).collect();
        let mut parts = Vec::new();
        for l in 0..links {
            let f = sender(1, Time::from_millis(l as u64), hz(rate), 3000, seq0.wrapping_add(l as u8 * 77), &reboots);
            parts.push((l, link(&f, &mut rng, loss, burst, dup, p_reorder, reorder)));
        }
        let (_, c) = watch(&merge(parts));
        prop_assert_eq!(c, None);
    }

    /// Two autopilots sharing an id on one link, each through its own faults, are found
    /// within a few seconds of traffic.
    #[test]
    fn two_senders_on_one_link_are_found(
        seed in any::<u64>(),
        rate_a in 10.0f64..120.0,
        rate_b in 10.0f64..120.0,
        seq_a in any::<u8>(),
        seq_b in any::<u8>(),
        offset_ms in 0u64..1000,
        loss in 0.0f64..0.2,
        dup in 0.0f64..0.1,
        p_reorder in 0.0f64..0.1,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = |r: f64| (r * 30.0) as usize;
        let a = sender(1, Time::ZERO, hz(rate_a), n(rate_a), seq_a, &[]);
        let b = sender(2, Time::from_millis(offset_ms), hz(rate_b), n(rate_b), seq_b, &[]);
        let a = link(&a, &mut rng, loss, 0, dup, p_reorder, 2);
        let b = link(&b, &mut rng, loss, 0, dup, p_reorder, 2);
        let (_, c) = watch(&merge(vec![(0, a), (0, b)]));
        let c = c.expect("a conflict");
        prop_assert!(
            c.at <= Time::from_millis(offset_ms) + Duration::from_secs(5),
            "found at {} (second sender from {} ms)", c.at, offset_ms
        );
    }
}
