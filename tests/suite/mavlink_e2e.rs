//! End-to-end tests of the link layer, the fleet and the `fleetmap` CLI over real sockets on
//! loopback.
//!
//! `Responder` is a minimal vehicle endpoint (heartbeat, position, home, GPS, the
//! simulator's vehicle-side mission server, ARM / DO_SET_MODE acknowledgements) used to test
//! transports, routing, signing and tlogs without the full simulator.

#![allow(deprecated)]

use fleetmap::fleet::{self, FleetConfig};
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::signing::{Signing, SigningKey};
use fleetmap_io::link::tlog::{read_tlog, spawn_tlog};
use fleetmap_io::{clock::unix_us as unix_now_us, link::transport::LinkOptions};
use fleetmap_sim::flavour::SimAutopilot;
use fleetmap_sim::mission_server::{HomeItem, MissionServer};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::*;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::net::UdpSocket;

use crate::common;

/// What a `Responder` saw and did.
#[derive(Default, Debug)]
struct Seen {
    armed: bool,
    custom_mode: u32,
    commands: Vec<MavCmd>,
    signing_drops: u64,
    unsigned_dropped: u64,
    bad_signature: u64,
}

/// A minimal ArduCopter-like endpoint on a UDP socket: answers whoever spoke last.
async fn responder(
    sock: UdpSocket,
    sysid: u8,
    signing: Option<Signing>,
    seen: Arc<Mutex<Seen>>,
    stop: tokio::sync::watch::Receiver<bool>,
    speedup: f64,
) {
    let mut codec = match signing {
        Some(s) => Codec::with_signing(s),
        None => Codec::new(),
    };
    // The vehicle's protocol timers run `speedup` times faster than wall time.
    let clock = MonotonicClock::with_speedup(speedup);
    let mut server = MissionServer::new(SimAutopilot::ArduPilot, sysid, 1);
    server.set_home(Some(HomeItem {
        lat_e7: 371_950_000,
        lon_e7: -805_800_000,
        alt_amsl_m: 600.0,
    }));
    let mut peer: Option<SocketAddr> = None;
    let mut buf = vec![0u8; 4096];
    let mut tick = tokio::time::interval(Duration::from_millis(10));
    let mut n = 0u64;
    loop {
        let mut out: Vec<MavMessage> = Vec::new();
        tokio::select! {
            _ = tick.tick() => {
                if *stop.borrow() { break; }
                let now = clock.now();
                if server.poll_timeout().is_some_and(|t| t <= now) {
                    server.handle_timeout(now);
                }
                n += 1;
                if !n.is_multiple_of(10) {
                    // Telemetry at 10 Hz, heartbeat at 1 Hz (wall time); timers every tick.
                    while let Some(m) = server.poll_transmit() {
                        out.push(m);
                    }
                    if let Some(p) = peer {
                        for m in out.drain(..) {
                            let bytes = codec.encode(sysid, 1, &m, unix_now_us());
                            let _ = sock.send_to(&bytes, p).await;
                        }
                    }
                    continue;
                }
                let (armed, mode) = {
                    let s = seen.lock().unwrap();
                    (s.armed, s.custom_mode)
                };
                if n % 100 == 10 {
                    out.push(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                        custom_mode: mode,
                        mavtype: MavType::MAV_TYPE_QUADROTOR,
                        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                        base_mode: if armed { MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED } else { MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED },
                        system_status: MavState::MAV_STATE_STANDBY,
                        mavlink_version: 3,
                    }));
                    out.push(MavMessage::HOME_POSITION(HOME_POSITION_DATA {
                        latitude: 371_950_000,
                        longitude: -805_800_000,
                        altitude: 600_000,
                        ..Default::default()
                    }));
                    out.push(MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                        fix_type: GpsFixType::GPS_FIX_TYPE_3D_FIX,
                        satellites_visible: 12,
                        ..Default::default()
                    }));
                    out.push(MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                        voltage_battery: 12_600,
                        battery_remaining: 87,
                        ..Default::default()
                    }));
                }
                out.push(MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: (now.as_micros() / 1000) as u32,
                    lat: 371_950_000,
                    lon: -805_800_000,
                    alt: 600_000,
                    relative_alt: 0,
                    hdg: 9000,
                    ..Default::default()
                }));
            }
            r = sock.recv_from(&mut buf) => {
                let Ok((len, from)) = r else { continue };
                peer = Some(from);
                let now = clock.now();
                for f in codec.decode(&buf[..len], unix_now_us()) {
                    let Ok(msg) = &f.message else { continue };
                    if server.handle_message(&f.header, msg, now) {
                        continue;
                    }
                    if let MavMessage::COMMAND_LONG(c) = msg {
                        if c.target_system != sysid { continue; }
                        let mut s = seen.lock().unwrap();
                        s.commands.push(c.command);
                        let result = match c.command {
                            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => { s.armed = c.param1 == 1.0; MavResult::MAV_RESULT_ACCEPTED }
                            MavCmd::MAV_CMD_DO_SET_MODE => { s.custom_mode = c.param2 as u32; MavResult::MAV_RESULT_ACCEPTED }
                            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => MavResult::MAV_RESULT_ACCEPTED,
                            MavCmd::MAV_CMD_DO_DIGICAM_CONTROL => MavResult::MAV_RESULT_ACCEPTED,
                            _ => MavResult::MAV_RESULT_UNSUPPORTED,
                        };
                        out.push(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                            command: c.command,
                            result,
                            progress: 0,
                            result_param2: 0,
                            target_system: f.sysid(),
                            target_component: f.compid(),
                        }));
                    }
                }
                let st = codec.stats();
                let mut s = seen.lock().unwrap();
                s.signing_drops = st.signing_drops();
                s.unsigned_dropped = st.unsigned_dropped;
                s.bad_signature = st.bad_signature;
            }
        }
        while let Some(m) = server.poll_transmit() {
            out.push(m);
        }
        while server.poll_event().is_some() {}
        if let Some(p) = peer {
            for m in out {
                let bytes = codec.encode(sysid, 1, &m, unix_now_us());
                let _ = sock.send_to(&bytes, p).await;
            }
        }
    }
}

struct Vehicle {
    addr: SocketAddr,
    seen: Arc<Mutex<Seen>>,
    stop: tokio::sync::watch::Sender<bool>,
}

async fn spawn_responder(sysid: u8, signing: Option<Signing>) -> Vehicle {
    spawn_responder_fast(sysid, signing, 1.0).await
}

async fn spawn_responder_fast(sysid: u8, signing: Option<Signing>, speedup: f64) -> Vehicle {
    let sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let addr = sock.local_addr().unwrap();
    let seen = Arc::new(Mutex::new(Seen::default()));
    let (stop, stop_rx) = tokio::sync::watch::channel(false);
    tokio::spawn(responder(
        sock,
        sysid,
        signing,
        seen.clone(),
        stop_rx,
        speedup,
    ));
    Vehicle { addr, seen, stop }
}

fn udpout(a: SocketAddr) -> ConnSpec {
    format!("udpout:{a}").parse().unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fleet_over_udp_sees_two_vehicles_routes_commands_and_transfers_missions() {
    let v1 = spawn_responder(1, None).await;
    let v2 = spawn_responder(2, None).await;
    let dir = tempfile::tempdir().unwrap();
    let tlog_path = dir.path().join("run.tlog");
    let (tlog, tlog_task) = spawn_tlog(&tlog_path).unwrap();
    let opts = LinkOptions {
        signing: None,
        tlog: Some(tlog),
    };
    let f = fleet::start(
        &[udpout(v1.addr), udpout(v2.addr)],
        &opts,
        FleetConfig::default(),
    )
    .await
    .unwrap();
    drop(opts);
    let a = f.wait_vehicle(1, Duration::from_secs(5)).await.unwrap();
    let b = f.wait_vehicle(2, Duration::from_secs(5)).await.unwrap();
    assert_eq!(
        (a.link, b.link),
        (0, 1),
        "each vehicle routed to its own link"
    );
    assert_eq!(
        a.flavour,
        fleetmap_core::proto::flavour::Flavour::ARDU_COPTER
    );
    // Telemetry reaches the snapshot.
    let a = f
        .wait_until(1, Duration::from_secs(5), |v| {
            v.home.is_some() && v.gps_fix == Some(3)
        })
        .await
        .unwrap();
    assert_eq!(a.battery_pct, Some(87));
    // Commands are routed to the right vehicle only.
    f.set_mode_named(2, "GUIDED").await.unwrap();
    assert_eq!(v2.seen.lock().unwrap().custom_mode, 4);
    assert_eq!(v1.seen.lock().unwrap().custom_mode, 0);
    f.arm(2).await.unwrap();
    assert!(v2.seen.lock().unwrap().armed);
    assert!(!v1.seen.lock().unwrap().armed);
    // Missions round-trip through ArduPilot's home item.
    let items = vec![
        MissionItem::takeoff(10.0),
        MissionItem::waypoint(37.196, -80.579, 12.0),
        MissionItem::waypoint(37.197, -80.578, 12.0),
        MissionItem::return_to_launch(),
    ];
    f.upload_mission(1, MissionType::Mission, items.clone())
        .await
        .unwrap();
    let (back, home) = f.download_mission(1, MissionType::Mission).await.unwrap();
    fleetmap_core::mission::wire::compare_items(&items, &back, true).unwrap();
    assert!(home.is_some());
    // Unknown vehicle: a typed error.
    assert!(matches!(
        f.arm(9).await,
        Err(fleetmap::fleet::FleetError::NoVehicle { sysid: 9 })
    ));
    let stats = f.links()[0].status();
    assert!(stats.stats.frames_in > 10 && stats.stats.frames_out > 5);
    f.shutdown().await;
    drop(f);
    let records = tokio::time::timeout(Duration::from_secs(5), tlog_task)
        .await
        .unwrap()
        .unwrap()
        .unwrap();
    assert!(records > 20);
    let rec = read_tlog(&tlog_path).unwrap();
    assert_eq!(rec.len() as u64, records);
    assert!(
        rec.iter().any(|(_, fr)| fr.sysid() == 255),
        "outgoing frames logged"
    );
    assert!(
        rec.iter().any(|(_, fr)| fr.sysid() == 2),
        "incoming frames logged"
    );
    assert!(rec.windows(2).all(|w| w[0].0 <= w[1].0 + 1_000_000));
    let _ = (v1.stop.send(true), v2.stop.send(true));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn signing_drops_unsigned_third_parties_and_wrong_keys() {
    let key = SigningKey::from_passphrase("field team 7");
    let v = spawn_responder(1, Some(Signing::new(key.clone(), 0))).await;

    // GCS with the right key: everything works.
    let opts = LinkOptions {
        signing: Some(Signing::new(key.clone(), 0)),
        tlog: None,
    };
    let f = fleet::start(&[udpout(v.addr)], &opts, FleetConfig::default())
        .await
        .unwrap();
    f.wait_vehicle(1, Duration::from_secs(5)).await.unwrap();
    f.set_mode_named(1, "LOITER").await.unwrap();
    assert_eq!(v.seen.lock().unwrap().custom_mode, 5);

    // A third party without the key sends an ARM command: ignored.
    let third = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let mut c = Codec::new();
    let arm = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        param1: 1.0,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    });
    for _ in 0..3 {
        third
            .send_to(&c.encode(250, 190, &arm, 0), v.addr)
            .await
            .unwrap();
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    {
        let s = v.seen.lock().unwrap();
        assert!(
            !s.armed,
            "an unsigned ARM from a third party must be ignored"
        );
        assert!(!s.commands.contains(&MavCmd::MAV_CMD_COMPONENT_ARM_DISARM));
        assert!(
            s.unsigned_dropped >= 3,
            "the vehicle counts the drops: {s:?}"
        );
    }
    f.shutdown().await;
    drop(f);

    // A GCS with a wrong key: nothing is accepted either way.
    let opts = LinkOptions {
        signing: Some(Signing::new(SigningKey::from_passphrase("wrong"), 0)),
        tlog: None,
    };
    let g = fleet::start(&[udpout(v.addr)], &opts, FleetConfig::default())
        .await
        .unwrap();
    // Its heartbeat reaches the responder, which answers: the answers must be dropped.
    assert!(g.wait_vehicle(1, Duration::from_secs(3)).await.is_err());
    let st = g.links()[0].status();
    assert!(
        st.stats.bad_signature > 0,
        "GCS counts bad signatures: {:?}",
        st.stats
    );
    assert_eq!(st.stats.frames_in, 0);
    assert!(
        v.seen.lock().unwrap().bad_signature > 0,
        "vehicle counts bad signatures"
    );
    g.shutdown().await;
    let _ = v.stop.send(true);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn udpin_answers_the_last_sender_and_tcp_reconnects() {
    // udpin: the fleet listens; a vehicle sends to it; the fleet answers that address.
    let listen = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = listen.local_addr().unwrap().port();
    drop(listen);
    let spec: ConnSpec = format!("udpin:127.0.0.1:{port}").parse().unwrap();
    let f = fleet::start(&[spec], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    let veh = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let mut c = Codec::new();
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GROUND_ROVER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_PX4,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    });
    veh.send_to(&c.encode(7, 1, &hb, 0), ("127.0.0.1", port))
        .await
        .unwrap();
    let v = f.wait_vehicle(7, Duration::from_secs(3)).await.unwrap();
    assert_eq!(v.flavour, fleetmap_core::proto::flavour::Flavour::PX4_ROVER);
    // The GCS heartbeat (1 Hz) comes back to the vehicle's address.
    let mut buf = [0u8; 512];
    let (n, _) = tokio::time::timeout(Duration::from_secs(3), veh.recv_from(&mut buf))
        .await
        .unwrap()
        .unwrap();
    let mut rx = Codec::new();
    let frames = rx.decode(&buf[..n], 0);
    assert!(frames.iter().any(|fr| fr.sysid() == 255));
    f.shutdown().await;

    // tcp: connect, lose the server, get it back.
    let l = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = l.local_addr().unwrap();
    let spec: ConnSpec = format!("tcp:{addr}").parse().unwrap();
    let g = fleet::start(&[spec], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    let (s1, _) = l.accept().await.unwrap();
    drop(s1); // peer goes away
    let (s2, _) = tokio::time::timeout(Duration::from_secs(5), l.accept())
        .await
        .expect("the link reconnects")
        .unwrap();
    use tokio::io::AsyncWriteExt;
    let mut s2 = s2;
    s2.write_all(&c.encode(8, 1, &hb, 0)).await.unwrap();
    g.wait_vehicle(8, Duration::from_secs(3)).await.unwrap();
    assert!(g.links()[0].status().connects >= 2);
    g.shutdown().await;
}

/// The mission protocol's acceptance: over real UDP on loopback against the embedded simulator with
/// 30 % loss each way, 50 uploads of a 200-item mission all succeed and a download returns
/// the same items.
///
/// The simulator (`sim::server` serving a `Sim` at real speed, as `fleetmap sim --loss 0.3`
/// does: the same loss on every vehicle's uplink and downlink) runs 25 copters, 13
/// ArduPilot and 12 PX4, and the fleet uploads twice to each, all vehicles in parallel,
/// every upload preceded by a clear and followed by a download compared item by item. Protocol timeouts are shortened to what loopback needs
/// (the defaults are the specification's for radios: 1500 ms / 250 ms): 40 ms for an
/// answer, 20 ms per item during a download — the simulator answers within a millisecond,
/// the rest is headroom for two busy cores (an early timeout only sends a duplicate, which
/// both autopilots tolerate). A round trip gets through with probability 0.7² = 0.49, and
/// PX4 stays busy for 5 s (`MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT`) after a download
/// whose final ACK was lost, refusing the next operation meanwhile: the transfers go on as
/// long as the vehicle answers (the default silence budget, 30 s). Takes about 30 s on two
/// cores (the time goes into waiting for timeouts: 25 vehicles in parallel cost little more
/// than one).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fifty_uploads_of_200_items_to_the_simulator_with_30_percent_loss_each_way() {
    use fleetmap_io::link::faults::LinkFaults;
    use fleetmap_sim::harness::SimConfig;
    use fleetmap_sim::server::{self};
    const VEHICLES: u8 = 25;
    const ROUNDS: usize = 2;
    let sim_cfg = SimConfig::from_spec(
        "13xcopter:ardupilot,12xcopter:px4",
        None,
        Some((37.1968, -80.5781)),
        30,
    )
    .unwrap()
    .with_faults(LinkFaults {
        loss: 0.3,
        ..LinkFaults::default()
    });
    let served = fleetmap_test_kit::sim::serve(
        sim_cfg,
        vec![server::parse_connection("udpin:127.0.0.1:0").unwrap()],
        1.0,
        fleetmap_sim::server::GcsClock::Wall,
    )
    .await;
    let specs: Vec<ConnSpec> = served.bound.iter().map(|b| udpout(b.local)).collect();
    let cfg = FleetConfig {
        mission: fleetmap_core::proto::mission::MissionConfig {
            timeout: Duration::from_millis(40),
            item_timeout: Duration::from_millis(20),
            settle: Duration::from_millis(20),
            ..fleetmap_core::proto::mission::MissionConfig::default()
        },
        ..FleetConfig::default()
    };
    let f = fleet::start(&specs, &LinkOptions::default(), cfg)
        .await
        .unwrap();
    for k in 1..=VEHICLES {
        f.wait_vehicle(k, Duration::from_secs(20)).await.unwrap();
    }
    // Positions 1 m apart, altitudes in whole centimetres, hold times in whole seconds:
    // what both autopilots store exactly.
    let items: Vec<MissionItem> = (0..200)
        .map(|i| MissionItem {
            param1: (i % 3) as f32,
            ..MissionItem::waypoint(
                37.1968 + f64::from(i) * 1e-5,
                -80.5781 + f64::from(i % 7) * 1e-5,
                10.0 + (i % 9) as f32 + 0.25,
            )
        })
        .collect();
    let started = std::time::Instant::now();
    let mut tasks = Vec::new();
    for k in 1..=VEHICLES {
        let (f, items) = (f.clone(), items.clone());
        tasks.push(tokio::spawn(async move {
            for round in 1..=ROUNDS {
                // Each round must really replace the list: clear it first.
                f.clear_mission(k, MissionType::Mission)
                    .await
                    .unwrap_or_else(|e| panic!("vehicle {k} clear {round}: {e}"));
                f.upload_mission(k, MissionType::Mission, items.clone())
                    .await
                    .unwrap_or_else(|e| panic!("vehicle {k} upload {round}: {e}"));
                let (back, _home) = f
                    .download_mission(k, MissionType::Mission)
                    .await
                    .unwrap_or_else(|e| panic!("vehicle {k} download {round}: {e}"));
                fleetmap_core::mission::wire::compare_items(&items, &back, false)
                    .unwrap_or_else(|d| panic!("vehicle {k} round {round}: {d}"));
            }
            ROUNDS
        }));
    }
    let mut uploads = 0;
    for t in tasks {
        uploads += t.await.unwrap();
    }
    assert_eq!(uploads, 50);
    eprintln!(
        "50 uploads and downloads of 200 items with 30 % loss each way: {:.1} s",
        started.elapsed().as_secs_f64()
    );
    // The loss was real: every vehicle's frames arrived with sequence gaps.
    for (i, l) in f.links().iter().enumerate() {
        let sysid = i as u8 + 1;
        let st = l.status();
        assert!(
            st.stats.sources[&fleetmap_core::proto::Endpoint::new(sysid, 1)].lost > 0,
            "vehicle {sysid}: no frame lost"
        );
    }
    f.shutdown().await;
    let sim = served.stop().await.unwrap();
    // Both autopilots hold the last upload.
    for k in 1..=VEHICLES {
        let v = sim.vehicle(k).unwrap();
        let stored = v.mission().items(MissionType::Mission);
        let user = if v.config().flavour.is_ardupilot() {
            &stored[1..]
        } else {
            stored
        };
        assert_eq!(user.len(), 200, "vehicle {k}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cli_vehicles_mission_files_and_commands() {
    let v = spawn_responder(4, None).await;
    let conn = format!("udpout:{}", v.addr);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = conn.clone();
    let (code, out, err) = tokio::task::spawn_blocking(move || {
        common::fleetmap().run(&["vehicles", "--connect", &c, "--wait", "1.5", "--json"])
    })
    .await
    .unwrap();
    assert_eq!(code, 0, "{err}");
    let snap: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(snap["vehicles"]["4"]["flavour"]["autopilot"], "ArduPilot");
    assert_eq!(snap["vehicles"]["4"]["mode"], "STABILIZE");

    // A Mission Planner .waypoints file up, a .plan down, identical items.
    let wp = d.join("m.waypoints");
    std::fs::write(
        &wp,
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t37.195\t-80.58\t600\t1\n\
         1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1\n\
         2\t0\t3\t16\t0\t0\t0\t0\t37.1955\t-80.5805\t10\t1\n\
         3\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0\t1\n",
    )
    .unwrap();
    let plan = d.join("back.plan");
    let (c, w, p) = (conn.clone(), wp.clone(), plan.clone());
    let r = tokio::task::spawn_blocking(move || {
        let up = common::fleetmap().run(&[
            "mission",
            "upload",
            "--connect",
            &c,
            "--sysid",
            "4",
            w.to_str().unwrap(),
        ]);
        let down = common::fleetmap().run(&[
            "mission",
            "download",
            "--connect",
            &c,
            "--sysid",
            "4",
            p.to_str().unwrap(),
        ]);
        let mode = common::fleetmap().run(&[
            "command",
            "--connect",
            &c,
            "--sysid",
            "4",
            "--json",
            "mode",
            "loiter",
        ]);
        let bad_mode = common::fleetmap().run(&[
            "command",
            "--connect",
            &c,
            "--sysid",
            "4",
            "mode",
            "MISSION",
        ]);
        let clear = common::fleetmap().run(&["mission", "clear", "--connect", &c, "--sysid", "4"]);
        let nobody = common::fleetmap().run(&[
            "mission",
            "clear",
            "--connect",
            &c,
            "--sysid",
            "9",
            "--wait",
            "1",
        ]);
        (up, down, mode, bad_mode, clear, nobody)
    })
    .await
    .unwrap();
    let (up, down, mode, bad_mode, clear, nobody) = r;
    assert_eq!(up.0, 0, "{}", up.2);
    assert!(
        up.1.contains("uploaded 3 mission item(s) to vehicle 4"),
        "{}",
        up.1
    );
    assert_eq!(down.0, 0, "{}", down.2);
    let p =
        fleetmap_core::mission::plan::parse_plan(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    let w = fleetmap_core::mission::wpl::parse_wpl(&std::fs::read_to_string(&wp).unwrap()).unwrap();
    fleetmap_core::mission::wire::compare_items(&w.items, &p.mission, true).unwrap();
    assert!(
        p.home.is_some(),
        "ArduPilot home kept as plannedHomePosition"
    );
    assert_eq!(mode.0, 0, "{}", mode.2);
    assert!(mode.1.contains("\"result\":\"mode LOITER\""), "{}", mode.1);
    assert_eq!(v.seen.lock().unwrap().custom_mode, 5);
    assert_eq!(bad_mode.0, 1);
    assert!(
        bad_mode
            .2
            .contains("unknown mode \"MISSION\" for ArduPilot copter"),
        "{}",
        bad_mode.2
    );
    assert_eq!(bad_mode.2.lines().count(), 1, "one line: {}", bad_mode.2);
    assert_eq!(clear.0, 0, "{}", clear.2);
    assert_eq!(nobody.0, 1);
    assert!(
        nobody.2.contains("no heartbeat from system 9"),
        "{}",
        nobody.2
    );

    // Malformed files: rejected before connecting, with the line number.
    let bad = d.join("bad.waypoints");
    std::fs::write(
        &bad,
        "QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0\n",
    )
    .unwrap();
    let (code, _, err) = common::fleetmap().run(&[
        "mission",
        "upload",
        "--connect",
        &conn,
        "--sysid",
        "4",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("line 3: expected 12 fields"), "{err}");
    let _ = v.stop.send(true);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn capture_goes_to_the_camera_component_when_there_is_one() {
    let v = spawn_responder(5, None).await;
    let f = fleet::start(
        &[udpout(v.addr)],
        &LinkOptions::default(),
        FleetConfig::default(),
    )
    .await
    .unwrap();
    f.wait_vehicle(5, Duration::from_secs(5)).await.unwrap();
    // No camera component: DO_DIGICAM_CONTROL to the autopilot.
    f.capture_image(5, 1).await.unwrap();
    assert!(
        v.seen
            .lock()
            .unwrap()
            .commands
            .contains(&MavCmd::MAV_CMD_DO_DIGICAM_CONTROL)
    );
    f.shutdown().await;
    // A camera (component 100) on its own link (a second radio or a Wi-Fi camera) announces
    // itself: IMAGE_START_CAPTURE goes to it, over that link.
    let cam = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let mut c = Codec::new();
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_CAMERA,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    let listen = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = listen.local_addr().unwrap().port();
    drop(listen);
    let g = fleet::start(
        &[
            udpout(v.addr),
            format!("udpin:127.0.0.1:{port}").parse().unwrap(),
        ],
        &LinkOptions::default(),
        FleetConfig::default(),
    )
    .await
    .unwrap();
    g.wait_vehicle(5, Duration::from_secs(5)).await.unwrap();
    cam.send_to(&c.encode(5, 100, &hb, 0), ("127.0.0.1", port))
        .await
        .unwrap();
    g.wait_until(5, Duration::from_secs(3), |v| v.camera_compid == Some(100))
        .await
        .unwrap();
    let cap = {
        let g = g.clone();
        tokio::spawn(async move { g.capture_image(5, 7).await })
    };
    let mut buf = [0u8; 512];
    let mut got = None;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(3);
    let mut rx = Codec::new();
    while got.is_none() && tokio::time::Instant::now() < deadline {
        if let Ok(Ok((n, from))) =
            tokio::time::timeout(Duration::from_millis(500), cam.recv_from(&mut buf)).await
        {
            for fr in rx.decode(&buf[..n], 0) {
                if let Ok(MavMessage::COMMAND_LONG(cmd)) = &fr.message
                    && cmd.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE
                {
                    assert_eq!((cmd.target_system, cmd.target_component), (5, 100));
                    assert_eq!((cmd.param3, cmd.param4), (1.0, 7.0));
                    got = Some(from);
                    let ack = MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                        command: cmd.command,
                        result: MavResult::MAV_RESULT_ACCEPTED,
                        progress: 0,
                        result_param2: 0,
                        target_system: 255,
                        target_component: 190,
                    });
                    cam.send_to(&c.encode(5, 100, &ack, 0), from).await.unwrap();
                }
            }
        }
    }
    assert!(
        got.is_some(),
        "IMAGE_START_CAPTURE reached the camera over its own link"
    );
    cap.await.unwrap().unwrap();
    // Its capture record (heard twice: the GCS asked again) and its on-board measurement:
    // the fleet counts one picture and one measurement for the camera's health.
    let captured = MavMessage::CAMERA_IMAGE_CAPTURED(CAMERA_IMAGE_CAPTURED_DATA {
        time_boot_ms: 4_000,
        image_index: 0,
        ..Default::default()
    });
    let measured = fleetmap_core::vision::onboard::OnboardMeasurement {
        time_boot_ms: 4_000,
        image_index_lo: 0,
        spec: 1,
        picture_bytes: 20_000,
        value: fleetmap_core::vision::onboard::GreenShare {
            share: 0.4,
            pixels: 1000,
        },
    }
    .to_message();
    for m in [&captured, &captured, &measured] {
        cam.send_to(&c.encode(5, 100, m, 0), ("127.0.0.1", port))
            .await
            .unwrap();
    }
    let v5 = g
        .wait_until(5, Duration::from_secs(3), |v| v.camera_measurements == 1)
        .await
        .unwrap();
    assert_eq!((v5.camera_pictures, v5.camera_measurements), (1, 1));
    assert!(
        v5.camera_age_s.is_some_and(|a| a < 3.0),
        "{:?}",
        v5.camera_age_s
    );
    g.shutdown().await;
    let _ = v.stop.send(true);
}

#[test]
fn unknown_frames_and_garbage_do_not_break_the_fleet_state() {
    // Pure check of the lenient heartbeat path used by the fleet: a MAV_TYPE newer than
    // our dialect still yields a vehicle.
    let mut c = Codec::new();
    let mut hb = c.encode(
        3,
        1,
        &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 4,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        }),
        0,
    );
    hb[14] = 77; // MAV_TYPE 77: unknown
    let n = hb.len();
    let crc = fleetmap_io::link::codec::frame_crc(&hb[1..n - 2], 50);
    hb[n - 2..].copy_from_slice(&crc.to_le_bytes());
    let frames = Codec::new().decode(&hb, 0);
    assert!(frames[0].message.is_err());
    let beat = fleetmap_core::proto::heartbeat::Beat::from_payload(frames[0].payload());
    assert_eq!((beat.mav_type, beat.custom_mode), (77, 4));
    let _ = (Time::ZERO, Endpoint::gcs(), MavHeader::default());
}
