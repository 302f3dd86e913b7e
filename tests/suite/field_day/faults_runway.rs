//! Runway mapping: a field day's faults on the runway field-test mission
//! (`missions/runway-field-test.toml`) flown by two simulated ArduCopters over the small strip
//! world ([`common::WORLD`], five by three 4 m cells, the grid anchored at its centre) with their
//! cameras classifying on board, in virtual time (in-process links, tokio's clock paused),
//! each fault scheduled in the simulator ([`fleetmap_sim::fault`]) — and each run killed once
//! at a progress line (the GCS task aborted: nothing more is saved, as with SIGKILL between two
//! writes) and resumed from its run directory, as `fleetmap resume` does:
//!
//! * a link outage of one drone for 30 s, and of both for 5 minutes, mid-mission;
//! * a battery failsafe mid-flight (the charge drops to 15 %: the autopilot returns the drone
//!   by itself): the run says why, keeps what was mapped, the simulated crew swaps the battery
//!   and the drone rejoins (auto-resume);
//! * a camera that dies mid-run and comes back: declared silent (not a battery swap), the drone
//!   lands and rejoins by itself once its camera is heard again;
//! * cameras slower than the pictures asked: paced to 3 kB/s (whole pictures sent), or needing
//!   4 s between pictures.
//!
//! Each must complete the map within two points of IoU of the same seed flown without a
//! fault (measured once, [`reference`]), lose nothing the saved state had at the kill, and tell
//! the operator of the fault, naming the vehicle. The small world keeps the file's wall time
//! small (about 20 s a run); the 3-drone field test takes minutes a run.

use fleetmap::app::kind::Outcome;
use fleetmap::fleet::FleetHandle;
use fleetmap::kinds::runway::demo::{self, DemoConfig};
use fleetmap::kinds::runway::report::{MappingReport, report, truth_coverage};
use fleetmap::kinds::runway::{self, MappingEvent};
use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::geo::Cell;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;
use fleetmap_sim::fault::parse_faults;
use std::collections::BTreeSet;
use std::path::Path;
use tokio::sync::OnceCell;

use crate::common;

/// The drones.
const DRONES: u8 = 2;

/// What one run gave.
struct Flown {
    /// Every progress line the operator saw, both halves of the run.
    lines: Vec<String>,
    /// The journal.
    events: Vec<MappingEvent>,
    /// The final state.
    state: MappingState,
    /// Its report, scored against the world.
    report: MappingReport,
    /// The saved state and the journal's images when the GCS was killed (`None`: the run
    /// ended before the kill).
    at_kill: Option<(MappingState, BTreeSet<String>)>,
}

impl Flown {
    fn iou(&self) -> f64 {
        self.report.truth.as_ref().expect("scored").iou
    }

    fn told(&self, what: &[&str]) -> Vec<&String> {
        self.lines
            .iter()
            .filter(|l| what.iter().all(|w| l.contains(w)))
            .collect()
    }
}

/// Where the GCS dies: at the `after`-th progress line after the first that contains `mark`
/// (`""`: from the start).
struct Kill<'a> {
    mark: &'a str,
    after: usize,
}

/// Fly the field test over the strip with `faults` scheduled ([`fleetmap_sim::fault`]'s
/// spec; `""`: none), cameras classifying on board or sending every picture, the GCS killed
/// at `kill` (if the run gets that far) and resumed.
async fn fly(name: &str, faults: &str, onboard: bool, kill: Option<Kill<'_>>) -> Flown {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn")
        .try_init();
    let started = std::time::Instant::now();
    let world = World::from_toml(common::WORLD).unwrap();
    let mut text = common::strip_mission();
    for s in 2..=DRONES {
        text.push_str(&format!(
            "\n[[vehicles]]\nsysid = {s}\nrole = \"drone\"\nname = \"uav{s}\"\n"
        ));
    }
    let def = MissionDef::parse(&text, "strip").unwrap();
    let cfg = DemoConfig {
        drones: usize::from(DRONES),
        seed: 1,
        swap_after_s: 20.0,
        faults: if faults.is_empty() {
            Vec::new()
        } else {
            parse_faults(faults).unwrap()
        },
        onboard: onboard.then(|| runway::runway_definition_of(&def).expect("a runway mission")),
        ..DemoConfig::default()
    };
    let spec = format!("{DRONES}xcopter:ardupilot");
    let (fleet, sim) = demo::start_virtual(&spec, world.clone(), &cfg)
        .await
        .unwrap();
    let (state, _, dir, _tmp) = common::runway::new_run(&fleet, &def, &text).await;
    let mut marked: Option<usize> = None;
    let (mut lines, killed) = run(&fleet, &dir, state, |l| {
        let Some(k) = &kill else { return false };
        match &mut marked {
            None if l.contains(k.mark) => {
                marked = Some(0);
                k.after == 0
            }
            None => false,
            Some(n) => {
                *n += 1;
                *n >= k.after
            }
        }
    })
    .await;
    let mut at_kill = None;
    if killed {
        // The laptop comes back: `fleetmap resume` reads the run directory.
        let saved: MappingState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
        at_kill = Some((
            saved.clone(),
            common::runway::journal_images(&common::journal::<MappingEvent>(&dir)),
        ));
        let (more, _) = run(&fleet, &dir, saved, |_| false).await;
        lines.extend(more);
    }
    let state: MappingState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
    let report = report(&state, Some(&cov));
    let events = common::journal::<MappingEvent>(&dir);
    fleet.shutdown().await;
    let _ = sim.stop().await;
    let t = report.truth.as_ref().expect("scored");
    let m = &report.mission_time;
    for e in &events {
        if let MappingEvent::ImageFailed { sysid, reason } = e {
            println!("{name}: vehicle {sysid}: picture lost: {reason}");
        }
    }
    println!(
        "{name}: IoU {:.4} (best possible {:.4}), DFS start {:.0} s, map complete {:.0} s, \
         last landing {:.0} s, battery swaps {}, {} lines, killed: {}, {:.1} s of wall time",
        t.iou,
        t.iou_best_possible,
        m.to_dfs_start_s.unwrap_or(f64::NAN),
        m.to_map_complete_s.unwrap_or(f64::NAN),
        m.to_last_landing_s.unwrap_or(f64::NAN),
        report.battery_swaps,
        lines.len(),
        at_kill.is_some(),
        started.elapsed().as_secs_f64()
    );
    Flown {
        lines,
        events,
        state,
        report,
        at_kill,
    }
}

fn decisions(s: &MappingState) -> BTreeSet<(u64, u8, Cell, bool)> {
    s.book
        .decisions()
        .iter()
        .map(|d| (d.visit, d.vehicle, d.cell, d.positive))
        .collect()
}

/// Run `state` in `dir` with auto-resume to its end, or until `stop` says so of a progress
/// line (the GCS dies there); returns the lines and whether it was stopped. A run that ends
/// other than finished fails the test.
async fn run(
    fleet: &FleetHandle,
    dir: &Path,
    state: MappingState,
    stop: impl FnMut(&str) -> bool,
) -> (Vec<String>, bool) {
    match common::runway::run_until(fleet, dir, state, stop).await {
        (lines, None) => (lines, true),
        (lines, Some(Outcome::Finished)) => (lines, false),
        (lines, Some(other)) => panic!("the run ended with {other:?}\n{lines:#?}"),
    }
}

/// The same seed flown without a fault and without a kill: its IoU (measured once for the
/// whole file; whichever test asks first flies it).
async fn reference() -> f64 {
    static REFERENCE: OnceCell<f64> = OnceCell::const_new();
    *REFERENCE
        .get_or_init(|| async {
            let f = fly("no fault (reference)", "", true, None).await;
            assert!(f.state.is_finished() && f.report.found);
            assert_eq!(f.report.battery_swaps, 0);
            let t = f.report.truth.as_ref().expect("scored");
            assert!(
                t.iou >= t.iou_best_possible - 0.01,
                "the fault-free run's IoU {:.4} is not the best possible {:.4}",
                t.iou,
                t.iou_best_possible
            );
            t.iou
        })
        .await
}

/// The run was killed, resumed and finished; its map is within two points of IoU of the
/// fault-free run's; nothing the saved state had at the kill (detections, decisions), nor any
/// image the journal had acknowledged, is missing from the final state; and no line calls a
/// camera fault a battery swap.
async fn check(f: &Flown) {
    let reference = reference().await;
    let (saved, acked) = f
        .at_kill
        .as_ref()
        .expect("the run ended before the GCS was to be killed");
    assert!(f.state.is_finished(), "not finished");
    assert!(f.report.finished && f.report.found);
    assert!(
        f.iou() >= reference - 0.02,
        "IoU {:.4} against {reference:.4} without the fault",
        f.iou()
    );
    let kept = common::runway::detections(&f.state);
    let lost: Vec<_> = common::runway::detections(saved)
        .difference(&kept)
        .cloned()
        .collect();
    assert!(lost.is_empty(), "detections lost across the kill: {lost:?}");
    let lost: Vec<_> = acked.difference(&kept).cloned().collect();
    assert!(lost.is_empty(), "acknowledged images lost: {lost:?}");
    let decided = decisions(&f.state);
    let lost: Vec<_> = decisions(saved).difference(&decided).cloned().collect();
    assert!(lost.is_empty(), "decisions lost across the kill: {lost:?}");
    assert!(
        saved.book.decisions().len() < f.state.book.decisions().len(),
        "the kill came after the mapping"
    );
    assert!(common::runway::journal_images(&f.events).is_subset(&kept));
    let muddled = f.told(&["CAMERA", "battery swap"]);
    assert!(muddled.is_empty(), "{muddled:#?}");
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn the_fault_free_reference_maps_the_strip() {
    let iou = reference().await;
    println!("reference IoU {iou:.4}");
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn one_drone_dark_for_30_s() {
    let f = fly(
        "drone 2 dark 30 s",
        "2:outage@70s..100s",
        true,
        Some(Kill {
            mark: "vehicle 2: LINK LOST",
            after: 1,
        }),
    )
    .await;
    check(&f).await;
    let told = f.told(&["vehicle 2: LINK LOST"]);
    assert!(!told.is_empty(), "{:#?}", f.lines);
    assert!(
        !f.told(&["vehicle 2: link back"]).is_empty(),
        "{:#?}",
        f.lines
    );
    assert!(f.told(&["vehicle 1: LINK LOST"]).is_empty());
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn every_drone_dark_for_5_minutes() {
    let f = fly(
        "both dark 5 min",
        "all:outage@60s..360s",
        true,
        Some(Kill {
            mark: "LINK LOST",
            after: 1,
        }),
    )
    .await;
    check(&f).await;
    for v in 1..=DRONES {
        let lost = format!("vehicle {v}: LINK LOST");
        assert!(!f.told(&[&lost]).is_empty(), "{:#?}", f.lines);
    }
    // the map waits for the links: it is completed after they are back
    let done = f.report.mission_time.to_map_complete_s.expect("complete");
    assert!(done > 360.0, "map complete at {done} s");
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_battery_failsafe_mid_flight_keeps_the_map_and_the_drone_rejoins() {
    let f = fly(
        "drone 2 battery failsafe",
        "2:battery=15@45s",
        true,
        Some(Kill {
            mark: "vehicle 2: the autopilot's failsafe took over",
            after: 1,
        }),
    )
    .await;
    check(&f).await;
    let why = f.told(&[
        "vehicle 2: the autopilot's failsafe took over (RTL)",
        "battery swap",
    ]);
    assert!(!why.is_empty(), "{:#?}", f.lines);
    assert!(
        !f.told(&["vehicle 2: fresh battery: taking off to resume"])
            .is_empty(),
        "{:#?}",
        f.lines
    );
    let r2 = f.state.robot(2).unwrap();
    assert_eq!(r2.battery_swaps, 1);
    assert_eq!(f.state.robot(1).unwrap().battery_swaps, 0);
    let swapped = f
        .events
        .iter()
        .position(|e| matches!(e, MappingEvent::Swapped { sysid: 2, by } if by == "auto"))
        .expect("drone 2 swapped by itself");
    // and mapped after it rejoined
    assert!(
        f.events[swapped..]
            .iter()
            .any(|e| matches!(e, MappingEvent::Image { sysid: 2, .. })),
        "drone 2 took no picture after its swap"
    );
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_camera_that_dies_and_comes_back_lets_its_drone_rejoin() {
    let f = fly(
        "drone 1 camera off 60–100 s",
        "1:camera=off@60s..100s",
        true,
        Some(Kill {
            mark: "vehicle 1: CAMERA SILENT",
            after: 1,
        }),
    )
    .await;
    check(&f).await;
    assert!(
        !f.told(&["vehicle 1: CAMERA SILENT", "rejoins by itself"])
            .is_empty(),
        "{:#?}",
        f.lines
    );
    assert!(
        !f.told(&["vehicle 1: its camera is back", "rejoin"])
            .is_empty(),
        "{:#?}",
        f.lines
    );
    // a camera fault, not a battery swap
    assert!(
        f.told(&["vehicle 1", "battery swap"]).is_empty(),
        "{:#?}",
        f.lines
    );
    assert_eq!(f.state.robot(1).unwrap().battery_swaps, 0);
    let (saved, _) = f.at_kill.as_ref().unwrap();
    let r1 = saved.robot(1).unwrap();
    assert!(r1.camera_fault.is_some() && r1.camera_silent, "{r1:?}");
    let r1 = f.state.robot(1).unwrap();
    assert!(r1.camera_fault.is_none() && !r1.camera_silent);
    let back = f
        .events
        .iter()
        .position(|e| matches!(e, MappingEvent::CameraBack { sysid: 1 }))
        .expect("journalled");
    assert!(f.events[..back].iter().any(|e| matches!(
        e,
        MappingEvent::CameraFault {
            sysid: 1,
            silent: true,
            ..
        }
    )));
    assert!(
        f.events[back..]
            .iter()
            .any(|e| matches!(e, MappingEvent::Image { sysid: 1, .. })),
        "drone 1 took no picture after its camera came back"
    );
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn cameras_paced_to_3_kb_per_s_still_deliver_every_picture() {
    // Whole pictures (no on-board classification) paced to 3 kB/s.
    let f = fly(
        "cameras at 3 kB/s",
        "all:camera-rate=3000",
        false,
        Some(Kill {
            mark: "",
            after: 12,
        }),
    )
    .await;
    check(&f).await;
    assert!(f.told(&["CAMERA"]).is_empty(), "{:#?}", f.lines);
    // Every picture counted (`check`); one capture (vehicle 2's 21st, after a battery swap)
    // times out behind the slow transfers and is taken again in every run so far (a
    // follow-up), no more.
    assert!(
        f.state.image_failures <= 1,
        "{} pictures lost",
        f.state.image_failures
    );
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn cameras_needing_4_s_between_pictures_still_deliver_them() {
    let f = fly(
        "cameras 4 s between pictures",
        "all:camera-interval=4",
        true,
        Some(Kill {
            mark: "",
            after: 12,
        }),
    )
    .await;
    check(&f).await;
    assert!(f.told(&["CAMERA"]).is_empty(), "{:#?}", f.lines);
    assert_eq!(f.state.image_failures, 0, "pictures lost");
}
