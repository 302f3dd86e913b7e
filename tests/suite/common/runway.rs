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
/// lines and the outcome if it ended ([`super::drive::until_stopped`]).
pub async fn run_until(
    fleet: &FleetHandle,
    dir: &Path,
    state: MappingState,
    stop: impl FnMut(&str) -> bool,
) -> (Vec<String>, Option<Outcome>) {
    let hub = images::spawn(fleet);
    let (tx, rx) = mpsc::unbounded_channel();
    let opts = RunOptions {
        auto_resume: true,
        progress: Some(tx),
        ..RunOptions::default()
    };
    let run = RunDir::open(dir).unwrap();
    let f = fleet.clone();
    let task = tokio::spawn(async move { runway::run(f, &hub, run, state, opts).await });
    super::drive::until_stopped(task, rx, stop).await
}
