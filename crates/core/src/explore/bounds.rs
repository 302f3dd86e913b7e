//! The bounds of the runway paper: Lemma 1 (upper bound on Algorithm 1, eq. 2), eq. (8)
//! (single robot), Lemma 2 (lower bound on the optimum, eq. 10), Theorems 1 and 2
//! (competitive ratios, eqs. 13 and 18) and §6's lawnmower baseline.
//!
//! Units: one cell is one length unit (the paper's unit footprint); speeds are cells per
//! time unit, so the bounds are times.
//!
//! **Which logarithm.** Lemma 1 writes ⌊log R⌋ without a base. It is Higashikawa et al.'s
//! term for a *binary* tree explored by robots halved at every branch: after ⌊log₂ R⌋ splits
//! the groups are single robots, which is why `1 + ⌊log₂ R⌋` reward functions sit on each
//! backbone edge. So the base is 2. It is also the stricter reading: eq. (2) is
//! `2(C + d·k)/((S_r − S_p)(1 + k))`, which decreases in `k` whenever `d_max < C` (always
//! true, `d_max ≤ C − 1`), and base 2 gives the largest `k`.
//!
//! **What the bounds are about.** `d_max` is the depth of the farthest vertex of the tree the
//! run built (§4.2: real edges length 1, dummy edges 0), not a grid distance. ALG is Problem 1's
//! exploration time: when the last robot is back at the start. Eq. (2) charges every move at the
//! slowest relative speed S_r − S_p; a simulation that charges each move at its own relative
//! speed (against, with or across the flow) can only be faster. The proof's eq. (3) assumes every
//! robot heads home as soon as the last leaf is reached, and its eq. (1) that no robot walks a rib
//! edge forward a second time; meeting-only sharing breaks both (docs/results/dfs.md).

use crate::geo::Cell;

/// ⌊log₂ r⌋ (0 for r ≤ 1).
pub(crate) fn floor_log2(r: usize) -> u32 {
    if r <= 1 {
        0
    } else {
        usize::BITS - 1 - r.leading_zeros()
    }
}

/// Lemma 1, eq. (2): `ALG ≤ 2(C + d_max⌊log R⌋) / ((S_r − S_p)(1 + ⌊log R⌋))` for `cells` = C
/// ROI cells, `d_max` of the built tree, `robots` = R, robot speed S_r and ROI speed S_p.
pub fn lemma1_upper_bound(
    cells: usize,
    d_max: u32,
    robots: usize,
    robot_speed: f64,
    roi_speed: f64,
) -> f64 {
    let k = f64::from(floor_log2(robots));
    2.0 * (cells as f64 + f64::from(d_max) * k) / ((robot_speed - roi_speed) * (1.0 + k))
}

/// Lemma 2, eq. (10): `OPT ≥ (C − 1) / ((S_r + S_p) R)`.
pub fn lemma2_lower_bound(cells: usize, robots: usize, robot_speed: f64, roi_speed: f64) -> f64 {
    cells.saturating_sub(1) as f64 / ((robot_speed + roi_speed) * robots.max(1) as f64)
}

/// Eq. (8), the tighter single-robot bound (R = 1, translating ROI): every tree edge is
/// flown once out and once back, and an edge flown against the ROI's motion on one pass is
/// flown with it on the other, so `ALG ≤ (C − 1)/(S_r + S_p) + (C − 1)/(S_r − S_p)` (eq. 7)
/// `≤ 2 S_r C / ((S_r + S_p)(S_r − S_p))`. With S_p = 0 it is Table 1's SRSR bound 2C/S_r.
/// Only meaningful for one robot.
pub fn eq8_single_robot_bound(cells: usize, robot_speed: f64, roi_speed: f64) -> f64 {
    2.0 * robot_speed * cells as f64 / ((robot_speed + roi_speed) * (robot_speed - roi_speed))
}

/// The lower bound on OPT used in the proofs of Theorems 1 and 2: OPT ≥ (C − 1)/((S_r +
/// S_p) R) (Lemma 2, eq. 10; eq. 19 for Theorem 2 with C_in^BEST, which is C on a grid ROI)
/// and OPT ≥ d_max/(S_r + S_p) (used between eqs. 14 and 15). Time units.
pub fn opt_lower_bound(
    cells: usize,
    d_max: u32,
    robots: usize,
    robot_speed: f64,
    roi_speed: f64,
) -> f64 {
    lemma2_lower_bound(cells, robots, robot_speed, roi_speed)
        .max(f64::from(d_max) / (robot_speed + roi_speed))
}

/// Theorem 1 (eq. 13) as a pair (competitive ratio, additive term):
/// `ALG ≤ 2(S_r + S_p)(R + ⌊log R⌋) / ((S_r − S_p)(1 + ⌊log R⌋)) · OPT + 2/((S_r − S_p)(1 + ⌊log R⌋))`.
pub fn theorem1_ratio(robots: usize, robot_speed: f64, roi_speed: f64) -> (f64, f64) {
    let k = f64::from(floor_log2(robots));
    let m = (robot_speed - roi_speed) * (1.0 + k);
    (
        2.0 * (robot_speed + roi_speed) * (robots.max(1) as f64 + k) / m,
        2.0 / m,
    )
}

/// Theorem 2 (eq. 18, arbitrary fat ROI shapes) as (competitive ratio, additive term):
/// `2(S_r + S_p)(18R + ⌊log R⌋)/M · OPT + 48/M` with `M = (S_r − S_p)(1 + ⌊log R⌋)`.
pub fn theorem2_ratio(robots: usize, robot_speed: f64, roi_speed: f64) -> (f64, f64) {
    let k = f64::from(floor_log2(robots));
    let m = (robot_speed - roi_speed) * (1.0 + k);
    (
        2.0 * (robot_speed + roi_speed) * (18.0 * robots.max(1) as f64 + k) / m,
        48.0 / m,
    )
}

/// A theorem's right-hand side `ratio · OPT + additive` evaluated at OPT =
/// [`opt_lower_bound`]. The theorems hold for every OPT at least that large, so this is
/// an upper bound on ALG; for Theorem 1 it is never below Lemma 1 (eq. 14 → 15 only uses
/// those two lower bounds on OPT).
pub fn theorem_bound_at(ratio: (f64, f64), opt_lower: f64) -> f64 {
    ratio.0 * opt_lower + ratio.1
}

/// Time for a robot at ground speed `robot_speed` to fly from the start to the point at
/// ROI-frame offset (`dx`, `dy`) cells (east, north) and back, straight each way, with the
/// ROI moving at `v` (east, north): `d/λ(u) + d/λ(−u)`. The largest over the ROI's cells is
/// a lower bound on any strategy that starts and ends at the start and must image every
/// cell — the lawnmower baseline of §6 ignores it.
pub fn round_trip_time(dx: f64, dy: f64, robot_speed: f64, v: (f64, f64)) -> f64 {
    let d = dx.hypot(dy);
    if d == 0.0 {
        return 0.0;
    }
    let u = (dx / d, dy / d);
    d / lambda(robot_speed, v, u) + d / lambda(robot_speed, v, (-u.0, -u.1))
}

/// λ along a unit axis direction for a ROI moving at `v` (east, north), robot speed `sr`.
fn lambda(sr: f64, v: (f64, f64), u: (f64, f64)) -> f64 {
    let uv = u.0 * v.0 + u.1 * v.1;
    -uv + (sr * sr - (v.0 * v.0 + v.1 * v.1) + uv * uv).sqrt()
}

/// Time for one robot to cover a `w` × `h` (cells, east × north) rectangle with a
/// boustrophedon of unit-footprint lanes, starting inside it: the best over lane
/// orientation, first-lane direction and the direction lanes step in.
pub(crate) fn lawnmower_rectangle_time(w: usize, h: usize, robot_speed: f64, v: (f64, f64)) -> f64 {
    if w == 0 || h == 0 {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    // (lane count, lane length, lane axis, step axis)
    let layouts = [
        (w, h, (0.0, 1.0), (1.0, 0.0)), // lanes run north–south, stepping east/west
        (h, w, (1.0, 0.0), (0.0, 1.0)), // lanes run east–west, stepping north/south
    ];
    for (lanes, len, along, step) in layouts {
        for first in [1.0, -1.0] {
            for side in [1.0, -1.0] {
                let fwd = lambda(robot_speed, v, (along.0 * first, along.1 * first));
                let back = lambda(robot_speed, v, (-along.0 * first, -along.1 * first));
                let st = lambda(robot_speed, v, (step.0 * side, step.1 * side));
                let n_fwd = lanes.div_ceil(2) as f64;
                let n_back = (lanes / 2) as f64;
                let l = (len - 1) as f64;
                let t = n_fwd * l / fwd + n_back * l / back + (lanes - 1) as f64 / st;
                best = best.min(t);
            }
        }
    }
    best
}

/// §6's lawnmower baseline: it knows the tightest axis-aligned rectangle containing the ROI,
/// splits it into `robots` strips along its length or along its breadth, covers each strip
/// with a lawnmower (ignoring the flight from the start to the strips) and keeps the better
/// of the two splits. The time is that of the largest strip. The grid is aligned with the
/// ROI's direction of motion, as in §6.
pub fn lawnmower_baseline(
    cells: impl IntoIterator<Item = Cell>,
    robots: usize,
    robot_speed: f64,
    roi_velocity: (f64, f64),
) -> f64 {
    let mut it = cells.into_iter();
    let Some(first) = it.next() else {
        return 0.0;
    };
    let (mut r0, mut r1, mut c0, mut c1) = (first.row, first.row, first.col, first.col);
    for c in it {
        r0 = r0.min(c.row);
        r1 = r1.max(c.row);
        c0 = c0.min(c.col);
        c1 = c1.max(c.col);
    }
    let w = (c1 - c0 + 1) as usize;
    let h = (r1 - r0 + 1) as usize;
    let r = robots.max(1);
    let split_w = lawnmower_rectangle_time(w.div_ceil(r), h, robot_speed, roi_velocity);
    let split_h = lawnmower_rectangle_time(w, h.div_ceil(r), robot_speed, roi_velocity);
    split_w.min(split_h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logs() {
        assert_eq!(
            [0, 1, 2, 3, 4, 7, 8, 20, 32].map(floor_log2),
            [0, 0, 1, 1, 2, 2, 3, 4, 5]
        );
    }

    #[test]
    fn lemma_values() {
        // Single robot, static: 2C/S_r (Table 1, SRSR).
        assert_eq!(lemma1_upper_bound(10, 7, 1, 1.0, 0.0), 20.0);
        // R = 20: k = 4, 2(120 + 4·30)/(1.5·5).
        let b = lemma1_upper_bound(120, 30, 20, 2.5, 1.0);
        assert!((b - 2.0 * (120.0 + 120.0) / (1.5 * 5.0)).abs() < 1e-12);
        assert!((lemma2_lower_bound(121, 4, 2.0, 0.5) - 120.0 / 10.0).abs() < 1e-12);
    }

    #[test]
    fn eq8_and_theorems() {
        // Static: eq. 8 is 2C/S_r.
        assert_eq!(eq8_single_robot_bound(10, 1.0, 0.0), 20.0);
        // S_r = 1, S_p = 0.4: 2·10/(1.4·0.6).
        assert!((eq8_single_robot_bound(10, 1.0, 0.4) - 20.0 / 0.84).abs() < 1e-12);
        // Eq. 8 is tighter than SRTR's 2C/(S_r − S_p).
        assert!(eq8_single_robot_bound(10, 1.0, 0.4) < 20.0 / 0.6);
        // R = 1, static: Theorem 1 is 2·OPT + 2 (2(R + 0)/1).
        assert_eq!(theorem1_ratio(1, 1.0, 0.0), (2.0, 2.0));
        // R = 20, S_p = 0.4: k = 4.
        let (r, a) = theorem1_ratio(20, 1.0, 0.4);
        assert!((r - 2.0 * 1.4 * 24.0 / 3.0).abs() < 1e-12);
        assert!((a - 2.0 / 3.0).abs() < 1e-12);
        let (r2, a2) = theorem2_ratio(20, 1.0, 0.4);
        assert!((r2 - 2.0 * 1.4 * 364.0 / 3.0).abs() < 1e-12);
        assert!((a2 - 16.0).abs() < 1e-12);
        // Theorem 1 at OPT's lower bound is never below Lemma 1.
        for (c, d, rr, sp) in [(120, 30, 20, 0.4), (7, 2, 2, 0.0), (200, 5, 1, 0.2)] {
            let lb = opt_lower_bound(c, d, rr, 1.0, sp);
            let t1 = theorem_bound_at(theorem1_ratio(rr, 1.0, sp), lb);
            assert!(t1 >= lemma1_upper_bound(c, d, rr, 1.0, sp) - 1e-9);
        }
        // Round trips: static, 3-4-5 triangle; against then with a northward ROI.
        assert_eq!(round_trip_time(3.0, 4.0, 1.0, (0.0, 0.0)), 10.0);
        let t = round_trip_time(0.0, 2.0, 1.0, (0.0, 0.5));
        assert!((t - (2.0 / 0.5 + 2.0 / 1.5)).abs() < 1e-12);
    }

    #[test]
    fn lawnmower_static_and_moving() {
        // Static: w·h − 1 unit moves.
        assert_eq!(lawnmower_rectangle_time(3, 4, 1.0, (0.0, 0.0)), 11.0);
        assert_eq!(lawnmower_rectangle_time(1, 1, 1.0, (0.0, 0.0)), 0.0);
        // A 1 × 5 strip in a ROI moving north at 0.5: run south against it at 1.5.
        let t = lawnmower_rectangle_time(1, 5, 1.0, (0.0, 0.5));
        assert!((t - 4.0 / 1.5).abs() < 1e-12);
        // Baseline: 10 × 2 box, 2 robots: split along the length → two 5 × 2 strips (9 moves).
        let cells: Vec<Cell> = (0..10)
            .flat_map(|c| (0..2).map(move |r| Cell::new(r, c)))
            .collect();
        assert_eq!(lawnmower_baseline(cells.clone(), 2, 1.0, (0.0, 0.0)), 9.0);
        // 40 robots: one column each (1 × 2 strips) → 1 move.
        assert_eq!(lawnmower_baseline(cells, 40, 1.0, (0.0, 0.0)), 1.0);
    }
}
