//! Driving a spatial-classification run in a test.

use fleetmap::fleet::FleetHandle;
use fleetmap::kinds::bandit::sim as bandit_sim;
use fleetmap::kinds::bandit::{self, RunOptions};
use fleetmap::store::{RunDir, RunMeta};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::planner::sortie::ClassificationState;
use fleetmap_core::world::World;
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

/// The hardware field of the spatial-classification papers (6 × 6 tiles, green ones to
/// find) and its mission, as `fleetmap demo --bandit` flies them.
pub fn hardware() -> (World, MissionDef) {
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
    let def = MissionDef::parse(bandit_sim::HARDWARE_MISSION, "hardware-6x6.toml").unwrap();
    (world, def)
}

/// Start a run of the [`hardware`] mission on `fleet`, in a run directory of its own.
pub async fn new_run(fleet: &FleetHandle) -> super::NewRun<ClassificationState> {
    let (_, def) = hardware();
    let state = bandit::new_state(fleet, &def, std::time::Duration::from_secs(60), None)
        .await
        .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let run = RunDir::create(
        &dir,
        RunMeta::new(fleetmap_core::planner::sortie::KIND, 0),
        Some(bandit_sim::HARDWARE_MISSION),
    )
    .unwrap();
    (state, run, dir, tmp)
}
