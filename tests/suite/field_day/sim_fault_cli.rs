//! `--fault` on the command line: the real `fleetmap sim` binary with a scheduled outage of
//! one of its two vehicles, listened to on a UDP socket playing the GCS; and the clear errors
//! of `fleetmap sim` and `fleetmap demo` for a spec that is wrong or names a vehicle the
//! simulation does not have.

use fleetmap_test_kit::Guard;
use fleetmap_test_kit::gcs::Gcs;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::time::{Duration, Instant};

use crate::common;

/// Run the binary with `args` to its end: (success, stderr).
fn run(args: &[&str]) -> (bool, String) {
    let (code, _, stderr) = common::fleetmap().run(args);
    (code == 0, stderr)
}

#[test]
fn fleetmap_sim_darkens_one_vehicles_link_in_its_outage_window() {
    let mut gcs = Gcs::bind();
    let port = gcs.addr().port();
    // ArduRover streams its positions at 1 Hz unasked: each carries the rover's time
    let mut sim = Guard::spawn(
        common::fleetmap()
            .command()
            .args([
                "sim",
                "--vehicles",
                "2xrover:ardupilot",
                "--connect",
                &format!("udpout:127.0.0.1:{port}"),
                "--home=37.1968,-80.5781",
                "--speedup",
                "10",
                "--duration",
                "40",
                "--fault",
                "1:outage@20s..30s",
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null()),
    );
    // (sysid, the vehicle's time in ms) of every GLOBAL_POSITION_INT
    let mut heard: Vec<(u8, u32)> = Vec::new();
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(60) {
        if let Some((_, frames)) = gcs.recv(Duration::from_millis(100)) {
            for f in frames {
                if let Ok(MavMessage::GLOBAL_POSITION_INT(p)) = f.message {
                    heard.push((f.header.system_id as u8, p.time_boot_ms));
                }
            }
        }
        if sim.try_wait().unwrap().is_some() {
            break;
        }
    }
    assert!(
        sim.try_wait().unwrap().is_some_and(|s| s.success()),
        "fleetmap sim did not end well within a minute"
    );
    let within = |sysid: u8, a: u32, b: u32| {
        heard
            .iter()
            .filter(|(s, t)| *s == sysid && (a..b).contains(t))
            .count()
    };
    // the rovers boot at simulated time 0, so their time is the simulation's; they send
    // positions from their position estimate on (15 s)
    assert!(within(1, 15_000, 20_000) >= 4, "{heard:?}");
    assert_eq!(within(1, 20_000, 30_000), 0, "{heard:?}");
    assert!(within(1, 30_000, 40_001) >= 5, "{heard:?}");
    assert!(within(2, 20_000, 30_000) >= 8, "{heard:?}");
}

#[test]
fn bad_fault_specs_are_refused_with_a_clear_error() {
    let sim = |fault: &str| {
        run(&[
            "sim",
            "--vehicles",
            "2xcopter:ardupilot",
            "--connect",
            "udpout:127.0.0.1:9",
            "--home=37.1968,-80.5781",
            "--duration",
            "1",
            "--fault",
            fault,
        ])
    };
    let (ok, err) = sim("1:explode@10s");
    assert!(!ok);
    assert!(err.contains("invalid fault \"1:explode@10s\""), "{err}");
    assert!(err.contains("unknown fault"), "{err}");
    let (ok, err) = sim("3:stuck@10s");
    assert!(!ok);
    assert!(err.contains("there is no vehicle 3"), "{err}");
    let (ok, err) = sim("2:battery=20@10s..20s");
    assert!(!ok);
    assert!(err.contains("takes no end time"), "{err}");
    // the demos check theirs before they fly
    let dir = tempfile::tempdir().unwrap();
    let run_dir = dir.path().join("run");
    let demo = |extra: &[&str]| {
        let mut a = vec!["demo", "--headless", "--run-dir", run_dir.to_str().unwrap()];
        a.extend_from_slice(extra);
        run(&a)
    };
    let (ok, err) = demo(&["--fault", "2:camera=sometimes"]);
    assert!(!ok);
    assert!(err.contains("camera=off"), "{err}");
    let (ok, err) = demo(&["--drones", "2", "--fault", "3:stuck@100s"]);
    assert!(!ok);
    assert!(err.contains("there is no vehicle 3"), "{err}");
    let (ok, err) = demo(&["--bandit", "--fault", "5:camera=off@100s"]);
    assert!(!ok);
    assert!(err.contains("vehicle 5 has no camera"), "{err}");
}
