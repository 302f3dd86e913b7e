//! Image sources: MAVLink image transmission, a watched directory and the simulated camera.
