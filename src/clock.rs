//! The shell's clock: the one place that reads the time.
//!
//! [`crate::time::Time`] is plain data; this module is the async edge that turns the
//! monotonic clock (tokio's, so that a paused tokio runtime gives virtual time) into
//! `Time` values for the pure core. Only the shell (link, fleet, UI, app, the simulator's
//! socket server) uses it; nothing in the core (proto, mission, planner, explore, vision,
//! sim logic, geo, time) may.

use crate::time::Time;
use std::time::Duration;
use tokio::time::Instant;

/// Wall-clock milliseconds since the Unix epoch (0 if the clock is before it): run
/// directories' creation times, and a moving region's epoch.
pub fn unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as u64)
        .unwrap_or(0)
}

/// Wall-clock microseconds since the Unix epoch (0 if the clock is before it): the
/// timestamp the links put on every frame they receive (`fleet::Incoming::unix_us`).
pub fn unix_us() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
        .unwrap_or(0)
}

/// The shell's clock: real monotonic time since the clock was created.
///
/// It reads `tokio::time::Instant`, which is the system's monotonic clock — except in a
/// tokio runtime whose clock is paused (tests with `start_paused`), where it is tokio's
/// virtual time: the fleet, the links and an in-memory simulator then all run on one
/// virtual timeline that jumps ahead whenever every task is waiting, so an hour of
/// flight takes only the CPU time of the work done.
///
/// Only the async shell (link, fleet, UI, the simulator's socket server) reads it; it hands
/// the resulting [`Time`] to the pure core. `speedup` makes simulated time run faster than
/// wall time (`fleetmap sim --speedup X`).
#[derive(Clone, Debug)]
pub struct MonotonicClock {
    start: Instant,
    speedup: f64,
}

impl MonotonicClock {
    /// A clock whose epoch is now, running at real speed.
    pub fn new() -> Self {
        Self::with_speedup(1.0)
    }

    /// A clock whose epoch is now, running `speedup` times faster than wall time
    /// (values that are not finite and positive count as 1).
    pub fn with_speedup(speedup: f64) -> Self {
        let speedup = if speedup.is_finite() && speedup > 0.0 {
            speedup
        } else {
            1.0
        };
        MonotonicClock {
            start: Instant::now(),
            speedup,
        }
    }

    /// The current time on this clock.
    pub fn now(&self) -> Time {
        Time::from_secs_f64(self.start.elapsed().as_secs_f64() * self.speedup)
    }

    /// The speed factor of this clock relative to wall time.
    pub fn speedup(&self) -> f64 {
        self.speedup
    }

    /// The wall-clock duration until this clock reaches `t` (zero if already past).
    pub fn wall_until(&self, t: Time) -> Duration {
        let sim = t.saturating_since(self.now());
        Duration::from_secs_f64(sim.as_secs_f64() / self.speedup)
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

/// A stopwatch for CPU-bound batch work (the planner's integer programs): a closure giving
/// the wall-clock seconds since this call, on `std::time::Instant` (HiGHS's own time limit is
/// wall time too, so the budget of [`crate::planner::ip::PlanOptions::time_limit`] is measured
/// on the same clock). The planner takes it as an argument and reads no clock itself.
pub fn stopwatch() -> impl Fn() -> f64 {
    let start = std::time::Instant::now();
    move || start.elapsed().as_secs_f64()
}
