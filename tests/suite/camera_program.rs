//! `fleetmap camera`: the camera program on a companion computer, taking its
//! pictures from a folder, beside a simulated ArduCopter, wired as a companion computer is —
//! a MAVLink router (as mavlink-router does: every datagram from one endpoint to all the
//! others) between the autopilot, the camera and the GCS. The GCS receives the camera's
//! on-board measurements (DEBUG_FLOAT_ARRAY tied to CAMERA_IMAGE_CAPTURED), not its pictures;
//! with a measurement definition the GCS does not share, it asks for the picture and gets it.

use fleetmap::app::images;
use fleetmap::fleet::{self, FleetConfig};
use fleetmap_core::vision::onboard::{Onboard, OnboardKind, OnboardMeasurement, OnboardSpec};
use fleetmap_core::vision::runway::onboard::RunwayMeasurement;
use image::RgbImage;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::net::SocketAddr;
use std::path::Path;
use std::process::Stdio;
use std::time::Duration;
use tokio::net::UdpSocket;

use crate::common;

/// The GCS accepts green shares of the definition `fingerprint` (nothing to announce).
fn green_accept(fingerprint: u32) -> images::OnboardAccept {
    images::OnboardAccept {
        fingerprint,
        announce: None,
    }
}

/// The camera's runway result a received image carries.
fn runway_result(img: &images::ReceivedImage) -> Option<RunwayMeasurement> {
    img.onboard.as_ref()?.get::<RunwayMeasurement>().copied()
}
use fleetmap_test_kit::router::{self, End};
use fleetmap_test_kit::{Guard, free_udp_port, sim};

const GREEN: [u8; 3] = [40, 160, 50];
const GREY: [u8; 3] = [128, 128, 128];

fn picture(dir: &Path, name: &str, rgb: [u8; 3]) {
    RgbImage::from_pixel(64, 64, image::Rgb(rgb))
        .save(dir.join(name))
        .unwrap();
    // distinct modification times: the camera takes the oldest first
    std::thread::sleep(Duration::from_millis(15));
}

fn start_capture(count: f32) -> MavMessage {
    MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
        param2: 0.5, // seconds between pictures
        param3: count,
        command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        target_system: 1,
        target_component: 100,
        ..mav::COMMAND_LONG_DATA::default()
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_camera_program_measures_a_folder_of_pictures_on_board() {
    let mission = concat!(env!("CARGO_MANIFEST_DIR"), "/missions/hardware-6x6.toml");
    let OnboardSpec::Green(spec) =
        fleetmap_camera::mission::onboard_spec(Path::new(mission)).unwrap()
    else {
        panic!("a spatial-classification mission measures the green share")
    };
    let folder = tempfile::tempdir().unwrap();
    let colours = [GREEN, GREY, GREEN, GREEN, GREY, GREY];
    for (i, c) in colours.iter().enumerate() {
        picture(folder.path(), &format!("shot{i}.png"), *c);
    }
    picture(folder.path(), "shot6.png", GREEN);

    // the GCS: one UDP port, the image hub accepting the mission's measurements
    let (link, ev_rx, gcs_addr) = fleetmap_test_kit::gcs::listening_link().await;

    // the camera program, listening where the router sends
    let cam_port = free_udp_port();
    let cam_addr: SocketAddr = format!("127.0.0.1:{cam_port}").parse().unwrap();
    let _camera = Guard::spawn(
        common::fleetmap()
            .command()
            .args([
                "camera",
                "--connect",
                &format!("udpin:127.0.0.1:{cam_port}"),
                "--source",
                &format!("folder:{}", folder.path().display()),
                "--mission",
                mission,
                "--wait-ms",
                "300",
            ])
            .stdout(Stdio::null()),
    );

    // the router, and a simulated ArduCopter without a camera of its own sending to it
    let vehicle_sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let router_vehicle = vehicle_sock.local_addr().unwrap();
    router::spawn(vec![
        End::Learn(vehicle_sock),
        End::Fixed(cam_addr),
        End::Fixed(gcs_addr),
    ])
    .await;
    let sim = sim::autopilot_for_a_camera(None, Some((37.195, -80.58)), router_vehicle, 1.0).await;
    let fleet = fleet::spawn(vec![link], ev_rx, FleetConfig::default(), sim.clock());
    let hub = images::spawn(&fleet);
    hub.accept_onboard(OnboardKind::Green, Some(green_accept(spec.fingerprint())));
    let mut rx = hub.subscribe();
    fleet
        .wait_vehicle(1, Duration::from_secs(30))
        .await
        .expect("the autopilot is heard through the router");

    // Until the camera has the autopilot's position it refuses to shoot: ask until it takes.
    let mut got = Vec::new();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
    fleet.send(start_capture(6.0)).await.unwrap();
    let mut last_ask = tokio::time::Instant::now();
    while got.len() < 6 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "{} of 6 measurements in 60 s",
            got.len()
        );
        match tokio::time::timeout(Duration::from_millis(500), rx.recv()).await {
            Ok(Ok(img)) => got.push(img),
            Ok(Err(e)) => panic!("image hub: {e}"),
            Err(_) if got.is_empty() && last_ask.elapsed() > Duration::from_secs(2) => {
                fleet.send(start_capture(6.0)).await.unwrap();
                last_ask = tokio::time::Instant::now();
            }
            Err(_) => {}
        }
    }
    for (img, colour) in got.iter().zip(colours) {
        let m = *img
            .onboard
            .as_ref()
            .and_then(Onboard::get::<OnboardMeasurement>)
            .expect("measured on board");
        assert!(img.bytes.is_empty(), "no picture on the link");
        assert_eq!(img.source, "on board");
        let want = if colour == GREEN { 1.0 } else { 0.0 };
        assert!((m.value.share - want).abs() < 0.02, "{m:?} for {colour:?}");
        assert_eq!(m.value.positive(&spec.green), colour == GREEN);
        let pose = img.pose.as_ref().expect("the capture's pose");
        assert!((pose.lat - 37.195).abs() < 1e-3, "{pose:?}");
        assert!(m.picture_bytes > 0);
    }

    // A GCS that measures differently asks for the picture and measures it itself.
    hub.accept_onboard(
        OnboardKind::Green,
        Some(green_accept(spec.fingerprint() ^ 1)),
    );
    fleet.send(start_capture(1.0)).await.unwrap();
    let img = tokio::time::timeout(Duration::from_secs(30), rx.recv())
        .await
        .expect("the picture is sent when asked for")
        .unwrap();
    assert!(img.onboard.is_none());
    assert_eq!(img.source, "mavlink");
    let share = fleetmap::kinds::bandit::measure_image(
        &img.bytes,
        &spec.green,
        &spec.camera,
        0.0,
        spec.cell_m,
        spec.crop_fraction,
    )
    .unwrap();
    assert!(share.1, "the seventh picture is green: {share:?}");
    assert!(img.pose.is_some());
    fleet.shutdown().await;
    let _ = sim.stop().await;
}

/// `fleetmap camera --source render --mission missions/runway-field-test.toml` on a simulated
/// ArduCopter's companion port: the mission's grid origin is the first vehicle's home, so the
/// camera classifies nothing until the GCS announces the grid; then every picture crosses the
/// link as its cell and five region counts (84 bytes at most), and a picture asked for is
/// classified by the GCS exactly as the camera did.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_camera_program_classifies_runway_pictures_on_board() {
    use fleetmap_core::geo::{Grid, LatLon};
    use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
    use fleetmap_core::vision::runway::onboard::{OnboardRegions, RunwaySpec, ShutterPose};
    let root = env!("CARGO_MANIFEST_DIR");
    let mission = format!("{root}/missions/runway-field-test.toml");
    let world_file = format!("{root}/assets/worlds/runway.toml");
    let OnboardSpec::Runway(def) =
        fleetmap_camera::mission::onboard_spec(Path::new(&mission)).unwrap()
    else {
        panic!("a runway mission classifies runway pictures")
    };
    assert!(
        def.grid.is_none(),
        "the field test's grid starts at the vehicle"
    );
    let (link, ev_rx, gcs_addr) = fleetmap_test_kit::gcs::listening_link().await;
    let cam_port = free_udp_port();
    let cam_addr: SocketAddr = format!("127.0.0.1:{cam_port}").parse().unwrap();
    let _camera = Guard::spawn(
        common::fleetmap()
            .command()
            .args([
                "camera",
                "--connect",
                &format!("udpin:127.0.0.1:{cam_port}"),
                "--source",
                "render",
                "--world",
                &world_file,
                "--mission",
                &mission,
            ])
            .stdout(Stdio::null()),
    );
    let vehicle_sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let router_vehicle = vehicle_sock.local_addr().unwrap();
    router::spawn(vec![
        End::Learn(vehicle_sock),
        End::Fixed(cam_addr),
        End::Fixed(gcs_addr),
    ])
    .await;
    let world = fleetmap_io::files::load_world(Path::new(&world_file)).unwrap();
    let sim = sim::autopilot_for_a_camera(Some(world), None, router_vehicle, 4.0).await;
    let fleet = fleet::spawn(vec![link], ev_rx, FleetConfig::at_speedup(4.0), sim.clock());
    let hub = images::spawn(&fleet);
    let mut rx = hub.subscribe();
    let v = fleet
        .wait_until(1, Duration::from_secs(120), |v| v.home.is_some())
        .await
        .expect("the vehicle's home");
    let home = v.home.unwrap();
    let spec = RunwaySpec {
        params: def.params,
        camera: def.camera,
        grid: Grid::new(LatLon::new(home.lat, home.lon), def.cell_m).unwrap(),
    };
    hub.accept_onboard(
        OnboardKind::Runway,
        Some(fleetmap::kinds::runway::onboard_accept(&spec, vec![1])),
    );
    fleet.takeoff(1, 12.0).await.unwrap();
    fleet
        .wait_until(1, Duration::from_secs(120), |v| {
            v.alt_rel.is_some_and(|a| a > 11.5)
        })
        .await
        .expect("at 12 m");
    let mut got = Vec::new();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
    fleet.send(start_capture(3.0)).await.unwrap();
    let mut last_ask = tokio::time::Instant::now();
    while got.len() < 3 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "{} of 3 results in 60 s",
            got.len()
        );
        match tokio::time::timeout(Duration::from_millis(500), rx.recv()).await {
            Ok(Ok(img)) => got.push(img),
            Ok(Err(e)) => panic!("image hub: {e}"),
            Err(_) if got.is_empty() && last_ask.elapsed() > Duration::from_secs(3) => {
                fleet.send(start_capture(3.0)).await.unwrap();
                last_ask = tokio::time::Instant::now();
            }
            Err(_) => {}
        }
    }
    for img in &got {
        let m = runway_result(img).expect("classified on board");
        assert!(img.bytes.is_empty(), "no picture on the link");
        let pose = img.pose.as_ref().expect("the capture's pose");
        let shutter = ShutterPose {
            lat_deg: pose.lat,
            lon_deg: pose.lon,
            alt_rel_m: pose.alt_rel_m,
            q: pose.q.expect("an attitude"),
        };
        assert_eq!(m.regions.unwrap().cell, spec.cut(&shutter).unwrap().cell);
        assert!(m.picture_bytes > 10_000);
    }
    // asked for, the last picture comes back, and the GCS classifies it as the camera did
    let img = got.last().unwrap();
    let (m, pose) = (runway_result(img).unwrap(), img.pose.clone().unwrap());
    let picture = tokio::time::timeout(
        Duration::from_secs(30),
        hub.ask_picture(1, pose.time_boot_ms, pose.image_index, m.picture_bytes),
    )
    .await
    .expect("the picture is sent when asked for")
    .unwrap();
    let decoded = load_image_bytes(&picture.bytes, &LoadLimits::default()).unwrap();
    let shutter = ShutterPose {
        lat_deg: pose.lat,
        lon_deg: pose.lon,
        alt_rel_m: pose.alt_rel_m,
        q: pose.q.unwrap(),
    };
    let r = spec.measure(&decoded, &shutter).unwrap();
    assert_eq!(OnboardRegions::of(&r), m.regions);
    fleet.shutdown().await;
    let _ = sim.stop().await;
}

#[test]
fn camera_help_names_its_sources() {
    let out = common::fleetmap()
        .command()
        .args(["camera", "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for source in [
        "render",
        "folder:DIR",
        "command:CMD",
        "v4l2:DEVICE",
        "serial:",
    ] {
        assert!(help.contains(source), "{source} missing from:\n{help}");
    }
    // an unknown source is refused with the list
    let out = common::fleetmap()
        .command()
        .args([
            "camera",
            "--connect",
            "udpin:127.0.0.1:0",
            "--source",
            "gopro:wifi",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("`folder:DIR`, `command:CMD`"), "{err}");
    // a V4L2 camera needs the camera crate's `v4l2` feature, which the station is built without
    let out = common::fleetmap()
        .command()
        .args([
            "camera",
            "--connect",
            "udpin:127.0.0.1:0",
            "--source",
            "v4l2:/dev/video0",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("feature `v4l2`"), "{err}");
}
