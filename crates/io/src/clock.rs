//! The shell's clock: the one place that reads the time.
//!
//! [`fleetmap_core::time::Time`] is plain data; this module is the async edge that turns the
//! monotonic clock (tokio's, so that a paused tokio runtime gives virtual time) into
//! `Time` values for the pure core. Only the shell (link, fleet, UI, app, the simulator's
//! socket server) uses it; nothing in the core (proto, mission, planner, explore, vision,
//! sim logic, geo, time) may.
//!
//! A clock reads one of three sources: the wall clock (times a speed-up), a simulator served
//! in this process ([`SimTime`]), or the vehicles' own time as their messages tell it
//! ([`VehicleTime`], estimated by the pure [`VehicleClock`]).

mod vehicles;

pub use vehicles::VehicleClock;

use fleetmap_core::time::Time;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::time::Instant;

/// Wall-clock milliseconds since the Unix epoch (0 if the clock is before it): run
/// directories' creation times, and a moving region's epoch.
pub fn unix_ms() -> u64 {
    unix_us() / 1000
}

/// Wall-clock microseconds since the Unix epoch (0 if the clock is before it): the one
/// reader of the wall clock. The links stamp every frame they receive and sign every frame
/// they send with it (`link::transport::LinkEvent::Frame`, tlogs, MAVLink signing), and
/// `fleetmap sim` serving sockets starts its signature timestamps from it.
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
    /// The vehicles' time, from their own timestamps.
    Vehicles(VehicleTime),
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

    /// A clock that reads the vehicles' time as `vehicles` estimates it from what they
    /// send (its epoch: when `vehicles` was made; wall time until a vehicle is heard). The
    /// owner of the link the vehicles speak on feeds it ([`VehicleTime::observe`]); a relay
    /// on this clock does so itself.
    pub fn vehicles(vehicles: &VehicleTime) -> Self {
        MonotonicClock {
            source: Source::Vehicles(vehicles.clone()),
        }
    }

    /// The simulator this clock follows, if it follows one.
    pub fn simulator(&self) -> Option<&SimTime> {
        match &self.source {
            Source::Simulator(s) => Some(s),
            _ => None,
        }
    }

    /// The vehicles' time this clock reads, if it reads theirs.
    pub fn vehicle_time(&self) -> Option<&VehicleTime> {
        match &self.source {
            Source::Vehicles(v) => Some(v),
            _ => None,
        }
    }

    /// The current time on this clock.
    pub fn now(&self) -> Time {
        match &self.source {
            Source::Wall { start, speedup } => {
                Time::from_secs_f64(start.elapsed().as_secs_f64() * speedup)
            }
            Source::Simulator(s) => s.now(),
            Source::Vehicles(v) => v.now(),
        }
    }

    /// The speed factor of this clock relative to wall time: the speed-up it was made with,
    /// or, following a simulator, the speed the simulator achieves now (its ceiling until
    /// measured; 1 when it has neither).
    pub fn speedup(&self) -> f64 {
        match &self.source {
            Source::Wall { speedup, .. } => *speedup,
            Source::Simulator(s) => s.achieved().or(s.ceiling()).unwrap_or(1.0),
            Source::Vehicles(v) => v.rate(),
        }
    }

    /// The wall-clock duration until this clock reaches `t` (zero if already past). Following
    /// a simulator, a lower bound (the simulator never runs faster than its ceiling; without
    /// one, at most `SimTime::MAX_WAIT`); reading the vehicles' time, at their current
    /// rate and at most [`VehicleTime::MAX_WAIT`]: a caller that wakes before `t` sleeps
    /// again.
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
            Source::Vehicles(v) => left.div_f64(v.rate()).min(VehicleTime::MAX_WAIT),
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
            Source::Vehicles(v) => {
                let before = (v.started_unix_ms as f64 - epoch_unix_ms as f64) / 1000.0;
                v.now().as_secs_f64() + before * v.rate()
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

/// The vehicles' time as the messages they send tell it, for a process that hears them but
/// does not run them (`fleetmap relay --clock vehicle` beside SITL or `fleetmap sim`): the
/// shell side of [`VehicleClock`], which it feeds with the wall time of each report. Cheap
/// to clone (shared).
#[derive(Clone, Debug)]
pub struct VehicleTime {
    inner: Arc<Mutex<VehicleClock>>,
    start: Instant,
    started_unix_ms: u64,
}

impl Default for VehicleTime {
    fn default() -> Self {
        VehicleTime::new()
    }
}

impl VehicleTime {
    /// Longest sleep of a clock reading the vehicles' time: the rate it sleeps at may
    /// change with the next report.
    pub const MAX_WAIT: Duration = Duration::from_millis(250);

    /// The vehicles' time, at 0 now, counting wall time until a vehicle is heard.
    pub fn new() -> VehicleTime {
        VehicleTime {
            inner: Arc::new(Mutex::new(VehicleClock::new())),
            start: Instant::now(),
            started_unix_ms: unix_ms(),
        }
    }

    fn wall(&self) -> Time {
        Time::from_micros(u64::try_from(self.start.elapsed().as_micros()).unwrap_or(u64::MAX))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, VehicleClock> {
        // the estimator is left consistent by every call, so a panic elsewhere cannot
        // poison what it holds
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// System `system` says `boot` has passed since it booted (a `time_boot_ms`), now.
    pub fn observe(&self, system: u8, boot: Duration) {
        let wall = self.wall();
        self.lock().observe(system, boot, wall);
    }

    /// The vehicles' time now.
    pub fn now(&self) -> Time {
        let wall = self.wall();
        self.lock().now(wall)
    }

    /// Vehicle seconds per wall second now (1 until measured).
    pub fn rate(&self) -> f64 {
        self.lock().rate()
    }

    /// Whether any vehicle has sent a time yet.
    pub fn heard(&self) -> bool {
        self.lock().heard()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// On tokio's paused clock: wall time until a vehicle is heard, then the vehicle's time
    /// and rate, and `wall_until` turns a vehicle-time deadline into a wall sleep at that
    /// rate (at most `VehicleTime::MAX_WAIT`).
    #[tokio::test(start_paused = true)]
    async fn a_clock_on_the_vehicles_time() {
        let vt = VehicleTime::new();
        let clock = MonotonicClock::vehicles(&vt);
        assert!(clock.vehicle_time().is_some() && clock.simulator().is_none());
        tokio::time::advance(Duration::from_secs(1)).await;
        assert_eq!(clock.now(), Time::from_secs(1));
        assert!(!vt.heard());
        for k in 0..=20u64 {
            vt.observe(1, Duration::from_millis(100_000 + k * 500));
            tokio::time::advance(Duration::from_millis(100)).await;
        }
        assert!(vt.heard());
        assert!((clock.speedup() - 5.0).abs() < 0.01, "{}", clock.speedup());
        // 2 s of wall at 5× since the first report, and 100 ms past the last
        let now = clock.now().as_secs_f64();
        assert!((now - 11.5).abs() < 0.01, "{now}");
        let t = clock.now() + Duration::from_millis(500);
        assert_eq!(clock.wall_until(t), Duration::from_millis(100));
        let far = clock.now() + Duration::from_secs(60);
        assert_eq!(clock.wall_until(far), VehicleTime::MAX_WAIT);
    }
}
