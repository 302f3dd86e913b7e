//! The spatial-classification run (bandit paper Algorithm 1, §V) on real or simulated
//! vehicles: the async shell around [`ClassificationState`].
//!
//! One loop asks the state what to do next ([`ClassificationState::next`]) and does it:
//!
//! * **Epoch** (Algorithm 1, steps 3–6): the goals (3) are chosen between sorties, while the
//!   drones charge on their stations; the IP (11) runs on a blocking thread
//!   ([`fleetmap_core::planner::ip::solve_instance`], K doubled when infeasible).
//! * **Sortie** (one sensing cycle): the cycle's missions ([`fleetmap_core::planner::sortie::missions`])
//!   are checked against the no-fly cells, uploaded to every vehicle that moves, read back and
//!   compared item by item, and checked again as read back — only then, and once every drone
//!   has the charge the sortie needs, are all vehicles started: drones take off from their
//!   station and fly their cells, capturing B images at each unclassified cell; once they are
//!   in the air, rovers drive their road cells at v_c = v_d·T_c/T_d (a rover never drives off
//!   with a drone taking off from it). A vehicle that refuses its mission stops the sortie
//!   before anything takes off.
//! * **Following**: one task per drone follows its mission; at the end of its cells it hovers
//!   until the station it lands on has arrived (a station that falls behind holds its drones at
//!   the rendezvous, and the next sortie waits for everyone), then lands on the station's
//!   reported position (its charger slot). With lock-step separation (7e) a coordinator holds
//!   every drone that is a step ahead (GUIDED hold) until the others have reached its step.
//! * **Images** → green-pixel measurement of the part of the image over the cell
//!   ([`fleetmap_core::vision::green`]) → H → (4); the state is saved (atomically) and the measurement
//!   journalled after every image.
//! * **Geofence**: at the start of a run every vehicle gets the no-fly cells as a fence
//!   (MAV_MISSION_TYPE_FENCE, inclusion + exclusion polygons), read back and enabled
//!   (ArduPilot DO_FENCE_ENABLE; PX4 enforces an uploaded fence).
//!
//! **Resume** (`fleetmap resume`): a sortie that was flying is followed to its end — the
//! vehicles fly their uploaded missions on their own, and drones left hovering at their last
//! cell are landed — then the rest of the epoch is planned again from where telemetry puts the
//! vehicles. A sortie that had not started is dropped and re-planned. Every measurement the
//! dead GCS had acknowledged is in the state; images taken while no GCS listened are lost, as
//! they would be with any ground station.

use self::error::SortieRejected;
use crate::app::error::Context as _;
use crate::app::error::RunnerResult;
use crate::app::flight::{self, Patience};
use crate::app::images::{ImageHub, ReceivedImage};
use crate::app::run::{Progress, RunCore};
use crate::fleet::{FleetHandle, VehicleSnapshot};
use crate::store::RunDir;
use fleetmap_core::geo::{Cell, LatLon, local};
use fleetmap_core::mission::definition::Role;
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::planner::bandit::Label;
use fleetmap_core::planner::ip::{PlanOptions, PlanStatus, solve_instance};
use fleetmap_core::planner::sortie::missions::{self, AreaRules};
use fleetmap_core::planner::sortie::{
    CaptureKey, ClassificationState, CycleEnd, CyclePhase, EpochStats, MAX_K, Measurement, Next,
    Separation, Sidelined, TeamConfig,
};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::Command;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::vision::geometry;
use fleetmap_core::vision::green::GreenParams;
use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use fleetmap_core::vision::onboard::GreenSpec;
use fleetmap_core::vision::sanity::{self, CaptureClaim, CaptureLimits, check_capture};
use fleetmap_io::watch;
use mavlink::dialects::ardupilotmega::MavCmd;
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{broadcast, mpsc};

use fleetmap_core::planner::sortie::KIND;

mod args;
pub mod commands;
#[cfg(feature = "sim")]
pub mod demo;
pub mod error;
mod events;
mod kind;
pub mod report;
pub use self::kind::Classification;
mod intake;
mod members;
mod panes;
mod pilot;
pub mod plan;
mod runner;
pub mod sample;
#[cfg(feature = "sim")]
pub mod sim;
mod sortie;
mod stragglers;
mod summary;
#[cfg(test)]
mod tests;
mod upload;

pub use self::args::{BoundArg, ModelArg};
pub use self::events::*;
pub use self::intake::*;

pub use self::runner::*;
use self::upload::*;

/// Options of a run.
#[derive(Default)]
pub struct RunOptions {
    /// Progress lines (headless stdout, the TUI's log).
    pub progress: Option<mpsc::UnboundedSender<Progress>>,
    /// The state after every change (the TUI's panes).
    pub view: Option<watch::Sender<Arc<ClassificationState>>>,
    /// Timeout scaling.
    pub patience: Patience,
    /// HiGHS time limit per solve, seconds (`None`: none).
    pub plan_time_limit_s: Option<f64>,
    /// Send drones off only with at least this charge, percent (`None`: the reserve plus
    /// 1.5 × the sortie's estimated need).
    pub min_takeoff_pct: Option<f64>,
    /// The operator's pause (the TUI): while it reads `true`, no new sortie starts — the
    /// drones in the air finish theirs and land on their stations, which is where a
    /// spatial-classification team waits (charging) between sorties anyway.
    pub pause: Option<watch::Receiver<bool>>,
    /// Carry on by itself through failures that may go away (a lost link, a vehicle late
    /// at a rendezvous, a sortie that could not start): the run picks up from its saved
    /// state as `fleetmap resume` would, and stops only for what a person must fix
    /// (`crate::app::error::RunnerError::needs_person`).
    pub auto_resume: bool,
}

/// The bandit run's shared part: the run core (state, store, progress, view) and what the
/// runner, the pilots and the image intake read besides.
struct Shared {
    run: Arc<RunCore<ClassificationState>>,
    fleet: FleetHandle,
    patience: Patience,
    /// Drones whose autopilot has reported charging at least once (BATTERY_STATUS
    /// charge_state): only for those is "not charging" evidence of a missed charger.
    reports_charging: Arc<std::sync::Mutex<BTreeSet<u8>>>,
    /// The run's image intake: which cameras are still sending pictures.
    hub: ImageHub,
}

impl Shared {
    fn say(&self, event: Progress) {
        self.run.say(event);
    }

    /// Mutate the state, save it, then journal `events`; notify everyone
    /// ([`RunCore::commit`] with the bandit's types).
    async fn commit<T>(
        &self,
        f: impl FnOnce(&mut ClassificationState) -> RunnerResult<(T, Vec<BanditEvent>)>,
    ) -> RunnerResult<T> {
        self.run.commit(f).await
    }

    async fn read<T>(&self, f: impl FnOnce(&ClassificationState) -> T) -> T {
        self.run.read(f).await
    }

    async fn wait_change(&self, timeout: Duration) {
        self.run.wait_change(timeout).await;
    }
}

struct Runner {
    shared: Arc<Shared>,
    plan_time_limit_s: Option<f64>,
    min_takeoff_pct: Option<f64>,
    pause: Option<watch::Receiver<bool>>,
    /// Drones of the sortie in flight whose mission would not start: they hover over their
    /// station and land at the rendezvous.
    no_mission: std::sync::Mutex<BTreeSet<u8>>,
}

/// One drone of a sortie: follows its mission, waits at the rendezvous, lands.
struct DronePilot {
    shared: Arc<Shared>,
    sysid: u8,
    items: Vec<MissionItem>,
    resumed: bool,
    /// Its mission did not start: it goes straight to the rendezvous.
    no_mission: bool,
    /// When the sortie must have ended, on the fleet's clock.
    deadline: fleetmap_core::time::Time,
}
