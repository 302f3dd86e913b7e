//! The fleet actor: one vehicle per MAVLink system id, its telemetry, and async operations
//! (arm, set mode, take off, go to, upload missions, capture images).
