//! `fleetmap signing keygen|setup` end to end: a key made from a passphrase as MAVProxy
//! makes it, installed on a `fleetmap sim` vehicle (a separate process) with SETUP_SIGNING; from
//! then on the vehicle ignores an unsigned command and obeys a signed one.

use sha2::{Digest, Sha256};
use std::process::Output;

use crate::common;
use fleetmap_test_kit::free_udp_port;

/// `fleetmap <what> --connect CONN --sysid 1 <rest>`.
fn on_vehicle_1(what: &[&str], conn: &str, rest: &[&str]) -> Output {
    let mut args = what.to_vec();
    args.extend(["--connect", conn, "--sysid", "1"]);
    args.extend(rest);
    common::fleetmap().output(&args)
}

fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout: {}\nstderr: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn keygen_then_setup_makes_the_vehicle_require_signatures() {
    let tmp = tempfile::tempdir().unwrap();
    let key = tmp.path().join("field.key");
    let key_s = key.to_str().unwrap();

    // keygen: SHA-256 of the passphrase, 64 hex digits, readable by the owner only.
    let out = common::fleetmap().output(&[
        "signing",
        "keygen",
        "--passphrase",
        "runway team 7",
        "--out",
        key_s,
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let hex = std::fs::read_to_string(&key).unwrap();
    let want: String = Sha256::digest(b"runway team 7")
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(hex.trim(), want);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&key).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600, "key file mode {mode:o}");
    }
    let empty = common::fleetmap().output(&["signing", "keygen", "--passphrase", ""]);
    assert!(!empty.status.success());

    // A simulated copter without a key.
    let port = free_udp_port();
    let _sim = common::fleetmap().quiet(&[
        "sim",
        "--vehicles",
        "1xcopter:ardupilot",
        "--home",
        "37.1968,-80.5781",
        "--connect",
        &format!("udpin:127.0.0.1:{port}"),
        "--seed",
        "2",
    ]);
    let conn = format!("udpout:127.0.0.1:{port}");

    // Before the key: an unsigned command is obeyed.
    let before = on_vehicle_1(&["command"], &conn, &["--json", "mode", "STABILIZE"]);
    assert!(before.status.success(), "{}", text(&before));

    // setup: the vehicle stores the key and confirms with a heartbeat signed with it.
    let setup = on_vehicle_1(&["signing", "setup"], &conn, &["--key", key_s, "--json"]);
    assert!(setup.status.success(), "{}", text(&setup));
    let v: serde_json::Value = serde_json::from_slice(&setup.stdout).unwrap();
    assert_eq!(v["confirmed"], true, "{v}");
    assert_eq!(v["sysid"], 1);
    // setup sends the key unsigned: refusing --signing-key is the command's own rule.
    let twice = on_vehicle_1(
        &["signing", "setup"],
        &conn,
        &["--key", key_s, "--signing-key", key_s],
    );
    assert!(!twice.status.success());

    // After: the same unsigned command gets no answer (the vehicle drops it) …
    let unsigned = on_vehicle_1(&["command"], &conn, &["--wait", "5", "mode", "ALT_HOLD"]);
    assert!(!unsigned.status.success(), "{}", text(&unsigned));
    assert!(
        String::from_utf8_lossy(&unsigned.stderr).contains("no COMMAND_ACK"),
        "{}",
        text(&unsigned)
    );
    // … and a signed one is obeyed.
    let signed = on_vehicle_1(
        &["command"],
        &conn,
        &["--signing-key", key_s, "--json", "mode", "ALT_HOLD"],
    );
    assert!(signed.status.success(), "{}", text(&signed));
    assert!(
        String::from_utf8_lossy(&signed.stdout).contains("\"result\":\"mode ALT_HOLD\""),
        "{}",
        text(&signed)
    );
}
