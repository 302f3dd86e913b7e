//! Spatial classification's built-in sample: a static fixture (`fleetmap tui --sample
//! classification`, the UI's snapshot tests).

use super::panes::LOOK;
use crate::panes::{
    MapModel, MissionModel, Model, Phase, Role, RunStatus, Sample, Stat, VehicleRow,
};
use crate::panes::{copter, log_line};
use fleetmap_core::geo::Cell;
use fleetmap_core::proto::flavour::{Autopilot, VehicleClass};
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;

/// The static fixture (an animated sample has no drones to choose).
pub(super) fn sample(_vehicles: usize) -> Sample {
    Sample::Static(Box::new(fixture()))
}

/// Spatial classification, epoch 4 on the 6 × 6 hardware-test grid: two drones, two
/// charging rovers on the road column, keep / reject / obstacle cells.
pub fn fixture() -> Model {
    let rows = ["K?x=?K", "??@=?x", "x?@=K?", "K?x=??", "??x=?K", "?x?=x?"];
    let mut map = MapModel::from_rows(LOOK.map, 10.0, Cell::new(0, 0), &rows)
        .expect("fixture rows are valid");
    map.home = Some(Cell::new(0, 3));
    let drone = |id: u8, ap: Autopilot, cell: Cell| {
        let mut v = copter(id);
        v.autopilot = ap;
        v.mode = if ap == Autopilot::Px4 {
            "Mission".into()
        } else {
            "AUTO".into()
        };
        v.cell = Some(cell);
        v.activity = Some(format!("sense {cell}"));
        v
    };
    let rover = |id: u8, cell: Cell| VehicleRow {
        role: Role::Station,
        vehicle_type: VehicleClass::Rover,
        mode: "AUTO".into(),
        alt_m: Some(0.0),
        speed_mps: Some(0.8),
        cell: Some(cell),
        activity: Some("charging pad".into()),
        camera: None,
        ..copter(id)
    };
    Model {
        time: Time::from_secs(1320),
        vehicles: vec![
            drone(1, Autopilot::ArduPilot, Cell::new(4, 1)),
            drone(2, Autopilot::Px4, Cell::new(1, 4)),
            rover(11, Cell::new(4, 3)),
            rover(12, Cell::new(1, 3)),
        ],
        map,
        mission: MissionModel {
            name: "6x6 hardware test".into(),
            kind: Some(LOOK.mission),
            phase: Phase::Epoch { p: 4 },
            status: RunStatus::Paused,
            cells_classified: 17,
            cells_total: Some(30),
            dfs: None,
            epochs_done: 3,
            flight_time_s: 1710.0,
            battery_swaps: 1,
            planner_time_s: 12.6,
            stats: vec![
                Stat {
                    label: "keep".into(),
                    value: "6".into(),
                },
                Stat {
                    label: "reject".into(),
                    value: "8".into(),
                },
                Stat {
                    label: "IP gap".into(),
                    value: "0.0 %".into(),
                },
            ],
        },
        log: vec![
            log_line(1201, Severity::Info, None, "epoch 4: IP solved in 3.1 s"),
            log_line(1260, Severity::Notice, None, "paused by operator"),
        ],
        sim_speed: None,
    }
}
