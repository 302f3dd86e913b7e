//! The fleet check before take-off, end to end: the real `fleetmap sim` (its simulated
//! ArduPilot 4.7 / PX4 1.16 autopilots answering PARAM_REQUEST_READ with their defaults, one
//! mistake per vehicle set with `--param`, `--sysid` or `--no-camera`) and the real
//! `fleetmap check --connect --json`, each finding checked by its kind, severity and vehicle;
//! then `fleetmap run` refusing to start on a blocker and starting with `--ignore-check`.

use fleetmap_test_kit::free_udp_port;
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::common;
use fleetmap_test_kit::Guard;

/// The runway field-test mission with drones 1..=n.
fn mission(n: u8) -> tempfile::NamedTempFile {
    let text = fleetmap::kinds::runway::demo::RUNWAY_MISSION;
    let at = 1 + text
        .find("\n[runway]")
        .expect("the mission's [runway] table");
    let mut extra = String::new();
    for k in 2..=n {
        extra.push_str(&format!("[[vehicles]]\nsysid = {k}\nrole = \"drone\"\n\n"));
    }
    let text = format!("{}{extra}{}", &text[..at], &text[at..]);
    let mut f = tempfile::NamedTempFile::new().unwrap();
    std::io::Write::write_all(&mut f, text.as_bytes()).unwrap();
    f
}

/// `fleetmap sim` with `vehicles` and `extra` arguments, sending to a free UDP port: the
/// process and the port.
fn sim(vehicles: &str, extra: &[&str]) -> (Guard, u16) {
    let port = free_udp_port();
    let connect = format!("udpout:127.0.0.1:{port}");
    let mut args = vec![
        "sim",
        "--vehicles",
        vehicles,
        "--world",
        "assets/worlds/runway.toml",
        "--connect",
        &connect,
    ];
    args.extend(extra);
    (common::fleetmap().quiet(&args), port)
}

/// `fleetmap check --connect --json` for `drones` drones: (exit success, findings as
/// (severity, check, sysid, fix)).
fn check(port: u16, drones: u8) -> (bool, Vec<(String, String, u64, String)>) {
    let m = mission(drones);
    let out = common::fleetmap()
        .command()
        .args([
            "check",
            "--json",
            "--wait",
            "20",
            "--connect",
            &format!("udpin:127.0.0.1:{port}"),
        ])
        .arg(m.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let v: Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("{e}: {text}\n{}", String::from_utf8_lossy(&out.stderr)));
    let findings = v
        .as_array()
        .expect("a list of findings")
        .iter()
        .map(|f| {
            (
                f["severity"].as_str().unwrap().to_string(),
                f["check"].as_str().unwrap().to_string(),
                f["sysid"].as_u64().unwrap(),
                f["fix"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    (out.status.success(), findings)
}

fn has(f: &[(String, String, u64, String)], severity: &str, check: &str, sysid: u64) -> bool {
    f.iter()
        .any(|(s, c, id, _)| s == severity && c == check && *id == sysid)
}

fn blockers(f: &[(String, String, u64, String)]) -> usize {
    f.iter().filter(|x| x.0 == "blocker").count()
}

#[test]
fn the_simulators_defaults_pass_with_the_warnings_of_arducopter_sitl() {
    let (_sim, port) = sim("2xcopter:ardupilot", &[]);
    let (ok, f) = check(port, 2);
    assert!(ok, "{f:?}");
    assert_eq!(blockers(&f), 0, "{f:?}");
    for id in [1, 2] {
        assert!(has(&f, "warning", "gcs-failsafe", id), "{f:?}");
        assert!(has(&f, "warning", "battery-failsafe", id), "{f:?}");
        assert!(has(&f, "warning", "geofence", id), "{f:?}");
    }
    // both return at 15 m to homes 3 m apart: the second is told to return higher
    assert!(
        f.iter()
            .any(|x| x.1 == "rtl-altitude" && x.2 == 2 && x.3 == "param set RTL_ALT 2000"),
        "{f:?}"
    );
    assert!(!has(&f, "warning", "rtl-altitude", 1), "{f:?}");
}

#[test]
fn failsafes_set_and_altitudes_apart_leave_nothing_to_say() {
    let mut args = Vec::new();
    for k in 1..=2 {
        for p in ["FS_GCS_ENABLE=1", "BATT_FS_LOW_ACT=2", "FENCE_ENABLE=1"] {
            args.push(format!("--param={k}:{p}"));
        }
    }
    args.push("--param=2:RTL_ALT=2500".into());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (_sim, port) = sim("2xcopter:ardupilot", &args);
    let (ok, f) = check(port, 2);
    assert!(ok && f.is_empty(), "{f:?}");
}

#[test]
fn a_gcs_id_enforced_to_another_station_is_a_blocker() {
    // vehicle 1 obeys only ground station 250; vehicle 2 takes 250 for its GCS, not enforced
    let (_sim, port) = sim(
        "2xcopter:ardupilot",
        &[
            "--param=1:MAV_GCS_SYSID=250",
            "--param=1:MAV_OPTIONS=1",
            "--param=2:MAV_GCS_SYSID=250",
        ],
    );
    let (ok, f) = check(port, 2);
    assert!(!ok);
    assert!(has(&f, "blocker", "gcs-id", 1), "{f:?}");
    assert!(has(&f, "warning", "gcs-id", 2), "{f:?}");
    assert_eq!(blockers(&f), 1, "{f:?}");
}

#[test]
fn two_autopilots_on_one_system_id_are_a_blocker() {
    let (_sim, port) = sim("2xcopter:ardupilot", &["--sysid", "2=1"]);
    let (ok, f) = check(port, 1);
    assert!(!ok);
    assert!(has(&f, "blocker", "duplicate-sysid", 1), "{f:?}");
}

#[test]
fn a_drone_without_a_camera_is_a_blocker() {
    let (_sim, port) = sim("2xcopter:ardupilot", &["--no-camera", "2"]);
    let (ok, f) = check(port, 2);
    assert!(!ok);
    assert!(has(&f, "blocker", "camera", 2), "{f:?}");
    assert_eq!(blockers(&f), 1, "{f:?}");
}

#[test]
fn px4_settings_are_read_byte_wise_by_their_names() {
    // PX4 1.16's defaults: battery failsafe only warns, both return at 60 m; vehicle 2's
    // geofence set to warn only
    let (_sim, port) = sim("2xcopter:px4", &["--param=2:GF_ACTION=1"]);
    let (ok, f) = check(port, 2);
    assert!(ok, "{f:?}");
    assert!(has(&f, "warning", "battery-failsafe", 1), "{f:?}");
    assert!(has(&f, "warning", "geofence", 2), "{f:?}");
    assert!(!has(&f, "warning", "geofence", 1), "{f:?}");
    assert!(
        f.iter()
            .any(|x| x.1 == "rtl-altitude" && x.2 == 2 && x.3 == "param set RTL_RETURN_ALT 65"),
        "{f:?}"
    );
    // NAV_DLL_ACT is 2 in PX4's SITL airframes, as simulated
    assert!(
        !f.iter().any(|x| x.1 == "gcs-failsafe" || x.1 == "unread"),
        "{f:?}"
    );
}

/// Start `fleetmap run --headless` on `port` with `extra` arguments and read its output
/// until `until` appears in a line or it exits: (lines, exit success if it exited).
fn run_until(port: u16, extra: &[&str], until: &str) -> (Vec<String>, Option<bool>) {
    let m = mission(2);
    let dir = tempfile::tempdir().unwrap();
    let mut child = Guard::spawn(
        common::fleetmap()
            .command()
            .arg("run")
            .arg(m.path())
            .args([
                "--headless",
                "--wait",
                "20",
                "--connect",
                &format!("udpin:127.0.0.1:{port}"),
                "--run-dir",
            ])
            .arg(dir.path().join("run"))
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let (tx, rx) = std::sync::mpsc::channel();
    for pipe in [
        Box::new(child.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
        Box::new(child.stderr.take().unwrap()),
    ] {
        let tx = tx.clone();
        std::thread::spawn(move || {
            for l in BufReader::new(pipe).lines().map_while(Result::ok) {
                let _ = tx.send(l);
            }
        });
    }
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut lines = Vec::new();
    while Instant::now() < deadline {
        if let Ok(l) = rx.recv_timeout(Duration::from_millis(200)) {
            let hit = l.contains(until);
            lines.push(l);
            if hit {
                return (lines, None);
            }
        }
        if let Ok(Some(status)) = child.try_wait() {
            while let Ok(l) = rx.recv_timeout(Duration::from_millis(200)) {
                lines.push(l);
            }
            return (lines, Some(status.success()));
        }
    }
    panic!("neither {until:?} nor an exit within 60 s: {lines:#?}");
}

#[test]
fn a_run_does_not_start_on_a_blocker_unless_told_to_ignore_the_check() {
    let (_sim, port) = sim("2xcopter:ardupilot", &["--no-camera", "1"]);
    let (lines, exit) = run_until(port, &[], "never printed");
    assert_eq!(exit, Some(false), "{lines:#?}");
    let all = lines.join("\n");
    assert!(
        all.contains("REFUSED: the fleet check found 1 blocker"),
        "{all}"
    );
    assert!(all.contains("vehicle 1 camera"), "{all}");
    drop(_sim);
    let (_sim, port) = sim("2xcopter:ardupilot", &["--no-camera", "1"]);
    let (lines, _) = run_until(port, &["--ignore-check"], "starting anyway");
    assert!(
        lines
            .iter()
            .any(|l| l.contains("blocker(s) ignored (--ignore-check)")),
        "{lines:#?}"
    );
}

#[test]
fn the_tui_shows_the_findings_and_its_start_checks_again() {
    use crate::common::pty;
    if !pty::have_script() {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    }
    let (_sim, port) = sim("2xcopter:ardupilot", &["--no-camera", "2"]);
    let m = mission(2);
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("ui.log");
    let cmd = format!(
        "{} --log-file {} tui --connect udpin:127.0.0.1:{port} --mission {}",
        common::fleetmap().path().display(),
        log.display(),
        m.path().display()
    );
    // Wide enough for the log pane beside the map and the fleet.
    let (_ui, mut keys, mut term) = pty::spawn(&cmd, 250, 70, &log);
    let deadline = Instant::now() + Duration::from_secs(90);
    // The blocker does not keep the UI shut: its findings open the log, START waits.
    term.wait_screen("NOT STARTED", deadline);
    term.wait_screen("fleet check: 1 blocker", deadline);
    term.wait_screen("vehicle 2 camera", deadline);
    // START checks the fleet again and refuses while the camera is missing.
    keys.press(b"s");
    term.wait_screen("START mission", deadline);
    keys.press(b"y");
    term.wait_screen("not started: fleet check: 1 blocker", deadline);
    term.pump(Duration::from_secs(1));
    assert!(term.text().contains("NOT STARTED"), "{}", term.dump());
    assert!(!term.text().contains("RUNNING"), "{}", term.dump());
    keys.press(b"q");
    keys.press(b"y");
}
