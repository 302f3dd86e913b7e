//! The embedded simulated autopilot: ArduPilot and PX4 copters and rovers stepped by virtual
//! time, their camera, the ground-truth worlds they fly over and the faults of their links.
//!
//! Everything here except [`server`] is pure: no sockets, no files, no clock reads. Time is
//! a [`crate::time::Time`] parameter.

pub mod flavour;
pub mod mission_server;

pub use flavour::{Flavour, Mode, SimAutopilot, VehicleKind};
pub use mission_server::{MissionEvent, MissionServer};
pub mod battery;
pub mod camera;
/// Link faults moved to [`crate::link::faults`] (the relay uses them too); the old path stays.
pub use crate::link::faults;
pub mod fence;
pub mod harness;
pub mod motion;
pub mod pace;
pub mod paired;
pub mod render;
pub mod server;
pub mod transfer_bench;
pub mod tx_queue;
pub mod vehicle;
/// The ground truth the simulator renders lives in the core ([`crate::world`]); the old path
/// still names it.
pub use crate::world;
