//! Driving a runway-mapping run in a test.

use fleetmap::app::images;
use fleetmap::app::kind::Outcome;
use fleetmap::app::runway::{self, RunOptions};
use fleetmap::fleet::FleetHandle;
use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::MappingState;
use std::path::Path;
use tokio::sync::mpsc;

/// Run `state` in `dir` with auto-resume until it ends, or until `stop` says so of a progress
/// line: the GCS dies there (the run task aborted, nothing more saved). Returns the progress
/// lines and the outcome if it ended; a run that fails fails the test. The run's end is taken
/// before a line waiting beside it (`biased`), so a virtual-time run stops at the same line
/// every time.
pub async fn run_until(
    fleet: &FleetHandle,
    dir: &Path,
    state: MappingState,
    mut stop: impl FnMut(&str) -> bool,
) -> (Vec<String>, Option<Outcome>) {
    let hub = images::spawn(fleet);
    let (tx, mut rx) = mpsc::unbounded_channel();
    let opts = RunOptions {
        auto_resume: true,
        progress: Some(tx),
        ..RunOptions::default()
    };
    let run = RunDir::open(dir).unwrap();
    let f = fleet.clone();
    let mut task = tokio::spawn(async move { runway::run(f, &hub, run, state, opts).await });
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
