//! OpenCV-exact colour conversions for 8-bit images: RGB → grey and RGB → HSV.
//!
//! Both follow OpenCV's integer code paths bit for bit, so that a classification computed
//! here equals `cv2.cvtColor` + `cv2.threshold` / `cv2.inRange` on the same pixels:
//!
//! * **Grey** (`COLOR_RGB2GRAY` / `COLOR_BGR2GRAY` on `CV_8U`): `RGB2Gray<uchar>` in
//!   opencv/opencv `modules/imgproc/src/color_rgb.simd.hpp` computes
//!   `CV_DESCALE(b·BY15 + g·GY15 + r·RY15, gray_shift)` with the fixed-point BT.601 weights
//!   `RY15 = 9798`, `GY15 = 19235`, `BY15 = 3735` (`round(0.299·2¹⁵)` …, they sum to 2¹⁵)
//!   and `gray_shift = 15` (constants in `modules/imgproc/src/color.hpp`);
//!   `CV_DESCALE(x, n) = (x + 2ⁿ⁻¹) >> n`, i.e. round half up. This is *not* the `image`
//!   crate's luma (which uses Rec. 709 weights in floating point).
//! * **HSV** (`COLOR_RGB2HSV` on `CV_8U`, hue range 180): `RGB2HSV_b` in
//!   `modules/imgproc/src/color_hsv.simd.hpp`, with its two division tables
//!   `sdiv_table[i] = round((255 << 12) / i)` and `hdiv_table180[i] = round((180 << 12) / (6·i))`
//!   and `hsv_shift = 12`. H is in 0..180 (two degrees per step), S and V in 0..=255.
//!
//! Both were checked against `cv2` 5.0 on all 2²⁴ colours (see `tests/py/test_vision_opencv.py`).

use image::{GrayImage, RgbImage};
use std::sync::LazyLock;

/// OpenCV's `RY15`: weight of red in the 15-bit fixed-point grey conversion.
pub(crate) const GRAY_R: u32 = 9798;
/// OpenCV's `GY15`: weight of green in the 15-bit fixed-point grey conversion.
pub(crate) const GRAY_G: u32 = 19235;
/// OpenCV's `BY15`: weight of blue in the 15-bit fixed-point grey conversion.
pub(crate) const GRAY_B: u32 = 3735;
/// OpenCV's `gray_shift`: the fixed-point scale is 2^15.
pub(crate) const GRAY_SHIFT: u32 = 15;

/// The weighted sum `r·RY15 + g·GY15 + b·BY15` before rounding (0..=255·2¹⁵).
#[inline(always)]
pub(crate) fn gray_sum(r: u8, g: u8, b: u8) -> u32 {
    u32::from(r) * GRAY_R + u32::from(g) * GRAY_G + u32::from(b) * GRAY_B
}

/// The grey level OpenCV's `cvtColor(…, COLOR_RGB2GRAY)` gives one 8-bit pixel.
#[inline(always)]
pub fn gray(r: u8, g: u8, b: u8) -> u8 {
    // The sum is at most 255·2¹⁵ + 2¹⁴, so the shifted value is at most 255.
    ((gray_sum(r, g, b) + (1 << (GRAY_SHIFT - 1))) >> GRAY_SHIFT) as u8
}

/// The smallest weighted sum ([`gray_sum`]) whose grey level is strictly above `threshold`,
/// i.e. `gray(r, g, b) > threshold ⇔ gray_sum(r, g, b) >= gray_sum_above(threshold)`.
/// For `threshold = 255` the bound is above every possible sum (nothing is above 255).
pub(crate) fn gray_sum_above(threshold: u8) -> u32 {
    // (s + 2¹⁴) >> 15 > t  ⇔  s + 2¹⁴ >= (t + 1)·2¹⁵.
    ((u32::from(threshold) + 1) << GRAY_SHIFT) - (1 << (GRAY_SHIFT - 1))
}

/// The whole image converted to grey exactly as OpenCV does (see the module docs).
pub(crate) fn to_gray(img: &RgbImage) -> GrayImage {
    let (w, h) = img.dimensions();
    let data: Vec<u8> = img
        .as_raw()
        .chunks_exact(3)
        .map(|p| gray(p[0], p[1], p[2]))
        .collect();
    // The length is w·h by construction.
    GrayImage::from_raw(w, h, data).unwrap_or_else(|| GrayImage::new(w, h))
}

const HSV_SHIFT: u32 = 12;

struct HsvTables {
    sdiv: [i32; 256],
    hdiv180: [i32; 256],
}

/// OpenCV's `RGB2HSV_b::TablesSingleton` (`saturate_cast<int>` of a double rounds to
/// nearest; none of these quotients is a tie).
static HSV_TABLES: LazyLock<HsvTables> = LazyLock::new(|| {
    let mut sdiv = [0i32; 256];
    let mut hdiv180 = [0i32; 256];
    for i in 1..256usize {
        sdiv[i] = (f64::from(255u32 << HSV_SHIFT) / i as f64).round_ties_even() as i32;
        hdiv180[i] = (f64::from(180u32 << HSV_SHIFT) / (6.0 * i as f64)).round_ties_even() as i32;
    }
    HsvTables { sdiv, hdiv180 }
});

#[cfg(test)]
/// The (H, S, V) triple OpenCV's `cvtColor(…, COLOR_RGB2HSV)` gives one 8-bit pixel:
/// H in 0..180, S and V in 0..=255.
#[inline]
pub(crate) fn hsv(r: u8, g: u8, b: u8) -> [u8; 3] {
    hsv_with(&HSV_TABLES, r, g, b)
}

#[inline(always)]
fn hsv_with(t: &HsvTables, r: u8, g: u8, b: u8) -> [u8; 3] {
    let (r, g, b) = (i32::from(r), i32::from(g), i32::from(b));
    let v = r.max(g).max(b);
    let vmin = r.min(g).min(b);
    let diff = v - vmin;
    let half = 1 << (HSV_SHIFT - 1);
    let s = (diff * t.sdiv[v as usize] + half) >> HSV_SHIFT;
    // The branch order of OpenCV's masks: red first, then green, then blue.
    let h0 = if v == r {
        g - b
    } else if v == g {
        b - r + 2 * diff
    } else {
        r - g + 4 * diff
    };
    let mut h = (h0 * t.hdiv180[diff as usize] + half) >> HSV_SHIFT;
    if h < 0 {
        h += 180;
    }
    [h.clamp(0, 255) as u8, s as u8, v as u8]
}

/// Membership of one pixel in an HSV box, as `cv2.inRange(hsv, lower, upper)`:
/// `lower[c] <= hsv[c] <= upper[c]` for all three channels (inclusive, no hue wrap-around).
#[inline]
pub(crate) fn hsv_in_range(r: u8, g: u8, b: u8, lower: [u8; 3], upper: [u8; 3]) -> bool {
    let p = hsv_with(&HSV_TABLES, r, g, b);
    (0..3).all(|c| lower[c] <= p[c] && p[c] <= upper[c])
}

/// Count of pixels of `img` inside the HSV box (see [`hsv_in_range`]).
pub(crate) fn count_hsv_in_range(img: &RgbImage, lower: [u8; 3], upper: [u8; 3]) -> u64 {
    let t: &HsvTables = &HSV_TABLES;
    img.as_raw()
        .chunks_exact(3)
        .filter(|p| {
            let q = hsv_with(t, p[0], p[1], p[2]);
            lower[0] <= q[0]
                && q[0] <= upper[0]
                && lower[1] <= q[1]
                && q[1] <= upper[1]
                && lower[2] <= q[2]
                && q[2] <= upper[2]
        })
        .count() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_weights_sum_to_one_and_round_half_up() {
        assert_eq!(GRAY_R + GRAY_G + GRAY_B, 1 << GRAY_SHIFT);
        for v in 0..=255u8 {
            assert_eq!(gray(v, v, v), v);
        }
        // Spot values computed by hand from the formula.
        assert_eq!(gray(255, 0, 0), 76); // (255·9798 + 16384) >> 15 = 76.74… → 76
        assert_eq!(gray(0, 255, 0), 150);
        assert_eq!(gray(0, 0, 255), 29);
        assert_eq!(gray(0, 1, 0), 1); // 19235 + 16384 >= 32768
        assert_eq!(gray(1, 0, 0), 0);
    }

    #[test]
    fn threshold_bound_is_exact() {
        for t in [0u8, 1, 100, 149, 150, 151, 254, 255] {
            let k = gray_sum_above(t);
            for r in (0..=255u8).step_by(5) {
                for g in (0..=255u8).step_by(3) {
                    for b in (0..=255u8).step_by(7) {
                        assert_eq!(gray(r, g, b) > t, gray_sum(r, g, b) >= k);
                    }
                }
            }
        }
    }

    #[test]
    fn hsv_primary_colours() {
        assert_eq!(hsv(255, 0, 0), [0, 255, 255]);
        assert_eq!(hsv(0, 255, 0), [60, 255, 255]);
        assert_eq!(hsv(0, 0, 255), [120, 255, 255]);
        assert_eq!(hsv(0, 0, 0), [0, 0, 0]);
        assert_eq!(hsv(200, 200, 200), [0, 0, 200]);
        // Values printed by cv2 5.0 for single pixels.
        assert_eq!(hsv(255, 0, 1), [0, 255, 255]);
        assert_eq!(hsv(10, 20, 30), [105, 170, 30]);
        assert_eq!(hsv(100, 200, 50), [50, 191, 200]);
        assert_eq!(hsv(255, 0, 200), [156, 255, 255]);
        assert_eq!(gray(10, 20, 30), 18);
        assert_eq!(gray(100, 200, 50), 153);
        assert_eq!(gray(255, 0, 200), 99);
    }
}
