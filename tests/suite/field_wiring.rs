//! Real fleets on real links: vehicles wired the way field setups wire them.
//!
//! * N simulated vehicles (3, and 50) each send to one GCS UDP port from a socket of their
//!   own, as several SITL instances or Wi-Fi drones do: every vehicle gets its telemetry
//!   (the GCS answers each at the address it speaks from), acknowledges commands, and takes
//!   a mission upload, all of them at once.
//! * The same with a MAVLink router in between (as mavlink-router or MAVProxy `--out` merge
//!   the vehicles): the GCS hears two copters from the router's one address, and telemetry,
//!   commands, uploads and downloads work for each (docs/field-wiring.md, "A router in
//!   between").
//! * `fleetmap mission upload` started before the vehicles power up: the ArduPilot copter
//!   heartbeats MAV_STATE_BOOT and refuses MISSION_COUNT with MAV_MISSION_NO_SPACE for its
//!   first 2 s, the PX4 copter answers at once; both uploads succeed once they are ready.

use fleetmap::fleet::{self, FleetConfig, FleetHandle};
use fleetmap_core::mission::item::MissionType;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::transport::LinkOptions;
use fleetmap_sim::harness::SimConfig;
use fleetmap_sim::server::{self};
use std::collections::HashSet;
use std::time::{Duration, Instant};

use crate::common;
use fleetmap_test_kit::router::{self, End};

const HOME: (f64, f64) = (37.1968, -80.5781);

/// How the vehicles reach the GCS's one UDP port.
#[derive(Clone, Copy, PartialEq)]
enum Wiring {
    /// Each vehicle sends to it from its own socket (`fleetmap sim --connect udpout:…`).
    Direct,
    /// Each vehicle sends to its own port of a router, which sends everything on to the GCS
    /// from one socket and everything from the GCS to every vehicle.
    Router,
}

/// A fleet listening on one loopback UDP port and the simulator serving `spec` to it, wired
/// as `wiring` says, at `speedup`.
async fn one_port(spec: &str, speedup: f64, wiring: Wiring) -> (FleetHandle, server::SimHandle) {
    let listen: ConnSpec = "udpin:127.0.0.1:0".parse().unwrap();
    let f = fleet::start(&[listen], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    let gcs = f.links()[0].local.expect("the port the GCS listens on");
    let cfg = SimConfig::from_spec(spec, None, Some(HOME), 11).unwrap();
    let endpoints = match wiring {
        Wiring::Direct => vec![fleetmap_test_kit::sim::udpout(gcs)],
        Wiring::Router => {
            let mut ends = vec![End::Fixed(gcs)];
            let mut endpoints = Vec::new();
            for _ in &cfg.vehicles {
                let s = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
                let a = s.local_addr().unwrap();
                endpoints.push(fleetmap_test_kit::sim::udpout(a));
                ends.push(End::Learn(s));
            }
            router::spawn(ends).await;
            endpoints
        }
    };
    let served =
        fleetmap_test_kit::sim::serve(cfg, endpoints, speedup, server::GcsClock::Wall).await;
    (f, served)
}

async fn every_vehicle_works(spec: &str, n: u8, wiring: Wiring) {
    let t0 = Instant::now();
    let (f, served) = one_port(spec, 5.0, wiring).await;
    // Each vehicle speaks from its own socket, bound to loopback like the GCS it talks to.
    let senders: HashSet<_> = served.bound.iter().map(|b| b.local).collect();
    assert_eq!(senders.len(), usize::from(n));
    assert!(senders.iter().all(|a| a.ip().is_loopback()), "{senders:?}");

    // Telemetry: battery, GPS and position from every one (stream requests reached each).
    for k in 1..=n {
        f.wait_until(k, Duration::from_secs(60), |v| {
            v.battery_pct.is_some() && v.gps_fix.is_some_and(|g| g >= 3) && v.position.is_some()
        })
        .await
        .unwrap_or_else(|v| panic!("vehicle {k} has no telemetry: {v:?}"));
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let st = f.links()[0].status();
    // Directly, one peer per vehicle; through a router, the router's one address.
    let peers = if wiring == Wiring::Router { 1 } else { n };
    assert_eq!(st.peers.len(), usize::from(peers), "peers {:?}", st.peers);

    // Commands and mission uploads, every vehicle at once.
    let mut tasks = Vec::new();
    for k in 1..=n {
        let f = f.clone();
        tasks.push(tokio::spawn(async move {
            common::command_and_mission_round_trip(&f, k, common::spread_mission(k, 19)).await;
        }));
    }
    for t in tasks {
        t.await.unwrap();
    }
    f.shutdown().await;
    let sim = served.stop().await.unwrap();
    for k in 1..=n {
        let v = sim.vehicle(k).unwrap();
        let stored = v.mission().items(MissionType::Mission);
        let home = usize::from(v.config().flavour.is_ardupilot());
        assert_eq!(stored.len() - home, 20, "vehicle {k}");
    }
    eprintln!(
        "{n} vehicles on one UDP port ({}): telemetry, commands and uploads in {:.1} s",
        if wiring == Wiring::Router {
            "through a router"
        } else {
            "directly"
        },
        t0.elapsed().as_secs_f64()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_copters_on_one_udp_port() {
    every_vehicle_works("3xcopter:ardupilot", 3, Wiring::Direct).await;
}

/// docs/field-wiring.md's router row: an ArduPilot and a PX4 copter behind a MAVLink router
/// that merges them onto one address, as mavlink-router and MAVProxy `--out` do.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_copters_behind_a_router() {
    every_vehicle_works("1xcopter:ardupilot,1xcopter:px4", 2, Wiring::Router).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fifty_copters_on_one_udp_port() {
    every_vehicle_works("25xcopter:ardupilot,25xcopter:px4", 50, Wiring::Direct).await;
}

/// `fleetmap mission upload` started before the simulator: it hears each vehicle's first
/// heartbeat while the vehicle boots and uploads once the vehicle is ready.
#[test]
fn mission_upload_while_the_vehicles_boot() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("m.waypoints");
    std::fs::write(
        &file,
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t37.1968\t-80.5781\t600\t1\n\
         1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1\n\
         2\t0\t3\t16\t0\t0\t0\t0\t37.1970\t-80.5780\t10\t1\n\
         3\t0\t3\t16\t0\t0\t0\t0\t37.1972\t-80.5782\t10\t1\n",
    )
    .unwrap();
    let port = fleetmap_test_kit::free_udp_port();
    let bin = common::fleetmap();
    let upload = |sysid: &str| {
        bin.command()
            .args([
                "mission",
                "upload",
                "--connect",
                &format!("udpin:127.0.0.1:{port}"),
                "--sysid",
                sysid,
                "--wait",
                "30",
                file.to_str().unwrap(),
            ])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    // Two GCS processes cannot share the port: one upload after the other, each started
    // before the vehicles boot.
    for (sysid, spec) in [("1", "1xcopter:ardupilot"), ("1", "1xcopter:px4")] {
        let gcs = upload(sysid);
        std::thread::sleep(Duration::from_millis(300));
        let mut sim = bin.quiet(&[
            "sim",
            "--vehicles",
            spec,
            "--connect",
            &format!("udpout:127.0.0.1:{port}"),
            "--home=37.1968,-80.5781",
        ]);
        let out = gcs.wait_with_output().unwrap();
        let _ = sim.kill();
        let _ = sim.wait();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(
            out.status.success(),
            "{spec}: exit {:?}\n{stdout}\n{stderr}",
            out.status
        );
        assert!(
            stdout.contains("uploaded 3 mission item(s)"),
            "{spec}: {stdout}"
        );
    }
}
