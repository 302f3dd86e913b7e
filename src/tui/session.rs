//! The live terminal session (async shell): the operator's UI on a real fleet, with or
//! without a run attached (of any registered kind).
//!
//! Three tasks around the UI ([`crate::tui::run`]):
//! * the **model producer** turns fleet snapshots, the panes of the run's state (a `watch`
//!   from the runner; [`RunKind::panes`]) and the log into [`crate::panes::Model`]s ten times a second
//!   ([`crate::tui::REFRESH`], [`crate::tui::live::build_model`]), and passes on those that
//!   differ from the previous one; the fleet is asked to publish its snapshots at least as
//!   often (in wall time), so that each frame shows fresh telemetry;
//! * the **command executor** carries out the operator's commands — mission-level ones
//!   through the runner, as the run's kind means them ([`RunKind::command`]: a
//!   pause, a resume, a recall, a battery swapped, …), vehicle-level ones through the fleet (arm, disarm, RTL,
//!   land, hold) — and answers each with a [`JobResult`];
//! * the **runner** ([`RunKind::fly_attached`]) once the operator starts the mission (or
//!   at once with `auto_start`).
//!
//! The session knows no mission kind: a [`SessionRun`] is any [`RunKind`]'s run.
//!
//! The UI never waits on any of them: it only reads the latest model and queues commands.

use crate::app::blocking::run_blocking;
use crate::app::error::RunError;
use crate::app::flight;
use crate::app::kind::{Attached, CommandReply, Outcome, RunKind};
use crate::app::preflight::StartCheck;
use crate::app::run::Progress;
use crate::fleet::FleetHandle;
use crate::launch::{OnFinish, Ready, exports_on_finish, run_world};
use crate::panes::{Model, Panes, RunInfo};
use crate::store::RunDir;
use crate::tui::live::{LiveLog, build_model};
use crate::tui::{
    App, Command, CommandError, CommandRequest, JobResult, REFRESH, ShellIo, ShellOptions, Target,
    UiConfig,
};
use fleetmap_core::preflight::{Finding, Severity as CheckSeverity};
use fleetmap_core::proto::severity::Severity;
use fleetmap_io::watch;
use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::mpsc;
use tokio::task::JoinSet;

/// How long a finished run's helpers (its log relay, its view relay) may take to pass on
/// what the run left in their channels, wall time: they end by themselves once the run has
/// dropped its senders, so this only bounds a sender kept alive elsewhere.
const DRAIN: Duration = Duration::from_secs(1);

/// How long an operator's quit waits for a finished run to write its exports (the plots of
/// a large map take seconds on a loaded laptop).
const EXPORTS_ON_QUIT: Duration = Duration::from_secs(120);

/// Why a session could not go on: the terminal failed, or (flying a run) its layer did.
#[derive(Debug, thiserror::Error)]
pub(crate) enum SessionError {
    /// The run's layer failed (reading its directory).
    #[error(transparent)]
    Run(#[from] RunError),
    /// The terminal failed.
    #[error(transparent)]
    Tui(#[from] crate::tui::TuiError),
}

/// Fly `ready` in the terminal UI on `fleet` until the operator quits (from the start with
/// `auto_start`, otherwise at the operator's START, which checks the fleet again): whether
/// the run finished. Its exports are written when it finishes.
pub(crate) async fn fly<K: RunKind>(
    ready: Ready<K>,
    fleet: &FleetHandle,
    config: SessionConfig,
    auto_start: bool,
) -> Result<bool, SessionError> {
    let at = ready.run_dir.path().to_path_buf();
    let world = run_blocking(move || {
        RunDir::open(&at)
            .ok()
            .and_then(|rd| run_world(&rd, None).ok())
    })
    .await
    .map_err(RunError::from)?
    .flatten();
    let mission = SessionRun::new::<K>(
        ready.run_dir,
        ready.state,
        ready.options,
        auto_start,
        Some(exports_on_finish::<K>(world)),
    )
    .with_check(ready.check);
    let SessionEnd::Quit { finished } = run(fleet.clone(), Some(mission), config).await?;
    Ok(finished)
}

/// A run the session drives, of any kind (the session is written once, for every
/// [`RunKind`]), with the fleet check of its start.
pub(crate) struct SessionRun {
    run: Box<dyn Attach>,
    check: Option<StartCheck>,
}

impl SessionRun {
    /// The run in `run_dir` of kind `K` from `state`, flown with `options`; it starts at
    /// once with `auto_start`, otherwise on the operator's START; `on_finish` is called
    /// with the final state when it finishes (exports, reports).
    pub(crate) fn new<K: RunKind>(
        run_dir: RunDir,
        state: K::State,
        options: K::Options,
        auto_start: bool,
        on_finish: Option<OnFinish<K::State>>,
    ) -> SessionRun {
        SessionRun {
            run: Box::new(KindRun::<K> {
                run_dir,
                state,
                options,
                auto_start,
                on_finish,
            }),
            check: None,
        }
    }

    /// The fleet check made before the session ([`crate::app::preflight::gate`]): its
    /// findings open the log, and the operator's START checks again.
    pub(crate) fn with_check(self, check: Option<StartCheck>) -> SessionRun {
        SessionRun { check, ..self }
    }
}

/// A run of kind `K`, before it starts.
struct KindRun<K: RunKind> {
    run_dir: RunDir,
    state: K::State,
    options: K::Options,
    auto_start: bool,
    on_finish: Option<OnFinish<K::State>>,
}

/// The latest state of the attached run (what the panes show), of whatever kind.
type RunState = Arc<dyn ShowRun>;

/// A run's state as the panes show it.
trait ShowRun: Send + Sync {
    /// Its panes ([`RunKind::panes`]).
    fn panes(&self, info: &RunInfo) -> Panes;
    /// Whether the run's state is finished ([`RunKind::is_finished`]): its exports may still
    /// be being written.
    fn is_finished(&self) -> bool;
}

/// A state of kind `K`, as the panes draw it: the state they last drew.
struct KindState<K: RunKind>(Arc<K::State>);

impl<K: RunKind> ShowRun for KindState<K> {
    fn panes(&self, info: &RunInfo) -> Panes {
        K::panes(&self.0, info)
    }
    fn is_finished(&self) -> bool {
        K::is_finished(&self.0)
    }
}

/// The operator's mission-level commands to a running run, of whatever kind.
trait MissionCommands: Send {
    /// See [`RunKind::command`].
    fn command(
        &self,
        command: Command,
        target: Target,
        targets: &[u8],
    ) -> Option<Result<CommandReply, CommandError>>;
}

/// The command channel of a run of kind `K`.
struct Operators<K: RunKind>(mpsc::UnboundedSender<K::Operator>);

impl<K: RunKind> MissionCommands for Operators<K> {
    fn command(
        &self,
        command: Command,
        target: Target,
        targets: &[u8],
    ) -> Option<Result<CommandReply, CommandError>> {
        K::command(command, target, targets, &self.0)
    }
}

/// How a run the session flew ended: `Ok(None)` when it finished, `Ok(Some(why))` when it
/// waits for the operator; its run directory; the task relaying its states to the view
/// (it ends once the run has dropped its view sender; dropping the set stops it).
type Driven = (
    Result<Option<String>, RunError>,
    std::path::PathBuf,
    JoinSet<()>,
);

/// The flight of an attached run, once started.
type Flight = Pin<Box<dyn Future<Output = Driven> + Send>>;

/// A run of some kind, type-erased for the session.
trait Attach: Send {
    fn name(&self) -> String;
    fn auto_start(&self) -> bool;
    fn view(&self) -> RunState;
    /// Its mission-level commands, and the flight to run once the operator STARTs it
    /// (progress lines to `progress`, states to `view`).
    fn fly(
        self: Box<Self>,
        fleet: FleetHandle,
        progress: mpsc::UnboundedSender<Progress>,
        view: watch::Sender<Option<RunState>>,
    ) -> (Box<dyn MissionCommands>, Flight);
}

impl<K: RunKind> Attach for KindRun<K> {
    fn name(&self) -> String {
        K::mission(&self.state).to_string()
    }

    fn auto_start(&self) -> bool {
        self.auto_start
    }

    fn view(&self) -> RunState {
        Arc::new(KindState::<K>(Arc::new(self.state.clone())))
    }

    fn fly(
        self: Box<Self>,
        fleet: FleetHandle,
        progress: mpsc::UnboundedSender<Progress>,
        view_tx: watch::Sender<Option<RunState>>,
    ) -> (Box<dyn MissionCommands>, Flight) {
        let (op_tx, op_rx) = mpsc::unbounded_channel::<K::Operator>();
        let m = *self;
        let flight = async move {
            let (vtx, mut vrx) = watch::channel(Arc::new(m.state.clone()));
            let mut relay = JoinSet::new();
            relay.spawn(async move {
                while vrx.changed().await.is_ok() {
                    let s = vrx.borrow_and_update().clone();
                    let _ = view_tx.send(Some(Arc::new(KindState::<K>(s))));
                }
            });
            let path = m.run_dir.path().to_path_buf();
            let attached = Attached {
                progress,
                view: vtx,
                operator: op_rx,
            };
            let r = K::fly_attached(&fleet, m.run_dir, m.state, m.options, attached).await;
            let r = match r {
                Ok((Outcome::Finished, state)) => {
                    // The outputs are file I/O: off the runtime workers.
                    let at = path.clone();
                    let on_finish = m.on_finish;
                    let _ = run_blocking(move || {
                        if let (Some(f), Ok(rd)) = (on_finish, RunDir::open(&at)) {
                            f(&rd, &state);
                        }
                    })
                    .await;
                    Ok(None)
                }
                Ok((Outcome::WaitingForOperator { waiting }, _)) => {
                    Ok(Some(crate::app::kind::waiting_lines(&waiting).join("; ")))
                }
                Err(e) => Err(e),
            };
            (r, path, relay)
        };
        (Box::new(Operators::<K>(op_tx)), Box::pin(flight))
    }
}

/// Settings of the UI.
pub(crate) struct SessionConfig {
    /// The title bar's source ("LIVE udpin:…", "DEMO (simulated)").
    pub source: crate::tui::Source,
    /// Keys and thresholds.
    pub ui: UiConfig,
    /// Where the log file is (shown in the help).
    pub(crate) log_file: Option<String>,
}

/// How the session ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum SessionEnd {
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
/// (an unchanged model wakes nobody). The task is spawned on `tasks`; it ends when the
/// receiver is dropped, or with the set.
fn spawn_model_producer(
    tasks: &mut JoinSet<()>,
    fleet: FleetHandle,
    shared: Arc<Shared>,
    period: Duration,
) -> watch::Receiver<Model> {
    let (snap_tx, snap_rx) = watch::channel(Model::default());
    tasks.spawn(async move {
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
                let mut m = build_model(&snap, view.as_ref().map(|s| s.panes(&info)), &log);
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
    snap_rx
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
pub(crate) async fn run(
    fleet: FleetHandle,
    mission: Option<SessionRun>,
    cfg: SessionConfig,
) -> Result<SessionEnd, crate::tui::TuiError> {
    if let Err(e) = fleet.set_snapshot_period(ui_snapshot_period(&fleet)).await {
        tracing::warn!("the fleet did not take the UI's snapshot period: {e}");
    }
    let (view_tx, view_rx) = watch::channel::<Option<RunState>>(None);
    let name = mission.as_ref().map(|m| m.run.name()).unwrap_or_default();
    let shared = Arc::new(Shared {
        log: Mutex::new(LiveLog::default()),
        info: Mutex::new(RunInfo {
            name,
            ..RunInfo::default()
        }),
        view: view_rx,
        finished: Mutex::new(false),
    });
    let (start_tx, start_rx) = tokio::sync::oneshot::channel::<()>();
    let has_run = mission.is_some();
    let mut start = Some(start_tx);
    let check = mission.as_ref().and_then(|m| m.check.clone());
    if let Some(c) = &check {
        log_findings(&shared, fleet.clock().now(), &c.findings);
    }

    // The runner: it flies once the operator STARTs it; its mission-level commands reach
    // the executor when it does. Its own set, apart from the others: a finished run is let
    // end by itself, an unfinished one is stopped.
    let (commands_tx, commands_rx) = tokio::sync::oneshot::channel::<Box<dyn MissionCommands>>();
    let mut runner = JoinSet::new();
    if let Some(SessionRun { run: m, .. }) = mission {
        let _ = view_tx.send(Some(m.view()));
        if m.auto_start()
            && let Some(tx) = start.take()
        {
            let _ = tx.send(());
        }
        let fleet = fleet.clone();
        let shared = shared.clone();
        runner.spawn(async move {
            if start_rx.await.is_err() {
                return;
            }
            if let Ok(mut i) = shared.info.lock() {
                i.started = true;
            }
            let (ptx, mut prx) = mpsc::unbounded_channel::<Progress>();
            // The run's helpers: stopped with this task when the session stops it.
            let mut helpers = JoinSet::new();
            {
                let shared = shared.clone();
                let fleet = fleet.clone();
                helpers.spawn(async move {
                    while let Some(p) = prx.recv().await {
                        if let Ok(mut l) = shared.log.lock() {
                            l.push(fleet.clock().now(), p.severity, p.sysid, p.text);
                        }
                    }
                });
            }
            let (commands, flight) = m.fly(fleet.clone(), ptx, view_tx);
            let _ = commands_tx.send(commands);
            let (result, path, mut relay) = flight.await;
            // The run's last progress lines and state reach the log and the panes before
            // the line that says how it ended.
            let _ = tokio::time::timeout(DRAIN, async {
                while helpers.join_next().await.is_some() {}
                while relay.join_next().await.is_some() {}
            })
            .await;
            helpers.shutdown().await;
            relay.shutdown().await;
            log_end(&shared, fleet.clock().now(), result, &path);
        });
    }
    let mut controls = Controls {
        has_run,
        start,
        check,
        commands: None,
        commands_rx: Some(commands_rx),
    };

    // The model producer and the command executor: stopped when the UI ends.
    let mut tasks = JoinSet::new();
    let snap_rx = spawn_model_producer(&mut tasks, fleet.clone(), shared.clone(), REFRESH);

    let (cmd_tx, mut cmd_rx) = mpsc::channel::<CommandRequest>(32);
    let (result_tx, result_rx) = mpsc::channel::<JobResult>(32);
    {
        let fleet = fleet.clone();
        let shared = shared.clone();
        tasks.spawn(async move {
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
        });
    }

    let mut app = App::new(cfg.ui, cfg.source);
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
        clock: fleetmap_io::clock::MonotonicClock::new(),
    };
    let result = crate::tui::run(app, io, options).await;
    tasks.shutdown().await;
    let finished = shared.finished.lock().map(|f| *f).unwrap_or(false);
    // A run whose state is finished is writing its exports (the UI says DONE from the
    // state, before they are written): an operator who quits at once must not cut them off.
    let exporting = shared
        .view
        .borrow()
        .as_ref()
        .is_some_and(|v| v.is_finished());
    if finished {
        // It has said how the run ended: nothing is left for it to do.
        while runner.join_next().await.is_some() {}
    } else if exporting {
        // Only its exports are left to write (seconds; bounded all the same).
        let joined = async { while runner.join_next().await.is_some() {} };
        if tokio::time::timeout(EXPORTS_ON_QUIT, joined).await.is_err() {
            tracing::warn!("the finished run's exports took over {EXPORTS_ON_QUIT:?}: stopped");
            runner.shutdown().await;
        }
    } else {
        runner.shutdown().await;
    }
    result?;
    let finished = shared.finished.lock().map(|f| *f).unwrap_or(finished);
    Ok(SessionEnd::Quit { finished })
}

/// What the command executor holds of the attached run.
struct Controls {
    /// Whether the session has a run.
    has_run: bool,
    /// The operator's START, until it is given.
    start: Option<tokio::sync::oneshot::Sender<()>>,
    /// The fleet check START makes again (`None`: the run was not checked).
    check: Option<StartCheck>,
    /// The running run's mission-level commands.
    commands: Option<Box<dyn MissionCommands>>,
    /// Where they come from once the run starts.
    commands_rx: Option<tokio::sync::oneshot::Receiver<Box<dyn MissionCommands>>>,
}

impl Controls {
    /// The running run's mission-level commands, once it has started (`None` before).
    async fn mission(&mut self, started: bool) -> Option<&dyn MissionCommands> {
        if self.commands.is_none()
            && started
            && let Some(rx) = self.commands_rx.take()
        {
            self.commands = rx.await.ok();
        }
        self.commands.as_deref()
    }
}

/// Put the fleet check's findings in the log pane, one line each (a blocker as an error,
/// a warning as a warning, each with its fix), then the summary line.
fn log_findings(shared: &Shared, now: fleetmap_core::time::Time, findings: &[Finding]) {
    let Ok(mut l) = shared.log.lock() else {
        return;
    };
    for f in findings {
        let severity = match f.severity {
            CheckSeverity::Blocker => Severity::Error,
            CheckSeverity::Warning => Severity::Warning,
        };
        l.push(
            now,
            severity,
            Some(f.sysid),
            crate::app::preflight::one_line(f),
        );
    }
    let blockers = fleetmap_core::preflight::blockers(findings) > 0;
    let severity = if blockers {
        Severity::Error
    } else {
        Severity::Notice
    };
    l.push(
        now,
        severity,
        None,
        crate::app::preflight::summary(findings),
    );
}

/// Tell the operator how the run ended (the log; the title bar for a failure).
fn log_end(
    shared: &Shared,
    now: fleetmap_core::time::Time,
    result: Result<Option<String>, RunError>,
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
            let msg = crate::app::error::chain(&e);
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

/// Carry out one operator command: mission-level ones through the runner (what they mean
/// is the run's kind's [`RunKind::command`]), vehicle-level ones through the fleet. Returns
/// what to tell the operator.
async fn execute(
    req: &CommandRequest,
    controls: &mut Controls,
    fleet: &FleetHandle,
    shared: &Shared,
) -> Result<String, CommandError> {
    let started = shared.info.lock().map(|i| i.started).unwrap_or(false);
    let targets: Vec<u8> = match req.target {
        Target::Vehicle(v) => vec![v],
        Target::All => fleet.snapshot().vehicles.keys().copied().collect(),
    };
    if req.command == Command::Start {
        if !controls.has_run {
            return Err(CommandError::NoMission);
        }
        if controls.start.is_none() {
            return Err(CommandError::AlreadyRunning);
        }
        if let Some(check) = &controls.check {
            let (findings, go) = check.at_start(fleet).await;
            log_findings(shared, fleet.clock().now(), &findings);
            if !go {
                return Err(CommandError::CheckFailed(crate::app::preflight::summary(
                    &findings,
                )));
            }
        }
        return match controls.start.take() {
            Some(tx) => {
                let _ = tx.send(());
                Ok("mission started".into())
            }
            None => Err(CommandError::AlreadyRunning),
        };
    }
    let running = controls.has_run && started;
    if running
        && let Some(mission) = controls.mission(started).await
        && let Some(reply) = mission.command(req.command, req.target, &targets)
    {
        let reply = reply?;
        if let Some(p) = reply.paused
            && let Ok(mut i) = shared.info.lock()
        {
            i.paused = p;
        }
        return Ok(reply.text);
    }
    match req.command {
        Command::Resume => return Err(CommandError::NotStarted),
        Command::BatterySwapped => return Err(CommandError::NotRunning),
        _ => {}
    }
    let mut errors = Vec::new();
    for v in &targets {
        let r = match req.command {
            Command::Hold => flight::hold_here(fleet, *v).await,
            Command::Rtl => fleet.rtl(*v).await,
            Command::Land => fleet.land(*v).await,
            Command::Arm => fleet.arm(*v).await,
            Command::Disarm => fleet.disarm(*v).await,
            Command::Start | Command::Resume | Command::BatterySwapped => Ok(()),
        };
        if let Err(e) = r {
            errors.push(e.to_string());
        }
    }
    if errors.is_empty() {
        Ok("accepted".into())
    } else {
        Err(CommandError::Vehicles(errors))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fleet::FleetConfig;
    use fleetmap_io::clock::MonotonicClock;

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
    ) -> (
        mpsc::Sender<fleetmap_io::link::transport::LinkEvent>,
        FleetHandle,
    ) {
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
        let mut tasks = JoinSet::new();
        let mut models = spawn_model_producer(&mut tasks, fleet.clone(), shared, REFRESH);
        let n = count_models(&mut models, 10).await;
        assert!(
            (99..=101).contains(&n),
            "{n} models in 10 s of virtual time"
        );
        // The fleet stops: its last snapshot stays, so the models stop too.
        fleet.shutdown().await;
        count_models(&mut models, 1).await;
        assert_eq!(count_models(&mut models, 5).await, 0);
        tasks.shutdown().await;
    }
}
