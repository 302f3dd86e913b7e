//! The embedded simulated autopilot: ArduPilot and PX4 copters and rovers stepped by virtual
//! time, the ground-truth worlds they fly over and the faults of their links. Their camera
//! (the MAVLink camera component and the renderer that draws its pictures) is the camera
//! crate's ([`fleetmap_camera::camera`], [`fleetmap_camera::render`]), which the companion
//! computer's `fleetmap-camera` program runs too.
//!
//! Everything here except [`server`] is pure: no sockets, no files, no clock reads. Time is
//! a [`fleetmap_core::time::Time`] parameter. The worlds it renders are the core's
//! ([`fleetmap_core::world`]), the faults its links inject the I/O edge's
//! ([`fleetmap_io::link::faults`]).

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod flavour;
pub mod mission_server;

pub mod battery;
pub mod fault;
pub mod fence;
pub mod harness;
pub mod motion;
pub mod pace;
pub mod server;
pub mod transfer_bench;
pub mod tx_queue;
pub mod vehicle;
