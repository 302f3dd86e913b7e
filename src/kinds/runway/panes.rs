//! Runway mapping's panes: the map (every decided cell, the DFS vertex states, the tracks),
//! the mission pane (phase, status, DFS counts, figures) and what each robot is doing, drawn
//! from a [`MappingState`].

use crate::panes::{
    CellState, DfsProgress, KindLook, MapKind, MapModel, MissionKind, MissionModel, Panes, Phase,
    RunInfo, RunStatus, Stat, Track,
};
use fleetmap_core::explore::dfs::VertexState;
use fleetmap_core::explore::mapping::{self, MappingState, RobotStatus};
use fleetmap_core::geo::Cell;
use fleetmap_core::vision::runway::votes::CellState as VoteState;
use std::collections::BTreeMap;

/// The cell states of a runway map, in legend order: not yet imaged, negative, then the DFS
/// vertex states of the positives.
const LEGEND: [CellState; 5] = [
    CellState::Unknown,
    CellState::Negative,
    CellState::PositiveUnexplored,
    CellState::UnderExploration,
    CellState::Explored,
];

/// How runway mapping's panes look.
pub(super) const LOOK: KindLook = KindLook {
    map: MapKind::new("runway", &LEGEND),
    mission: MissionKind::new("runway mapping", false),
    sample_help: "Synthetic runway-mapping animation (sweep, positives, battery swaps)",
    sample: "runway",
};

/// The panes of a runway-mapping run.
pub(super) fn panes(state: &MappingState, info: &RunInfo) -> Panes {
    Panes {
        map: map(state),
        mission: mission(state, info),
        order: state.robots.iter().map(|r| r.sysid).collect(),
        grid: state.grid.clone(),
        activity: state
            .robots
            .iter()
            .filter_map(|r| Some((r.sysid, activity(state, r.sysid)?)))
            .collect(),
    }
}

/// The map of a runway-mapping run: every decided cell, DFS vertex states, tracks.
fn map(state: &MappingState) -> MapModel {
    let mut cells: BTreeMap<Cell, CellState> = BTreeMap::new();
    let ex = state.explorer.as_ref();
    for (c, s, _) in state.cell_map() {
        let st = match s {
            VoteState::Positive => match ex.and_then(|e| e.vertex_state(c)) {
                Some(VertexState::Explored) => CellState::Explored,
                Some(VertexState::UnderExploration) => CellState::UnderExploration,
                _ => CellState::PositiveUnexplored,
            },
            VoteState::Negative => CellState::Negative,
            VoteState::Unknown => CellState::Unknown,
        };
        cells.insert(c, st);
    }
    let s = state.grid.cell_size();
    let track_cells = |t: &[[f64; 2]]| -> Vec<Cell> {
        let mut out: Vec<Cell> = Vec::new();
        for p in t {
            let c = state.grid.cell_of_xy(p[0], p[1]);
            if out.last() != Some(&c) {
                out.push(c);
            }
        }
        let keep = out.len().saturating_sub(40);
        out.split_off(keep)
    };
    let tracks: Vec<Track> = state
        .robots
        .iter()
        .map(|r| Track {
            sysid: r.sysid,
            cells: track_cells(&r.track),
        })
        .collect();
    // The rectangle: the sweep box, every known cell and every track, plus a margin.
    let mut rmin = i32::MAX;
    let mut rmax = i32::MIN;
    let mut cmin = i32::MAX;
    let mut cmax = i32::MIN;
    let mut grow = |c: Cell| {
        rmin = rmin.min(c.row);
        rmax = rmax.max(c.row);
        cmin = cmin.min(c.col);
        cmax = cmax.max(c.col);
    };
    grow(Cell::new(0, 0));
    for sw in &state.sweeps {
        let b = sw.strip;
        grow(state.grid.cell_of_xy(b.east_min, b.north_min));
        grow(state.grid.cell_of_xy(b.east_max, b.north_max));
    }
    for c in cells.keys() {
        grow(*c);
    }
    for t in &tracks {
        for c in &t.cells {
            grow(*c);
        }
    }
    let (rmin, rmax) = (rmin - 1, rmax + 1);
    let (cmin, cmax) = (cmin - 1, cmax + 1);
    let rows = (rmax - rmin + 1).clamp(1, 400) as u32;
    let cols = (cmax - cmin + 1).clamp(1, 400) as u32;
    let mut m = MapModel::new(LOOK.map, s, Cell::new(rmin, cmin), rows, cols);
    for (c, st) in cells {
        m.set(c, st);
    }
    m.tracks = tracks;
    m.home = Some(Cell::new(0, 0));
    m
}

/// What robot `sysid` is doing (`None`: not one of the run's robots).
fn activity(state: &MappingState, sysid: u8) -> Option<String> {
    let r = state.robot(sysid).ok()?;
    let mut a = r.status.name().to_string();
    if r.status == RobotStatus::Exploring
        && let Some(ex) = &state.explorer
        && let Ok(rs) = ex.robot(fleetmap_core::explore::dfs::RobotId(sysid))
    {
        let cell = ex.tree().node(rs.node).cell;
        a = format!("DFS {cell}");
    }
    if let Some((c, k)) = r.visit {
        a = format!("imaging {c} {k}/{}", state.params.images_per_cell);
    }
    Some(a)
}

/// The mission pane of a runway-mapping run.
fn mission(state: &MappingState, info: &RunInfo) -> MissionModel {
    let phase = match &state.phase {
        _ if !info.started => Phase::Idle,
        mapping::Phase::Sweep | mapping::Phase::Confirm { .. } => Phase::Sweep,
        mapping::Phase::Explore { .. } => {
            if state
                .robots
                .iter()
                .all(|r| matches!(r.status, RobotStatus::ReturningHome | RobotStatus::Landed))
            {
                Phase::Return
            } else {
                Phase::Dfs
            }
        }
        mapping::Phase::Finished { .. } => {
            if state.is_finished() {
                Phase::Done
            } else {
                Phase::Return
            }
        }
    };
    let status = if info.failed.is_some() {
        RunStatus::Failed
    } else if state.phase.finish_reason() == Some(mapping::FinishReason::BeyondReach) {
        RunStatus::BeyondReach
    } else if state.is_finished() {
        RunStatus::Done
    } else if !info.started {
        RunStatus::NotStarted
    } else if info.paused {
        RunStatus::Paused
    } else if state
        .robots
        .iter()
        .any(|r| r.status == RobotStatus::AwaitingSwap)
    {
        RunStatus::BatterySwap
    } else {
        RunStatus::Running
    };
    let dfs = state.explorer.as_ref().map(|e| {
        let vs = e.vertex_states();
        let count = |s: VertexState| vs.iter().filter(|(_, v)| *v == s).count() as u32;
        DfsProgress {
            explored: count(VertexState::Explored),
            under_exploration: count(VertexState::UnderExploration),
            unexplored: count(VertexState::Unexplored),
        }
    });
    let positive = state.book.positive_cells().len();
    let mut stats = vec![
        Stat {
            label: "runway cells".into(),
            value: positive.to_string(),
        },
        Stat {
            label: "images".into(),
            value: format!("{} ({} lost)", state.images, state.image_failures),
        },
        Stat {
            label: "decisions".into(),
            value: state.book.decisions().len().to_string(),
        },
    ];
    if let mapping::Phase::Confirm { sysid, cell } = state.phase {
        stats.push(Stat {
            label: "confirming".into(),
            value: format!("{cell} (vehicle {sysid})"),
        });
    }
    if let mapping::Phase::Finished {
        gave_up: Some(g), ..
    } = &state.phase
    {
        stats.push(Stat {
            label: "ended".into(),
            value: g.to_string(),
        });
    }
    if let Some(e) = &info.failed {
        stats.push(Stat {
            label: "error".into(),
            value: e.clone(),
        });
    }
    MissionModel {
        name: info.name.clone(),
        kind: Some(LOOK.mission),
        phase,
        status,
        cells_classified: state.book.cells().count() as u32,
        cells_total: None,
        dfs,
        epochs_done: 0,
        flight_time_s: state.robots.iter().map(|r| r.flight_s).sum(),
        battery_swaps: state.robots.iter().map(|r| r.battery_swaps).sum(),
        planner_time_s: 0.0,
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::explore::dfs::Sharing;
    use fleetmap_core::geo::{Grid, LatLon};
    use fleetmap_core::mission::definition::MissionDef;
    use fleetmap_core::time::Time;

    fn state() -> MappingState {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/missions/runway-field-test.toml"
        ))
        .unwrap();
        let def = MissionDef::parse(&text, "m.toml").unwrap();
        let grid = Grid::new(
            LatLon {
                lat: 37.1965,
                lon: -80.5785,
            },
            4.0,
        )
        .unwrap();
        MappingState::new(&def, grid, Sharing::Gcs).unwrap()
    }

    #[test]
    fn an_idle_run_shows_the_sweep_box_and_not_started() {
        let s = state();
        let info = RunInfo {
            name: "runway".into(),
            ..RunInfo::default()
        };
        let p = panes(&s, &info);
        assert_eq!(p.mission.status, RunStatus::NotStarted);
        assert_eq!(p.mission.phase, Phase::Idle);
        // the sweep box (40 m × 40 m of 4 m cells) and a margin
        assert!(
            p.map.rows >= 10 && p.map.cols >= 10,
            "{}x{}",
            p.map.rows,
            p.map.cols
        );
        assert_eq!(p.map.get(Cell::new(0, 0)), Some(CellState::Unknown));
        assert_eq!(
            p.order,
            s.robots.iter().map(|r| r.sysid).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_run_beyond_reach_says_so_from_the_moment_it_gives_up() {
        let mut s = state();
        let info = RunInfo {
            name: "plume".into(),
            started: true,
            ..RunInfo::default()
        };
        let why = fleetmap_core::explore::reach::Unreachable::Outpaced {
            drift_m_s: 1.5,
            speed_m_s: 1.0,
        };
        s.on_beyond_reach(1, Cell::new(2, 3), why, Time::from_secs(60))
            .unwrap();
        let m = mission(&s, &info);
        assert_eq!(m.status, RunStatus::BeyondReach);
        assert_eq!(m.status.label(), "BEYOND REACH");
        assert_eq!(m.phase, Phase::Return, "the drone still flies home");
        let ended = m.stats.iter().find(|x| x.label == "ended").unwrap();
        assert!(
            ended.value.starts_with("beyond reach (vehicle 1 to cell")
                && ended.value.contains("1.50 m/s"),
            "{}",
            ended.value
        );
        s.on_going_home(1, Time::from_secs(61)).unwrap();
        s.on_landed(1, Time::from_secs(90)).unwrap();
        let m = mission(&s, &info);
        assert_eq!(m.status, RunStatus::BeyondReach);
        assert_eq!(m.phase, Phase::Done);
    }
}
