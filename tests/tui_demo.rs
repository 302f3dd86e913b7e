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

mod common;
use common::WORLD;

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
    // The screen as a terminal shows it: ratatui redraws only the cells that changed, so a
    // word on the screen need not appear whole in the byte stream.
    let mut term = Term {
        raw: Vec::new(),
        screen: vt100::Parser::new(40, 120, 0),
        rx,
        log: log.clone(),
    };
    let mut key = |k: &[u8]| {
        stdin.write_all(k).unwrap();
        stdin.flush().unwrap();
    };
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
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "did not quit; {}",
            term.dump()
        );
        term.pump(Duration::from_millis(100));
    };
    term.pump(Duration::from_millis(200));
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

/// What the pseudo-terminal shows: the raw stream and a terminal emulator fed with it.
struct Term {
    raw: Vec<u8>,
    screen: vt100::Parser,
    rx: mpsc::Receiver<Vec<u8>>,
    log: std::path::PathBuf,
}

impl Term {
    /// Take what arrives within `d`.
    fn pump(&mut self, d: Duration) {
        if let Ok(c) = self.rx.recv_timeout(d) {
            self.take(c);
        }
        while let Ok(c) = self.rx.try_recv() {
            self.take(c);
        }
    }

    fn take(&mut self, c: Vec<u8>) {
        self.screen.process(&c);
        self.raw.extend(c);
    }

    /// The text on the screen now.
    fn text(&self) -> String {
        self.screen.screen().contents()
    }

    /// Wait until `needle` is on the screen.
    fn wait_screen(&mut self, needle: &str, deadline: Instant) {
        while !self.text().contains(needle) {
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {needle:?}; {}",
                self.dump()
            );
            self.pump(Duration::from_millis(200));
        }
    }

    fn dump(&self) -> String {
        format!(
            "the screen:\n{}\nthe log:\n{}",
            self.text(),
            std::fs::read_to_string(&self.log).unwrap_or_default()
        )
    }
}
