//! The green share measured on board ([`fleetmap_core::vision::onboard`], `"fm.green"`): the
//! spatial-classification mission's measurement of each picture.

use super::{Measurer, Picture};
use fleetmap_core::mission::definition::{MissionDef, MissionKind};
use fleetmap_core::vision::onboard::{GreenSpec, OnboardMeasurement, OnboardSpec};
use mavlink::dialects::ardupilotmega::MavMessage;
use std::path::Path;

/// The measurement definition of the spatial-classification mission `def` (its green box,
/// camera, cell size and the planner's crop), or `None` for another kind of mission.
pub fn spec_of(def: &MissionDef) -> Option<GreenSpec> {
    (def.kind == MissionKind::SpatialClassification).then(|| GreenSpec {
        green: fleetmap_core::planner::sortie::green_params(def),
        camera: def.camera,
        cell_m: def.grid.cell_size_m,
        crop_fraction: fleetmap_core::planner::sortie::CROP_FRACTION,
    })
}

/// [`spec_of`] as a camera is given it (a mission file read from `path` cannot fail to give
/// its green share).
pub(super) fn onboard_spec(def: &MissionDef, _path: &Path) -> anyhow::Result<Option<OnboardSpec>> {
    Ok(spec_of(def).map(OnboardSpec::Green))
}

/// A camera starting with `spec`.
pub(super) fn measurer(spec: &GreenSpec) -> Box<dyn Measurer> {
    Box::new(Green(*spec))
}

/// A camera measuring the green share of its pictures.
#[derive(Debug)]
struct Green(GreenSpec);

impl Measurer for Green {
    /// Measured on the picture as taken, at the altitude the capture message reports (as
    /// the GCS would).
    fn measure(&self, p: &Picture<'_>) -> Option<MavMessage> {
        let m = OnboardMeasurement {
            time_boot_ms: p.captured.time_boot_ms,
            image_index_lo: p.captured.image_index as u16,
            spec: self.0.fingerprint(),
            picture_bytes: p.jpeg.len() as u32,
            value: self.0.measure(p.image, p.alt_rel_m),
        };
        Some(m.to_message())
    }

    fn fingerprint(&self) -> Option<u32> {
        Some(self.0.fingerprint())
    }
}
