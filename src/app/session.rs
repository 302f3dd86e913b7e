//! The live terminal session (async shell): the operator's UI on a real fleet, with or
//! without a run attached (runway mapping or spatial classification).
//!
//! Three tasks around the UI ([`crate::tui::run`]):
//! * the **model producer** turns fleet snapshots, the run's state (a `watch` from the
//!   runner) and the log into [`crate::tui::Model`]s ten times a second
//!   ([`crate::tui::REFRESH`], [`crate::tui::live::build_model`]), and passes on those that
//!   differ from the previous one; the fleet is asked to publish its snapshots at least as
//!   often (in wall time), so that each frame shows fresh telemetry;
//! * the **command executor** carries out the operator's commands — mission-level ones
//!   through the runner's [`Operator`] channel (pause, resume, recall, land, battery
//!   swapped), vehicle-level ones through the fleet (arm, disarm, RTL, land, hold) — and
//!   answers each with a [`JobResult`];
//! * the **runner** ([`crate::app::runway::run`] or [`crate::app::bandit::run`]) once the
//!   operator starts the mission (or at once with `auto_start`).
//!
//! A spatial-classification run has no per-vehicle mission commands: its PAUSE holds the
//! next sortie (the drones in the air finish theirs and land on their stations), and RTL,
//! LAND, ARM and DISARM go straight to the vehicle (the run then stops at the next
//! rendezvous it misses; `fleetmap resume` re-plans from where the team is).
//!
//! The UI never waits on any of them: it only reads the latest model and queues commands.

use crate::app::bandit;
use crate::app::flight;
use crate::app::images;
use crate::app::run::Progress;
use crate::app::runway::{self, Operator, Outcome, RunOptions};
use crate::explore::mapping::MappingState;
use crate::fleet::FleetHandle;
use crate::planner::sortie::ClassificationState;
use crate::store::RunDir;
use crate::tui::live::{LiveLog, RunInfo, RunView, build_model};
use crate::tui::{
    App, Command, CommandRequest, JobResult, Model, REFRESH, Severity, ShellIo, ShellOptions,
    Target, UiConfig,
};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::{mpsc, watch};

/// What to do with a finished run's final state `S` (write its exports).
pub type OnFinish<S> = Box<dyn FnOnce(&RunDir, &S) + Send>;

/// A run the session drives.
pub struct MappingRun {
    /// Its directory.
    pub run_dir: RunDir,
    /// Its state (new or loaded).
    pub state: MappingState,
    /// Start at once instead of waiting for the operator's START.
    pub auto_start: bool,
    /// Options of the runner (operator, progress and view are set by the session).
    pub options: RunOptions,
    /// Called with the final state when the run finishes (exports, reports).
    pub on_finish: Option<OnFinish<MappingState>>,
}

/// A spatial-classification run the session drives.
pub struct ClassificationRun {
    /// Its directory.
    pub run_dir: RunDir,
    /// Its state (new or loaded).
    pub state: ClassificationState,
    /// Start at once instead of waiting for the operator's START.
    pub auto_start: bool,
    /// Options of the runner (progress, view and pause are set by the session).
    pub options: bandit::RunOptions,
    /// Called with the final state when the run finishes.
    pub on_finish: Option<OnFinish<ClassificationState>>,
}

/// The run attached to a session.
pub enum SessionRun {
    /// Runway mapping.
    Mapping(Box<MappingRun>),
    /// Spatial classification.
    Classification(Box<ClassificationRun>),
}

impl From<MappingRun> for SessionRun {
    fn from(m: MappingRun) -> Self {
        SessionRun::Mapping(Box::new(m))
    }
}

impl From<ClassificationRun> for SessionRun {
    fn from(m: ClassificationRun) -> Self {
        SessionRun::Classification(Box::new(m))
    }
}

impl SessionRun {
    fn name(&self) -> String {
        match self {
            SessionRun::Mapping(m) => m.state.mission.clone(),
            SessionRun::Classification(m) => m.state.mission.clone(),
        }
    }

    fn auto_start(&self) -> bool {
        match self {
            SessionRun::Mapping(m) => m.auto_start,
            SessionRun::Classification(m) => m.auto_start,
        }
    }

    fn view(&self) -> RunState {
        match self {
            SessionRun::Mapping(m) => RunState::Mapping(Arc::new(m.state.clone())),
            SessionRun::Classification(m) => RunState::Classification(Arc::new(m.state.clone())),
        }
    }
}

/// The latest state of the attached run (what the panes show).
#[derive(Clone)]
enum RunState {
    Mapping(Arc<MappingState>),
    Classification(Arc<ClassificationState>),
}

impl RunState {
    fn view(&self) -> RunView<'_> {
        match self {
            RunState::Mapping(s) => RunView::Mapping(s),
            RunState::Classification(s) => RunView::Classification(s),
        }
    }
}

/// Settings of the UI.
pub struct SessionConfig {
    /// Title-bar source text ("LIVE udpin:…", "DEMO (simulated)").
    pub label: String,
    /// Keys and thresholds.
    pub ui: UiConfig,
    /// Where the log file is (shown in the help).
    pub log_file: Option<String>,
}

/// How the session ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SessionEnd {
    /// The operator quit; the run (if any) had not finished (its state is saved).
    Quit {
        /// Whether a run had finished.
        finished: bool,
    },
}

struct Shared {
    log: Mutex<LiveLog>,
    info: Mutex<RunInfo>,
    view: watch::Receiver<Option<RunState>>,
    finished: Mutex<bool>,
}

/// Every `period` (wall time), a [`Model`] from the fleet's latest snapshot, the run's state
/// and the log, published on the returned channel when it differs from the previous one
/// (an unchanged model wakes nobody). Ends when the receiver is dropped.
fn spawn_model_producer(
    fleet: FleetHandle,
    shared: Arc<Shared>,
    period: Duration,
) -> (tokio::task::JoinHandle<()>, watch::Receiver<Model>) {
    let (snap_tx, snap_rx) = watch::channel(Model::default());
    let task = tokio::spawn(async move {
        let mut tick = tokio::time::interval(period);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        loop {
            tick.tick().await;
            let snap = fleet.snapshot();
            let view = shared.view.borrow().clone();
            let info = shared.info.lock().map(|i| i.clone()).unwrap_or_default();
            let model = {
                let Ok(mut log) = shared.log.lock() else {
                    return;
                };
                log.absorb(&snap);
                let mut m = build_model(&snap, view.as_ref().map(|s| (s.view(), &info)), &log);
                m.sim_speed = fleet.clock().simulator().and_then(|s| s.achieved());
                m
            };
            if snap_tx.is_closed() {
                return;
            }
            snap_tx.send_if_modified(|m| {
                if *m == model {
                    false
                } else {
                    *m = model;
                    true
                }
            });
        }
    });
    (task, snap_rx)
}

/// The fleet snapshot period (on the fleet's clock) that gives the UI a fresh snapshot for
/// every frame: [`REFRESH`] of wall time, or the fleet's own period when that is shorter.
fn ui_snapshot_period(fleet: &FleetHandle) -> Duration {
    let speedup = fleet.clock().speedup();
    let wall = if speedup.is_finite() && speedup > 0.0 {
        REFRESH.mul_f64(speedup.min(1e3))
    } else {
        REFRESH
    };
    wall.min(fleet.config().snapshot_period)
}

/// Run the UI on `fleet` until the operator quits.
pub async fn run(
    fleet: FleetHandle,
    mission: Option<SessionRun>,
    cfg: SessionConfig,
) -> anyhow::Result<SessionEnd> {
    if let Err(e) = fleet.set_snapshot_period(ui_snapshot_period(&fleet)).await {
        tracing::warn!("the fleet did not take the UI's snapshot period: {e}");
    }
    let (view_tx, view_rx) = watch::channel::<Option<RunState>>(None);
    let name = mission.as_ref().map(SessionRun::name).unwrap_or_default();
    let shared = Arc::new(Shared {
        log: Mutex::new(LiveLog::default()),
        info: Mutex::new(RunInfo {
            name,
            ..RunInfo::default()
        }),
        view: view_rx,
        finished: Mutex::new(false),
    });
    let (op_tx, op_rx) = mpsc::unbounded_channel::<Operator>();
    let (pause_tx, pause_rx) = watch::channel(false);
    let (start_tx, start_rx) = tokio::sync::oneshot::channel::<()>();
    let mut controls = Controls {
        kind: mission.as_ref().map(|m| match m {
            SessionRun::Mapping(_) => AttachedKind::Mapping,
            SessionRun::Classification(_) => AttachedKind::Classification,
        }),
        start: Some(start_tx),
        operator: op_tx,
        pause: pause_tx,
    };

    // The runner.
    let runner = mission.map(|m| {
        let _ = view_tx.send(Some(m.view()));
        if m.auto_start()
            && let Some(tx) = controls.start.take()
        {
            let _ = tx.send(());
        }
        let fleet = fleet.clone();
        let shared = shared.clone();
        let channels = RunChannels {
            view: view_tx,
            operator: op_rx,
            pause: pause_rx,
        };
        tokio::spawn(async move {
            if start_rx.await.is_err() {
                return;
            }
            if let Ok(mut i) = shared.info.lock() {
                i.started = true;
            }
            let (ptx, mut prx) = mpsc::unbounded_channel::<Progress>();
            let logger = {
                let shared = shared.clone();
                let fleet = fleet.clone();
                tokio::spawn(async move {
                    while let Some(p) = prx.recv().await {
                        if let Ok(mut l) = shared.log.lock() {
                            l.push(fleet.clock().now(), p.severity, p.sysid, p.text);
                        }
                    }
                })
            };
            let (result, path, relay) = drive_run(m, fleet.clone(), ptx, channels).await;
            log_end(&shared, fleet.clock().now(), result, &path);
            tokio::time::sleep(Duration::from_millis(300)).await;
            logger.abort();
            relay.abort();
        })
    });

    // The model producer.
    let (producer, snap_rx) = spawn_model_producer(fleet.clone(), shared.clone(), REFRESH);

    // The command executor.
    let (cmd_tx, mut cmd_rx) = mpsc::channel::<CommandRequest>(32);
    let (result_tx, result_rx) = mpsc::channel::<JobResult>(32);
    let executor = {
        let fleet = fleet.clone();
        let shared = shared.clone();
        tokio::spawn(async move {
            while let Some(req) = cmd_rx.recv().await {
                let outcome = execute(&req, &mut controls, &fleet, &shared).await;
                if result_tx
                    .send(JobResult {
                        id: req.id,
                        outcome,
                    })
                    .await
                    .is_err()
                {
                    return;
                }
            }
        })
    };

    let mut app = App::new(cfg.ui, cfg.label);
    app.log_file = cfg.log_file;
    let io = ShellIo {
        snapshots: snap_rx,
        job_results: result_rx,
        commands: cmd_tx,
    };
    // The UI's own timers (confirmation timeouts, stale data) run on the wall clock, also
    // when the fleet's clock runs faster (the demo).
    let options = ShellOptions {
        tick: REFRESH,
        clock: crate::clock::MonotonicClock::new(),
    };
    let result = crate::tui::run(app, io, options).await;
    producer.abort();
    executor.abort();
    let finished = shared.finished.lock().map(|f| *f).unwrap_or(false);
    if let Some(r) = runner
        && !finished
    {
        r.abort();
    }
    result?;
    Ok(SessionEnd::Quit { finished })
}

/// The kind of run attached to the session (what its mission-level commands mean).
#[derive(Clone, Copy, PartialEq, Eq)]
enum AttachedKind {
    Mapping,
    Classification,
}

/// What the command executor holds of the attached run.
struct Controls {
    /// The attached run's kind (`None`: the session has no run).
    kind: Option<AttachedKind>,
    /// The operator's START, until it is given.
    start: Option<tokio::sync::oneshot::Sender<()>>,
    /// Mission-level commands to the runway runner.
    operator: mpsc::UnboundedSender<Operator>,
    /// The spatial-classification runner's pause.
    pause: watch::Sender<bool>,
}

/// What the runner task takes from the session: where to publish the view, and the
/// operator's channels.
struct RunChannels {
    view: watch::Sender<Option<RunState>>,
    operator: mpsc::UnboundedReceiver<Operator>,
    pause: watch::Receiver<bool>,
}

/// Fly the attached run to its end (its final state goes to `on_finish`, off the runtime's
/// workers). Returns `Ok(None)` when it finished, `Ok(Some(why))` when it waits for the
/// operator, its run directory, and the task relaying its states to the view.
async fn drive_run(
    m: SessionRun,
    fleet: FleetHandle,
    progress: mpsc::UnboundedSender<Progress>,
    channels: RunChannels,
) -> (
    anyhow::Result<Option<String>>,
    std::path::PathBuf,
    tokio::task::JoinHandle<()>,
) {
    let RunChannels {
        view: view_tx,
        operator,
        pause,
    } = channels;
    match m {
        SessionRun::Mapping(m) => {
            let m = *m;
            let hub = images::spawn(&fleet);
            let (vtx, mut vrx) = watch::channel(Arc::new(m.state.clone()));
            let relay = tokio::spawn(async move {
                while vrx.changed().await.is_ok() {
                    let s = vrx.borrow_and_update().clone();
                    let _ = view_tx.send(Some(RunState::Mapping(s)));
                }
            });
            let path = m.run_dir.path().to_path_buf();
            let opts = RunOptions {
                operator: Some(operator),
                progress: Some(progress),
                view: Some(vtx),
                ..m.options
            };
            let r = runway::run(fleet.clone(), &hub, m.run_dir, m.state, opts).await;
            let r = match r {
                Ok(Outcome::Finished) => {
                    // The outputs are file I/O: off the runtime workers.
                    let at = path.clone();
                    let on_finish = m.on_finish;
                    let _ = runway::cpu(move || {
                        if let (Some(f), Ok(rd)) = (on_finish, RunDir::open(&at))
                            && let Ok(Some(state)) = rd.load_state::<MappingState>()
                        {
                            f(&rd, &state);
                        }
                    })
                    .await;
                    Ok(None)
                }
                Ok(Outcome::WaitingForOperator { sysids }) => {
                    Ok(Some(format!("vehicles {sysids:?} wait for the operator")))
                }
                Err(e) => Err(e),
            };
            (r, path, relay)
        }
        SessionRun::Classification(m) => {
            let m = *m;
            let (vtx, mut vrx) = watch::channel(Arc::new(m.state.clone()));
            let relay = tokio::spawn(async move {
                while vrx.changed().await.is_ok() {
                    let s = vrx.borrow_and_update().clone();
                    let _ = view_tx.send(Some(RunState::Classification(s)));
                }
            });
            let path = m.run_dir.path().to_path_buf();
            let opts = bandit::RunOptions {
                progress: Some(progress),
                view: Some(vtx),
                pause: Some(pause),
                ..m.options
            };
            let hub = crate::app::images::image_hub(&fleet);
            let r = bandit::run(fleet.clone(), &hub, m.run_dir, m.state, opts).await;
            let r = match r {
                Ok(state) => {
                    // The outputs are file I/O: off the runtime workers.
                    let at = path.clone();
                    let on_finish = m.on_finish;
                    let _ = runway::cpu(move || {
                        if let (Some(f), Ok(rd)) = (on_finish, RunDir::open(&at)) {
                            f(&rd, &state);
                        }
                    })
                    .await;
                    Ok(None)
                }
                Err(e) => Err(e),
            };
            (r, path, relay)
        }
    }
}

/// Tell the operator how the run ended (the log; the title bar for a failure).
fn log_end(
    shared: &Shared,
    now: crate::time::Time,
    result: anyhow::Result<Option<String>>,
    path: &std::path::Path,
) {
    let (severity, line) = match result {
        Ok(None) => {
            if let Ok(mut f) = shared.finished.lock() {
                *f = true;
            }
            (
                Severity::Notice,
                format!(
                    "mission finished: every vehicle landed; results in {}",
                    path.display()
                ),
            )
        }
        Ok(Some(waiting)) => (Severity::Warning, waiting),
        Err(e) => {
            let msg = format!("{e:#}");
            tracing::error!("the run stopped: {msg}");
            if let Ok(mut i) = shared.info.lock() {
                i.failed = Some(msg.clone());
            }
            (
                Severity::Error,
                format!(
                    "the run stopped: {msg} (state saved; `fleetmap resume {}`)",
                    path.display()
                ),
            )
        }
    };
    if let Ok(mut l) = shared.log.lock() {
        l.push(now, severity, None, line);
    }
}

/// Carry out one operator command: mission-level ones through the runner, vehicle-level ones
/// through the fleet. Returns what to tell the operator.
async fn execute(
    req: &CommandRequest,
    controls: &mut Controls,
    fleet: &FleetHandle,
    shared: &Shared,
) -> Result<String, String> {
    let started = shared.info.lock().map(|i| i.started).unwrap_or(false);
    let has_run = controls.kind.is_some();
    let running = has_run && started;
    let classification = controls.kind == Some(AttachedKind::Classification);
    // Runway mapping: mission-level commands go through the runner.
    let mapping = running && !classification;
    let set_paused = |p: bool| {
        if let Ok(mut i) = shared.info.lock() {
            i.paused = p;
        }
    };
    let targets: Vec<u8> = match req.target {
        Target::Vehicle(v) => vec![v],
        Target::All => fleet.snapshot().vehicles.keys().copied().collect(),
    };
    let op = &controls.operator;
    match req.command {
        Command::Start => {
            if !has_run {
                Err("no mission is loaded (start fleetmap with --mission or --resume)".into())
            } else if let Some(tx) = controls.start.take() {
                let _ = tx.send(());
                Ok("mission started".into())
            } else {
                Err("the mission is already running".into())
            }
        }
        Command::Hold if running && classification && matches!(req.target, Target::All) => {
            let _ = controls.pause.send(true);
            set_paused(true);
            Ok(
                "paused: no new sortie starts (drones in the air finish theirs and land on \
                 their stations)"
                    .into(),
            )
        }
        Command::Resume if running && classification => {
            let _ = controls.pause.send(false);
            set_paused(false);
            Ok("mission resumed".into())
        }
        Command::Hold if mapping => {
            let _ = op.send(Operator::Pause);
            set_paused(true);
            Ok("every vehicle holds (the mission is paused)".into())
        }
        Command::Resume if mapping => {
            let _ = op.send(Operator::Resume);
            set_paused(false);
            Ok("mission resumed".into())
        }
        Command::Resume => Err("no mission is running (START it first)".into()),
        Command::Rtl if mapping => {
            for v in &targets {
                let _ = op.send(Operator::Recall(*v));
            }
            Ok(format!(
                "returning home: {targets:?} (their vertices are kept)"
            ))
        }
        Command::Land if mapping => {
            for v in &targets {
                let _ = op.send(Operator::Land(*v));
            }
            Ok(format!("landing: {targets:?} (their vertices are kept)"))
        }
        Command::BatterySwapped => {
            if mapping {
                for v in &targets {
                    let _ = op.send(Operator::BatterySwapped(*v));
                }
                Ok("the vehicle resumes from its vertex".into())
            } else if running {
                Err(
                    "the drones of a spatial-classification run charge on their stations: \
                     there is no battery swap to confirm"
                        .into(),
                )
            } else {
                Err("no mission is running".into())
            }
        }
        cmd => {
            let mut errors = Vec::new();
            for v in &targets {
                let r = match cmd {
                    Command::Hold => flight::hold_here(fleet, *v).await,
                    Command::Rtl => fleet.rtl(*v).await,
                    Command::Land => fleet.land(*v).await,
                    Command::Arm => fleet.arm(*v).await,
                    Command::Disarm => fleet.disarm(*v).await,
                    _ => Ok(()),
                };
                if let Err(e) = r {
                    errors.push(e.to_string());
                }
            }
            if errors.is_empty() {
                Ok("accepted".into())
            } else {
                Err(errors.join("; "))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::MonotonicClock;
    use crate::fleet::FleetConfig;

    fn shared() -> (Arc<Shared>, watch::Sender<Option<RunState>>) {
        let (view_tx, view_rx) = watch::channel(None);
        let shared = Arc::new(Shared {
            log: Mutex::new(LiveLog::default()),
            info: Mutex::new(RunInfo::default()),
            view: view_rx,
            finished: Mutex::new(false),
        });
        (shared, view_tx)
    }

    /// Models received on `rx` until `secs` seconds from now.
    async fn count_models(rx: &mut watch::Receiver<Model>, secs: u64) -> usize {
        let end = tokio::time::Instant::now() + Duration::from_secs(secs);
        let mut n = 0;
        while let Ok(Ok(())) = tokio::time::timeout_at(end, rx.changed()).await {
            rx.borrow_and_update();
            n += 1;
        }
        n
    }

    /// A fleet without links on `clock` (and the sender that keeps its event channel open).
    fn linkless_fleet(
        clock: MonotonicClock,
    ) -> (mpsc::Sender<crate::link::transport::LinkEvent>, FleetHandle) {
        let (tx, rx) = mpsc::channel(1);
        let fleet = crate::fleet::spawn(Vec::new(), rx, FleetConfig::default(), clock);
        (tx, fleet)
    }

    #[tokio::test(start_paused = true)]
    async fn a_real_time_fleet_is_asked_for_a_snapshot_per_frame_a_fast_one_keeps_its_own() {
        let (_tx, fleet) = linkless_fleet(MonotonicClock::new());
        assert_eq!(ui_snapshot_period(&fleet), REFRESH);
        fleet.shutdown().await;
        // The demo's clock at 10x: 200 ms of its time is 20 ms of wall time already.
        let (_tx, fleet) = linkless_fleet(MonotonicClock::with_speedup(10.0));
        assert_eq!(
            ui_snapshot_period(&fleet),
            FleetConfig::default().snapshot_period
        );
        fleet.shutdown().await;
    }

    /// The live screen's data cadence, counted over virtual time (tokio's paused clock):
    /// with the fleet publishing at least once per frame, the producer passes on a model every
    /// [`REFRESH`] — ten a second, never more — and nothing once the data stops changing.
    #[tokio::test(start_paused = true)]
    async fn the_model_producer_passes_on_ten_models_a_second_and_none_unchanged() {
        let (_tx, fleet) = linkless_fleet(MonotonicClock::new());
        // Faster than the producer, so that every tick finds a newer snapshot whichever of
        // the two tasks wakes first at a shared instant.
        fleet
            .set_snapshot_period(Duration::from_millis(50))
            .await
            .expect("the fleet runs");
        let (shared, _view_tx) = shared();
        let (producer, mut models) = spawn_model_producer(fleet.clone(), shared, REFRESH);
        let n = count_models(&mut models, 10).await;
        assert!(
            (99..=101).contains(&n),
            "{n} models in 10 s of virtual time"
        );
        // The fleet stops: its last snapshot stays, so the models stop too.
        fleet.shutdown().await;
        count_models(&mut models, 1).await;
        assert_eq!(count_models(&mut models, 5).await, 0);
        producer.abort();
    }
}
