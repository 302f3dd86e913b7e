//! Spatial classification: a field day's faults on the bandit paper's 6×6 hardware
//! mission (4 ArduCopter drones, 2 ArduRover charging stations) on the embedded simulator,
//! in virtual time (in-process links, tokio's clock paused), each fault scheduled in the
//! simulator ([`fleetmap_sim::fault`]) — and each run killed once at a moment drawn from the
//! fault's seed (the GCS task aborted: nothing more is saved, as with SIGKILL between two
//! writes) and resumed from its run directory, as `fleetmap resume` does:
//!
//! * a link outage of one drone for 30 s, and of every vehicle for 5 minutes, mid-sortie;
//! * a battery failsafe mid-sortie (the drone's charge drops to 15 %: its autopilot returns
//!   it): the run says why, keeps its measurements, plans its visits for the others, and the
//!   drone rejoins after the crew swapped its battery;
//! * a camera that dies mid-run and comes back; a camera slower than the samples asked
//!   (whole pictures, no on-board measurement, paced to a few kB/s): the sortie waits for the
//!   pictures still arriving;
//! * a charging rover stuck on its way to the rendezvous: the drones land on it where it
//!   stands instead of hovering until empty, and the run goes on with it held there.
//!
//! Every run must end with keep = the green tiles, nothing unclassified, no measurement
//! counted twice, and the operator told of the fault, naming the vehicle.

use crate::common::bandit::run_until;
use fleetmap::fleet::FleetHandle;
use fleetmap::kinds::bandit::sim::{self as bandit_sim, SimSetup};
use fleetmap::kinds::bandit::{self, BanditEvent};
use fleetmap::store::RunDir;
use fleetmap_core::planner::sortie::ClassificationState;
use fleetmap_sim::fault::parse_faults;
use fleetmap_sim::server::SimTask;
use std::collections::BTreeSet;

use crate::common;

/// What one faulty run gave.
struct Flown {
    /// Every progress line the operator saw, both halves of the run.
    lines: Vec<String>,
    /// The journal.
    events: Vec<BanditEvent>,
    /// The final state.
    state: ClassificationState,
    /// Simulated seconds to the end.
    seconds: f64,
    /// Whether the kill happened (the run was still going at the drawn moment).
    killed: bool,
}

/// Fly the hardware mission with `faults` scheduled in the simulator; the GCS is killed at
/// the `kill_at`-th progress line (if the run gets that far) and resumed.
async fn fly(name: &str, faults: &str, setup: SimSetup, crew: &[u8], kill_at: usize) -> Flown {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn,highs=error")
        .try_init();
    let (fleet, sim) = start(&setup, faults, crew).await;
    let (state, _, dir, _tmp) = common::bandit::new_run(&fleet).await;
    let mut n = 0;
    let (mut lines, killed) = run_until(&fleet, &dir, state, |_| {
        n += 1;
        n == kill_at
    })
    .await;
    if killed {
        // The laptop comes back: `fleetmap resume` reads the run directory.
        let saved: ClassificationState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
        let (more, _) = run_until(&fleet, &dir, saved, |_| false).await;
        lines.extend(more);
    }
    let state: ClassificationState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    let events = common::journal::<BanditEvent>(&dir);
    fleet.shutdown().await;
    let sim = sim.stop().await.unwrap();
    let seconds = sim.now().as_secs_f64();
    println!(
        "{name}: {} epochs, {} measurements, {} images ignored, {} failed, killed: {killed} \
         (at line {kill_at} of {}), {seconds:.0} s simulated",
        state.epochs.len(),
        state.measurements,
        state.ignored_images,
        state.image_failures,
        lines.len(),
    );
    Flown {
        lines,
        events,
        state,
        seconds,
        killed,
    }
}

/// The simulator with `faults` scheduled ([`fleetmap_sim::fault`]'s spec) and a fleet on it,
/// in virtual time; the crew swaps the batteries of the drones in `crew` 20 s after they
/// landed with a used one.
async fn start(setup: &SimSetup, faults: &str, crew: &[u8]) -> (FleetHandle, SimTask) {
    let (world, _) = common::bandit::hardware();
    let mut cfg = bandit_sim::sim_config(bandit_sim::HARDWARE_TEAM, &world, setup)
        .unwrap()
        .with_scheduled_faults(parse_faults(faults).unwrap());
    for &s in crew {
        cfg.vehicles[usize::from(s) - 1].swap_after_s = Some(20.0);
    }
    bandit_sim::start_virtual_with(cfg, setup).await.unwrap()
}

/// The run ended right: every cell classified, keep = the green tiles, and the journal's
/// measurements are the state's — numbered 1…n, each once: none counted twice across the
/// kill, none lost (the state is saved before its events are journalled, so a kill between
/// the two could leave a gap; the aborts here fall on other awaits, and a gap would show).
fn check_finished(f: &Flown) {
    let (world, _) = common::bandit::hardware();
    assert!(f.killed, "the run ended before the GCS was to be killed");
    assert!(f.state.is_finished(), "not finished");
    assert_eq!(f.state.bandit.keep(), world.green_cells(), "keep set");
    assert!(f.state.bandit.unclassified().is_empty());
    let mut numbers = BTreeSet::new();
    for e in &f.events {
        if let BanditEvent::Measurement(m) = e
            && m.n > 0
        {
            assert!(numbers.insert(m.n), "measurement {} journalled twice", m.n);
        }
    }
    let expected: BTreeSet<u64> = (1..=f.state.measurements).collect();
    assert_eq!(
        numbers, expected,
        "the journal's measurements are the state's"
    );
    assert!(matches!(
        f.events.last(),
        Some(BanditEvent::Finished { .. })
    ));
}

fn told<'a>(f: &'a Flown, what: &str) -> Vec<&'a String> {
    f.lines.iter().filter(|l| l.contains(what)).collect()
}

fn onboard() -> SimSetup {
    let (_, def) = common::bandit::hardware();
    SimSetup {
        seed: 3,
        camera_px: 160,
        charge_minutes: 6.0,
        onboard: bandit::green_spec_of(&def),
        ..SimSetup::default()
    }
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_drone_dark_for_30_s_and_everyone_dark_for_5_minutes() {
    // One drone's link out for 30 s mid-sortie; the whole team's for 5 minutes.
    let one = fly(
        "drone 2 dark 30 s",
        "2:outage@80s..110s",
        onboard(),
        &[],
        14,
    )
    .await;
    check_finished(&one);
    let all = fly(
        "everyone dark 5 min",
        "all:outage@80s..380s",
        onboard(),
        &[],
        20,
    )
    .await;
    check_finished(&all);
    println!("outage runs: {:.0} s and {:.0} s", one.seconds, all.seconds);
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_battery_failsafe_mid_sortie_keeps_the_samples_and_the_drone_rejoins() {
    let f = fly(
        "drone 2 battery failsafe",
        "2:battery=15@80s",
        onboard(),
        &[2],
        16,
    )
    .await;
    check_finished(&f);
    let out = told(&f, "drone 2: its autopilot took it out of its mission");
    assert!(!out.is_empty(), "{:#?}", f.lines);
    assert!(
        f.events
            .iter()
            .any(|e| matches!(e, BanditEvent::VehicleOut { sysid: 2, .. })),
        "drone 2 out in the journal"
    );
    for l in f
        .lines
        .iter()
        .filter(|l| l.contains("drone 2") || l.contains("vehicle 2"))
    {
        println!("  {l}");
    }
    // Landed off every station: flown to one once its battery is swapped, then back in.
    assert!(
        !told(&f, "drone 2: ready again").is_empty()
            && !told(&f, "flying it to station").is_empty(),
        "{:#?}",
        f.lines
    );
    assert!(
        f.events
            .iter()
            .any(|e| matches!(e, BanditEvent::VehicleBack { sysid: 2, .. })),
        "drone 2 rejoined: {:#?}",
        f.lines
    );
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_camera_that_dies_and_comes_back() {
    let f = fly(
        "drone 1 camera off 80–250 s",
        "1:camera=off@80s..250s",
        onboard(),
        &[],
        18,
    )
    .await;
    check_finished(&f);
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_camera_slower_than_the_samples_asked_still_delivers_them() {
    // Whole pictures (no on-board measurement) paced to 3 kB/s: a visit's 30 pictures take
    // longer than the hover over the cell.
    let setup = SimSetup {
        onboard: None,
        ..onboard()
    };
    let f = fly("cameras at 3 kB/s", "all:camera-rate=3000", setup, &[], 22).await;
    check_finished(&f);
    assert!(
        told(&f, "no measurement reached the GCS").is_empty(),
        "{:#?}",
        f.lines
    );
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_station_stuck_on_its_way_does_not_leave_drones_hovering() {
    let f = fly("station 5 stuck", "5:stuck@100s", onboard(), &[], 12).await;
    check_finished(&f);
    let stuck = told(&f, "station 5: stuck on its way");
    assert!(!stuck.is_empty(), "{:#?}", f.lines);
}
