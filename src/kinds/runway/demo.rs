//! The runway-mapping demo (`fleetmap demo`): the embedded simulator and the GCS in one
//! process (async shell).
//!
//! The simulator ([`fleetmap_sim::harness::Sim`], served on loopback UDP by
//! [`fleetmap_sim::server::spawn`]) flies three ArduPilot copters over the runway world; the
//! GCS talks to them over real sockets exactly as it would to SITL or hardware, with its
//! clock running at the simulator's speed-up so every protocol timer, the liveness window
//! and the flight times keep their real-time meaning in simulated seconds. The world and
//! the mission are compiled into the binary, so the demo runs from any directory. The
//! mission is flown to the end (battery swaps included when `--battery-minutes` is short
//! enough), sped up to finish within minutes.

use crate::app::error::SimStartError;
use crate::app::kind::{Outcome, RunSettings};
use crate::fleet::FleetHandle;
use crate::kinds::runway::Runway;
use crate::kinds::runway::report::{MappingReport, ROI_SURFACES};
use crate::launch::NewRun;
use crate::launch::demo::{DemoInputs, DemoKind, DemoPlan, DemoTeam, camera_rate};
use crate::launch::sim_fleet::{UdpWiring, serve_udp, serve_virtual};
use anyhow::{Context as _, bail};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_sim::fault::ScheduledFault;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::pace::Speed;
use fleetmap_sim::server::{SimHandle, SimTask};

/// The runway world (`assets/worlds/runway.toml`).
pub const RUNWAY_WORLD: &str = include_str!("../../../assets/worlds/runway.toml");
/// The runway field-test mission (`missions/runway-field-test.toml`).
pub const RUNWAY_MISSION: &str = include_str!("../../../missions/runway-field-test.toml");

/// What the demo flies.
#[derive(Clone, Debug)]
pub struct DemoConfig {
    /// Number of drones (system ids 1..=n).
    pub drones: usize,
    /// Simulated seconds per wall second.
    pub speedup: f64,
    /// Seed of the simulator (same seed, same world noise and link behaviour).
    pub seed: u64,
    /// Battery endurance, minutes.
    pub battery_minutes: f64,
    /// Seconds after landing until the simulated crew has swapped the battery.
    pub swap_after_s: f64,
    /// Altitude separation between drones, metres (0: all at 12 m).
    pub altitude_separation_m: f64,
    /// Cameras that classify runway pictures on board with this definition (the mission's:
    /// [`crate::kinds::runway::runway_definition_of`]) and send each picture's cell and region
    /// counts instead of the picture; `None`: every picture is sent whole.
    pub onboard: Option<fleetmap_core::vision::runway::onboard::RunwayDefinition>,
    /// Each vehicle behind its own telemetry radio (budget counted in simulated time), the
    /// fleet told its budget (`sim_fleet::fleet_config`); `None`: links that carry everything.
    pub radio: Option<RadioConfig>,
    /// Faults scheduled in the simulator ([`fleetmap_sim::fault`]: link outages, a battery
    /// that drops, a camera that dies or slows, a vehicle stuck), in simulated time.
    pub faults: Vec<ScheduledFault>,
}

impl Default for DemoConfig {
    fn default() -> Self {
        DemoConfig {
            drones: 3,
            speedup: 10.0,
            seed: 1,
            battery_minutes: 12.0,
            swap_after_s: 30.0,
            altitude_separation_m: 0.0,
            onboard: None,
            radio: None,
            faults: Vec::new(),
        }
    }
}

/// The plume mission (`missions/plume.toml`), flown over a world whose region moves.
pub(crate) const PLUME_MISSION: &str = include_str!("../../../missions/plume.toml");

/// The runway mission with `cfg.drones` drones and the demo's separation.
pub fn runway_mission(cfg: &DemoConfig) -> Result<(String, MissionDef), SimStartError> {
    mission_with(RUNWAY_MISSION, RUNWAY_MISSION_FILE, cfg)
}

/// The file names of the built-in missions (under `missions/`).
const RUNWAY_MISSION_FILE: &str = "runway-field-test.toml";
const PLUME_MISSION_FILE: &str = "plume.toml";

/// The mission the demo flies over `world`: the runway field test, or the plume mission
/// when the world's region of interest moves, its velocity given as the world's own (the
/// demo's forecast is exact). Regions that move at different velocities are refused: the
/// runner maps one frame. Also returns the built-in mission's file name.
pub fn mission_for(
    world: &World,
    cfg: &DemoConfig,
) -> Result<(String, MissionDef, &'static str), SimStartError> {
    let mut moving = world
        .regions
        .iter()
        .filter(|r| ROI_SURFACES.contains(&r.surface) && r.velocity_ne != (0.0, 0.0))
        .map(|r| r.velocity_ne);
    let Some((vn, ve)) = moving.next() else {
        let (text, def) = runway_mission(cfg)?;
        return Ok((text, def, RUNWAY_MISSION_FILE));
    };
    if moving.any(|v| v != (vn, ve)) {
        return Err(SimStartError::MovingRegions {
            world: world.name.clone(),
        });
    }
    let text = PLUME_MISSION.replace(
        "roi_velocity_ne_mps = [0.0, 0.3]",
        &format!("roi_velocity_ne_mps = [{vn:?}, {ve:?}]"),
    );
    let (text, def) = mission_with(&text, PLUME_MISSION_FILE, cfg)?;
    Ok((text, def, PLUME_MISSION_FILE))
}

/// Mission text `base` (built-in file `file`) with `cfg`'s drones, separation and battery: the
/// mission's `flight_time_min` (the endurance the GCS judges returns and reach by) is the
/// simulated batteries' `battery_minutes`, so that a shorter battery is not flown as a
/// 12-minute one.
fn mission_with(
    base: &str,
    file: &str,
    cfg: &DemoConfig,
) -> Result<(String, MissionDef), SimStartError> {
    const BATTERY_LINE: &str = "flight_time_min = 12.0";
    if !base.contains(BATTERY_LINE) {
        return Err(SimStartError::NoBatteryLine {
            file: file.to_string(),
            line: BATTERY_LINE,
        });
    }
    let mut text = base
        .replace(
            "altitude_separation_m = 0.0",
            &format!("altitude_separation_m = {:?}", cfg.altitude_separation_m),
        )
        .replacen(
            BATTERY_LINE,
            &format!("flight_time_min = {:?}", cfg.battery_minutes),
            1,
        );
    // Appended at the end: after the sweep table, so a [[vehicles]] header starts its own
    // array-of-tables entry.
    for k in 2..=cfg.drones {
        text.push_str(&format!(
            "\n[[vehicles]]\nsysid = {k}\nrole = \"drone\"\nname = \"uav{k}\"\n"
        ));
    }
    let def =
        MissionDef::parse(&text, &format!("{file} (built in)")).map_err(SimStartError::Mission)?;
    Ok((text, def))
}

/// A running demo simulator and the fleet connected to it.
pub struct DemoFleet {
    /// The fleet (GCS side).
    pub fleet: FleetHandle,
    /// The simulator task.
    pub sim: SimHandle,
    /// The world.
    pub world: World,
    /// When the simulator started, ms since the Unix epoch: its world's time 0 (where a
    /// moving region's polygon is as written), the demo run's region epoch.
    pub(crate) started_unix_ms: u64,
}

/// The simulator with `spec` vehicles over `world` behind in-process links and a fleet on
/// them, both on the runtime's clock at real speed: with tokio's clock paused (tests with
/// `start_paused`) the whole run is virtual and as fast as the CPU allows.
pub async fn start_virtual(
    spec: &str,
    world: World,
    cfg: &DemoConfig,
) -> Result<(FleetHandle, SimTask), SimStartError> {
    let sim = Sim::new(sim_config(spec, world, cfg)?, Time::ZERO)?;
    Ok(serve_virtual(sim, cfg.radio.as_ref()))
}

fn sim_config(spec: &str, world: World, cfg: &DemoConfig) -> Result<SimConfig, SimStartError> {
    let mut sc = SimConfig::from_spec(spec, Some(world), None, cfg.seed)?
        .with_scheduled_faults(cfg.faults.iter().copied());
    for v in &mut sc.vehicles {
        if v.flavour.is_copter() {
            v.battery.minutes = cfg.battery_minutes;
        }
        v.swap_after_s = Some(cfg.swap_after_s);
        if let Some(c) = v.camera.as_mut() {
            c.onboard = cfg
                .onboard
                .clone()
                .map(fleetmap_core::vision::onboard::OnboardSpec::Runway);
            c.transfer_rate_bps = camera_rate(cfg.radio.as_ref());
        }
    }
    Ok(match &cfg.radio {
        Some(r) => sc.with_radio(r.clone()),
        None => sc,
    })
}

/// Start the simulator with `spec` vehicles over `world` and a fleet connected to each
/// vehicle over loopback UDP, on the simulator's own time (at most `cfg.speedup` times the
/// wall clock's, slower when the machine is busy).
pub async fn start(spec: &str, world: World, cfg: &DemoConfig) -> Result<DemoFleet, SimStartError> {
    let speed = Speed::times(cfg.speedup).ok_or(SimStartError::Speed)?;
    start_at(spec, world, cfg, speed).await
}

/// [`start`] at `speed` (`Speed::Max`: as fast as the machine can; the fleet's timeouts are
/// then stretched as for 4×, [`crate::fleet::FleetConfig::at_speedup`]), `cfg.speedup` aside.
pub(crate) async fn start_at(
    spec: &str,
    world: World,
    cfg: &DemoConfig,
    speed: Speed,
) -> Result<DemoFleet, SimStartError> {
    let sim = Sim::new(sim_config(spec, world.clone(), cfg)?, Time::ZERO)?;
    let (fleet, handle) =
        serve_udp(sim, UdpWiring::LinkPerVehicle, speed, cfg.radio.as_ref()).await?;
    Ok(DemoFleet {
        fleet,
        started_unix_ms: handle.time.started_unix_ms(),
        sim: handle,
        world,
    })
}

/// `fleetmap demo`: the runway demo has no flag of its own; it flies unless another kind's
/// flag is given. The world is the built-in runway (or `--world`), the mission the field test
/// (or the plume mission over a moving region), the team `--drones` ArduPilot copters; on a
/// radio the cameras classify their pictures on board.
impl DemoKind for Runway {
    type Flags = crate::launch::demo::NoFlags;
    /// The simulator's vehicles (`--drones` copters), the world, the set-up.
    type Team = (String, World, DemoConfig);
    const RUN_DIR_PREFIX: &'static str = "demo";

    fn chosen(_: &Self::Flags) -> bool {
        false
    }

    fn misplaced(_: &Self::Flags) -> Option<String> {
        None
    }

    fn plan(args: &DemoInputs, _: &Self::Flags) -> anyhow::Result<DemoPlan<Self::Team>> {
        if !(1..=8).contains(&args.options.drones) {
            bail!("--drones must be between 1 and 8");
        }
        args.check_pace()?;
        let mut cfg = DemoConfig {
            drones: args.options.drones,
            speedup: args.options.speedup,
            seed: args.options.seed,
            battery_minutes: args.options.battery_minutes,
            altitude_separation_m: args.options.separation,
            radio: args.radio.config()?,
            faults: crate::launch::demo::fault_schedule(args.faults)?,
            ..DemoConfig::default()
        };
        let (world_text, world) = match &args.options.world {
            Some(p) => fleetmap_io::files::read_world(p)?,
            None => {
                let text = RUNWAY_WORLD.to_string();
                let world = World::from_toml(&text).context("the demo world")?;
                (text, world)
            }
        };
        let (text, def, mission_file) = mission_for(&world, &cfg)?;
        if cfg.radio.is_some() {
            // pictures do not fit a radio: the cameras classify them on board
            cfg.onboard = super::runway_definition_of(&def);
        }
        Ok(DemoPlan {
            intro: format!(
                "demo: simulator with {} ArduPilot copter(s) over the {} world, {}x real time",
                cfg.drones, world.name, cfg.speedup
            ),
            label: format!(
                "DEMO: {} simulated ArduPilot copter(s), {}x real time",
                cfg.drones, cfg.speedup
            ),
            auto_start: !args.options.manual,
            new: NewRun {
                def,
                text,
                mission_path: format!("built-in {mission_file}"),
                run_dir: None,
                world_toml: Some(world_text),
                extra: serde_json::Value::Null,
            },
            team: (format!("{}xcopter:ardupilot", cfg.drones), world, cfg),
        })
    }

    async fn start((spec, world, cfg): Self::Team) -> Result<DemoTeam, SimStartError> {
        let d = start(&spec, world, &cfg).await?;
        Ok(DemoTeam {
            fleet: d.fleet,
            sim: d.sim,
            started_unix_ms: d.started_unix_ms,
        })
    }

    fn settings(args: &DemoInputs, team: &DemoTeam) -> RunSettings {
        // A moving region is where the world file draws it at the simulator's start.
        RunSettings {
            auto_resume: !args.options.manual,
            roi_epoch_unix_ms: Some(team.started_unix_ms),
            ..args.settings()
        }
    }

    fn summary(r: &MappingReport) -> Vec<String> {
        let mut lines = vec![
            format!("demo finished: {}", r.phase),
            format!(
                "  map: {} runway cells; tree {} vertices ({} explored); {} images at cell centres, {} decisions",
                r.cells_mapped, r.tree_vertices, r.explored_vertices, r.images, r.detections
            ),
            format!(
                "  flight: {:.0} s airborne in all, {:.0} m, {} battery swap(s)",
                r.flight_time_s, r.distance_m, r.battery_swaps
            ),
            super::kind::mission_time_line(&r.mission_time),
        ];
        if let Some([n, e]) = r.roi_velocity_ne_mps {
            lines.push(format!(
                "  the region moved at {:.2} m/s (north {n:.2}, east {e:.2}): mapped in its own frame, \
                 scored against where it was at the simulator's start",
                n.hypot(e)
            ));
        }
        if let Some(t) = &r.truth {
            lines.push(format!(
                "  IoU with the ground truth {:.1} % (best possible on this grid {:.1} %; the paper's field test {:.1} %); \
                 {} false positive and {} false negative decision(s)",
                100.0 * t.iou,
                100.0 * t.iou_best_possible,
                100.0 * t.paper_iou,
                t.false_positives,
                t.false_negatives
            ));
        }
        lines
    }

    fn succeeded(outcome: &Outcome, r: &MappingReport) -> bool {
        matches!(outcome, Outcome::Finished) && r.finished
    }
}
