//! The simulator's socket server on loopback: every vehicle on its own UDP or TCP endpoint,
//! speaking MAVLink 2 frames that an independent codec decodes; commands get answered;
//! captured images are written before they are announced.

use crate::common;

use fleetmap_core::time::Time;
use fleetmap_io::link::codec::Codec;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::server::{ServeOptions, parse_connection, spawn};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const HOME: (f64, f64) = (37.1965, -80.5785);

fn arm_cmd() -> MavMessage {
    MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
        param1: 1.0,
        command: mav::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        target_system: 2,
        target_component: 1,
        ..mav::COMMAND_LONG_DATA::default()
    })
}

fn gcs() -> MavHeader {
    MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    }
}

#[tokio::test]
async fn udp_endpoints_per_vehicle() {
    let cfg = SimConfig::from_spec("2xcopter:px4", None, Some(HOME), 1).unwrap();
    let sim = Sim::new(cfg, Time::ZERO).unwrap();
    let t0 = std::time::Instant::now();
    let h = spawn(
        sim,
        ServeOptions {
            endpoints: vec![parse_connection("udpin:127.0.0.1:0").unwrap()],
            speed: fleetmap_sim::pace::Speed::Times(20.0),
            gcs: fleetmap_sim::server::GcsClock::Wall,
            image_dir: None,
            duration_s: None,
        },
    )
    .await
    .unwrap();
    assert_eq!(h.bound.len(), 2);
    assert_ne!(h.bound[0].local, h.bound[1].local);
    // talk to vehicle 2 only: it answers (and only it)
    let sock = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let to = h.bound[1].local;
    let mut codec = Codec::new();
    let mut buf = vec![0u8; 65536];
    let hb = fleetmap_io::link::codec::encode_frame(
        &gcs(),
        &MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
            mavtype: mav::MavType::MAV_TYPE_GCS,
            ..mav::HEARTBEAT_DATA::default()
        }),
        mavlink::MavlinkVersion::V2,
        None,
        0,
    );
    sock.send_to(&hb, to).await.unwrap();
    let arm = fleetmap_io::link::codec::encode_frame(
        &gcs(),
        &arm_cmd(),
        mavlink::MavlinkVersion::V2,
        None,
        0,
    );
    sock.send_to(&arm, to).await.unwrap();
    let mut got_ack = None;
    let mut sysids = std::collections::BTreeSet::new();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    while tokio::time::Instant::now() < deadline && got_ack.is_none() {
        let Ok(Ok((n, _))) =
            tokio::time::timeout(Duration::from_millis(500), sock.recv_from(&mut buf)).await
        else {
            continue;
        };
        for f in codec.decode(&buf[..n], 0) {
            sysids.insert(f.sysid());
            if let Ok(MavMessage::COMMAND_ACK(a)) = f.message {
                got_ack = Some(a.result);
            }
        }
    }
    // not armable yet (no position estimate in the first simulated seconds)
    assert_eq!(
        got_ack,
        Some(mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED)
    );
    assert_eq!(sysids.into_iter().collect::<Vec<_>>(), vec![2]);
    let sim = h.stop().await.unwrap();
    // lock-step: never ahead of 20× the wall time it was served for
    let ceiling = t0.elapsed().as_secs_f64() * 20.0;
    assert!(
        sim.now().as_secs_f64() <= ceiling,
        "{} > {ceiling}",
        sim.now()
    );
    assert!(sim.vehicle(2).is_some_and(|v| v.boots() == 1));
}

#[tokio::test]
async fn tcp_endpoint_and_image_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = SimConfig::from_spec("1xcopter:ardupilot", None, Some(HOME), 2).unwrap();
    cfg.vehicles[0].camera.as_mut().unwrap().file_dir = Some(dir.path().display().to_string());
    let sim = Sim::new(cfg, Time::ZERO).unwrap();
    let h = spawn(
        sim,
        ServeOptions {
            endpoints: vec![parse_connection("tcpin:127.0.0.1:0").unwrap()],
            speed: fleetmap_sim::pace::Speed::Times(10.0),
            gcs: fleetmap_sim::server::GcsClock::Wall,
            image_dir: Some(dir.path().to_path_buf()),
            duration_s: None,
        },
    )
    .await
    .unwrap();
    let mut stream = tokio::net::TcpStream::connect(h.bound[0].local)
        .await
        .unwrap();
    let cmd = MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
        param2: 0.0,
        param3: 1.0,
        command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        target_system: 1,
        target_component: 100,
        ..mav::COMMAND_LONG_DATA::default()
    });
    let frame =
        fleetmap_io::link::codec::encode_frame(&gcs(), &cmd, mavlink::MavlinkVersion::V2, None, 0);
    stream.write_all(&frame).await.unwrap();
    let mut codec = Codec::new();
    let mut buf = vec![0u8; 65536];
    let mut url = None;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    while tokio::time::Instant::now() < deadline && url.is_none() {
        let Ok(Ok(n)) =
            tokio::time::timeout(Duration::from_millis(500), stream.read(&mut buf)).await
        else {
            continue;
        };
        for f in codec.decode(&buf[..n], 0) {
            if let Ok(MavMessage::CAMERA_IMAGE_CAPTURED(c)) = f.message {
                url = Some(
                    c.file_url
                        .to_str()
                        .unwrap_or("")
                        .trim_end_matches('\0')
                        .to_string(),
                );
            }
        }
    }
    let url = url.expect("CAMERA_IMAGE_CAPTURED over TCP");
    // the file exists by the time it is announced
    let bytes = fleetmap_io::files::read_file_url(&url, 10 << 20).unwrap();
    let meta = fleetmap_core::vision::meta::read_meta(&bytes).unwrap();
    assert_eq!(meta.sysid, 1);
    assert!(image::load_from_memory(&bytes).is_ok());
    h.stop().await.unwrap();
}

/// `fleetmap sim --camera-only` (the camera crate's serve loop): a simulated camera for a
/// real autopilot. The "autopilot"
/// here is this test, sending what ArduPilot's AP_Camera sends for a picture.
#[tokio::test]
#[allow(deprecated)]
async fn camera_for_a_real_autopilot() {
    let dir = tempfile::tempdir().unwrap();
    let world = std::sync::Arc::new(
        fleetmap_io::files::load_world(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/assets/worlds/runway.toml"
        )))
        .unwrap(),
    );
    let cfg = fleetmap_camera::camera::CameraConfig {
        file_dir: Some(dir.path().display().to_string()),
        mavlink_transfer: false,
        ..Default::default()
    };
    let cams = fleetmap_camera::paired::PairedCameras::new(world.clone(), cfg, 3);
    let (bound_tx, bound_rx) = tokio::sync::oneshot::channel();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let image_dir = dir.path().to_path_buf();
    let task = tokio::spawn(fleetmap_camera::serve::serve(
        cams,
        None,
        parse_connection("udpin:127.0.0.1:0").unwrap(),
        Some(image_dir),
        None,
        move |link| {
            let _ = bound_tx.send(link.local.expect("a UDP socket's address"));
        },
        async move {
            let _ = stop_rx.await;
        },
    ));
    let to = bound_rx.await.unwrap();
    let sock = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let ap = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: 0,
    };
    let (lat, lon) = world.default_home(1).unwrap();
    let send = |m: MavMessage| {
        fleetmap_io::link::codec::encode_frame(&ap, &m, mavlink::MavlinkVersion::V2, None, 0)
    };
    sock.send_to(
        &send(MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
            autopilot: mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            mavtype: mav::MavType::MAV_TYPE_QUADROTOR,
            ..mav::HEARTBEAT_DATA::default()
        })),
        to,
    )
    .await
    .unwrap();
    sock.send_to(
        &send(MavMessage::CAMERA_FEEDBACK(mav::CAMERA_FEEDBACK_DATA {
            lat: (lat * 1e7) as i32,
            lng: (lon * 1e7) as i32,
            alt_msl: 622.0,
            alt_rel: 12.0,
            target_system: 1,
            ..mav::CAMERA_FEEDBACK_DATA::default()
        })),
        to,
    )
    .await
    .unwrap();
    let mut codec = Codec::new();
    let mut buf = vec![0u8; 65536];
    let mut url = None;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    while tokio::time::Instant::now() < deadline && url.is_none() {
        let Ok(Ok((n, _))) =
            tokio::time::timeout(Duration::from_millis(500), sock.recv_from(&mut buf)).await
        else {
            continue;
        };
        for f in codec.decode(&buf[..n], 0) {
            if let Ok(MavMessage::CAMERA_IMAGE_CAPTURED(ref c)) = f.message {
                assert_eq!((f.sysid(), f.compid()), (1, 100));
                assert_eq!(c.lat, (lat * 1e7) as i32);
                url = Some(
                    c.file_url
                        .to_str()
                        .unwrap_or("")
                        .trim_end_matches('\0')
                        .to_string(),
                );
            }
        }
    }
    let url = url.expect("CAMERA_IMAGE_CAPTURED from the camera component");
    let bytes = fleetmap_io::files::read_file_url(&url, 10 << 20).unwrap();
    let meta = fleetmap_core::vision::meta::read_meta(&bytes).unwrap();
    assert_eq!(meta.sysid, 1);
    assert!((meta.alt_rel_m - 12.0).abs() < 0.01, "{meta:?}");
    let _ = stop_tx.send(());
    task.await.unwrap().unwrap();
}

/// A simulator on a starved machine still answers within the GCS's command timeout. Its
/// runtime gets one turn every ~95 ms (a blocking task holds the only thread in between) at
/// a ceiling of 20×. When its clock kept pace with the wall, every turn produced two
/// simulated seconds of telemetry from six vehicles; before the outgoing links were paced
/// (`sim::tx_queue`), the backlog grew without bound and a COMMAND_ACK waited behind seconds
/// of stale telemetry until the fleet's four attempts ran out (the lock-step flight's
/// failure under CI load). In lock-step (`sim::pace`) it steps at most 200 ms per turn and
/// runs at about 2×; the fleet follows its time.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_starved_simulator_still_answers_commands_in_time() {
    use fleetmap::fleet::FleetConfig;
    use fleetmap::kinds::bandit::sim::HARDWARE_TEAM;
    use fleetmap_io::clock::MonotonicClock;

    use std::time::Instant;

    const SPEEDUP: f64 = 20.0;
    let (link, ev_rx, gcs) = fleetmap_test_kit::gcs::listening_link().await;
    let cfg = SimConfig::from_spec(HARDWARE_TEAM, None, Some(HOME), 1).unwrap();
    // the hog: the thread is blocked but for one turn of the runtime every 95 ms
    let starved = common::StarvedSim::start(cfg, SPEEDUP, gcs, || {
        std::thread::sleep(Duration::from_millis(95))
    })
    .await;
    let fleet = fleetmap::fleet::spawn(
        vec![link],
        ev_rx,
        FleetConfig::at_speedup(SPEEDUP),
        MonotonicClock::following(&starved.time),
    );
    for sysid in 1..=6u8 {
        fleet
            .wait_vehicle(sysid, Duration::from_secs(20))
            .await
            .unwrap();
        fleet.wait_booted(sysid).await.unwrap();
    }
    // The fleet asks every vehicle for its telemetry streams; let the backlog build.
    tokio::time::sleep(Duration::from_secs(3)).await;
    let mut worst = Duration::ZERO;
    for round in 0..8 {
        let mut set = tokio::task::JoinSet::new();
        for sysid in 1..=6u8 {
            let fleet = fleet.clone();
            let mode = match (sysid <= 4, round % 2) {
                (true, 0) => "ALT_HOLD",
                (true, _) => "STABILIZE",
                (false, 0) => "HOLD",
                (false, _) => "MANUAL",
            };
            set.spawn(async move {
                let t = Instant::now();
                let r = fleet.set_mode_named(sysid, mode).await;
                (sysid, mode, r, t.elapsed())
            });
        }
        while let Some(r) = set.join_next().await {
            let (sysid, mode, r, took) = r.unwrap();
            r.unwrap_or_else(|e| panic!("round {round}: vehicle {sysid} to {mode}: {e}"));
            worst = worst.max(took);
        }
    }
    let speed = starved
        .time
        .achieved()
        .expect("the simulator measured its speed");
    fleet.shutdown().await;
    starved.stop();
    println!("48 mode changes on a starved simulator at {speed:.1}×: slowest {worst:?}");
    // lock-step: at most 200 ms of simulated time per 95 ms turn
    assert!(speed < 2.5, "the starved simulator ran at {speed:.1}×");
    // one attempt's worth of wall time (1 s) and the turn it waits for
    assert!(worst < Duration::from_millis(1500), "slowest {worst:?}");
}
