//! The flight battery: capacity expressed as minutes of hover, voltage under load and charge
//! remaining, as a 4-cell LiPo reports them.
//!
//! Discharge: the current is the hover current (capacity / hover time) times a load factor
//! (forward flight costs more with air speed, climbing more, idling on the ground little,
//! disarmed avionics almost nothing). Voltage: the open-circuit voltage of the charge left
//! (4.2 V/cell full, 3.7 V/cell at 20 %, 3.3 V/cell empty) minus the internal-resistance sag.

use serde::{Deserialize, Serialize};

/// Battery parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BatteryConfig {
    /// Minutes of hover (copter) or driving (rover) on a full battery.
    pub minutes: f64,
    /// Capacity, mAh (BATT_CAPACITY).
    pub(crate) capacity_mah: f64,
    /// Cells in series.
    pub cells: u32,
    /// Internal resistance of the pack, ohms.
    pub(crate) resistance_ohm: f64,
    /// Minutes to recharge from empty on a charging station.
    pub charge_minutes: f64,
}

impl BatteryConfig {
    /// A copter pack lasting `minutes` of hover (the runway paper: 12 minutes).
    pub fn copter(minutes: f64) -> BatteryConfig {
        BatteryConfig {
            minutes,
            capacity_mah: 5000.0,
            cells: 4,
            resistance_ohm: 0.03,
            charge_minutes: 30.0,
        }
    }

    /// A rover pack (rovers serve as charging stations and drive for hours).
    pub fn rover() -> BatteryConfig {
        BatteryConfig {
            minutes: 240.0,
            capacity_mah: 20000.0,
            cells: 4,
            resistance_ohm: 0.01,
            charge_minutes: 120.0,
        }
    }
}

/// Battery state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Battery {
    /// Parameters.
    pub config: BatteryConfig,
    /// Charge consumed since the last full charge, mAh.
    pub(crate) consumed_mah: f64,
    /// Current drawn now, A.
    pub(crate) current_a: f64,
}

impl Battery {
    /// A full battery.
    pub fn full(config: BatteryConfig) -> Battery {
        Battery {
            config,
            consumed_mah: 0.0,
            current_a: 0.0,
        }
    }

    /// Hover current, A.
    pub(crate) fn hover_current(&self) -> f64 {
        self.config.capacity_mah / 1000.0 / (self.config.minutes.max(0.1) / 60.0)
    }

    /// Draw `load` × the hover current for `dt` seconds.
    pub fn drain(&mut self, load: f64, dt: f64) {
        self.current_a = self.hover_current() * load.max(0.0);
        self.consumed_mah =
            (self.consumed_mah + self.current_a * dt / 3.6).min(self.config.capacity_mah);
    }

    /// Charge for `dt` seconds at the station's rate.
    pub fn charge(&mut self, dt: f64) {
        let rate = self.config.capacity_mah / (self.config.charge_minutes.max(0.1) * 60.0);
        self.consumed_mah = (self.consumed_mah - rate * dt).max(0.0);
        self.current_a = -rate * 3.6;
    }

    /// The charge left drops to `fraction` (0–1) of the capacity at once; a battery with
    /// less left keeps what it has.
    pub(crate) fn drop_to(&mut self, fraction: f64) {
        let consumed = (1.0 - fraction.clamp(0.0, 1.0)) * self.config.capacity_mah;
        self.consumed_mah = self.consumed_mah.max(consumed);
    }

    /// Fraction of charge left, 0–1.
    pub fn fraction(&self) -> f64 {
        (1.0 - self.consumed_mah / self.config.capacity_mah).clamp(0.0, 1.0)
    }

    /// Charge left, percent (0–100), as BATTERY_STATUS.battery_remaining.
    pub fn percent(&self) -> i8 {
        (self.fraction() * 100.0).round() as i8
    }

    /// Open-circuit voltage of one cell at the charge left.
    fn cell_ocv(&self) -> f64 {
        let f = self.fraction();
        // piecewise-linear LiPo curve
        const PTS: [(f64, f64); 6] = [
            (0.0, 3.30),
            (0.05, 3.55),
            (0.2, 3.70),
            (0.5, 3.82),
            (0.9, 4.08),
            (1.0, 4.20),
        ];
        for w in PTS.windows(2) {
            let ((f0, v0), (f1, v1)) = (w[0], w[1]);
            if f <= f1 {
                return v0 + (v1 - v0) * (f - f0) / (f1 - f0);
            }
        }
        4.20
    }

    /// Terminal voltage under the present load, volts.
    pub(crate) fn voltage(&self) -> f64 {
        f64::from(self.config.cells) * self.cell_ocv() - self.current_a * self.config.resistance_ohm
    }

    /// Whether the battery is empty.
    pub fn empty(&self) -> bool {
        self.fraction() <= 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twelve_minutes_of_hover() {
        let mut b = Battery::full(BatteryConfig::copter(12.0));
        assert_eq!(b.percent(), 100);
        assert!((b.voltage() - 16.8).abs() < 1e-9);
        for _ in 0..(6 * 60 * 20) {
            b.drain(1.0, 0.05);
        }
        assert!((b.fraction() - 0.5).abs() < 1e-6, "{}", b.fraction());
        assert!(b.voltage() < 15.3 && b.voltage() > 14.5, "{}", b.voltage());
        b.charge(15.0 * 60.0);
        assert_eq!(b.percent(), 100);
    }
}
