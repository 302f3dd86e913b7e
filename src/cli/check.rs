//! `fleetmap check MISSION.toml`: validate a mission definition file and print a short
//! summary (exit 0), or every error as `file:line:column: key: message` (exit 1).
//! `--json` prints the parsed definition as JSON instead (or `{"errors": [...]}`).
//!
//! `fleetmap check --connect CONN MISSION.toml` then checks the fleet the mission would fly
//! (`app::preflight`, docs/fleet-check.md): every finding with its fix, exit 1 on a blocker.

use crate::app::kind::plural;
use clap::Args;
use fleetmap_core::mission::definition::{DefErrors, MissionDef, Origin};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `fleetmap check`.
#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The mission definition file (TOML).
    pub mission: PathBuf,
    /// Print the parsed definition (defaults filled in) as JSON; on errors, print
    /// `{"errors": [{"file", "line", "column", "path", "message"}, ...]}`.
    #[arg(long)]
    pub json: bool,
    /// Also check the fleet on these links before take-off (system ids, the ground-station
    /// id each autopilot obeys, failsafes, return altitudes, geofence, cameras, telemetry
    /// against the link): every finding with its fix, exit status 1 on a blocker.
    #[arg(long = "connect", value_name = "CONN")]
    pub connect: Vec<fleetmap_io::link::ConnSpec>,
    /// With --connect: what every vehicle's link carries (as for `fleetmap run`).
    #[arg(long, value_name = "LINK", requires = "connect")]
    pub link: Option<fleetmap_core::budget::LinkBudget>,
    /// With --connect: our MAVLink system id (255 by default, as for `fleetmap run`).
    #[arg(long, value_name = "ID", requires = "connect", value_parser = clap::value_parser!(u8).range(1..))]
    pub gcs_sysid: Option<u8>,
    /// With --connect: wait this long for every vehicle's heartbeat, seconds.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 30.0,
        requires = "connect"
    )]
    pub wait: f64,
}

/// Validate the file and report.
pub fn run(args: CheckArgs) -> anyhow::Result<ExitCode> {
    match fleetmap_io::files::load_mission(&args.mission) {
        Ok(def) => {
            if args.json && args.connect.is_empty() {
                println!("{}", serde_json::to_string_pretty(&def)?);
            } else if !args.json {
                print!("{}", summary(&def, &args.mission.display().to_string()));
            }
            if args.connect.is_empty() {
                return Ok(ExitCode::SUCCESS);
            }
            check_fleet(&args, &def)
        }
        Err(errors) => {
            if args.json {
                println!("{}", serde_json::to_string_pretty(&errors_json(&errors))?);
            }
            for e in &errors.errors {
                eprintln!("{e}");
            }
            let n = errors.errors.len();
            eprintln!(
                "fleetmap: {}: {n} error{}",
                args.mission.display(),
                if n == 1 { "" } else { "s" }
            );
            Ok(ExitCode::FAILURE)
        }
    }
}

/// `--connect`: check the fleet on the links, print the findings (JSON with `--json`).
fn check_fleet(args: &CheckArgs, def: &MissionDef) -> anyhow::Result<ExitCode> {
    if !(args.wait.is_finite() && args.wait >= 0.0) {
        anyhow::bail!("--wait must be a non-negative number of seconds");
    }
    let wait = std::time::Duration::from_secs_f64(args.wait);
    let mut conn = crate::cli::vehicles::ConnectArgs::defaults(args.connect.clone());
    conn.link = args.link;
    if let Some(id) = args.gcs_sysid {
        conn.gcs_sysid = id;
    }
    let conn = conn.with_mission_links(def);
    let findings = crate::cli::vehicles::block_on(async move {
        let session = crate::cli::vehicles::Session::open(&conn).await?;
        let findings = crate::app::preflight::run_check(&session.fleet, def, wait, wait).await;
        session.close().await?;
        anyhow::Ok(findings)
    })??;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&findings)?);
    } else {
        print!("{}", crate::app::preflight::render(&findings));
    }
    Ok(if fleetmap_core::preflight::blockers(&findings) > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

fn errors_json(errors: &DefErrors) -> serde_json::Value {
    let list: Vec<serde_json::Value> = errors
        .errors
        .iter()
        .map(|e| {
            serde_json::json!({
                "file": e.file,
                "line": e.line,
                "column": e.column,
                "path": e.path,
                "message": e.message,
            })
        })
        .collect();
    serde_json::json!({ "errors": list })
}

fn sysids<'a>(
    it: impl Iterator<Item = &'a fleetmap_core::mission::definition::VehicleDef>,
) -> String {
    it.map(|v| v.sysid.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// A kind's own summary lines ([`crate::app::kind::RunKind::summary_lines`]).
struct SummaryLines<'a>(&'a MissionDef);

impl crate::kinds::KindVisitor for SummaryLines<'_> {
    type Output = Vec<String>;
    fn visit<K: crate::app::kind::RunKind>(self) -> Vec<String> {
        K::summary_lines(self.0)
    }
}

/// The human summary printed on success.
pub fn summary(def: &MissionDef, file: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{file}: ok");
    let _ = writeln!(s, "  name        {}", def.name);
    if let Some(d) = &def.description {
        let _ = writeln!(s, "              {d}");
    }
    let _ = writeln!(s, "  kind        {}", def.kind);
    let origin = match def.grid.origin {
        Origin::Vehicle => match def.vehicles.first() {
            Some(v) => format!("home of the first vehicle (sysid {})", v.sysid),
            None => "home of the first vehicle".to_string(),
        },
        Origin::Coordinates(p) => format!("{:.6}, {:.6}", p.lat, p.lon),
    };
    let extent = match (def.area.rows, def.area.cols) {
        (Some(r), Some(c)) => format!(
            "{r} x {c} cells (rows 0-{}, cols 0-{})",
            r.saturating_sub(1),
            c.saturating_sub(1)
        ),
        _ => "unbounded".to_string(),
    };
    let _ = writeln!(
        s,
        "  grid        origin = {origin}; {} m cells; {extent}",
        def.grid.cell_size_m
    );
    let drones = def.drones().count();
    let stations = def.stations().count();
    let mut team = format!(
        "{} (sysid {})",
        plural(drones, "drone", "drones"),
        sysids(def.drones())
    );
    if stations > 0 {
        let _ = write!(
            team,
            "; {} (sysid {})",
            plural(stations, "station", "stations"),
            sysids(def.stations())
        );
    }
    let _ = writeln!(s, "  vehicles    {team}");
    let f = &def.flight;
    let top = f.altitude_m + drones.saturating_sub(1) as f64 * f.altitude_separation_m;
    let mut alt = format!("{} m above home", f.altitude_m);
    if f.altitude_separation_m > 0.0 && drones > 1 {
        let _ = write!(
            alt,
            " + {} m per drone (up to {top} m)",
            f.altitude_separation_m
        );
    }
    let _ = write!(alt, "; drones {} m/s", f.speed_m_s);
    if let Some(v) = def.station_speed_m_s() {
        let _ = write!(alt, ", stations {v} m/s");
    }
    let _ = writeln!(s, "  flight      {alt}");
    let _ = writeln!(
        s,
        "  battery     {} min, return home at {} %",
        def.battery.flight_time_min, def.battery.rtl_reserve_pct
    );
    // What only this kind's section of the file says: the kind's own lines.
    match crate::kinds::of_mission(def, SummaryLines(def)) {
        Ok(lines) => {
            for l in lines {
                let _ = writeln!(s, "  {l}");
            }
        }
        Err(e) => {
            let _ = writeln!(s, "  ({e})");
        }
    }
    s
}
