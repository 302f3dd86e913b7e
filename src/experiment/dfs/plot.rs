//! PNG plots of the DFS study, like the paper's Fig. 7: (a) an example ROI with the tree the
//! run built, (b–d) cost against cells, robots and speed ratio, with Lemma 1, the lawnmower
//! baseline, Lemma 2 and the longest round trip from the start to a cell (mean, with min–max
//! bars over the trials).
//!
//! Rendering is plotters' bitmap backend into a memory buffer, encoded with `image`; text
//! uses DejaVu Sans embedded from `assets/fonts/` through plotters' `ab_glyph` feature, so no
//! fontconfig is needed on the machine.

use super::{DfsStudyError, SpeedRatio, Study, Sweep, trial_roi};
use fleetmap_core::explore::dfs::NodeKind;
use fleetmap_core::explore::dfs::{Allocation, Sharing};
use fleetmap_core::explore::simulate::{SimConfig, simulate};
use image::ImageEncoder;
use plotters::prelude::*;

const W: u32 = 960;
const H: u32 = 640;

fn err(name: &str, e: impl std::fmt::Display) -> DfsStudyError {
    DfsStudyError::Output {
        path: name.into(),
        reason: format!("plotting failed: {e}"),
    }
}

fn encode(name: &str, rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, DfsStudyError> {
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| err(name, e))?;
    Ok(png)
}

/// One line with min–max bars.
struct Series {
    name: String,
    color: RGBColor,
    /// (x, mean, min, max)
    points: Vec<(f64, f64, f64, f64)>,
}

fn line_chart(
    name: &str,
    title: &str,
    x_desc: &str,
    xs: &[(f64, String)],
    series: &[Series],
) -> Result<Vec<u8>, DfsStudyError> {
    crate::plot::register_font();
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(name, e))?;
        let (x0, x1) = xs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (x, _)| {
                (a.min(*x), b.max(*x))
            });
        let pad = ((x1 - x0) * 0.05).max(0.5);
        let ymax = series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.3))
            .filter(|v| v.is_finite())
            .fold(1.0, f64::max)
            * 1.08;
        let labels: Vec<(f64, String)> = xs.to_vec();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(64)
            .build_cartesian_2d((x0 - pad)..(x1 + pad), 0f64..ymax)
            .map_err(|e| err(name, e))?;
        let fmt = move |x: &f64| {
            labels
                .iter()
                .find(|(v, _)| (v - x).abs() < 1e-6)
                .map(|(_, l)| l.clone())
                .unwrap_or_default()
        };
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc("exploration time (cell lengths / S_r)")
            .x_labels(xs.len() * 4 + 1)
            .disable_x_mesh()
            .x_label_formatter(&fmt)
            .label_style(("sans-serif", 16))
            .axis_desc_style(("sans-serif", 18))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(|e| err(name, e))?;
        for s in series {
            let color = s.color;
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().map(|p| (p.0, p.1)),
                    color.stroke_width(2),
                ))
                .map_err(|e| err(name, e))?
                .label(s.name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                });
            chart
                .draw_series(
                    s.points.iter().map(|p| {
                        ErrorBar::new_vertical(p.0, p.2, p.1, p.3, color.stroke_width(1), 8)
                    }),
                )
                .map_err(|e| err(name, e))?;
            chart
                .draw_series(
                    s.points
                        .iter()
                        .map(|p| Circle::new((p.0, p.1), 3, color.filled())),
                )
                .map_err(|e| err(name, e))?;
        }
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 16))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(name, e))?;
        root.present().map_err(|e| err(name, e))?;
    }
    encode(name, &buf, W, H)
}

const ALG: [RGBColor; 3] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(188, 189, 34),
];
const UPPER: [RGBColor; 3] = [
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];
const LAWN: RGBColor = RGBColor(44, 160, 44);
const LEMMA2: RGBColor = RGBColor(127, 127, 127);
const REACH: RGBColor = RGBColor(23, 190, 207);

fn sweep_chart(
    study: &Study,
    sweep: Sweep,
    name: &str,
    title: &str,
    x_desc: &str,
) -> Result<Option<Vec<u8>>, DfsStudyError> {
    let modes: Vec<(Sharing, Allocation)> = {
        let mut m: Vec<(Sharing, Allocation)> = study
            .configurations
            .iter()
            .map(|c| (c.sharing, c.allocation))
            .collect();
        m.dedup();
        m
    };
    let rows: Vec<_> = study
        .summaries
        .iter()
        .filter(|s| s.config.sweep == sweep)
        .collect();
    if rows.is_empty() {
        return Ok(None);
    }
    // x positions: the value for cells and robots; categories for ratios ("static" last).
    let x_of = |s: &super::ConfigSummary| -> f64 {
        match sweep {
            Sweep::Cells => s.config.cells as f64,
            Sweep::Robots => s.config.robots as f64,
            Sweep::Ratio => rows
                .iter()
                .filter(|r| {
                    (r.config.sharing, r.config.allocation)
                        == (rows[0].config.sharing, rows[0].config.allocation)
                })
                .position(|r| r.config.speed_ratio == s.config.speed_ratio)
                .unwrap_or(0) as f64,
        }
    };
    let mut xs: Vec<(f64, String)> = Vec::new();
    for s in &rows {
        let x = x_of(s);
        if !xs.iter().any(|(v, _)| *v == x) {
            let label = match sweep {
                Sweep::Cells => s.config.cells.to_string(),
                Sweep::Robots => s.config.robots.to_string(),
                Sweep::Ratio => match s.config.speed_ratio {
                    SpeedRatio::Static => "static".into(),
                    SpeedRatio::Ratio(r) => format!("{r}"),
                },
            };
            xs.push((x, label));
        }
    }
    let mut series = Vec::new();
    for (mi, mode) in modes.iter().enumerate() {
        let mine: Vec<_> = rows
            .iter()
            .filter(|s| (s.config.sharing, s.config.allocation) == *mode)
            .collect();
        let suffix = if modes.len() > 1 {
            format!(" ({} sharing, {} allocation)", mode.0, mode.1)
        } else {
            String::new()
        };
        series.push(Series {
            name: format!("Algorithm 1{suffix}"),
            color: ALG[mi % ALG.len()],
            points: mine
                .iter()
                .map(|s| (x_of(s), s.cost.mean, s.cost.min, s.cost.max))
                .collect(),
        });
        series.push(Series {
            name: format!("Lemma 1 upper bound{suffix}"),
            color: UPPER[mi % UPPER.len()],
            points: mine
                .iter()
                .map(|s| {
                    let b = s.lemma1_upper;
                    (x_of(s), b.mean, b.min, b.max)
                })
                .collect(),
        });
        if mi == 0 {
            series.push(Series {
                name: "lawnmower baseline (§6)".into(),
                color: LAWN,
                points: mine
                    .iter()
                    .map(|s| {
                        let b = s.lawnmower_lower;
                        (x_of(s), b.mean, b.min, b.max)
                    })
                    .collect(),
            });
            series.push(Series {
                name: "Lemma 2 lower bound".into(),
                color: LEMMA2,
                points: mine
                    .iter()
                    .map(|s| {
                        let b = s.lemma2_lower;
                        (x_of(s), b.mean, b.min, b.max)
                    })
                    .collect(),
            });
            series.push(Series {
                name: "longest round trip from the start".into(),
                color: REACH,
                points: mine
                    .iter()
                    .map(|s| {
                        let b = s.reach_lower;
                        (x_of(s), b.mean, b.min, b.max)
                    })
                    .collect(),
            });
        }
    }
    line_chart(name, title, x_desc, &xs, &series).map(Some)
}

/// Fig. 7a: an example ROI (trial 0 with the largest cell count of the study) with the tree
/// Algorithm 1 built on it and the start cell in red.
fn roi_figure(study: &Study) -> Result<Vec<u8>, DfsStudyError> {
    const NAME: &str = "fig7a_roi.png";
    crate::plot::register_font();
    let conf = study
        .configurations
        .iter()
        .max_by_key(|c| c.cells)
        .copied()
        .ok_or_else(|| err(NAME, "no configuration"))?;
    let (roi, start, _) = trial_roi(study.seed, conf.cells, 0);
    let out = simulate(
        &roi,
        start,
        &SimConfig {
            robots: conf.robots,
            sharing: conf.sharing,
            allocation: conf.allocation,
            ..SimConfig::default()
        },
    )
    .map_err(|e| err(NAME, e))?;
    let (mut r0, mut r1, mut c0, mut c1) = (start.row, start.row, start.col, start.col);
    for c in &roi {
        r0 = r0.min(c.row);
        r1 = r1.max(c.row);
        c0 = c0.min(c.col);
        c1 = c1.max(c.col);
    }
    let side = ((r1 - r0).max(c1 - c0) + 3) as f64;
    let (cx, cy) = (f64::from(c0 + c1) / 2.0, f64::from(r0 + r1) / 2.0);
    let size = 720u32;
    let mut buf = vec![0u8; (size * size * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (size, size)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(NAME, e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "Random ROI, {} cells; tree of a {}-robot run (start in red)",
                    roi.len(),
                    conf.robots
                ),
                ("sans-serif", 20),
            )
            .margin(12)
            .build_cartesian_2d(
                (cx - side / 2.0)..(cx + side / 2.0),
                (cy - side / 2.0)..(cy + side / 2.0),
            )
            .map_err(|e| err(NAME, e))?;
        chart
            .draw_series(roi.iter().map(|c| {
                let (x, y) = (f64::from(c.col), f64::from(c.row));
                Rectangle::new(
                    [(x - 0.45, y - 0.45), (x + 0.45, y + 0.45)],
                    RGBColor(190, 190, 190).filled(),
                )
            }))
            .map_err(|e| err(NAME, e))?;
        let tree = out.explorer.tree();
        let edges: Vec<((f64, f64), (f64, f64))> = tree
            .nodes()
            .iter()
            .filter(|n| n.kind == NodeKind::Real)
            .filter_map(|n| {
                let p = tree.node(n.parent?).cell;
                Some((
                    (f64::from(p.col), f64::from(p.row)),
                    (f64::from(n.cell.col), f64::from(n.cell.row)),
                ))
            })
            .collect();
        chart
            .draw_series(
                edges
                    .into_iter()
                    .map(|(a, b)| PathElement::new(vec![a, b], BLUE.stroke_width(2))),
            )
            .map_err(|e| err(NAME, e))?;
        chart
            .draw_series(std::iter::once(Circle::new(
                (f64::from(start.col), f64::from(start.row)),
                7,
                RED.filled(),
            )))
            .map_err(|e| err(NAME, e))?;
        root.present().map_err(|e| err(NAME, e))?;
    }
    encode(NAME, &buf, size, size)
}

/// All figures of the study: (file name, PNG bytes).
pub(crate) fn figures(study: &Study) -> Result<Vec<(String, Vec<u8>)>, DfsStudyError> {
    let mut out = vec![("fig7a_roi.png".to_string(), roi_figure(study)?)];
    let specs = [
        (
            Sweep::Cells,
            "fig7b_cells.png",
            "Change in number of ROI cells",
            "number of ROI cells C",
        ),
        (
            Sweep::Robots,
            "fig7c_robots.png",
            "Change in number of robots",
            "number of robots R",
        ),
        (
            Sweep::Ratio,
            "fig7d_ratio.png",
            "Change in speed ratio",
            "speed ratio S_r / S_p",
        ),
    ];
    for (sweep, name, title, x_desc) in specs {
        if let Some(png) = sweep_chart(study, sweep, name, title, x_desc)? {
            out.push((name.to_string(), png));
        }
    }
    Ok(out)
}
