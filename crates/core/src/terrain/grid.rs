//! The grids of the MAVLink terrain protocol, as ArduPilot asks for them and a GCS answers.
//!
//! ArduPilot's terrain library (`libraries/AP_Terrain`) keeps ground heights in blocks of
//! 28 × 32 points `grid_spacing` metres apart (`TERRAIN_GRID_BLOCK_SIZE_X` north,
//! `_Y` east, `AP_Terrain.h`), each block cut into 7 × 8 squares of 4 × 4 points, one bit
//! each of a 56-bit mask. A TERRAIN_REQUEST names a block by its south-west corner
//! (`lat`, `lon`, 1e-7 degrees) and `grid_spacing`, and sets the bits of the squares it lacks
//! (`AP_Terrain::request_missing`, `TerrainGCS.cpp`). The GCS answers one TERRAIN_DATA per
//! bit, with the request's corner and spacing, the bit (`gridbit`) and 16 heights in metres
//! AMSL. ArduPilot puts `data[4·x + y]` at row `4·(gridbit / 8) + x` (north) and column
//! `4·(gridbit % 8) + y` (east) of the block (`AP_Terrain::handle_terrain_data`; the bit
//! number is `subgrid_y + 8·subgrid_x`, `TerrainUtil.cpp` `grid_bitnum`). So the square of
//! bit `b` starts `4·spacing·(b / 8)` metres north and `4·spacing·(b % 8)` metres east of
//! the corner, and its point `i` lies `spacing·(i / 4)` north and `spacing·(i % 4)` east of
//! that — what Mission Planner (`Utilities/TerrainFollow.cs`, `QueueSendGrid`, `SendGrid`)
//! and MAVProxy (`modules/mavproxy_terrain.py`, `send_terrain_data_bit`) send.
//!
//! Offsets in metres become degrees as ArduPilot's `Location::offset` makes them
//! (`libraries/AP_Common/Location.cpp`: 1e-7 degree of latitude is
//! `LOCATION_SCALING_FACTOR` m, a degree of longitude that times the cosine of the
//! latitude half-way), computed in `f64` and from the corner in one step (Mission Planner
//! and MAVProxy chain two offsets; the difference is far below a sample of SRTM). Heights are
//! rounded to the nearest metre, where Mission Planner and MAVProxy truncate.

/// Points on a side of the square one TERRAIN_DATA carries (`TERRAIN_GRID_MAVLINK_SIZE`).
pub const SQUARE: usize = 4;
/// Squares of a block north (`TERRAIN_GRID_BLOCK_MUL_X`).
pub const SQUARES_NORTH: u8 = 7;
/// Squares of a block east (`TERRAIN_GRID_BLOCK_MUL_Y`).
pub const SQUARES_EAST: u8 = 8;
/// Bits of a request's mask that name squares.
pub const BITS: u8 = SQUARES_NORTH * SQUARES_EAST;

/// Metres per 1e-7 degree of latitude (`LOCATION_SCALING_FACTOR`, `AP_Common/Location.h`).
pub const METRES_PER_E7: f64 = 0.011_131_884_502_145_034;

/// A TERRAIN_REQUEST: which squares of which block the vehicle lacks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Request {
    /// The block's south-west corner, 1e-7 degrees.
    pub lat_e7: i32,
    /// The block's south-west corner, 1e-7 degrees.
    pub lon_e7: i32,
    /// Metres between points.
    pub spacing_m: u16,
    /// Bit `b` set: square `b` is wanted (bits 56 and up mean nothing).
    pub mask: u64,
}

/// One TERRAIN_DATA's content: a square's heights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Square {
    /// The square's bit in the request's mask.
    pub gridbit: u8,
    /// Heights, metres AMSL, `data[4·north + east]`.
    pub heights: [i16; 16],
}

/// A point `north_m`, `east_m` metres from (`lat_e7`, `lon_e7`), degrees.
pub fn offset(lat_e7: i32, lon_e7: i32, north_m: f64, east_m: f64) -> (f64, f64) {
    let dlat = north_m / METRES_PER_E7;
    let mid = (f64::from(lat_e7) + dlat / 2.0) * 1e-7;
    let scale = mid.to_radians().cos().max(0.01); // `longitude_scale`
    let dlon = east_m / METRES_PER_E7 / scale;
    (
        (f64::from(lat_e7) + dlat) * 1e-7,
        (f64::from(lon_e7) + dlon) * 1e-7,
    )
}

/// Points between the corners of neighbouring blocks north and east
/// (`TERRAIN_GRID_BLOCK_SPACING_X`, `_Y`): a block overlaps the next by one square's row.
pub const BLOCK_STEP: (u32, u32) = (
    (SQUARES_NORTH as u32 - 1) * SQUARE as u32,
    (SQUARES_EAST as u32 - 1) * SQUARE as u32,
);

/// The south-west corner (1e-7 degrees) of the block ArduPilot keeps a location in, for
/// points `spacing_m` apart (`AP_Terrain::calculate_grid_info`, `TerrainUtil.cpp`): blocks
/// are laid from the whole degree south-west of the point, every [`BLOCK_STEP`] points, and
/// the point's offset from that degree is measured as `Location::get_distance_NE` measures
/// it. What a vehicle at that location asks for first.
pub fn block_of(lat_e7: i32, lon_e7: i32, spacing_m: u16) -> (i32, i32) {
    let deg = |v: i32| i64::from(v).div_euclid(10_000_000) * 10_000_000;
    let (ref_lat, ref_lon) = (deg(lat_e7), deg(lon_e7));
    let mid = (ref_lat as f64 + f64::from(lat_e7)) / 2.0 * 1e-7;
    let scale = mid.to_radians().cos().max(0.01);
    let north = (f64::from(lat_e7) - ref_lat as f64) * METRES_PER_E7;
    let east = (f64::from(lon_e7) - ref_lon as f64) * METRES_PER_E7 * scale;
    let s = f64::from(spacing_m.max(1));
    let idx_x = (north / s) as u32 / BLOCK_STEP.0;
    let idx_y = (east / s) as u32 / BLOCK_STEP.1;
    // `Location::offset` from the degree, in whole 1e-7 degrees as ArduPilot keeps them
    let dlat = (f64::from(idx_x * BLOCK_STEP.0) * s / METRES_PER_E7) as i64;
    let half = (ref_lat + dlat / 2) as f64 * 1e-7;
    let dlon = (f64::from(idx_y * BLOCK_STEP.1) * s
        / METRES_PER_E7
        / half.to_radians().cos().max(0.01)) as i64;
    ((ref_lat + dlat) as i32, (ref_lon + dlon) as i32)
}

impl Request {
    /// The squares asked for, in bit order.
    pub fn gridbits(&self) -> impl Iterator<Item = u8> + '_ {
        (0..BITS).filter(|b| self.mask & (1u64 << b) != 0)
    }

    /// Where the points of square `gridbit` are, in TERRAIN_DATA's order: (lat, lon) degrees.
    pub fn square_points(&self, gridbit: u8) -> [(f64, f64); 16] {
        let s = f64::from(self.spacing_m);
        let (north0, east0) = (
            (usize::from(gridbit / SQUARES_EAST) * SQUARE) as f64,
            (usize::from(gridbit % SQUARES_EAST) * SQUARE) as f64,
        );
        std::array::from_fn(|i| {
            let (x, y) = ((i / SQUARE) as f64, (i % SQUARE) as f64);
            offset(self.lat_e7, self.lon_e7, (north0 + x) * s, (east0 + y) * s)
        })
    }

    /// Square `gridbit` answered from `height` (metres AMSL at a point, or why not), or the
    /// first point it could not answer with the reason.
    pub fn answer<E>(
        &self,
        gridbit: u8,
        mut height: impl FnMut(f64, f64) -> Result<f64, E>,
    ) -> Result<Square, ((f64, f64), E)> {
        let mut heights = [0i16; 16];
        for (h, (lat, lon)) in heights.iter_mut().zip(self.square_points(gridbit)) {
            let m = height(lat, lon).map_err(|e| ((lat, lon), e))?;
            // i16::MIN is SRTM's void: never sent as a height
            *h = m.round().clamp(-32767.0, 32767.0) as i16;
        }
        Ok(Square { gridbit, heights })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squares_are_laid_out_as_ardupilot_reads_them() {
        let r = Request {
            lat_e7: -353_632_610,
            lon_e7: 1_491_652_300,
            spacing_m: 100,
            mask: (1 << 56) - 1 + (1 << 60),
        };
        assert_eq!(r.gridbits().count(), 56, "bits past 55 mean nothing");
        // bit 0's first point is the corner itself
        let p = r.square_points(0);
        assert!((p[0].0 - -35.363261).abs() < 1e-12 && (p[0].1 - 149.16523).abs() < 1e-12);
        // bit 9 = second square north (9 / 8 = 1), second east (9 % 8 = 1): its point 6 is
        // 4 + 1 points north and 4 + 2 points east of the corner
        let q = r.square_points(9)[6];
        let (n, e) = (5.0 * 100.0, 6.0 * 100.0);
        let (lat, lon) = offset(r.lat_e7, r.lon_e7, n, e);
        assert_eq!(q, (lat, lon));
        // the offsets are metres: 500 m north is 0.0044916° of latitude
        assert!((lat - -35.363261 - 500.0 / METRES_PER_E7 * 1e-7).abs() < 1e-12);
        // and 600 m east is 600 m at the cosine of the mid latitude
        let mid = (-35.363261 + lat) / 2.0;
        let east_m = (lon - 149.16523) * 1e7 * METRES_PER_E7 * mid.to_radians().cos();
        assert!((east_m - 600.0).abs() < 1e-6, "{east_m}");
        // the last square's far corner: 27 points north, 31 east
        let far = r.square_points(55)[15];
        assert_eq!(far, offset(r.lat_e7, r.lon_e7, 2700.0, 3100.0));
    }

    /// ArduCopter 4.7 SITL at its CMAC home asked first for the block at
    /// (-353747690, 1491548424), spacing 100, and then for the 8 around it
    /// (docs/results/conformance.md, "Terrain served from tiles").
    #[test]
    fn blocks_are_where_ardupilot_lays_them() {
        let (lat, lon) = block_of(-353_632_610, 1_491_652_300, 100);
        assert!((lat - -353_747_690).abs() <= 1, "{lat}");
        assert!((lon - 1_491_548_424).abs() <= 1, "{lon}");
        // its northern neighbour: the corner 24 points north
        let (lat2, lon2) = block_of(-353_532_093 + 10, 1_491_548_214 + 10, 100);
        assert!((lat2 - -353_532_093).abs() <= 1, "{lat2}");
        assert!((lon2 - 1_491_548_214).abs() <= 1, "{lon2}");
        // northern hemisphere, east of Greenwich
        let (lat3, lon3) = block_of(473_977_420, 85_455_940, 100);
        assert!(lat3 <= 473_977_420 && lon3 <= 85_455_940);
        assert!(473_977_420 - lat3 < 24 * 100 * 90 && 85_455_940 - lon3 < 28 * 100 * 140);
    }

    #[test]
    fn answers_round_and_name_the_missing_point() {
        let r = Request {
            lat_e7: 470_000_000,
            lon_e7: 80_000_000,
            spacing_m: 30,
            mask: 1,
        };
        let sq = r.answer(0, |lat, _| Ok::<_, ()>(lat * 10.0)).unwrap();
        assert_eq!(sq.heights[0], 470);
        let sq = r
            .answer(3, |_, lon| Ok::<_, ()>(lon * 100.0 + 0.5))
            .unwrap();
        assert_eq!(sq.gridbit, 3);
        assert_eq!(sq.heights[0], 801);
        let e = r
            .answer(0, |lat, lon| if lon > 8.0 { Err("void") } else { Ok(lat) })
            .unwrap_err();
        assert_eq!(e.1, "void");
        assert!(e.0.1 > 8.0);
    }
}
