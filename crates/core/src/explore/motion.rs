//! A translating ROI (paper §3–4): the region moves at a known constant velocity (a plume in
//! a steady wind); the DFS tracks cells in the region's own frame and the robots fly at
//! speed S_r relative to the ground.
//!
//! The ROI frame coincides with the ground grid at `epoch` and moves with the ROI: a point
//! fixed in the ROI at ROI-frame coordinates `x` is at ground position `x + v·(t − epoch)`.
//! Cells are indexed as in docs/grid.md (cell (row, col) centred at (col·s, row·s) east,
//! north of the grid origin).
//!
//! Moving along a unit direction `u` of the ROI frame at ground speed S_r, a robot progresses
//! relative to the ROI at `λ(u) = −u·v + √(S_r² − |v|² + (u·v)²)`: S_r − S_p when moving with
//! the flow, S_r + S_p against it and √(S_r² − S_p²) across it. Lemma 1's bound uses the worst
//! case S_r − S_p; the simulations of §6 charge every move at its own λ.

use super::ExploreError;
use crate::geo::Cell;
use crate::time::Time;
use serde::{Deserialize, Serialize};

/// The ROI's motion: constant velocity (east, north) in metres per second (or, in the
/// experiments, cells per unit time), with the ROI frame equal to the ground at `epoch`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoiMotion {
    /// Velocity towards east, m/s.
    pub velocity_east: f64,
    /// Velocity towards north, m/s.
    pub velocity_north: f64,
    /// When the ROI frame coincides with the ground grid.
    pub epoch: Time,
}

impl Default for RoiMotion {
    fn default() -> Self {
        RoiMotion::STATIC
    }
}

impl RoiMotion {
    /// A static ROI.
    pub const STATIC: RoiMotion = RoiMotion {
        velocity_east: 0.0,
        velocity_north: 0.0,
        epoch: Time::ZERO,
    };

    /// A ROI moving at (`velocity_east`, `velocity_north`) m/s, frames equal at `epoch`.
    pub fn new(velocity_east: f64, velocity_north: f64, epoch: Time) -> RoiMotion {
        RoiMotion {
            velocity_east,
            velocity_north,
            epoch,
        }
    }

    /// S_p: the ROI's speed.
    pub fn speed(&self) -> f64 {
        self.velocity_east.hypot(self.velocity_north)
    }

    /// Seconds from the epoch to `t` (negative before it).
    fn elapsed(&self, t: Time) -> f64 {
        (t.as_micros() as f64 - self.epoch.as_micros() as f64) / 1e6
    }

    /// How far the ROI has moved between the epoch and `t`: (east, north) metres.
    pub(crate) fn displacement(&self, t: Time) -> (f64, f64) {
        let s = self.elapsed(t);
        (self.velocity_east * s, self.velocity_north * s)
    }

    /// Ground point (east, north) at time `t` → the ROI-frame point under it.
    pub fn ground_to_roi(&self, east: f64, north: f64, t: Time) -> (f64, f64) {
        let (de, dn) = self.displacement(t);
        (east - de, north - dn)
    }

    /// ROI-frame point → where it is on the ground at time `t`.
    pub(crate) fn roi_to_ground(&self, east: f64, north: f64, t: Time) -> (f64, f64) {
        let (de, dn) = self.displacement(t);
        (east + de, north + dn)
    }

    #[cfg(test)]
    /// The ROI-frame cell under ground point (east, north) at time `t`, for square cells of
    /// `cell_size` metres.
    pub(crate) fn cell_at(&self, east: f64, north: f64, t: Time, cell_size: f64) -> Cell {
        let (e, n) = self.ground_to_roi(east, north, t);
        Cell::new(
            (n / cell_size).round() as i32,
            (e / cell_size).round() as i32,
        )
    }

    /// Ground position (east, north) at time `t` of the centre of ROI-frame `cell`.
    pub fn cell_centre(&self, cell: Cell, t: Time, cell_size: f64) -> (f64, f64) {
        self.roi_to_ground(
            f64::from(cell.col) * cell_size,
            f64::from(cell.row) * cell_size,
            t,
        )
    }

    fn check(&self, robot_speed: f64) -> Result<(), ExploreError> {
        let sp = self.speed();
        if robot_speed.is_finite() && sp.is_finite() && robot_speed > sp {
            Ok(())
        } else {
            Err(ExploreError::Speeds {
                robot_speed,
                roi_speed: sp,
            })
        }
    }

    /// λ(u): how fast a robot flying at ground speed `robot_speed` progresses along the unit
    /// direction (`dir_east`, `dir_north`) of the ROI frame.
    pub(crate) fn relative_speed(
        &self,
        robot_speed: f64,
        dir_east: f64,
        dir_north: f64,
    ) -> Result<f64, ExploreError> {
        self.check(robot_speed)?;
        let norm = dir_east.hypot(dir_north);
        let (ue, un) = if norm > 0.0 {
            (dir_east / norm, dir_north / norm)
        } else {
            (1.0, 0.0)
        };
        let uv = ue * self.velocity_east + un * self.velocity_north;
        let vv = self.speed().powi(2);
        Ok(-uv + (robot_speed * robot_speed - vv + uv * uv).sqrt())
    }

    /// Time to fly from the centre of ROI-frame cell `from` to that of `to` (straight, in
    /// the ROI frame) at ground speed `robot_speed`, cells of `cell_size`.
    pub(crate) fn travel_time(
        &self,
        from: Cell,
        to: Cell,
        cell_size: f64,
        robot_speed: f64,
    ) -> Result<f64, ExploreError> {
        let de = f64::from(to.col - from.col) * cell_size;
        let dn = f64::from(to.row - from.row) * cell_size;
        let d = de.hypot(dn);
        if d == 0.0 {
            self.check(robot_speed)?;
            return Ok(0.0);
        }
        Ok(d / self.relative_speed(robot_speed, de, dn)?)
    }

    /// Where and when a robot at ground point (`east`, `north`) at time `now`, flying
    /// straight at `robot_speed`, meets the centre of ROI-frame `cell`: (seconds of flight,
    /// ground (east, north) of the meeting point). The experiments' model of a visit to a
    /// translating ROI, and where the field runner flies for one (`kinds::runway`'s
    /// `RoiClock::intercept`).
    pub fn intercept(
        &self,
        east: f64,
        north: f64,
        now: Time,
        cell: Cell,
        cell_size: f64,
        robot_speed: f64,
    ) -> Result<(f64, (f64, f64)), ExploreError> {
        self.check(robot_speed)?;
        let (ce, cn) = self.cell_centre(cell, now, cell_size);
        let (de, dn) = (ce - east, cn - north);
        let dv = de * self.velocity_east + dn * self.velocity_north;
        let k = robot_speed * robot_speed - self.speed().powi(2);
        let tau = (dv + (dv * dv + k * (de * de + dn * dn)).sqrt()) / k;
        Ok((
            tau,
            (
                ce + self.velocity_east * tau,
                cn + self.velocity_north * tau,
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_and_cells() {
        let m = RoiMotion::new(0.5, -0.25, Time::from_secs(10));
        let t = Time::from_secs(30); // 20 s later: moved (10, −5) m
        assert_eq!(m.displacement(t), (10.0, -5.0));
        let (e, n) = m.roi_to_ground(4.0, 8.0, t);
        assert_eq!((e, n), (14.0, 3.0));
        assert_eq!(m.ground_to_roi(e, n, t), (4.0, 8.0));
        // Ground point (14, 3) at t is over ROI-frame (4, 8): cell (2, 1) with 4 m cells.
        assert_eq!(m.cell_at(14.0, 3.0, t, 4.0), Cell::new(2, 1));
        assert_eq!(m.cell_centre(Cell::new(2, 1), t, 4.0), (14.0, 3.0));
        // Before the epoch the ROI was behind.
        assert_eq!(m.displacement(Time::ZERO), (-5.0, 2.5));
        assert_eq!(
            RoiMotion::STATIC.cell_at(5.9, -6.1, t, 4.0),
            Cell::new(-2, 1)
        );
    }

    #[test]
    fn relative_speeds() {
        let m = RoiMotion::new(0.0, 1.0, Time::ZERO); // moving north at S_p = 1
        let sr = 2.5;
        let with = m.relative_speed(sr, 0.0, 1.0).unwrap();
        let against = m.relative_speed(sr, 0.0, -1.0).unwrap();
        let across = m.relative_speed(sr, 1.0, 0.0).unwrap();
        assert!((with - 1.5).abs() < 1e-12);
        assert!((against - 3.5).abs() < 1e-12);
        assert!((across - (sr * sr - 1.0f64).sqrt()).abs() < 1e-12);
        assert!(
            (m.travel_time(Cell::new(0, 0), Cell::new(1, 0), 1.0, sr)
                .unwrap()
                - 1.0 / 1.5)
                .abs()
                < 1e-12
        );
        assert!(m.relative_speed(1.0, 1.0, 0.0).is_err());
        assert!(m.relative_speed(f64::NAN, 1.0, 0.0).is_err());
        // Static: everything at S_r.
        assert_eq!(
            RoiMotion::STATIC.relative_speed(2.0, 0.3, 0.4).unwrap(),
            2.0
        );
    }

    #[test]
    fn intercept_meets_the_moving_cell() {
        let m = RoiMotion::new(0.3, 0.4, Time::from_secs(5));
        let now = Time::from_secs(12);
        let (tau, (e, n)) = m
            .intercept(-7.0, 3.0, now, Cell::new(3, -2), 4.0, 2.0)
            .unwrap();
        // The robot flies |p − q| in τ at 2 m/s ...
        assert!(((e + 7.0).hypot(n - 3.0) - 2.0 * tau).abs() < 1e-9);
        // ... and the cell centre is there at now + τ.
        let later = now + std::time::Duration::from_secs_f64(tau);
        let (ce, cn) = m.cell_centre(Cell::new(3, -2), later, 4.0);
        assert!((ce - e).abs() < 1e-5 && (cn - n).abs() < 1e-5);
        let (tau0, _) = RoiMotion::STATIC
            .intercept(0.0, 0.0, now, Cell::new(0, 3), 4.0, 2.0)
            .unwrap();
        assert!((tau0 - 6.0).abs() < 1e-12);
    }
}
