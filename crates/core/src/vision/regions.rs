//! The five regions of a downward picture the runway classifier counts in (centre, top,
//! bottom, left, right; image coordinates, top = the first rows), where they lie in a picture
//! of a given size (`RegionGrid`) and the pixel counts per region ([`RegionCounts`]). Shared
//! by the fast pipeline ([`super::fast`]), its reference ([`super::reference`]) and the
//! classifier ([`super::runway`]), so that neither implementation imports the classifier.

use serde::{Deserialize, Serialize};
use std::ops::Range;

/// One of the five regions of the image used by the model (image coordinates: top is the
/// first rows).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Region {
    /// Middle row band, middle column band.
    Center = 0,
    /// First row band, middle column band.
    Top = 1,
    /// Middle row band, first column band.
    Left = 2,
    /// Last row band, middle column band.
    Bottom = 3,
    /// Middle row band, last column band.
    Right = 4,
}

impl Region {
    /// The five regions in the order centre, top, left, bottom, right.
    pub const ALL: [Region; 5] = [
        Region::Center,
        Region::Top,
        Region::Left,
        Region::Bottom,
        Region::Right,
    ];

    /// (row band, column band) of the region, each 0, 1 or 2.
    pub(crate) const fn bands(self) -> (usize, usize) {
        match self {
            Region::Center => (1, 1),
            Region::Top => (0, 1),
            Region::Left => (1, 0),
            Region::Bottom => (2, 1),
            Region::Right => (1, 2),
        }
    }
}

/// The 3×3 split of a `width × height` image: row boundaries ⌊k·height/3⌋ and column
/// boundaries ⌊k·width/3⌋ for k = 0, 1, 2, 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RegionGrid {
    /// Row boundaries (pixels).
    pub rows: [u32; 4],
    /// Column boundaries (pixels).
    pub cols: [u32; 4],
}

impl RegionGrid {
    /// The split of a `width × height` image.
    pub(crate) fn new(width: u32, height: u32) -> RegionGrid {
        let cut = |n: u32, k: u64| (u64::from(n) * k / 3) as u32;
        RegionGrid {
            rows: [0, cut(height, 1), cut(height, 2), height],
            cols: [0, cut(width, 1), cut(width, 2), width],
        }
    }

    /// (rows, columns) of `region`, half-open pixel ranges.
    pub(crate) fn bounds(&self, region: Region) -> (Range<u32>, Range<u32>) {
        let (rb, cb) = region.bands();
        (
            self.rows[rb]..self.rows[rb + 1],
            self.cols[cb]..self.cols[cb + 1],
        )
    }
}

/// Black pixel counts of the five regions, indexed by `Region as usize`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RegionCounts {
    /// Black (0) pixels after the dilation, per region.
    pub black: [u64; 5],
    /// Pixels per region.
    pub pixels: [u64; 5],
}

impl RegionCounts {
    /// Fraction of black pixels per region (0 for an empty region).
    pub fn fractions(&self) -> RegionFractions {
        let f = |r: Region| {
            let i = r as usize;
            if self.pixels[i] == 0 {
                0.0
            } else {
                self.black[i] as f64 / self.pixels[i] as f64
            }
        };
        RegionFractions {
            center: f(Region::Center),
            top: f(Region::Top),
            left: f(Region::Left),
            bottom: f(Region::Bottom),
            right: f(Region::Right),
        }
    }
}

/// Fractions (0..=1) of black pixels in the five regions, in image coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionFractions {
    /// Centre region.
    pub center: f64,
    /// Top region (towards the vehicle's nose).
    pub top: f64,
    /// Left region.
    pub left: f64,
    /// Bottom region.
    pub bottom: f64,
    /// Right region.
    pub right: f64,
}

impl RegionFractions {
    /// The fraction of `region`.
    pub fn get(&self, region: Region) -> f64 {
        match region {
            Region::Center => self.center,
            Region::Top => self.top,
            Region::Left => self.left,
            Region::Bottom => self.bottom,
            Region::Right => self.right,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn region_bounds_follow_the_floor_formula() {
        let g = RegionGrid::new(10, 7);
        assert_eq!(g.cols, [0, 3, 6, 10]);
        assert_eq!(g.rows, [0, 2, 4, 7]);
        assert_eq!(g.bounds(Region::Top), (0..2, 3..6));
        assert_eq!(g.bounds(Region::Right), (2..4, 6..10));
        let g = RegionGrid::new(1920, 1080);
        assert_eq!(g.cols, [0, 640, 1280, 1920]);
        assert_eq!(g.rows, [0, 360, 720, 1080]);
    }
}
