//! MAVLink transports (UDP, TCP, serial), framing, routing, signing and `.tlog` recording.
//!
//! * [`codec`] — the sans-IO frame codec (MAVLink 1 and 2 in, MAVLink 2 out, CRC, resync,
//!   statistics), used by our links and by the simulator.
//! * [`signing`] — MAVLink 2 message signing (keys, signing, verification).
//! * [`addr`] — connection strings as MAVProxy writes them.
//! * [`transport`] — one tokio task per link (UDP in/out, TCP client/server, serial).
//! * [`tlog`] — `.tlog` recording and reading.
//!
//! Routing by (sysid, compid) is done by the fleet (`crate::fleet`), which knows on which
//! link each component was last heard.

pub mod addr;
pub mod codec;
pub mod signing;
pub mod tlog;
pub mod transport;

pub use addr::ConnSpec;
