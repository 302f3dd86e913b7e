//! What a spatial-classification run produced (pure): the report behind `fleetmap report
//! RUN_DIR` for `spatial-classification` runs and the PNG of the classification progress per
//! epoch, like the bandit paper's Fig. 4 (percentage of cells classified after each epoch;
//! with a simulated world, solid for the interesting cells and dashed for the others, as in
//! its Figs. 5–6).
//!
//! With a simulated world the report scores the labels against the ground truth: the
//! interesting cells are the world's green tiles (§V: "the four green tiles represent the
//! interesting cells"); an error is a kept cell that is not green or a rejected green one
//! (the labelling error criterion (2); Prop. 1 bounds the probability of any error by δ).

use crate::app::error::PlotError;
use fleetmap_core::geo::Cell;
use fleetmap_core::planner::bandit::Label;
use fleetmap_core::planner::sortie::{ClassificationState, EpochStats};
use plotters::prelude::*;
use serde::Serialize;
use std::collections::BTreeSet;

/// A cell as `[row, col]` (the mission-file form).
pub(crate) type CellPair = [i32; 2];

fn pair(c: Cell) -> CellPair {
    [c.row, c.col]
}

/// One epoch in the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct EpochLine {
    /// Epoch p.
    pub epoch: u64,
    /// E_p.
    pub goals: Vec<CellPair>,
    /// Sensing cycles flown.
    pub cycles: usize,
    /// IP solves (1 + re-plans).
    pub solves: u32,
    /// Planner wall time, seconds.
    pub(crate) planner_s: f64,
    /// Sortie time, seconds.
    pub(crate) flight_s: f64,
    /// Measurements counted.
    pub measurements: u64,
    /// Capture visits.
    pub visits: u64,
    /// |K|, |R| and unclassified cells after the epoch.
    pub keep: usize,
    /// |R| after the epoch.
    pub reject: usize,
    /// Unclassified cells after the epoch.
    pub unclassified: usize,
    /// Cells classified during the epoch.
    pub classified: Vec<CellPair>,
}

impl EpochLine {
    fn of(e: &EpochStats) -> EpochLine {
        EpochLine {
            epoch: e.epoch,
            goals: e.goals.iter().map(|&c| pair(c)).collect(),
            cycles: e.cycles,
            solves: e.solves,
            planner_s: e.planner_s,
            flight_s: e.flight_s,
            measurements: e.measurements,
            visits: e.visits,
            keep: e.keep,
            reject: e.reject,
            unclassified: e.unclassified,
            classified: e.classified.iter().map(|&(c, _)| pair(c)).collect(),
        }
    }
}

/// The report (`fleetmap report RUN_DIR --json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClassificationReport {
    /// Mission name.
    pub mission: String,
    /// Whether every cell is classified (Algorithm 1 terminated).
    pub finished: bool,
    /// K: cells classified interesting.
    pub keep: Vec<CellPair>,
    /// R: cells classified uninteresting.
    pub reject: Vec<CellPair>,
    /// Candidate cells not classified yet.
    pub unclassified: Vec<CellPair>,
    /// With a simulated world: its interesting cells (green tiles) among the candidates.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interesting_truth: Option<Vec<CellPair>>,
    /// With a simulated world: the cells labelled wrongly (kept but not interesting, or
    /// rejected but interesting).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub errors: Option<Vec<CellPair>>,
    /// Epochs finished.
    pub epochs: usize,
    /// Sensing cycles per finished epoch.
    pub sensing_cycles_per_epoch: Vec<usize>,
    /// Planner wall time per finished epoch, seconds.
    pub planner_seconds_per_epoch: Vec<f64>,
    /// Sortie time per finished epoch, seconds.
    pub(crate) flight_seconds_per_epoch: Vec<f64>,
    /// The epochs in detail.
    pub(crate) per_epoch: Vec<EpochLine>,
    /// Drone flight time, all drones together, seconds airborne.
    pub flight_time_s: f64,
    /// Airborne seconds per drone.
    pub(crate) airborne_s: Vec<(u8, f64)>,
    /// Time the sorties took (the team's clock), seconds.
    pub(crate) sortie_time_s: f64,
    /// Measurements counted into H.
    pub measurements: u64,
    /// Images received but not counted.
    pub ignored_images: u64,
    /// Images that could not be read.
    pub image_failures: u64,
    /// Samples |H_l| per candidate cell.
    pub samples: Vec<(CellPair, u64)>,
    /// Times the run was resumed.
    pub resumes: u32,
    /// The vehicles out of the run when it was saved, by system id: why, and what a person
    /// must fix (absent: tried again by itself).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub(crate) out: Vec<(u8, fleetmap_core::planner::sortie::Sidelined)>,
    /// θ, ε, δ, the confidence bound (`paper` or `kl`), D, B, Td, Tc, K, C, separation.
    pub(crate) parameters: serde_json::Value,
}

/// The report of `state`; `truth` is the set of interesting cells of a simulated world.
pub fn report(state: &ClassificationState, truth: Option<&[Cell]>) -> ClassificationReport {
    let b = &state.bandit;
    let cells = |l: Label| -> Vec<CellPair> {
        b.cells
            .iter()
            .zip(&b.labels)
            .filter(|(_, x)| **x == l)
            .map(|(&c, _)| pair(c))
            .collect()
    };
    let candidates: BTreeSet<Cell> = b.cells.iter().copied().collect();
    let (interesting_truth, errors) = match truth {
        Some(t) => {
            let set: BTreeSet<Cell> = t
                .iter()
                .copied()
                .filter(|c| candidates.contains(c))
                .collect();
            let errors: Vec<CellPair> = b
                .cells
                .iter()
                .zip(&b.labels)
                .filter(|(c, l)| match l {
                    Label::Keep => !set.contains(c),
                    Label::Reject => set.contains(c),
                    Label::Unclassified => false,
                })
                .map(|(&c, _)| pair(c))
                .collect();
            (Some(set.iter().map(|&c| pair(c)).collect()), Some(errors))
        }
        None => (None, None),
    };
    let p = &state.params;
    ClassificationReport {
        mission: state.mission.clone(),
        finished: state.is_finished(),
        keep: cells(Label::Keep),
        reject: cells(Label::Reject),
        unclassified: cells(Label::Unclassified),
        interesting_truth,
        errors,
        epochs: state.epochs.len(),
        sensing_cycles_per_epoch: state.epochs.iter().map(|e| e.cycles).collect(),
        planner_seconds_per_epoch: state.epochs.iter().map(|e| e.planner_s).collect(),
        flight_seconds_per_epoch: state.epochs.iter().map(|e| e.flight_s).collect(),
        per_epoch: state.epochs.iter().map(EpochLine::of).collect(),
        flight_time_s: state.airborne_s.values().sum(),
        airborne_s: state.airborne_s.iter().map(|(&s, &t)| (s, t)).collect(),
        sortie_time_s: state.epochs.iter().map(|e| e.flight_s).sum(),
        measurements: state.measurements,
        ignored_images: state.ignored_images,
        image_failures: state.image_failures,
        samples: b
            .cells
            .iter()
            .zip(&b.samples)
            .map(|(&c, &n)| (pair(c), n))
            .collect(),
        resumes: state.resumes,
        out: state.out.iter().map(|(&s, o)| (s, o.clone())).collect(),
        parameters: serde_json::json!({
            "theta": p.theta, "epsilon": p.epsilon, "delta": p.delta,
            "bound": b.bound.name(),
            "epoch_goals": p.epoch_goals, "batch_size": p.batch,
            "drone_cycle_steps": p.td, "station_cycle_steps": p.tc, "max_cycles": p.k_max,
            "charger_capacity": p.capacity, "separation": p.separation,
        }),
    }
}

/// The classification progress after each finished epoch p = 0, 1, …: percentages (0–100)
/// of (interesting, uninteresting, all) candidate cells classified, the first two by
/// `truth` (without it, by the labels: keep and reject).
pub fn progress(state: &ClassificationState, truth: Option<&[Cell]>) -> Vec<(f64, f64, f64)> {
    let b = &state.bandit;
    let truth: Option<BTreeSet<Cell>> = truth.map(|t| t.iter().copied().collect());
    let interesting = |l: usize| match &truth {
        Some(t) => t.contains(&b.cells[l]),
        None => b.labels[l] == Label::Keep,
    };
    let n_int = (0..b.len()).filter(|&l| interesting(l)).count().max(1) as f64;
    let n_un = (b.len() as f64 - n_int).max(1.0);
    let n = b.len().max(1) as f64;
    (0..state.epochs.len() as u64)
        .map(|p| {
            let done = |l: usize| b.classified_at[l].is_some_and(|q| q <= p);
            let ci = (0..b.len()).filter(|&l| done(l) && interesting(l)).count() as f64;
            let cu = (0..b.len()).filter(|&l| done(l) && !interesting(l)).count() as f64;
            (100.0 * ci / n_int, 100.0 * cu / n_un, 100.0 * (ci + cu) / n)
        })
        .collect()
}

/// The progress plot (Fig. 4) as PNG bytes, `width × height` pixels.
pub fn progress_png(
    state: &ClassificationState,
    truth: Option<&[Cell]>,
    width: u32,
    height: u32,
) -> Result<Vec<u8>, PlotError> {
    crate::plot::register_font();
    let pts = progress(state, truth);
    let mut series: Vec<(f64, f64, f64, f64)> = vec![(0.0, 0.0, 0.0, 0.0)];
    series.extend(
        pts.iter()
            .enumerate()
            .map(|(p, &(i, u, a))| ((p + 1) as f64, i, u, a)),
    );
    let max_x = (series.len() as f64 - 1.0).max(1.0);
    let (first, second) = if truth.is_some() {
        ("interesting cells", "uninteresting cells")
    } else {
        ("kept cells", "rejected cells")
    };
    let mut buf = vec![0u8; (width * height * 3) as usize];
    let err = |e: &dyn std::fmt::Display| PlotError::Drawing(e.to_string());
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let title = format!("{}: classification progress per epoch", state.mission);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..max_x, 0f64..105f64)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("epochs completed")
            .y_desc("cells classified (%)")
            .x_labels(12)
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
            .light_line_style(RGBColor(238, 238, 238))
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(|e| err(&e))?;
        let blue = RGBColor(31, 119, 180);
        let orange = RGBColor(255, 127, 14);
        let grey = RGBColor(90, 90, 90);
        chart
            .draw_series(LineSeries::new(
                series.iter().map(|s| (s.0, s.1)),
                blue.stroke_width(3),
            ))
            .map_err(|e| err(&e))?
            .label(first)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(3))
            });
        chart
            .draw_series(DashedLineSeries::new(
                series.iter().map(|s| (s.0, s.2)),
                6,
                4,
                orange.stroke_width(3),
            ))
            .map_err(|e| err(&e))?
            .label(second)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], orange.stroke_width(3))
            });
        chart
            .draw_series(LineSeries::new(
                series.iter().map(|s| (s.0, s.3)),
                grey.stroke_width(1),
            ))
            .map_err(|e| err(&e))?
            .label("all candidate cells")
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(1))
            });
        chart
            .draw_series(
                series
                    .iter()
                    .map(|s| Circle::new((s.0, s.1), 3, blue.filled())),
            )
            .map_err(|e| err(&e))?;
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let img = image::RgbImage::from_raw(width, height, buf).ok_or(PlotError::BufferSize)?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    Ok(png)
}

fn cell_labels(state: &ClassificationState) -> Vec<(Cell, &'static str)> {
    let b = &state.bandit;
    let mut v: Vec<(Cell, &'static str)> = b
        .cells
        .iter()
        .zip(&b.labels)
        .map(|(&c, l)| {
            (
                c,
                match l {
                    Label::Keep => "keep",
                    Label::Reject => "reject",
                    Label::Unclassified => "unclassified",
                },
            )
        })
        .collect();
    v.extend(state.layout.obstacles.iter().map(|&c| (c, "no-fly")));
    let candidates: BTreeSet<Cell> = b.cells.iter().copied().collect();
    v.extend(
        state
            .layout
            .roads
            .iter()
            .filter(|c| !candidates.contains(c))
            .map(|&c| (c, "road")),
    );
    v
}

/// The labelled cells as a GeoJSON FeatureCollection (property `label`: keep, reject,
/// unclassified, no-fly or road).
pub fn geojson(state: &ClassificationState) -> serde_json::Value {
    let cells: Vec<(Cell, serde_json::Value)> = cell_labels(state)
        .into_iter()
        .map(|(c, l)| (c, serde_json::json!({ "label": l })))
        .collect();
    fleetmap_core::geo::export::cells_geojson(&state.grid, &cells, &[])
}

/// The labelled cells as KML (green keep, grey reject, white unclassified, red no-fly,
/// dark road).
pub fn kml(state: &ClassificationState) -> String {
    use fleetmap_core::geo::export::kml_colour;
    let cells: Vec<(Cell, String, String)> = cell_labels(state)
        .into_iter()
        .map(|(c, l)| {
            let colour = match l {
                "keep" => kml_colour(40, 180, 60, 200),
                "reject" => kml_colour(140, 140, 140, 160),
                "no-fly" => kml_colour(220, 60, 30, 180),
                "road" => kml_colour(50, 50, 60, 140),
                _ => kml_colour(255, 255, 255, 120),
            };
            (c, format!("{l} {c}"), colour)
        })
        .collect();
    fleetmap_core::geo::export::cells_kml(&state.grid, &cells, &[])
}
