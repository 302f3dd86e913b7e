//! The simulator keeps time as SITL does: starved of CPU, it runs slower than its
//! ceiling instead of skipping ahead, and what the vehicles report stays consistent with the
//! time they were simulated for.
//!
//! An ArduCopter and a PX4 copter at a ceiling of 20× share their runtime's only thread with
//! a CPU-bound task that holds it for 25 ms between two turns (at most 200 ms of simulated
//! time per turn in lock-step: 8×), beside two CPU-bound threads that keep the machine's cores
//! busy. A fleet on the simulator's own time flies a mission on both to the end. What SITL
//! guarantees is checked on everything the vehicles sent:
//! - the simulator ran slower than asked (well under 20×), and reports that speed;
//! - no moment is missing: consecutive GLOBAL_POSITION_INT are never more than 1.5 s of the
//!   vehicle's own time (`time_boot_ms`) apart, and none is older than the one before;
//! - no position jumps: between two reports the vehicle moved no faster than a copter flies;
//! - the battery reported is the battery simulated, and it was drawn no faster than the
//!   flight allows for the time simulated;
//! - every command was answered (take-off, mission start) and both missions flown to the end.
//!
//! Before lock-step the simulator's clock kept pace with the wall whatever CPU it got: here it
//! would have stepped half a simulated second per turn at 20× — the speed checks fail.

use crate::common;

use fleetmap::fleet::Incoming;
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_io::clock::MonotonicClock;
use fleetmap_sim::harness::SimConfig;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

const HOME: (f64, f64) = (37.1968, -80.5781);
const CEILING: f64 = 20.0;
/// Fastest a simulated copter flies (WPNAV_SPEED, RTL, descent and wind together), m/s.
const FASTEST_M_S: f64 = 25.0;

/// Spin on the CPU for `d` of wall time.
fn burn(d: Duration) {
    let t = Instant::now();
    let mut x = 0u64;
    while t.elapsed() < d {
        x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
    }
}

/// What one vehicle sent, in the order it arrived.
#[derive(Default, Debug)]
struct Heard {
    /// (time_boot_ms, lat, lon, relative altitude m) of every GLOBAL_POSITION_INT.
    positions: Vec<(u32, f64, f64, f64)>,
    /// (time_boot_ms of the last position before it, battery remaining %) of every
    /// SYS_STATUS.
    battery: Vec<(u32, i8)>,
}

fn metres(a: (f64, f64), b: (f64, f64)) -> f64 {
    let dn = (b.0 - a.0).to_radians() * 6_371_000.0;
    let de = (b.1 - a.1).to_radians() * 6_371_000.0 * a.0.to_radians().cos();
    dn.hypot(de)
}

fn mission(k: u8) -> Vec<MissionItem> {
    let east = f64::from(k) * 3e-4;
    // with its position: PX4 flies a take-off item to it (one at 0, 0 is never reached)
    let mut v = vec![MissionItem::takeoff_at(HOME.0, HOME.1 + east, 10.0)];
    for (dn, de) in [(2e-4, 0.0), (2e-4, 2e-4), (0.0, 2e-4), (0.0, 0.0)] {
        v.push(MissionItem::waypoint(HOME.0 + dn, HOME.1 + east + de, 12.0));
    }
    v.push(MissionItem::return_to_launch());
    v
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_starved_simulator_slows_down_and_stays_consistent() {
    let t0 = Instant::now();
    let stop = Arc::new(AtomicBool::new(false));
    // two CPU-bound threads: the machine is busy
    let hogs: Vec<_> = (0..2)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    burn(Duration::from_millis(20));
                }
            })
        })
        .collect();

    let (link, ev_rx, gcs) = fleetmap_test_kit::gcs::listening_link().await;
    let cfg = SimConfig::from_spec("1xcopter:ardupilot,1xcopter:px4", None, Some(HOME), 3).unwrap();
    // the simulator's thread is held on the CPU for 25 ms between two turns
    let starved =
        common::StarvedSim::start(cfg, CEILING, gcs, || burn(Duration::from_millis(25))).await;
    let sim_time = starved.time.clone();
    let fleet = fleetmap::fleet::spawn(
        vec![link],
        ev_rx,
        fleetmap::fleet::FleetConfig::at_speedup(CEILING),
        MonotonicClock::following(&sim_time),
    );

    // everything the vehicles send, from the start
    let mut frames = fleet.subscribe();
    let (done_tx, mut done) = tokio::sync::oneshot::channel::<()>();
    let collector = tokio::spawn(async move {
        let mut heard: BTreeMap<u8, Heard> = BTreeMap::new();
        loop {
            let r = tokio::select! {
                r = frames.recv() => r,
                _ = &mut done => return heard,
            };
            match r {
                Ok(Incoming { frame, .. }) => {
                    let h = heard.entry(frame.sysid()).or_default();
                    match &frame.message {
                        // (0, 0): no position estimate yet
                        Ok(MavMessage::GLOBAL_POSITION_INT(p)) if p.lat != 0 || p.lon != 0 => {
                            h.positions.push((
                                p.time_boot_ms,
                                f64::from(p.lat) / 1e7,
                                f64::from(p.lon) / 1e7,
                                f64::from(p.relative_alt) / 1e3,
                            ))
                        }
                        Ok(MavMessage::SYS_STATUS(s)) if s.battery_remaining >= 0 => {
                            let at = h.positions.last().map_or(0, |p| p.0);
                            h.battery.push((at, s.battery_remaining));
                        }
                        _ => {}
                    }
                }
                Err(tokio::sync::broadcast::error::RecvError::Lagged(n)) => {
                    panic!("the test's collector fell {n} frames behind")
                }
                Err(tokio::sync::broadcast::error::RecvError::Closed) => return heard,
            }
        }
    });

    let mut flights = tokio::task::JoinSet::new();
    for sysid in 1..=2u8 {
        let fleet = fleet.clone();
        flights.spawn(async move {
            fleet
                .wait_vehicle(sysid, Duration::from_secs(60))
                .await
                .unwrap_or_else(|e| panic!("vehicle {sysid}: {e}"));
            fleet.wait_booted(sysid).await.unwrap();
            fleet
                .upload_mission(sysid, MissionType::Mission, mission(sysid))
                .await
                .unwrap_or_else(|e| panic!("vehicle {sysid} upload: {e}"));
            // ready to arm: a position estimate (ArduPilot 15 s, PX4 8 s of its time)
            fleet
                .wait_until(sysid, Duration::from_secs(120), |v| {
                    v.position.is_some() && v.gps_fix.is_some_and(|g| g >= 3)
                })
                .await
                .unwrap_or_else(|v| panic!("vehicle {sysid} has no position: {v:?}"));
            let mut attempts = 0;
            loop {
                match fleet.takeoff(sysid, 10.0).await {
                    Ok(()) => break,
                    // the estimate may still settle: the autopilot refuses, and says so
                    Err(e) if attempts < 20 => {
                        attempts += 1;
                        eprintln!("vehicle {sysid}: take-off refused ({e}), again");
                        tokio::time::sleep(Duration::from_millis(500)).await;
                    }
                    Err(e) => panic!("vehicle {sysid} take-off: {e}"),
                }
            }
            fleet
                .wait_until(sysid, Duration::from_secs(120), |v| {
                    v.alt_rel.is_some_and(|a| a > 8.0)
                })
                .await
                .unwrap_or_else(|v| panic!("vehicle {sysid} did not climb: {v:?}"));
            fleet
                .start_mission(sysid)
                .await
                .unwrap_or_else(|e| panic!("vehicle {sysid} mission start: {e}"));
            let last = (mission(sysid).len() - 1) as u16;
            fleet
                .wait_until(sysid, Duration::from_secs(300), |v| {
                    v.reached.contains(&(last - 1)) && v.on_ground() && !v.armed
                })
                .await
                .unwrap_or_else(|v| panic!("vehicle {sysid} did not finish its mission: {v:?}"));
            sysid
        });
    }
    while let Some(r) = flights.join_next().await {
        let sysid = r.unwrap();
        println!("vehicle {sysid}: mission flown, landed, disarmed");
    }
    let speed = sim_time
        .achieved()
        .expect("the simulator measured its speed");
    let simulated = sim_time.now();
    let _ = done_tx.send(());
    fleet.shutdown().await;
    let sim = starved.stop();
    stop.store(true, Ordering::Relaxed);
    for h in hogs {
        h.join().unwrap();
    }
    let heard = collector.await.unwrap();
    let wall = t0.elapsed();
    println!(
        "starved simulator: {:.1} s simulated in {:.1} s of wall time, {speed:.1}× at the end \
         ({CEILING}× asked)",
        simulated.as_secs_f64(),
        wall.as_secs_f64()
    );

    // it slowed down instead of keeping pace with the wall
    assert!(speed < CEILING / 2.0, "ran at {speed:.1}×");
    assert!(
        simulated.as_secs_f64() < wall.as_secs_f64() * CEILING / 2.0,
        "{simulated} in {wall:?}"
    );

    for sysid in 1..=2u8 {
        let h = &heard[&sysid];
        assert!(
            h.positions.len() > 100,
            "vehicle {sysid}: {:?}",
            h.positions.len()
        );
        let mut worst_gap = 0u32;
        let mut fastest = 0f64;
        for w in h.positions.windows(2) {
            let (a, b) = (w[0], w[1]);
            assert!(b.0 >= a.0, "vehicle {sysid}: time went back {a:?} → {b:?}");
            let dt_ms = b.0 - a.0;
            worst_gap = worst_gap.max(dt_ms);
            let d = metres((a.1, a.2), (b.1, b.2)).hypot(b.3 - a.3);
            // GPS error wanders (0.4 m per axis): allow a metre on top of the flight
            let limit = FASTEST_M_S * f64::from(dt_ms) / 1e3 + 1.0;
            assert!(
                d <= limit,
                "vehicle {sysid}: moved {d:.1} m in {dt_ms} ms ({a:?} → {b:?})"
            );
            if dt_ms > 0 {
                fastest = fastest.max(d / (f64::from(dt_ms) / 1e3));
            }
        }
        assert!(
            worst_gap <= 1500,
            "vehicle {sysid}: {worst_gap} ms of its time without a position report"
        );
        // the battery: as simulated, drawn only over the time simulated
        let v = sim.vehicle(sysid).unwrap();
        let (last_at, last_pct) = *h.battery.last().expect("SYS_STATUS");
        assert!(
            (i32::from(last_pct) - i32::from(v.battery().percent())).abs() <= 1,
            "vehicle {sysid}: reported {last_pct} %, simulated {} %",
            v.battery().percent()
        );
        let (first_at, first_pct) = h.battery[0];
        let secs = f64::from(last_at.saturating_sub(first_at)) / 1e3;
        let hover_pct_per_s = 100.0 / (v.battery().config.minutes * 60.0);
        let drawn = f64::from(first_pct) - f64::from(last_pct);
        assert!(
            drawn <= 2.0 * hover_pct_per_s * secs + 1.0,
            "vehicle {sysid}: {drawn} % drawn in {secs:.0} s of its time"
        );
        println!(
            "vehicle {sysid}: {} positions, longest gap {worst_gap} ms, fastest {fastest:.1} m/s, \
             battery {first_pct} → {last_pct} % over {secs:.0} s",
            h.positions.len()
        );
    }
}
