//! The launch machine against lost and delayed ACKs: unit cases of each rule, and a property
//! test of a whole take-off through the real command sender ([`CommandSender`]), a lossy,
//! delaying link each way and a model of ArduCopter's arming and take-off rules (DISARM_DELAY,
//! a NAV_TAKEOFF refused disarmed or off the ground, pre-arm checks).

use super::*;
use crate::proto::Endpoint;
use crate::proto::command::{CommandConfig, CommandEvent, CommandSender};
use crate::proto::flavour::{Flavour, Step as FlavourStep};
use crate::proto::mode::CopterMode;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{COMMAND_ACK_DATA, MavCmd, MavMessage, MavResult};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;

const GUIDED: Mode = Mode::Copter(CopterMode::Guided);

fn t(ms: u64) -> Time {
    Time::from_millis(ms)
}

fn ground(mode: Option<Mode>, armed: bool) -> Observed {
    Observed {
        heard: true,
        armed,
        mode,
        landed: Landed::OnGround,
        alt_rel_m: Some(0.0),
        climb_m_s: Some(0.0),
        ..Observed::default()
    }
}

fn airborne_goal() -> Goal {
    Goal::Airborne { mode: Some(GUIDED) }
}

#[test]
fn steps_in_order_and_an_effect_without_its_ack_counts() {
    let mut l = Launch::new(airborne_goal(), LaunchConfig::default(), t(0));
    let mut obs = ground(Some(Mode::Copter(CopterMode::Stabilize)), false);
    assert_eq!(l.poll(t(0), &obs), Action::Send(Step::SetMode(GUIDED)));
    // No ACK yet, and none ever: the heartbeat shows GUIDED.
    assert!(matches!(l.poll(t(100), &obs), Action::Wait(_)));
    obs.mode = Some(GUIDED);
    assert_eq!(l.poll(t(300), &obs), Action::Send(Step::Arm));
    obs.armed = true;
    assert_eq!(l.poll(t(600), &obs), Action::Send(Step::Takeoff));
    // The ACK of the take-off is lost; the resend is refused (already flying) — and the
    // state shows it climbing.
    l.on_result(
        Step::Takeoff,
        Err(CommandError::Failed {
            command: MavCmd::MAV_CMD_NAV_TAKEOFF,
        }),
        t(1700),
    );
    obs.climb_m_s = Some(1.0);
    obs.alt_rel_m = Some(0.4);
    assert!(
        matches!(l.poll(t(1800), &obs), Action::Wait(_)),
        "climbing: no second take-off, but not done before it is off the ground"
    );
    obs.landed = Landed::TakingOff;
    assert_eq!(l.poll(t(2000), &obs), Action::Done);
    assert_eq!((l.commands(), l.failures()), (3, 0));
    // A late result changes nothing.
    l.on_result(Step::Arm, Ok(()), t(2100));
    assert_eq!(l.poll(t(2200), &obs), Action::Done);
}

#[test]
fn a_refusal_counts_after_its_grace_and_the_retry_starts_from_the_state() {
    let cfg = LaunchConfig::default();
    let mut l = Launch::new(airborne_goal(), cfg, t(0));
    let mut obs = ground(Some(GUIDED), true);
    assert_eq!(l.poll(t(0), &obs), Action::Send(Step::Takeoff));
    // Refused: the copter disarmed itself meanwhile (DISARM_DELAY).
    l.on_result(
        Step::Takeoff,
        Err(CommandError::Failed {
            command: MavCmd::MAV_CMD_NAV_TAKEOFF,
        }),
        t(500),
    );
    obs.armed = false;
    assert!(matches!(l.poll(t(1000), &obs), Action::Wait(_)), "grace");
    let at = t(500) + REFUSAL_GRACE;
    match l.poll(at, &obs) {
        Action::Wait(w) => assert_eq!(w, at + cfg.backoff_first, "first back-off"),
        a => panic!("{a:?}"),
    }
    assert_eq!(l.failures(), 1);
    assert!(matches!(
        l.last_cause(),
        Some(Cause::Refused {
            step: Step::Takeoff,
            ..
        })
    ));
    // From the current state: arm again, then take off.
    assert_eq!(
        l.poll(at + cfg.backoff_first, &obs),
        Action::Send(Step::Arm)
    );
    obs.armed = true;
    let next = at + cfg.backoff_first + Duration::from_millis(200);
    assert_eq!(l.poll(next, &obs), Action::Send(Step::Takeoff));
}

#[test]
fn accepted_without_effect_is_not_done_and_back_off_is_bounded() {
    let cfg = LaunchConfig {
        max_failures: 4,
        ..LaunchConfig::default()
    };
    let mut l = Launch::new(Goal::Mode(GUIDED), cfg, t(0));
    let obs = ground(Some(Mode::Copter(CopterMode::Loiter)), false);
    let mut now = t(0);
    let mut backoffs = Vec::new();
    loop {
        match l.poll(now, &obs) {
            Action::Send(Step::SetMode(m)) => {
                assert_eq!(m, GUIDED);
                l.on_result(Step::SetMode(m), Ok(()), now + Duration::from_millis(200));
                now += Duration::from_millis(200);
            }
            Action::Wait(w) => {
                if l.failures() > backoffs.len() as u32 {
                    backoffs.push(w.saturating_since(now));
                }
                now = w;
            }
            Action::Failed(f) => {
                assert_eq!(f.failures, 4);
                assert_eq!(f.commands, 4);
                assert!(matches!(f.cause, Cause::NoEffect { .. }), "{f}");
                break;
            }
            Action::Done | Action::Send(_) => panic!("never in GUIDED"),
        }
    }
    let secs: Vec<u64> = backoffs.iter().map(|d| d.as_secs()).collect();
    assert_eq!(secs, vec![1, 2, 4], "1 s, doubling, at most 4 s");
}

#[test]
fn a_vehicle_that_is_not_ready_is_not_armed_and_a_silent_one_not_sent_to() {
    let cfg = LaunchConfig::default();
    let mut l = Launch::new(airborne_goal(), cfg, t(0));
    let mut obs = ground(Some(GUIDED), false);
    obs.blockers = vec!["pre-arm checks failing: PreArm: Compass not calibrated".into()];
    let mut now = t(0);
    let f = loop {
        match l.poll(now, &obs) {
            Action::Wait(w) => now = w,
            Action::Failed(f) => break f,
            a => panic!("{a:?}"),
        }
    };
    assert_eq!(f.commands, 0);
    assert!(f.waited >= cfg.ready_wait);
    assert!(f.to_string().contains("Compass not calibrated"), "{f}");

    let mut l = Launch::new(Goal::Armed { mode: None }, cfg, t(0));
    let obs = Observed::default();
    let mut now = t(0);
    let f = loop {
        match l.poll(now, &obs) {
            Action::Wait(w) => now = w,
            Action::Failed(f) => break f,
            a => panic!("{a:?}"),
        }
    };
    assert!(matches!(f.cause, Cause::Silent { .. }) && f.cause.is_link());
    assert!(f.waited >= cfg.silence_wait && f.waited < cfg.silence_wait * 2);
}

// ------------------------------------------------------------------------------------------
// The whole take-off through a lossy link.

/// ArduCopter's rules that a launch meets: GUIDED to arm for a take-off, pre-arm checks,
/// DISARM_DELAY on the ground, NAV_TAKEOFF refused when disarmed or off the ground.
#[derive(Debug)]
struct Copter {
    mode: Mode,
    armed: bool,
    armed_at: Time,
    takeoff_at: Option<Time>,
    alt: f32,
    /// Ready to arm from this time on (`None`: never, a pre-arm failure that persists).
    ready_at: Option<Time>,
    /// NAV_TAKEOFF received while off the ground (a resend: harmless, refused).
    takeoffs_in_air: u32,
}

const DISARM_DELAY: Duration = Duration::from_secs(10);

impl Copter {
    fn ready(&self, now: Time) -> bool {
        self.ready_at.is_some_and(|r| now >= r)
    }

    /// Its take-off is under way or done (armed and climbing), by its own state.
    fn took_off(&self) -> bool {
        self.armed && self.takeoff_at.is_some()
    }

    fn on_ground(&self, now: Time) -> bool {
        self.takeoff_at
            .is_none_or(|t0| now.saturating_since(t0) < Duration::from_millis(500))
    }

    fn step(&mut self, now: Time, dt: Duration) {
        if self.armed
            && self.takeoff_at.is_none()
            && now.saturating_since(self.armed_at) >= DISARM_DELAY
        {
            self.armed = false;
        }
        if !self.on_ground(now) && self.alt < 10.0 {
            self.alt += 2.0 * dt.as_secs_f32();
        }
    }

    fn command(
        &mut self,
        c: &mavlink::dialects::ardupilotmega::COMMAND_LONG_DATA,
        now: Time,
    ) -> MavResult {
        use MavResult::*;
        match c.command {
            MavCmd::MAV_CMD_DO_SET_MODE => match Flavour::ARDU_COPTER.mode_of(c.param2 as u32) {
                Some(m) => {
                    self.mode = m;
                    MAV_RESULT_ACCEPTED
                }
                None => MAV_RESULT_DENIED,
            },
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if c.param1 > 0.5 => {
                if self.armed {
                    MAV_RESULT_ACCEPTED
                } else if !self.ready(now) {
                    MAV_RESULT_FAILED
                } else {
                    self.armed = true;
                    self.armed_at = now;
                    MAV_RESULT_ACCEPTED
                }
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => {
                if !self.on_ground(now) || self.takeoff_at.is_some() {
                    self.takeoffs_in_air += 1;
                    MAV_RESULT_FAILED
                } else if !self.armed || self.mode != GUIDED {
                    MAV_RESULT_FAILED
                } else {
                    self.takeoff_at = Some(now);
                    MAV_RESULT_ACCEPTED
                }
            }
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    /// What its telemetry says now.
    fn telemetry(&self, now: Time) -> Observed {
        let off = !self.on_ground(now);
        Observed {
            heard: true,
            booting: false,
            armed: self.armed,
            mode: Some(self.mode),
            landed: match (self.armed, off, self.takeoff_at.is_some()) {
                (true, true, _) => Landed::InAir,
                (true, false, true) => Landed::TakingOff,
                _ => Landed::OnGround,
            },
            alt_rel_m: Some(self.alt),
            climb_m_s: Some(if off && self.alt < 10.0 { 2.0 } else { 0.0 }),
            blockers: if self.ready(now) {
                Vec::new()
            } else {
                vec!["pre-arm checks failing: PreArm: Compass not calibrated".into()]
            },
        }
    }
}

/// A link direction: each frame lost with probability `loss`, delayed up to `max_delay`.
struct Air {
    loss: f64,
    max_delay: Duration,
    /// Frames in flight by arrival time (and a counter keeping equal times apart).
    queue: BTreeMap<(Time, u64), Frame>,
    n: u64,
}

#[derive(Debug)]
enum Frame {
    Command(MavMessage),
    Ack(MavMessage),
    Telemetry(Box<Observed>),
}

impl Air {
    fn new(loss: f64, max_delay: Duration) -> Air {
        Air {
            loss,
            max_delay,
            queue: BTreeMap::new(),
            n: 0,
        }
    }

    fn send(&mut self, f: Frame, now: Time, rng: &mut ChaCha8Rng) {
        if rng.random::<f64>() < self.loss {
            return;
        }
        let d = self.max_delay.mul_f64(rng.random::<f64>());
        self.n += 1;
        self.queue.insert((now + d, self.n), f);
    }

    fn due(&mut self, now: Time) -> Vec<Frame> {
        let later = self.queue.split_off(&(now + Duration::from_micros(1), 0));
        let due = std::mem::replace(&mut self.queue, later);
        due.into_values().collect()
    }
}

struct Flight {
    outcome: Action,
    at: Time,
    copter: Copter,
    /// Take-off steps the launch sent while it saw the copter off the ground or climbing.
    takeoffs_seen_flying: u32,
    /// Take-off commands whose result was a refusal: where a GCS trusting one ACK stops.
    takeoffs_refused: u32,
}

/// Fly one launch to its end: the GCS (launch + command sender) at 50 ms ticks, the copter
/// at 50 ms, telemetry every `telemetry`.
fn fly(
    seed: u64,
    loss_up: f64,
    loss_down: f64,
    delay: Duration,
    telemetry: Duration,
    ready_at: Option<Time>,
) -> Flight {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let gcs = Endpoint::gcs();
    let target = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
    let mut sender = CommandSender::new(gcs, CommandConfig::default());
    let mut launch = Launch::new(airborne_goal(), LaunchConfig::default(), Time::ZERO);
    let mut copter = Copter {
        mode: Mode::Copter(CopterMode::Stabilize),
        armed: false,
        armed_at: Time::ZERO,
        takeoff_at: None,
        alt: 0.0,
        ready_at,
        takeoffs_in_air: 0,
    };
    let mut up = Air::new(loss_up, delay);
    let mut down = Air::new(loss_down, delay);
    let mut seen = Observed::default();
    let mut heard_at: Option<Time> = None;
    let mut next_telemetry = Time::ZERO;
    let mut ids: BTreeMap<u64, Step> = BTreeMap::new();
    let mut takeoffs_seen_flying = 0;
    let mut takeoffs_refused = 0;
    let tick = Duration::from_millis(50);
    let mut now = Time::ZERO;
    let header = MavHeader {
        system_id: 1,
        component_id: crate::proto::AUTOPILOT_COMPID,
        sequence: 0,
    };
    let takeoff_cmd = match Flavour::ARDU_COPTER.takeoff(target, 10.0, None) {
        Ok(steps) => steps
            .into_iter()
            .find_map(|s| match s {
                FlavourStep::Command(c) => Some(c),
                _ => None,
            })
            .expect("a take-off command"),
        Err(e) => panic!("{e}"),
    };
    loop {
        // The vehicle's side.
        copter.step(now, tick);
        for f in up.due(now) {
            if let Frame::Command(MavMessage::COMMAND_LONG(c)) = f {
                let result = copter.command(&c, now);
                let ack = MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                    command: c.command,
                    result,
                    progress: 0,
                    result_param2: 0,
                    target_system: crate::proto::GCS_SYSID,
                    target_component: crate::proto::GCS_COMPID,
                });
                down.send(Frame::Ack(ack), now, &mut rng);
            }
        }
        if now >= next_telemetry {
            down.send(
                Frame::Telemetry(Box::new(copter.telemetry(now))),
                now,
                &mut rng,
            );
            next_telemetry = now + telemetry;
        }
        // The GCS's side.
        for f in down.due(now) {
            match f {
                Frame::Ack(m) => sender.handle_message(&header, &m, now),
                Frame::Telemetry(o) => {
                    seen = *o;
                    heard_at = Some(now);
                }
                Frame::Command(_) => {}
            }
        }
        if sender.poll_timeout().is_some_and(|d| d <= now) {
            sender.handle_timeout(now);
        }
        while let Some(ev) = sender.poll_event() {
            if let CommandEvent::Done { id, result } = ev
                && let Some(step) = ids.remove(&id)
            {
                if step == Step::Takeoff && result.as_ref().is_err_and(|e| !e.is_transient()) {
                    takeoffs_refused += 1;
                }
                launch.on_result(step, result.map(|_| ()), now);
            }
        }
        seen.heard = heard_at.is_some_and(|h| now.saturating_since(h) <= Duration::from_secs(3));
        match launch.poll(now, &seen) {
            Action::Send(step) => {
                if seen.off_ground() || seen.climbing() {
                    takeoffs_seen_flying += u32::from(step == Step::Takeoff);
                }
                let cmd = match step {
                    Step::SetMode(m) => Flavour::ARDU_COPTER.set_mode_command(target, m),
                    Step::Arm => Flavour::ARDU_COPTER.arm_command(target, true),
                    Step::Takeoff => takeoff_cmd.clone(),
                };
                let id = sender.start(cmd, now);
                ids.insert(id, step);
            }
            Action::Wait(_) => {}
            a @ (Action::Done | Action::Failed(_)) => {
                return Flight {
                    outcome: a,
                    at: now,
                    copter,
                    takeoffs_seen_flying,
                    takeoffs_refused,
                };
            }
        }
        while let Some(m) = sender.poll_transmit() {
            up.send(Frame::Command(m), now, &mut rng);
        }
        now += tick;
        assert!(now < Time::from_secs(600), "the launch never ended");
    }
}

/// The longest a launch may take: the readiness wait, then every failed attempt with its
/// command sender's resends, its window and its back-off.
fn bound(cfg: &LaunchConfig) -> Duration {
    let attempt =
        CommandSender::budget(&CommandConfig::default()) + cfg.takeoff_confirm + cfg.backoff_max;
    cfg.ready_wait + attempt * (cfg.max_failures + 1)
}

#[test]
fn a_lost_takeoff_ack_whose_resend_is_refused_still_takes_off() {
    // Find a seed where the copter refused a resent take-off (its first ACK lost): what the
    // field saw as "NAV_TAKEOFF: failed". The launch must end in the air all the same.
    let mut found = 0;
    for seed in 0..200 {
        let f = fly(
            seed,
            0.1,
            0.3,
            Duration::from_millis(300),
            Duration::from_millis(500),
            Some(Time::ZERO),
        );
        assert_eq!(f.outcome, Action::Done, "seed {seed}");
        assert!(f.copter.took_off(), "seed {seed}");
        found += usize::from(f.copter.takeoffs_in_air > 0 && f.takeoffs_refused > 0);
    }
    eprintln!("{found} of 200 take-offs had a refused resend and still flew");
    assert!(
        found > 0,
        "no resend of a take-off was refused in 200 flights"
    );
}

#[test]
fn a_persistent_prearm_failure_ends_the_launch_without_arming() {
    let f = fly(
        7,
        0.1,
        0.1,
        Duration::from_millis(200),
        Duration::from_millis(500),
        None,
    );
    match &f.outcome {
        Action::Failed(fail) => {
            assert!(matches!(fail.cause, Cause::NotReady { .. }), "{fail}");
            assert!(!fail.cause.is_link());
            assert_eq!(
                fail.commands, 0,
                "nothing sent to a vehicle not ready: {fail}"
            );
        }
        a => panic!("{a:?}"),
    }
    assert!(!f.copter.armed);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Through links that lose up to 30 % of the frames each way and delay them up to
    /// 0.8 s, with telemetry every 0.2–2 s and a copter that becomes ready up to 30 s
    /// late: the launch ends with the copter taking off or in the air (its own state, not the GCS's
    /// view), within
    /// the bound of its retries, and never sends a take-off while it sees the copter
    /// climbing or in the air.
    #[test]
    fn a_take_off_through_a_lossy_link_ends_in_the_air(
        seed in 0u64..1_000_000,
        loss_up in 0.0f64..0.3,
        loss_down in 0.0f64..0.3,
        delay_ms in 0u64..800,
        telemetry_ms in 200u64..2000,
        ready_s in 0u64..30,
    ) {
        let f = fly(
            seed,
            loss_up,
            loss_down,
            Duration::from_millis(delay_ms),
            Duration::from_millis(telemetry_ms),
            Some(Time::from_secs(ready_s)),
        );
        prop_assert_eq!(&f.outcome, &Action::Done);
        prop_assert!(f.copter.took_off());
        prop_assert!(f.at.saturating_since(Time::ZERO) <= bound(&LaunchConfig::default()));
        prop_assert_eq!(f.takeoffs_seen_flying, 0);
    }

    /// A link that carries nothing: the launch gives up within its bound, saying the
    /// vehicle was not heard, and the copter never moved.
    #[test]
    fn a_dead_link_gives_up_in_time(seed in 0u64..1_000_000) {
        let f = fly(seed, 1.0, 1.0, Duration::ZERO, Duration::from_millis(500), Some(Time::ZERO));
        match &f.outcome {
            Action::Failed(fail) => prop_assert!(fail.cause.is_link(), "{}", fail),
            a => prop_assert!(false, "{:?}", a),
        }
        prop_assert!(f.at.saturating_since(Time::ZERO) <= LaunchConfig::default().silence_wait + Duration::from_secs(1));
        prop_assert!(!f.copter.armed);
    }
}
