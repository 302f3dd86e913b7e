//! Driving a spatial-classification run in a test.

use fleetmap::app::bandit::{self, RunOptions};
use fleetmap::fleet::FleetHandle;
use fleetmap::store::RunDir;
use fleetmap_core::planner::sortie::ClassificationState;
use std::path::Path;
use tokio::sync::mpsc;

/// Run `state` in `dir` with auto-resume to its end, or until `stop` says so of a progress
/// line: the GCS dies there (the run task aborted, nothing more saved). Returns the progress
/// lines and whether it was stopped. The run's end is taken before a line waiting beside it
/// (`biased`), so a virtual-time run stops at the same line every time.
pub async fn run_until(
    fleet: &FleetHandle,
    dir: &Path,
    state: ClassificationState,
    mut stop: impl FnMut(&str) -> bool,
) -> (Vec<String>, bool) {
    let hub = fleetmap::app::images::image_hub(fleet);
    let (tx, mut rx) = mpsc::unbounded_channel();
    let opts = RunOptions {
        progress: Some(tx),
        auto_resume: true,
        ..RunOptions::default()
    };
    let run = RunDir::open(dir).unwrap();
    let fleet = fleet.clone();
    let mut task =
        tokio::spawn(async move { bandit::run(fleet, &hub, run, state, opts).await.map(|_| ()) });
    let mut lines = Vec::new();
    loop {
        tokio::select! {
            biased;
            r = &mut task => {
                if let Err(e) = r.expect("the run task") {
                    panic!("the run failed: {}\n{lines:#?}", fleetmap::app::error::chain(&e));
                }
                while let Ok(l) = rx.try_recv() {
                    lines.push(l.to_string());
                }
                return (lines, false);
            }
            Some(l) = rx.recv() => {
                let l = l.to_string();
                eprintln!("{l}");
                let halt = stop(&l);
                lines.push(l);
                if halt {
                    task.abort();
                    let _ = task.await;
                    return (lines, true);
                }
            }
        }
    }
}
