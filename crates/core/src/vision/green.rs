//! The bandit paper's measurement (§V, "Hardware-based validation"): "Using OpenCV, the
//! computer counts the number of green pixels in each image to obtain noisy measurements of
//! whether the visited cell is interesting or not", B = 30 images per visited cell.
//!
//! A pixel is green when its HSV value (OpenCV's 8-bit convention: H in 0..180, S and V in
//! 0..=255, computed exactly as `cv2.cvtColor(…, COLOR_RGB2HSV)`, see [`super::color`]) lies
//! in the box `lower ..= upper` on all three channels — `cv2.inRange(hsv, lower, upper)`,
//! bounds inclusive, no hue wrap-around. The share of green pixels is compared with
//! `min_fraction`: at or above it the image is one positive Bernoulli realisation of ν_l
//! ("interesting"), below it a negative one. The paper gives neither the HSV range nor the
//! fraction; the defaults are a generic green and one quarter of the image.

use super::VisionError;
use super::color;
use image::{GrayImage, Luma, RgbImage};
use serde::{Deserialize, Serialize};

/// Parameters of the green-pixel measurement.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GreenParams {
    /// Lower HSV bound, inclusive (H 0..180, S, V 0..=255). Default [35, 60, 40].
    pub lower: [u8; 3],
    /// Upper HSV bound, inclusive. Default [85, 255, 255].
    pub upper: [u8; 3],
    /// An image is a positive measurement when its green share (0..=1) is at least this.
    /// Default 0.25.
    pub min_fraction: f64,
}

impl Default for GreenParams {
    fn default() -> GreenParams {
        GreenParams {
            lower: [35, 60, 40],
            upper: [85, 255, 255],
            min_fraction: 0.25,
        }
    }
}

impl GreenParams {
    /// Check the parameters: `min_fraction` in [0, 1], hue bounds below 180 (OpenCV's 8-bit
    /// hue never reaches 180, an upper bound of 179 or more already means "any hue").
    pub fn validate(&self) -> Result<(), VisionError> {
        let f = self.min_fraction;
        if !(f.is_finite() && (0.0..=1.0).contains(&f)) {
            return Err(VisionError::InvalidParams(format!(
                "green min fraction must be in [0, 1], got {f}"
            )));
        }
        if self.lower[0] > 180 || self.upper[0] > 180 {
            return Err(VisionError::InvalidParams(format!(
                "hue bounds are in 0..=180 (OpenCV 8-bit HSV), got {} and {}",
                self.lower[0], self.upper[0]
            )));
        }
        Ok(())
    }
}

/// Number of green pixels of `img`.
pub(crate) fn green_count(img: &RgbImage, params: &GreenParams) -> u64 {
    color::count_hsv_in_range(img, params.lower, params.upper)
}

/// Share (0..=1) of green pixels of `img`; 0 for an image without pixels.
pub fn green_fraction(img: &RgbImage, params: &GreenParams) -> f64 {
    let n = u64::from(img.width()) * u64::from(img.height());
    if n == 0 {
        return 0.0;
    }
    green_count(img, params) as f64 / n as f64
}

/// One Bernoulli measurement: `true` when the green share is at least `min_fraction`.
pub fn measure(img: &RgbImage, params: &GreenParams) -> bool {
    img.width() > 0 && img.height() > 0 && green_fraction(img, params) >= params.min_fraction
}

#[cfg(test)]
/// The B measurements of one visit (one per image), computed in parallel.
pub(crate) fn measure_visit(images: &[RgbImage], params: &GreenParams) -> Vec<bool> {
    use rayon::prelude::*;
    images.par_iter().map(|img| measure(img, params)).collect()
}

/// The `cv2.inRange` mask: 255 for green pixels, 0 elsewhere (debugging, comparison).
pub fn green_mask(img: &RgbImage, params: &GreenParams) -> GrayImage {
    GrayImage::from_fn(img.width(), img.height(), |x, y| {
        let p = img.get_pixel(x, y).0;
        Luma([
            if color::hsv_in_range(p[0], p[1], p[2], params.lower, params.upper) {
                255
            } else {
                0
            },
        ])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn green_tile_is_positive_grey_tile_negative() {
        let p = GreenParams::default();
        let tile = RgbImage::from_fn(30, 20, |x, _| {
            if x < 12 {
                image::Rgb([40, 160, 50])
            } else {
                image::Rgb([128, 128, 128])
            }
        });
        assert!((green_fraction(&tile, &p) - 0.4).abs() < 1e-12);
        assert!(measure(&tile, &p));
        let grey = RgbImage::from_pixel(10, 10, image::Rgb([128, 128, 128]));
        assert_eq!(green_fraction(&grey, &p), 0.0);
        assert!(!measure(&grey, &p));
        assert_eq!(
            measure_visit(&[tile.clone(), grey, tile], &p),
            [true, false, true]
        );
        assert_eq!(green_fraction(&RgbImage::new(0, 0), &p), 0.0);
        let mask = green_mask(&RgbImage::from_pixel(2, 2, image::Rgb([0, 255, 0])), &p);
        assert!(mask.pixels().all(|q| q.0[0] == 255));
    }

    #[test]
    fn validation() {
        let bad = GreenParams {
            min_fraction: 1.5,
            ..GreenParams::default()
        };
        assert!(bad.validate().is_err());
        assert!(GreenParams::default().validate().is_ok());
    }
}
