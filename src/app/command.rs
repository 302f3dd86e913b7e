//! What an operator asks of a run or of a vehicle, and why it was not done: the vocabulary
//! the terminal UI sends and the mission kinds and the session answer
//! ([`crate::app::kind::RunKind::command`]). It lives below the UI so that the run layer
//! answers commands without knowing the UI that sent them.

use std::fmt;

/// Which vehicles a command is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    /// The whole fleet / the mission as a whole.
    All,
    /// One vehicle, by MAVLink system id.
    Vehicle(u8),
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Target::All => f.write_str("all vehicles"),
            Target::Vehicle(id) => write!(f, "vehicle {id}"),
        }
    }
}

/// An operator command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Command {
    /// Start the mission.
    Start,
    /// Hold position (pause).
    Hold,
    /// Resume the paused mission.
    Resume,
    /// Return to launch.
    Rtl,
    /// Land where it is.
    Land,
    /// Arm the motors.
    Arm,
    /// Disarm the motors.
    Disarm,
    /// The battery was swapped; resume this vehicle's part of the mission.
    BatterySwapped,
}

impl Command {
    /// Upper-case verb for logs and dialogs.
    pub fn verb(self) -> &'static str {
        match self {
            Command::Start => "START mission",
            Command::Hold => "HOLD",
            Command::Resume => "RESUME mission",
            Command::Rtl => "RETURN TO LAUNCH",
            Command::Land => "LAND",
            Command::Arm => "ARM",
            Command::Disarm => "DISARM",
            Command::BatterySwapped => "BATTERY SWAPPED, resume",
        }
    }

    /// What it will do, for the confirmation dialog.
    pub(crate) fn consequence(self) -> &'static str {
        match self {
            Command::Start => "Uploads the missions and the vehicles take off.",
            Command::Hold => "The vehicles stop and hold position.",
            Command::Resume => "The vehicles continue the mission from where they stopped.",
            Command::Rtl => "Flies back to the launch point and lands.",
            Command::Land => "Descends and lands at its current position.",
            Command::Arm => "Motors start spinning.",
            Command::Disarm => "Motors STOP. In the air the vehicle falls.",
            Command::BatterySwapped => "Takes off again and continues from its last vertex.",
        }
    }
}

/// Why a command the operator asked for was not carried out.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    /// START without a run.
    #[error("no mission is loaded (start fleetmap with --mission or --resume)")]
    NoMission,
    /// START again.
    #[error("the mission is already running")]
    AlreadyRunning,
    /// A mission-level command before START.
    #[error("no mission is running (START it first)")]
    NotStarted,
    /// A mission-level command without a running run.
    #[error("no mission is running")]
    NotRunning,
    /// The command has no meaning for this kind of mission (why).
    #[error("{0}")]
    NotForThisMission(&'static str),
    /// One or more vehicles refused or did not answer (each one's reason).
    #[error("{}", .0.join("; "))]
    Vehicles(Vec<String>),
    /// The command never left the UI (why, saying so: a replay, the sample, a full queue…).
    #[error("{0}")]
    NotSent(&'static str),
    /// START refused: the fleet check found a blocker (its summary; the findings are in
    /// the log).
    #[error("not started: {0} (fix what the log says, or restart with --ignore-check)")]
    CheckFailed(String),
}
