//! MAVLink transports (UDP, TCP, serial), framing, routing, signing and `.tlog` recording.
//!
//! * [`codec`] — the sans-IO frame codec (MAVLink 1 and 2 in, MAVLink 2 out, CRC, resync,
//!   statistics), used by our links and by the simulator.
//! * [`signing`] — MAVLink 2 message signing (keys, signing, verification).

pub mod codec;
pub mod signing;
