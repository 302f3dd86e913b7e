//! The aerial image a downward-looking camera sees: the world's ground truth rendered at a
//! camera pose, with the disturbances of a real camera.
//!
//! Geometry: a nadir pinhole camera ([`CameraModel`]) fixed to the airframe, like the runway
//! paper's GoPro (§7). The image's up direction is the vehicle's heading, so the heading
//! rotates the footprint; the airframe's roll and pitch (the tilt a copter needs to hold
//! against wind or to accelerate) move the optical axis, which shifts the footprint by
//! `altitude · tan(tilt)` (the small perspective stretch of a tilted view is neglected —
//! a 3° tilt changes the scale across a 12 m footprint by under 1 %).
//!
//! Appearance: every surface has a world-fixed procedural texture (the same patch of ground
//! looks the same in consecutive images), then per image: a global exposure change and a
//! slowly varying cloud-shadow field, vignetting, a slight defocus/motion blur, and sensor
//! noise; all seeded. Grass is a mix of sunlit blades (grey level ≈ 160–230) and darker
//! gaps (≈ 60–130); runway asphalt stays below ≈ 135 under every exposure the renderer
//! draws, so the runway paper's classifier (grey, threshold 150, 7 dilations, §7 and Fig. 9)
//! sees the asphalt black and the grass — after dilation closes its gaps — white. The
//! runway's dashed white centreline is a realistic false "white" inside the runway.
//!
//! A degraded sensor (`Disturbances::swap_tiles`): the image draws the bandit field's green
//! tiles with the grey tiles' texture and the grey tiles with the green ones', so the GCS's
//! green-share measurement of that image says the other class.

use crate::pose::CameraPose;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::world::{Surface, World};
use image::RgbImage;
use rand::RngExt;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The per-image disturbances, drawn from a seed by [`Disturbances::draw`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Disturbances {
    /// Global exposure gain (1 = nominal).
    pub exposure: f64,
    /// Strength of the cloud-shadow field (0 = none, 0.15 = shadows 15 % darker).
    pub(crate) cloud_shadow: f64,
    /// Vignetting: brightness falls by this fraction at the image corners.
    pub(crate) vignetting: f64,
    /// Gaussian blur sigma in pixels (defocus and motion).
    pub(crate) blur_px: f32,
    /// Sensor noise standard deviation, grey levels.
    pub(crate) noise_sigma: f64,
    /// Seed of the noise and cloud field of this image.
    pub seed: u64,
    /// Render every green tile as a grey tile and every grey tile as a green one: the image
    /// shows the other class of the bandit field's tiles (a misclassifying sensor,
    /// [`crate::camera::CameraConfig::misclassify_probability`]). Never drawn by
    /// [`Disturbances::draw`]; the camera sets it.
    #[serde(default)]
    pub(crate) swap_tiles: bool,
}

impl Disturbances {
    /// No disturbance at all (for geometry tests).
    pub fn none() -> Disturbances {
        Disturbances {
            exposure: 1.0,
            cloud_shadow: 0.0,
            vignetting: 0.0,
            blur_px: 0.0,
            noise_sigma: 0.0,
            seed: 0,
            swap_tiles: false,
        }
    }

    /// Draw realistic disturbances for one image from `seed`: exposure within ±12 %, cloud
    /// shadows up to 10 %, 6 % vignetting, blur 0.5–1.1 px, noise σ 2–4 grey levels.
    pub fn draw(seed: u64) -> Disturbances {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_D157_u64);
        Disturbances {
            exposure: 1.0 + rng.random_range(-0.12..0.12),
            cloud_shadow: rng.random_range(0.0..0.10),
            vignetting: 0.06,
            blur_px: rng.random_range(0.5..1.1),
            noise_sigma: rng.random_range(2.0..4.0),
            seed,
            swap_tiles: false,
        }
    }
}

/// Where the image centre falls on the ground, local metres (east, north) around the
/// world's reference, given the pose.
pub fn footprint_center(world: &World, pose: &CameraPose) -> (f64, f64) {
    let (e0, n0) = world.to_local(pose.lat, pose.lon);
    let h = pose.heading_deg.to_radians();
    let (fwd_e, fwd_n) = (h.sin(), h.cos());
    let (right_e, right_n) = (h.cos(), -h.sin());
    // Camera axis = body down axis: nose-up pitch looks forward, right-down roll looks left.
    let a = pose.alt_agl_m.max(0.0);
    let fwd = a * pose.pitch_deg.to_radians().tan();
    let right = -a * pose.roll_deg.to_radians().tan();
    (
        e0 + fwd * fwd_e + right * right_e,
        n0 + fwd * fwd_n + right * right_n,
    )
}

#[cfg(test)]
/// The ground point (local east, north metres) seen by pixel (`u`, `v`) (centre of the
/// pixel; `u` right, `v` down).
pub(crate) fn pixel_ground(
    world: &World,
    pose: &CameraPose,
    camera: &CameraModel,
    u: f64,
    v: f64,
) -> (f64, f64) {
    let (ce, cn) = footprint_center(world, pose);
    let gsd = camera.ground_sample_distance(pose.alt_agl_m.max(0.01));
    let x = (u + 0.5 - f64::from(camera.width_px) / 2.0) * gsd;
    let y = (f64::from(camera.height_px) / 2.0 - v - 0.5) * gsd;
    let h = pose.heading_deg.to_radians();
    (
        ce + x * h.cos() + y * h.sin(),
        cn - x * h.sin() + y * h.cos(),
    )
}

#[inline]
fn hash_u64(ix: i64, iy: i64, salt: u64) -> u64 {
    let mut z = (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ salt.wrapping_mul(0x1656_67B1_9E37_79F9);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[inline]
fn hash2(ix: i64, iy: i64, salt: u64) -> f64 {
    (hash_u64(ix, iy, salt) >> 11) as f64 / (1u64 << 53) as f64
}

/// Smooth value noise in [0, 1) at (x, y) in units of the noise cell.
#[inline]
fn value_noise(x: f64, y: f64, salt: u64) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let (tx, ty) = (x - fx, y - fy);
    let sx = tx * tx * (3.0 - 2.0 * tx);
    let sy = ty * ty * (3.0 - 2.0 * ty);
    let a = hash2(ix, iy, salt);
    let b = hash2(ix + 1, iy, salt);
    let c = hash2(ix, iy + 1, salt);
    let d = hash2(ix + 1, iy + 1, salt);
    let ab = a + (b - a) * sx;
    let cd = c + (d - c) * sx;
    ab + (cd - ab) * sy
}

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

fn scale(c: [f64; 3], k: f64) -> [f64; 3] {
    [c[0] * k, c[1] * k, c[2] * k]
}

/// The texture colour (linear 0–255 RGB before exposure) of `surface` at world-fixed local
/// point (e, n) metres. `rel` is the point's position inside its region's bounding box
/// (0..1, 0..1) for surfaces drawn relative to their cell.
#[allow(clippy::too_many_arguments)]
fn texture(
    surface: Surface,
    e: f64,
    n: f64,
    world_salt: u64,
    rel: (f64, f64),
    marking: bool,
    gsd: f64,
) -> [f64; 3] {
    match surface {
        Surface::Grass => {
            // Grass has contrast at every scale: sunlit blades (≈2 cm), clumps (≈5 cm), tufts
            // (≈12 cm) and patches (≈30 cm). An octave much finer than a pixel averages out
            // inside the pixel, so octaves are faded by the ground sample distance and the
            // remaining ones rescaled: whatever the altitude, the image shows bright tufts
            // between darker gaps, as a real camera does.
            const OCT: [(f64, f64, u64); 3] = [(0.02, 1.0, 1), (0.05, 1.0, 2), (0.12, 0.6, 3)];
            let mut acc = 0.0;
            let mut norm = 0.0;
            for (cell, wgt, k) in OCT {
                let fade = (cell / gsd - 0.7).clamp(0.0, 1.0);
                if fade <= 0.0 {
                    continue;
                }
                let f = 1.0 / cell;
                let nz = value_noise(e * f + n * f * 0.25, n * f * 1.4, world_salt ^ k);
                acc += wgt * fade * (nz - 0.5);
                norm += (wgt * fade) * (wgt * fade);
            }
            // Coarser structure (patches ≈30 cm–1 m, tone over metres, 1.5 m mowing stripes)
            // changes the brightness of blades and gaps alike.
            let patch = 0.6 * value_noise(e / 0.3, n / 0.3, world_salt ^ 16)
                + 0.4 * value_noise(e, n, world_salt ^ 3);
            let tone = value_noise(e * 0.25, n * 0.25, world_salt ^ 4);
            let stripe = if ((e * 0.6 + n * 0.8) / 1.5).rem_euclid(2.0) < 1.0 {
                1.03
            } else {
                0.97
            };
            let b = 0.5 + 0.17 * acc / norm.sqrt().max(1e-9);
            let lit = ((b - 0.41) / 0.14).clamp(0.0, 1.0);
            let dark = [40.0, 70.0, 28.0];
            let mid = [88.0, 132.0, 55.0];
            let bright = [208.0, 244.0, 160.0];
            let c = if lit < 0.5 {
                mix(dark, mid, lit * 2.0)
            } else {
                mix(mid, bright, (lit - 0.5) * 2.0)
            };
            scale(c, (0.9 + 0.14 * patch) * (0.96 + 0.08 * tone) * stripe)
        }
        Surface::Asphalt => {
            if marking {
                let w = 0.85 + 0.1 * value_noise(e * 20.0, n * 20.0, world_salt ^ 5);
                return scale([232.0, 232.0, 226.0], w);
            }
            let grain = value_noise(e * 60.0, n * 60.0, world_salt ^ 6);
            let stone = hash2(
                (e * 40.0).floor() as i64,
                (n * 40.0).floor() as i64,
                world_salt ^ 7,
            );
            let wear = value_noise(e * 0.4, n * 0.4, world_salt ^ 8);
            let mut g = 78.0 + 22.0 * grain + 12.0 * wear;
            if stone > 0.97 {
                g += 18.0; // light aggregate
            } else if stone < 0.02 {
                g -= 20.0; // tar spots
            }
            [g * 0.98, g, g * 1.03]
        }
        Surface::GreenTile => {
            let v = value_noise(e * 8.0, n * 8.0, world_salt ^ 9);
            scale([40.0, 165.0, 70.0], 0.9 + 0.15 * v)
        }
        Surface::GreyTile => {
            let v = value_noise(e * 8.0, n * 8.0, world_salt ^ 10);
            let g = 125.0 + 18.0 * v;
            [g, g, g * 1.02]
        }
        Surface::Obstacle => {
            // a coloured triangular prism seen from above, on the floor
            let (x, y) = rel;
            let inside = y > 0.15 && y < 0.85 && (x - 0.5).abs() < (0.85 - y) * 0.5 + 1e-9;
            if inside {
                let shade = if x < 0.5 { 1.0 } else { 0.78 }; // two lit faces
                scale([225.0, 105.0, 35.0], shade)
            } else {
                texture(Surface::Floor, e, n, world_salt, rel, false, gsd)
            }
        }
        Surface::Road => {
            // small white triangles along the road cell's edges
            let (x, y) = rel;
            let edge = x.min(1.0 - x).min(y.min(1.0 - y));
            let along = if x.min(1.0 - x) < y.min(1.0 - y) {
                y
            } else {
                x
            };
            let phase = (along * 10.0).fract();
            if edge < 0.05 && edge < 0.05 * (1.0 - (2.0 * phase - 1.0).abs()) {
                [225.0, 225.0, 220.0]
            } else {
                let v = value_noise(e * 30.0, n * 30.0, world_salt ^ 11);
                let g = 62.0 + 14.0 * v;
                [g, g, g * 1.05]
            }
        }
        Surface::Floor => {
            let v = value_noise(e * 4.0, n * 4.0, world_salt ^ 12);
            let f = value_noise(e * 50.0, n * 50.0, world_salt ^ 13);
            let g = 150.0 + 12.0 * v + 8.0 * f;
            [g, g * 0.95, g * 0.88]
        }
        Surface::Water => {
            let ripple = value_noise(e * 6.0 + n * 2.0, n * 1.5, world_salt ^ 14);
            let glint = if ripple > 0.93 { 60.0 } else { 0.0 };
            [70.0 + glint, 105.0 + glint, 125.0 + glint]
        }
        Surface::Plume => {
            let v = value_noise(e * 2.0, n * 2.0, world_salt ^ 15);
            scale([58.0, 50.0, 36.0], 0.85 + 0.3 * v)
        }
    }
}

/// Whether local point (e, n) lies on the runway's dashed centreline: 0.45 m wide, 6 m dashes
/// every 10 m along the axis.
fn on_centreline(world: &World, region_idx: usize, e: f64, n: f64, t_s: f64) -> bool {
    let r = &world.regions[region_idx];
    let Some(h) = r.axis_heading_deg else {
        return false;
    };
    let (cx, cy) = {
        let b = r.bbox();
        ((b.0 + b.2) / 2.0, (b.1 + b.3) / 2.0)
    };
    let (de, dn) = (
        e - r.velocity_ne.1 * t_s - cx,
        n - r.velocity_ne.0 * t_s - cy,
    );
    let hr = h.to_radians();
    let along = de * hr.sin() + dn * hr.cos();
    let across = de * hr.cos() - dn * hr.sin();
    across.abs() < 0.225 && (along + 1000.0).rem_euclid(10.0) < 6.0
}

/// Render the image seen at `pose` at world time `t_s` seconds.
pub fn render(
    world: &World,
    pose: &CameraPose,
    camera: &CameraModel,
    t_s: f64,
    dist: &Disturbances,
) -> RgbImage {
    let (w, h) = (camera.width_px, camera.height_px);
    let world_salt = world.name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |a, b| {
        (a ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    });
    let (ce, cn) = footprint_center(world, pose);
    let gsd = camera.ground_sample_distance(pose.alt_agl_m.max(0.01));
    let hr = pose.heading_deg.to_radians();
    let (re, rn) = (hr.cos() * gsd, -hr.sin() * gsd); // one pixel right
    let (de, dn) = (-hr.sin() * gsd, -hr.cos() * gsd); // one pixel down
    let x0 = 0.5 - f64::from(w) / 2.0;
    let y0 = 0.5 - f64::from(h) / 2.0;
    let cloud_t = t_s * 0.05; // clouds drift slowly
    let cx = f64::from(w) / 2.0;
    let cy = f64::from(h) / 2.0;
    let rmax2 = cx * cx + cy * cy;
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    // rows are independent: render them in parallel (the result does not depend on the
    // number of threads)
    use rayon::prelude::*;
    buf.par_chunks_mut(w as usize * 3)
        .enumerate()
        .for_each(|(v, row)| {
            let v = v as u32;
            let fv = f64::from(v) + y0;
            for u in 0..w {
                let fu = f64::from(u) + x0;
                let e = ce + fu * re + fv * de;
                let n = cn + fu * rn + fv * dn;
                let mut surface = world.background;
                let mut rel = (0.5, 0.5);
                let mut marking = false;
                for (i, r) in world.regions.iter().enumerate().rev() {
                    if r.contains_local(e, n, t_s) {
                        surface = r.surface;
                        let b = r.bbox();
                        let (le, ln) = (e - r.velocity_ne.1 * t_s, n - r.velocity_ne.0 * t_s);
                        rel = (
                            (le - b.0) / (b.2 - b.0).max(1e-9),
                            (ln - b.1) / (b.3 - b.1).max(1e-9),
                        );
                        marking = r.markings
                            && r.surface == Surface::Asphalt
                            && on_centreline(world, i, e, n, t_s);
                        break;
                    }
                }
                if dist.swap_tiles {
                    surface = match surface {
                        Surface::GreenTile => Surface::GreyTile,
                        Surface::GreyTile => Surface::GreenTile,
                        s => s,
                    };
                }
                let mut c = texture(surface, e, n, world_salt, rel, marking, gsd);
                let mut k = dist.exposure;
                if dist.cloud_shadow > 0.0 {
                    let cl = value_noise(e * 0.05 + cloud_t, n * 0.05, dist.seed ^ 77);
                    k *= 1.0 - dist.cloud_shadow * (cl - 0.3).max(0.0) / 0.7;
                }
                if dist.vignetting > 0.0 {
                    let (du, dv) = (f64::from(u) + 0.5 - cx, f64::from(v) + 0.5 - cy);
                    k *= 1.0 - dist.vignetting * (du * du + dv * dv) / rmax2;
                }
                c = scale(c, k);
                let o = u as usize * 3;
                row[o] = c[0].clamp(0.0, 255.0) as u8;
                row[o + 1] = c[1].clamp(0.0, 255.0) as u8;
                row[o + 2] = c[2].clamp(0.0, 255.0) as u8;
            }
        });
    let mut img = RgbImage::from_raw(w, h, buf).unwrap_or_else(|| RgbImage::new(w, h));
    if dist.blur_px > 0.05 {
        img = imageproc::filter::gaussian_blur_f32(&img, dist.blur_px);
    }
    if dist.noise_sigma > 0.0 {
        // Irwin–Hall sum of four uniform bytes per channel (≈ Gaussian), from a counter-based
        // hash of (seed, pixel): deterministic and cheap
        let k = dist.noise_sigma * 1.732 / 127.5;
        for (i, p) in img.pixels_mut().enumerate() {
            let a = hash_u64(i as i64, 0, dist.seed ^ 0x0015_E77E);
            let b = hash_u64(i as i64, 1, dist.seed ^ 0x0015_E77E);
            let words = [a as u32, (a >> 32) as u32, b as u32];
            for (ch, w) in p.0.iter_mut().zip(words) {
                let s = f64::from((w & 0xff) + ((w >> 8) & 0xff) + ((w >> 16) & 0xff) + (w >> 24))
                    - 510.0;
                let x = f64::from(*ch) + s * k;
                *ch = x.round().clamp(0.0, 255.0) as u8;
            }
        }
    }
    img
}

#[cfg(test)]
/// OpenCV's fixed-point BT.601 grey level of an RGB pixel (`cv2.cvtColor(RGB2GRAY)`), used
/// by the pixel-statistics tests.
pub(crate) fn gray_bt601(p: &image::Rgb<u8>) -> u8 {
    // OpenCV: (R*4899 + G*9617 + B*1868 + (1 << 13)) >> 14
    let [r, g, b] = p.0;
    ((u32::from(r) * 4899 + u32::from(g) * 9617 + u32::from(b) * 1868 + (1 << 13)) >> 14) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runway_world() -> World {
        World::from_toml(
            r#"
            name = "runway"
            background = "grass"
            [[region]]
            name = "runway"
            surface = "asphalt"
            rectangle = { center = [37.1968, -80.5781], length_m = 92.0, width_m = 21.0, heading_deg = 58.0 }
            markings = true
            "#,
        )
        .unwrap()
    }

    #[test]
    fn heading_rotates_the_footprint() {
        let w = runway_world();
        let cam = CameraModel::paper();
        let pose = CameraPose {
            lat: 37.1968,
            lon: -80.5781,
            alt_agl_m: 12.0,
            heading_deg: 90.0,
            roll_deg: 0.0,
            pitch_deg: 0.0,
        };
        let (ce, cn) = footprint_center(&w, &pose);
        // top-centre pixel is 6 m ahead = east when heading east
        let (e, n) = pixel_ground(&w, &pose, &cam, 239.5, -0.5);
        assert!(
            (e - ce - 6.0).abs() < 1e-6 && (n - cn).abs() < 1e-6,
            "{e} {n}"
        );
        // nose-up pitch looks forward
        let tilted = CameraPose {
            pitch_deg: 5.0,
            ..pose
        };
        let (te, _) = footprint_center(&w, &tilted);
        assert!((te - ce - 12.0 * 5f64.to_radians().tan()).abs() < 1e-9);
    }

    #[test]
    fn asphalt_is_dark_and_grass_has_bright_blades() {
        let w = runway_world();
        let cam = CameraModel::paper();
        for seed in 0..4u64 {
            let d = Disturbances::draw(seed);
            // over the runway, clear of the centreline: heading along the axis, 5 m to the side
            let (lat, lon) = fleetmap_core::geo::local::offset(
                37.1968,
                -80.5781,
                -5.0 * 58f64.to_radians().sin(),
                5.0 * 58f64.to_radians().cos(),
            );
            let pose = CameraPose {
                lat,
                lon,
                alt_agl_m: 6.0,
                heading_deg: 58.0,
                roll_deg: 0.0,
                pitch_deg: 0.0,
            };
            let img = render(&w, &pose, &cam, 0.0, &d);
            let grays: Vec<u8> = img.pixels().map(gray_bt601).collect();
            let bright = grays.iter().filter(|g| **g >= 150).count();
            assert!(bright < grays.len() / 100, "asphalt too bright: {bright}");
            // over grass far from the runway
            let (lat, lon) = fleetmap_core::geo::local::offset(37.1968, -80.5781, -60.0, -60.0);
            let img = render(&w, &CameraPose { lat, lon, ..pose }, &cam, 0.0, &d);
            let grays: Vec<u8> = img.pixels().map(gray_bt601).collect();
            let bright = grays.iter().filter(|g| **g >= 150).count() as f64 / grays.len() as f64;
            let dark = grays.iter().filter(|g| **g < 150).count() as f64 / grays.len() as f64;
            assert!(
                bright > 0.08 && dark > 0.3,
                "grass bright {bright} dark {dark}"
            );
        }
    }

    /// The runway paper's pipeline (grey, threshold 150, 7 dilations with a 3×3 square =
    /// one 15×15 max filter; OpenCV ignores the border for dilation): fraction of black
    /// pixels in the image.
    fn black_fraction_after_dilation(img: &RgbImage) -> f64 {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let white: Vec<bool> = img.pixels().map(|p| gray_bt601(p) > 150).collect();
        let mut rows = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (x.saturating_sub(7), (x + 7).min(w - 1));
                rows[y * w + x] = (a..=b).any(|i| white[y * w + i]);
            }
        }
        let mut black = 0usize;
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (y.saturating_sub(7), (y + 7).min(h - 1));
                if !(a..=b).any(|j| rows[j * w + x]) {
                    black += 1;
                }
            }
        }
        black as f64 / (w * h) as f64
    }

    #[test]
    fn classifier_sees_asphalt_black_and_grass_white() {
        let w = runway_world();
        let cam = CameraModel::paper();
        for seed in 0..6u64 {
            let d = Disturbances::draw(seed * 7 + 1);
            for alt in [8.0, 12.0, 16.0] {
                let side = 5.0;
                let (lat, lon) = fleetmap_core::geo::local::offset(
                    37.1968,
                    -80.5781,
                    -side * 58f64.to_radians().sin(),
                    side * 58f64.to_radians().cos(),
                );
                let pose = CameraPose {
                    lat,
                    lon,
                    alt_agl_m: alt,
                    heading_deg: 58.0,
                    roll_deg: 0.0,
                    pitch_deg: 0.0,
                };
                let img = render(&w, &pose, &cam, 0.0, &d);
                let f = black_fraction_after_dilation(&img);
                if seed == 0 && alt == 12.0 {
                    let _ = img.save("/tmp/sim_asphalt.png");
                }
                // 5 m off the centreline, a 12 m footprint reaches 1 m past it at 12 m
                assert!(f > 0.75, "asphalt seed {seed} alt {alt}: black {f}");
                let (lat, lon) = fleetmap_core::geo::local::offset(37.1968, -80.5781, -60.0, -60.0);
                let img = render(&w, &CameraPose { lat, lon, ..pose }, &cam, 0.0, &d);
                if seed == 0 && alt == 12.0 {
                    let _ = img.save("/tmp/sim_grass.png");
                }
                let f = black_fraction_after_dilation(&img);
                assert!(f < 0.01, "grass seed {seed} alt {alt}: black {f}");
            }
        }
    }
}
