//! The mission grid: square cells in the UTM frame of the origin's zone.
//!
//! Cell (row, col) is the half-open square
//! `[e₀ + (col − ½)s, e₀ + (col + ½)s) × [n₀ + (row − ½)s, n₀ + (row + ½)s)` in UTM metres,
//! where (e₀, n₀) is the origin's UTM coordinate and s the cell size: the origin is the
//! centre of cell (0, 0), rows grow north, columns east (docs/grid.md). The zone and
//! hemisphere are fixed when the grid is made and never change, also for cells in the next
//! zone or across the equator.
//!
//! Cell sizes are UTM grid metres: one grid metre is 1/k ground metres, where the UTM scale
//! k is 0.9996 on the central meridian and up to ≈1.0010 at the zone edge (see
//! [`super::utm::convergence_and_scale`]). For a 4 m cell that is at most ±1.6 mm.

use super::utm::{self, MAX_LAT, MIN_LAT};
use super::{Cell, GeoError, Hemisphere, LatLon, Utm};
use ::geo::{Area, BooleanOps, BoundingRect, Coord, LineString, MultiPolygon, Polygon, Rect};
use serde::{Deserialize, Serialize};

/// Smallest supported cell size, metres.
pub(crate) const MIN_CELL_SIZE_M: f64 = 0.001;
/// Largest supported cell size, metres.
pub(crate) const MAX_CELL_SIZE_M: f64 = 100_000.0;
/// The most candidate cells [`Grid::polygon_coverage`] examines.
pub(crate) const MAX_COVERAGE_CELLS: u64 = 4_000_000;
/// Covered fractions at or below this are treated as "touching along an edge" (round-off of
/// the polygon clipping) and left out of [`Grid::polygon_coverage`].
pub(crate) const COVERAGE_EPS: f64 = 1e-9;

/// A square-cell grid anchored at a WGS84 origin (the centre of cell (0, 0)), in the UTM
/// zone and hemisphere chosen when it was made.
///
/// Serialised as `{"origin": {"lat", "lon"}, "cell_size_m", "zone", "hemisphere"}`; loading
/// re-validates everything (a missing zone/hemisphere means the origin's standard ones).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "GridSpec", into = "GridSpec")]
pub struct Grid {
    origin: LatLon,
    cell_size: f64,
    zone: u8,
    hemisphere: Hemisphere,
    /// The origin in the grid's UTM frame (easting, northing), metres.
    origin_en: (f64, f64),
}

/// The serialised form of a [`Grid`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GridSpec {
    origin: LatLon,
    cell_size_m: f64,
    #[serde(default)]
    zone: Option<u8>,
    #[serde(default)]
    hemisphere: Option<Hemisphere>,
}

impl TryFrom<GridSpec> for Grid {
    type Error = GeoError;
    fn try_from(s: GridSpec) -> Result<Grid, GeoError> {
        match (s.zone, s.hemisphere) {
            (None, None) => Grid::new(s.origin, s.cell_size_m),
            (zone, hemisphere) => {
                let origin = s.origin.validate()?;
                let zone = match zone {
                    Some(z) => z,
                    None => utm::zone_for(origin.lat, origin.lon)?,
                };
                let hemisphere = hemisphere.unwrap_or(Hemisphere::of_lat(origin.lat));
                Grid::new_in_zone(origin, s.cell_size_m, zone, hemisphere)
            }
        }
    }
}

impl From<Grid> for GridSpec {
    fn from(g: Grid) -> GridSpec {
        GridSpec {
            origin: g.origin,
            cell_size_m: g.cell_size,
            zone: Some(g.zone),
            hemisphere: Some(g.hemisphere),
        }
    }
}

fn check_cell_size(size: f64) -> Result<f64, GeoError> {
    if !size.is_finite() {
        return Err(GeoError::NotFinite {
            what: "cell size",
            value: size,
        });
    }
    if size <= 0.0 {
        return Err(GeoError::CellSizeNotPositive { size });
    }
    if !(MIN_CELL_SIZE_M..=MAX_CELL_SIZE_M).contains(&size) {
        return Err(GeoError::CellSizeOutOfRange { size });
    }
    Ok(size)
}

/// The index of the half-open interval `[(k − ½)s, (k + ½)s)` that contains `v` (metres
/// from the origin): ⌊v/s + ½⌋, computed without rounding the `+ ½` (the fractional part of
/// v/s is exact), saturating at the i32 range; NaN gives 0.
fn index_of(v: f64, s: f64) -> i32 {
    let q = v / s;
    let k = q.floor();
    let k = if q - k >= 0.5 { k + 1.0 } else { k };
    k as i32
}

impl Grid {
    /// A grid with cells of `cell_size_m` metres whose cell (0, 0) is centred on `origin`,
    /// in the origin's standard UTM zone ([`utm::zone_for`]) and hemisphere.
    pub fn new(origin: LatLon, cell_size_m: f64) -> Result<Grid, GeoError> {
        let origin = origin.validate()?;
        let zone = utm::zone_for(origin.lat, origin.lon)?;
        Grid::new_in_zone(origin, cell_size_m, zone, Hemisphere::of_lat(origin.lat))
    }

    /// A grid in a chosen UTM `zone` and `hemisphere` (e.g. the zone where most of a field
    /// lies when its start point is just across a zone edge). The origin must be within
    /// `utm::MAX_ZONE_OFFSET_DEG` of the zone's central meridian.
    pub fn new_in_zone(
        origin: LatLon,
        cell_size_m: f64,
        zone: u8,
        hemisphere: Hemisphere,
    ) -> Result<Grid, GeoError> {
        let cell_size = check_cell_size(cell_size_m)?;
        let u = utm::to_utm_in_zone(origin, zone, hemisphere)?;
        Ok(Grid {
            origin,
            cell_size,
            zone,
            hemisphere,
            origin_en: (u.easting, u.northing),
        })
    }

    /// The origin (centre of cell (0, 0)), degrees.
    pub fn origin(&self) -> LatLon {
        self.origin
    }

    /// The cell size, UTM metres.
    pub fn cell_size(&self) -> f64 {
        self.cell_size
    }

    /// The grid's UTM zone (1..=60).
    pub fn zone(&self) -> u8 {
        self.zone
    }

    /// The grid's UTM hemisphere.
    pub fn hemisphere(&self) -> Hemisphere {
        self.hemisphere
    }

    #[cfg(test)]
    /// The origin in the grid's UTM frame.
    pub(crate) fn origin_utm(&self) -> Utm {
        self.utm_at(self.origin_en.0, self.origin_en.1)
    }

    fn utm_at(&self, easting: f64, northing: f64) -> Utm {
        Utm {
            easting,
            northing,
            zone: self.zone,
            hemisphere: self.hemisphere,
        }
    }

    /// The UTM coordinate of the centre of cell `c`: origin + (col·s, row·s).
    pub fn cell_center_utm(&self, c: Cell) -> Utm {
        let s = self.cell_size;
        self.utm_at(
            self.origin_en.0 + f64::from(c.col) * s,
            self.origin_en.1 + f64::from(c.row) * s,
        )
    }

    /// The WGS84 position of the centre of cell `c`, degrees.
    ///
    /// Infallible: for cells beyond the UTM domain (north of 84°N, south of 80°S) or far
    /// from the zone this is the mathematical continuation of the projection, which
    /// [`Grid::cell_of`] will refuse. Use [`Grid::checked_cell_center`] to get an error
    /// instead.
    pub fn cell_center(&self, c: Cell) -> LatLon {
        utm::raw_from_utm(&self.cell_center_utm(c))
    }

    /// [`Grid::cell_center`], but an error when the centre is outside the UTM domain or
    /// farther than `utm::MAX_ZONE_OFFSET_DEG` from the zone.
    pub fn checked_cell_center(&self, c: Cell) -> Result<LatLon, GeoError> {
        utm::from_utm(&self.cell_center_utm(c))
    }

    /// The cell that contains `p` (cells are half-open: a point on the boundary between two
    /// cells belongs to the northern/eastern one).
    pub fn cell_of(&self, p: LatLon) -> Result<Cell, GeoError> {
        let (e, n) = self.to_xy(p)?;
        Ok(self.cell_of_xy(e, n))
    }

    /// The cell that contains `(east_m, north_m)` metres from the origin in the grid frame.
    /// Non-finite input gives cell 0 in that axis; indices saturate at the i32 range.
    pub fn cell_of_xy(&self, east_m: f64, north_m: f64) -> Cell {
        Cell::new(
            index_of(north_m, self.cell_size),
            index_of(east_m, self.cell_size),
        )
    }

    /// The cell that contains `u`, which should be in the grid's zone and hemisphere. A
    /// coordinate in the other hemisphere of the same zone is shifted by the false
    /// northing; one in another zone is re-projected through WGS84. Use
    /// `Grid::try_cell_of_utm` for input from files or the network.
    pub fn cell_of_utm(&self, u: &Utm) -> Cell {
        let (e, n) = if u.zone == self.zone {
            (
                u.easting,
                u.northing - u.hemisphere.false_northing() + self.hemisphere.false_northing(),
            )
        } else {
            let p = utm::raw_from_utm(u);
            let dlon = p.lon - utm::central_meridian(self.zone);
            let dlon = (dlon + 180.0).rem_euclid(360.0) - 180.0;
            let f = super::tm::forward(p.lat, dlon);
            (
                utm::FALSE_EASTING + f.x,
                f.y + self.hemisphere.false_northing(),
            )
        };
        self.cell_of_xy(e - self.origin_en.0, n - self.origin_en.1)
    }

    #[cfg(test)]
    /// The cell that contains `u`, strictly: `u` must be finite and in the grid's zone and
    /// hemisphere ([`GeoError::ZoneMismatch`] otherwise).
    pub(crate) fn try_cell_of_utm(&self, u: &Utm) -> Result<Cell, GeoError> {
        for (what, value) in [("easting", u.easting), ("northing", u.northing)] {
            if !value.is_finite() {
                return Err(GeoError::NotFinite { what, value });
            }
        }
        if u.zone != self.zone || u.hemisphere != self.hemisphere {
            return Err(GeoError::ZoneMismatch {
                zone: self.zone,
                hemisphere: self.hemisphere,
                got_zone: u.zone,
                got_hemisphere: u.hemisphere,
            });
        }
        Ok(self.cell_of_utm(u))
    }

    /// `p` in the grid frame: (east, north) metres from the origin along the UTM axes of the
    /// grid's zone.
    pub fn to_xy(&self, p: LatLon) -> Result<(f64, f64), GeoError> {
        let u = utm::to_utm_in_zone(p, self.zone, self.hemisphere)?;
        Ok((u.easting - self.origin_en.0, u.northing - self.origin_en.1))
    }

    /// The WGS84 position `east_m`, `north_m` metres from the origin in the grid frame.
    pub fn from_xy(&self, east_m: f64, north_m: f64) -> Result<LatLon, GeoError> {
        for (what, value) in [("east offset", east_m), ("north offset", north_m)] {
            if !value.is_finite() {
                return Err(GeoError::NotFinite { what, value });
            }
        }
        utm::from_utm(&self.utm_at(self.origin_en.0 + east_m, self.origin_en.1 + north_m))
    }

    /// The corners of cell `c` in the order south-west, south-east, north-east, north-west
    /// (counter-clockwise), degrees. Infallible like [`Grid::cell_center`].
    pub(crate) fn cell_corners(&self, c: Cell) -> [LatLon; 4] {
        let h = self.cell_size / 2.0;
        let ctr = self.cell_center_utm(c);
        [(-h, -h), (h, -h), (h, h), (-h, h)]
            .map(|(de, dn)| utm::raw_from_utm(&self.utm_at(ctr.easting + de, ctr.northing + dn)))
    }

    /// Meridian convergence (degrees, clockwise from true north to grid north) and UTM scale
    /// factor at `p` in the grid's zone: a true heading `h` runs at `h − γ` across the grid.
    pub fn convergence_and_scale(&self, p: LatLon) -> Result<(f64, f64), GeoError> {
        utm::convergence_and_scale(p, self.zone)
    }

    #[cfg(test)]
    /// The cells whose squares overlap the rectangle `[min_east, max_east] × [min_north,
    /// max_north]` (metres from the origin in the grid frame), sorted by cell. A rectangle
    /// that only touches a cell's edge does not overlap it.
    pub(crate) fn cells_in_xy_rect(
        &self,
        min_east: f64,
        min_north: f64,
        max_east: f64,
        max_north: f64,
    ) -> Result<Vec<Cell>, GeoError> {
        for (what, value) in [
            ("min_east", min_east),
            ("min_north", min_north),
            ("max_east", max_east),
            ("max_north", max_north),
        ] {
            if !value.is_finite() {
                return Err(GeoError::NotFinite { what, value });
            }
        }
        if min_east > max_east || min_north > max_north {
            return Err(GeoError::Polygon(format!(
                "rectangle has min > max (east {min_east}..{max_east}, north {min_north}..{max_north})"
            )));
        }
        let s = self.cell_size;
        // A cell k overlaps [lo, hi] iff (k − ½)s < hi and (k + ½)s > lo.
        let lo_idx = |lo: f64| (lo / s - 0.5).floor() as i64 + 1;
        let hi_idx = |hi: f64| (hi / s + 0.5).ceil() as i64 - 1;
        let (c0, c1) = (lo_idx(min_east), hi_idx(max_east));
        let (r0, r1) = (lo_idx(min_north), hi_idx(max_north));
        let count = ((c1 - c0 + 1).max(0) as u64) * ((r1 - r0 + 1).max(0) as u64);
        if count > MAX_COVERAGE_CELLS {
            return Err(GeoError::TooManyCells {
                what: "the rectangle",
                count,
                max: MAX_COVERAGE_CELLS,
            });
        }
        let mut out = Vec::with_capacity(count as usize);
        for r in r0..=r1 {
            for c in c0..=c1 {
                out.push(Cell::new(r as i32, c as i32));
            }
        }
        Ok(out)
    }

    /// The cells a WGS84 polygon touches, each with the fraction of the cell's area it covers
    /// (0 < fraction ≤ 1), sorted by cell. This is how a ground-truth region is compared
    /// with a map.
    ///
    /// The vertices are projected into the grid's UTM frame and joined by straight lines
    /// there, then each candidate cell square is intersected with the polygon (geo's
    /// boolean operations, i_overlay) and its area measured. A straight line in UTM differs
    /// from the geodesic between the same vertices by at most about L²·x/(8R²) (L the edge
    /// length, x the distance from the central meridian, R ≈ 6 371 km): 9 µm for a 100 m edge
    /// at a zone edge, about 1 mm for a 1 km edge — well under a millimetre for field-sized
    /// polygons. The ring may be given closed or open, in either orientation; it must have
    /// at least 3 distinct vertices and not intersect itself (self-intersecting rings are
    /// filled with the even-odd rule). Cells touched only along an edge or at a corner
    /// (fraction ≤ `COVERAGE_EPS`) are not listed.
    pub fn polygon_coverage(&self, polygon: &[LatLon]) -> Result<Vec<(Cell, f64)>, GeoError> {
        let mut ring: Vec<Coord<f64>> = Vec::with_capacity(polygon.len() + 1);
        for (i, p) in polygon.iter().enumerate() {
            let (x, y) = self.to_xy(*p).map_err(|e| {
                GeoError::Polygon(format!("vertex {i} ({}, {}): {e}", p.lat, p.lon))
            })?;
            let c = Coord { x, y };
            if ring.last() != Some(&c) {
                ring.push(c);
            }
        }
        if ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        if ring.len() < 3 {
            return Err(GeoError::Polygon(format!(
                "{} distinct vertices, at least 3 are needed",
                ring.len()
            )));
        }
        let poly = Polygon::new(LineString::new(ring), vec![]);
        let Some(bb) = poly.bounding_rect() else {
            return Ok(Vec::new());
        };
        let s = self.cell_size;
        let col0 = index_of(bb.min().x, s);
        let col1 = index_of(bb.max().x, s);
        let row0 = index_of(bb.min().y, s);
        let row1 = index_of(bb.max().y, s);
        let count = (i64::from(col1) - i64::from(col0) + 1) as u64
            * (i64::from(row1) - i64::from(row0) + 1) as u64;
        if count > MAX_COVERAGE_CELLS {
            return Err(GeoError::TooManyCells {
                what: "the polygon's bounding box",
                count,
                max: MAX_COVERAGE_CELLS,
            });
        }
        let cell_area = s * s;
        let mut out = Vec::new();
        for row in row0..=row1 {
            // Clip to the row's strip first, then to each cell of the strip's extent.
            let y0 = (f64::from(row) - 0.5) * s;
            let strip = Rect::new(
                Coord {
                    x: bb.min().x - s,
                    y: y0,
                },
                Coord {
                    x: bb.max().x + s,
                    y: y0 + s,
                },
            )
            .to_polygon();
            let part: MultiPolygon<f64> = poly.intersection(&strip);
            if part.unsigned_area() <= COVERAGE_EPS * cell_area {
                continue;
            }
            let Some(pb) = part.bounding_rect() else {
                continue;
            };
            for col in index_of(pb.min().x, s)..=index_of(pb.max().x, s) {
                let x0 = (f64::from(col) - 0.5) * s;
                let cell = Rect::new(
                    Coord { x: x0, y: y0 },
                    Coord {
                        x: x0 + s,
                        y: y0 + s,
                    },
                )
                .to_polygon();
                let a = part.intersection(&cell).unsigned_area();
                let frac = (a / cell_area).min(1.0);
                if frac > COVERAGE_EPS {
                    out.push((Cell::new(row, col), frac));
                }
            }
        }
        Ok(out)
    }

    /// Is the centre of `c` inside the UTM domain and the zone's supported extent?
    pub fn cell_in_domain(&self, c: Cell) -> bool {
        let (lat, dlon) = utm::raw_inverse(&self.cell_center_utm(c));
        (MIN_LAT..=MAX_LAT).contains(&lat) && dlon.abs() <= utm::MAX_ZONE_OFFSET_DEG
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        Grid::new(LatLon::new(37.1968, -80.5781), 4.0).unwrap()
    }

    #[test]
    fn origin_is_centre_of_cell_zero() {
        let g = grid();
        assert_eq!(g.zone(), 17);
        assert_eq!(g.hemisphere(), Hemisphere::North);
        assert_eq!(g.cell_of(g.origin()), Ok(Cell::new(0, 0)));
        let c = g.cell_center(Cell::new(0, 0));
        assert!((c.lat - 37.1968).abs() < 1e-12 && (c.lon + 80.5781).abs() < 1e-12);
        let u = g.cell_center_utm(Cell::new(-3, 7));
        let o = g.origin_utm();
        assert_eq!(u.easting - o.easting, 28.0);
        assert_eq!(u.northing - o.northing, -12.0);
    }

    #[test]
    fn half_open_boundaries() {
        let g = grid();
        assert_eq!(g.cell_of_xy(1.999_999, 0.0), Cell::new(0, 0));
        assert_eq!(g.cell_of_xy(2.0, 0.0), Cell::new(0, 1));
        assert_eq!(g.cell_of_xy(-2.0, 0.0), Cell::new(0, 0));
        assert_eq!(g.cell_of_xy(-2.000_001, 0.0), Cell::new(0, -1));
        assert_eq!(g.cell_of_xy(0.0, -6.0), Cell::new(-1, 0));
        assert_eq!(g.cell_of_xy(0.0, -6.000_001), Cell::new(-2, 0));
        assert_eq!(g.cell_of_xy(f64::NAN, 1e300), Cell::new(i32::MAX, 0));
    }

    #[test]
    fn bad_grids() {
        let o = LatLon::new(37.0, -80.0);
        assert_eq!(
            Grid::new(o, 0.0),
            Err(GeoError::CellSizeNotPositive { size: 0.0 })
        );
        assert_eq!(
            Grid::new(o, -4.0),
            Err(GeoError::CellSizeNotPositive { size: -4.0 })
        );
        assert!(matches!(
            Grid::new(o, f64::NAN),
            Err(GeoError::NotFinite { .. })
        ));
        assert!(matches!(
            Grid::new(o, 1e-6),
            Err(GeoError::CellSizeOutOfRange { .. })
        ));
        assert!(matches!(
            Grid::new(LatLon::new(95.0, 0.0), 4.0),
            Err(GeoError::LatitudeOutOfRange { .. })
        ));
        assert!(matches!(
            Grid::new(LatLon::new(85.0, 0.0), 4.0),
            Err(GeoError::OutsideUtm { .. })
        ));
    }

    #[test]
    fn serde_round_trip_and_validation() {
        let g = grid();
        let j = serde_json::to_string(&g).unwrap();
        assert_eq!(
            j,
            r#"{"origin":{"lat":37.1968,"lon":-80.5781},"cell_size_m":4.0,"zone":17,"hemisphere":"N"}"#
        );
        let back: Grid = serde_json::from_str(&j).unwrap();
        assert_eq!(back, g);
        let bare: Grid =
            serde_json::from_str(r#"{"origin":{"lat":37.1968,"lon":-80.5781},"cell_size_m":4}"#)
                .unwrap();
        assert_eq!(bare, g);
        let err = serde_json::from_str::<Grid>(
            r#"{"origin":{"lat":37.1968,"lon":-80.5781},"cell_size_m":0}"#,
        )
        .unwrap_err();
        assert!(err.to_string().contains("cell size"), "{err}");
        let forced: Grid = serde_json::from_str(
            r#"{"origin":{"lat":37.1968,"lon":-80.5781},"cell_size_m":4,"zone":18}"#,
        )
        .unwrap();
        assert_eq!(forced.zone(), 18);
    }

    #[test]
    fn zone_and_hemisphere_stay_fixed() {
        // Origin 1 km west of the 12°E edge (zone 32 at 45°N); cells 2 km east are in zone 33.
        let g = Grid::new(LatLon::new(45.0, 11.987), 10.0).unwrap();
        assert_eq!(g.zone(), 32);
        let east = g.cell_center(Cell::new(0, 200));
        assert!(east.lon > 12.0);
        assert_eq!(g.cell_of(east), Ok(Cell::new(0, 200)));
        assert_eq!(g.cell_center_utm(Cell::new(0, 200)).zone, 32);
        // A northern grid on the equator reaches south with negative northings.
        let eq = Grid::new(LatLon::new(0.000_1, 30.0), 5.0).unwrap();
        let south = eq.cell_center_utm(Cell::new(-10, 0));
        assert!(south.northing < 0.0 && south.hemisphere == Hemisphere::North);
        let p = eq.cell_center(Cell::new(-10, 0));
        assert!(p.lat < 0.0);
        assert_eq!(eq.cell_of(p), Ok(Cell::new(-10, 0)));
        // The same point given in its own (southern, neighbouring) frame maps to the same cell.
        let u = utm::to_utm(p).unwrap();
        assert_eq!(u.hemisphere, Hemisphere::South);
        assert_eq!(eq.cell_of_utm(&u), Cell::new(-10, 0));
        assert!(matches!(
            eq.try_cell_of_utm(&u),
            Err(GeoError::ZoneMismatch { .. })
        ));
        let other_zone = utm::to_utm_in_zone(p, 37, Hemisphere::South).unwrap();
        assert_eq!(eq.cell_of_utm(&other_zone), Cell::new(-10, 0));
    }

    #[test]
    fn corners_surround_the_centre() {
        let g = grid();
        let c = Cell::new(-2, 5);
        let [sw, se, ne, nw] = g.cell_corners(c);
        let ctr = g.cell_center(c);
        assert!(sw.lat < ctr.lat && nw.lat > ctr.lat && sw.lon < ctr.lon && se.lon > ctr.lon);
        assert!(ne.lat > ctr.lat && ne.lon > ctr.lon);
        let (e, n) = g.to_xy(ne).unwrap();
        assert!((e - 22.0).abs() < 1e-6 && (n + 6.0).abs() < 1e-6);
    }

    #[test]
    fn diamond_coverage_is_analytic() {
        // |x| + |y| ≤ s around the centre of cell (0, 0): the cell itself is fully covered,
        // its four edge neighbours a quarter each, the diagonal ones touch at a point only.
        let g = grid();
        let s = g.cell_size();
        let poly: Vec<LatLon> = [(s, 0.0), (0.0, s), (-s, 0.0), (0.0, -s)]
            .iter()
            .map(|&(e, n)| g.from_xy(e, n).unwrap())
            .collect();
        let cov = g.polygon_coverage(&poly).unwrap();
        let expect = [
            (Cell::new(-1, 0), 0.25),
            (Cell::new(0, -1), 0.25),
            (Cell::new(0, 0), 1.0),
            (Cell::new(0, 1), 0.25),
            (Cell::new(1, 0), 0.25),
        ];
        assert_eq!(cov.len(), expect.len(), "{cov:?}");
        for ((c, f), (ce, fe)) in cov.iter().zip(expect) {
            assert_eq!(*c, ce);
            assert!((f - fe).abs() < 1e-6, "{c}: {f} vs {fe}");
        }
    }

    #[test]
    fn bad_polygons() {
        let g = grid();
        let o = g.origin();
        assert!(matches!(
            g.polygon_coverage(&[o, o, o]),
            Err(GeoError::Polygon(_))
        ));
        let bad = [o, LatLon::new(91.0, 0.0), LatLon::new(37.0, -80.0)];
        let e = g.polygon_coverage(&bad).unwrap_err().to_string();
        assert!(e.contains("vertex 1"), "{e}");
        let huge = [
            g.from_xy(-50_000.0, -50_000.0).unwrap(),
            g.from_xy(50_000.0, -50_000.0).unwrap(),
            g.from_xy(0.0, 50_000.0).unwrap(),
        ];
        assert!(matches!(
            g.polygon_coverage(&huge),
            Err(GeoError::TooManyCells { .. })
        ));
    }

    #[test]
    fn rect_cells() {
        let g = grid();
        let cells = g.cells_in_xy_rect(-2.0, -2.0, 2.0, 2.0).unwrap();
        assert_eq!(cells, vec![Cell::new(0, 0)]);
        let cells = g.cells_in_xy_rect(-2.1, 0.0, 6.5, 1.0).unwrap();
        assert_eq!(
            cells,
            vec![
                Cell::new(0, -1),
                Cell::new(0, 0),
                Cell::new(0, 1),
                Cell::new(0, 2)
            ]
        );
    }
}
