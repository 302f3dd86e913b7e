//! The position estimate: a GPS error process (shared and per-receiver parts) seen through
//! the estimator's smoothing, and the readiness of the GPS fix and of the estimate.

use super::*;

/// GPS error processes and the estimator's state.
#[derive(Debug)]
pub(super) struct Estimator {
    /// The error of the position estimate (what the autopilot reports and steers by), metres
    /// east and north: the GPS error ([`SimVehicle::gps_raw_err`]) through the estimator's
    /// smoothing, two first-order lags of [`ESTIMATE_LAG_S`].
    pub(super) gps_err: (f64, f64),
    /// The first of those two lags.
    pub(super) gps_lag: (f64, f64),
    /// This vehicle's own random stream (its receiver's error).
    pub(super) rng: ChaCha8Rng,
    /// The shared GPS error process (same seed in every vehicle of a simulation).
    pub(super) gps_rng: ChaCha8Rng,
    /// The common-mode part of `gps_err`, metres east and north.
    pub(super) gps_common: (f64, f64),
    /// This receiver's own part of `gps_err`, metres east and north.
    pub(super) gps_own: (f64, f64),
    /// "EKF3 IMU0 is using GPS" / "Ready for takeoff!" sent since the last boot.
    pub(super) position_ok_announced: bool,
}

impl Estimator {
    /// The processes seeded from `cfg` with their first samples drawn (the estimate's lags
    /// start at zero; [`SimVehicle::new`] sets them to the first raw error).
    pub(super) fn new(cfg: &VehicleConfig) -> Estimator {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        let mut gps_rng = ChaCha8Rng::seed_from_u64(cfg.gps_common_seed);
        let (s, o) = (cfg.gps_error_sigma_m, cfg.gps_own_sigma_m);
        let gps_common = (gauss(&mut gps_rng) * s, gauss(&mut gps_rng) * s);
        let gps_own = (gauss(&mut rng) * o, gauss(&mut rng) * o);
        Estimator {
            gps_err: (0.0, 0.0),
            gps_lag: (0.0, 0.0),
            rng,
            gps_rng,
            gps_common,
            gps_own,
            position_ok_announced: false,
        }
    }
}

impl SimVehicle {
    pub(super) fn position_ok(&self, now: Time) -> bool {
        self.boot_s(now) >= self.cfg.position_ready_after_s
    }

    pub(super) fn gps_fix(&self, now: Time) -> bool {
        self.boot_s(now) >= self.cfg.gps_fix_after_s
    }

    /// The GPS receiver's error now (shared part + own part), metres east and north.
    pub(super) fn gps_raw_err(&self) -> (f64, f64) {
        (
            self.estimator.gps_common.0 + self.estimator.gps_own.0,
            self.estimator.gps_common.1 + self.estimator.gps_own.1,
        )
    }

    pub(super) fn est(&self) -> (f64, f64) {
        (
            self.flight.m.e + self.estimator.gps_err.0,
            self.flight.m.n + self.estimator.gps_err.1,
        )
    }

    pub(super) fn wind_ne(&self) -> (f64, f64) {
        self.cfg.wind.map(|w| w.velocity_ne()).unwrap_or((0.0, 0.0))
    }

    pub(super) fn ground_amsl(&self) -> f64 {
        self.cfg.ground_alt_amsl_m
    }
}
