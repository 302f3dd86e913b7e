//! Sensing-cycle paths as autopilot missions, the no-fly cells as a geofence, and the safety
//! check of every list before it is flown (pure: no I/O, no clock).
//!
//! **Drone mission of one sensing cycle** (bandit paper §III-B: a cycle starts and ends on a
//! station; §V: B images at each unclassified cell along the path), cells of the re-paired plan
//! (§III-C) in order, at the drone's own altitude:
//!
//! ```text
//! NAV_TAKEOFF alt                              the station's cell (step 0)
//! DO_CHANGE_SPEED v_d
//! NAV_WAYPOINT centre(cell_0)                  from the charging pad to the cell's centre
//! for step j = 1 … T_d − 1:
//!     NAV_WAYPOINT centre(cell_j)              when the cell changes (a pass flies nothing)
//!     IMAGE_START_CAPTURE interval, B          at an unclassified candidate cell …
//!     NAV_LOITER_TIME ⌈B·interval⌉ + 1 s       … hovering over its centre meanwhile
//!     NAV_LOITER_TIME settle / one step        lock-step only: where the barrier holds (7e)
//! NAV_WAYPOINT centre(last cell)               when the list would end on a hover
//! ```
//!
//! The mission ends hovering over the last cell; the landing on the station is commanded by
//! the runner once that station is there (the rendezvous, (9d)), at the station's reported
//! position — a deviation from "land on the cell" that a real charging pad needs anyway (a
//! rover stops within its waypoint radius, ArduRover's WP_RADIUS = 2 m, of the cell centre).
//!
//! Capture items come *after* the waypoint: ArduPilot's AP_Mission starts the do-commands that
//! follow a navigation command when that command completes, PX4's navigator when it reaches
//! them, so in both the images are taken during the loiter over the cell centre.
//!
//! **Station mission**: DO_CHANGE_SPEED v_c = v_d·T_c/T_d (γ = T_d/T_c, §II) and one waypoint
//! per road cell the station moves to.
//!
//! **Geofence** (MAV_MISSION_TYPE_FENCE): one inclusion polygon around the search area G and
//! one exclusion polygon per rectangle of no-fly cells O (adjacent cells merged, so the 16
//! obstacles of the 10×10 default fit PX4's 64 fence points). Every polygon is *shrunk* by a
//! margin (the inclusion one grown): the planner's king moves pass diagonally through the
//! corner point two obstacles share, where an exact cell-shaped fence would be breached by
//! the GPS error alone. The GCS check below is exact instead.
//!
//! **Check** ([`check_mission`]): every position item is inside G and not in O (stations: on a
//! road cell), and no straight leg between consecutive positions — from the vehicle's cell at
//! the start — crosses the interior of a no-fly cell (a leg through a shared corner touches the
//! cells only at that point and is allowed).

use crate::geo::{Cell, GeoError, Grid, LatLon};
use crate::mission::item::MissionItem;
use crate::mission::item::{cmd, frame};
use std::collections::BTreeSet;

/// A cycle's mission and where each step of the cycle is in it.
#[derive(Clone, Debug, PartialEq)]
pub struct CycleMission {
    /// The items to upload (user numbering: no ArduPilot home item).
    pub items: Vec<MissionItem>,
    /// For each step j of the cycle, the item whose completion means the vehicle has done
    /// step j (arrived and, at a capture cell, finished hovering); `None` for step 0 and for
    /// passes without an item.
    pub step_done: Vec<Option<u16>>,
    /// For each step j, the item reached on *arrival* at the step's cell (the waypoint, or a
    /// lock-step pass's loiter).
    pub step_arrive: Vec<Option<u16>>,
    /// The steps with an image capture.
    pub(crate) capture_steps: Vec<usize>,
}

/// What a drone's cycle mission needs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DroneMissionSpec<'a> {
    /// The drone's cells at steps 0 … T_d − 1 (mission cells).
    pub path: &'a [Cell],
    /// For each step, whether to capture B images there.
    pub capture: &'a [bool],
    /// Flight altitude above home, metres.
    pub altitude_m: f64,
    /// Ground speed, m/s.
    pub speed_m_s: f64,
    /// B, images per visit.
    pub batch: u32,
    /// Seconds between two images.
    pub(crate) capture_interval_s: f64,
    /// Lock-step flight (7e): a loiter at every step where the runner's barrier holds the
    /// drone.
    pub lock_step: bool,
    /// Lock-step: hover time of a pass (the drone stays), seconds — one step's flight time.
    pub(crate) step_s: f64,
    /// Lock-step: hover after arriving at a cell without captures, seconds.
    pub(crate) settle_s: f64,
}

/// Seconds a drone hovers over a capture cell: ⌈B·interval⌉ + 1 (whole seconds: ArduPilot
/// stores waypoint delays in whole seconds).
pub(crate) fn capture_hold_s(batch: u32, interval_s: f64) -> f64 {
    (f64::from(batch) * interval_s.max(0.0)).ceil() + 1.0
}

fn centre(grid: &Grid, c: Cell) -> LatLon {
    grid.cell_center(c)
}

/// NAV_LOITER_TIME over (`lat`, `lon`) for `seconds`, param3 = +1 (ArduPilot keeps only the
/// sign of param3, the loiter direction, and reads 0 back as +1; PX4 takes it as a 1 m
/// radius, which a copter hovering in place ignores).
fn hover(seconds: f64, p: LatLon, alt: f32) -> MissionItem {
    MissionItem {
        param3: 1.0,
        ..MissionItem::loiter_time(seconds as f32, p.lat, p.lon, alt)
    }
}

fn seq(items: &[MissionItem]) -> u16 {
    u16::try_from(items.len().saturating_sub(1)).unwrap_or(u16::MAX)
}

/// The drone mission of one sensing cycle (see the module documentation).
pub(crate) fn drone_mission(grid: &Grid, spec: &DroneMissionSpec<'_>) -> CycleMission {
    let alt = spec.altitude_m as f32;
    // Taking off from the start cell: the take-off item carries its centre (PX4 flies an
    // airborne take-off item as a waypoint to its position, see `MissionItem::takeoff_at`).
    let takeoff = match spec.path.first() {
        Some(&c0) => {
            let p = centre(grid, c0);
            MissionItem::takeoff_at(p.lat, p.lon, alt)
        }
        None => MissionItem::takeoff(alt),
    };
    let mut items = vec![takeoff, MissionItem::change_speed(spec.speed_m_s as f32)];
    // Over the centre of the start cell first: the drone took off from a charging pad up to
    // a rover's stopping distance (ArduRover WP_RADIUS, 2 m) off that centre, and a diagonal
    // leg from there would pass an obstacle's corner closer than the straight legs between
    // cell centres that `check_mission` verifies (the geofence breaches of the CI runs).
    if let Some(&c0) = spec.path.first() {
        let p = centre(grid, c0);
        items.push(MissionItem::waypoint(p.lat, p.lon, alt));
    }
    let n = spec.path.len();
    let mut step_done = vec![None; n];
    let mut step_arrive = vec![None; n];
    let mut capture_steps = Vec::new();
    for j in 1..n {
        let cell = spec.path[j];
        let moved = cell != spec.path[j - 1];
        let p = centre(grid, cell);
        let before = items.len();
        if moved {
            items.push(MissionItem::waypoint(p.lat, p.lon, alt));
            step_arrive[j] = Some(seq(&items));
        }
        if moved && spec.capture.get(j).copied().unwrap_or(false) {
            items.push(MissionItem::image_start_capture(
                spec.capture_interval_s as f32,
                spec.batch,
            ));
            let hold = capture_hold_s(spec.batch, spec.capture_interval_s);
            items.push(hover(hold, p, alt));
            capture_steps.push(j);
        } else if spec.lock_step {
            let hold = if moved { spec.settle_s } else { spec.step_s };
            items.push(hover(hold.max(1.0).round(), p, alt));
            if !moved {
                step_arrive[j] = Some(seq(&items));
            }
        }
        if items.len() > before {
            step_done[j] = Some(seq(&items));
        }
    }
    // A mission must not end on a hover: ArduPilot reports a waypoint or loiter with a delay
    // reached on *arrival*, so the end of the hover is marked by a plain waypoint after it.
    if let (Some(last), Some(&cell)) = (items.last(), spec.path.last())
        && last.command == cmd::NAV_LOITER_TIME
    {
        let p = centre(grid, cell);
        items.push(MissionItem::waypoint(p.lat, p.lon, alt));
        if let Some(d) = step_done.last_mut() {
            *d = Some(seq(&items));
        }
    }
    CycleMission {
        items,
        step_done,
        step_arrive,
        capture_steps,
    }
}

/// The station mission of one sensing cycle: DO_CHANGE_SPEED, then a waypoint per move.
pub fn station_mission(grid: &Grid, path: &[Cell], speed_m_s: f64) -> CycleMission {
    let mut items = vec![MissionItem::change_speed(speed_m_s as f32)];
    let n = path.len();
    let mut step_done = vec![None; n];
    for j in 1..n {
        if path[j] != path[j - 1] {
            let p = centre(grid, path[j]);
            items.push(MissionItem::waypoint(p.lat, p.lon, 0.0));
            step_done[j] = Some(seq(&items));
        }
    }
    CycleMission {
        items,
        step_arrive: step_done.clone(),
        step_done,
        capture_steps: Vec::new(),
    }
}

/// The last step whose item has been reached (steps without an item count as done when the
/// step before them is): 0 when nothing has been reached yet.
pub fn steps_done(step_items: &[Option<u16>], reached: &[u16]) -> usize {
    let mut done = 0;
    for (j, item) in step_items.iter().enumerate().skip(1) {
        match item {
            Some(s) if reached.contains(s) => done = j,
            Some(_) => break,
            None => done = j,
        }
    }
    done
}

/// Rectangles `(row0, col0, row1, col1)` (inclusive) covering exactly the cells `cells`:
/// horizontal runs, then runs with the same columns in consecutive rows merged.
pub(crate) fn merge_cells(cells: &[Cell]) -> Vec<(i32, i32, i32, i32)> {
    let set: BTreeSet<Cell> = cells.iter().copied().collect();
    let mut runs: Vec<(i32, i32, i32)> = Vec::new(); // (row, col0, col1)
    let mut it = set.iter().peekable();
    while let Some(&c) = it.next() {
        let mut end = c.col;
        while let Some(&&n) = it.peek() {
            if n.row == c.row && n.col == end + 1 {
                end = n.col;
                it.next();
            } else {
                break;
            }
        }
        runs.push((c.row, c.col, end));
    }
    let mut rects: Vec<(i32, i32, i32, i32)> = Vec::new();
    let mut used = vec![false; runs.len()];
    for i in 0..runs.len() {
        if used[i] {
            continue;
        }
        used[i] = true;
        let (r, c0, c1) = runs[i];
        let mut r1 = r;
        loop {
            let next = runs
                .iter()
                .enumerate()
                .position(|(k, &(rr, a, b))| !used[k] && rr == r1 + 1 && a == c0 && b == c1);
            match next {
                Some(k) => {
                    used[k] = true;
                    r1 += 1;
                }
                None => break,
            }
        }
        rects.push((r, c0, r1, c1));
    }
    rects
}

fn polygon(
    grid: &Grid,
    command: u16,
    (x0, y0, x1, y1): (f64, f64, f64, f64),
) -> Result<Vec<MissionItem>, GeoError> {
    let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)];
    corners
        .iter()
        .map(|&(e, n)| {
            let p = grid.from_xy(e, n)?;
            Ok(MissionItem {
                frame: frame::GLOBAL,
                param1: 4.0,
                ..MissionItem::at(command, p.lat, p.lon, 0.0)
            })
        })
        .collect()
}

/// The geofence of a search area of `rows × cols` cells with no-fly cells `obstacles`: an
/// inclusion polygon around the area grown by `margin_m`, and an exclusion polygon per
/// merged rectangle of obstacles shrunk by `margin_m` (metres; see the module documentation).
pub fn fence_items(
    grid: &Grid,
    rows: u32,
    cols: u32,
    obstacles: &[Cell],
    margin_m: f64,
) -> Result<Vec<MissionItem>, GeoError> {
    let s = grid.cell_size();
    let m = margin_m.clamp(0.0, 0.45 * s);
    let mut items = polygon(
        grid,
        cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
        (
            -0.5 * s - m,
            -0.5 * s - m,
            (f64::from(cols) - 0.5) * s + m,
            (f64::from(rows) - 0.5) * s + m,
        ),
    )?;
    for (r0, c0, r1, c1) in merge_cells(obstacles) {
        let rect = (
            (f64::from(c0) - 0.5) * s + m,
            (f64::from(r0) - 0.5) * s + m,
            (f64::from(c1) + 0.5) * s - m,
            (f64::from(r1) + 0.5) * s - m,
        );
        items.extend(polygon(
            grid,
            cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
            rect,
        )?);
    }
    Ok(items)
}

/// Whether the segment a → b (cell units) crosses the box `[x0, x1] × [y0, y1]`
/// (Liang–Barsky clipping).
pub(crate) fn segment_hits_box(a: (f64, f64), b: (f64, f64), bx: (f64, f64, f64, f64)) -> bool {
    let (x0, y0, x1, y1) = bx;
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0 = 0.0f64;
    let mut t1 = 1.0f64;
    for (p, q) in [
        (-dx, a.0 - x0),
        (dx, x1 - a.0),
        (-dy, a.1 - y0),
        (dy, y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    t0 <= t1
}

/// Which cells a checked list may use.
#[derive(Clone, Debug, PartialEq)]
pub struct AreaRules<'a> {
    /// Rows of the search area G.
    pub rows: u32,
    /// Columns of G.
    pub cols: u32,
    /// O, the no-fly cells.
    pub obstacles: &'a [Cell],
    /// For stations: R, the cells they may be on (`None` for drones).
    pub roads: Option<&'a [Cell]>,
}

/// The first violation [`check_mission`] finds in a mission, naming the item (its index in
/// the list).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum UnsafeMission {
    /// The item's position has no place on the grid.
    #[error("item {item}: {source}")]
    Position {
        /// The item's index.
        item: usize,
        /// Why the grid cannot place it.
        source: GeoError,
    },
    /// The item is outside the search area.
    #[error("item {item} at cell {cell} is outside the search area")]
    Outside {
        /// The item's index.
        item: usize,
        /// Its cell.
        cell: Cell,
    },
    /// The item is in a no-fly cell.
    #[error("item {item} is in no-fly cell {cell}")]
    NoFly {
        /// The item's index.
        item: usize,
        /// Its cell.
        cell: Cell,
    },
    /// A station's item is off the roads.
    #[error("item {item} at cell {cell} is off the roads")]
    OffRoad {
        /// The item's index.
        item: usize,
        /// Its cell.
        cell: Cell,
    },
    /// The straight leg to the item crosses a no-fly cell.
    #[error("the leg to item {item} (cell {cell}) crosses no-fly cell {crossed}")]
    LegCrosses {
        /// The item's index.
        item: usize,
        /// Its cell.
        cell: Cell,
        /// The no-fly cell the leg crosses.
        crossed: Cell,
    },
}

/// Check an uploaded (or read-back) mission of a vehicle starting at cell `start` (see the
/// module documentation): the first violation, naming the item.
pub fn check_mission(
    grid: &Grid,
    rules: &AreaRules<'_>,
    start: Cell,
    items: &[MissionItem],
) -> Result<(), UnsafeMission> {
    let s = grid.cell_size();
    let obstacles: BTreeSet<Cell> = rules.obstacles.iter().copied().collect();
    let roads: Option<BTreeSet<Cell>> = rules.roads.map(|r| r.iter().copied().collect());
    // Interiors: each obstacle cell shrunk by 1 % of a cell, so a leg through a corner passes.
    const EPS: f64 = 0.01;
    let boxes: Vec<(Cell, (f64, f64, f64, f64))> = obstacles
        .iter()
        .map(|&c| {
            let (x, y) = (f64::from(c.col), f64::from(c.row));
            (
                c,
                (x - 0.5 + EPS, y - 0.5 + EPS, x + 0.5 - EPS, y + 0.5 - EPS),
            )
        })
        .collect();
    let mut here = (f64::from(start.col), f64::from(start.row));
    for (i, it) in items.iter().enumerate() {
        let positional = matches!(
            it.command,
            cmd::NAV_WAYPOINT | cmd::NAV_LOITER_TIME | cmd::NAV_LAND
        ) && (it.x != 0 || it.y != 0);
        if !positional {
            continue;
        }
        let (e, n) = grid
            .to_xy(LatLon::new(it.lat(), it.lon()))
            .map_err(|source| UnsafeMission::Position { item: i, source })?;
        let p = (e / s, n / s);
        let cell = grid.cell_of_xy(e, n);
        let inside = cell.row >= 0
            && cell.col >= 0
            && (cell.row as u32) < rules.rows
            && (cell.col as u32) < rules.cols;
        if !inside {
            return Err(UnsafeMission::Outside { item: i, cell });
        }
        if obstacles.contains(&cell) {
            return Err(UnsafeMission::NoFly { item: i, cell });
        }
        if let Some(r) = &roads
            && !r.contains(&cell)
        {
            return Err(UnsafeMission::OffRoad { item: i, cell });
        }
        if let Some((c, _)) = boxes.iter().find(|(_, b)| segment_hits_box(here, p, *b)) {
            return Err(UnsafeMission::LegCrosses {
                item: i,
                cell,
                crossed: *c,
            });
        }
        here = p;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        Grid::new(LatLon::new(37.195, -80.58), 5.0).unwrap()
    }

    #[test]
    fn drone_mission_holds_over_capture_cells_and_marks_steps() {
        let g = grid();
        let path = [
            Cell::new(3, 1),
            Cell::new(2, 1),
            Cell::new(2, 1),
            Cell::new(3, 1),
        ];
        let capture = [false, true, true, false];
        let m = drone_mission(
            &g,
            &DroneMissionSpec {
                path: &path,
                capture: &capture,
                altitude_m: 12.0,
                speed_m_s: 2.0,
                batch: 30,
                capture_interval_s: 0.25,
                lock_step: false,
                step_s: 2.5,
                settle_s: 2.0,
            },
        );
        let cmds: Vec<u16> = m.items.iter().map(|i| i.command).collect();
        assert_eq!(
            cmds,
            vec![
                cmd::NAV_TAKEOFF,
                cmd::DO_CHANGE_SPEED,
                cmd::NAV_WAYPOINT,
                cmd::NAV_WAYPOINT,
                cmd::IMAGE_START_CAPTURE,
                cmd::NAV_LOITER_TIME,
                cmd::NAV_WAYPOINT
            ]
        );
        // from the pad to the centre of the start cell before the first leg
        let c0 = g.cell_center(path[0]);
        let off = crate::geo::local::distance(c0.lat, c0.lon, m.items[2].lat(), m.items[2].lon());
        assert!(off < 0.02, "{off} m from the centre of {}", path[0]);
        assert_eq!(m.items[4].param3, 30.0);
        assert_eq!(m.items[5].param1, 9.0, "⌈30 · 0.25⌉ + 1");
        // a pass captures nothing (one visit, as in the study's `visits`)
        assert_eq!(m.capture_steps, vec![1]);
        assert_eq!(m.step_done, vec![None, Some(5), None, Some(6)]);
        assert_eq!(steps_done(&m.step_done, &[]), 0);
        assert_eq!(steps_done(&m.step_done, &[3]), 0);
        assert_eq!(steps_done(&m.step_done, &[3, 5]), 2);
        assert_eq!(steps_done(&m.step_done, &[3, 5, 6]), 3);
        let rules = AreaRules {
            rows: 6,
            cols: 6,
            obstacles: &[Cell::new(2, 2)],
            roads: None,
        };
        assert!(check_mission(&g, &rules, path[0], &m.items).is_ok());
    }

    #[test]
    fn lock_step_missions_loiter_at_every_step() {
        let g = grid();
        let path = [Cell::new(0, 0), Cell::new(0, 1), Cell::new(0, 1)];
        let m = drone_mission(
            &g,
            &DroneMissionSpec {
                path: &path,
                capture: &[false; 3],
                altitude_m: 10.0,
                speed_m_s: 2.0,
                batch: 10,
                capture_interval_s: 0.25,
                lock_step: true,
                step_s: 3.0,
                settle_s: 2.0,
            },
        );
        assert_eq!(
            m.items.len(),
            7,
            "ends on a plain waypoint after the last hover"
        );
        assert_eq!(m.items[6].command, cmd::NAV_WAYPOINT);
        assert_eq!(m.step_arrive, vec![None, Some(3), Some(5)]);
        assert_eq!(m.step_done, vec![None, Some(4), Some(6)]);
        assert_eq!(m.items[5].param1, 3.0);
    }

    #[test]
    fn legs_through_obstacles_are_refused_corners_are_not() {
        let g = grid();
        let obstacles = [Cell::new(1, 1), Cell::new(0, 1)];
        let rules = AreaRules {
            rows: 3,
            cols: 3,
            obstacles: &obstacles,
            roads: None,
        };
        let wp = |r, c| {
            let p = g.cell_center(Cell::new(r, c));
            MissionItem::waypoint(p.lat, p.lon, 10.0)
        };
        // (0,0) → (0,2) goes straight through (0,1)
        let e = check_mission(&g, &rules, Cell::new(0, 0), &[wp(0, 2)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("crosses no-fly cell (0, 1)"), "{e}");
        // (2,0) → (2,1) → (2,2) is clear; (1,0) → (2,1) passes the corner of (1,1)
        assert!(check_mission(&g, &rules, Cell::new(2, 0), &[wp(2, 1), wp(2, 2)]).is_ok());
        assert!(check_mission(&g, &rules, Cell::new(1, 0), &[wp(2, 1)]).is_ok());
        let e = check_mission(&g, &rules, Cell::new(2, 0), &[wp(1, 1)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("no-fly cell (1, 1)"), "{e}");
        let e = check_mission(&g, &rules, Cell::new(2, 0), &[wp(3, 0)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("outside the search area"), "{e}");
        let roads = [Cell::new(2, 0), Cell::new(2, 1)];
        let station = AreaRules {
            roads: Some(&roads),
            ..rules.clone()
        };
        let e = check_mission(&g, &station, Cell::new(2, 0), &[wp(2, 1), wp(2, 2)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("off the roads"), "{e}");
    }

    #[test]
    fn fence_merges_obstacles() {
        let g = grid();
        let obstacles = [
            Cell::new(9, 1),
            Cell::new(9, 2),
            Cell::new(9, 3),
            Cell::new(8, 1),
            Cell::new(5, 5),
        ];
        let rects = merge_cells(&obstacles);
        assert_eq!(rects, vec![(5, 5, 5, 5), (8, 1, 8, 1), (9, 1, 9, 3)]);
        let two_rows = merge_cells(&[
            Cell::new(0, 0),
            Cell::new(0, 1),
            Cell::new(1, 0),
            Cell::new(1, 1),
        ]);
        assert_eq!(two_rows, vec![(0, 0, 1, 1)]);
        let items = fence_items(&g, 10, 10, &obstacles, 1.0).unwrap();
        assert_eq!(items.len(), 4 * 4);
        // The simulator's fence keeping to these items: tests/suite/planner.rs.
    }
}
