//! The end-to-end tests of a field day's faults, in one test binary: every test
//! binary is one more link of the whole crate on CI's two cores (about 40 s each), so the
//! five files share one.
//!
//! * `faults_bandit`, `faults_runway`: the fault matrix on the embedded simulator, both
//!   missions (docs/results/faults.md);
//! * `sysid_conflict`: two autopilots on one system id, refused before anything is sent;
//! * `virtual_repro`: same seed, same run in virtual time;
//! * `sim_fault_cli`: `fleetmap sim|demo --fault` on the command line.

mod faults_bandit;
mod faults_runway;
mod sim_fault_cli;
mod sysid_conflict;
mod virtual_repro;
