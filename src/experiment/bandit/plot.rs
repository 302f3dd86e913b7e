//! PNG plots of classification progress per epoch, like the bandit paper's Fig. 5 and Fig. 6:
//! one colour per variant, solid lines for the interesting cells and dashed lines for the
//! uninteresting ones (percentage classified, mean over trials).
//!
//! Rendering uses plotters' bitmap backend into a memory buffer and the `image` crate for the
//! PNG encoding; text is drawn with ab_glyph from DejaVu Sans shipped in `assets/fonts` (Bitstream
//! Vera licence, `assets/fonts/DejaVuSans-LICENSE.txt`), so no fontconfig is needed.

use super::VariantSummary;
use plotters::prelude::*;

/// Why a plot could not be drawn.
#[derive(Debug, thiserror::Error)]
pub(crate) enum PlotError {
    /// plotters failed.
    #[error("plot drawing failed: {0}")]
    Draw(String),
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Encode(String),
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Draw the progress curves of `variants` as a PNG (width × height pixels); the x axis
/// (epochs) is logarithmic with `log_x`, as in Fig. 5.
pub(crate) fn progress_png(
    title: &str,
    variants: &[VariantSummary],
    log_x: bool,
    width: u32,
    height: u32,
) -> Result<Vec<u8>, PlotError> {
    crate::plot::register_font();
    let mut buf = vec![0u8; (width * height * 3) as usize];
    let longest = variants
        .iter()
        .map(|v| v.progress.len())
        .max()
        .unwrap_or(1)
        .max(2) as f64;
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let series = |v: &VariantSummary, interesting: bool| -> Vec<(f64, f64)> {
            v.progress
                .iter()
                .enumerate()
                .map(|(p, &(i, u))| ((p + 1) as f64, 100.0 * if interesting { i } else { u }))
                .collect()
        };
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(if log_x {
                        "epoch (log scale); solid: interesting cells, dashed: uninteresting cells"
                    } else {
                        "epoch; solid: interesting cells, dashed: uninteresting cells"
                    })
                    .y_desc("cells classified (%, mean over trials)")
                    .x_labels(12)
                    .x_label_formatter(&|x| format!("{x:.0}"))
                    .y_label_formatter(&|y| format!("{y:.0}"))
                    .light_line_style(RGBColor(238, 238, 238))
                    .label_style(("sans-serif", 16))
                    .draw()
                    .map_err(|e| err(&e))?;
                for (n, v) in variants.iter().enumerate() {
                    let colour = COLOURS[n % COLOURS.len()];
                    chart
                        .draw_series(LineSeries::new(series(v, true), colour.stroke_width(2)))
                        .map_err(|e| err(&e))?
                        .label(v.config.label.clone())
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                        });
                    chart
                        .draw_series(DashedLineSeries::new(
                            series(v, false),
                            6,
                            4,
                            colour.stroke_width(2),
                        ))
                        .map_err(|e| err(&e))?;
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 14))
                    .position(SeriesLabelPosition::LowerRight)
                    .draw()
                    .map_err(|e| err(&e))?;
            }};
        }
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60);
        if log_x {
            draw!(
                builder
                    .build_cartesian_2d((1f64..longest).log_scale(), 0f64..100f64)
                    .map_err(|e| err(&e))?
            );
        } else {
            draw!(
                builder
                    .build_cartesian_2d(1f64..longest, 0f64..100f64)
                    .map_err(|e| err(&e))?
            );
        }
        root.present().map_err(|e| err(&e))?;
    }
    let img = image::RgbImage::from_raw(width, height, buf)
        .ok_or_else(|| PlotError::Encode("buffer size mismatch".into()))?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| PlotError::Encode(e.to_string()))?;
    Ok(png)
}
