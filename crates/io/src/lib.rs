//! fleetmap's I/O edge: what both the ground station and the simulator need to talk to the
//! outside world, and nothing that decides.
//!
//! | module | responsibility |
//! |---|---|
//! | [`link`] | MAVLink transports (UDP, TCP, serial, in-memory), framing, signing, tlogs, fault injection |
//! | [`clock`] | the only clock reader: the monotonic clock (tokio's, virtual when paused) and the planner's stopwatch |
//! | [`files`] | the only place mission files, world files, image files and `file://` URLs are read; atomic writes |
//! | [`watch`] | tokio's watch channel with receivers woken in a defined order (a run in virtual time is the same every time) |

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod clock;
pub mod files;
pub mod link;
pub mod watch;
