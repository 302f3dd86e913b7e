//! `fleetmap command --connect CONN --sysid N arm|disarm|mode NAME|takeoff ALT|goto LAT LON ALT|rtl|land`.
//!
//! Each action is done the way the vehicle's autopilot wants it (see `proto::flavour`):
//! arming waits for the vehicle to be really ready, modes are confirmed by the heartbeat,
//! take-off switches ArduCopter to GUIDED and arms first, and waits for the climb.

use super::vehicles::{ConnectArgs, Session, block_on};
use anyhow::bail;
use clap::{Args, Subcommand};
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of `fleetmap command`.
#[derive(Debug, Args)]
pub struct CommandArgs {
    /// Connection options.
    #[command(flatten)]
    pub conn: ConnectArgs,
    /// The vehicle's system id.
    #[arg(long, value_name = "N")]
    pub sysid: u8,
    /// Wait this long for the vehicle's first heartbeat, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 15.0)]
    pub wait: f64,
    /// What to do.
    #[command(subcommand)]
    pub action: Action,
}

/// The actions.
#[derive(Debug, Clone, Subcommand)]
pub enum Action {
    /// Arm (after the readiness checks: GPS fix, position estimate, home, pre-arm checks).
    Arm,
    /// Disarm.
    Disarm,
    /// Switch to a flight mode (e.g. GUIDED, AUTO, RTL for ArduPilot; MISSION, HOLD for PX4).
    Mode {
        /// Mode name (case-insensitive).
        name: String,
    },
    /// Arm and take off to ALT metres above home; waits for the climb.
    Takeoff {
        /// Altitude above home, metres.
        alt: f32,
    },
    /// Go to a point now (DO_REPOSITION / guided).
    Goto {
        /// Latitude, degrees.
        #[arg(allow_negative_numbers = true)]
        lat: f64,
        /// Longitude, degrees.
        #[arg(allow_negative_numbers = true)]
        lon: f64,
        /// Altitude above home, metres.
        #[arg(allow_negative_numbers = true)]
        alt: f32,
    },
    /// Return to launch.
    Rtl,
    /// Land here.
    Land,
    /// Reboot the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN; disarmed only) and wait
    /// until it is up again: what a battery swap does to a vehicle.
    Reboot {
        /// Return once the command is sent (acknowledged, or not answered because the
        /// autopilot went down at once), without waiting for it to come back.
        #[arg(long)]
        no_wait: bool,
    },
}

/// Run `fleetmap command`.
pub fn run(args: CommandArgs) -> anyhow::Result<ExitCode> {
    if !(args.wait.is_finite() && args.wait >= 0.0) {
        bail!("--wait must be a non-negative number of seconds");
    }
    match &args.action {
        Action::Takeoff { alt } if !(alt.is_finite() && *alt > 0.0 && *alt < 10_000.0) => {
            bail!("take-off altitude must be between 0 and 10000 m, got {alt}")
        }
        Action::Goto { lat, lon, alt } => {
            if !(lat.is_finite() && lat.abs() <= 90.0 && lon.is_finite() && lon.abs() <= 180.0) {
                bail!("goto: {lat},{lon} is not a latitude,longitude");
            }
            if !alt.is_finite() {
                bail!("goto: altitude {alt} is not a number");
            }
        }
        _ => {}
    }
    block_on(async move {
        let s = Session::open(&args.conn).await?;
        let r = async {
            let sysid = args.sysid;
            s.vehicle(sysid, Duration::from_secs_f64(args.wait)).await?;
            let f = &s.fleet;
            let done = match &args.action {
                Action::Arm => {
                    f.arm(sysid).await?;
                    "armed".to_string()
                }
                Action::Disarm => {
                    f.disarm(sysid).await?;
                    "disarmed".to_string()
                }
                Action::Mode { name } => {
                    f.set_mode_named(sysid, name).await?;
                    format!(
                        "mode {}",
                        f.vehicle(sysid).map(|v| v.mode).unwrap_or_default()
                    )
                }
                Action::Takeoff { alt } => {
                    f.takeoff(sysid, *alt).await?;
                    let alt = *alt;
                    f.wait_until(sysid, Duration::from_secs(120), |v| {
                        v.alt_rel
                            .is_some_and(|a| fleetmap_core::proto::flavour::takeoff_reached(a, alt))
                    })
                    .await
                    .map_err(|v| {
                        anyhow::anyhow!(
                            "take-off accepted but the vehicle did not reach {alt} m (at {})",
                            v.and_then(|v| v.alt_rel)
                                .map(|a| format!("{a:.1} m"))
                                .unwrap_or_else(|| "unknown altitude".into())
                        )
                    })?;
                    format!("airborne at {alt} m")
                }
                Action::Goto { lat, lon, alt } => {
                    f.goto(sysid, *lat, *lon, *alt).await?;
                    format!("going to {lat:.7},{lon:.7} at {alt} m")
                }
                Action::Rtl => {
                    f.rtl(sysid).await?;
                    "returning to launch".to_string()
                }
                Action::Land => {
                    f.land(sysid).await?;
                    "landing".to_string()
                }
                Action::Reboot { no_wait: true } => {
                    f.send_reboot(sysid).await?;
                    "reboot sent".to_string()
                }
                Action::Reboot { no_wait: false } => {
                    let took = f.reboot(sysid).await?;
                    format!("rebooted, up again after {:.1} s", took.as_secs_f64())
                }
            };
            if args.conn.json {
                println!(
                    "{}",
                    serde_json::json!({"sysid": sysid, "ok": true, "result": done})
                );
            } else {
                println!("vehicle {sysid}: {done}");
            }
            anyhow::Ok(())
        }
        .await;
        s.close().await?;
        r.map(|_| ExitCode::SUCCESS)
    })?
}
