//! The log pane's data: STATUSTEXT messages and GCS messages with their severity.

use fleetmap_core::time::Time;
use serde::{Deserialize, Serialize};

use fleetmap_core::proto::severity::Severity;

/// One log line: a STATUSTEXT from a vehicle, or a message from the GCS itself.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct LogEntry {
    /// When it was received.
    pub time: Time,
    /// Severity.
    pub severity: Severity,
    /// The vehicle that sent it; `None` for the GCS.
    pub sysid: Option<u8>,
    /// The text.
    pub text: String,
}
