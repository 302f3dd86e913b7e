//! One of the workspace's programs run from a test.
//!
//! Cargo tells a package's integration tests where it built the package's binaries
//! (`CARGO_BIN_EXE_<name>`, at compile time): the test passes that path in
//! ([`Bin::new`], [`Bin::built`]), since the kit is another package and is not told.

use crate::process::Guard;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// A program under test, by its path.
#[derive(Clone, Debug)]
pub struct Bin {
    path: PathBuf,
}

impl Bin {
    /// The program at `path` (for a test, what cargo put in `CARGO_BIN_EXE_<name>`).
    pub fn new(path: impl Into<PathBuf>) -> Bin {
        Bin { path: path.into() }
    }

    /// The program at `built` (what cargo put in `CARGO_BIN_EXE_<name>`), or at the path in the
    /// environment variable `var` when it is set: the same tests then run against a binary
    /// built elsewhere (an installed or release build, as the Python tests' `FLEETMAP_BIN`).
    pub fn built(var: &str, built: &str) -> Bin {
        Bin {
            path: std::env::var_os(var).map_or_else(|| PathBuf::from(built), PathBuf::from),
        }
    }

    /// Where the program is.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A command for the program, to add arguments and redirections to.
    pub fn command(&self) -> Command {
        Command::new(&self.path)
    }

    /// Run the program with `args` to its end, stdin empty, and take what it printed.
    pub fn output(&self, args: &[impl AsRef<OsStr>]) -> Output {
        self.command()
            .args(args)
            .stdin(Stdio::null())
            .output()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", self.path.display()))
    }

    /// [`Bin::output`] of a run that must succeed: the test fails showing its stderr
    /// otherwise.
    pub fn ok(&self, args: &[impl AsRef<OsStr>]) -> Output {
        let out = self.output(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        out
    }

    /// [`Bin::output`] as (exit code, stdout, stderr), with -1 for a program ended by a
    /// signal and the text decoded lossily.
    pub fn run(&self, args: &[impl AsRef<OsStr>]) -> (i32, String, String) {
        let out = self.output(args);
        (
            out.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    }

    /// Start the program with `args` under a [`Guard`], its stdout and stderr discarded (a
    /// `fleetmap sim` the test talks to over UDP, say).
    pub fn quiet(&self, args: &[impl AsRef<OsStr>]) -> Guard {
        Guard::spawn(
            self.command()
                .args(args)
                .stdout(Stdio::null())
                .stderr(Stdio::null()),
        )
    }

    /// Start the program with `args` under a [`Guard`], its stdout and stderr appended to the
    /// file `log` (created if missing: several processes of one test may share it).
    pub fn logged(&self, args: &[impl AsRef<OsStr>], log: &Path) -> Guard {
        let out = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(log)
            .unwrap_or_else(|e| panic!("cannot open the log {}: {e}", log.display()));
        let err = out.try_clone().expect("the log's second handle");
        Guard::spawn(self.command().args(args).stdout(out).stderr(err))
    }
}
