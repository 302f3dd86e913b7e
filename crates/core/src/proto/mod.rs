//! Sans-IO MAVLink micro-services (heartbeat, command, mission transfer) and autopilot flavours.
//!
//! Every machine here is pure: no sockets, no clock reads. They follow the quinn-proto shape
//! (docs/architecture.md, "Layers"): feed received messages with `handle_message(header, msg, now)`, call
//! `handle_timeout(now)` when `poll_timeout()` says so, send whatever `poll_transmit()`
//! yields (messages carry their own target ids), and read results with `poll_event()`.
//! The GCS's fleet actor runs one set of machines per vehicle.
//!
//! * [`heartbeat`] — the GCS heartbeat (1 Hz) and vehicle liveness (lost after 3 s of
//!   silence, back on the next heartbeat, reboots detected).
//! * [`command`] — COMMAND_LONG / COMMAND_INT with COMMAND_ACK, retries, IN_PROGRESS.
//! * [`arming`] — when a vehicle may be armed (more than the autopilot's flag).
//! * [`launch`] — getting a vehicle into a mode, armed or off the ground, confirmed from its
//!   own state and retried from it with a bounded back-off.
//! * [`mission`] — mission, fence and rally upload / download / clear / set current.
//! * [`flavour`] — everything that differs between ArduPilot Copter, ArduPilot Rover and
//!   PX4: which mode table, how to arm, take off, start a mission, go to a point, return, land.
//! * [`mode`] — the one table of flight modes per autopilot (names and `custom_mode`
//!   numbers), shared by the GCS and the simulator.
//! * [`telemetry`] — which telemetry to ask a vehicle for so that it fits its link, and the
//!   streams to stop on a radio.
//! * [`uplink`] — what the GCS sends a vehicle over a radio, most urgent first and paced.
//! * [`sysid_conflict`] — two autopilots answering as one system id on one link, told from
//!   their sequence counters and heartbeats.
//! * [`params`] — reading a few parameters by name (PARAM_REQUEST_READ), retried with
//!   back-off over a lossy link.
//! * [`camera_tally`] — what a vehicle's camera did: pictures taken and measurements sent,
//!   each counted once however often it is heard.
//! * [`image_transfer`] — receiving pictures by MAVLink image transmission
//!   (DATA_TRANSMISSION_HANDSHAKE + ENCAPSULATED_DATA), with re-requests on a lossy link.

pub mod arming;
pub mod camera_tally;
pub mod captures;
pub mod command;
pub mod flavour;
pub mod heartbeat;
pub mod image_transfer;
pub mod launch;
pub mod mission;
pub mod mode;
pub mod params;
pub mod severity;
pub mod sysid_conflict;
pub mod telemetry;
pub mod uplink;

use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::MavComponent;

pub use crate::identity::{GCS_COMPID, GCS_SYSID};
/// The autopilot's component id (MAV_COMP_ID_AUTOPILOT1 = 1).
pub const AUTOPILOT_COMPID: u8 = MavComponent::MAV_COMP_ID_AUTOPILOT1 as u8;
/// The first camera's component id (MAV_COMP_ID_CAMERA = 100).
pub const CAMERA_COMPID: u8 = MavComponent::MAV_COMP_ID_CAMERA as u8;

/// A MAVLink endpoint: (system id, component id).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub struct Endpoint {
    /// System id (1…255).
    pub sysid: u8,
    /// Component id.
    pub compid: u8,
}

impl Endpoint {
    /// The endpoint (`sysid`, `compid`).
    pub const fn new(sysid: u8, compid: u8) -> Endpoint {
        Endpoint { sysid, compid }
    }

    /// The GCS endpoint (255, 190).
    pub const fn gcs() -> Endpoint {
        Endpoint::new(GCS_SYSID, GCS_COMPID)
    }

    /// The sender of a received frame.
    pub fn of(header: &MavHeader) -> Endpoint {
        Endpoint::new(header.system_id as u8, header.component_id)
    }

    /// Whether a message addressed to (`target_system`, `target_component`) is for us
    /// (0 is broadcast).
    pub(crate) fn is_addressed_by(&self, target_system: u8, target_component: u8) -> bool {
        (target_system == 0 || target_system == self.sysid)
            && (target_component == 0 || target_component == self.compid)
    }
}

impl From<(u8, u8)> for Endpoint {
    /// The endpoint of a (system id, component id) pair.
    fn from((sysid, compid): (u8, u8)) -> Endpoint {
        Endpoint::new(sysid, compid)
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.sysid, self.compid)
    }
}
