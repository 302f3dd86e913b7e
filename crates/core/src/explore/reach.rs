//! Reach of a moving region's cell: before a drone flies out to a cell — a
//! confirmation, a DFS move, a rejoin after a swap — can it get there, take the cell's pictures
//! and still come home on what its battery holds? Pure: no clock, no I/O; the region's time
//! comes in as `now`.
//!
//! The rule ([`reach`]):
//!
//! 1. A region drifting at least as fast as the drones cruise (|v| ≥ S_r) cannot be followed:
//!    no intercept exists in general, and a drone cannot stay over a cell for its pictures.
//!    [`Reach::BeyondReach`] ([`Unreachable::Outpaced`]).
//! 2. **Fly** when the charge now, less the leg out (the flight to the intercept, where the
//!    cell's centre will be when the drone gets there at S_r, [`RoiMotion::intercept`]) and
//!    the time over the cell (`dwell_s`, during which the cell drifts on), still covers the
//!    return home from where the cell will be at the end of the visit: flight home, descent,
//!    landing margin and the reserve (`BatteryModel::return_pct`, the runner's return rule).
//! 3. Otherwise, would a fresh battery from home do? A drone leaving home at any time from now
//!    on, with the charge a swapped battery is guaranteed to report (`full_pct`, less
//!    `MARGIN_PCT`), arriving at time T where the cell is then, costs a round trip that grows
//!    with the cell's distance from home at T and T + `dwell_s`. That distance is convex in T,
//!    and the earliest possible arrival is the intercept from home leaving now; so the best
//!    trip is found on [earliest arrival, closest approach] by a ternary search. When even the
//!    best is more than `full_pct` can pay, the cell is [`Reach::BeyondReach`]
//!    ([`Unreachable::OutOfRange`]): waiting or swapping will never bring it within reach (a
//!    region drifting away only gets farther).
//! 4. Within reach from home: [`Reach::SwapFirst`] when a swap would give the drone more
//!    charge than it has; with a battery as full as a swap gives, [`Reach::Wait`] when the
//!    cell comes within reach only later (it drifts towards home), else `SwapFirst` (the drone
//!    is farther from the cell than home is).
//!
//! `MARGIN_PCT` makes the fresh-battery test of step 3 a little stricter than the test of
//! step 2, so that a drone standing at home on a fresh battery is never told to swap for the
//! same battery again (the two tests differ only by where the drone stands, a metre or two).

use super::motion::RoiMotion;
use crate::geo::Cell;
use crate::time::Time;
use serde::{Deserialize, Serialize};

/// Points of charge by which the from-home test (step 3) is stricter than the test from where
/// the drone is (step 2): 1 % of a 12-minute battery is 7 s of flight, several metres — more
/// than a landed drone is off its home.
pub(crate) const MARGIN_PCT: f64 = 1.0;

/// How the run charges a flight against the battery: the runner's return rule
/// (`MappingState::battery_needed_pct`) and the flight time it is measured in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryModel {
    /// Flight time on a full battery, seconds.
    pub(crate) endurance_s: f64,
    /// Cruise speed over the ground, m/s.
    pub speed_m_s: f64,
    /// Charge kept in reserve on landing, percent.
    pub(crate) reserve_pct: f64,
    /// Descent rate on the way home, m/s.
    pub descent_rate_m_s: f64,
    /// Seconds added for the approach, the landing and wind.
    pub landing_margin_s: f64,
}

impl BatteryModel {
    /// Charge `secs` seconds of flight use, percent.
    pub(crate) fn flight_pct(&self, secs: f64) -> f64 {
        100.0 * secs.max(0.0) / self.endurance_s.max(1.0)
    }

    /// Charge needed to get home from `distance_home_m` away at `altitude_m` and land, plus
    /// the reserve, percent: the flight home at the cruise speed, the descent and the landing
    /// margin as a share of the endurance.
    pub(crate) fn return_pct(&self, distance_home_m: f64, altitude_m: f64) -> f64 {
        let home_s = distance_home_m.max(0.0) / self.speed_m_s.max(0.1)
            + altitude_m.max(0.0) / self.descent_rate_m_s.max(0.01)
            + self.landing_margin_s.max(0.0);
        self.reserve_pct + self.flight_pct(home_s)
    }
}

/// The drone and the flight being judged. Positions are ground metres (east, north) of the
/// grid origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leg {
    /// Where the drone is now.
    pub from: (f64, f64),
    /// Where it lands to change its battery.
    pub home: (f64, f64),
    /// Its flight altitude above home, metres (the descent on the way home).
    pub altitude_m: f64,
    /// Its charge now, percent.
    pub(crate) charge_pct: f64,
    /// Seconds it stays over the cell once there (its pictures), following the cell as it
    /// drifts: flight time charged, and the return starts that much farther along.
    pub dwell_s: f64,
}

/// Why a cell cannot be reached, even on a full battery from home.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "why", rename_all = "snake_case")]
pub enum Unreachable {
    /// The region drifts at least as fast as the drones fly.
    Outpaced {
        /// The region's speed over the ground, m/s.
        drift_m_s: f64,
        /// The drones' cruise speed, m/s.
        speed_m_s: f64,
    },
    /// The best round trip from home, whenever it starts, needs more than a full battery.
    OutOfRange {
        /// How far from home the cell is at the best arrival, metres.
        distance_m: f64,
        /// Charge that trip needs (out, over the cell, back, reserve), percent.
        needed_pct: f64,
        /// The charge a swapped battery is counted on for, percent.
        full_pct: f64,
    },
}

impl std::fmt::Display for Unreachable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unreachable::Outpaced {
                drift_m_s,
                speed_m_s,
            } => write!(
                f,
                "the region drifts at {drift_m_s:.2} m/s, the drones fly at {speed_m_s:.2} m/s"
            ),
            Unreachable::OutOfRange {
                distance_m,
                needed_pct,
                full_pct,
            } => write!(
                f,
                "at best {distance_m:.0} m from home, a round trip of {needed_pct:.0} % of a \
                 battery (a full one counts {full_pct:.0} %)"
            ),
        }
    }
}

/// The verdict on a flight to a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// Go: the charge covers the leg out, the cell's pictures and the return.
    Fly {
        /// Seconds of the leg out.
        leg_s: f64,
        /// Where the cell's centre will be on arrival, ground metres (east, north).
        arrival: (f64, f64),
        /// Charge left at the end of the visit less what the return needs, percent (≥ 0).
        spare_pct: f64,
    },
    /// Change the battery first (a fresh one from home reaches the cell).
    SwapFirst {
        /// Charge the flight from here needs (out, over the cell, back, reserve), percent.
        needed_pct: f64,
    },
    /// A swap would not help yet: the cell comes within reach later (it drifts towards home).
    Wait {
        /// Seconds until a drone leaving home could make the trip.
        secs: f64,
    },
    /// Not even a full battery from home reaches the cell and brings the drone back, now or
    /// later.
    BeyondReach(Unreachable),
}

/// Judge a flight to the centre of region cell `cell` (square cells of `cell_m` metres) of a
/// region moving as `motion`, at region time `now` (see the module docs). `full_pct` is the
/// charge a swapped battery is guaranteed to report.
pub fn reach(
    motion: &RoiMotion,
    cell: Cell,
    cell_m: f64,
    now: Time,
    leg: &Leg,
    battery: &BatteryModel,
    full_pct: f64,
) -> Reach {
    let speed = battery.speed_m_s;
    let drift = motion.speed();
    let outpaced = Reach::BeyondReach(Unreachable::Outpaced {
        drift_m_s: drift,
        speed_m_s: speed,
    });
    if !(speed.is_finite() && drift.is_finite() && speed > drift) {
        return outpaced;
    }
    let dwell = leg.dwell_s.max(0.0);
    let (ve, vn) = (motion.velocity_east, motion.velocity_north);
    let dist_home = |(e, n): (f64, f64)| (e - leg.home.0).hypot(n - leg.home.1);
    let Ok((tau, arrival)) = motion.intercept(leg.from.0, leg.from.1, now, cell, cell_m, speed)
    else {
        return outpaced;
    };
    // Step 2: from here, now.
    let leave = (arrival.0 + ve * dwell, arrival.1 + vn * dwell);
    let needed =
        battery.flight_pct(tau + dwell) + battery.return_pct(dist_home(leave), leg.altitude_m);
    if leg.charge_pct >= needed {
        return Reach::Fly {
            leg_s: tau,
            arrival,
            spare_pct: leg.charge_pct - needed,
        };
    }
    // Step 3: from home on a fresh battery, the best arrival time from now on. The cell's
    // centre x seconds after now, relative to home:
    let (ce, cn) = motion.cell_centre(cell, now, cell_m);
    let (re, rn) = (ce - leg.home.0, cn - leg.home.1);
    let at = |x: f64| (re + ve * x, rn + vn * x);
    let trip_pct = |x: f64| {
        let (ae, an) = at(x);
        let (le, ln) = at(x + dwell);
        battery.flight_pct(ae.hypot(an) / speed + dwell)
            + battery.return_pct(le.hypot(ln), leg.altitude_m)
    };
    let Ok((tau_home, _)) = motion.intercept(leg.home.0, leg.home.1, now, cell, cell_m, speed)
    else {
        return outpaced;
    };
    let v2 = ve * ve + vn * vn;
    // Closest approach of the cell to home (both terms of the trip are smallest between it
    // less the dwell and it).
    let closest = if v2 > 0.0 {
        (-(re * ve + rn * vn) / v2).max(0.0)
    } else {
        0.0
    };
    let (mut lo, mut hi) = (tau_home, closest.max(tau_home));
    for _ in 0..100 {
        let a = lo + (hi - lo) / 3.0;
        let b = hi - (hi - lo) / 3.0;
        if trip_pct(a) <= trip_pct(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let best = (lo + hi) / 2.0;
    let best_pct = trip_pct(best);
    let full = full_pct - MARGIN_PCT;
    if best_pct > full {
        let (ae, an) = at(best);
        return Reach::BeyondReach(Unreachable::OutOfRange {
            distance_m: ae.hypot(an),
            needed_pct: best_pct,
            full_pct,
        });
    }
    // Step 4.
    if leg.charge_pct < full_pct {
        return Reach::SwapFirst { needed_pct: needed };
    }
    if trip_pct(tau_home) <= full {
        return Reach::SwapFirst { needed_pct: needed };
    }
    // The earliest arrival from home that a fresh battery pays for: trip_pct falls from
    // `tau_home` to `best`; bisect for where it crosses `full`.
    let (mut a, mut b) = (tau_home, best);
    for _ in 0..100 {
        let m = (a + b) / 2.0;
        if trip_pct(m) <= full {
            b = m;
        } else {
            a = m;
        }
    }
    let (ae, an) = at(b);
    Reach::Wait {
        secs: (b - ae.hypot(an) / speed).max(0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The field test's battery: 12 minutes, 20 % reserve, 1 m/s, 1 m/s descent, 30 s margin.
    fn battery(speed: f64) -> BatteryModel {
        BatteryModel {
            endurance_s: 720.0,
            speed_m_s: speed,
            reserve_pct: 20.0,
            descent_rate_m_s: 1.0,
            landing_margin_s: 30.0,
        }
    }

    fn leg(from: (f64, f64), charge_pct: f64) -> Leg {
        Leg {
            from,
            home: (0.0, 0.0),
            altitude_m: 12.0,
            charge_pct,
            dwell_s: 0.0,
        }
    }

    #[test]
    fn a_static_cell_in_range_is_flown_to_and_the_spare_is_what_is_left() {
        let b = battery(1.0);
        // Cell (0, 10) of 4 m cells: 40 m east. From home: 40 s out, 40 + 12 + 30 s back.
        let r = reach(
            &RoiMotion::STATIC,
            Cell::new(0, 10),
            4.0,
            Time::ZERO,
            &leg((0.0, 0.0), 100.0),
            &b,
            90.0,
        );
        let needed = 100.0 * 40.0 / 720.0 + 20.0 + 100.0 * 82.0 / 720.0;
        match r {
            Reach::Fly {
                leg_s,
                arrival,
                spare_pct,
            } => {
                assert!((leg_s - 40.0).abs() < 1e-9);
                assert!((arrival.0 - 40.0).abs() < 1e-9 && arrival.1.abs() < 1e-9);
                assert!((spare_pct - (100.0 - needed)).abs() < 1e-9, "{spare_pct}");
            }
            other => panic!("{other:?}"),
        }
        // With just less than that: a swap first (a fresh battery does it).
        let r = reach(
            &RoiMotion::STATIC,
            Cell::new(0, 10),
            4.0,
            Time::ZERO,
            &leg((0.0, 0.0), needed - 0.1),
            &b,
            90.0,
        );
        assert!(matches!(r, Reach::SwapFirst { needed_pct } if (needed_pct - needed).abs() < 1e-9));
    }

    #[test]
    fn the_leg_out_counts_not_only_the_return_from_here() {
        // A drone 100 m east of home with 40 %: the return from here needs 20 + 142/7.2 ≈ 39.7 %
        // (the runner's check between steps lets it go on), but the cell is 100 m farther east:
        // 100 s out and 242 s back need 20 + 342/7.2 ≈ 67.5 %.
        let b = battery(1.0);
        let here = b.return_pct(100.0, 12.0);
        assert!(here < 40.0);
        let r = reach(
            &RoiMotion::STATIC,
            Cell::new(0, 50),
            4.0,
            Time::ZERO,
            &leg((100.0, 0.0), 40.0),
            &b,
            90.0,
        );
        assert!(
            matches!(r, Reach::SwapFirst { needed_pct } if (needed_pct - (20.0 + 342.0 / 7.2)).abs() < 1e-9),
            "{r:?}"
        );
    }

    #[test]
    fn a_drifting_cell_is_charged_where_it_will_be() {
        // Drifting east at 0.5 m/s; a drone at home, 2 m/s, the cell 40 m east: it meets the
        // cell after 40 / 1.5 = 26.7 s, 53.3 m east, and stays 20 s over it, leaving 63.3 m
        // east. The same charge that flies to a static cell 40 m away is not enough.
        let m = RoiMotion::new(0.5, 0.0, Time::ZERO);
        let b = battery(2.0);
        let mut l = leg((0.0, 0.0), 0.0);
        l.dwell_s = 20.0;
        let needed_static = b.flight_pct(20.0 + 20.0) + b.return_pct(40.0, 12.0);
        let needed = b.flight_pct(40.0 / 1.5 + 20.0) + b.return_pct(40.0 / 1.5 * 2.0 + 10.0, 12.0);
        l.charge_pct = needed - 0.01;
        assert!(l.charge_pct > needed_static);
        let r = reach(&m, Cell::new(0, 10), 4.0, Time::ZERO, &l, &b, 90.0);
        assert!(
            matches!(r, Reach::SwapFirst { needed_pct } if (needed_pct - needed).abs() < 1e-9),
            "{r:?}"
        );
        l.charge_pct = needed + 0.01;
        match reach(&m, Cell::new(0, 10), 4.0, Time::ZERO, &l, &b, 90.0) {
            Reach::Fly { leg_s, arrival, .. } => {
                assert!((leg_s - 40.0 / 1.5).abs() < 1e-9);
                assert!((arrival.0 - 40.0 / 1.5 * 2.0).abs() < 1e-9, "{arrival:?}");
            }
            other => panic!("{other:?}"),
        }
        // Later in the region's time the cell is farther east: 200 s on, 140 m.
        let r = reach(
            &m,
            Cell::new(0, 10),
            4.0,
            Time::from_secs(200),
            &l,
            &b,
            90.0,
        );
        assert!(matches!(r, Reach::SwapFirst { .. }), "{r:?}");
    }

    #[test]
    fn a_region_as_fast_as_the_drones_is_beyond_reach() {
        let b = battery(1.0);
        for (ve, vn) in [(1.0, 0.0), (-0.6, 0.8), (0.0, -1.5), (f64::NAN, 0.0)] {
            let m = RoiMotion::new(ve, vn, Time::ZERO);
            // Whatever the charge, and even with the cell right under the drone.
            let r = reach(
                &m,
                Cell::new(0, 0),
                4.0,
                Time::ZERO,
                &leg((0.0, 0.0), 100.0),
                &b,
                90.0,
            );
            match r {
                Reach::BeyondReach(Unreachable::Outpaced {
                    drift_m_s,
                    speed_m_s,
                }) => {
                    assert!(drift_m_s.is_nan() || drift_m_s >= 1.0);
                    assert_eq!(speed_m_s, 1.0);
                }
                other => panic!("{ve} {vn}: {other:?}"),
            }
        }
        // Just slower than the drones: in reach when near.
        let m = RoiMotion::new(0.9, 0.0, Time::ZERO);
        let r = reach(
            &m,
            Cell::new(0, 1),
            4.0,
            Time::ZERO,
            &leg((0.0, 0.0), 100.0),
            &b,
            90.0,
        );
        assert!(matches!(r, Reach::Fly { .. }), "{r:?}");
    }

    #[test]
    fn a_region_drifting_away_goes_out_of_range_for_good() {
        // 0.5 m/s away from home, drones at 1 m/s: a cell 100 m out is met after 200 s, 200 m
        // out — 200 + 212 + 30 s of a 720 s battery and the reserve: 81.4 %. A fresh battery
        // (90 %, less the margin) does it; 30 s later the cell is 115 m out and the trip
        // needs 20 + (230 + 242 + 30) / 7.2 = 89.7 %: beyond reach.
        let m = RoiMotion::new(0.5, 0.0, Time::ZERO);
        let b = battery(1.0);
        let cell = Cell::new(0, 25);
        let r = reach(&m, cell, 4.0, Time::ZERO, &leg((0.0, 0.0), 50.0), &b, 90.0);
        assert!(matches!(r, Reach::SwapFirst { .. }), "{r:?}");
        let r = reach(
            &m,
            cell,
            4.0,
            Time::from_secs(30),
            &leg((0.0, 0.0), 50.0),
            &b,
            90.0,
        );
        match r {
            Reach::BeyondReach(Unreachable::OutOfRange {
                distance_m,
                needed_pct,
                full_pct,
            }) => {
                assert!((distance_m - 230.0).abs() < 1e-3, "{distance_m}");
                assert!(
                    (needed_pct - (20.0 + 502.0 / 7.2)).abs() < 1e-6,
                    "{needed_pct}"
                );
                assert_eq!(full_pct, 90.0);
            }
            other => panic!("{other:?}"),
        }
        // A drone already out there with charge enough still flies to it: the verdict is on
        // the flight, not on the region.
        let r = reach(
            &m,
            cell,
            4.0,
            Time::from_secs(30),
            &leg((150.0, 0.0), 80.0),
            &b,
            90.0,
        );
        assert!(matches!(r, Reach::Fly { .. }), "{r:?}");
    }

    #[test]
    fn a_region_drifting_towards_home_is_waited_for_not_given_up() {
        // 0.5 m/s west, towards home; the cell 400 m east: out of range now (a trip of more
        // than 100 %), within range once it has come closer.
        let m = RoiMotion::new(-0.5, 0.0, Time::ZERO);
        let b = battery(1.0);
        let cell = Cell::new(0, 100);
        // A drone at home on a fresh battery: wait, then fly.
        let r = reach(&m, cell, 4.0, Time::ZERO, &leg((0.0, 0.0), 95.0), &b, 90.0);
        let Reach::Wait { secs } = r else {
            panic!("{r:?}")
        };
        assert!(secs > 0.0);
        let later = Time::from_secs_f64(secs + 5.0);
        let r = reach(&m, cell, 4.0, later, &leg((0.0, 0.0), 95.0), &b, 90.0);
        assert!(matches!(r, Reach::Fly { .. }), "after {secs} s: {r:?}");
        // A drone with a used battery changes it meanwhile.
        let r = reach(&m, cell, 4.0, Time::ZERO, &leg((0.0, 0.0), 60.0), &b, 90.0);
        assert!(matches!(r, Reach::SwapFirst { .. }), "{r:?}");
    }

    #[test]
    fn a_fresh_drone_at_home_is_never_sent_to_swap_again() {
        // Whatever the cell and the drift (slower than the drones), a drone standing (up to a
        // couple of metres off) at home with a battery as full as a swap gives is told to fly,
        // to wait or that the cell is beyond reach — never to swap: a swap could not help.
        let b = battery(1.0);
        for k in 0..400 {
            let ve = f64::from(k % 7) * 0.13 - 0.4;
            let vn = f64::from(k % 5) * 0.11 - 0.2;
            let m = RoiMotion::new(ve, vn, Time::ZERO);
            let cell = Cell::new(k % 40 - 20, (k * 7) % 90 - 45);
            let off = (f64::from(k % 3) - 1.0, f64::from(k % 4) * 0.5 - 0.75);
            let now = Time::from_secs(u64::from(k as u32 % 11) * 37);
            let r = reach(&m, cell, 4.0, now, &leg(off, 90.0), &b, 90.0);
            assert!(!matches!(r, Reach::SwapFirst { .. }), "{k}: {r:?}");
        }
    }
}
