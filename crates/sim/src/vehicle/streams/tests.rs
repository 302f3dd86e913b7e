//! The schedules against what ArduCopter / ArduRover 4.7 SITL and PX4 1.16 SIH were measured
//! to send (docs/results/conformance.md, "Telemetry on the link"): per message, rate and bytes
//! on the wire (MAVLink 2, trailing zeros cut, no signature), and how they answer the requests
//! and RADIO_STATUS.

use super::*;
use crate::flavour::SimFlavour;
use crate::vehicle::telemetry::Schedule;
use crate::vehicle::test_probe::Probe;
use mavlink::dialects::ardupilotmega::{self as mav, MavMessage};
use std::collections::BTreeMap;

/// Bytes per second per message id measured on the real autopilot (PARAM_VALUE, STATUSTEXT
/// and TIMESYNC left out: events, not streams).
type Table = &'static [(u32, f64)];

/// ArduCopter 4.7 SITL after fleetmap's requests (2003 B/s).
const ARDUCOPTER_FLEETMAP: Table = &[
    (164, 224.0),
    (11030, 224.0),
    (33, 200.0),
    (32, 200.0),
    (30, 160.0),
    (178, 144.0),
    (24, 104.0),
    (163, 80.0),
    (62, 68.0),
    (193, 68.0),
    (136, 64.0),
    (241, 64.0),
    (74, 60.0),
    (147, 53.0),
    (2, 45.0),
    (1, 43.0),
    (152, 38.0),
    (242, 34.0),
    (168, 32.0),
    (125, 28.0),
    (0, 21.0),
    (42, 17.0),
    (133, 14.0),
    (245, 14.0),
];

/// ArduCopter after REQUEST_DATA_STREAM(ALL, stop) and 8 SET_MESSAGE_INTERVALs (527 B/s).
const ARDUCOPTER_BUDGET: Table = &[
    (33, 201.0),
    (24, 105.0),
    (147, 53.0),
    (1, 43.0),
    (193, 34.0),
    (242, 34.0),
    (0, 21.0),
    (42, 17.0),
    (245, 14.0),
];

/// ArduRover 4.7 SITL before any request (861 B/s).
const ARDUROVER_DEFAULTS: Table = &[
    (164, 56.0),
    (65, 54.0),
    (147, 53.0),
    (24, 52.0),
    (1, 43.0),
    (27, 41.0),
    (163, 40.0),
    (30, 40.0),
    (33, 40.0),
    (178, 36.0),
    (116, 36.0),
    (129, 34.0),
    (34, 34.0),
    (193, 33.0),
    (241, 32.0),
    (74, 30.0),
    (32, 28.0),
    (29, 26.0),
    (137, 26.0),
    (36, 22.0),
    (2, 22.0),
    (0, 21.0),
    (152, 19.0),
    (42, 17.0),
    (125, 14.0),
];

/// ArduRover after fleetmap's requests (1877 B/s).
const ARDUROVER_FLEETMAP: Table = &[
    (164, 224.0),
    (33, 200.0),
    (32, 200.0),
    (30, 160.0),
    (178, 144.0),
    (24, 104.0),
    (163, 80.0),
    (193, 68.0),
    (241, 64.0),
    (74, 60.0),
    (65, 54.0),
    (147, 53.0),
    (2, 45.0),
    (1, 43.0),
    (27, 41.0),
    (152, 38.0),
    (116, 36.0),
    (129, 34.0),
    (34, 34.0),
    (242, 34.0),
    (125, 28.0),
    (29, 26.0),
    (137, 26.0),
    (36, 22.0),
    (0, 21.0),
    (42, 17.0),
    (245, 13.0),
];

/// PX4 1.16 SIH on a TELEM1-like link (`-r 1200 -s`, no SITL overrides), no request (1018 B/s;
/// and LINK_NODE_STATUS, which the measuring script's dialect did not decode: its 1 Hz of 37
/// bytes, measured on the SITL link, times the rate multiplier).
const PX4_TELEM1_DEFAULTS: Table = &[
    (8, 16.3),
    (30, 259.6),
    (31, 190.4),
    (24, 121.1),
    (33, 87.9),
    (74, 51.7),
    (83, 40.6),
    (85, 40.5),
    (12901, 30.8),
    (1, 22.9),
    (36, 21.5),
    (0, 20.6),
    (141, 19.3),
    (32, 17.6),
    (12904, 16.3),
    (42, 15.7),
    (242, 13.6),
    (29, 11.4),
    (230, 11.0),
    (147, 10.7),
    (245, 6.2),
    (132, 5.1),
    (4, 2.1),
    (241, 1.1),
];

/// PX4 1.16 SIH, a Normal-mode instance at 100 000 B/s without the SITL's overrides, no
/// request (2298 B/s, and LINK_NODE_STATUS as above: 1 Hz of 37 bytes).
const PX4_NORMAL_DEFAULTS: Table = &[
    (8, 37.0),
    (30, 601.4),
    (31, 440.0),
    (24, 280.0),
    (33, 200.0),
    (74, 119.6),
    (83, 95.7),
    (85, 93.6),
    (12901, 68.6),
    (1, 50.9),
    (36, 48.0),
    (141, 43.1),
    (32, 39.2),
    (12904, 36.2),
    (242, 34.0),
    (230, 27.4),
    (147, 26.9),
    (29, 25.5),
    (0, 20.6),
    (42, 15.7),
    (245, 13.7),
    (132, 12.7),
    (241, 3.2),
    (4, 2.1),
];

/// PX4 1.16 SIH on its SITL UDP GCS link after fleetmap's requests (14990 B/s; LINK_NODE_STATUS
/// measured apart, by `hitl/link_checks.py`).
const PX4_SITL_FLEETMAP: Table = &[
    (8, 37.0),
    (85, 3151.0),
    (36, 2451.0),
    (83, 2399.0),
    (31, 2199.0),
    (30, 2001.0),
    (32, 2000.0),
    (33, 201.0),
    (24, 112.0),
    (12901, 71.0),
    (74, 60.0),
    (147, 54.0),
    (1, 53.0),
    (141, 45.0),
    (12904, 38.0),
    (242, 34.0),
    (230, 27.0),
    (29, 26.0),
    (0, 21.0),
    (42, 16.0),
    (245, 14.0),
    (132, 13.0),
];

/// The simulator's bytes per second over the last `secs` against `table`: the total within
/// `total_tol`, each message of 20 B/s or more (in either) within `msg_tol`.
fn assert_matches(p: &Probe, secs: f64, table: Table, total_tol: f64, msg_tol: f64, what: &str) {
    let events = [22u32, 253, 111, 77, 244, 49];
    let sim: BTreeMap<u32, f64> = p
        .table(secs)
        .into_iter()
        .filter(|(id, _)| !events.contains(id))
        .map(|(id, (hz, b))| (id, hz * b))
        .collect();
    let real: BTreeMap<u32, f64> = table.iter().copied().collect();
    let (ts, tr) = (sim.values().sum::<f64>(), real.values().sum::<f64>());
    assert!(
        (ts - tr).abs() <= total_tol * tr,
        "{what}: {ts:.0} B/s, measured {tr:.0}\nsim {sim:?}"
    );
    for id in sim.keys().chain(real.keys()) {
        let (s, r) = (
            sim.get(id).copied().unwrap_or(0.0),
            real.get(id).copied().unwrap_or(0.0),
        );
        if s.max(r) >= 20.0 {
            assert!(
                (s - r).abs() <= msg_tol * r.max(1.0),
                "{what}: message {id}: {s:.1} B/s, measured {r:.1}"
            );
        }
    }
}

#[test]
fn arducopter_sends_only_heartbeat_until_asked() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(40.0);
    let t = p.table(30.0);
    assert!((t[&0].0 - 1.0).abs() < 0.05, "{t:?}");
    // TIMESYNC every 10 s, home and origin once: ~30 B/s as measured (36 with PARAM_VALUE)
    assert!(p.bps(30.0) < 40.0, "{t:?}");
    assert!(
        t.keys().all(|id| [0, 111, 242, 49, 253].contains(id)),
        "{t:?}"
    );
}

#[test]
fn arducopter_costs_what_sitl_costs_after_fleetmaps_requests() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(40.0);
    p.fleetmap_requests();
    p.run(33.0);
    assert_matches(&p, 30.0, ARDUCOPTER_FLEETMAP, 0.05, 0.12, "ArduCopter");
}

#[test]
fn ardurover_streams_every_group_at_1_hz_and_as_sitl_after_requests() {
    let mut p = Probe::new(SimFlavour::ARDU_ROVER, None);
    p.run(40.0);
    // (LOCAL_POSITION_NED: 28 bytes at rest just after boot, 40 later, when the EKF's vertical
    // velocity is no longer exactly 0; the simulator sends 40)
    assert_matches(
        &p,
        20.0,
        ARDUROVER_DEFAULTS,
        0.05,
        0.45,
        "ArduRover defaults",
    );
    p.fleetmap_requests();
    p.run(33.0);
    assert_matches(&p, 30.0, ARDUROVER_FLEETMAP, 0.05, 0.12, "ArduRover");
}

/// REQUEST_DATA_STREAM(ALL, stop), then SET_MESSAGE_INTERVAL for 8 messages.
fn budget(p: &mut Probe) {
    p.stream(mav::MavDataStream::MAV_DATA_STREAM_ALL, 0, 0);
    for (id, us) in [
        (33, 200_000.0),
        (1, 1e6),
        (24, 500_000.0),
        (245, 1e6),
        (42, 1e6),
        (242, 2e6),
        (147, 1e6),
        (193, 1e6),
    ] {
        assert_eq!(
            p.interval(id, us),
            Some(mav::MavResult::MAV_RESULT_ACCEPTED)
        );
    }
}

#[test]
fn arducopter_set_message_interval_alone_after_all_streams_stop() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(30.0);
    p.fleetmap_requests();
    p.run(5.0);
    budget(&mut p);
    p.run(33.0);
    assert_matches(&p, 30.0, ARDUCOPTER_BUDGET, 0.05, 0.12, "ArduCopter budget");
    // GET_MESSAGE_INTERVAL: µs, −1 when not sent, 0 and FAILED for an unknown id
    let get = |p: &mut Probe, id: u32| {
        p.intervals.clear();
        let r = p.command(
            mav::MavCmd::MAV_CMD_GET_MESSAGE_INTERVAL,
            [id as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        (r, p.intervals.last().map(|i| i.1))
    };
    use mav::MavResult::{MAV_RESULT_ACCEPTED as OK, MAV_RESULT_FAILED as FAILED};
    assert_eq!(get(&mut p, 33), (Some(OK), Some(200_000)));
    assert_eq!(get(&mut p, 242), (Some(OK), Some(2_000_000)));
    assert_eq!(get(&mut p, 30), (Some(OK), Some(-1)));
    assert_eq!(get(&mut p, 0), (Some(OK), Some(1_000_000)));
    assert_eq!(get(&mut p, 12345), (Some(FAILED), Some(0)));
    // a later REQUEST_DATA_STREAM sets every message of its group again
    p.stream(mav::MavDataStream::MAV_DATA_STREAM_EXTRA3, 2, 1);
    p.run(13.0);
    let t = p.table(10.0);
    assert!((t[&147].0 - 2.0).abs() < 0.15, "BATTERY_STATUS {t:?}");
    assert!((t[&193].0 - 2.0).abs() < 0.15, "EKF_STATUS_REPORT {t:?}");
    assert!((t[&163].0 - 2.0).abs() < 0.15, "AHRS {t:?}");
    // interval 0 is the group's rate: POSITION is stopped, so GLOBAL_POSITION_INT stops
    assert_eq!(p.interval(33, 0.0), Some(OK));
    p.run(12.0);
    assert!(!p.table(10.0).contains_key(&33));
    // a reboot restores the boot rates (nothing is saved): only HEARTBEAT again
    assert_eq!(
        p.command(
            mav::MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        ),
        Some(OK)
    );
    p.run(30.0);
    assert!(
        p.table(20.0)
            .keys()
            .all(|id| [0, 111, 242, 49, 253].contains(id))
    );
}

#[test]
fn ardupilot_refuses_unknown_messages_and_rates_it_cannot_keep() {
    use mav::MavResult::MAV_RESULT_DENIED as DENIED;
    let mut p = Probe::new(SimFlavour::ARDU_ROVER, None);
    p.run(2.0);
    assert_eq!(p.interval(12345, 1e6), Some(DENIED));
    assert!(
        p.texts
            .iter()
            .any(|t| t == "No ap_message for mavlink id (12345)")
    );
    // ArduRover's 50 Hz loop: nothing faster than every 25 ms
    assert_eq!(p.interval(33, 10_000.0), Some(DENIED));
    assert!(p.texts.iter().any(|t| t.contains("too fast")));
    assert_eq!(p.interval(33, -2.0), Some(DENIED));
    assert_eq!(
        p.interval(33, 40_000.0),
        Some(mav::MavResult::MAV_RESULT_ACCEPTED)
    );
}

#[test]
fn radio_status_slows_ardupilots_streams_and_lets_them_recover() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(30.0);
    p.fleetmap_requests();
    p.run(20.0);
    let radio = |p: &mut Probe, txbuf: u8, secs: u32| {
        for _ in 0..secs {
            p.send(MavMessage::RADIO_STATUS(mav::RADIO_STATUS_DATA {
                rssi: 200,
                remrssi: 200,
                txbuf,
                noise: 40,
                remnoise: 40,
                rxerrors: 0,
                fixed: 0,
            }));
            p.run(1.0);
        }
    };
    let t0 = p.secs();
    let before = p.bps_between(t0 - 10.0, t0);
    // txbuf 10 %: +60 ms a report, up to about 2 s (measured: GLOBAL_POSITION_INT 0.4–0.6 Hz
    // after 30 s, 300–400 B/s)
    radio(&mut p, 10, 60);
    let t1 = p.secs();
    let slow = p.bps_between(t1 - 10.0, t1);
    let gpi = p.hz_between(33, t1 - 10.0, t1);
    assert!((0.35..0.6).contains(&gpi), "GLOBAL_POSITION_INT {gpi} Hz");
    assert!(slow < 0.25 * before, "{before} → {slow} B/s");
    // 60 reports: capped once past 2 s
    assert_eq!(slowdown_ms(&p), 2040);
    // HEARTBEAT is never slowed down
    assert!((p.hz_between(0, t1 - 10.0, t1) - 1.0).abs() < 0.15);
    // 100 % free: −40 ms a report down to 200 ms, then −20 ms: back within a minute
    radio(&mut p, 100, 60);
    let t2 = p.secs();
    assert!(p.hz_between(33, t2 - 5.0, t2) > 4.5);
    assert_eq!(slowdown_ms(&p), 0);
}

#[test]
fn ardupilot_streams_slow_down_four_times_while_receiving_waypoints() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(30.0);
    p.fleetmap_requests();
    p.run(10.0);
    p.send(MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
        count: 12,
        target_system: 1,
        target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
        mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
        opaque_id: 0,
    }));
    let t0 = p.secs();
    // answer each request 0.8 s later (under ArduPilot's 1 s re-request)
    let mut sent = 0u16;
    for _ in 0..60 {
        if sent == 12 {
            break;
        }
        p.run(0.8);
        let Some(&seq) = p.mission_requests.last() else {
            continue;
        };
        p.mission_requests.clear();
        p.send(MavMessage::MISSION_ITEM_INT(mav::MISSION_ITEM_INT_DATA {
            seq,
            command: mav::MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x: 371_965_000 + i32::from(seq) * 100,
            y: -805_785_000,
            z: 10.0,
            target_system: 1,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            autocontinue: 1,
            ..mav::MISSION_ITEM_INT_DATA::default()
        }));
        sent = seq + 1;
    }
    assert_eq!(sent, 12, "the upload ended early");
    let t1 = p.secs();
    // measured 1.2–1.4 Hz (5 Hz / 4) while receiving
    let during = p.hz_between(33, t0 + 1.0, t1 - 0.5);
    assert!(
        (1.0..1.6).contains(&during),
        "{during} Hz during the upload"
    );
    p.run(6.0);
    assert!(p.hz_between(33, t1 + 1.0, t1 + 6.0) > 4.5);
}

#[test]
fn ardupilot_buckets_share_intervals_and_take_the_nearest_when_full() {
    let t = Time::ZERO;
    let mut s = ApSchedule::new(crate::flavour::SimVehicleClass::Copter, t);
    // ten intervals fill the ten buckets; an eleventh joins the nearest
    let ids = [1u32, 2, 24, 30, 32, 33, 74, 147, 163, 178];
    for (i, id) in ids.iter().enumerate() {
        s.set_message_interval(*id, 100_000.0 * (i + 1) as f32, t)
            .unwrap();
    }
    s.set_message_interval(193, 340_000.0, t).unwrap();
    assert_eq!(s.interval_ms(193), Some(300));
    // a message alone in its bucket frees it when it moves; then a new interval gets one
    s.set_message_interval(1, 300_000.0, t).unwrap();
    assert_eq!(s.interval_ms(1), Some(300));
    s.set_message_interval(241, 150_000.0, t).unwrap();
    assert_eq!(s.interval_ms(241), Some(150));
    // −1 takes it out
    s.set_message_interval(241, -1.0, t).unwrap();
    assert_eq!(s.interval_ms(241), None);
}

#[test]
fn px4_on_telem1_scales_its_normal_streams_to_1200_bytes_a_second() {
    let mut p = Probe::new(SimFlavour::PX4_COPTER, Some(Px4Link::TELEM1));
    p.run(40.0);
    assert_matches(&p, 30.0, PX4_TELEM1_DEFAULTS, 0.06, 0.15, "PX4 TELEM1");
}

#[test]
fn px4_on_a_network_link_streams_its_normal_mode_at_full_rate() {
    let mut p = Probe::new(SimFlavour::PX4_COPTER, None);
    assert_eq!(p.v.config().px4_link, Px4Link::NETWORK);
    p.run(40.0);
    assert_matches(&p, 30.0, PX4_NORMAL_DEFAULTS, 0.05, 0.12, "PX4 Normal");
}

#[test]
fn px4_sitl_gcs_link_has_its_50_hz_streams() {
    let mut p = Probe::new(SimFlavour::PX4_COPTER, Some(Px4Link::SITL_UDP));
    p.run(20.0);
    p.fleetmap_requests();
    p.run(13.0);
    assert_matches(&p, 10.0, PX4_SITL_FLEETMAP, 0.05, 0.12, "PX4 SITL");
}

#[test]
fn px4_answers_interval_requests_as_px4_does() {
    use mav::MavResult::{MAV_RESULT_ACCEPTED as OK, MAV_RESULT_FAILED as FAILED};
    let mut p = Probe::new(SimFlavour::PX4_COPTER, Some(Px4Link::SITL_UDP));
    p.run(10.0);
    // no stream for MISSION_CURRENT (the mission manager sends it), EKF_STATUS_REPORT, 12345
    assert_eq!(p.interval(42, 1e6), Some(FAILED));
    assert_eq!(p.interval(193, 1e6), Some(FAILED));
    assert_eq!(p.interval(12345, 1e6), Some(FAILED));
    let get = |p: &mut Probe, id: u32| {
        p.intervals.clear();
        let r = p.command(
            mav::MavCmd::MAV_CMD_GET_MESSAGE_INTERVAL,
            [id as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        (r, p.intervals.last().map(|i| i.1))
    };
    assert_eq!(get(&mut p, 30), (Some(OK), Some(20_000)));
    assert_eq!(get(&mut p, 42), (Some(OK), Some(0)));
    assert_eq!(get(&mut p, 12345), (Some(OK), Some(0)));
    // REQUEST_DATA_STREAM is ignored
    p.stream(mav::MavDataStream::MAV_DATA_STREAM_ALL, 0, 0);
    p.run(3.0);
    assert!(p.table(2.0)[&30].0 > 45.0);
    // 0: back to the Normal-mode rate (the SITL's 50 Hz was a `mavlink stream` override)
    assert_eq!(p.interval(30, 0.0), Some(OK));
    p.run(3.0);
    assert!((p.table(2.0)[&30].0 - 15.0).abs() < 1.0);
    // −1: stopped
    assert_eq!(p.interval(30, -1.0), Some(OK));
    p.run(3.0);
    assert!(!p.table(2.0).contains_key(&30));
    assert_eq!(get(&mut p, 30), (Some(OK), Some(0)));
}

fn radio(p: &mut Probe, txbuf: u8, secs: u32) {
    for _ in 0..secs {
        p.send(MavMessage::RADIO_STATUS(mav::RADIO_STATUS_DATA {
            txbuf,
            ..mav::RADIO_STATUS_DATA::default()
        }));
        p.run(1.0);
    }
}

#[test]
fn px4_radio_status_multiplier_on_telem1() {
    let mut p = Probe::new(SimFlavour::PX4_COPTER, Some(Px4Link::TELEM1));
    p.run(30.0);
    let before = p.bps(10.0);
    // ×0.8 a report below 25 % free, down to the 5 % floor (measured 110–200 B/s)
    radio(&mut p, 10, 20);
    let low = p.bps(10.0);
    assert!(low < 0.2 * before, "{before} → {low} B/s");
    assert!((rate_mult(&p) - 0.05).abs() < 1e-6, "the 5 % floor");
    assert!(
        (p.table(10.0)[&0].0 - 1.0).abs() < 0.15,
        "HEARTBEAT keeps its rate"
    );
    // ×1.025 a report above 50 %: slow (measured: still at the floor a minute later)
    radio(&mut p, 100, 30);
    assert!(p.bps(10.0) < 0.3 * before);
    // without RADIO_STATUS for MAV_RADIO_TOUT (5 s) the multiplier is reset
    p.run(12.0);
    assert!(p.bps(5.0) > 0.9 * before, "{before} → {} B/s", p.bps(5.0));
    assert!((rate_mult(&p) - 0.45).abs() < 0.05, "{}", rate_mult(&p));
}

#[test]
fn px4_sitl_link_ignores_radio_status() {
    let mut p = Probe::new(SimFlavour::PX4_COPTER, Some(Px4Link::SITL_UDP));
    p.run(20.0);
    let before = p.bps(10.0);
    radio(&mut p, 10, 20);
    let after = p.bps(10.0);
    assert!(
        (after - before).abs() < 0.05 * before,
        "{before} → {after} B/s"
    );
}

/// ArduPilot's `stream_slowdown_ms` now.
fn slowdown_ms(p: &Probe) -> u16 {
    match &p.v.telemetry.schedule {
        Schedule::ArduPilot(s) => s.slowdown_ms(),
        Schedule::Px4(_) => 0,
    }
}

/// PX4's rate multiplier now.
fn rate_mult(p: &Probe) -> f32 {
    match &p.v.telemetry.schedule {
        Schedule::ArduPilot(_) => 1.0,
        Schedule::Px4(s) => s.rate_mult(),
    }
}

fn print(name: &str, p: &Probe, secs: f64) {
    println!("\n{name}: {:.1} B/s", p.bps(secs));
    for (id, (hz, b)) in p.table(secs) {
        println!("| {id} | {hz:.2} | {b:.1} | {:.1} |", hz * b);
    }
}

#[test]
#[ignore = "prints the simulator's tables to compare with the measured ones"]
fn print_tables() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(40.0);
    print("copter a", &p, 30.0);
    p.fleetmap_requests();
    p.run(33.0);
    print("copter b", &p, 30.0);
    let mut p = Probe::new(SimFlavour::ARDU_ROVER, None);
    p.run(40.0);
    print("rover a", &p, 30.0);
    p.fleetmap_requests();
    p.run(33.0);
    print("rover b", &p, 30.0);
    for link in [Px4Link::TELEM1, Px4Link::SITL_UDP] {
        let mut p = Probe::new(SimFlavour::PX4_COPTER, Some(link));
        p.run(40.0);
        print(&format!("px4 {link:?} a"), &p, 30.0);
        p.fleetmap_requests();
        p.run(33.0);
        print(&format!("px4 {link:?} b"), &p, 30.0);
    }
}

/// Three ArduCopters for 20 simulated minutes through the harness (encoding every frame), with
/// each set of requests: CPU time per run, to compare the requests' cost.
#[test]
#[ignore = "prints timings"]
fn cost_of_the_requests() {
    use crate::harness::{Sim, SimConfig};
    use mavlink::MavHeader;
    let gcs = MavHeader {
        system_id: fleetmap_core::proto::GCS_SYSID as u32,
        component_id: fleetmap_core::proto::GCS_COMPID,
        sequence: 0,
    };
    type Requests = fn(&mut Sim, u8, &MavHeader);
    let all4: Requests = |sim, s, h| {
        sim.send(
            s,
            h,
            &MavMessage::REQUEST_DATA_STREAM(mav::REQUEST_DATA_STREAM_DATA {
                req_message_rate: 4,
                target_system: s,
                target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
                req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
                start_stop: 1,
            }),
        )
    };
    fn interval(sim: &mut Sim, s: u8, h: &MavHeader, id: u32, us: f32) {
        sim.send(
            s,
            h,
            &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param1: id as f32,
                param2: us,
                command: mav::MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                target_system: s,
                target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
                ..mav::COMMAND_LONG_DATA::default()
            }),
        )
    }
    let fleetmap: Requests = |sim, s, h| {
        use mav::MavDataStream as S;
        for (st, hz) in [
            (S::MAV_DATA_STREAM_EXTENDED_STATUS, 2),
            (S::MAV_DATA_STREAM_POSITION, 5),
            (S::MAV_DATA_STREAM_EXTRA1, 4),
            (S::MAV_DATA_STREAM_EXTRA2, 4),
            (S::MAV_DATA_STREAM_EXTRA3, 2),
        ] {
            sim.send(
                s,
                h,
                &MavMessage::REQUEST_DATA_STREAM(mav::REQUEST_DATA_STREAM_DATA {
                    req_message_rate: hz,
                    target_system: s,
                    target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
                    req_stream_id: st,
                    start_stop: 1,
                }),
            );
        }
        for (id, us) in crate::vehicle::test_probe::FLEETMAP_INTERVALS {
            interval(sim, s, h, id, us);
        }
    };
    let budget: Requests = |sim, s, h| {
        for (id, us) in [
            (33, 200_000.0),
            (1, 1e6),
            (24, 500_000.0),
            (245, 1e6),
            (42, 1e6),
            (242, 2e6),
            (147, 1e6),
            (193, 1e6),
        ] {
            interval(sim, s, h, id, us);
        }
    };
    for (name, req) in [
        ("ALL at 4 Hz", all4),
        ("fleetmap", fleetmap),
        ("budget", budget),
    ] {
        let t0 = std::time::Instant::now();
        let cfg =
            SimConfig::from_spec("3xcopter:ardupilot", None, Some((37.1965, -80.5785)), 1).unwrap();
        let mut sim = Sim::new(cfg, Time::ZERO).unwrap();
        sim.advance_to(Time::from_secs(20));
        for s in 1..=3 {
            req(&mut sim, s, &gcs);
        }
        let mut frames = 0usize;
        for m in 1..=20 {
            sim.advance_to(Time::from_secs(20 + 60 * m));
            for s in 1..=3 {
                while sim.recv_bytes(s).is_some() {
                    frames += 1;
                }
            }
        }
        println!(
            "{name}: {:.0} ms, {:.0} frames per vehicle-second",
            t0.elapsed().as_secs_f64() * 1e3,
            frames as f64 / 3600.0
        );
    }
}
