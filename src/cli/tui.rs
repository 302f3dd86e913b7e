//! `fleetmap tui`: the operator's terminal UI.
//!
//! LIVE with `--connect CONN` (the vehicles heard on the links, their commands executed by
//! the fleet), with a run from `--mission FILE` or `--resume RUN_DIR` (runway mapping or
//! spatial classification) that starts on the operator's START (`crate::tui::session`). Without `--connect` it shows the
//! built-in SAMPLE (a synthetic animation, or a static spatial-classification fixture) or a
//! recorded REPLAY file — and says so in the title bar; operator commands are then reported
//! as *not sent* because no vehicle is connected. `--snapshot COLSxROWS` prints one frame as text without
//! a terminal; `fleetmap bench tui` measures the redraw rate.

use crate::app::kind::{RunKind, RunSettings};
use crate::app::preflight::OnBlocker;
use crate::launch::{NewRun, Start, prepare};
use crate::panes::{Animation, Model, Sample};
use crate::store::RunDir;
use crate::tui;
use crate::tui::UiConfig;
use crate::tui::replay::{ReplayFrame, read_replay, write_replay};
use crate::tui::sample;
use crate::tui::update;
use crate::tui::view;
use crate::tui::{App, CommandRequest, Event, JobResult};
use crate::tui::{ShellIo, ShellOptions};
use anyhow::{Context, anyhow, bail};
use clap::Args;
use clap::builder::{PossibleValue, PossibleValuesParser};
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::watch;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// The values of `--sample`: each mission kind's sample, with what it shows.
fn sample_values() -> PossibleValuesParser {
    PossibleValuesParser::new(
        tui::kinds::sample_names()
            .into_iter()
            .map(|(name, help)| PossibleValue::new(name).help(help)),
    )
}

/// The default `--sample`: the default kind's (the first registered).
fn default_sample() -> String {
    tui::kinds::sample_names()
        .first()
        .map(|(name, _)| name.to_string())
        .unwrap_or_default()
}

/// Arguments of `fleetmap tui`.
#[derive(Debug, Args)]
pub struct TuiArgs {
    /// Play back a replay file (JSON Lines of {"t_ms", "model"}) instead of the built-in sample.
    #[arg(long, value_name = "FILE")]
    pub replay: Option<PathBuf>,
    /// The built-in sample shown without --replay.
    #[arg(long, default_value_t = default_sample(), value_parser = sample_values())]
    pub sample: String,
    /// Drones in the runway sample (1-20).
    #[arg(long, default_value_t = 3)]
    pub vehicles: usize,
    /// Playback speed factor for the replay or the sample animation.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// UI config file: its keys and thresholds tables (TOML; see --print-config).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Print the configuration (every action with its keys, every threshold) and exit.
    #[arg(long)]
    pub(crate) print_config: bool,
    /// Print one frame as text at COLSxROWS (e.g. 80x24) and exit; needs no terminal.
    #[arg(long, value_name = "COLSxROWS")]
    pub snapshot: Option<String>,
    /// With --snapshot: seconds into the replay or sample (default: end of the replay, 300 s of the sample).
    #[arg(long, value_name = "SECONDS")]
    pub at: Option<f64>,
    /// Write the runway sample as a replay file (one frame per simulated second) and exit.
    #[arg(long, value_name = "FILE")]
    pub(crate) export_sample: Option<PathBuf>,
    /// LIVE: connect to vehicles (MAVProxy connection strings; may be given several times).
    #[arg(long = "connect", value_name = "CONN")]
    pub connect: Vec<fleetmap_io::link::ConnSpec>,
    /// LIVE: load this mission definition; it starts when the operator presses START (`s`).
    #[arg(
        long,
        value_name = "FILE",
        requires = "connect",
        conflicts_with = "resume"
    )]
    pub mission: Option<PathBuf>,
    /// LIVE: continue this run directory; it starts on START (`s`).
    #[arg(long, value_name = "RUN_DIR")]
    pub resume: Option<PathBuf>,
    /// LIVE, with --mission: the run directory to create (default: runs/NAME-DATE).
    #[arg(long, value_name = "DIR", requires = "mission")]
    pub run_dir: Option<PathBuf>,
    /// LIVE: take off again by itself after a battery swap (otherwise: `b`).
    #[arg(long)]
    pub auto_resume: bool,
    /// LIVE: start even when the fleet check before take-off finds a blocker
    /// (docs/fleet-check.md).
    #[arg(long)]
    pub ignore_check: bool,
    /// LIVE: what every vehicle's link carries (`radio:BYTES`, `radio`, `unlimited`; as for
    /// `fleetmap run`). Default: the mission file's `link`.
    #[arg(long, value_name = "LINK")]
    pub link: Option<fleetmap_core::budget::LinkBudget>,
}

/// Whether stdin and stdout are both terminals (the UI can run).
pub fn interactive() -> bool {
    std::io::stdout().is_terminal() && std::io::stdin().is_terminal()
}

/// The UI's default log file (see [`default_log_file`]).
pub(crate) fn ui_log_file() -> Option<PathBuf> {
    let base = std::env::var_os("XDG_STATE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state")));
    if let Some(dir) = base.map(|b| b.join("fleetmap"))
        && std::fs::create_dir_all(&dir).is_ok()
    {
        return Some(dir.join("tui.log"));
    }
    Some(std::env::temp_dir().join("fleetmap-tui.log"))
}

/// Where the TUI logs when `--log-file` is not given: `$XDG_STATE_HOME/fleetmap/tui.log`
/// (or `~/.local/state/fleetmap/tui.log`, or the temp directory), because stderr is the
/// screen while the UI runs. `None` for the modes that do not open the UI.
pub(crate) fn default_log_file(args: &TuiArgs) -> Option<PathBuf> {
    if args.print_config || args.snapshot.is_some() || args.export_sample.is_some() {
        return None;
    }
    ui_log_file()
}

/// Parse `COLSxROWS`.
pub(crate) fn parse_size(s: &str) -> anyhow::Result<(u16, u16)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow!("--snapshot {s:?}: expected COLSxROWS, e.g. 80x24"))?;
    let w: u16 = w
        .trim()
        .parse()
        .map_err(|_| anyhow!("--snapshot {s:?}: {w:?} is not a column count"))?;
    let h: u16 = h
        .trim()
        .parse()
        .map_err(|_| anyhow!("--snapshot {s:?}: {h:?} is not a row count"))?;
    if !(1..=1000).contains(&w) || !(1..=1000).contains(&h) {
        bail!("--snapshot {s:?}: size must be between 1x1 and 1000x1000");
    }
    Ok((w, h))
}

/// Render `app` into a `w × h` text screen (one string per row, trailing spaces trimmed).
pub(crate) fn render_text(app: &App, w: u16, h: u16) -> anyhow::Result<Vec<String>> {
    let mut terminal = Terminal::new(TestBackend::new(w, h))?;
    terminal.draw(|f| view::render(app, f))?;
    let buf = terminal.backend().buffer();
    Ok((0..h)
        .map(|y| {
            let mut line = String::new();
            for x in 0..w {
                line.push_str(buf[(x, y)].symbol());
            }
            line.trim_end().to_string()
        })
        .collect())
}

fn load_config(args: &TuiArgs) -> anyhow::Result<UiConfig> {
    match &args.config {
        Some(p) => UiConfig::load(p).with_context(|| format!("config {}", p.display())),
        None => Ok(UiConfig::default()),
    }
}

/// What the UI shows, before it starts.
enum Source {
    Replay(PathBuf, Vec<ReplayFrame>),
    Animated(Box<dyn Animation>),
    Static(Box<Model>),
}

impl Source {
    fn label(&self) -> crate::tui::Source {
        use crate::tui::{Source as S, SourceKind};
        match self {
            Source::Replay(p, _) => S::new(
                SourceKind::Replay,
                format!(
                    "REPLAY {} (recorded, no vehicles connected)",
                    p.file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default()
                ),
            ),
            Source::Animated(_) => S::new(
                SourceKind::Sample,
                "SAMPLE: synthetic data, no vehicles connected",
            ),
            Source::Static(_) => S::new(
                SourceKind::Sample,
                "SAMPLE: static fixture, no vehicles connected",
            ),
        }
    }

    /// The model at `at` seconds (default: replay end / 300 s of the sample).
    fn model_at(self, at: Option<f64>) -> Model {
        match self {
            Source::Replay(_, frames) => {
                let t = at.map(|s| (s.max(0.0) * 1000.0) as u64);
                let frame = match t {
                    Some(t) => frames.iter().rev().find(|f| f.t_ms <= t).or(frames.first()),
                    None => frames.last(),
                };
                frame.map(|f| f.model.clone()).unwrap_or_default()
            }
            Source::Animated(mut run) => {
                run.step(Duration::from_secs(at.unwrap_or(300.0).max(0.0) as u64));
                run.model()
            }
            Source::Static(m) => *m,
        }
    }
}

/// Run `fleetmap tui`.
pub fn run(args: TuiArgs, log_file: Option<&Path>) -> anyhow::Result<ExitCode> {
    let config = load_config(&args)?;
    if args.print_config {
        print!("{}", config.to_toml());
        return Ok(ExitCode::SUCCESS);
    }
    if !(args.speed.is_finite() && args.speed > 0.0) {
        bail!("--speed {}: must be a positive number", args.speed);
    }
    if !(1..=20).contains(&args.vehicles) {
        bail!(
            "--vehicles {}: the sample has 1 to 20 drones",
            args.vehicles
        );
    }
    if let Some(at) = args.at
        && !(at.is_finite() && at >= 0.0)
    {
        bail!("--at {at}: must be a time in seconds, 0 or more");
    }
    if let Some(path) = &args.export_sample {
        // The default kind's sample (the animated one), whatever --sample says.
        let frames = match tui::kinds::sample(&default_sample(), args.vehicles) {
            Some(Sample::Animated(mut run)) => {
                let mut frames = vec![ReplayFrame {
                    t_ms: 0,
                    model: run.model(),
                }];
                while !run.done() && frames.len() < 20_000 {
                    run.step(Duration::from_secs(1));
                    let model = run.model();
                    frames.push(ReplayFrame {
                        t_ms: model.time.as_millis(),
                        model,
                    });
                }
                frames
            }
            Some(Sample::Static(model)) => vec![ReplayFrame {
                t_ms: 0,
                model: *model,
            }],
            None => bail!("no built-in sample to export"),
        };
        write_replay(path, &frames)?;
        println!("wrote {} frames to {}", frames.len(), path.display());
        return Ok(ExitCode::SUCCESS);
    }
    if !args.connect.is_empty() || args.resume.is_some() {
        return run_live(args, config, log_file);
    }
    let source = match &args.replay {
        Some(p) => Source::Replay(p.clone(), read_replay(p)?),
        None => match tui::kinds::sample(&args.sample, args.vehicles) {
            Some(Sample::Animated(run)) => Source::Animated(run),
            Some(Sample::Static(model)) => Source::Static(model),
            None => bail!("--sample {}: no such sample", args.sample),
        },
    };
    let mut config = config;
    // Recorded and synthetic data are not live: no "NO DATA" alarm when they stop.
    config.thresholds.stale_after_s = 0.0;
    let mut app = App::new(config, source.label());
    app.log_file = log_file.map(|p| p.display().to_string());

    if let Some(size) = &args.snapshot {
        let (w, h) = parse_size(size)?;
        let model = source.model_at(args.at);
        update(&mut app, Event::Resize(w, h));
        update(&mut app, Event::Tick(model.time));
        update(&mut app, Event::Snapshot(Box::new(model)));
        for line in render_text(&app, w, h)? {
            println!("{line}");
        }
        return Ok(ExitCode::SUCCESS);
    }

    if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
        bail!(
            "the terminal UI needs an interactive terminal on stdin and stdout (use --snapshot COLSxROWS for a text rendering)"
        );
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(run_ui(app, source, args.speed))?;
    if let Some(p) = log_file {
        eprintln!("fleetmap: the UI log is in {}", p.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// What `tui --mission` or `tui --resume` flies and the connections, before the links are
/// open.
fn live_start(args: &TuiArgs) -> anyhow::Result<(Option<Start>, Vec<ConnSpec>)> {
    let mut connect = args.connect.clone();
    let start = if let Some(dir) = &args.resume {
        let rd =
            RunDir::open(dir).with_context(|| format!("cannot open the run {}", dir.display()))?;
        if connect.is_empty() {
            for c in &rd.meta().connections {
                connect.push(c.parse().map_err(|e| anyhow!("{c}: {e}"))?);
            }
        }
        Some(Start::Resume(Box::new(rd)))
    } else if let Some(p) = &args.mission {
        let mut new = NewRun::from_file(p)?;
        new.run_dir = args.run_dir.clone();
        Some(Start::New(Box::new(new)))
    } else {
        None
    };
    if connect.is_empty() {
        bail!("give --connect (the run remembers no connection)");
    }
    Ok((start, connect))
}

/// `fleetmap tui --connect CONN [--mission FILE | --resume RUN_DIR]`: the UI on live
/// vehicles, with a run (runway mapping or spatial classification) the operator starts. The
/// run starts as `fleetmap run` starts one ([`crate::launch`]).
fn run_live(args: TuiArgs, config: UiConfig, log_file: Option<&Path>) -> anyhow::Result<ExitCode> {
    if !interactive() {
        bail!("the terminal UI needs an interactive terminal on stdin and stdout");
    }
    let (start, connect) = live_start(&args)?;
    let connections: Vec<String> = connect.iter().map(|c| c.to_string()).collect();
    let live = Live {
        settings: RunSettings {
            auto_resume: args.auto_resume,
            on_blocker: OnBlocker::unless_ignored(args.ignore_check, OnBlocker::AtStart),
            ..Default::default()
        },
        config: crate::tui::session::SessionConfig {
            source: crate::tui::Source::new(
                crate::tui::SourceKind::Live,
                format!("LIVE {}", connections.join(", ")),
            ),
            ui: config,
            log_file: log_file.map(|p| p.display().to_string()),
        },
        connections,
        conn: crate::cli::vehicles::ConnectArgs {
            link: args.link,
            ..crate::cli::vehicles::ConnectArgs::defaults(connect)
        },
        start: None,
    };
    let Some(start) = start else {
        return crate::cli::vehicles::block_on(async move {
            let session = crate::cli::vehicles::Session::open(&live.conn).await?;
            let end = crate::tui::session::run(session.fleet.clone(), None, live.config).await;
            session.close().await?;
            end?;
            Ok(ExitCode::SUCCESS)
        })?;
    };
    let kind = match &start {
        Start::Resume(rd) => rd.meta().kind.clone(),
        Start::New(new) => new.def.kind.as_str().to_string(),
    };
    let conn = match &start {
        Start::New(new) => live.conn.clone().with_mission_links(&new.def),
        Start::Resume(rd) => live.conn.clone().with_run_links(rd)?,
    };
    let live = Live {
        start: Some(start),
        conn,
        ..live
    };
    crate::kinds::by_name(&kind, live).map_err(|e| anyhow!("{e}: cannot be flown from the UI"))?
}

/// A LIVE session with a run, for [`crate::kinds::by_name`].
struct Live {
    settings: RunSettings,
    connections: Vec<String>,
    conn: crate::cli::vehicles::ConnectArgs,
    config: crate::tui::session::SessionConfig,
    start: Option<Start>,
}

impl crate::kinds::KindVisitor for Live {
    type Output = anyhow::Result<ExitCode>;

    /// Open the links, make the run ready (its vehicles heard within a minute, as
    /// [`crate::launch::prepare`] does for `fleetmap run`) and fly it in the UI; the
    /// operator STARTs it.
    fn visit<K: RunKind>(self) -> anyhow::Result<ExitCode> {
        let Live {
            settings,
            connections,
            conn,
            config,
            start,
        } = self;
        let start = start.context("no run to fly")?;
        crate::cli::vehicles::block_on(async move {
            let session = crate::cli::vehicles::Session::open(&conn).await?;
            let fleet = &session.fleet;
            let wait = Duration::from_secs(60);
            let flown = async {
                let ready = prepare::<K>(fleet, &connections, start, &settings, wait).await?;
                crate::tui::session::fly(ready, fleet, config, false).await
            }
            .await;
            session.close().await?;
            flown?;
            Ok(ExitCode::SUCCESS)
        })?
    }
}

async fn run_ui(app: App, source: Source, speed: f64) -> anyhow::Result<()> {
    let clock = MonotonicClock::with_speedup(speed);
    let (snap_tx, snap_rx) = watch::channel(Model::default());
    let (cmd_tx, mut cmd_rx) = mpsc::channel::<CommandRequest>(32);
    let (result_tx, result_rx) = mpsc::channel(32);
    let not_sent = match &source {
        Source::Replay(..) => "not sent: this is a replay, no vehicles are connected",
        _ => "not sent: this is the built-in sample, no vehicles are connected",
    };
    // Commands: nothing can execute them here, so each gets an honest failure.
    // The command answerer and the model producer end with the UI (the set is dropped).
    let mut tasks = tokio::task::JoinSet::new();
    tasks.spawn(async move {
        while let Some(req) = cmd_rx.recv().await {
            let r = JobResult {
                id: req.id,
                outcome: Err(crate::tui::CommandError::NotSent(not_sent)),
            };
            if result_tx.send(r).await.is_err() {
                break;
            }
        }
    });
    let producer_clock = clock.clone();
    tasks.spawn(async move {
        match source {
            Source::Static(m) => {
                snap_tx.send_replace(*m);
                // Keep the channel open so the UI does not report a closed source.
                snap_tx.closed().await;
            }
            Source::Replay(_, frames) => {
                for f in frames {
                    let at = Time::from_millis(f.t_ms);
                    tokio::time::sleep(producer_clock.wall_until(at)).await;
                    snap_tx.send_replace(f.model);
                }
                snap_tx.closed().await;
            }
            Source::Animated(mut run) => {
                snap_tx.send_replace(run.model());
                let mut next = Time::from_secs(1);
                while !run.done() {
                    tokio::time::sleep(producer_clock.wall_until(next)).await;
                    run.step(Duration::from_secs(1));
                    next += Duration::from_secs(1);
                    if snap_tx.send(run.model()).is_err() {
                        break;
                    }
                }
                snap_tx.closed().await;
            }
        }
    });
    let io = ShellIo {
        snapshots: snap_rx,
        job_results: result_rx,
        commands: cmd_tx,
    };
    let options = ShellOptions {
        tick: crate::tui::REFRESH,
        clock,
    };
    let result = crate::tui::run(app, io, options).await;
    drop(tasks);
    result?;
    Ok(())
}

/// Arguments of `fleetmap bench tui`.
#[derive(Debug, Args)]
pub struct TuiBenchArgs {
    /// Vehicles in the generated fleet.
    #[arg(long, default_value_t = 50)]
    pub vehicles: usize,
    /// Frames to render.
    #[arg(long, default_value_t = 300)]
    pub frames: u32,
    /// Screen size COLSxROWS.
    #[arg(long, default_value = "250x70")]
    pub size: String,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `fleetmap bench tui`: full-frame redraws into an off-screen terminal, frames per second.
pub fn bench(args: TuiBenchArgs) -> anyhow::Result<ExitCode> {
    let (w, h) = parse_size(&args.size)?;
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let apps: Vec<App> = [1u64, 2]
        .iter()
        .map(|&seed| {
            let mut app = App::new(
                UiConfig::default(),
                crate::tui::Source::new(crate::tui::SourceKind::Bench, "BENCH generated"),
            );
            update(&mut app, Event::Resize(w, h));
            update(
                &mut app,
                Event::Snapshot(Box::new(sample::generated(args.vehicles, seed))),
            );
            app
        })
        .collect();
    let mut terminal = Terminal::new(TestBackend::new(w, h))?;
    // Warm up once (first frame fills an empty buffer).
    terminal.draw(|f| view::render(&apps[0], f))?;
    let start = Instant::now();
    for i in 0..args.frames {
        let app = &apps[(i % 2) as usize];
        terminal.draw(|f| view::render(app, f))?;
    }
    let elapsed = start.elapsed().as_secs_f64();
    let fps = f64::from(args.frames) / elapsed;
    let ms = elapsed * 1000.0 / f64::from(args.frames);
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "bench": "tui_redraw",
                "vehicles": args.vehicles,
                "cols": w,
                "rows": h,
                "frames": args.frames,
                "seconds": elapsed,
                "frames_per_second": fps,
                "ms_per_frame": ms,
            })
        );
    } else {
        println!(
            "tui redraw: {} vehicles, {w}x{h}: {} frames in {:.3} s = {fps:.0} frames/s ({ms:.2} ms/frame; requirement: >= 10 frames/s)",
            args.vehicles, args.frames, elapsed
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `tui --mission` once wrote `created_unix_ms` 0 and named its run directory
    /// `runs/NAME-SECONDS`; it now plans its run as `fleetmap run` does: the same
    /// `run.json` and the default directory `runs/NAME-YYYYMMDD-HHMMSS`.
    #[test]
    fn tui_mission_plans_its_run_as_fleetmap_run_does() {
        use crate::cli::{Cli, Command};
        use clap::Parser as _;
        let mission = "missions/runway-field-test.toml";
        let conn = "udpin:127.0.0.1:14550";
        let cli = Cli::parse_from(["fleetmap", "tui", "--connect", conn, "--mission", mission]);
        let Command::Tui(args) = cli.command else {
            panic!("not the tui command");
        };
        let (start, connect) = live_start(&args).expect("the mission file reads");
        let Some(Start::New(tui)) = start else {
            panic!("--mission starts a new run");
        };
        let connections: Vec<String> = connect.iter().map(|c| c.to_string()).collect();
        let run = NewRun::from_file(Path::new(mission)).expect("the mission file reads");
        // 2024-02-29 13:04:05 UTC
        let t = 1_709_211_845_000;
        let (dir, meta) = tui.plan(tui.def.kind.as_str(), &connections, t);
        let (run_dir, run_meta) = run.plan(run.def.kind.as_str(), &connections, t);
        assert_eq!(meta.created_unix_ms, t);
        assert_eq!(
            dir,
            crate::launch::default_run_dir(&tui.def.name, t),
            "the default run directory"
        );
        assert_eq!(dir, run_dir);
        assert_eq!(
            serde_json::to_value(&meta).ok(),
            serde_json::to_value(&run_meta).ok()
        );
        assert_eq!(meta.connections, vec![conn.to_string()]);
        assert_eq!(meta.mission_path.as_deref(), Some(mission));
    }

    #[test]
    fn sizes_parse_or_explain() {
        assert_eq!(parse_size("80x24").ok(), Some((80, 24)));
        assert_eq!(parse_size("250X70").ok(), Some((250, 70)));
        for bad in ["80", "x24", "80x", "0x10", "80x-1", "axb"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
