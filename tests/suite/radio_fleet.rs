//! Every simulated vehicle behind its own SiK radio pair to one fleet, in process on tokio's
//! paused clock (`Relay::for_fleet` + `server::spawn_memory`, as `link::relay`'s
//! documentation shows): telemetry, commands and mission round trips work over 2,000 B/s
//! half-duplex radios that lose 10 % on the air, each radio stays within its budget, and
//! the fleet hears its radio's RADIO_STATUS on every link.

use fleetmap::fleet::{self, FleetConfig};
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_io::link::relay::{Relay, RelayOptions};
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::server;
use std::collections::BTreeMap;
use std::time::Duration;

use crate::common;

#[tokio::test(start_paused = true)]
async fn three_vehicles_each_behind_its_own_radio() {
    let n = 3u8;
    let cfg =
        SimConfig::from_spec("3xcopter:ardupilot", None, Some((37.1968, -80.5781)), 5).unwrap();
    let sim = Sim::new(cfg, Time::ZERO).unwrap();
    let t0 = tokio::time::Instant::now();

    // One radio per vehicle: the fleet's link i is the GCS side of radio i.
    let (ev_tx, ev_rx) = tokio::sync::mpsc::channel(4096);
    let (stop_tx, stop_rx) = tokio::sync::watch::channel(false);
    let (mut links, mut ports, mut radios) = (Vec::new(), Vec::new(), Vec::new());
    for (i, sysid) in sim.sysids().into_iter().enumerate() {
        let opts = RelayOptions {
            radio: RadioConfig {
                loss: 0.1,
                ..RadioConfig::radio(2000)
            },
            seed: u64::from(sysid),
            ..RelayOptions::default()
        };
        let (relay, link, port) =
            Relay::for_fleet(&format!("radio-{sysid}"), opts, i, ev_tx.clone());
        links.push(link);
        ports.push(port);
        let mut stop = stop_rx.clone();
        radios.push(tokio::spawn(relay.run(
            Duration::from_secs(3600),
            |_| {},
            async move {
                let _ = stop.wait_for(|s| *s).await;
            },
        )));
    }
    drop(ev_tx);
    let sim = server::spawn_memory(sim, ports);
    let f = fleet::spawn(links, ev_rx, FleetConfig::default(), MonotonicClock::new());

    // RADIO_STATUS heard per link
    let mut incoming = f.subscribe();
    let reports = tokio::spawn(async move {
        let mut per_link: BTreeMap<usize, u64> = BTreeMap::new();
        loop {
            match incoming.recv().await {
                Ok(i) => {
                    if i.frame.msg_id == 109 && i.frame.sysid() == 51 && i.frame.compid() == 68 {
                        *per_link.entry(i.link).or_default() += 1;
                    }
                }
                Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => {}
                Err(_) => return per_link,
            }
        }
    });

    eprintln!(
        "[{:.1} s] waiting for telemetry",
        t0.elapsed().as_secs_f64()
    );
    for k in 1..=n {
        f.wait_until(k, Duration::from_secs(120), |v| {
            v.battery_pct.is_some() && v.gps_fix.is_some_and(|g| g >= 3) && v.position.is_some()
        })
        .await
        .unwrap_or_else(|v| panic!("vehicle {k} has no telemetry: {v:?}"));
    }
    eprintln!("[{:.1} s] telemetry", t0.elapsed().as_secs_f64());
    let mut tasks = Vec::new();
    for k in 1..=n {
        let f = f.clone();
        tasks.push(tokio::spawn(async move {
            common::command_and_mission_round_trip(&f, k, common::spread_mission(k, 11)).await;
        }));
    }
    for t in tasks {
        t.await.unwrap();
    }
    eprintln!("[{:.1} s] missions", t0.elapsed().as_secs_f64());
    tokio::time::sleep(Duration::from_secs(30)).await;
    f.shutdown().await;
    let _ = stop_tx.send(true);
    let mut stats = Vec::new();
    for r in radios {
        stats.push(r.await.unwrap());
    }
    let _ = sim.stop().await;
    drop(f); // the last sender of the fleet's frames: the counting task ends
    let heard = reports.await.unwrap();
    eprintln!(
        "{n} vehicles through 2000 B/s radios, {:.0} s of virtual time; RADIO_STATUS per link \
         {heard:?}",
        t0.elapsed().as_secs_f64()
    );
    for (i, s) in stats.iter().enumerate() {
        let secs = s.clock_us as f64 / 1e6;
        let (up, down) = (&s.up, &s.down);
        eprintln!(
            "radio {}: up {} B, down {} B ({:.0} B/s in all), lost {} / {}, dropped {} / {}, \
             reports {} to the GCS, {} to the vehicle",
            i + 1,
            up.bytes_out,
            down.bytes_out,
            (up.bytes_out + down.bytes_out) as f64 / secs,
            up.lost,
            down.lost,
            up.rate_dropped,
            down.rate_dropped,
            s.gcs_radio.radio_status,
            s.vehicle_radio.radio_status
        );
        assert!(((up.bytes_out + down.bytes_out) as f64) <= 2000.0 * secs);
        assert!(up.air_us + down.air_us <= s.clock_us + 134_000);
        assert!(up.lost > 0 && down.lost > 0);
        // about one report a second each way (one per heartbeat that got on the air)
        assert!(s.gcs_radio.radio_status as f64 > 0.5 * secs, "{s:?}");
        assert!(s.vehicle_radio.radio_status as f64 > 0.5 * secs, "{s:?}");
        // the fleet heard them on this vehicle's link
        assert!(heard.get(&i).copied().unwrap_or(0) >= s.gcs_radio.radio_status / 2);
    }
}
