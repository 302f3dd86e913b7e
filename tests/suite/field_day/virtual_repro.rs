//! Same seed, same run: a mission flown in virtual time — the simulator
//! behind in-process links, the GCS on a current-thread runtime whose clock is paused, as
//! `fleetmap experiment runway` and the end-to-end tests fly — is the same run every time it is
//! flown with the same seed, to the byte: the run directory (snapshot and journal), the
//! operator's progress lines and the report.
//!
//! Each flight gets a fresh runtime, as each trial of the study does. The machine's load must
//! not matter: nothing may depend on the order in which tokio picks among ready `select!`
//! branches, on a hash map's iteration order, on work finishing on another thread while the
//! paused clock jumps, or on a wall-clock reading.
//!
//! * Runway mapping: three drones over the strip world, their cameras classifying on board,
//!   each behind its own 2,000 B/s radio losing 10 % of its frames (results and audit pictures
//!   asked for again, commands retried), 4-minute batteries (swaps and reboots).
//! * Spatial classification: the bandit paper's 6×6 hardware mission (4 drones, 2 rover
//!   stations) to its end. Its journal and state hold the IP solver's wall time
//!   (`planned`'s `seconds`, `planner_s`, and the progress line's "planner … s"), a
//!   measurement of this machine: those fields are left out of the comparison, nothing else.

use fleetmap::app::images;
use fleetmap::app::kind::Outcome;
use fleetmap::kinds::bandit::sim::{self as bandit_sim, SimSetup};
use fleetmap::kinds::bandit::{self, BanditEvent};
use fleetmap::kinds::runway::demo::{self, DemoConfig};
use fleetmap::kinds::runway::report::{report, truth_coverage};
use fleetmap::kinds::runway::{self, RunOptions};
use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::planner::sortie::ClassificationState;
use fleetmap_core::world::World;
use fleetmap_io::link::radio::RadioConfig;
use serde_json::Value;
use std::path::Path;
use std::time::Instant;

use crate::common;

/// A fresh current-thread runtime with its clock paused: the study's trial runtime.
fn virtual_runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .expect("a runtime")
}

/// The files of the run directory `dir` that a run writes (`run.json`, `mission.toml`,
/// `state.json`, `events.jsonl`), name and bytes.
fn run_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// What one flight left behind.
#[derive(Debug, PartialEq)]
struct Flight {
    /// The run directory's files.
    files: Vec<(String, Vec<u8>)>,
    /// The operator's progress lines.
    lines: Vec<String>,
    /// The report (runway: its JSON) or the final state's summary.
    report: String,
    /// What to print of it.
    summary: String,
}

/// Where the first difference between two flights is, for the failure message.
fn first_difference(a: &Flight, b: &Flight) -> String {
    for ((na, ba), (nb, bb)) in a.files.iter().zip(&b.files) {
        if na != nb {
            return format!("files {na} / {nb}");
        }
        if ba != bb {
            let (ta, tb) = (String::from_utf8_lossy(ba), String::from_utf8_lossy(bb));
            for (k, (la, lb)) in ta.lines().zip(tb.lines()).enumerate() {
                if la != lb {
                    return format!("{na}, line {}:\n  {la}\n  {lb}", k + 1);
                }
            }
            return format!("{na}: {} / {} bytes", ba.len(), bb.len());
        }
    }
    if a.files.len() != b.files.len() {
        return format!("{} / {} files", a.files.len(), b.files.len());
    }
    for (k, (la, lb)) in a.lines.iter().zip(&b.lines).enumerate() {
        if la != lb {
            return format!("progress line {}:\n  {la}\n  {lb}", k + 1);
        }
    }
    if a.lines.len() != b.lines.len() {
        return format!("{} / {} progress lines", a.lines.len(), b.lines.len());
    }
    format!("reports:\n  {}\n  {}", a.report, b.report)
}

/// Fly `fly` twice, each on a fresh paused runtime, and require the same flight.
fn twice(what: &str, fly: impl Fn() -> Flight) {
    let mut flights = Vec::new();
    for k in 0..2 {
        let t = Instant::now();
        let f = fly();
        eprintln!(
            "{what}, flight {}: {} journal bytes, {} progress lines, {:.1} s of wall time; {}",
            k + 1,
            f.files
                .iter()
                .find(|(n, _)| n == "events.jsonl")
                .map_or(0, |(_, b)| b.len()),
            f.lines.len(),
            t.elapsed().as_secs_f64(),
            f.summary
        );
        flights.push(f);
    }
    let (a, b) = (&flights[0], &flights[1]);
    assert!(
        a.files
            .iter()
            .any(|(n, b)| n == "events.jsonl" && !b.is_empty()),
        "{what}: nothing journalled"
    );
    assert!(
        a == b,
        "{what}: the same seed flew two different runs; first difference: {}",
        first_difference(a, b)
    );
}

/// Three drones over the strip on simulator seed `seed` with `battery_min`-minute batteries: the
/// cameras classifying on board, each vehicle behind a 2,000 B/s radio losing 10 % of its
/// frames (`radio`); or whole pictures on links that carry everything. One flight.
fn fly_runway(seed: u64, radio: bool, battery_min: f64) -> Flight {
    virtual_runtime().block_on(async {
        let world = World::from_toml(common::WORLD).unwrap();
        let mut cfg = DemoConfig {
            drones: 3,
            seed,
            battery_minutes: battery_min,
            swap_after_s: 20.0,
            radio: radio.then(|| RadioConfig {
                loss: 0.1,
                ..RadioConfig::radio(2000)
            }),
            ..DemoConfig::default()
        };
        let mut text = common::strip_mission().replacen(
            "flight_time_min = 12.0",
            &format!("flight_time_min = {battery_min:?}"),
            1,
        );
        for k in 2..=cfg.drones {
            text.push_str(&format!(
                "\n[[vehicles]]\nsysid = {k}\nrole = \"drone\"\nname = \"uav{k}\"\n"
            ));
        }
        let def = MissionDef::parse(&text, "strip").unwrap();
        // Behind radios, cameras classifying on board: results, not pictures, cross them (the
        // GCS asks for a picture to audit a close vote).
        if radio {
            cfg.onboard = Some(runway::runway_definition_of(&def).expect("a runway mission"));
        }
        let (fleet, sim) = demo::start_virtual("3xcopter:ardupilot", world.clone(), &cfg)
            .await
            .unwrap();
        let (state, run_dir, dir, _tmp) = common::runway::new_run(&fleet, &def, &text).await;
        let hub = images::spawn(&fleet);
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
        let opts = RunOptions {
            auto_resume: true,
            progress: Some(tx),
            ..RunOptions::default()
        };
        let outcome = runway::run(fleet.clone(), &hub, run_dir, state, opts)
            .await
            .unwrap();
        assert_eq!(outcome, Outcome::Finished);
        let mut lines = Vec::new();
        while let Ok(l) = rx.try_recv() {
            lines.push(l.to_string());
        }
        let state: MappingState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
        let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
        let r = report(&state, Some(&cov));
        assert!(r.finished && r.cells_mapped > 0, "{r:?}");
        fleet.shutdown().await;
        let _ = sim.stop().await;
        let m = &r.mission_time;
        Flight {
            files: run_files(&dir),
            lines,
            report: serde_json::to_string(&r).unwrap(),
            summary: format!(
                "{} cells, {} images, {} swaps, map complete {:?} s, last landing {:?} s",
                r.cells_mapped, r.images, r.battery_swaps, m.to_map_complete_s, m.to_last_landing_s
            ),
        }
    })
}

#[test]
fn a_runway_run_in_virtual_time_is_the_same_every_time() {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn")
        .try_init();
    twice("runway, 3 drones, on board behind lossy radios", || {
        fly_runway(5, true, 4.0)
    });
    twice("runway, 3 drones, whole pictures, short batteries", || {
        fly_runway(2, false, 2.5)
    });
}

/// `v` with every field named in `wall` removed, at any depth.
fn without(mut v: Value, wall: &[&str]) -> Value {
    fn strip(v: &mut Value, wall: &[&str]) {
        match v {
            Value::Object(m) => {
                m.retain(|k, _| !wall.contains(&k.as_str()));
                m.values_mut().for_each(|x| strip(x, wall));
            }
            Value::Array(a) => a.iter_mut().for_each(|x| strip(x, wall)),
            _ => {}
        }
    }
    strip(&mut v, wall);
    v
}

/// `line` with the solver's wall time replaced by "…": "epoch P: G goals planned in K sensing
/// cycle(s) (0.03 s)" and "epoch P done: …, planner 0.05 s, …".
fn without_solver_time(line: &str) -> String {
    let mut out = line.to_string();
    for (before, after) in [(" sensing cycle(s) (", " s)"), (", planner ", " s")] {
        if let Some(i) = out.find(before) {
            let start = i + before.len();
            if let Some(j) = out[start..].find(after) {
                out.replace_range(start..start + j, "…");
            }
        }
    }
    out
}

/// The bandit paper's hardware mission to its end, in virtual time: one flight. The solver's
/// wall time is taken out of the journal (`planned`'s `seconds`, `epoch_done`'s `planner_s`),
/// the state (`planner_s`) and the progress lines.
fn fly_bandit(seed: u64) -> Flight {
    virtual_runtime().block_on(async {
        let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
        let setup = SimSetup {
            seed,
            camera_px: 160,
            charge_minutes: 6.0,
            ..SimSetup::default()
        };
        let (fleet, sim) = bandit_sim::start_virtual(bandit_sim::HARDWARE_TEAM, &world, &setup)
            .await
            .unwrap();
        let (state, run, dir, _tmp) = common::bandit::new_run(&fleet).await;
        let hub = images::image_hub(&fleet);
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
        let opts = bandit::RunOptions {
            progress: Some(tx),
            auto_resume: true,
            ..bandit::RunOptions::default()
        };
        bandit::run(fleet.clone(), &hub, run, state, opts)
            .await
            .unwrap();
        let mut lines = Vec::new();
        while let Ok(l) = rx.try_recv() {
            lines.push(without_solver_time(&l.to_string()));
        }
        let saved = RunDir::open(&dir).unwrap();
        let done: ClassificationState = saved.load_state().unwrap().unwrap();
        assert!(done.is_finished());
        assert_eq!(done.bandit.keep(), world.green_cells(), "keep set");
        let state: Value = saved.load_state().unwrap().unwrap();
        let journal: Vec<Value> = saved
            .read_events::<BanditEvent>()
            .unwrap()
            .events
            .into_iter()
            .map(|l| {
                let v = without(serde_json::to_value(l.event).unwrap(), &["planner_s"]);
                if v["event"] == "planned" {
                    without(v, &["seconds"])
                } else {
                    v
                }
            })
            .collect();
        fleet.shutdown().await;
        let _ = sim.stop().await;
        let mut files: Vec<(String, Vec<u8>)> = run_files(&dir)
            .into_iter()
            .filter(|(n, _)| n != "state.json" && n != "events.jsonl")
            .collect();
        // one record a line, and the state pretty-printed: a difference names its line
        let journal: String = journal.iter().map(|v| v.to_string() + "\n").collect();
        files.push(("events.jsonl".into(), journal.into_bytes()));
        files.push((
            "state.json".into(),
            serde_json::to_vec_pretty(&without(state, &["planner_s"])).unwrap(),
        ));
        files.sort();
        let report = format!(
            "{} epochs, {} vehicles flew",
            done.epochs.len(),
            done.airborne_s.values().filter(|s| **s > 0.0).count()
        );
        Flight {
            files,
            lines,
            summary: report.clone(),
            report,
        }
    })
}

#[test]
fn a_bandit_run_in_virtual_time_is_the_same_every_time() {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn,highs=error")
        .try_init();
    twice("spatial classification, hardware mission", || fly_bandit(3));
}
