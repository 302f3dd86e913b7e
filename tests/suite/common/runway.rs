//! Driving a runway-mapping run in a test.

use fleetmap::app::images;
use fleetmap::app::kind::Outcome;
use fleetmap::fleet::FleetHandle;
use fleetmap::kinds::runway::KIND;
use fleetmap::kinds::runway::MappingEvent;
use fleetmap::kinds::runway::{self, RunOptions};
use fleetmap::store::{RunDir, RunMeta};
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::mission::definition::MissionDef;
use std::collections::BTreeSet;
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

/// The images whose detections the journal `events` acknowledged (by image id).
pub fn journal_images(events: &[MappingEvent]) -> BTreeSet<String> {
    events
        .iter()
        .filter_map(|e| match e {
            MappingEvent::Image { image_id, .. } => Some(image_id.clone()),
            _ => None,
        })
        .collect()
}

/// The images whose detections the map `s` holds (by image id).
pub fn detections(s: &MappingState) -> BTreeSet<String> {
    s.book
        .detections()
        .iter()
        .map(|r| r.detection.image_id.clone())
        .collect()
}

/// Start a run of the runway mission `def` (read from `text`) on `fleet`, the GCS sharing out
/// the grid (sorties of at most 60 s between two plans), in a run directory of its own.
pub async fn new_run(
    fleet: &FleetHandle,
    def: &MissionDef,
    text: &str,
) -> super::NewRun<MappingState> {
    let state = fleetmap::kinds::runway::new_mapping(
        fleet,
        def,
        Sharing::Gcs,
        std::time::Duration::from_secs(60),
    )
    .await
    .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let run = RunDir::create(&dir, RunMeta::new(KIND, 0), Some(text)).unwrap();
    (state, run, dir, tmp)
}

/// Options for a run that resumes by itself after a battery swap (`auto_resume`), its progress
/// lines printed to stderr by the returned task, which ends when the run drops its sender.
pub fn printed_options() -> (RunOptions, tokio::task::JoinHandle<()>) {
    let (tx, mut rx) = mpsc::unbounded_channel();
    let printer = tokio::spawn(async move {
        while let Some(line) = rx.recv().await {
            eprintln!("{line}");
        }
    });
    let opts = RunOptions {
        auto_resume: true,
        progress: Some(tx),
        ..RunOptions::default()
    };
    (opts, printer)
}
