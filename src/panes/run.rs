//! What a mission kind supplies to the screen: its panes drawn from its state
//! ([`Panes`]), how it looks ([`KindLook`]) and its built-in sample ([`Sample`]).

use super::{Battery, CameraHealth, Gps, GpsFix, LinkState, MissionProgress, Role};
use super::{LogEntry, MapKind, MapModel, MissionKind, MissionModel, Model, VehicleRow};
use fleetmap_core::geo::Grid;
use fleetmap_core::proto::flavour::{Autopilot, VehicleClass};
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use std::collections::BTreeMap;
use std::time::Duration;

/// What the mission runner is doing, as the session knows it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunInfo {
    /// Mission name.
    pub name: String,
    /// Started (the operator pressed start, or the run started by itself).
    pub started: bool,
    /// Paused by the operator.
    pub paused: bool,
    /// The runner stopped on an error.
    pub failed: Option<String>,
}

/// A run's panes, as its kind draws them from its state.
#[derive(Clone, Debug)]
pub struct Panes {
    /// The map pane.
    pub map: MapModel,
    /// The mission pane.
    pub mission: MissionModel,
    /// The run's vehicles in mission order (the fleet table lists them first).
    pub order: Vec<u8>,
    /// The mission grid (the fleet table's cell of each vehicle).
    pub grid: Grid,
    /// What each of the run's vehicles is doing (the fleet table's activity), by system id.
    pub activity: BTreeMap<u8, String>,
}

/// How a kind's panes look, whatever the state: what the UI needs to draw a recorded model
/// of the kind, and the name of its built-in sample.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KindLook {
    /// Its map: label and legend.
    pub map: MapKind,
    /// Its name on the mission pane, and whether it counts epochs.
    pub mission: MissionKind,
    /// The value of `fleetmap tui --sample` that shows its built-in sample.
    pub sample: &'static str,
    /// What that sample shows (`fleetmap tui --help`).
    pub sample_help: &'static str,
}

/// A synthetic run that moves: the UI shows it step by step.
pub trait Animation: Send {
    /// Advance by `dt` of simulated time.
    fn step(&mut self, dt: Duration);
    /// The current state as a [`Model`].
    fn model(&self) -> Model;
    /// Whether it finished.
    fn done(&self) -> bool;
}

/// A kind's built-in sample (`fleetmap tui --sample`): labelled SAMPLE wherever it is shown.
pub enum Sample {
    /// A synthetic animation.
    Animated(Box<dyn Animation>),
    /// A static fixture.
    Static(Box<Model>),
}

/// A fixture's ArduPilot copter `sysid` in AUTO: armed, 76 %, 3D fix, good link and camera.
pub(crate) fn copter(sysid: u8) -> VehicleRow {
    VehicleRow {
        sysid,
        role: Role::Drone,
        autopilot: Autopilot::ArduPilot,
        vehicle_type: VehicleClass::Copter,
        mode: "AUTO".into(),
        armed: true,
        battery: Battery {
            remaining_pct: Some(76),
            voltage_v: Some(15.9),
            cells: Some(4),
        },
        gps: Gps {
            fix: GpsFix::Fix3d,
            satellites: Some(14),
        },
        alt_m: Some(12.0),
        speed_mps: Some(1.0),
        mission: Some(MissionProgress {
            current: 7,
            total: 31,
        }),
        link: LinkState {
            quality_pct: Some(98),
            lost: false,
            last_heard_s: Some(0.2),
            bytes_per_s: Some(612.0),
            budget_bytes_per_s: Some(2000),
            rssi: Some((182, 176)),
        },
        cell: None,
        activity: None,
        camera: Some(CameraHealth {
            heard_s: 0.4,
            silent: false,
            pictures: 42,
            measurements: 41,
        }),
    }
}

/// A fixture's log line at `t_s` seconds.
pub(crate) fn log_line(t_s: u64, severity: Severity, sysid: Option<u8>, text: &str) -> LogEntry {
    LogEntry {
        time: Time::from_secs(t_s),
        severity,
        sysid,
        text: text.into(),
    }
}
