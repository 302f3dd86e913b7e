//! `fleetmap signing keygen|setup|remove`: MAVLink 2 signing keys.
//!
//! * `keygen --passphrase TEXT [--out FILE]`: the key is SHA-256 of the passphrase, as
//!   MAVProxy (`signing setup PASSPHRASE`, `mavproxy_signing.py` `passphrase_to_key`) and
//!   Mission Planner derive it, so the same passphrase gives the same key in all three.
//!   Written as 64 hexadecimal digits (file mode 0600).
//! * `setup --connect CONN --sysid N --key FILE`: sends SETUP_SIGNING with the key and an
//!   initial timestamp (10 µs units since 2015-01-01, as MAVProxy computes it) to the
//!   vehicle's autopilot, which stores it (ArduPilot `GCS_Signing.cpp`
//!   `handle_setup_signing`, not while armed) and from then on signs and requires
//!   signatures. SETUP_SIGNING has no acknowledgement, so it is sent three times, unsigned
//!   (the vehicle has no key yet), and the command then listens for a signed heartbeat with
//!   the new key to confirm. PX4 1.16 has no MAVLink signing and ignores it.
//! * `remove --connect CONN --sysid N --signing-key FILE`: SETUP_SIGNING with an all-zero
//!   key, signed with the current one; confirmed by an unsigned heartbeat.

use super::vehicles::{ConnectArgs, Session, block_on};
use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use fleetmap_io::clock::unix_us;
use fleetmap_io::link::signing::{SigningKey, signing_timestamp};
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{HEARTBEAT_DATA, MavMessage, SETUP_SIGNING_DATA};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of `fleetmap signing`.
#[derive(Debug, Args)]
pub struct SigningArgs {
    /// What to do.
    #[command(subcommand)]
    pub what: SigningCommand,
}

/// The signing subcommands.
#[derive(Debug, Subcommand)]
pub enum SigningCommand {
    /// Make a key file from a passphrase (SHA-256, as MAVProxy and Mission Planner).
    Keygen {
        /// The passphrase.
        #[arg(long)]
        passphrase: String,
        /// Where to write the key (stdout if absent).
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Send the key to a vehicle (SETUP_SIGNING).
    Setup {
        /// Connection options (do not give --signing-key: the vehicle has no key yet).
        #[command(flatten)]
        conn: ConnectArgs,
        /// The vehicle's system id.
        #[arg(long, value_name = "N")]
        sysid: u8,
        /// The key file to install.
        #[arg(long, value_name = "FILE")]
        key: PathBuf,
        /// Wait this long for the vehicle's first heartbeat, seconds.
        #[arg(long, value_name = "SECONDS", default_value_t = 15.0)]
        wait: f64,
    },
    /// Remove the key from a vehicle: SETUP_SIGNING with an all-zero key and timestamp,
    /// which ArduPilot and PX4 take as "signing off" (MAVProxy's `signing remove`). Give
    /// --signing-key with the vehicle's current key: a signing vehicle ignores it unsigned.
    Remove {
        /// Connection options, with --signing-key.
        #[command(flatten)]
        conn: ConnectArgs,
        /// The vehicle's system id.
        #[arg(long, value_name = "N")]
        sysid: u8,
        /// Wait this long for the vehicle's first heartbeat, seconds.
        #[arg(long, value_name = "SECONDS", default_value_t = 15.0)]
        wait: f64,
    },
}

/// Send SETUP_SIGNING with `secret_key` and `timestamp` to vehicle `sysid` (heard within
/// `wait`) and return whether one of its heartbeats then `confirms` the change within 5 s.
/// SETUP_SIGNING has no acknowledgement, so it goes out three times. An armed vehicle is
/// refused here: ArduPilot ignores SETUP_SIGNING while armed (`GCS_Signing.cpp`
/// `handle_setup_signing`, "ERROR: Won't setup signing when armed").
async fn send_setup_signing(
    s: &Session,
    sysid: u8,
    wait: Duration,
    secret_key: [u8; 32],
    timestamp: u64,
    confirms: impl Fn(&fleetmap_io::link::codec::Frame) -> bool,
) -> anyhow::Result<bool> {
    let v = s.vehicle(sysid, wait).await?;
    if v.armed {
        bail!(
            "vehicle {sysid} is armed: autopilots do not change their signing key while armed; disarm it first"
        );
    }
    let msg = MavMessage::SETUP_SIGNING(SETUP_SIGNING_DATA {
        initial_timestamp: timestamp,
        target_system: sysid,
        target_component: v.compid,
        secret_key,
    });
    let mut sub = s.fleet.subscribe();
    for _ in 0..3 {
        s.fleet.send(msg.clone()).await?;
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let confirmed = tokio::time::timeout(Duration::from_secs(5), async {
        while let Ok(inc) = sub.recv().await {
            let f = &inc.frame;
            if f.sysid() == sysid && f.msg_id == HEARTBEAT_DATA::ID && confirms(f) {
                return true;
            }
        }
        false
    })
    .await
    .unwrap_or(false);
    Ok(confirmed)
}

/// Run `fleetmap signing`.
pub fn run(args: SigningArgs) -> anyhow::Result<ExitCode> {
    match args.what {
        SigningCommand::Keygen { passphrase, out } => {
            if passphrase.is_empty() {
                bail!("the passphrase is empty");
            }
            let key = SigningKey::from_passphrase(&passphrase);
            match out {
                Some(path) => {
                    fleetmap_io::files::atomic_write(
                        &path,
                        format!("{}\n", key.to_hex()).as_bytes(),
                    )
                    .with_context(|| format!("cannot write {}", path.display()))?;
                    #[cfg(unix)]
                    {
                        use std::os::unix::fs::PermissionsExt;
                        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600))
                            .with_context(|| format!("cannot restrict {}", path.display()))?;
                    }
                    println!(
                        "key written to {} (fingerprint {})",
                        path.display(),
                        key.fingerprint()
                    );
                }
                None => println!("{}", key.to_hex()),
            }
            Ok(ExitCode::SUCCESS)
        }
        SigningCommand::Setup {
            conn,
            sysid,
            key,
            wait,
        } => {
            if conn.signing_key.is_some() {
                bail!("signing setup sends the key unsigned: do not give --signing-key");
            }
            if !(wait.is_finite() && wait >= 0.0) {
                bail!("--wait must be a non-negative number of seconds");
            }
            let key = SigningKey::read(&key)?;
            block_on(async move {
                let s = Session::open(&conn).await?;
                let r = async {
                    // Confirmation: a heartbeat from the vehicle signed with the new key.
                    let confirmed = send_setup_signing(
                        &s,
                        sysid,
                        Duration::from_secs_f64(wait),
                        key.0,
                        signing_timestamp(unix_us()),
                        |f| {
                            let Some(sig) = f.signature else {
                                return false;
                            };
                            let n = f.raw.len();
                            let expected = fleetmap_io::link::signing::Signing::signature(
                                &key,
                                &f.raw[..n - 13],
                                f.raw[n - 13],
                                sig.timestamp,
                            );
                            expected[..] == f.raw[n - 6..]
                        },
                    )
                    .await?;
                    if conn.json {
                        println!(
                            "{}",
                            serde_json::json!({"sysid": sysid, "sent": true, "confirmed": confirmed, "fingerprint": key.fingerprint()})
                        );
                    } else if confirmed {
                        println!("vehicle {sysid} now signs with key {}", key.fingerprint());
                    } else {
                        println!(
                            "SETUP_SIGNING sent to vehicle {sysid} (key {}); no signed heartbeat seen yet — connect with --signing-key to check",
                            key.fingerprint()
                        );
                    }
                    anyhow::Ok(())
                }
                .await;
                s.close().await?;
                r.map(|_| ExitCode::SUCCESS)
            })?
        }
        SigningCommand::Remove {
            mut conn,
            sysid,
            wait,
        } => {
            // The confirmation is an unsigned heartbeat: the link must let it through.
            conn.allow_unsigned = true;
            if conn.signing_key.is_none() {
                bail!("signing remove must be signed with the vehicle's key: give --signing-key");
            }
            if !(wait.is_finite() && wait >= 0.0) {
                bail!("--wait must be a non-negative number of seconds");
            }
            block_on(async move {
                let s = Session::open(&conn).await?;
                let r = async {
                    // Confirmation: an unsigned heartbeat from the vehicle.
                    let confirmed = send_setup_signing(
                        &s,
                        sysid,
                        Duration::from_secs_f64(wait),
                        [0; 32],
                        0,
                        |f| f.signature.is_none(),
                    )
                    .await?;
                    if conn.json {
                        println!(
                            "{}",
                            serde_json::json!({"sysid": sysid, "sent": true, "confirmed": confirmed})
                        );
                    } else if confirmed {
                        println!("vehicle {sysid} no longer signs");
                    } else {
                        println!("signing removal sent to vehicle {sysid}; it still sends signed heartbeats");
                    }
                    if confirmed {
                        anyhow::Ok(())
                    } else {
                        Err(anyhow::anyhow!("vehicle {sysid} still signs after the removal"))
                    }
                }
                .await;
                s.close().await?;
                r.map(|_| ExitCode::SUCCESS)
            })?
        }
    }
}
