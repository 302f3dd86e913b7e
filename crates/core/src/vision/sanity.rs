//! Whether a picture was taken where it is credited: the check both mission runners make
//! before a picture counts for a cell (pure; the runners supply the numbers).
//!
//! A picture's pose is what the camera reported (CAMERA_IMAGE_CAPTURED lat / lon /
//! relative_alt / q, or the JPEG's metadata), else the vehicle's telemetry at the capture.
//! It passes when
//!
//! * its horizontal distance from where it should have been taken (the cell centre the
//!   vehicle was sent to; in the sweep, where the vehicle is) is at most
//!   [`CaptureLimits::horizontal_m`],
//! * its altitude above home is within [`CaptureLimits::vertical_m`] of the planned one,
//! * the optical axis is within [`CaptureLimits::max_tilt_deg`] of the vertical (from the
//!   reported attitude, when there is one), and
//! * the camera's heading is within [`CaptureLimits::max_heading_error_deg`] of the
//!   vehicle's (when both are known).
//!
//! Why these defaults ([`CaptureLimits::hover`]): the runner flies to a cell until the
//! vehicle is within its arrival tolerance (0.5 m) and 1 m of altitude and slower than
//! 0.3 m/s, turns it to the grid within 3°, and only then takes pictures, so a camera that
//! reports the vehicle's own estimate stays inside those bounds; the check adds a margin for
//! the hover's motion between arrival and the shutter. A camera that never learned where the
//! vehicle is (the SITL defect: every picture at the boot pose) fails by tens of metres and
//! by the whole flight altitude.

use nalgebra::UnitQuaternion;

/// Limits of [`check_capture`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaptureLimits {
    /// Largest horizontal distance from where the picture should have been taken, metres.
    pub horizontal_m: f64,
    /// Largest difference between the capture altitude and the planned one, metres.
    pub vertical_m: f64,
    /// Largest angle of the optical axis from the vertical, degrees.
    pub max_tilt_deg: f64,
    /// Largest difference between the camera's heading and the vehicle's, degrees.
    pub max_heading_error_deg: f64,
}

/// Default horizontal margin on top of the arrival tolerance, metres: the hover's drift
/// between arrival and the shutter (the simulated copter holds within ≈0.1 m; ArduCopter's
/// position controller in light wind within ≈0.3 m).
pub(crate) const HOVER_MARGIN_M: f64 = 0.5;
/// Default vertical tolerance, metres: the runner's arrival condition is 1 m on the
/// telemetry altitude; 0.5 m more for altitude-hold bob at the shutter. At 12 m it is a
/// footprint scale error of 12 %, which the orthophoto corrects (it uses the capture
/// altitude).
pub const VERTICAL_M: f64 = 1.5;
/// Default tilt limit, degrees. A hovering copter tilts by what the wind needs
/// (tan θ = 0.0035 · v², the simulator's drag model: 2.5° in the paper's 3.6 m/s wind, 10° only
/// in 7 m/s); at 12 m a 10° tilt moves the view by 2.1 m, half a 4 m cell, so beyond it a
/// neighbour region of the 3 × 3 is more than half outside the picture.
pub const MAX_TILT_DEG: f64 = 10.0;
/// Tilt limit for sweep pictures, degrees. They are taken at the sweep's waypoints, where a
/// copter brakes at up to its waypoint acceleration (ArduCopter WPNAV_ACCEL 2.5 m/s²: 14.3°
/// of tilt, the figure every sweep picture of the simulated copter shows); they are cut around
/// where the camera looked (the orthophoto) and only nominate a candidate that checked cell
/// pictures confirm, so only an attitude no braking explains is refused (ArduCopter's
/// ANGLE_MAX is 30°).
pub const SWEEP_MAX_TILT_DEG: f64 = 20.0;
/// Default heading tolerance, degrees: the runner turns the vehicle to the grid within 3°
/// before the pictures; a camera heading 10° off that is not this vehicle's attitude now
/// (a stale or placeholder quaternion).
pub(crate) const MAX_HEADING_ERROR_DEG: f64 = 10.0;

impl CaptureLimits {
    /// The limits for a picture taken hovering over a cell centre the vehicle arrived at
    /// within `arrival_tolerance_m` (the runway runner's): the arrival tolerance plus
    /// `HOVER_MARGIN_M` horizontally, [`VERTICAL_M`], [`MAX_TILT_DEG`],
    /// `MAX_HEADING_ERROR_DEG`.
    pub fn hover(arrival_tolerance_m: f64) -> CaptureLimits {
        CaptureLimits {
            horizontal_m: arrival_tolerance_m.max(0.0) + HOVER_MARGIN_M,
            vertical_m: VERTICAL_M,
            max_tilt_deg: MAX_TILT_DEG,
            max_heading_error_deg: MAX_HEADING_ERROR_DEG,
        }
    }
}

/// What is known of one picture.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CaptureClaim {
    /// Horizontal distance from where the picture should have been taken, metres (`None`:
    /// checked elsewhere, e.g. by matching the position to a capture visit).
    pub horizontal_offset_m: Option<f64>,
    /// Altitude above home at the shutter, metres (`None`: unknown, not checked).
    pub altitude_m: Option<f64>,
    /// Attitude at the shutter, body → NED (`None`: unknown, not checked).
    pub attitude: Option<UnitQuaternion<f64>>,
    /// The camera's heading, degrees clockwise from north (`None`: unknown).
    pub heading_deg: Option<f64>,
    /// The vehicle's heading at the capture, degrees (`None`: not checked).
    pub expected_heading_deg: Option<f64>,
}

/// Why a picture does not count.
#[derive(Clone, Debug, PartialEq)]
pub enum Rejection {
    /// Taken too far from where it should have been.
    Position {
        /// Distance, metres (infinite when the position is not a number).
        distance_m: f64,
        /// The limit, metres.
        limit_m: f64,
    },
    /// Taken at the wrong altitude.
    Altitude {
        /// Capture altitude above home, metres.
        altitude_m: f64,
        /// Planned altitude, metres.
        planned_m: f64,
        /// The limit, metres.
        limit_m: f64,
    },
    /// The camera looked too far off the vertical.
    Tilt {
        /// Roll, degrees.
        roll_deg: f64,
        /// Pitch, degrees.
        pitch_deg: f64,
        /// Angle of the optical axis from the vertical, degrees.
        tilt_deg: f64,
        /// The limit, degrees.
        limit_deg: f64,
    },
    /// The camera's heading is not the vehicle's.
    Heading {
        /// The camera's, degrees.
        camera_deg: f64,
        /// The vehicle's, degrees.
        vehicle_deg: f64,
        /// The limit, degrees.
        limit_deg: f64,
    },
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Rejection::Position {
                distance_m,
                limit_m,
            } => {
                if distance_m.is_finite() {
                    write!(
                        f,
                        "taken {distance_m:.1} m from where it should have been (limit {limit_m:.1} m)"
                    )
                } else {
                    write!(f, "its position is not a number (limit {limit_m:.1} m)")
                }
            }
            Rejection::Altitude {
                altitude_m,
                planned_m,
                limit_m,
            } => write!(
                f,
                "taken at {altitude_m:.1} m above home, {:.1} m from the planned {planned_m:.1} m (limit {limit_m:.1} m)",
                (altitude_m - planned_m).abs()
            ),
            Rejection::Tilt {
                roll_deg,
                pitch_deg,
                tilt_deg,
                limit_deg,
            } => write!(
                f,
                "camera tilted {tilt_deg:.1}° off the vertical (roll {roll_deg:.1}°, pitch {pitch_deg:.1}°; limit {limit_deg:.0}°)"
            ),
            Rejection::Heading {
                camera_deg,
                vehicle_deg,
                limit_deg,
            } => write!(
                f,
                "camera heading {camera_deg:.0}° is not the vehicle's {vehicle_deg:.0}° (limit {limit_deg:.0}°)"
            ),
        }
    }
}

/// The smallest angle between two headings, degrees (0..=180).
pub(crate) fn heading_difference_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// Check `claim` against `limits` for a picture planned at `planned_altitude_m` above home:
/// the first of position, altitude, tilt, heading that fails (non-numbers fail).
pub fn check_capture(
    claim: &CaptureClaim,
    planned_altitude_m: f64,
    limits: &CaptureLimits,
) -> Result<(), Rejection> {
    if let Some(d) = claim.horizontal_offset_m
        && !(d.is_finite() && d <= limits.horizontal_m)
    {
        return Err(Rejection::Position {
            distance_m: if d.is_nan() { f64::INFINITY } else { d },
            limit_m: limits.horizontal_m,
        });
    }
    if let Some(a) = claim.altitude_m
        && !(a.is_finite() && (a - planned_altitude_m).abs() <= limits.vertical_m)
    {
        return Err(Rejection::Altitude {
            altitude_m: a,
            planned_m: planned_altitude_m,
            limit_m: limits.vertical_m,
        });
    }
    if let Some(att) = &claim.attitude {
        let tilt = super::geometry::tilt_deg(att);
        if !(tilt.is_finite() && tilt <= limits.max_tilt_deg) {
            let (roll_deg, pitch_deg, _) = super::geometry::euler_deg(att);
            return Err(Rejection::Tilt {
                roll_deg,
                pitch_deg,
                tilt_deg: tilt,
                limit_deg: limits.max_tilt_deg,
            });
        }
    }
    if let (Some(c), Some(v)) = (claim.heading_deg, claim.expected_heading_deg)
        && c.is_finite()
        && v.is_finite()
        && heading_difference_deg(c, v) > limits.max_heading_error_deg
    {
        return Err(Rejection::Heading {
            camera_deg: c.rem_euclid(360.0),
            vehicle_deg: v.rem_euclid(360.0),
            limit_deg: limits.max_heading_error_deg,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::geometry::attitude_from_euler_deg;
    use proptest::prelude::*;

    fn good() -> CaptureClaim {
        CaptureClaim {
            horizontal_offset_m: Some(0.3),
            altitude_m: Some(12.2),
            attitude: Some(attitude_from_euler_deg(1.0, -2.0, 91.0)),
            heading_deg: Some(91.0),
            expected_heading_deg: Some(89.0),
        }
    }

    #[test]
    fn a_picture_taken_there_passes() {
        let l = CaptureLimits::hover(0.5);
        assert_eq!(l.horizontal_m, 1.0);
        assert_eq!(check_capture(&good(), 12.0, &l), Ok(()));
        // nothing known: nothing to reject
        assert_eq!(check_capture(&CaptureClaim::default(), 12.0, &l), Ok(()));
    }

    #[test]
    fn each_limit_rejects_with_its_reason() {
        let l = CaptureLimits::hover(0.5);
        let far = CaptureClaim {
            horizontal_offset_m: Some(31.0),
            ..good()
        };
        let r = check_capture(&far, 12.0, &l).unwrap_err();
        assert!(matches!(r, Rejection::Position { distance_m, .. } if distance_m == 31.0));
        assert!(r.to_string().contains("31.0 m"), "{r}");
        let nan = CaptureClaim {
            horizontal_offset_m: Some(f64::NAN),
            ..good()
        };
        assert!(check_capture(&nan, 12.0, &l).is_err());
        // the boot pose: on the ground
        let low = CaptureClaim {
            altitude_m: Some(0.0),
            ..good()
        };
        let r = check_capture(&low, 12.0, &l).unwrap_err();
        assert!(matches!(r, Rejection::Altitude { .. }), "{r:?}");
        assert!(r.to_string().contains("12.0 m from the planned"), "{r}");
        let tilted = CaptureClaim {
            attitude: Some(attitude_from_euler_deg(8.0, 8.0, 90.0)),
            ..good()
        };
        let r = check_capture(&tilted, 12.0, &l).unwrap_err();
        match r {
            Rejection::Tilt {
                roll_deg,
                pitch_deg,
                tilt_deg,
                ..
            } => {
                assert!((roll_deg - 8.0).abs() < 1e-6 && (pitch_deg - 8.0).abs() < 1e-6);
                assert!(tilt_deg > 11.0 && tilt_deg < 11.5, "{tilt_deg}");
            }
            other => panic!("{other:?}"),
        }
        let turned = CaptureClaim {
            heading_deg: Some(0.0),
            ..good()
        };
        let r = check_capture(&turned, 12.0, &l).unwrap_err();
        assert!(matches!(r, Rejection::Heading { .. }), "{r:?}");
        // the first failing check is reported
        let all = CaptureClaim {
            horizontal_offset_m: Some(50.0),
            altitude_m: Some(0.0),
            ..good()
        };
        assert!(matches!(
            check_capture(&all, 12.0, &l),
            Err(Rejection::Position { .. })
        ));
    }

    #[test]
    fn headings_wrap() {
        assert!((heading_difference_deg(359.0, 1.0) - 2.0).abs() < 1e-12);
        assert!((heading_difference_deg(-90.0, 270.0)).abs() < 1e-12);
        let l = CaptureLimits::hover(0.5);
        let c = CaptureClaim {
            heading_deg: Some(355.0),
            expected_heading_deg: Some(3.0),
            ..CaptureClaim::default()
        };
        assert_eq!(check_capture(&c, 12.0, &l), Ok(()));
    }

    proptest! {
        /// The check passes exactly when every known quantity is within its limit.
        #[test]
        fn passes_exactly_within_the_limits(
            d in 0.0f64..3.0,
            alt in 8.0f64..16.0,
            roll in -20.0f64..20.0,
            pitch in -20.0f64..20.0,
            yaw in 0.0f64..360.0,
            vehicle in 0.0f64..360.0,
        ) {
            let l = CaptureLimits::hover(0.5);
            let att = attitude_from_euler_deg(roll, pitch, yaw);
            let c = CaptureClaim {
                horizontal_offset_m: Some(d),
                altitude_m: Some(alt),
                attitude: Some(att),
                heading_deg: Some(yaw),
                expected_heading_deg: Some(vehicle),
            };
            let tilt = crate::vision::geometry::tilt_deg(&att);
            let want = d <= l.horizontal_m
                && (alt - 12.0).abs() <= l.vertical_m
                && tilt <= l.max_tilt_deg
                && heading_difference_deg(yaw, vehicle) <= l.max_heading_error_deg;
            prop_assert_eq!(check_capture(&c, 12.0, &l).is_ok(), want);
        }
    }
}
