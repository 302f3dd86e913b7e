//! What a vehicle's link carries: the byte budget the GCS plans its telemetry requests and its
//! own sends against.
//!
//! A field team's vehicles talk to the laptop through telemetry radios. A SiK radio pair at
//! 57,600 baud with error correction on carries about 1–2 kB/s of MAVLink **in all**, both
//! directions together: its air time is shared by the two ends (time-division duplex), and
//! at range it loses frames (PX4-Autopilot issue 1206 and pull request 28714 measured it). A
//! Wi-Fi bridge, a simulator on this machine or a USB cable carry far more than any autopilot
//! sends. The budget is counted in the **vehicles' time** — the clock the autopilots stream
//! by — so a simulator at ×N is given N times the bytes per wall second.
//!
//! A mission file says it with `link = "radio:2000"` (for every vehicle, or per vehicle),
//! the command line with `--link radio:2000`; a GCS that hears RADIO_STATUS from a radio on a
//! vehicle's link without being told assumes [`LinkBudget::radio`].

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The bytes a vehicle's link carries per second, both directions together.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LinkBudget {
    /// A link that carries whatever the vehicle sends (Wi-Fi, a cable, a simulator on this
    /// machine): the GCS asks for its full telemetry.
    #[default]
    Unlimited,
    /// A telemetry radio carrying `bytes_per_s` bytes per second of the vehicles' time, both
    /// directions together.
    Radio {
        /// Bytes per second, both directions together (at least [`LinkBudget::MIN_RADIO`]).
        bytes_per_s: u32,
    },
}

/// Why a link budget could not be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BudgetError {
    /// Not one of the words the budget is written with.
    #[error("`{0}` is not a link: write `unlimited`, `radio` or `radio:BYTES_PER_SECOND`")]
    Unknown(String),
    /// The radio's rate is not a whole number in range.
    #[error(
        "`{0}`: a radio carries a whole number of bytes per second, {min} to {max}",
        min = LinkBudget::MIN_RADIO,
        max = LinkBudget::MAX_RADIO
    )]
    BadRate(String),
}

impl LinkBudget {
    /// What `radio` alone means, bytes per second: a 57,600-baud SiK pair with error
    /// correction, the slow end of the 1–2 kB/s such a pair carries in all.
    pub const RADIO_BYTES_PER_S: u32 = 2000;
    /// The slowest radio the GCS plans for, bytes per second: below it the heartbeats and
    /// the slowest telemetry alone would not fit.
    pub const MIN_RADIO: u32 = 300;
    /// The fastest "radio", bytes per second (a 250,000-baud link); faster is unlimited.
    pub const MAX_RADIO: u32 = 100_000;
    /// The share of a radio's bytes the vehicle's telemetry may take (the rest is for
    /// commands, mission transfers, measurements and the GCS's own sends): 40 %, 800 B/s on
    /// a 2,000 B/s radio.
    pub const TELEMETRY_SHARE: f64 = 0.4;
    /// The share of a radio's bytes the GCS's own paced sends may take (heartbeats and
    /// commands go first and are not held back): 25 %, 500 B/s on a 2,000 B/s radio.
    pub const UPLINK_SHARE: f64 = 0.25;

    /// A radio of [`LinkBudget::RADIO_BYTES_PER_S`].
    pub const fn radio() -> LinkBudget {
        LinkBudget::Radio {
            bytes_per_s: Self::RADIO_BYTES_PER_S,
        }
    }

    /// The radio's bytes per second, `None` when unlimited.
    pub fn bytes_per_s(self) -> Option<u32> {
        match self {
            LinkBudget::Unlimited => None,
            LinkBudget::Radio { bytes_per_s } => Some(bytes_per_s),
        }
    }

    /// Whether the link is a radio with a budget.
    pub fn is_limited(self) -> bool {
        self.bytes_per_s().is_some()
    }

    /// Bytes per second the vehicle's telemetry may take ([`LinkBudget::TELEMETRY_SHARE`]),
    /// `None` when unlimited.
    pub fn telemetry_bytes_per_s(self) -> Option<f64> {
        self.bytes_per_s()
            .map(|b| f64::from(b) * Self::TELEMETRY_SHARE)
    }

    /// Bytes per second the GCS's own paced sends may take ([`LinkBudget::UPLINK_SHARE`]),
    /// `None` when unlimited.
    pub fn uplink_bytes_per_s(self) -> Option<f64> {
        self.bytes_per_s()
            .map(|b| f64::from(b) * Self::UPLINK_SHARE)
    }
}

impl fmt::Display for LinkBudget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkBudget::Unlimited => f.write_str("unlimited"),
            LinkBudget::Radio { bytes_per_s } => write!(f, "radio:{bytes_per_s}"),
        }
    }
}

impl FromStr for LinkBudget {
    type Err = BudgetError;

    /// `unlimited`, `radio` ([`LinkBudget::radio`]) or `radio:BYTES` (bytes per second, both
    /// directions together); case-insensitive, surrounding blanks ignored.
    fn from_str(s: &str) -> Result<LinkBudget, BudgetError> {
        let t = s.trim().to_ascii_lowercase();
        match t.split_once(':') {
            None if t == "unlimited" => Ok(LinkBudget::Unlimited),
            None if t == "radio" => Ok(LinkBudget::radio()),
            Some(("radio", rate)) => match rate.trim().parse::<u32>() {
                Ok(b) if (Self::MIN_RADIO..=Self::MAX_RADIO).contains(&b) => {
                    Ok(LinkBudget::Radio { bytes_per_s: b })
                }
                _ => Err(BudgetError::BadRate(s.trim().to_string())),
            },
            _ => Err(BudgetError::Unknown(s.trim().to_string())),
        }
    }
}

impl Serialize for LinkBudget {
    /// As its text (`"unlimited"`, `"radio:2000"`): run files and JSON stay readable.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for LinkBudget {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<LinkBudget, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_writes_the_words_of_a_budget() {
        assert_eq!("unlimited".parse(), Ok(LinkBudget::Unlimited));
        assert_eq!(" Radio ".parse(), Ok(LinkBudget::radio()));
        assert_eq!(
            "radio:5000".parse(),
            Ok(LinkBudget::Radio { bytes_per_s: 5000 })
        );
        for b in [
            LinkBudget::Unlimited,
            LinkBudget::Radio { bytes_per_s: 1200 },
        ] {
            assert_eq!(b.to_string().parse(), Ok(b));
            let json = serde_json::to_string(&b).unwrap();
            assert_eq!(serde_json::from_str::<LinkBudget>(&json).unwrap(), b);
        }
        assert_eq!(
            "wifi".parse::<LinkBudget>(),
            Err(BudgetError::Unknown("wifi".into()))
        );
        for bad in [
            "radio:",
            "radio:12",
            "radio:-5",
            "radio:1e3",
            "radio:200000",
        ] {
            assert!(
                matches!(bad.parse::<LinkBudget>(), Err(BudgetError::BadRate(_))),
                "{bad}"
            );
        }
    }

    #[test]
    fn shares_of_a_radio() {
        let r = LinkBudget::radio();
        assert_eq!(r.telemetry_bytes_per_s(), Some(800.0));
        assert_eq!(r.uplink_bytes_per_s(), Some(500.0));
        assert!(r.is_limited() && !LinkBudget::Unlimited.is_limited());
        assert_eq!(LinkBudget::Unlimited.telemetry_bytes_per_s(), None);
    }
}
