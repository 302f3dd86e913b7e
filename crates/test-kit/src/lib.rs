//! What the workspace's integration tests share, written once: the end-to-end tests of the
//! ground station (`tests/suite`) and of the companion computer's camera
//! (`crates/camera/tests`) both use it.
//!
//! | module | what |
//! |---|---|
//! | [`process`] | a child process killed when its guard drops, so a failing test leaves nothing running |
//! | [`bin`] | one of the workspace's programs run from a test (`fleetmap`, `fleetmap-camera`) |
//! | [`router`] | a MAVLink router between a GCS, vehicles and a serial line, as mavlink-router runs one |
//! | [`gcs`] | a test's own GCS (system 255, component 190): a UDP socket, or the messages for a simulation stepped in the test |
//! | [`sim`] | the embedded simulated autopilot served to a test on UDP |
//! | [`geo`] | positions a few metres from a home |
//!
//! The kit does not depend on the ground station (`fleetmap`): the camera's tests use it, and
//! the camera builds without HiGHS or the terminal UI. What only the ground station's suite
//! needs lives in `tests/suite/common`.

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod bin;
pub mod gcs;
pub mod geo;
pub mod process;
pub mod router;
pub mod sim;

pub use bin::Bin;
pub use geo::at;
pub use process::Guard;

/// A UDP port on 127.0.0.1 that was free a moment ago (for a program under test to listen on:
/// another process may take it before the program binds it, which on loopback in a test is
/// rare enough).
pub fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free UDP port on 127.0.0.1")
        .port()
}
