//! The runway-mapping section of a mission file: `[runway]` and its `[runway.sweep]` box,
//! with their defaults, how the reader reads them (step 2) and the rules a runway-mapping
//! definition obeys (step 3).

use super::kinds::KindSection;
use super::reader::{Ctx, Val, get};
use super::validate::{Checker, check_latlon, check_other_tables, num};
use super::*;
use crate::mission::strategy::Allocation;
use toml::de::DeTable;

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

fn default_sweep_position_tolerance_m() -> f64 {
    1.0
}
fn default_images_per_cell() -> u32 {
    5
}
fn default_votes_required() -> u32 {
    3
}
fn default_intensity_threshold() -> u8 {
    150
}
fn default_dilations() -> u32 {
    7
}
fn default_black_fraction() -> f64 {
    0.5
}

/// The allocation of a mission that does not name one: the drones spread over the frontier.
fn default_allocation() -> Allocation {
    Allocation::Spread
}

impl MissionDef {
    /// Cells whose centres lie in a [`SweepBox::Local`] sweep box, row-major from the
    /// south-west (`None` for WGS84 corners, which need the origin's position, without a
    /// runway table, or when the box holds more than `MAX_CELLS` cells).
    pub fn sweep_cells(&self) -> Option<Vec<Cell>> {
        let SweepBox::Local { north_m, east_m } = self.runway.as_ref()?.sweep else {
            return None;
        };
        let s = self.grid.cell_size_m;
        let finite = north_m.iter().chain(&east_m).all(|x| x.is_finite());
        if !(s > 0.0 && s.is_finite() && finite) {
            return None;
        }
        let span = |lo: f64, hi: f64| ((lo / s).ceil(), (hi / s).floor());
        let ((r0, r1), (c0, c1)) = (span(north_m[0], north_m[1]), span(east_m[0], east_m[1]));
        let count = (r1 - r0 + 1.0).max(0.0) * (c1 - c0 + 1.0).max(0.0);
        if count > MAX_CELLS as f64 || r0.abs().max(r1.abs()).max(c0.abs()).max(c1.abs()) > 1e9 {
            return None;
        }
        let (r0, r1, c0, c1) = (r0 as i32, r1 as i32, c0 as i32, c1 as i32);
        Some(
            (r0..=r1)
                .flat_map(|r| (c0..=c1).map(move |c| Cell::new(r, c)))
                .collect(),
        )
    }
}

/// The runway-mapping kind's section: `[runway]`, read by [`read_runway`] and checked by
/// [`check_runway`].
pub(super) struct Section;

impl KindSection for Section {
    fn read(&self, ctx: &mut Ctx<'_>, root: &DeTable<'_>, def: &mut MissionDef) {
        def.runway = read_runway(ctx, root);
    }

    fn check(&self, c: &mut Checker, def: &MissionDef) {
        check_runway(c, def);
    }

    fn has_stations(&self) -> bool {
        false
    }
}

/// `[runway]` with its defaults, `None` when the file has no such table.
fn read_runway(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> Option<RunwayDef> {
    let known = [
        "images_per_cell",
        "votes_required",
        "intensity_threshold",
        "dilations",
        "black_fraction",
        "lane_spacing_m",
        "sweep_heading_error_deg",
        "sweep_position_tolerance_m",
        "allocation",
        "roi_velocity_ne_mps",
        "sweep",
    ];
    let t = ctx.sub_table(root, "", "runway", &known)?;
    let count = |c: &mut Ctx<'_>, p: &str, v: &Val<'_>| c.int_of::<u32>(p, v, "an integer ≥ 1");
    let p = "runway";
    let images_per_cell = ctx.or(t, p, "images_per_cell", default_images_per_cell(), count);
    let votes_required = ctx.or(t, p, "votes_required", default_votes_required(), count);
    let intensity_threshold = ctx.or(
        t,
        p,
        "intensity_threshold",
        default_intensity_threshold(),
        |c, p, v| c.int_of::<u8>(p, v, "an integer 0–255"),
    );
    let dilations = ctx.or(t, p, "dilations", default_dilations(), |c, p, v| {
        c.int_of::<u32>(p, v, "an integer ≥ 0")
    });
    let black_fraction = ctx.or(
        t,
        p,
        "black_fraction",
        default_black_fraction(),
        Ctx::num_of,
    );
    let lane_spacing_m = ctx.opt(t, p, "lane_spacing_m", Ctx::num_of).unwrap_or(None);
    let sweep_heading_error_deg = ctx
        .opt(t, p, "sweep_heading_error_deg", Ctx::num_of)
        .unwrap_or(None);
    let sweep_position_tolerance_m = ctx.or(
        t,
        p,
        "sweep_position_tolerance_m",
        default_sweep_position_tolerance_m(),
        Ctx::num_of,
    );
    let allocations = Allocation::ALL.map(|a| (a.name(), a));
    // A mission file without the key spreads the drones over the frontier (with direct
    // transit, the field's rules: docs/results/dfs.md, "Team runway mapping").
    let allocation = ctx.or(t, p, "allocation", default_allocation(), |c, p, v| {
        c.word_of(p, v, &allocations)
    });
    let velocity = "[north, east] (metres per second)";
    let roi_velocity_ne_mps = ctx
        .opt(t, p, "roi_velocity_ne_mps", |c, p, v| {
            c.nums_of::<2>(p, v, velocity)
        })
        .unwrap_or(None);
    let sweep = read_sweep(ctx, t);
    Some(RunwayDef {
        images_per_cell,
        votes_required,
        intensity_threshold,
        dilations,
        black_fraction,
        lane_spacing_m,
        sweep_heading_error_deg,
        sweep_position_tolerance_m,
        allocation,
        roi_velocity_ne_mps,
        sweep,
    })
}

/// `[runway.sweep]` (required): local metres or WGS84 corners, not both; a placeholder
/// (poisoned) when it cannot be read.
fn read_sweep(ctx: &mut Ctx<'_>, runway: &DeTable<'_>) -> SweepBox {
    let placeholder = SweepBox::Local {
        north_m: [f64::NAN; 2],
        east_m: [f64::NAN; 2],
    };
    let expected = "a table [runway.sweep] with north_m = [min, max], east_m = [min, max] \
                    (metres from the origin) or south_west = { lat, lon }, north_east = { lat, lon }";
    let Some(v) = get(runway, "sweep") else {
        ctx.missing("runway", "sweep", expected);
        ctx.poison("runway.sweep");
        return placeholder;
    };
    let p = "runway.sweep";
    let known = ["north_m", "east_m", "south_west", "north_east"];
    let Some(t) = ctx.table(p, v, &known) else {
        ctx.poison(p);
        return placeholder;
    };
    let has = |k: &str| get(t, k).is_some();
    let local = has("north_m") || has("east_m");
    let corners = has("south_west") || has("north_east");
    if local && corners {
        ctx.push(
            v.span().start,
            p,
            "give either north_m/east_m (metres from the origin) or south_west/north_east \
             (WGS84 corners), not both"
                .into(),
        );
        ctx.poison(p);
        return placeholder;
    }
    if corners {
        let sw = ctx.req(t, p, "south_west", "{ lat = …, lon = … }", Ctx::latlon_of);
        let ne = ctx.req(t, p, "north_east", "{ lat = …, lon = … }", Ctx::latlon_of);
        match (sw, ne) {
            (Some(south_west), Some(north_east)) => SweepBox::Corners {
                south_west,
                north_east,
            },
            _ => {
                ctx.poison(p);
                placeholder
            }
        }
    } else {
        let range = "[min, max] (metres from the origin)";
        let n = ctx.req(t, p, "north_m", range, |c, p, v| {
            c.nums_of::<2>(p, v, range)
        });
        let e = ctx.req(t, p, "east_m", range, |c, p, v| c.nums_of::<2>(p, v, range));
        match (n, e) {
            (Some(north_m), Some(east_m)) => SweepBox::Local { north_m, east_m },
            _ => {
                ctx.poison(p);
                placeholder
            }
        }
    }
}

/// Step 3 for a runway-mapping definition: a team of drones alone on an unbounded grid (the
/// stations, start cells, area bounds and roads of the kinds with stations refused), no
/// other kind's table, and the `[runway]` values.
fn check_runway(c: &mut Checker, def: &MissionDef) {
    // `only for kind = "…"`: the kinds with stations.
    let only_for = format!("only for kind = {}", MissionKind::with_stations(true));
    let mut drones = 0;
    for (i, v) in def.vehicles.iter().enumerate() {
        match v.role {
            Role::Drone => drones += 1,
            Role::Station => c.rule(
                format!("vehicles[{i}].role"),
                &["kind"],
                format!(
                    "runway mapping flies drones only, found a station (charging stations \
                     belong to {} missions)",
                    MissionKind::with_stations(false)
                ),
            ),
        }
        if v.start.is_some() {
            c.rule(
                format!("vehicles[{i}].start"),
                &["kind"],
                format!("start cells are {only_for} (runway drones start at their home)"),
            );
        }
    }
    if drones == 0 && !def.vehicles.is_empty() {
        c.rule(
            "vehicles",
            &["kind"],
            "expected at least one vehicle with role = \"drone\"".into(),
        );
    }
    for (key, present) in [
        ("area.rows", def.area.rows.is_some()),
        ("area.cols", def.area.cols.is_some()),
        ("area.roads", def.area.roads.is_some()),
    ] {
        if present {
            c.rule(
                key,
                &["kind"],
                format!("{only_for} (the runway grid is unbounded and has no roads)"),
            );
        }
    }
    check_other_tables(c, def);
    let Some(r) = &def.runway else {
        c.rule(
            "runway",
            &["kind"],
            "missing table [runway] with [runway.sweep] (the box the lawnmower sweeps first)"
                .into(),
        );
        return;
    };
    c.int(
        "runway.images_per_cell",
        r.images_per_cell.into(),
        1,
        100,
        "an integer 1–100",
    );
    if r.votes_required == 0 || r.votes_required > r.images_per_cell {
        c.value(
            "runway.votes_required",
            &["runway.images_per_cell"],
            format!(
                "expected an integer 1–{} (at most images_per_cell), found {}",
                r.images_per_cell, r.votes_required
            ),
        );
    }
    c.int(
        "runway.dilations",
        r.dilations.into(),
        0,
        100,
        "an integer 0–100",
    );
    c.number(
        "runway.black_fraction",
        r.black_fraction,
        r.black_fraction > 0.0 && r.black_fraction <= 1.0,
        "a fraction > 0 and ≤ 1",
    );
    if let Some(l) = r.lane_spacing_m {
        c.number(
            "runway.lane_spacing_m",
            l,
            l > 0.0 && l <= 10_000.0,
            "a number > 0 and ≤ 10000 (metres)",
        );
    }
    if let Some(e) = r.sweep_heading_error_deg {
        c.number(
            "runway.sweep_heading_error_deg",
            e,
            (0.0..45.0).contains(&e),
            "a number ≥ 0 and < 45 (degrees)",
        );
    }
    c.number(
        "runway.sweep_position_tolerance_m",
        r.sweep_position_tolerance_m,
        (0.0..=100.0).contains(&r.sweep_position_tolerance_m),
        "a number ≥ 0 and ≤ 100 (metres)",
    );
    if let Some([n, e]) = r.roi_velocity_ne_mps {
        let speed = n.hypot(e);
        if !(n.is_finite() && e.is_finite() && speed < def.flight.speed_m_s) {
            c.value(
                "runway.roi_velocity_ne_mps",
                &["flight.speed_m_s"],
                format!(
                    "expected [north, east] m/s slower than flight.speed_m_s = {} (a robot \
                     must outrun the region to visit its cells), found [{}, {}]",
                    num(def.flight.speed_m_s),
                    num(n),
                    num(e)
                ),
            );
        }
    }
    match r.sweep {
        SweepBox::Local { north_m, east_m } => {
            for (key, [lo, hi]) in [("north_m", north_m), ("east_m", east_m)] {
                let ok = lo.is_finite()
                    && hi.is_finite()
                    && lo < hi
                    && lo.abs().max(hi.abs()) <= 100_000.0;
                if !ok {
                    c.value(
                        format!("runway.sweep.{key}"),
                        &[],
                        format!(
                            "expected [min, max] with min < max, within 100 km of the origin \
                             (metres), found [{}, {}]",
                            num(lo),
                            num(hi)
                        ),
                    );
                }
            }
        }
        SweepBox::Corners {
            south_west,
            north_east,
        } => {
            check_latlon(c, "runway.sweep.south_west", south_west);
            check_latlon(c, "runway.sweep.north_east", north_east);
            if !(south_west.lat < north_east.lat && south_west.lon < north_east.lon) {
                c.value(
                    "runway.sweep.north_east",
                    &["runway.sweep.south_west"],
                    format!(
                        "expected a corner north and east of south_west ({}, {}), found ({}, {})",
                        num(south_west.lat),
                        num(south_west.lon),
                        num(north_east.lat),
                        num(north_east.lon)
                    ),
                );
            }
        }
    }
}
