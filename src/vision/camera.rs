//! Camera footprint geometry for a downward-facing pinhole camera.
//!
//! The runway paper (§7) flies at 12 m so that the centre ninth of each image covers one
//! 4 m × 4 m cell: the full footprint is then 12 m × 12 m, which is a field of view of
//! 2·atan(6/12) = 53.13° across both image axes. [`CameraModel::paper`] is that camera;
//! the paper's GoPro images were cropped to this view, which is the deviation we make
//! explicit by modelling the camera as square.

use serde::{Deserialize, Serialize};

/// A nadir-pointing pinhole camera with square pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraModel {
    /// Horizontal field of view across the image width, degrees (0 < hfov < 180).
    pub hfov_deg: f64,
    /// Image width in pixels.
    pub width_px: u32,
    /// Image height in pixels.
    pub height_px: u32,
}

impl CameraModel {
    /// The runway paper's camera: square image, 53.13° field of view, so that at 12 m the
    /// footprint is 12 m × 12 m and its centre ninth is one 4 m cell.
    pub fn paper() -> CameraModel {
        CameraModel {
            hfov_deg: 2.0 * 0.5f64.atan().to_degrees(),
            width_px: 480,
            height_px: 480,
        }
    }

    /// Vertical field of view in degrees, from the horizontal one and the aspect ratio.
    pub fn vfov_deg(&self) -> f64 {
        let half = (self.hfov_deg.to_radians() / 2.0).tan();
        let aspect = f64::from(self.height_px) / f64::from(self.width_px.max(1));
        2.0 * (half * aspect).atan().to_degrees()
    }

    /// Ground footprint (width along the image x axis, height along y), metres, at
    /// `altitude` metres above flat ground.
    pub fn footprint(&self, altitude: f64) -> (f64, f64) {
        let w = 2.0 * altitude * (self.hfov_deg.to_radians() / 2.0).tan();
        let h = 2.0 * altitude * (self.vfov_deg().to_radians() / 2.0).tan();
        (w, h)
    }

    /// Ground size of one pixel along x, metres, at `altitude`.
    pub fn ground_sample_distance(&self, altitude: f64) -> f64 {
        self.footprint(altitude).0 / f64::from(self.width_px.max(1))
    }

    /// The altitude (metres) at which the larger side of the centre ninth of the image
    /// equals `cell_size` metres, so that the centre region sees one cell and nothing of
    /// the cells beside it. For [`CameraModel::paper`] and 4 m cells this is 12 m.
    pub fn altitude_for_cell(&self, cell_size: f64) -> f64 {
        let (w1, h1) = self.footprint(1.0);
        3.0 * cell_size / w1.max(h1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_camera_flies_at_12_m_for_4_m_cells() {
        let cam = CameraModel::paper();
        assert!((cam.altitude_for_cell(4.0) - 12.0).abs() < 1e-9);
        let (w, h) = cam.footprint(12.0);
        assert!((w - 12.0).abs() < 1e-9 && (h - 12.0).abs() < 1e-9);
        assert!((cam.vfov_deg() - cam.hfov_deg).abs() < 1e-9);
    }

    #[test]
    fn wide_image_is_limited_by_its_width() {
        let cam = CameraModel {
            hfov_deg: 90.0,
            width_px: 1920,
            height_px: 1080,
        };
        let (w, h) = cam.footprint(10.0);
        assert!((w - 20.0).abs() < 1e-9);
        assert!((h - 20.0 * 1080.0 / 1920.0).abs() < 1e-9);
        assert!((cam.altitude_for_cell(4.0) - 6.0).abs() < 1e-9);
    }
}
