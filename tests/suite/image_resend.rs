//! A picture that misses one packet on its way to the GCS is recovered whole, through
//! simulated cameras behind one autopilot port as `fleetmap sim --camera-only` serves a SITL
//! fleet: four vehicles, each camera paced (the queue of a camera shooting faster than it can
//! send), each GCS request forwarded to the cameras' port by every autopilot (a
//! DATA_TRANSMISSION_HANDSHAKE has no target, ArduPilot's `MAVLink_routing` and PX4's
//! `Mavlink::forward_message` pass it to every port that has a component on it), and the
//! GCS's image intake ([`fleetmap::app::images::Intake`]) asking for what it missed.
//!
//! In-process and deterministic: a virtual clock in 5 ms steps, a fixed latency each way, and
//! a fault that drops the k-th ENCAPSULATED_DATA of one picture (the first time it goes out,
//! or the first two times).
//!
//! Before the fix (2026-12-04) the receiver asked for a picture only once the camera had gone
//! quiet — after the whole queue — and the camera then no longer held it (it kept its 16
//! latest *captures*, and answered a size it did not hold with its latest picture, every
//! camera behind the port at once): the picture was lost.

use fleetmap::app::images::{ImageFailure, Intake};
use fleetmap_camera::camera::{CameraConfig, RECENT_IMAGES};
use fleetmap_camera::paired::PairedCameras;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

const GCS: MavHeader = MavHeader {
    system_id: 255,
    component_id: 190,
    sequence: 0,
};
/// Vehicles (and cameras) behind the one port.
const VEHICLES: u8 = 4;
/// Pictures each camera takes, one every 0.2 s.
const PICTURES: u32 = 40;
/// Time step of the virtual clock.
const STEP: Duration = Duration::from_millis(5);
/// One-way latency between the cameras and the GCS (through an autopilot).
const LATENCY: Duration = Duration::from_millis(20);

fn world() -> Arc<World> {
    Arc::new(
        fleetmap_io::files::load_world(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/assets/worlds/hardware-6x6.toml"
        )))
        .unwrap(),
    )
}

/// Drop packet `seqnr` of camera `camera`'s picture number `picture` (0-based, in the order
/// of the pictures' first announcements) the first `times` times it goes out.
#[derive(Clone, Copy, Debug)]
struct Fault {
    camera: u8,
    picture: usize,
    seqnr: u16,
    times: u32,
}

/// The cameras, the GCS intake, and the links between them (see the module docs).
struct Bench {
    /// Each vehicle's home (the world's default homes).
    homes: Vec<(f64, f64)>,
    cams: PairedCameras,
    intake: Intake,
    now: Time,
    fault: Fault,
    dropped: u32,
    /// camera → GCS: (arrival, header, message)
    up: VecDeque<(Time, MavHeader, MavMessage)>,
    /// GCS → cameras: (arrival, message), one copy per autopilot
    down: VecDeque<(Time, MavMessage)>,
    /// Sizes each camera announced, in order, with when they left.
    announced: BTreeMap<u8, Vec<(Time, u32)>>,
    /// The picture each camera is sending now.
    sending: BTreeMap<u8, u32>,
    /// (camera, JPEG, when captured)
    captured: Vec<(u8, Arc<Vec<u8>>, Time)>,
    /// (camera, JPEG, when the GCS had it whole)
    received: Vec<(u8, Arc<Vec<u8>>, Time)>,
    /// GCS requests: (the camera whose receiver asked, when, size asked for)
    requests: Vec<(u8, Time, u32)>,
    failures: Vec<ImageFailure>,
}

impl Bench {
    fn new(fault: Fault) -> Bench {
        let config = {
            let mut c = CameraConfig {
                // 4 kB/s (a third of it taken by the CAMERA_IMAGE_CAPTURED of five captures a
                // second), a picture of 4–7 kB every 2 s: the camera shoots ten times faster
                // than it sends, as 54 kB pictures at 20 kB/s every 0.2 s do
                transfer_rate_bps: Some(4_000.0),
                ..CameraConfig::default()
            };
            c.model.width_px = 128;
            c.model.height_px = 128;
            c
        };
        let w = world();
        Bench {
            homes: (1..=VEHICLES)
                .map(|k| w.default_home(usize::from(k)).unwrap())
                .collect(),
            cams: PairedCameras::new(w, config, 7),
            intake: Intake::new(Endpoint::gcs()),
            now: Time::ZERO,
            fault,
            dropped: 0,
            up: VecDeque::new(),
            down: VecDeque::new(),
            announced: BTreeMap::new(),
            sending: BTreeMap::new(),
            captured: Vec::new(),
            received: Vec::new(),
            requests: Vec::new(),
            failures: Vec::new(),
        }
    }

    /// What autopilot `sysid` tells its camera port at `now`: its heartbeat, then its
    /// position every 100 ms (flying east at 2 m/s from its home, 10 m up, so that each
    /// picture differs from the one before).
    fn autopilot(&mut self, sysid: u8) {
        let h = MavHeader {
            system_id: u32::from(sysid),
            component_id: 1,
            sequence: 0,
        };
        let ms = self.now.as_millis();
        if ms == 0 {
            let hb = MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                autopilot: mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                mavtype: mav::MavType::MAV_TYPE_QUADROTOR,
                mavlink_version: 3,
                ..mav::HEARTBEAT_DATA::default()
            });
            self.cams.handle_message(&h, &hb, self.now);
        }
        if ms.is_multiple_of(100) {
            let (lat, lon) = self.homes[usize::from(sysid - 1)];
            let east_m = 2.0 * self.now.as_secs_f64();
            let lon = lon + east_m / (111_320.0 * lat.to_radians().cos());
            let pos = MavMessage::GLOBAL_POSITION_INT(mav::GLOBAL_POSITION_INT_DATA {
                time_boot_ms: ms as u32,
                lat: (lat * 1e7).round() as i32,
                lon: (lon * 1e7).round() as i32,
                alt: 610_000,
                relative_alt: 10_000,
                hdg: 9_000,
                ..mav::GLOBAL_POSITION_INT_DATA::default()
            });
            self.cams.handle_message(&h, &pos, self.now);
        }
    }

    /// Whether the fault drops `m` from camera `cam`.
    fn drops(&mut self, cam: u8, m: &MavMessage) -> bool {
        let f = self.fault;
        if cam != f.camera || self.dropped >= f.times {
            return false;
        }
        let MavMessage::ENCAPSULATED_DATA(d) = m else {
            return false;
        };
        let order = &self.announced[&cam];
        let mut firsts: Vec<u32> = Vec::new();
        for (_, s) in order {
            if !firsts.contains(s) {
                firsts.push(*s);
            }
        }
        let hit = firsts.get(f.picture) == self.sending.get(&cam) && d.seqnr == f.seqnr;
        if hit {
            self.dropped += 1;
        }
        hit
    }

    fn step(&mut self) {
        let now = self.now;
        for k in 1..=VEHICLES {
            self.autopilot(k);
        }
        if now == Time::from_secs(1) {
            // every camera shoots PICTURES pictures, one every 0.2 s (the GCS's command,
            // forwarded by each autopilot to its camera)
            for k in 1..=VEHICLES {
                let cmd = MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                    param2: 0.2,
                    param3: PICTURES as f32,
                    command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                    target_system: k,
                    target_component: 100,
                    ..mav::COMMAND_LONG_DATA::default()
                });
                self.cams.handle_message(&GCS, &cmd, now);
            }
        }
        // GCS → cameras
        while self.down.front().is_some_and(|(t, _)| *t <= now) {
            if let Some((_, m)) = self.down.pop_front() {
                self.cams.handle_message(&GCS, &m, now);
            }
        }
        self.cams.step(now);
        while let Some((sysid, img)) = self.cams.poll_image() {
            self.captured.push((sysid, img.jpeg.clone(), now));
        }
        while let Some((h, m)) = self.cams.poll_transmit() {
            let cam = h.system_id as u8;
            if let MavMessage::DATA_TRANSMISSION_HANDSHAKE(d) = &m {
                self.announced.entry(cam).or_default().push((now, d.size));
                self.sending.insert(cam, d.size);
            }
            if !self.drops(cam, &m) {
                self.up.push_back((now + LATENCY, h, m));
            }
        }
        // cameras → GCS
        while self.up.front().is_some_and(|(t, _, _)| *t <= now) {
            if let Some((_, h, m)) = self.up.pop_front() {
                let from = Endpoint::new(h.system_id as u8, h.component_id);
                self.intake.handle_message(from, &m, now);
            }
        }
        if self.intake.poll_timeout().is_some_and(|t| t <= now) {
            self.intake.handle_timeout(now);
        }
        while let Some((cam, m)) = self.intake.poll_transmit() {
            if let MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) = &m {
                self.requests.push((cam.sysid, now, h.size));
            }
            // no target: every autopilot on the port forwards it to the cameras
            for _ in 1..=VEHICLES {
                self.down.push_back((now + LATENCY, m.clone()));
            }
        }
        while let Some(img) = self.intake.poll_image() {
            self.received.push((img.sysid, img.bytes.clone(), now));
        }
        self.failures.extend(self.intake.failures.drain(..));
        self.now += STEP;
    }

    /// Run until every picture is in (or lost), at most `limit` of virtual time.
    fn run(&mut self, limit: Duration) {
        let all = usize::from(VEHICLES) * PICTURES as usize;
        while self.now < Time::ZERO + limit
            && (self.captured.len() < all || self.received.len() + self.failures.len() < all)
        {
            self.step();
        }
    }

    /// The JPEG of camera `cam`'s picture `picture` (in the order of capture).
    fn picture(&self, cam: u8, picture: usize) -> Arc<Vec<u8>> {
        let mine: Vec<&Arc<Vec<u8>>> = self
            .captured
            .iter()
            .filter(|(c, _, _)| *c == cam)
            .map(|(_, j, _)| j)
            .collect();
        mine[picture].clone()
    }

    /// Check what every run must show: every picture of every camera arrived byte for byte,
    /// nothing was lost, only the faulty camera sent a picture again; returns when the GCS
    /// had the faulty picture whole.
    fn check(&self) -> Time {
        let f = self.fault;
        assert!(self.failures.is_empty(), "{:?}", self.failures);
        assert_eq!(self.dropped, f.times, "the fault dropped its packet");
        for cam in 1..=VEHICLES {
            let taken: Vec<&Arc<Vec<u8>>> = self
                .captured
                .iter()
                .filter(|(c, _, _)| *c == cam)
                .map(|(_, j, _)| j)
                .collect();
            assert_eq!(taken.len(), PICTURES as usize, "camera {cam}");
            if cam == f.camera {
                // the size names a picture: no other picture of this camera has the lost one's
                let size = taken[f.picture].len();
                assert_eq!(taken.iter().filter(|j| j.len() == size).count(), 1);
            }
            for (k, jpeg) in taken.iter().enumerate() {
                let got = self
                    .received
                    .iter()
                    .filter(|(c, j, _)| *c == cam && j == *jpeg)
                    .count();
                assert_eq!(got, 1, "camera {cam} picture {k}: received {got} times");
            }
            let announcements = self.announced.get(&cam).map_or(0, Vec::len);
            let resends = self.requests.iter().filter(|r| r.0 == cam).count();
            assert_eq!(
                announcements,
                PICTURES as usize + resends,
                "camera {cam}: each picture once, plus one re-send per request for its own: \
                 requests {:?}, announced {:?}",
                self.requests,
                self.announced.get(&cam)
            );
        }
        assert_eq!(
            self.received.len(),
            usize::from(VEHICLES) * PICTURES as usize
        );
        let lost = self.picture(f.camera, f.picture);
        assert!(
            self.requests
                .iter()
                .all(|(c, _, s)| (*c, *s as usize) == (f.camera, lost.len())),
            "{:?} asked for, the picture of {} bytes lost a packet",
            self.requests,
            lost.len()
        );
        self.received
            .iter()
            .find(|(_, j, _)| *j == lost)
            .map(|(_, _, t)| *t)
            .expect("the picture that lost a packet arrived")
    }

    /// When the camera took its last picture, and when the GCS had camera `cam`'s last
    /// picture.
    fn last_capture_and_reception(&self, cam: u8) -> (Time, Time) {
        let last_capture = self
            .captured
            .iter()
            .filter(|(c, _, _)| *c == cam)
            .map(|(_, _, t)| *t)
            .max()
            .unwrap();
        let last = self.picture(cam, PICTURES as usize - 1);
        let got = self
            .received
            .iter()
            .find(|(_, j, _)| *j == last)
            .map(|(_, _, t)| *t)
            .unwrap();
        (last_capture, got)
    }
}

/// Four cameras, each queueing 40 pictures (it shoots every 0.2 s and sends one every 2 s);
/// camera 2 loses one packet of its second picture — the first, one in the middle, the last.
/// The GCS asks for that picture while the camera is still shooting, only camera 2 answers,
/// once, and the picture arrives whole long before the queue is through; every other picture
/// arrives once and whole.
#[test]
fn a_picture_missing_one_packet_is_recovered_while_the_camera_keeps_shooting() {
    for seqnr in [0u16, 7, u16::MAX] {
        let fault = Fault {
            camera: 2,
            picture: 1,
            seqnr,
            times: 1,
        };
        let mut bench = Bench::new(fault);
        if seqnr == u16::MAX {
            // the last packet: run until the picture is known, then aim at its end
            let mut probe = Bench::new(Fault { times: 0, ..fault });
            while probe.captured.iter().filter(|(c, _, _)| *c == 2).count() < 2 {
                probe.step();
            }
            let last = probe.picture(2, 1).len().div_ceil(253) as u16 - 1;
            bench = Bench::new(Fault {
                seqnr: last,
                ..fault
            });
        }
        bench.run(Duration::from_secs(600));
        let recovered = bench.check();
        assert_eq!(
            bench.requests.len(),
            1,
            "packet {seqnr}: {:?}",
            bench.requests
        );
        let (_, asked, _) = bench.requests[0];
        let (last_capture, last_received) = bench.last_capture_and_reception(2);
        assert!(
            asked < last_capture,
            "packet {seqnr}: asked at {asked}, while the camera still shoots (until {last_capture})"
        );
        assert!(
            recovered < last_received,
            "packet {seqnr}: recovered at {recovered}, before the queue is through \
             ({last_received})"
        );
        // more pictures were taken after the lost one than a camera keeps by capture
        let after = PICTURES as usize - 1 - fault.picture;
        assert!(after > RECENT_IMAGES, "{after} pictures after it");
    }
}

/// The re-send loses the same packet again: the GCS asks a second time (once the camera has
/// gone on to a new picture without it), and the picture arrives whole.
#[test]
fn a_re_send_that_loses_the_packet_again_is_asked_for_again() {
    let fault = Fault {
        camera: 3,
        picture: 2,
        seqnr: 4,
        times: 2,
    };
    let mut bench = Bench::new(fault);
    bench.run(Duration::from_secs(600));
    let recovered = bench.check();
    assert_eq!(bench.requests.len(), 2, "{:?}", bench.requests);
    let (_, last_received) = bench.last_capture_and_reception(3);
    assert!(recovered < last_received, "{recovered} / {last_received}");
}

/// `fleetmap sim --camera-only` on one `udpin` port with two autopilots sending to it (two
/// SITLs' SERIAL1): each camera's frames go back to its own autopilot's address, not to
/// whichever autopilot spoke last. Sent to the last sender, one camera's packets travelled
/// through every autopilot and arrived out of order (an image short of its packet 0, 1 or
/// its last ones through four ArduCopter SITLs), and the camera's requests for one
/// autopilot's telemetry reached another one.
#[test]
fn each_camera_answers_through_its_own_autopilot() {
    use fleetmap_io::link::codec::Codec;
    use std::net::UdpSocket;
    let port = fleetmap_test_kit::free_udp_port();
    let _child = crate::common::fleetmap().quiet(&[
        "sim",
        "--camera-only",
        "--world",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/assets/worlds/hardware-6x6.toml"
        ),
        "--camera-px",
        "64",
        "--image-rate",
        "20000",
        "--duration",
        "20",
        "--connect",
        &format!("udpin:127.0.0.1:{port}"),
    ]);
    let w = world();
    let aps: Vec<UdpSocket> = (0..2)
        .map(|_| {
            let s = UdpSocket::bind("127.0.0.1:0").unwrap();
            s.set_read_timeout(Some(Duration::from_millis(5))).unwrap();
            s
        })
        .collect();
    let mut codec = Codec::new();
    // what each autopilot heard: (sysid, compid, message)
    let mut heard: Vec<Vec<(u8, u8, MavMessage)>> = vec![Vec::new(), Vec::new()];
    let start = std::time::Instant::now();
    let mut asked = false;
    let mut buf = [0u8; 65536];
    let mut tick = 0u32;
    while start.elapsed() < Duration::from_secs(15) {
        tick += 1;
        for (i, s) in aps.iter().enumerate() {
            let sysid = i as u8 + 1;
            let (lat, lon) = w.default_home(usize::from(sysid)).unwrap();
            let ms = start.elapsed().as_millis() as u32;
            let mut out = codec.encode(
                sysid,
                1,
                &MavMessage::GLOBAL_POSITION_INT(mav::GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: 10_000 + ms,
                    lat: (lat * 1e7).round() as i32,
                    lon: (lon * 1e7).round() as i32,
                    alt: 610_000,
                    relative_alt: 10_000,
                    ..mav::GLOBAL_POSITION_INT_DATA::default()
                }),
                0,
            );
            if tick % 10 == 1 {
                out.extend(codec.encode(
                    sysid,
                    1,
                    &MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                        autopilot: mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                        mavtype: mav::MavType::MAV_TYPE_QUADROTOR,
                        mavlink_version: 3,
                        ..mav::HEARTBEAT_DATA::default()
                    }),
                    0,
                ));
            }
            s.send_to(&out, ("127.0.0.1", port)).unwrap();
        }
        // once both cameras exist, camera 1 takes three pictures — the command comes
        // through autopilot 2, the last to speak
        if !asked && start.elapsed() > Duration::from_secs(2) {
            asked = true;
            let cmd = codec.encode(
                255,
                190,
                &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                    param2: 0.3,
                    param3: 3.0,
                    command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                    target_system: 1,
                    target_component: 100,
                    ..mav::COMMAND_LONG_DATA::default()
                }),
                0,
            );
            aps[1].send_to(&cmd, ("127.0.0.1", port)).unwrap();
        }
        let until = std::time::Instant::now() + Duration::from_millis(50);
        while std::time::Instant::now() < until {
            for (i, s) in aps.iter().enumerate() {
                while let Ok(n) = s.recv(&mut buf) {
                    for f in codec.decode(&buf[..n], 0) {
                        let (sysid, compid) = (f.sysid(), f.compid());
                        if let Ok(m) = f.message {
                            heard[i].push((sysid, compid, m));
                        }
                    }
                }
            }
        }
        let packets = heard[0]
            .iter()
            .filter(|(_, _, m)| matches!(m, MavMessage::ENCAPSULATED_DATA(_)))
            .count();
        let handshakes = heard[0]
            .iter()
            .filter(|(_, _, m)| matches!(m, MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)))
            .count();
        if handshakes == 3 && packets > 0 && start.elapsed() > Duration::from_secs(8) {
            break;
        }
    }
    for (i, h) in heard.iter().enumerate() {
        let me = i as u8 + 1;
        let strangers: Vec<&(u8, u8, MavMessage)> = h.iter().filter(|(s, _, _)| *s != me).collect();
        assert!(
            strangers.is_empty(),
            "autopilot {me} heard {} frames of another camera, e.g. {:?}",
            strangers.len(),
            strangers.first()
        );
        // its camera's heartbeat and its requests for telemetry, addressed to it
        assert!(
            h.iter()
                .any(|(_, c, m)| *c == 100 && matches!(m, MavMessage::HEARTBEAT(_)))
        );
        assert!(h.iter().any(|(_, _, m)| matches!(
            m,
            MavMessage::COMMAND_LONG(c) if c.target_system == me
                && c.command == mav::MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL
        )));
    }
    // camera 1's three pictures came back through autopilot 1, packets in order
    let mut seq: Vec<Vec<u16>> = Vec::new();
    for (_, _, m) in &heard[0] {
        match m {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) => seq.push(Vec::new()),
            MavMessage::ENCAPSULATED_DATA(d) => {
                if let Some(s) = seq.last_mut() {
                    s.push(d.seqnr);
                }
            }
            _ => {}
        }
    }
    assert_eq!(seq.len(), 3, "three pictures announced through autopilot 1");
    for s in &seq[..2] {
        assert_eq!(*s, (0..s.len() as u16).collect::<Vec<_>>());
    }
}
