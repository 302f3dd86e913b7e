//! The vehicles' time, estimated from their own timestamps (pure: the wall time of each
//! observation is an argument).
//!
//! A relay between a GCS and an autopilot in another process — SITL at `--speedup 5`, or
//! `fleetmap sim` — should count a radio's bytes per second of the *vehicle's* time, as a
//! radio flying with the vehicle would, whatever speed the simulator actually achieves on a
//! loaded machine. The autopilot stamps most of its telemetry with its time since boot
//! (`time_boot_ms`), so [`VehicleClock`] reads that: a clock that stands where the vehicles'
//! newest timestamp says and, between reports, runs at the rate their time has been running
//! against the wall clock over the last [`VehicleClock::RATE_WINDOW`].
//!
//! * Before any vehicle has sent a time it counts wall time (rate 1).
//! * Each system's boot time is mapped onto the clock by an offset fixed when it is first
//!   heard (its time then is the clock's), so several systems share one timeline; the
//!   clock follows whichever is ahead.
//! * A timestamp at or below the newest one seen from that system (a reordered, repeated
//!   or older message) is ignored; one more than [`VehicleClock::REBOOT_BACK`] below it is a
//!   reboot (after a battery swap `time_boot_ms` starts again from 0) once the next report
//!   below it confirms the new count (one stray small timestamp cannot throw the clock):
//!   the system is mapped anew where the clock stands, and the rate is kept.
//! * The clock never goes back. A report ahead of it moves it forward at once; one behind
//!   it by more than [`VehicleClock::MAX_LEAD`] of wall time at the current rate (the
//!   vehicle slowed down or stalled; older and repeated timestamps count here) re-anchors
//!   it there, and it stands still until that line catches up; smaller lags are the
//!   reports' own transit delay and are left alone, so the clock keeps to the leading edge
//!   of the reports (the minimum-delay idea of NTP).
//! * A simulator in lock-step that stalls sends nothing at all, so the clock runs on past
//!   the newest report for at most [`VehicleClock::MAX_SILENCE`] of wall time, then waits
//!   for the next one (long enough for the slowest stream an autopilot slowed down by its
//!   radio still sends: ArduPilot adds at most 2 s to a stream's interval).

use fleetmap_core::time::Time;
use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

/// One system's mapping onto the clock.
#[derive(Clone, Debug)]
struct System {
    /// Clock µs = boot µs + offset.
    offset: f64,
    /// Newest boot time heard, µs.
    last_boot: u64,
    /// Recent (wall µs, boot µs) reports, oldest first, for the rate.
    samples: VecDeque<(u64, u64)>,
    /// A report that looked like a reboot, not yet confirmed: (wall µs, boot µs).
    reboot: Option<(u64, u64)>,
}

/// The vehicles' time as seen from the wall clock (see the module documentation).
#[derive(Clone, Debug)]
pub struct VehicleClock {
    /// The clock reads `anchor + rate × (wall − anchor_wall)` (µs), never less than `shown`.
    anchor_wall: u64,
    anchor: f64,
    /// Vehicle seconds per wall second.
    rate: f64,
    /// The last value returned.
    shown: u64,
    systems: BTreeMap<u8, System>,
    /// Wall time of the newest fresh report, µs.
    last_fresh: Option<u64>,
}

impl Default for VehicleClock {
    fn default() -> Self {
        VehicleClock::new()
    }
}

impl VehicleClock {
    /// How far below a system's newest timestamp a new one must be to count as a reboot
    /// (of vehicle time; smaller steps back are reordered messages).
    pub const REBOOT_BACK: Duration = Duration::from_secs(3);
    /// The wall-time window over which the rate is measured.
    pub const RATE_WINDOW: Duration = Duration::from_secs(10);
    /// The shortest wall-time span a rate is measured over.
    pub const MIN_SPAN: Duration = Duration::from_millis(500);
    /// How far (wall time at the current rate) the clock may run ahead of the newest
    /// report before it waits for the vehicles.
    pub const MAX_LEAD: Duration = Duration::from_millis(500);
    /// How long (wall time) the clock runs on after the newest report before it waits.
    pub const MAX_SILENCE: Duration = Duration::from_secs(5);
    /// Slowest and fastest rates believed, vehicle seconds per wall second.
    const RATES: (f64, f64) = (1e-3, 1e4);

    /// A clock at 0 at wall time 0, counting wall time until a vehicle is heard.
    pub fn new() -> VehicleClock {
        VehicleClock {
            anchor_wall: 0,
            anchor: 0.0,
            rate: 1.0,
            shown: 0,
            systems: BTreeMap::new(),
            last_fresh: None,
        }
    }

    /// Vehicle seconds per wall second now (1 until measured).
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Whether any vehicle has sent a time yet.
    pub fn heard(&self) -> bool {
        !self.systems.is_empty()
    }

    fn line(&self, wall: u64) -> f64 {
        self.anchor + self.rate * (wall as f64 - self.anchor_wall as f64)
    }

    /// The clock at wall time `wall` (never less than a value returned before).
    pub fn now(&mut self, wall: Time) -> Time {
        let mut w = wall.as_micros();
        if let Some(last) = self.last_fresh {
            w = w.min(last.saturating_add(Self::MAX_SILENCE.as_micros() as u64));
        }
        let v = self.line(w).max(0.0) as u64;
        self.shown = self.shown.max(v);
        Time::from_micros(self.shown)
    }

    /// System `system` reported `boot` since its boot, received at wall time `wall`.
    pub fn observe(&mut self, system: u8, boot: Duration, wall: Time) {
        let boot = u64::try_from(boot.as_micros()).unwrap_or(u64::MAX);
        let w = wall.as_micros();
        let here = self.now(wall).as_micros() as f64;
        let fresh = |boot: u64| System {
            offset: here - boot as f64,
            last_boot: boot,
            samples: VecDeque::from([(w, boot)]),
            reboot: None,
        };
        let lead = |clock: &VehicleClock| clock.rate * Self::MAX_LEAD.as_micros() as f64;
        let Some(s) = self.systems.get_mut(&system) else {
            self.systems.insert(system, fresh(boot));
            self.last_fresh = Some(w);
            return;
        };
        let back = u64::try_from(Self::REBOOT_BACK.as_micros()).unwrap_or(u64::MAX);
        if boot.saturating_add(back) < s.last_boot {
            // confirmed by a second report of the new count: not before the first, and not
            // further on than the time since then allows (twice the rate, plus the margin)
            let confirmed = s.reboot.is_some_and(|(rw, rb)| {
                let allowed = 2.0 * self.rate * w.saturating_sub(rw) as f64 + back as f64;
                boot >= rb && ((boot - rb) as f64) <= allowed
            });
            if confirmed {
                *s = fresh(boot);
                self.last_fresh = Some(w);
            } else {
                s.reboot = Some((w, boot));
            }
            return;
        }
        let observed = s.offset + boot as f64;
        if boot <= s.last_boot {
            // older or repeated: the vehicle's time was at most this when it was sent
            if self.line(w) - observed > lead(self) {
                self.anchor = observed;
                self.anchor_wall = w;
            }
            return;
        }
        s.last_boot = boot;
        s.reboot = None;
        s.samples.push_back((w, boot));
        let window = Self::RATE_WINDOW.as_micros() as u64;
        while s.samples.len() > 2 && s.samples.front().is_some_and(|(sw, _)| w - sw > window) {
            s.samples.pop_front();
        }
        let new_rate = s.samples.front().and_then(|&(sw, sb)| {
            let span = w.saturating_sub(sw);
            (span >= Self::MIN_SPAN.as_micros() as u64)
                .then(|| ((boot - sb) as f64 / span as f64).clamp(Self::RATES.0, Self::RATES.1))
        });
        if let Some(r) = new_rate {
            // keep the line continuous where it stands, then turn it
            self.anchor = self.line(w);
            self.anchor_wall = w;
            self.rate = r;
        }
        self.last_fresh = Some(w);
        let line = self.line(w);
        if observed > line || line - observed > lead(self) {
            self.anchor = observed;
            self.anchor_wall = w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall_ms(ms: u64) -> Time {
        Time::from_millis(ms)
    }

    /// A vehicle at `speed` × wall time whose boot time is `boot0_ms` at wall 0, reporting at
    /// the wall times `walls` (ms) with `delay(i)` ms of transit: returns the clock's reading
    /// at each report's arrival and the vehicle's true time then.
    fn follow(
        c: &mut VehicleClock,
        sys: u8,
        speed: f64,
        walls: impl Iterator<Item = u64>,
        boot0_ms: f64,
        delay: impl Fn(u64) -> u64,
    ) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        for (i, w) in walls.enumerate() {
            let boot = boot0_ms + (w as f64) * speed;
            let d = delay(i as u64);
            c.observe(
                sys,
                Duration::from_micros((boot * 1000.0) as u64),
                wall_ms(w + d),
            );
            let read = c.now(wall_ms(w + d)).as_micros() as f64 / 1000.0;
            out.push((read, boot + d as f64 * speed));
        }
        out
    }

    #[test]
    fn counts_wall_time_until_a_vehicle_is_heard() {
        let mut c = VehicleClock::new();
        assert!(!c.heard());
        assert_eq!(c.now(wall_ms(1500)), wall_ms(1500));
        assert_eq!(c.rate(), 1.0);
        // the first report maps the vehicle's time onto the clock where it stands
        c.observe(1, Duration::from_secs(100), wall_ms(2000));
        assert!(c.heard());
        assert_eq!(c.now(wall_ms(2000)), wall_ms(2000));
    }

    /// A vehicle at 5× with 1–9 ms of transit jitter: after the first second the clock runs
    /// at 5× within 1 %, and reads the vehicle's true time within 60 ms of vehicle time (the
    /// jitter at 5×, plus the report interval's extrapolation error).
    #[test]
    fn follows_a_vehicle_at_five_times() {
        let mut c = VehicleClock::new();
        let got = follow(&mut c, 1, 5.0, (0..60_000).step_by(100), 30_000.0, |i| {
            1 + (i * 7) % 9
        });
        assert!((c.rate() - 5.0).abs() < 0.05, "rate {}", c.rate());
        let first = got[0];
        for (k, (read, truth)) in got.iter().enumerate().skip(10) {
            let (r, t) = (read - first.0, truth - first.1);
            assert!(
                (r - t).abs() < 60.0,
                "report {k}: clock {r} ms, vehicle {t} ms"
            );
        }
        // between reports it extrapolates at the rate: 60 s of wall later, 300 s more
        let a = c.now(wall_ms(60_000)).as_secs_f64();
        let b = c.now(wall_ms(61_000)).as_secs_f64();
        assert!((b - a - 5.0).abs() < 0.05, "{}", b - a);
    }

    /// Reordered reports (older timestamps arriving late) are ignored; the clock never
    /// goes back.
    #[test]
    fn ignores_reordered_reports_and_never_goes_back() {
        let mut c = VehicleClock::new();
        let mut last = Time::ZERO;
        for i in 0..2000u64 {
            let w = i * 10;
            // every third report is one that was sent 400 ms of vehicle time earlier
            let boot = if i % 3 == 2 {
                w * 2 + 9_600
            } else {
                w * 2 + 10_000
            };
            c.observe(1, Duration::from_millis(boot), wall_ms(w));
            let now = c.now(wall_ms(w));
            assert!(now >= last);
            last = now;
        }
        assert!((c.rate() - 2.0).abs() < 0.02, "{}", c.rate());
        let span = c.now(wall_ms(19_990)).as_secs_f64();
        assert!((span - 2.0 * 19.99).abs() < 0.1, "{span}");
    }

    /// A reboot (time since boot back to 0) re-anchors the system where the clock stands:
    /// the clock goes on from there at the same rate, without a jump either way.
    #[test]
    fn a_reboot_re_anchors_and_keeps_the_rate() {
        let mut c = VehicleClock::new();
        follow(&mut c, 1, 4.0, (0..20_000).step_by(50), 600_000.0, |_| 2);
        let before = c.now(wall_ms(20_000)).as_secs_f64();
        // the battery swap: 2 s of wall silence, then the autopilot boots at 0
        let got = follow(
            &mut c,
            1,
            4.0,
            (22_000..40_000).step_by(50),
            -88_000.0,
            |_| 2,
        );
        assert!((c.rate() - 4.0).abs() < 0.04, "{}", c.rate());
        let after = c.now(wall_ms(40_000)).as_secs_f64();
        // 20 s of wall at 4×: 80 s (the silence counted at the rate)
        assert!((after - before - 80.0).abs() < 0.5, "{before} → {after}");
        // and it follows the rebooted vehicle
        let first = got[0];
        for (read, truth) in got.iter().skip(20) {
            assert!(((read - first.0) - (truth - first.1)).abs() < 30.0);
        }
    }

    /// One stray report with a small timestamp (a message whose time was not filled in) is
    /// not a reboot: the clock keeps following the vehicle.
    #[test]
    fn a_stray_small_timestamp_is_not_a_reboot() {
        let mut c = VehicleClock::new();
        follow(&mut c, 1, 2.0, (0..10_000).step_by(100), 500_000.0, |_| 1);
        c.observe(1, Duration::from_millis(12), wall_ms(10_001));
        let got = follow(
            &mut c,
            1,
            2.0,
            (10_050..20_000).step_by(100),
            500_000.0,
            |_| 1,
        );
        let (read, truth) = got[got.len() - 1];
        // the clock still reads the vehicle's time on the first mapping (offset 1 ms − 500 s)
        assert!(
            (read - (truth - 500_000.0 + 1.0)).abs() < 10.0,
            "{read} {truth}"
        );
    }

    /// A vehicle that stalls (no time moves for 5 s of wall, e.g. a simulator paused by a
    /// loaded machine) holds the clock within the lead; it then follows again.
    #[test]
    fn a_stalled_vehicle_holds_the_clock() {
        let mut c = VehicleClock::new();
        follow(&mut c, 1, 5.0, (0..10_000).step_by(100), 1000.0, |_| 1);
        let t0 = c.now(wall_ms(10_000)).as_secs_f64();
        // the vehicle's time stands at 51 s while 5 s of wall pass: reports repeat it
        for w in (10_000..15_000).step_by(100) {
            c.observe(1, Duration::from_millis(51_000), wall_ms(w));
        }
        let held = c.now(wall_ms(15_000)).as_secs_f64();
        // it ran on for at most 1 s of lead (0.5 s of wall at 5×) past the last report
        // plus the one report interval, then waited
        assert!(held - t0 < 3.5, "{t0} → {held}");
        // the vehicle resumes: the clock re-anchors to it and stands still until the
        // vehicle's time catches up with what it has shown
        for w in (15_000..25_000).step_by(100) {
            c.observe(
                1,
                Duration::from_millis(51_000 + (w - 15_000) * 5),
                wall_ms(w),
            );
        }
        let end = c.now(wall_ms(25_000)).as_secs_f64();
        assert!((end - (t0 + 50.0)).abs() < 1.5, "{t0} → {end}");
    }

    /// A vehicle that goes silent: the clock runs on for 5 s of wall time at the rate, then
    /// waits; reports that come back ahead of it move it on.
    #[test]
    fn a_silent_vehicle_stops_the_clock_after_a_while() {
        let mut c = VehicleClock::new();
        follow(&mut c, 1, 5.0, (0..10_000).step_by(100), 0.0, |_| 1);
        let t0 = c.now(wall_ms(9_901)).as_secs_f64();
        let t1 = c.now(wall_ms(30_000)).as_secs_f64();
        assert!((t1 - t0 - 25.0).abs() < 0.1, "{t0} → {t1}");
        // it ran all along (the link was down): the first report moves the clock on
        follow(&mut c, 1, 5.0, (30_000..31_000).step_by(100), 0.0, |_| 1);
        let t2 = c.now(wall_ms(31_000)).as_secs_f64();
        assert!((t2 - t0 - 105.5).abs() < 0.1, "{t0} → {t2}");
    }

    /// Two systems booted at different times share the clock: each is mapped where the clock
    /// stood when first heard, and the clock keeps the common rate.
    #[test]
    fn several_systems_share_one_timeline() {
        let mut c = VehicleClock::new();
        for w in (0..30_000u64).step_by(50) {
            c.observe(1, Duration::from_millis(500_000 + w * 3), wall_ms(w));
            if w >= 5_000 {
                c.observe(2, Duration::from_millis(7_000 + w * 3), wall_ms(w + 1));
            }
        }
        assert!((c.rate() - 3.0).abs() < 0.03, "{}", c.rate());
        let a = c.now(wall_ms(30_000)).as_secs_f64();
        assert!((a - 90.0).abs() < 0.5, "{a}");
    }
}
