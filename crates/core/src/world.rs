//! Ground-truth worlds: what the simulated camera sees and what a run is scored against.
//!
//! Pure (core): a world is parsed from TOML text ([`World::from_toml`]); the shell's loader
//! (`files::load_world`) reads the file. The simulator renders it, the GCS's reports and
//! exports score a run against it.
//!
//! A world file (`assets/worlds/*.toml`) lists regions — WGS84 polygons with a [`Surface`]
//! (runway asphalt, grass, green and grey tiles, obstacles, roads) — drawn over a background
//! surface, optionally translating at a constant velocity (the runway paper's moving plume,
//! §4), plus the default home position of each vehicle. A region is given as one of
//! - `polygon = [[lat, lon], …]` (degrees),
//! - `rectangle = { center = [lat, lon], length_m, width_m, heading_deg }` (long axis heading,
//!   clockwise from true north), or
//! - `cells = [[row, col], …]` of the world's `[grid]` (origin = centre of cell (0, 0), rows
//!   north, columns east, UTM-aligned as in docs/grid.md).
//!
//! Default homes are either listed (`[[home]] lat/lon`, `home_cells`) or generated
//! (`[homes] reference, first_north_m/first_east_m, step_north_m/step_east_m`: vehicle k at
//! `geo::local::offset(reference, first + (k−1)·step)`), so vehicle k of
//! `fleetmap sim --vehicles …` starts where the matching mission file expects it.
//!
//! Internally every polygon is also kept in local tangent-plane metres (east, north) around
//! the world's reference point, which is what the renderer samples.

use crate::geo::local;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors reading or using a world.
#[derive(Debug, Error)]
pub enum WorldError {
    /// The file is not valid TOML or does not have the expected fields.
    #[error("invalid world file {path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A value is out of range or inconsistent.
    #[error("invalid world {name}: {message}")]
    Invalid {
        /// The world's name.
        name: String,
        /// What is wrong.
        message: String,
    },
}

/// What the ground is made of; decides its colour and texture in images.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Surface {
    /// Mown grass in sunlight: bright blades over darker gaps.
    Grass,
    /// Runway asphalt: dark grey aggregate.
    Asphalt,
    /// A green tile (the bandit paper's interesting cells).
    GreenTile,
    /// A grey tile (uninteresting cells).
    GreyTile,
    /// An obstacle / no-fly cell (coloured prism).
    Obstacle,
    /// A road cell (station-admissible), dark with small triangular tiles at its edges.
    Road,
    /// Indoor floor / bare ground.
    Floor,
    /// Lake water.
    Water,
    /// A dark pollutant plume on water (the runway paper's motivating scenario).
    Plume,
}

/// A region of the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    /// Its name (for reports).
    pub name: String,
    /// What it is made of.
    pub surface: Surface,
    /// The polygon at time 0, (lat, lon) degrees, not closed (last ≠ first).
    pub polygon: Vec<(f64, f64)>,
    /// The polygon at time 0 in local metres (east, north) around the world reference.
    pub local: Vec<(f64, f64)>,
    /// Constant translation velocity (north, east) m/s.
    pub velocity_ne: (f64, f64),
    /// Draw runway centreline markings (asphalt only).
    pub markings: bool,
    /// Long axis heading in degrees (rectangles), used to orient markings.
    pub axis_heading_deg: Option<f64>,
    bbox: (f64, f64, f64, f64),
}

impl Region {
    /// Whether local point (east, north) metres lies inside the region at time `t_s` seconds.
    pub fn contains_local(&self, east: f64, north: f64, t_s: f64) -> bool {
        let e = east - self.velocity_ne.1 * t_s;
        let n = north - self.velocity_ne.0 * t_s;
        if e < self.bbox.0 || e > self.bbox.2 || n < self.bbox.1 || n > self.bbox.3 {
            return false;
        }
        point_in_polygon(&self.local, e, n)
    }

    /// The polygon (lat, lon) degrees at time `t_s` seconds (translated by its velocity).
    pub(crate) fn polygon_at(&self, t_s: f64) -> Vec<(f64, f64)> {
        let (vn, ve) = self.velocity_ne;
        if vn == 0.0 && ve == 0.0 {
            return self.polygon.clone();
        }
        self.polygon
            .iter()
            .map(|&(la, lo)| local::offset(la, lo, vn * t_s, ve * t_s))
            .collect()
    }

    /// The local bounding box (min east, min north, max east, max north) at time 0.
    pub fn bbox(&self) -> (f64, f64, f64, f64) {
        self.bbox
    }
}

/// Even–odd point-in-polygon test.
pub fn point_in_polygon(poly: &[(f64, f64)], x: f64, y: f64) -> bool {
    let mut inside = false;
    let n = poly.len();
    if n < 3 {
        return false;
    }
    let mut j = n - 1;
    for i in 0..n {
        let (xi, yi) = poly[i];
        let (xj, yj) = poly[j];
        if ((yi > y) != (yj > y)) && (x < (xj - xi) * (y - yi) / (yj - yi) + xi) {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// A constant wind.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wind {
    /// Speed, m/s.
    pub speed_mps: f64,
    /// Direction it blows *from*, degrees clockwise from north (meteorological).
    pub from_deg: f64,
}

impl Wind {
    /// The air's velocity (north, east) in m/s.
    pub fn velocity_ne(&self) -> (f64, f64) {
        let to = (self.from_deg + 180.0).to_radians();
        (self.speed_mps * to.cos(), self.speed_mps * to.sin())
    }
}

/// A loaded world.
#[derive(Clone, Debug, PartialEq)]
pub struct World {
    /// Name.
    pub name: String,
    /// What it represents.
    pub description: String,
    /// Surface outside every region.
    pub background: Surface,
    /// Ground elevation above mean sea level, metres.
    pub ground_alt_amsl_m: f64,
    /// The regions, drawn in order (later ones on top).
    pub regions: Vec<Region>,
    /// Wind (none when absent).
    pub wind: Option<Wind>,
    /// Reference point of the local metres (lat, lon).
    pub reference: (f64, f64),
    /// The grid of `cells` regions, if any: (origin lat, origin lon, cell size m).
    pub grid: Option<(f64, f64, f64)>,
    homes: HomeRule,
}

#[derive(Clone, Debug, PartialEq)]
enum HomeRule {
    None,
    List(Vec<(f64, f64)>),
    Row {
        reference: (f64, f64),
        first: (f64, f64),
        step: (f64, f64),
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WorldFile {
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default = "default_background")]
    background: Surface,
    #[serde(default)]
    ground_alt_amsl_m: f64,
    wind: Option<Wind>,
    grid: Option<GridFile>,
    homes: Option<HomesFile>,
    #[serde(default)]
    home: Vec<LatLonFile>,
    #[serde(default)]
    home_cells: Vec<[i32; 2]>,
    #[serde(default)]
    region: Vec<RegionFile>,
}

fn default_background() -> Surface {
    Surface::Grass
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LatLonFile {
    lat: f64,
    lon: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GridFile {
    origin: [f64; 2],
    cell_size_m: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HomesFile {
    reference: [f64; 2],
    first_north_m: f64,
    first_east_m: f64,
    #[serde(default)]
    step_north_m: f64,
    #[serde(default)]
    step_east_m: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RectFile {
    center: [f64; 2],
    length_m: f64,
    width_m: f64,
    heading_deg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionFile {
    name: String,
    surface: Surface,
    polygon: Option<Vec<[f64; 2]>>,
    rectangle: Option<RectFile>,
    cells: Option<Vec<[i32; 2]>>,
    velocity_ne_mps: Option<[f64; 2]>,
    #[serde(default)]
    markings: bool,
}

/// The four corners (lat, lon) of grid cell (`row`, `col`) of the mission grid
/// ([`crate::geo::Grid`], docs/grid.md: cell (0, 0) centred on `origin`, `size` metre cells
/// aligned with the UTM grid of the origin's zone), counter-clockwise from the south-west
/// corner. An origin or size the grid rejects falls back to the tangent plane.
pub(crate) fn grid_cell_corners(
    origin: (f64, f64),
    size: f64,
    row: i32,
    col: i32,
) -> Vec<(f64, f64)> {
    match crate::geo::Grid::new(crate::geo::LatLon::new(origin.0, origin.1), size) {
        Ok(g) => g
            .cell_corners(crate::geo::Cell::new(row, col))
            .iter()
            .map(|p| (p.lat, p.lon))
            .collect(),
        Err(_) => {
            let h = size / 2.0;
            let (cn, ce) = (f64::from(row) * size, f64::from(col) * size);
            [(-h, -h), (-h, h), (h, h), (h, -h)]
                .iter()
                .map(|&(dn, de)| local::offset(origin.0, origin.1, cn + dn, ce + de))
                .collect()
        }
    }
}

/// The centre (lat, lon) of grid cell (`row`, `col`) (see `grid_cell_corners`).
pub fn grid_cell_center(origin: (f64, f64), size: f64, row: i32, col: i32) -> (f64, f64) {
    match crate::geo::Grid::new(crate::geo::LatLon::new(origin.0, origin.1), size) {
        Ok(g) => {
            let p = g.cell_center(crate::geo::Cell::new(row, col));
            (p.lat, p.lon)
        }
        Err(_) => local::offset(
            origin.0,
            origin.1,
            f64::from(row) * size,
            f64::from(col) * size,
        ),
    }
}

/// The corners (lat, lon) of a rectangle centred on `center` with its long axis along
/// `heading_deg`.
pub(crate) fn rectangle_corners(
    center: (f64, f64),
    length_m: f64,
    width_m: f64,
    heading_deg: f64,
) -> Vec<(f64, f64)> {
    let h = heading_deg.to_radians();
    let (ax_n, ax_e) = (h.cos(), h.sin()); // along the long axis
    let (cr_n, cr_e) = (-h.sin(), h.cos()); // across (to the right)
    let (l2, w2) = (length_m / 2.0, width_m / 2.0);
    [(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)]
        .iter()
        .map(|&(a, c)| {
            let n = a * l2 * ax_n + c * w2 * cr_n;
            let e = a * l2 * ax_e + c * w2 * cr_e;
            local::offset(center.0, center.1, n, e)
        })
        .collect()
}

fn valid_latlon(lat: f64, lon: f64) -> bool {
    lat.is_finite()
        && lon.is_finite()
        && (-90.0..=90.0).contains(&lat)
        && (-180.0..=180.0).contains(&lon)
}

impl World {
    /// Parse and check the text of the world file `file` (named in a parse error); the shell
    /// reads the file (the GCS's `files::load_world`).
    pub fn from_toml_file(text: &str, file: &str) -> Result<World, WorldError> {
        World::from_toml(text).map_err(|e| match e {
            WorldError::Parse { message, .. } => WorldError::Parse {
                path: file.to_string(),
                message,
            },
            other => other,
        })
    }

    /// Parse a world from TOML text.
    pub fn from_toml(text: &str) -> Result<World, WorldError> {
        let f: WorldFile = toml::from_str(text).map_err(|e| WorldError::Parse {
            path: "<text>".into(),
            message: e.to_string(),
        })?;
        let invalid = |m: String| WorldError::Invalid {
            name: f.name.clone(),
            message: m,
        };
        let grid = match &f.grid {
            Some(g) => {
                if !valid_latlon(g.origin[0], g.origin[1]) {
                    return Err(invalid("grid origin is not a valid lat/lon".into()));
                }
                if !(g.cell_size_m.is_finite() && g.cell_size_m > 0.0) {
                    return Err(invalid(format!(
                        "grid cell_size_m must be positive, got {}",
                        g.cell_size_m
                    )));
                }
                Some((g.origin[0], g.origin[1], g.cell_size_m))
            }
            None => None,
        };
        // (region, its polygon, the long-axis heading of rectangles)
        type Parsed = (RegionFile, Vec<(f64, f64)>, Option<f64>);
        let mut polys: Vec<Parsed> = Vec::new();
        for r in f.region {
            let given = [
                r.polygon.is_some(),
                r.rectangle.is_some(),
                r.cells.is_some(),
            ]
            .iter()
            .filter(|x| **x)
            .count();
            if given != 1 {
                return Err(invalid(format!(
                    "region {:?} needs exactly one of polygon, rectangle, cells",
                    r.name
                )));
            }
            if let Some(p) = &r.polygon {
                if p.len() < 3 {
                    return Err(invalid(format!(
                        "region {:?}: a polygon needs 3 or more vertices",
                        r.name
                    )));
                }
                if p.iter().any(|v| !valid_latlon(v[0], v[1])) {
                    return Err(invalid(format!("region {:?}: invalid vertex", r.name)));
                }
                let mut pts: Vec<(f64, f64)> = p.iter().map(|v| (v[0], v[1])).collect();
                if pts.len() > 3 && pts.first() == pts.last() {
                    pts.pop();
                }
                polys.push((r, pts, None));
            } else if let Some(rect) = &r.rectangle {
                let ok = valid_latlon(rect.center[0], rect.center[1])
                    && rect.length_m > 0.0
                    && rect.width_m > 0.0
                    && rect.heading_deg.is_finite();
                if !ok {
                    return Err(invalid(format!("region {:?}: invalid rectangle", r.name)));
                }
                let pts = rectangle_corners(
                    (rect.center[0], rect.center[1]),
                    rect.length_m,
                    rect.width_m,
                    rect.heading_deg,
                );
                let h = rect.heading_deg;
                polys.push((r, pts, Some(h)));
            } else if let Some(cells) = r.cells.clone() {
                let Some((la, lo, s)) = grid else {
                    return Err(invalid(format!(
                        "region {:?} lists cells but the world has no [grid]",
                        r.name
                    )));
                };
                for c in cells {
                    let pts = grid_cell_corners((la, lo), s, c[0], c[1]);
                    let rf = RegionFile {
                        name: format!("{} ({}, {})", r.name, c[0], c[1]),
                        surface: r.surface,
                        polygon: None,
                        rectangle: None,
                        cells: None,
                        velocity_ne_mps: r.velocity_ne_mps,
                        markings: r.markings,
                    };
                    polys.push((rf, pts, None));
                }
            }
        }
        // Reference point: the grid origin, else the first region's first vertex, else the
        // first home.
        let reference = if let Some((la, lo, _)) = grid {
            (la, lo)
        } else if let Some((_, p, _)) = polys.first() {
            p[0]
        } else if let Some(h) = f.home.first() {
            (h.lat, h.lon)
        } else if let Some(h) = &f.homes {
            (h.reference[0], h.reference[1])
        } else {
            return Err(invalid(
                "a world needs at least a region, a grid or a home".into(),
            ));
        };
        let regions = polys
            .into_iter()
            .map(|(r, pts, heading)| {
                let local_pts: Vec<(f64, f64)> = pts
                    .iter()
                    .map(|&(la, lo)| {
                        let (n, e) = local::delta(reference.0, reference.1, la, lo);
                        (e, n)
                    })
                    .collect();
                let bbox = local_pts
                    .iter()
                    .fold((f64::MAX, f64::MAX, f64::MIN, f64::MIN), |b, &(e, n)| {
                        (b.0.min(e), b.1.min(n), b.2.max(e), b.3.max(n))
                    });
                let v = r.velocity_ne_mps.unwrap_or([0.0, 0.0]);
                Region {
                    name: r.name,
                    surface: r.surface,
                    polygon: pts,
                    local: local_pts,
                    velocity_ne: (v[0], v[1]),
                    markings: r.markings,
                    axis_heading_deg: heading,
                    bbox,
                }
            })
            .collect();
        let homes = if let Some(h) = f.homes {
            if !valid_latlon(h.reference[0], h.reference[1]) {
                return Err(invalid("homes reference is not a valid lat/lon".into()));
            }
            HomeRule::Row {
                reference: (h.reference[0], h.reference[1]),
                first: (h.first_north_m, h.first_east_m),
                step: (h.step_north_m, h.step_east_m),
            }
        } else if !f.home.is_empty() {
            if f.home.iter().any(|h| !valid_latlon(h.lat, h.lon)) {
                return Err(invalid("a home is not a valid lat/lon".into()));
            }
            HomeRule::List(f.home.iter().map(|h| (h.lat, h.lon)).collect())
        } else if !f.home_cells.is_empty() {
            let Some((la, lo, s)) = grid else {
                return Err(invalid("home_cells needs a [grid]".into()));
            };
            HomeRule::List(
                f.home_cells
                    .iter()
                    .map(|c| grid_cell_center((la, lo), s, c[0], c[1]))
                    .collect(),
            )
        } else {
            HomeRule::None
        };
        if let Some(w) = &f.wind
            && !(w.speed_mps.is_finite() && w.speed_mps >= 0.0 && w.from_deg.is_finite())
        {
            return Err(invalid(
                "wind speed must be ≥ 0 and direction finite".into(),
            ));
        }
        Ok(World {
            name: f.name,
            description: f.description,
            background: f.background,
            ground_alt_amsl_m: f.ground_alt_amsl_m,
            regions,
            wind: f.wind,
            reference,
            grid,
            homes,
        })
    }

    /// A featureless world: `surface` everywhere around `reference` (what a camera sees when
    /// no world file is given).
    pub fn flat(surface: Surface, reference: (f64, f64), ground_alt_amsl_m: f64) -> World {
        World {
            name: "flat".into(),
            description: String::new(),
            background: surface,
            ground_alt_amsl_m,
            regions: Vec::new(),
            wind: None,
            reference,
            grid: None,
            homes: HomeRule::None,
        }
    }

    /// The default home (lat, lon) of vehicle `k` (1-based, in `--vehicles` order), if the
    /// world defines one.
    pub fn default_home(&self, k: usize) -> Option<(f64, f64)> {
        if k == 0 {
            return None;
        }
        match &self.homes {
            HomeRule::None => None,
            HomeRule::List(v) => v.get(k - 1).copied(),
            HomeRule::Row {
                reference,
                first,
                step,
            } => {
                let i = (k - 1) as f64;
                Some(local::offset(
                    reference.0,
                    reference.1,
                    first.0 + i * step.0,
                    first.1 + i * step.1,
                ))
            }
        }
    }

    /// Local metres (east, north) of (lat, lon) around the world's reference point.
    pub fn to_local(&self, lat: f64, lon: f64) -> (f64, f64) {
        let (n, e) = local::delta(self.reference.0, self.reference.1, lat, lon);
        (e, n)
    }

    /// The surface and the topmost region (if any) at local (east, north), time `t_s`.
    pub fn surface_at_local(&self, east: f64, north: f64, t_s: f64) -> (Surface, Option<&Region>) {
        for r in self.regions.iter().rev() {
            if r.contains_local(east, north, t_s) {
                return (r.surface, Some(r));
            }
        }
        (self.background, None)
    }

    /// The surface at (lat, lon) at time `t_s` seconds.
    pub fn surface_at(&self, lat: f64, lon: f64, t_s: f64) -> Surface {
        let (e, n) = self.to_local(lat, lon);
        self.surface_at_local(e, n, t_s).0
    }

    /// The polygons (lat, lon) of every region with surface `s` at time `t_s` (the ground
    /// truth a run is scored against).
    pub fn polygons_of(&self, s: Surface, t_s: f64) -> Vec<Vec<(f64, f64)>> {
        self.regions
            .iter()
            .filter(|r| r.surface == s)
            .map(|r| r.polygon_at(t_s))
            .collect()
    }

    /// The grid cells (row, col) listed with surface `s` (worlds with a `[grid]`), parsed back
    /// from region names `"name (row, col)"`.
    pub fn cells_of(&self, s: Surface) -> Vec<(i32, i32)> {
        self.regions
            .iter()
            .filter(|r| r.surface == s)
            .filter_map(|r| {
                let open = r.name.rfind('(')?;
                let inner = r.name[open + 1..].trim_end_matches(')');
                let (a, b) = inner.split_once(',')?;
                Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
            })
            .collect()
    }

    /// The interesting cells of a bandit field: its green tiles as mission cells, sorted
    /// (row, then column) and without repeats — the truth a classification run is scored
    /// against.
    pub fn green_cells(&self) -> Vec<crate::geo::Cell> {
        let mut v: Vec<crate::geo::Cell> = self
            .cells_of(Surface::GreenTile)
            .into_iter()
            .map(|(r, c)| crate::geo::Cell::new(r, c))
            .collect();
        v.sort();
        v.dedup();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_has_the_right_size_and_heading() {
        let c = (37.1968, -80.5781);
        let p = rectangle_corners(c, 92.0, 21.0, 58.0);
        let d01 = local::distance(p[0].0, p[0].1, p[1].0, p[1].1);
        let d12 = local::distance(p[1].0, p[1].1, p[2].0, p[2].1);
        assert!((d01 - 21.0).abs() < 1e-3, "{d01}");
        assert!((d12 - 92.0).abs() < 1e-3, "{d12}");
        let b = local::bearing(p[1].0, p[1].1, p[2].0, p[2].1);
        assert!((b - 58.0).abs() < 1e-3, "{b}");
    }

    #[test]
    fn parses_regions_homes_and_cells() {
        let w = World::from_toml(
            r#"
            name = "t"
            background = "floor"
            home_cells = [[3, 1], [3, 4]]
            [grid]
            origin = [37.195, -80.58]
            cell_size_m = 5.0
            [[region]]
            name = "green"
            surface = "green_tile"
            cells = [[5, 0], [1, 2]]
            "#,
        )
        .unwrap();
        assert_eq!(w.regions.len(), 2);
        assert_eq!(w.cells_of(Surface::GreenTile), vec![(5, 0), (1, 2)]);
        let h = w.default_home(1).unwrap();
        let (e, n) = w.to_local(h.0, h.1);
        // UTM cell centres vs the local tangent plane: the meridian convergence (≈0.25° here)
        // moves a point 15 m away by ≈7 cm
        assert!((e - 5.0).abs() < 0.1 && (n - 15.0).abs() < 0.1, "{e} {n}");
        let (ce, cn) = w.to_local(
            grid_cell_center((37.195, -80.58), 5.0, 5, 0).0,
            grid_cell_center((37.195, -80.58), 5.0, 5, 0).1,
        );
        assert_eq!(w.surface_at_local(ce, cn, 0.0).0, Surface::GreenTile);
        assert_eq!(w.surface_at_local(ce + 5.0, cn, 0.0).0, Surface::Floor);
        assert!(w.default_home(3).is_none());
        assert!(
            World::from_toml("name = \"x\"\n[[region]]\nname=\"a\"\nsurface=\"grass\"\n").is_err()
        );
        assert!(World::from_toml("name = \"x\"\nbogus = 1\n").is_err());
    }

    #[test]
    fn moving_region_translates() {
        let w = World::from_toml(
            r#"
            name = "plume"
            background = "water"
            [[region]]
            name = "plume"
            surface = "plume"
            rectangle = { center = [10.0, 20.0], length_m = 10.0, width_m = 10.0, heading_deg = 0.0 }
            velocity_ne_mps = [0.0, 1.0]
            "#,
        )
        .unwrap();
        let (e, n) = w.to_local(10.0, 20.0);
        assert_eq!(w.surface_at_local(e, n, 0.0).0, Surface::Plume);
        assert_eq!(w.surface_at_local(e, n, 20.0).0, Surface::Water);
        assert_eq!(w.surface_at_local(e + 20.0, n, 20.0).0, Surface::Plume);
    }
}
