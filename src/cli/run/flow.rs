//! `run`, `resume`, `report` and `export` written once, for any [`RunKind`].
//!
//! File work (creating the run directory, writing the exports, reading the world back) runs
//! before the async runtime starts or on its blocking pool (`cpu`), never on a runtime worker.

use super::dir::{connections_label, default_run_dir, remembered_connections, run_world, unix_ms};
use super::{ExportArgs, ReportArgs, ResumeArgs, RunArgs};
use crate::app::kind::{Outcome, RunKind, report_json, write_exports};
use crate::app::run::Progress;
use crate::app::runway::cpu;
use crate::cli::vehicles::{ConnectArgs, Session, block_on};
use crate::fleet::FleetHandle;
use crate::mission::definition::MissionDef;
use crate::store::{RunDir, RunMeta};
use crate::world::World;
use anyhow::{Context as _, bail};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// Print progress events as they come (headless runs): one line each, with the seconds
/// since the run started.
fn print_progress() -> (
    tokio::sync::mpsc::UnboundedSender<Progress>,
    tokio::task::JoinHandle<()>,
) {
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Progress>();
    let task = tokio::spawn(async move {
        let start = std::time::Instant::now();
        while let Some(p) = rx.recv().await {
            println!("[{:7.1} s] {p}", start.elapsed().as_secs_f64());
        }
    });
    (tx, task)
}

/// Fly `state` to its end (or the operator) on an open fleet; with `headless`, progress
/// lines on stdout. Shared by `run`, `resume` and the demo. Returns how it ended, the final
/// state and the run directory's path.
pub async fn drive<K: RunKind>(
    fleet: &FleetHandle,
    run_dir: RunDir,
    state: K::State,
    options: K::Options,
    headless: bool,
) -> anyhow::Result<(Outcome, K::State, PathBuf)> {
    let path = run_dir.path().to_path_buf();
    let (progress, printer) = if headless {
        let (tx, task) = print_progress();
        (Some(tx), Some(task))
    } else {
        (None, None)
    };
    let out = K::fly(fleet, run_dir, state, options, progress).await;
    if let Some(p) = printer {
        let _ = tokio::time::timeout(Duration::from_secs(1), p).await;
    }
    let (outcome, state) = out?;
    Ok((outcome, state, path))
}

/// Write the exports of the run at `path` (its world from `run.json`) off the runtime's
/// workers; returns the files written.
pub async fn finish_exports<K: RunKind>(
    path: &Path,
    state: &K::State,
) -> anyhow::Result<(Vec<PathBuf>, K::Report)> {
    let (path, state) = (path.to_path_buf(), state.clone());
    cpu(move || -> anyhow::Result<(Vec<PathBuf>, K::Report)> {
        let run_dir = RunDir::open(&path)?;
        let world = run_world(&run_dir, None)?;
        let files = write_exports::<K>(&run_dir, &state, world.as_ref())?;
        Ok((files, K::report(&state, world.as_ref())?))
    })
    .await?
}

/// The exports for the TUI session to write when the run finishes, scored against `world`.
pub fn exports_on_finish<K: RunKind>(
    world: Option<World>,
) -> crate::app::session::OnFinish<K::State> {
    Box::new(move |rd, st| {
        if let Err(e) = write_exports::<K>(rd, st, world.as_ref()) {
            tracing::warn!("exports: {e:#}");
        }
    })
}

/// Fly a run headless (progress lines, then the report), or in the terminal UI when there is
/// a terminal and `headless` is not asked for; prints how it ended.
pub async fn fly<K: RunKind>(
    fleet: &FleetHandle,
    run_dir: RunDir,
    state: K::State,
    options: K::Options,
    headless: bool,
    label: String,
) -> anyhow::Result<ExitCode> {
    if headless || !crate::cli::tui::interactive() {
        let (outcome, state, path) = drive::<K>(fleet, run_dir, state, options, true).await?;
        return match outcome {
            Outcome::Finished => {
                let (files, report) = finish_exports::<K>(&path, &state).await?;
                println!("run finished: {}", path.display());
                for l in K::report_lines(&report) {
                    println!("{l}");
                }
                for f in files {
                    println!("  wrote {}", f.display());
                }
                println!("`fleetmap report {}` for the results", path.display());
                Ok(ExitCode::SUCCESS)
            }
            Outcome::WaitingForOperator { sysids } => {
                let list: Vec<String> = sysids.iter().map(|s| s.to_string()).collect();
                println!(
                    "vehicle(s) {} landed for a battery swap: swap, then `fleetmap resume {}`",
                    list.join(", "),
                    path.display()
                );
                Ok(ExitCode::from(3))
            }
        };
    }
    let path = run_dir.path().to_path_buf();
    let at = path.clone();
    let world = cpu(move || {
        RunDir::open(&at)
            .ok()
            .and_then(|rd| run_world(&rd, None).ok())
    })
    .await?
    .flatten();
    let mission = K::session_run(
        run_dir,
        state,
        options,
        true,
        Some(exports_on_finish::<K>(world)),
    );
    fly_in_ui(fleet, mission, &path, label).await
}

/// The UI settings of a terminal session: default keys and thresholds, the UI log file.
pub fn ui_session(label: String) -> crate::app::session::SessionConfig {
    crate::app::session::SessionConfig {
        label,
        ui: crate::tui::UiConfig::default(),
        log_file: crate::cli::tui::ui_log_file().map(|p| p.display().to_string()),
    }
}

/// Fly `mission` (its run directory at `path`) in the terminal UI until the operator quits;
/// prints how it ended.
async fn fly_in_ui(
    fleet: &FleetHandle,
    mission: crate::app::session::SessionRun,
    path: &Path,
    label: String,
) -> anyhow::Result<ExitCode> {
    let crate::app::session::SessionEnd::Quit { finished } =
        crate::app::session::run(fleet.clone(), Some(mission), ui_session(label)).await?;
    if finished {
        println!(
            "run finished: `fleetmap report {}` for the results",
            path.display()
        );
    } else {
        println!(
            "the UI was closed before the run finished; its state is saved: `fleetmap resume {}`",
            path.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn wait_of(secs: f64) -> anyhow::Result<Duration> {
    if !(secs.is_finite() && secs >= 0.0) {
        bail!("--wait must be a non-negative number of seconds");
    }
    Ok(Duration::from_secs_f64(secs))
}

/// [`fly`] on an open session (connected with `conn`), then close the session whatever the
/// run's result.
async fn fly_then_close<K: RunKind>(
    session: Session,
    conn: &ConnectArgs,
    run_dir: RunDir,
    state: K::State,
    options: K::Options,
    headless: bool,
) -> anyhow::Result<ExitCode> {
    let label = format!("LIVE {}", connections_label(&conn.connect));
    let result = fly::<K>(&session.fleet, run_dir, state, options, headless, label).await;
    session.close().await?;
    result
}

/// `fleetmap run` for a mission of kind `K` (`text` is the mission file, already parsed as
/// `def`).
pub fn start<K: RunKind>(args: RunArgs, def: MissionDef, text: String) -> anyhow::Result<ExitCode> {
    let settings = args.runner.settings();
    let wait = wait_of(args.runner.wait)?;
    let options = K::options(&settings)?;
    let mut meta = RunMeta::new(K::KIND, unix_ms());
    meta.mission_path = Some(args.mission.display().to_string());
    meta.connections = args.conn.connect.iter().map(|c| c.to_string()).collect();
    if let Some(w) = &args.world {
        crate::files::load_world(w).with_context(|| format!("world {}", w.display()))?;
        let abs = std::fs::canonicalize(w).unwrap_or_else(|_| w.clone());
        meta.extra = serde_json::json!({"world": abs.display().to_string()});
    }
    let dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| default_run_dir(&def.name));
    block_on(async move {
        let session = Session::open(&args.conn).await?;
        let state = K::new_state(&session.fleet, &def, &settings, wait).await?;
        let at = dir.clone();
        let run_dir = cpu(move || {
            RunDir::create(&at, meta, Some(&text))
                .with_context(|| format!("cannot create the run directory {}", at.display()))
        })
        .await??;
        println!("{}", K::started_line(&dir, &state));
        let headless = args.runner.headless;
        fly_then_close::<K>(session, &args.conn, run_dir, state, options, headless).await
    })?
}

/// `fleetmap resume` of a run of kind `K`.
pub fn resume<K: RunKind>(args: ResumeArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
    let mut state: K::State = run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", args.run_dir.display()))?;
    if K::is_finished(&state) {
        println!("the run is already finished");
        return Ok(ExitCode::SUCCESS);
    }
    let connect = if args.connect.is_empty() {
        remembered_connections(&run_dir)?
    } else {
        args.connect.clone()
    };
    if connect.is_empty() {
        bail!("the run remembers no connection: give --connect");
    }
    let conn = ConnectArgs {
        signing_key: args.signing_key.clone(),
        tlog: args.tlog.clone(),
        ..ConnectArgs::defaults(connect)
    };
    let settings = args.runner.settings();
    let wait = wait_of(args.runner.wait)?;
    let options = K::options(&settings)?;
    block_on(async move {
        let session = Session::open(&conn).await?;
        let how = K::prepare_resume(&session.fleet, &mut state, &settings, wait).await?;
        println!("resuming {} ({how})", args.run_dir.display());
        let headless = args.runner.headless;
        fly_then_close::<K>(session, &conn, run_dir, state, options, headless).await
    })?
}

/// A run's state, for `report` and `export`.
fn load<K: RunKind>(run_dir: &RunDir) -> anyhow::Result<K::State> {
    run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", run_dir.path().display()))
}

/// `fleetmap report` of a run of kind `K`.
pub fn report<K: RunKind>(args: ReportArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
    let state = load::<K>(&run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let r = K::report(&state, world.as_ref())?;
    if args.json {
        let events = run_dir.read_events::<K::Event>()?;
        let events: Vec<K::Event> = events.events.into_iter().map(|e| e.event).collect();
        let v = report_json::<K>(&r, &events)?;
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "run {} — mission {}",
        args.run_dir.display(),
        K::mission(&state)
    );
    for l in K::report_lines(&r) {
        println!("{l}");
    }
    Ok(ExitCode::SUCCESS)
}

/// `fleetmap export` of a run of kind `K`.
pub fn export<K: RunKind>(args: ExportArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
    let state = load::<K>(&run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let (name, bytes) = K::export(&state, world.as_ref(), args.format.into())?;
    let path = match &args.out {
        Some(p) => {
            crate::store::atomic_write(p, &bytes)
                .with_context(|| format!("cannot write {}", p.display()))?;
            p.clone()
        }
        None => run_dir.write_export(name, &bytes)?,
    };
    println!("{}", path.display());
    Ok(ExitCode::SUCCESS)
}
