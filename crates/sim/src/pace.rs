//! Lock-step pacing: how far the simulator may step at a given wall time, and how fast it
//! has really been running.
//!
//! ArduPilot's and PX4's SITL run in lock-step: the physics advances one fixed step at a
//! time and `--speedup N` is a ceiling, so on a busy machine the vehicle runs slower than N×
//! and everything it does stays consistent with the time it was simulated for. ArduPilot's
//! `Aircraft::sync_frame_time` (libraries/SITL/SIM_Aircraft.cpp) keeps a sleep debt: it sleeps
//! only while the frames run ahead of `speedup × wall time`, and never lets the debt fall
//! below −100 ms, so a late frame is made up for by at most 100 ms of wall time and the rest
//! is simply lost speed; PX4's SITL steps its modules from the simulator's time through its
//! lock-step scheduler (platforms/posix lockstep_scheduler). The simulator here does the
//! same: `Pacer::allowed` says up to which simulated time the shell may step now. When the
//! shell falls behind by more than `Pacer::max_lag` (it was starved: a busy CPU, a slow
//! link), the schedule is moved instead of caught up — the simulator never steps a burst of
//! simulated seconds to make up for wall time it did not get, it just runs slower.
//! [`Speed::Max`] has no ceiling: every turn of the shell steps one batch
//! (`Pacer::MAX_BATCH`) and lets the I/O run.
//!
//! `SpeedMeter` measures the speed achieved (simulated seconds per wall second over the
//! last few seconds), which the shell reports and the GCS clock follows
//! (`fleetmap_io::clock::SimTime`).
//!
//! Pure: the caller passes the wall-clock `now`.

use fleetmap_core::time::Time;
use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;
use std::time::Duration;
use thiserror::Error;

/// How fast the simulator may run: a ceiling in simulated seconds per wall second, or as
/// fast as the machine allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Speed {
    /// At most this many simulated seconds per wall second (finite, positive).
    Times(f64),
    /// As fast as the machine allows (a Monte Carlo of whole missions).
    Max,
}

/// `--speedup` was neither a positive number nor `max`.
#[derive(Debug, Error, PartialEq)]
#[error("speed-up {0:?}: expected a positive number of simulated seconds per second, or max")]
pub struct SpeedError(String);

impl Speed {
    /// Real time.
    pub(crate) const REAL_TIME: Speed = Speed::Times(1.0);

    /// A ceiling of `x` simulated seconds per wall second (`None` unless finite and positive).
    pub fn times(x: f64) -> Option<Speed> {
        (x.is_finite() && x > 0.0).then_some(Speed::Times(x))
    }

    /// The ceiling, simulated seconds per wall second (`None`: no ceiling).
    pub fn ceiling(self) -> Option<f64> {
        match self {
            Speed::Times(x) => Some(x),
            Speed::Max => None,
        }
    }
}

impl FromStr for Speed {
    type Err = SpeedError;
    fn from_str(s: &str) -> Result<Speed, SpeedError> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("max") {
            return Ok(Speed::Max);
        }
        t.parse::<f64>()
            .ok()
            .and_then(Speed::times)
            .ok_or_else(|| SpeedError(s.to_string()))
    }
}

impl fmt::Display for Speed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Speed::Times(x) => write!(f, "{x}×"),
            Speed::Max => f.write_str("max"),
        }
    }
}

/// The lock-step schedule (see the module documentation).
#[derive(Clone, Debug)]
pub(crate) struct Pacer {
    speed: Speed,
    /// (wall, simulated) time the schedule is anchored at: simulated time may reach
    /// `sim + (wall_now − wall) · ceiling`.
    anchor: Option<(Time, Time)>,
    /// Times the schedule was moved because the shell fell behind.
    slowed: u64,
}

impl Pacer {
    /// Most simulated time stepped in one turn of the shell without serving its I/O in
    /// between, with [`Speed::Max`]: two 20 Hz physics steps.
    pub(crate) const MAX_BATCH: Duration = Duration::from_millis(100);
    /// Most simulated time the shell may make up at once after a late turn (see
    /// [`Pacer::max_lag`]).
    pub(crate) const MAX_LAG_SIM: Duration = Duration::from_millis(100);
    /// Most wall time the shell may make up at once after a late turn: a timer that fires a
    /// few milliseconds late (the scheduler's granularity) costs no speed.
    pub(crate) const MAX_LAG_WALL: Duration = Duration::from_millis(10);

    /// A schedule for `speed`, anchored at its first [`Pacer::allowed`].
    pub(crate) fn new(speed: Speed) -> Pacer {
        Pacer {
            speed,
            anchor: None,
            slowed: 0,
        }
    }

    /// The speed asked for.
    pub(crate) fn speed(&self) -> Speed {
        self.speed
    }

    /// How far simulated time may lag the schedule before the schedule is moved instead:
    /// [`Pacer::MAX_LAG_SIM`], or [`Pacer::MAX_LAG_WALL`] of wall time at the ceiling if
    /// that is more (at 20× it is 200 ms, four physics steps).
    pub(crate) fn max_lag(&self) -> Duration {
        match self.speed {
            Speed::Times(x) => Self::MAX_LAG_SIM.max(Self::MAX_LAG_WALL.mul_f64(x)),
            Speed::Max => Self::MAX_BATCH,
        }
    }

    #[cfg(test)]
    /// How many times the schedule was moved because the shell fell behind (the simulator
    /// ran slower than its ceiling).
    pub(crate) fn slowed(&self) -> u64 {
        self.slowed
    }

    /// The simulated time up to which the simulator standing at `sim` may step at wall time
    /// `wall`: never ahead of the ceiling's schedule, and at most [`Pacer::max_lag`] past
    /// `sim` (when it is further behind, the schedule moves: it runs slower instead of
    /// catching up). With [`Speed::Max`], `sim` + [`Pacer::MAX_BATCH`].
    pub(crate) fn allowed(&mut self, wall: Time, sim: Time) -> Time {
        let Speed::Times(x) = self.speed else {
            return sim + Self::MAX_BATCH;
        };
        let lag = self.max_lag();
        let (w0, s0) = *self.anchor.get_or_insert((wall, sim));
        let target = s0 + wall.saturating_since(w0).mul_f64(x);
        if target > sim + lag {
            // starved: from here on the schedule starts `lag` ahead of where we are
            self.anchor = Some((wall, sim + lag));
            self.slowed += 1;
            sim + lag
        } else {
            target
        }
    }

    /// The wall time at which simulated time `t` is on the schedule (`None`: at once).
    pub(crate) fn wall_at(&self, t: Time) -> Option<Time> {
        let (Speed::Times(x), Some((w0, s0))) = (self.speed, self.anchor) else {
            return None;
        };
        Some(w0 + t.saturating_since(s0).div_f64(x))
    }
}

/// Simulated seconds per wall second over the last [`SpeedMeter::WINDOW`] of wall time, and
/// over the whole run.
#[derive(Clone, Debug, Default)]
pub(crate) struct SpeedMeter {
    /// (wall, simulated) samples, at least [`SpeedMeter::SPACING`] apart, the oldest within
    /// the window (plus one before it, the window's start).
    samples: VecDeque<(Time, Time)>,
    first: Option<(Time, Time)>,
    last: Option<(Time, Time)>,
}

impl SpeedMeter {
    /// Wall time the current speed is measured over.
    pub(crate) const WINDOW: Duration = Duration::from_secs(2);
    /// Least wall time between two kept samples.
    pub(crate) const SPACING: Duration = Duration::from_millis(100);
    /// Least wall time a speed is measured over.
    pub(crate) const LEAST: Duration = Duration::from_millis(500);

    /// An empty meter.
    pub(crate) fn new() -> SpeedMeter {
        SpeedMeter::default()
    }

    /// The simulator stood at simulated time `sim` at wall time `wall`.
    pub(crate) fn record(&mut self, wall: Time, sim: Time) {
        self.first.get_or_insert((wall, sim));
        self.last = Some((wall, sim));
        if self
            .samples
            .back()
            .is_none_or(|(w, _)| wall.saturating_since(*w) >= Self::SPACING)
        {
            self.samples.push_back((wall, sim));
        }
        while self.samples.len() > 2
            && self
                .samples
                .get(1)
                .is_some_and(|(w, _)| wall.saturating_since(*w) >= Self::WINDOW)
        {
            self.samples.pop_front();
        }
    }

    fn rate(from: (Time, Time), to: (Time, Time)) -> Option<f64> {
        let wall = to.0.saturating_since(from.0);
        (wall >= Self::LEAST)
            .then(|| to.1.saturating_since(from.1).as_secs_f64() / wall.as_secs_f64())
    }

    /// Simulated seconds per wall second over about the last [`SpeedMeter::WINDOW`] (`None`
    /// until [`SpeedMeter::LEAST`] of wall time has been measured).
    pub(crate) fn current(&self) -> Option<f64> {
        Self::rate(*self.samples.front()?, self.last?)
    }

    /// Simulated seconds per wall second since the first sample.
    pub(crate) fn overall(&self) -> Option<f64> {
        Self::rate(self.first?, self.last?)
    }

    /// Simulated and wall time since the first sample.
    pub(crate) fn totals(&self) -> (Duration, Duration) {
        match (self.first, self.last) {
            (Some(f), Some(l)) => (l.1.saturating_since(f.1), l.0.saturating_since(f.0)),
            _ => (Duration::ZERO, Duration::ZERO),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(x: u64) -> Time {
        Time::from_millis(x)
    }

    #[test]
    fn speed_parses_numbers_and_max() {
        assert_eq!("20".parse::<Speed>(), Ok(Speed::Times(20.0)));
        assert_eq!(" MAX ".parse::<Speed>(), Ok(Speed::Max));
        assert_eq!("0.5".parse::<Speed>(), Ok(Speed::Times(0.5)));
        for bad in ["0", "-1", "inf", "NaN", "fast", ""] {
            assert!(bad.parse::<Speed>().is_err(), "{bad}");
        }
        assert_eq!(Speed::Times(20.0).to_string(), "20×");
        assert_eq!(Speed::Max.to_string(), "max");
    }

    #[test]
    fn never_ahead_of_the_ceiling() {
        let mut p = Pacer::new(Speed::Times(10.0));
        assert_eq!(p.allowed(ms(1000), ms(0)), ms(0));
        // 30 ms of wall time at 10×: 300 ms of simulated time, no more
        assert_eq!(p.allowed(ms(1030), ms(0)), ms(100));
        assert_eq!(p.slowed(), 1, "more than 100 ms behind: the schedule moved");
        let mut p = Pacer::new(Speed::Times(10.0));
        p.allowed(ms(1000), ms(0));
        assert_eq!(p.allowed(ms(1005), ms(0)), ms(50));
        assert_eq!(p.allowed(ms(1005), ms(50)), ms(50));
        assert_eq!(p.wall_at(ms(100)), Some(ms(1010)));
        assert_eq!(p.slowed(), 0);
    }

    #[test]
    fn a_starved_shell_slows_down_instead_of_catching_up() {
        // one turn every 95 ms of wall time at 20×: the schedule would allow 1.9 s of
        // simulated time per turn; lock-step steps at most max_lag (200 ms) per turn
        let mut p = Pacer::new(Speed::Times(20.0));
        assert_eq!(p.max_lag(), Duration::from_millis(200));
        let mut sim = ms(0);
        for turn in 0..100u64 {
            let allowed = p.allowed(ms(turn * 95), sim);
            assert!(allowed.saturating_since(sim) <= p.max_lag());
            sim = allowed;
        }
        // 99 turns of 200 ms: 19.8 s in 9.4 s of wall time (≈ 2.1×, not 20×)
        assert_eq!(sim, ms(99 * 200));
        assert_eq!(p.slowed(), 99);
    }

    #[test]
    fn late_timers_cost_no_speed() {
        // every turn a few ms late, on average on time: the ceiling is kept
        let mut p = Pacer::new(Speed::Times(20.0));
        let mut sim = ms(0);
        let mut wall = 0u64;
        for turn in 0..2000u64 {
            wall += if turn % 3 == 0 { 8 } else { 1 };
            sim = p.allowed(ms(wall), sim);
        }
        assert_eq!(p.slowed(), 0);
        // anchored at the first turn (wall 8 ms)
        assert_eq!(sim, ms((wall - 8) * 20));
    }

    #[test]
    fn max_steps_one_batch_per_turn() {
        let mut p = Pacer::new(Speed::Max);
        assert_eq!(p.allowed(ms(5), ms(1000)), ms(1100));
        assert_eq!(p.wall_at(ms(5000)), None);
    }

    #[test]
    fn the_meter_measures_the_recent_speed() {
        let mut m = SpeedMeter::new();
        assert_eq!(m.current(), None);
        // 10 s at 20×, then 10 s at 2×, sampled every 10 ms
        let mut sim = 0u64;
        for i in 0..=2000u64 {
            m.record(ms(i * 10), ms(sim));
            sim += if i < 1000 { 200 } else { 20 };
        }
        let now = m.current().unwrap();
        assert!((now - 2.0).abs() < 0.05, "{now}");
        let all = m.overall().unwrap();
        assert!((all - 11.0).abs() < 0.05, "{all}");
        let (s, w) = m.totals();
        assert_eq!(w, Duration::from_secs(20));
        assert_eq!(s, Duration::from_secs(220));
        assert!(m.samples.len() <= 22, "{}", m.samples.len());
    }
}
