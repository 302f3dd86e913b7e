//! `fleetmap mission fly` end to end: the real binary as two processes, `fleetmap sim` serving
//! one simulated vehicle on loopback UDP faster than real time and `fleetmap mission fly`
//! flying a small mission file on it — for an ArduPilot copter (QGC WPL 110 file), a PX4
//! copter (QGroundControl `.plan`) and an ArduPilot rover.
//!
//! `mission fly` starts as soon as the simulator has opened its socket, while the simulated
//! autopilot is still booting (no GPS fix, no position estimate): it must wait for the
//! vehicle to become ready on its own. The GCS lives on the wall clock while the simulator
//! runs 8 times faster, so PX4's GCS-link checks must be judged in the GCS's time.
//!
//! Each test takes about 15–30 s of wall time.

use crate::common;

use fleetmap_core::mission::item::MissionItem;
use fleetmap_core::mission::plan::{Plan, write_plan};
use fleetmap_test_kit::{Guard, at, free_udp_port};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

/// Home of the simulated vehicle (degrees).
const HOME: (f64, f64) = (37.1968, -80.5781);
/// Simulated seconds per wall second.
const SPEEDUP: &str = "8";

/// Start `fleetmap sim` with one vehicle `spec` listening on 127.0.0.1:`port`; returns once
/// it has printed its endpoint (its socket is open and its vehicle has just powered up).
/// Its log goes to `log`.
fn start_sim(spec: &str, port: u16, log: &Path) -> Guard {
    let err = std::fs::File::create(log).unwrap();
    let mut proc = Guard::spawn(
        common::fleetmap()
            .command()
            .args([
                "sim",
                "--vehicles",
                spec,
                "--home",
                &format!("{},{}", HOME.0, HOME.1),
                "--connect",
                &format!("udpin:127.0.0.1:{port}"),
                "--speedup",
                SPEEDUP,
                "--seed",
                "3",
                "-v",
            ])
            .stdout(Stdio::piped())
            .stderr(err),
    );
    let out = proc.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(out).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx
        .recv_timeout(Duration::from_secs(30))
        .expect("fleetmap sim did not start");
    assert!(line.starts_with("vehicle 1 "), "fleetmap sim said {line:?}");
    proc
}

/// Run `fleetmap mission VERB` on vehicle 1 at 127.0.0.1:`port` with `extra` options and
/// `file`; returns (exit code, stdout, stderr). Killed after `limit`.
fn mission_cmd(
    verb: &str,
    port: u16,
    extra: &[&str],
    file: &Path,
    limit: Duration,
) -> (i32, String, String) {
    let connect = format!("udpout:127.0.0.1:{port}");
    let mut args = vec!["mission", verb, "--connect", &connect, "--sysid", "1"];
    args.extend_from_slice(extra);
    args.push(file.to_str().unwrap());
    let mut child = common::fleetmap()
        .command()
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start fleetmap mission");
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `fleetmap mission fly` with a 200 s flight budget, killed after 240 s.
fn fly(port: u16, file: &Path) -> (i32, String, String) {
    mission_cmd(
        "fly",
        port,
        &["--timeout", "200"],
        file,
        Duration::from_secs(240),
    )
}

/// Fly `items` (written to `file_name` in the temporary directory: `.plan` or `.waypoints`)
/// on a simulated `spec` vehicle and check that every item was reached and the vehicle came
/// down (`end`: "landed and disarmed", or "back at home" for a rover).
fn fly_and_check(spec: &str, file_name: &str, items: &[MissionItem], end: &str) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(file_name);
    let text = if file_name.ends_with(".plan") {
        write_plan(&Plan {
            mission: items.to_vec(),
            home: Some((HOME.0, HOME.1, 0.0)),
            firmware_type: 12,
            ..Plan::default()
        })
    } else {
        let home = MissionItem {
            frame: 0,
            ..MissionItem::waypoint(HOME.0, HOME.1, 0.0)
        };
        fleetmap_core::mission::wpl::write_wpl(Some(&home), items)
    };
    std::fs::write(&file, text).unwrap();
    let port = free_udp_port();
    let sim_log = dir.path().join("sim.log");
    let _sim = start_sim(spec, port, &sim_log);
    // No pause: the vehicle has only just powered up.
    let (code, out, err) = fly(port, &file);
    let context = || {
        format!(
            "exit {code}\n--- stdout\n{out}\n--- stderr\n{err}\n--- simulator log\n{}",
            std::fs::read_to_string(&sim_log).unwrap_or_default()
        )
    };
    assert_eq!(code, 0, "{}", context());
    assert!(
        out.contains("verified: the vehicle holds the same mission"),
        "{}",
        context()
    );
    let n = items.len();
    let mut last_reached = 0;
    for i in 1..=n {
        let needle = format!("item {i}/{n} reached");
        let pos = out
            .find(&needle)
            .unwrap_or_else(|| panic!("no {needle:?}\n{}", context()));
        last_reached = last_reached.max(pos);
    }
    assert!(
        out.contains(&format!("{n}/{n} navigation items")),
        "{}",
        context()
    );
    let done = out.find("every mission item flown").expect("mission done");
    let down = out
        .find(end)
        .unwrap_or_else(|| panic!("no {end:?}\n{}", context()));
    assert!(last_reached < done && done < down, "{}", context());
}

/// Take off to 5 m, a 17 m × 18 m triangle at 5 m.
fn copter_mission(takeoff_at: Option<(f64, f64)>) -> Vec<MissionItem> {
    let takeoff = match takeoff_at {
        Some((lat, lon)) => MissionItem::at(
            fleetmap_core::mission::item::cmd::NAV_TAKEOFF,
            lat,
            lon,
            5.0,
        ),
        None => MissionItem::takeoff(5.0),
    };
    let (a, b, c) = (
        at(HOME, 17.0, 0.0),
        at(HOME, 17.0, 18.0),
        at(HOME, 0.0, 18.0),
    );
    vec![
        takeoff,
        MissionItem::waypoint(a.0, a.1, 5.0),
        MissionItem::waypoint(b.0, b.1, 5.0),
        MissionItem::waypoint(c.0, c.1, 5.0),
    ]
}

#[test]
fn ardupilot_copter_flies_a_waypoints_file() {
    fly_and_check(
        "1xcopter:ardupilot",
        "triangle.waypoints",
        &copter_mission(None),
        "landed and disarmed",
    );
}

#[test]
fn px4_copter_flies_a_plan_file() {
    // QGroundControl writes a PX4 take-off item at the vehicle's position.
    fly_and_check(
        "1xcopter:px4",
        "triangle.plan",
        &copter_mission(Some(HOME)),
        "landed and disarmed",
    );
}

#[test]
fn ardupilot_rover_drives_a_waypoints_file() {
    let (a, b) = (at(HOME, 12.0, 0.0), at(HOME, 12.0, 12.0));
    let items = vec![
        MissionItem::waypoint(a.0, a.1, 0.0),
        MissionItem::waypoint(b.0, b.1, 0.0),
    ];
    fly_and_check(
        "1xrover:ardupilot",
        "square.waypoints",
        &items,
        "back at home",
    );
}

/// A file as Mission Planner and ArduPilot's own test missions write them, in
/// `dir`: tabs and spaces mixed, numbered 0, 1, 2, 4, 12 (ArduCopter's weathervane mission has
/// that gap), and an RTL line in frame 3 carrying the last waypoint's position, which
/// ArduCopter stores as frame 0 without a position (`AP_Mission::stored_in_location`). Four
/// items behind the home line.
fn mission_planner_file(dir: &Path) -> std::path::PathBuf {
    let file = dir.join("weathervane-like.txt");
    let (a, b) = (at(HOME, 15.0, 0.0), at(HOME, 15.0, 15.0));
    let text = format!(
        "QGC WPL 110\n\
         0\t1\t0\t16\t0\t0\t0\t0\t{h0:.8}\t{h1:.8}\t0\t1\n\
         1\t0\t3\t22\t0.0 0.0 0.0 0.0\t0\t0\t6.000000\t1\n\
         2\t0\t3\t16\t0\t0\t0\t0\t{a0:.8}\t{a1:.8}\t6\t1\n\
         4 0 3 16 0 0 0 0 {b0:.8} {b1:.8} 6 1\n\
         12\t0\t3\t20\t0\t0\t0\t0\t{b0:.8}\t{b1:.8}\t6\t1\n",
        h0 = HOME.0,
        h1 = HOME.1,
        a0 = a.0,
        a1 = a.1,
        b0 = b.0,
        b1 = b.1,
    );
    std::fs::write(&file, text).unwrap();
    file
}

/// `mission fly` renumbers [`mission_planner_file`] with a warning, verifies the read-back by
/// ArduPilot's storage rules and flies it home.
#[test]
fn ardupilot_copter_flies_a_mission_planner_file_with_gaps_and_a_frame_3_rtl() {
    let dir = tempfile::tempdir().unwrap();
    let file = mission_planner_file(dir.path());
    let port = free_udp_port();
    let sim_log = dir.path().join("sim.log");
    let _sim = start_sim("1xcopter:ardupilot", port, &sim_log);
    let (code, out, err) = fly(port, &file);
    let context = format!("exit {code}\n--- stdout\n{out}\n--- stderr\n{err}");
    assert_eq!(code, 0, "{context}");
    assert!(
        err.contains("items renumbered in file order: line 5 is numbered 4, read as item 3"),
        "{context}"
    );
    assert!(
        out.contains("verified: the vehicle holds the same mission"),
        "{context}"
    );
    assert!(out.contains("every mission item flown"), "{context}");
    assert!(out.contains("landed and disarmed"), "{context}");
}

/// `fleetmap mission upload --verify` (waiting up to 60 s for the vehicle), killed after 120 s.
fn upload_verify(port: u16, file: &Path) -> (i32, String, String) {
    mission_cmd(
        "upload",
        port,
        &["--wait", "60", "--verify"],
        file,
        Duration::from_secs(120),
    )
}

/// `mission upload --verify`: [`mission_planner_file`], whose RTL line ArduCopter
/// stores as frame 0 without a position, is uploaded, read back and judged by ArduPilot's
/// storage rules: it verifies.
#[test]
fn ardupilot_copter_upload_verify_accepts_a_frame_3_rtl() {
    let dir = tempfile::tempdir().unwrap();
    let file = mission_planner_file(dir.path());
    let port = free_udp_port();
    let sim_log = dir.path().join("sim.log");
    let _sim = start_sim("1xcopter:ardupilot", port, &sim_log);
    let (code, out, err) = upload_verify(port, &file);
    let context = format!("exit {code}\n--- stdout\n{out}\n--- stderr\n{err}");
    assert_eq!(code, 0, "{context}");
    assert!(
        out.contains("uploaded 4 mission item(s) to vehicle 1"),
        "{context}"
    );
    assert!(
        out.contains("verified: the vehicle holds the same mission"),
        "{context}"
    );
}

/// `mission upload --verify` on PX4: a `.plan` shaped like PX4's own
/// `MC_mission_box.plan` (integration tests), whose take-off carries QGroundControl's pitch 15
/// in param1, with a waypoint yawing to −90°. PX4 keeps neither a take-off pitch nor a negative
/// yaw (`format_mavlink_mission_item` returns param1 0 and 270°); the simulated PX4 stores
/// items as PX4 does, and the read-back verifies by PX4's rules.
#[test]
fn px4_copter_upload_verify_accepts_what_px4_keeps_of_a_qgc_plan() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("box.plan");
    let mut items = copter_mission(Some(HOME));
    items[0].param1 = 15.0;
    items[1].param4 = -90.0;
    std::fs::write(
        &file,
        write_plan(&Plan {
            mission: items,
            home: Some((HOME.0, HOME.1, 0.0)),
            firmware_type: 12,
            ..Plan::default()
        }),
    )
    .unwrap();
    let port = free_udp_port();
    let sim_log = dir.path().join("sim.log");
    let _sim = start_sim("1xcopter:px4", port, &sim_log);
    let (code, out, err) = upload_verify(port, &file);
    let context = format!("exit {code}\n--- stdout\n{out}\n--- stderr\n{err}");
    assert_eq!(code, 0, "{context}");
    assert!(
        out.contains("verified: the vehicle holds the same mission"),
        "{context}"
    );
}
