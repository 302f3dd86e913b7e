//! The field kit's end-to-end tests.
//!
//! * `fleet_check`: `fleetmap check --connect` and the check at a run's start, against
//!   `fleetmap sim` with one mistake per vehicle (docs/fleet-check.md).
//! * `terrain`: QGroundControl plans whose altitudes need terrain fleetmap cannot compute,
//!   refused before anything is sent; terrain served from SRTM tiles to the embedded
//!   simulator (`fleetmap sim` + `fleetmap mission fly --terrain`), and a missing tile named
//!   before take-off.

mod fleet_check;
mod terrain;
