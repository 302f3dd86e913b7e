//! The spatial-classification demo (`fleetmap demo --bandit`): the simulator in-process (4
//! ArduPilot copters and 2 ArduPilot rovers over the hardware field
//! `assets/worlds/hardware-6x6.toml`, [`super::sim`]) and the hardware mission
//! `missions/hardware-6x6.toml` flown to the end — in the terminal UI when there is a
//! terminal, otherwise (or with `--headless`) progress lines, then the report with the keep
//! set (scored against the world's green tiles). Headless, the exit status is 0 when every
//! cell is classified and the keep set is the green tiles.

use super::report::ClassificationReport;
use super::sim::{self, SimSetup};
use super::{BoundArg, Classification};
use crate::app::error::SimStartError;
use crate::app::kind::{Outcome, RunKind, RunSettings};
use crate::launch::NewRun;
use crate::launch::demo::{DemoInputs, DemoKind, DemoPlan, DemoTeam, fault_schedule};
use anyhow::{Context as _, bail};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;

/// The flags of `fleetmap demo` for the spatial-classification demo.
#[derive(Debug, clap::Args)]
pub(crate) struct ClassificationDemoFlags {
    /// The spatial-classification demo instead: the bandit paper's 6×6 hardware mission
    /// with 4 ArduPilot copters and 2 ArduPilot rovers as charging stations.
    #[arg(long)]
    pub bandit: bool,
    /// With --bandit: side of the simulated camera images, pixels. The measurement is the
    /// green share of the part of the image over the cell, so a smaller image with the same
    /// field of view measures the same; 480 (the runway camera's) renders, sends and
    /// measures 9 times the pixels and made the demo 6 times slower on 2 cores.
    #[arg(long, value_name = "PX", default_value_t = 160)]
    pub camera_px: u32,
    /// With --bandit: the confidence bound (`classification.bound`; default the mission's,
    /// the KL bound). `paper` flies the paper's (3b), which needs about four times the
    /// samples (and epochs) before every cell is labelled.
    #[arg(long, value_enum)]
    pub bound: Option<BoundArg>,
    /// With --bandit: the simulated cameras' sensor (the bandit paper's degraded sensor, §V).
    #[command(flatten)]
    pub sensor: fleetmap_camera::cli::SensorArgs,
}

impl DemoKind for Classification {
    type Flags = ClassificationDemoFlags;
    /// The world and the simulated team's set-up (the hardware team).
    type Team = (World, SimSetup);
    const RUN_DIR_PREFIX: &'static str = "demo-bandit";

    fn chosen(flags: &ClassificationDemoFlags) -> bool {
        flags.bandit
    }

    fn misplaced(flags: &ClassificationDemoFlags) -> Option<String> {
        (flags.sensor.flip != 0.0)
            .then(|| "--sensor-flip is for the spatial-classification demo (--bandit)".into())
    }

    fn plan(
        args: &DemoInputs<'_>,
        flags: &ClassificationDemoFlags,
    ) -> anyhow::Result<DemoPlan<Self::Team>> {
        args.check_pace()?;
        if !(16..=1920).contains(&flags.camera_px) {
            bail!("--camera-px must be between 16 and 1920");
        }
        let sensor_flip = flags.sensor.probability()?;
        // How the run's settings name the sensor: in the progress lines, the UI title and
        // run.json.
        let sensor = if sensor_flip > 0.0 {
            format!(", degraded sensor (flip {sensor_flip})")
        } else {
            String::new()
        };
        let world = World::from_toml(sim::HARDWARE_WORLD).context("the built-in 6x6 world")?;
        let text = match flags.bound {
            None => sim::HARDWARE_MISSION.to_string(),
            Some(b) => sim::HARDWARE_MISSION.replacen(
                "[classification]",
                &format!("[classification]\nbound = \"{}\"", b.bound().name()),
                1,
            ),
        };
        let def = MissionDef::parse(&text, "hardware-6x6.toml (built in)")
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let setup = SimSetup {
            speedup: args.options.speedup,
            seed: args.options.seed,
            camera_px: flags.camera_px,
            battery_minutes: args.options.battery_minutes,
            sensor_flip,
            // a field camera measures on board: the green share, not the picture, on the link
            onboard: super::green_spec_of(&def),
            radio: args.radio.config()?,
            faults: fault_schedule(args.faults)?,
            ..SimSetup::default()
        };
        Ok(DemoPlan {
            intro: format!(
                "demo: simulator with 4 ArduPilot copters and 2 ArduPilot rovers (charging \
                 stations) over the bandit paper's 6x6 field, {}x real time{sensor}",
                setup.speedup
            ),
            label: format!(
                "DEMO: 4 simulated ArduPilot copters, 2 rovers, {}x real time{sensor}",
                setup.speedup
            ),
            auto_start: true,
            new: NewRun {
                def,
                text,
                mission_path: "built-in hardware-6x6.toml".into(),
                run_dir: None,
                world_toml: Some(sim::HARDWARE_WORLD.to_string()),
                extra: serde_json::json!({ "sensor_flip": sensor_flip }),
            },
            team: (world, setup),
        })
    }

    async fn start((world, setup): Self::Team) -> Result<DemoTeam, SimStartError> {
        let d = sim::start_team(sim::HARDWARE_TEAM, &world, &setup).await?;
        Ok(DemoTeam {
            started_unix_ms: d.sim.time.started_unix_ms(),
            fleet: d.fleet,
            sim: d.sim,
        })
    }

    fn settings(args: &DemoInputs, _: &DemoTeam) -> RunSettings {
        args.settings()
    }

    fn summary(r: &ClassificationReport) -> Vec<String> {
        let mut lines = vec!["demo finished".to_string()];
        lines.extend(Classification::report_lines(r));
        lines
    }

    fn succeeded(_: &Outcome, r: &ClassificationReport) -> bool {
        r.finished && r.interesting_truth.as_ref() == Some(&r.keep)
    }
}
