//! fleetmap's MAVLink camera, for a drone's companion computer and for the simulator.
//!
//! [`camera`] is one vehicle's camera component (id 100): the MAVLink camera protocol, its
//! triggers, image transmission and the on-board measurement. [`paired`] runs one for every
//! autopilot heard on a link, stamping pictures with the pose the autopilot reports. The
//! program `fleetmap-camera` ([`cli`]) serves them over a serial port, UDP or TCP
//! ([`serve`], on [`fleetmap_io::link`]) with pictures from a folder, a command run per shot
//! or a V4L2 device ([`source`]); with the `render` feature, drawn from a world file
//! ([`render`], what the embedded simulator's vehicles and a camera for SITL use).
//!
//! It builds without the planner's HiGHS solver (`fleetmap-core` without `highs`), without
//! the simulator and without the terminal UI: a small program for a Raspberry Pi.

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod camera;
pub mod cli;
pub mod mission;
pub mod paired;
pub mod pose;
#[cfg(feature = "render")]
pub mod render;
pub mod serve;
pub mod source;
