//! The plain, obviously-correct runway pipeline: one full image per step, one pixel at a
//! time. It exists to check the fast path ([`super::fast`]) and is used by the property
//! tests and the debug output; it is several times slower.
//!
//! Each function is the direct transcription of the OpenCV call it stands for.

use super::color;
use super::regions::{Region, RegionCounts, RegionGrid};
use image::{GrayImage, Luma, RgbImage};

/// `cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)`.
pub fn gray(img: &RgbImage) -> GrayImage {
    color::to_gray(img)
}

/// `cv2.threshold(gray, t, 255, cv2.THRESH_BINARY)[1]`: 255 where the value is strictly
/// greater than `t`, 0 elsewhere.
pub fn threshold(gray: &GrayImage, t: u8) -> GrayImage {
    GrayImage::from_fn(gray.width(), gray.height(), |x, y| {
        Luma([if gray.get_pixel(x, y).0[0] > t {
            255
        } else {
            0
        }])
    })
}

/// One `cv2.dilate(img, np.ones((3, 3), np.uint8))`: the maximum over the 3×3
/// neighbourhood, pixels outside the image ignored (OpenCV's default border for
/// dilation, `BORDER_CONSTANT` with `morphologyDefaultBorderValue()`, never wins).
pub(crate) fn dilate3x3(img: &GrayImage) -> GrayImage {
    let (w, h) = img.dimensions();
    GrayImage::from_fn(w, h, |x, y| {
        let mut m = 0u8;
        for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                m = m.max(img.get_pixel(xx, yy).0[0]);
            }
        }
        Luma([m])
    })
}

/// `cv2.dilate(img, np.ones((3, 3), np.uint8), iterations=n)`.
pub(crate) fn dilate(img: &GrayImage, iterations: u32) -> GrayImage {
    let mut out = img.clone();
    for _ in 0..iterations {
        out = dilate3x3(&out);
    }
    out
}

/// Pixels equal to 0 ("black") per region, counted one by one.
pub(crate) fn count_regions(img: &GrayImage) -> RegionCounts {
    let grid = RegionGrid::new(img.width(), img.height());
    let mut counts = RegionCounts::default();
    for region in Region::ALL {
        let (rows, cols) = grid.bounds(region);
        for y in rows {
            for x in cols.clone() {
                counts.pixels[region as usize] += 1;
                if img.get_pixel(x, y).0[0] == 0 {
                    counts.black[region as usize] += 1;
                }
            }
        }
    }
    counts
}

/// The whole pipeline: grey → threshold → `iterations` 3×3 dilations → black counts.
pub(crate) fn region_counts(img: &RgbImage, t: u8, iterations: u32) -> RegionCounts {
    count_regions(&dilate(&threshold(&gray(img), t), iterations))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dilation_iterations_compose_into_a_square() {
        let mut img = GrayImage::new(20, 20);
        img.put_pixel(10, 0, Luma([255]));
        let d = dilate(&img, 3);
        for y in 0..20 {
            for x in 0..20 {
                let inside = (7..=13).contains(&x) && y <= 3;
                assert_eq!(d.get_pixel(x, y).0[0] == 255, inside, "({x}, {y})");
            }
        }
    }
}
