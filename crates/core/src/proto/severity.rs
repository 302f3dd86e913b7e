//! Message severity, the MAVLink vocabulary shared by STATUSTEXT, the fleet's snapshots, the
//! runners' progress and the TUI's log.

use serde::{Deserialize, Serialize};

/// Message severity, as MAV_SEVERITY (0 = emergency … 7 = debug).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// MAV_SEVERITY_EMERGENCY.
    Emergency,
    /// MAV_SEVERITY_ALERT.
    Alert,
    /// MAV_SEVERITY_CRITICAL.
    Critical,
    /// MAV_SEVERITY_ERROR.
    Error,
    /// MAV_SEVERITY_WARNING.
    Warning,
    /// MAV_SEVERITY_NOTICE.
    Notice,
    /// MAV_SEVERITY_INFO.
    #[default]
    Info,
    /// MAV_SEVERITY_DEBUG.
    Debug,
}

impl Severity {
    /// From the MAVLink wire value (values above 7 count as debug).
    pub fn from_mav(v: u8) -> Severity {
        match v {
            0 => Severity::Emergency,
            1 => Severity::Alert,
            2 => Severity::Critical,
            3 => Severity::Error,
            4 => Severity::Warning,
            5 => Severity::Notice,
            6 => Severity::Info,
            _ => Severity::Debug,
        }
    }

    /// The MAVLink wire value (MAV_SEVERITY, 0–7).
    pub fn to_mav(self) -> u8 {
        self as u8
    }

    /// Four-letter tag shown in the log.
    pub fn tag(self) -> &'static str {
        match self {
            Severity::Emergency => "EMRG",
            Severity::Alert => "ALRT",
            Severity::Critical => "CRIT",
            Severity::Error => "ERR ",
            Severity::Warning => "WARN",
            Severity::Notice => "NOTE",
            Severity::Info => "INFO",
            Severity::Debug => "DBG ",
        }
    }
}
