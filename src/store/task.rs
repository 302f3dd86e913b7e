//! The store task: the one owner of an open [`RunDir`] during a run, doing every save and
//! journal append off the async workers.
//!
//! A runner sends jobs (closures over `&mut RunDir`) through `RunStore::run` and awaits
//! their result, which arrives only once the job has returned — for [`RunDir::save_state`] and
//! [`RunDir::append_event`] that is after their fsyncs, so an acknowledged save is on disk, as
//! when the runner called them itself. Jobs run one at a time in the order they were sent:
//! a runner that sends while holding its state lock gets its snapshots and journal records
//! written in the order of its state changes.
//!
//! In a multi-threaded runtime the jobs run on a dedicated thread (named `fleetmap-store`),
//! so serialising the state (pretty-printed JSON) and the fsyncs never block a runtime
//! worker. In a current-thread runtime (the virtual-clock tests, `start_paused`) they run
//! inline, like `crate::app::blocking::run_blocking`'s work: while the only thread waited for another one, a
//! paused clock would jump to the next timer and virtual time would run on during the write.

use super::RunDir;
use std::sync::mpsc as std_mpsc;
use tokio::sync::oneshot;

/// One piece of work on the run directory.
type Job = Box<dyn FnOnce(&mut RunDir) + Send + 'static>;

/// Handle to the store task owning a run directory (see the module docs).
pub(crate) struct RunStore {
    inner: Inner,
}

enum Inner {
    /// Jobs go to the dedicated thread, in order.
    Thread(std_mpsc::Sender<Job>),
    /// Current-thread runtime (or no runtime): jobs run inline on the caller.
    Inline(Box<std::sync::Mutex<RunDir>>),
}

/// The store task is gone (its thread panicked in a job): nothing more can be saved.
#[derive(Debug, thiserror::Error)]
#[error("the run store task stopped (a save panicked): nothing more can be saved")]
pub(crate) struct StoreGone;

impl RunStore {
    /// Take ownership of `run`: a dedicated thread in a multi-threaded tokio runtime, inline
    /// execution in a current-thread runtime or outside a runtime. Fails only when the
    /// operating system refuses a thread.
    pub(crate) fn spawn(run: RunDir) -> std::io::Result<RunStore> {
        let threaded = tokio::runtime::Handle::try_current()
            .is_ok_and(|h| h.runtime_flavor() != tokio::runtime::RuntimeFlavor::CurrentThread);
        if !threaded {
            return Ok(RunStore::inline(run));
        }
        let (tx, rx) = std_mpsc::channel::<Job>();
        let spawned = std::thread::Builder::new()
            .name("fleetmap-store".into())
            .spawn(move || {
                let mut run = run;
                // Ends when every sender is dropped (the run finished).
                while let Ok(job) = rx.recv() {
                    job(&mut run);
                }
            });
        spawned.map(|_| RunStore {
            inner: Inner::Thread(tx),
        })
    }

    /// Jobs run inline on the caller (tests, current-thread runtimes).
    pub(crate) fn inline(run: RunDir) -> RunStore {
        RunStore {
            inner: Inner::Inline(Box::new(std::sync::Mutex::new(run))),
        }
    }

    /// Run `job` on the run directory and return its result once it has finished (after
    /// its fsyncs: a save it reports done is durable). Jobs run in the order they are sent.
    pub(crate) async fn run<T: Send + 'static>(
        &self,
        job: impl FnOnce(&mut RunDir) -> T + Send + 'static,
    ) -> Result<T, StoreGone> {
        match &self.inner {
            Inner::Inline(run) => {
                let mut run = run.lock().map_err(|_| StoreGone)?;
                Ok(job(&mut run))
            }
            Inner::Thread(tx) => {
                let (done, result) = oneshot::channel();
                tx.send(Box::new(move |run: &mut RunDir| {
                    let _ = done.send(job(run));
                }))
                .map_err(|_| StoreGone)?;
                result.await.map_err(|_| StoreGone)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::RunMeta;

    async fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let run = RunDir::create(dir.path().join("r"), RunMeta::new("t", 0), None).unwrap();
        let store = RunStore::spawn(run).unwrap();
        for i in 0..5u32 {
            store
                .run(move |r| {
                    r.save_state(&i)?;
                    r.append_event(&i)
                })
                .await
                .unwrap()
                .unwrap();
        }
        let r = RunDir::open(dir.path().join("r")).unwrap();
        assert_eq!(r.load_state::<u32>().unwrap(), Some(4));
        let log = r.read_events::<u32>().unwrap();
        let got: Vec<u32> = log.events.iter().map(|l| l.event).collect();
        assert_eq!(got, vec![0, 1, 2, 3, 4]);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn jobs_run_in_order_on_the_store_thread() {
        round_trip().await;
    }

    #[tokio::test(flavor = "current_thread")]
    async fn jobs_run_inline_in_a_current_thread_runtime() {
        round_trip().await;
    }
}
