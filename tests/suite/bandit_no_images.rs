//! A spatial-classification run whose pictures never reach the GCS: the drones fly
//! their sorties and take their pictures, but nothing arrives — as on PX4 SIH drones whose
//! camera ignored the mission's capture commands, twelve epochs of the same three goals with
//! no measurement and no word about it. The run now says after each sortie which drone's
//! visits are short of their images, and stops after three epochs in a row without a
//! measurement, with a reason, instead of flying the same goals for ever.

use fleetmap::kinds::bandit::sim::{self as bandit_sim, SimSetup};
use fleetmap::kinds::bandit::{self, BanditEvent, RunOptions};
use fleetmap::store::RunDir;
use fleetmap_core::planner::sortie::{ClassificationState, MAX_EPOCHS_WITHOUT_MEASUREMENT};
use fleetmap_core::world::World;
use std::time::Duration;

use crate::common;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_whose_pictures_never_arrive_stops_with_a_reason() {
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
    let setup = SimSetup {
        speedup: 20.0,
        seed: 3,
        camera_px: 160,
        battery_minutes: 12.0,
        charge_minutes: 6.0,
        sensor_flip: 0.0,
        onboard: None,
        radio: None,
        faults: Vec::new(),
    };
    let d = bandit_sim::start_team(bandit_sim::HARDWARE_TEAM, &world, &setup)
        .await
        .unwrap();
    let (state, run, dir, _tmp) = common::bandit::new_run(&d.fleet).await;
    // The image intake listens to a fleet with no link: the pictures the simulated cameras
    // take and send never reach it.
    let (_events, deaf_rx) = tokio::sync::mpsc::channel(1);
    let deaf = fleetmap::fleet::spawn(
        Vec::new(),
        deaf_rx,
        fleetmap::fleet::FleetConfig::default(),
        d.fleet.clock().clone(),
    );
    let hub = fleetmap::app::images::image_hub(&deaf);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<fleetmap::app::run::Progress>();
    let lines = tokio::spawn(async move {
        let mut all = Vec::new();
        while let Some(p) = rx.recv().await {
            println!("{p}");
            all.push(p.to_string());
        }
        all
    });
    let opts = RunOptions {
        progress: Some(tx),
        ..RunOptions::default()
    };
    let err = tokio::time::timeout(
        Duration::from_secs(600),
        bandit::run(d.fleet.clone(), &hub, run, state, opts),
    )
    .await
    .expect("the run did not stop within 600 s")
    .expect_err("a run without pictures cannot finish");
    let msg = fleetmap::app::error::chain(&err);
    assert!(
        msg.contains(&format!(
            "no measurement reached the GCS in the last {MAX_EPOCHS_WITHOUT_MEASUREMENT} epochs"
        )),
        "{msg}"
    );
    d.fleet.shutdown().await;
    deaf.shutdown().await;
    d.sim.stop().await.unwrap();
    let lines = lines.await.unwrap();
    // After every sortie, a warning names the drones whose visits got no image.
    assert!(
        lines
            .iter()
            .any(|l| l.contains("images missing after the sortie") && l.contains("0 of 30 at cell")),
        "{lines:#?}"
    );
    // Stopped at the start of the fourth epoch: three flown, none measured.
    let run = RunDir::open(&dir).unwrap();
    let st: ClassificationState = run.load_state().unwrap().unwrap();
    assert_eq!(st.epochs.len(), MAX_EPOCHS_WITHOUT_MEASUREMENT);
    assert!(
        st.epochs
            .iter()
            .all(|e| e.visits > 0 && e.measurements == 0)
    );
    assert_eq!(st.measurements, 0);
    let log = run.read_events::<BanditEvent>().unwrap();
    assert!(
        !log.events
            .iter()
            .any(|e| matches!(&e.event, BanditEvent::Measurement(_)))
    );
}
