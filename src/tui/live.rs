//! The live adapter's pure half: fleet snapshots and the runway-mapping state become the UI's
//! [`Model`] (the async half, which feeds it and carries out the operator's commands, is
//! `crate::tui::session`).
//!
//! Nothing here reads a clock or touches the network: [`LiveLog`] keeps the messages (the
//! vehicles' STATUSTEXT and the runner's progress lines) with the times it is given, and
//! [`build_model`] is a function of its arguments.

use super::model::{
    Battery, CameraHealth, CellState, DfsProgress, Gps, GpsFix, LinkState, LogEntry, MapKind,
    MapModel, MissionKind, MissionModel, MissionProgress, Model, Phase, Role, RunStatus, Stat,
    Track, VehicleRow,
};
use crate::app::kind::RunView;
use crate::fleet::{FleetSnapshot, VehicleSnapshot};
use fleetmap_core::explore::dfs::VertexState;
use fleetmap_core::explore::mapping::{self, MappingState, RobotStatus};
use fleetmap_core::geo::{Cell, Grid, LatLon};
use fleetmap_core::planner::bandit::Label;
use fleetmap_core::planner::sortie::{ClassificationState, CyclePhase};
use fleetmap_core::proto::flavour::VehicleClass;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use fleetmap_core::vision::runway::votes::CellState as VoteState;
use std::collections::{BTreeMap, HashMap};

/// Most messages kept.
pub(crate) const LOG_CAPACITY: usize = 500;

/// The messages shown in the log pane.
#[derive(Clone, Debug, Default)]
pub struct LiveLog {
    /// Oldest first.
    pub(crate) entries: Vec<LogEntry>,
    /// The last STATUSTEXT taken from each vehicle (its arrival time).
    seen: HashMap<u8, Time>,
}

impl LiveLog {
    /// Add a line.
    pub fn push(
        &mut self,
        time: Time,
        severity: Severity,
        sysid: Option<u8>,
        text: impl Into<String>,
    ) {
        self.entries.push(LogEntry {
            time,
            severity,
            sysid,
            text: text.into(),
        });
        if self.entries.len() > LOG_CAPACITY {
            let excess = self.entries.len() - LOG_CAPACITY;
            self.entries.drain(..excess);
        }
    }

    /// Take the vehicles' new STATUSTEXTs from a snapshot.
    pub fn absorb(&mut self, fleet: &FleetSnapshot) {
        for v in fleet.vehicles.values() {
            if let Some(t) = &v.last_text
                && self.seen.get(&v.sysid) != Some(&t.at)
            {
                self.seen.insert(v.sysid, t.at);
                self.push(t.at, t.severity, Some(v.sysid), t.text.clone());
            }
        }
    }
}

fn gps_fix(fix: Option<u8>) -> GpsFix {
    match fix {
        None | Some(0) => GpsFix::NoGps,
        Some(1) => GpsFix::NoFix,
        Some(2) => GpsFix::Fix2d,
        Some(3) => GpsFix::Fix3d,
        Some(4) => GpsFix::Dgps,
        Some(5) => GpsFix::RtkFloat,
        Some(_) => GpsFix::RtkFixed,
    }
}

/// One fleet-table row.
pub(crate) fn vehicle_row(
    v: &VehicleSnapshot,
    role: Role,
    grid: Option<&Grid>,
    activity: Option<String>,
) -> VehicleRow {
    let cell = match (grid, v.position) {
        (Some(g), Some(p)) => g
            .cell_of(LatLon {
                lat: p.lat,
                lon: p.lon,
            })
            .ok(),
        _ => None,
    };
    VehicleRow {
        sysid: v.sysid,
        role,
        autopilot: v.flavour.autopilot,
        vehicle_type: v.flavour.class,
        mode: if v.sysid_conflict.is_some() {
            "ID CONFLICT".into()
        } else {
            v.mode.clone()
        },
        armed: v.armed,
        battery: Battery {
            remaining_pct: v.battery_pct.and_then(|p| u8::try_from(p).ok()),
            voltage_v: v.battery_v,
            cells: None,
        },
        gps: Gps {
            fix: gps_fix(v.gps_fix),
            satellites: v.satellites,
        },
        alt_m: v.alt_rel,
        speed_mps: v.groundspeed,
        mission: match (v.mission_current, v.mission_total) {
            (Some(c), Some(t)) if t > 0 => Some(MissionProgress {
                current: c.saturating_add(1).min(t),
                total: t,
            }),
            _ => None,
        },
        link: LinkState {
            quality_pct: Some((100.0 - v.link_quality.loss_pct).clamp(0.0, 100.0).round() as u8),
            lost: !v.alive,
            last_heard_s: Some(v.heartbeat_age_s as f32),
            bytes_per_s: Some(
                (v.link_quality.down_bytes_per_s + v.link_quality.up_bytes_per_s) as f32,
            ),
            budget_bytes_per_s: v.link_quality.budget.bytes_per_s(),
            rssi: v
                .link_quality
                .radio
                .map(|r| (r.status.rssi, r.status.remrssi)),
        },
        cell,
        camera: v.camera_age_s.map(|age| CameraHealth {
            heard_s: age as f32,
            silent: v.camera_silent(),
            pictures: v.camera_pictures,
            measurements: v.camera_measurements,
        }),
        // Said where the operator looks first, over whatever the runner had it doing.
        activity: match &v.sysid_conflict {
            Some(_) => Some(format!(
                "TWO AUTOPILOTS AS ID {}: not commanded; {}",
                v.sysid,
                crate::fleet::SysidConflict::FIX
            )),
            None => activity,
        },
    }
}

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

/// The map of a runway-mapping run: every decided cell, DFS vertex states, tracks.
pub(crate) fn runway_map(state: &MappingState) -> MapModel {
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
    let mut m = MapModel::new(MapKind::Runway, s, Cell::new(rmin, cmin), rows, cols);
    for (c, st) in cells {
        m.set(c, st);
    }
    m.tracks = tracks;
    m.home = Some(Cell::new(0, 0));
    m
}

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
pub fn runway_mission(state: &MappingState, info: &RunInfo) -> MissionModel {
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
        kind: Some(MissionKind::RunwayMapping),
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

/// The map of a spatial-classification run: G with O (obstacles), R (roads, while
/// unclassified) and the labels of (4); the drones' paths of the sortie in flight as tracks;
/// the first station's start cell as home.
pub(crate) fn classification_map(state: &ClassificationState) -> MapModel {
    let l = &state.layout;
    let mut m = MapModel::new(
        MapKind::Classification,
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

/// What a member of a spatial-classification team is doing.
fn classification_activity(state: &ClassificationState, sysid: u8) -> Option<String> {
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
pub(crate) fn classification_mission(state: &ClassificationState, info: &RunInfo) -> MissionModel {
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
        kind: Some(MissionKind::SpatialClassification),
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

impl RunView<'_> {
    fn grid(&self) -> &Grid {
        match self {
            RunView::Mapping(s) => &s.grid,
            RunView::Classification(s) => &s.grid,
        }
    }

    /// The run's vehicles in mission order (drones, then stations).
    fn order(&self) -> Vec<u8> {
        match self {
            RunView::Mapping(s) => s.robots.iter().map(|r| r.sysid).collect(),
            RunView::Classification(s) => s
                .drones
                .iter()
                .chain(&s.stations)
                .map(|m| m.sysid)
                .collect(),
        }
    }

    fn activity(&self, sysid: u8) -> Option<String> {
        match self {
            RunView::Mapping(s) => activity(s, sysid),
            RunView::Classification(s) => classification_activity(s, sysid),
        }
    }
}

/// The whole UI model: the fleet's vehicles (mission robots first, in mission order), the
/// mission's map and progress when a run is attached, and the log.
pub fn build_model(
    fleet: &FleetSnapshot,
    mission: Option<(RunView<'_>, &RunInfo)>,
    log: &LiveLog,
) -> Model {
    let grid = mission.as_ref().map(|(s, _)| s.grid());
    let mut order: Vec<u8> = mission.as_ref().map(|(s, _)| s.order()).unwrap_or_default();
    for id in fleet.vehicles.keys() {
        if !order.contains(id) {
            order.push(*id);
        }
    }
    let vehicles = order
        .iter()
        .filter_map(|id| fleet.vehicles.get(id))
        .map(|v| {
            let role = if v.flavour.class == VehicleClass::Rover {
                Role::Station
            } else {
                Role::Drone
            };
            let act = mission.as_ref().and_then(|(s, _)| s.activity(v.sysid));
            vehicle_row(v, role, grid, act)
        })
        .collect();
    let (map, mission_model) = match mission {
        Some((RunView::Mapping(s), info)) => (runway_map(s), runway_mission(s, info)),
        Some((RunView::Classification(s), info)) => {
            (classification_map(s), classification_mission(s, info))
        }
        None => (MapModel::default(), MissionModel::default()),
    };
    Model {
        time: fleet.time,
        vehicles,
        map,
        mission: mission_model,
        log: log.entries.clone(),
        sim_speed: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::explore::dfs::Sharing;
    use fleetmap_core::mission::definition::MissionDef;

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
        let m = build_model(
            &FleetSnapshot::default(),
            Some(((&s).into(), &info)),
            &LiveLog::default(),
        );
        assert_eq!(m.mission.status, RunStatus::NotStarted);
        assert_eq!(m.mission.phase, Phase::Idle);
        // the sweep box (40 m × 40 m of 4 m cells) and a margin
        assert!(
            m.map.rows >= 10 && m.map.cols >= 10,
            "{}x{}",
            m.map.rows,
            m.map.cols
        );
        assert_eq!(m.map.get(Cell::new(0, 0)), Some(CellState::Unknown));
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
        let m = runway_mission(&s, &info);
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
        let m = runway_mission(&s, &info);
        assert_eq!(m.status, RunStatus::BeyondReach);
        assert_eq!(m.phase, Phase::Done);
    }

    #[test]
    fn log_takes_each_statustext_once() {
        let mut log = LiveLog::default();
        let mut f = FleetSnapshot::default();
        let mut v = VehicleSnapshot::test_copter(3);
        v.last_text = Some(crate::fleet::StatusText {
            severity: fleetmap_core::proto::severity::Severity::Warning,
            text: "PreArm: Need Position Estimate".into(),
            at: Time::from_secs(2),
        });
        f.vehicles.insert(3, v);
        log.absorb(&f);
        log.absorb(&f);
        assert_eq!(log.entries.len(), 1);
        assert_eq!(log.entries[0].severity, Severity::Warning);
        assert_eq!(log.entries[0].sysid, Some(3));
    }
}
