//! Measurements on the run state: an image matched to the capture visit its position
//! falls in, counted into H (at most B per visit) and classified at once by (4).

use super::*;

/// Why an image counts for no capture visit ([`ClassificationState::match_image`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ImageMismatch {
    /// No sortie is flying.
    #[error("no sortie is flying")]
    NoSortie,
    /// The vehicle (sysid) is not a drone of the sortie flying.
    #[error("vehicle {0} is not a drone of this sortie")]
    NotADrone(u8),
    /// The image was taken too far from the centre of its cell.
    #[error("taken {off_m:.1} m from the centre of cell {cell} (more than {tolerance_m:.1} m)")]
    OffCentre {
        /// The cell the image was taken over.
        cell: Cell,
        /// Its distance from the cell's centre (m).
        off_m: f64,
        /// The largest distance that counts (m).
        tolerance_m: f64,
    },
    /// The cell's capture visits have all their images.
    #[error("cell {cell} already has its {batch} images for this visit")]
    VisitFull {
        /// The cell.
        cell: Cell,
        /// Images per visit (B).
        batch: u32,
    },
    /// The cell is not visited to capture in this sortie.
    #[error("cell {0} is not a capture cell of this sortie")]
    NotACaptureCell(Cell),
}

impl ClassificationState {
    /// The capture visit an image taken by `sysid` at (`east_m`, `north_m`) (grid metres)
    /// belongs to: `(visit index, cell)`, or why it does not count.
    pub fn match_image(
        &self,
        sysid: u8,
        east_m: f64,
        north_m: f64,
    ) -> Result<(usize, Cell), ImageMismatch> {
        let c = self.cycle().ok_or(ImageMismatch::NoSortie)?;
        let leg = c
            .drones
            .iter()
            .find(|d| d.sysid == sysid)
            .ok_or(ImageMismatch::NotADrone(sysid))?;
        let cell = self.grid.cell_of_xy(east_m, north_m);
        let s = self.grid.cell_size();
        let (dx, dy) = (
            east_m - f64::from(cell.col) * s,
            north_m - f64::from(cell.row) * s,
        );
        let off = dx.hypot(dy) / s;
        if off > self.params.capture_tolerance {
            return Err(ImageMismatch::OffCentre {
                cell,
                off_m: off * s,
                tolerance_m: self.params.capture_tolerance * s,
            });
        }
        let batch = self.params.batch;
        leg.captures
            .iter()
            .position(|v| v.cell == cell && v.counted < batch)
            .map(|i| (i, cell))
            .ok_or_else(|| {
                if leg.captures.iter().any(|v| v.cell == cell) {
                    ImageMismatch::VisitFull { cell, batch }
                } else {
                    ImageMismatch::NotACaptureCell(cell)
                }
            })
    }

    /// Whether this capture was counted already.
    pub fn seen(&self, key: CaptureKey) -> bool {
        self.cycle().is_some_and(|c| c.seen.contains(&key))
    }

    /// Count one measurement of visit `visit` of drone `sysid` (see the module
    /// documentation): H_l grows by one, then (4) is applied.
    pub fn record(
        &mut self,
        sysid: u8,
        visit: usize,
        key: CaptureKey,
        green_fraction: f64,
        positive: bool,
    ) -> Result<Recorded, SortieError> {
        let p_epoch = self.bandit.epoch;
        let n_next = self.measurements + 1;
        let (cell, k) = {
            let c = self.cycle_mut()?;
            let k = c.k;
            let leg = c
                .drones
                .iter_mut()
                .find(|d| d.sysid == sysid)
                .ok_or(SortieError::UnknownVehicle(sysid))?;
            let v = leg
                .captures
                .get_mut(visit)
                .ok_or_else(|| SortieError::Phase(format!("no capture visit {visit}")))?;
            v.counted += 1;
            let cell = v.cell;
            c.seen.push(key);
            (cell, k)
        };
        let l = self.bandit.index_of(cell);
        let counted = l.is_some_and(|l| self.bandit.record(l, u64::from(positive), 1));
        let m = Measurement {
            n: if counted { n_next } else { 0 },
            epoch: p_epoch,
            cycle: k,
            sysid,
            cell,
            green_fraction,
            positive,
            counted,
        };
        let mut classified = Vec::new();
        if counted {
            self.measurements = n_next;
            if let Some(e) = &mut self.epoch {
                e.measured.insert(cell);
                e.measurements += 1;
                if let Some(c) = &mut e.cycle {
                    c.measurements += 1;
                }
            }
            classified = self
                .bandit
                .classify()
                .into_iter()
                .map(|l| (self.bandit.cells[l], self.bandit.labels[l]))
                .collect();
            self.last_measurement = Some(m.clone());
        } else {
            self.ignored_images += 1;
        }
        Ok(Recorded {
            measurement: m,
            classified,
        })
    }
}
