//! Why a fleet operation failed, and which failures are worth trying again.

use fleetmap_core::proto::command::CommandError;
use fleetmap_core::proto::flavour::FlavourError;
use fleetmap_core::proto::mission::MissionError;

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
    /// The fleet task has stopped.
    #[error("the fleet task has stopped")]
    Stopped,
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
    ///   its telemetry in time).
    ///
    /// Every other variant is final: refusals (`ArmRefused`, a `Command` or `Mission`
    /// rejection, a read-back that differs), `Flavour`, `NotReady`, `Booting`, `NoVehicle`
    /// and `Stopped`. This is the rule the bandit runner applies (`app::bandit`, its
    /// `transient` function) when it decides whether to retry an upload.
    pub(crate) fn is_transient(&self) -> bool {
        match self {
            FleetError::Mission { error, .. } => error.is_transient(),
            FleetError::Command { error, .. } => error.is_transient(),
            FleetError::NotConfirmed { .. } => true,
            _ => false,
        }
    }
}
