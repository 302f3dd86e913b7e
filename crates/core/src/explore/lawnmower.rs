//! The lawnmower (boustrophedon) sweep of §7's first mode: cover a bounding box known to
//! contain part of the ROI with image footprints that leave no gap, split among the robots,
//! as mission items for an AUTO mission.
//!
//! # Geometry
//! The box is in the grid's local frame (metres east/north of the grid origin). Lanes run
//! along the longer side of the box; the box is cut across the lanes into one strip per
//! robot, each strip as wide as its robot's share (proportional to its lane spacing, so
//! robots at different altitudes get balanced work). Inside a strip, `n` lanes sit at the
//! centres of `n` equal sub-strips no wider than the across-track spacing, and each lane has
//! `m` capture points at the centres of `m` equal pieces no longer than the along-track
//! spacing; every capture then covers its own sub-rectangle, so the union covers the box.
//!
//! # Heading and spacing
//! The footprint (`CameraModel::footprint(altitude)`: width along the image x axis, height
//! along y) rotates with the vehicle's heading, so the spacing depends on what the heading
//! can be at a capture ([`HeadingPolicy`]):
//! - [`HeadingPolicy::Any`] (default): no assumption. A w × h rectangle at any rotation always
//!   contains the centred disc of diameter min(w, h), and a rectangle a × b fits in that disc
//!   when a² + b² ≤ min(w, h)², so captures sit on a square lattice of side min(w, h)/√2.
//!   Safe whatever `WP_YAW_BEHAVIOR` (ArduPilot) or `MPC_YAW_MODE` (PX4) say, with wind crab,
//!   and while the vehicle yaws at the end of a lane.
//! - [`HeadingPolicy::AlongTrack`]: the nose points along the lane within ±θ (the autopilots'
//!   defaults yaw towards the next waypoint: ArduPilot `WP_YAW_BEHAVIOR` = 2, PX4
//!   `MPC_YAW_MODE` = 0). The image x axis is then across the track, and the a × b cell fits
//!   in the footprint rotated by up to θ when a·cosθ + b·sinθ ≤ w and a·sinθ + b·cosθ ≤ h.
//!
//! Both subtract `2 × position_tolerance_m` from the footprint first (the image centre may be
//! that far from the waypoint).
//!
//! # Mission items (both ArduPilot and PX4 execute them)
//! `NAV_TAKEOFF` (positioned at the first capture point: PX4 flies an airborne take-off item as
//! a waypoint to its position), `DO_CHANGE_SPEED`, then for every capture a `NAV_WAYPOINT` at the capture
//! point followed by `IMAGE_START_CAPTURE` with interval 0 and count 1 (one picture when the
//! waypoint is reached), and `NAV_RETURN_TO_LAUNCH` at the end. A capture item per waypoint
//! (rather than `DO_SET_CAM_TRIGG_DIST`, which depends on the autopilot's own trigger
//! configuration) gives exactly one image per planned footprint. PX4 accepts
//! `IMAGE_START_CAPTURE` in missions (PX4/PX4-Autopilot
//! `src/modules/navigator/mission_feasibility_checker.cpp`, `checkMissionItemValidity`);
//! ArduPilot executes it as a mission command and takes a single picture when the total is 1
//! (ArduPilot/ardupilot `libraries/AP_Mission/AP_Mission_Commands.cpp`,
//! `start_command_camera`). The waypoint's acceptance radius (param2, honoured by PX4) is the
//! position tolerance; param1 is the hold time.

use super::ExploreError;
use crate::mission::item::MissionItem;
use crate::vision::camera::CameraModel;
use serde::{Deserialize, Serialize};
use std::fmt::Display;

/// An axis-aligned rectangle in the grid's local frame, metres east/north of the grid
/// origin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocalBox {
    /// Western edge, metres east of the origin.
    pub east_min: f64,
    /// Eastern edge, metres east of the origin.
    pub east_max: f64,
    /// Southern edge, metres north of the origin.
    pub north_min: f64,
    /// Northern edge, metres north of the origin.
    pub north_max: f64,
}

impl LocalBox {
    /// East–west extent, metres.
    pub fn width(&self) -> f64 {
        self.east_max - self.east_min
    }

    /// North–south extent, metres.
    pub fn height(&self) -> f64 {
        self.north_max - self.north_min
    }

    /// Whether (`east`, `north`) is inside (edges included).
    pub fn contains(&self, east: f64, north: f64) -> bool {
        (self.east_min..=self.east_max).contains(&east)
            && (self.north_min..=self.north_max).contains(&north)
    }
}

/// What the vehicle's heading may be when an image is taken (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum HeadingPolicy {
    /// Any heading: spacing from the disc inscribed in the footprint.
    #[default]
    Any,
    /// Nose along the lane (either way) within ±`max_error_deg` (< 45°).
    AlongTrack {
        /// Largest deviation from the lane direction, degrees.
        max_error_deg: f64,
    },
}

/// Distances between captures that leave no gap, metres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spacing {
    /// Between lanes.
    pub across_m: f64,
    /// Between captures on a lane.
    pub(crate) along_m: f64,
}

/// The largest capture spacing that leaves no gap for `camera` at `altitude_m` with the
/// heading policy and a position error of up to `tolerance_m`.
pub(crate) fn capture_spacing(
    camera: &CameraModel,
    altitude_m: f64,
    heading: HeadingPolicy,
    tolerance_m: f64,
) -> Result<Spacing, ExploreError> {
    if !(altitude_m.is_finite() && altitude_m > 0.0) {
        return Err(ExploreError::Lawnmower(format!(
            "altitude {altitude_m} m must be positive"
        )));
    }
    if !(tolerance_m.is_finite() && tolerance_m >= 0.0) {
        return Err(ExploreError::Lawnmower(format!(
            "position tolerance {tolerance_m} m must be ≥ 0"
        )));
    }
    if !(camera.hfov_deg > 0.0 && camera.hfov_deg < 180.0) {
        return Err(ExploreError::Lawnmower(format!(
            "camera field of view {}° must be between 0 and 180",
            camera.hfov_deg
        )));
    }
    let (w, h) = camera.footprint(altitude_m);
    let (w, h) = (w - 2.0 * tolerance_m, h - 2.0 * tolerance_m);
    let s = match heading {
        HeadingPolicy::Any => {
            let d = w.min(h) / std::f64::consts::SQRT_2;
            Spacing {
                across_m: d,
                along_m: d,
            }
        }
        HeadingPolicy::AlongTrack { max_error_deg } => {
            if !(0.0..45.0).contains(&max_error_deg) {
                return Err(ExploreError::Lawnmower(format!(
                    "heading error {max_error_deg}° must be in [0, 45)"
                )));
            }
            let (sin, cos) = max_error_deg.to_radians().sin_cos();
            let det = cos * cos - sin * sin;
            Spacing {
                across_m: (w * cos - h * sin) / det,
                along_m: (h * cos - w * sin) / det,
            }
        }
    };
    if !(s.across_m > 0.0 && s.along_m > 0.0) {
        return Err(ExploreError::Lawnmower(format!(
            "the {w:.2} m × {h:.2} m footprint (after the position tolerance) at {altitude_m} m \
             leaves no usable spacing with heading policy {heading:?}"
        )));
    }
    Ok(s)
}

/// Inputs of the sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LawnmowerConfig {
    /// The bounding box to sweep (grid local frame, metres).
    pub area: LocalBox,
    /// The camera.
    pub camera: CameraModel,
    /// Flight altitude of each robot, metres relative to home: one entry per robot.
    pub altitudes_m: Vec<f64>,
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// What the heading may be at a capture.
    pub heading: HeadingPolicy,
    /// Worst distance between a waypoint and where the image is taken, metres.
    pub position_tolerance_m: f64,
    /// The distance between lanes, metres (`None`: the widest that leaves no gap, per
    /// robot, from `capture_spacing`). Wider than that is refused: it would leave gaps.
    #[serde(default)]
    pub lane_spacing_m: Option<f64>,
    /// Seconds to hold at each capture waypoint (0: fly through).
    pub hold_s: f64,
    /// End each mission with RETURN_TO_LAUNCH (the sweep found nothing).
    pub return_to_launch: bool,
}

/// One robot's part of the sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    /// Index of the robot (order of `altitudes_m`).
    pub robot: usize,
    /// Its altitude, metres.
    pub altitude_m: f64,
    /// Its strip of the box.
    pub strip: LocalBox,
    /// Whether lanes run north–south (else east–west).
    pub(crate) lanes_north_south: bool,
    /// The spacing actually used (≤ the allowed one).
    pub spacing: Spacing,
    /// Number of lanes.
    pub lanes: usize,
    /// Capture points in flight order, (east, north) metres from the grid origin.
    pub captures: Vec<(f64, f64)>,
    /// Index in `items` of each capture's waypoint.
    pub(crate) waypoint_seq: Vec<usize>,
    /// Length of the path from the first to the last capture, metres.
    pub length_m: f64,
    /// The mission (user numbering: no home item).
    pub items: Vec<MissionItem>,
}

/// Plan the sweep: one [`Sweep`] per robot (per entry of `altitudes_m`). `to_latlon` maps a
/// point of the grid's local frame (east, north metres) to (latitude, longitude) degrees —
/// e.g. `|e, n| grid.from_xy(e, n).map(|p| (p.lat, p.lon))`.
pub fn plan<F, E>(cfg: &LawnmowerConfig, to_latlon: F) -> Result<Vec<Sweep>, ExploreError>
where
    F: Fn(f64, f64) -> Result<(f64, f64), E>,
    E: Display,
{
    let b = cfg.area;
    let finite = [b.east_min, b.east_max, b.north_min, b.north_max]
        .iter()
        .all(|v| v.is_finite());
    if !finite || b.width() < 0.0 || b.height() < 0.0 {
        return Err(ExploreError::Lawnmower(format!(
            "bad bounding box: east {}..{} m, north {}..{} m",
            b.east_min, b.east_max, b.north_min, b.north_max
        )));
    }
    if cfg.altitudes_m.is_empty() {
        return Err(ExploreError::Lawnmower("no robots (no altitudes)".into()));
    }
    if !(cfg.speed_mps.is_finite() && cfg.speed_mps > 0.0) {
        return Err(ExploreError::Lawnmower(format!(
            "speed {} m/s must be positive",
            cfg.speed_mps
        )));
    }
    if !(cfg.hold_s.is_finite() && cfg.hold_s >= 0.0) {
        return Err(ExploreError::Lawnmower(format!(
            "hold time {} s must be ≥ 0",
            cfg.hold_s
        )));
    }
    let spacings = cfg
        .altitudes_m
        .iter()
        .map(|&a| {
            let mut s = capture_spacing(&cfg.camera, a, cfg.heading, cfg.position_tolerance_m)?;
            if let Some(l) = cfg.lane_spacing_m {
                if !(l.is_finite() && l > 0.0) {
                    return Err(ExploreError::Lawnmower(format!(
                        "lane spacing {l} m must be positive"
                    )));
                }
                if l > s.across_m + 1e-9 {
                    return Err(ExploreError::Lawnmower(format!(
                        "a lane spacing of {l} m leaves gaps between the lanes: at {a} m the \
                         camera covers at most {:.2} m across without one (heading {:?}, \
                         position tolerance {} m)",
                        s.across_m, cfg.heading, cfg.position_tolerance_m
                    )));
                }
                s.across_m = l;
            }
            Ok(s)
        })
        .collect::<Result<Vec<_>, ExploreError>>()?;
    let ns = b.height() >= b.width();
    // (across, along) extents in metres, and a mapping back to (east, north).
    let (across0, across_len, along0, along_len) = if ns {
        (b.east_min, b.width(), b.north_min, b.height())
    } else {
        (b.north_min, b.height(), b.east_min, b.width())
    };
    let to_en = |across: f64, along: f64| if ns { (across, along) } else { (along, across) };
    let total: f64 = spacings.iter().map(|s| s.across_m).sum();
    let mut out = Vec::with_capacity(spacings.len());
    let mut start = across0;
    for (k, (sp, &alt)) in spacings.iter().zip(&cfg.altitudes_m).enumerate() {
        let width = across_len * sp.across_m / total;
        let lanes = ((width / sp.across_m).ceil() as usize).max(1);
        let points = ((along_len / sp.along_m).ceil() as usize).max(1);
        let (da, dl) = (width / lanes as f64, along_len / points as f64);
        let mut captures = Vec::with_capacity(lanes * points);
        for lane in 0..lanes {
            let a = start + (lane as f64 + 0.5) * da;
            for p in 0..points {
                let p = if lane % 2 == 0 { p } else { points - 1 - p };
                captures.push(to_en(a, along0 + (p as f64 + 0.5) * dl));
            }
        }
        let length_m = captures
            .windows(2)
            .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
            .sum();
        let alt_f = alt as f32;
        // The take-off item carries the first capture point as its position: PX4 flies a
        // take-off item as a waypoint once airborne ([`MissionItem::takeoff_at`]).
        let takeoff = match captures.first() {
            Some(&(e, n)) => {
                let (lat, lon) = to_latlon(e, n).map_err(|err| ExploreError::Projection {
                    east_m: e,
                    north_m: n,
                    reason: err.to_string(),
                })?;
                MissionItem::takeoff_at(lat, lon, alt_f)
            }
            None => MissionItem::takeoff(alt_f),
        };
        let mut items = vec![takeoff, MissionItem::change_speed(cfg.speed_mps as f32)];
        let mut waypoint_seq = Vec::with_capacity(captures.len());
        for &(e, n) in &captures {
            let (lat, lon) = to_latlon(e, n).map_err(|err| ExploreError::Projection {
                east_m: e,
                north_m: n,
                reason: err.to_string(),
            })?;
            waypoint_seq.push(items.len());
            let mut wp = MissionItem::waypoint(lat, lon, alt_f);
            wp.param1 = cfg.hold_s as f32;
            wp.param2 = cfg.position_tolerance_m as f32;
            items.push(wp);
            items.push(MissionItem::image_start_capture(0.0, 1));
        }
        if cfg.return_to_launch {
            items.push(MissionItem::return_to_launch());
        }
        let (s0, s1) = (start, start + width);
        let strip = if ns {
            LocalBox {
                east_min: s0,
                east_max: s1,
                ..b
            }
        } else {
            LocalBox {
                north_min: s0,
                north_max: s1,
                ..b
            }
        };
        out.push(Sweep {
            robot: k,
            altitude_m: alt,
            strip,
            lanes_north_south: ns,
            spacing: Spacing {
                across_m: da,
                along_m: dl,
            },
            lanes,
            captures,
            waypoint_seq,
            length_m,
            items,
        });
        start += width;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::local;
    use crate::mission::item::cmd;

    fn runway_box() -> LocalBox {
        // docs/fixtures.md: north −8 … +32 m, east −20 … +20 m.
        LocalBox {
            east_min: -20.0,
            east_max: 20.0,
            north_min: -8.0,
            north_max: 32.0,
        }
    }

    fn cfg(altitudes: Vec<f64>, heading: HeadingPolicy) -> LawnmowerConfig {
        LawnmowerConfig {
            area: runway_box(),
            camera: CameraModel::paper(),
            altitudes_m: altitudes,
            speed_mps: 1.0,
            heading,
            position_tolerance_m: 1.0,
            lane_spacing_m: None,
            hold_s: 0.0,
            return_to_launch: true,
        }
    }

    fn latlon(e: f64, n: f64) -> Result<(f64, f64), std::convert::Infallible> {
        Ok(local::offset(37.1966, -80.5785, n, e))
    }

    /// Every point of the box is inside the (rotated) footprint of some capture, for every
    /// heading the policy allows.
    fn assert_covered(sweeps: &[Sweep], cam: &CameraModel, headings: &[f64], tol: f64) {
        let b = runway_box();
        let steps = 80;
        for i in 0..=steps {
            for j in 0..=steps {
                let e = b.east_min + b.width() * i as f64 / steps as f64;
                let n = b.north_min + b.height() * j as f64 / steps as f64;
                let covered = sweeps.iter().any(|s| {
                    let (w, h) = cam.footprint(s.altitude_m);
                    let (w, h) = (w / 2.0 - tol, h / 2.0 - tol);
                    s.captures.iter().any(|&(ce, cn)| {
                        headings.iter().all(|&hd| {
                            // Heading hd (clockwise from north; for north–south lanes the
                            // lane heading is 0): image y axis along hd, x to its right.
                            let (sin, cos) = hd.to_radians().sin_cos();
                            let (de, dn) = (e - ce, n - cn);
                            let y = de * sin + dn * cos;
                            let x = de * cos - dn * sin;
                            x.abs() <= w + 1e-9 && y.abs() <= h + 1e-9
                        })
                    })
                });
                assert!(covered, "({e:.2}, {n:.2}) not covered");
            }
        }
    }

    #[test]
    fn any_heading_covers_the_box() {
        let c = cfg(vec![12.0, 14.0, 16.0], HeadingPolicy::Any);
        let sweeps = plan(&c, latlon).unwrap();
        assert_eq!(sweeps.len(), 3);
        let headings: Vec<f64> = (0..36).map(|k| k as f64 * 10.0).collect();
        assert_covered(&sweeps, &c.camera, &headings, 1.0);
        // Strips tile the box, widths proportional to the spacing.
        assert_eq!(sweeps[0].strip.east_min, -20.0);
        assert!((sweeps[2].strip.east_max - 20.0).abs() < 1e-9);
        for w in sweeps.windows(2) {
            assert!((w[0].strip.east_max - w[1].strip.east_min).abs() < 1e-9);
        }
        let sp = capture_spacing(&c.camera, 12.0, HeadingPolicy::Any, 1.0).unwrap();
        assert!((sp.across_m - 10.0 / 2f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn along_track_covers_within_its_heading_error() {
        let c = cfg(
            vec![12.0],
            HeadingPolicy::AlongTrack {
                max_error_deg: 10.0,
            },
        );
        let sweeps = plan(&c, latlon).unwrap();
        // Lanes run north–south (the box is square: height ≥ width); headings 0 or 180 ± 10°.
        assert!(sweeps[0].lanes_north_south);
        for base in [0.0, 180.0] {
            for d in [-10.0, -5.0, 0.0, 5.0, 10.0] {
                assert_covered(&sweeps, &c.camera, &[base + d], 1.0);
            }
        }
        // Fewer captures than with any heading.
        let any = plan(&cfg(vec![12.0], HeadingPolicy::Any), latlon).unwrap();
        assert!(sweeps[0].captures.len() < any[0].captures.len());
    }

    #[test]
    fn mission_items_and_boustrophedon_order() {
        let sweeps = plan(&cfg(vec![12.0, 12.0], HeadingPolicy::Any), latlon).unwrap();
        let s = &sweeps[0];
        assert_eq!(s.items[0].command, cmd::NAV_TAKEOFF);
        assert_eq!(s.items[0].z, 12.0);
        assert_eq!(s.items[1].command, cmd::DO_CHANGE_SPEED);
        assert_eq!(s.items.last().unwrap().command, cmd::NAV_RETURN_TO_LAUNCH);
        assert_eq!(s.waypoint_seq.len(), s.captures.len());
        for (&seq, &(e, n)) in s.waypoint_seq.iter().zip(&s.captures) {
            let wp = s.items[seq];
            assert_eq!(wp.command, cmd::NAV_WAYPOINT);
            let (lat, lon) = latlon(e, n).unwrap();
            assert!((wp.lat() - lat).abs() < 1e-7 && (wp.lon() - lon).abs() < 1e-7);
            let cap = s.items[seq + 1];
            assert_eq!(cap.command, cmd::IMAGE_START_CAPTURE);
            assert_eq!((cap.param2, cap.param3), (0.0, 1.0));
            assert!(s.strip.contains(e, n));
        }
        // Consecutive captures are one spacing apart: along a lane, or across to the next.
        for w in s.captures.windows(2) {
            let d = (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1);
            assert!(
                (d - s.spacing.along_m).abs() < 1e-9 || (d - s.spacing.across_m).abs() < 1e-9,
                "{d}"
            );
        }
        assert!(s.lanes >= 2);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let mut c = cfg(vec![12.0], HeadingPolicy::Any);
        c.altitudes_m = vec![];
        assert!(plan(&c, latlon).is_err());
        c.altitudes_m = vec![-1.0];
        assert!(plan(&c, latlon).is_err());
        c.altitudes_m = vec![12.0];
        c.position_tolerance_m = 7.0;
        assert!(plan(&c, latlon).is_err());
        c.position_tolerance_m = 1.0;
        c.area.east_max = f64::NAN;
        assert!(plan(&c, latlon).is_err());
        c.area = runway_box();
        let failing = |_: f64, _: f64| Err::<(f64, f64), _>("outside the UTM zone");
        let err = plan(&c, failing).unwrap_err();
        assert!(err.to_string().contains("outside the UTM zone"));
        assert!(
            capture_spacing(
                &c.camera,
                12.0,
                HeadingPolicy::AlongTrack {
                    max_error_deg: 50.0
                },
                0.0
            )
            .is_err()
        );
    }

    #[test]
    fn wide_box_runs_east_west() {
        let mut c = cfg(vec![12.0], HeadingPolicy::Any);
        c.area = LocalBox {
            east_min: 0.0,
            east_max: 100.0,
            north_min: 0.0,
            north_max: 10.0,
        };
        let s = &plan(&c, latlon).unwrap()[0];
        assert!(!s.lanes_north_south);
        assert_eq!(s.lanes, 2);
        // First lane goes east, second comes back west.
        assert!(s.captures[1].0 > s.captures[0].0);
        let last = s.captures.len() - 1;
        assert!(s.captures[last].0 < s.captures[last - 1].0);
    }

    #[test]
    fn a_given_lane_spacing_is_flown_and_a_gapped_one_refused() {
        // The paper's camera at 12 m: a 12 m footprint, 1 m tolerance → 10 m / √2 = 7.07 m.
        let cam = CameraModel::paper();
        let widest = capture_spacing(&cam, 12.0, HeadingPolicy::Any, 1.0).unwrap();
        assert!((widest.across_m - 5.0 * std::f64::consts::SQRT_2).abs() < 1e-9);
        let auto = plan(&cfg(vec![12.0], HeadingPolicy::Any), latlon).unwrap();
        let mut c = cfg(vec![12.0], HeadingPolicy::Any);
        c.lane_spacing_m = Some(4.0);
        let narrow = plan(&c, latlon).unwrap();
        assert!(narrow[0].spacing.across_m <= 4.0 + 1e-9);
        assert!(narrow[0].lanes > auto[0].lanes);
        assert_covered(&narrow, &cam, &[0.0, 45.0, 90.0], 1.0);
        c.lane_spacing_m = Some(12.0);
        let err = plan(&c, latlon).unwrap_err().to_string();
        assert!(err.contains("leaves gaps") && err.contains("7.07"), "{err}");
    }
}
