//! The real binary in a pseudo-terminal (util-linux `script`), its screen read through a
//! terminal emulator (vt100): shared by the TUI end-to-end tests.

use fleetmap_test_kit::Guard;
use std::io::{Read, Write};
use std::process::{ChildStdin, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Whether util-linux `script` is there (the tests skip without it).
pub fn have_script() -> bool {
    std::process::Command::new("script")
        .arg("--version")
        .output()
        .is_ok()
}

/// `shell` (after `stty cols COLS rows ROWS`) in a pseudo-terminal of `cols` × `rows`: the
/// `script` process (killed when dropped: a failed test leaves no UI running, as the program
/// in the pseudo-terminal gets SIGHUP when `script` goes), its stdin (the keyboard) and the
/// screen. `log` is the UI's log file (shown when a wait fails).
pub fn spawn(shell: &str, cols: u16, rows: u16, log: &std::path::Path) -> (Guard, Keys, Term) {
    let cmd = format!("stty cols {cols} rows {rows} && exec {shell}");
    let mut child = Guard::spawn(
        std::process::Command::new("script")
            .args(["-qfec", &cmd, "/dev/null"])
            .env("TERM", "xterm-256color")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let stdin = child.stdin.take().expect("stdin");
    let mut stdout = child.stdout.take().expect("stdout");
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
    let term = Term {
        raw: Vec::new(),
        screen: vt100::Parser::new(rows, cols, 0),
        rx,
        log: log.to_path_buf(),
    };
    (child, Keys(stdin), term)
}

/// The keyboard of the pseudo-terminal.
pub struct Keys(ChildStdin);

impl Keys {
    /// Type `k`.
    pub fn press(&mut self, k: &[u8]) {
        self.0.write_all(k).expect("key");
        self.0.flush().expect("flush");
    }
}

/// Wait for the child to exit (pumping the screen), at most `limit`.
pub fn wait_exit(child: &mut Guard, term: &mut Term, limit: Duration) -> std::process::ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(s) = child.try_wait().expect("try_wait") {
            term.pump(Duration::from_millis(200));
            return s;
        }
        assert!(t0.elapsed() < limit, "did not quit; {}", term.dump());
        term.pump(Duration::from_millis(100));
    }
}

/// What the pseudo-terminal shows: the raw stream and a terminal emulator fed with it.
pub struct Term {
    /// Every byte received.
    pub raw: Vec<u8>,
    screen: vt100::Parser,
    rx: mpsc::Receiver<Vec<u8>>,
    log: std::path::PathBuf,
}

impl Term {
    /// Take what arrives within `d`.
    pub fn pump(&mut self, d: Duration) {
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
    pub fn text(&self) -> String {
        self.screen.screen().contents()
    }

    /// Wait until `needle` is on the screen.
    pub fn wait_screen(&mut self, needle: &str, deadline: Instant) {
        self.wait_until(needle, deadline, |t| t.text().contains(needle));
    }

    /// Wait until `needle` has arrived in the raw stream (an escape sequence, say).
    pub fn wait_raw(&mut self, needle: &[u8], deadline: Instant) {
        let what = String::from_utf8_lossy(needle).into_owned();
        self.wait_until(&what, deadline, |t| {
            t.raw.windows(needle.len()).any(|w| w == needle)
        });
    }

    /// Pump the screen until `done`; past `deadline`, fail naming `what`.
    fn wait_until(&mut self, what: &str, deadline: Instant, done: impl Fn(&Term) -> bool) {
        while !done(self) {
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what:?}; {}",
                self.dump()
            );
            self.pump(Duration::from_millis(200));
        }
    }

    /// The screen and the UI log, for a failure message.
    pub fn dump(&self) -> String {
        format!(
            "the screen:\n{}\nthe log:\n{}",
            self.text(),
            std::fs::read_to_string(&self.log).unwrap_or_default()
        )
    }
}
