//! `fleetmap demo`: a mission kind flown on the embedded simulator, the station in the same
//! process (async shell).
//!
//! Each kind brings its own demo (`DemoKind`, in its folder: the built-in world and mission,
//! the simulated team, the on-board measurement, the report's lines and what counts as
//! success) and its own flags; `fleetmap demo` (`src/cli/demo.rs`) is written once over them,
//! the kind chosen through the registry ([`crate::kinds`]). This file holds the flags
//! every demo shares ([`DemoOptions`], [`RadioArgs`], `--fault`) and the simulated cameras'
//! pacing behind a radio.

use crate::app::error::SimStartError;
use crate::app::kind::{Outcome, RunKind, RunSettings};
use crate::fleet::FleetHandle;
use crate::launch::NewRun;
use anyhow::{Context as _, bail};
use clap::Args;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_sim::fault::ScheduledFault;
use fleetmap_sim::server::SimHandle;
use std::path::PathBuf;

/// The flags of `fleetmap demo` every demo shares (with [`RadioArgs`] and `--fault`); each
/// kind has its own besides (`DemoKind::Flags`, one of which chooses its demo).
#[derive(Debug, Args)]
pub struct DemoOptions {
    /// No terminal UI: progress lines and the final report on stdout.
    #[arg(long)]
    pub headless: bool,
    /// Keep the run here (default: a new directory under runs/).
    #[arg(long, value_name = "DIR")]
    pub run_dir: Option<PathBuf>,
    /// Number of drones.
    #[arg(long, value_name = "N", default_value_t = 3)]
    pub drones: usize,
    /// Simulated seconds per wall second.
    #[arg(long, value_name = "X", default_value_t = 10.0)]
    pub speedup: f64,
    /// Seed of the simulator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Battery endurance, minutes of hover.
    #[arg(long, value_name = "MIN", default_value_t = 12.0)]
    pub battery_minutes: f64,
    /// Altitude separation between the drones, metres.
    #[arg(long, value_name = "M", default_value_t = 0.0)]
    pub separation: f64,
    /// Print the final report as JSON.
    #[arg(long)]
    pub json: bool,
    /// The operator drives: the mission waits for START (`s`), and after a battery swap a
    /// vehicle waits for "battery swapped — resume" (`b`). Default: both by themselves.
    #[arg(long)]
    pub manual: bool,
    /// Start even when the fleet check before take-off finds a blocker (docs/fleet-check.md).
    #[arg(long)]
    pub ignore_check: bool,
    /// Fly over this world instead of the built-in runway (its default homes must put the
    /// region inside the mission's sweep box).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
}

/// What every demo is given from the command line.
pub(crate) struct DemoInputs<'a> {
    /// The shared flags.
    pub options: &'a DemoOptions,
    /// `--radio`, `--radio-loss`.
    pub radio: &'a RadioArgs,
    /// `--fault` (each occurrence as given).
    pub faults: &'a [String],
}

impl DemoInputs<'_> {
    /// Refuse a speed-up outside (0, 50] and a battery under 3 minutes (every demo's limits).
    pub(crate) fn check_pace(&self) -> anyhow::Result<()> {
        let o = self.options;
        if !(o.speedup.is_finite() && o.speedup > 0.0 && o.speedup <= 50.0) {
            bail!("--speedup must be in (0, 50]");
        }
        if !(o.battery_minutes.is_finite() && o.battery_minutes >= 3.0) {
            bail!("--battery-minutes must be at least 3");
        }
        Ok(())
    }

    /// The settings every demo's run starts with: the fleet check's blockers stop it unless
    /// `--ignore-check`.
    pub(crate) fn settings(&self) -> RunSettings {
        RunSettings {
            on_blocker: crate::app::preflight::OnBlocker::unless_ignored(
                self.options.ignore_check,
                crate::app::preflight::OnBlocker::Stop,
            ),
            ..RunSettings::default()
        }
    }
}

/// The schedule `--fault` gives (each occurrence one or more comma-separated entries).
pub(crate) fn fault_schedule(specs: &[String]) -> anyhow::Result<Vec<ScheduledFault>> {
    let mut all = Vec::new();
    for s in specs {
        all.extend(fleetmap_sim::fault::parse_faults(s).context("--fault")?);
    }
    Ok(all)
}

/// `--radio` and `--radio-loss`: every simulated vehicle behind its own radio (`fleetmap demo`,
/// `fleetmap sim`).
#[derive(Debug, Args)]
pub struct RadioArgs {
    /// Every vehicle behind its own simulated telemetry radio carrying this many bytes a
    /// second of simulated time, both directions together (a SiK pair: half duplex, 4 kB
    /// buffers, RADIO_STATUS); a GCS should plan for it as fleetmap does with
    /// `--link radio:BYTES`.
    #[arg(long = "radio", value_name = "BYTES_PER_S")]
    pub radio_bytes_per_s: Option<u32>,
    /// With --radio: the share of frames each radio loses on the air, 0–1.
    #[arg(
        long = "radio-loss",
        value_name = "P",
        default_value_t = 0.0,
        requires = "radio_bytes_per_s"
    )]
    pub radio_loss: f64,
}

impl RadioArgs {
    /// The radio these arguments describe, if any.
    pub(crate) fn config(&self) -> anyhow::Result<Option<RadioConfig>> {
        let Some(b) = self.radio_bytes_per_s else {
            return Ok(None);
        };
        let min = fleetmap_core::budget::LinkBudget::MIN_RADIO;
        let max = fleetmap_core::budget::LinkBudget::MAX_RADIO;
        if !(min..=max).contains(&b) {
            bail!("--radio must be between {min} and {max} bytes a second");
        }
        let cfg = RadioConfig {
            loss: self.radio_loss,
            ..RadioConfig::radio(b)
        };
        cfg.validate()
            .map_err(|e| anyhow::anyhow!("--radio-loss: {e}"))?;
        Ok(Some(cfg))
    }
}

/// The share of a radio's bytes a camera's pictures may take, as `fleetmap camera
/// --image-rate` is set for a radio (about 600 B/s on 2,000 B/s): what is left when the
/// vehicle's telemetry (40 %) and the GCS's sends (25 %) have theirs.
pub(crate) const CAMERA_RADIO_SHARE: f64 = 0.3;

/// The simulated cameras' image pacing behind `radio` ([`CAMERA_RADIO_SHARE`] of it), `None`
/// (one burst per picture) without one.
pub(crate) fn camera_rate(radio: Option<&RadioConfig>) -> Option<f64> {
    radio
        .filter(|r| r.bytes_per_s > 0)
        .map(|r| f64::from(r.bytes_per_s) * CAMERA_RADIO_SHARE)
}

/// What a kind's demo flies, decided before anything starts.
pub(crate) struct DemoPlan<T> {
    /// The simulated team, given to [`DemoKind::start`].
    pub team: T,
    /// The run to start (the mission's text and definition, the built-in file it comes from,
    /// the world's text, the settings `run.json` keeps); its directory is the demo's.
    pub new: NewRun,
    /// The line printed when the simulator is up, headless.
    pub intro: String,
    /// The terminal UI's title.
    pub label: String,
    /// Whether the mission starts by itself (without the operator's START).
    pub auto_start: bool,
}

/// A demo's simulator, running, and the fleet connected to it.
pub(crate) struct DemoTeam {
    /// The fleet (GCS side).
    pub fleet: FleetHandle,
    /// The simulator task.
    pub sim: SimHandle,
    /// When the simulator started, ms since the Unix epoch: its world's time 0.
    pub started_unix_ms: u64,
}

/// A mission kind's built-in demo on the embedded simulator: its own flags, the world, the
/// mission and the team it flies, and how its report is told. `fleetmap demo` flies the first
/// kind of the registry unless another kind's flags choose that kind ([`DemoKind::chosen`]).
pub(crate) trait DemoKind: RunKind {
    /// The kind's own flags of `fleetmap demo`.
    type Flags: clap::Args + std::fmt::Debug + 'static;
    /// The simulated team's set-up, from [`DemoKind::plan`] to [`DemoKind::start`].
    type Team;
    /// The default run directory's name under `runs/`, before `-<Unix seconds>`.
    const RUN_DIR_PREFIX: &'static str;
    /// Whether `flags` choose this kind's demo.
    fn chosen(flags: &Self::Flags) -> bool;
    /// Why `flags` cannot be given when another kind's demo flies (`None`: they can).
    fn misplaced(flags: &Self::Flags) -> Option<String>;
    /// Check the arguments and decide what the demo flies: the world, the mission, the team.
    fn plan(args: &DemoInputs<'_>, flags: &Self::Flags) -> anyhow::Result<DemoPlan<Self::Team>>;
    /// Start the simulator with the team and a fleet connected to it.
    async fn start(team: Self::Team) -> Result<DemoTeam, SimStartError>;
    /// The run's settings, the simulator started.
    fn settings(args: &DemoInputs<'_>, team: &DemoTeam) -> RunSettings;
    /// The report's lines printed at the end, headless.
    fn summary(report: &Self::Report) -> Vec<String>;
    /// Whether the demo succeeded (headless: exit status 0).
    fn succeeded(outcome: &Outcome, report: &Self::Report) -> bool;
}

/// Work for the demo the flags choose: [`DemoVisitor::visit`] is called with its kind.
pub(crate) trait DemoVisitor {
    /// What the work returns.
    type Output;
    /// Do the work for kind `K`, whose own flags are `flags`.
    fn visit<K: DemoKind>(self, flags: &K::Flags) -> Self::Output;
}

/// Every kind's demo flags, as one list ([`crate::kinds::DemoFlags`]: [`KindFlags`]
/// ending in [`NoFlags`]).
pub(crate) trait DemoFlagList: clap::Args + std::fmt::Debug {
    /// `v` with the first kind of the list whose flags choose it; `Err(v)` when none does.
    fn chosen<V: DemoVisitor>(&self, v: V) -> Result<V::Output, V>;
    /// Why a flag given cannot be when kind `flying` flies (the first kind that says so).
    fn misplaced(&self, flying: &str) -> Option<String>;
}

/// The end of the list: no flags.
#[derive(Debug)]
pub(crate) struct NoFlags;

impl clap::FromArgMatches for NoFlags {
    fn from_arg_matches(_: &clap::ArgMatches) -> Result<Self, clap::Error> {
        Ok(NoFlags)
    }
    fn update_from_arg_matches(&mut self, _: &clap::ArgMatches) -> Result<(), clap::Error> {
        Ok(())
    }
}

impl clap::Args for NoFlags {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        cmd
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        cmd
    }
}

impl DemoFlagList for NoFlags {
    fn chosen<V: DemoVisitor>(&self, v: V) -> Result<V::Output, V> {
        Err(v)
    }
    fn misplaced(&self, _: &str) -> Option<String> {
        None
    }
}

/// Kind `K`'s flags, then the rest of the list's.
pub(crate) struct KindFlags<K: DemoKind, R>(K::Flags, R);

impl<K: DemoKind, R: DemoFlagList> KindFlags<K, R> {
    /// `v` with the demo the flags choose: the first kind whose flags choose it, else `K`
    /// (the registry's first kind).
    pub(crate) fn visit<V: DemoVisitor>(&self, v: V) -> V::Output {
        match self.chosen(v) {
            Ok(out) => out,
            Err(v) => v.visit::<K>(&self.0),
        }
    }
}

impl<K: DemoKind, R: std::fmt::Debug> std::fmt::Debug for KindFlags<K, R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple(K::KIND).field(&self.0).finish()?;
        write!(f, ", ")?;
        self.1.fmt(f)
    }
}

impl<K: DemoKind, R: clap::FromArgMatches> clap::FromArgMatches for KindFlags<K, R> {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        Self::from_arg_matches_mut(&mut m.clone())
    }
    fn from_arg_matches_mut(m: &mut clap::ArgMatches) -> Result<Self, clap::Error> {
        Ok(KindFlags(
            K::Flags::from_arg_matches_mut(m)?,
            R::from_arg_matches_mut(m)?,
        ))
    }
    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        self.update_from_arg_matches_mut(&mut m.clone())
    }
    fn update_from_arg_matches_mut(&mut self, m: &mut clap::ArgMatches) -> Result<(), clap::Error> {
        self.0.update_from_arg_matches_mut(m)?;
        self.1.update_from_arg_matches_mut(m)
    }
}

impl<K: DemoKind, R: clap::Args> clap::Args for KindFlags<K, R> {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        R::augment_args(K::Flags::augment_args(cmd))
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        R::augment_args_for_update(K::Flags::augment_args_for_update(cmd))
    }
}

impl<K: DemoKind, R: DemoFlagList> DemoFlagList for KindFlags<K, R> {
    fn chosen<V: DemoVisitor>(&self, v: V) -> Result<V::Output, V> {
        if K::chosen(&self.0) {
            Ok(v.visit::<K>(&self.0))
        } else {
            self.1.chosen(v)
        }
    }
    fn misplaced(&self, flying: &str) -> Option<String> {
        let here = if K::KIND == flying {
            None
        } else {
            K::misplaced(&self.0)
        };
        here.or_else(|| self.1.misplaced(flying))
    }
}
