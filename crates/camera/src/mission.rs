//! What a camera measures on board, read from a mission file (`--mission`): whichever of
//! the on-board measurements the mission has (`camera::onboard`: a spatial-classification
//! mission's green share, a runway mission's cell and 3 × 3 region counts). The ground
//! station gives its simulated cameras the same definitions.

use anyhow::Context;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::vision::onboard::OnboardSpec;
use std::path::Path;

/// The on-board measurement definition of the mission file at `path`. An error for a file
/// that cannot be read or is not a valid mission, for a mission with nothing to measure on
/// board, and for one whose measurement a camera cannot make (a runway mission whose region
/// moves: its pictures are credited in the region's frame, which the camera cannot follow;
/// they stay on the picture path).
pub fn onboard_spec(path: &Path) -> anyhow::Result<OnboardSpec> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let def = MissionDef::parse(&text, &path.display().to_string())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    crate::camera::onboard::required_spec_of(&def, path)
}
