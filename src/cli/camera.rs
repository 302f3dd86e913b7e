//! `fleetmap camera`: a MAVLink camera component for a companion computer next to an
//! autopilot. It speaks the MAVLink camera protocol as the vehicle's component 100 (HEARTBEAT
//! as MAV_TYPE_CAMERA, CAMERA_INFORMATION, MAV_CMD_IMAGE_START_CAPTURE / _STOP_CAPTURE), takes
//! a picture whenever the autopilot fires its shutter (ArduPilot's CAMERA_FEEDBACK, PX4's
//! CAMERA_TRIGGER) or a GCS asks, stamps it with the autopilot's pose (GLOBAL_POSITION_INT
//! and ATTITUDE, asked for as a GCS asks), and sends CAMERA_IMAGE_CAPTURED.
//!
//! With `--mission`, it measures every picture on board with the same vision code as the GCS
//! and sends the result in a DEBUG_FLOAT_ARRAY instead of the picture, which it keeps and
//! sends when a GCS asks for it (image transmission's request form, paced to
//! `--image-rate`): a spatial-classification mission's green share
//! ([`fleetmap_core::vision::onboard`], 52 bytes) or a runway mission's cell and 3 × 3 regions
//! ([`fleetmap_core::vision::onboard_runway`], 84 bytes; with `origin = "vehicle"` the grid
//! comes from the GCS when the run starts). Without, it pushes every picture by MAVLink
//! image transmission, paced to `--image-rate`.
//!
//! Sources: `render` draws the picture from a world file at the reported pose (what
//! `fleetmap sim --camera-only` has always done, for SITL); `folder:DIR` takes each shot's
//! picture from a folder a real camera writes into ([`fleetmap_io::files::pictures`]).

use anyhow::{Context, bail};
use clap::Args;
use fleetmap_core::vision::onboard::OnboardSpec;
use fleetmap_sim::camera::CameraConfig;
use fleetmap_sim::paired::PairedCameras;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;
use std::sync::Arc;
use std::time::Duration;

/// Where a camera's pictures come from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// Rendered from `--world` at the pose the autopilot reports (a camera for SITL).
    Render,
    /// Taken from a folder a camera writes into: each shot takes the oldest picture not used
    /// yet.
    Folder(PathBuf),
}

/// A `--source` that is neither `render` nor `folder:DIR` (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown picture source {0:?}: expected `render` or `folder:DIR`")]
pub struct UnknownSource(pub String);

impl FromStr for Source {
    type Err = UnknownSource;

    fn from_str(s: &str) -> Result<Source, UnknownSource> {
        match s.split_once(':') {
            _ if s == "render" => Ok(Source::Render),
            Some(("folder", dir)) if !dir.is_empty() => Ok(Source::Folder(PathBuf::from(dir))),
            _ => Err(UnknownSource(s.to_string())),
        }
    }
}

/// Arguments of `fleetmap camera`.
#[derive(Debug, Args)]
pub struct CameraArgs {
    /// Where the autopilot is: its companion-computer port, e.g. `udpin:0.0.0.0:14552`
    /// where an ArduPilot SERIALn / PX4 MAVLink instance sends, `udpout:HOST:PORT`, or
    /// `tcpin:HOST:PORT`. Every autopilot heard there gets a camera (system id = the
    /// autopilot's). A serial port: put mavlink-router or MAVProxy in between.
    #[arg(long)]
    pub connect: String,
    /// Where pictures come from: `render` (drawn from --world at the autopilot's pose: a
    /// camera for SITL) or `folder:DIR` (a folder a real camera writes into; each shot takes
    /// the oldest picture not used yet, waiting up to --wait-ms for one).
    #[arg(long, value_name = "render|folder:DIR")]
    pub source: Source,
    /// World file to render (with `--source render`).
    #[arg(long)]
    pub world: Option<PathBuf>,
    /// Measure every picture on board with this mission file's definition and send the
    /// result instead of the picture: a spatial-classification mission's green share (its
    /// green box, camera, cell size; 52 bytes) or a runway mission's cell and five region
    /// counts (its threshold, dilations, black fraction, camera and grid; 84 bytes — with
    /// `origin = "vehicle"` the GCS tells the grid when the run starts). The picture is sent
    /// when the GCS asks for it. The GCS uses the result when its mission measures the same
    /// way, and asks for the picture otherwise.
    #[arg(long, value_name = "FILE")]
    pub mission: Option<PathBuf>,
    /// Also push every picture by image transmission when measuring on board.
    #[arg(long)]
    pub(crate) push_pictures: bool,
    /// Never push pictures by image transmission (only --image-dir files, or on request).
    #[arg(long)]
    pub(crate) no_image_transfer: bool,
    /// Write the pictures here (and announce their file:// URLs).
    #[arg(long)]
    pub image_dir: Option<PathBuf>,
    /// Bytes per second of MAVLink 2 frames the image transmission may use (0: no pacing).
    /// The pictures go through the autopilot, which drops what its ports cannot take.
    #[arg(long, value_name = "BYTES_PER_S", default_value_t = 20_000)]
    pub(crate) image_rate: u32,
    /// With `--source folder`: how long a shot waits for a new picture, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 1000)]
    pub(crate) wait_ms: u64,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Seed of the rendered pictures' disturbances.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A degraded rendered sensor (see `fleetmap sim --sensor-flip`).
    #[command(flatten)]
    pub sensor: SensorArgs,
}

/// `--sensor-flip P`, shared by `fleetmap camera`, `fleetmap sim` and `fleetmap demo --bandit`.
#[derive(Debug, Clone, Args)]
pub struct SensorArgs {
    /// A degraded sensor: each camera image, independently with probability P (0 ≤ P < 0.5),
    /// shows the other class of tile — green tiles drawn grey and grey ones green — as the
    /// bandit paper's degraded-sensor hardware run (§V) added 5 % classification noise
    /// (`--sensor-flip 0.05`); the GCS is unchanged. 0: no image is flipped. In `fleetmap
    /// demo`, only with --bandit.
    #[arg(
        long = "sensor-flip",
        value_name = "P",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub flip: f64,
}

impl SensorArgs {
    /// The flip probability, checked: at least 0 and below 0.5 (at 0.5 an image says nothing
    /// about its cell; above, the sensor would be a better one with its classes swapped).
    pub(crate) fn probability(&self) -> anyhow::Result<f64> {
        let p = self.flip;
        if !(p.is_finite() && (0.0..0.5).contains(&p)) {
            bail!("--sensor-flip must be a probability at least 0 and below 0.5 (got {p})");
        }
        Ok(p)
    }
}

/// The on-board measurement definition of the mission file at `path`: a spatial-classification
/// mission's green share or a runway mission's regions. An error for a file that cannot be
/// read or is not a valid mission, and for a runway mission whose region moves (its pictures
/// are credited in the region's frame, which the camera cannot follow: they stay on the
/// picture path).
pub fn onboard_spec(path: &Path) -> anyhow::Result<OnboardSpec> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let def =
        fleetmap_core::mission::definition::MissionDef::parse(&text, &path.display().to_string())
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    if let Some(green) = crate::app::bandit::green_spec_of(&def) {
        return Ok(OnboardSpec::Green(green));
    }
    if def
        .runway
        .as_ref()
        .is_some_and(|r| r.roi_velocity_ne_mps.is_some_and(|v| v != [0.0, 0.0]))
    {
        bail!(
            "{}: the region moves (runway.roi_velocity_ne_mps): its pictures are classified by \
             the GCS in the region's frame; start the camera without --mission",
            path.display()
        );
    }
    crate::app::runway::runway_definition_of(&def)
        .map(OnboardSpec::Runway)
        .with_context(|| format!("{}: nothing to measure on board", path.display()))
}

/// Run `fleetmap camera`.
pub fn run(args: CameraArgs) -> anyhow::Result<ExitCode> {
    let endpoint = fleetmap_sim::server::parse_connection(&args.connect)?;
    let onboard = args.mission.as_deref().map(onboard_spec).transpose()?;
    let mut cfg = CameraConfig {
        mavlink_transfer: (onboard.is_none() || args.push_pictures) && !args.no_image_transfer,
        // 0 = one burst per image, as the embedded simulator's cameras send
        transfer_rate_bps: (args.image_rate > 0).then_some(f64::from(args.image_rate)),
        misclassify_probability: args.sensor.probability()?,
        onboard,
        ..CameraConfig::default()
    };
    if let Some(d) = &args.image_dir {
        std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
        cfg.file_dir = Some(
            d.canonicalize()
                .with_context(|| format!("cannot resolve {}", d.display()))?
                .display()
                .to_string(),
        );
    }
    let (cams, folder) = match &args.source {
        Source::Render => {
            let Some(world) = &args.world else {
                bail!("--source render needs --world");
            };
            let world = Arc::new(fleetmap_io::files::load_world(world)?);
            (PairedCameras::new(world, cfg, args.seed), None)
        }
        Source::Folder(dir) => {
            let f = fleetmap_io::files::pictures::FolderSource::new(
                dir,
                Duration::from_millis(args.wait_ms),
            )?;
            (PairedCameras::external(cfg, args.seed), Some(f))
        }
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    rt.block_on(fleetmap_sim::server::serve_paired(
        cams,
        folder,
        endpoint,
        args.image_dir.clone(),
        args.duration,
        |bound| {
            for b in bound {
                println!("camera listening on {} (local {})", b.endpoint, b.local);
            }
            use std::io::Write;
            let _ = std::io::stdout().flush();
        },
        async {
            let _ = tokio::signal::ctrl_c().await;
        },
    ))?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_parse() {
        assert_eq!("render".parse::<Source>(), Ok(Source::Render));
        assert_eq!(
            "folder:/media/cam".parse::<Source>(),
            Ok(Source::Folder("/media/cam".into()))
        );
        assert!("folder:".parse::<Source>().is_err());
        assert!("v4l2:/dev/video0".parse::<Source>().is_err());
    }
}
