//! Runway pictures classified on board, end to end in virtual time: the runway paper's field
//! test (`missions/runway-field-test.toml`, `origin = "vehicle"`) with three simulated
//! ArduCopters whose cameras classify every picture themselves and send its cell and five
//! region counts (DEBUG_FLOAT_ARRAY "fm.rwy", 84 bytes) instead of the picture. The GCS
//! announces the run's grid to the cameras, votes on their results exactly as on its own
//! classifications, and asks for a picture only to audit a decision won by one vote.
//!
//! The same seed is flown again with cameras that send every picture: the two maps must be
//! within a point of IoU of each other, and the on-board one within a point of the best
//! possible. And again with every vehicle behind its own 2,000 B/s radio losing 10 % of its
//! frames: within a point of the best possible, and complete in at most 1.15 times the time
//! of the same seed on plain links.

use fleetmap::app::images;
use fleetmap::app::kind::Outcome;
use fleetmap::kinds::runway::demo::{self, DemoConfig};
use fleetmap::kinds::runway::report::{MappingReport, report, truth_coverage};
use fleetmap::kinds::runway::{self, MappingEvent, RunOptions};
use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::world::World;
use fleetmap_io::link::radio::{RadioConfig, RadioStats};
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};

use crate::common;

/// What the cameras sent the GCS, as its links received it.
#[derive(Debug, Default)]
struct Traffic {
    /// Runway results: frames, bytes on the wire, and the largest frame.
    results: (u64, u64, u64),
    /// Cameras' statuses (no picture): frames, and those saying the camera has no grid.
    statuses: u64,
    no_grid: u64,
    /// CAMERA_IMAGE_CAPTURED: frames and bytes.
    announced: (u64, u64),
    /// Pictures whose image transmission started (camera, size).
    pictures: BTreeSet<(u8, u32)>,
    /// ENCAPSULATED_DATA bytes on the wire.
    picture_bytes: u64,
}

struct Flown {
    state: MappingState,
    report: MappingReport,
    events: Vec<MappingEvent>,
    traffic: Traffic,
    /// Each vehicle's radio counts (empty without radios) and the simulated seconds they
    /// were counted over.
    radios: (Vec<RadioStats>, f64),
    wall_s: f64,
}

/// The runway field test with `drones` drones on simulator seed `seed`, its cameras
/// classifying on board or sending every picture, each vehicle behind `radio` or not.
async fn fly(onboard: bool, drones: usize, seed: u64, radio: Option<RadioConfig>) -> Flown {
    let world = World::from_toml(demo::RUNWAY_WORLD).unwrap();
    let cfg = DemoConfig {
        drones,
        seed,
        radio,
        ..DemoConfig::default()
    };
    let (text, _) = demo::runway_mission(&cfg).unwrap();
    fly_mission(world, &text, cfg, onboard).await
}

/// Fly mission `text` over `world` with `cfg`'s team, the cameras classifying on board or not.
async fn fly_mission(world: World, text: &str, mut cfg: DemoConfig, onboard: bool) -> Flown {
    let started = std::time::Instant::now();
    let def = fleetmap_core::mission::definition::MissionDef::parse(text, "mission").unwrap();
    if onboard {
        cfg.onboard = Some(runway::runway_definition_of(&def).expect("a runway mission"));
    }
    let spec = format!("{}xcopter:ardupilot", cfg.drones);
    let (fleet, sim) = demo::start_virtual(&spec, world.clone(), &cfg)
        .await
        .unwrap();
    let traffic = Arc::new(Mutex::new(Traffic::default()));
    let counter = {
        let traffic = traffic.clone();
        let mut frames = fleet.subscribe();
        tokio::spawn(async move {
            while let Ok(inc) = frames.recv().await {
                let f = &inc.frame;
                if f.compid() != 100 {
                    continue;
                }
                let n = f.raw.len() as u64;
                let mut t = traffic.lock().unwrap();
                match &f.message {
                    Ok(MavMessage::DEBUG_FLOAT_ARRAY(d)) if d.time_usec == 0 => {
                        t.statuses += 1;
                        t.no_grid += u64::from(d.data[1] == 0.0);
                    }
                    Ok(MavMessage::DEBUG_FLOAT_ARRAY(_)) => {
                        t.results.0 += 1;
                        t.results.1 += n;
                        t.results.2 = t.results.2.max(n);
                    }
                    Ok(MavMessage::CAMERA_IMAGE_CAPTURED(_)) => {
                        t.announced.0 += 1;
                        t.announced.1 += n;
                    }
                    Ok(MavMessage::DATA_TRANSMISSION_HANDSHAKE(h)) => {
                        t.pictures.insert((f.sysid(), h.size));
                    }
                    Ok(MavMessage::ENCAPSULATED_DATA(_)) => t.picture_bytes += n,
                    _ => {}
                }
            }
        })
    };
    let (state, run_dir, path, _tmp) = common::runway::new_run(&fleet, &def, text).await;
    let hub = images::spawn(&fleet);
    let opts = RunOptions {
        auto_resume: true,
        ..RunOptions::default()
    };
    let outcome = runway::run(fleet.clone(), &hub, run_dir, state, opts)
        .await
        .unwrap();
    assert_eq!(outcome, Outcome::Finished);
    let state: MappingState = RunDir::open(&path).unwrap().load_state().unwrap().unwrap();
    let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
    let report = report(&state, Some(&cov));
    let events = common::journal::<MappingEvent>(&path);
    fleet.shutdown().await;
    let radios = match sim.stop().await {
        Ok(sim) => (
            (1..=cfg.drones as u8)
                .filter_map(|v| sim.radio_stats(v))
                .collect(),
            sim.now().as_secs_f64(),
        ),
        Err(_) => (Vec::new(), 0.0),
    };
    counter.abort();
    let traffic = std::mem::take(&mut *traffic.lock().unwrap());
    Flown {
        state,
        report,
        events,
        traffic,
        radios,
        wall_s: started.elapsed().as_secs_f64(),
    }
}

/// How many journal records of each kind, and the mission clock's milestones.
fn summary(f: &Flown) -> String {
    let mut kinds = std::collections::BTreeMap::new();
    for e in &f.events {
        let v = serde_json::to_value(e).unwrap();
        let k = v["event"].as_str().unwrap_or("?").to_string();
        *kinds.entry(k).or_insert(0u32) += 1;
    }
    let m = &f.report.mission_time;
    for rb in &f.report.robots {
        let t = &rb.time;
        eprintln!(
            "  vehicle {}: {} images, flying {:.0} s (imaging {:.0}, homing {:.0}), waiting {:.0} s {:?}, ground {:.0} s",
            rb.sysid,
            rb.images,
            t.flying_s,
            t.imaging_s,
            t.homing_s,
            t.waiting_s,
            t.waiting,
            t.ground_s
        );
    }
    format!(
        "DFS start {:?} s, map complete {:?} s, last landing {:?} s, swaps {}, journal {kinds:?}",
        m.to_dfs_start_s, m.to_map_complete_s, m.to_last_landing_s, f.report.battery_swaps
    )
}

fn iou(r: &MappingReport) -> (f64, f64) {
    let t = r.truth.as_ref().expect("scored against the world");
    (t.iou, t.iou_best_possible)
}

/// Three drones map the field test with their cameras classifying on board: every vote and
/// every sweep picture is a camera's result, no picture crosses the link but the audits'
/// (each classified by the GCS exactly as the camera had), and the map is within a point of
/// the best possible IoU and of the same seed flown with pictures.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn three_drones_map_the_runway_with_cameras_classifying_on_board() {
    let seed = 1;
    let on = fly(true, 3, seed, None).await;
    let (iou_on, best) = iou(&on.report);
    let t = &on.traffic;
    let o = &on.state.onboard;
    let images = on.state.book.detections().len() as u64;
    eprintln!(
        "on board: IoU {iou_on:.4} (best {best:.4}), {images} cell pictures, {} sweep, \
         {} results ({} B: {:.1} B each, at most {}), {} statuses, \
         {} announcements ({} B), {} pictures sent ({} B), {o:?}, {:.0} s of wall time",
        on.state.sweep_images.len(),
        t.results.0,
        t.results.1,
        t.results.1 as f64 / t.results.0.max(1) as f64,
        t.results.2,
        t.statuses,
        t.announced.0,
        t.announced.1,
        t.pictures.len(),
        t.picture_bytes,
        on.wall_s
    );
    eprintln!("on board: {}", summary(&on));
    assert!(on.report.finished && on.report.found);
    assert!(
        iou_on >= best - 0.01,
        "IoU {iou_on:.4} is more than a point below the best possible {best:.4}"
    );
    // Every vote and every sweep picture came from a camera.
    assert!(images > 100, "{images}");
    assert_eq!(o.cell_pictures, images);
    assert_eq!(o.sweep_pictures, on.state.sweep_images.len() as u64);
    all_on_board(&on.events);
    // A result per announced picture, at most 84 bytes each (MAVLink 2 truncates the
    // trailing zeros: fewer for a picture of grass), and a few statuses: the cameras had no
    // grid until the run announced it, and again after each battery swap.
    assert_eq!(t.results.0, t.announced.0, "{t:?}");
    assert!(t.results.2 <= 84, "{t:?}");
    assert!(t.no_grid >= 3 && t.statuses <= 40, "{t:?}");
    // Pictures only for the audits, and every audit's classification is the camera's.
    audits_agree(&on);

    let pics = fly(false, 3, seed, None).await;
    let (iou_pics, _) = iou(&pics.report);
    eprintln!(
        "pictures: IoU {iou_pics:.4}, {} pictures sent ({} B), {:.0} s of wall time",
        pics.traffic.pictures.len(),
        pics.traffic.picture_bytes,
        pics.wall_s
    );
    eprintln!("pictures: {}", summary(&pics));
    assert_eq!(pics.state.onboard, Default::default());
    assert!(pics.traffic.pictures.len() >= 500);
    assert!(
        (iou_on - iou_pics).abs() <= 0.01,
        "on board IoU {iou_on:.4}, with pictures {iou_pics:.4}"
    );
}

/// Every cell-centre and sweep picture of the journal was classified on board.
fn all_on_board(events: &[MappingEvent]) {
    for e in events {
        match e {
            MappingEvent::Image { onboard, .. } | MappingEvent::SweepImage { onboard, .. } => {
                assert!(onboard, "{e:?}")
            }
            _ => {}
        }
    }
}

/// The audits journalled are the state's, every one that got its picture agreed with the
/// camera bit for bit, and no picture crossed the link but theirs.
fn audits_agree(f: &Flown) {
    let o = &f.state.onboard;
    let audits: Vec<_> = f
        .events
        .iter()
        .filter_map(|e| match e {
            MappingEvent::Audit { agreed, .. } => Some(*agreed),
            _ => None,
        })
        .collect();
    assert_eq!(audits.len() as u64, o.audits);
    assert!(
        f.traffic.pictures.len() as u64 <= o.audits,
        "{} pictures sent for {} audits",
        f.traffic.pictures.len(),
        o.audits
    );
    assert_eq!(o.audits_disagreed, 0, "{audits:?}");
    assert_eq!(o.audits_agreed + o.audits_lost, o.audits);
}

/// One drone over the small strip on a fixed grid (the camera has the grid from the mission
/// file), one picture per cell decided by one vote: every decision is won by one vote, so the
/// GCS audits a picture of each cell it can (one audit in flight per vehicle) — each picture
/// arrives, and the GCS's classification of it is the camera's exactly.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn audits_of_one_vote_decisions_agree_with_the_camera() {
    let world = World::from_toml(common::WORLD).unwrap();
    let text = common::strip_mission()
        .replacen("images_per_cell = 5", "images_per_cell = 1", 1)
        .replacen("votes_required = 3", "votes_required = 1", 1);
    let cfg = DemoConfig {
        drones: 1,
        seed: 3,
        ..DemoConfig::default()
    };
    let f = fly_mission(world, &text, cfg, true).await;
    let o = &f.state.onboard;
    eprintln!("strip: {o:?}, {:?}, {}", f.traffic, summary(&f));
    assert!(f.report.finished && f.report.found);
    all_on_board(&f.events);
    audits_agree(&f);
    assert!(o.audits >= 3, "{o:?}");
    assert_eq!(o.audits_agreed, o.audits, "{o:?}");
    assert_eq!(f.traffic.pictures.len() as u64, o.audits);
    // the grid came with the mission: no camera ever said it had none
    assert_eq!(f.traffic.no_grid, 0, "{:?}", f.traffic);
    assert!(f.traffic.statuses >= 1);
    let (iou, best) = iou(&f.report);
    assert!(iou >= best - 0.05, "{iou} {best}");
}

/// What each message cost per vehicle on the radios, bytes per second of simulated time
/// (what the vehicle offered its radio, and what the GCS offered), largest first.
fn radio_table(label: &str, radios: &[RadioStats], seconds: f64) {
    let n = radios.len().max(1) as f64 * seconds.max(1.0);
    let mut down = std::collections::BTreeMap::<u32, u64>::new();
    let mut up = std::collections::BTreeMap::<u32, u64>::new();
    for r in radios {
        for (id, c) in &r.down.by_message {
            *down.entry(*id).or_default() += c.bytes_in;
        }
        for (id, c) in &r.up.by_message {
            *up.entry(*id).or_default() += c.bytes_in;
        }
    }
    for (dir, m) in [("vehicle->GCS", down), ("GCS->vehicle", up)] {
        let total: u64 = m.values().sum();
        let mut rows: Vec<_> = m.into_iter().collect();
        rows.sort_by_key(|(_, b)| std::cmp::Reverse(*b));
        let rows: Vec<String> = rows
            .iter()
            .map(|(id, b)| format!("{id}:{:.1}", *b as f64 / n))
            .collect();
        eprintln!(
            "{label} {dir}: {:.0} B/s per vehicle [{}]",
            total as f64 / n,
            rows.join(" ")
        );
    }
    for (i, r) in radios.iter().enumerate() {
        eprintln!(
            "{label} radio {}: down {} B out, {} lost, {} dropped, peak buffer {} B; up {} B out, \
             {} lost, {} dropped; air {:.0} %",
            i + 1,
            r.down.bytes_out,
            r.down.lost,
            r.down.dropped,
            r.down.peak_buffer_bytes,
            r.up.bytes_out,
            r.up.lost,
            r.up.dropped,
            (r.down.air_us + r.up.air_us) as f64 / 1e4 / seconds.max(1.0)
        );
    }
}

/// The field test's three drones, every vehicle behind its own 2,000 B/s radio (half
/// duplex, 4 kB buffers, 10 % of frames lost, counted in the vehicles' time), the cameras
/// classifying on board: the map is within a point of the best possible IoU and complete in
/// at most 1.15 times the same seed's time on plain links.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn three_drones_map_the_runway_over_2000_byte_radios_with_loss() {
    let seed = 1;
    let radio = RadioConfig {
        loss: 0.1,
        ..RadioConfig::radio(2000)
    };
    let over = fly(true, 3, seed, Some(radio)).await;
    let plain = fly(true, 3, seed, None).await;
    let (iou_r, best) = iou(&over.report);
    let (iou_p, _) = iou(&plain.report);
    eprintln!(
        "radio: IoU {iou_r:.4} (best {best:.4}), {:?}, {} pictures, {:.0} s of wall time",
        over.state.onboard,
        over.traffic.pictures.len(),
        over.wall_s
    );
    eprintln!("radio: {}", summary(&over));
    eprintln!("plain: IoU {iou_p:.4}, {}", summary(&plain));
    radio_table("radio", &over.radios.0, over.radios.1);
    for e in &over.events {
        if matches!(
            e,
            MappingEvent::ImageFailed { .. } | MappingEvent::StepFailed { .. }
        ) {
            eprintln!("radio: {e:?}");
        }
    }
    assert_eq!(over.radios.0.len(), 3);
    assert!(plain.radios.0.is_empty());
    assert!(over.report.finished && over.report.found);
    assert!(
        iou_r >= best - 0.01,
        "IoU {iou_r:.4} over the radios is more than a point below the best possible {best:.4}"
    );
    all_on_board(&over.events);
    audits_agree(&over);
    let t_r = over
        .report
        .mission_time
        .to_map_complete_s
        .expect("map complete");
    let t_p = plain
        .report
        .mission_time
        .to_map_complete_s
        .expect("map complete");
    assert!(
        t_r <= 1.15 * t_p,
        "the map took {t_r:.0} s over the radios, {t_p:.0} s on plain links"
    );
    // The radios did lose frames, and the air stayed within its budget.
    for r in &over.radios.0 {
        assert!(r.down.lost > 0 && r.up.lost > 0, "{r:?}");
        let air_s = (r.down.air_us + r.up.air_us) as f64 / 1e6;
        assert!(
            air_s <= over.radios.1 + 1.0,
            "{air_s} s of air in {} s",
            over.radios.1
        );
    }
}
