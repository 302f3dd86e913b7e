//! The mission pane's data: which mission, its phase, run status and progress figures.

use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::fmt;

/// Which mission the pane shows, as its kind describes itself.
///
/// Replay files record its name with `_` for spaces (`"runway_mapping"`; `"none"` without a
/// mission); the UI takes whether it counts epochs from the kind this build registers under
/// that name.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct MissionKind {
    /// What the pane calls it, lower case ("… (name)").
    pub name: Cow<'static, str>,
    /// Whether its runs count epochs: the pane shows "Epochs N done" from the start.
    pub epochs: bool,
}

impl MissionKind {
    /// A kind named `name` (lower case, words separated by spaces) that counts epochs or not.
    pub const fn new(name: &'static str, epochs: bool) -> MissionKind {
        MissionKind {
            name: Cow::Borrowed(name),
            epochs,
        }
    }

    /// The name as replay files record it: `_` for each space.
    pub(crate) fn recorded(&self) -> String {
        self.name.replace(' ', "_")
    }
}

/// How replay files spell [`MissionModel::kind`]: `"none"`, or the kind's name with `_` for
/// spaces (the spelling of the UI's own enum of kinds before the kinds named themselves).
mod kind_replay {
    use super::MissionKind;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::borrow::Cow;

    pub(super) fn serialize<S: Serializer>(
        k: &Option<MissionKind>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        match k {
            None => "none".to_string(),
            Some(k) => k.recorded(),
        }
        .serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<MissionKind>, D::Error> {
        let recorded = String::deserialize(d)?;
        Ok((recorded != "none").then(|| MissionKind {
            name: Cow::Owned(recorded.replace('_', " ")),
            epochs: false,
        }))
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
