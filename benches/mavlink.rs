//! MAVLink benchmarks: frame decoding throughput, and a 200-item mission upload — in-process
//! (the GCS machine against the simulator's vehicle-side mission server, no loss, no
//! latency) and over loopback UDP (the whole GCS stack, `FleetHandle` with its links and
//! actor, against the embedded simulator served by `sim::server`, no loss) — reported as
//! items per second.
//!
//! `cargo bench --bench mavlink` (`-- loopback` for the UDP one only)

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::mission::{MissionClient, MissionConfig, MissionEvent, MissionOp};
use fleetmap_core::time::Time;
use fleetmap_io::link::codec::Codec;
use fleetmap_sim::flavour::SimAutopilot;
use fleetmap_sim::mission_server::MissionServer;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::*;
use std::hint::black_box;
use std::time::Duration;

/// A realistic telemetry mix: position, attitude, heartbeat, status, GPS, mission item.
fn telemetry_stream(frames: usize) -> Vec<u8> {
    let mut c = Codec::new();
    let msgs = [
        MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            time_boot_ms: 123_456,
            lat: 371_950_000,
            lon: -805_800_000,
            alt: 612_000,
            relative_alt: 12_000,
            vx: 100,
            vy: -50,
            vz: 3,
            hdg: 9000,
        }),
        MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: 123_456,
            roll: 0.01,
            pitch: -0.02,
            yaw: 1.5,
            rollspeed: 0.001,
            pitchspeed: 0.002,
            yawspeed: 0.003,
        }),
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 3,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        }),
        MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
            fix_type: GpsFixType::GPS_FIX_TYPE_3D_FIX,
            satellites_visible: 14,
            lat: 371_950_000,
            lon: -805_800_000,
            ..Default::default()
        }),
        MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
            seq: 12,
            x: 371_950_000,
            y: -805_800_000,
            z: 12.0,
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            autocontinue: 1,
            ..Default::default()
        }),
    ];
    let mut out = Vec::new();
    for i in 0..frames {
        out.extend_from_slice(&c.encode(1, 1, &msgs[i % msgs.len()], 0));
    }
    out
}

fn decode(c: &mut Criterion) {
    let n = 10_000;
    let stream = telemetry_stream(n);
    let mut g = c.benchmark_group("decode");
    g.throughput(Throughput::Bytes(stream.len() as u64));
    for chunk in [64usize, 1500, 65_536] {
        g.bench_with_input(
            BenchmarkId::new("frames_10k_chunk", chunk),
            &chunk,
            |b, &chunk| {
                b.iter(|| {
                    let mut codec = Codec::new();
                    let mut count = 0;
                    for part in stream.chunks(chunk) {
                        count += codec.decode(part, 0).len();
                    }
                    assert_eq!(count, n);
                    black_box(count)
                })
            },
        );
    }
    g.finish();
}

/// One 200-item upload, GCS machine ↔ vehicle server, messages passed in memory.
fn upload_once(ap: bool, items: &[MissionItem]) -> usize {
    let vehicle = Endpoint::new(1, fleetmap_core::proto::AUTOPILOT_COMPID);
    let mut client = MissionClient::new(Endpoint::gcs(), vehicle, ap, MissionConfig::default());
    let mut server = MissionServer::new(
        if ap {
            SimAutopilot::ArduPilot
        } else {
            SimAutopilot::Px4
        },
        1,
        1,
    );
    let gcs_hdr = MavHeader {
        system_id: fleetmap_core::proto::GCS_SYSID as u32,
        component_id: fleetmap_core::proto::GCS_COMPID,
        sequence: 0,
    };
    let veh_hdr = MavHeader {
        system_id: 1,
        component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
        sequence: 0,
    };
    let now = Time::from_secs(1);
    let id = client.start(
        MissionOp::Upload {
            kind: MissionType::Mission,
            items: items.to_vec(),
            home: None,
        },
        now,
    );
    loop {
        let mut moved = false;
        while let Some(m) = client.poll_transmit() {
            server.handle_message(&gcs_hdr, &m, now);
            moved = true;
        }
        while let Some(m) = server.poll_transmit() {
            client.handle_message(&veh_hdr, &m, now);
            moved = true;
        }
        while server.poll_event().is_some() {}
        while let Some(ev) = client.poll_event() {
            if let MissionEvent::Done { id: i, result } = ev
                && i == id
            {
                assert!(result.is_ok(), "{result:?}");
                return items.len();
            }
        }
        assert!(moved, "stalled");
    }
}

fn upload(c: &mut Criterion) {
    let items: Vec<MissionItem> = (0..200)
        .map(|i| MissionItem::waypoint(37.19 + f64::from(i) * 1e-5, -80.58, 12.0))
        .collect();
    let mut g = c.benchmark_group("mission_upload_200_items");
    g.throughput(Throughput::Elements(items.len() as u64));
    g.measurement_time(Duration::from_secs(5));
    g.bench_function("ardupilot", |b| {
        b.iter(|| black_box(upload_once(true, &items)))
    });
    g.bench_function("px4", |b| b.iter(|| black_box(upload_once(false, &items))));
    g.finish();
}

/// A 200-item upload over loopback UDP, no loss: `fleet::start` on `udpout:` links to
/// `sim::server` serving one ArduPilot and one PX4 copter at real speed on
/// `udpin:127.0.0.1:0`, `FleetHandle::upload_mission` to completion (final MISSION_ACK).
/// The mission protocol runs with the specification's timeouts, but the quiet time between
/// two operations (`MissionConfig::settle`, 250 ms) is 1 ms, so that each iteration times
/// the transfer and not the pause before it. The vehicles stream their telemetry meanwhile,
/// as they would.
fn upload_loopback(c: &mut Criterion) {
    use fleetmap::fleet::{self, FleetConfig};
    use fleetmap_io::link::transport::LinkOptions;
    use fleetmap_sim::harness::{Sim, SimConfig};
    use fleetmap_sim::server::{self, ServeOptions};
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("tokio runtime");
    let (f, served) = rt.block_on(async {
        let cfg = SimConfig::from_spec(
            "1xcopter:ardupilot,1xcopter:px4",
            None,
            Some((37.1968, -80.5781)),
            1,
        )
        .expect("sim config");
        let served = server::spawn(
            Sim::new(cfg, Time::ZERO).expect("sim"),
            ServeOptions {
                endpoints: vec![server::parse_connection("udpin:127.0.0.1:0").expect("endpoint")],
                speed: fleetmap_sim::pace::Speed::Times(1.0),
                gcs: fleetmap_sim::server::GcsClock::Wall,
                image_dir: None,
                duration_s: None,
            },
        )
        .await
        .expect("serve the simulator");
        let specs: Vec<fleetmap_io::link::ConnSpec> = served
            .bound
            .iter()
            .map(|b| format!("udpout:{}", b.local).parse().expect("conn"))
            .collect();
        let mut fc = FleetConfig::default();
        fc.mission.settle = Duration::from_millis(1);
        let f = fleet::start(&specs, &LinkOptions::default(), fc)
            .await
            .expect("fleet");
        for k in 1..=2 {
            f.wait_vehicle(k, Duration::from_secs(10))
                .await
                .expect("vehicle heard");
        }
        (f, served)
    });
    let items: Vec<MissionItem> = (0..200)
        .map(|i| MissionItem::waypoint(37.19 + f64::from(i) * 1e-5, -80.58, 12.0))
        .collect();
    let mut g = c.benchmark_group("mission_upload_200_items_loopback_udp");
    g.throughput(Throughput::Elements(items.len() as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(10));
    for (name, sysid) in [("ardupilot", 1u8), ("px4", 2)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let out = rt
                    .block_on(f.upload_mission(sysid, MissionType::Mission, items.clone()))
                    .expect("upload");
                black_box(out)
            })
        });
    }
    g.finish();
    rt.block_on(async {
        f.shutdown().await;
        let _ = served.stop().await;
    });
}

criterion_group!(benches, decode, upload, upload_loopback);
criterion_main!(benches);
