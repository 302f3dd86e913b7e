//! The bandit run's journal records (`events.jsonl`): epochs, plans, sorties, every
//! counted measurement, read back by the report and by `fleetmap resume`.

use super::*;

/// A journal record of the run (`events.jsonl`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum BanditEvent {
    /// The runner started (or resumed).
    Started {
        /// Whether this continues an earlier start.
        resumed: bool,
    },
    /// A vehicle holds the geofence (uploaded, read back, enabled).
    Fence {
        /// Vehicle.
        sysid: u8,
        /// Fence items.
        items: usize,
    },
    /// Epoch p began with these goals (3).
    EpochStarted {
        /// Epoch p.
        epoch: u64,
        /// E_p.
        goals: Vec<Cell>,
    },
    /// The IP planned the rest of the epoch.
    Planned {
        /// Epoch p.
        epoch: u64,
        /// Sensing cycles.
        cycles: usize,
        /// Goals planned for.
        goals: usize,
        /// Solver wall time, seconds.
        seconds: f64,
        /// A re-plan (resume, or the team ended elsewhere than planned).
        replan: bool,
    },
    /// The missions of a sortie were built and checked.
    SortiePrepared {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
        /// Vehicles that move, with their item counts.
        missions: Vec<(u8, usize)>,
    },
    /// Every mission of the sortie is on its vehicle, read back identical.
    SortieVerified {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
    },
    /// A vehicle refused its mission: the sortie stopped before take-off.
    SortieRejected {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// The sortie's vehicles were started.
    SortieStarted {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
    },
    /// One image measurement (counted or not).
    Measurement(Measurement),
    /// An image that does not count (why).
    ImageIgnored {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// An image could not be read.
    ImageFailed {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// A cell was classified by (4).
    Classified {
        /// The cell.
        cell: Cell,
        /// Keep or reject.
        label: Label,
        /// |H_l|.
        samples: u64,
        /// μ̂_l.
        mean: f64,
    },
    /// A drone landed on its station at the rendezvous.
    Landed {
        /// Vehicle.
        sysid: u8,
        /// The cell.
        cell: Cell,
        /// Distance to the station, metres.
        from_station_m: f64,
    },
    /// The sortie ended with the team at `config`.
    SortieDone {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
        /// Seconds flown.
        seconds: f64,
        /// The team configuration.
        config: TeamConfig,
    },
    /// Lock-step (7e): a drone a step ahead of the others holds where it is.
    Held {
        /// Vehicle.
        sysid: u8,
        /// The step it has arrived at.
        step: usize,
    },
    /// A prepared sortie was dropped before anything drove: on resume (nothing had
    /// started), or because a vehicle could not start ([`BanditEvent::VehicleOut`]).
    SortieDropped {
        /// Epoch p.
        epoch: u64,
    },
    /// A vehicle could not start and is out of the run for now (the others fly, the rest of
    /// the epoch is planned without it; `fix`: what a person must fix, else it is tried
    /// again by itself).
    VehicleOut {
        /// Vehicle.
        sysid: u8,
        /// Drone or station.
        role: Role,
        /// What failed.
        reason: String,
        /// What a person must fix (absent: it is tried again at a later sortie).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        fix: Option<String>,
        /// Epoch p.
        epoch: u64,
    },
    /// A vehicle that was out takes part again.
    VehicleBack {
        /// Vehicle.
        sysid: u8,
        /// Why it was out.
        was: String,
    },
    /// The epoch ended.
    EpochDone(EpochStats),
    /// Every cell is classified.
    Finished {
        /// K.
        keep: Vec<Cell>,
        /// R.
        reject: Vec<Cell>,
    },
}
