//! Runway pictures classified on board ([`fleetmap_core::vision::runway::onboard`]): the grid
//! the GCS announces, the camera's status while it has none, and the result of one picture.
//!
//! A camera given a runway mission whose grid origin is the first vehicle's home does not
//! know the grid until the GCS announces it (`"fm.grid"`, untargeted, forwarded to the
//! camera by the autopilot). Until then it says so every
//! [`fleetmap_core::vision::runway::onboard::STATUS_PERIOD_S`] seconds of its clock (a status
//! with fingerprint 0) and announces each picture unclassified, keeping it: the GCS asks for
//! it. It answers every announcement with a status naming the fingerprint it now classifies
//! with, and forgets the grid when it reboots with its vehicle.

use super::{CameraConfig, SimCamera};
use fleetmap_core::time::Time;
use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use fleetmap_core::vision::onboard::OnboardSpec;
use fleetmap_core::vision::runway::onboard::{
    GridAnnouncement, OnboardRegions, RunwayDefinition, RunwayMeasurement, STATUS_PERIOD_S,
    ShutterPose,
};
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;

/// The runway definition of `config`, as the camera starts with it.
pub(super) fn runway_of(config: &CameraConfig) -> Option<RunwayDefinition> {
    match &config.onboard {
        Some(OnboardSpec::Runway(d)) => Some(d.clone()),
        _ => None,
    }
}

impl SimCamera {
    /// A message from a GCS (any component but the vehicle's own): a request to send a
    /// picture again (DATA_TRANSMISSION_HANDSHAKE, `SimCamera::handle_handshake_request`)
    /// or the run's grid (DEBUG_FLOAT_ARRAY `"fm.grid"`), which a camera classifying runway
    /// pictures takes and answers with its status. Anything else is ignored.
    pub fn handle_gcs_message(&mut self, msg: &MavMessage) {
        match msg {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => self.handle_handshake_request(h.size),
            MavMessage::DEBUG_FLOAT_ARRAY(d) => {
                let (Some(def), Some(a)) =
                    (self.runway.as_mut(), GridAnnouncement::from_message(d))
                else {
                    return;
                };
                let spec = def.adopt(&a);
                self.outbox
                    .push_back(RunwayMeasurement::status(spec).to_message());
            }
            _ => {}
        }
    }

    /// The fingerprint the camera classifies runway pictures with (`None`: it does not
    /// classify runway pictures, or has no grid yet).
    pub fn runway_fingerprint(&self) -> Option<u32> {
        self.runway
            .as_ref()
            .and_then(RunwayDefinition::spec)
            .map(|s| s.fingerprint())
    }

    /// At `now`: a camera classifying runway pictures without a grid says so, every
    /// [`STATUS_PERIOD_S`] seconds.
    pub(super) fn status_tick(&mut self, now: Time) {
        let waiting = self.runway.as_ref().is_some_and(|d| d.grid.is_none());
        let due = self
            .last_status
            .is_none_or(|t| now.saturating_since(t).as_secs_f64() >= STATUS_PERIOD_S);
        if waiting && due {
            self.last_status = Some(now);
            self.outbox
                .push_back(RunwayMeasurement::status(0).to_message());
        }
    }

    /// The runway result of the picture `jpeg` announced by `captured`: classified when the
    /// camera has the whole definition and the picture can be cut (its JPEG decoded, as the
    /// GCS would decode it, and the pose as the announcement carries it), else announced
    /// unclassified. `None`: the camera does not classify runway pictures.
    pub(super) fn runway_result(
        &self,
        jpeg: &[u8],
        captured: &mav::CAMERA_IMAGE_CAPTURED_DATA,
    ) -> Option<RunwayMeasurement> {
        let def = self.runway.as_ref()?;
        let spec = def.spec();
        let regions = spec.as_ref().and_then(|s| {
            let img = load_image_bytes(jpeg, &LoadLimits::default()).ok()?;
            let r = s.measure(&img, &ShutterPose::of_captured(captured)).ok()?;
            OnboardRegions::of(&r)
        });
        Some(RunwayMeasurement {
            time_boot_ms: captured.time_boot_ms,
            image_index_lo: captured.image_index as u16,
            spec: spec.map_or(0, |s| s.fingerprint()),
            picture_bytes: jpeg.len() as u32,
            regions,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::geo::{Grid, LatLon};
    use fleetmap_core::vision::camera::CameraModel;
    use fleetmap_core::vision::runway::RunwayParams;
    use fleetmap_core::vision::runway::onboard::RunwaySpec;

    pub(crate) fn runway_config() -> CameraConfig {
        CameraConfig {
            onboard: Some(OnboardSpec::Runway(RunwayDefinition {
                params: RunwayParams::default(),
                camera: CameraModel::paper(),
                cell_m: 4.0,
                grid: None,
            })),
            ..CameraConfig::default()
        }
    }

    fn statuses(cam: &mut SimCamera) -> Vec<u32> {
        std::iter::from_fn(|| cam.poll_transmit())
            .filter_map(|m| match m {
                MavMessage::DEBUG_FLOAT_ARRAY(d) => RunwayMeasurement::from_message(&d),
                _ => None,
            })
            .map(|m| {
                assert!(m.is_status());
                m.spec
            })
            .collect()
    }

    /// Without a grid the camera says so every ten seconds of its clock; the GCS's grid
    /// makes it answer with the definition's fingerprint and go quiet; a reboot forgets it.
    #[test]
    fn a_camera_without_the_grid_says_so_until_it_is_announced() {
        let mut cam = SimCamera::new(1, runway_config(), 1);
        assert_eq!(cam.runway_fingerprint(), None);
        cam.advance(Time::from_secs(1));
        assert_eq!(statuses(&mut cam), vec![0]);
        cam.advance(Time::from_secs(10));
        assert_eq!(statuses(&mut cam), Vec::<u32>::new());
        cam.advance(Time::from_secs(11));
        assert_eq!(statuses(&mut cam), vec![0]);
        let spec = RunwaySpec {
            params: RunwayParams::default(),
            camera: CameraModel::paper(),
            grid: Grid::new(LatLon::new(-35.36, 149.16), 4.0).unwrap(),
        };
        // another array, or a grid with a broken layout: nothing
        let mut other = spec.announcement().to_message();
        if let MavMessage::DEBUG_FLOAT_ARRAY(d) = &mut other {
            d.data[14] = 61.0;
        }
        cam.handle_gcs_message(&other);
        assert_eq!(cam.runway_fingerprint(), None);
        cam.handle_gcs_message(&spec.announcement().to_message());
        assert_eq!(cam.runway_fingerprint(), Some(spec.fingerprint()));
        assert_eq!(statuses(&mut cam), vec![spec.fingerprint()]);
        cam.advance(Time::from_secs(40));
        assert_eq!(statuses(&mut cam), Vec::<u32>::new());
        cam.reboot();
        assert_eq!(cam.runway_fingerprint(), None);
        cam.advance(Time::from_secs(41));
        assert_eq!(statuses(&mut cam), vec![0]);
        // a camera that does not classify runway pictures ignores the grid and says nothing
        let mut plain = SimCamera::new(2, CameraConfig::default(), 1);
        plain.handle_gcs_message(&spec.announcement().to_message());
        plain.advance(Time::from_secs(1));
        assert_eq!(plain.runway_fingerprint(), None);
        assert!(plain.poll_transmit().is_none());
    }
}
