//! The runway scene: what the runway paper's GoPro sees from 12 m (§7, Figure 9), for tests,
//! golden files and benchmarks. Sunlit grass that is mostly bright (grey above 150) with
//! small dark gaps and shadows between the blades — the gaps the 7 dilations close — and a
//! strip of dark asphalt with a little light gravel and optional white markings (edge lines
//! and centre-line dashes), at any angle and position, with an exposure factor to mimic
//! changing sunlight.
//!
//! A pure function of the parameters and the seed, as every scene of
//! [`crate::vision::synth`] (whose texture it shares).

use crate::vision::synth::{clamp_u8, jitter};
use image::{Rgb, RgbImage};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The asphalt strip of a runway scene, in pixels of the image.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunwayStrip {
    /// Direction of the runway's axis, degrees clockwise from the image's "up".
    pub angle_deg: f64,
    /// Signed distance of the axis from the image centre, pixels (positive to the axis'
    /// right-hand side).
    pub offset_px: f64,
    /// Width of the asphalt, pixels.
    pub width_px: f64,
    /// Length of the asphalt, pixels, centred `along_px` along the axis from the image
    /// centre; `None` = longer than the image.
    pub length_px: Option<f64>,
    /// Position of the strip's middle along the axis, pixels from the image centre.
    pub along_px: f64,
    /// Paint white edge lines and centre-line dashes.
    pub markings: bool,
}

/// A runway scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunwayScene {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Seed of the shapes and the texture.
    pub seed: u64,
    /// The asphalt strip, if any.
    pub runway: Option<RunwayStrip>,
    /// Share of the grass covered by dark gaps (0..1). Default 0.12.
    pub gap_density: f64,
    /// Largest radius of a dark gap, pixels. Default 3.
    pub gap_radius_px: f64,
    /// Light gravel specks per asphalt pixel. Default 0.0002.
    pub gravel_density: f64,
    /// Brightness factor (1 = nominal; 0.6 = overcast; 1.5 = over-exposed).
    pub exposure: f64,
}

impl RunwayScene {
    /// A scene of `width × height` pixels with the default texture and no runway.
    pub fn grass(width: u32, height: u32, seed: u64) -> RunwayScene {
        RunwayScene {
            width,
            height,
            seed,
            runway: None,
            gap_density: 0.12,
            gap_radius_px: 3.0,
            gravel_density: 0.0002,
            exposure: 1.0,
        }
    }

    /// The same scene with a runway strip.
    pub fn with_runway(mut self, strip: RunwayStrip) -> RunwayScene {
        self.runway = Some(strip);
        self
    }
}

/// Paint the disc of radius `r` centred at (`cx`, `cy`) with `f(x, y)`.
fn disc(img: &mut RgbImage, cx: f64, cy: f64, r: f64, mut f: impl FnMut(u32, u32) -> Rgb<u8>) {
    let (w, h) = (img.width() as f64, img.height() as f64);
    let y0 = (cy - r).floor().max(0.0) as u32;
    let y1 = (cy + r).ceil().min(h - 1.0).max(0.0) as u32;
    let x0 = (cx - r).floor().max(0.0) as u32;
    let x1 = (cx + r).ceil().min(w - 1.0).max(0.0) as u32;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
            if dx * dx + dy * dy <= r * r && x < img.width() && y < img.height() {
                let p = f(x, y);
                img.put_pixel(x, y, p);
            }
        }
    }
}

/// Coordinates of pixel (x, y) in the strip's frame: (across the axis, along the axis).
fn strip_frame(s: &RunwayStrip, w: u32, h: u32, x: u32, y: u32) -> (f64, f64) {
    let (px, py) = (
        x as f64 + 0.5 - w as f64 / 2.0,
        // Image y grows downwards; "up" is −y.
        -(y as f64 + 0.5 - h as f64 / 2.0),
    );
    let a = s.angle_deg.to_radians();
    // Axis direction (clockwise from up) and its right-hand normal.
    let (ax, ay) = (a.sin(), a.cos());
    let (nx, ny) = (ay, -ax);
    (
        px * nx + py * ny - s.offset_px,
        px * ax + py * ay - s.along_px,
    )
}

fn on_asphalt(s: &RunwayStrip, across: f64, along: f64) -> bool {
    across.abs() <= s.width_px / 2.0 && s.length_px.is_none_or(|l| along.abs() <= l / 2.0)
}

fn is_marking(s: &RunwayStrip, across: f64, along: f64) -> bool {
    if !s.markings {
        return false;
    }
    let line = (s.width_px * 0.02).clamp(2.0, 12.0);
    let edge = across.abs() >= s.width_px / 2.0 - 2.5 * line
        && across.abs() <= s.width_px / 2.0 - 1.5 * line;
    let dash_len = (s.width_px * 0.6).max(8.0);
    let centre = across.abs() <= line / 2.0 && (along / dash_len).rem_euclid(2.0) < 1.0;
    edge || centre
}

/// Render a runway scene.
pub fn render_runway(scene: &RunwayScene) -> RgbImage {
    let (w, h, seed) = (scene.width, scene.height, scene.seed);
    // Sunlit grass: light yellow-green, grey ≈ 160..200.
    let mut img = RgbImage::from_fn(w, h, |x, y| {
        let t = jitter(seed, x, y, 1, 12);
        let u = jitter(seed, x, y, 2, 4);
        Rgb([
            (176 + t + u).clamp(0, 255) as u8,
            (196 + t).clamp(0, 255) as u8,
            (118 + t / 2 - u).clamp(0, 255) as u8,
        ])
    });
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let area = f64::from(w) * f64::from(h);
    // Dark gaps and shadows between the blades (grey ≈ 60..110).
    let r_max = scene.gap_radius_px.max(0.5);
    let mean_area = std::f64::consts::PI * (0.5 + r_max) * (0.5 + r_max) / 3.0;
    let gaps = (scene.gap_density.clamp(0.0, 1.0) * area / mean_area).round() as u64;
    for _ in 0..gaps {
        let cx = rng.random_range(0.0..f64::from(w.max(1)));
        let cy = rng.random_range(0.0..f64::from(h.max(1)));
        let r = rng.random_range(0.5..=r_max);
        let shade: i32 = rng.random_range(0..50);
        disc(&mut img, cx, cy, r, |x, y| {
            let t = jitter(seed, x, y, 5, 10);
            Rgb([
                (58 + shade + t).clamp(0, 255) as u8,
                (88 + shade + t).clamp(0, 255) as u8,
                (36 + shade / 2 + t).clamp(0, 255) as u8,
            ])
        });
    }
    if let Some(s) = &scene.runway {
        let mut asphalt = 0u64;
        for y in 0..h {
            for x in 0..w {
                let (across, along) = strip_frame(s, w, h, x, y);
                if !on_asphalt(s, across, along) {
                    continue;
                }
                asphalt += 1;
                let p = if is_marking(s, across, along) {
                    let t = jitter(seed, x, y, 6, 6);
                    Rgb([(238 + t) as u8, (238 + t) as u8, (232 + t) as u8])
                } else {
                    // Asphalt, grey ≈ 55..95 with a slow blotchy variation.
                    let blotch = jitter(seed, x / 16, y / 16, 7, 12);
                    let t = blotch + jitter(seed, x, y, 8, 8);
                    Rgb([
                        (74 + t).clamp(0, 255) as u8,
                        (75 + t).clamp(0, 255) as u8,
                        (78 + t).clamp(0, 255) as u8,
                    ])
                };
                img.put_pixel(x, y, p);
            }
        }
        // Light gravel specks on the asphalt.
        let specks = (scene.gravel_density.max(0.0) * asphalt as f64).round() as u64;
        let mut placed = 0;
        let mut tries = 0;
        while placed < specks && tries < specks * 20 + 100 {
            tries += 1;
            let x = rng.random_range(0..w.max(1));
            let y = rng.random_range(0..h.max(1));
            let (across, along) = strip_frame(s, w, h, x, y);
            if x < w && y < h && on_asphalt(s, across, along) {
                let v = rng.random_range(175..=230u8);
                img.put_pixel(x, y, Rgb([v, v, v.saturating_sub(6)]));
                placed += 1;
            }
        }
    }
    if (scene.exposure - 1.0).abs() > f64::EPSILON {
        let e = scene.exposure.max(0.0);
        for p in img.pixels_mut() {
            for c in &mut p.0 {
                *c = clamp_u8(f64::from(*c) * e);
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_pixels() {
        let s = RunwayScene::grass(64, 48, 7).with_runway(RunwayStrip {
            angle_deg: 30.0,
            offset_px: 5.0,
            width_px: 20.0,
            length_px: None,
            along_px: 0.0,
            markings: true,
        });
        assert_eq!(render_runway(&s), render_runway(&s));
        let other = RunwayScene { seed: 8, ..s };
        assert_ne!(render_runway(&s), render_runway(&other));
    }

    #[test]
    fn asphalt_is_dark_and_grass_bright() {
        use crate::vision::color::gray;
        let s = RunwayScene::grass(100, 100, 1).with_runway(RunwayStrip {
            angle_deg: 0.0,
            offset_px: 25.0,
            width_px: 50.0,
            length_px: None,
            along_px: 0.0,
            markings: false,
        });
        let img = render_runway(&s);
        let mean = |x0: u32, x1: u32| {
            let mut sum = 0u64;
            for y in 0..100 {
                for x in x0..x1 {
                    let p = img.get_pixel(x, y).0;
                    sum += u64::from(gray(p[0], p[1], p[2]));
                }
            }
            sum as f64 / (100.0 * f64::from(x1 - x0))
        };
        // The strip is the right half (axis 25 px right of the centre, 50 px wide).
        assert!(mean(55, 100) < 100.0, "asphalt {}", mean(55, 100));
        assert!(mean(0, 45) > 150.0, "grass {}", mean(0, 45));
    }
}
