//! What a runway-mapping run produced (pure): the report behind `fleetmap report RUN_DIR`,
//! the map as GeoJSON and KML (runway paper Fig. 11: the mapped cells over the region in
//! Google Earth / QGIS) and a PNG of the grid like Fig. 10.
//!
//! With a simulated world the report scores the map against the ground truth:
//! * `iou` — the paper's figure (§7, 75.7 % in the field test): the area of the intersection of
//!   the region and the mapped cells over the area of their union;
//! * `iou_best_possible` — the IoU of the best labelling this grid allows: every cell more
//!   than half covered by the region (adding a cell with coverage f changes the
//!   intersection by f and the union by 1 − f, so a cell helps exactly when f > ½ … up to
//!   the IoU itself; the majority labelling is the standard reference, and the one the
//!   acceptance figures are measured against);
//! * false positives / negatives of the visit decisions ("483 detections, 27 false
//!   positives, 53 false negatives" in §7) and of the final cells, a cell counting as region
//!   when more than half of it is.

use fleetmap_core::explore::dfs::ExplorerConfig;
use fleetmap_core::explore::dfs::VertexState;
use fleetmap_core::explore::mapping::{FinishReason, GaveUp, MappingState, OnboardTally};
use fleetmap_core::geo::{Cell, GeoError, Grid, LatLon};
use fleetmap_core::vision::runway::votes::CellState;
use fleetmap_core::world::{Surface, World};
use image::{Rgb, RgbImage};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};

/// The surfaces that make up the region of interest in a world (runway asphalt, a plume).
pub(crate) const ROI_SURFACES: [Surface; 2] = [Surface::Asphalt, Surface::Plume];

/// The paper's field-test IoU (§7).
pub(crate) const PAPER_IOU: f64 = 0.757;

/// The region of interest of `world` on `grid`: every cell it touches with the covered
/// fraction (regions of the ROI surfaces at time `t_s`; overlaps are not double-counted
/// beyond a fraction of 1).
pub fn truth_coverage(
    grid: &Grid,
    world: &World,
    t_s: f64,
) -> Result<BTreeMap<Cell, f64>, GeoError> {
    let mut cov: BTreeMap<Cell, f64> = BTreeMap::new();
    for s in ROI_SURFACES {
        for poly in world.polygons_of(s, t_s) {
            let ring: Vec<LatLon> = poly.iter().map(|&(lat, lon)| LatLon { lat, lon }).collect();
            for (c, f) in grid.polygon_coverage(&ring)? {
                let e = cov.entry(c).or_insert(0.0);
                *e = (*e + f).min(1.0);
            }
        }
    }
    Ok(cov)
}

/// The region's outline polygons (lat, lon) for the exports.
pub(crate) fn truth_outlines(world: &World, t_s: f64) -> Vec<Vec<LatLon>> {
    ROI_SURFACES
        .iter()
        .flat_map(|&s| world.polygons_of(s, t_s))
        .map(|p| {
            p.into_iter()
                .map(|(lat, lon)| LatLon { lat, lon })
                .collect()
        })
        .collect()
}

/// IoU of the cell set `map` with a region given by its per-cell coverage.
pub fn iou(map: &BTreeSet<Cell>, coverage: &BTreeMap<Cell, f64>) -> f64 {
    let area: f64 = coverage.values().sum();
    let inter: f64 = map
        .iter()
        .map(|c| coverage.get(c).copied().unwrap_or(0.0))
        .sum();
    let union = area + map.len() as f64 - inter;
    if union <= 0.0 { 0.0 } else { inter / union }
}

/// Confusion counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    /// Said region, is region.
    pub(crate) true_positives: u64,
    /// Said region, is not.
    pub false_positives: u64,
    /// Said not region, is not.
    pub(crate) true_negatives: u64,
    /// Said not region, is region.
    pub false_negatives: u64,
}

impl From<fleetmap_core::vision::runway::votes::Confusion> for Counts {
    fn from(c: fleetmap_core::vision::runway::votes::Confusion) -> Counts {
        Counts {
            true_positives: c.true_positives,
            false_positives: c.false_positives,
            true_negatives: c.true_negatives,
            false_negatives: c.false_negatives,
        }
    }
}

/// The run's mission time, seconds of the fleet clock — the vehicles' clock: the
/// wall clock with real vehicles, the simulator's time when it runs in the GCS's process —
/// from the first take-off ([`fleetmap_core::explore::mapping::MissionClock`]). What a team plans its
/// day by, and the runway paper's figure (§7: one UAV, 73 minutes, six battery swaps).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MissionTime {
    /// From the runner's start to the first take-off (uploads, arming), seconds.
    pub before_takeoff_s: f64,
    /// From the first take-off to the start of the DFS (the sweep and the confirmation);
    /// `None` until a confirmation found the region.
    pub to_dfs_start_s: Option<f64>,
    /// From the first take-off to the complete map (every cell decided); `None` until then.
    pub to_map_complete_s: Option<f64>,
    /// From the first take-off to the last landing; `None` while a drone is out.
    pub to_last_landing_s: Option<f64>,
    /// Since the first take-off as far as the run got (the last landing once finished).
    pub elapsed_s: f64,
    /// Times a runner started on the run (1: never resumed); the time between a stop and its
    /// resume is not counted.
    pub starts: u32,
    /// Share of the drones' time (drones × `elapsed_s`) spent flying and working.
    pub flying_share: f64,
    /// Share spent airborne and holding (waiting for a confirmation, a vertex, pictures …).
    pub waiting_share: f64,
    /// Share spent on the ground (before the first flight, swaps, landed at the end).
    pub ground_share: f64,
}

/// One drone's time since the team's first take-off, seconds of the fleet clock, sampled
/// every [`fleetmap_core::explore::mapping::CLOCK_SAMPLE_S`] s: its flying, waiting and ground
/// seconds add up to `elapsed_s`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RobotTimeReport {
    /// The three shares added up (the run's elapsed mission time).
    pub elapsed_s: f64,
    /// Airborne and working: sweep, flights to cells, pictures, flights home.
    pub flying_s: f64,
    /// Of `flying_s`: over a cell taking its pictures.
    pub imaging_s: f64,
    /// Of `flying_s`: flying home — for a battery swap (or to land for good when the map is
    /// complete by then), or at the end.
    pub homing_s: f64,
    /// Of `flying_s`: after the map was complete, before homing — the step a drone was
    /// flying when the last vertex was imaged (runs before drones went home from where they
    /// were: the walk back to the DFS's start, with which Algorithm 1 ends).
    pub(crate) returning_s: f64,
    /// Airborne and holding.
    pub waiting_s: f64,
    /// `waiting_s` by what it waited for: `confirmation_s` (another drone confirming),
    /// `sweep_s` (its sweep flown, the others' not), `pictures_s` (sweep pictures in
    /// transfer), `dfs_start_s` (at the root before the team's first split), `vertex_s` (at a
    /// later vertex: companions on their way, another drone imaging the cell), `operator_s`.
    pub waiting: fleetmap_core::explore::mapping::WaitTimes,
    /// On the ground.
    pub ground_s: f64,
    /// Of `ground_s`: before its first take-off.
    pub ground_before_s: f64,
    /// Of `ground_s`: between two flights (battery swap, camera fault, the take-off after).
    pub ground_swap_s: f64,
    /// Of `ground_s`: landed for good while others still flew.
    pub ground_done_s: f64,
    /// `flying_s` / `elapsed_s` (0 when nothing elapsed).
    pub flying_share: f64,
    /// `waiting_s` / `elapsed_s`.
    pub waiting_share: f64,
    /// `ground_s` / `elapsed_s`.
    pub ground_share: f64,
}

impl RobotTimeReport {
    fn of(t: &fleetmap_core::explore::mapping::RobotTimes) -> RobotTimeReport {
        let elapsed = t.accounted_s();
        let share = |x: f64| if elapsed > 0.0 { x / elapsed } else { 0.0 };
        RobotTimeReport {
            elapsed_s: elapsed,
            flying_s: t.flying_s,
            imaging_s: t.imaging_s,
            homing_s: t.homing_s,
            returning_s: t.returning_s,
            waiting_s: t.waiting_s(),
            waiting: t.waiting,
            ground_s: t.ground_s,
            ground_before_s: t.ground_before_s,
            ground_swap_s: t.ground_swap_s,
            ground_done_s: t.ground_done_s,
            flying_share: share(t.flying_s),
            waiting_share: share(t.waiting_s()),
            ground_share: share(t.ground_s),
        }
    }
}

/// Per-robot figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RobotReport {
    /// System id.
    pub sysid: u8,
    /// Altitude, metres above home.
    pub altitude_m: f64,
    /// Final status.
    pub status: String,
    /// Airborne time, seconds.
    pub flight_time_s: f64,
    /// Distance flown, metres.
    pub distance_m: f64,
    /// Battery swaps.
    pub battery_swaps: u32,
    /// Images classified.
    pub images: u64,
    /// Its time since the team's first take-off: flying, waiting, on the ground.
    pub time: RobotTimeReport,
}

/// Scores against the ground truth.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TruthReport {
    /// IoU of the map with the region (the paper's measure).
    pub iou: f64,
    /// IoU of the best labelling of this grid (cells more than half covered).
    pub iou_best_possible: f64,
    /// The paper's field-test IoU, for comparison.
    pub paper_iou: f64,
    /// Cells more than half covered by the region.
    pub region_cells: usize,
    /// Of those, how many the map has.
    pub region_cells_mapped: usize,
    /// Visit decisions vs the truth (the paper's "detections").
    pub decisions: Counts,
    /// Final cell states vs the truth.
    pub cells: Counts,
    /// Sum of false-positive decisions (the paper: 27 of 483).
    pub false_positives: u64,
    /// Sum of false-negative decisions (the paper: 53 of 483).
    pub false_negatives: u64,
}

/// Why a run ended beyond reach ([`GaveUp::BeyondReach`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BeyondReachReport {
    /// The vehicle whose flight was judged.
    pub sysid: u8,
    /// The region cell it was to fly to, `[row, col]`.
    pub cell: [i32; 2],
    /// The figures: `outpaced` (`drift_m_s`, `speed_m_s`) or `out_of_range` (`distance_m`,
    /// `needed_pct`, `full_pct`).
    #[serde(flatten)]
    pub why: fleetmap_core::explore::reach::Unreachable,
    /// The same in words.
    pub reason: String,
}

/// `fleetmap report RUN_DIR --json` for a runway-mapping run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MappingReport {
    /// Run kind.
    pub kind: &'static str,
    /// Mission name.
    pub mission: String,
    /// How the DFS allocated the robots at a vertex: `paper` (Algorithm 1's split),
    /// `nearest_frontier` or `spread` (ours; `runway.allocation`, with GCS sharing only).
    pub allocation: &'static str,
    /// Vertex-state sharing: `gcs` or `meet`.
    pub sharing: String,
    /// The region's velocity over the ground, `[north, east]` m/s, when it moved: the map
    /// is then in the region's own frame, which is the grid at the run's epoch (where the
    /// mission put the region), and the truth is the region at that epoch.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub roi_velocity_ne_mps: Option<[f64; 2]>,
    /// Where the run is.
    pub phase: String,
    /// Whether the run is over (every robot landed).
    pub finished: bool,
    /// Whether the region was found.
    pub found: bool,
    /// How the run ended: `mapped`, `region_not_found` or `beyond_reach` (`null` while it
    /// goes on).
    pub finish_reason: Option<FinishReason>,
    /// When the run ended beyond reach: which flight was judged and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beyond_reach: Option<BeyondReachReport>,
    /// Cells mapped as region.
    pub cells_mapped: usize,
    /// The mapped cells, `[row, col]`.
    pub positive_cells: Vec<[i32; 2]>,
    /// Cells decided not region.
    pub negative_cells: usize,
    /// Tree vertices (real cells).
    pub tree_vertices: usize,
    /// Vertices explored.
    pub explored_vertices: usize,
    /// Vertices not yet explored.
    pub unexplored_vertices: usize,
    /// Cell-centre images counted as votes.
    pub images: usize,
    /// Visit decisions (the paper's "detections").
    pub detections: usize,
    /// Sweep images.
    pub(crate) sweep_images: usize,
    /// Images lost or unreadable.
    pub image_failures: u64,
    /// Pictures the cameras classified on board (their results crossed the link, not the
    /// pictures) and the audits of them; absent when there were none.
    #[serde(skip_serializing_if = "is_none_onboard")]
    pub onboard: OnboardTally,
    /// Airborne time of all robots, seconds.
    pub flight_time_s: f64,
    /// Distance flown by all robots, metres.
    pub distance_m: f64,
    /// Battery swaps of all robots.
    pub battery_swaps: u32,
    /// Mission time: first take-off to the complete map and to the last landing.
    pub mission_time: MissionTime,
    /// Per robot.
    pub robots: Vec<RobotReport>,
    /// Against the ground truth, when the run's world is known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<TruthReport>,
    /// Same as `truth.iou` (top level for scripts).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iou: Option<f64>,
    /// Same as `truth.iou_best_possible`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iou_best_possible: Option<f64>,
}

fn is_none_onboard(t: &OnboardTally) -> bool {
    *t == OnboardTally::default()
}

/// The report of `state`, scored against `coverage` (from [`truth_coverage`]) when given.
pub fn report(state: &MappingState, coverage: Option<&BTreeMap<Cell, f64>>) -> MappingReport {
    let map: BTreeSet<Cell> = state.book.positive_cells().into_iter().collect();
    let negative = state
        .book
        .cells()
        .filter(|(_, r)| r.state == CellState::Negative)
        .count();
    let (tree_vertices, explored, unexplored) = match &state.explorer {
        Some(e) => {
            let vs = e.vertex_states();
            (
                e.tree().real_count(),
                vs.iter()
                    .filter(|(_, v)| *v == VertexState::Explored)
                    .count(),
                vs.iter()
                    .filter(|(_, v)| *v == VertexState::Unexplored)
                    .count(),
            )
        }
        None => (0, 0, 0),
    };
    let truth = coverage.map(|cov| {
        let best: BTreeSet<Cell> = cov
            .iter()
            .filter(|(_, f)| **f > 0.5)
            .map(|(c, _)| *c)
            .collect();
        let is_region = |c: Cell| cov.get(&c).is_some_and(|f| *f > 0.5);
        let e = state.book.evaluate(is_region);
        TruthReport {
            iou: iou(&map, cov),
            iou_best_possible: iou(&best, cov),
            paper_iou: PAPER_IOU,
            region_cells: best.len(),
            region_cells_mapped: best.intersection(&map).count(),
            decisions: e.decisions.into(),
            cells: e.cells.into(),
            false_positives: e.decisions.false_positives,
            false_negatives: e.decisions.false_negatives,
        }
    });
    let robots: Vec<RobotReport> = state
        .robots
        .iter()
        .map(|r| RobotReport {
            sysid: r.sysid,
            altitude_m: r.altitude_m,
            status: r.status.name().to_string(),
            flight_time_s: r.flight_s,
            distance_m: r.distance_m,
            battery_swaps: r.battery_swaps,
            images: r.images,
            time: RobotTimeReport::of(&r.times),
        })
        .collect();
    let clock = &state.clock;
    let team_s: f64 = robots.iter().map(|r| r.time.elapsed_s).sum();
    let team_share = |f: fn(&RobotTimeReport) -> f64| {
        if team_s > 0.0 {
            robots.iter().map(|r| f(&r.time)).sum::<f64>() / team_s
        } else {
            0.0
        }
    };
    let mission_time = MissionTime {
        before_takeoff_s: clock.before_takeoff_s,
        to_dfs_start_s: clock.dfs_start_s,
        to_map_complete_s: clock.map_complete_s,
        to_last_landing_s: clock.last_landing_s,
        elapsed_s: clock.elapsed_s,
        starts: clock.starts,
        flying_share: team_share(|t| t.flying_s),
        waiting_share: team_share(|t| t.waiting_s),
        ground_share: team_share(|t| t.ground_s),
    };
    MappingReport {
        kind: crate::kinds::runway::KIND,
        mission: state.mission.clone(),
        allocation: ExplorerConfig {
            sharing: state.params.sharing,
            allocation: state.params.allocation,
            direct_transit: false,
        }
        .effective_allocation()
        .name(),
        sharing: serde_json::to_value(state.params.sharing)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default(),
        roi_velocity_ne_mps: state.params.roi_velocity_ne_mps,
        phase: state.phase.to_string(),
        finished: state.is_finished(),
        found: state.explorer.is_some(),
        finish_reason: state.phase.finish_reason(),
        beyond_reach: match &state.phase {
            fleetmap_core::explore::mapping::Phase::Finished {
                gave_up: Some(g @ GaveUp::BeyondReach { sysid, cell, why }),
                ..
            } => Some(BeyondReachReport {
                sysid: *sysid,
                cell: [cell.row, cell.col],
                why: *why,
                reason: g.to_string(),
            }),
            _ => None,
        },
        cells_mapped: map.len(),
        positive_cells: map.iter().map(|c| [c.row, c.col]).collect(),
        negative_cells: negative,
        tree_vertices,
        explored_vertices: explored,
        unexplored_vertices: unexplored,
        images: state.book.detections().len(),
        detections: state.book.decisions().len(),
        sweep_images: state.sweep_images.len(),
        image_failures: state.image_failures,
        onboard: state.onboard,
        flight_time_s: robots.iter().map(|r| r.flight_time_s).sum(),
        distance_m: robots.iter().map(|r| r.distance_m).sum(),
        battery_swaps: robots.iter().map(|r| r.battery_swaps).sum(),
        mission_time,
        iou: truth.as_ref().map(|t| t.iou),
        iou_best_possible: truth.as_ref().map(|t| t.iou_best_possible),
        truth,
        robots,
    }
}

/// How a cell is drawn (Fig. 10's legend).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CellClass {
    /// Nothing known.
    Unknown,
    /// Decided not region.
    NonRegion,
    /// Region, not visited by the DFS.
    Unexplored,
    /// Region, visited by the DFS.
    Explored,
}

impl CellClass {
    /// Name in the exports.
    pub(crate) fn name(self) -> &'static str {
        match self {
            CellClass::Unknown => "unknown",
            CellClass::NonRegion => "non-runway",
            CellClass::Unexplored => "unexplored runway",
            CellClass::Explored => "explored",
        }
    }

    /// Fig. 10's colours: grey, white, black, green.
    pub(crate) fn rgb(self) -> [u8; 3] {
        match self {
            CellClass::Unknown => [150, 150, 150],
            CellClass::NonRegion => [255, 255, 255],
            CellClass::Unexplored => [0, 0, 0],
            CellClass::Explored => [0, 170, 0],
        }
    }
}

/// Every cell the run decided, classified for drawing.
pub(crate) fn classes(state: &MappingState) -> Vec<(Cell, CellClass)> {
    state
        .cell_map()
        .into_iter()
        .map(|(c, s, v)| {
            let class = match (s, v) {
                (
                    CellState::Positive,
                    Some(VertexState::Explored | VertexState::UnderExploration),
                ) => CellClass::Explored,
                (CellState::Positive, _) => CellClass::Unexplored,
                (CellState::Negative, _) => CellClass::NonRegion,
                (CellState::Unknown, _) => CellClass::Unknown,
            };
            (c, class)
        })
        .collect()
}

/// The map as a GeoJSON FeatureCollection: one polygon per decided cell (`state`, `class`)
/// and the region's outline when known.
pub fn geojson(state: &MappingState, outlines: &[Vec<LatLon>]) -> serde_json::Value {
    let cells: Vec<(Cell, serde_json::Value)> = classes(state)
        .into_iter()
        .map(|(c, k)| {
            (
                c,
                serde_json::json!({"class": k.name(), "runway": matches!(k, CellClass::Explored | CellClass::Unexplored)}),
            )
        })
        .collect();
    let extra: Vec<(Vec<LatLon>, serde_json::Value)> = outlines
        .iter()
        .map(|p| (p.clone(), serde_json::json!({"name": "ground truth"})))
        .collect();
    fleetmap_core::geo::export::cells_geojson(&state.grid, &cells, &extra)
}

/// The map as KML (Google Earth): mapped cells green/black, non-region white, the region's
/// outline in blue (Fig. 11).
pub fn kml(state: &MappingState, outlines: &[Vec<LatLon>]) -> String {
    use fleetmap_core::geo::export::kml_colour;
    let cells: Vec<(Cell, String, String)> = classes(state)
        .into_iter()
        .map(|(c, k)| {
            let [r, g, b] = k.rgb();
            (c, k.name().to_string(), kml_colour(r, g, b, 0x99))
        })
        .collect();
    let extra: Vec<(Vec<LatLon>, String)> = outlines
        .iter()
        .map(|p| (p.clone(), kml_colour(0, 0, 255, 0xff)))
        .collect();
    fleetmap_core::geo::export::cells_kml(&state.grid, &cells, &extra)
}

/// Pixels per cell in the PNG.
pub(crate) const PNG_CELL_PX: u32 = 24;

/// The grid like the paper's Fig. 10: unknown grey, non-runway white, unexplored runway
/// black, explored green; the tracks in red; the region's outline in blue. North up.
pub fn png(state: &MappingState, outlines: &[Vec<LatLon>]) -> RgbImage {
    let grid = &state.grid;
    let s = grid.cell_size();
    let classes = classes(state);
    // Extent in metres (grid frame): cells, tracks, outlines, with a cell of margin.
    let mut e0 = f64::INFINITY;
    let mut e1 = f64::NEG_INFINITY;
    let mut n0 = f64::INFINITY;
    let mut n1 = f64::NEG_INFINITY;
    let mut grow = |e: f64, n: f64| {
        if e.is_finite() && n.is_finite() {
            e0 = e0.min(e);
            e1 = e1.max(e);
            n0 = n0.min(n);
            n1 = n1.max(n);
        }
    };
    for (c, _) in &classes {
        let (e, n) = (f64::from(c.col) * s, f64::from(c.row) * s);
        grow(e - s / 2.0, n - s / 2.0);
        grow(e + s / 2.0, n + s / 2.0);
    }
    for r in &state.robots {
        for p in &r.track {
            grow(p[0], p[1]);
        }
    }
    let outlines_xy: Vec<Vec<(f64, f64)>> = outlines
        .iter()
        .map(|p| p.iter().filter_map(|q| grid.to_xy(*q).ok()).collect())
        .collect();
    for p in &outlines_xy {
        for &(e, n) in p {
            grow(e, n);
        }
    }
    if !e0.is_finite() {
        (e0, e1, n0, n1) = (-s, s, -s, s);
    }
    // Snap to whole cells plus one cell of margin.
    let c0 = (e0 / s - 0.5).floor() as i64 - 1;
    let c1 = (e1 / s - 0.5).ceil() as i64 + 1;
    let r0 = (n0 / s - 0.5).floor() as i64 - 1;
    let r1 = (n1 / s - 0.5).ceil() as i64 + 1;
    let cols = (c1 - c0 + 1).clamp(1, 400) as u32;
    let rows = (r1 - r0 + 1).clamp(1, 400) as u32;
    let px = PNG_CELL_PX;
    let mut img = RgbImage::from_pixel(cols * px, rows * px, Rgb(CellClass::Unknown.rgb()));
    // metres → pixel (x east, y south)
    let west = (c0 as f64 - 0.5) * s;
    let north = (r1 as f64 + 0.5) * s;
    let to_px = |e: f64, n: f64| -> (f32, f32) {
        (
            ((e - west) / s * f64::from(px)) as f32,
            ((north - n) / s * f64::from(px)) as f32,
        )
    };
    for (c, k) in &classes {
        let col = i64::from(c.col) - c0;
        let row = r1 - i64::from(c.row);
        if !(0..i64::from(cols)).contains(&col) || !(0..i64::from(rows)).contains(&row) {
            continue;
        }
        let rect = imageproc::rect::Rect::at(col as i32 * px as i32, row as i32 * px as i32)
            .of_size(px, px);
        imageproc::drawing::draw_filled_rect_mut(&mut img, rect, Rgb(k.rgb()));
    }
    // grid lines
    let line = Rgb([110, 110, 110]);
    let (w, h) = (img.width(), img.height());
    for k in 0..=cols {
        let x = (k * px).min(w - 1) as f32;
        imageproc::drawing::draw_line_segment_mut(&mut img, (x, 0.0), (x, h as f32), line);
    }
    for k in 0..=rows {
        let y = (k * px).min(h - 1) as f32;
        imageproc::drawing::draw_line_segment_mut(&mut img, (0.0, y), (w as f32, y), line);
    }
    for p in &outlines_xy {
        for w in 0..p.len() {
            let (a, b) = (p[w], p[(w + 1) % p.len()]);
            let (pa, pb) = (to_px(a.0, a.1), to_px(b.0, b.1));
            for d in [-1.0f32, 0.0, 1.0] {
                imageproc::drawing::draw_line_segment_mut(
                    &mut img,
                    (pa.0 + d, pa.1),
                    (pb.0 + d, pb.1),
                    Rgb([0, 60, 255]),
                );
            }
        }
    }
    for r in &state.robots {
        for w in r.track.windows(2) {
            let (a, b) = (to_px(w[0][0], w[0][1]), to_px(w[1][0], w[1][1]));
            imageproc::drawing::draw_line_segment_mut(&mut img, a, b, Rgb([220, 0, 0]));
        }
    }
    img
}

/// Whether the run found the region and finished (for exit statuses).
pub fn succeeded(state: &MappingState) -> bool {
    state.is_finished() && state.phase.finish_reason() == Some(FinishReason::Mapped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iou_of_exact_and_shifted_maps() {
        let cov: BTreeMap<Cell, f64> = [(Cell::new(0, 0), 1.0), (Cell::new(0, 1), 0.5)]
            .into_iter()
            .collect();
        let one: BTreeSet<Cell> = [Cell::new(0, 0)].into_iter().collect();
        // region area 1.5 cells; map = 1 cell inside: IoU = 1 / 1.5
        assert!((iou(&one, &cov) - 1.0 / 1.5).abs() < 1e-12);
        let both: BTreeSet<Cell> = [Cell::new(0, 0), Cell::new(0, 1)].into_iter().collect();
        // inter 1.5, union 2
        assert!((iou(&both, &cov) - 0.75).abs() < 1e-12);
        assert_eq!(iou(&BTreeSet::new(), &cov), 0.0);
    }
}
