//! The simulated camera: images of the runway world classified by the runway paper's
//! pipeline (`vision::runway::classify`: grey, threshold 150, 7 dilations, 3×3 regions — §7) give the labels the ground
//! truth calls for on the runway, off it and on its edge; images arrive intact over MAVLink
//! image transmission on a lossy link and as files; the same seed gives the same images.

#![allow(deprecated)]

use fleetmap_camera::pose::CameraPose;
use fleetmap_camera::render::{Disturbances, render};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::image_transfer::{ImageEvent, ImageReceiver, ReceiverConfig};
use fleetmap_core::time::Time;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::vision::meta::read_meta;
use fleetmap_core::vision::runway::{NeighbourLabels, RegionReading, RunwayParams, classify};
use fleetmap_core::world::{Surface, World, grid_cell_center};
use fleetmap_io::files::read_file_url;
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::faults::LinkFaults;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_test_kit::gcs::{Headers, command_long, heartbeat, status_text};
use image::RgbImage;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::time::Duration;

fn runway() -> World {
    fleetmap_io::files::load_world(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/worlds/runway.toml"
    )))
    .unwrap()
}

/// The runway paper's classifier (src/vision, §7: grey, threshold 150, 7 dilations, 3×3
/// regions) on the image as the GCS receives it: JPEG at the camera's quality, decoded.
fn classify_as_received(img: &RgbImage, heading_deg: f64) -> RegionReading {
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 85)
        .encode_image(img)
        .unwrap();
    let decoded = image::load_from_memory(&jpeg).unwrap().to_rgb8();
    classify(&decoded, heading_deg, &RunwayParams::default()).unwrap()
}

/// Fraction of grid cell (r, c) (4 m cells, origin = vehicle 1's home) covered by asphalt.
fn coverage(world: &World, origin: (f64, f64), r: i32, c: i32) -> f64 {
    let (lat, lon) = grid_cell_center(origin, 4.0, r, c);
    let (ce, cn) = world.to_local(lat, lon);
    let n = 40;
    let mut hit = 0;
    for i in 0..n {
        for j in 0..n {
            let e = ce - 2.0 + (f64::from(i) + 0.5) * 4.0 / f64::from(n);
            let nn = cn - 2.0 + (f64::from(j) + 0.5) * 4.0 / f64::from(n);
            if world.surface_at_local(e, nn, 0.0).0 == Surface::Asphalt {
                hit += 1;
            }
        }
    }
    f64::from(hit) / f64::from(n * n)
}

#[test]
fn runway_images_classify_as_the_ground_truth_says() {
    let world = runway();
    let origin = world.default_home(1).unwrap();
    let cam = CameraModel::paper();
    let mut on = Vec::new();
    let mut off = Vec::new();
    let mut edge = Vec::new();
    for r in -4..14 {
        for c in -10..12 {
            let cov = coverage(&world, origin, r, c);
            // a ring of cells around each cell tells how far the runway is
            let near: f64 = (-1..=1)
                .flat_map(|dr| (-1..=1).map(move |dc| (dr, dc)))
                .map(|(dr, dc)| coverage(&world, origin, r + dr, c + dc))
                .fold(0.0, f64::max);
            if cov >= 0.999 {
                on.push((r, c, cov));
            } else if near == 0.0 {
                off.push((r, c, cov));
            } else if cov > 0.05 && cov < 0.95 {
                edge.push((r, c, cov));
            }
        }
    }
    assert!(
        on.len() >= 20 && off.len() >= 20 && edge.len() >= 20,
        "{} {} {}",
        on.len(),
        off.len(),
        edge.len()
    );
    let pick = |v: &Vec<(i32, i32, f64)>, n: usize| -> Vec<(i32, i32, f64)> {
        let step = (v.len() / n).max(1);
        v.iter().step_by(step).take(n).copied().collect()
    };
    let mut k = 0u64;
    let mut shoot = |r: i32, c: i32, heading_deg: f64| -> RegionReading {
        k += 1;
        let (lat, lon) = grid_cell_center(origin, 4.0, r, c);
        let pose = CameraPose {
            lat,
            lon,
            alt_agl_m: 12.0,
            heading_deg,
            roll_deg: 0.0,
            pitch_deg: 0.0,
        };
        classify_as_received(
            &render(&world, &pose, &cam, 0.0, &Disturbances::draw(1000 + k)),
            heading_deg,
        )
    };
    // the ground truth's labels of a cell and its neighbours (None: too close to call)
    let truth = |r: i32, c: i32| -> [Option<bool>; 5] {
        [(0, 0), (1, 0), (0, -1), (-1, 0), (0, 1)].map(|(dr, dc)| {
            let cov = coverage(&world, origin, r + dr, c + dc);
            (!(0.4..=0.6).contains(&cov)).then_some(cov > 0.5)
        })
    };
    let as_array = |l: &NeighbourLabels| [l.center, l.north, l.west, l.south, l.east];
    let (mut agree, mut decided) = (0, 0);
    let mut tally = |r: i32, c: i32, got: &RegionReading| {
        for (want, got) in truth(r, c).iter().zip(as_array(&got.labels)) {
            if let Some(w) = want {
                decided += 1;
                agree += usize::from(*w == got);
            }
        }
    };
    for (i, (r, c, _)) in pick(&on, 10).into_iter().enumerate() {
        // headings: the labels are turned into grid directions by the classifier
        let got = shoot(r, c, 90.0 * (i % 4) as f64);
        // the dashed white centreline can take up to ~35 % of a cell after dilation
        assert!(
            got.fractions.center >= 0.6 && got.labels.center,
            "runway cell ({r},{c}): {:?}",
            got.fractions
        );
        tally(r, c, &got);
    }
    for (i, (r, c, _)) in pick(&off, 10).into_iter().enumerate() {
        let got = shoot(r, c, 90.0 * (i % 4) as f64);
        assert!(
            got.fractions.center <= 0.03 && !got.labels.center,
            "grass cell ({r},{c}): {:?}",
            got.fractions
        );
        assert_eq!(
            got.labels,
            NeighbourLabels::default(),
            "grass cell ({r},{c})"
        );
        tally(r, c, &got);
    }
    for (r, c, cov) in pick(&edge, 16) {
        let got = shoot(r, c, 0.0);
        // dilation eats ≈ 7 px = 17 cm into the asphalt along the edge; markings more
        let f = got.fractions.center;
        assert!(
            (f - cov).abs() <= 0.25,
            "edge cell ({r},{c}) coverage {cov:.2} black {f:.2}"
        );
        tally(r, c, &got);
    }
    assert!(
        decided >= 150 && agree * 100 >= decided * 97,
        "{agree}/{decided} labels agree with the ground truth"
    );
    // golden: four cells of the runway world, labels (centre, N, W, S, E) as the paper's
    // pipeline gives them on this renderer (seeded disturbances)
    let golden = [
        ((5, 0), [true, true, true, true, true]),
        ((-4, -10), [false, false, false, false, false]),
        // edges: a cell on the runway's north-west edge, one just north-west of it
        ((5, -5), [true, false, false, true, true]),
        ((8, -1), [false, false, false, true, true]),
    ];
    for ((r, c), want) in golden {
        let got = shoot(r, c, 0.0);
        assert_eq!(
            as_array(&got.labels),
            want,
            "cell ({r},{c}): {:?}",
            got.fractions
        );
    }
}

#[test]
fn same_seed_same_image() {
    let world = runway();
    let cam = CameraModel::paper();
    let (lat, lon) = world.default_home(1).unwrap();
    let pose = CameraPose {
        lat,
        lon,
        alt_agl_m: 12.0,
        heading_deg: 30.0,
        roll_deg: 2.0,
        pitch_deg: -1.0,
    };
    let a = render(&world, &pose, &cam, 0.0, &Disturbances::draw(9));
    let b = render(&world, &pose, &cam, 0.0, &Disturbances::draw(9));
    let c = render(&world, &pose, &cam, 0.0, &Disturbances::draw(10));
    assert_eq!(a, b);
    assert_ne!(a, c);
}

struct Gcs {
    sim: Sim,
    codec: Codec,
    headers: Headers,
    rx: ImageReceiver,
    images: Vec<Vec<u8>>,
    captured: Vec<mav::CAMERA_IMAGE_CAPTURED_DATA>,
}

impl Gcs {
    fn send(&mut self, msg: MavMessage) {
        let h = self.headers.next_header();
        self.sim.send(1, &h, &msg);
    }

    fn command(&mut self, comp: u8, cmd: u16, p: [f32; 7]) {
        self.send(command_long((1, comp), cmd, p));
    }

    fn run(&mut self, secs: f64) {
        let end = self.sim.now() + Duration::from_secs_f64(secs);
        while self.sim.now() < end {
            let t = self.sim.now() + Duration::from_millis(50);
            self.sim.advance_to(t);
            if (t.as_millis() / 50).is_multiple_of(20) {
                self.send(heartbeat());
            }
            while let Some(d) = self.sim.recv_bytes(1) {
                for f in self.codec.decode(&d, 0) {
                    let from = Endpoint::new(f.sysid(), f.compid());
                    let Ok(m) = f.message else { continue };
                    if let MavMessage::CAMERA_IMAGE_CAPTURED(c) = &m {
                        self.captured.push(c.clone());
                    }
                    self.rx.handle_message(from, &m, t);
                }
            }
            if self.rx.poll_timeout().is_some_and(|x| x <= t) {
                self.rx.handle_timeout(t);
            }
            while let Some(req) = self.rx.poll_transmit() {
                self.send(req);
            }
            while let Some(ev) = self.rx.poll_event() {
                if let ImageEvent::Image { jpeg, .. } = ev {
                    self.images.push(jpeg);
                }
            }
        }
    }
}

#[test]
fn images_arrive_over_a_lossy_link_and_as_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = SimConfig::from_spec("1xcopter:px4", Some(runway()), None, 11).unwrap();
    cfg.vehicles[0].camera.as_mut().unwrap().file_dir = Some(dir.path().display().to_string());
    let mut cfg = cfg.with_faults(LinkFaults::none());
    cfg.downlink[0] = LinkFaults {
        loss: 0.1,
        ..LinkFaults::none()
    };
    let sim = Sim::new(cfg, Time::ZERO).unwrap();
    let mut g = Gcs {
        sim,
        codec: Codec::new(),
        headers: Headers::default(),
        rx: ImageReceiver::new(
            Endpoint::new(1, 100),
            Endpoint::gcs(),
            ReceiverConfig::default(),
        ),
        images: Vec::new(),
        captured: Vec::new(),
    };
    g.run(12.0);
    // five pictures one second apart from the ground (PX4 camera on component 100)
    g.command(100, 2000, [0.0, 1.0, 5.0, 0.0, 0.0, 0.0, 0.0]);
    g.run(12.0);
    let mut truth = Vec::new();
    while let Some((_, img)) = g.sim.poll_image() {
        // the shell's job: write the file before the CAMERA_IMAGE_CAPTURED is read
        std::fs::write(dir.path().join(&img.file_name), &*img.jpeg).unwrap();
        truth.push(img);
    }
    assert_eq!(truth.len(), 5);
    // every image that announced itself over the lossy link was either completed intact or
    // reported lost; at 10 % loss with re-send requests most arrive
    assert!(g.images.len() >= 4, "{} images", g.images.len());
    for j in &g.images {
        let meta = read_meta(j).expect("metadata");
        let t = truth
            .iter()
            .find(|t| t.meta.image_index == meta.image_index)
            .unwrap();
        assert_eq!(**j, *t.jpeg, "image {} corrupted", meta.image_index);
    }
    assert!(g.rx.requests > 0 || g.rx.completed == 5);
    // the announced files hold the same bytes
    for c in &g.captured {
        let url = c
            .file_url
            .to_str()
            .unwrap_or("")
            .trim_end_matches('\0')
            .to_string();
        assert!(url.starts_with("file://"), "{url:?}");
        let bytes = read_file_url(&url, 10 << 20).unwrap();
        let t = truth
            .iter()
            .find(|t| t.meta.image_index == c.image_index)
            .unwrap();
        assert_eq!(bytes, *t.jpeg);
    }
}

// ------------------------------------------------------------------------------------------
// The camera for a real autopilot (`fleetmap sim --camera-only`, sim::paired): it asks the
// autopilot for the telemetry it needs, never renders from a stale pose, and paces its image
// transmission so that a routing autopilot can forward it.

use fleetmap_camera::camera::{CameraConfig, attitude_quaternion};
use fleetmap_camera::paired::PairedCameras;

const AP1: MavHeader = MavHeader {
    system_id: 1,
    component_id: 1,
    sequence: 0,
};
const GCS: MavHeader = MavHeader {
    system_id: 255,
    component_id: 190,
    sequence: 0,
};

fn paired(cfg: CameraConfig) -> PairedCameras {
    PairedCameras::new(std::sync::Arc::new(runway()), cfg, 5)
}

fn autopilot_heartbeat(autopilot: mav::MavAutopilot) -> MavMessage {
    MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
        autopilot,
        mavtype: mav::MavType::MAV_TYPE_QUADROTOR,
        system_status: mav::MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
        ..mav::HEARTBEAT_DATA::default()
    })
}

/// GLOBAL_POSITION_INT at the runway world's first home, 12 m up, heading `hdg_deg`.
fn position_at_home(time_boot_ms: u32, hdg_deg: f64) -> MavMessage {
    let (lat, lon) = runway().default_home(1).unwrap();
    MavMessage::GLOBAL_POSITION_INT(mav::GLOBAL_POSITION_INT_DATA {
        time_boot_ms,
        lat: (lat * 1e7).round() as i32,
        lon: (lon * 1e7).round() as i32,
        alt: 612_000,
        relative_alt: 12_000,
        hdg: (hdg_deg * 100.0).round() as u16,
        ..mav::GLOBAL_POSITION_INT_DATA::default()
    })
}

fn image_start_capture(target_system: u8) -> MavMessage {
    MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
        param2: 0.0, // one picture
        param3: 1.0,
        command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        target_system,
        target_component: 100,
        ..mav::COMMAND_LONG_DATA::default()
    })
}

fn sent(cams: &mut PairedCameras) -> Vec<(MavHeader, MavMessage)> {
    std::iter::from_fn(|| cams.poll_transmit()).collect()
}

fn acks(msgs: &[(MavHeader, MavMessage)]) -> Vec<mav::COMMAND_ACK_DATA> {
    msgs.iter()
        .filter_map(|(_, m)| match m {
            MavMessage::COMMAND_ACK(a) => Some(a.clone()),
            _ => None,
        })
        .collect()
}

fn texts(msgs: &[(MavHeader, MavMessage)]) -> Vec<String> {
    msgs.iter().filter_map(|(_, m)| status_text(m)).collect()
}

/// REQUEST_DATA_STREAMs as (stream, rate Hz) and SET_MESSAGE_INTERVALs as (message id,
/// interval µs).
type TelemetryRequests = (Vec<(mav::MavDataStream, u16)>, Vec<(u32, f32)>);

/// The requests for telemetry sent to autopilot `sysid`, all from its camera component.
fn telemetry_requests(msgs: &[(MavHeader, MavMessage)], sysid: u8) -> TelemetryRequests {
    let mut streams = Vec::new();
    let mut intervals = Vec::new();
    for (h, m) in msgs {
        match m {
            MavMessage::REQUEST_DATA_STREAM(r) if r.target_system == sysid => {
                assert_eq!((h.system_id, h.component_id), (u32::from(sysid), 100));
                assert_eq!((r.target_component, r.start_stop), (1, 1));
                streams.push((r.req_stream_id, r.req_message_rate));
            }
            MavMessage::COMMAND_LONG(c)
                if c.target_system == sysid
                    && c.command == mav::MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL =>
            {
                assert_eq!((h.system_id, h.component_id), (u32::from(sysid), 100));
                assert_eq!(c.target_component, 1);
                intervals.push((c.param1 as u32, c.param2));
            }
            _ => {}
        }
    }
    (streams, intervals)
}

#[test]
fn paired_camera_asks_each_autopilot_for_its_telemetry() {
    let mut cams = paired(CameraConfig::default());
    cams.handle_message(
        &AP1,
        &autopilot_heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA),
        Time::from_secs(1),
    );
    let px4 = MavHeader {
        system_id: 2,
        ..AP1
    };
    cams.handle_message(
        &px4,
        &autopilot_heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_PX4),
        Time::from_secs(1),
    );
    let msgs = sent(&mut cams);
    // ArduPilot: the stream groups (QGC's initializeStreamRates, MAVProxy --streamrate) and
    // the message intervals, 10 Hz
    let (streams, intervals) = telemetry_requests(&msgs, 1);
    assert_eq!(
        streams,
        vec![
            (mav::MavDataStream::MAV_DATA_STREAM_POSITION, 10),
            (mav::MavDataStream::MAV_DATA_STREAM_EXTRA1, 10),
        ]
    );
    assert_eq!(intervals, vec![(33, 100_000.0), (30, 100_000.0)]);
    // PX4 ignores REQUEST_DATA_STREAM: intervals only
    let (streams, intervals) = telemetry_requests(&msgs, 2);
    assert!(streams.is_empty(), "{streams:?}");
    assert_eq!(intervals, vec![(33, 100_000.0), (30, 100_000.0)]);
    // asked once: the next heartbeats ask nothing
    cams.handle_message(
        &AP1,
        &autopilot_heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA),
        Time::from_secs(2),
    );
    assert_eq!(
        telemetry_requests(&sent(&mut cams), 1),
        (Vec::new(), Vec::new())
    );
}

#[test]
fn paired_camera_without_a_position_refuses_to_capture() {
    let mut cams = paired(CameraConfig::default());
    cams.handle_message(
        &AP1,
        &autopilot_heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA),
        Time::from_secs(1),
    );
    cams.step(Time::from_secs(1));
    let _ = sent(&mut cams);
    cams.handle_message(&GCS, &image_start_capture(1), Time::from_secs(2));
    cams.step(Time::from_secs(2));
    let msgs = sent(&mut cams);
    let acks = acks(&msgs);
    assert_eq!(acks.len(), 1);
    assert_eq!(
        acks[0].command,
        mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        "{acks:?}"
    );
    assert_eq!(
        acks[0].result,
        mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED
    );
    assert_eq!(
        (acks[0].target_system, acks[0].target_component),
        (255, 190)
    );
    assert_eq!(
        texts(&msgs),
        vec!["camera: never had a position from vehicle 1".to_string()]
    );
    assert!(msgs.iter().all(|(h, _)| h.component_id == 100));
    assert!(
        !msgs
            .iter()
            .any(|(_, m)| matches!(m, MavMessage::CAMERA_IMAGE_CAPTURED(_)))
    );
    assert!(cams.poll_image().is_none());
    assert_eq!((cams.refused(), cams.refused_for(1)), (1, 1));
}

#[test]
fn paired_camera_renders_from_a_pose_a_tenth_of_a_second_old() {
    let mut cams = paired(CameraConfig::default());
    cams.handle_message(
        &AP1,
        &autopilot_heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA),
        Time::from_secs(1),
    );
    cams.handle_message(&AP1, &position_at_home(10_000, 58.0), Time::from_secs(10));
    cams.handle_message(
        &AP1,
        &MavMessage::ATTITUDE(mav::ATTITUDE_DATA {
            time_boot_ms: 10_000,
            roll: 3f32.to_radians(),
            pitch: (-2f32).to_radians(),
            yaw: 58f32.to_radians(),
            ..mav::ATTITUDE_DATA::default()
        }),
        Time::from_secs(10),
    );
    let _ = sent(&mut cams);
    cams.handle_message(&GCS, &image_start_capture(1), Time::from_millis(10_100));
    cams.step(Time::from_millis(10_100));
    let msgs = sent(&mut cams);
    assert_eq!(
        acks(&msgs).iter().map(|a| a.result).collect::<Vec<_>>(),
        vec![mav::MavResult::MAV_RESULT_ACCEPTED]
    );
    assert!(texts(&msgs).is_empty());
    let (sysid, img) = cams.poll_image().expect("an image");
    assert_eq!(sysid, 1);
    let (lat, lon) = runway().default_home(1).unwrap();
    assert!((img.true_pose.lat - lat).abs() < 1e-7 && (img.true_pose.lon - lon).abs() < 1e-7);
    assert!((img.true_pose.alt_agl_m - 12.0).abs() < 1e-9);
    assert!((img.true_pose.roll_deg - 3.0).abs() < 1e-4);
    assert!((img.true_pose.pitch_deg + 2.0).abs() < 1e-4);
    assert!((img.true_pose.heading_deg - 58.0).abs() < 1e-4);
    // CAMERA_IMAGE_CAPTURED carries the pose the picture was rendered at, attitude included
    let captured: Vec<_> = msgs
        .iter()
        .filter_map(|(_, m)| match m {
            MavMessage::CAMERA_IMAGE_CAPTURED(c) => Some(c.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(captured.len(), 1);
    let c = &captured[0];
    assert_eq!(
        (c.lat, c.lon),
        ((lat * 1e7).round() as i32, (lon * 1e7).round() as i32)
    );
    assert_eq!((c.relative_alt, c.alt), (12_000, 612_000));
    let want = attitude_quaternion(
        img.true_pose.roll_deg,
        img.true_pose.pitch_deg,
        img.true_pose.heading_deg,
    );
    for (got, want) in c.q.iter().zip(want) {
        assert!((got - want).abs() < 1e-6, "{:?} vs {want:?}", c.q);
    }
    assert_eq!(cams.refused(), 0);
}

#[test]
fn paired_camera_refuses_a_pose_two_seconds_old_and_asks_again() {
    let mut cams = paired(CameraConfig::default());
    cams.handle_message(
        &AP1,
        &autopilot_heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA),
        Time::from_secs(1),
    );
    cams.handle_message(&AP1, &position_at_home(10_000, 58.0), Time::from_secs(10));
    cams.step(Time::from_secs(10));
    let _ = sent(&mut cams);
    assert_eq!(cams.telemetry_requests(1), 1);
    cams.handle_message(&GCS, &image_start_capture(1), Time::from_secs(12));
    cams.step(Time::from_secs(12));
    let msgs = sent(&mut cams);
    assert_eq!(
        acks(&msgs).iter().map(|a| a.result).collect::<Vec<_>>(),
        vec![mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED]
    );
    assert_eq!(
        texts(&msgs),
        vec!["camera: no position from vehicle 1 for 2.0 s".to_string()]
    );
    assert!(cams.poll_image().is_none());
    assert_eq!(cams.refused(), 1);
    // the telemetry stopped: asked for again (streams and intervals)
    let (streams, intervals) = telemetry_requests(&msgs, 1);
    assert_eq!((streams.len(), intervals.len()), (2, 2));
    assert_eq!(cams.telemetry_requests(1), 2);
    // and not again before 2 s have passed
    cams.step(Time::from_millis(13_900));
    assert_eq!(cams.telemetry_requests(1), 2);
    cams.step(Time::from_secs(14));
    assert_eq!(cams.telemetry_requests(1), 3);
}

/// Run `cams` from `t0` in steps of 10 ms until `until` and return every message sent from
/// camera 1 with the time it left.
fn run_paired(cams: &mut PairedCameras, t0: Time, until: Time) -> Vec<(Time, MavMessage)> {
    let mut out = Vec::new();
    let mut t = t0;
    while t <= until {
        cams.step(t);
        while let Some((h, m)) = cams.poll_transmit() {
            assert_eq!((h.system_id, h.component_id), (1, 100));
            out.push((t, m));
        }
        t += Duration::from_millis(10);
    }
    out
}

#[test]
fn paced_image_transmission_takes_size_over_rate_and_every_packet_goes_out() {
    let rate = 20_000.0;
    let feedback = {
        let (lat, lon) = runway().default_home(1).unwrap();
        MavMessage::CAMERA_FEEDBACK(mav::CAMERA_FEEDBACK_DATA {
            lat: (lat * 1e7).round() as i32,
            lng: (lon * 1e7).round() as i32,
            alt_msl: 612.0,
            alt_rel: 12.0,
            yaw: 58.0,
            target_system: 1,
            ..mav::CAMERA_FEEDBACK_DATA::default()
        })
    };
    let mut cams = paired(CameraConfig {
        transfer_rate_bps: Some(rate),
        ..CameraConfig::default()
    });
    let t0 = Time::from_secs(1);
    cams.handle_message(&AP1, &feedback, t0);
    let out = run_paired(&mut cams, t0, Time::from_secs(30));
    let (_, img) = cams.poll_image().expect("the feedback's picture");
    let size = img.jpeg.len();
    assert!(size > 20_000, "{size} bytes"); // a 480-px JPEG: tens of kilobytes
    let packets = size.div_ceil(253);
    // every packet went out, in order, after its handshake
    let data: Vec<(Time, u16)> = out
        .iter()
        .filter_map(|(t, m)| match m {
            MavMessage::ENCAPSULATED_DATA(d) => Some((*t, d.seqnr)),
            _ => None,
        })
        .collect();
    assert_eq!(
        data.iter().map(|d| d.1).collect::<Vec<_>>(),
        (0..packets as u16).collect::<Vec<_>>()
    );
    let handshake = out
        .iter()
        .position(|(_, m)| matches!(m, MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)))
        .expect("a handshake");
    let first_data = out
        .iter()
        .position(|(_, m)| matches!(m, MavMessage::ENCAPSULATED_DATA(_)))
        .unwrap();
    assert!(handshake < first_data);
    // CAMERA_IMAGE_CAPTURED is not held back by the pacing
    assert!(
        out.iter()
            .any(|(t, m)| *t == t0 && matches!(m, MavMessage::CAMERA_IMAGE_CAPTURED(_)))
    );
    // it took about size / rate seconds of the camera's clock (frames carry 267 bytes per
    // 253 of image; the bucket starts with 50 ms of rate)
    let took = data
        .last()
        .map(|(t, _)| t.saturating_since(t0).as_secs_f64())
        .unwrap_or(0.0);
    let nominal = size as f64 / rate;
    assert!(
        took >= 0.95 * nominal && took <= 1.15 * nominal,
        "{size} bytes took {took:.2} s at {rate} B/s (nominal {nominal:.2} s)"
    );
    // and no second carried more than the rate plus the bucket
    for (i, (t, _)) in data.iter().enumerate() {
        let in_window = data[i..]
            .iter()
            .take_while(|(u, _)| u.saturating_since(*t) < Duration::from_secs(1))
            .count();
        assert!(
            in_window as f64 * 267.0 <= rate + 0.05 * rate + 267.0,
            "{in_window} packets in the second after {t}"
        );
    }
    // the GCS's receiver puts the image together from what went out
    let mut rx = ImageReceiver::new(
        Endpoint::new(1, 100),
        Endpoint::gcs(),
        ReceiverConfig::default(),
    );
    for (t, m) in &out {
        rx.handle_message(Endpoint::new(1, 100), m, *t);
    }
    let got: Vec<_> = std::iter::from_fn(|| rx.poll_event()).collect();
    assert!(
        matches!(&got[..], [ImageEvent::Image { jpeg, .. }] if *jpeg == *img.jpeg),
        "{} events",
        got.len()
    );
    // unpaced (the embedded simulator's default): everything in the first step
    let mut cams = paired(CameraConfig::default());
    cams.handle_message(&AP1, &feedback, t0);
    let out = run_paired(&mut cams, t0, t0);
    let n = out
        .iter()
        .filter(|(_, m)| matches!(m, MavMessage::ENCAPSULATED_DATA(_)))
        .count();
    assert_eq!(n, packets);
}

/// Connect `cams` to vehicle 1 of `sim` for `secs` seconds from `from`, in 50 ms steps;
/// collects the GLOBAL_POSITION_INTs the camera heard (with their arrival). Returns the end.
fn link(
    sim: &mut Sim,
    cams: &mut PairedCameras,
    from: Time,
    secs: u64,
    heard: &mut Vec<(Time, mav::GLOBAL_POSITION_INT_DATA)>,
) -> Time {
    let mut t = from;
    while t < from + Duration::from_secs(secs) {
        t += Duration::from_millis(50);
        sim.advance_to(t);
        while let Some((h, m)) = sim.recv(1) {
            if let MavMessage::GLOBAL_POSITION_INT(p) = &m {
                heard.push((t, p.clone()));
            }
            cams.handle_message(&h, &m, t);
        }
        cams.step(t);
        while let Some((h, m)) = cams.poll_transmit() {
            sim.send(1, &h, &m);
        }
    }
    t
}

#[test]
fn paired_camera_wakes_a_silent_arducopter() {
    // the embedded ArduCopter behaves as the real one on a serial port: HEARTBEAT only
    // until someone asks (its own camera is off: the paired camera plays component 100)
    let mut cfg = SimConfig::from_spec("1xcopter:ardupilot", Some(runway()), None, 3)
        .unwrap()
        .with_faults(LinkFaults::none());
    cfg.vehicles[0].camera = None;
    let mut sim = Sim::new(cfg, Time::ZERO).unwrap();
    let mut t = Time::ZERO;
    let mut positions = 0;
    while t < Time::from_secs(20) {
        t += Duration::from_millis(50);
        sim.advance_to(t);
        while let Some((_, m)) = sim.recv(1) {
            positions += usize::from(matches!(m, MavMessage::GLOBAL_POSITION_INT(_)));
        }
    }
    assert_eq!(positions, 0, "ArduCopter streamed without being asked");
    // the camera joins the link
    let mut cams = paired(CameraConfig::default());
    let mut heard = Vec::new();
    let t = link(&mut sim, &mut cams, t, 5, &mut heard);
    assert!(cams.telemetry_requests(1) >= 1);
    // about 10 Hz for the last 3 s
    let recent = heard
        .iter()
        .filter(|(h, _)| *h + Duration::from_secs(3) >= t)
        .count();
    assert!((25..=35).contains(&recent), "{recent} positions in 3 s");
    // a capture now is rendered at the copter's position
    cams.handle_message(&GCS, &image_start_capture(1), t);
    link(&mut sim, &mut cams, t, 1, &mut heard);
    let (_, img) = cams.poll_image().expect("an image");
    let (_, p) = heard.last().expect("a position");
    assert!((img.true_pose.lat - f64::from(p.lat) * 1e-7).abs() < 1e-6);
    assert!((img.true_pose.lon - f64::from(p.lon) * 1e-7).abs() < 1e-6);
    assert_eq!(cams.refused(), 0);
}

// ------------------------------------------------------------------ degraded sensor (§V)

/// The degraded sensor (`CameraConfig::misclassify_probability`) fools the GCS's own
/// measurement: a flipped image of a green tile of the bandit paper's hardware field is
/// measured not green, a flipped image of a grey tile green, and unflipped images the other
/// way round. The images are the simulated camera's JPEGs (160 px, as the bandit tests fly)
/// measured with the parameters the GCS's run takes from the hardware mission.
#[test]
fn a_flipped_image_is_measured_as_the_other_class_by_the_gcs() {
    use fleetmap::kinds::bandit::measure_image;
    use fleetmap::kinds::bandit::sim::{HARDWARE_MISSION, HARDWARE_WORLD};
    use fleetmap_camera::camera::{CaptureContext, SimCamera};
    use fleetmap_core::geo::{Grid, LatLon};
    use fleetmap_core::mission::definition::{MissionDef, Origin};
    use fleetmap_core::planner::sortie::ClassificationState;

    let world = World::from_toml(HARDWARE_WORLD).unwrap();
    let def = MissionDef::parse(HARDWARE_MISSION, "hardware-6x6.toml").unwrap();
    let Origin::Coordinates(o) = def.grid.origin else {
        panic!("the hardware mission has a fixed origin");
    };
    let cell_m = def.grid.cell_size_m;
    let grid = Grid::new(LatLon::new(o.lat, o.lon), cell_m).unwrap();
    let params = ClassificationState::new(&def, grid, None).unwrap().params;
    // The GCS's measurement of one image of cell (row, col) taken from `alt` m by a camera
    // that flips with probability `p` (0 or 1 here: never or always).
    let measured = |p: f64, (row, col): (i32, i32), alt: f64, seed: u64| -> bool {
        let mut cfg = CameraConfig {
            misclassify_probability: p,
            mavlink_transfer: false,
            ..CameraConfig::default()
        };
        cfg.model.width_px = 160;
        cfg.model.height_px = 160;
        let mut cam = SimCamera::new(1, cfg, seed);
        let (lat, lon) = grid_cell_center((o.lat, o.lon), cell_m, row, col);
        let ctx = CaptureContext {
            true_pose: CameraPose {
                lat,
                lon,
                alt_agl_m: alt,
                heading_deg: 0.0,
                roll_deg: 0.0,
                pitch_deg: 0.0,
            },
            reported: (lat, lon, alt),
            alt_amsl_m: 600.0 + alt,
            time_boot_ms: 1_000,
            now: Time::from_secs(1),
            world_t_s: 1.0,
        };
        cam.capture_now(&ctx, Some(&world));
        let img = cam.poll_image().expect("an image of the field");
        assert_eq!(img.misclassified, p >= 1.0);
        let (f, positive) = measure_image(
            &img.jpeg,
            &params.green,
            &params.camera,
            alt,
            cell_m,
            params.crop_fraction,
        )
        .unwrap();
        println!("p {p} cell ({row}, {col}) at {alt} m: green share {f:.3}");
        positive
    };
    let green = world.cells_of(Surface::GreenTile);
    let grey = world.cells_of(Surface::GreyTile);
    assert_eq!((green.len(), grey.len()), (4, 10));
    // every tile, from the drones' four altitudes (10, 12, 14, 16 m)
    for (k, &cell) in green.iter().chain(&grey).enumerate() {
        let is_green = green.contains(&cell);
        let alt = 10.0 + 2.0 * (k % 4) as f64;
        let seed = k as u64;
        assert_eq!(
            measured(0.0, cell, alt, seed),
            is_green,
            "{cell:?} as it is"
        );
        assert_eq!(
            measured(1.0, cell, alt, seed),
            !is_green,
            "{cell:?} flipped"
        );
    }
}
