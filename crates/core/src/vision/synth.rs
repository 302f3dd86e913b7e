//! Deterministic synthetic camera images for tests, golden files and benchmarks, and the
//! texture they share.
//!
//! A **tile scene** is the bandit paper's hardware set-up (§V, Fig. 3): a green or grey floor
//! tile seen from above, possibly shifted so a neighbour shows at the edge. The runway scene
//! is the runway's own ([`crate::vision::runway::synth`]).
//!
//! Everything is a pure function of the parameters and the seed (ChaCha8 for the random
//! shapes, a stateless integer hash for the per-pixel texture), so the same call gives the
//! same pixels on every machine.

use image::{Rgb, RgbImage};
use serde::{Deserialize, Serialize};

/// A stateless 32-bit hash of (seed, x, y, salt) — the per-pixel texture.
fn hash(seed: u64, x: u32, y: u32, salt: u32) -> u32 {
    let mut z = seed
        ^ (u64::from(x) << 32 | u64::from(y)).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ u64::from(salt).wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as u32
}

/// A per-pixel offset in `-amplitude..=amplitude`, a pure function of its arguments.
pub(crate) fn jitter(seed: u64, x: u32, y: u32, salt: u32, amplitude: i32) -> i32 {
    if amplitude == 0 {
        return 0;
    }
    (hash(seed, x, y, salt) % (2 * amplitude as u32 + 1)) as i32 - amplitude
}

/// `v` rounded into a byte.
pub(crate) fn clamp_u8(v: f64) -> u8 {
    v.round().clamp(0.0, 255.0) as u8
}

/// A floor tile of the bandit paper's hardware experiment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TileScene {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Seed of the texture.
    pub seed: u64,
    /// Green (interesting) or grey tile under the camera.
    pub green: bool,
    /// Horizontal shift of the tile's edge, as a fraction of the width: the columns beyond
    /// `(1 − shift)·width` show the neighbouring (grey) floor.
    pub shift: f64,
    /// Brightness factor.
    pub exposure: f64,
}

/// Render a tile scene: a green or grey tile with noise and a light vignette.
pub fn render_tile(scene: &TileScene) -> RgbImage {
    let (w, h, seed) = (scene.width, scene.height, scene.seed);
    let edge = (1.0 - scene.shift.clamp(0.0, 1.0)) * f64::from(w);
    RgbImage::from_fn(w, h, |x, y| {
        let (dx, dy) = (
            f64::from(x) / f64::from(w.max(1)) - 0.5,
            f64::from(y) / f64::from(h.max(1)) - 0.5,
        );
        let vignette = 1.0 - 0.5 * (dx * dx + dy * dy);
        let t = f64::from(jitter(seed, x, y, 9, 12));
        let base = if scene.green && f64::from(x) < edge {
            [48.0, 150.0, 64.0]
        } else {
            [132.0, 132.0, 128.0]
        };
        let e = scene.exposure.max(0.0) * vignette;
        Rgb(base.map(|c| clamp_u8((c + t) * e)))
    })
}
