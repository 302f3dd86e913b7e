//! `fleetmap vehicles --connect CONN [--wait SECONDS]`: the vehicles heard and their state.
//!
//! Also home of the connection options every MAVLink command shares ([`ConnectArgs`]:
//! `--connect` (repeatable), `--signing-key`, `--tlog`, `--json`, mission protocol timeouts)
//! and of `Session`, which opens the links and the fleet and closes them cleanly (the
//! tlog is flushed before the command exits).

use crate::fleet::{self, FleetConfig, FleetHandle, FleetSnapshot, VehicleSnapshot};
use anyhow::Context;
use clap::Args;
use fleetmap_core::budget::LinkBudget;
use fleetmap_core::proto::GCS_SYSID;
use fleetmap_core::proto::mission::MissionConfig;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::signing::{Signing, SigningKey};
use fleetmap_io::link::tlog::{TlogError, spawn_tlog};
use fleetmap_io::link::transport::LinkOptions;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Connection options shared by the MAVLink commands.
#[derive(Debug, Clone, Args)]
pub struct ConnectArgs {
    /// Connection string, as MAVProxy writes them: udpin:HOST:PORT, udpout:HOST:PORT,
    /// tcp:HOST:PORT, tcpin:HOST:PORT, serial:PATH:BAUD. May be given several times.
    #[arg(long = "connect", value_name = "CONN", required = true)]
    pub connect: Vec<ConnSpec>,
    /// MAVLink 2 signing key file (64 hex digits; see `fleetmap signing keygen`):
    /// outgoing frames are signed, unsigned or wrongly signed incoming frames dropped.
    #[arg(long, value_name = "FILE")]
    pub signing_key: Option<PathBuf>,
    /// With --signing-key, still accept unsigned incoming frames (MAVProxy's
    /// `allow_unsigned`).
    #[arg(long)]
    pub(crate) allow_unsigned: bool,
    /// Record every frame in and out to this .tlog file.
    #[arg(long, value_name = "FILE")]
    pub tlog: Option<PathBuf>,
    /// Machine-readable output (JSON).
    #[arg(long)]
    pub json: bool,
    /// Mission protocol: wait for MISSION_COUNT / REQUEST / ACK answers, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 1500)]
    pub(crate) mission_timeout_ms: u64,
    /// Mission protocol: wait for each item during a download, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 250)]
    pub(crate) item_timeout_ms: u64,
    /// Our MAVLink system id (MAVProxy's `--source-system`): 255 by default, the id
    /// ArduPilot's MAV_GCS_SYSID expects; give another to run a second GCS beside the first
    /// on the same link (replies are routed to each by system id).
    #[arg(long, value_name = "ID", default_value_t = GCS_SYSID, value_parser = clap::value_parser!(u8).range(1..))]
    pub(crate) gcs_sysid: u8,
    /// Mission protocol: give up after the vehicle has not answered for this long,
    /// seconds (a transfer goes on as long as it answers, however lossy the link).
    #[arg(long, value_name = "SECONDS", default_value_t = 30)]
    pub(crate) mission_silence_s: u64,
    /// What every vehicle's link carries: `radio:BYTES` (a telemetry radio: bytes per second
    /// of the vehicles' time, both directions together), `radio` (2000, a 57,600-baud SiK
    /// pair) or `unlimited`. The GCS then asks only for the telemetry that fits. Default: the
    /// mission file's `link`, else unlimited until a radio reports itself (RADIO_STATUS).
    #[arg(long, value_name = "LINK")]
    pub link: Option<LinkBudget>,
    /// Per-vehicle links from a mission file (`[[vehicles]] link`); `--link` overrides them.
    #[arg(skip)]
    pub(crate) vehicle_links: BTreeMap<u8, LinkBudget>,
    /// A folder of SRTM tiles to answer the vehicles' TERRAIN_REQUESTs from (`--terrain` of
    /// `mission fly` and `run`).
    #[arg(skip)]
    pub(crate) terrain: Option<PathBuf>,
}

impl ConnectArgs {
    /// The options with their defaults, on `connect` (for commands that take only some of
    /// them from their own command line).
    pub(crate) fn defaults(connect: Vec<ConnSpec>) -> ConnectArgs {
        let mission = MissionConfig::default();
        ConnectArgs {
            connect,
            signing_key: None,
            allow_unsigned: false,
            tlog: None,
            json: false,
            mission_timeout_ms: mission.timeout.as_millis() as u64,
            item_timeout_ms: mission.item_timeout.as_millis() as u64,
            mission_silence_s: mission.silence.as_secs(),
            gcs_sysid: fleetmap_core::proto::Endpoint::gcs().sysid,
            link: None,
            vehicle_links: BTreeMap::new(),
            terrain: None,
        }
    }

    /// Take the links a mission file gives (`link`, `[[vehicles]] link`) where the command
    /// line gave none: `--link` applies to every vehicle.
    pub(crate) fn with_mission_links(
        mut self,
        def: &fleetmap_core::mission::definition::MissionDef,
    ) -> ConnectArgs {
        if self.link.is_none() {
            self.link = def.link;
            self.vehicle_links = def
                .vehicles
                .iter()
                .filter_map(|v| v.link.map(|l| (v.sysid, l)))
                .collect();
        }
        self
    }

    /// Take the links the mission file of the run in `run_dir` gives (its copy,
    /// `mission.toml`) where the command line gave none.
    pub(crate) fn with_run_links(
        self,
        run_dir: &crate::store::RunDir,
    ) -> anyhow::Result<ConnectArgs> {
        Ok(match run_dir.mission_text()? {
            Some(text) => {
                match fleetmap_core::mission::definition::MissionDef::parse(&text, "mission.toml") {
                    Ok(def) => self.with_mission_links(&def),
                    Err(_) => self,
                }
            }
            None => self,
        })
    }
}

/// An open fleet over the requested links, and the tlog writer if any.
pub(crate) struct Session {
    /// The fleet.
    pub fleet: FleetHandle,
    tlog: Option<tokio::task::JoinHandle<Result<u64, TlogError>>>,
    /// The terrain server, with `--terrain`.
    pub(crate) terrain: Option<crate::app::terrain::TerrainService>,
}

impl Session {
    /// Open the links and start the fleet.
    pub(crate) async fn open(args: &ConnectArgs) -> anyhow::Result<Session> {
        let mut opts = LinkOptions::default();
        if let Some(path) = &args.signing_key {
            let key = SigningKey::read(path)?;
            let mut s = Signing::new(key, 0);
            s.accept_unsigned = args.allow_unsigned;
            opts.signing = Some(s);
        }
        let mut tlog = None;
        if let Some(path) = &args.tlog {
            let (h, task) = spawn_tlog(path)?;
            opts.tlog = Some(h);
            tlog = Some(task);
        }
        let cfg = FleetConfig {
            gcs: fleetmap_core::proto::Endpoint::new(
                args.gcs_sysid,
                fleetmap_core::proto::Endpoint::gcs().compid,
            ),
            mission: MissionConfig {
                timeout: Duration::from_millis(args.mission_timeout_ms.max(1)),
                item_timeout: Duration::from_millis(args.item_timeout_ms.max(1)),
                silence: Duration::from_secs(args.mission_silence_s.max(1)),
                ..MissionConfig::default()
            },
            budget: args.link,
            vehicle_budgets: args.vehicle_links.clone(),
            terrain: args.terrain.is_some(),
            ..FleetConfig::default()
        };
        if let Some(dir) = &args.terrain
            && !dir.is_dir()
        {
            anyhow::bail!("--terrain {}: not a folder", dir.display());
        }
        let fleet = fleet::start(&args.connect, &opts, cfg)
            .await
            .context("cannot open the connection")?;
        let terrain = args
            .terrain
            .clone()
            .map(|dir| crate::app::terrain::spawn(&fleet, dir));
        Ok(Session {
            fleet,
            tlog,
            terrain,
        })
    }

    /// Wait for vehicle `sysid` (its first heartbeat).
    pub(crate) async fn vehicle(
        &self,
        sysid: u8,
        wait: Duration,
    ) -> anyhow::Result<VehicleSnapshot> {
        self.fleet.wait_vehicle(sysid, wait).await.with_context(|| {
            format!(
                "no heartbeat from system {sysid} within {:.0} s",
                wait.as_secs_f64()
            )
        })
    }

    /// Stop the fleet and the links; flush the tlog.
    pub(crate) async fn close(self) -> anyhow::Result<()> {
        if let Some(t) = &self.terrain {
            t.stop();
        }
        self.fleet.shutdown().await;
        let Session { fleet, tlog, .. } = self;
        drop(fleet);
        if let Some(task) = tlog {
            // The writer ends when the last link (holding a tlog handle) has stopped.
            match tokio::time::timeout(Duration::from_secs(5), task).await {
                Ok(Ok(r)) => {
                    r?;
                }
                Ok(Err(e)) => anyhow::bail!("tlog writer failed: {e}"),
                Err(_) => anyhow::bail!("tlog writer did not finish within 5 s"),
            }
        }
        Ok(())
    }
}

/// Run `f` on a small tokio runtime (the CLI is otherwise synchronous).
pub fn block_on<F: std::future::Future>(f: F) -> anyhow::Result<F::Output> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    Ok(rt.block_on(f))
}

/// Arguments of `fleetmap vehicles`.
#[derive(Debug, Args)]
pub struct VehiclesArgs {
    /// Connection options.
    #[command(flatten)]
    pub conn: ConnectArgs,
    /// Listen this long before reporting, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 3.0)]
    pub wait: f64,
}

/// One line per vehicle.
pub(crate) fn format_vehicle(v: &VehicleSnapshot) -> String {
    let pos = v
        .position
        .map(|p| format!("{:.7},{:.7}", p.lat, p.lon))
        .unwrap_or_else(|| "-".into());
    let alt = v
        .alt_rel
        .map(|a| format!("{a:.1} m"))
        .unwrap_or_else(|| "-".into());
    let gps = match (v.gps_fix, v.satellites) {
        (Some(f), Some(s)) => format!("fix{f}/{s}sat"),
        (Some(f), None) => format!("fix{f}"),
        _ => "-".into(),
    };
    let batt = match (v.battery_pct, v.battery_v) {
        (Some(p), Some(u)) => format!("{p}% {u:.1}V"),
        (Some(p), None) => format!("{p}%"),
        (None, Some(u)) => format!("{u:.1}V"),
        _ => "-".into(),
    };
    format!(
        "{:<4} {:<18} {:<10} {:<6} {:<24} {:<9} {:<12} {:<11} {}{}{}",
        v.sysid,
        v.flavour.to_string(),
        v.mode,
        if v.armed { "ARMED" } else { "-" },
        pos,
        alt,
        gps,
        batt,
        if v.alive { "" } else { "LOST " },
        if v.sysid_conflict.is_some() {
            "ID CONFLICT "
        } else {
            ""
        },
        format_link(&v.link_quality),
    )
}

/// What a vehicle's link carries and how it fares: loss, messages and bytes per second each
/// way (on the fleet's clock), the budget it is planned for, and the radio's own report
/// (signal at each end, free transmit buffer) when a radio reports itself.
pub(crate) fn format_link(q: &crate::fleet::LinkQuality) -> String {
    let mut s = format!(
        "{:.1}% loss {:.0} msg/s {:.0}↓ {:.0}↑ B/s {}{}",
        q.loss_pct,
        q.rate_hz,
        q.down_bytes_per_s,
        q.up_bytes_per_s,
        q.budget,
        if q.budget_assumed { " (assumed)" } else { "" },
    );
    if let Some(r) = &q.radio {
        s.push_str(&format!(
            " rssi {}/{} txbuf {}% rxerr {}",
            r.status.rssi, r.status.remrssi, r.status.txbuf, r.status.rxerrors
        ));
    }
    s
}

/// Print a snapshot (table or JSON).
pub(crate) fn print_snapshot(s: &FleetSnapshot, json: bool) -> anyhow::Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(s)?);
        return Ok(());
    }
    println!(
        "{:<4} {:<18} {:<10} {:<6} {:<24} {:<9} {:<12} {:<11} LINK",
        "SYS", "AUTOPILOT", "MODE", "ARMED", "POSITION", "ALT(rel)", "GPS", "BATTERY"
    );
    for v in s.vehicles.values() {
        println!("{}", format_vehicle(v));
        if let Some(c) = &v.sysid_conflict {
            println!(
                "     SYSTEM ID CONFLICT: two or more autopilots answer as system id {} on link \
                 {} ({}; found {:.1} s after it was first heard). fleetmap sends nothing to it. \
                 To fix: {}.",
                v.sysid,
                c.link,
                c.evidence,
                c.detect_s,
                crate::fleet::SysidConflict::FIX
            );
        }
        if let Some(c) = v.camera_compid {
            // a companion computer's camera (fleetmap-camera) answers as component 100
            println!("     camera: component {c}");
        }
        if let Some(t) = &v.last_text {
            println!("     last message: {}", t.text);
        }
    }
    for l in &s.links {
        println!(
            "link {}: {} frames in, {} out, {} bad CRC, {} signature drops",
            l.name,
            l.stats.frames_in,
            l.stats.frames_out,
            l.stats.bad_crc,
            l.stats.signing_drops()
        );
    }
    Ok(())
}

/// Run `fleetmap vehicles`.
pub fn run(args: VehiclesArgs) -> anyhow::Result<ExitCode> {
    if !(args.wait.is_finite() && args.wait >= 0.0) {
        anyhow::bail!("--wait must be a non-negative number of seconds");
    }
    block_on(async move {
        let session = Session::open(&args.conn).await?;
        tokio::time::sleep(Duration::from_secs_f64(args.wait)).await;
        let snap = session.fleet.snapshot();
        let found = !snap.vehicles.is_empty();
        let conflicts: Vec<u8> = snap
            .vehicles
            .values()
            .filter(|v| v.sysid_conflict.is_some())
            .map(|v| v.sysid)
            .collect();
        print_snapshot(&snap, args.conn.json)?;
        session.close().await?;
        if !found {
            let names: Vec<String> = args.conn.connect.iter().map(|c| c.to_string()).collect();
            anyhow::bail!(
                "no vehicle heard on {} within {} s",
                names.join(", "),
                args.wait
            );
        }
        if let Some(first) = conflicts.first() {
            anyhow::bail!(
                "two or more autopilots answer as system id {first}: {}",
                crate::fleet::SysidConflict::FIX
            );
        }
        Ok(ExitCode::SUCCESS)
    })?
}
