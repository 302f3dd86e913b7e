//! The spatial-classification run on the embedded simulator (async shell): the bandit
//! paper's hardware field (§V, Fig. 3) with ArduPilot copters as drones and ArduPilot rovers
//! as charging stations, served on loopback UDP by [`fleetmap_sim::server::spawn`] with the
//! GCS clock running at the simulator's speed-up — what `fleetmap demo --bandit` and the
//! end-to-end tests fly.

use crate::app::error::SimStartError;
use crate::fleet::FleetHandle;
use crate::launch::sim_fleet::{UdpWiring, serve_udp, serve_virtual};
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_sim::fault::ScheduledFault;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::pace::Speed;
use fleetmap_sim::server::{SimHandle, SimTask};

/// The hardware field world (`assets/worlds/hardware-6x6.toml`).
pub const HARDWARE_WORLD: &str = include_str!("../../../assets/worlds/hardware-6x6.toml");
/// The hardware test mission (`missions/hardware-6x6.toml`).
pub const HARDWARE_MISSION: &str = include_str!("../../../missions/hardware-6x6.toml");
/// The team of the hardware mission: 4 drones (sysids 1–4) and 2 rovers (5–6).
pub const HARDWARE_TEAM: &str = "4xcopter:ardupilot,2xrover:ardupilot";
/// The 10×10 simulation default's world (`assets/worlds/sim-10x10.toml`).
pub const SIM10_WORLD: &str = include_str!("../../../assets/worlds/sim-10x10.toml");
/// The 10×10 simulation default's mission (`missions/sim-10x10.toml`).
pub const SIM10_MISSION: &str = include_str!("../../../missions/sim-10x10.toml");
/// Its team: 10 drones (sysids 1–10) and 5 rovers (11–15).
pub const SIM10_TEAM: &str = "10xcopter:ardupilot,5xrover:ardupilot";

/// How the simulated team is set up.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSetup {
    /// Simulated seconds per wall second.
    pub speedup: f64,
    /// Seed of the simulator.
    pub seed: u64,
    /// Side of the (square) camera images, pixels (480: the paper's camera; fewer render
    /// faster with the same field of view).
    pub camera_px: u32,
    /// Copter battery endurance, minutes of hover.
    pub battery_minutes: f64,
    /// Minutes a copter battery takes to charge from empty on a station (30: a typical
    /// charger; the paper's wireless pads are slower).
    pub charge_minutes: f64,
    /// A degraded sensor: the probability that a camera image shows the other class of tile
    /// (0: none; the bandit paper's §V degraded-sensor run: 0.05). See
    /// [`fleetmap_camera::camera::CameraConfig::misclassify_probability`].
    pub sensor_flip: f64,
    /// Cameras that measure on board with this definition (the mission's:
    /// [`crate::kinds::bandit::green_spec_of`]) and send the green share instead of the
    /// picture; `None`: every picture is sent whole.
    pub onboard: Option<fleetmap_core::vision::onboard::GreenSpec>,
    /// Each vehicle behind its own telemetry radio (budget counted in simulated time), the
    /// fleet told its budget; `None`: links that carry everything.
    pub radio: Option<RadioConfig>,
    /// Faults scheduled in the simulator ([`fleetmap_sim::fault`]: link outages, a battery
    /// that drops, a camera that dies or slows, a rover stuck on its way), in simulated time.
    pub faults: Vec<ScheduledFault>,
}

impl Default for SimSetup {
    fn default() -> Self {
        SimSetup {
            speedup: 10.0,
            seed: 1,
            camera_px: 480,
            battery_minutes: 12.0,
            charge_minutes: 30.0,
            sensor_flip: 0.0,
            onboard: None,
            radio: None,
            faults: Vec::new(),
        }
    }
}

/// The simulator configuration for `spec` over `world` (the world's default homes: the
/// mission's start cells), without battery swaps (the rovers charge the drones).
pub fn sim_config(spec: &str, world: &World, setup: &SimSetup) -> Result<SimConfig, SimStartError> {
    let mut sc = SimConfig::from_spec(spec, Some(world.clone()), None, setup.seed)?
        .with_scheduled_faults(setup.faults.iter().copied());
    for v in &mut sc.vehicles {
        if v.flavour.is_copter() {
            v.battery.minutes = setup.battery_minutes;
            v.battery.charge_minutes = setup.charge_minutes;
        }
        v.swap_after_s = None;
        if let Some(c) = v.camera.as_mut() {
            c.model.width_px = setup.camera_px.max(8);
            c.model.height_px = setup.camera_px.max(8);
            c.misclassify_probability = setup.sensor_flip;
            c.onboard = setup
                .onboard
                .map(fleetmap_core::vision::onboard::OnboardSpec::Green);
            c.transfer_rate_bps = crate::launch::demo::camera_rate(setup.radio.as_ref());
        }
    }
    Ok(match &setup.radio {
        Some(r) => sc.with_radio(r.clone()),
        None => sc,
    })
}

/// A running simulator and the fleet connected to it.
pub struct SimFleet {
    /// The fleet (GCS side).
    pub fleet: FleetHandle,
    /// The simulator task.
    pub sim: SimHandle,
}

/// Serve `sim` at up to `speedup` and connect a fleet to it on the simulator's own time
/// (slower when the machine is busy: [`fleetmap_sim::pace`]), wired
/// as field teams wire several vehicles: the fleet listens on one loopback UDP port
/// (`udpin:127.0.0.1:0`) and every vehicle sends to it from its own socket (the simulator's
/// `udpout`), as several SITL instances or Wi-Fi drones do.
/// The fleet is told each link's budget when `setup` puts the vehicles behind radios.
pub async fn start(sim: Sim, setup: &SimSetup) -> Result<SimFleet, SimStartError> {
    let speed = Speed::times(setup.speedup).ok_or(SimStartError::Speed)?;
    let (fleet, sim) = serve_udp(sim, UdpWiring::FleetListens, speed, setup.radio.as_ref()).await?;
    Ok(SimFleet { fleet, sim })
}

/// Build and serve a simulator for `spec` over `world` (see [`sim_config`], [`start`]).
pub async fn start_team(
    spec: &str,
    world: &World,
    setup: &SimSetup,
) -> Result<SimFleet, SimStartError> {
    let sim = Sim::new(sim_config(spec, world, setup)?, Time::ZERO)?;
    start(sim, setup).await
}

/// The simulator for `spec` over `world` behind in-process links, one per vehicle, and a
/// fleet on them, both on the runtime's clock at real speed (`setup.speedup` aside): with
/// tokio's clock paused (tests with `start_paused`) the whole run is virtual and as fast as
/// the CPU allows.
pub async fn start_virtual(
    spec: &str,
    world: &World,
    setup: &SimSetup,
) -> Result<(FleetHandle, SimTask), SimStartError> {
    let sim = Sim::new(sim_config(spec, world, setup)?, Time::ZERO)?;
    Ok(serve_virtual(sim, setup.radio.as_ref()))
}

/// [`start_virtual`] with a simulator configuration of the caller's ([`sim_config`] changed:
/// faults scheduled, a crew that swaps some batteries).
pub async fn start_virtual_with(
    cfg: SimConfig,
    setup: &SimSetup,
) -> Result<(FleetHandle, SimTask), SimStartError> {
    let sim = Sim::new(cfg, Time::ZERO)?;
    Ok(serve_virtual(sim, setup.radio.as_ref()))
}
