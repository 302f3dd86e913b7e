//! Kinematic motion of a copter or a rover: speed, acceleration, climb and yaw-rate limits, a
//! constant wind, and the tilt a copter needs for them (which moves its fixed camera).
//!
//! Positions are local tangent-plane metres (east, north, up above the flat ground) around a
//! reference point shared by every vehicle of a simulation (see `geo::local`).
//!
//! The horizontal controller follows a trapezoidal speed profile toward its target (the
//! speed that still allows stopping at the target with the acceleration limit, capped by the
//! commanded speed), like the S-curve position controllers of ArduCopter (AC_WPNav) and PX4
//! (FlightTaskAuto) at the level of detail a mapping mission needs. A copter's ground speed is
//! also limited by the air speed it can reach at its maximum tilt: with the drag model
//! `tan(tilt) = DRAG · v_air²` (≈2.5° at 3.6 m/s, ≈30° at 12.8 m/s), a headwind slows fast
//! legs; the same tilt moves the camera's footprint downwind.

use serde::{Deserialize, Serialize};

/// Gravity, m/s².
pub const G: f64 = 9.80665;
/// Drag coefficient of the tilt model: tan(tilt) = DRAG · airspeed² (s²/m²).
pub(crate) const DRAG: f64 = 0.0035;

/// Motion limits of a vehicle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Default horizontal speed in autonomous modes, m/s (WPNAV_SPEED / MPC_XY_CRUISE /
    /// WP_SPEED).
    pub speed_mps: f64,
    /// Horizontal acceleration, m/s² (WPNAV_ACCEL / MPC_ACC_HOR / ATC_ACCEL_MAX).
    pub(crate) accel_mps2: f64,
    /// Climb rate, m/s (WPNAV_SPEED_UP / MPC_Z_VEL_MAX_UP).
    pub(crate) climb_mps: f64,
    /// Descent rate, m/s (WPNAV_SPEED_DN / MPC_Z_VEL_MAX_DN).
    pub(crate) descent_mps: f64,
    /// Final landing descent rate, m/s (LAND_SPEED / MPC_LAND_SPEED).
    pub(crate) land_mps: f64,
    /// Vertical acceleration, m/s².
    pub(crate) accel_z_mps2: f64,
    /// Yaw rate, degrees/s.
    pub(crate) yaw_rate_dps: f64,
    /// Maximum tilt, degrees (ANGLE_MAX / MPC_TILTMAX_AIR); limits the air speed.
    pub max_tilt_deg: f64,
}

impl Limits {
    /// ArduCopter defaults: WPNAV_SPEED 10 m/s, WPNAV_ACCEL 2.5 m/s², WPNAV_SPEED_UP 2.5,
    /// WPNAV_SPEED_DN 1.5, LAND_SPEED 0.5, ANGLE_MAX 30°.
    pub(crate) const ARDUCOPTER: Limits = Limits {
        speed_mps: 10.0,
        accel_mps2: 2.5,
        climb_mps: 2.5,
        descent_mps: 1.5,
        land_mps: 0.5,
        accel_z_mps2: 2.5,
        yaw_rate_dps: 90.0,
        max_tilt_deg: 30.0,
    };
    /// PX4 multicopter defaults: MPC_XY_CRUISE 5 m/s, MPC_ACC_HOR 3 m/s², MPC_Z_VEL_MAX_UP 3,
    /// MPC_Z_VEL_MAX_DN 1.5, MPC_LAND_SPEED 0.7, MPC_YAWRAUTO_MAX 45°/s, MPC_TILTMAX_AIR 45°.
    pub const PX4_COPTER: Limits = Limits {
        speed_mps: 5.0,
        accel_mps2: 3.0,
        climb_mps: 3.0,
        descent_mps: 1.5,
        land_mps: 0.7,
        accel_z_mps2: 3.0,
        yaw_rate_dps: 45.0,
        max_tilt_deg: 45.0,
    };
    /// Rover defaults (ArduRover WP_SPEED 2 m/s, ATC_ACCEL_MAX 1 m/s²; PX4 rover similar).
    pub(crate) const ROVER: Limits = Limits {
        speed_mps: 2.0,
        accel_mps2: 1.0,
        climb_mps: 0.0,
        descent_mps: 0.0,
        land_mps: 0.0,
        accel_z_mps2: 0.0,
        yaw_rate_dps: 90.0,
        max_tilt_deg: 0.0,
    };
}

/// The kinematic state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct State {
    /// East, metres.
    pub e: f64,
    /// North, metres.
    pub n: f64,
    /// Height above ground, metres.
    pub u: f64,
    /// Velocity east, m/s.
    pub ve: f64,
    /// Velocity north, m/s.
    pub vn: f64,
    /// Velocity up, m/s.
    pub(crate) vu: f64,
    /// Heading, degrees clockwise from north (0–360).
    pub heading_deg: f64,
    /// Roll, degrees (right side down positive).
    pub roll_deg: f64,
    /// Pitch, degrees (nose up positive).
    pub pitch_deg: f64,
}

impl State {
    /// Horizontal ground speed, m/s.
    pub(crate) fn ground_speed(&self) -> f64 {
        self.ve.hypot(self.vn)
    }
}

/// What the motion controller should do this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Stay on the ground (motors off or idle): no motion.
    Ground,
    /// Go to (e, n, u) at up to `speed` m/s horizontally; `yaw_deg` holds a heading, `None`
    /// faces the direction of travel.
    Goto {
        /// Target east, m.
        e: f64,
        /// Target north, m.
        n: f64,
        /// Target height, m.
        u: f64,
        /// Horizontal speed limit, m/s.
        speed: f64,
        /// Heading to hold, degrees; `None` = face the target.
        yaw_deg: Option<f64>,
    },
    /// Hold (e, n) and descend at `rate` m/s to the ground (landing).
    Descend {
        /// East, m.
        e: f64,
        /// North, m.
        n: f64,
        /// Descent rate, m/s.
        rate: f64,
    },
}

/// Advance `s` by `dt` seconds under `cmd`. `wind_ne` is the air velocity (north, east) m/s;
/// `rover` vehicles steer like a skid-steer ground robot (turn toward the target, slow down
/// while turning) and never leave the ground.
pub fn step(s: &mut State, cmd: &Command, lim: &Limits, wind_ne: (f64, f64), rover: bool, dt: f64) {
    let (tgt, speed, yaw_hold, descend_rate) = match *cmd {
        Command::Ground => {
            s.ve = 0.0;
            s.vn = 0.0;
            s.vu = 0.0;
            s.roll_deg = 0.0;
            s.pitch_deg = 0.0;
            return;
        }
        Command::Goto {
            e,
            n,
            u,
            speed,
            yaw_deg,
        } => ((e, n, u), speed.max(0.0), yaw_deg, None),
        Command::Descend { e, n, rate } => ((e, n, s.u), lim.speed_mps.min(2.0), None, Some(rate)),
    };
    let (de, dn) = (tgt.0 - s.e, tgt.1 - s.n);
    let dist = de.hypot(dn);
    let (ax_prev, ay_prev) = (s.ve, s.vn);
    if rover {
        rover_step(s, de, dn, dist, speed, lim, dt);
    } else {
        // desired velocity: trapezoidal profile, proportional near the target
        let vmax = speed
            .min((2.0 * lim.accel_mps2 * dist).sqrt())
            .min(1.5 * dist);
        let (mut vde, mut vdn) = if dist > 1e-9 {
            (de / dist * vmax, dn / dist * vmax)
        } else {
            (0.0, 0.0)
        };
        // air-speed limit from the maximum tilt
        let (wn, we) = wind_ne;
        let v_air_max = (lim.max_tilt_deg.to_radians().tan() / DRAG).sqrt();
        let (ae, an) = (vde - we, vdn - wn);
        let air = ae.hypot(an);
        if air > v_air_max {
            // keep the direction of travel, reduce the ground speed until the air speed fits:
            // |v·d − w| = v_air_max, v ≥ 0
            if dist > 1e-9 {
                let (ue, un) = (de / dist, dn / dist);
                let b = -2.0 * (ue * we + un * wn);
                let c = we * we + wn * wn - v_air_max * v_air_max;
                let disc = b * b - 4.0 * c;
                let v = if disc >= 0.0 {
                    ((-b + disc.sqrt()) / 2.0).max(0.0)
                } else {
                    0.0
                };
                let v = v.min(vmax);
                vde = ue * v;
                vdn = un * v;
            }
        }
        let (dve, dvn) = (vde - s.ve, vdn - s.vn);
        let dv = dve.hypot(dvn);
        let max_dv = lim.accel_mps2 * dt;
        let k = if dv > max_dv { max_dv / dv } else { 1.0 };
        s.ve += dve * k;
        s.vn += dvn * k;
        s.e += s.ve * dt;
        s.n += s.vn * dt;
        // vertical
        let vu_des = match descend_rate {
            Some(r) => -r,
            None => {
                let dz = tgt.2 - s.u;
                let cap = if dz > 0.0 {
                    lim.climb_mps
                } else {
                    lim.descent_mps
                };
                let v = cap
                    .min((2.0 * lim.accel_z_mps2 * dz.abs()).sqrt())
                    .min(1.5 * dz.abs());
                v * dz.signum()
            }
        };
        let dvu = (vu_des - s.vu).clamp(-lim.accel_z_mps2 * dt, lim.accel_z_mps2 * dt);
        s.vu += dvu;
        s.u = (s.u + s.vu * dt).max(0.0);
        if s.u <= 0.0 && s.vu < 0.0 {
            s.vu = 0.0;
        }
        // heading: face the direction of travel while moving, else hold
        let want = match yaw_hold {
            Some(y) => Some(y),
            None if dist > 2.0 && s.ground_speed() > 0.3 => {
                Some(de.atan2(dn).to_degrees().rem_euclid(360.0))
            }
            None => None,
        };
        if let Some(w) = want {
            turn_toward(s, w, lim.yaw_rate_dps, dt);
        }
        // tilt: horizontal thrust = acceleration + drag, in g
        let (acc_e, acc_n) = ((s.ve - ax_prev) / dt, (s.vn - ay_prev) / dt);
        let (air_e, air_n) = (s.ve - wind_ne.1, s.vn - wind_ne.0);
        let air = air_e.hypot(air_n);
        let t_e = acc_e / G + DRAG * air * air_e;
        let t_n = acc_n / G + DRAG * air * air_n;
        let h = s.heading_deg.to_radians();
        let t_fwd = t_e * h.sin() + t_n * h.cos();
        let t_right = t_e * h.cos() - t_n * h.sin();
        let max = lim.max_tilt_deg.to_radians().tan();
        s.pitch_deg = -t_fwd.clamp(-max, max).atan().to_degrees();
        s.roll_deg = t_right.clamp(-max, max).atan().to_degrees();
    }
}

fn turn_toward(s: &mut State, want_deg: f64, rate_dps: f64, dt: f64) {
    let err = (want_deg - s.heading_deg + 540.0).rem_euclid(360.0) - 180.0;
    let max = rate_dps * dt;
    s.heading_deg = (s.heading_deg + err.clamp(-max, max)).rem_euclid(360.0);
}

fn rover_step(s: &mut State, de: f64, dn: f64, dist: f64, speed: f64, lim: &Limits, dt: f64) {
    s.u = 0.0;
    s.vu = 0.0;
    s.roll_deg = 0.0;
    s.pitch_deg = 0.0;
    let v = s.ground_speed();
    let mut v_des = 0.0;
    if dist > 0.05 {
        let bearing = de.atan2(dn).to_degrees().rem_euclid(360.0);
        turn_toward(s, bearing, lim.yaw_rate_dps, dt);
        let err = ((bearing - s.heading_deg + 540.0).rem_euclid(360.0) - 180.0).abs();
        // slow down while the heading error is large (pivot turns above 60°)
        let align = if err > 60.0 {
            0.0
        } else {
            err.to_radians().cos()
        };
        v_des = speed
            .min((2.0 * lim.accel_mps2 * dist).sqrt())
            .min(1.5 * dist)
            * align;
    }
    let dv = (v_des - v).clamp(-lim.accel_mps2 * dt, lim.accel_mps2 * dt);
    let nv = (v + dv).max(0.0);
    let h = s.heading_deg.to_radians();
    s.ve = nv * h.sin();
    s.vn = nv * h.cos();
    s.e += s.ve * dt;
    s.n += s.vn * dt;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fly(
        s: &mut State,
        cmd: Command,
        lim: &Limits,
        wind: (f64, f64),
        rover: bool,
        secs: f64,
    ) -> f64 {
        let dt = 0.05;
        let mut t = 0.0;
        while t < secs {
            step(s, &cmd, lim, wind, rover, dt);
            t += dt;
        }
        t
    }

    #[test]
    fn copter_reaches_a_target_and_stops() {
        let mut s = State::default();
        let lim = Limits::ARDUCOPTER;
        let cmd = Command::Goto {
            e: 30.0,
            n: 40.0,
            u: 12.0,
            speed: 5.0,
            yaw_deg: None,
        };
        fly(&mut s, cmd, &lim, (0.0, 0.0), false, 30.0);
        assert!(
            (s.e - 30.0).abs() < 0.05 && (s.n - 40.0).abs() < 0.05,
            "{s:?}"
        );
        assert!((s.u - 12.0).abs() < 0.05);
        assert!(s.ground_speed() < 0.05);
        assert!((s.heading_deg - 36.87).abs() < 1.0, "{}", s.heading_deg);
    }

    #[test]
    fn headwind_slows_fast_legs_and_tilts() {
        let lim = Limits::ARDUCOPTER;
        let cmd = Command::Goto {
            e: 0.0,
            n: 1000.0,
            u: 10.0,
            speed: 12.0,
            yaw_deg: None,
        };
        let mut calm = State {
            u: 10.0,
            ..State::default()
        };
        fly(&mut calm, cmd, &lim, (0.0, 0.0), false, 20.0);
        let mut windy = State {
            u: 10.0,
            ..State::default()
        };
        // wind from the north at 6 m/s: air moves south
        fly(&mut windy, cmd, &lim, (-6.0, 0.0), false, 20.0);
        assert!(windy.n < calm.n - 50.0, "{} vs {}", windy.n, calm.n);
        assert!(
            windy.pitch_deg < -20.0,
            "nose down into the wind: {}",
            windy.pitch_deg
        );
        // hovering in wind: tilted into the wind
        let mut hover = State {
            u: 10.0,
            ..State::default()
        };
        let hold = Command::Goto {
            e: 0.0,
            n: 0.0,
            u: 10.0,
            speed: 5.0,
            yaw_deg: Some(0.0),
        };
        fly(&mut hover, hold, &lim, (0.0, 3.6), false, 5.0);
        // wind toward the east: the copter leans west (left side down, negative roll)
        assert!(
            hover.roll_deg < -1.5 && hover.roll_deg > -4.0,
            "{}",
            hover.roll_deg
        );
    }

    #[test]
    fn rover_turns_then_drives_and_stays_on_the_ground() {
        let mut s = State::default();
        let lim = Limits::ROVER;
        let cmd = Command::Goto {
            e: -10.0,
            n: 0.0,
            u: 5.0,
            speed: 2.0,
            yaw_deg: None,
        };
        fly(&mut s, cmd, &lim, (3.0, 3.0), true, 15.0);
        assert!((s.e + 10.0).abs() < 0.1 && s.n.abs() < 0.5, "{s:?}");
        assert_eq!(s.u, 0.0);
    }
}
