//! One way to start, resume and fly a run, whichever door it comes through: `fleetmap run`
//! and `resume`, `fleetmap tui --mission` and `--resume`, and `fleetmap demo`.
//!
//! A door parses its own options and opens its own fleet (real links, or the demo's
//! simulator: the simulator's start-up stays in the demo), then calls `prepare` with the
//! connected fleet and what to start (`Start`), and flies the run it gets back
//! (`Ready::fly_headless`, or `tui::session::fly` in the UI). What every run directory gets
//! is therefore decided here once: the creation time, the default directory name
//! (`runs/NAME-YYYYMMDD-HHMMSS`), the connections, and the simulated world, which is kept in
//! the run directory as `world.toml` so that `fleetmap report` scores it later wherever the
//! run directory goes.
//!
//! | module | what |
//! |---|---|
//! | this file | the one way to start or resume a run (`prepare`, then `Ready::fly_headless` or the UI's `tui::session::fly`), for `run`, `resume`, `tui --mission` and `demo` |
//! | [`demo`] | (feature `sim`) `fleetmap demo`: what a kind's demo on the embedded simulator supplies (`demo::DemoKind`, in the kind's folder), and the flags every demo shares |
//! | [`sim_fleet`] | (feature `sim`) the embedded simulator and a fleet on it, started together over loopback UDP or in-process links (the demo, the bandit team, tests) |

#[cfg(feature = "sim")]
pub mod demo;
#[cfg(feature = "sim")]
pub mod sim_fleet;

use crate::app::blocking::run_blocking;
use crate::app::error::RunError;
use crate::app::kind::{Outcome, RunKind, RunSettings, write_exports};
use crate::app::preflight::{StartCheck, gate};
use crate::app::run::Progress;
use crate::fleet::FleetHandle;
use crate::store::{RunDir, RunMeta};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The name of the world's copy in a run directory (`run.json` extra `world`).
pub(crate) const WORLD_FILE: &str = "world.toml";

/// A new run: the mission and where its directory goes.
#[derive(Clone, Debug)]
pub(crate) struct NewRun {
    /// The mission definition, parsed from `text`.
    pub def: MissionDef,
    /// The mission file as read (its copy is the run's `mission.toml`).
    pub text: String,
    /// Where the mission was read from, as `run.json` remembers it.
    pub mission_path: String,
    /// The run directory (must not exist or be empty); `None`: [`default_run_dir`].
    pub run_dir: Option<PathBuf>,
    /// The simulated world the vehicles fly over, as TOML (ground truth for the report).
    pub(crate) world_toml: Option<String>,
    /// More of the run's settings for `run.json`'s `extra` (an object; anything else is
    /// ignored), e.g. a demo's simulated sensor.
    pub extra: serde_json::Value,
}

impl NewRun {
    /// A new run of the mission file `path` (read by [`fleetmap_io::files::read_mission`]).
    pub(crate) fn from_file(path: &Path) -> Result<NewRun, RunError> {
        let (text, def) = fleetmap_io::files::read_mission(path)?;
        Ok(NewRun {
            def,
            text,
            mission_path: path.display().to_string(),
            run_dir: None,
            world_toml: None,
            extra: serde_json::Value::Null,
        })
    }

    /// Fly over the world in the file `path` (read and checked by
    /// [`fleetmap_io::files::read_world`]; copied into the run directory).
    pub(crate) fn with_world_file(mut self, path: &Path) -> Result<NewRun, RunError> {
        let (text, _) = fleetmap_io::files::read_world(path)?;
        self.world_toml = Some(text);
        Ok(self)
    }

    /// The run directory and its `run.json` for a run of kind `kind` created at
    /// `created_unix_ms`, connected through `connections`.
    pub(crate) fn plan(
        &self,
        kind: &str,
        connections: &[String],
        created_unix_ms: u64,
    ) -> (PathBuf, RunMeta) {
        let dir = self
            .run_dir
            .clone()
            .unwrap_or_else(|| default_run_dir(&self.def.name, created_unix_ms));
        let mut meta = RunMeta::new(kind, created_unix_ms);
        meta.mission_path = Some(self.mission_path.clone());
        meta.connections = connections.to_vec();
        let mut extra = serde_json::Map::new();
        if self.world_toml.is_some() {
            extra.insert("world".into(), WORLD_FILE.into());
        }
        if let serde_json::Value::Object(more) = &self.extra {
            extra.extend(more.clone());
        }
        if !extra.is_empty() {
            meta.extra = serde_json::Value::Object(extra);
        }
        (dir, meta)
    }
}

/// What to fly.
pub(crate) enum Start {
    /// A new run (its vehicles must be heard on the fleet).
    New(Box<NewRun>),
    /// A saved run to continue.
    Resume(Box<RunDir>),
}

/// A run ready to fly: its directory and state, and what to tell the operator about it.
pub(crate) struct Ready<K: RunKind> {
    /// The run directory.
    pub run_dir: RunDir,
    /// The state to fly from.
    pub state: K::State,
    /// The runner's options.
    pub options: K::Options,
    /// A new run's [`RunKind::started_line`], or how a resumed one continues
    /// ([`RunKind::prepare_resume`]).
    pub line: String,
    /// The fleet check's findings, and what to check again at the operator's START (`None`:
    /// a resumed run whose mission file is not in its directory, so not checked).
    pub(crate) check: Option<StartCheck>,
}

/// Make `start` ready to fly on `fleet`: for a new run, wait up to `wait` for its vehicles,
/// make its state and create its directory (with the world beside it); for a saved run,
/// load its state and [`RunKind::prepare_resume`] it.
pub(crate) async fn prepare<K: RunKind>(
    fleet: &FleetHandle,
    connections: &[String],
    start: Start,
    settings: &RunSettings,
    wait: Duration,
) -> Result<Ready<K>, RunError> {
    let options = K::options(settings)?;
    match start {
        Start::New(new) => {
            let new = *new;
            // the fleet check, before anything is created, uploaded or armed
            let check = gate(fleet, &new.def, wait, settings.on_blocker).await?;
            let state = K::new_state(fleet, &new.def, settings, wait).await?;
            let (dir, meta) = new.plan(K::KIND, connections, fleetmap_io::clock::unix_ms());
            let line = K::started_line(&dir, &state);
            let (text, world) = (new.text, new.world_toml);
            let run_dir = run_blocking(move || -> Result<RunDir, RunError> {
                let run_dir = RunDir::create(&dir, meta, Some(&text))
                    .map_err(|source| RunError::CreateRunDir { path: dir, source })?;
                if let Some(w) = world {
                    let path = run_dir.path().join(WORLD_FILE);
                    fleetmap_io::files::atomic_write(&path, w.as_bytes())
                        .map_err(|source| RunError::Write { path, source })?;
                }
                Ok(run_dir)
            })
            .await??;
            Ok(Ready {
                run_dir,
                state,
                options,
                line,
                check: Some(check),
            })
        }
        Start::Resume(run_dir) => {
            let run_dir = *run_dir;
            let (at, path) = (run_dir.path().to_path_buf(), run_dir.path().to_path_buf());
            let loaded =
                run_blocking(move || RunDir::open(&at).and_then(|rd| rd.load_state::<K::State>()))
                    .await??;
            let mut state = loaded.ok_or_else(|| RunError::NoState { path: path.clone() })?;
            if K::is_finished(&state) {
                return Err(RunError::Finished { path });
            }
            let at = run_dir.path().to_path_buf();
            let def = run_blocking(move || RunDir::open(&at).map(|rd| rd.mission_text())).await?;
            let check = match def {
                Ok(Ok(Some(text))) => match MissionDef::parse(&text, "mission.toml") {
                    Ok(def) => Some(gate(fleet, &def, wait, settings.on_blocker).await?),
                    Err(_) => None,
                },
                _ => None,
            };
            let line = K::prepare_resume(fleet, &mut state, settings, wait).await?;
            Ok(Ready {
                run_dir,
                state,
                options,
                line,
                check,
            })
        }
    }
}

impl<K: RunKind> Ready<K> {
    /// Fly the run on `fleet` without the terminal UI, progress events to `progress`: how
    /// it ended and its final state. The caller writes the exports ([`finish_exports`]); in
    /// the UI, `crate::tui::session::fly` flies it and writes them when it finishes.
    pub(crate) async fn fly_headless(
        self,
        fleet: &FleetHandle,
        progress: Option<tokio::sync::mpsc::UnboundedSender<Progress>>,
    ) -> Result<(Outcome, K::State), RunError> {
        K::fly(fleet, self.run_dir, self.state, self.options, progress).await
    }
}

/// Write the exports of the run at `path` (its world from `run.json`) off the runtime's
/// workers; returns the files written and the report.
pub(crate) async fn finish_exports<K: RunKind>(
    path: &Path,
    state: &K::State,
) -> Result<(Vec<PathBuf>, K::Report), RunError> {
    let (path, state) = (path.to_path_buf(), state.clone());
    run_blocking(move || -> Result<(Vec<PathBuf>, K::Report), RunError> {
        let run_dir = RunDir::open(&path)?;
        let world = run_world(&run_dir, None)?;
        let files = write_exports::<K>(&run_dir, &state, world.as_ref())?;
        Ok((files, K::report(&state, world.as_ref())?))
    })
    .await?
}

/// What to do with a finished run's final state `S` (write its exports).
pub(crate) type OnFinish<S> = Box<dyn FnOnce(&RunDir, &S) + Send>;

/// The exports for the TUI session to write when the run finishes, scored against `world`.
pub(crate) fn exports_on_finish<K: RunKind>(world: Option<World>) -> OnFinish<K::State> {
    Box::new(move |rd, st| {
        if let Err(e) = write_exports::<K>(rd, st, world.as_ref()) {
            tracing::warn!("exports: {}", crate::app::error::chain(&e));
        }
    })
}

/// The world a run was started with (`run.json` extra `world`), or `override_`.
pub(crate) fn run_world(run: &RunDir, override_: Option<&Path>) -> Result<Option<World>, RunError> {
    let path = match override_ {
        Some(p) => Some(p.to_path_buf()),
        None => run
            .meta()
            .extra
            .get("world")
            .and_then(|v| v.as_str())
            .map(PathBuf::from),
    };
    // A relative path in run.json is relative to the run directory (where [`prepare`] keeps
    // the world; runs of older versions name an absolute path).
    let path = path.map(|p| {
        if override_.is_none() && p.is_relative() {
            run.path().join(p)
        } else {
            p
        }
    });
    match path {
        Some(p) => match fleetmap_io::files::load_world(&p) {
            Ok(w) => Ok(Some(w)),
            Err(source) => Err(RunError::World { path: p, source }),
        },
        None => Ok(None),
    }
}

/// `runs/NAME-YYYYMMDD-HHMMSS` (UTC at `unix_ms`), with the mission name made safe for a path.
pub(crate) fn default_run_dir(name: &str, unix_ms: u64) -> PathBuf {
    let secs = unix_ms / 1000;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_run_directory_is_named_after_the_mission_and_the_utc_time() {
        // 2024-02-29 13:04:05 UTC
        let t = 1_709_211_845_000;
        assert_eq!(
            default_run_dir("runway field/test", t),
            PathBuf::from("runs/runway_field_test-20240229-130405")
        );
    }
}
