//! Where a run lives: the default run-directory name, the world a run was started with, the
//! connections it remembers.

use crate::link::ConnSpec;
use crate::store::RunDir;
use crate::world::World;
use anyhow::Context as _;
use std::path::{Path, PathBuf};

pub(crate) use crate::clock::unix_ms;

/// `runs/NAME-YYYYMMDD-HHMMSS` (UTC), with the mission name made safe for a path.
pub(crate) fn default_run_dir(name: &str) -> PathBuf {
    let secs = unix_ms() / 1000;
    // civil date from days since the epoch (Howard Hinnant's algorithm)
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    let safe: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    PathBuf::from("runs").join(format!(
        "{safe}-{y:04}{m:02}{d:02}-{:02}{:02}{:02}",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    ))
}

/// The world a run was started with (`run.json` extra `world`), or `override_`.
pub fn run_world(run: &RunDir, override_: Option<&Path>) -> anyhow::Result<Option<World>> {
    let path = match override_ {
        Some(p) => Some(p.to_path_buf()),
        None => run
            .meta()
            .extra
            .get("world")
            .and_then(|v| v.as_str())
            .map(PathBuf::from),
    };
    // A relative path in run.json is relative to the run directory (the demo keeps its
    // world there).
    let path = path.map(|p| {
        if override_.is_none() && p.is_relative() {
            run.path().join(p)
        } else {
            p
        }
    });
    match path {
        Some(p) => Ok(Some(
            crate::files::load_world(&p).with_context(|| format!("world {}", p.display()))?,
        )),
        None => Ok(None),
    }
}

/// The connections `run.json` remembers, parsed.
pub(crate) fn remembered_connections(run: &RunDir) -> anyhow::Result<Vec<ConnSpec>> {
    run.meta()
        .connections
        .iter()
        .map(|c| {
            c.parse::<ConnSpec>()
                .map_err(|e| anyhow::anyhow!("{c}: {e}"))
        })
        .collect()
}

/// The connections as one label ("LIVE udpin:…, tcp:…").
pub(crate) fn connections_label(conns: &[ConnSpec]) -> String {
    conns
        .iter()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}
