//! The centre crops both missions cut out of a received picture before measuring it: the
//! runway's 3 × 3 cells ([`crop_to_cells`]) and the bandit's share of one cell
//! ([`crop_to_cell`]). Both compute the crop from the camera's ground footprint at the
//! capture altitude (`CameraModel::footprint`) and cut it with `centre_crop`.

use crate::vision::camera::CameraModel;
use image::RgbImage;

/// The centred `cw` × `ch` pixels of `img` (each at most the image's size).
pub(crate) fn centre_crop(img: &RgbImage, cw: u32, ch: u32) -> RgbImage {
    let (w, h) = img.dimensions();
    let (cw, ch) = (cw.min(w), ch.min(h));
    image::imageops::crop_imm(img, (w - cw) / 2, (h - ch) / 2, cw, ch).to_image()
}

/// The part of an image taken at `altitude_m` that covers the 3 × 3 cells around its centre
/// (the runway paper's sensing model assumes the footprint is exactly 3 × 3 cells, true at
/// 12 m for 4 m cells; a drone flying higher for separation sees more, so its image is
/// cropped to the same ground area). Lower than that the whole image is used.
pub fn crop_to_cells(
    img: RgbImage,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
) -> RgbImage {
    let (fw, fh) = camera.footprint(altitude_m);
    let want = 3.0 * cell_m;
    if !(fw.is_finite() && fh.is_finite()) || fw <= want * 1.001 || fh <= want * 1.001 {
        return img;
    }
    let (w, h) = img.dimensions();
    let cw = ((f64::from(w) * want / fw).round() as u32).clamp(3, w);
    let ch = ((f64::from(h) * want / fh).round() as u32).clamp(3, h);
    centre_crop(&img, cw, ch)
}

/// The measured part of an image taken at `altitude_m`: a centred square covering
/// `fraction` of a `cell_m` cell on the ground (the whole image when the footprint is
/// smaller than that).
pub fn crop_to_cell(
    img: &RgbImage,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
    fraction: f64,
) -> RgbImage {
    let (fw, fh) = camera.footprint(altitude_m.max(0.1));
    let want = cell_m * fraction.clamp(0.05, 1.0);
    let (w, h) = img.dimensions();
    let side = |f: f64, n: u32| -> u32 {
        if f.is_finite() && f > want {
            ((f64::from(n) * want / f).round() as u32).clamp(1, n)
        } else {
            n
        }
    };
    centre_crop(img, side(fw, w), side(fh, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn higher_drones_crop_to_the_three_cells_around_the_centre() {
        let cam = CameraModel::paper();
        let img = RgbImage::new(480, 480);
        // at 12 m the footprint is exactly 3 cells: unchanged
        assert_eq!(
            crop_to_cells(img.clone(), &cam, 12.0, 4.0).dimensions(),
            (480, 480)
        );
        // at 24 m it is 6 cells wide: the centre half
        assert_eq!(
            crop_to_cells(img.clone(), &cam, 24.0, 4.0).dimensions(),
            (240, 240)
        );
        // lower: the whole image
        assert_eq!(crop_to_cells(img, &cam, 8.0, 4.0).dimensions(), (480, 480));
    }

    #[test]
    fn crop_covers_the_fraction_of_a_cell_at_any_altitude() {
        let cam = CameraModel::paper();
        let img = RgbImage::new(480, 480);
        // 10 m up: a 10 m footprint; 0.6 of a 5 m cell is 3 m = 144 px
        assert_eq!(
            crop_to_cell(&img, &cam, 10.0, 5.0, 0.6).dimensions(),
            (144, 144)
        );
        assert_eq!(
            crop_to_cell(&img, &cam, 20.0, 5.0, 0.6).dimensions(),
            (72, 72)
        );
        // lower than the cell: the whole image
        assert_eq!(
            crop_to_cell(&img, &cam, 2.0, 5.0, 0.6).dimensions(),
            (480, 480)
        );
    }
}
