//! The shell's clock: the one place that reads the time.
//!
//! [`fleetmap_core::time::Time`] is plain data; this module is the async edge that turns the
//! monotonic clock (tokio's, so that a paused tokio runtime gives virtual time) into
//! `Time` values for the pure core. Only the shell (link, fleet, UI, app, the simulator's
//! socket server) uses it; nothing in the core (proto, mission, planner, explore, vision,
//! sim logic, geo, time) may.

use fleetmap_core::time::Time;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
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

/// The shell's clock: real monotonic time since the clock was created, or the time of a
/// simulator served in this process.
///
/// It reads `tokio::time::Instant`, which is the system's monotonic clock — except in a
/// tokio runtime whose clock is paused (tests with `start_paused`), where it is tokio's
/// virtual time: the fleet, the links and an in-memory simulator then all run on one
/// virtual timeline that jumps ahead whenever every task is waiting, so an hour of
/// flight takes only the CPU time of the work done.
///
/// Only the async shell (link, fleet, UI, the simulator's socket server) reads it; it hands
/// the resulting [`Time`] to the pure core. `speedup` makes simulated time run faster than
/// wall time (`fleetmap sim --speedup X`). A GCS in the same process as the simulator it
/// flies (the demo, the tests) follows the simulator's own time instead
/// ([`MonotonicClock::following`]): the simulator runs in lock-step and slows down when the
/// machine is busy (`crate::sim::pace`), and the GCS's timeouts slow down with it.
#[derive(Clone, Debug)]
pub struct MonotonicClock {
    source: Source,
}

#[derive(Clone, Debug)]
enum Source {
    /// Wall time since `start`, times `speedup`.
    Wall { start: Instant, speedup: f64 },
    /// A simulator's published time.
    Simulator(SimTime),
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
            source: Source::Wall {
                start: Instant::now(),
                speedup,
            },
        }
    }

    /// A clock that reads the simulated time `sim` publishes (its epoch: the simulator's
    /// start).
    pub fn following(sim: &SimTime) -> Self {
        MonotonicClock {
            source: Source::Simulator(sim.clone()),
        }
    }

    /// The simulator this clock follows, if it follows one.
    pub fn simulator(&self) -> Option<&SimTime> {
        match &self.source {
            Source::Simulator(s) => Some(s),
            Source::Wall { .. } => None,
        }
    }

    /// The current time on this clock.
    pub fn now(&self) -> Time {
        match &self.source {
            Source::Wall { start, speedup } => {
                Time::from_secs_f64(start.elapsed().as_secs_f64() * speedup)
            }
            Source::Simulator(s) => s.now(),
        }
    }

    /// The speed factor of this clock relative to wall time: the speed-up it was made with,
    /// or, following a simulator, the speed the simulator achieves now (its ceiling until
    /// measured; 1 when it has neither).
    pub fn speedup(&self) -> f64 {
        match &self.source {
            Source::Wall { speedup, .. } => *speedup,
            Source::Simulator(s) => s.achieved().or(s.ceiling()).unwrap_or(1.0),
        }
    }

    /// The wall-clock duration until this clock reaches `t` (zero if already past). Following
    /// a simulator, a lower bound (the simulator never runs faster than its ceiling; without
    /// one, at most [`SimTime::MAX_WAIT`]): a caller that wakes before `t` sleeps again.
    pub fn wall_until(&self, t: Time) -> Duration {
        let left = t.saturating_since(self.now());
        match &self.source {
            Source::Wall { speedup, .. } => left.div_f64(*speedup),
            Source::Simulator(s) => match s.ceiling() {
                Some(x) => left.div_f64(x),
                None => left
                    .div_f64(s.achieved().unwrap_or(1.0).max(1.0))
                    .min(SimTime::MAX_WAIT),
            },
        }
    }

    /// Seconds on this clock since the wall-clock moment `epoch_unix_ms`, now: the wall time
    /// since then times the speed-up; following a simulator, its time since its start plus
    /// the wall time from `epoch_unix_ms` to that start at its ceiling (exactly the simulated
    /// time when the epoch is the simulator's start, [`SimTime::started_unix_ms`]). May be
    /// negative for an epoch in the future.
    pub fn secs_since_unix_ms(&self, epoch_unix_ms: u64) -> f64 {
        match &self.source {
            Source::Wall { speedup, .. } => {
                (unix_ms() as f64 - epoch_unix_ms as f64) / 1000.0 * speedup
            }
            Source::Simulator(s) => {
                let before = (s.started_unix_ms() as f64 - epoch_unix_ms as f64) / 1000.0;
                s.now().as_secs_f64() + before * s.ceiling().unwrap_or(1.0)
            }
        }
    }
}

/// The time of a simulator served in this process, as its shell publishes it after every
/// step (`crate::sim::server`), with the speed it achieves: what a GCS in the same process
/// follows ([`MonotonicClock::following`]) and what the demo's screen shows. Cheap to clone
/// (shared).
#[derive(Clone, Debug)]
pub struct SimTime {
    inner: Arc<SimTimeInner>,
}

#[derive(Debug)]
struct SimTimeInner {
    /// Simulated microseconds since the simulator's start.
    sim_us: AtomicU64,
    /// Achieved simulated seconds per wall second (f64 bits; 0: not measured yet).
    achieved: AtomicU64,
    /// The ceiling (f64 bits; 0: none, `--speedup max`).
    ceiling: AtomicU64,
    /// When simulated time 0 was, ms since the Unix epoch.
    started_unix_ms: u64,
}

impl SimTime {
    /// Longest sleep of a clock following a simulator without a ceiling.
    pub(crate) const MAX_WAIT: Duration = Duration::from_millis(20);

    /// A simulator's time, at 0 now, that will run at most `ceiling` times faster than wall
    /// time (`None`: as fast as it can).
    pub fn new(ceiling: Option<f64>) -> SimTime {
        let ceiling = ceiling.filter(|x| x.is_finite() && *x > 0.0).unwrap_or(0.0);
        SimTime {
            inner: Arc::new(SimTimeInner {
                sim_us: AtomicU64::new(0),
                achieved: AtomicU64::new(0f64.to_bits()),
                ceiling: AtomicU64::new(ceiling.to_bits()),
                started_unix_ms: unix_ms(),
            }),
        }
    }

    /// The simulator now stands at `t` (since its start) and runs at `achieved` simulated
    /// seconds per wall second (`None`: not measured yet). Time never goes back.
    pub fn publish(&self, t: Time, achieved: Option<f64>) {
        self.inner
            .sim_us
            .fetch_max(t.as_micros(), Ordering::Release);
        if let Some(a) = achieved.filter(|a| a.is_finite() && *a > 0.0) {
            self.inner.achieved.store(a.to_bits(), Ordering::Release);
        }
    }

    /// Simulated time since the simulator's start.
    pub fn now(&self) -> Time {
        Time::from_micros(self.inner.sim_us.load(Ordering::Acquire))
    }

    /// Simulated seconds per wall second over the last few seconds, once measured.
    pub fn achieved(&self) -> Option<f64> {
        let a = f64::from_bits(self.inner.achieved.load(Ordering::Acquire));
        (a > 0.0).then_some(a)
    }

    /// The most simulated seconds per wall second it may run (`None`: no ceiling).
    pub fn ceiling(&self) -> Option<f64> {
        let c = f64::from_bits(self.inner.ceiling.load(Ordering::Acquire));
        (c > 0.0).then_some(c)
    }

    /// When simulated time 0 was, ms since the Unix epoch.
    pub fn started_unix_ms(&self) -> u64 {
        self.inner.started_unix_ms
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

/// A stopwatch for CPU-bound batch work (the planner's integer programs): a closure giving
/// the wall-clock seconds since this call, on `std::time::Instant` (HiGHS's own time limit is
/// wall time too, so the budget of [`fleetmap_core::planner::ip::PlanOptions::time_limit`] is measured
/// on the same clock). The planner takes it as an argument and reads no clock itself.
pub fn stopwatch() -> impl Fn() -> f64 {
    let start = std::time::Instant::now();
    move || start.elapsed().as_secs_f64()
}
