//! The embedded simulated autopilot: vehicles, battery, camera and worlds, stepped by time.
