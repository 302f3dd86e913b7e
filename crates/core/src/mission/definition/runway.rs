//! The runway-mapping section of a mission file: `[runway]` and its `[runway.sweep]` box,
//! with their defaults.

use super::*;

/// `[runway.sweep]`: the bounding box the lawnmower phase sweeps (runway paper §7), known to
/// contain part of the region.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum SweepBox {
    /// Metres relative to the grid origin — the form to use with `origin = "vehicle"`,
    /// whose position is only known at run time.
    Local {
        /// Northward extent `[min, max]`, metres from the origin.
        north_m: [f64; 2],
        /// Eastward extent `[min, max]`, metres from the origin.
        east_m: [f64; 2],
    },
    /// WGS84 corners.
    Corners {
        /// South-west corner.
        south_west: LatLon,
        /// North-east corner.
        north_east: LatLon,
    },
}

/// `[runway]`: the runway classifier and sweep (runway paper §7).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunwayDef {
    /// Images taken over every visited cell. Paper: 5.
    #[serde(default = "default_images_per_cell")]
    pub images_per_cell: u32,
    /// Positive votes (of `images_per_cell`) that make a cell positive. Paper: 3.
    #[serde(default = "default_votes_required")]
    pub votes_required: u32,
    /// Grayscale threshold (0–255): darker pixels are "black" (runway). Paper: 150.
    #[serde(default = "default_intensity_threshold")]
    pub intensity_threshold: u8,
    /// Dilations of the thresholded image (fill the gaps in the grass). Paper: 7.
    #[serde(default = "default_dilations")]
    pub dilations: u32,
    /// An image region (one of the 3×3) votes "runway" when at least this fraction of its
    /// pixels is black. The paper uses "a threshold" without giving it; 0.5 is our choice.
    #[serde(default = "default_black_fraction")]
    pub black_fraction: f64,
    /// Distance between the sweep's lawnmower lanes, metres. Absent: the widest spacing
    /// that leaves no gap between the pictures of neighbouring lanes, for the camera at each
    /// drone's altitude, the heading rule `sweep_heading_error_deg` and the position error
    /// `sweep_position_tolerance_m` (7.07 m for the paper's camera at 12 m with the
    /// defaults). A wider spacing would leave gaps and is refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lane_spacing_m: Option<f64>,
    /// How far the nose may be from the lane direction at a sweep picture, degrees (< 45).
    /// Absent: any heading (the spacing then assumes the footprint may be rotated
    /// arbitrarily: the disc inscribed in it). ArduPilot's default `WP_YAW_BEHAVIOR` turns
    /// the nose towards the next waypoint, so an along-track rule usually holds, but a
    /// gust or a PX4 vehicle need not keep it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep_heading_error_deg: Option<f64>,
    /// Worst distance between a sweep waypoint and where its picture is taken, metres.
    /// Our choice (1 m): the position limit of the image sanity check.
    #[serde(default = "default_sweep_position_tolerance_m")]
    pub(crate) sweep_position_tolerance_m: f64,
    /// How the DFS sends the robots at a vertex on (`"paper"`: Algorithm 1's split;
    /// `"nearest_frontier"`: towards the nearest unexplored vertex; `"spread"`: the robots
    /// spread over the frontier; the last two with GCS sharing). A mission file without the
    /// key gets `"spread"`: on the field test it maps with 6 drones in 0.18–0.19 of one
    /// drone's time where the paper's split takes 0.24, checked (not proved) within Lemma 1
    /// by a property test (`docs/results/dfs.md`, "Team runway mapping").
    #[serde(default = "default_allocation")]
    pub allocation: Allocation,
    /// The region's velocity over the ground, `[north, east]` metres per second, when it
    /// translates (a plume in a current or a steady wind, from a forecast or a plume model;
    /// runway paper §3–4). The region is where the mission's geometry says at the run's
    /// start (`run-directory.md`: `roi_epoch_unix_ms`); the DFS maps it in its own frame and
    /// each visit aims at where the cell will be when the vehicle gets there. Absent: a
    /// static region. Must be slower than `flight.speed_m_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roi_velocity_ne_mps: Option<[f64; 2]>,
    /// The box to sweep.
    pub sweep: SweepBox,
}

pub(crate) fn default_sweep_position_tolerance_m() -> f64 {
    1.0
}
pub(super) fn default_images_per_cell() -> u32 {
    5
}
pub(super) fn default_votes_required() -> u32 {
    3
}
pub(super) fn default_intensity_threshold() -> u8 {
    150
}
pub(super) fn default_dilations() -> u32 {
    7
}
pub(super) fn default_black_fraction() -> f64 {
    0.5
}

/// The allocation of a mission that does not name one: the drones spread over the frontier.
pub(crate) fn default_allocation() -> Allocation {
    Allocation::Spread
}
