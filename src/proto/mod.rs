//! Sans-IO MAVLink micro-services (heartbeat, command, mission transfer) and autopilot flavours.
