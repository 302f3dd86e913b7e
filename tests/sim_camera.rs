//! The simulated camera: images of the runway world classified by the runway paper's
//! pipeline (`vision::runway::classify`: grey, threshold 150, 7 dilations, 3×3 regions — §7) give the labels the ground
//! truth calls for on the runway, off it and on its edge; images arrive intact over MAVLink
//! image transmission on a lossy link and as files; the same seed gives the same images.

#![allow(deprecated)]

use fleetmap::imagery::meta::read_meta;
use fleetmap::imagery::transfer::{ImageEvent, ImageReceiver, ReceiverConfig, read_file_url};
use fleetmap::link::codec::Codec;
use fleetmap::sim::faults::LinkFaults;
use fleetmap::sim::harness::{Sim, SimConfig};
use fleetmap::sim::render::{CameraPose, Disturbances, render};
use fleetmap::sim::world::{Surface, World, grid_cell_center};
use fleetmap::time::Time;
use fleetmap::vision::camera::CameraModel;
use fleetmap::vision::runway::{Classification, NeighbourLabels, RunwayParams, classify};
use image::RgbImage;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use std::time::Duration;

fn runway() -> World {
    World::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/worlds/runway.toml"
    )))
    .unwrap()
}

/// The runway paper's classifier (src/vision, §7: grey, threshold 150, 7 dilations, 3×3
/// regions) on the image as the GCS receives it: JPEG at the camera's quality, decoded.
fn classify_as_received(img: &RgbImage, heading_deg: f64) -> Classification {
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
    let mut shoot = |r: i32, c: i32, heading_deg: f64| -> Classification {
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
    let mut tally = |r: i32, c: i32, got: &Classification| {
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
    seq: u8,
    rx: ImageReceiver,
    images: Vec<Vec<u8>>,
    captured: Vec<mav::CAMERA_IMAGE_CAPTURED_DATA>,
}

impl Gcs {
    fn send(&mut self, msg: MavMessage) {
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        self.sim.send(1, &h, &msg);
    }

    fn command(&mut self, comp: u8, cmd: u16, p: [f32; 7]) {
        self.send(MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command: mav::MavCmd::from_u16(cmd).unwrap(),
            target_system: 1,
            target_component: comp,
            confirmation: 0,
        }));
    }

    fn run(&mut self, secs: f64) {
        let end = self.sim.now() + Duration::from_secs_f64(secs);
        while self.sim.now() < end {
            let t = self.sim.now() + Duration::from_millis(50);
            self.sim.advance_to(t);
            if (t.as_millis() / 50).is_multiple_of(20) {
                self.send(MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                    custom_mode: 0,
                    mavtype: mav::MavType::MAV_TYPE_GCS,
                    autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
                    base_mode: mav::MavModeFlag::empty(),
                    system_status: mav::MavState::MAV_STATE_ACTIVE,
                    mavlink_version: 3,
                }));
            }
            while let Some(d) = self.sim.recv_bytes(1) {
                for f in self.codec.decode(&d, 0) {
                    let from = (f.sysid(), f.compid());
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
        seq: 0,
        rx: ImageReceiver::new((1, 100), (255, 190), ReceiverConfig::default()),
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
