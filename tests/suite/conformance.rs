//! The conformance checks of `hitl/conformance.py` against the embedded simulator,
//! an ArduPilot and a PX4 copter side by side: ready, upload right after a reboot, mission
//! round trips through `fleetmap relay` at 0, 30 and 50 % loss (+ 5 % duplicates), a flight
//! with `fleetmap mission fly`, signing, arming and take-off when commands come late or twice,
//! telemetry per message against the tables measured on SITL (and the slowdown under
//! RADIO_STATUS), and the runway field test (over a small world, with the GCS killed and
//! resumed in the middle). The same runner, pointed at a connection
//! string, checks a real autopilot (docs/results/conformance.md has the table).
//!
//! The simulators run at real time for the transfers (judged on the clock the autopilot's own
//! timeouts run on) and the two runs mostly wait, so they run in parallel: a few minutes.

use crate::common;

#[test]
fn conformance_checks_pass_against_the_simulator() {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/hitl/conformance.py");
    // The runway check flies the field-test mission over the small strip world of the
    // other runway tests (see `common::WORLD`), on a grid anchored at its centre: the same
    // check as on a real autopilot, minutes shorter.
    let tmp = tempfile::tempdir().unwrap();
    let world = tmp.path().join("strip.toml");
    std::fs::write(&world, common::WORLD).unwrap();
    let fixed = common::strip_mission();
    let mission = tmp.path().join("strip-mission.toml");
    std::fs::write(&mission, fixed).unwrap();
    let (world, mission) = (world.to_str().unwrap(), mission.to_str().unwrap());
    let runs: Vec<(&str, std::process::Child)> = ["sim:ardupilot-copter", "sim:px4-copter"]
        .into_iter()
        .map(|target| {
            let child = std::process::Command::new("python3")
                .args([
                    script,
                    target,
                    "--items",
                    "10",
                    "--trials",
                    "1",
                    "--losses",
                    "0,30,50",
                    "--checks",
                    "ready,boot,transfer,fly,signing,arming,streams,runway",
                    "--world",
                    world,
                    "--mission",
                    mission,
                    "--kill-after",
                    "10",
                ])
                .env("FLEETMAP", common::fleetmap().path())
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .expect("python3 runs hitl/conformance.py");
            (target, child)
        })
        .collect();
    let mut failed = Vec::new();
    for (target, child) in runs {
        let out = child.wait_with_output().expect("the runner finishes");
        let text = String::from_utf8_lossy(&out.stdout);
        eprintln!("{text}{}", String::from_utf8_lossy(&out.stderr));
        if !out.status.success() {
            failed.push(target);
        }
        for check in [
            "ready",
            "boot",
            "transfer 0%",
            "transfer 30%",
            "transfer 50%",
            "fly",
            "signing",
            "arming",
            "streams",
            "runway",
        ] {
            assert!(
                text.lines()
                    .any(|l| l.starts_with("PASS") && l.contains(&format!(" {check} "))),
                "{target}: check {check:?} did not pass:\n{text}"
            );
        }
    }
    assert!(failed.is_empty(), "conformance failed for {failed:?}");
}
