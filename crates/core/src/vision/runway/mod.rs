//! The runway sensing model of the runway paper, §7 ("Field Experiment").
//!
//! > "Each image is first converted into grayscale and thresholded (at the intensity value
//! > of 150). Then, the thresholded image is dilated (7 times) so that the gaps in the grass
//! > region are filled in … Then the percentage of black pixels in the individual regions is
//! > calculated … Finally, we produce a binary classification result based on if this
//! > percentage is above or below a threshold."
//!
//! Precisely, for an 8-bit RGB image of `w × h` pixels:
//!
//! 1. grey = OpenCV's fixed-point BT.601 (`cv2.cvtColor(…, COLOR_RGB2GRAY)`, see
//!    [`super::color`]);
//! 2. binary = 255 where grey **>** `intensity_threshold` (150), else 0
//!    (`cv2.threshold(…, 150, 255, THRESH_BINARY)`);
//! 3. dilated = `dilation_iterations` (7) successive 3×3 dilations
//!    (`cv2.dilate(…, np.ones((3, 3)), iterations=7)`, default border: the outside never
//!    wins) — white grass gaps close, the dark asphalt stays black;
//! 4. the image is cut into 3×3 regions at rows ⌊k·h/3⌋ and columns ⌊k·w/3⌋, k = 0..3;
//!    the fraction of **black** (0) pixels of `dilated` is taken in the centre, top, left,
//!    bottom and right regions (the corners are not used);
//! 5. a region is labelled *runway* when its black fraction is **≥**
//!    `black_fraction_threshold` (the paper does not give its value; 0.5 by default);
//! 6. the labels go to the current cell (centre) and its four neighbours, after the
//!    vehicle's heading is applied (below).
//!
//! **Heading.** The camera looks straight down with the top of the image towards the
//! vehicle's nose and the right of the image towards its right side (starboard). The
//! heading ψ (degrees clockwise from north, any real value) is normalised to [0, 360) and
//! rounded to the nearest quarter turn `k = ⌊ψ/90 + ½⌋ mod 4` (ties go clockwise: 45° is
//! east, 315° is north); an image region then looks at the compass direction obtained by
//! turning it `k` quarter turns clockwise: with k = 0 top → north, right → east, bottom →
//! south, left → west; with k = 1 (heading ≈ east) top → east, right → south, bottom →
//! west, left → north; and so on. Headings that are not multiples of 90° are therefore
//! treated as the nearest one — the paper flies along the grid, and the 3×3 regions cannot
//! say more than which neighbour is closest to a region's centre anyway.
//!
//! The work is done by the fast bit-packed pipeline ([`crate::vision::fast`]);
//! [`analyse_reference`] runs the plain reference implementation
//! ([`crate::vision::reference`]) for tests and checks.
//!
//! The runway's other vision lives here too: the pictures classified on board and the grid
//! announced to the cameras ([`onboard`]), the 3-of-5 vote book ([`votes`]) and the
//! synthetic runway scene ([`synth`]).

pub mod onboard;
pub mod synth;
pub mod votes;

use crate::geo::Dir4;
use crate::vision::regions::{Region, RegionCounts, RegionFractions};
use crate::vision::{VisionError, fast, reference};
use image::RgbImage;
use serde::{Deserialize, Serialize};

/// Parameters of the runway sensing model (runway paper §7).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RunwayParams {
    /// Grey level threshold: pixels with grey **strictly above** it become white. Paper: 150.
    pub intensity_threshold: u8,
    /// Number of 3×3 dilations (equivalently the radius of one square dilation). Paper: 7.
    pub dilation_iterations: u32,
    /// A region is labelled runway when its fraction of black pixels (0..=1) is at least this.
    /// The paper does not give the value; 0.5 by default.
    pub black_fraction_threshold: f64,
}

impl Default for RunwayParams {
    fn default() -> RunwayParams {
        RunwayParams {
            intensity_threshold: 150,
            dilation_iterations: 7,
            black_fraction_threshold: 0.5,
        }
    }
}

/// Largest accepted number of dilations (a bigger square than any image changes nothing).
pub(crate) const MAX_DILATION_ITERATIONS: u32 = 1 << 20;

impl RunwayParams {
    /// Check the parameters: the fraction threshold must be a number in [0, 1].
    pub fn validate(&self) -> Result<(), VisionError> {
        let t = self.black_fraction_threshold;
        if !(t.is_finite() && (0.0..=1.0).contains(&t)) {
            return Err(VisionError::InvalidParams(format!(
                "black fraction threshold must be in [0, 1], got {t}"
            )));
        }
        if self.dilation_iterations > MAX_DILATION_ITERATIONS {
            return Err(VisionError::InvalidParams(format!(
                "dilation iterations must be at most {MAX_DILATION_ITERATIONS}, got {}",
                self.dilation_iterations
            )));
        }
        Ok(())
    }
}

/// Labels (true = region of interest, i.e. runway) of the current cell and its four grid
/// neighbours.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct NeighbourLabels {
    /// The cell under the vehicle (the centre region).
    pub center: bool,
    /// The northern neighbour (row + 1).
    pub north: bool,
    /// The western neighbour (column − 1).
    pub west: bool,
    /// The southern neighbour (row − 1).
    pub south: bool,
    /// The eastern neighbour (column + 1).
    pub east: bool,
}

impl NeighbourLabels {
    /// The label of the neighbour in direction `d`.
    pub fn get(&self, d: Dir4) -> bool {
        match d {
            Dir4::North => self.north,
            Dir4::West => self.west,
            Dir4::South => self.south,
            Dir4::East => self.east,
        }
    }

    fn set(&mut self, d: Dir4, v: bool) {
        match d {
            Dir4::North => self.north = v,
            Dir4::West => self.west = v,
            Dir4::South => self.south = v,
            Dir4::East => self.east = v,
        }
    }
}

/// Quarter turns clockwise (0..4) of the heading `heading_deg` (degrees clockwise from
/// north), rounded to the nearest quarter, ties clockwise; `None` when not finite.
pub(crate) fn quarter_turns(heading_deg: f64) -> Option<u8> {
    if !heading_deg.is_finite() {
        return None;
    }
    let h = heading_deg.rem_euclid(360.0);
    Some(((h / 90.0 + 0.5).floor() as i64).rem_euclid(4) as u8)
}

/// The compass direction seen by image `region` (not the centre) when the vehicle's heading
/// is `turns` quarter turns clockwise from north.
pub(crate) fn region_direction(region: Region, turns: u8) -> Option<Dir4> {
    // Clockwise order from the top of the image / from north.
    let image_index = match region {
        Region::Center => return None,
        Region::Top => 0,
        Region::Right => 1,
        Region::Bottom => 2,
        Region::Left => 3,
    };
    const COMPASS: [Dir4; 4] = [Dir4::North, Dir4::East, Dir4::South, Dir4::West];
    Some(COMPASS[(image_index + usize::from(turns)) % 4])
}

/// Labels for the grid from the black fractions, the heading and the threshold.
pub fn labels(
    fractions: &RegionFractions,
    heading_deg: f64,
    black_fraction_threshold: f64,
) -> Result<NeighbourLabels, VisionError> {
    let turns = quarter_turns(heading_deg).ok_or(VisionError::InvalidHeading(heading_deg))?;
    let positive = |r: Region| fractions.get(r) >= black_fraction_threshold;
    let mut out = NeighbourLabels {
        center: positive(Region::Center),
        ..NeighbourLabels::default()
    };
    for region in [Region::Top, Region::Left, Region::Bottom, Region::Right] {
        if let Some(d) = region_direction(region, turns) {
            out.set(d, positive(region));
        }
    }
    Ok(out)
}

/// What one image says (a *reading*): the black fractions and counts of its five regions
/// and the labels they give the cell under the camera and its four neighbours.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionReading {
    /// Black fractions in image coordinates.
    pub fractions: RegionFractions,
    /// Labels of the current cell and its neighbours (grid coordinates, heading applied).
    pub labels: NeighbourLabels,
    /// The raw counts behind `fractions`.
    pub counts: RegionCounts,
    /// The heading used, degrees clockwise from north.
    pub heading_deg: f64,
    /// The heading rounded to quarter turns clockwise from north (0..4).
    pub(crate) quarter_turns: u8,
}

/// Images must be at least this many pixels wide and high, so that every region has pixels.
pub(crate) const MIN_SIDE: u32 = 3;

fn check_size(img: &RgbImage) -> Result<(), VisionError> {
    let (w, h) = img.dimensions();
    if w < MIN_SIDE || h < MIN_SIDE {
        return Err(VisionError::TooSmall {
            width: w,
            height: h,
        });
    }
    Ok(())
}

/// Black pixel counts per region (steps 1–4) with the fast pipeline.
pub fn analyse(img: &RgbImage, params: &RunwayParams) -> Result<RegionCounts, VisionError> {
    params.validate()?;
    check_size(img)?;
    Ok(fast::region_counts(
        img,
        params.intensity_threshold,
        params.dilation_iterations,
    ))
}

/// [`analyse`] with reusable buffers (for streams of images).
pub fn analyse_in(
    ws: &mut fast::Workspace,
    img: &RgbImage,
    params: &RunwayParams,
) -> Result<RegionCounts, VisionError> {
    params.validate()?;
    check_size(img)?;
    Ok(fast::region_counts_in(
        ws,
        img,
        params.intensity_threshold,
        params.dilation_iterations,
    ))
}

/// Black pixel counts per region with the plain reference implementation (slow; for tests).
pub fn analyse_reference(
    img: &RgbImage,
    params: &RunwayParams,
) -> Result<RegionCounts, VisionError> {
    params.validate()?;
    check_size(img)?;
    Ok(reference::region_counts(
        img,
        params.intensity_threshold,
        params.dilation_iterations,
    ))
}

/// Classify one image taken with the vehicle heading `heading_deg` (degrees clockwise from
/// north): region fractions and the labels of the current cell and its four neighbours.
///
/// Errors: parameters out of range, a non-finite heading, an image smaller than 3×3.
pub fn classify(
    img: &RgbImage,
    heading_deg: f64,
    params: &RunwayParams,
) -> Result<RegionReading, VisionError> {
    let counts = analyse(img, params)?;
    reading_from_counts(counts, heading_deg, params)
}

/// The reading that follows from region counts (steps 5–6).
pub fn reading_from_counts(
    counts: RegionCounts,
    heading_deg: f64,
    params: &RunwayParams,
) -> Result<RegionReading, VisionError> {
    params.validate()?;
    let turns = quarter_turns(heading_deg).ok_or(VisionError::InvalidHeading(heading_deg))?;
    let fractions = counts.fractions();
    let labels = labels(&fractions, heading_deg, params.black_fraction_threshold)?;
    Ok(RegionReading {
        fractions,
        labels,
        counts,
        heading_deg,
        quarter_turns: turns,
    })
}

#[cfg(test)]
/// Classify several images in parallel (rayon), one result per image in the same order.
pub(crate) fn classify_many(
    images: &[(&RgbImage, f64)],
    params: &RunwayParams,
) -> Vec<Result<RegionReading, VisionError>> {
    use rayon::prelude::*;
    images
        .par_iter()
        .map_init(fast::Workspace::default, |ws, (img, heading)| {
            let counts = analyse_in(ws, img, params)?;
            reading_from_counts(counts, *heading, params)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_rounds_to_quarters_with_ties_clockwise() {
        let q = |h| quarter_turns(h).unwrap();
        assert_eq!(q(0.0), 0);
        assert_eq!(q(44.9), 0);
        assert_eq!(q(45.0), 1);
        assert_eq!(q(90.0), 1);
        assert_eq!(q(135.0), 2);
        assert_eq!(q(224.99), 2);
        assert_eq!(q(225.0), 3);
        assert_eq!(q(314.9), 3);
        assert_eq!(q(315.0), 0);
        assert_eq!(q(-45.0), 0);
        assert_eq!(q(-46.0), 3);
        assert_eq!(q(-90.0), 3);
        assert_eq!(q(720.0 + 180.0), 2);
        assert_eq!(quarter_turns(f64::NAN), None);
        assert_eq!(quarter_turns(f64::INFINITY), None);
    }

    #[test]
    fn heading_rotates_regions_onto_neighbours() {
        let f = RegionFractions {
            center: 0.0,
            top: 1.0,
            left: 0.0,
            bottom: 0.0,
            right: 0.0,
        };
        // Only the top region (towards the nose) is black.
        let l = |h| labels(&f, h, 0.5).unwrap();
        assert!(l(0.0).north && !l(0.0).east && !l(0.0).south && !l(0.0).west);
        assert!(l(90.0).east && !l(90.0).north);
        assert!(l(180.0).south && !l(180.0).north);
        assert!(l(270.0).west && !l(270.0).north);
        let f = RegionFractions {
            right: 0.7,
            ..RegionFractions::default()
        };
        // The right of the image is the vehicle's right side.
        let l = |h| labels(&f, h, 0.5).unwrap();
        assert!(l(0.0).east);
        assert!(l(90.0).south);
        assert!(l(180.0).west);
        assert!(l(270.0).north);
        assert!(matches!(
            labels(&f, f64::NAN, 0.5),
            Err(VisionError::InvalidHeading(_))
        ));
    }

    #[test]
    fn label_threshold_is_inclusive() {
        let f = RegionFractions {
            center: 0.5,
            ..RegionFractions::default()
        };
        assert!(labels(&f, 0.0, 0.5).unwrap().center);
        assert!(!labels(&f, 0.0, 0.500001).unwrap().center);
    }

    #[test]
    fn classify_many_equals_one_by_one() {
        use super::synth::{RunwayScene, RunwayStrip, render_runway};
        let p = RunwayParams::default();
        let imgs: Vec<RgbImage> = (0..6)
            .map(|i| {
                render_runway(&RunwayScene::grass(90 + i, 60, u64::from(i)).with_runway(
                    RunwayStrip {
                        angle_deg: f64::from(i) * 30.0,
                        offset_px: 10.0,
                        width_px: 40.0,
                        length_px: None,
                        along_px: 0.0,
                        markings: false,
                    },
                ))
            })
            .chain([RgbImage::new(2, 2)])
            .collect();
        let jobs: Vec<(&RgbImage, f64)> = imgs
            .iter()
            .enumerate()
            .map(|(i, img)| (img, i as f64 * 90.0))
            .collect();
        let many = classify_many(&jobs, &p);
        assert_eq!(many.len(), imgs.len());
        for ((img, heading), got) in jobs.iter().zip(&many) {
            match (classify(img, *heading, &p), got) {
                (Ok(want), Ok(got)) => assert_eq!(&want, got),
                (Err(_), Err(VisionError::TooSmall { .. })) => {}
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn tiny_images_and_bad_params_are_errors() {
        let img = RgbImage::new(2, 10);
        assert!(matches!(
            classify(&img, 0.0, &RunwayParams::default()),
            Err(VisionError::TooSmall { .. })
        ));
        let img = RgbImage::new(3, 3);
        let c = classify(&img, 0.0, &RunwayParams::default()).unwrap();
        assert_eq!(c.fractions.center, 1.0);
        let bad = RunwayParams {
            black_fraction_threshold: f64::NAN,
            ..RunwayParams::default()
        };
        assert!(matches!(
            classify(&img, 0.0, &bad),
            Err(VisionError::InvalidParams(_))
        ));
    }
}
