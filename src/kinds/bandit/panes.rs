//! Spatial classification's panes: the map (G with obstacles, roads and the labels of (4);
//! the paths of the sortie in flight), the mission pane (epoch, status, keep / reject,
//! figures) and what each drone and station is doing, drawn from a [`ClassificationState`].

use crate::panes::{
    CellState, KindLook, MapKind, MapModel, MissionKind, MissionModel, Panes, Phase, RunInfo,
    RunStatus, Stat, Track,
};
use fleetmap_core::geo::Cell;
use fleetmap_core::planner::bandit::Label;
use fleetmap_core::planner::sortie::{ClassificationState, CyclePhase};

/// The cell states of a classification map, in legend order: not yet classified, the two
/// labels, then the cells no drone senses.
const LEGEND: [CellState; 5] = [
    CellState::Unclassified,
    CellState::Keep,
    CellState::Reject,
    CellState::Obstacle,
    CellState::Road,
];

/// How spatial classification's panes look.
pub(super) const LOOK: KindLook = KindLook {
    map: MapKind::new("classification", &LEGEND),
    mission: MissionKind::new("spatial classification", true),
    sample_help: "Static spatial-classification snapshot (drones and charging rovers on a 6x6 grid)",
    sample: "classification",
};

/// The panes of a spatial-classification run.
pub(super) fn panes(state: &ClassificationState, info: &RunInfo) -> Panes {
    // The run's vehicles in mission order: drones, then stations.
    let order: Vec<u8> = state
        .drones
        .iter()
        .chain(&state.stations)
        .map(|m| m.sysid)
        .collect();
    Panes {
        map: map(state),
        mission: mission(state, info),
        activity: order
            .iter()
            .filter_map(|&id| Some((id, activity(state, id)?)))
            .collect(),
        order,
        grid: state.grid.clone(),
    }
}

/// The map of a spatial-classification run: G with O (obstacles), R (roads, while
/// unclassified) and the labels of (4); the drones' paths of the sortie in flight as tracks;
/// the first station's start cell as home.
fn map(state: &ClassificationState) -> MapModel {
    let l = &state.layout;
    let mut m = MapModel::new(
        LOOK.map,
        state.grid.cell_size(),
        Cell::new(0, 0),
        l.rows.clamp(1, 400),
        l.cols.clamp(1, 400),
    );
    for r in 0..l.rows as i32 {
        for c in 0..l.cols as i32 {
            m.set(Cell::new(r, c), CellState::Unclassified);
        }
    }
    for &c in &l.roads {
        m.set(c, CellState::Road);
    }
    for (&c, label) in state.bandit.cells.iter().zip(&state.bandit.labels) {
        match label {
            Label::Keep => m.set(c, CellState::Keep),
            Label::Reject => m.set(c, CellState::Reject),
            Label::Unclassified => false,
        };
    }
    for &c in &l.obstacles {
        m.set(c, CellState::Obstacle);
    }
    if let Some(cy) = state.cycle() {
        m.tracks = cy
            .drones
            .iter()
            .filter(|d| d.flies)
            .map(|d| Track {
                sysid: d.sysid,
                cells: d.path.clone(),
            })
            .collect();
    }
    m.home = state.config.stations.first().copied();
    m
}

/// What a member of a spatial-classification team is doing (`None`: not a member).
fn activity(state: &ClassificationState, sysid: u8) -> Option<String> {
    let cy = state.cycle();
    if let Some(i) = state.drones.iter().position(|d| d.sysid == sysid) {
        let leg = cy.and_then(|c| c.drones.iter().find(|d| d.sysid == sysid));
        return Some(match (cy, leg) {
            (Some(c), Some(d)) if c.phase == CyclePhase::Started && d.flies && !d.landed => {
                format!("sortie {}/{}", d.step, d.path.len())
            }
            (Some(c), Some(d)) if c.phase == CyclePhase::Started && d.landed => {
                "on station".to_string()
            }
            _ => match state.config.drones.get(i) {
                Some(cell) => format!("charging {cell}"),
                None => "charging".to_string(),
            },
        });
    }
    let i = state.stations.iter().position(|d| d.sysid == sysid)?;
    let leg = cy.and_then(|c| c.stations.iter().find(|d| d.sysid == sysid));
    Some(match (cy, leg) {
        (Some(c), Some(d)) if c.phase == CyclePhase::Started && d.drives && !d.arrived => {
            format!("driving {}/{}", d.step, d.path.len())
        }
        _ => match state.config.stations.get(i) {
            Some(cell) => format!("station {cell}"),
            None => "station".to_string(),
        },
    })
}

/// The mission pane of a spatial-classification run.
fn mission(state: &ClassificationState, info: &RunInfo) -> MissionModel {
    let finished = state.is_finished();
    let phase = if finished {
        Phase::Done
    } else if !info.started {
        Phase::Idle
    } else {
        // Epochs are 0-based in the paper's notation; the pane counts from 1.
        Phase::Epoch {
            p: u32::try_from(state.bandit.epoch.saturating_add(1)).unwrap_or(u32::MAX),
        }
    };
    let status = if info.failed.is_some() {
        RunStatus::Failed
    } else if finished {
        RunStatus::Done
    } else if !info.started {
        RunStatus::NotStarted
    } else if info.paused {
        RunStatus::Paused
    } else {
        RunStatus::Running
    };
    let keep = state.bandit.keep().len();
    let reject = state.bandit.reject().len();
    let mut stats = vec![
        Stat {
            label: "keep".into(),
            value: keep.to_string(),
        },
        Stat {
            label: "reject".into(),
            value: reject.to_string(),
        },
        Stat {
            label: "measurements".into(),
            value: format!(
                "{} ({} ignored, {} lost)",
                state.measurements, state.ignored_images, state.image_failures
            ),
        },
    ];
    if let Some(e) = &state.epoch {
        let cycles = e.plan.as_ref().map_or(0, |p| p.cycles);
        stats.push(Stat {
            label: "sortie".into(),
            value: match &e.cycle {
                Some(c) => format!("cycle {} of {cycles}", c.k + 1),
                None => format!("{} of {cycles} flown", e.cycles_flown),
            },
        });
        let goals: Vec<String> = e.goals.iter().map(|c| c.to_string()).collect();
        stats.push(Stat {
            label: "goals".into(),
            value: goals.join(" "),
        });
    }
    if let Some(e) = &info.failed {
        stats.push(Stat {
            label: "error".into(),
            value: e.clone(),
        });
    }
    let planner_s: f64 = state.epochs.iter().map(|e| e.planner_s).sum::<f64>()
        + state.epoch.as_ref().map_or(0.0, |e| e.planner_s);
    MissionModel {
        name: info.name.clone(),
        kind: Some(LOOK.mission),
        phase,
        status,
        cells_classified: (keep + reject) as u32,
        cells_total: Some(state.bandit.len() as u32),
        dfs: None,
        epochs_done: state.epochs.len() as u32,
        flight_time_s: state.airborne_s.values().sum(),
        battery_swaps: 0,
        planner_time_s: planner_s,
        stats,
    }
}
