//! Runway mapping end to end on the embedded simulator (issue 6): the GCS's runway run
//! (`fleetmap::app::runway`) flies simulated ArduPilot copters over the runway world through
//! the real fleet, link codec and image transfer, on tokio's paused clock — fully virtual
//! time, so a flight of an hour and more takes only the CPU time of its work.

use fleetmap::app::demo::{self, DemoConfig};
use fleetmap::app::images;
use fleetmap::app::runway::report::{report, truth_coverage};
use fleetmap::app::runway::{self, Outcome, RunOptions};
use fleetmap::explore::Sharing;
use fleetmap::explore::mapping::{MappingState, RobotStatus};
use fleetmap::geo::local;
use fleetmap::sim::world::World;
use fleetmap::store::{RunDir, RunMeta};
use std::time::Duration;

struct Finished {
    state: MappingState,
    report: fleetmap::app::runway::report::MappingReport,
    fleet: fleetmap::fleet::FleetHandle,
}

async fn fly(drones: usize, seed: u64) -> Finished {
    let world = World::from_toml(demo::RUNWAY_WORLD).unwrap();
    let cfg = DemoConfig {
        drones,
        seed,
        ..DemoConfig::default()
    };
    let (text, def) = demo::runway_mission(&cfg).unwrap();
    let spec = format!("{drones}xcopter:ardupilot");
    let (fleet, sim) = demo::start_virtual(&spec, world.clone(), &cfg)
        .await
        .unwrap();
    let state = fleetmap::app::new_mapping(&fleet, &def, Sharing::Gcs, Duration::from_secs(60))
        .await
        .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let run_dir = RunDir::create(
        tmp.path().join("run"),
        RunMeta::new(runway::KIND, 0),
        Some(&text),
    )
    .unwrap();
    let path = run_dir.path().to_path_buf();
    let hub = images::spawn(&fleet);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let printer = tokio::spawn(async move {
        while let Some(line) = rx.recv().await {
            eprintln!("{line}");
        }
    });
    let opts = RunOptions {
        auto_resume: true,
        progress: Some(tx),
        ..RunOptions::default()
    };
    let outcome = runway::run(fleet.clone(), &hub, run_dir, state, opts)
        .await
        .unwrap();
    assert_eq!(outcome, Outcome::Finished);
    let _ = printer.await;
    // What was saved is what the report reads.
    let state: MappingState = RunDir::open(&path).unwrap().load_state().unwrap().unwrap();
    let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
    let r = report(&state, Some(&cov));
    let _ = sim.stop().await;
    Finished {
        state,
        report: r,
        fleet,
    }
}

fn print(r: &fleetmap::app::runway::report::MappingReport) {
    let t = r.truth.as_ref().unwrap();
    eprintln!(
        "runway: {} cells mapped, tree {} vertices, {} images, {} decisions ({} FP, {} FN), \
         IoU {:.3} (best possible {:.3}, paper {:.3}), {:.0} s airborne, {} battery swaps",
        r.cells_mapped,
        r.tree_vertices,
        r.images,
        r.detections,
        t.false_positives,
        t.false_negatives,
        t.iou,
        t.iou_best_possible,
        t.paper_iou,
        r.flight_time_s,
        r.battery_swaps
    );
}

/// The runway paper's field test (§7): one UAV, 12-minute batteries, 4 m cells at 12 m,
/// 1 m/s, five images per cell. It must finish with battery swaps, and its map must be
/// within 5 points of IoU of the best any labelling of this grid can reach (the paper's own
/// map reached 75.7 %).
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn one_robot_maps_the_runway_with_battery_swaps() {
    let f = fly(1, 1).await;
    print(&f.report);
    let t = f.report.truth.as_ref().unwrap();
    assert!(f.report.finished);
    assert!(
        f.report.battery_swaps >= 1,
        "no battery swap: {:?}",
        f.report
    );
    assert!(
        t.iou >= t.iou_best_possible - 0.05,
        "IoU {:.3} is more than 5 points below the best possible {:.3}",
        t.iou,
        t.iou_best_possible
    );
    assert!(f.report.tree_vertices >= 100, "{}", f.report.tree_vertices);
}

/// Three robots: every cell of the runway explored, every robot back at the start and then
/// home.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn three_robots_explore_every_runway_cell_and_come_back() {
    let f = fly(3, 2).await;
    print(&f.report);
    let s = &f.state;
    let ex = s.explorer.as_ref().unwrap();
    assert!(ex.is_finished());
    assert_eq!(f.report.unexplored_vertices, 0);
    assert_eq!(f.report.explored_vertices, f.report.tree_vertices);
    // Every cell mostly on the runway is in the map and was visited by the DFS.
    let t = f.report.truth.as_ref().unwrap();
    assert!(
        t.region_cells_mapped * 100 >= t.region_cells * 95,
        "{} of {} runway cells mapped",
        t.region_cells_mapped,
        t.region_cells
    );
    for r in &s.robots {
        assert_eq!(r.status, RobotStatus::Landed, "vehicle {}", r.sysid);
        // back at the start, then landed at home
        let v = f.fleet.vehicle(r.sysid).unwrap();
        let (p, h) = (v.position.unwrap(), v.home.unwrap());
        assert!(
            local::distance(p.lat, p.lon, h.lat, h.lon) < 3.0,
            "vehicle {} is not home",
            r.sysid
        );
        assert!(!v.armed);
        assert_eq!(
            ex.robot(fleetmap::explore::RobotId(r.sysid)).unwrap().phase,
            fleetmap::explore::dfs::Phase::Done
        );
    }
    assert!(f.report.robots.iter().all(|r| r.images > 0));
}
