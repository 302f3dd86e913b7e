//! What `fleetmap check` says of a spatial-classification mission file's own section: its
//! cells and roads, the planner's parameters and the green classifier.

use crate::app::kind::plural;
use fleetmap_core::mission::definition::MissionDef;

/// The summary lines of `def`'s classification section, label first (`cells       …`).
pub(crate) fn summary_lines(def: &MissionDef) -> Vec<String> {
    let roads = match &def.area.roads {
        Some(r) => plural(r.len(), "road cell", "road cells"),
        None => "no road restriction".to_string(),
    };
    let roads_note = match (&def.area.roads, def.area.roads_are_candidates) {
        (Some(_), true) => " (roads included)",
        (Some(_), false) => " (roads excluded)",
        (None, _) => "",
    };
    let mut out = vec![format!(
        "cells       {}; {roads}; {}{roads_note}",
        plural(def.area.obstacles.len(), "obstacle", "obstacles"),
        plural(
            def.candidate_cells().len(),
            "candidate cell",
            "candidate cells"
        ),
    )];
    if let Some(c) = &def.classification {
        let cap = c
            .charger_capacity
            .map_or("no limit".to_string(), |c| c.to_string());
        out.push(format!(
            "planner     theta={} epsilon={} delta={} D={} B={} Td={} Tc={} K={} C={cap}",
            c.theta,
            c.epsilon,
            c.delta,
            c.epoch_goals,
            c.batch_size,
            c.drone_cycle_steps,
            c.station_cycle_steps,
            c.max_cycles
        ));
        out.push(format!(
            "green       HSV {:?} to {:?}, positive at {} of the pixels",
            c.green.hsv_min, c.green.hsv_max, c.green.fraction_threshold
        ));
    }
    out
}
