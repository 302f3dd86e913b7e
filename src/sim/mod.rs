//! The embedded simulated autopilot: ArduPilot and PX4 copters and rovers stepped by virtual
//! time, their camera, the ground-truth worlds they fly over and the faults of their links.
//!
//! Everything here except [`server`] is pure: no sockets, no files, no clock reads. Time is
//! a [`crate::time::Time`] parameter.

pub mod flavour;
pub mod mission_server;

pub use flavour::{Autopilot, Flavour, Mode, VehicleKind};
pub use mission_server::{MissionEvent, MissionServer};
