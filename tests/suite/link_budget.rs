//! A vehicle's link budget in the fleet: on a telemetry radio the GCS asks only for the
//! telemetry that fits, stops what the vehicle streams unasked, still shows everything fresh,
//! and reads what the radio reports about itself (RADIO_STATUS) for the vehicles behind it —
//! planning for a radio when it was told nothing.
//!
//! The simulated vehicles talk to the fleet over in-process links on tokio's paused clock; a
//! tap between them counts the bytes each message id costs and injects what a SiK radio at
//! the GCS's end writes into its serial side (RADIO_STATUS from system 51, component 68).

use fleetmap::fleet::{self, FleetConfig, FleetHandle};
use fleetmap_core::budget::LinkBudget;
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::transport::{LinkOptions, MemoryPort, open_memory_link};
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::server;
use mavlink::dialects::ardupilotmega::{MavMessage, RADIO_STATUS_DATA};
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::mpsc;

/// Bytes per message id that crossed from the vehicle to the GCS, and when.
type Tally = Arc<Mutex<Vec<(tokio::time::Instant, u32, usize)>>>;

struct Rig {
    fleet: FleetHandle,
    tally: Tally,
    _sim: server::SimTask,
}

/// One simulated vehicle of `spec` on an in-process link to a fleet configured with
/// `budget`; a tap counts what the vehicle sends and, when `radio` is given, writes a
/// RADIO_STATUS with that `txbuf` into the GCS's side every second.
async fn rig(spec: &str, budget: Option<LinkBudget>, radio: Option<u8>) -> Rig {
    let sim = Sim::new(
        SimConfig::from_spec(spec, None, Some((37.1968, -80.5781)), 7).unwrap(),
        Time::ZERO,
    )
    .unwrap();
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let (link, gcs_end) = open_memory_link(0, "radio", &LinkOptions::default(), ev_tx);
    // The simulator's end of the link, with the tap in between.
    let (up_tx, up_rx) = mpsc::unbounded_channel();
    let (down_tx, mut down_rx) = mpsc::unbounded_channel::<Vec<u8>>();
    let MemoryPort {
        from_gcs: mut gcs_out,
        to_gcs: gcs_in,
    } = gcs_end;
    tokio::spawn(async move {
        while let Some(b) = gcs_out.recv().await {
            if up_tx.send(b).is_err() {
                return;
            }
        }
    });
    let tally: Tally = Arc::new(Mutex::new(Vec::new()));
    let t = tally.clone();
    let into_gcs = gcs_in.clone();
    tokio::spawn(async move {
        let mut codec = Codec::new();
        while let Some(b) = down_rx.recv().await {
            for f in codec.decode(&b, 0) {
                t.lock()
                    .unwrap()
                    .push((tokio::time::Instant::now(), f.msg_id, f.raw.len()));
            }
            if into_gcs.send(b).is_err() {
                return;
            }
        }
    });
    if let Some(txbuf) = radio {
        tokio::spawn(async move {
            let mut codec = Codec::new();
            let mut tick = tokio::time::interval(Duration::from_secs(1));
            loop {
                tick.tick().await;
                let m = MavMessage::RADIO_STATUS(RADIO_STATUS_DATA {
                    rxerrors: 3,
                    fixed: 0,
                    rssi: 180,
                    remrssi: 170,
                    txbuf,
                    noise: 40,
                    remnoise: 42,
                });
                if gcs_in.send(codec.encode(51, 68, &m, 0)).is_err() {
                    return;
                }
            }
        });
    }
    let sim = server::spawn_memory(
        sim,
        vec![MemoryPort {
            from_gcs: up_rx,
            to_gcs: down_tx,
        }],
    );
    let cfg = FleetConfig {
        budget,
        ..FleetConfig::default()
    };
    let fleet = fleet::spawn(vec![link], ev_rx, cfg, MonotonicClock::new());
    Rig {
        fleet,
        tally,
        _sim: sim,
    }
}

/// Bytes per second per message id the vehicle sent between `from` and `to` seconds after
/// `t0`.
fn rates(tally: &Tally, t0: tokio::time::Instant, from: u64, to: u64) -> BTreeMap<u32, f64> {
    let mut out = BTreeMap::new();
    for (t, id, n) in tally.lock().unwrap().iter() {
        let s = t.duration_since(t0).as_secs();
        if (from..to).contains(&s) {
            *out.entry(*id).or_insert(0.0) += *n as f64 / (to - from) as f64;
        }
    }
    out
}

/// A PX4 copter streams ATTITUDE, VFR_HUD and more by default. Told its link is a
/// 2,000-byte radio, the GCS asks for its telemetry within 800 B/s and stops what it did
/// not ask for; the vehicle's state in the snapshot stays fresh. Unlimited, the same vehicle
/// keeps its default streams.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_radio_gets_only_the_telemetry_that_fits() {
    let t0 = tokio::time::Instant::now();
    let radio = rig("1xcopter:px4", Some(LinkBudget::radio()), None).await;
    let open = rig("1xcopter:px4", None, None).await;
    tokio::time::sleep(Duration::from_secs(60)).await;
    let on_radio = rates(&radio.tally, t0, 30, 60);
    let unlimited = rates(&open.tally, t0, 30, 60);
    let total = |m: &BTreeMap<u32, f64>| m.values().sum::<f64>();
    eprintln!("radio: {on_radio:?}\nunlimited: {unlimited:?}");
    assert!(
        total(&on_radio) <= 800.0,
        "{:.0} B/s on a 2,000 B/s radio",
        total(&on_radio)
    );
    assert!(total(&unlimited) > total(&on_radio));
    // ATTITUDE (30) and VFR_HUD (74) were not asked for on the radio.
    assert!(unlimited.contains_key(&30) && unlimited.contains_key(&74));
    assert!(!on_radio.contains_key(&30), "{on_radio:?}");
    assert!(!on_radio.contains_key(&74), "{on_radio:?}");
    // What the fleet pane shows is fresh.
    let v = radio.fleet.vehicle(1).unwrap();
    assert!(v.position.is_some() && v.battery_pct.is_some() && v.gps_fix.is_some());
    assert!(v.alt_rel.is_some() && v.home.is_some());
    let snap = radio.fleet.snapshot();
    assert_eq!(v.link_quality.budget, LinkBudget::radio());
    assert!(!v.link_quality.budget_assumed);
    assert!(
        (300.0..=800.0).contains(&v.link_quality.down_bytes_per_s),
        "{:.0} B/s down",
        v.link_quality.down_bytes_per_s
    );
    assert!(v.link_quality.up_bytes_per_s > 0.0);
    assert!(snap.time > Time::from_secs(59));
}

/// A radio that reports itself on the link of a vehicle the GCS was told nothing about: the
/// snapshot shows its report, and the GCS plans for a radio from then on.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_radio_that_reports_itself_is_planned_for() {
    let t0 = tokio::time::Instant::now();
    let rig = rig("1xcopter:px4", None, Some(97)).await;
    tokio::time::sleep(Duration::from_secs(60)).await;
    let v = rig.fleet.vehicle(1).unwrap();
    let q = v.link_quality;
    assert_eq!(q.budget, LinkBudget::radio());
    assert!(q.budget_assumed);
    let r = q.radio.expect("the radio's report");
    assert_eq!(
        (
            r.status.rssi,
            r.status.remrssi,
            r.status.txbuf,
            r.status.rxerrors
        ),
        (180, 170, 97, 3)
    );
    assert!(r.age_s <= 1.5);
    let late = rates(&rig.tally, t0, 30, 60);
    assert!(!late.contains_key(&30), "ATTITUDE stopped: {late:?}");
}
