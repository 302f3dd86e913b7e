//! Runway mapping's built-in samples: the fixture of the UI's snapshot tests (the DFS phase
//! of a three-copter run) and `fleetmap tui --sample runway`, a toy animation that makes the
//! panes move without vehicles.
//!
//! None of this is the mission algorithm: the animation moves drones along lawnmower lanes
//! over a hidden diagonal strip, then visits the positives found, so the panes have
//! changing content. The UI labels it SAMPLE wherever it is shown.

use super::panes::LOOK;
use crate::panes::{
    Animation, Battery, CameraHealth, CellState, DfsProgress, Gps, GpsFix, LinkState, LogEntry,
    MapModel, MissionModel, MissionProgress, Model, Phase, RunStatus, Sample, Stat, Track,
};
use crate::panes::{copter, log_line};
use fleetmap_core::geo::Cell;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use std::time::Duration;

/// The animation of `vehicles` drones (1–20).
pub(super) fn sample(vehicles: usize) -> Sample {
    Sample::Animated(Box::new(Toy::new(vehicles)))
}

/// Runway mapping in the DFS phase: three ArduPilot copters (one low on battery, one with a
/// lost link), a 12 × 20 grid with negatives, positives, explored and under-exploration cells.
pub fn fixture() -> Model {
    let rows = [
        "....................",
        "....................",
        "..........------....",
        "..------------++----",
        "..-----------+*#----",
        "..----------+##-----",
        "..---------###------",
        "..--------##--------",
        "..-------#----------",
        "..------------------",
        "....................",
        "....................",
    ];
    let mut map = MapModel::from_rows(LOOK.map, 4.0, Cell::new(-2, -2), &rows)
        .expect("fixture rows are valid");
    map.home = Some(Cell::new(0, 0));
    map.tracks = vec![Track {
        sysid: 1,
        cells: vec![Cell::new(0, 1), Cell::new(0, 2), Cell::new(0, 3)],
    }];
    let mut v1 = copter(1);
    v1.cell = Some(Cell::new(6, 13));
    v1.activity = Some("DFS vertex (6, 13)".into());
    let mut v2 = copter(2);
    v2.cell = Some(Cell::new(4, 10));
    v2.battery = Battery {
        remaining_pct: Some(27),
        voltage_v: Some(14.3),
        cells: Some(4),
    };
    v2.mission = Some(MissionProgress {
        current: 3,
        total: 12,
    });
    v2.activity = Some("DFS vertex (4, 10)".into());
    let mut v3 = copter(3);
    v3.cell = Some(Cell::new(0, 0));
    v3.mode = "RTL".into();
    v3.alt_m = Some(3.5);
    v3.speed_mps = Some(0.4);
    v3.battery = Battery {
        remaining_pct: Some(14),
        voltage_v: Some(13.7),
        cells: Some(4),
    };
    v3.gps = Gps {
        fix: GpsFix::Fix3d,
        satellites: Some(5),
    };
    v3.camera = Some(CameraHealth {
        heard_s: 12.4,
        silent: true,
        pictures: 97,
        measurements: 95,
    });
    v3.link = LinkState {
        quality_pct: Some(0),
        lost: true,
        last_heard_s: Some(12.4),
        ..LinkState::default()
    };
    v3.mission = None;
    v3.activity = Some("battery swap".into());
    Model {
        time: Time::from_secs(754),
        vehicles: vec![v1, v2, v3],
        map,
        mission: MissionModel {
            name: "runway field test".into(),
            kind: Some(LOOK.mission),
            phase: Phase::Dfs,
            status: RunStatus::Running,
            cells_classified: 148,
            cells_total: Some(240),
            dfs: Some(DfsProgress {
                explored: 9,
                under_exploration: 1,
                unexplored: 3,
            }),
            epochs_done: 0,
            flight_time_s: 1984.0,
            battery_swaps: 2,
            planner_time_s: 0.84,
            stats: vec![
                Stat {
                    label: "positives".into(),
                    value: "13".into(),
                },
                Stat {
                    label: "images".into(),
                    value: "740".into(),
                },
            ],
        },
        log: vec![
            log_line(12, Severity::Info, Some(1), "Mission: 1 Takeoff"),
            log_line(13, Severity::Info, Some(2), "Mission: 1 Takeoff"),
            log_line(14, Severity::Info, Some(3), "Mission: 1 Takeoff"),
            log_line(
                402,
                Severity::Notice,
                None,
                "first positive at (3, 14): DFS starts",
            ),
            log_line(
                688,
                Severity::Warning,
                Some(3),
                "Battery 1 is low 14.2V used 3890 mAh",
            ),
            log_line(
                701,
                Severity::Critical,
                Some(3),
                "Battery 1 is critical 13.8V",
            ),
            log_line(702, Severity::Info, Some(3), "RTL for a battery swap"),
            log_line(
                741,
                Severity::Error,
                None,
                "vehicle 3: no heartbeat for 5 s (link lost)",
            ),
            log_line(
                750,
                Severity::Warning,
                Some(2),
                "Battery 1 is low 14.4V used 2950 mAh",
            ),
        ],
        sim_speed: None,
    }
}

/// Percent drained per simulated second in [`Toy`].
const DRAIN_PCT_PER_S: f64 = 0.5;

struct SampleDrone {
    sysid: u8,
    pos: Cell,
    /// Remaining waypoints of its lanes (sweep), front first.
    path: Vec<Cell>,
    battery_pct: f64,
    /// While swapping: when the swap ends.
    swap_until: Option<Time>,
    target: Option<Cell>,
    warned: bool,
}

/// A toy runway-mapping animation (see the module documentation): `n` copters sweep a
/// 16 × 24 grid in lanes, mark cells negative or positive against a hidden diagonal strip,
/// then visit the positives (DFS phase stand-in), then return; batteries drain and get
/// swapped. Deterministic for a given `n`.
pub(crate) struct Toy {
    t: Time,
    map: MapModel,
    truth: Vec<bool>,
    drones: Vec<SampleDrone>,
    phase: Phase,
    log: Vec<LogEntry>,
    swaps: u32,
    flight_s: f64,
}

impl Toy {
    /// Grid rows.
    const ROWS: u32 = 16;
    /// Grid columns.
    const COLS: u32 = 24;

    /// A run with `n` drones (1–20).
    pub(crate) fn new(n: usize) -> Toy {
        let n = n.clamp(1, 20);
        let map = MapModel::new(LOOK.map, 4.0, Cell::new(0, 0), Toy::ROWS, Toy::COLS);
        let truth = (0..Toy::ROWS as i32)
            .flat_map(|r| {
                (0..Toy::COLS as i32).map(move |c| {
                    let centre = 2.0 + 0.5 * f64::from(c);
                    (f64::from(r) - centre).abs() <= 1.0 && (4..20).contains(&c)
                })
            })
            .collect();
        let drones = (0..n)
            .map(|i| {
                let mut path = Vec::new();
                for (lane, r) in (i as i32..Toy::ROWS as i32).step_by(n).enumerate() {
                    let cols: Vec<i32> = if lane % 2 == 0 {
                        (0..Toy::COLS as i32).collect()
                    } else {
                        (0..Toy::COLS as i32).rev().collect()
                    };
                    path.extend(cols.into_iter().map(|c| Cell::new(r, c)));
                }
                path.reverse(); // pop() from the back
                SampleDrone {
                    sysid: (i + 1) as u8,
                    pos: Cell::new(0, 0),
                    path,
                    battery_pct: 100.0 - 12.0 * (i % 5) as f64,
                    swap_until: None,
                    target: None,
                    warned: false,
                }
            })
            .collect();
        let mut map = map;
        map.home = Some(Cell::new(0, 0));
        Toy {
            t: Time::ZERO,
            map,
            truth,
            drones,
            phase: Phase::Sweep,
            log: vec![LogEntry {
                time: Time::ZERO,
                severity: Severity::Notice,
                sysid: None,
                text: "SAMPLE: synthetic animation, no vehicles are connected".into(),
            }],
            swaps: 0,
            flight_s: 0.0,
        }
    }

    fn truth(&self, c: Cell) -> bool {
        let i = c.row as usize * Toy::COLS as usize + c.col as usize;
        self.truth.get(i).copied().unwrap_or(false)
    }

    fn note(&mut self, severity: Severity, sysid: Option<u8>, text: String) {
        self.log.push(LogEntry {
            time: self.t,
            severity,
            sysid,
            text,
        });
        if self.log.len() > 300 {
            self.log.remove(0);
        }
    }

    fn step_one(&mut self) {
        self.t += Duration::from_secs(1);
        let now = self.t;
        let mut events = Vec::new();
        for i in 0..self.drones.len() {
            let d = &mut self.drones[i];
            if let Some(until) = d.swap_until {
                if now >= until {
                    d.swap_until = None;
                    d.battery_pct = 100.0;
                    d.warned = false;
                    events.push((
                        Severity::Info,
                        Some(d.sysid),
                        "battery swapped, resuming".to_string(),
                    ));
                }
                continue;
            }
            if self.phase == Phase::Done {
                continue;
            }
            d.battery_pct -= DRAIN_PCT_PER_S;
            self.flight_s += 1.0;
            if d.battery_pct <= 30.0 && !d.warned {
                d.warned = true;
                events.push((
                    Severity::Warning,
                    Some(d.sysid),
                    format!("Battery 1 is low {:.0}%", d.battery_pct),
                ));
            }
            if d.battery_pct <= 20.0 {
                d.swap_until = Some(now + Duration::from_secs(8));
                events.push((
                    Severity::Critical,
                    Some(d.sysid),
                    "battery critical: swap".into(),
                ));
                self.swaps += 1;
                continue;
            }
            let next = match self.phase {
                Phase::Sweep => d.path.pop(),
                Phase::Dfs | Phase::Return => d.target.map(|t| {
                    let mut p = d.pos;
                    if p.row != t.row {
                        p.row += (t.row - p.row).signum();
                    } else if p.col != t.col {
                        p.col += (t.col - p.col).signum();
                    }
                    p
                }),
                _ => None,
            };
            if let Some(p) = next {
                d.pos = p;
            }
        }
        for (s, id, text) in events {
            self.note(s, id, text);
        }
        // Sensing and vertex bookkeeping.
        for i in 0..self.drones.len() {
            let pos = self.drones[i].pos;
            if self.drones[i].swap_until.is_some() {
                continue;
            }
            match self.map.get(pos) {
                Some(CellState::Unknown) => {
                    let s = if self.truth(pos) {
                        CellState::PositiveUnexplored
                    } else {
                        CellState::Negative
                    };
                    self.map.set(pos, s);
                }
                Some(CellState::UnderExploration) if self.drones[i].target == Some(pos) => {
                    self.map.set(pos, CellState::Explored);
                    self.drones[i].target = None;
                }
                _ => {}
            }
        }
        match self.phase {
            Phase::Sweep if self.drones.iter().all(|d| d.path.is_empty()) => {
                self.phase = Phase::Dfs;
                self.note(
                    Severity::Notice,
                    None,
                    "sweep done: visiting positives".into(),
                );
            }
            Phase::Dfs => {
                for i in 0..self.drones.len() {
                    if self.drones[i].target.is_some() || self.drones[i].swap_until.is_some() {
                        continue;
                    }
                    let pos = self.drones[i].pos;
                    let best = (0..Toy::ROWS as i32)
                        .flat_map(|r| (0..Toy::COLS as i32).map(move |c| Cell::new(r, c)))
                        .filter(|&c| self.map.get(c) == Some(CellState::PositiveUnexplored))
                        .min_by_key(|&c| c.manhattan(pos));
                    if let Some(c) = best {
                        self.map.set(c, CellState::UnderExploration);
                        self.drones[i].target = Some(c);
                    }
                }
                let busy = self.drones.iter().any(|d| d.target.is_some());
                if !busy {
                    self.phase = Phase::Return;
                    for d in &mut self.drones {
                        d.target = Some(Cell::new(0, 0));
                    }
                    self.note(
                        Severity::Notice,
                        None,
                        "all positives explored: returning".into(),
                    );
                }
            }
            Phase::Return if self.drones.iter().all(|d| d.pos == Cell::new(0, 0)) => {
                self.phase = Phase::Done;
                self.note(Severity::Notice, None, "done".into());
            }
            _ => {}
        }
    }
}

impl Animation for Toy {
    /// Advance by `dt` of simulated time (in whole seconds; one cell per second).
    fn step(&mut self, dt: Duration) {
        for _ in 0..dt.as_secs().max(1) {
            self.step_one();
        }
    }

    fn model(&self) -> Model {
        let counts = self.map.counts();
        let classified: u32 = counts[1..5].iter().sum();
        let vehicles = self
            .drones
            .iter()
            .map(|d| {
                let mut v = copter(d.sysid);
                let swapping = d.swap_until.is_some();
                let done = self.phase == Phase::Done;
                v.cell = Some(d.pos);
                v.battery.remaining_pct = Some(d.battery_pct.clamp(0.0, 100.0).round() as u8);
                v.battery.voltage_v = Some((13.2 + 3.6 * d.battery_pct / 100.0) as f32);
                v.armed = !swapping && !done;
                v.mode = match (swapping, self.phase) {
                    (true, _) | (_, Phase::Done) => "LAND".into(),
                    (_, Phase::Sweep) => "AUTO".into(),
                    (_, Phase::Return) => "RTL".into(),
                    _ => "GUIDED".into(),
                };
                v.alt_m = Some(if swapping || done { 0.0 } else { 12.0 });
                v.speed_mps = Some(if swapping || done { 0.0 } else { 1.0 });
                v.mission = Some(MissionProgress {
                    current: (Toy::COLS * Toy::ROWS / self.drones.len() as u32)
                        .saturating_sub(d.path.len() as u32) as u16,
                    total: (Toy::COLS * Toy::ROWS / self.drones.len() as u32) as u16,
                });
                v.activity = Some(if swapping {
                    "battery swap".into()
                } else {
                    match (self.phase, d.target) {
                        (Phase::Dfs, Some(t)) => format!("vertex {t}"),
                        (p, _) => p.to_string(),
                    }
                });
                v
            })
            .collect();
        let dfs = (self.phase != Phase::Sweep).then(|| DfsProgress {
            explored: counts[4],
            under_exploration: counts[3],
            unexplored: counts[2],
        });
        Model {
            time: self.t,
            vehicles,
            map: self.map.clone(),
            mission: MissionModel {
                name: "SAMPLE runway (synthetic)".into(),
                kind: Some(LOOK.mission),
                phase: self.phase,
                status: if self.phase == Phase::Done {
                    RunStatus::Done
                } else if self.drones.iter().any(|d| d.swap_until.is_some()) {
                    RunStatus::BatterySwap
                } else {
                    RunStatus::Running
                },
                cells_classified: classified,
                cells_total: Some(Toy::ROWS * Toy::COLS),
                dfs,
                epochs_done: 0,
                flight_time_s: self.flight_s,
                battery_swaps: self.swaps,
                planner_time_s: 0.0,
                stats: Vec::new(),
            },
            log: self.log.clone(),
            sim_speed: None,
        }
    }

    fn done(&self) -> bool {
        self.phase == Phase::Done
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_run_sweeps_explores_swaps_and_finishes() {
        let mut run = Toy::new(3);
        let mut saw_dfs = false;
        for _ in 0..2000 {
            run.step(Duration::from_secs(1));
            saw_dfs |= run.model().mission.phase == Phase::Dfs;
            if run.done() {
                break;
            }
        }
        assert!(run.done(), "the sample finishes");
        assert!(saw_dfs);
        let m = run.model();
        let counts = m.map.counts();
        assert_eq!(counts[0], 0, "every cell was imaged");
        assert!(counts[4] > 0, "positives were explored");
        assert_eq!(counts[2] + counts[3], 0, "no positive left unexplored");
        assert!(m.mission.battery_swaps > 0);
    }
}
