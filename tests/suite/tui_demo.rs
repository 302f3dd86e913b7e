//! `fleetmap demo` in a pseudo-terminal: the real binary with the embedded
//! simulator and the terminal UI, driven by keys as an operator would — START (`s`, `y`),
//! the drone lands for a battery swap, "battery swapped — resume" (`b`, `y`) after the
//! simulated crew has swapped it, and the run goes on to the end; then quit (`q`, `y`).
//!
//! The test reads the run directory's saved state to know when to press the keys (the screen
//! is a stream of escape sequences), and checks the screen for the status words.

use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::{MappingState, RobotStatus};
use std::path::Path;
use std::time::{Duration, Instant};

use crate::common;
use common::WORLD;
use common::pty;

fn state(dir: &Path) -> Option<MappingState> {
    RunDir::open(dir).ok()?.load_state().ok()?
}

#[test]
fn demo_in_a_pty_start_battery_swap_resume_done() {
    if !pty::have_script() {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let world = tmp.path().join("strip.toml");
    std::fs::write(&world, WORLD).unwrap();
    let run = tmp.path().join("run");
    let log = tmp.path().join("ui.log");
    let cmd = format!(
        "{} --log-file {} demo --run-dir {} --drones 1 --world {} --battery-minutes 4 \
         --speedup 15 --manual",
        common::fleetmap().path().display(),
        log.display(),
        run.display(),
        world.display()
    );
    let (mut child, mut keys, mut term) = pty::spawn(&cmd, 120, 40, &log);
    let mut key = |k: &[u8]| keys.press(k);
    let deadline = Instant::now() + Duration::from_secs(400);
    // The UI is up, the mission waits for START.
    term.wait_screen("NOT STARTED", deadline);
    key(b"s");
    term.wait_screen("START mission", deadline);
    key(b"y");
    term.wait_screen("RUNNING", deadline);
    // Fly until the battery swap, resume it (as often as it takes), until done.
    let mut swaps_resumed = 0;
    loop {
        assert!(
            Instant::now() < deadline,
            "the run did not finish; {}",
            term.dump()
        );
        term.pump(Duration::from_millis(300));
        let Some(s) = state(&run) else { continue };
        if s.is_finished() {
            break;
        }
        let waiting = s.robots[0].status == RobotStatus::AwaitingSwap;
        // The simulated crew swaps 30 s (simulated) after landing: wait for the fresh battery.
        let fresh =
            s.robots[0].reboots_at_landing.is_some() && term.text().contains("BATTERY SWAP");
        if waiting && fresh {
            std::thread::sleep(Duration::from_secs(3));
            key(b"b");
            term.wait_screen("BATTERY SWAPPED", Instant::now() + Duration::from_secs(20));
            key(b"y");
            // The state says so once the runner took it.
            let t0 = Instant::now();
            while state(&run).is_some_and(|s| s.robots[0].status == RobotStatus::AwaitingSwap) {
                assert!(
                    t0.elapsed() < Duration::from_secs(30),
                    "the swap was not taken; {}",
                    term.dump()
                );
                term.pump(Duration::from_millis(200));
            }
            swaps_resumed += 1;
        }
    }
    term.wait_screen("DONE", deadline);
    key(b"q");
    term.wait_screen("QUIT fleetmap?", Instant::now() + Duration::from_secs(30));
    key(b"y");
    let status = pty::wait_exit(&mut child, &mut term, Duration::from_secs(30));
    assert!(status.success(), "{}", term.dump());
    assert!(
        String::from_utf8_lossy(&term.raw).contains("\x1b[?1049l"),
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
