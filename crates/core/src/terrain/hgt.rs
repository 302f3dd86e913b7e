//! SRTM `.hgt` tiles: one degree of latitude and longitude of ground heights.
//!
//! A tile is named by its south-west corner (`N47E008.hgt` covers 47–48° N, 8–9° E;
//! `S36E149.hgt` covers 36–35° S, 149–150° E) and holds a square of big-endian signed 16-bit
//! heights in metres above mean sea level, row by row from the **north** edge to the south,
//! each row from the west edge to the east: 1201 × 1201 samples (SRTM3, 3 arc-seconds) or
//! 3601 × 3601 (SRTM1, 1 arc-second). The edges are shared with the neighbouring tiles, and
//! -32768 marks a void (no measurement). That is the layout Mission Planner reads
//! (`ExtLibs/Utilities/srtm.cs`) and MAVProxy's `srtm.py`; ArduPilot's
//! `libraries/AP_Terrain/tools/create_terrain.py` reads the same tiles to build its own
//! terrain cache.
//!
//! A height between samples is interpolated bilinearly from the four around it, as those
//! readers do; a void among the four makes the height unknown.

use std::fmt;

/// The value of a sample with no measurement.
pub const VOID: i16 = -32768;

/// Samples on a side of an SRTM3 (3 arc-second) tile.
pub const SRTM3_SIDE: usize = 1201;
/// Samples on a side of an SRTM1 (1 arc-second) tile.
pub const SRTM1_SIDE: usize = 3601;

/// What is wrong with a tile's name or bytes.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HgtError {
    /// Not a tile name like `N47E008` or `S36W122`.
    #[error("{0:?} is not an SRTM tile name (like N47E008 or S36W122)")]
    Name(String),
    /// A size that is neither SRTM3 nor SRTM1.
    #[error(
        "{bytes} bytes is not an SRTM tile: 1201 × 1201 (SRTM3, 2 884 802 bytes) or 3601 × 3601 \
         (SRTM1, 25 934 402 bytes) big-endian 16-bit samples"
    )]
    Size {
        /// The length of what was read.
        bytes: usize,
    },
}

/// A tile by its south-west corner, whole degrees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TileId {
    /// Latitude of the south edge, degrees (−90 … 89).
    pub lat: i16,
    /// Longitude of the west edge, degrees (−180 … 179).
    pub lon: i16,
}

impl TileId {
    /// The tile a point lies in (a point on an edge belongs to the tile north or east of it).
    pub fn containing(lat: f64, lon: f64) -> TileId {
        let lat = lat.floor().clamp(-90.0, 89.0) as i16;
        // wrap longitude into −180 … 179
        let lon = ((lon.floor() as i64 + 180).rem_euclid(360) - 180) as i16;
        TileId { lat, lon }
    }

    /// Parse a tile name (`N47E008`, case-insensitive), without its extension.
    pub fn parse(name: &str) -> Result<TileId, HgtError> {
        let bad = || HgtError::Name(name.to_string());
        let b = name.as_bytes();
        if b.len() != 7 || !name.is_ascii() {
            return Err(bad());
        }
        let ns = match b[0].to_ascii_uppercase() {
            b'N' => 1,
            b'S' => -1,
            _ => return Err(bad()),
        };
        let ew = match b[3].to_ascii_uppercase() {
            b'E' => 1,
            b'W' => -1,
            _ => return Err(bad()),
        };
        let lat: i16 = name[1..3].parse().map_err(|_| bad())?;
        let lon: i16 = name[4..7].parse().map_err(|_| bad())?;
        let (lat, lon) = (ns * lat, ew * lon);
        if !(-90..=89).contains(&lat) || !(-180..=179).contains(&lon) {
            return Err(bad());
        }
        Ok(TileId { lat, lon })
    }

    /// The tile's file name: `N47E008.hgt`.
    pub fn file_name(&self) -> String {
        format!("{self}.hgt")
    }
}

impl fmt::Display for TileId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ns = if self.lat < 0 { 'S' } else { 'N' };
        let ew = if self.lon < 0 { 'W' } else { 'E' };
        write!(
            f,
            "{ns}{:02}{ew}{:03}",
            self.lat.unsigned_abs(),
            self.lon.unsigned_abs()
        )
    }
}

/// One tile's samples.
#[derive(Clone, PartialEq, Eq)]
pub struct Tile {
    id: TileId,
    side: usize,
    /// Row-major from the north-west corner.
    samples: Vec<i16>,
}

impl fmt::Debug for Tile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Tile({}, {}×{})", self.id, self.side, self.side)
    }
}

impl Tile {
    /// A tile from the bytes of its `.hgt` file.
    pub fn from_hgt(id: TileId, bytes: &[u8]) -> Result<Tile, HgtError> {
        let side = match bytes.len() {
            n if n == SRTM3_SIDE * SRTM3_SIDE * 2 => SRTM3_SIDE,
            n if n == SRTM1_SIDE * SRTM1_SIDE * 2 => SRTM1_SIDE,
            bytes => return Err(HgtError::Size { bytes }),
        };
        let samples = bytes
            .chunks_exact(2)
            .map(|c| i16::from_be_bytes([c[0], c[1]]))
            .collect();
        Ok(Tile { id, side, samples })
    }

    /// A tile of `side` × `side` samples (1201 or 3601) given row by row from the north-west
    /// corner; `None` if the count is wrong. For tools and tests that make tiles.
    pub fn from_samples(id: TileId, side: usize, samples: Vec<i16>) -> Option<Tile> {
        ((side == SRTM3_SIDE || side == SRTM1_SIDE) && samples.len() == side * side)
            .then_some(Tile { id, side, samples })
    }

    /// The tile's bytes as a `.hgt` file holds them.
    pub fn to_hgt(&self) -> Vec<u8> {
        self.samples.iter().flat_map(|s| s.to_be_bytes()).collect()
    }

    /// Which tile this is.
    pub fn id(&self) -> TileId {
        self.id
    }

    /// Samples on a side (1201 or 3601).
    pub fn side(&self) -> usize {
        self.side
    }

    /// Sample `row` (0 at the north edge), `col` (0 at the west edge); `None` for a void or
    /// outside the tile.
    pub fn sample(&self, row: usize, col: usize) -> Option<i16> {
        if row >= self.side || col >= self.side {
            return None;
        }
        let v = self.samples[row * self.side + col];
        (v != VOID).then_some(v)
    }

    /// The ground height at a point of this tile, metres AMSL, interpolated bilinearly
    /// between the four samples around it; `None` outside the tile or when one of the four
    /// is a void.
    pub fn height(&self, lat: f64, lon: f64) -> Option<f64> {
        let n = (self.side - 1) as f64;
        // position in samples from the south-west corner
        let y = (lat - f64::from(self.id.lat)) * n;
        let x = (lon - f64::from(self.id.lon)) * n;
        // (NaN is in no range)
        if !((0.0..=n).contains(&y) && (0.0..=n).contains(&x)) {
            return None;
        }
        // the cell's south-west sample, kept inside on the north and east edges
        let (y0, x0) = (y.floor().min(n - 1.0), x.floor().min(n - 1.0));
        let (fy, fx) = (y - y0, x - x0);
        let (y0, x0) = (y0 as usize, x0 as usize);
        let row_s = self.side - 1 - y0; // rows count from the north
        let row_n = row_s - 1;
        let sw = f64::from(self.sample(row_s, x0)?);
        let se = f64::from(self.sample(row_s, x0 + 1)?);
        let nw = f64::from(self.sample(row_n, x0)?);
        let ne = f64::from(self.sample(row_n, x0 + 1)?);
        let south = sw + (se - sw) * fx;
        let north = nw + (ne - nw) * fx;
        Some(south + (north - south) * fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_read_and_print_both_hemispheres() {
        for (name, lat, lon) in [
            ("N47E008", 47, 8),
            ("S36E149", -36, 149),
            ("N47W122", 47, -122),
            ("s01w001", -1, -1),
            ("N00E000", 0, 0),
        ] {
            let id = TileId::parse(name).unwrap();
            assert_eq!((id.lat, id.lon), (lat, lon), "{name}");
            assert_eq!(id.to_string(), name.to_ascii_uppercase());
        }
        for bad in [
            "N47E08", "X47E008", "N47X008", "N9aE008", "N90E000", "S00E180", "",
        ] {
            assert!(TileId::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(
            TileId::containing(-35.363261, 149.16523).file_name(),
            "S36E149.hgt"
        );
        assert_eq!(TileId::containing(47.0, 8.0).to_string(), "N47E008");
        assert_eq!(TileId::containing(47.63, -122.08).to_string(), "N47W123");
        assert_eq!(TileId::containing(10.0, 180.0).to_string(), "N10W180");
    }

    fn ramp(side: usize) -> Tile {
        // height = 2 × (metres-ish index east) + row-from-south
        let samples = (0..side * side)
            .map(|i| {
                let (row, col) = (i / side, i % side);
                (2 * col + (side - 1 - row)) as i16
            })
            .collect();
        Tile::from_samples(TileId { lat: 47, lon: 8 }, side, samples).unwrap()
    }

    #[test]
    fn bytes_are_big_endian_rows_from_the_north() {
        let t = ramp(SRTM3_SIDE);
        let bytes = t.to_hgt();
        assert_eq!(bytes.len(), 2_884_802);
        assert_eq!(Tile::from_hgt(t.id(), &bytes).unwrap(), t);
        // the first sample is the north-west corner: row-from-south 1200, col 0
        assert_eq!(i16::from_be_bytes([bytes[0], bytes[1]]), 1200);
        assert_eq!(
            Tile::from_hgt(t.id(), &bytes[..100]),
            Err(HgtError::Size { bytes: 100 })
        );
        // corners and a point between samples
        assert_eq!(t.height(47.0, 8.0), Some(0.0));
        assert_eq!(t.height(48.0, 9.0), Some(3600.0));
        assert_eq!(t.height(47.0, 9.0), Some(2400.0));
        let h = t.height(47.0 + 0.5 / 1200.0, 8.0 + 0.25 / 1200.0).unwrap();
        assert!((h - 1.0).abs() < 1e-9, "{h}");
        assert_eq!(t.height(46.99, 8.5), None);
        assert_eq!(t.height(47.5, 9.01), None);
    }

    #[test]
    fn srtm1_tiles_and_voids() {
        let mut samples = vec![100i16; SRTM1_SIDE * SRTM1_SIDE];
        // a void at row 10, col 20 (north-west area)
        samples[10 * SRTM1_SIDE + 20] = VOID;
        let t = Tile::from_hgt(
            TileId { lat: -36, lon: 149 },
            &samples
                .iter()
                .flat_map(|s| s.to_be_bytes())
                .collect::<Vec<_>>(),
        )
        .unwrap();
        assert_eq!(t.side(), SRTM1_SIDE);
        assert_eq!(t.sample(10, 20), None);
        assert_eq!(t.sample(10, 21), Some(100));
        let lat_of_row = |r: f64| -35.0 - r / 3600.0;
        let lon_of_col = |c: f64| 149.0 + c / 3600.0;
        assert_eq!(t.height(lat_of_row(10.5), lon_of_col(20.5)), None);
        assert_eq!(t.height(lat_of_row(10.5), lon_of_col(21.5)), Some(100.0));
    }
}
