//! The embedded simulator's links carrying telemetry radios (`SimConfig::radio`): each
//! vehicle behind its own SiK pair, the budget counted in simulated time. A GCS that asks a
//! copter for every stream at 10 Hz gets no more than the radio carries; RADIO_STATUS comes
//! out at both ends (into the autopilot, which slows its streams, and to the GCS); frames
//! are lost at the configured rate; and the radio's frames arrive when their last byte has
//! crossed, between the simulator's 20 Hz ticks too.

use fleetmap_core::time::Time;
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_test_kit::gcs::heartbeat;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{self as mav, MavMessage};

fn gcs() -> MavHeader {
    MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    }
}

#[allow(deprecated)]
fn all_streams(hz: u16) -> MavMessage {
    MavMessage::REQUEST_DATA_STREAM(mav::REQUEST_DATA_STREAM_DATA {
        req_message_rate: hz,
        target_system: 1,
        target_component: 1,
        req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
        start_stop: 1,
    })
}

/// Fly `seconds` of a copter asked for everything at 10 Hz, the GCS heartbeating at 1 Hz;
/// returns (bytes the GCS received, RADIO_STATUS frames among them, arrival times).
fn run(cfg: SimConfig, seconds: u64) -> (Sim, u64, u64, Vec<Time>) {
    let mut sim = Sim::new(cfg, Time::ZERO).unwrap();
    let (mut bytes, mut reports, mut arrivals) = (0u64, 0u64, Vec::new());
    let mut codec = Codec::new();
    for s in 0..seconds * 20 {
        let t = Time::from_millis(s * 50);
        if s % 20 == 0 {
            sim.send(1, &gcs(), &heartbeat());
            if s % 100 == 0 {
                sim.send(1, &gcs(), &all_streams(10));
            }
        }
        // step through every moment something happens up to t
        while sim.poll_timeout() <= t {
            let next = sim.poll_timeout();
            sim.advance_to(next);
            while let Some(d) = sim.recv_bytes(1) {
                bytes += d.len() as u64;
                arrivals.push(sim.now());
                for f in codec.decode(&d, 0) {
                    if f.msg_id == 109 {
                        reports += 1;
                    }
                }
            }
        }
    }
    (sim, bytes, reports, arrivals)
}

#[test]
fn a_copter_behind_a_radio_gets_no_more_than_the_radio_carries() {
    let home = Some((37.1968, -80.5781));
    let open = SimConfig::from_spec("1xcopter:ardupilot", None, home, 3).unwrap();
    let (_, open_bytes, open_reports, _) = run(open.clone(), 120);
    let radio = RadioConfig {
        loss: 0.1,
        ..RadioConfig::radio(2000)
    };
    let (sim, bytes, reports, arrivals) = run(open.with_radio(radio), 120);
    let stats = sim.radio_stats(1).expect("a radio");
    eprintln!(
        "unlimited {open_bytes} B, radio {bytes} B ({:.0} B/s), {reports} reports; up {:?} \
         down {:?}",
        bytes as f64 / 120.0,
        (stats.up.bytes_out, stats.up.lost),
        (stats.down.bytes_out, stats.down.lost, stats.down.dropped)
    );
    // Unlimited, the copter sends more than 2,000 B/s when asked for everything.
    assert!(open_bytes > 2000 * 120, "{open_bytes}");
    assert_eq!(open_reports, 0);
    // Behind the radio: both directions together within the budget (the reports written
    // into the GCS's side cost no air, lost frames do), and the air mostly busy (the
    // autopilot slows its streams as the radio's buffer fills, so not always).
    let air =
        stats.up.bytes_out + stats.up.bytes_lost + stats.down.bytes_out + stats.down.bytes_lost;
    assert!(air <= 2000 * 120 + 300, "{air} B on the air in 120 s");
    assert!(air >= 2000 * 100, "{air} B: the air was idle");
    let air_s = (stats.up.air_us + stats.down.air_us) as f64 / 1e6;
    assert!(
        (100.0..=120.5).contains(&air_s),
        "the air held {air_s} s of 120"
    );
    // The copter asked for everything could not send it all: its radio's buffer overflowed.
    assert!(stats.down.dropped > 0);
    // About 10 % of the vehicle's frames lost on the air.
    let loss = stats.down.lost as f64 / (stats.down.lost + stats.down.frames_out) as f64;
    assert!((0.07..0.13).contains(&loss), "{loss}");
    // The radio reports itself to the GCS, and to the autopilot (which slows its streams).
    assert!(reports >= 100, "{reports} RADIO_STATUS at the GCS");
    assert!(stats.vehicle.radio_status >= 100);
    // Frames arrive when they have crossed, not only at the 20 Hz ticks.
    let off_tick = arrivals
        .iter()
        .filter(|t| t.as_micros() % 50_000 != 0)
        .count();
    assert!(
        off_tick * 2 > arrivals.len(),
        "{off_tick} of {}",
        arrivals.len()
    );
}
