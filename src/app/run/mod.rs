//! The run core both mission runners share: the state behind one lock, its durable commits
//! through the store task, the change counter the pilots wait on, the progress lines and the
//! view the TUI draws.
//!
//! A commit mutates the state under the lock, hands a snapshot (one `Arc` clone shared with
//! the view) and the step's journal records to the `RunStore` and waits, still holding the
//! lock, for their acknowledgement: nobody reads a state that is not yet on disk, and
//! snapshots and records reach the disk in the order of the changes — as when the runners
//! wrote the files themselves — but the JSON serialisation and the fsyncs happen on the store
//! thread, never on a runtime worker.

mod progress;

pub use progress::Progress;

use crate::app::error::Context as _;
use crate::app::error::{RunnerError, RunnerResult, Step};
use crate::store::{RunDir, RunStore};
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::watch;
use serde::Serialize;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{Mutex, mpsc};

/// How often [`RunCore::spawn_tracker`] samples the fleet, in runtime time.
pub(crate) const TRACK_PERIOD: Duration = Duration::from_millis(500);

/// The shared core of a run over state `S` (see the module docs).
pub(crate) struct RunCore<S> {
    state: Mutex<S>,
    store: RunStore,
    changed: watch::Sender<u64>,
    progress: Option<mpsc::UnboundedSender<Progress>>,
    view: Option<watch::Sender<Arc<S>>>,
    clock: MonotonicClock,
}

impl<S> RunCore<S>
where
    S: Clone + Serialize + Send + Sync + 'static,
{
    /// A core over `state`, saving to `run` (through a store task, see [`RunStore::spawn`]),
    /// reading time from `clock`, sending progress events to `progress` and states to `view`.
    pub(crate) fn new(
        state: S,
        run: RunDir,
        clock: MonotonicClock,
        progress: Option<mpsc::UnboundedSender<Progress>>,
        view: Option<watch::Sender<Arc<S>>>,
    ) -> RunnerResult<RunCore<S>> {
        let store = RunStore::spawn(run).map_err(RunnerError::StoreThread)?;
        let (changed, _) = watch::channel(0u64);
        Ok(RunCore {
            state: Mutex::new(state),
            store,
            changed,
            progress,
            view,
            clock,
        })
    }

    /// The store task (for the few jobs that are not a commit: reading the journal back on
    /// resume).
    pub(crate) fn store(&self) -> &RunStore {
        &self.store
    }

    /// The fleet clock's time now.
    pub(crate) fn now(&self) -> fleetmap_core::time::Time {
        self.clock.now()
    }

    /// Log `event` and pass it to the progress channel (headless stdout, the TUI's log).
    pub(crate) fn say(&self, event: Progress) {
        match event.severity {
            s if s <= fleetmap_core::proto::severity::Severity::Warning => {
                tracing::warn!("{}", event.text)
            }
            _ => tracing::info!("{}", event.text),
        }
        if let Some(p) = &self.progress {
            let _ = p.send(event);
        }
    }

    /// Mutate the state with `f`, save it, then journal the events `f` returned; publish
    /// the view and wake everyone waiting for a change. Returns once both are durable.
    pub(crate) async fn commit<T, E, Er>(
        &self,
        f: impl FnOnce(&mut S) -> Result<(T, Vec<E>), Er>,
    ) -> RunnerResult<T>
    where
        E: Serialize + Send + 'static,
        RunnerError: From<Er>,
    {
        self.update(|s| f(s).map(|(t, events)| (t, events, true)))
            .await
    }

    /// Like [`RunCore::commit`], but `f` also says whether the state changed at all: when it
    /// did not (and has no events), nothing is saved and nobody is woken.
    pub(crate) async fn update<T, E, Er>(
        &self,
        f: impl FnOnce(&mut S) -> Result<(T, Vec<E>, bool), Er>,
    ) -> RunnerResult<T>
    where
        E: Serialize + Send + 'static,
        RunnerError: From<Er>,
    {
        let mut state = self.state.lock().await;
        let (out, events, changed) = f(&mut *state)?;
        if !changed && events.is_empty() {
            return Ok(out);
        }
        let snapshot = Arc::new(state.clone());
        let saved = snapshot.clone();
        self.store
            .run(move |run| -> RunnerResult<()> {
                run.save_state(&*saved).context(Step::SaveState)?;
                for ev in &events {
                    run.append_event(ev).context(Step::Journal)?;
                }
                Ok(())
            })
            .await??;
        if let Some(v) = &self.view {
            let _ = v.send(snapshot);
        }
        drop(state);
        self.changed.send_modify(|n| *n += 1);
        Ok(out)
    }

    /// Read the state.
    pub(crate) async fn read<T>(&self, f: impl FnOnce(&S) -> T) -> T {
        f(&*self.state.lock().await)
    }

    /// Wake everyone waiting for a change (an operator command arrived).
    pub(crate) fn notify(&self) {
        self.changed.send_modify(|n| *n += 1);
    }

    /// A receiver of the change counter (bumped after every commit and [`RunCore::notify`]).
    pub(crate) fn subscribe(&self) -> watch::Receiver<u64> {
        self.changed.subscribe()
    }

    /// Wait for the next change, at most `timeout`.
    pub(crate) async fn wait_change(&self, timeout: Duration) {
        let mut rx = self.changed.subscribe();
        rx.borrow_and_update();
        let _ = tokio::time::timeout(timeout, rx.changed()).await;
    }

    /// Every [`TRACK_PERIOD`], call `tick(state, dt_s)` with the fleet-clock seconds since the
    /// last call (positions, airborne time: kept in memory, saved with the next commit) and
    /// publish the view. The task runs in `tasks` until the runner shuts that set down (or
    /// drops it).
    pub(crate) fn spawn_tracker(
        self: &Arc<Self>,
        tasks: &mut tokio::task::JoinSet<()>,
        mut tick: impl FnMut(&mut S, f64) + Send + 'static,
    ) {
        let core = self.clone();
        tasks.spawn(async move {
            let mut last = core.now();
            let mut interval = tokio::time::interval(TRACK_PERIOD);
            loop {
                interval.tick().await;
                let now = core.now();
                let dt = (now - last).as_secs_f64();
                last = now;
                let mut state = core.state.lock().await;
                tick(&mut *state, dt);
                if let Some(v) = &core.view {
                    let _ = v.send(Arc::new(state.clone()));
                }
            }
        });
    }
}
