//! The runway run's journal records (`events.jsonl`): one per acknowledged step, read back
//! by the report and by `fleetmap resume`.

use super::*;
use fleetmap_core::explore::mapping::{FinishReason, MilestoneKind};
use fleetmap_core::explore::reach::Unreachable;

/// A journal record of the run (`events.jsonl`), one per acknowledged step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum MappingEvent {
    /// The runner started (or resumed) with these drones.
    Started {
        /// Drones.
        robots: Vec<u8>,
        /// Whether this continues an earlier start.
        resumed: bool,
    },
    /// A sweep image was classified.
    SweepImage {
        /// Vehicle.
        sysid: u8,
        /// Image name.
        image_id: String,
        /// Cell under the camera.
        cell: Cell,
        /// Labels (centre, north, west, south, east).
        labels: [bool; 5],
        /// Classified by the camera on board (its result, not the picture, crossed the link).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        onboard: bool,
    },
    /// A sweep image showed the region: confirmation of `cell` starts.
    Candidate {
        /// Vehicle.
        sysid: u8,
        /// The cell to confirm.
        cell: Cell,
    },
    /// A cell-centre image was classified and its votes counted.
    Image {
        /// Vehicle.
        sysid: u8,
        /// Image name.
        image_id: String,
        /// The cell it was taken over.
        cell: Cell,
        /// Labels (centre, north, west, south, east).
        labels: [bool; 5],
        /// Black fractions (centre, top, left, bottom, right; image coordinates).
        fractions: [f64; 5],
        /// Cells whose state changed.
        changed: Vec<(Cell, String)>,
        /// Classified by the camera on board (its result, not the picture, crossed the link).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        onboard: bool,
    },
    /// A picture classified on board whose vote settled a decision won by one vote was asked
    /// for and classified by the GCS (an audit of the camera): the comparison.
    Audit {
        /// Vehicle.
        sysid: u8,
        /// The cell it was taken over.
        cell: Cell,
        /// The image's name in the run ([`MappingEvent::Image`]).
        image_id: String,
        /// The camera's labels (centre, north, west, south, east).
        camera: [bool; 5],
        /// The GCS's labels (`None`: no picture to classify).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gcs: Option<[bool; 5]>,
        /// Whether the GCS's classification is the camera's exactly (cell, region counts,
        /// labels); `None`: the picture did not arrive or could not be read (`reason`).
        agreed: Option<bool>,
        /// Why there is no comparison.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reason: Option<String>,
    },
    /// The confirmation ended; `root` is where the DFS starts (`None`: back to sweeping).
    Confirmed {
        /// Vehicle.
        sysid: u8,
        /// The candidate.
        cell: Cell,
        /// The DFS root.
        root: Option<Cell>,
    },
    /// A robot reached a vertex.
    Arrived {
        /// Vehicle.
        sysid: u8,
        /// The vertex.
        cell: Cell,
    },
    /// A vertex was imaged; `added` are its new children.
    Observed {
        /// Vehicle.
        sysid: u8,
        /// The vertex.
        cell: Cell,
        /// Cells added to the tree.
        added: Vec<Cell>,
    },
    /// A robot's sweep mission ended.
    SweepComplete {
        /// Vehicle.
        sysid: u8,
    },
    /// A robot's battery is low: it goes home for a swap.
    BatteryLow {
        /// Vehicle.
        sysid: u8,
        /// Charge, percent.
        pct: f64,
        /// Charge the flight home needs, percent.
        needed_pct: f64,
    },
    /// A robot landed for a battery swap.
    LandedForSwap {
        /// Vehicle.
        sysid: u8,
    },
    /// A robot has a fresh battery.
    Swapped {
        /// Vehicle.
        sysid: u8,
        /// How it was noticed: "auto" or "operator".
        by: String,
    },
    /// A robot flies home at the end.
    GoingHome {
        /// Vehicle.
        sysid: u8,
    },
    /// A robot landed at the end.
    Landed {
        /// Vehicle.
        sysid: u8,
    },
    /// A picture was dropped because it was not taken where it would be credited
    /// ([`fleetmap_core::vision::sanity::check_capture`]: position, altitude, tilt or heading out of
    /// limits); a cell-centre picture is taken again.
    ImageRejected {
        /// Vehicle.
        sysid: u8,
        /// The cell it was taken for (`None`: a sweep picture, checked against the vehicle's
        /// position).
        cell: Option<Cell>,
        /// Why, with the figures.
        reason: String,
        /// Failed pictures so far in this visit (a cell), or rejected in a row (the sweep).
        retakes: u32,
    },
    /// The camera failed too often ([`RunOptions::max_retakes`]): nothing more of it is
    /// credited; the vehicle leaves the tree, lands at home and waits for the operator.
    CameraFault {
        /// Vehicle.
        sysid: u8,
        /// The cell being imaged (`None`: in the sweep).
        cell: Option<Cell>,
        /// The last failure.
        reason: String,
        /// The camera went silent (captures unanswered, pictures that never came) rather
        /// than sending wrong pictures: it may come back by itself. Absent: false.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        silent: bool,
    },
    /// A vehicle's silent camera was heard again: the vehicle rejoins by itself (auto-resume;
    /// no battery swap).
    CameraBack {
        /// Vehicle.
        sysid: u8,
    },
    /// An image was lost or unreadable.
    ImageFailed {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// A drone could not take off, or its steps kept failing: it leaves the tree as for a
    /// battery swap (its vertex kept) and waits on the ground; the others go on.
    Grounded {
        /// Vehicle.
        sysid: u8,
        /// What failed.
        reason: String,
        /// What a person must fix (absent: it is tried again by itself with auto-resume).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fix: Option<String>,
    },
    /// A grounded drone takes part again.
    ReadyAgain {
        /// Vehicle.
        sysid: u8,
        /// How: "auto" (its telemetry says it is ready) or "operator".
        by: String,
    },
    /// A step failed and will be retried.
    StepFailed {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// A milestone of the mission clock was reached (journalled with the step that reached
    /// it, or with the next step for the first take-off, which the clock's sampling sees).
    Milestone {
        /// `first_takeoff`, `dfs_start`, `map_complete` or `last_landing`.
        what: MilestoneKind,
        /// Seconds of the fleet clock since the first take-off.
        mission_s: f64,
    },
    /// A drone's flight to a cell was judged beyond reach ([`fleetmap_core::explore::reach`]): the
    /// run finishes ([`fleetmap_core::explore::mapping::GaveUp::BeyondReach`]), every drone goes
    /// home, and nothing is labelled for it.
    BeyondReach {
        /// Vehicle.
        sysid: u8,
        /// The region cell it was to fly to.
        cell: Cell,
        /// Why, with the figures.
        why: Unreachable,
    },
    /// The run is over.
    Finished {
        /// Whether the region was found.
        found: bool,
        /// How it ended (absent in journals written before it was recorded).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reason: Option<FinishReason>,
    },
}
