//! A child process a test started, killed when the test ends however it ends.

use std::path::Path;
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

/// A child process, killed (SIGKILL) and reaped when dropped if it is still running: a failed
/// assertion unwinds through the guard and leaves no simulator or GCS behind. A child that
/// starts children of its own must end them when it is killed (the pseudo-terminal's
/// `script` does: the program inside gets SIGHUP when the terminal closes).
///
/// The child stays in the test's process group, so that Ctrl-C on `cargo test` reaches it
/// too (a test binary that is interrupted or killed runs no destructor).
#[derive(Debug)]
pub struct Guard(Child);

impl Guard {
    /// Start `cmd` under a guard; panics naming the program if it cannot start.
    pub fn spawn(cmd: &mut Command) -> Guard {
        match cmd.spawn() {
            Ok(child) => Guard(child),
            Err(e) => panic!("cannot start {:?}: {e}", cmd.get_program()),
        }
    }

    /// Guard a child started elsewhere.
    pub fn new(child: Child) -> Guard {
        Guard(child)
    }

    /// Send signal `name` (`TERM`, `INT`: what `kill -NAME` takes) to the child, as an
    /// operator or a service manager would; panics if `kill` fails (the child is gone).
    pub fn signal(&self, name: &str) {
        let status = Command::new("kill")
            .args([format!("-{name}"), self.0.id().to_string()])
            .status()
            .expect("run kill");
        assert!(status.success(), "kill -{name} {} failed", self.0.id());
    }

    /// Wait for the child to exit, at most `limit` (a hang guard, not a speed requirement):
    /// past it the child is killed and the test fails with `what()` (a log, say).
    pub fn wait_for(&mut self, limit: Duration, what: impl FnOnce() -> String) -> ExitStatus {
        let t0 = Instant::now();
        loop {
            if let Some(s) = self.0.try_wait().expect("wait for the child") {
                return s;
            }
            if t0.elapsed() > limit {
                let _ = self.0.kill();
                let _ = self.0.wait();
                panic!("the child did not finish within {limit:?}\n{}", what());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The child's exit code (-1 if a signal ended it), waiting at most `limit`: past it the
    /// test fails showing the file `log` (where [`crate::Bin::logged`] sent its output).
    pub fn code_within(&mut self, limit: Duration, log: &Path) -> i32 {
        self.wait_for(limit, || {
            format!("log:\n{}", std::fs::read_to_string(log).unwrap_or_default())
        })
        .code()
        .unwrap_or(-1)
    }
}

impl std::ops::Deref for Guard {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Guard {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl Drop for Guard {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}
