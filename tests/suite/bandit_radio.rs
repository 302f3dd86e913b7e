//! The bandit paper's 6×6 mission over telemetry radios. Every vehicle sends to one
//! GCS port through its own SiK radio pair (`fleetmap relay --radio 5000`: a 57,600-baud
//! radio's 5,000 bytes a second shared by both directions, as its time-division duplex
//! shares the air, a 4 kB buffer in each radio with tail drop, RADIO_STATUS written into
//! both sides), on the simulator's clock; the drones' cameras measure on board and send the
//! green share (52 bytes) instead of the picture. The mission ends with keep = the green
//! tiles, no labelling error, and no more epochs than the same flight on unlimited links.

use fleetmap::fleet;
use fleetmap::kinds::bandit::report as bandit_report;
use fleetmap::kinds::bandit::sim::{self as bandit_sim, SimSetup};
use fleetmap::kinds::bandit::{self, RunOptions};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;
use fleetmap_io::link::radio::{RadioConfig, RadioStats};
use fleetmap_io::link::relay::{Relay, RelayOptions, RelayStats};
use fleetmap_sim::server::GcsClock;
use std::time::{Duration, Instant};

use crate::common;

/// Simulated seconds per wall second (the relays follow the simulator's clock).
const SPEEDUP: f64 = 20.0;

struct Flight {
    report: bandit_report::ClassificationReport,
    keep_is_truth: bool,
    /// Each relay's counts (empty without relays).
    radios: Vec<RelayStats>,
}

/// Fly the hardware mission with on-board measurement, each vehicle behind a radio pair
/// carrying `rate` bytes a second in all (`None`: straight to the GCS port).
async fn fly(name: &str, rate: Option<u32>) -> Flight {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn,highs=error")
        .try_init();
    let t0 = Instant::now();
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
    let def = MissionDef::parse(bandit_sim::HARDWARE_MISSION, "hardware-6x6.toml").unwrap();
    let green = world.green_cells();
    let setup = SimSetup {
        speedup: SPEEDUP,
        seed: 3,
        camera_px: 160,
        charge_minutes: 6.0,
        onboard: bandit::green_spec_of(&def),
        ..SimSetup::default()
    };
    let cfg = bandit_sim::sim_config(bandit_sim::HARDWARE_TEAM, &world, &setup).unwrap();

    // The GCS: one UDP port for the whole team.
    let (link, ev_rx, gcs) = fleetmap_test_kit::gcs::listening_link().await;

    // One radio per vehicle, each sending to the GCS port from its own socket.
    let mut relays = Vec::new();
    let mut endpoints = Vec::new();
    for _ in 0..6 {
        match rate {
            Some(rate) => {
                let r = Relay::open(
                    format!("udpout:{gcs}").parse().unwrap(),
                    "udpin:127.0.0.1:0".parse().unwrap(),
                    RelayOptions {
                        radio: RadioConfig::radio(rate),
                        ..RelayOptions::default()
                    },
                )
                .await
                .unwrap();
                let v = r.vehicle_local().unwrap();
                endpoints.push(fleetmap_test_kit::sim::udpout(v));
                relays.push(r);
            }
            None => endpoints.push(fleetmap_test_kit::sim::udpout(gcs)),
        }
    }
    let handle = fleetmap_test_kit::sim::serve(cfg, endpoints, SPEEDUP, GcsClock::Simulator).await;
    let (stop_tx, stop_rx) = fleetmap_io::watch::channel(false);
    let radios: Vec<_> = relays
        .into_iter()
        .map(|r| {
            let mut stop = stop_rx.clone();
            tokio::spawn(r.with_clock(handle.clock()).run(
                Duration::from_secs(3600),
                |_| {},
                async move {
                    let _ = stop.wait_for(|s| *s).await;
                },
            ))
        })
        .collect();
    let fleet = fleet::spawn(
        vec![link],
        ev_rx,
        fleet::FleetConfig::at_speedup(SPEEDUP),
        handle.clock(),
    );
    let (state, run, _, _tmp) = common::bandit::new_run(&fleet).await;
    let hub = fleetmap::app::images::image_hub(&fleet);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let label = name.to_string();
    let printer = tokio::spawn(async move {
        while let Some(l) = rx.recv().await {
            println!("[{label} {:6.1} s] {l}", t0.elapsed().as_secs_f64());
        }
    });
    let done = tokio::time::timeout(
        Duration::from_secs(400),
        bandit::run(
            fleet.clone(),
            &hub,
            run,
            state,
            RunOptions {
                progress: Some(tx),
                ..RunOptions::default()
            },
        ),
    )
    .await
    .unwrap_or_else(|_| panic!("{name}: the run did not finish within 400 s"))
    .unwrap_or_else(|e| {
        panic!(
            "{name}: the run failed: {}",
            fleetmap::app::error::chain(&e)
        )
    });
    fleet.shutdown().await;
    let _ = stop_tx.send(true);
    let mut stats = Vec::new();
    for r in radios {
        stats.push(r.await.unwrap());
    }
    let _ = handle.stop().await;
    printer.abort();
    let report = bandit_report::report(&done, Some(&green));
    println!(
        "{name}: {} epochs, {} measurements, {} images ignored, {} failed, {:.0} s of drone \
         flight, wall {:.1} s; radios (up B, up dropped, down B, down dropped, s): {:?}",
        report.epochs,
        report.measurements,
        done.ignored_images,
        done.image_failures,
        report.flight_time_s,
        t0.elapsed().as_secs_f64(),
        stats
            .iter()
            .map(|s| (
                s.up.bytes_out,
                s.up.rate_dropped,
                s.down.bytes_out,
                s.down.rate_dropped,
                s.clock_us / 1_000_000
            ))
            .collect::<Vec<_>>()
    );
    Flight {
        keep_is_truth: done.is_finished() && done.bandit.keep() == green,
        report,
        radios: stats,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hardware_mission_through_5000_byte_radios_measured_on_board() {
    let open = fly("unlimited links", None).await;
    assert!(open.keep_is_truth, "unlimited: keep is not the green tiles");
    let radio = fly("5000 B/s half-duplex radios", Some(5000)).await;
    assert!(radio.keep_is_truth, "radios: keep is not the green tiles");
    assert_eq!(radio.report.errors.as_deref(), Some(&[][..]));
    assert_eq!(radio.radios.len(), 6);
    assert!(
        radio.report.epochs <= open.report.epochs,
        "{} epochs through the radios, {} on unlimited links",
        radio.report.epochs,
        open.report.epochs
    );
    // The radios carried the run: every vehicle's link was used both ways, none carried more
    // than its 5,000 bytes a second of simulated time in all, and each side had its radio's
    // reports.
    for s in &radio.radios {
        assert!(s.down.bytes_out > 0 && s.up.bytes_out > 0, "{s:?}");
        let secs = s.clock_us as f64 / 1e6;
        let carried = (s.up.bytes_out + s.down.bytes_out) as f64;
        assert!(
            carried <= 5000.0 * secs,
            "{carried} B in {secs:.0} s of simulated time"
        );
        assert!(s.gcs_radio.radio_status > 0 && s.vehicle_radio.radio_status > 0);
    }
}

/// Fly the hardware mission in virtual time (in-process links, tokio's clock paused) with
/// on-board measurement, every vehicle behind its own simulated `radio` (`None`: plain
/// links); returns the report, whether keep is the green tiles, and each radio's counts
/// with the simulated seconds they were counted over.
async fn fly_virtual(
    name: &str,
    radio: Option<RadioConfig>,
) -> (
    bandit_report::ClassificationReport,
    bool,
    Vec<RadioStats>,
    f64,
) {
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
    let def = MissionDef::parse(bandit_sim::HARDWARE_MISSION, "hardware-6x6.toml").unwrap();
    let green = world.green_cells();
    let setup = SimSetup {
        seed: 3,
        camera_px: 160,
        charge_minutes: 6.0,
        onboard: bandit::green_spec_of(&def),
        radio,
        ..SimSetup::default()
    };
    let (fleet, sim) = bandit_sim::start_virtual(bandit_sim::HARDWARE_TEAM, &world, &setup)
        .await
        .unwrap();
    let (state, run, _, _tmp) = common::bandit::new_run(&fleet).await;
    let hub = fleetmap::app::images::image_hub(&fleet);
    let done = bandit::run(fleet.clone(), &hub, run, state, RunOptions::default())
        .await
        .unwrap_or_else(|e| {
            panic!(
                "{name}: the run failed: {}",
                fleetmap::app::error::chain(&e)
            )
        });
    fleet.shutdown().await;
    let sim = sim.stop().await.unwrap();
    let stats: Vec<RadioStats> = sim
        .sysids()
        .into_iter()
        .filter_map(|v| sim.radio_stats(v))
        .collect();
    let seconds = sim.now().as_secs_f64();
    let report = bandit_report::report(&done, Some(&green));
    println!(
        "{name}: {} epochs, {} measurements, {} images ignored, {} failed, {:.0} s of drone \
         flight, {seconds:.0} s simulated",
        report.epochs,
        report.measurements,
        done.ignored_images,
        done.image_failures,
        report.flight_time_s,
    );
    let keep_is_truth = done.is_finished() && done.bandit.keep() == green;
    (report, keep_is_truth, stats, seconds)
}

/// The acceptance of telemetry radios for spatial classification: the 6×6 mission with
/// every vehicle behind its own 2,000 B/s radio (half duplex, 4 kB buffers, 10 % of frames
/// lost, counted in the vehicles' time), the cameras measuring on board, ends as on plain
/// links: keep = the green tiles, nothing unclassified, the same number of epochs.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn hardware_mission_through_2000_byte_radios_losing_10_percent() {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn,highs=error")
        .try_init();
    let (plain, plain_ok, none, _) = fly_virtual("plain links", None).await;
    assert!(plain_ok, "plain: keep is not the green tiles");
    assert!(none.is_empty());
    let radio = RadioConfig {
        loss: 0.1,
        ..RadioConfig::radio(2000)
    };
    let (over, ok, radios, seconds) = fly_virtual("2000 B/s radios, 10 % loss", Some(radio)).await;
    assert!(ok, "radios: keep is not the green tiles");
    assert!(over.unclassified.is_empty(), "{:?}", over.unclassified);
    assert_eq!(over.errors.as_deref(), Some(&[][..]));
    assert_eq!(over.epochs, plain.epochs);
    assert_eq!(radios.len(), 6);
    for (i, r) in radios.iter().enumerate() {
        let air_s = (r.down.air_us + r.up.air_us) as f64 / 1e6;
        println!(
            "radio {}: down {} B/s offered, {} lost, {} dropped; up {} B/s offered, {} lost; \
             air {:.0} %",
            i + 1,
            r.down.bytes_in as f64 / seconds,
            r.down.lost,
            r.down.dropped,
            r.up.bytes_in as f64 / seconds,
            r.up.lost,
            100.0 * air_s / seconds
        );
        assert!(r.down.lost > 0 && r.up.lost > 0, "{r:?}");
        assert!(air_s <= seconds + 1.0, "{air_s} s of air in {seconds} s");
    }
}
