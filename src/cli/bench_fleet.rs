//! `fleetmap bench fleet`: the GCS's CPU time per vehicle, and the terminal UI's frame rate,
//! with N simulated ArduPilot copters streaming telemetry to one UDP port.
//!
//! This process runs the fleet (`udpin` on a free loopback port, the telemetry rates the UI
//! needs requested as for any vehicle) and the UI's model and render at its live cadence
//! ([`crate::tui::REFRESH`]) into an off-screen 160×50 terminal; the simulator runs as a
//! child process (`fleetmap sim`), so its CPU time is not counted. CPU time is this process's
//! user + system time from `/proc/self/stat` (Linux), in clock ticks of 1/100 s.

use crate::fleet::{self, FleetConfig, FleetHandle, VehicleSnapshot};
use crate::tui::UiConfig;
use crate::tui::live::{LiveLog, build_model};
use crate::tui::update;
use crate::tui::{App, Event};
use crate::tui::{REFRESH, view};
use anyhow::{Context, bail};
use clap::Args;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::transport::LinkOptions;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use std::path::Path;
use std::process::{Child, Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

/// Arguments of `fleetmap bench fleet`.
#[derive(Debug, Args)]
pub struct BenchFleetArgs {
    /// Simulated ArduPilot copters (system ids 1…N), all sending to one UDP port.
    #[arg(long, default_value_t = 50)]
    pub vehicles: u8,
    /// Length of the measurement, seconds of wall time (after every vehicle is ready).
    #[arg(long, default_value_t = 20.0)]
    pub seconds: f64,
    /// Give up when the vehicles do not all report battery, GPS fix and position within
    /// this many seconds of the simulator's start.
    #[arg(long, default_value_t = 60.0)]
    pub(crate) ready_timeout: f64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Columns × rows of the off-screen terminal the UI draws into.
const SCREEN: (u16, u16) = (160, 50);

/// Linux reports process times in clock ticks of 1/100 s (`USER_HZ`, `sysconf(_SC_CLK_TCK)`
/// on every mainstream architecture).
const TICKS_PER_SECOND: f64 = 100.0;

/// This process's CPU time so far (user + system, every thread), seconds, from fields 14
/// and 15 (`utime`, `stime`) of `/proc/self/stat`.
fn cpu_seconds() -> anyhow::Result<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat")
        .context("cannot read /proc/self/stat (the CPU measurement needs Linux)")?;
    // The command name (field 2) is in parentheses and may hold spaces: count after it.
    let rest = stat
        .rsplit_once(')')
        .map(|(_, r)| r)
        .context("/proc/self/stat: no ')' after the command name")?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // `rest` starts at field 3 (state): utime is field 14, stime field 15.
    let tick = |i: usize, what: &str| -> anyhow::Result<u64> {
        fields
            .get(i)
            .and_then(|f| f.parse::<u64>().ok())
            .with_context(|| format!("/proc/self/stat: no {what} field"))
    };
    let ticks = tick(11, "utime")? + tick(12, "stime")?;
    Ok(ticks as f64 / TICKS_PER_SECOND)
}

/// The simulator child: killed and reaped when dropped, whatever happened.
struct SimChild(Child);

impl SimChild {
    /// `Some(description)` when the child has exited.
    fn exited(&mut self) -> Option<String> {
        match self.0.try_wait() {
            Ok(Some(status)) => Some(status.to_string()),
            Ok(None) => None,
            Err(e) => Some(format!("cannot be waited for: {e}")),
        }
    }
}

impl Drop for SimChild {
    fn drop(&mut self) {
        // An error means it has already exited; wait() reaps it either way.
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn ready(v: &VehicleSnapshot) -> bool {
    v.battery_pct.is_some() && v.gps_fix.is_some_and(|f| f >= 3) && v.position.is_some()
}

/// Wait until vehicles 1…n all have battery, a 3D GPS fix and a position; returns how long
/// that took (wall time).
async fn wait_ready(
    fleet: &FleetHandle,
    n: u8,
    timeout: Duration,
    sim: &mut SimChild,
) -> anyhow::Result<Duration> {
    let start = Instant::now();
    let mut tick = tokio::time::interval(Duration::from_millis(200));
    loop {
        tick.tick().await;
        if let Some(status) = sim.exited() {
            bail!("the simulator exited ({status}) before its vehicles were ready");
        }
        let snap = fleet.snapshot();
        let vehicles: Vec<Option<&VehicleSnapshot>> =
            (1..=n).map(|id| snap.vehicles.get(&id)).collect();
        if vehicles.iter().all(|v| v.is_some_and(ready)) {
            return Ok(start.elapsed());
        }
        if start.elapsed() >= timeout {
            let count = |f: &dyn Fn(&VehicleSnapshot) -> bool| {
                vehicles.iter().filter(|v| v.is_some_and(f)).count()
            };
            bail!(
                "after {:.0} s only {} of {n} vehicles are ready: heard {}, battery {}, \
                 3D GPS fix {}, position {}",
                timeout.as_secs_f64(),
                count(&ready),
                count(&|_| true),
                count(&|v| v.battery_pct.is_some()),
                count(&|v| v.gps_fix.is_some_and(|f| f >= 3)),
                count(&|v| v.position.is_some()),
            );
        }
    }
}

/// What one measurement produced.
#[derive(Debug)]
struct Figures {
    ready_s: f64,
    wall_s: f64,
    cpu_s: f64,
    frames_in: u64,
    frames: usize,
    frame_mean_ms: f64,
    frame_max_ms: f64,
    frame_total_s: f64,
}

/// Start the fleet and the simulator, wait for the vehicles, measure.
async fn measure(args: &BenchFleetArgs, exe: &Path) -> anyhow::Result<Figures> {
    let spec: ConnSpec = "udpin:127.0.0.1:0"
        .parse()
        .context("the GCS connection string")?;
    let fleet = fleet::start(&[spec], &LinkOptions::default(), FleetConfig::default())
        .await
        .context("cannot open the GCS's UDP port")?;
    let link = fleet.links().first().context("the fleet has no link")?;
    let port = link
        .local
        .context("the GCS's UDP socket has no local address")?
        .port();
    // As the live UI does: a fresh snapshot for every frame.
    fleet
        .set_snapshot_period(REFRESH)
        .await
        .context("the fleet did not take the UI's snapshot period")?;
    let mut sim = SimChild(
        Command::new(exe)
            .args([
                "sim".to_string(),
                "--vehicles".to_string(),
                format!("{}xcopter:ardupilot", args.vehicles),
                "--connect".to_string(),
                format!("udpout:127.0.0.1:{port}"),
                "--home=37.1968,-80.5781".to_string(),
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .with_context(|| format!("cannot start the simulator {}", exe.display()))?,
    );
    let ready_after = wait_ready(
        &fleet,
        args.vehicles,
        Duration::from_secs_f64(args.ready_timeout),
        &mut sim,
    )
    .await?;

    let mut app = App::new(
        UiConfig::default(),
        crate::tui::Source::new(
            crate::tui::SourceKind::Bench,
            format!("BENCH udpin:127.0.0.1:{port}"),
        ),
    );
    let _ = update(&mut app, Event::Resize(SCREEN.0, SCREEN.1));
    let mut terminal = Terminal::new(TestBackend::new(SCREEN.0, SCREEN.1))?;
    let mut log = LiveLog::default();
    let mut tick = tokio::time::interval(REFRESH);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut frame_times = Vec::new();

    let frames_in0 = link.status().stats.frames_in;
    let cpu0 = cpu_seconds()?;
    let start = Instant::now();
    let end = start + Duration::from_secs_f64(args.seconds);
    loop {
        tick.tick().await;
        if Instant::now() >= end {
            break;
        }
        // One frame as the live session makes it: model from the latest snapshot, then draw.
        let t0 = Instant::now();
        let snap = fleet.snapshot();
        log.absorb(&snap);
        let model = build_model(&snap, None, &log);
        let _ = update(&mut app, Event::Snapshot(Box::new(model)));
        let _ = update(&mut app, Event::Tick(fleet.clock().now()));
        terminal.draw(|f| view::render(&app, f))?;
        frame_times.push(t0.elapsed());
    }
    let cpu1 = cpu_seconds()?;
    let wall_s = start.elapsed().as_secs_f64();
    let frames_in1 = link.status().stats.frames_in;
    if let Some(status) = sim.exited() {
        bail!("the simulator exited ({status}) during the measurement");
    }
    drop(sim);
    fleet.shutdown().await;

    let frame_total_s: f64 = frame_times.iter().map(Duration::as_secs_f64).sum();
    let frame_max_ms = frame_times
        .iter()
        .map(|d| d.as_secs_f64() * 1e3)
        .fold(0.0, f64::max);
    Ok(Figures {
        ready_s: ready_after.as_secs_f64(),
        wall_s,
        cpu_s: cpu1 - cpu0,
        frames_in: frames_in1.saturating_sub(frames_in0),
        frames: frame_times.len(),
        frame_mean_ms: frame_total_s * 1e3 / frame_times.len().max(1) as f64,
        frame_max_ms,
        frame_total_s,
    })
}

/// Run `fleetmap bench fleet` and print the figures.
pub(crate) fn run(args: BenchFleetArgs) -> anyhow::Result<ExitCode> {
    if args.vehicles == 0 || args.vehicles > 250 {
        bail!("--vehicles must be between 1 and 250");
    }
    if !(args.seconds.is_finite() && args.seconds >= 1.0 && args.seconds <= 86_400.0) {
        bail!("--seconds must be between 1 and 86400");
    }
    if !(args.ready_timeout.is_finite()
        && args.ready_timeout > 0.0
        && args.ready_timeout <= 86_400.0)
    {
        bail!("--ready-timeout must be between 0 and 86400 seconds");
    }
    let exe = std::env::current_exe().context("cannot find this program to start the simulator")?;
    let f = crate::cli::vehicles::block_on(measure(&args, &exe))??;
    let n = f64::from(args.vehicles);
    let msgs_per_s = f.frames_in as f64 / f.wall_s;
    let cpu_pct = f.cpu_s / f.wall_s * 100.0;
    let per_vehicle_pct = cpu_pct / n;
    let per_vehicle_us = f.cpu_s * 1e6 / f.wall_s / n;
    let us_per_msg = if f.frames_in > 0 {
        f.cpu_s * 1e6 / f.frames_in as f64
    } else {
        0.0
    };
    let fps = f.frames as f64 / f.wall_s;
    let tui_pct = f.frame_total_s / f.wall_s * 100.0;
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "bench": "fleet_cpu",
                "vehicles": args.vehicles,
                "ready_after_seconds": f.ready_s,
                "seconds": f.wall_s,
                "messages_received": f.frames_in,
                "messages_per_second": msgs_per_s,
                "cpu_seconds": f.cpu_s,
                "cpu_percent_of_one_core": cpu_pct,
                "cpu_percent_per_vehicle": per_vehicle_pct,
                "cpu_us_per_second_per_vehicle": per_vehicle_us,
                "cpu_us_per_message": us_per_msg,
                "tui_cols": SCREEN.0,
                "tui_rows": SCREEN.1,
                "tui_frames": f.frames,
                "tui_frames_per_second": fps,
                "tui_ms_per_frame_mean": f.frame_mean_ms,
                "tui_ms_per_frame_max": f.frame_max_ms,
                "tui_percent_of_wall_time": tui_pct,
            })
        );
    } else {
        println!(
            "GCS with {} simulated ArduPilot copters on one UDP port (simulator in a child \
             process, not counted), all ready after {:.1} s; measured for {:.1} s of wall time:",
            args.vehicles, f.ready_s, f.wall_s
        );
        println!(
            "  messages received: {} ({msgs_per_s:.0} /s, {:.1} /s per vehicle)",
            f.frames_in,
            msgs_per_s / n
        );
        println!(
            "  GCS CPU (user+system, /proc/self/stat): {:.2} s = {cpu_pct:.1} % of one core; \
             per vehicle {per_vehicle_pct:.3} % of a core = {per_vehicle_us:.0} µs of CPU per \
             second; {us_per_msg:.1} µs per message",
            f.cpu_s
        );
        println!(
            "  TUI (model + render at {} ms cadence, {}x{} off-screen): {} frames = {fps:.1} \
             frames/s, {:.2} ms mean, {:.2} ms max per frame ({tui_pct:.1} % of wall time)",
            REFRESH.as_millis(),
            SCREEN.0,
            SCREEN.1,
            f.frames,
            f.frame_mean_ms,
            f.frame_max_ms
        );
    }
    Ok(ExitCode::SUCCESS)
}
