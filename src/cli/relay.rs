//! `fleetmap relay --gcs CONN --vehicle CONN [--radio B/S | --rate B/S] [--loss P] …`: relay
//! MAVLink between a GCS and a vehicle through a model of a pair of telemetry radios (a byte
//! budget shared by both directions or one each way, a buffer in each radio, loss on the air,
//! RADIO_STATUS reports), duplicating, delaying or corrupting frames on the way
//! ([`fleetmap_io::link::relay`], [`fleetmap_io::link::radio`]); e.g. between `fleetmap` and a
//! real SITL to judge telemetry and mission transfers over a poor radio, counted in the
//! vehicles' own time (`--clock vehicle`). Also home of the fault options that `fleetmap sim`
//! shares.

use anyhow::Context;
use clap::{Args, ValueEnum};
use fleetmap_io::clock::{MonotonicClock, VehicleTime};
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::faults::{LinkFaults, parse_blackouts};
use fleetmap_io::link::radio::{Duplex, RadioConfig};
use fleetmap_io::link::relay::{self, DirectionStats, RelayOptions, RelayStats};
use mavlink::Message;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::path::PathBuf;
use std::process::ExitCode;
use std::str::FromStr;
use std::time::Duration;

/// Link faults, each way (`fleetmap sim`, `fleetmap relay`).
#[derive(Debug, Clone, Args)]
pub struct FaultArgs {
    /// Probability of losing a frame, each way.
    #[arg(long, default_value_t = 0.0)]
    pub loss: f64,
    /// Probability of duplicating a frame.
    #[arg(long, default_value_t = 0.0)]
    pub dup: f64,
    /// Probability of delaying a frame behind later ones.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) reorder: f64,
    /// One-way latency, milliseconds.
    #[arg(long, default_value_t = 0.0)]
    pub latency_ms: f64,
    /// Uniform latency jitter, milliseconds.
    #[arg(long, default_value_t = 0.0)]
    pub jitter_ms: f64,
    /// Probability of corrupting a frame (one byte flipped: bad CRC).
    #[arg(long, default_value_t = 0.0)]
    pub corrupt: f64,
    /// Link blackouts as START+DURATION seconds (of simulated time for `sim`, since the
    /// start for `relay`), comma separated.
    #[arg(long, value_name = "S+D,…")]
    pub(crate) blackout: Option<String>,
}

impl FaultArgs {
    /// The faults, checked.
    pub fn faults(&self) -> anyhow::Result<LinkFaults> {
        let faults = LinkFaults {
            loss: self.loss,
            duplicate: self.dup,
            reorder: self.reorder,
            latency_ms: self.latency_ms,
            jitter_ms: self.jitter_ms,
            corrupt: self.corrupt,
            blackouts: match &self.blackout {
                Some(b) => parse_blackouts(b)?,
                None => Vec::new(),
            },
        };
        faults.validate()?;
        Ok(faults)
    }
}

/// Whether the radios share the air (`--duplex`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DuplexArg {
    /// One budget for both directions, shared fairly when both have data (a SiK radio pair).
    Half,
    /// The budget each way.
    Full,
}

/// On or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

/// The clock the relay counts time on (`--clock`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ClockArg {
    /// Wall time.
    Wall,
    /// The vehicles' time, from the time stamps of what they send.
    Vehicle,
    /// Wall time times N.
    Speedup(f64),
}

impl FromStr for ClockArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "wall" => Ok(ClockArg::Wall),
            "vehicle" => Ok(ClockArg::Vehicle),
            _ => {
                let n = s
                    .strip_prefix("speedup:")
                    .and_then(|n| n.parse::<f64>().ok())
                    .filter(|n| n.is_finite() && *n > 0.0)
                    .ok_or_else(|| {
                        format!("expected wall, vehicle or speedup:N (N > 0), got {s:?}")
                    })?;
                Ok(ClockArg::Speedup(n))
            }
        }
    }
}

impl ClockArg {
    fn name(self) -> String {
        match self {
            ClockArg::Wall => "wall".into(),
            ClockArg::Vehicle => "vehicle".into(),
            ClockArg::Speedup(n) => format!("speedup:{n}"),
        }
    }
}

/// Arguments of `fleetmap relay`.
#[derive(Debug, Args)]
pub struct RelayArgs {
    /// The GCS's side, e.g. `udpin:127.0.0.1:14600` (point the GCS at it with
    /// `--connect udpout:127.0.0.1:14600`).
    #[arg(long, value_name = "CONN")]
    pub gcs: ConnSpec,
    /// The vehicle's side, e.g. `tcp:127.0.0.1:5762` (a SITL's SERIAL1).
    #[arg(long, value_name = "CONN")]
    pub vehicle: ConnSpec,
    /// A pair of SiK telemetry radios carrying this many bytes per second of MAVLink in all,
    /// both directions together (they take turns on one channel; when both have data each
    /// gets half, an idle one gives its time to the other), with a 4096-byte buffer in each
    /// radio (a frame that does not fit is dropped) and RADIO_STATUS reports written into
    /// each side after that side's heartbeats, as SiK radios do. Field radios carry about
    /// 1000–2000. --duplex, --buffer and --radio-status change the parts.
    #[arg(long, value_name = "BYTES_PER_S", conflicts_with = "rate")]
    pub radio: Option<u32>,
    /// Byte rate each way, bytes per second (0: unlimited): about 5000 for a 57,600-baud
    /// radio. Frames wait in a buffer of 1850 bytes (a SiK radio's serial buffer) and one
    /// that would overflow it is dropped. No RADIO_STATUS unless --radio-status.
    #[arg(long, value_name = "BYTES_PER_S")]
    pub rate: Option<u32>,
    /// With --radio or --rate: `half` shares the budget between the two directions, `full`
    /// gives it to each (defaults: half for --radio, full for --rate).
    #[arg(long, value_enum)]
    pub duplex: Option<DuplexArg>,
    /// With --radio or --rate: each radio's buffer, bytes (never less than one longest
    /// frame, 280).
    #[arg(long, value_name = "BYTES")]
    pub buffer: Option<u32>,
    /// Whether each radio writes RADIO_STATUS (system 51, component 68) into its own side
    /// after each heartbeat from that side goes on the air: free buffer space, signal and
    /// noise levels, frames it failed to receive (autopilots slow their telemetry when the
    /// buffer fills). On by default with --radio; `--radio-status` alone means on.
    #[arg(long, value_enum, value_name = "on|off", num_args = 0..=1, default_missing_value = "on")]
    pub radio_status: Option<OnOff>,
    /// Signal strength both radios report in RADIO_STATUS, SiK units (about 2 per dB).
    #[arg(long, value_name = "0-255", default_value_t = 100)]
    pub rssi: u8,
    /// Background noise both radios report in RADIO_STATUS, SiK units.
    #[arg(long, value_name = "0-255", default_value_t = 40)]
    pub noise: u8,
    /// Faults, each way. --loss is the radios' loss on the air (a lost frame used its
    /// airtime and counts as a receive error in the other radio's reports); the others
    /// apply to what the radios deliver.
    #[command(flatten)]
    pub faults: FaultArgs,
    /// Seed of the faults and losses (same seed and traffic, same losses).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The clock rates, the reports and the blackouts are counted on: `wall`; `vehicle`,
    /// the vehicles' own time read from the time stamps of what they send (a simulator or
    /// SITL at ×5 then gets five times the bytes per wall second; wall time until the first
    /// time stamp); or `speedup:N`, wall time times N.
    #[arg(long, value_name = "wall|vehicle|speedup:N", default_value = "wall")]
    pub clock: ClockArg,
    /// When it stops, write the final counts to this JSON file (atomically): per direction,
    /// per radio, and per MAVLink message id with its name and bytes per second of the
    /// relay's clock.
    #[arg(long, value_name = "FILE")]
    pub stats: Option<PathBuf>,
    /// Print the counts every this many seconds of the relay's clock (0: only at the end).
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub(crate) report_every: f64,
    /// Stop after this many seconds of wall time (default: until interrupted by Ctrl-C or
    /// SIGTERM).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Print the counts as JSON lines.
    #[arg(long)]
    pub json: bool,
}

impl RelayArgs {
    /// The radio pair the options describe, and the faults after it (--loss moved to the
    /// radios' air).
    fn radio(&self) -> anyhow::Result<(RadioConfig, LinkFaults)> {
        let mut faults = self.faults.faults()?;
        let limited = self.radio.is_some() || self.rate.is_some();
        let mut radio = match (self.radio, self.rate) {
            (Some(b), _) => RadioConfig::radio(b),
            (None, Some(b)) => RadioConfig::per_direction(b),
            (None, None) => RadioConfig::unlimited(),
        };
        if !limited && (self.duplex.is_some() || self.buffer.is_some()) {
            anyhow::bail!("--duplex and --buffer need --radio or --rate");
        }
        if let Some(d) = self.duplex {
            radio.duplex = match d {
                DuplexArg::Half => Duplex::Half,
                DuplexArg::Full => Duplex::Full,
            };
        }
        if let Some(b) = self.buffer {
            radio.buffer_bytes = b;
        }
        if let Some(s) = self.radio_status {
            radio.radio_status = s == OnOff::On;
        }
        for levels in [&mut radio.gcs_levels, &mut radio.vehicle_levels] {
            levels.rssi = self.rssi;
            levels.noise = self.noise;
        }
        radio.loss = std::mem::take(&mut faults.loss);
        radio.validate()?;
        Ok((radio, faults))
    }
}

/// One direction's counts as a line.
fn line(name: &str, d: &DirectionStats, radio: &RadioConfig) -> String {
    let limit = if radio.bytes_per_s > 0 {
        format!(
            "; {} dropped on a full buffer (peak {} of {} bytes), {:.1} s on the air",
            d.rate_dropped,
            d.peak_queue_bytes,
            radio.capacity(),
            d.air_us as f64 / 1e6
        )
    } else {
        String::new()
    };
    format!(
        "{name}: {} frames in ({} bytes), {} out ({} bytes), {} lost on the air, {} dropped, \
         {} duplicated, {} corrupted{limit}",
        d.frames_in,
        d.bytes_in,
        d.frames_out,
        d.bytes_out,
        d.lost,
        d.dropped,
        d.duplicated,
        d.corrupted
    )
}

/// Print the counts: JSON (every field of [`RelayStats`]) or a line per direction and one
/// for the radios' reports.
fn print(stats: &RelayStats, json: bool, radio: &RadioConfig) {
    if json {
        if let Ok(s) = serde_json::to_string(stats) {
            println!("{s}");
        }
        return;
    }
    println!("{}", line("gcs→vehicle", &stats.up, radio));
    println!("{}", line("vehicle→gcs", &stats.down, radio));
    let secs = stats.clock_us as f64 / 1e6;
    let rate = |b: u64| if secs > 0.0 { b as f64 / secs } else { 0.0 };
    println!(
        "{secs:.1} s on the relay's clock ({:.1} s of wall time): {:.0} B/s up, {:.0} B/s down; \
         RADIO_STATUS {} to the GCS, {} to the vehicle; receive errors {} at the GCS, {} on \
         the vehicle",
        stats.wall_us as f64 / 1e6,
        rate(stats.up.bytes_out),
        rate(stats.down.bytes_out),
        stats.gcs_radio.radio_status,
        stats.vehicle_radio.radio_status,
        stats.gcs_radio.rx_errors,
        stats.vehicle_radio.rx_errors
    );
}

/// The `--stats` file: the counts, the configuration, and per message id its name and
/// bytes per second (sent on) of the relay's clock.
fn stats_json(
    stats: &RelayStats,
    opts: &RelayOptions,
    clock: ClockArg,
) -> anyhow::Result<serde_json::Value> {
    let mut v = serde_json::to_value(stats)?;
    let secs = stats.clock_us as f64 / 1e6;
    for dir in ["up", "down"] {
        let Some(map) = v[dir]["by_message"].as_object_mut() else {
            continue;
        };
        for (id, m) in map.iter_mut() {
            let name = id
                .parse::<u32>()
                .ok()
                .and_then(MavMessage::default_message_from_id)
                .map(|m| m.message_name().to_string())
                .unwrap_or_else(|| "unknown".into());
            let bytes = m["bytes_out"].as_f64().unwrap_or(0.0);
            m["name"] = name.into();
            m["bytes_out_per_s"] = if secs > 0.0 { bytes / secs } else { 0.0 }.into();
        }
    }
    v["clock"] = clock.name().into();
    v["radio"] = serde_json::to_value(&opts.radio)?;
    v["faults"] = serde_json::to_value(&opts.faults)?;
    v["seed"] = opts.seed.into();
    Ok(v)
}

/// Resolves on Ctrl-C or SIGTERM.
async fn interrupted() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        if let Ok(mut term) = signal(SignalKind::terminate()) {
            tokio::select! {
                _ = tokio::signal::ctrl_c() => {}
                _ = term.recv() => {}
            }
            return;
        }
    }
    let _ = tokio::signal::ctrl_c().await;
}

/// Run `fleetmap relay`.
pub fn run(args: RelayArgs) -> anyhow::Result<ExitCode> {
    let (radio, faults) = args.radio()?;
    if !(args.report_every.is_finite() && args.report_every >= 0.0) {
        anyhow::bail!("--report-every must be ≥ 0");
    }
    if let Some(d) = args.duration
        && !(d.is_finite() && d >= 0.0)
    {
        anyhow::bail!("--duration must be ≥ 0");
    }
    let every = if args.report_every > 0.0 {
        Duration::from_secs_f64(args.report_every)
    } else {
        Duration::from_secs(365 * 86_400)
    };
    let json = args.json;
    let duration = args.duration;
    let opts = RelayOptions {
        radio,
        faults,
        seed: args.seed,
    };
    let shown = opts.clone();
    let clock_arg = args.clock;
    let stats = crate::cli::vehicles::block_on(async {
        // made inside the runtime: the clocks read tokio's time
        let clock = match clock_arg {
            ClockArg::Wall => None,
            ClockArg::Vehicle => Some(MonotonicClock::vehicles(&VehicleTime::new())),
            ClockArg::Speedup(n) => Some(MonotonicClock::with_speedup(n)),
        };
        let stop = async {
            match duration {
                Some(d) => {
                    tokio::select! {
                        _ = tokio::time::sleep(Duration::from_secs_f64(d)) => {}
                        _ = interrupted() => {}
                    }
                }
                None => interrupted().await,
            }
        };
        relay::run(
            args.gcs,
            args.vehicle,
            opts,
            clock,
            every,
            |s| print(s, json, &shown.radio),
            stop,
        )
        .await
    })??;
    print(&stats, json, &shown.radio);
    if let Some(path) = &args.stats {
        let v = stats_json(&stats, &shown, clock_arg)?;
        let text = serde_json::to_string_pretty(&v)?;
        fleetmap_io::files::atomic_write(path, text.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}
