//! Why a fleet operation failed, and which failures are worth trying again.

use fleetmap_core::proto::command::CommandError;
use fleetmap_core::proto::flavour::FlavourError;
use fleetmap_core::proto::launch::{Cause, Landed, LaunchFailure, Step};
use fleetmap_core::proto::mission::MissionError;
use std::fmt;

/// Why a fleet operation failed.
///
/// Each message is whole: the protocol error a variant wraps is part of it and is not also
/// returned by `Error::source`, so that printing the chain of causes (`{:#}`, or the
/// binary's one-line report) does not repeat it ("vehicle 1: X: X").
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// No heartbeat from that system (yet).
    #[error("vehicle {sysid}: no heartbeat received from system {sysid}")]
    NoVehicle {
        /// System id.
        sysid: u8,
    },
    /// A command was refused or not acknowledged.
    #[error("vehicle {sysid}: {error}")]
    Command {
        /// System id.
        sysid: u8,
        /// The command error.
        error: CommandError,
    },
    /// A mission operation failed.
    #[error("vehicle {sysid}: {error}")]
    Mission {
        /// System id.
        sysid: u8,
        /// The mission error.
        error: MissionError,
    },
    /// The action does not apply to this vehicle, or a mode name is unknown.
    #[error("vehicle {sysid}: {error}")]
    Flavour {
        /// System id.
        sysid: u8,
        /// The flavour error.
        error: FlavourError,
    },
    /// The vehicle did not become ready to arm in time.
    #[error("vehicle {sysid}: not ready to arm after {waited_s:.0} s: {}", reasons.join("; "))]
    NotReady {
        /// System id.
        sysid: u8,
        /// Seconds waited.
        waited_s: f64,
        /// Why.
        reasons: Vec<String>,
    },
    /// The arm command was refused.
    #[error("vehicle {sysid}: arming refused: {error}{}", prearm.as_ref().map(|t| format!(" (autopilot says: {t})")).unwrap_or_default())]
    ArmRefused {
        /// System id.
        sysid: u8,
        /// The command error.
        error: CommandError,
        /// The last pre-arm failure text, if any.
        prearm: Option<String>,
    },
    /// A state the vehicle should reach did not show up in its telemetry in time.
    #[error("vehicle {sysid}: {what} not seen within {waited_s:.1} s (now: {now})")]
    NotConfirmed {
        /// System id.
        sysid: u8,
        /// What was awaited.
        what: String,
        /// Seconds waited.
        waited_s: f64,
        /// The current state, for the message.
        now: String,
    },
    /// A mode change, an arming or a take-off did not get there, retried from the vehicle's
    /// state as far as [`fleetmap_core::proto::launch`] allows: what it was for and what
    /// ended it ([`LaunchFailure`]), and what the vehicle's telemetry said then.
    #[error("vehicle {sysid}: {failure}; the vehicle is {state}")]
    NotStarted {
        /// System id.
        sysid: u8,
        /// The launch that gave up.
        failure: Box<LaunchFailure>,
        /// The vehicle's state when it gave up.
        state: Box<StateSeen>,
    },
    /// The vehicle did not finish booting in time.
    #[error("vehicle {sysid}: still booting after {waited_s:.0} s ({why})")]
    Booting {
        /// System id.
        sysid: u8,
        /// Seconds waited.
        waited_s: f64,
        /// What showed it booting.
        why: String,
    },
    /// Two or more autopilots answer as this system id: whatever is sent to it reaches one
    /// of them, so nothing is ([`crate::fleet::SysidConflict`]).
    #[error(
        "vehicle {sysid}: two or more autopilots answer as system id {sysid} ({evidence}); \
         fleetmap sends nothing to it: {}",
        crate::fleet::SysidConflict::FIX
    )]
    SysidConflict {
        /// System id.
        sysid: u8,
        /// What showed it.
        evidence: String,
    },
    /// The fleet task has stopped.
    #[error("the fleet task has stopped")]
    Stopped,
}

/// What to fix on a vehicle that never became ready to arm, from what blocked it.
fn not_ready_fix(reasons: &[String]) -> String {
    match reasons.iter().find(|r| r.contains("pre-arm")) {
        Some(r) => format!("clear its {r}"),
        None => format!("make it ready to arm ({})", reasons.join("; ")),
    }
}

/// A vehicle's state as its telemetry last said, for an error message.
#[derive(Clone, Debug, PartialEq)]
pub struct StateSeen {
    /// Heard within the liveness window.
    pub heard: bool,
    /// Armed.
    pub armed: bool,
    /// Its mode's name.
    pub mode: String,
    /// Its landed state.
    pub landed: Landed,
    /// Altitude above home, metres.
    pub alt_rel_m: Option<f32>,
    /// The last pre-arm failure it reported, if recent.
    pub prearm: Option<String>,
}

impl fmt::Display for StateSeen {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.heard {
            f.write_str("not heard, last seen ")?;
        }
        f.write_str(if self.armed { "armed" } else { "disarmed" })?;
        match self.landed {
            Landed::OnGround => f.write_str(", on the ground")?,
            Landed::TakingOff => f.write_str(", taking off")?,
            Landed::InAir => f.write_str(", in the air")?,
            Landed::Landing => f.write_str(", landing")?,
            Landed::Unknown => {}
        }
        write!(f, ", mode {}", self.mode)?;
        if let Some(a) = self.alt_rel_m {
            write!(f, ", {a:.1} m above home")?;
        }
        if let Some(t) = &self.prearm {
            write!(f, ", autopilot says: {t}")?;
        }
        Ok(())
    }
}

impl FleetError {
    /// Whether the operation may succeed when tried again: the vehicle did not answer (a
    /// lost frame, a busy or lossy link), as opposed to the vehicle saying no.
    ///
    /// Exactly these are transient:
    /// * [`FleetError::Mission`] wrapping a transient [`MissionError`] (see
    ///   [`MissionError::is_transient`]: `Timeout` or `OverBudget`);
    /// * [`FleetError::Command`] wrapping a transient [`CommandError`] (see
    ///   [`CommandError::is_transient`]: `Timeout`);
    /// * [`FleetError::NotConfirmed`] (a state the vehicle should reach did not show up in
    ///   its telemetry in time);
    /// * [`FleetError::NotStarted`] whose last attempt went unanswered, or was accepted
    ///   without its effect showing ([`Cause::is_link`], [`Cause::NoEffect`]).
    ///
    /// Every other variant is final: refusals (`ArmRefused`, a `Command` or `Mission`
    /// rejection, a read-back that differs), `Flavour`, `NotReady`, `Booting`, `NoVehicle`
    /// `SysidConflict` and `Stopped`. This is the rule the bandit runner applies (`kinds::bandit`, its
    /// `transient` function) when it decides whether to retry an upload.
    pub(crate) fn is_transient(&self) -> bool {
        match self {
            FleetError::Mission { error, .. } => error.is_transient(),
            FleetError::Command { error, .. } => error.is_transient(),
            FleetError::NotConfirmed { .. } => true,
            FleetError::NotStarted { failure, .. } => {
                failure.cause.is_link() || matches!(failure.cause, Cause::NoEffect { .. })
            }
            _ => false,
        }
    }

    /// What a person must fix before trying again can succeed, said for the operator
    /// (`None`: trying again later may work by itself). `fleetmap run --auto-resume` carries
    /// on through the other failures (a lost ACK, a link outage, a vehicle still booting, a
    /// take-off refused because the copter had disarmed meanwhile) and stops for these:
    ///
    /// * a vehicle that never became ready to arm ([`FleetError::NotReady`]: its GPS, its
    ///   position estimate, a pre-arm check that keeps failing), or that never finished
    ///   booting ([`FleetError::Booting`]);
    /// * an arming refused with a pre-arm failure the autopilot reports
    ///   ([`FleetError::ArmRefused`], or a [`FleetError::NotStarted`] whose last refusal came
    ///   with one);
    /// * a list the autopilot refuses as invalid ([`FleetError::Mission`] with
    ///   [`MissionError::Rejected`] outside a boot), a mode or action this autopilot does not
    ///   have ([`FleetError::Flavour`]), a command it does not support.
    pub(crate) fn needs_person(&self) -> Option<String> {
        match self {
            FleetError::NotReady { reasons, .. } => Some(not_ready_fix(reasons)),
            FleetError::Booting { waited_s, .. } => Some(format!(
                "it did not finish booting in {waited_s:.0} s: check it, power-cycle it"
            )),
            FleetError::ArmRefused {
                prearm: Some(t), ..
            } => Some(format!("clear the pre-arm failure it reports: {t}")),
            FleetError::NotStarted { failure, state, .. } => {
                match (&failure.cause, &state.prearm) {
                    (Cause::NotReady { reasons }, _) => Some(not_ready_fix(reasons)),
                    (
                        Cause::Refused {
                            step: Step::Arm, ..
                        },
                        Some(t),
                    ) => Some(format!("clear the pre-arm failure it reports: {t}")),
                    (
                        Cause::Refused {
                            error:
                                CommandError::Unsupported { .. }
                                | CommandError::Denied { .. }
                                | CommandError::UnsupportedFrame { .. },
                            ..
                        },
                        _,
                    ) => Some(format!(
                        "{}: check the vehicle's setup (firmware, parameters)",
                        failure.cause
                    )),
                    _ => None,
                }
            }
            FleetError::Mission {
                error: error @ MissionError::Rejected { .. },
                ..
            } => Some(format!(
                "the autopilot refuses the list ({error}): check the mission against the vehicle"
            )),
            FleetError::Flavour { error, .. } => Some(format!("{error}")),
            FleetError::SysidConflict { .. } => Some(crate::fleet::SysidConflict::FIX.to_string()),
            FleetError::Command {
                error:
                    error @ (CommandError::Unsupported { .. } | CommandError::UnsupportedFrame { .. }),
                ..
            } => Some(format!("{error}: check the vehicle's firmware")),
            _ => None,
        }
    }
}
