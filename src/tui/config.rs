//! The UI configuration file (TOML): the key map and the warning thresholds.
//!
//! ```toml
//! [keys]                    # any action, one key or a list; omitted actions keep their defaults
//! rtl_all = ["T", "ctrl-r"]
//! land = "L"
//!
//! [thresholds]              # omitted values keep their defaults
//! battery_warn_pct = 35
//! ```
//!
//! `fleetmap tui --print-config` prints every action with its default keys and every
//! threshold, ready to edit.

use super::keymap::{KeyMap, KeyMapError, KeysValue};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

/// When values turn yellow (warning) or red (critical).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Thresholds {
    /// Battery remaining at or below this is a warning, percent.
    pub(crate) battery_warn_pct: u8,
    /// Battery remaining at or below this is critical, percent.
    pub(crate) battery_crit_pct: u8,
    /// Per-cell voltage at or below this is a warning, volts (LiPo: 3.6).
    pub(crate) cell_warn_v: f32,
    /// Per-cell voltage at or below this is critical, volts (LiPo: 3.5).
    pub(crate) cell_crit_v: f32,
    /// Link quality at or below this is a warning, percent.
    pub(crate) link_warn_pct: u8,
    /// Fewer satellites than this is a warning.
    pub(crate) min_satellites: u8,
    /// No snapshot for this long marks the data as stale, seconds (0 = never).
    pub(crate) stale_after_s: f64,
    /// An unanswered confirmation dialog closes itself after this long, seconds.
    pub(crate) confirm_timeout_s: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            battery_warn_pct: 30,
            battery_crit_pct: 20,
            cell_warn_v: 3.6,
            cell_crit_v: 3.5,
            link_warn_pct: 70,
            min_satellites: 6,
            stale_after_s: 3.0,
            confirm_timeout_s: 15.0,
        }
    }
}

impl Thresholds {
    /// [`Thresholds::stale_after_s`] as a duration, `None` when disabled.
    pub(crate) fn stale_after(&self) -> Option<Duration> {
        (self.stale_after_s > 0.0 && self.stale_after_s.is_finite())
            .then(|| Duration::from_secs_f64(self.stale_after_s))
    }

    /// [`Thresholds::confirm_timeout_s`] as a duration (at least one second).
    pub(crate) fn confirm_timeout(&self) -> Duration {
        if self.confirm_timeout_s.is_finite() && self.confirm_timeout_s >= 1.0 {
            Duration::from_secs_f64(self.confirm_timeout_s)
        } else {
            Duration::from_secs(1)
        }
    }
}

/// Key map + thresholds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UiConfig {
    /// Key bindings.
    pub keys: KeyMap,
    /// Warning thresholds.
    pub thresholds: Thresholds,
}

/// A problem with the UI config file.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not valid TOML, or an unknown section/field.
    #[error("{0}")]
    Toml(String),
    /// A bad key binding.
    #[error("[keys]: {0}")]
    Keys(#[from] KeyMapError),
    /// Thresholds that contradict each other.
    #[error("[thresholds]: {0}")]
    Thresholds(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    #[serde(default)]
    keys: BTreeMap<String, KeysValue>,
    #[serde(default)]
    thresholds: Thresholds,
}

impl UiConfig {
    /// Parse a config file's text.
    pub fn from_toml_str(text: &str) -> Result<UiConfig, ConfigError> {
        let raw: RawConfig = toml::from_str(text).map_err(|e| ConfigError::Toml(e.to_string()))?;
        let keys = KeyMap::with_overrides(&raw.keys)?;
        let t = &raw.thresholds;
        if t.battery_crit_pct > t.battery_warn_pct {
            return Err(ConfigError::Thresholds(format!(
                "battery_crit_pct ({}) is above battery_warn_pct ({})",
                t.battery_crit_pct, t.battery_warn_pct
            )));
        }
        if t.cell_crit_v > t.cell_warn_v {
            return Err(ConfigError::Thresholds(format!(
                "cell_crit_v ({}) is above cell_warn_v ({})",
                t.cell_crit_v, t.cell_warn_v
            )));
        }
        Ok(UiConfig {
            keys,
            thresholds: raw.thresholds,
        })
    }

    /// Read and parse a config file.
    pub fn load(path: &Path) -> Result<UiConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.display().to_string(),
            source,
        })?;
        UiConfig::from_toml_str(&text)
    }

    /// The whole file with every value spelled out (defaults, or this config's values).
    pub(crate) fn to_toml(&self) -> String {
        let mut out = String::from(
            "# fleetmap terminal UI configuration (fleetmap tui --config FILE).\n\
             # Keys: one key or a list; a character (\"q\", \"T\", \"?\") or a name (space tab backtab\n\
             # enter esc backspace up down left right home end pageup pagedown f1..f12) with optional\n\
             # ctrl-/alt-/shift- prefixes. Omitted actions keep their defaults.\n",
        );
        out.push_str(&self.keys.to_toml());
        out.push_str("\n[thresholds]\n");
        let t = toml::to_string(&self.thresholds).unwrap_or_default();
        out.push_str(&t);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::keymap::{Action, Key};

    #[test]
    fn printed_defaults_parse_back_to_the_defaults() {
        let text = UiConfig::default().to_toml();
        let parsed = UiConfig::from_toml_str(&text).expect("printed config parses");
        assert_eq!(parsed, UiConfig::default());
    }

    #[test]
    fn overrides_replace_only_what_they_name() {
        let c = UiConfig::from_toml_str(
            "[keys]\nland = \"L\"\nrtl_all = [\"T\", \"ctrl-r\"]\n[thresholds]\nbattery_warn_pct = 40\n",
        )
        .expect("valid");
        assert_eq!(c.keys.keys(Action::Land), &[Key::char('L')]);
        assert_eq!(
            c.keys.keys(Action::RtlAll),
            &[Key::char('T'), Key::ctrl('r')]
        );
        assert_eq!(c.keys.keys(Action::Start), &[Key::char('s')]);
        assert_eq!(c.thresholds.battery_warn_pct, 40);
        assert_eq!(c.thresholds.battery_crit_pct, 20);
    }

    #[test]
    fn errors_name_the_problem() {
        let e = UiConfig::from_toml_str("[keys]\nfly_away = \"x\"\n").unwrap_err();
        assert!(
            e.to_string().contains("\"fly_away\" is not an action"),
            "{e}"
        );
        let e = UiConfig::from_toml_str("[keys]\nland = \"lll\"\n").unwrap_err();
        assert!(e.to_string().contains("\"lll\" is not a key"), "{e}");
        let e = UiConfig::from_toml_str("[keys]\nland = \"s\"\n").unwrap_err();
        assert!(e.to_string().contains("bound to both"), "{e}");
        let e = UiConfig::from_toml_str("[colours]\nx = 1\n").unwrap_err();
        assert!(e.to_string().contains("colours"), "{e}");
        let e = UiConfig::from_toml_str("[thresholds]\nbattery_crit_pct = 50\n").unwrap_err();
        assert!(e.to_string().contains("battery_crit_pct (50)"), "{e}");
        let e = UiConfig::from_toml_str("[thresholds]\nbogus = 1\n").unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
    }
}
