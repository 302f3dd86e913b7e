//! `fleetmap sim …`: serve simulated ArduPilot / PX4 copters and rovers over MAVLink.

use anyhow::{Context, bail};
use clap::Args;
use fleetmap_core::time::Time;
use fleetmap_core::world::Wind;
use fleetmap_io::clock::SimTime;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::pace::Speed;
use fleetmap_sim::server::{GcsClock, ServeOptions, parse_connection, serve};
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `fleetmap sim`.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// Vehicles, e.g. `3xcopter:ardupilot,1xrover:ardupilot`; vehicle k gets system id k.
    #[arg(long, default_value = "1xcopter:ardupilot")]
    pub vehicles: String,
    /// Give vehicle K system id ID instead of K (`--sysid 2=1`), also an id another vehicle
    /// has: two autopilots left at the same SYSID_THISMAV, as two SITLs sending to one GCS
    /// port. Repeatable.
    #[arg(long = "sysid", value_name = "K=ID")]
    pub(crate) sysids: Vec<String>,
    /// Set parameter NAME of vehicle K to VALUE over its autopilot's defaults
    /// (`--param 1:MAV_OPTIONS=1`): what a ground station reads with PARAM_REQUEST_READ, and
    /// for ArduPilot's MAV_OPTIONS / MAV_GCS_SYSID which ground station it obeys. Repeatable.
    #[arg(long = "param", value_name = "K:NAME=VALUE")]
    pub(crate) params: Vec<String>,
    /// Vehicle K has no camera component (a drone whose camera is off). Repeatable.
    #[arg(long = "no-camera", value_name = "K")]
    pub(crate) no_camera: Vec<usize>,
    /// Where to serve them: `udpout:HOST:PORT` or `udp:HOST:PORT` (each vehicle from its own
    /// socket), `udpin:HOST:PORT` / `tcpin:HOST:PORT` (vehicle k on PORT+k−1); repeat once
    /// per vehicle for explicit endpoints.
    #[arg(long, required = true)]
    pub connect: Vec<String>,
    /// World file (ground truth and default homes), e.g. assets/worlds/runway.toml.
    #[arg(long)]
    pub world: Option<PathBuf>,
    /// Home of vehicle 1 as LAT,LON (the others 3 m east of each other); overrides the
    /// world's homes.
    #[arg(long, value_name = "LAT,LON", allow_hyphen_values = true)]
    pub home: Option<String>,
    /// The most simulated seconds per wall second, or `max` (as fast as this machine can).
    /// The simulator runs in lock-step, as SITL does: on a busy machine it runs slower than
    /// asked rather than skipping ahead; it prints the speed it achieves every 10 s.
    #[arg(long, value_name = "N|max", default_value = "1")]
    pub speedup: Speed,
    /// Faults of every vehicle's link, each way.
    #[command(flatten)]
    pub faults: crate::cli::relay::FaultArgs,
    /// The simulated crew: swap the battery this many seconds after a vehicle is landed and
    /// disarmed with a used battery (it then reboots, as a power-cycled autopilot does).
    /// Without it nobody swaps: the vehicle keeps its battery (no GCS command swaps one).
    #[arg(long, value_name = "SECONDS")]
    pub(crate) swap_after: Option<f64>,
    /// Minutes of hover on a full copter battery.
    #[arg(long, default_value_t = 12.0)]
    pub battery_minutes: f64,
    /// Minutes a copter battery takes to charge from empty on a charging station (a rover
    /// it has landed on).
    #[arg(long, value_name = "MIN", default_value_t = 30.0)]
    pub charge_minutes: f64,
    /// Side of the (square) camera images, pixels: the paper's camera has 480; fewer render
    /// faster with the same field of view.
    #[arg(long, value_name = "PX", default_value_t = 480)]
    pub camera_px: u32,
    /// The simulated cameras' sensor.
    #[command(flatten)]
    pub sensor: fleetmap_camera::cli::SensorArgs,
    /// Battery level (percent) that triggers the failsafe RTL (default: the autopilot's).
    #[arg(long, value_name = "PCT")]
    pub(crate) low_battery: Option<f64>,
    /// Wind as SPEED@FROM (m/s, degrees the wind blows from), e.g. 3.6@270.
    #[arg(long, value_name = "SPEED@FROM", allow_hyphen_values = true)]
    pub wind: Option<String>,
    /// Write camera images here and announce their file:// URLs in CAMERA_IMAGE_CAPTURED.
    #[arg(long)]
    pub image_dir: Option<PathBuf>,
    /// Do not push images over MAVLink image transmission.
    #[arg(long)]
    pub(crate) no_image_transfer: bool,
    /// The cameras measure every picture on board with this mission file's definition (a
    /// spatial-classification mission's green share, or a runway mission's 3 × 3 regions)
    /// and send the result instead of the picture, as `fleetmap camera --mission` does; the
    /// picture is sent when the GCS asks.
    #[arg(long, value_name = "FILE")]
    pub(crate) camera_mission: Option<PathBuf>,
    /// Stop after this many simulated seconds.
    #[arg(long)]
    pub duration: Option<f64>,
    /// MAVLink 2 signing key file (as `fleetmap signing` / MAVProxy write it): vehicles sign
    /// what they send and ignore unsigned frames.
    #[arg(long, value_name = "FILE")]
    pub signing_key: Option<PathBuf>,
    /// Seed of every random process (same seed, same run).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the endpoints as one JSON object per line.
    #[arg(long)]
    pub json: bool,
    /// Simulate only the cameras, for the real autopilots (SITL) heard on --connect (e.g.
    /// `udpin:0.0.0.0:14552` where the SITL sends): a picture the autopilot takes
    /// (CAMERA_FEEDBACK, CAMERA_TRIGGER, IMAGE_START_CAPTURE to component 100) is rendered
    /// from --world at the autopilot's reported pose. The cameras ask each autopilot for
    /// GLOBAL_POSITION_INT and ATTITUDE at 10 Hz (ArduCopter sends nothing on a serial port
    /// until asked) and refuse a capture while the last position is over 0.5 s old
    /// (IMAGE_START_CAPTURE answered TEMPORARILY_REJECTED, a STATUSTEXT says why);
    /// CAMERA_FEEDBACK brings its own pose and is always rendered. Images go to --image-dir
    /// and, unless --no-image-transfer, over MAVLink paced by --image-rate. --vehicles is
    /// ignored.
    #[arg(long)]
    pub(crate) camera_only: bool,
    /// With --camera-only: bytes per second of MAVLink 2 frames (267 per ENCAPSULATED_DATA)
    /// the image transmission may use; 0 sends each image in one burst. The images go
    /// through the autopilot, which drops a forwarded frame when the outgoing port's buffer
    /// is full (ArduPilot MAVLink_routing): a 60–100 KB picture sent in one burst lost ~40 %
    /// of its packets through ArduCopter SITL. 20 000 B/s is 75 frames/s; a 480-px picture
    /// of the runway world (≈ 120 KB at quality 85) takes about 6 s. It is a chosen figure,
    /// not one measured against SITL: SITL's network serial ports read one UDP datagram and
    /// move at most 10 000 bytes per I/O tick (AP_HAL_SITL UARTDriver), so 75 datagrams/s
    /// stays far below what they take, and it leaves room for the telemetry on the port the
    /// GCS uses. A 57600-baud radio carries ~5 KB/s in all: use 3000 there.
    #[arg(long, value_name = "BYTES_PER_S", default_value_t = 20_000)]
    pub(crate) image_rate: u32,
    /// Every vehicle behind its own simulated telemetry radio, counted in simulated time.
    #[command(flatten)]
    pub(crate) radio: crate::cli::demo::RadioArgs,
    /// A scheduled fault, `TARGET:FAULT[@START[..END]]` (repeatable, or comma-separated):
    /// TARGET a vehicle number or `all`; FAULT `outage`, `battery=PERCENT`, `camera=off`,
    /// `camera-rate=BYTES_PER_S`, `camera-interval=SECONDS` or `stuck`; times in simulated
    /// seconds (`300s`, `5m`). E.g. `2:battery=20@300s`, `all:outage@120s..420s`
    /// (docs/simulator.md, "Scheduled faults").
    #[arg(long = "fault", value_name = "SPEC")]
    pub(crate) scheduled_faults: Vec<String>,
}

fn parse_pair(s: &str, what: &str) -> anyhow::Result<(f64, f64)> {
    let (a, b) = s
        .split_once([',', '@'])
        .with_context(|| format!("{what}: expected two numbers, got {s:?}"))?;
    let a: f64 = a
        .trim()
        .parse()
        .with_context(|| format!("{what}: {a:?} is not a number"))?;
    let b: f64 = b
        .trim()
        .parse()
        .with_context(|| format!("{what}: {b:?} is not a number"))?;
    if !a.is_finite() || !b.is_finite() {
        bail!("{what}: numbers must be finite");
    }
    Ok((a, b))
}

/// Build the simulation `fleetmap sim` would serve (also used by tests).
pub fn build(args: &SimArgs) -> anyhow::Result<SimConfig> {
    let world = match &args.world {
        Some(p) => Some(fleetmap_io::files::load_world(p)?),
        None => None,
    };
    let home = match &args.home {
        Some(h) => {
            let (lat, lon) = parse_pair(h, "--home")?;
            if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
                bail!("--home: {lat},{lon} is not a valid position");
            }
            Some((lat, lon))
        }
        None => None,
    };
    if !(args.battery_minutes.is_finite() && args.battery_minutes > 0.0) {
        bail!("--battery-minutes must be positive");
    }
    if !(args.charge_minutes.is_finite() && args.charge_minutes > 0.0) {
        bail!("--charge-minutes must be positive");
    }
    if !(8..=4096).contains(&args.camera_px) {
        bail!("--camera-px must be between 8 and 4096");
    }
    let sensor_flip = args.sensor.probability()?;
    let mut cfg = SimConfig::from_spec(&args.vehicles, world, home, args.seed)?
        .with_scheduled_faults(crate::cli::demo::fault_schedule(&args.scheduled_faults)?);
    for s in &args.sysids {
        let parsed = s.split_once('=').and_then(|(k, id)| {
            Some((
                k.trim().parse::<usize>().ok()?,
                id.trim().parse::<u8>().ok()?,
            ))
        });
        match parsed {
            Some((k, id)) if id > 0 => cfg = cfg.with_sysid(k, id)?,
            _ => bail!("--sysid {s:?}: give VEHICLE=ID, e.g. 2=1 (ID 1–255)"),
        }
    }
    for s in &args.params {
        let parsed = s.split_once(':').and_then(|(k, kv)| {
            let (name, value) = kv.split_once('=')?;
            Some((
                k.trim().parse::<usize>().ok()?,
                name.trim().to_string(),
                value.trim().parse::<f32>().ok()?,
            ))
        });
        match parsed {
            Some((k, name, value))
                if (1..=cfg.vehicles.len()).contains(&k)
                    && !name.is_empty()
                    && name.len() <= 16
                    && value.is_finite() =>
            {
                cfg.vehicles[k - 1].params.push((name, value));
            }
            _ => bail!(
                "--param {s:?}: give VEHICLE:NAME=VALUE, e.g. 1:MAV_OPTIONS=1 (vehicle 1–{}, \
                 a name of at most 16 characters)",
                cfg.vehicles.len()
            ),
        }
    }
    for &k in &args.no_camera {
        match cfg.vehicles.get_mut(k.wrapping_sub(1)) {
            Some(v) => v.camera = None,
            None => bail!("--no-camera {k}: no vehicle {k}"),
        }
    }
    let faults = args.faults.faults()?;
    cfg = cfg.with_faults(faults);
    if let Some(r) = args.radio.config()? {
        cfg = cfg.with_radio(r);
    }
    if let Some(k) = &args.signing_key {
        cfg.signing_key = Some(fleetmap_io::link::signing::SigningKey::read(k)?);
    }
    // signature timestamps follow the wall clock when serving sockets
    cfg.unix_epoch_us = match fleetmap_io::clock::unix_us() {
        0 => fleetmap_sim::harness::DEFAULT_EPOCH_US, // a clock before 1970
        us => us,
    };
    if let Some(w) = &args.wind {
        let (speed, from) = parse_pair(w, "--wind")?;
        if speed < 0.0 {
            bail!("--wind: speed must be ≥ 0");
        }
        cfg = cfg.with_wind(Some(Wind {
            speed_mps: speed,
            from_deg: from,
        }));
    }
    let image_dir = match &args.image_dir {
        Some(d) => {
            std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
            Some(
                d.canonicalize()
                    .with_context(|| format!("cannot resolve {}", d.display()))?,
            )
        }
        None => None,
    };
    let onboard = args
        .camera_mission
        .as_deref()
        .map(fleetmap_camera::mission::onboard_spec)
        .transpose()?;
    for v in &mut cfg.vehicles {
        if v.flavour.is_copter() {
            v.battery.minutes = args.battery_minutes;
            v.battery.charge_minutes = args.charge_minutes;
        }
        if let Some(p) = args.low_battery {
            if !(0.0..100.0).contains(&p) {
                bail!("--low-battery must be between 0 and 100");
            }
            v.failsafe.rtl_pct = p;
            v.failsafe.land_pct = v.failsafe.land_pct.min(p / 2.0);
        }
        v.swap_after_s = args.swap_after;
        if let Some(c) = v.camera.as_mut() {
            c.model.width_px = args.camera_px;
            c.model.height_px = args.camera_px;
            c.mavlink_transfer = !args.no_image_transfer;
            c.onboard = onboard.clone();
            c.file_dir = image_dir.as_ref().map(|d| d.display().to_string());
            c.misclassify_probability = sensor_flip;
        }
    }
    Ok(cfg)
}

/// `fleetmap sim --camera-only`: `fleetmap camera --source render` for the one endpoint.
fn run_camera_only(args: SimArgs) -> anyhow::Result<ExitCode> {
    let [connect] = <[String; 1]>::try_from(args.connect)
        .map_err(|_| anyhow::anyhow!("--camera-only takes one --connect endpoint"))?;
    if args.world.is_none() {
        bail!("--camera-only needs --world");
    }
    if !args.scheduled_faults.is_empty() {
        bail!("--fault is for the simulated vehicles; --camera-only simulates none");
    }
    fleetmap_camera::cli::run(fleetmap_camera::cli::CameraArgs {
        connect,
        source: fleetmap_camera::source::SourceSpec::Render,
        world: args.world,
        mission: args.camera_mission,
        push_pictures: false,
        image_dir: args.image_dir,
        no_image_transfer: args.no_image_transfer,
        image_rate: args.image_rate,
        wait_ms: 0,
        command_timeout_ms: 0,
        duration: args.duration,
        seed: args.seed,
        sensor: args.sensor,
    })
}

/// Run `fleetmap sim`.
pub fn run(args: SimArgs) -> anyhow::Result<ExitCode> {
    let endpoints = args
        .connect
        .iter()
        .map(|c| parse_connection(c))
        .collect::<Result<Vec<_>, _>>()?;
    if args.camera_only {
        return run_camera_only(args);
    }
    let cfg = build(&args)?;
    let descr: Vec<String> = cfg
        .vehicles
        .iter()
        .map(|v| format!("{} at {:.7},{:.7}", v.flavour, v.start.0, v.start.1))
        .collect();
    let sim = Sim::new(cfg, Time::ZERO)?;
    let opts = ServeOptions {
        endpoints,
        speed: args.speedup,
        // the GCS is another process, on the wall clock: PX4's GCS-link timeouts are
        // judged over as many more simulated seconds as the simulator achieves per second
        gcs: GcsClock::Wall,
        image_dir: args.image_dir.clone(),
        duration_s: args.duration,
    };
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let json = args.json;
    let started = std::time::Instant::now();
    let mut served_time = None;
    rt.block_on(async {
        let shutdown = async {
            let _ = tokio::signal::ctrl_c().await;
        };
        serve(
            sim,
            opts,
            |bound, time| {
                served_time = Some(time.clone());
                tokio::spawn(report_speed(time.clone(), json));
                for (b, d) in bound.iter().zip(&descr) {
                    if json {
                        println!(
                            "{}",
                            serde_json::json!({
                                "sysid": b.sysid,
                                "vehicle": d,
                                "endpoint": b.endpoint.to_string(),
                                "local": b.local.to_string(),
                            })
                        );
                    } else {
                        println!(
                            "vehicle {} ({d}) on {} (local {})",
                            b.sysid, b.endpoint, b.local
                        );
                    }
                }
                use std::io::Write;
                let _ = std::io::stdout().flush();
            },
            shutdown,
        )
        .await
    })?;
    if let Some(time) = served_time {
        // the whole run's speed
        let (sim_s, wall_s) = (time.now().as_secs_f64(), started.elapsed().as_secs_f64());
        let speed = if wall_s > 0.0 { sim_s / wall_s } else { 0.0 };
        speed_line(sim_s, speed, time.ceiling(), Some(wall_s), json);
    }
    Ok(ExitCode::SUCCESS)
}

/// The speed achieved, as `fleetmap sim` prints it: a line of text, or with `--json` an
/// object `{"sim_time_s", "speed", "speedup"}` (`speedup`: the ceiling asked, `null` for
/// `max`), with `"wall_s"` for the whole run at its end (`wall_s` given).
fn speed_line(sim_s: f64, speed: f64, ceiling: Option<f64>, wall_s: Option<f64>, json: bool) {
    let round = |x: f64, k: f64| (x * k).round() / k;
    if json {
        let mut o = serde_json::json!({
            "sim_time_s": round(sim_s, 1000.0),
            "speed": round(speed, 100.0),
            "speedup": ceiling,
        });
        if let (Some(w), Some(m)) = (wall_s, o.as_object_mut()) {
            m.insert("wall_s".into(), round(w, 1000.0).into());
        }
        println!("{o}");
    } else {
        let asked = ceiling.map_or("max".to_string(), |c| format!("{c}×"));
        match wall_s {
            Some(w) => println!(
                "simulator: {sim_s:.1} s simulated in {w:.1} s of wall time, {speed:.1}× \
                 ({asked} asked)"
            ),
            None => println!(
                "simulator: {sim_s:.1} s simulated, running at {speed:.1}× ({asked} asked)"
            ),
        }
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
}

/// How often `fleetmap sim` prints the speed it achieves, wall time.
const SPEED_REPORT: std::time::Duration = std::time::Duration::from_secs(10);

/// Print the simulator's speed over the last seconds every [`SPEED_REPORT`] ([`speed_line`]).
async fn report_speed(time: SimTime, json: bool) {
    let mut tick = tokio::time::interval(SPEED_REPORT);
    tick.tick().await;
    loop {
        tick.tick().await;
        if let Some(speed) = time.achieved() {
            speed_line(time.now().as_secs_f64(), speed, time.ceiling(), None, json);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::cli::{Cli, Command};
    use clap::Parser;

    /// Coordinates as people type them: a negative latitude as its own argument
    /// (`--home -35.36,149.16`), not only `--home=-35.36,…`.
    #[test]
    fn negative_coordinates_parse_as_their_own_argument() {
        let cli = Cli::try_parse_from([
            "fleetmap",
            "sim",
            "--connect",
            "udpout:127.0.0.1:14550",
            "--home",
            "-35.363261,149.165230",
            "--wind",
            "3.6@-90",
        ])
        .unwrap_or_else(|e| panic!("{e}"));
        let Command::Sim(args) = cli.command else {
            panic!("not sim")
        };
        assert_eq!(args.home.as_deref(), Some("-35.363261,149.165230"));
        let cfg = super::build(&args).unwrap();
        let (lat, lon) = cfg.vehicles[0].start;
        assert!((lat + 35.363261).abs() < 1e-9 && (lon - 149.165230).abs() < 1e-9);
    }

    fn parse(extra: &[&str]) -> anyhow::Result<Command> {
        let mut argv = vec!["fleetmap"];
        argv.extend(extra);
        Ok(Cli::try_parse_from(argv)?.command)
    }

    /// `--sensor-flip P` reaches every camera of `fleetmap sim` (default 0); P must be a
    /// probability below 0.5, for `fleetmap sim` and `fleetmap demo --bandit` alike, and the
    /// runway demo has no use for it.
    #[test]
    fn sensor_flip_reaches_every_camera_and_is_checked() {
        let sim = |flip: &str| -> anyhow::Result<fleetmap_sim::harness::SimConfig> {
            let Command::Sim(args) = parse(&[
                "sim",
                "--connect",
                "udpout:127.0.0.1:14550",
                "--vehicles",
                "2xcopter:ardupilot",
                "--home",
                "37.0,-80.0",
                "--sensor-flip",
                flip,
            ])?
            else {
                panic!("not sim")
            };
            super::build(&args)
        };
        let cfg = sim("0.05").unwrap();
        let cams: Vec<f64> = cfg
            .vehicles
            .iter()
            .filter_map(|v| v.camera.as_ref().map(|c| c.misclassify_probability))
            .collect();
        assert_eq!(cams, vec![0.05, 0.05]);
        let cfg = sim("0").unwrap();
        assert!(
            cfg.vehicles
                .iter()
                .filter_map(|v| v.camera.as_ref())
                .all(|c| c.misclassify_probability == 0.0)
        );
        for bad in ["0.5", "0.7", "-0.01", "NaN", "inf"] {
            let e = sim(bad).expect_err(bad).to_string();
            assert!(
                e.contains("--sensor-flip must be a probability"),
                "{bad}: {e}"
            );
        }
        let demo = |argv: &[&str]| -> anyhow::Result<std::process::ExitCode> {
            let Command::Demo(args) = parse(argv)? else {
                panic!("not demo")
            };
            crate::cli::demo::run(args)
        };
        let e = demo(&["demo", "--bandit", "--headless", "--sensor-flip", "0.5"]).unwrap_err();
        assert!(
            e.to_string()
                .contains("--sensor-flip must be a probability"),
            "{e}"
        );
        let e = demo(&["demo", "--headless", "--sensor-flip", "0.05"]).unwrap_err();
        assert!(e.to_string().contains("--bandit"), "{e}");
    }
}
