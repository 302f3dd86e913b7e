//! Spatial classification's own errors: what its runner meets that no other kind does — a
//! sortie the vehicles refused or the planner could not make, an unsafe mission, a check of
//! its own that did not hold (a charger, a start cell, a plan, the members, the pictures)
//! ([`BanditError`]), and a drone or station late ([`Overdue`]). The runner's layer carries
//! them boxed ([`RunnerError::Kind`], [`RunnerError::Overdue`]) and reads them back typed
//! ([`RunnerError::kind`]); each reads as the operator read it before it moved here.

use crate::app::error::{KindError, RunnerError, kind_causes};
use fleetmap_core::planner::sortie::SortieError;
use std::time::Duration;

/// What the spatial-classification runner meets that is its own. A person must see to it.
#[derive(Debug, thiserror::Error)]
pub enum BanditError {
    /// The vehicles refused the sortie's missions.
    #[error(transparent)]
    Rejected(#[from] SortieRejected),
    /// The planner could not make or check a sortie.
    #[error(transparent)]
    Sortie(#[from] SortieError),
    /// A mission would cross a no-fly cell (or leave the area, or a station its
    /// roads), before upload or as the vehicle read it back.
    #[error("{role} {sysid}: the mission{} is unsafe", if *.read_back { " as read back" } else { "" })]
    UnsafeMission {
        /// The vehicle's role ("drone", "station", "vehicle").
        role: &'static str,
        /// The vehicle.
        sysid: u8,
        /// Whether the list checked is the one the vehicle returned.
        read_back: bool,
        /// The first violation.
        #[source]
        source: fleetmap_core::planner::sortie::missions::UnsafeMission,
    },
    /// A charging station reports no position to land on.
    #[error("station {station} reports no position")]
    StationPosition {
        /// The station.
        station: u8,
    },
    /// A drone has no station to land on.
    #[error("no landing station")]
    NoLandingStation,
    /// The run's state has no sortie where the step needs one.
    #[error("{0}")]
    NoSortie(SortieStage),
    /// A vehicle is not where its start cell is.
    #[error(
        "vehicle {sysid} is {distance_m:.1} m from the centre of its start cell {cell}: place \
         it there (or fix `start` in the mission file)"
    )]
    Misplaced {
        /// The vehicle.
        sysid: u8,
        /// How far from the cell's centre, metres.
        distance_m: f64,
        /// Its start cell.
        cell: fleetmap_core::geo::Cell,
    },
    /// A drone's charge does not rise on its station.
    #[error(
        "drone {sysid} is not charging (stuck at {pct} %, the sortie needs {need_pct:.0} %): put \
         it on its station's charger or swap its battery{nearest}"
    )]
    NotCharging {
        /// The drone.
        sysid: u8,
        /// Its charge, percent (-1: unknown).
        pct: i8,
        /// What the sortie needs, percent.
        need_pct: f64,
        /// Where the nearest station is, as a sentence after the advice (empty: unknown).
        nearest: String,
    },
    /// The planner found no plan from where the team is.
    #[error(
        "epoch {epoch}: the planner found no plan ({status}{}): the goals cannot be reached \
         from where the team is within {cycles} sensing cycles",
        if message.is_empty() { String::new() } else { format!(": {message}") }
    )]
    NoPlan {
        /// The epoch.
        epoch: u64,
        /// The solver's status.
        status: &'static str,
        /// The solver's message (empty: none).
        message: String,
        /// The sensing cycles planned for.
        cycles: usize,
    },
    /// The run cannot go on without members a person must fix.
    #[error("{why}: a person must fix {members}")]
    MembersNeedPerson {
        /// Why the run needs them.
        why: String,
        /// Each member out and what to fix, "role sysid: fix; …".
        members: String,
    },
    /// The run cannot go on without members, none of which came back.
    #[error("{why}, and after {tries} tries none of them is ready: {members}")]
    MembersNotReady {
        /// Why the run needs them.
        why: String,
        /// How many times they were tried.
        tries: u32,
        /// Each member out and why, "role sysid: reason; …".
        members: String,
    },
    /// Epochs in a row had capture visits and no measurement: the pictures do not arrive.
    #[error(
        "no measurement reached the GCS in the last {epochs} epochs ({visits} capture visits): \
         the drones' pictures (or their cameras' on-board measurements) do not arrive — \
         check that each drone's camera takes its pictures and that its messages \
         (CAMERA_IMAGE_CAPTURED with DEBUG_FLOAT_ARRAY, or image transmission) reach the \
         GCS, then `fleetmap resume` the run"
    )]
    NoMeasurements {
        /// The epochs without a measurement.
        epochs: usize,
        /// The capture visits they had.
        visits: u64,
    },
}

impl From<BanditError> for RunnerError {
    fn from(e: BanditError) -> Self {
        RunnerError::Kind(KindError::new(e))
    }
}

impl From<Overdue> for RunnerError {
    fn from(e: Overdue) -> Self {
        RunnerError::Overdue(KindError::new(e))
    }
}

kind_causes!(BanditError: SortieRejected, SortieError);

/// Where in a sortie's life a step needed one ([`BanditError::NoSortie`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SortieStage {
    /// Uploading a planned sortie.
    Prepared,
    /// Starting a verified sortie.
    Verified,
    /// Waiting for a flying sortie to end.
    Flying,
    /// Recording where an ended sortie left the team.
    Ended,
}

impl std::fmt::Display for SortieStage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SortieStage::Prepared => "no sortie is prepared",
            SortieStage::Verified => "no sortie is verified",
            SortieStage::Flying => "no sortie is flying",
            SortieStage::Ended => "no sortie",
        })
    }
}

/// A drone or station late: what trying again may get past (a link outage, a slow
/// rendezvous).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Overdue {
    /// A sortie did not end within its budget.
    #[error("epoch {epoch} cycle {cycle}: the sortie did not end within {budget_s:.0} s")]
    Sortie {
        /// The epoch.
        epoch: u64,
        /// The sensing cycle.
        cycle: usize,
        /// Its budget, seconds.
        budget_s: f64,
    },
    /// A drone's mission did not end by the sortie's deadline.
    #[error("drone {sysid}: its mission did not end in time (at step {step})")]
    Mission {
        /// The drone.
        sysid: u8,
        /// The last mission step it reached.
        step: usize,
    },
    /// A drone's station never came to the rendezvous.
    #[error("drone {sysid}: station {station} never reached the rendezvous")]
    Rendezvous {
        /// The drone.
        sysid: u8,
        /// Its station.
        station: u8,
    },
    /// A drone its autopilot took out of its mission has not landed.
    #[error(
        "drone {sysid}: taken out of its mission by its autopilot ({mode}), it has not landed \
         by the end of the sortie"
    )]
    TakenOut {
        /// The drone.
        sysid: u8,
        /// The mode it was in.
        mode: String,
    },
    /// A drone did not land in time.
    #[error("drone {sysid}: did not land within {wait:?}")]
    Landing {
        /// The drone.
        sysid: u8,
        /// How long the runner waited.
        wait: Duration,
    },
}

/// Why a sortie stopped before take-off.
#[derive(Debug, thiserror::Error)]
#[error(
    "the sortie of epoch {epoch}, cycle {cycle} stopped before take-off: vehicle {sysid} \
     rejected its mission: {reason}"
)]
pub struct SortieRejected {
    /// Epoch p.
    pub epoch: u64,
    /// Cycle.
    pub cycle: usize,
    /// The vehicle.
    pub sysid: u8,
    /// Why.
    pub reason: String,
}
