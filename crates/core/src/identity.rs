//! The ground station's own MAVLink identity, defined once for the whole workspace: the
//! protocol machines (`proto`, which offers it as `fleetmap_core::proto::GCS_SYSID` and
//! `GCS_COMPID`), the mission files' validation (a vehicle may not take the GCS's system id),
//! the simulator and the camera. A module of its own, below both `proto` and `mission`, so
//! that neither imports the other for it.

use mavlink::dialects::ardupilotmega::MavComponent;

/// The GCS's MAVLink system id (docs/grid.md: 255, as QGroundControl and MAVProxy use). Every
/// place that sends or expects the GCS's identity uses this (and [`GCS_COMPID`]).
pub const GCS_SYSID: u8 = 255;
/// The GCS's component id (MAV_COMP_ID_MISSIONPLANNER = 190, as QGroundControl uses).
pub const GCS_COMPID: u8 = MavComponent::MAV_COMP_ID_MISSIONPLANNER as u8;
