//! One mission kind: everything `fleetmap run`, `resume`, `report`, `export`, the TUI session
//! and the demo need of a runner, so that each of them is written once for every mission.
//!
//! Each kind is a folder of `src/kinds/` (its runner, its `RunKind`, its panes) registered in
//! [`crate::kinds`]. A run directory remembers its kind (`run.json`'s `kind`, the
//! kind's [`RunKind::KIND`]); the commands dispatch on it once, through the registry.

use crate::app::command::{Command, CommandError, Target};
use crate::app::error::RunError;
use crate::app::run::Progress;
use crate::fleet::FleetHandle;
use crate::panes::{KindLook, Panes, RunInfo, Sample};
use crate::store::RunDir;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;
use fleetmap_io::watch;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::future::Future;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::mpsc;

/// How a run ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The mission is complete and every robot landed.
    Finished,
    /// Robots are on the ground waiting for the operator (runway mapping: battery swaps
    /// without `auto_resume`, a faulty camera, a drone that cannot take off): run
    /// `fleetmap resume` once each vehicle's task is done.
    WaitingForOperator {
        /// The vehicles waiting, in system-id order, each with what it waits for.
        waiting: Vec<(u8, OperatorTask)>,
    },
}

impl Outcome {
    /// The vehicles waiting for the operator (none when the run finished).
    pub fn waiting_sysids(&self) -> Vec<u8> {
        match self {
            Outcome::Finished => Vec::new(),
            Outcome::WaitingForOperator { waiting } => waiting.iter().map(|(s, _)| *s).collect(),
        }
    }
}

/// What a vehicle on the ground waits for a person to do before `fleetmap resume`: a camera
/// fault is not a battery swap, and the operator is told which is which.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OperatorTask {
    /// It landed for a battery swap.
    BatterySwap,
    /// Its camera was declared faulty (why): fix the camera (a fresh battery does not).
    CameraFix(String),
    /// It is out of the run for what a person must fix (the fix, or the reason when no fix
    /// is known): a drone that could not take off, arm or change mode.
    Fix(String),
}

/// One line per task of the vehicles waiting for the operator, naming each vehicle:
/// "vehicle(s) 1, 3 wait for a battery swap", "vehicle 2 waits for its camera fixed (…)".
pub fn waiting_lines(waiting: &[(u8, OperatorTask)]) -> Vec<String> {
    let mut lines: Vec<(OperatorTask, Vec<u8>)> = Vec::new();
    for (sysid, task) in waiting {
        match lines.iter_mut().find(|(t, _)| t == task) {
            Some((_, ids)) => ids.push(*sysid),
            None => lines.push((task.clone(), vec![*sysid])),
        }
    }
    lines
        .into_iter()
        .map(|(task, ids)| {
            let list: Vec<String> = ids.iter().map(u8::to_string).collect();
            if ids.len() == 1 {
                format!("vehicle {} waits for {task}", list[0])
            } else {
                format!("vehicles {} wait for {task}", list.join(", "))
            }
        })
        .collect()
}

impl std::fmt::Display for OperatorTask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OperatorTask::BatterySwap => f.write_str("a battery swap"),
            OperatorTask::CameraFix(why) => write!(f, "its camera fixed ({why})"),
            OperatorTask::Fix(fix) => write!(f, "a fix: {fix}"),
        }
    }
}

/// What `fleetmap export` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// GeoJSON FeatureCollection (QGIS).
    Geojson,
    /// KML (Google Earth).
    Kml,
    /// PNG: the grid (runway mapping, the runway paper's Fig. 10) or the classification
    /// progress per epoch (spatial classification, the bandit paper's Fig. 4).
    Png,
}

/// What the TUI session gives a run it flies ([`RunKind::fly_attached`]).
pub struct Attached<K: RunKind + ?Sized> {
    /// Progress lines (the session's log).
    pub progress: mpsc::UnboundedSender<Progress>,
    /// The state after every change (the panes).
    pub view: watch::Sender<Arc<K::State>>,
    /// The operator's mission-level commands.
    pub operator: mpsc::UnboundedReceiver<K::Operator>,
}

/// A mission-level command's reply ([`RunKind::command`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CommandReply {
    /// What to tell the operator.
    pub text: String,
    /// The run is now paused (`Some(true)`) or running again (`Some(false)`).
    pub paused: Option<bool>,
}

impl CommandReply {
    /// A reply that does not change whether the run is paused.
    pub fn text(text: impl Into<String>) -> CommandReply {
        CommandReply {
            text: text.into(),
            paused: None,
        }
    }

    /// A reply to a pause (`true`) or resume (`false`).
    pub fn paused(paused: bool, text: impl Into<String>) -> CommandReply {
        CommandReply {
            text: text.into(),
            paused: Some(paused),
        }
    }
}

/// The operator's choices for a run (`fleetmap run` / `resume` options, the demo's, the TUI's).
#[derive(Clone, Debug)]
pub struct RunSettings {
    /// Runway mapping: take off again by itself once a vehicle reports a fresh battery.
    pub auto_resume: bool,
    /// Scale of every flight timeout (2 = twice as patient).
    pub patience: f64,
    /// Runway mapping: how the robots share the DFS vertex states.
    pub sharing: fleetmap_core::explore::dfs::Sharing,
    /// Spatial classification: keep the drones in step (the bandit paper's 7e) even when the
    /// mission separates them by altitude (`None`: as the mission implies).
    pub(crate) lock_step: Option<bool>,
    /// Spatial classification: HiGHS time limit per integer-program solve, seconds.
    pub plan_time_limit_s: Option<f64>,
    /// Runway mapping with a moving region: when the region was where the mission's world
    /// draws it, milliseconds since the Unix epoch (the demo's simulator start; `None`: the
    /// run's start).
    pub roi_epoch_unix_ms: Option<u64>,
    /// What a blocker of the fleet check (`app::preflight`) does: stop the start, nothing
    /// (`--ignore-check`), or wait for the operator's START in the UI.
    pub on_blocker: crate::app::preflight::OnBlocker,
}

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            auto_resume: false,
            patience: 1.0,
            sharing: fleetmap_core::explore::dfs::Sharing::Gcs,
            lock_step: None,
            plan_time_limit_s: None,
            roi_epoch_unix_ms: None,
            on_blocker: crate::app::preflight::OnBlocker::Stop,
        }
    }
}

/// A mission kind (see the module docs). Its methods are the parts in which the two missions
/// differ; the generic commands (`crate::launch`, `cli::run`) do the rest once.
pub trait RunKind: Send + Sync + 'static {
    /// The `kind` in `run.json`.
    const KIND: &'static str;
    /// The exports written at the end of a run, in this order.
    const EXPORTS: [ExportFormat; 3];
    /// How the kind's panes look, whatever the state (its map's legend, its name on the
    /// mission pane, the name of its built-in sample).
    const LOOK: KindLook;
    /// The state saved in `state.json` after every step.
    type State: Clone + Serialize + DeserializeOwned + Send + Sync + 'static;
    /// The runner's options.
    type Options: Send + 'static;
    /// A record of the run's journal (`events.jsonl`).
    type Event: DeserializeOwned + Send + 'static;
    /// What `fleetmap report` shows (its JSON form is `--json`).
    type Report: Serialize + Send + 'static;
    /// A mission-level command of the operator, as the runner takes it (the TUI session).
    type Operator: Send + 'static;

    /// The mission's name.
    fn mission(state: &Self::State) -> &str;
    /// Whether nothing is left to do.
    fn is_finished(state: &Self::State) -> bool;
    /// The vehicles the run flies.
    fn sysids(state: &Self::State) -> Vec<u8>;

    /// The runner's options for `settings` (checked: a clear error for a bad value).
    fn options(settings: &RunSettings) -> Result<Self::Options, RunError>;
    /// A new run's state for `def`, once its vehicles are heard on `fleet` (waits up to `wait`
    /// for each).
    fn new_state(
        fleet: &FleetHandle,
        def: &MissionDef,
        settings: &RunSettings,
        wait: Duration,
    ) -> impl Future<Output = Result<Self::State, RunError>> + Send;
    /// What to tell the operator about a new run in `dir`.
    fn started_line(dir: &std::path::Path, state: &Self::State) -> String;
    /// What `fleetmap check` prints of this kind's own section of the mission file `def`,
    /// a line each, label first (after the lines every kind shares).
    fn summary_lines(def: &MissionDef) -> Vec<String>;
    /// Make a saved state ready to fly again: wait up to `wait` for its vehicles, and (unless
    /// the run resumes by itself) take `fleetmap resume` as the operator's "battery swapped".
    /// Returns what to tell the operator.
    fn prepare_resume(
        fleet: &FleetHandle,
        state: &mut Self::State,
        settings: &RunSettings,
        wait: Duration,
    ) -> impl Future<Output = Result<String, RunError>> + Send;

    /// Fly the run to its end (or until the operator is needed), sending progress to
    /// `progress`. Returns how it ended and the state it ended in.
    fn fly(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: Self::State,
        options: Self::Options,
        progress: Option<mpsc::UnboundedSender<Progress>>,
    ) -> impl Future<Output = Result<(Outcome, Self::State), RunError>> + Send;
    /// Fly the run in the TUI session (`crate::tui::session`): like [`RunKind::fly`], with
    /// the state published after every change and the operator's mission-level commands
    /// (those [`RunKind::command`] sent) taken as they come.
    fn fly_attached(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: Self::State,
        options: Self::Options,
        attached: Attached<Self>,
    ) -> impl Future<Output = Result<(Outcome, Self::State), RunError>> + Send;
    /// What the operator's `command` to `target` (the vehicles `targets`) means for a
    /// running run of this kind: a mission-level command sent on `operator` and the reply,
    /// a refusal, or `None` when the command goes to the vehicles themselves.
    fn command(
        command: Command,
        target: Target,
        targets: &[u8],
        operator: &mpsc::UnboundedSender<Self::Operator>,
    ) -> Option<Result<CommandReply, CommandError>>;
    /// The TUI's panes of a run in `state` (`info`: what the session knows of the run).
    fn panes(state: &Self::State, info: &RunInfo) -> Panes;
    /// The built-in sample of `fleetmap tui --sample` ([`KindLook::sample`]); `vehicles`:
    /// the drones of an animated one (1–20).
    fn sample(vehicles: usize) -> Sample;

    /// The report, scored against `world`'s ground truth when there is one.
    fn report(state: &Self::State, world: Option<&World>) -> Result<Self::Report, RunError>;
    /// Figures of the journal for the JSON report (`journal_records`, …).
    fn journal_figures(events: &[Self::Event]) -> serde_json::Map<String, serde_json::Value>;
    /// The report as text lines (`fleetmap report`, the end of a headless run).
    fn report_lines(report: &Self::Report) -> Vec<String>;
    /// One export: the file name under `exports/` and its bytes.
    fn export(
        state: &Self::State,
        world: Option<&World>,
        format: ExportFormat,
    ) -> Result<(&'static str, Vec<u8>), RunError>;
}

/// Write every export of a finished run into its `exports/` (file I/O: call it off the
/// runtime's workers). Returns the files written.
pub(crate) fn write_exports<K: RunKind>(
    run_dir: &RunDir,
    state: &K::State,
    world: Option<&World>,
) -> Result<Vec<PathBuf>, RunError> {
    K::EXPORTS
        .iter()
        .map(|f| {
            let (name, bytes) = K::export(state, world, *f)?;
            Ok(run_dir.write_export(name, &bytes)?)
        })
        .collect()
}

/// The JSON form of the report: the report's fields and the journal's figures.
pub fn report_json<K: RunKind>(
    report: &K::Report,
    events: &[K::Event],
) -> Result<serde_json::Value, RunError> {
    let mut v = serde_json::to_value(report)?;
    if let Some(o) = v.as_object_mut() {
        o.extend(K::journal_figures(events));
    }
    Ok(v)
}

/// Encode `img` as PNG bytes.
pub(crate) fn png_bytes(img: &image::RgbImage) -> Result<Vec<u8>, RunError> {
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)?;
    Ok(buf.into_inner())
}

/// `n` and the word: `1 obstacle`, `3 obstacles`.
pub(crate) fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}
