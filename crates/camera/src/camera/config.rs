//! The camera's configuration: optics, JPEG quality, where images go (files, MAVLink, on-board
//! measurement), capture interval, transfer pacing, a degraded sensor, an outside source.

use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::vision::onboard::OnboardSpec;
// named in the documentation only
#[cfg(doc)]
use super::{RECENT_IMAGES, Shot, SimCamera};
#[cfg(all(doc, feature = "render"))]
use crate::render::Disturbances;

/// How captured images leave the vehicle.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraConfig {
    /// Optics and resolution.
    pub model: CameraModel,
    /// JPEG quality, 1–100.
    pub jpeg_quality: u8,
    /// Push every image over MAVLink image transmission.
    pub mavlink_transfer: bool,
    /// Directory (absolute) the images are written to and announced from in
    /// CAMERA_IMAGE_CAPTURED.file_url; `None` = no files.
    pub file_dir: Option<String>,
    /// Minimum time between two captures, seconds (a real camera needs time to expose and
    /// store).
    pub min_interval_s: f64,
    /// Pace MAVLink image transmission to this many bytes per second of MAVLink 2 frames
    /// (header, payload and CRC; 267 bytes per ENCAPSULATED_DATA), on the camera's clock.
    /// `None` (the default) queues an image's handshake and all its packets at once.
    /// Values that are not finite and positive count as `None`.
    pub transfer_rate_bps: Option<f64>,
    /// A degraded sensor: the probability (0–1, per image) that a picture shows the other
    /// class of the bandit field — rendered with every green tile drawn as a grey tile and
    /// every grey tile as a green one (`Disturbances::swap_tiles`), so the GCS's unchanged
    /// green-share measurement reads 0 over a green tile and 1 over a grey one. Drawn
    /// independently for each image from the camera's seed and the image's name (vehicle,
    /// boot, index): the same seed flips the same images. The bandit paper's degraded-sensor
    /// hardware run (§V) added 5 % of such classification noise: 0.05. 0 (the default), a
    /// negative or a non-finite value: no image is flipped. Other surfaces are drawn as they
    /// are.
    pub misclassify_probability: f64,
    /// Measure every picture on board with this definition and send the result
    /// (DEBUG_FLOAT_ARRAY after CAMERA_IMAGE_CAPTURED) instead of pushing the picture: the
    /// bandit mission's green share ([`fleetmap_core::vision::onboard`], `"fm.green"`) or the
    /// runway mission's 3 × 3 regions ([`fleetmap_core::vision::runway::onboard`], `"fm.rwy"`;
    /// a definition without a grid waits for the GCS's announcement, and announces its
    /// pictures unclassified meanwhile). The picture is kept ([`RECENT_IMAGES`]) and sent when
    /// a GCS asks for it. `None` (the default): no measurement, pictures pushed as
    /// `mavlink_transfer` says.
    pub onboard: Option<OnboardSpec>,
    /// The pictures come from outside (a real camera's folder, a video device) instead of
    /// the renderer: a capture becomes a [`Shot`] the shell takes with
    /// `SimCamera::poll_shot` and completes with `SimCamera::deliver`.
    pub external: bool,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            model: CameraModel::paper(),
            jpeg_quality: 85,
            mavlink_transfer: true,
            file_dir: None,
            min_interval_s: 0.2,
            transfer_rate_bps: None,
            misclassify_probability: 0.0,
            onboard: None,
            external: false,
        }
    }
}
