//! One mission kind: everything `fleetmap run`, `resume`, `report`, `export`, the TUI session
//! and the demo need of a runner, so that each of them is written once for both missions.
//!
//! The two kinds are [`crate::app::runway::Runway`] (runway mapping, `run.json` kind
//! `runway-mapping`) and [`crate::app::bandit::Classification`] (spatial classification,
//! `spatial-classification`). A run directory remembers its kind; [`Kind`] is that name read
//! back, and the commands dispatch on it once.

use crate::app::run::Progress;
use crate::app::session::SessionRun;
use crate::fleet::FleetHandle;
use crate::mission::definition::MissionDef;
use crate::store::{RunDir, RunMeta};
use crate::world::World;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::future::Future;
use std::path::PathBuf;
use std::time::Duration;
use tokio::sync::mpsc;

/// How a run ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The mission is complete and every robot landed.
    Finished,
    /// Robots are on the ground waiting for the operator (runway mapping: battery swaps
    /// without `auto_resume`): run `fleetmap resume` after the swaps.
    WaitingForOperator {
        /// The vehicles waiting.
        sysids: Vec<u8>,
    },
}

/// What `fleetmap export` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// GeoJSON FeatureCollection (QGIS).
    Geojson,
    /// KML (Google Earth).
    Kml,
    /// PNG: the grid (runway mapping, the runway paper's Fig. 10) or the classification
    /// progress per epoch (spatial classification, the bandit paper's Fig. 4).
    Png,
}

/// The operator's choices for a run (`fleetmap run` / `resume` options, the demo's, the TUI's).
#[derive(Clone, Debug)]
pub struct RunSettings {
    /// Runway mapping: take off again by itself once a vehicle reports a fresh battery.
    pub auto_resume: bool,
    /// Scale of every flight timeout (2 = twice as patient).
    pub patience: f64,
    /// Runway mapping: how the robots share the DFS vertex states.
    pub sharing: crate::explore::Sharing,
    /// Spatial classification: keep the drones in step (the bandit paper's 7e) even when the
    /// mission separates them by altitude (`None`: as the mission implies).
    pub lock_step: Option<bool>,
    /// Spatial classification: HiGHS time limit per integer-program solve, seconds.
    pub plan_time_limit_s: Option<f64>,
}

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            auto_resume: false,
            patience: 1.0,
            sharing: crate::explore::Sharing::Gcs,
            lock_step: None,
            plan_time_limit_s: None,
        }
    }
}

/// A mission kind (see the module docs). Its methods are the parts in which the two missions
/// differ; [`Kind`] and the generic commands in `cli::run` do the rest once.
pub trait RunKind: Send + Sync + 'static {
    /// The `kind` in `run.json`.
    const KIND: &'static str;
    /// The exports written at the end of a run, in this order.
    const EXPORTS: [ExportFormat; 3];
    /// The state saved in `state.json` after every step.
    type State: Clone + Serialize + DeserializeOwned + Send + Sync + 'static;
    /// The runner's options.
    type Options: Send + 'static;
    /// A record of the run's journal (`events.jsonl`).
    type Event: DeserializeOwned + Send + 'static;
    /// What `fleetmap report` shows (its JSON form is `--json`).
    type Report: Serialize + Send + 'static;

    /// The mission's name.
    fn mission(state: &Self::State) -> &str;
    /// Whether nothing is left to do.
    fn is_finished(state: &Self::State) -> bool;
    /// The vehicles the run flies.
    fn sysids(state: &Self::State) -> Vec<u8>;

    /// The runner's options for `settings` (checked: a clear error for a bad value).
    fn options(settings: &RunSettings) -> anyhow::Result<Self::Options>;
    /// A new run's state for `def`, once its vehicles are heard on `fleet` (waits up to `wait`
    /// for each).
    fn new_state(
        fleet: &FleetHandle,
        def: &MissionDef,
        settings: &RunSettings,
        wait: Duration,
    ) -> impl Future<Output = anyhow::Result<Self::State>> + Send;
    /// What to tell the operator about a new run in `dir`.
    fn started_line(dir: &std::path::Path, state: &Self::State) -> String;
    /// Make a saved state ready to fly again: wait up to `wait` for its vehicles, and (unless
    /// the run resumes by itself) take `fleetmap resume` as the operator's "battery swapped".
    /// Returns what to tell the operator.
    fn prepare_resume(
        fleet: &FleetHandle,
        state: &mut Self::State,
        settings: &RunSettings,
        wait: Duration,
    ) -> impl Future<Output = anyhow::Result<String>> + Send;

    /// Fly the run to its end (or until the operator is needed), sending progress to
    /// `progress`. Returns how it ended and the state it ended in.
    fn fly(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: Self::State,
        options: Self::Options,
        progress: Option<mpsc::UnboundedSender<Progress>>,
    ) -> impl Future<Output = anyhow::Result<(Outcome, Self::State)>> + Send;
    /// The run for the TUI session; `on_finish` is called with the final state.
    fn session_run(
        run_dir: RunDir,
        state: Self::State,
        options: Self::Options,
        auto_start: bool,
        on_finish: Option<crate::app::session::OnFinish<Self::State>>,
    ) -> SessionRun;

    /// The report, scored against `world`'s ground truth when there is one.
    fn report(state: &Self::State, world: Option<&World>) -> anyhow::Result<Self::Report>;
    /// Figures of the journal for the JSON report (`journal_records`, …).
    fn journal_figures(events: &[Self::Event]) -> serde_json::Map<String, serde_json::Value>;
    /// The report as text lines (`fleetmap report`, the end of a headless run).
    fn report_lines(report: &Self::Report) -> Vec<String>;
    /// One export: the file name under `exports/` and its bytes.
    fn export(
        state: &Self::State,
        world: Option<&World>,
        format: ExportFormat,
    ) -> anyhow::Result<(&'static str, Vec<u8>)>;
}

/// The kind of a run directory, as `run.json` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// [`crate::app::runway::Runway`].
    RunwayMapping,
    /// [`crate::app::bandit::Classification`].
    SpatialClassification,
}

impl Kind {
    /// The kind of a mission definition.
    pub fn of_mission(def: &MissionDef) -> Kind {
        match def.kind {
            crate::mission::definition::MissionKind::RunwayMapping => Kind::RunwayMapping,
            crate::mission::definition::MissionKind::SpatialClassification => {
                Kind::SpatialClassification
            }
        }
    }

    /// The kind `run.json` names, or a clear error for a kind this build does not know.
    pub fn of_run(meta: &RunMeta) -> anyhow::Result<Kind> {
        use crate::app::{bandit::Classification, runway::Runway};
        match meta.kind.as_str() {
            Runway::KIND => Ok(Kind::RunwayMapping),
            Classification::KIND => Ok(Kind::SpatialClassification),
            other => anyhow::bail!(
                "a {other} run; this build knows {} and {} runs",
                Runway::KIND,
                Classification::KIND
            ),
        }
    }
}

/// Wait up to `wait` for vehicle `sysid`'s heartbeat (a clear error when it stays silent).
pub async fn heard(fleet: &FleetHandle, sysid: u8, wait: Duration) -> anyhow::Result<()> {
    use anyhow::Context as _;
    fleet.wait_vehicle(sysid, wait).await.with_context(|| {
        format!(
            "no heartbeat from system {sysid} within {:.0} s",
            wait.as_secs_f64()
        )
    })?;
    Ok(())
}

/// Write every export of a finished run into its `exports/` (file I/O: call it off the
/// runtime's workers). Returns the files written.
pub fn write_exports<K: RunKind>(
    run_dir: &RunDir,
    state: &K::State,
    world: Option<&World>,
) -> anyhow::Result<Vec<PathBuf>> {
    K::EXPORTS
        .iter()
        .map(|f| {
            let (name, bytes) = K::export(state, world, *f)?;
            Ok(run_dir.write_export(name, &bytes)?)
        })
        .collect()
}

/// The JSON form of the report: the report's fields and the journal's figures.
pub fn report_json<K: RunKind>(
    report: &K::Report,
    events: &[K::Event],
) -> anyhow::Result<serde_json::Value> {
    let mut v = serde_json::to_value(report)?;
    if let Some(o) = v.as_object_mut() {
        o.extend(K::journal_figures(events));
    }
    Ok(v)
}

/// Encode `img` as PNG bytes.
pub fn png_bytes(img: &image::RgbImage) -> anyhow::Result<Vec<u8>> {
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)?;
    Ok(buf.into_inner())
}
