//! The mission pane's data: which mission, its phase, run status and progress figures.

use serde::{Deserialize, Serialize};
use std::fmt;

/// The mission kind: the mission file's vocabulary (`None`: no mission loaded).
pub(crate) use fleetmap_core::mission::definition::MissionKind;

/// How replay files spell [`MissionModel::kind`]: `"none"`, `"runway_mapping"`,
/// `"spatial_classification"` (the UI's own spelling before it used the mission file's kind).
mod kind_replay {
    use super::MissionKind;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// The recorded form (snake_case unit variants).
    #[derive(Serialize, Deserialize)]
    #[serde(rename_all = "snake_case")]
    enum Recorded {
        None,
        RunwayMapping,
        SpatialClassification,
    }

    pub(super) fn serialize<S: Serializer>(
        k: &Option<MissionKind>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        match k {
            None => Recorded::None,
            Some(MissionKind::RunwayMapping) => Recorded::RunwayMapping,
            Some(MissionKind::SpatialClassification) => Recorded::SpatialClassification,
        }
        .serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<MissionKind>, D::Error> {
        Ok(match Recorded::deserialize(d)? {
            Recorded::None => None,
            Recorded::RunwayMapping => Some(MissionKind::RunwayMapping),
            Recorded::SpatialClassification => Some(MissionKind::SpatialClassification),
        })
    }
}

/// The mission's phase.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "phase")]
pub enum Phase {
    /// Loaded, not started.
    #[default]
    Idle,
    /// Runway mapping phase 1: the lawnmower sweep of the bounding box.
    Sweep,
    /// Runway mapping phase 2: the multi-robot recursive DFS.
    Dfs,
    /// Spatial classification epoch `p` (1-based).
    Epoch {
        /// The epoch number.
        p: u32,
    },
    /// Returning to the start.
    Return,
    /// Finished.
    Done,
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Phase::Idle => write!(f, "idle"),
            Phase::Sweep => write!(f, "sweep"),
            Phase::Dfs => write!(f, "DFS"),
            Phase::Epoch { p } => write!(f, "epoch {p}"),
            Phase::Return => write!(f, "return"),
            Phase::Done => write!(f, "done"),
        }
    }
}

/// Whether the run is moving.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// Not started yet.
    #[default]
    NotStarted,
    /// Flying.
    Running,
    /// Paused by the operator (vehicles holding).
    Paused,
    /// Waiting for the operator to swap a battery.
    BatterySwap,
    /// Completed.
    Done,
    /// Ended because the region drifted beyond the drones' reach (runway mapping; shown from
    /// the moment the run gives up, while the drones fly home).
    BeyondReach,
    /// Stopped on an error.
    Failed,
}

impl RunStatus {
    /// Upper-case label for the status bar.
    pub fn label(self) -> &'static str {
        match self {
            RunStatus::NotStarted => "NOT STARTED",
            RunStatus::Running => "RUNNING",
            RunStatus::Paused => "PAUSED",
            RunStatus::BatterySwap => "BATTERY SWAP",
            RunStatus::Done => "DONE",
            RunStatus::BeyondReach => "BEYOND REACH",
            RunStatus::Failed => "FAILED",
        }
    }
}

/// DFS vertex counts (runway mapping phase 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DfsProgress {
    /// Vertices fully explored.
    pub explored: u32,
    /// Vertices a robot is exploring now.
    pub(crate) under_exploration: u32,
    /// Known vertices not yet visited.
    pub unexplored: u32,
}

/// A labelled figure the runner wants shown (IoU, false positives, …).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stat {
    /// Label.
    pub label: String,
    /// Value, already formatted with its unit.
    pub value: String,
}

/// The mission pane.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MissionModel {
    /// Human name of the mission (from its definition file).
    pub name: String,
    /// Its kind (`None`: no mission loaded).
    #[serde(with = "kind_replay")]
    pub kind: Option<MissionKind>,
    /// Phase.
    pub phase: Phase,
    /// Running, paused, …
    pub status: RunStatus,
    /// Cells classified so far.
    pub cells_classified: u32,
    /// Cells to classify in total, when known.
    pub cells_total: Option<u32>,
    /// DFS vertex counts, in phase 2 of runway mapping.
    pub dfs: Option<DfsProgress>,
    /// Epochs completed (spatial classification).
    pub(crate) epochs_done: u32,
    /// Flight time so far (summed over the fleet's airborne time), seconds.
    pub flight_time_s: f64,
    /// Battery swaps so far.
    pub battery_swaps: u32,
    /// Time spent in the planner (IP solves, DFS updates), seconds.
    pub(crate) planner_time_s: f64,
    /// Extra figures.
    pub stats: Vec<Stat>,
}
