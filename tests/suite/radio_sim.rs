//! The real binaries on the wall clock: `fleetmap sim --speedup 5` (one ArduPilot copter) →
//! `fleetmap relay --radio 2000 --clock vehicle --stats FILE` → a UDP socket playing the
//! GCS (a heartbeat a second, and the copter's streams asked for at 20 Hz: far more than
//! the radio carries). The relay counts its budget in the copter's time, read from the
//! `time_boot_ms` of what it sends, so it carries about 2,000 B/s of the copter's time —
//! some 10,000 B per wall second at ×5, fewer if a busy machine slows the simulator, which is
//! why the figure is checked against the copter's own timestamps and not the wall clock.
//! RADIO_STATUS reaches both sides, and SIGTERM makes the relay write its counts.

#![allow(deprecated)] // REQUEST_DATA_STREAM: still what ArduPilot's streams obey

use fleetmap_test_kit::gcs::Gcs;
use fleetmap_test_kit::{Guard, free_udp_port};
use mavlink::dialects::ardupilotmega::{
    HEARTBEAT_DATA, MavAutopilot, MavDataStream, MavMessage, MavType, REQUEST_DATA_STREAM_DATA,
};
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use crate::common;

/// A frame the GCS socket received: when, its bytes, its sender and message.
struct Got {
    at: Instant,
    len: usize,
    sysid: u8,
    compid: u8,
    msg: MavMessage,
}

/// The copter's time since boot in `m`, ms, if it carries one.
fn boot_ms(m: &MavMessage) -> Option<u32> {
    match m {
        MavMessage::ATTITUDE(d) => Some(d.time_boot_ms),
        MavMessage::GLOBAL_POSITION_INT(d) => Some(d.time_boot_ms),
        MavMessage::SYSTEM_TIME(d) => Some(d.time_boot_ms),
        _ => None,
    }
}

#[test]
fn relay_radio_2000_carries_2000_bytes_per_second_of_the_vehicles_time() {
    let dir = tempfile::tempdir().unwrap();
    let stats_file = dir.path().join("radio.json");
    let mut gcs = Gcs::bind();
    let gport = gcs.addr().port();
    let vport = free_udp_port();
    let mut relay = Guard::spawn(
        common::fleetmap()
            .command()
            .args([
                "relay",
                "--gcs",
                &format!("udpout:127.0.0.1:{gport}"),
                "--vehicle",
                &format!("udpin:127.0.0.1:{vport}"),
                "--radio",
                "2000",
                "--clock",
                "vehicle",
                "--stats",
                stats_file.to_str().unwrap(),
                "--report-every",
                "0",
                "--duration",
                "300",
            ])
            .stdout(std::process::Stdio::piped()),
    );
    // the relay's vehicle side is bound before the copter starts sending (a copter that
    // finds no one listening just retries: udpout)
    std::thread::sleep(Duration::from_millis(500));
    let _sim = Guard::spawn(
        common::fleetmap()
            .command()
            .args([
                "sim",
                "--vehicles",
                "1xcopter:ardupilot",
                "--connect",
                &format!("udpout:127.0.0.1:{vport}"),
                "--home=37.1968,-80.5781",
                "--speedup",
                "5",
                "--duration",
                "3000",
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null()),
    );

    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        mavlink_version: 3,
        ..HEARTBEAT_DATA::default()
    });
    let streams = MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
        req_message_rate: 20,
        target_system: 1,
        target_component: 1,
        req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
        start_stop: 1,
    });
    let mut relay_addr: Option<SocketAddr> = None;
    let mut got: Vec<Got> = Vec::new();
    let start = Instant::now();
    let mut next_beat = start;
    let mut flowing: Option<Instant> = None;
    // 14 s of wall time once the streams flow (about 70 s of the copter's time)
    while flowing.is_none_or(|t| t.elapsed() < Duration::from_secs(14)) {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the copter's streams never came through the relay"
        );
        if let Some(to) = relay_addr
            && Instant::now() >= next_beat
        {
            gcs.send(&heartbeat, to);
            gcs.send(&streams, to);
            next_beat += Duration::from_secs(1);
        }
        if let Some((from, frames)) = gcs.recv(Duration::from_millis(50)) {
            relay_addr.get_or_insert(from);
            for f in frames {
                let Ok(msg) = f.message.clone() else { continue };
                if flowing.is_none() && matches!(msg, MavMessage::ATTITUDE(_)) {
                    flowing = Some(Instant::now());
                }
                got.push(Got {
                    at: Instant::now(),
                    len: f.raw.len(),
                    sysid: f.sysid(),
                    compid: f.compid(),
                    msg,
                });
            }
        }
    }
    relay.signal("TERM");
    assert!(relay.wait().unwrap().success(), "the relay failed");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats_file).expect("the stats file"))
            .unwrap();

    // What the GCS received from the copter after the radio's buffer filled (4 s after the
    // streams began), against the copter's own clock: the first and last time stamps.
    let flowing = flowing.unwrap();
    let from = flowing + Duration::from_secs(4);
    let window: Vec<&Got> = got
        .iter()
        .filter(|g| g.at >= from && g.sysid == 1)
        .collect();
    let stamps: Vec<u32> = window.iter().filter_map(|g| boot_ms(&g.msg)).collect();
    let (first, last) = (*stamps.iter().min().unwrap(), *stamps.iter().max().unwrap());
    let vehicle_s = f64::from(last - first) / 1000.0;
    let wall_s = window
        .last()
        .unwrap()
        .at
        .duration_since(window[0].at)
        .as_secs_f64();
    let bytes: usize = window.iter().map(|g| g.len).sum();
    let per_vehicle_s = bytes as f64 / vehicle_s;
    let reports: Vec<&Got> = got
        .iter()
        .filter(|g| matches!(g.msg, MavMessage::RADIO_STATUS(_)))
        .collect();
    let s = |path: &[&str]| {
        path.iter()
            .fold(&stats, |v, k| &v[*k])
            .as_f64()
            .unwrap_or_else(|| panic!("{path:?} in {stats}"))
    };
    eprintln!(
        "{bytes} B from the copter in {vehicle_s:.1} s of its time ({wall_s:.1} s of wall \
         time): {per_vehicle_s:.0} B/s of its time, {:.0} B/s of wall time; the relay's clock \
         ran {:.2}× wall time; RADIO_STATUS {} at the GCS, {} sent to the copter; up {} B, down \
         {} B, {} dropped on a full buffer",
        bytes as f64 / wall_s,
        s(&["clock_us"]) / s(&["wall_us"]),
        reports.len(),
        s(&["vehicle_radio", "radio_status"]),
        s(&["up", "bytes_out"]),
        s(&["down", "bytes_out"]),
        s(&["down", "rate_dropped"]),
    );
    // 2,000 B/s of the copter's time in all; the GCS's heartbeats and requests take about
    // 15 B/s of it, RADIO_STATUS none. The margin is the radio's buffer (4 kB, 2 s, drains at
    // the rate whatever the machine does) over a window of some 50 s of the copter's time.
    assert!(
        vehicle_s > 20.0,
        "only {vehicle_s:.1} s of the copter's time"
    );
    assert!(
        per_vehicle_s > 1800.0 && per_vehicle_s < 2100.0,
        "{per_vehicle_s:.0} B/s of the copter's time"
    );
    // the radio was the limit
    assert!(s(&["down", "rate_dropped"]) > 0.0);
    // RADIO_STATUS on both sides: the GCS's radio answers the GCS's heartbeats, the copter's
    // radio the copter's
    assert!(reports.len() >= 5, "{} reports at the GCS", reports.len());
    for r in &reports {
        assert_eq!((r.sysid, r.compid), (51, 68));
        let MavMessage::RADIO_STATUS(d) = &r.msg else {
            unreachable!()
        };
        assert!(d.txbuf <= 100 && d.rssi == 100 && d.remrssi == 100);
    }
    assert!(s(&["vehicle_radio", "radio_status"]) >= 5.0);
    // the stats file: its clock, and per message id with names
    assert_eq!(stats["clock"], "vehicle");
    assert_eq!(stats["down"]["by_message"]["30"]["name"], "ATTITUDE");
    assert!(s(&["down", "by_message", "30", "bytes_out"]) > 0.0);
    assert_eq!(stats["radio"]["duplex"], "half");
    assert_eq!(stats["radio"]["buffer_bytes"], 4096);
}
