//! `run`, `resume`, `report` and `export` written once, for any [`RunKind`].
//!
//! A run starts and flies through [`crate::launch`] (as `tui --mission` and the demo
//! do); this module adds what the command line shows: progress lines, the report, exit codes.

use super::dir::{connections_label, remembered_connections};
use super::{ExportArgs, ReportArgs, ResumeArgs, RunArgs};
use crate::app::kind::{Outcome, RunKind, RunSettings, report_json};
use crate::app::run::Progress;
use crate::cli::vehicles::{ConnectArgs, Session, block_on};
use crate::fleet::FleetHandle;
use crate::launch::{NewRun, Ready, Start, finish_exports, prepare, run_world};
use crate::store::RunDir;
use anyhow::{Context as _, bail};
use fleetmap_io::link::ConnSpec;
use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

/// Print progress events as they come (headless runs): one line each, with the seconds
/// since the run started.
pub(crate) fn print_progress() -> (
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

/// Fly a ready run ([`crate::launch::prepare`]) headless (progress lines, then the
/// report), or in the terminal UI when there is a terminal and `headless` is not asked for;
/// prints how it ended. `run` and `resume` fly through here.
pub(super) async fn fly<K: RunKind>(
    fleet: &FleetHandle,
    ready: Ready<K>,
    headless: bool,
    source: crate::tui::Source,
) -> anyhow::Result<ExitCode> {
    let path = ready.run_dir.path().to_path_buf();
    if headless || !crate::cli::tui::interactive() {
        let (tx, printer) = print_progress();
        let flown = ready.fly_headless(fleet, Some(tx)).await;
        let _ = tokio::time::timeout(Duration::from_secs(1), printer).await;
        let (outcome, state) = flown?;
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
            Outcome::WaitingForOperator { waiting } => {
                for line in crate::app::kind::waiting_lines(&waiting) {
                    println!("{line}, on the ground");
                }
                println!("then `fleetmap resume {}`", path.display());
                Ok(ExitCode::from(3))
            }
        };
    }
    let finished = crate::tui::session::fly(ready, fleet, ui_session(source), true).await?;
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

/// The UI settings of a terminal session: default keys and thresholds, the UI log file.
pub(crate) fn ui_session(source: crate::tui::Source) -> crate::tui::session::SessionConfig {
    crate::tui::session::SessionConfig {
        source,
        ui: crate::tui::UiConfig::default(),
        log_file: crate::cli::tui::ui_log_file().map(|p| p.display().to_string()),
    }
}

fn wait_of(secs: f64) -> anyhow::Result<Duration> {
    if !(secs.is_finite() && secs >= 0.0) {
        bail!("--wait must be a non-negative number of seconds");
    }
    Ok(Duration::from_secs_f64(secs))
}

/// Open a session on `conn`, make `start` ready on it (printing its line), [`fly`] it, then
/// close the session whatever the run's result.
async fn connect_and_fly<K: RunKind>(
    conn: &ConnectArgs,
    start: Start,
    settings: &RunSettings,
    wait: Duration,
    headless: bool,
    resumed: Option<&Path>,
) -> anyhow::Result<ExitCode> {
    let session = Session::open(conn).await?;
    let connections: Vec<String> = conn.connect.iter().map(|c| c.to_string()).collect();
    let source = crate::tui::Source::new(
        crate::tui::SourceKind::Live,
        format!("LIVE {}", connections_label(&conn.connect)),
    );
    let result = async {
        let ready = prepare::<K>(&session.fleet, &connections, start, settings, wait).await?;
        match resumed {
            Some(dir) => println!("resuming {} ({})", dir.display(), ready.line),
            None => println!("{}", ready.line),
        }
        fly::<K>(&session.fleet, ready, headless, source).await
    }
    .await;
    session.close().await?;
    result
}

/// `fleetmap run` for a mission of kind `K`.
pub(super) fn start<K: RunKind>(args: RunArgs, new: NewRun) -> anyhow::Result<ExitCode> {
    let settings = args.runner.settings();
    let wait = wait_of(args.runner.wait)?;
    K::options(&settings)?;
    block_on(async move {
        let headless = args.runner.headless;
        let mut conn = args.conn.clone().with_mission_links(&new.def);
        conn.terrain = args.terrain.clone();
        connect_and_fly::<K>(
            &conn,
            Start::New(Box::new(new)),
            &settings,
            wait,
            headless,
            None,
        )
        .await
    })?
}

/// `fleetmap resume` of a run of kind `K`.
pub(super) fn resume<K: RunKind>(args: ResumeArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
    let state: K::State = run_dir
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
    let conn = resume_connection(&args, connect).with_run_links(&run_dir)?;
    let settings = args.runner.settings();
    let wait = wait_of(args.runner.wait)?;
    K::options(&settings)?;
    block_on(async move {
        let headless = args.runner.headless;
        let start = Start::Resume(Box::new(run_dir));
        connect_and_fly::<K>(&conn, start, &settings, wait, headless, Some(&args.run_dir)).await
    })?
}

/// How `fleetmap resume` connects: `connect` with the options it was given (a resumed run
/// remembers its links, not its key, log or terrain folder).
fn resume_connection(args: &ResumeArgs, connect: Vec<ConnSpec>) -> ConnectArgs {
    ConnectArgs {
        signing_key: args.signing_key.clone(),
        tlog: args.tlog.clone(),
        link: args.link,
        terrain: args.terrain.clone(),
        ..ConnectArgs::defaults(connect)
    }
}

/// A run's state, for `report` and `export`.
fn load<K: RunKind>(run_dir: &RunDir) -> anyhow::Result<K::State> {
    run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", run_dir.path().display()))
}

/// `fleetmap report` of a run of kind `K`.
pub(super) fn report<K: RunKind>(args: ReportArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
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
pub(super) fn export<K: RunKind>(args: ExportArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
    let state = load::<K>(&run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let (name, bytes) = K::export(&state, world.as_ref(), args.format.into())?;
    let path = match &args.out {
        Some(p) => {
            fleetmap_io::files::atomic_write(p, &bytes)
                .with_context(|| format!("cannot write {}", p.display()))?;
            p.clone()
        }
        None => run_dir.write_export(name, &bytes)?,
    };
    println!("{}", path.display());
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[test]
    fn resume_serves_terrain_from_the_folder_it_is_given() {
        let cli = crate::cli::Cli::try_parse_from([
            "fleetmap",
            "resume",
            "runs/r1",
            "--terrain",
            "tiles",
            "--connect",
            "udpin:0.0.0.0:14550",
        ])
        .expect("resume parses");
        let crate::cli::Command::Resume(args) = cli.command else {
            panic!("not resume");
        };
        let conn = resume_connection(&args, args.connect.clone());
        assert_eq!(conn.terrain.as_deref(), Some(std::path::Path::new("tiles")));
    }
}
