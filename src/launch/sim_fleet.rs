//! The embedded simulator and a fleet connected to it, started together (async shell): over
//! loopback UDP on the simulator's own time ([`serve_udp`]), or over in-process links on the
//! runtime's clock (`serve_virtual`). The runway demo ([`crate::kinds::runway::demo`]), the simulated
//! bandit team ([`crate::kinds::bandit::sim`]) and the tests start theirs here.

use crate::app::error::SimStartError;
use crate::fleet::{self, FleetConfig, FleetHandle};
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_io::link::transport::{LinkOptions, open_link, open_memory_link};
use fleetmap_sim::harness::Sim;
use fleetmap_sim::pace::Speed;
use fleetmap_sim::server::{self, GcsClock, ServeOptions, SimHandle, SimTask};
use tokio::sync::mpsc;

/// How the fleet and the simulator meet on loopback UDP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UdpWiring {
    /// The simulator listens on one port per vehicle (`udpin:127.0.0.1:0`) and the fleet
    /// opens one link to each, as to SITL instances each on its own port.
    LinkPerVehicle,
    /// The fleet listens on one port (`udpin:127.0.0.1:0`) and every vehicle sends to it from
    /// its own socket (the simulator's `udpout`), as field teams wire several SITL instances
    /// or Wi-Fi drones.
    FleetListens,
}

/// Serve `sim` at `speed` over loopback UDP wired as `wiring`, and spawn a fleet on it that
/// follows the simulator's own time (slower than `speed` when the machine is busy:
/// [`fleetmap_sim::pace`]), its timeouts stretched for `speed` (as for 4× at `Speed::Max`,
/// [`FleetConfig::at_speedup`]) and told each link's budget when the vehicles are behind
/// `radio` (`fleet_config`).
pub async fn serve_udp(
    sim: Sim,
    wiring: UdpWiring,
    speed: Speed,
    radio: Option<&RadioConfig>,
) -> Result<(FleetHandle, SimHandle), SimStartError> {
    let serve = |endpoint: &str| -> Result<ServeOptions, SimStartError> {
        Ok(ServeOptions {
            endpoints: vec![server::parse_connection(endpoint).map_err(SimStartError::Connection)?],
            speed,
            // the fleet below follows the simulator's time
            gcs: GcsClock::Simulator,
            image_dir: None,
            duration_s: None,
        })
    };
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let (links, handle) = match wiring {
        UdpWiring::FleetListens => {
            let spec: ConnSpec = "udpin:127.0.0.1:0".parse()?;
            let link = open_link(0, spec, &LinkOptions::default(), ev_tx).await?;
            let gcs = link.local.ok_or(SimStartError::NoLocalAddress)?;
            let handle = server::spawn(sim, serve(&format!("udpout:{gcs}"))?)
                .await
                .map_err(SimStartError::Server)?;
            (vec![link], handle)
        }
        UdpWiring::LinkPerVehicle => {
            let handle = server::spawn(sim, serve("udpin:127.0.0.1:0")?)
                .await
                .map_err(SimStartError::Server)?;
            let mut links = Vec::new();
            for (i, b) in handle.bound.iter().enumerate() {
                let spec: ConnSpec = format!("udpout:{}", b.local).parse()?;
                links.push(open_link(i, spec, &LinkOptions::default(), ev_tx.clone()).await?);
            }
            drop(ev_tx);
            (links, handle)
        }
    };
    let ceiling = speed.ceiling().unwrap_or(4.0);
    let fleet = fleet::spawn(
        links,
        ev_rx,
        fleet_config(FleetConfig::at_speedup(ceiling), radio),
        handle.clock(),
    );
    Ok((fleet, handle))
}

/// Serve `sim` over in-process links, one per vehicle, and spawn a fleet on them, both on the
/// runtime's clock; the fleet plans for `radio` when the vehicles are behind radios.
pub fn serve_virtual(sim: Sim, radio: Option<&RadioConfig>) -> (FleetHandle, SimTask) {
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let mut links = Vec::new();
    let mut ports = Vec::new();
    for (i, sysid) in sim.sysids().into_iter().enumerate() {
        let (h, p) = open_memory_link(
            i,
            &format!("sim-{sysid}"),
            &LinkOptions::default(),
            ev_tx.clone(),
        );
        links.push(h);
        ports.push(p);
    }
    drop(ev_tx);
    let handle = server::spawn_memory(sim, ports);
    let fleet = fleet::spawn(
        links,
        ev_rx,
        fleet_config(FleetConfig::default(), radio),
        MonotonicClock::new(),
    );
    (fleet, handle)
}

/// `base` with the budget of `radio` (what an operator writes as `--link radio:BYTES` for
/// such a radio): the fleet plans each vehicle's telemetry and paces its own sends to it.
pub(crate) fn fleet_config(mut base: FleetConfig, radio: Option<&RadioConfig>) -> FleetConfig {
    if let Some(r) = radio.filter(|r| r.bytes_per_s > 0) {
        base.budget = Some(fleetmap_core::budget::LinkBudget::Radio {
            bytes_per_s: r.bytes_per_s,
        });
    }
    base
}
