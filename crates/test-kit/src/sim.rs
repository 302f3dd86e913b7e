//! The embedded simulated autopilot served to a test on UDP, as `fleetmap sim` serves it.

use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use fleetmap_io::link::ConnSpec;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::pace::Speed;
use fleetmap_sim::server::{self, GcsClock, ServeOptions, SimHandle};
use std::net::SocketAddr;

/// Serve `cfg` (from simulated time zero) on `endpoints` at up to `speed` simulated seconds per
/// wall second, the GCS keeping `gcs`'s clock, with no image files and no end: stop it with
/// [`SimHandle::stop`].
pub async fn serve(
    cfg: SimConfig,
    endpoints: Vec<ConnSpec>,
    speed: f64,
    gcs: GcsClock,
) -> SimHandle {
    let sim = Sim::new(cfg, Time::ZERO).expect("the simulation");
    server::spawn(
        sim,
        ServeOptions {
            endpoints,
            speed: Speed::times(speed).expect("a positive, finite speed-up"),
            gcs,
            image_dir: None,
            duration_s: None,
        },
    )
    .await
    .expect("the simulator serves")
}

/// The endpoint of a vehicle that sends to `to` from its own socket (`udpout:`, SITL's
/// `udpclient`).
pub fn udpout(to: SocketAddr) -> ConnSpec {
    server::parse_connection(&format!("udpout:{to}")).expect("a udpout endpoint")
}

/// A simulated ArduCopter without a camera of its own, sending to `to` at up to `speed`× on
/// the simulator's clock: the autopilot beside a camera program under test (the companion
/// computer's), over `world` or at `home` (degrees) on a blank one.
pub async fn autopilot_for_a_camera(
    world: Option<World>,
    home: Option<(f64, f64)>,
    to: SocketAddr,
    speed: f64,
) -> SimHandle {
    let mut cfg =
        SimConfig::from_spec("1xcopter:ardupilot", world, home, 1).expect("the copter's spec");
    cfg.vehicles[0].camera = None;
    serve(cfg, vec![udpout(to)], speed, GcsClock::Simulator).await
}
