//! Driving a run task in a test until it ends or a progress line stops it.

use fleetmap::app::error::RunnerError;
use fleetmap::app::run::Progress;
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

/// Wait for `task` (a runner) to end, printing and keeping its progress lines from `rx`, or
/// until `stop` says so of a line: the GCS dies there (the task aborted, nothing more saved).
/// Returns the lines and the runner's result if it ended; a run that fails fails the test.
/// The run's end is taken before a line waiting beside it (`biased`), so a virtual-time run
/// stops at the same line every time.
pub async fn until_stopped<T>(
    mut task: JoinHandle<Result<T, RunnerError>>,
    mut rx: mpsc::UnboundedReceiver<Progress>,
    mut stop: impl FnMut(&str) -> bool,
) -> (Vec<String>, Option<T>) {
    let mut lines = Vec::new();
    loop {
        tokio::select! {
            biased;
            r = &mut task => {
                let outcome = r.expect("the run task");
                while let Ok(l) = rx.try_recv() {
                    lines.push(l.to_string());
                }
                match outcome {
                    Ok(o) => return (lines, Some(o)),
                    Err(e) => panic!(
                        "the run failed: {}\n{lines:#?}",
                        fleetmap::app::error::chain(&e)
                    ),
                }
            }
            Some(l) = rx.recv() => {
                let l = l.to_string();
                eprintln!("{l}");
                let halt = stop(&l);
                lines.push(l);
                if halt {
                    task.abort();
                    let _ = task.await;
                    return (lines, None);
                }
            }
        }
    }
}
