//! Getting a vehicle going — into a mode, armed, or off the ground — confirmed from what the
//! vehicle itself reports, not from one COMMAND_ACK. Sans-IO, like the other machines here:
//! the shell feeds it the vehicle's state ([`Observed`]: HEARTBEAT armed flag and mode,
//! EXTENDED_SYS_STATE landed state, GLOBAL_POSITION_INT altitude and climb rate, the arming
//! checks) and each command's result ([`Launch::on_result`]), asks [`Launch::poll`] what to
//! do, sends the command of the [`Step`] it names, and waits until the time it names or the
//! next change of state.
//!
//! Why not trust the ACK: over a telemetry radio that loses frames, an ACK can be lost while
//! its command took effect, and the command sender's own retransmission of a command that
//! took effect can then be refused. ArduCopter refuses a NAV_TAKEOFF when disarmed or already
//! off the ground (`Mode::do_user_takeoff`, ArduCopter/takeoff.cpp: "can't takeoff again"),
//! so a take-off whose first ACK was lost is answered MAV_RESULT_FAILED by its resend while
//! the copter climbs; and an ARM accepted with the take-off lost behind it ends with the
//! copter disarming itself after DISARM_DELAY (10 s) on the ground, so that the next
//! take-off fails too. Both were seen on ArduCopter 4.7 SITL behind a 2 kB/s radio with 10 %
//! loss ("MAV_CMD_NAV_TAKEOFF: failed").
//!
//! The rules, as a careful operator would apply them:
//!
//! * **A step is done when its effect shows** in the vehicle's state — the mode in the
//!   heartbeat, the armed flag, the vehicle off the ground or climbing — whatever its ACK
//!   said or if none came.
//! * **An accepted command without effect is not done**: accepted (or unanswered after the
//!   command sender's own resends) and no effect within the step's window
//!   ([`LaunchConfig::mode_confirm`], `arm_confirm`, `takeoff_confirm`) is a failed attempt;
//!   a refusal is one too, after [`REFUSAL_GRACE`] in which the state may still show that an
//!   earlier copy of the command took effect.
//! * **Retry from the current state**: after a failed attempt the next step is chosen again
//!   from what the vehicle reports now — set the mode again if it changed, arm again after an
//!   auto-disarm, take off again while still on the ground — and never a take-off while the
//!   vehicle is seen climbing or in the air.
//! * **Bounded back-off** between failed attempts: [`LaunchConfig::backoff_first`] (1 s),
//!   doubling, at most [`LaunchConfig::backoff_max`] (4 s), and at most
//!   [`LaunchConfig::max_failures`] (5) failed attempts. 4 s keeps a retry inside
//!   ArduCopter's DISARM_DELAY (10 s) of an arm that went through, so that the take-off that
//!   follows it finds the copter still armed; five attempts with the command sender's four
//!   transmissions each make 20 commands over about 40 s, enough to ride out a radio's bad
//!   patch, and short enough that the rest of a team is not kept waiting for long.
//! * **Arming waits for readiness**: a vehicle whose arming checks fail ([`Observed::blockers`]:
//!   no GPS fix, no position estimate or home, pre-arm failures) is not sent ARM — it is
//!   waited for, at most [`LaunchConfig::ready_wait`], then the launch fails with what still
//!   blocks it. A vehicle not heard is not sent anything — waited for at most
//!   [`LaunchConfig::silence_wait`].
//!
//! What others do: QGroundControl validates a mode change by the heartbeat (three tries,
//! `FirmwarePlugin::_setFlightModeAndValidate`) and an arm by the armed flag, but arms only
//! once (`FirmwarePlugin::_armVehicleAndValidate`), and its command queue does not resend
//! most commands at all (`Vehicle::_sendMavCommandShouldRetry`: a resend of ARM that arrives
//! seconds later could arm a vehicle someone walked up to); its guided take-off on ArduPilot
//! is GUIDED, arm, NAV_TAKEOFF (`APMFirmwarePlugin::_guidedModeTakeoff`), trusting the ACK
//! of the last. MAVSDK (`ActionImpl::takeoff_async_apm`, `ActionImpl::arm_async`) sends each
//! command through its command sender (resends on timeout, like [`super::command`]) and
//! reports the ACK. MAVProxy's `arm throttle`, `mode` and `takeoff` send once. We follow
//! QGroundControl in confirming each step from the vehicle's state and its order of steps;
//! we re-arm after an auto-disarm where it would not, because a sortie start is an unattended
//! start from a charging station, and a re-arm is followed at once by the take-off.

use super::command::CommandError;
use super::mode::Mode;
use crate::time::Time;
use std::fmt;
use std::time::Duration;

/// After a refusal, how long the vehicle's state still gets to show that an earlier copy of
/// the command took effect before the refusal counts (state arrives a telemetry period later
/// than the ACK).
pub const REFUSAL_GRACE: Duration = Duration::from_millis(1500);

/// Altitude above home at which a vehicle with no landed state counts as off the ground,
/// metres.
const OFF_GROUND_M: f32 = 1.0;

/// Climb rate above which an armed vehicle counts as taking off, m/s (up positive).
const CLIMBING_M_S: f32 = 0.3;

/// How often to look again while waiting on nothing in particular.
const LOOK_AGAIN: Duration = Duration::from_millis(500);

/// Longest wait for a command's result once sent (the shell's command has its own, shorter
/// timeout; this only keeps a lost result from holding the launch for ever).
const RESULT_WAIT: Duration = Duration::from_secs(60);

/// The windows and bounds of a launch (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LaunchConfig {
    /// After a mode command is answered, how long the heartbeat gets to show the mode.
    pub mode_confirm: Duration,
    /// After an arm command is answered, how long the heartbeat gets to show armed.
    pub arm_confirm: Duration,
    /// After a take-off command is answered, how long the vehicle gets to leave the ground.
    pub takeoff_confirm: Duration,
    /// First back-off after a failed attempt.
    pub backoff_first: Duration,
    /// Longest back-off.
    pub backoff_max: Duration,
    /// Failed attempts after which the launch gives up.
    pub max_failures: u32,
    /// Longest wait for a vehicle that is not ready to arm (or still booting).
    pub ready_wait: Duration,
    /// Longest wait for a vehicle that is not heard.
    pub silence_wait: Duration,
}

impl Default for LaunchConfig {
    fn default() -> Self {
        LaunchConfig {
            mode_confirm: Duration::from_secs(5),
            arm_confirm: Duration::from_secs(5),
            takeoff_confirm: Duration::from_secs(8),
            backoff_first: Duration::from_secs(1),
            backoff_max: Duration::from_secs(4),
            max_failures: 5,
            ready_wait: Duration::from_secs(60),
            silence_wait: Duration::from_secs(20),
        }
    }
}

/// What the launch is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Goal {
    /// The vehicle in this mode.
    Mode(Mode),
    /// The vehicle armed (in `mode` first, when given: ArduCopter arms in GUIDED).
    Armed {
        /// The mode to be in before arming.
        mode: Option<Mode>,
    },
    /// The vehicle off the ground: armed (in `mode` first, when given), then taken off.
    Airborne {
        /// The mode to be in before arming and taking off (ArduCopter GUIDED; PX4 none:
        /// its NAV_TAKEOFF switches to TAKEOFF itself).
        mode: Option<Mode>,
    },
}

impl fmt::Display for Goal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Goal::Mode(m) => write!(f, "mode {}", m.name()),
            Goal::Armed { .. } => write!(f, "arming"),
            Goal::Airborne { .. } => write!(f, "take-off"),
        }
    }
}

/// The landed state (EXTENDED_SYS_STATE `landed_state`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Landed {
    /// Not reported (or MAV_LANDED_STATE_UNDEFINED).
    #[default]
    Unknown,
    /// On the ground.
    OnGround,
    /// Taking off.
    TakingOff,
    /// In the air.
    InAir,
    /// Landing.
    Landing,
}

/// The vehicle's state as last reported (stale by a telemetry period or more).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Observed {
    /// Heard within the liveness window.
    pub heard: bool,
    /// Still booting.
    pub booting: bool,
    /// HEARTBEAT: armed.
    pub armed: bool,
    /// HEARTBEAT: its mode, when the flavour's table has it.
    pub mode: Option<Mode>,
    /// EXTENDED_SYS_STATE.
    pub landed: Landed,
    /// Altitude above home, metres.
    pub alt_rel_m: Option<f32>,
    /// Climb rate, m/s (up positive).
    pub climb_m_s: Option<f32>,
    /// Why it cannot be armed now (empty: it can), as the arming checks say.
    pub blockers: Vec<String>,
}

impl Observed {
    /// Seen off the ground: armed, and in the air (or taking off) by its landed state, or
    /// above `OFF_GROUND_M` when it reports none.
    pub fn off_ground(&self) -> bool {
        self.armed
            && match self.landed {
                Landed::InAir | Landed::TakingOff => true,
                Landed::OnGround | Landed::Landing => false,
                Landed::Unknown => self.alt_rel_m.is_some_and(|a| a >= OFF_GROUND_M),
            }
    }

    /// Seen climbing while armed: a take-off under way that the landed state may not show
    /// yet.
    pub fn climbing(&self) -> bool {
        self.armed && self.climb_m_s.is_some_and(|c| c > CLIMBING_M_S)
    }
}

/// One step of a launch: the shell sends the command for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Switch to this mode (MAV_CMD_DO_SET_MODE).
    SetMode(Mode),
    /// Arm (MAV_CMD_COMPONENT_ARM_DISARM).
    Arm,
    /// Take off (MAV_CMD_NAV_TAKEOFF, as the flavour builds it).
    Takeoff,
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Step::SetMode(m) => write!(f, "mode {}", m.name()),
            Step::Arm => write!(f, "arm"),
            Step::Takeoff => write!(f, "take-off"),
        }
    }
}

/// Why an attempt (or the whole launch) failed.
#[derive(Clone, Debug, PartialEq)]
pub enum Cause {
    /// The vehicle refused the step's command.
    Refused {
        /// The step.
        step: Step,
        /// Its answer.
        error: CommandError,
    },
    /// The vehicle never answered the step's command (after the command sender's resends),
    /// and its state did not show the effect either.
    NoAnswer {
        /// The step.
        step: Step,
        /// The command sender's error (`None`: no result came at all).
        error: Option<CommandError>,
    },
    /// The vehicle accepted the step's command but its state did not show the effect in
    /// time.
    NoEffect {
        /// The step.
        step: Step,
        /// How long its state was watched after the answer.
        waited: Duration,
    },
    /// The vehicle was not ready to arm (or still booting) for the whole of
    /// [`LaunchConfig::ready_wait`].
    NotReady {
        /// What still blocked it.
        reasons: Vec<String>,
    },
    /// The vehicle was not heard for the whole of [`LaunchConfig::silence_wait`].
    Silent {
        /// How long.
        waited: Duration,
    },
}

impl Cause {
    /// Whether this says the vehicle did not answer (a link that lost its frames), as
    /// opposed to the vehicle saying no or showing that it cannot.
    pub fn is_link(&self) -> bool {
        matches!(self, Cause::NoAnswer { .. } | Cause::Silent { .. })
    }
}

impl fmt::Display for Cause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Cause::Refused { step, error } => write!(f, "{step} refused: {error}"),
            Cause::NoAnswer {
                step,
                error: Some(error),
            } => write!(f, "{step} not answered: {error}"),
            Cause::NoAnswer { step, error: None } => write!(f, "{step}: no answer"),
            Cause::NoEffect { step, waited } => write!(
                f,
                "{step} accepted but not seen in the vehicle's state within {:.1} s",
                waited.as_secs_f64()
            ),
            Cause::NotReady { reasons } => {
                write!(f, "not ready to arm: {}", reasons.join("; "))
            }
            Cause::Silent { waited } => {
                write!(f, "not heard for {:.0} s", waited.as_secs_f64())
            }
        }
    }
}

/// A launch that gave up.
#[derive(Clone, Debug, PartialEq)]
pub struct LaunchFailure {
    /// What it was for.
    pub goal: Goal,
    /// Commands sent.
    pub commands: u32,
    /// Failed attempts.
    pub failures: u32,
    /// Since the launch started.
    pub waited: Duration,
    /// The last failure's cause (what ended it).
    pub cause: Cause,
}

impl fmt::Display for LaunchFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} not achieved after {} command(s), {} failed attempt(s) in {:.0} s: {}",
            self.goal,
            self.commands,
            self.failures,
            self.waited.as_secs_f64(),
            self.cause
        )
    }
}

/// What the shell should do now.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Send the command of this step, then report its result ([`Launch::on_result`]).
    Send(Step),
    /// Nothing until this time, a new state of the vehicle or a command's result.
    Wait(Time),
    /// The goal is reached.
    Done,
    /// The launch gave up.
    Failed(LaunchFailure),
}

/// The command out: its step, when it went, and its result once known.
#[derive(Clone, Debug)]
struct Pending {
    step: Step,
    sent: Time,
    result: Option<(Result<(), CommandError>, Time)>,
}

/// One launch (see the module docs).
#[derive(Clone, Debug)]
pub struct Launch {
    goal: Goal,
    cfg: LaunchConfig,
    started: Time,
    pending: Option<Pending>,
    commands: u32,
    failures: u32,
    last: Option<Cause>,
    retry_at: Option<Time>,
    silent_since: Option<Time>,
    unready_since: Option<Time>,
    /// Set once the launch is over: what every later poll returns.
    outcome: Option<Action>,
}

impl Launch {
    /// A launch for `goal`, started at `now`.
    pub fn new(goal: Goal, cfg: LaunchConfig, now: Time) -> Launch {
        Launch {
            goal,
            cfg,
            started: now,
            pending: None,
            commands: 0,
            failures: 0,
            last: None,
            retry_at: None,
            silent_since: None,
            unready_since: None,
            outcome: None,
        }
    }

    /// The goal.
    pub fn goal(&self) -> Goal {
        self.goal
    }

    /// Commands sent so far.
    pub fn commands(&self) -> u32 {
        self.commands
    }

    /// Failed attempts so far.
    pub fn failures(&self) -> u32 {
        self.failures
    }

    /// The last failed attempt's cause.
    pub fn last_cause(&self) -> Option<&Cause> {
        self.last.as_ref()
    }

    /// The result of the command sent for `step` (its ACK, or the command sender's error).
    /// A result for a step that is no longer waited for (its effect showed first) is
    /// ignored.
    pub fn on_result(&mut self, step: Step, result: Result<(), CommandError>, now: Time) {
        if let Some(p) = &mut self.pending
            && p.step == step
            && p.result.is_none()
        {
            p.result = Some((result, now));
        }
    }

    /// Whether `goal` is reached in `obs`.
    fn reached(&self, obs: &Observed) -> bool {
        match self.goal {
            Goal::Mode(m) => obs.mode == Some(m),
            Goal::Armed { .. } => obs.armed,
            Goal::Airborne { .. } => obs.off_ground(),
        }
    }

    /// Whether the effect of `step` shows in `obs`.
    fn took_effect(step: Step, obs: &Observed) -> bool {
        match step {
            Step::SetMode(m) => obs.mode == Some(m),
            Step::Arm => obs.armed,
            Step::Takeoff => obs.off_ground() || obs.climbing(),
        }
    }

    fn window(&self, step: Step) -> Duration {
        match step {
            Step::SetMode(_) => self.cfg.mode_confirm,
            Step::Arm => self.cfg.arm_confirm,
            Step::Takeoff => self.cfg.takeoff_confirm,
        }
    }

    fn backoff(&self) -> Duration {
        let n = self.failures.saturating_sub(1).min(16);
        self.cfg
            .backoff_first
            .saturating_mul(1u32 << n)
            .min(self.cfg.backoff_max)
    }

    fn fail(&mut self, cause: Cause, now: Time) {
        self.pending = None;
        self.failures += 1;
        self.last = Some(cause);
        self.retry_at = Some(now + self.backoff());
    }

    fn give_up(&mut self, cause: Cause, now: Time) -> Action {
        self.pending = None;
        let a = Action::Failed(LaunchFailure {
            goal: self.goal,
            commands: self.commands,
            failures: self.failures,
            waited: now.saturating_since(self.started),
            cause,
        });
        self.outcome = Some(a.clone());
        a
    }

    /// The step that gets the vehicle in `obs` closer to the goal, or `None` to wait (it is
    /// seen climbing: never a second take-off).
    fn next_step(&self, obs: &Observed) -> Option<Step> {
        let wrong_mode = |m: Option<Mode>| m.filter(|&m| obs.mode != Some(m));
        match self.goal {
            Goal::Mode(m) => Some(Step::SetMode(m)),
            Goal::Armed { mode } => Some(match wrong_mode(mode) {
                Some(m) => Step::SetMode(m),
                None => Step::Arm,
            }),
            Goal::Airborne { mode } => {
                if obs.climbing() {
                    return None;
                }
                Some(match (wrong_mode(mode), obs.armed) {
                    (Some(m), _) => Step::SetMode(m),
                    (None, false) => Step::Arm,
                    (None, true) => Step::Takeoff,
                })
            }
        }
    }

    /// What to do now, given the vehicle's state as last reported.
    pub fn poll(&mut self, now: Time, obs: &Observed) -> Action {
        if let Some(a) = &self.outcome {
            return a.clone();
        }
        if self.reached(obs) {
            self.pending = None;
            self.outcome = Some(Action::Done);
            return Action::Done;
        }
        // The command out: its effect, its answer, or the end of its window.
        if let Some(p) = self.pending.clone() {
            if Self::took_effect(p.step, obs) {
                self.pending = None;
            } else {
                match p.result {
                    None => {
                        let until = p.sent + RESULT_WAIT;
                        if now < until {
                            return Action::Wait(until.min(now + LOOK_AGAIN));
                        }
                        self.fail(
                            Cause::NoAnswer {
                                step: p.step,
                                error: None,
                            },
                            now,
                        );
                    }
                    Some((Ok(()), at)) => {
                        let w = self.window(p.step);
                        if now < at + w {
                            return Action::Wait((at + w).min(now + LOOK_AGAIN));
                        }
                        self.fail(
                            Cause::NoEffect {
                                step: p.step,
                                waited: w,
                            },
                            now,
                        );
                    }
                    Some((Err(error), at)) => {
                        // Unanswered: the effect may still show (the ACKs were lost, not
                        // the command); refused: an earlier copy may have done it.
                        let (w, cause) = if error.is_transient() {
                            (
                                self.window(p.step),
                                Cause::NoAnswer {
                                    step: p.step,
                                    error: Some(error),
                                },
                            )
                        } else {
                            (
                                REFUSAL_GRACE,
                                Cause::Refused {
                                    step: p.step,
                                    error,
                                },
                            )
                        };
                        if now < at + w {
                            return Action::Wait((at + w).min(now + LOOK_AGAIN));
                        }
                        self.fail(cause, now);
                    }
                }
            }
        }
        if self.failures >= self.cfg.max_failures.max(1)
            && let Some(c) = self.last.clone()
        {
            return self.give_up(c, now);
        }
        if let Some(t) = self.retry_at
            && now < t
        {
            return Action::Wait(t);
        }
        // Not heard: nothing to send to.
        if !obs.heard {
            let since = *self.silent_since.get_or_insert(now);
            let waited = now.saturating_since(since);
            if waited >= self.cfg.silence_wait {
                return self.give_up(Cause::Silent { waited }, now);
            }
            return Action::Wait(now + LOOK_AGAIN);
        }
        self.silent_since = None;
        // Booting, or not ready to arm while it must still be armed.
        let must_arm = !obs.armed && !matches!(self.goal, Goal::Mode(_));
        let mut reasons = Vec::new();
        if obs.booting {
            reasons.push("still booting".to_string());
        } else if must_arm {
            reasons.extend(obs.blockers.iter().cloned());
        }
        if !reasons.is_empty() {
            let since = *self.unready_since.get_or_insert(now);
            if now.saturating_since(since) >= self.cfg.ready_wait {
                return self.give_up(Cause::NotReady { reasons }, now);
            }
            return Action::Wait(now + LOOK_AGAIN);
        }
        self.unready_since = None;
        match self.next_step(obs) {
            None => Action::Wait(now + LOOK_AGAIN),
            Some(step) => {
                self.commands += 1;
                self.retry_at = None;
                self.pending = Some(Pending {
                    step,
                    sent: now,
                    result: None,
                });
                Action::Send(step)
            }
        }
    }
}

#[cfg(test)]
mod tests;
