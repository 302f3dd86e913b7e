//! Terrain: SRTM height tiles and the MAVLink terrain protocol that gives them to ArduPilot.
//!
//! An ArduPilot vehicle flying a mission in the terrain frame (altitudes above the ground)
//! with `TERRAIN_ENABLE` set needs the ground heights under its path; it asks the GCS for them
//! with TERRAIN_REQUEST and refuses to arm ("PreArm: waiting for terrain data") until it has
//! them. fleetmap answers from `.hgt` tiles in a folder the operator gives (`--terrain DIR`):
//!
//! * [`hgt`]: a tile parsed from its bytes (SRTM3 and SRTM1), its name, heights between
//!   samples;
//! * [`grid`]: where the 4 × 4 points of each square of a request lie, and a square's answer;
//! * [`serve`]: which squares to send to which vehicle, paced, and what a vehicle waits for
//!   when no tile covers it.
//!
//! [`Tiles`] is the set of tiles read so far. Reading the files is the shell's
//! (`fleetmap_io::files::terrain`).

pub mod grid;
pub mod hgt;
pub mod serve;

use hgt::{Tile, TileId};
use serve::Missing;
use std::collections::BTreeMap;

/// The tiles at hand, by their corner.
#[derive(Clone, Debug, Default)]
pub struct Tiles {
    tiles: BTreeMap<TileId, Tile>,
}

impl Tiles {
    /// No tiles.
    pub fn new() -> Tiles {
        Tiles::default()
    }

    /// Add (or replace) a tile.
    pub fn insert(&mut self, tile: Tile) {
        self.tiles.insert(tile.id(), tile);
    }

    /// Whether the tile is at hand.
    pub fn contains(&self, id: TileId) -> bool {
        self.tiles.contains_key(&id)
    }

    /// How many tiles.
    pub fn len(&self) -> usize {
        self.tiles.len()
    }

    /// No tiles at all.
    pub fn is_empty(&self) -> bool {
        self.tiles.is_empty()
    }

    /// The ground height at a point, metres AMSL, or why it is unknown.
    pub fn height(&self, lat: f64, lon: f64) -> Result<f64, Missing> {
        let id = TileId::containing(lat, lon);
        let tile = self.tiles.get(&id).ok_or(Missing::NoTile(id))?;
        tile.height(lat, lon).ok_or(Missing::Void(id))
    }
}

/// The tiles the squares of `request` lie on (every point checked), in order.
pub fn tiles_for(request: &grid::Request) -> Vec<TileId> {
    let mut ids: Vec<TileId> = request
        .gridbits()
        .flat_map(|b| request.square_points(b))
        .map(|(lat, lon)| TileId::containing(lat, lon))
        .collect();
    ids.sort();
    ids.dedup();
    ids
}

#[cfg(test)]
mod tests {
    use super::grid::Request;
    use super::hgt::SRTM3_SIDE;
    use super::*;
    use proptest::prelude::*;

    /// A tile whose samples follow `f(row, col)` (rows from the north).
    fn tile(id: TileId, f: impl Fn(usize, usize) -> i16) -> Tile {
        let n = SRTM3_SIDE;
        let samples = (0..n * n).map(|i| f(i / n, i % n)).collect();
        Tile::from_samples(id, n, samples).unwrap()
    }

    /// The reference: the nearest four samples found by plain arithmetic on the tile's
    /// 3-arc-second lattice, weighted by distance, with no shortcut of the real code.
    fn reference(t: &Tile, lat: f64, lon: f64) -> Option<f64> {
        let id = t.id();
        let arcsec_n = (lat - f64::from(id.lat)) * 3600.0 / 3.0; // samples north of the south edge
        let arcsec_e = (lon - f64::from(id.lon)) * 3600.0 / 3.0;
        let mut total = 0.0;
        for (dn, de) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            let sn = (arcsec_n.floor() + dn).min(1200.0);
            let se = (arcsec_e.floor() + de).min(1200.0);
            let wn = 1.0 - (arcsec_n - sn).abs();
            let we = 1.0 - (arcsec_e - se).abs();
            if wn <= 0.0 || we <= 0.0 {
                continue;
            }
            let row = 1200 - sn as usize;
            total += wn * we * f64::from(t.sample(row, se as usize)?);
        }
        Some(total)
    }

    proptest! {
        /// Heights between samples agree with the reference for any point of the tile.
        #[test]
        fn heights_agree_with_a_plain_reference(
            lat in 47.0f64..47.9999, lon in 8.0f64..8.9999, seed in 0u64..1000
        ) {
            let id = TileId { lat: 47, lon: 8 };
            let t = tile(id, |r, c| ((r * 7 + c * 13 + seed as usize) % 2000) as i16 - 100);
            let got = Tiles { tiles: [(id, t.clone())].into() }.height(lat, lon).unwrap();
            let want = reference(&t, lat, lon).unwrap();
            prop_assert!((got - want).abs() < 1e-6, "{got} vs {want}");
        }

        /// Every square of any request near a tile's middle is answered with the heights of
        /// the points the protocol places, rounded, and lies on that tile.
        #[test]
        fn squares_carry_the_heights_of_their_points(
            lat in 47.1f64..47.8, lon in 8.1f64..8.8, spacing in 30u16..200, bit in 0u8..56
        ) {
            let id = TileId { lat: 47, lon: 8 };
            let t = tile(id, |r, c| (r as i16) - (c as i16) / 2);
            let tiles = Tiles { tiles: [(id, t.clone())].into() };
            let r = Request {
                lat_e7: (lat * 1e7) as i32, lon_e7: (lon * 1e7) as i32, spacing_m: spacing,
                mask: 1 << bit,
            };
            prop_assert_eq!(tiles_for(&r), vec![id]);
            let sq = r.answer(bit, |a, b| tiles.height(a, b)).unwrap();
            for (h, (a, b)) in sq.heights.iter().zip(r.square_points(bit)) {
                let want = reference(&t, a, b).unwrap().round() as i16;
                prop_assert_eq!(*h, want);
            }
        }
    }

    #[test]
    fn missing_and_void_heights_say_which_tile() {
        let id = TileId { lat: -36, lon: 149 };
        let mut tiles = Tiles::new();
        assert_eq!(tiles.height(-35.36, 149.16), Err(Missing::NoTile(id)));
        tiles.insert(tile(id, |r, _| if r < 600 { hgt::VOID } else { 584 }));
        assert_eq!(tiles.height(-35.9, 149.16), Ok(584.0));
        assert_eq!(tiles.height(-35.1, 149.16), Err(Missing::Void(id)));
        assert!(tiles.contains(id) && tiles.len() == 1);
        // a block on a tile edge needs both tiles
        let r = Request {
            lat_e7: -350_100_000,
            lon_e7: 1_491_000_000,
            spacing_m: 100,
            mask: (1 << 56) - 1,
        };
        assert_eq!(tiles_for(&r), vec![id, TileId { lat: -35, lon: 149 }]);
    }
}
