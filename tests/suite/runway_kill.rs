//! The GCS killed with SIGKILL at 20 random moments of a runway-mapping run:
//! `fleetmap sim` and `fleetmap run` are separate processes; after every kill the run
//! directory loads, every detection acknowledged so far (journaled) is still in the saved
//! state, and `fleetmap resume` carries on. The run completes, and its map equals that of an
//! uninterrupted run of the same mission with the same simulator seed.
//!
//! The world is a small strip (five by three 4 m cells and a 0.25 m margin, see
//! [`common::WORLD`]) on a grid anchored at its centre, so that no cell's label depends on
//! which images happened to be taken when (checked below against the world's ground truth):
//! the test is about losing nothing, not about the classifier's edge cases, and it keeps CI
//! short.

use fleetmap::kinds::runway::report::truth_coverage;
use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::world::World;
use rand::{RngExt, SeedableRng};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::common;
use common::WORLD;
use fleetmap_test_kit::{Guard, free_udp_port};

/// The simulator's speed-up. The 20 kills come 0.3–2.5 s apart (28 s of GCS time on
/// average) and must all fall inside the run: at 20× the run sometimes finished after fewer
/// (1 of 12 runs on a quiet machine), at 10× it lasts about twice as long in wall time.
const SPEEDUP: &str = "10";

fn start_sim(world: &Path, port: u16) -> Guard {
    common::fleetmap().quiet(&[
        "sim",
        "--vehicles",
        "1xcopter:ardupilot",
        "--world",
        world.to_str().unwrap(),
        "--connect",
        &format!("udpin:127.0.0.1:{port}"),
        "--speedup",
        SPEEDUP,
        "--swap-after",
        "20",
        "--seed",
        "7",
    ])
}

fn run_args<'a>(mission: &'a str, conn: &'a str, dir: &'a str, world: &'a str) -> Vec<&'a str> {
    vec![
        "run",
        mission,
        "--connect",
        conn,
        "--headless",
        "--auto-resume",
        "--run-dir",
        dir,
        "--world",
        world,
    ]
}

fn saved(dir: &Path) -> Option<MappingState> {
    RunDir::open(dir)
        .expect("the run loads after a kill")
        .load_state::<MappingState>()
        .expect("the state loads after a kill")
}

#[test]
fn gcs_killed_twenty_times_loses_nothing_and_maps_the_same() {
    // FLEETMAP_KEEP_RUN=1 keeps both runs and their logs (the directory is printed).
    let (_guard, root) = {
        let tmp = tempfile::tempdir().unwrap();
        if std::env::var_os("FLEETMAP_KEEP_RUN").is_some() {
            let kept = tmp.keep();
            eprintln!("runs kept in {}", kept.display());
            (None, kept)
        } else {
            let root = tmp.path().to_path_buf();
            (Some(tmp), root)
        }
    };
    let world = root.join("strip.toml");
    std::fs::write(&world, WORLD).unwrap();
    // The field-test mission on a grid anchored at the strip's centre (not at the home the
    // simulated GPS reports).
    let fixed = common::strip_mission();
    let mission_path = root.join("strip-mission.toml");
    std::fs::write(&mission_path, fixed).unwrap();
    let mission = mission_path.to_str().unwrap();
    let w = world.to_str().unwrap().to_string();

    // 1. The uninterrupted reference run.
    let reference: PathBuf = root.join("reference");
    {
        let port = free_udp_port();
        let _sim = start_sim(&world, port);
        let conn = format!("udpout:127.0.0.1:{port}");
        let log = root.join("reference.log");
        let d = reference.to_str().unwrap().to_string();
        let mut g = common::fleetmap().logged(&run_args(mission, &conn, &d, &w), &log);
        let code = g.code_within(Duration::from_secs(300), &log);
        assert_eq!(code, 0, "{}", std::fs::read_to_string(&log).unwrap());
    }
    let ref_state = saved(&reference).unwrap();
    assert!(ref_state.is_finished());
    let ref_map = ref_state.book.positive_cells();
    // The premise: every cell the strip touches is wholly runway or barely touched, and the
    // uninterrupted run maps exactly the whole ones.
    let truth = truth_coverage(&ref_state.grid, &World::from_toml(WORLD).unwrap(), 0.0).unwrap();
    for (cell, f) in &truth {
        assert!(
            *f > 0.99 || *f < 0.1,
            "cell {cell} is {:.0} % runway: the strip is not aligned with the grid",
            f * 100.0
        );
    }
    let whole: Vec<_> = truth
        .iter()
        .filter(|(_, f)| **f > 0.5)
        .map(|(c, _)| *c)
        .collect();
    assert_eq!(whole.len(), 15);
    assert_eq!(
        ref_map, whole,
        "the uninterrupted run's map is not the strip"
    );

    // 2. The same run, killed 20 times.
    let port = free_udp_port();
    let _sim = start_sim(&world, port);
    let conn = format!("udpout:127.0.0.1:{port}");
    let run = root.join("killed");
    let d = run.to_str().unwrap().to_string();
    let log = root.join("killed.log");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2024);
    let mut child = common::fleetmap().logged(&run_args(mission, &conn, &d, &w), &log);
    // The run exists once its first state is saved; the kills start from there.
    let t0 = Instant::now();
    while !run.join("state.json").exists() {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "the run never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut kills = 0;
    let mut ever: BTreeSet<String> = BTreeSet::new();
    let mut finished_early = false;
    while kills < 20 {
        let delay = Duration::from_millis(rng.random_range(300..2500));
        std::thread::sleep(delay);
        if child.try_wait().unwrap().is_some() {
            finished_early = true;
            break;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        kills += 1;
        // The run loads; everything acknowledged is still there.
        let acked = common::runway::journal_images(&common::journal(&run));
        let state = saved(&run).expect("a saved state");
        let kept = common::runway::detections(&state);
        let lost: Vec<&String> = acked.difference(&kept).collect();
        assert!(
            lost.is_empty(),
            "kill {kills}: acknowledged detections lost: {lost:?}"
        );
        let gone: Vec<&String> = ever.difference(&kept).collect();
        assert!(
            gone.is_empty(),
            "kill {kills}: saved detections disappeared: {gone:?}"
        );
        ever = kept;
        if state.is_finished() {
            finished_early = true;
            break;
        }
        child = common::fleetmap().logged(&["resume", &d, "--headless", "--auto-resume"], &log);
    }
    if !finished_early {
        let code = child.code_within(Duration::from_secs(300), &log);
        assert_eq!(code, 0, "{}", std::fs::read_to_string(&log).unwrap());
    }
    let _ = child.kill();
    let _ = child.wait();
    let state = saved(&run).unwrap();
    assert!(
        state.is_finished(),
        "{}",
        std::fs::read_to_string(&log).unwrap()
    );
    let acked = common::runway::journal_images(&common::journal(&run));
    assert!(acked.is_subset(&common::runway::detections(&state)));
    eprintln!(
        "{kills} kills; reference map {:?}; killed-run map {:?}; {} images",
        ref_map,
        state.book.positive_cells(),
        state.images
    );
    assert_eq!(kills, 20, "the run ended after only {kills} kills");
    assert_eq!(state.book.positive_cells(), ref_map);
}
