//! MAVLink transports (UDP, TCP, serial), framing, routing, signing and `.tlog` recording.
