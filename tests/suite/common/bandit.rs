//! Driving a spatial-classification run in a test.

use fleetmap::app::bandit::{self, RunOptions};
use fleetmap::fleet::FleetHandle;
use fleetmap::store::RunDir;
use fleetmap_core::planner::sortie::ClassificationState;
use std::path::Path;
use tokio::sync::mpsc;

/// Run `state` in `dir` with auto-resume to its end, or until `stop` says so of a progress
/// line: the GCS dies there (the run task aborted, nothing more saved). Returns the progress
/// lines and whether it was stopped ([`super::drive::until_stopped`]).
pub async fn run_until(
    fleet: &FleetHandle,
    dir: &Path,
    state: ClassificationState,
    stop: impl FnMut(&str) -> bool,
) -> (Vec<String>, bool) {
    let hub = fleetmap::app::images::image_hub(fleet);
    let (tx, rx) = mpsc::unbounded_channel();
    let opts = RunOptions {
        progress: Some(tx),
        auto_resume: true,
        ..RunOptions::default()
    };
    let run = RunDir::open(dir).unwrap();
    let fleet = fleet.clone();
    let task = tokio::spawn(async move { bandit::run(fleet, &hub, run, state, opts).await });
    let (lines, ended) = super::drive::until_stopped(task, rx, stop).await;
    (lines, ended.is_none())
}
