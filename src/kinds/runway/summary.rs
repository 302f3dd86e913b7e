//! What `fleetmap check` says of a runway-mapping mission file's own section: its cells, the
//! sweep box and the classifier's settings.

use crate::app::kind::plural;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::mission::definition::runway::SweepBox;

/// The summary lines of `def`'s runway section, label first (`cells       …`).
pub(crate) fn summary_lines(def: &MissionDef) -> Vec<String> {
    let mut out = vec![format!(
        "cells       {}",
        plural(def.area.obstacles.len(), "obstacle", "obstacles")
    )];
    if let Some(r) = &def.runway {
        let sweep = match r.sweep {
            SweepBox::Local { north_m, east_m } => format!(
                "north {} to {} m, east {} to {} m from the origin ({} cells)",
                north_m[0],
                north_m[1],
                east_m[0],
                east_m[1],
                def.sweep_cells().map_or(0, |c| c.len())
            ),
            SweepBox::Corners {
                south_west,
                north_east,
            } => format!(
                "({:.6}, {:.6}) to ({:.6}, {:.6})",
                south_west.lat, south_west.lon, north_east.lat, north_east.lon
            ),
        };
        out.push(format!("sweep       {sweep}"));
        out.push(format!(
            "classifier  {} images per cell, {} votes, threshold {}, {} dilations, \
             black fraction {}, FOV {:.2} deg",
            r.images_per_cell,
            r.votes_required,
            r.intensity_threshold,
            r.dilations,
            r.black_fraction,
            def.camera.hfov_deg
        ));
    }
    out
}
