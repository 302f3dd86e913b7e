//! When the runner counts a drone's battery as fresh (after a swap, or after the autopilot
//! rebooted), from the mission's `[battery]` keys.

use serde::{Deserialize, Serialize};

/// How the runner judges a drone's charge (the `[battery]` keys of the same names; see
/// [`crate::mission::definition::BatteryDef`] for where each default comes from).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BatteryRules {
    /// Descent rate assumed on the way home, m/s.
    pub descent_rate_m_s: f64,
    /// Seconds added for the approach, the landing and wind.
    pub landing_margin_s: f64,
    /// Charge at which a swapped drone counts as fresh, percent.
    pub fresh_pct: f64,
    /// The same after the autopilot rebooted since it landed, percent.
    pub fresh_after_reboot_pct: f64,
}

impl From<&crate::mission::definition::BatteryDef> for BatteryRules {
    fn from(b: &crate::mission::definition::BatteryDef) -> BatteryRules {
        BatteryRules {
            descent_rate_m_s: b.descent_rate_m_s,
            landing_margin_s: b.landing_margin_s,
            fresh_pct: b.fresh_pct,
            fresh_after_reboot_pct: b.fresh_after_reboot_pct,
        }
    }
}

impl Default for BatteryRules {
    fn default() -> Self {
        BatteryRules::from(&crate::mission::definition::BatteryDef::default())
    }
}

impl BatteryRules {
    /// Whether a drone reporting `pct` percent has a fresh battery (`rebooted`: its
    /// autopilot restarted since it landed, so the pack was unplugged).
    pub fn is_fresh(&self, pct: f64, rebooted: bool) -> bool {
        pct >= self.fresh_pct || (rebooted && pct >= self.fresh_after_reboot_pct)
    }
}
