//! `fleetmap mission upload|download|clear|fly`: mission, fence and rally lists on a vehicle.
//!
//! Files: `.plan` (QGroundControl JSON; `--type` picks its mission, geofence or rally
//! points) or QGC WPL 110 text (`.waypoints`, anything else).
//!
//! `upload --verify` reads the mission back after the upload and compares it with the file by
//! the autopilot's storage rules (`verify_mission`, what `fly` does before it takes off).
//!
//! `fly` uploads, verifies by download, takes off the way the autopilot wants it (ArduCopter:
//! GUIDED + arm + NAV_TAKEOFF; PX4: arm + NAV_TAKEOFF with AMSL altitude; rovers just arm),
//! starts the mission (MAV_CMD_MISSION_START), prints a line per item reached, then returns
//! to launch and waits for the landing (rovers: for the arrival at home). It exits 0 only
//! when every navigation item was flown and the vehicle is down.

use super::vehicles::{ConnectArgs, Session, block_on};
use crate::app::terrain::TerrainService;
use crate::fleet::{FleetError, FleetHandle, VehicleSnapshot};
use anyhow::{Context, bail};
use clap::{Args, Subcommand, ValueEnum};
use fleetmap_core::mission::item::cmd::is_nav;
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::mission::item::{cmd, frame};
use fleetmap_core::mission::plan::{Plan, parse_plan, write_plan};
use fleetmap_core::mission::wire::compare_items;
use fleetmap_core::mission::wpl::{parse_wpl, write_wpl};
use fleetmap_core::proto::flavour::{Autopilot, takeoff_reached};
use fleetmap_core::proto::mission::MissionOutcome;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Which list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ListType {
    /// The flight plan.
    Mission,
    /// The geofence.
    Fence,
    /// Rally points.
    Rally,
}

impl From<ListType> for MissionType {
    fn from(t: ListType) -> MissionType {
        match t {
            ListType::Mission => MissionType::Mission,
            ListType::Fence => MissionType::Fence,
            ListType::Rally => MissionType::Rally,
        }
    }
}

/// Options common to the mission subcommands.
#[derive(Debug, Args)]
pub struct Target {
    /// Connection options.
    #[command(flatten)]
    pub conn: ConnectArgs,
    /// The vehicle's system id.
    #[arg(long, value_name = "N")]
    pub sysid: u8,
    /// Which list.
    #[arg(long = "type", value_enum, default_value_t = ListType::Mission)]
    pub kind: ListType,
    /// Wait this long for the vehicle's first heartbeat, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 15.0)]
    pub wait: f64,
}

/// Arguments of `fleetmap mission`.
#[derive(Debug, Args)]
pub struct MissionArgs {
    /// What to do.
    #[command(subcommand)]
    pub what: MissionCommand,
}

/// The mission subcommands.
#[derive(Debug, Subcommand)]
pub enum MissionCommand {
    /// Upload a list from FILE.
    Upload {
        /// Vehicle and connection.
        #[command(flatten)]
        target: Target,
        /// A .plan or .waypoints file.
        file: PathBuf,
        /// After the upload, read the mission back and compare it with the file by the
        /// autopilot's storage rules (as `mission fly` does); exit non-zero with the first
        /// difference. Mission lists only.
        #[arg(long)]
        verify: bool,
    },
    /// Download a list to FILE (or stdout as QGC WPL 110).
    Download {
        /// Vehicle and connection.
        #[command(flatten)]
        target: Target,
        /// Where to write (.plan or .waypoints); stdout if absent.
        file: Option<PathBuf>,
    },
    /// Clear a list.
    Clear {
        /// Vehicle and connection.
        #[command(flatten)]
        target: Target,
    },
    /// Upload, verify, take off, fly every item, return and land.
    Fly {
        /// Vehicle and connection.
        #[command(flatten)]
        target: Target,
        /// The mission (.plan or .waypoints).
        file: PathBuf,
        /// Take-off altitude above home, metres (default: the mission's NAV_TAKEOFF or
        /// first waypoint altitude).
        #[arg(long, value_name = "METRES")]
        takeoff_alt: Option<f32>,
        /// Give up if the whole flight takes longer, seconds.
        #[arg(long, value_name = "SECONDS", default_value_t = 1800.0)]
        timeout: f64,
        /// Answer the vehicle's terrain requests (TERRAIN_REQUEST) from the SRTM tiles in this
        /// folder (`N47E008.hgt` or `.hgt.zip`); a mission with terrain-frame items then
        /// waits for the vehicle to have its terrain before it takes off (docs/terrain.md).
        #[arg(long, value_name = "DIR")]
        terrain: Option<PathBuf>,
    },
}

/// Items of list `kind` from a file, with the file's home if it has one.
pub(crate) fn read_list(
    path: &Path,
    kind: MissionType,
) -> anyhow::Result<(Vec<MissionItem>, Option<MissionItem>)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("plan"))
    {
        let p = parse_plan(&text).with_context(|| format!("{}", path.display()))?;
        let home = p.home.map(|(lat, lon, alt)| MissionItem {
            frame: frame::GLOBAL,
            ..MissionItem::at(cmd::NAV_WAYPOINT, lat, lon, alt as f32)
        });
        let items = match kind {
            MissionType::Mission => p.mission,
            MissionType::Fence => p.fence,
            MissionType::Rally => p.rally,
        };
        Ok((items, home))
    } else {
        let w = parse_wpl(&text).with_context(|| format!("{}", path.display()))?;
        for warning in &w.warnings {
            eprintln!("warning: {}: {warning}", path.display());
        }
        Ok((w.items, w.home))
    }
}

/// Write list `kind` to a file (format by extension).
pub(crate) fn write_list(
    path: &Path,
    kind: MissionType,
    items: &[MissionItem],
    home: Option<&MissionItem>,
    v: &VehicleSnapshot,
) -> anyhow::Result<()> {
    let text = if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("plan"))
    {
        let mut p = Plan {
            firmware_type: v.flavour.autopilot.mav_autopilot(),
            vehicle_type: v.mav_type,
            home: home
                .map(|h| (h.lat(), h.lon(), f64::from(h.z)))
                .or_else(|| v.home.map(|h| (h.lat, h.lon, f64::from(h.alt_amsl)))),
            ..Plan::default()
        };
        match kind {
            MissionType::Mission => p.mission = items.to_vec(),
            MissionType::Fence => p.fence = items.to_vec(),
            MissionType::Rally => p.rally = items.to_vec(),
        }
        write_plan(&p)
    } else {
        write_wpl(home, items)
    };
    fleetmap_io::files::atomic_write(path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))
}

fn wait_of(t: &Target) -> anyhow::Result<Duration> {
    if !(t.wait.is_finite() && t.wait >= 0.0) {
        bail!("--wait must be a non-negative number of seconds");
    }
    Ok(Duration::from_secs_f64(t.wait))
}

/// Run `fleetmap mission …`.
pub fn run(args: MissionArgs) -> anyhow::Result<ExitCode> {
    match args.what {
        MissionCommand::Upload {
            target,
            file,
            verify,
        } => {
            let kind: MissionType = target.kind.into();
            if verify && kind != MissionType::Mission {
                bail!(
                    "--verify checks mission lists only: fence and rally points are stored \
                     by rules of their own (ArduPilot keeps rally altitudes in whole metres)"
                );
            }
            let (items, _home) = read_list(&file, kind)?;
            block_on(async move {
                let s = Session::open(&target.conn).await?;
                let r = async {
                    let v = s.vehicle(target.sysid, wait_of(&target)?).await?;
                    if let Some(why) = px4_takeoff_without_position(&v, &items) {
                        eprintln!("warning: {why}");
                    }
                    let out = s
                        .fleet
                        .upload_mission(target.sysid, kind, items.clone())
                        .await?;
                    if let MissionOutcome::Uploaded {
                        count,
                        verified_by_download,
                    } = out
                    {
                        if target.conn.json {
                            println!(
                                "{}",
                                serde_json::json!({"uploaded": count, "type": format!("{kind:?}").to_lowercase(), "verified_by_download": verified_by_download})
                            );
                        } else {
                            println!(
                                "uploaded {count} {} item(s) to vehicle {}{}",
                                format!("{kind:?}").to_lowercase(),
                                target.sysid,
                                if verified_by_download {
                                    " (final ACK lost; confirmed by reading the list back)"
                                } else {
                                    ""
                                }
                            );
                        }
                    }
                    if verify {
                        verify_mission(&s.fleet, target.sysid, &v, &items).await?;
                        say(
                            target.conn.json,
                            "verified",
                            VERIFIED.into(),
                            serde_json::json!({"verified": true, "count": items.len()}),
                        );
                    }
                    anyhow::Ok(())
                }
                .await;
                s.close().await?;
                r.map(|_| ExitCode::SUCCESS)
            })?
        }
        MissionCommand::Download { target, file } => {
            let kind: MissionType = target.kind.into();
            block_on(async move {
                let s = Session::open(&target.conn).await?;
                let r = async {
                    let v = s.vehicle(target.sysid, wait_of(&target)?).await?;
                    let (items, home) = s.fleet.download_mission(target.sysid, kind).await?;
                    match &file {
                        Some(path) => {
                            write_list(path, kind, &items, home.as_ref(), &v)?;
                            if target.conn.json {
                                println!(
                                    "{}",
                                    serde_json::json!({"downloaded": items.len(), "file": path})
                                );
                            } else {
                                println!(
                                    "downloaded {} item(s) to {}",
                                    items.len(),
                                    path.display()
                                );
                            }
                        }
                        None if target.conn.json => {
                            println!("{}", serde_json::json!({"items": items, "home": home}));
                        }
                        None => print!("{}", write_wpl(home.as_ref(), &items)),
                    }
                    anyhow::Ok(())
                }
                .await;
                s.close().await?;
                r.map(|_| ExitCode::SUCCESS)
            })?
        }
        MissionCommand::Clear { target } => {
            let kind: MissionType = target.kind.into();
            block_on(async move {
                let s = Session::open(&target.conn).await?;
                let r = async {
                    s.vehicle(target.sysid, wait_of(&target)?).await?;
                    s.fleet.clear_mission(target.sysid, kind).await?;
                    if target.conn.json {
                        println!(
                            "{}",
                            serde_json::json!({"cleared": format!("{kind:?}").to_lowercase()})
                        );
                    } else {
                        println!(
                            "cleared the {} of vehicle {}",
                            format!("{kind:?}").to_lowercase(),
                            target.sysid
                        );
                    }
                    anyhow::Ok(())
                }
                .await;
                s.close().await?;
                r.map(|_| ExitCode::SUCCESS)
            })?
        }
        MissionCommand::Fly {
            mut target,
            file,
            takeoff_alt,
            timeout,
            terrain,
        } => {
            target.conn.terrain = terrain;
            if target.kind != ListType::Mission {
                bail!("mission fly flies a mission (--type mission)");
            }
            if !(timeout.is_finite() && timeout > 0.0) {
                bail!("--timeout must be a positive number of seconds");
            }
            let (items, _home) = read_list(&file, MissionType::Mission)?;
            if items.is_empty() {
                bail!("{}: the mission has no items", file.display());
            }
            block_on(async move {
                let s = Session::open(&target.conn).await?;
                let r = fly(
                    &s.fleet,
                    &target,
                    items,
                    takeoff_alt,
                    Duration::from_secs_f64(timeout),
                    s.terrain.as_ref(),
                )
                .await;
                s.close().await?;
                r.map(|_| ExitCode::SUCCESS)
            })?
        }
    }
}

/// Print a progress line (or a JSON event with --json).
fn say(json: bool, event: &str, text: String, extra: serde_json::Value) {
    if json {
        let mut o = serde_json::json!({"event": event, "message": text});
        if let (Some(m), Some(e)) = (o.as_object_mut(), extra.as_object()) {
            for (k, v) in e {
                m.insert(k.clone(), v.clone());
            }
        }
        println!("{o}");
    } else {
        println!("{text}");
    }
}

/// PX4 flies a mission's take-off item as a waypoint to the item's position
/// (`navigator/mission.cpp`); one without a position (latitude/longitude 0, 0, which
/// ArduCopter takes as "here") is never reached and the mission stops there (seen on PX4 1.16
/// SITL). Says which item, for a PX4 vehicle.
fn px4_takeoff_without_position(v: &VehicleSnapshot, items: &[MissionItem]) -> Option<String> {
    if v.flavour.autopilot != fleetmap_core::proto::flavour::Autopilot::Px4 {
        return None;
    }
    let i = items.iter().position(|it| {
        it.command == fleetmap_core::mission::item::cmd::NAV_TAKEOFF && it.x == 0 && it.y == 0
    })?;
    Some(format!(
        "item {i}: NAV_TAKEOFF without a position (latitude/longitude 0, 0): PX4 flies a \
         take-off item to its position and never reaches that one; give the launch position \
         (QGroundControl writes it)"
    ))
}

/// What `upload --verify` and `fly` print when the read-back matches.
const VERIFIED: &str = "verified: the vehicle holds the same mission";

/// Read vehicle `sysid`'s mission back and compare it with `sent`, the items just uploaded,
/// by the storage rules of the vehicle's autopilot (`v`; [`compare_items`]: ArduPilot keeps
/// no position for commands outside `AP_Mission::stored_in_location` and only the parameters
/// its packed command has). The error names the first difference: the item, the field, what
/// was sent and what came back.
async fn verify_mission(
    fleet: &FleetHandle,
    sysid: u8,
    v: &VehicleSnapshot,
    sent: &[MissionItem],
) -> anyhow::Result<()> {
    let (back, _) = fleet
        .download_mission(sysid, MissionType::Mission)
        .await
        .context("reading the mission back to verify it")?;
    compare_items(sent, &back, v.flavour.home_item())
        .map_err(|d| anyhow::anyhow!("the mission read back from the vehicle differs: {d}"))
}

async fn fly(
    fleet: &FleetHandle,
    target: &Target,
    items: Vec<MissionItem>,
    takeoff_alt: Option<f32>,
    budget: Duration,
    terrain: Option<&TerrainService>,
) -> anyhow::Result<()> {
    let json = target.conn.json;
    let sysid = target.sysid;
    let started = Instant::now();
    let remaining = |what: &str| -> anyhow::Result<Duration> {
        budget
            .checked_sub(started.elapsed())
            .filter(|d| !d.is_zero())
            .with_context(|| format!("the flight took longer than --timeout while {what}"))
    };
    let v = fleet
        .wait_vehicle(sysid, wait_of(target)?)
        .await
        .with_context(|| format!("no heartbeat from system {sysid}"))?;
    if let Some(why) = px4_takeoff_without_position(&v, &items) {
        bail!("{why}");
    }
    say(
        json,
        "vehicle",
        format!("vehicle {sysid}: {} in {}", v.flavour, v.mode),
        serde_json::json!({"sysid": sysid}),
    );

    // 1. Upload and verify by download.
    fleet
        .upload_mission(sysid, MissionType::Mission, items.clone())
        .await?;
    say(
        json,
        "uploaded",
        format!("uploaded {} items", items.len()),
        serde_json::json!({"count": items.len()}),
    );
    verify_mission(fleet, sysid, &v, &items).await?;
    say(json, "verified", VERIFIED.into(), serde_json::json!({}));
    let nav: Vec<u16> = items
        .iter()
        .enumerate()
        .filter(|(_, it)| is_nav(it.command))
        .map(|(i, _)| i as u16)
        .collect();
    let last_nav = nav.last().copied();
    let ends_on_ground = items
        .iter()
        .rev()
        .find(|it| is_nav(it.command))
        .is_some_and(|it| it.command == cmd::NAV_LAND || it.command == cmd::NAV_RETURN_TO_LAUNCH);

    // 2. Terrain: an ArduPilot vehicle with terrain-frame items waits for its terrain.
    let terrain_items = items
        .iter()
        .filter(|it| frame::is_terrain(it.frame))
        .count();
    if terrain_items > 0 && v.flavour.autopilot == Autopilot::ArduPilot {
        match terrain {
            Some(t) => {
                let limit = remaining("waiting for terrain")?;
                wait_for_terrain(json, sysid, t, limit).await?;
            }
            None => say(
                json,
                "terrain",
                format!(
                    "{terrain_items} item(s) fly in the terrain frame: the vehicle needs terrain \
                     data (TERRAIN_ENABLE 1) and has it only from its own cache; give --terrain \
                     DIR to serve SRTM tiles"
                ),
                serde_json::json!({"terrain_items": terrain_items}),
            ),
        }
    }

    // 3. Arm, take off in the right mode, start.
    let flies = v.flavour.flies();
    if flies {
        let alt = takeoff_alt
            .or_else(|| {
                items
                    .iter()
                    .find(|it| it.command == cmd::NAV_TAKEOFF || it.command == cmd::NAV_WAYPOINT)
                    .map(|it| it.z)
            })
            .filter(|a| *a > 0.5)
            .unwrap_or(10.0);
        say(
            json,
            "takeoff",
            format!("arming and taking off to {alt:.1} m"),
            serde_json::json!({"alt": alt}),
        );
        fleet.takeoff(sysid, alt).await?;
        let t = remaining("climbing")?;
        // Done as the autopilot judges it: PX4 stops within NAV_MC_ALT_RAD (0.8 m) below.
        let up = fleet
            .wait_until(sysid, t.min(Duration::from_secs(120)), |s| {
                s.alt_rel.is_some_and(|a| takeoff_reached(a, alt))
            })
            .await
            .map_err(|v| {
                anyhow::anyhow!(
                    "vehicle {sysid} did not climb to {alt:.1} m (at {})",
                    v.and_then(|v| v.alt_rel)
                        .map(|a| format!("{a:.1} m"))
                        .unwrap_or_else(|| "unknown altitude".into())
                )
            })?;
        say(
            json,
            "airborne",
            format!("at {:.1} m", up.alt_rel.unwrap_or(alt)),
            serde_json::json!({}),
        );
    } else {
        say(json, "arm", "arming".into(), serde_json::json!({}));
        fleet.arm(sysid).await?;
    }
    fleet.start_mission(sysid).await?;
    say(
        json,
        "started",
        "mission started".into(),
        serde_json::json!({}),
    );

    // 4. Follow it.
    let total = items.len();
    let mut flown: Vec<bool> = vec![false; total];
    let mut rx = fleet.watch();
    let mut last_current: Option<u16> = None;
    let mut announced: Vec<bool> = vec![false; total];
    loop {
        let t = remaining("flying the mission")?;
        let snap = match tokio::time::timeout(t, rx.changed()).await {
            Ok(Ok(())) => rx.borrow_and_update().vehicles.get(&sysid).cloned(),
            Ok(Err(_)) => bail!("the fleet stopped"),
            Err(_) => bail!("the flight took longer than --timeout while flying the mission"),
        };
        let Some(s) = snap else { continue };
        if !s.alive {
            continue;
        }
        for &r in &s.reached {
            if let Some(f) = flown.get_mut(usize::from(r)) {
                *f = true;
            }
        }
        if let Some(c) = s.mission_current {
            // Passing item c means every item before it in this leg was done.
            if let Some(l) = last_current
                && c > l
            {
                for f in flown.iter_mut().take(usize::from(c)).skip(usize::from(l)) {
                    *f = true;
                }
            }
            last_current = Some(c);
        }
        for (i, f) in flown.iter().enumerate() {
            if *f && !announced[i] && is_nav(items[i].command) {
                announced[i] = true;
                let done = nav.iter().filter(|&&k| flown[usize::from(k)]).count();
                say(
                    json,
                    "reached",
                    format!(
                        "item {}/{} reached ({}) — {done}/{} navigation items",
                        i + 1,
                        total,
                        command_name(items[i].command),
                        nav.len()
                    ),
                    serde_json::json!({"item": i, "done": done, "nav_items": nav.len()}),
                );
            }
        }
        let all_flown = nav.iter().all(|&k| flown[usize::from(k)]);
        let complete = s.mission_complete();
        if all_flown
            && (last_nav.is_none() || complete || last_nav.is_some_and(|l| flown[usize::from(l)]))
        {
            break;
        }
        if ends_on_ground
            && s.on_ground()
            && !s.armed
            && nav.iter().rev().skip(1).all(|&k| flown[usize::from(k)])
        {
            // The mission's own landing finished it.
            if let Some(l) = last_nav {
                flown[usize::from(l)] = true;
            }
            break;
        }
        if s.on_ground() && !s.armed && flies && started.elapsed() > Duration::from_secs(20) {
            let done = nav.iter().filter(|&&k| flown[usize::from(k)]).count();
            bail!(
                "vehicle {sysid} is on the ground and disarmed after {done} of {} navigation items (mode {}{})",
                nav.len(),
                s.mode,
                s.last_text
                    .map(|t| format!(", last message: {}", t.text))
                    .unwrap_or_default()
            );
        }
    }
    say(
        json,
        "mission_done",
        "every mission item flown".into(),
        serde_json::json!({}),
    );

    // 5. Return and land.
    let s = fleet
        .vehicle(sysid)
        .ok_or(FleetError::NoVehicle { sysid })?;
    let down = |s: &VehicleSnapshot| s.on_ground() && !s.armed;
    if !(flies && down(&s)) {
        say(
            json,
            "rtl",
            "returning to launch".into(),
            serde_json::json!({}),
        );
        fleet.rtl(sysid).await?;
        let t = remaining("returning")?;
        if flies {
            fleet
                .wait_until(sysid, t, down)
                .await
                .map_err(|_| anyhow::anyhow!("vehicle {sysid} did not land within --timeout"))?;
            say(
                json,
                "landed",
                "landed and disarmed".into(),
                serde_json::json!({}),
            );
        } else {
            let home = s.home;
            fleet
                .wait_until(sysid, t, |v| match (home, v.position) {
                    (Some(h), Some(p)) => {
                        fleetmap_core::geo::local::distance(h.lat, h.lon, p.lat, p.lon) < 3.0
                            && v.groundspeed.is_some_and(|g| g < 0.3)
                    }
                    _ => false,
                })
                .await
                .map_err(|_| {
                    anyhow::anyhow!("vehicle {sysid} did not arrive home within --timeout")
                })?;
            say(json, "home", "back at home".into(), serde_json::json!({}));
        }
    } else {
        say(
            json,
            "landed",
            "landed and disarmed".into(),
            serde_json::json!({}),
        );
    }
    Ok(())
}

/// How long `fly` waits for a vehicle's terrain to make progress before it gives up: no
/// TERRAIN_REPORT that changed, and no square sent, for this long.
const TERRAIN_STALL: Duration = Duration::from_secs(30);

/// Wait until vehicle `sysid` reports its terrain complete (TERRAIN_REPORT with nothing
/// pending and something loaded), printing its progress at most every 5 s; fail with what it
/// waits for when no tile has it (and the vehicle still lacks it 10 s later), when nothing
/// moved for [`TERRAIN_STALL`], or after `limit` (what is left of `--timeout`).
async fn wait_for_terrain(
    json: bool,
    sysid: u8,
    t: &TerrainService,
    limit: Duration,
) -> anyhow::Result<()> {
    let mut rx = t.watch();
    let started = Instant::now();
    let mut last: Option<(u16, u16)> = None;
    let mut waiting_since: Option<Instant> = None;
    let mut printed: Option<Instant> = None;
    let mut moved = (Instant::now(), 0u64);
    say(
        json,
        "terrain",
        format!(
            "waiting for vehicle {sysid}'s terrain (served from {})",
            t.dir().display()
        ),
        serde_json::json!({}),
    );
    loop {
        let v = rx.borrow_and_update().vehicles.get(&sysid).cloned();
        if let Some(v) = &v {
            if v.report != last || v.squares_sent != moved.1 {
                moved = (Instant::now(), v.squares_sent);
            }
            if v.report != last
                && let Some((pending, loaded)) = v.report
            {
                last = v.report;
                let done = pending == 0 && loaded > 0;
                // a line every 5 s at most, and the last one
                let quiet =
                    !done && printed.is_some_and(|p: Instant| p.elapsed() < Duration::from_secs(5));
                if !quiet {
                    printed = Some(Instant::now());
                    say(
                        json,
                        "terrain",
                        format!(
                            "terrain: {pending} squares pending, {loaded} loaded ({} sent)",
                            v.squares_sent
                        ),
                        serde_json::json!({"pending": pending, "loaded": loaded, "sent": v.squares_sent}),
                    );
                }
                if done {
                    return Ok(());
                }
            }
            match (&v.waiting, waiting_since) {
                (Some(line), None) => {
                    waiting_since = Some(Instant::now());
                    say(
                        json,
                        "terrain_missing",
                        line.clone(),
                        serde_json::json!({"sysid": sysid}),
                    );
                }
                (None, _) => waiting_since = None,
                (Some(line), Some(since)) if since.elapsed() > Duration::from_secs(10) => {
                    bail!("{line}");
                }
                _ => {}
            }
        }
        let left = limit
            .checked_sub(started.elapsed())
            .filter(|d| !d.is_zero() && moved.0.elapsed() < TERRAIN_STALL);
        let Some(left) = left else {
            let what = v.and_then(|v| v.waiting).unwrap_or_else(|| {
                format!(
                    "vehicle {sysid} still lacks terrain (last report: {last:?} pending/loaded)"
                )
            });
            bail!(
                "no terrain after {:.0} s: {what}",
                started.elapsed().as_secs_f64()
            );
        };
        let _ = tokio::time::timeout(left.min(Duration::from_secs(1)), rx.changed()).await;
    }
}

fn command_name(c: u16) -> String {
    use mavlink::dialects::ardupilotmega::MavCmd;
    use num_traits::FromPrimitive;
    MavCmd::from_u16(c)
        .map(|m| format!("{m:?}").trim_start_matches("MAV_CMD_").to_string())
        .unwrap_or_else(|| format!("command {c}"))
}
