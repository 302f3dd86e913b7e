//! Image sanity and camera geometry (issue "Proven on the real autopilots"): a picture counts
//! for a cell only when it was taken there, and the 3 × 3 cells are cut where the camera
//! really looked.
//!
//! End to end, the GCS's runway run flies a simulated ArduPilot copter over a small strip
//! world ([`common::WORLD`]) on tokio's paused clock, as `tests/suite/runway.rs` does, but with a
//! frame rewriter between the simulator and the fleet that makes the camera misreport:
//!
//! * some pictures claim a position 30 m away and some transfers are lost: those are
//!   dropped and taken again, the run completes, nothing misplaced is credited and the map is
//!   the strip;
//! * every picture claims the same far-away position on the ground (a camera stuck at its
//!   boot pose): no picture is credited, no runway cell is mapped, and the vehicle lands and
//!   waits for the operator with a camera-fault message;
//! * the camera goes bad in the middle of the DFS: the visit retakes up to the limit, then the
//!   same stop — only what was taken before counts.
//!
//! And against references: the orthophoto of a level camera is the centre crop; a ground
//! point goes into the image and back; the simulator's tilted renders, resampled, read like
//! level ones.

use fleetmap::app::images;
use fleetmap::app::kind::{OperatorTask, Outcome};
use fleetmap::fleet::{self, FleetConfig};
use fleetmap::kinds::runway::report::truth_coverage;
use fleetmap::kinds::runway::{self, MappingEvent, RunOptions};
use fleetmap::store::RunDir;
use fleetmap_camera::pose::CameraPose;
use fleetmap_camera::render::{Disturbances, render};
use fleetmap_core::explore::mapping::{MappingState, RobotStatus};
use fleetmap_core::geo::{LatLon, local};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::time::Time;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::vision::crop::crop_to_cells;
use fleetmap_core::vision::geometry::{
    CameraView, OrthoRequest, attitude_from_euler_deg, orthophoto, view_centre_offset,
};
use fleetmap_core::vision::runway::{RunwayParams, classify};
use fleetmap_core::world::World;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::codec::{Codec, encode_frame};
use fleetmap_io::link::transport::{LinkOptions, MemoryPort, open_memory_link};
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::server;
use mavlink::dialects::ardupilotmega::{CAMERA_IMAGE_CAPTURED_DATA, MavMessage};
use proptest::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::mpsc;

use crate::common;
use common::{STRIP_CENTRE, WORLD};

/// What the rewriter does to one capture (by its image index).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fate {
    /// Delivered as the simulator sent it.
    Keep,
    /// CAMERA_IMAGE_CAPTURED says it was taken elsewhere: (lat, lon, relative altitude m).
    Claim(f64, f64, f64),
    /// CAMERA_IMAGE_CAPTURED moved by (north, east) metres.
    Shift(f64, f64),
    /// The image transfer (handshake and packets) never reaches the GCS.
    Lose,
}

/// Counts of what the rewriter did.
#[derive(Debug, Default)]
struct Tampered {
    moved: AtomicU32,
    lost: AtomicU32,
}

type Rule = Box<dyn Fn(i32) -> Fate + Send + Sync>;

/// Forward the simulator's bytes for one vehicle to the GCS, rewriting or dropping frames as
/// `rule` says for each capture (the frames of an image transfer belong to the capture whose
/// CAMERA_IMAGE_CAPTURED came last: the simulated camera sends that first).
/// With `payload_rate` (bytes per second), the image transfer's frames are queued and passed on
/// no faster than that, as a slow payload link carries them (PX4 SITL's: 4000 B/s).
fn rewriter(
    mut from_sim: mpsc::UnboundedReceiver<Vec<u8>>,
    to_gcs: mpsc::UnboundedSender<Vec<u8>>,
    rule: Arc<Rule>,
    tampered: Arc<Tampered>,
    payload_rate: Option<u32>,
) {
    let slow = payload_rate.map(|rate| {
        let (tx, mut rx) = mpsc::unbounded_channel::<Vec<u8>>();
        let to_gcs = to_gcs.clone();
        tokio::spawn(async move {
            while let Some(raw) = rx.recv().await {
                tokio::time::sleep(Duration::from_secs_f64(raw.len() as f64 / f64::from(rate)))
                    .await;
                if to_gcs.send(raw).is_err() {
                    return;
                }
            }
        });
        tx
    });
    tokio::spawn(async move {
        let mut codec = Codec::new();
        let mut current = Fate::Keep;
        while let Some(bytes) = from_sim.recv().await {
            let mut out = Vec::with_capacity(bytes.len());
            for frame in codec.decode(&bytes, 0) {
                match &frame.message {
                    Ok(MavMessage::CAMERA_IMAGE_CAPTURED(c)) => {
                        current = rule(c.image_index);
                        let mut c: CAMERA_IMAGE_CAPTURED_DATA = c.clone();
                        match current {
                            Fate::Claim(lat, lon, alt) => {
                                c.lat = (lat * 1e7).round() as i32;
                                c.lon = (lon * 1e7).round() as i32;
                                c.relative_alt = (alt * 1000.0).round() as i32;
                            }
                            Fate::Shift(n, e) => {
                                let (lat, lon) = local::offset(
                                    f64::from(c.lat) * 1e-7,
                                    f64::from(c.lon) * 1e-7,
                                    n,
                                    e,
                                );
                                c.lat = (lat * 1e7).round() as i32;
                                c.lon = (lon * 1e7).round() as i32;
                            }
                            Fate::Keep | Fate::Lose => {
                                out.extend_from_slice(&frame.raw);
                                continue;
                            }
                        }
                        tampered.moved.fetch_add(1, Ordering::Relaxed);
                        let msg = MavMessage::CAMERA_IMAGE_CAPTURED(c);
                        out.extend(encode_frame(&frame.header, &msg, frame.version, None, 0));
                    }
                    Ok(MavMessage::DATA_TRANSMISSION_HANDSHAKE(h))
                        if current == Fate::Lose && h.size > 0 =>
                    {
                        tampered.lost.fetch_add(1, Ordering::Relaxed);
                    }
                    Ok(
                        MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)
                        | MavMessage::ENCAPSULATED_DATA(_),
                    ) if current == Fate::Lose => {}
                    Ok(
                        MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)
                        | MavMessage::ENCAPSULATED_DATA(_),
                    ) if slow.is_some() => {
                        if let Some(slow) = &slow {
                            let _ = slow.send(frame.raw.clone());
                        }
                    }
                    _ => out.extend_from_slice(&frame.raw),
                }
            }
            if !out.is_empty() && to_gcs.send(out).is_err() {
                return;
            }
        }
    });
}

struct Flown {
    outcome: Outcome,
    state: MappingState,
    events: Vec<MappingEvent>,
    progress: Vec<String>,
    tampered: Arc<Tampered>,
    fleet: fleetmap::fleet::FleetHandle,
    world: World,
}

/// The runway run with one simulated ArduPilot copter over the strip world, its camera's
/// frames passed through `rule`.
async fn fly(rule: Rule, seed: u64) -> Flown {
    fly_over(rule, seed, None).await
}

/// [`fly`] with the image transfers carried at `payload_rate` bytes per second at most.
async fn fly_over(rule: Rule, seed: u64, payload_rate: Option<u32>) -> Flown {
    let world = World::from_toml(WORLD).unwrap();
    let text = common::strip_mission();
    let def = MissionDef::parse(&text, "strip mission").unwrap();
    let mut cfg =
        SimConfig::from_spec("1xcopter:ardupilot", Some(world.clone()), None, seed).unwrap();
    for v in &mut cfg.vehicles {
        v.swap_after_s = Some(20.0);
    }
    let sim = Sim::new(cfg, Time::ZERO).unwrap();
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let rule = Arc::new(rule);
    let tampered = Arc::new(Tampered::default());
    let mut links = Vec::new();
    let mut ports = Vec::new();
    for (i, sysid) in sim.sysids().into_iter().enumerate() {
        let (h, gcs_end) = open_memory_link(
            i,
            &format!("sim-{sysid}"),
            &LinkOptions::default(),
            ev_tx.clone(),
        );
        links.push(h);
        let (sim_tx, sim_rx) = mpsc::unbounded_channel();
        rewriter(
            sim_rx,
            gcs_end.to_gcs,
            rule.clone(),
            tampered.clone(),
            payload_rate,
        );
        ports.push(MemoryPort {
            from_gcs: gcs_end.from_gcs,
            to_gcs: sim_tx,
        });
    }
    drop(ev_tx);
    let sim = server::spawn_memory(sim, ports);
    let fleet = fleet::spawn(links, ev_rx, FleetConfig::default(), MonotonicClock::new());
    let (state, run_dir, path, _tmp) = common::runway::new_run(&fleet, &def, &text).await;
    let hub = images::spawn(&fleet);
    let (tx, mut rx) = mpsc::unbounded_channel::<fleetmap::app::run::Progress>();
    let lines = Arc::new(Mutex::new(Vec::new()));
    let kept = lines.clone();
    let printer = tokio::spawn(async move {
        while let Some(line) = rx.recv().await {
            eprintln!("{line}");
            kept.lock().unwrap().push(line.text);
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
    let _ = printer.await;
    let run = RunDir::open(&path).unwrap();
    let state: MappingState = run.load_state().unwrap().unwrap();
    let events = common::journal::<MappingEvent>(&path);
    let _ = sim.stop().await;
    let progress = lines.lock().unwrap().clone();
    Flown {
        outcome,
        state,
        events,
        progress,
        tampered,
        fleet,
        world,
    }
}

/// Every credited picture was taken within `limit_m` of its cell's centre.
fn assert_credited_where_taken(s: &MappingState, limit_m: f64) {
    for r in s.book.detections() {
        let d = &r.detection;
        let p = d
            .position
            .as_ref()
            .expect("a credited picture has a position");
        let (e, n) = s
            .grid
            .to_xy(LatLon {
                lat: p.lat_deg,
                lon: p.lon_deg,
            })
            .unwrap();
        let c = s.grid.cell_size();
        let off = (e - f64::from(d.cell.col) * c).hypot(n - f64::from(d.cell.row) * c);
        assert!(
            off <= limit_m,
            "{} credited to cell {} was taken {off:.1} m from its centre",
            d.image_id,
            d.cell
        );
    }
}

/// The map is exactly the strip's whole cells; returns the mapped cells.
fn assert_maps_the_strip(s: &MappingState, world: &World) -> Vec<fleetmap_core::geo::Cell> {
    let truth = truth_coverage(&s.grid, world, 0.0).unwrap();
    let mut want: Vec<_> = truth
        .iter()
        .filter(|(_, f)| **f > 0.99)
        .map(|(c, _)| *c)
        .collect();
    let mut got = s.book.positive_cells();
    want.sort();
    got.sort();
    assert_eq!(got, want, "mapped {got:?}, the strip is {want:?}");
    got
}

fn rejected(events: &[MappingEvent]) -> Vec<(Option<fleetmap_core::geo::Cell>, String)> {
    events
        .iter()
        .filter_map(|e| match e {
            MappingEvent::ImageRejected { cell, reason, .. } => Some((*cell, reason.clone())),
            _ => None,
        })
        .collect()
}

/// Pictures that claim to be 30 m away, and lost transfers, are dropped and taken again: the
/// run completes, nothing misplaced is credited, and the map is the strip.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn misplaced_and_lost_pictures_are_taken_again() {
    let rule: Rule = Box::new(|i| match i {
        i if i % 5 == 2 => Fate::Shift(30.0, 0.0),
        i if i % 7 == 3 => Fate::Lose,
        _ => Fate::Keep,
    });
    let f = fly(rule, 7).await;
    assert_eq!(f.outcome, Outcome::Finished);
    let s = &f.state;
    assert!(s.is_finished());
    let moved = f.tampered.moved.load(Ordering::Relaxed);
    let lost = f.tampered.lost.load(Ordering::Relaxed);
    assert!(moved >= 10 && lost >= 5, "moved {moved}, lost {lost}");
    // Every misplaced picture of a cell visit was dropped, with its distance.
    let rej = rejected(&f.events);
    let at_cells: Vec<_> = rej.iter().filter(|(c, _)| c.is_some()).collect();
    assert!(at_cells.len() >= 5, "{rej:?}");
    for (cell, reason) in &rej {
        assert!(
            reason.contains("taken 30.") || reason.contains("taken 29."),
            "cell {cell:?}: {reason}"
        );
    }
    // Each was followed by a retake: the visits still got their five pictures.
    let lost_events = f
        .events
        .iter()
        .filter(|e| matches!(e, MappingEvent::ImageFailed { reason, .. } if reason.contains("no image arrived")))
        .count();
    assert!(lost_events >= 3, "{lost_events} lost pictures journalled");
    assert!(
        !f.events
            .iter()
            .any(|e| matches!(e, MappingEvent::CameraFault { .. }))
    );
    let explorer = s.explorer.as_ref().unwrap();
    assert!(explorer.is_finished());
    let credited = s.book.detections().len();
    let vertices = explorer.tree().real_count();
    assert!(
        credited >= vertices * 5,
        "{credited} pictures credited for {vertices} vertices"
    );
    assert_credited_where_taken(s, 1.0);
    let got = assert_maps_the_strip(s, &f.world);
    eprintln!(
        "misplaced {moved}, lost {lost}: {} rejected ({} at cells), {lost_events} lost journalled, \
         {credited} credited, {} cells mapped",
        rej.len(),
        at_cells.len(),
        got.len()
    );
}

/// A camera that never learned where the vehicle is (every picture at its boot pose, on the
/// ground 300 m away): nothing is credited, no runway is mapped, and the vehicle lands and
/// waits for the operator, saying why.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_camera_stuck_at_its_boot_pose_maps_nothing_and_waits_for_the_operator() {
    let (lat, lon) = local::offset(STRIP_CENTRE.0, STRIP_CENTRE.1, -300.0, -150.0);
    let rule: Rule = Box::new(move |_| Fate::Claim(lat, lon, 0.0));
    let f = fly(rule, 7).await;
    waits_for_the_camera(&f.outcome);
    let s = &f.state;
    assert!(
        s.book.positive_cells().is_empty(),
        "{:?}",
        s.book.positive_cells()
    );
    assert!(s.book.detections().is_empty());
    assert!(!f.events.iter().any(|e| matches!(
        e,
        MappingEvent::Image { .. }
            | MappingEvent::Candidate { .. }
            | MappingEvent::SweepImage { .. }
    )));
    let rej = rejected(&f.events);
    assert_eq!(rej.len(), 6, "{rej:?}");
    assert!(
        rej.iter()
            .all(|(_, r)| r.contains("m from where it should have been")),
        "{rej:?}"
    );
    let fault = f.events.iter().find_map(|e| match e {
        MappingEvent::CameraFault { reason, .. } => Some(reason.clone()),
        _ => None,
    });
    let fault = fault.expect("a camera fault is journalled");
    assert!(fault.contains("6 sweep pictures in a row"), "{fault}");
    assert!(
        f.progress
            .iter()
            .any(|l| l.contains("CAMERA FAULT") && l.contains("waits for the operator")),
        "{:?}",
        f.progress
    );
    assert!(
        f.progress
            .iter()
            .any(|l| l.contains("waiting for the operator to fix the camera"))
    );
    // Landed and disarmed, waiting; not resumed although the battery is good.
    let r = s.robot(1).unwrap();
    assert_eq!(r.status, RobotStatus::AwaitingSwap);
    let v = f.fleet.vehicle(1).unwrap();
    assert!(!v.armed);
    assert!(!s.is_finished());
}

/// No picture ever arrives (an autopilot without a camera backend, a camera that is not
/// connected: here every transfer is lost): after more sweep capture points than the retake
/// limit without a picture, the camera is declared faulty with a reason that says what to
/// check, and the vehicle waits for the operator; nothing is mapped.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_sweep_that_gets_no_pictures_stops_with_a_clear_reason() {
    let rule: Rule = Box::new(|_| Fate::Lose);
    let f = fly(rule, 5).await;
    waits_for_the_camera(&f.outcome);
    assert!(f.state.book.detections().is_empty());
    assert!(f.state.book.positive_cells().is_empty());
    let fault = f.events.iter().find_map(|e| match e {
        MappingEvent::CameraFault { reason, .. } => Some(reason.clone()),
        _ => None,
    });
    let fault = fault.expect("a camera fault is journalled");
    assert!(
        fault.contains("sweep pictures did not arrive") && fault.contains("CAM1_TYPE"),
        "{fault}"
    );
    assert!(f.tampered.lost.load(Ordering::Relaxed) >= 6);
}

/// The camera goes bad during the DFS (from its 40th picture on, every picture claims a
/// place 25 m away): the visit retakes up to the limit, then the camera is declared faulty
/// and the vehicle waits; only the pictures taken before count, and each was taken at its
/// cell.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_camera_that_goes_bad_mid_run_stops_the_visit_at_the_retake_limit() {
    let rule: Rule = Box::new(|i| {
        if i >= 40 {
            Fate::Shift(0.0, 25.0)
        } else {
            Fate::Keep
        }
    });
    let f = fly(rule, 7).await;
    waits_for_the_camera(&f.outcome);
    let s = &f.state;
    let fault_cell = f
        .events
        .iter()
        .find_map(|e| match e {
            MappingEvent::CameraFault { cell, .. } => Some(*cell),
            _ => None,
        })
        .expect("a camera fault is journalled");
    let cell = fault_cell.expect("the fault happened during a cell visit");
    // The visit's failed pictures: 1..=6, the sixth over the limit of 5 retakes.
    let tail: Vec<u32> = f
        .events
        .iter()
        .filter_map(|e| match e {
            MappingEvent::ImageRejected {
                cell: Some(c),
                retakes,
                ..
            } if *c == cell => Some(*retakes),
            _ => None,
        })
        .collect();
    assert_eq!(tail, vec![1, 2, 3, 4, 5, 6], "{:?}", rejected(&f.events));
    assert!(
        f.progress
            .iter()
            .any(|l| l.contains("taking it again (5 of 5)")),
        "{:?}",
        f.progress
    );
    assert!(!s.book.detections().is_empty());
    assert_credited_where_taken(s, 1.0);
    assert_eq!(s.robot(1).unwrap().status, RobotStatus::AwaitingSwap);
}

// ---- geometry against references ----

/// An image whose red channel is x and green channel y (pixel indices; ≤ 256 px).
fn coordinate_image(w: u32, h: u32) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8, y as u8, 0]))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A level camera facing north right over the centre: the orthophoto is the runner's
    /// centre crop (`crop_to_cells`) within a pixel, for any optics, image size, cell size
    /// and altitude.
    #[test]
    fn a_level_orthophoto_is_the_centre_crop(
        w in 24u32..=256,
        h in 24u32..=256,
        hfov in 30.0f64..100.0,
        cell in 1.0f64..8.0,
        k in 0.7f64..4.0,
    ) {
        let cam = CameraModel::new(hfov, w, h).unwrap();
        let alt = k * cam.altitude_for_cell(cell);
        let img = coordinate_image(w, h);
        let req = OrthoRequest { cell_m: cell, centre_east_north_m: (0.0, 0.0), grid_north_deg: 0.0 };
        let o = orthophoto(&img, &cam, &attitude_from_euler_deg(0.0, 0.0, 0.0), alt, &req).unwrap();
        let crop = crop_to_cells(img.clone(), &cam, alt, cell);
        let (ow, oh) = o.image.dimensions();
        let (cw, ch) = crop.dimensions();
        prop_assert!(ow.abs_diff(cw) <= 1 && oh.abs_diff(ch) <= 1, "{ow}×{oh} vs {cw}×{ch}");
        prop_assert!(o.seen_fraction > 0.999);
        for (x, y, p) in o.image.enumerate_pixels() {
            if x >= cw || y >= ch {
                continue;
            }
            let q = crop.get_pixel(x, y);
            prop_assert!(
                (i32::from(p[0]) - i32::from(q[0])).abs() <= 1
                    && (i32::from(p[1]) - i32::from(q[1])).abs() <= 1,
                "pixel ({x}, {y}): orthophoto samples ({}, {}), crop ({}, {})", p[0], p[1], q[0], q[1]
            );
        }
    }

    /// For any roll, pitch and yaw, a ground point projected into the image and back lands
    /// where it started.
    #[test]
    fn a_ground_point_goes_into_the_image_and_back(
        roll in -25.0f64..25.0,
        pitch in -25.0f64..25.0,
        yaw in 0.0f64..360.0,
        alt in 3.0f64..50.0,
        north in -0.6f64..0.6,
        east in -0.6f64..0.6,
    ) {
        let cam = CameraModel::paper();
        let view = CameraView::new(&cam, 480, 480, &attitude_from_euler_deg(roll, pitch, yaw), alt).unwrap();
        let (n, e) = (north * alt, east * alt);
        let (u, v) = view.pixel_of_ground(n, e).unwrap();
        let (n2, e2) = view.ground_of_pixel(u, v).unwrap();
        prop_assert!((n - n2).abs() < 1e-6 && (e - e2).abs() < 1e-6, "({n}, {e}) → ({u}, {v}) → ({n2}, {e2})");
    }
}

/// The optical axis meets the ground where the simulator centres its render
/// (`fleetmap_camera::render::footprint_center`) for any tilt and heading.
#[test]
fn the_view_centre_is_the_simulators() {
    let world = World::from_toml(WORLD).unwrap();
    for (roll, pitch, yaw) in [
        (0.0, 0.0, 0.0),
        (5.0, 0.0, 0.0),
        (0.0, -7.0, 45.0),
        (3.0, 4.0, 200.0),
    ] {
        let pose = CameraPose {
            lat: STRIP_CENTRE.0,
            lon: STRIP_CENTRE.1,
            alt_agl_m: 12.0,
            heading_deg: yaw,
            roll_deg: roll,
            pitch_deg: pitch,
        };
        let (ce, cn) = fleetmap_camera::render::footprint_center(&world, &pose);
        let (e0, n0) = world.to_local(pose.lat, pose.lon);
        let (n, e) = view_centre_offset(&attitude_from_euler_deg(roll, pitch, yaw), 12.0).unwrap();
        // The simulator shifts by a·tan(pitch) forward and a·tan(roll) to the left, each
        // exact for one axis; the pinhole's exact axis differs by under 1 cm at these tilts.
        assert!(
            (e - (ce - e0)).abs() < 0.02 && (n - (cn - n0)).abs() < 0.02,
            "r{roll} p{pitch} y{yaw}: ({n}, {e}) vs ({}, {})",
            cn - n0,
            ce - e0
        );
    }
}

/// The simulator's renders of the strip's edge from a camera tilted by 6° (the view 1.3 m
/// off), resampled at the attitude, read like the level render: every region's black
/// fraction within 0.04 of the level one's, where the centre crop of the tilted render is off
/// by more than 0.1 in some region.
#[test]
fn tilted_renders_resampled_read_like_level_ones() {
    let world = World::from_toml(WORLD).unwrap();
    let cam = CameraModel::paper();
    let params = RunwayParams::default();
    // Over the strip's southern edge (the strip is 12.5 m north–south).
    let (lat, lon) = local::offset(STRIP_CENTRE.0, STRIP_CENTRE.1, -6.0, 2.0);
    let level = CameraPose {
        lat,
        lon,
        alt_agl_m: 12.0,
        heading_deg: 0.0,
        roll_deg: 0.0,
        pitch_deg: 0.0,
    };
    let img0 = render(&world, &level, &cam, 0.0, &Disturbances::none());
    let f0 = classify(&img0, 0.0, &params).unwrap().fractions;
    let regions = |f: fleetmap_core::vision::regions::RegionFractions| {
        [f.center, f.top, f.left, f.bottom, f.right]
    };
    let mut worst_crop = 0.0f64;
    for (roll, pitch, yaw) in [
        (0.0, 6.0, 0.0),
        (0.0, -6.0, 0.0),
        (6.0, 0.0, 90.0),
        (-4.0, 4.5, 180.0),
    ] {
        let pose = CameraPose {
            heading_deg: yaw,
            roll_deg: roll,
            pitch_deg: pitch,
            ..level
        };
        let img = render(&world, &pose, &cam, 0.0, &Disturbances::none());
        let att = attitude_from_euler_deg(roll, pitch, yaw);
        let req = OrthoRequest {
            cell_m: 4.0,
            centre_east_north_m: (0.0, 0.0),
            grid_north_deg: 0.0,
        };
        let o = orthophoto(&img, &cam, &att, 12.0, &req).unwrap();
        let fo = classify(&o.image, 0.0, &params).unwrap().fractions;
        let fc = classify(&img, yaw, &params).unwrap().fractions;
        // The crop's regions are in image coordinates: turn them to north-up for comparison.
        let fc = regions(fc);
        let turns = ((yaw / 90.0).round() as usize) % 4;
        // image (centre, top, left, bottom, right) → north-up: a turn of 90° puts top east.
        let ring = [fc[1], fc[4], fc[3], fc[2]]; // top, right, bottom, left (clockwise)
        let mut north_up = [0.0; 4];
        for (k, v) in ring.iter().enumerate() {
            north_up[(k + turns) % 4] = *v; // 0 north, 1 east, 2 south, 3 west
        }
        let fc = [fc[0], north_up[0], north_up[3], north_up[2], north_up[1]];
        for (k, (a, b)) in regions(fo).iter().zip(regions(f0)).enumerate() {
            assert!(
                (a - b).abs() < 0.04,
                "r{roll} p{pitch} y{yaw}: region {k}: orthophoto {a:.3}, level {b:.3}"
            );
        }
        for (a, b) in fc.iter().zip(regions(f0)) {
            worst_crop = worst_crop.max((a - b).abs());
        }
    }
    assert!(
        worst_crop > 0.1,
        "the tilt should matter to the centre crop ({worst_crop:.3})"
    );
}

/// Pictures carried by a slow payload link (4000 B/s, PX4 SITL's) arrive long after the
/// vehicle passed their capture points, queued behind each other: the camera announced them
/// and their data keeps flowing, so none counts as missing — no false camera fault — and the
/// run maps the strip.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn pictures_queued_on_a_slow_payload_link_are_not_a_camera_fault() {
    let rule: Rule = Box::new(|_| Fate::Keep);
    let f = fly_over(rule, 7, Some(8000)).await;
    let faults: Vec<_> = f
        .events
        .iter()
        .filter(|e| matches!(e, MappingEvent::CameraFault { .. }))
        .collect();
    assert!(faults.is_empty(), "{faults:?}");
    assert_eq!(f.outcome, Outcome::Finished);
    let s = &f.state;
    assert!(s.explorer.as_ref().is_some_and(|e| e.is_finished()));
    assert_maps_the_strip(s, &f.world);
}

/// Vehicle 1 alone waits on the ground, for its camera to be fixed: not for a battery swap
/// (a camera fault is not a battery swap, and the operator is told so).
fn waits_for_the_camera(outcome: &Outcome) {
    match outcome {
        Outcome::WaitingForOperator { waiting } => {
            assert_eq!(waiting.len(), 1, "{waiting:?}");
            assert_eq!(waiting[0].0, 1);
            assert!(
                matches!(waiting[0].1, OperatorTask::CameraFix(_)),
                "{waiting:?}"
            );
            let lines = fleetmap::app::kind::waiting_lines(waiting);
            assert!(
                lines[0].starts_with("vehicle 1 waits for its camera fixed"),
                "{lines:?}"
            );
        }
        other => panic!("expected vehicle 1 to wait for its camera, got {other:?}"),
    }
}
