//! `fleetmap run MISSION.toml --connect CONN`, `fleetmap resume RUN_DIR`,
//! `fleetmap report RUN_DIR [--json]`, `fleetmap export RUN_DIR --format geojson|kml|png`.
//!
//! Both mission kinds: runway mapping ([`crate::kinds::runway`]) and spatial classification
//! ([`crate::kinds::bandit`]), each a [`crate::app::kind::RunKind`]: the commands are written
//! once (`flow`) and dispatch on the kind once — `run` on the mission file's, `resume`,
//! `report` and `export` on the one in `run.json`.
//!
//! A run lives in its directory (`src/store`): `run.json` remembers the kind, the mission
//! file and the connection strings, so `fleetmap resume RUN_DIR` needs nothing else after a
//! battery swap or a crashed laptop. `--world FILE` (a simulated world) is remembered too:
//! the report then scores the map against its ground truth.

mod dir;
pub(crate) mod flow;

use crate::app::kind::{self, RunKind, RunSettings};
use crate::cli::vehicles::ConnectArgs;
use crate::kinds::{self, KindVisitor};
use crate::launch::NewRun;
use crate::store::RunDir;
use anyhow::Context as _;
use clap::{Args, ValueEnum};
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_io::link::ConnSpec;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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
    pub(crate) lock_step: bool,
    /// Spatial classification: HiGHS time limit per integer-program solve, seconds.
    #[arg(long, value_name = "SECONDS")]
    pub(crate) plan_time_limit: Option<f64>,
    /// Start even when the fleet check before take-off finds a blocker (a duplicate system
    /// id, an autopilot that obeys another ground station, a drone without a camera): the
    /// findings are still printed (docs/fleet-check.md).
    #[arg(long)]
    pub ignore_check: bool,
}

impl RunnerArgs {
    /// The run settings these options choose.
    pub fn settings(&self) -> RunSettings {
        RunSettings {
            auto_resume: self.auto_resume,
            patience: self.patience,
            sharing: self.sharing.into(),
            lock_step: self.lock_step.then_some(true),
            plan_time_limit_s: self.plan_time_limit,
            roi_epoch_unix_ms: None,
            on_blocker: crate::app::preflight::OnBlocker::unless_ignored(
                self.ignore_check,
                crate::app::preflight::OnBlocker::Stop,
            ),
        }
    }
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
    /// Answer the ArduPilot vehicles' terrain requests (TERRAIN_REQUEST) from the SRTM tiles
    /// in this folder (`N47E008.hgt` or `.hgt.zip`; docs/terrain.md).
    #[arg(long, value_name = "DIR")]
    pub terrain: Option<PathBuf>,
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
    /// What every vehicle's link carries (as for `fleetmap run`; default: the run's mission
    /// file's `link`).
    #[arg(long, value_name = "LINK")]
    pub link: Option<fleetmap_core::budget::LinkBudget>,
    /// Answer the ArduPilot vehicles' terrain requests from the SRTM tiles in this folder,
    /// as `fleetmap run --terrain` (the run does not remember it: give it again).
    #[arg(long, value_name = "DIR")]
    pub terrain: Option<PathBuf>,
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

impl From<ExportFormat> for kind::ExportFormat {
    fn from(f: ExportFormat) -> kind::ExportFormat {
        match f {
            ExportFormat::Geojson => kind::ExportFormat::Geojson,
            ExportFormat::Kml => kind::ExportFormat::Kml,
            ExportFormat::Png => kind::ExportFormat::Png,
        }
    }
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

/// `fleetmap run`.
pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    let mut new = NewRun::from_file(&args.mission)?;
    new.run_dir = args.run_dir.clone();
    if let Some(w) = &args.world {
        new = new.with_world_file(w)?;
    }
    struct Run(RunArgs, NewRun);
    impl KindVisitor for Run {
        type Output = anyhow::Result<ExitCode>;
        fn visit<K: RunKind>(self) -> Self::Output {
            flow::start::<K>(self.0, self.1)
        }
    }
    let def = new.def.clone();
    kinds::of_mission(&def, Run(args, new))?
}

/// Open the run directory at `dir` and call `v` with its kind.
fn with_run<V: KindVisitor<Output = anyhow::Result<ExitCode>>>(
    dir: &Path,
    v: impl FnOnce(RunDir) -> V,
) -> anyhow::Result<ExitCode> {
    let run_dir =
        RunDir::open(dir).with_context(|| format!("cannot open the run {}", dir.display()))?;
    let kind = run_dir.meta().kind.clone();
    kinds::by_name(&kind, v(run_dir)).with_context(|| format!("{}", dir.display()))?
}

/// `fleetmap resume`.
pub fn resume(args: ResumeArgs) -> anyhow::Result<ExitCode> {
    struct Resume(ResumeArgs, RunDir);
    impl KindVisitor for Resume {
        type Output = anyhow::Result<ExitCode>;
        fn visit<K: RunKind>(self) -> Self::Output {
            let Resume(args, run_dir) = self;
            if let Some(t) = run_dir.torn_tail_at_open() {
                println!(
                    "note: the journal's last record was cut short by the crash ({} bytes at line {}); it was never acknowledged and is dropped",
                    t.len, t.line
                );
            }
            flow::resume::<K>(args, run_dir)
        }
    }
    let dir = args.run_dir.clone();
    with_run(&dir, |rd| Resume(args, rd))
}

/// `fleetmap report`.
pub(crate) fn report_cmd(args: ReportArgs) -> anyhow::Result<ExitCode> {
    struct Report(ReportArgs, RunDir);
    impl KindVisitor for Report {
        type Output = anyhow::Result<ExitCode>;
        fn visit<K: RunKind>(self) -> Self::Output {
            flow::report::<K>(self.0, self.1)
        }
    }
    let dir = args.run_dir.clone();
    with_run(&dir, |rd| Report(args, rd))
}

/// `fleetmap export`.
pub fn export(args: ExportArgs) -> anyhow::Result<ExitCode> {
    struct Export(ExportArgs, RunDir);
    impl KindVisitor for Export {
        type Output = anyhow::Result<ExitCode>;
        fn visit<K: RunKind>(self) -> Self::Output {
            flow::export::<K>(self.0, self.1)
        }
    }
    let dir = args.run_dir.clone();
    with_run(&dir, |rd| Export(args, rd))
}
