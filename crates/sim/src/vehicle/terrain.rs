//! The terrain an ArduCopter keeps (one block of squares), which the simulated autopilot asks
//! the GCS for with TERRAIN_REQUEST and reports in TERRAIN_REPORT.

use super::mav;

/// The terrain an ArduCopter keeps, cut down to one block: the one under the vehicle, laid
/// as ArduPilot lays it ([`fleetmap_core::terrain::grid::block_of`], 100 m apart, its
/// `TERRAIN_SPACING` default), and which of its 56 squares arrived in TERRAIN_DATA
/// (`AP_Terrain::handle_terrain_data`). A real ArduCopter also keeps the 8 blocks around it
/// and those under the mission's items; the simulator asks for one.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Terrain {
    /// The block's corner (1e-7 degrees).
    pub(super) block: Option<(i32, i32)>,
    /// Bit `b`: square `b` arrived.
    pub(super) have: u64,
}

impl Terrain {
    /// Metres between points (ArduPilot's `TERRAIN_SPACING` default).
    pub(super) const SPACING: u16 = 100;
    /// Every square of a block.
    pub(super) const ALL: u64 = (1 << fleetmap_core::terrain::grid::BITS) - 1;

    /// The block for a vehicle at (`lat_e7`, `lon_e7`): a new one starts empty.
    pub(super) fn at(&mut self, lat_e7: i32, lon_e7: i32) -> (i32, i32) {
        let b = fleetmap_core::terrain::grid::block_of(lat_e7, lon_e7, Self::SPACING);
        if self.block != Some(b) {
            *self = Terrain {
                block: Some(b),
                have: 0,
            };
        }
        b
    }

    /// A TERRAIN_DATA arrived.
    pub(super) fn data(&mut self, d: &mav::TERRAIN_DATA_DATA) {
        if self.block == Some((d.lat, d.lon))
            && d.grid_spacing == Self::SPACING
            && d.gridbit < fleetmap_core::terrain::grid::BITS
        {
            self.have |= 1 << d.gridbit;
        }
    }

    /// Whether every square of the block arrived.
    pub(super) fn complete(&self) -> bool {
        self.block.is_some() && self.have & Self::ALL == Self::ALL
    }
}
