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

use super::{Measurer, Picture};
use anyhow::bail;
use fleetmap_core::geo::{Grid, LatLon};
use fleetmap_core::mission::definition::{MissionDef, MissionKind, Origin};
use fleetmap_core::time::Time;
use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use fleetmap_core::vision::onboard::OnboardSpec;
use fleetmap_core::vision::runway::RunwayParams;
use fleetmap_core::vision::runway::onboard::{
    GridAnnouncement, OnboardRegions, RunwayDefinition, RunwayMeasurement, STATUS_PERIOD_S,
    ShutterPose,
};
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::path::Path;

/// The on-board definition of the runway mission `def`: its classifier, camera and cell
/// size, and its grid when the origin is fixed — with `origin = "vehicle"` the GCS announces
/// it when the run starts. `None` for another kind of mission.
pub fn definition_of(def: &MissionDef) -> Option<RunwayDefinition> {
    let rw = def.runway.as_ref()?;
    if def.kind != MissionKind::RunwayMapping {
        return None;
    }
    let grid = match def.grid.origin {
        Origin::Coordinates(p) => Grid::new(
            LatLon {
                lat: p.lat,
                lon: p.lon,
            },
            def.grid.cell_size_m,
        )
        .ok(),
        Origin::Vehicle => None,
    };
    Some(RunwayDefinition {
        // as the ground station's runway run reads them
        params: RunwayParams {
            intensity_threshold: rw.intensity_threshold,
            dilation_iterations: rw.dilations,
            black_fraction_threshold: rw.black_fraction,
        },
        camera: def.camera,
        cell_m: def.grid.cell_size_m,
        grid,
    })
}

/// The on-board definition of the runway mission `def` read from `path`; an error when its
/// region moves (its pictures are credited in the region's frame, which the camera cannot
/// follow: they stay on the picture path).
pub(super) fn onboard_spec(def: &MissionDef, path: &Path) -> anyhow::Result<Option<OnboardSpec>> {
    if def
        .runway
        .as_ref()
        .is_some_and(|r| r.roi_velocity_ne_mps.is_some_and(|v| v != [0.0, 0.0]))
    {
        bail!(
            "{}: the region moves (runway.roi_velocity_ne_mps): its pictures are classified by \
             the GCS in the region's frame; start the camera without --mission",
            path.display()
        );
    }
    Ok(definition_of(def).map(OnboardSpec::Runway))
}

/// A camera classifying runway pictures: its definition, the grid once known (the grid the
/// GCS announced replaces the mission file's).
#[derive(Debug)]
pub(super) struct Runway {
    def: RunwayDefinition,
    /// When the camera last said it has no grid (on its clock).
    last_status: Option<Time>,
}

/// A camera starting with `def`.
pub(super) fn measurer(def: &RunwayDefinition) -> Box<dyn Measurer> {
    Box::new(Runway {
        def: def.clone(),
        last_status: None,
    })
}

impl Measurer for Runway {
    /// The runway result of the picture: classified when the camera has the whole definition
    /// and the picture can be cut (its JPEG decoded, as the GCS would decode it, and the pose
    /// as the announcement carries it), else announced unclassified.
    fn measure(&self, p: &Picture<'_>) -> Option<MavMessage> {
        let spec = self.def.spec();
        let regions = spec.as_ref().and_then(|s| {
            let img = load_image_bytes(p.jpeg, &LoadLimits::default()).ok()?;
            let r = s
                .measure(&img, &ShutterPose::of_captured(p.captured))
                .ok()?;
            OnboardRegions::of(&r)
        });
        let m = RunwayMeasurement {
            time_boot_ms: p.captured.time_boot_ms,
            image_index_lo: p.captured.image_index as u16,
            spec: spec.map_or(0, |s| s.fingerprint()),
            picture_bytes: p.jpeg.len() as u32,
            regions,
        };
        Some(m.to_message())
    }

    /// The run's grid (`"fm.grid"`): taken, and answered with the camera's status.
    fn handle_gcs_message(&mut self, d: &mav::DEBUG_FLOAT_ARRAY_DATA) -> Option<MavMessage> {
        let a = GridAnnouncement::from_message(d)?;
        let spec = self.def.adopt(&a);
        Some(RunwayMeasurement::status(spec).to_message())
    }

    /// Without a grid, a status every [`STATUS_PERIOD_S`] seconds.
    fn status_tick(&mut self, now: Time) -> Option<MavMessage> {
        let waiting = self.def.grid.is_none();
        let due = self
            .last_status
            .is_none_or(|t| now.saturating_since(t).as_secs_f64() >= STATUS_PERIOD_S);
        if !(waiting && due) {
            return None;
        }
        self.last_status = Some(now);
        Some(RunwayMeasurement::status(0).to_message())
    }

    fn fingerprint(&self) -> Option<u32> {
        self.def.spec().map(|s| s.fingerprint())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraConfig, SimCamera};
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
        assert_eq!(cam.onboard_fingerprint(), None);
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
        assert_eq!(cam.onboard_fingerprint(), None);
        cam.handle_gcs_message(&spec.announcement().to_message());
        assert_eq!(cam.onboard_fingerprint(), Some(spec.fingerprint()));
        assert_eq!(statuses(&mut cam), vec![spec.fingerprint()]);
        cam.advance(Time::from_secs(40));
        assert_eq!(statuses(&mut cam), Vec::<u32>::new());
        cam.reboot();
        assert_eq!(cam.onboard_fingerprint(), None);
        cam.advance(Time::from_secs(41));
        assert_eq!(statuses(&mut cam), vec![0]);
        // a camera that does not classify runway pictures ignores the grid and says nothing
        let mut plain = SimCamera::new(2, CameraConfig::default(), 1);
        plain.handle_gcs_message(&spec.announcement().to_message());
        plain.advance(Time::from_secs(1));
        assert_eq!(plain.onboard_fingerprint(), None);
        assert!(plain.poll_transmit().is_none());
    }
}
