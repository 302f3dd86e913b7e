//! `fleetmap demo` in a pseudo-terminal (issue 9): the real binary with the embedded
//! simulator and the terminal UI, driven by keys as an operator would — START (`s`, `y`),
//! the drone lands for a battery swap, "battery swapped — resume" (`b`, `y`) after the
//! simulated crew has swapped it, and the run goes on to the end; then quit (`q`, `y`).
//!
//! The test reads the run directory's saved state to know when to press the keys (the screen
//! is a stream of escape sequences), and checks the screen for the status words.

use fleetmap::explore::mapping::{MappingState, RobotStatus};
use fleetmap::store::RunDir;
use std::io::{Read, Write};
use std::path::Path;
use std::process::Stdio;
use std::sync::mpsc;
use std::time::{Duration, Instant};

const WORLD: &str = r#"
name = "strip"
description = "A 20 m x 12 m asphalt strip aligned with the grid (test world)"
background = "grass"
ground_alt_amsl_m = 600.0

[[region]]
name = "strip"
surface = "asphalt"
rectangle = { center = [37.196800, -80.578100], length_m = 20.0, width_m = 12.0, heading_deg = 90.0 }
markings = false

[homes]
reference = [37.196800, -80.578100]
first_north_m = -12.0
first_east_m = 0.0
step_north_m = 0.0
step_east_m = 3.0
"#;

fn bin() -> String {
    std::env::var("FLEETMAP_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_fleetmap").to_string())
}

fn state(dir: &Path) -> Option<MappingState> {
    RunDir::open(dir).ok()?.load_state().ok()?
}

#[test]
fn demo_in_a_pty_start_battery_swap_resume_done() {
    if std::process::Command::new("script")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let world = tmp.path().join("strip.toml");
    std::fs::write(&world, WORLD).unwrap();
    let run = tmp.path().join("run");
    let log = tmp.path().join("ui.log");
    let cmd = format!(
        "stty cols 120 rows 40 && exec {} --log-file {} demo --run-dir {} --drones 1 --world {} \
         --battery-minutes 4 --speedup 15 --manual",
        bin(),
        log.display(),
        run.display(),
        world.display()
    );
    let mut child = std::process::Command::new("script")
        .args(["-qfec", &cmd, "/dev/null"])
        .env("TERM", "xterm-256color")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("script runs");
    let mut stdin = child.stdin.take().unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel::<Vec<u8>>();
    std::thread::spawn(move || {
        let mut buf = [0u8; 8192];
        while let Ok(n) = stdout.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let mut seen: Vec<u8> = Vec::new();
    let mut pump = |seen: &mut Vec<u8>, d: Duration| {
        if let Ok(c) = rx.recv_timeout(d) {
            seen.extend(c);
        }
        while let Ok(c) = rx.try_recv() {
            seen.extend(c);
        }
    };
    let dump = |seen: &[u8]| {
        let all = String::from_utf8_lossy(seen);
        let tail: String = all
            .chars()
            .rev()
            .take(2000)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        format!(
            "screen ends with {tail:?}\nlog:\n{}",
            std::fs::read_to_string(&log).unwrap_or_default()
        )
    };
    let mut key = |k: &[u8]| {
        stdin.write_all(k).unwrap();
        stdin.flush().unwrap();
    };
    let deadline = Instant::now() + Duration::from_secs(400);
    let wait_screen =
        |seen: &mut Vec<u8>, needle: &str, pump: &mut dyn FnMut(&mut Vec<u8>, Duration)| {
            while !String::from_utf8_lossy(seen).contains(needle) {
                assert!(
                    Instant::now() < deadline,
                    "timed out waiting for {needle:?}; {}",
                    dump(seen)
                );
                pump(seen, Duration::from_millis(200));
            }
        };
    // The UI is up, the mission waits for START.
    wait_screen(&mut seen, "NOT STARTED", &mut pump);
    key(b"s");
    wait_screen(&mut seen, "START mission", &mut pump);
    key(b"y");
    wait_screen(&mut seen, "RUNNING", &mut pump);
    // Fly until the battery swap, resume it (as often as it takes), until done.
    let mut swaps_resumed = 0;
    loop {
        assert!(
            Instant::now() < deadline,
            "the run did not finish; {}",
            dump(&seen)
        );
        pump(&mut seen, Duration::from_millis(300));
        let Some(s) = state(&run) else { continue };
        if s.is_finished() {
            break;
        }
        let waiting = s.robots[0].status == RobotStatus::AwaitingSwap;
        // The simulated crew swaps 30 s (simulated) after landing: wait for the fresh battery.
        let fresh = s.robots[0].reboots_at_landing.is_some()
            && String::from_utf8_lossy(&seen).contains("BATTERY SWAP");
        if waiting && fresh {
            std::thread::sleep(Duration::from_secs(3));
            let mark = seen.len();
            key(b"b");
            let t0 = Instant::now();
            while !String::from_utf8_lossy(&seen[mark..]).contains("BATTERY SWAPPED") {
                assert!(
                    t0.elapsed() < Duration::from_secs(20),
                    "no confirmation dialog; {}",
                    dump(&seen)
                );
                pump(&mut seen, Duration::from_millis(100));
            }
            key(b"y");
            // The state says so once the runner took it.
            let t0 = Instant::now();
            while state(&run).is_some_and(|s| s.robots[0].status == RobotStatus::AwaitingSwap) {
                assert!(
                    t0.elapsed() < Duration::from_secs(30),
                    "the swap was not taken; {}",
                    dump(&seen)
                );
                pump(&mut seen, Duration::from_millis(200));
            }
            swaps_resumed += 1;
        }
    }
    wait_screen(&mut seen, "DONE", &mut pump);
    key(b"q");
    wait_screen(&mut seen, "QUIT fleetmap?", &mut pump);
    key(b"y");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "did not quit; {}",
            dump(&seen)
        );
        pump(&mut seen, Duration::from_millis(100));
    };
    assert!(status.success(), "{}", dump(&seen));
    assert!(
        String::from_utf8_lossy(&seen).contains("\x1b[?1049l"),
        "left the alternate screen"
    );
    let s = state(&run).unwrap();
    assert!(s.is_finished());
    assert!(
        swaps_resumed >= 1 && s.robots[0].battery_swaps >= 1,
        "no battery swap"
    );
    assert_eq!(
        s.book.positive_cells().len(),
        15,
        "{:?}",
        s.book.positive_cells()
    );
    // the exports were written when the run finished
    assert!(run.join("exports/map.png").exists());
}
