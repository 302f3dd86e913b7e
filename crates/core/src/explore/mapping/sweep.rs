//! The lawnmower sweep phase of the runway mapping run: positions, sweep images and their
//! detections, the progress and end of each drone's sweep.

use super::*;

impl MappingState {
    /// Record the position of `sysid` (metres east/north of the grid origin) for its track
    /// and distance, and `dt_air_s` seconds of airborne time since the last call.
    pub fn on_position(
        &mut self,
        sysid: u8,
        east: f64,
        north: f64,
        dt_air_s: f64,
    ) -> Result<(), MappingError> {
        let r = self.robot_mut(sysid)?;
        if dt_air_s.is_finite() && dt_air_s > 0.0 {
            r.flight_s += dt_air_s;
        }
        if !(east.is_finite() && north.is_finite()) {
            return Ok(());
        }
        match r.track.last().copied() {
            Some([e, n]) => {
                let d = ((east - e).powi(2) + (north - n).powi(2)).sqrt();
                if d >= 1.0 {
                    r.distance_m += d;
                    r.track.push([east, north]);
                }
            }
            None => r.track.push([east, north]),
        }
        Ok(())
    }

    /// A sweep image of `sysid` taken over `cell` was classified. Returns the candidate cell
    /// when it starts a confirmation (the first positive region of the run that is not a
    /// rejected candidate).
    #[allow(clippy::too_many_arguments)]
    pub fn on_sweep_image(
        &mut self,
        sysid: u8,
        cell: Cell,
        heading_deg: f64,
        fractions: RegionFractions,
        labels: NeighbourLabels,
        now: Time,
    ) -> Result<Option<Cell>, MappingError> {
        self.touch(now);
        self.images += 1;
        self.robot_mut(sysid)?.images += 1;
        self.sweep_images.push(SweepImage {
            image_id: format!("img{:06}", self.images),
            sysid,
            time: now,
            cell,
            heading_deg,
            fractions,
            labels,
        });
        if self.phase != Phase::Sweep {
            return Ok(None);
        }
        // The centre first, then north, west, south, east.
        let mut candidates = vec![(cell, labels.center)];
        candidates.extend(Dir4::ALL.into_iter().map(|d| (cell.step(d), labels.get(d))));
        let pick = candidates
            .into_iter()
            .find(|(c, positive)| *positive && !self.rejected.contains(c))
            .map(|(c, _)| c);
        if let Some(c) = pick {
            self.phase = Phase::Confirm { sysid, cell: c };
        }
        Ok(pick)
    }

    /// `sysid` is flying to sweep item `item` (user numbering).
    pub fn on_sweep_progress(&mut self, sysid: u8, item: u16) -> Result<(), MappingError> {
        self.robot_mut(sysid)?.sweep_item = Some(item);
        Ok(())
    }

    /// The sweep mission of `sysid` is complete. When every robot's is, and the run is still
    /// sweeping, the run ends without a detection.
    pub fn on_sweep_complete(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.robot_mut(sysid)?.status = RobotStatus::SweepDone;
        if self.phase == Phase::Sweep
            && self.robots.iter().all(|r| {
                matches!(
                    r.status,
                    RobotStatus::SweepDone | RobotStatus::Landed | RobotStatus::AwaitingSwap
                )
            })
        {
            self.phase = Phase::Finished {
                found: false,
                gave_up: None,
            };
        }
        self.note_milestones(now);
        Ok(())
    }
}
