//! The mission grid: square cells anchored at a UTM origin, and conversions between cells,
//! UTM coordinates and WGS84 latitude/longitude.
//!
//! Conventions (docs/grid.md): the origin is the centre of cell (0, 0); rows grow north and
//! columns grow east; cell (row, col) has its centre at origin + (col·s, row·s) in
//! (easting, northing); indices may be negative.
//!
//! Modules:
//! - [`utm`]: WGS84 ↔ UTM with Krüger's series to n⁶ (agrees with PROJ to nanometres; the
//!   measured numbers are in docs/results/geo.md), zone rules with the Norway/Svalbard
//!   exceptions, and forced-zone conversion for grids that reach into the next zone.
//! - [`Grid`] (in `grid.rs`): cells ↔ UTM ↔ WGS84, point → cell, polygon → covered cells.
//! - [`export`]: cells and polygons → GeoJSON (RFC 7946) and KML (Google Earth, QGIS).
//! - [`local`]: tangent-plane offsets for vehicle motion (not for cells).

pub mod export;
mod grid;
pub mod local;
mod tm;
pub mod utm;

pub use grid::Grid;

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A WGS84 position: latitude and longitude in degrees (north and east positive). The one
/// position type of the grid, the mission definitions (`{ lat = …, lon = … }`, other keys
/// refused) and the GCS.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LatLon {
    /// Latitude in degrees, −90..=90 (UTM needs −80..=84).
    pub lat: f64,
    /// Longitude in degrees, −180..=180.
    pub lon: f64,
}

impl LatLon {
    /// The position (`lat`, `lon`) in degrees (not validated; see [`LatLon::validate`]).
    pub const fn new(lat: f64, lon: f64) -> LatLon {
        LatLon { lat, lon }
    }

    /// Check that both numbers are finite, the latitude is within -90..=90° and the
    /// longitude within −180..=180°.
    pub fn validate(self) -> Result<LatLon, GeoError> {
        if !self.lat.is_finite() {
            return Err(GeoError::NotFinite {
                what: "latitude",
                value: self.lat,
            });
        }
        if !self.lon.is_finite() {
            return Err(GeoError::NotFinite {
                what: "longitude",
                value: self.lon,
            });
        }
        if !(-90.0..=90.0).contains(&self.lat) {
            return Err(GeoError::LatitudeOutOfRange { lat: self.lat });
        }
        if !(-180.0..=180.0).contains(&self.lon) {
            return Err(GeoError::LongitudeOutOfRange { lon: self.lon });
        }
        Ok(self)
    }
}

impl fmt::Display for LatLon {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.lat, self.lon)
    }
}

impl FromStr for LatLon {
    type Err = GeoError;

    /// Parse `"LAT,LON"` in degrees (spaces allowed around the numbers), validated.
    fn from_str(s: &str) -> Result<LatLon, GeoError> {
        let parse_err = |why: &str| GeoError::Parse {
            input: s.to_string(),
            expected: format!("LAT,LON in decimal degrees, e.g. 37.1968,-80.5781 ({why})"),
        };
        let (lat, lon) = s.split_once(',').ok_or_else(|| parse_err("no comma"))?;
        let lat: f64 = lat
            .trim()
            .parse()
            .map_err(|_| parse_err("the latitude is not a number"))?;
        let lon: f64 = lon
            .trim()
            .parse()
            .map_err(|_| parse_err("the longitude is not a number"))?;
        LatLon::new(lat, lon).validate()
    }
}

/// The UTM hemisphere: selects the false northing (0 m north, 10 000 000 m south).
/// Written `"N"` / `"S"` in JSON and on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Hemisphere {
    /// Northern hemisphere (false northing 0 m).
    #[serde(rename = "N", alias = "north")]
    North,
    /// Southern hemisphere (false northing 10 000 000 m).
    #[serde(rename = "S", alias = "south")]
    South,
}

impl Hemisphere {
    /// The hemisphere of a latitude in degrees (the equator is north, as in PROJ/EPSG).
    pub fn of_lat(lat: f64) -> Hemisphere {
        if lat >= 0.0 {
            Hemisphere::North
        } else {
            Hemisphere::South
        }
    }

    /// The false northing in metres: 0 north, 10 000 000 south.
    pub(crate) const fn false_northing(self) -> f64 {
        match self {
            Hemisphere::North => 0.0,
            Hemisphere::South => 10_000_000.0,
        }
    }

    /// `'N'` or `'S'`.
    pub const fn letter(self) -> char {
        match self {
            Hemisphere::North => 'N',
            Hemisphere::South => 'S',
        }
    }
}

impl fmt::Display for Hemisphere {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.letter())
    }
}

impl FromStr for Hemisphere {
    type Err = GeoError;

    /// `N`/`S` or `north`/`south` (any case).
    fn from_str(s: &str) -> Result<Hemisphere, GeoError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "n" | "north" => Ok(Hemisphere::North),
            "s" | "south" => Ok(Hemisphere::South),
            _ => Err(GeoError::Parse {
                input: s.to_string(),
                expected: "a hemisphere: N or S".to_string(),
            }),
        }
    }
}

/// A UTM coordinate: easting and northing in metres (false easting 500 000 m, false northing
/// per [`Hemisphere`]), in `zone` (1..=60).
///
/// A grid keeps its origin's zone and hemisphere for all its cells, so a `Utm` produced by a
/// [`Grid`] may lie outside its zone's 6° band (forced zone) or have a negative northing (a
/// northern grid reaching south of the equator).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Utm {
    /// Easting in metres (500 000 m on the central meridian).
    pub easting: f64,
    /// Northing in metres (0 m at the equator north, 10 000 000 m at the equator south).
    pub northing: f64,
    /// UTM zone number, 1..=60.
    pub zone: u8,
    /// Hemisphere (false northing).
    pub hemisphere: Hemisphere,
}

impl fmt::Display for Utm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}{} {:.3} E {:.3} N",
            self.zone, self.hemisphere, self.easting, self.northing
        )
    }
}

/// What went wrong in a geodetic conversion or a grid operation.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GeoError {
    /// A number that must be finite is NaN or infinite.
    #[error("{what} must be a finite number, got {value}")]
    NotFinite {
        /// Which quantity (e.g. "latitude").
        what: &'static str,
        /// The value received.
        value: f64,
    },
    /// Latitude outside −90..=90°.
    #[error("latitude {lat}° is out of range: expected -90..=90°")]
    LatitudeOutOfRange {
        /// The latitude received, degrees.
        lat: f64,
    },
    /// Longitude outside −180..=180°.
    #[error("longitude {lon}° is out of range: expected -180..=180°")]
    LongitudeOutOfRange {
        /// The longitude received, degrees.
        lon: f64,
    },
    /// Latitude outside the UTM domain 80°S..=84°N (UPS covers the poles; fleetmap does not).
    #[error("latitude {lat}° is outside UTM, which is defined from 80°S to 84°N")]
    OutsideUtm {
        /// The latitude, degrees.
        lat: f64,
    },
    /// A zone number outside 1..=60.
    #[error("UTM zone {zone} does not exist: expected 1..=60")]
    InvalidZone {
        /// The zone received.
        zone: u8,
    },
    /// A point too far from the central meridian of a forced zone.
    #[error(
        "longitude {lon}° is {offset_deg:.3}° from the central meridian of UTM zone {zone}: \
         at most {max_deg}° is supported"
    )]
    TooFarFromZone {
        /// The longitude, degrees.
        lon: f64,
        /// The zone.
        zone: u8,
        /// Distance from the central meridian, degrees.
        offset_deg: f64,
        /// The limit, degrees (`utm::MAX_ZONE_OFFSET_DEG`).
        max_deg: f64,
    },
    /// A UTM coordinate in a different zone or hemisphere than required.
    #[error("UTM coordinate is in zone {got_zone}{got_hemisphere}, expected {zone}{hemisphere}")]
    ZoneMismatch {
        /// The zone required (the grid's).
        zone: u8,
        /// The hemisphere required.
        hemisphere: Hemisphere,
        /// The zone received.
        got_zone: u8,
        /// The hemisphere received.
        got_hemisphere: Hemisphere,
    },
    /// A cell size that is zero or negative.
    #[error("cell size must be greater than 0 m, got {size} m")]
    CellSizeNotPositive {
        /// The size received, metres.
        size: f64,
    },
    /// A cell size outside the supported range.
    #[error(
        "cell size {size} m is out of range: expected {min}..={max} m",
        min = grid::MIN_CELL_SIZE_M,
        max = grid::MAX_CELL_SIZE_M
    )]
    CellSizeOutOfRange {
        /// The size received, metres.
        size: f64,
    },
    /// A polygon that cannot be used.
    #[error("invalid polygon: {0}")]
    Polygon(String),
    /// A request that would enumerate too many cells.
    #[error("{what} spans {count} cells, more than the limit of {max}")]
    TooManyCells {
        /// What was asked.
        what: &'static str,
        /// How many cells it would take.
        count: u64,
        /// The limit.
        max: u64,
    },
    /// Text that does not parse.
    #[error("cannot parse {input:?}: expected {expected}")]
    Parse {
        /// The text received.
        input: String,
        /// What was expected.
        expected: String,
    },
}

/// A grid cell index: `row` grows north, `col` grows east; both may be negative.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Cell {
    /// Row index (northward).
    pub row: i32,
    /// Column index (eastward).
    pub col: i32,
}

impl Cell {
    /// The cell at (`row`, `col`).
    pub const fn new(row: i32, col: i32) -> Cell {
        Cell { row, col }
    }

    /// The neighbour one step in direction `d`.
    pub const fn step(self, d: Dir4) -> Cell {
        let (dr, dc) = d.delta();
        Cell {
            row: self.row + dr,
            col: self.col + dc,
        }
    }

    /// The four edge neighbours in the order north, west, south, east.
    pub(crate) fn neighbours4(self) -> [Cell; 4] {
        Dir4::ALL.map(|d| self.step(d))
    }

    #[cfg(test)]
    /// The eight king's-move neighbours (edge and corner), clockwise from north.
    pub(crate) fn neighbours8(self) -> [Cell; 8] {
        const D: [(i32, i32); 8] = [
            (1, 0),
            (1, 1),
            (0, 1),
            (-1, 1),
            (-1, 0),
            (-1, -1),
            (0, -1),
            (1, -1),
        ];
        D.map(|(dr, dc)| Cell::new(self.row + dr, self.col + dc))
    }

    /// Manhattan (4-neighbour) distance in cells.
    pub fn manhattan(self, other: Cell) -> u32 {
        self.row.abs_diff(other.row) + self.col.abs_diff(other.col)
    }

    #[cfg(test)]
    /// Chebyshev (king's move) distance in cells.
    pub(crate) fn chebyshev(self, other: Cell) -> u32 {
        self.row
            .abs_diff(other.row)
            .max(self.col.abs_diff(other.col))
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}, {})", self.row, self.col)
    }
}

/// A grid direction: one of the four edge neighbours of a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dir4 {
    /// Row + 1.
    North,
    /// Column − 1.
    West,
    /// Row − 1.
    South,
    /// Column + 1.
    East,
}

impl Dir4 {
    /// North, west, south, east: counter-clockwise from north.
    pub const ALL: [Dir4; 4] = [Dir4::North, Dir4::West, Dir4::South, Dir4::East];

    /// (Δrow, Δcol) of one step in this direction.
    pub const fn delta(self) -> (i32, i32) {
        match self {
            Dir4::North => (1, 0),
            Dir4::West => (0, -1),
            Dir4::South => (-1, 0),
            Dir4::East => (0, 1),
        }
    }

    #[cfg(test)]
    /// The opposite direction.
    pub(crate) const fn opposite(self) -> Dir4 {
        match self {
            Dir4::North => Dir4::South,
            Dir4::West => Dir4::East,
            Dir4::South => Dir4::North,
            Dir4::East => Dir4::West,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_and_distances() {
        let c = Cell::new(-1, 2);
        assert_eq!(
            c.neighbours4(),
            [
                Cell::new(0, 2),
                Cell::new(-1, 1),
                Cell::new(-2, 2),
                Cell::new(-1, 3)
            ]
        );
        for d in Dir4::ALL {
            assert_eq!(c.step(d).step(d.opposite()), c);
        }
        assert_eq!(c.manhattan(Cell::new(2, 0)), 5);
        assert_eq!(c.chebyshev(Cell::new(2, 0)), 3);
        assert!(c.neighbours8().iter().all(|n| c.chebyshev(*n) == 1));
    }
}
