//! What a run shows: the operator's screen as plain data, which the terminal UI draws
//! (`crate::tui`) and each mission kind fills from its state (`RunKind::panes` in
//! `crate::app::kind`).
//!
//! The UI never reads the fleet actor or the mission runners directly. An adapter
//! (`crate::tui::live`) fills a [`Model`] from fleet snapshots and the run's [`Panes`] and
//! publishes it on a `fleetmap_io::watch` channel; a replay file, a built-in sample or a test
//! constructs one the same way. Every type of the model is `serde`, so a [`Model`] round-trips
//! through JSON (replay files are JSON Lines of `crate::tui::replay::ReplayFrame`).
//!
//! Units are in the field names: metres (`_m`), metres per second (`_mps`), volts (`_v`),
//! seconds (`_s`), percent (`_pct`). Times are [`Time`] (µs on the clock of whoever made
//! the model; the UI shows them as elapsed `h:mm:ss`).
//!
//! One file per pane's data: `vehicle` (fleet rows), `map` (grid and cell states),
//! `mission` (phase and progress), `log` (messages); `run` is what a kind supplies (its
//! panes from its state, its look, its built-in sample).

mod log;
mod map;
mod mission;
mod run;
mod vehicle;

pub use log::LogEntry;
pub use map::{CellState, MapError, MapKind, MapModel, Track};
pub use mission::{DfsProgress, MissionKind, MissionModel, Phase, RunStatus, Stat};
pub use run::{Animation, KindLook, Panes, RunInfo, Sample};
pub(crate) use run::{copter, log_line};
pub(crate) use vehicle::Role;
pub use vehicle::{Battery, CameraHealth, Gps, GpsFix, LinkState, MissionProgress, VehicleRow};

use fleetmap_core::time::Time;
use serde::{Deserialize, Serialize};

/// Everything the screen shows that comes from outside the UI.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Model {
    /// When the adapter made this snapshot (on its clock).
    pub time: Time,
    /// One row per known vehicle, in display order.
    pub vehicles: Vec<VehicleRow>,
    /// The mission grid and its cell states.
    pub map: MapModel,
    /// Mission phase and progress.
    pub mission: MissionModel,
    /// Recent messages, oldest first (the adapter keeps it bounded).
    pub log: Vec<LogEntry>,
    /// Simulated seconds per wall second the simulator achieves, when the fleet runs on a
    /// simulator's time (the demo): below its ceiling on a busy machine (lock-step).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sim_speed: Option<f64>,
}

impl Model {
    /// The row of the vehicle with system id `sysid`.
    pub fn vehicle(&self, sysid: u8) -> Option<&VehicleRow> {
        self.vehicles.iter().find(|v| v.sysid == sysid)
    }
}
/// `h:mm:ss` (or `mm:ss` under an hour) of a duration in seconds; negative and NaN show as 0.
pub(crate) fn format_hms(secs: f64) -> String {
    let s = if secs.is_finite() && secs > 0.0 {
        secs as u64
    } else {
        0
    };
    let (h, m, s) = (s / 3600, (s / 60) % 60, s % 60);
    if h > 0 {
        format!("{h}:{m:02}:{s:02}")
    } else {
        format!("{m:02}:{s:02}")
    }
}

#[cfg(test)]
mod tests;
