//! The simulated camera: images of the runway world classified by the runway paper's
//! pipeline (grey, threshold 150, 7 dilations, 3×3 regions — §7) give the labels the ground
//! truth calls for on the runway, off it and on its edge; images arrive intact over MAVLink
//! image transmission on a lossy link and as files; the same seed gives the same images.

#![allow(deprecated)]

use fleetmap::imagery::meta::read_meta;
use fleetmap::imagery::transfer::{ImageEvent, ImageReceiver, ReceiverConfig, read_file_url};
use fleetmap::link::codec::Codec;
use fleetmap::sim::faults::LinkFaults;
use fleetmap::sim::harness::{Sim, SimConfig};
use fleetmap::sim::render::{CameraPose, Disturbances, gray_bt601, render};
use fleetmap::sim::world::{Surface, World, grid_cell_center};
use fleetmap::time::Time;
use fleetmap::vision::camera::CameraModel;
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

/// Black fraction of the centre ninth after the paper's pipeline: grey > 150 is white, then
/// a 15×15 maximum (seven 3×3 dilations; pixels outside the image never count).
fn centre_black_fraction(img: &RgbImage) -> f64 {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let white: Vec<bool> = img.pixels().map(|p| gray_bt601(p) > 150).collect();
    let mut rows = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(7), (x + 7).min(w - 1));
            rows[y * w + x] = (a..=b).any(|i| white[y * w + i]);
        }
    }
    let (x0, x1, y0, y1) = (w / 3, 2 * w / 3, h / 3, 2 * h / 3);
    let mut black = 0usize;
    for y in y0..y1 {
        for x in x0..x1 {
            let (a, b) = (y.saturating_sub(7), (y + 7).min(h - 1));
            if !(a..=b).any(|j| rows[j * w + x]) {
                black += 1;
            }
        }
    }
    black as f64 / ((x1 - x0) * (y1 - y0)) as f64
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
    let mut shoot = |r: i32, c: i32| -> f64 {
        k += 1;
        let (lat, lon) = grid_cell_center(origin, 4.0, r, c);
        let pose = CameraPose {
            lat,
            lon,
            alt_agl_m: 12.0,
            heading_deg: 0.0,
            roll_deg: 0.0,
            pitch_deg: 0.0,
        };
        centre_black_fraction(&render(
            &world,
            &pose,
            &cam,
            0.0,
            &Disturbances::draw(1000 + k),
        ))
    };
    for (r, c, _) in pick(&on, 10) {
        let f = shoot(r, c);
        // the dashed white centreline can take up to ~35 % of a cell after dilation
        assert!(f >= 0.6, "runway cell ({r},{c}) black {f}");
    }
    for (r, c, _) in pick(&off, 10) {
        let f = shoot(r, c);
        assert!(f <= 0.03, "grass cell ({r},{c}) black {f}");
    }
    let mut agree = 0;
    let mut decided = 0;
    for (r, c, cov) in pick(&edge, 16) {
        let f = shoot(r, c);
        // dilation eats ≈ 7 px = 17 cm into the asphalt along the edge; markings more
        assert!(
            (f - cov).abs() <= 0.25,
            "edge cell ({r},{c}) coverage {cov:.2} black {f:.2}"
        );
        if !(0.4..=0.6).contains(&cov) {
            decided += 1;
            if (f >= 0.5) == (cov >= 0.5) {
                agree += 1;
            }
        }
    }
    assert!(
        decided >= 8 && agree * 10 >= decided * 9,
        "{agree}/{decided} edge labels agree"
    );
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
