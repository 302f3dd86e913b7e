//! Typed progress events: what a runner tells the operator (headless stdout, the TUI's log).
//!
//! Each event carries the vehicle it is about and its severity, set where the event is made,
//! so the TUI colours and filters the log without reading the text.

use fleetmap_core::proto::severity::Severity;
use std::fmt;

/// One progress event of a run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Progress {
    /// The vehicle (MAVLink system id) the event is about, if it is about one.
    pub sysid: Option<u8>,
    /// How much the operator should care (MAVLink `MAV_SEVERITY`: the TUI's colours).
    pub severity: Severity,
    /// The line as printed (headless runs print exactly this).
    pub text: String,
}

impl Progress {
    /// An event at `severity`, about no vehicle in particular.
    pub fn new(severity: Severity, text: impl Into<String>) -> Progress {
        Progress {
            sysid: None,
            severity,
            text: text.into(),
        }
    }

    /// Routine progress ([`Severity::Info`]).
    pub fn info(text: impl Into<String>) -> Progress {
        Progress::new(Severity::Info, text)
    }

    /// Something the operator should notice: battery swaps, operator commands
    /// ([`Severity::Notice`]).
    pub(crate) fn notice(text: impl Into<String>) -> Progress {
        Progress::new(Severity::Notice, text)
    }

    /// Something went wrong and is being dealt with: retries, lost pictures
    /// ([`Severity::Warning`]).
    pub fn warning(text: impl Into<String>) -> Progress {
        Progress::new(Severity::Warning, text)
    }

    /// Something the operator has to act on ([`Severity::Error`]).
    pub fn error(text: impl Into<String>) -> Progress {
        Progress::new(Severity::Error, text)
    }

    /// The same event, about vehicle `sysid`.
    pub(crate) fn about(mut self, sysid: u8) -> Progress {
        self.sysid = Some(sysid);
        self
    }
}

impl fmt::Display for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_event_prints_its_text_and_keeps_vehicle_and_severity() {
        let p = Progress::warning("vehicle 3: no answer (retrying)").about(3);
        assert_eq!(p.to_string(), "vehicle 3: no answer (retrying)");
        assert_eq!(p.sysid, Some(3));
        assert_eq!(p.severity, Severity::Warning);
        assert_eq!(Progress::info("epoch 2: goals").sysid, None);
    }
}
