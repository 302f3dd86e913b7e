//! `fleetmap run MISSION.toml --connect CONN`, `fleetmap resume RUN_DIR`,
//! `fleetmap report RUN_DIR [--json]`, `fleetmap export RUN_DIR --format geojson|kml|png`.
//!
//! Both mission kinds: runway mapping ([`crate::app::runway`]) and spatial classification
//! ([`crate::app::bandit`]); `resume`, `report` and `export` follow the kind in `run.json`.
//!
//! A run lives in its directory (`src/store`): `run.json` remembers the kind, the mission
//! file and the connection strings, so `fleetmap resume RUN_DIR` needs nothing else after a
//! battery swap or a crashed laptop. `--world FILE` (a simulated world) is remembered too:
//! the report then scores the map against its ground truth.

use crate::app::bandit::{self, BanditEvent};
use crate::app::bandit_report;
use crate::app::flight::Patience;
use crate::app::images;
use crate::app::report::{self, truth_coverage, truth_outlines};
use crate::app::runway::{self, MappingEvent, Outcome, RunOptions};
use crate::cli::vehicles::{ConnectArgs, Session, block_on};
use crate::explore::Sharing;
use crate::explore::mapping::MappingState;
use crate::link::ConnSpec;
use crate::mission::definition::{MissionDef, MissionKind};
use crate::planner::sortie::ClassificationState;
use crate::sim::world::World;
use crate::store::{RunDir, RunMeta};
use anyhow::{Context as _, bail};
use clap::{Args, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// Options shared by `run` and `resume`.
#[derive(Debug, Clone, Args)]
pub struct RunnerArgs {
    /// Run without the terminal UI: progress lines on stdout.
    #[arg(long)]
    pub headless: bool,
    /// After a battery swap, take off again by itself as soon as the vehicle reports a fresh
    /// battery (otherwise the operator confirms the swap: the TUI's `b`, or `fleetmap resume`).
    #[arg(long)]
    pub auto_resume: bool,
    /// Wait this long for every mission vehicle's heartbeat (and the home position), seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub wait: f64,
    /// Scale every flight timeout (2 = twice as patient; for slow links or slow simulators).
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub patience: f64,
    /// How robots share the DFS vertex states: gcs (default; the GCS hears every robot) or
    /// meet (the paper's model: only when robots meet).
    #[arg(long, value_name = "MODE", default_value = "gcs")]
    pub sharing: SharingArg,
    /// Spatial classification: keep the drones in step (the paper's mid-cycle separation,
    /// 7e) even when the mission separates them by altitude.
    #[arg(long)]
    pub lock_step: bool,
    /// Spatial classification: HiGHS time limit per integer-program solve, seconds.
    #[arg(long, value_name = "SECONDS")]
    pub plan_time_limit: Option<f64>,
}

/// `--sharing`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SharingArg {
    /// Through the GCS.
    Gcs,
    /// When robots meet.
    Meet,
}

impl From<SharingArg> for Sharing {
    fn from(s: SharingArg) -> Sharing {
        match s {
            SharingArg::Gcs => Sharing::Gcs,
            SharingArg::Meet => Sharing::Meet,
        }
    }
}

/// Arguments of `fleetmap run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The mission definition (TOML).
    pub mission: PathBuf,
    /// Connection options.
    #[command(flatten)]
    pub conn: ConnectArgs,
    /// Runner options.
    #[command(flatten)]
    pub runner: RunnerArgs,
    /// The run directory (must not exist or be empty). Default: runs/NAME-YYYYMMDD-HHMMSS.
    #[arg(long, value_name = "DIR")]
    pub run_dir: Option<PathBuf>,
    /// The simulated world the vehicles fly over (ground truth for the report's IoU).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
}

/// Arguments of `fleetmap resume`.
#[derive(Debug, Args)]
pub struct ResumeArgs {
    /// The run directory.
    pub run_dir: PathBuf,
    /// Connection strings (default: the ones the run was started with).
    #[arg(long = "connect", value_name = "CONN")]
    pub connect: Vec<ConnSpec>,
    /// MAVLink 2 signing key file.
    #[arg(long, value_name = "FILE")]
    pub signing_key: Option<PathBuf>,
    /// Record every frame to this .tlog file.
    #[arg(long, value_name = "FILE")]
    pub tlog: Option<PathBuf>,
    /// Runner options.
    #[command(flatten)]
    pub runner: RunnerArgs,
}

/// Arguments of `fleetmap report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// The run directory.
    pub run_dir: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Score against this world (default: the one the run was started with, if any).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
}

/// `fleetmap export --format`.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ExportFormat {
    /// GeoJSON FeatureCollection (QGIS).
    Geojson,
    /// KML (Google Earth).
    Kml,
    /// PNG: the grid (runway mapping, the runway paper's Fig. 10) or the classification
    /// progress per epoch (spatial classification, the bandit paper's Fig. 4).
    Png,
}

/// Arguments of `fleetmap export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The run directory.
    pub run_dir: PathBuf,
    /// What to write.
    #[arg(long, value_enum)]
    pub format: ExportFormat,
    /// Output file (default: RUN_DIR/exports/map.EXT).
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Ground-truth world for the outline (default: the run's).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
}

fn unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as u64)
        .unwrap_or(0)
}

fn default_run_dir(name: &str) -> PathBuf {
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
            World::load(&p).with_context(|| format!("world {}", p.display()))?,
        )),
        None => Ok(None),
    }
}

/// Print progress lines as they come (headless runs).
fn print_progress() -> (
    tokio::sync::mpsc::UnboundedSender<crate::app::run::Progress>,
    tokio::task::JoinHandle<()>,
) {
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<crate::app::run::Progress>();
    let task = tokio::spawn(async move {
        let start = std::time::Instant::now();
        while let Some(line) = rx.recv().await {
            println!("[{:7.1} s] {line}", start.elapsed().as_secs_f64());
        }
    });
    (tx, task)
}

fn wait_of(secs: f64) -> anyhow::Result<Duration> {
    if !(secs.is_finite() && secs >= 0.0) {
        bail!("--wait must be a non-negative number of seconds");
    }
    Ok(Duration::from_secs_f64(secs))
}

/// Run a runway-mapping state to its end (or the operator) on an open fleet; prints the
/// outcome. Shared by `run`, `resume` and the demo.
pub async fn drive_mapping(
    fleet: &crate::fleet::FleetHandle,
    run_dir: RunDir,
    state: MappingState,
    mut opts: RunOptions,
    headless: bool,
) -> anyhow::Result<(Outcome, PathBuf)> {
    let path = run_dir.path().to_path_buf();
    let hub = images::spawn(fleet);
    let mut printer = None;
    if headless && opts.progress.is_none() {
        let (tx, task) = print_progress();
        opts.progress = Some(tx);
        printer = Some(task);
    }
    let out = runway::run(fleet.clone(), &hub, run_dir, state, opts).await;
    if let Some(p) = printer {
        let _ = tokio::time::timeout(Duration::from_secs(1), p).await;
    }
    Ok((out?, path))
}

fn finish_message(outcome: &Outcome, path: &Path) -> ExitCode {
    match outcome {
        Outcome::Finished => {
            println!(
                "run finished: `fleetmap report {}` for the results",
                path.display()
            );
            ExitCode::SUCCESS
        }
        Outcome::WaitingForOperator { sysids } => {
            let list: Vec<String> = sysids.iter().map(|s| s.to_string()).collect();
            println!(
                "vehicle(s) {} landed for a battery swap: swap, then `fleetmap resume {}`",
                list.join(", "),
                path.display()
            );
            ExitCode::from(3)
        }
    }
}

/// `fleetmap run`.
pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    let text = std::fs::read_to_string(&args.mission)
        .with_context(|| format!("cannot read {}", args.mission.display()))?;
    let def = MissionDef::parse(&text, &args.mission.display().to_string())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if def.kind == MissionKind::SpatialClassification {
        return run_classification(args, def, text);
    }
    let wait = wait_of(args.runner.wait)?;
    if let Some(w) = &args.world {
        World::load(w).with_context(|| format!("world {}", w.display()))?;
    }
    let dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| default_run_dir(&def.name));
    block_on(async move {
        let session = Session::open(&args.conn).await?;
        let state =
            crate::app::new_mapping(&session.fleet, &def, args.runner.sharing.into(), wait).await?;
        let mut meta = RunMeta::new(runway::KIND, unix_ms());
        meta.mission_path = Some(args.mission.display().to_string());
        meta.connections = args.conn.connect.iter().map(|c| c.to_string()).collect();
        if let Some(w) = &args.world {
            let abs = std::fs::canonicalize(w).unwrap_or_else(|_| w.clone());
            meta.extra = serde_json::json!({"world": abs.display().to_string()});
        }
        let run_dir = RunDir::create(&dir, meta, Some(&text))
            .with_context(|| format!("cannot create the run directory {}", dir.display()))?;
        println!(
            "run directory {} — grid origin {:.7},{:.7}, {} m cells, {} drone(s)",
            dir.display(),
            state.grid.origin().lat,
            state.grid.origin().lon,
            state.grid.cell_size(),
            state.robots.len()
        );
        let opts = RunOptions {
            auto_resume: args.runner.auto_resume,
            patience: Patience {
                factor: args.runner.patience,
            },
            ..RunOptions::default()
        };
        let label = format!("LIVE {}", meta_label(&args.conn.connect));
        let result = fly_mapping(
            &session.fleet,
            run_dir,
            state,
            opts,
            args.runner.headless,
            label,
        )
        .await;
        session.close().await?;
        result
    })?
}

fn meta_label(conns: &[ConnSpec]) -> String {
    conns
        .iter()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Fly a runway-mapping run headless (progress lines), or in the terminal UI when there is
/// a terminal and `headless` is not asked for; prints how it ended.
pub async fn fly_mapping(
    fleet: &crate::fleet::FleetHandle,
    run_dir: RunDir,
    state: MappingState,
    opts: RunOptions,
    headless: bool,
    label: String,
) -> anyhow::Result<ExitCode> {
    if headless || !crate::cli::tui::interactive() {
        let (outcome, path) = drive_mapping(fleet, run_dir, state, opts, true).await?;
        return Ok(finish_message(&outcome, &path));
    }
    let path = run_dir.path().to_path_buf();
    let world = run_world(&run_dir, None).ok().flatten();
    let mission = crate::app::session::MappingRun {
        run_dir,
        state,
        auto_start: true,
        options: opts,
        on_finish: Some(Box::new(move |rd, st| {
            if let Err(e) = write_exports(rd, st, world.as_ref()) {
                tracing::warn!("exports: {e:#}");
            }
        })),
    };
    fly_in_ui(fleet, mission.into(), &path, label).await
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
    fleet: &crate::fleet::FleetHandle,
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

/// `fleetmap resume`.
pub fn resume(args: ResumeArgs) -> anyhow::Result<ExitCode> {
    let run_dir = RunDir::open(&args.run_dir)
        .with_context(|| format!("cannot open the run {}", args.run_dir.display()))?;
    if let Some(t) = run_dir.torn_tail_at_open() {
        println!(
            "note: the journal's last record was cut short by the crash ({} bytes at line {}); it was never acknowledged and is dropped",
            t.len, t.line
        );
    }
    if run_dir.meta().kind == bandit::KIND {
        return resume_classification(args, run_dir);
    }
    if run_dir.meta().kind != runway::KIND {
        bail!(
            "{} is a {} run; this build resumes runway-mapping and spatial-classification runs",
            args.run_dir.display(),
            run_dir.meta().kind
        );
    }
    let state: MappingState = run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", args.run_dir.display()))?;
    if state.is_finished() {
        println!("the run is already finished");
        return Ok(ExitCode::SUCCESS);
    }
    let connect = if args.connect.is_empty() {
        run_dir
            .meta()
            .connections
            .iter()
            .map(|c| {
                c.parse::<ConnSpec>()
                    .map_err(|e| anyhow::anyhow!("{c}: {e}"))
            })
            .collect::<anyhow::Result<Vec<_>>>()?
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
    let wait = wait_of(args.runner.wait)?;
    block_on(async move {
        let session = Session::open(&conn).await?;
        for r in &state.robots {
            session.vehicle(r.sysid, wait).await?;
        }
        println!(
            "resuming {} ({}, {} images so far)",
            args.run_dir.display(),
            state.phase,
            state.images
        );
        let opts = RunOptions {
            auto_resume: args.runner.auto_resume,
            patience: Patience {
                factor: args.runner.patience,
            },
            // The operator ran `resume`: robots that were waiting for a swap may go.
            ..RunOptions::default()
        };
        let mut state = state;
        if !args.runner.auto_resume {
            // Running `fleetmap resume` is the operator's "battery swapped" for every robot
            // that was waiting on the ground.
            let now = session.fleet.clock().now();
            for r in state.robots.clone() {
                if r.status == crate::explore::mapping::RobotStatus::AwaitingSwap {
                    state.on_swapped(r.sysid, now)?;
                }
            }
        }
        let label = format!("LIVE {}", meta_label(&conn.connect));
        let result = fly_mapping(
            &session.fleet,
            run_dir,
            state,
            opts,
            args.runner.headless,
            label,
        )
        .await;
        session.close().await?;
        result
    })?
}

/// Load a runway-mapping run's state.
fn load_mapping(dir: &Path) -> anyhow::Result<(RunDir, MappingState)> {
    let run_dir =
        RunDir::open(dir).with_context(|| format!("cannot open the run {}", dir.display()))?;
    if run_dir.meta().kind != runway::KIND {
        bail!(
            "{} is a {} run, not {}",
            dir.display(),
            run_dir.meta().kind,
            runway::KIND
        );
    }
    let state: MappingState = run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", dir.display()))?;
    Ok((run_dir, state))
}

/// `fleetmap report`.
pub fn report_cmd(args: ReportArgs) -> anyhow::Result<ExitCode> {
    if run_kind(&args.run_dir)? == bandit::KIND {
        return report_classification(args);
    }
    let (run_dir, state) = load_mapping(&args.run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let cov = match &world {
        Some(w) => Some(truth_coverage(&state.grid, w, 0.0)?),
        None => None,
    };
    let r = report::report(&state, cov.as_ref());
    let events = run_dir.read_events::<MappingEvent>()?;
    if args.json {
        let mut v = serde_json::to_value(&r)?;
        if let Some(o) = v.as_object_mut() {
            o.insert(
                "journal_records".into(),
                serde_json::json!(events.events.len()),
            );
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("run {} — mission {}", args.run_dir.display(), r.mission);
    println!(
        "  {} ({})",
        r.phase,
        if r.finished {
            "every robot landed"
        } else {
            "not finished"
        }
    );
    println!(
        "  map: {} runway cells, {} non-runway; tree {} vertices ({} explored, {} unexplored)",
        r.cells_mapped,
        r.negative_cells,
        r.tree_vertices,
        r.explored_vertices,
        r.unexplored_vertices
    );
    println!(
        "  images: {} at cell centres ({} decisions), {} in the sweep, {} lost",
        r.images, r.detections, r.sweep_images, r.image_failures
    );
    println!(
        "  flight: {:.0} s airborne, {:.0} m, {} battery swap(s)",
        r.flight_time_s, r.distance_m, r.battery_swaps
    );
    for rb in &r.robots {
        println!(
            "  vehicle {} at {:.1} m: {}, {:.0} s, {:.0} m, {} swap(s), {} images",
            rb.sysid,
            rb.altitude_m,
            rb.status,
            rb.flight_time_s,
            rb.distance_m,
            rb.battery_swaps,
            rb.images
        );
    }
    if let Some(t) = &r.truth {
        println!(
            "  vs ground truth: IoU {:.1} % (best possible on this grid {:.1} %, paper {:.1} %); \
             {} of {} region cells mapped; decisions: {} false positive(s), {} false negative(s) of {}",
            100.0 * t.iou,
            100.0 * t.iou_best_possible,
            100.0 * t.paper_iou,
            t.region_cells_mapped,
            t.region_cells,
            t.false_positives,
            t.false_negatives,
            r.detections
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Write every export of a run into its `exports/` (used at the end of runs and demos).
pub fn write_exports(
    run_dir: &RunDir,
    state: &MappingState,
    world: Option<&World>,
) -> anyhow::Result<Vec<PathBuf>> {
    let outlines = world.map(|w| truth_outlines(w, 0.0)).unwrap_or_default();
    let mut out = Vec::new();
    let gj = serde_json::to_vec_pretty(&report::geojson(state, &outlines))?;
    out.push(run_dir.write_export("map.geojson", &gj)?);
    out.push(run_dir.write_export("map.kml", report::kml(state, &outlines).as_bytes())?);
    out.push(run_dir.write_export("map.png", &png_bytes(state, &outlines)?)?);
    Ok(out)
}

fn png_bytes(
    state: &MappingState,
    outlines: &[Vec<crate::geo::LatLon>],
) -> anyhow::Result<Vec<u8>> {
    let img = report::png(state, outlines);
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)?;
    Ok(buf.into_inner())
}

/// `fleetmap export`.
pub fn export(args: ExportArgs) -> anyhow::Result<ExitCode> {
    if run_kind(&args.run_dir)? == bandit::KIND {
        return export_classification(args);
    }
    let (run_dir, state) = load_mapping(&args.run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let outlines = world
        .as_ref()
        .map(|w| truth_outlines(w, 0.0))
        .unwrap_or_default();
    let (bytes, name) = match args.format {
        ExportFormat::Geojson => (
            serde_json::to_vec_pretty(&report::geojson(&state, &outlines))?,
            "map.geojson",
        ),
        ExportFormat::Kml => (report::kml(&state, &outlines).into_bytes(), "map.kml"),
        ExportFormat::Png => (png_bytes(&state, &outlines)?, "map.png"),
    };
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

// ------------------------------------------------------------------ spatial classification

fn run_kind(dir: &Path) -> anyhow::Result<String> {
    let run_dir =
        RunDir::open(dir).with_context(|| format!("cannot open the run {}", dir.display()))?;
    Ok(run_dir.meta().kind.clone())
}

/// The interesting cells of a simulated world (its green tiles).
fn world_truth(world: Option<&World>) -> Option<Vec<crate::geo::Cell>> {
    world.map(crate::app::bandit_sim::green_tiles)
}

/// Run a spatial-classification state to its end on an open fleet (progress lines on
/// stdout when `headless`); shared by `run`, `resume` and `demo --bandit`. Returns the final
/// state and the run directory.
pub async fn drive_classification(
    fleet: &crate::fleet::FleetHandle,
    run_dir: RunDir,
    state: ClassificationState,
    mut opts: bandit::RunOptions,
    headless: bool,
) -> anyhow::Result<(ClassificationState, PathBuf)> {
    let path = run_dir.path().to_path_buf();
    let hub = crate::app::images::image_hub(fleet);
    let mut printer = None;
    if headless && opts.progress.is_none() {
        let (tx, task) = print_progress();
        opts.progress = Some(tx);
        printer = Some(task);
    }
    let out = bandit::run(fleet.clone(), &hub, run_dir, state, opts).await;
    if let Some(p) = printer {
        let _ = tokio::time::timeout(Duration::from_secs(1), p).await;
    }
    Ok((out?, path))
}

fn classification_opts(r: &RunnerArgs) -> anyhow::Result<bandit::RunOptions> {
    if let Some(t) = r.plan_time_limit
        && !(t.is_finite() && t > 0.0)
    {
        bail!("--plan-time-limit must be a positive number of seconds");
    }
    Ok(bandit::RunOptions {
        patience: Patience { factor: r.patience },
        plan_time_limit_s: r.plan_time_limit,
        ..bandit::RunOptions::default()
    })
}

/// Write the classification exports (progress PNG, GeoJSON, KML) into the run's `exports/`.
pub fn write_classification_exports(
    run_dir: &RunDir,
    state: &ClassificationState,
    world: Option<&World>,
) -> anyhow::Result<Vec<PathBuf>> {
    let truth = world_truth(world);
    let png = bandit_report::progress_png(state, truth.as_deref(), 900, 560)?;
    Ok(vec![
        run_dir.write_export("progress.png", &png)?,
        run_dir.write_export(
            "cells.geojson",
            &serde_json::to_vec_pretty(&bandit_report::geojson(state))?,
        )?,
        run_dir.write_export("cells.kml", bandit_report::kml(state).as_bytes())?,
    ])
}

/// Print the classification report as text.
pub fn print_classification(r: &bandit_report::ClassificationReport) {
    let cells = |v: &[[i32; 2]]| -> String {
        if v.is_empty() {
            "none".into()
        } else {
            v.iter()
                .map(|c| format!("({}, {})", c[0], c[1]))
                .collect::<Vec<_>>()
                .join(" ")
        }
    };
    println!(
        "  {}: {} epoch(s), {} measurements, {:.0} s of drone flight, {:.0} s of sorties",
        if r.finished {
            "every cell classified"
        } else {
            "not finished"
        },
        r.epochs,
        r.measurements,
        r.flight_time_s,
        r.sortie_time_s
    );
    println!("  keep ({}): {}", r.keep.len(), cells(&r.keep));
    println!("  reject ({}): {}", r.reject.len(), cells(&r.reject));
    if !r.unclassified.is_empty() {
        println!(
            "  unclassified ({}): {}",
            r.unclassified.len(),
            cells(&r.unclassified)
        );
    }
    if let (Some(t), Some(e)) = (&r.interesting_truth, &r.errors) {
        println!(
            "  vs ground truth: interesting {}; {} labelling error(s){}",
            cells(t),
            e.len(),
            if e.is_empty() {
                String::new()
            } else {
                format!(": {}", cells(e))
            }
        );
    }
    for e in &r.per_epoch {
        println!(
            "  epoch {:>2}: {} cycle(s), planner {:.2} s, sorties {:.0} s, {} measurements, \
             keep {} reject {} unclassified {}",
            e.epoch,
            e.cycles,
            e.planner_s,
            e.flight_s,
            e.measurements,
            e.keep,
            e.reject,
            e.unclassified
        );
    }
}

fn run_classification(args: RunArgs, def: MissionDef, text: String) -> anyhow::Result<ExitCode> {
    let wait = wait_of(args.runner.wait)?;
    if let Some(w) = &args.world {
        World::load(w).with_context(|| format!("world {}", w.display()))?;
    }
    let opts = classification_opts(&args.runner)?;
    let dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| default_run_dir(&def.name));
    block_on(async move {
        let session = Session::open(&args.conn).await?;
        let lock = args.runner.lock_step.then_some(true);
        let state = bandit::new_state(&session.fleet, &def, wait, lock).await?;
        let mut meta = RunMeta::new(bandit::KIND, unix_ms());
        meta.mission_path = Some(args.mission.display().to_string());
        meta.connections = args.conn.connect.iter().map(|c| c.to_string()).collect();
        if let Some(w) = &args.world {
            let abs = std::fs::canonicalize(w).unwrap_or_else(|_| w.clone());
            meta.extra = serde_json::json!({"world": abs.display().to_string()});
        }
        let run_dir = RunDir::create(&dir, meta, Some(&text))
            .with_context(|| format!("cannot create the run directory {}", dir.display()))?;
        println!(
            "run directory {} — {}: {} candidate cells, {} drone(s), {} station(s), {:?} separation",
            dir.display(),
            state.mission,
            state.bandit.len(),
            state.drones.len(),
            state.stations.len(),
            state.params.separation
        );
        let label = format!("LIVE {}", meta_label(&args.conn.connect));
        let result = fly_classification(
            &session.fleet,
            run_dir,
            state,
            opts,
            args.runner.headless,
            label,
        )
        .await;
        session.close().await?;
        result
    })?
}

/// Fly a spatial-classification run headless (progress lines, then the report), or in the
/// terminal UI when there is a terminal and `headless` is not asked for.
pub async fn fly_classification(
    fleet: &crate::fleet::FleetHandle,
    run_dir: RunDir,
    state: ClassificationState,
    opts: bandit::RunOptions,
    headless: bool,
    label: String,
) -> anyhow::Result<ExitCode> {
    if headless || !crate::cli::tui::interactive() {
        let (state, path) = drive_classification(fleet, run_dir, state, opts, true).await?;
        return finish_classification(&state, &path);
    }
    let path = run_dir.path().to_path_buf();
    let world = run_world(&run_dir, None).ok().flatten();
    let mission = crate::app::session::ClassificationRun {
        run_dir,
        state,
        auto_start: true,
        options: opts,
        on_finish: Some(Box::new(move |rd, st| {
            if let Err(e) = write_classification_exports(rd, st, world.as_ref()) {
                tracing::warn!("exports: {e:#}");
            }
        })),
    };
    fly_in_ui(fleet, mission.into(), &path, label).await
}

fn finish_classification(state: &ClassificationState, path: &Path) -> anyhow::Result<ExitCode> {
    let run_dir = RunDir::open(path)?;
    let world = run_world(&run_dir, None)?;
    let exports = write_classification_exports(&run_dir, state, world.as_ref())?;
    let r = bandit_report::report(state, world_truth(world.as_ref()).as_deref());
    println!("run finished: {}", path.display());
    print_classification(&r);
    for e in exports {
        println!("  wrote {}", e.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn resume_classification(args: ResumeArgs, run_dir: RunDir) -> anyhow::Result<ExitCode> {
    let state: ClassificationState = run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", args.run_dir.display()))?;
    if state.is_finished() {
        println!("the run is already finished");
        return Ok(ExitCode::SUCCESS);
    }
    let connect = if args.connect.is_empty() {
        run_dir
            .meta()
            .connections
            .iter()
            .map(|c| {
                c.parse::<ConnSpec>()
                    .map_err(|e| anyhow::anyhow!("{c}: {e}"))
            })
            .collect::<anyhow::Result<Vec<_>>>()?
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
    let wait = wait_of(args.runner.wait)?;
    let opts = classification_opts(&args.runner)?;
    block_on(async move {
        let session = Session::open(&conn).await?;
        for sysid in state.sysids() {
            session.vehicle(sysid, wait).await?;
            session
                .fleet
                .wait_until(sysid, wait, |v| v.position.is_some())
                .await
                .map_err(|_| anyhow::anyhow!("vehicle {sysid} reports no position"))?;
        }
        println!(
            "resuming {} (epoch {}, {} measurements so far, keep {}, reject {}, unclassified {})",
            args.run_dir.display(),
            state.bandit.epoch,
            state.measurements,
            state.bandit.keep().len(),
            state.bandit.reject().len(),
            state.bandit.unclassified().len()
        );
        let label = format!("LIVE {}", meta_label(&conn.connect));
        let result = fly_classification(
            &session.fleet,
            run_dir,
            state,
            opts,
            args.runner.headless,
            label,
        )
        .await;
        session.close().await?;
        result
    })?
}

fn load_classification(dir: &Path) -> anyhow::Result<(RunDir, ClassificationState)> {
    let run_dir =
        RunDir::open(dir).with_context(|| format!("cannot open the run {}", dir.display()))?;
    let state: ClassificationState = run_dir
        .load_state()?
        .with_context(|| format!("{} has no saved state yet", dir.display()))?;
    Ok((run_dir, state))
}

fn report_classification(args: ReportArgs) -> anyhow::Result<ExitCode> {
    let (run_dir, state) = load_classification(&args.run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let r = bandit_report::report(&state, world_truth(world.as_ref()).as_deref());
    let events = run_dir.read_events::<BanditEvent>()?;
    if args.json {
        let mut v = serde_json::to_value(&r)?;
        if let Some(o) = v.as_object_mut() {
            o.insert(
                "journal_records".into(),
                serde_json::json!(events.events.len()),
            );
            let logged = events
                .events
                .iter()
                .filter(|e| matches!(&e.event, BanditEvent::Measurement(m) if m.counted))
                .count();
            o.insert("journal_measurements".into(), serde_json::json!(logged));
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("run {} — mission {}", args.run_dir.display(), r.mission);
    print_classification(&r);
    Ok(ExitCode::SUCCESS)
}

fn export_classification(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let (run_dir, state) = load_classification(&args.run_dir)?;
    let world = run_world(&run_dir, args.world.as_deref())?;
    let truth = world_truth(world.as_ref());
    let (bytes, name) = match args.format {
        ExportFormat::Png => (
            bandit_report::progress_png(&state, truth.as_deref(), 900, 560)?,
            "progress.png",
        ),
        ExportFormat::Geojson => (
            serde_json::to_vec_pretty(&bandit_report::geojson(&state))?,
            "cells.geojson",
        ),
        ExportFormat::Kml => (bandit_report::kml(&state).into_bytes(), "cells.kml"),
    };
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
