//! The team-size study's figure: time to the complete map and to the last landing against
//! the number of drones (mean, min–max bars over the trials), beside one drone's time divided
//! by the team size (a team that never waits and splits the work evenly) and the goals.
//!
//! Rendering is plotters' bitmap backend into a memory buffer, encoded with `image`; text
//! uses DejaVu Sans embedded from `assets/fonts/` through plotters' `ab_glyph` feature, so no
//! fontconfig is needed on the machine.

use super::{GOALS, Stat, Study};
use image::ImageEncoder;
use plotters::prelude::*;

const W: u32 = 960;
const H: u32 = 640;

const MAP: RGBColor = RGBColor(31, 119, 180);
const LANDING: RGBColor = RGBColor(255, 127, 14);
const IDEAL: RGBColor = RGBColor(127, 127, 127);
const GOAL: RGBColor = RGBColor(214, 39, 40);

/// `runway_team.png`: simulated seconds from the first take-off against the team size.
pub(crate) fn team_png(study: &Study) -> anyhow::Result<Vec<u8>> {
    crate::plot::register_font();
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("plotting runway_team.png: {e}");
    let points = |f: fn(&super::TeamSummary) -> Option<Stat>| -> Vec<(f64, Stat)> {
        study
            .summaries
            .iter()
            .filter_map(|s| f(s).map(|x| (s.drones as f64, x)))
            .collect()
    };
    let map = points(|s| s.to_map_complete_s);
    let landing = points(|s| s.to_last_landing_s);
    let one = study
        .summaries
        .iter()
        .find(|s| s.drones == 1)
        .and_then(|s| s.to_map_complete_s)
        .map(|x| x.mean);
    let n_max = study
        .summaries
        .iter()
        .map(|s| s.drones)
        .max()
        .unwrap_or(1)
        .max(2) as f64;
    let y_max = map
        .iter()
        .chain(&landing)
        .map(|(_, s)| s.max)
        .fold(1.0, f64::max)
        * 1.1;
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "Runway field test: mission time by team size (simulator in {}, {} min batteries)",
                    study.speedup, study.battery_minutes
                ),
                ("sans-serif", 22),
            )
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(70)
            .build_cartesian_2d(0.5f64..(n_max + 0.5), 0f64..y_max)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("drones")
            .y_desc("simulated seconds from the first take-off")
            .x_labels(n_max as usize + 1)
            .x_label_formatter(&|x| {
                if (x - x.round()).abs() < 1e-6 && *x >= 1.0 {
                    format!("{x:.0}")
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|y| format!("{y:.0}"))
            .disable_x_mesh()
            .label_style(("sans-serif", 16))
            .axis_desc_style(("sans-serif", 18))
            .draw()
            .map_err(|e| err(&e))?;
        if let Some(one) = one {
            let curve: Vec<(f64, f64)> = (0..=100)
                .map(|k| 1.0 + (n_max - 1.0) * f64::from(k) / 100.0)
                .map(|n| (n, one / n))
                .collect();
            chart
                .draw_series(DashedLineSeries::new(curve, 6, 4, IDEAL.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label("one drone's map time / drones")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], IDEAL.stroke_width(2))
                });
            let goals: Vec<(f64, f64)> = GOALS
                .iter()
                .filter(|g| g.0 as f64 <= n_max)
                .map(|&(n, share)| (n as f64, one * share))
                .collect();
            chart
                .draw_series(
                    goals
                        .iter()
                        .map(|&p| Cross::new(p, 8, GOAL.stroke_width(3))),
                )
                .map_err(|e| err(&e))?
                .label("goal (3 drones 0.36×, 6 drones 0.20× of one)")
                .legend(|(x, y)| Cross::new((x + 12, y), 6, GOAL.stroke_width(3)));
        }
        for (name, colour, pts) in [
            ("to the complete map", MAP, &map),
            ("to the last landing", LANDING, &landing),
        ] {
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|(n, s)| (*n, s.mean)),
                    colour.stroke_width(2),
                ))
                .map_err(|e| err(&e))?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3))
                });
            chart
                .draw_series(pts.iter().map(|(n, s)| {
                    ErrorBar::new_vertical(*n, s.min, s.mean, s.max, colour.stroke_width(1), 8)
                }))
                .map_err(|e| err(&e))?;
            chart
                .draw_series(
                    pts.iter()
                        .map(|(n, s)| Circle::new((*n, s.mean), 4, colour.filled())),
                )
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 16))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&buf, W, H, image::ExtendedColorType::Rgb8)
        .map_err(|e| err(&e))?;
    Ok(png)
}
