//! The camera program's command line (`fleetmap-camera`, and `fleetmap camera` in the ground
//! station): a MAVLink camera component for a companion computer next to an autopilot. It
//! speaks the MAVLink camera protocol as the vehicle's component 100 (HEARTBEAT as
//! MAV_TYPE_CAMERA, CAMERA_INFORMATION, MAV_CMD_IMAGE_START_CAPTURE / _STOP_CAPTURE), takes a
//! picture whenever the autopilot fires its shutter (ArduPilot's CAMERA_FEEDBACK, PX4's
//! CAMERA_TRIGGER) or a GCS asks, stamps it with the autopilot's pose (GLOBAL_POSITION_INT
//! and ATTITUDE, asked for as a GCS asks), and sends CAMERA_IMAGE_CAPTURED.
//!
//! With `--mission`, it measures every picture on board with the same vision code as the GCS
//! and sends the result in a DEBUG_FLOAT_ARRAY instead of the picture, which it keeps and
//! sends when a GCS asks for it (image transmission's request form, paced to
//! `--image-rate`): a spatial-classification mission's green share
//! ([`fleetmap_core::vision::onboard`], 52 bytes) or a runway mission's cell and 3 × 3 regions
//! ([`fleetmap_core::vision::runway::onboard`], 84 bytes; with `origin = "vehicle"` the grid
//! comes from the GCS when the run starts). Without, it pushes every picture by MAVLink
//! image transmission, paced to `--image-rate`.
//!
//! Links: [`crate::serve`]. Sources: [`crate::source`].

use crate::camera::CameraConfig;
use crate::paired::PairedCameras;
use crate::source::{PictureSource, SourceSpec};
use anyhow::{Context, bail};
use clap::Args;
use fleetmap_io::link::{ConnSpec, ConnSpecError};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of the camera program.
#[derive(Debug, Args)]
pub struct CameraArgs {
    /// Where the autopilot is: a serial port wired to its TELEM port,
    /// `serial:/dev/ttyAMA0:921600` (a Raspberry Pi's UART); `udpin:0.0.0.0:14552` where an
    /// ArduPilot SERIALn / PX4 MAVLink instance (or mavlink-router) sends; `udp:HOST:PORT` /
    /// `udpout:HOST:PORT` to send to it; `tcp:HOST:PORT` or `tcpin:HOST:PORT`. Every
    /// autopilot heard there gets a camera (system id = the autopilot's).
    #[arg(long)]
    pub connect: String,
    /// Where pictures come from: `folder:DIR` (a folder a camera writes into; each shot takes
    /// the oldest picture not used yet, waiting up to --wait-ms for one), `command:CMD` (run
    /// `sh -c CMD` per shot, `{out}` replaced by the file it must write, e.g.
    /// `command:libcamera-still -n -o {out}`; killed after --command-timeout-ms),
    /// `v4l2:DEVICE` (a frame from a V4L2 camera; built with the `v4l2` feature) or `render`
    /// (drawn from --world at the autopilot's pose: a camera for SITL; built with `render`).
    #[arg(long, value_name = "folder:DIR|command:CMD|v4l2:DEVICE|render")]
    pub source: SourceSpec,
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
    pub push_pictures: bool,
    /// Never push pictures by image transmission (only --image-dir files, or on request).
    #[arg(long)]
    pub no_image_transfer: bool,
    /// Write the pictures here (and announce their file:// URLs).
    #[arg(long)]
    pub image_dir: Option<PathBuf>,
    /// Bytes per second of MAVLink 2 frames the image transmission may use (0: no pacing).
    /// The pictures go through the autopilot, which drops what its ports cannot take.
    #[arg(long, value_name = "BYTES_PER_S", default_value_t = 20_000)]
    pub image_rate: u32,
    /// With `--source folder`: how long a shot waits for a new picture, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 1000)]
    pub wait_ms: u64,
    /// With `--source command`: how long the command may run per shot before it is killed
    /// and the capture fails, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 10_000)]
    pub command_timeout_ms: u64,
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

/// `--sensor-flip P`, shared by the camera program, `fleetmap sim` and `fleetmap demo --bandit`.
#[derive(Debug, Clone, Args)]
pub struct SensorArgs {
    /// A degraded sensor: each rendered image, independently with probability P
    /// (0 ≤ P < 0.5), shows the other class of tile — green tiles drawn grey and grey ones
    /// green — as the bandit paper's degraded-sensor hardware run (§V) added 5 %
    /// classification noise (`--sensor-flip 0.05`); the GCS is unchanged. 0: no image is
    /// flipped. In `fleetmap demo`, only with --bandit.
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
    pub fn probability(&self) -> anyhow::Result<f64> {
        let p = self.flip;
        if !(p.is_finite() && (0.0..0.5).contains(&p)) {
            bail!("--sensor-flip must be a probability at least 0 and below 0.5 (got {p})");
        }
        Ok(p)
    }
}

/// A `--connect` string as a vehicle-side program reads it: the ground station's connection
/// strings ([`fleetmap_io::link::ConnSpec`]), except that `udp:HOST:PORT` sends to HOST:PORT
/// (udpout), as an autopilot's or a simulator's `--out` does.
pub fn parse_connect(s: &str) -> Result<ConnSpec, ConnSpecError> {
    let spec: ConnSpec = s.parse()?;
    let udp = s
        .split_once(':')
        .is_some_and(|(scheme, _)| scheme.eq_ignore_ascii_case("udp"));
    match spec {
        ConnSpec::UdpIn { host, port } if udp => {
            if port == 0 {
                return Err(ConnSpecError {
                    input: s.to_string(),
                    why: "udp (udpout) needs a non-zero port".into(),
                });
            }
            Ok(ConnSpec::UdpOut { host, port })
        }
        other => Ok(other),
    }
}

/// The cameras and the picture source `args` ask for.
fn cameras(
    args: &CameraArgs,
    cfg: CameraConfig,
) -> anyhow::Result<(PairedCameras, Option<PictureSource>)> {
    Ok(match &args.source {
        #[cfg(feature = "render")]
        SourceSpec::Render => {
            let Some(world) = &args.world else {
                bail!("--source render needs --world");
            };
            let world = std::sync::Arc::new(fleetmap_io::files::load_world(world)?);
            (PairedCameras::new(world, cfg, args.seed), None)
        }
        #[cfg(not(feature = "render"))]
        SourceSpec::Render => {
            bail!("this camera program was built without the renderer (cargo feature `render`)")
        }
        SourceSpec::Folder(dir) => {
            let f = fleetmap_io::files::pictures::FolderSource::new(
                dir,
                Duration::from_millis(args.wait_ms),
            )?;
            (
                PairedCameras::external(cfg, args.seed),
                Some(PictureSource::Folder(f)),
            )
        }
        SourceSpec::Command(cmd) => {
            let c = crate::source::command::CommandSource::new(
                cmd,
                &std::env::temp_dir(),
                Duration::from_millis(args.command_timeout_ms),
            )?;
            (
                PairedCameras::external(cfg, args.seed),
                Some(PictureSource::Command(c)),
            )
        }
        #[cfg(feature = "v4l2")]
        SourceSpec::V4l2(dev) => {
            let d = crate::source::v4l2::V4l2Source::open(dev)?;
            (
                PairedCameras::external(cfg, args.seed),
                Some(PictureSource::V4l2(d)),
            )
        }
        #[cfg(not(feature = "v4l2"))]
        SourceSpec::V4l2(_) => {
            bail!("this camera program was built without V4L2 support (cargo feature `v4l2`)")
        }
    })
}

/// Run the camera program.
pub fn run(args: CameraArgs) -> anyhow::Result<ExitCode> {
    let endpoint = parse_connect(&args.connect)?;
    let onboard = args
        .mission
        .as_deref()
        .map(crate::mission::onboard_spec)
        .transpose()?;
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
    let (cams, source) = cameras(&args, cfg)?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let served = rt.block_on(crate::serve::serve(
        cams,
        source,
        endpoint,
        args.image_dir.clone(),
        args.duration,
        |link| {
            match link.local {
                Some(local) => println!("camera listening on {} (local {local})", link.spec),
                None => println!("camera listening on {}", link.spec),
            }
            use std::io::Write;
            let _ = std::io::stdout().flush();
        },
        async {
            let _ = tokio::signal::ctrl_c().await;
        },
    ))?;
    for (sysid, n) in &served.pictures {
        tracing::info!("camera for vehicle {sysid}: {n} pictures");
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn udp_sends_and_serial_opens_a_port() {
        assert_eq!(
            parse_connect("udp:127.0.0.1:14550"),
            Ok(ConnSpec::UdpOut {
                host: "127.0.0.1".into(),
                port: 14550
            })
        );
        assert!(parse_connect("udp:127.0.0.1:0").is_err());
        assert_eq!(
            parse_connect("serial:/dev/ttyAMA0:921600"),
            Ok(ConnSpec::Serial {
                path: "/dev/ttyAMA0".into(),
                baud: 921_600
            })
        );
    }
}
