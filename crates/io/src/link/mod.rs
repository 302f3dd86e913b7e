//! MAVLink transports (UDP, TCP, serial), framing, routing, signing and `.tlog` recording.
//!
//! * [`codec`] — the sans-IO frame codec (MAVLink 1 and 2 in, MAVLink 2 out, CRC, resync,
//!   statistics), used by our links and by the simulator.
//! * [`signing`] — MAVLink 2 message signing (keys, signing, verification).
//! * `addr` — connection strings as MAVProxy writes them.
//! * [`peers`] — the peers of a link that serves several (`udpin`, `tcpin`) and the route
//!   of each system id among them.
//! * [`transport`] — one tokio task per link (UDP in/out, TCP client/server, serial).
//! * [`faults`] — seeded loss, duplication, reordering, latency, corruption and blackouts
//!   of whole frames (pure), used by the simulator's links and by [`relay`].
//! * [`radio`] — a SiK telemetry radio pair (pure): a byte budget on the air shared by both
//!   directions or one each way, a buffer in each radio, loss on the air, RADIO_STATUS.
//! * [`relay`] — a frame relay between two links through a radio pair and those faults
//!   (`fleetmap relay`), on the wall clock, a simulator's or the vehicles' own time.
//! * [`tlog`] — `.tlog` recording and reading.
//!
//! Routing by (sysid, compid) is done in two steps: the fleet (`crate::fleet`) picks the
//! link each component was last heard on, and a link that serves several peers picks the
//! peer that system speaks from.

mod addr;
pub mod codec;
pub mod faults;
pub mod peers;
pub mod radio;
pub mod relay;
pub mod signing;
pub mod tlog;
pub mod transport;

pub use addr::{ConnSpec, ConnSpecError};
