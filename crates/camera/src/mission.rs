//! What a camera measures on board, read from a mission file (`--mission`): a
//! spatial-classification mission's green share or a runway mission's cell and 3 × 3 region
//! counts. The ground station gives its simulated cameras the same definitions.

use anyhow::{Context, bail};
use fleetmap_core::geo::{Grid, LatLon};
use fleetmap_core::mission::definition::{MissionDef, MissionKind, Origin};
use fleetmap_core::vision::onboard::{GreenSpec, OnboardSpec};
use fleetmap_core::vision::runway::RunwayParams;
use fleetmap_core::vision::runway::onboard::RunwayDefinition;
use std::path::Path;

/// The measurement definition of the spatial-classification mission `def` (its green box,
/// camera, cell size and the planner's crop), or `None` for another kind of mission.
pub fn green_spec_of(def: &MissionDef) -> Option<GreenSpec> {
    (def.kind == MissionKind::SpatialClassification).then(|| GreenSpec {
        green: fleetmap_core::planner::sortie::green_params(def),
        camera: def.camera,
        cell_m: def.grid.cell_size_m,
        crop_fraction: fleetmap_core::planner::sortie::CROP_FRACTION,
    })
}

/// The on-board definition of the runway mission `def`: its classifier, camera and cell
/// size, and its grid when the origin is fixed — with `origin = "vehicle"` the GCS announces
/// it when the run starts. `None` for another kind of mission.
pub fn runway_definition_of(def: &MissionDef) -> Option<RunwayDefinition> {
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

/// The on-board measurement definition of the mission file at `path`: a spatial-classification
/// mission's green share or a runway mission's regions. An error for a file that cannot be
/// read or is not a valid mission, and for a runway mission whose region moves (its pictures
/// are credited in the region's frame, which the camera cannot follow: they stay on the
/// picture path).
pub fn onboard_spec(path: &Path) -> anyhow::Result<OnboardSpec> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let def = MissionDef::parse(&text, &path.display().to_string())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if let Some(green) = green_spec_of(&def) {
        return Ok(OnboardSpec::Green(green));
    }
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
    runway_definition_of(&def)
        .map(OnboardSpec::Runway)
        .with_context(|| format!("{}: nothing to measure on board", path.display()))
}
