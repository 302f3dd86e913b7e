//! Camera footprint geometry for a downward-facing pinhole camera.
//!
//! The runway paper (§7) flies at 12 m so that the centre region of the image's 3 × 3 split
//! covers one 4 m × 4 m cell: the full footprint is then 12 m × 12 m, which is a field of
//! view of 2·atan(6/12) = 53.13° across both image axes. [`CameraModel::paper`] is that
//! camera. The paper does not give its GoPro HERO4's field of view or aspect ratio (a
//! HERO4's is wider and 4:3 or 16:9); a square footprint is its §3 model of the sensor, and
//! the classifier crops every picture to the 3 × 3 cells around its centre
//! ([`crate::vision::crop`]), so a wider real camera measures the same cells.

use super::VisionError;
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
    pub(crate) fn vfov_deg(&self) -> f64 {
        let half = (self.hfov_deg.to_radians() / 2.0).tan();
        let aspect = f64::from(self.height_px) / f64::from(self.width_px.max(1));
        2.0 * (half * aspect).atan().to_degrees()
    }

    /// Ground footprint (width along the image x axis, height along y), metres, at
    /// `altitude` metres above flat ground.
    pub(crate) fn footprint(&self, altitude: f64) -> (f64, f64) {
        let w = 2.0 * altitude * (self.hfov_deg.to_radians() / 2.0).tan();
        let h = 2.0 * altitude * (self.vfov_deg().to_radians() / 2.0).tan();
        (w, h)
    }

    /// Ground size of one pixel along x, metres, at `altitude`.
    pub fn ground_sample_distance(&self, altitude: f64) -> f64 {
        self.footprint(altitude).0 / f64::from(self.width_px.max(1))
    }

    /// A camera with horizontal field of view `hfov_deg` and `width_px × height_px`
    /// square pixels, checked: 0 < hfov < 180, and at least one pixel each way.
    pub fn new(hfov_deg: f64, width_px: u32, height_px: u32) -> Result<CameraModel, VisionError> {
        let cam = CameraModel {
            hfov_deg,
            width_px,
            height_px,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// Check the model (see [`CameraModel::new`]).
    pub fn validate(&self) -> Result<(), VisionError> {
        if !(self.hfov_deg.is_finite() && self.hfov_deg > 0.0 && self.hfov_deg < 180.0) {
            return Err(VisionError::InvalidParams(format!(
                "camera field of view must be in (0, 180) degrees, got {}",
                self.hfov_deg
            )));
        }
        if self.width_px == 0 || self.height_px == 0 {
            return Err(VisionError::InvalidParams(format!(
                "camera image must have pixels, got {}×{}",
                self.width_px, self.height_px
            )));
        }
        Ok(())
    }

    #[cfg(test)]
    /// Ground footprint (metres, along x and y) of the centre region of the 3×3 split — the
    /// part of the image that decides the label of the cell under the vehicle.
    pub(crate) fn centre_region_footprint(&self, altitude: f64) -> (f64, f64) {
        let (w, h) = self.footprint(altitude);
        (w / 3.0, h / 3.0)
    }

    #[cfg(test)]
    /// Ground offset (north, east) in metres from the point under the camera to the centre
    /// of pixel (`x`, `y`) (pixel units, 0 = left / top edge; pixel centres at +0.5), for
    /// a nadir camera at `altitude` metres whose image top points to `heading_deg`
    /// (degrees clockwise from north) and whose image right is the vehicle's right.
    pub(crate) fn ground_offset(
        &self,
        x: f64,
        y: f64,
        altitude: f64,
        heading_deg: f64,
    ) -> (f64, f64) {
        let gsd = self.ground_sample_distance(altitude);
        // Forward (towards the top of the image) and right, metres.
        let right = (x - f64::from(self.width_px) / 2.0) * gsd;
        let forward = (f64::from(self.height_px) / 2.0 - y) * gsd;
        let (s, c) = heading_deg.to_radians().sin_cos();
        (forward * c - right * s, forward * s + right * c)
    }

    #[cfg(test)]
    /// Inverse of [`CameraModel::ground_offset`]: the image position (pixel units) that
    /// sees the ground point `north`, `east` metres from the point under the camera.
    pub(crate) fn pixel_of(
        &self,
        north: f64,
        east: f64,
        altitude: f64,
        heading_deg: f64,
    ) -> (f64, f64) {
        let gsd = self.ground_sample_distance(altitude);
        let (s, c) = heading_deg.to_radians().sin_cos();
        let forward = north * c + east * s;
        let right = -north * s + east * c;
        (
            right / gsd + f64::from(self.width_px) / 2.0,
            f64::from(self.height_px) / 2.0 - forward / gsd,
        )
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
    fn pixels_map_to_ground_and_back() {
        let cam = CameraModel::paper();
        // At 12 m a 480 px image covers 12 m: 40 px per metre.
        let (n, e) = cam.ground_offset(240.0, 0.0, 12.0, 0.0);
        assert!((n - 6.0).abs() < 1e-9 && e.abs() < 1e-9);
        // Heading east: the top of the image is east, the right is south.
        let (n, e) = cam.ground_offset(240.0, 0.0, 12.0, 90.0);
        assert!(n.abs() < 1e-9 && (e - 6.0).abs() < 1e-9);
        let (n, e) = cam.ground_offset(480.0, 240.0, 12.0, 90.0);
        assert!((n + 6.0).abs() < 1e-9 && e.abs() < 1e-9);
        for h in [0.0, 33.0, 90.0, 200.0] {
            let (x, y) = cam.pixel_of(1.5, -2.0, 12.0, h);
            let (n, e) = cam.ground_offset(x, y, 12.0, h);
            assert!((n - 1.5).abs() < 1e-9 && (e + 2.0).abs() < 1e-9);
        }
        let (cw, ch) = cam.centre_region_footprint(12.0);
        assert!((cw - 4.0).abs() < 1e-9 && (ch - 4.0).abs() < 1e-9);
        assert!(CameraModel::new(180.0, 10, 10).is_err());
        assert!(CameraModel::new(60.0, 0, 10).is_err());
        assert!(CameraModel::new(60.0, 640, 480).is_ok());
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
