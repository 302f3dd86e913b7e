//! The `fleetmap-camera` program on a serial link, as on a companion computer wired to the
//! autopilot's TELEM2: a pseudo-terminal pair stands in for the UART (the program opens the
//! slave by its path, as it would open /dev/ttyAMA0), the embedded simulated ArduCopter is
//! the autopilot, and a router in the test forwards between the autopilot's UDP port, the
//! serial line and the GCS (as an autopilot routes between its TELEM ports, or mavlink-router
//! does). The pictures come from a command run per shot (`command:cp PICTURE {out}`) and are
//! measured on board with a spatial-classification mission: the GCS must receive the
//! camera's HEARTBEAT, each CAMERA_IMAGE_CAPTURED with the autopilot's position, and the
//! green share measured on board right after it.

use fleetmap_core::vision::onboard::OnboardMeasurement;
use fleetmap_test_kit::gcs::Gcs;
use fleetmap_test_kit::router::{self, End};
use fleetmap_test_kit::{Bin, Guard, sim};
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::process::Stdio;
use std::time::Duration;
use tokio::net::UdpSocket;

const HOME: (f64, f64) = (37.195, -80.58);

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
async fn the_camera_program_answers_over_a_serial_line_with_pictures_from_a_command() {
    use tokio_serial::SerialPort;
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let mission = format!("{root}/missions/hardware-6x6.toml");
    let dir = tempfile::tempdir().unwrap();
    let picture = dir.path().join("green.jpg");
    image::RgbImage::from_pixel(64, 64, image::Rgb([40, 160, 50]))
        .save(&picture)
        .unwrap();

    // the UART: the camera opens the slave by its path; the slave stays open here so that
    // the master does not read a hang-up before the camera has opened it
    let (master, slave) = tokio_serial::SerialStream::pair().expect("a pty pair");
    let tty = slave.name().expect("the slave's path");
    let camera = Bin::new(env!("CARGO_BIN_EXE_fleetmap-camera"));
    let _camera = Guard::spawn(
        camera
            .command()
            .args([
                "--connect",
                &format!("serial:{tty}:921600"),
                "--source",
                &format!("command:cp '{}' {{out}}", picture.display()),
                "--mission",
                &mission,
                "--command-timeout-ms",
                "5000",
            ])
            .stdout(Stdio::null()),
    );

    // the GCS and the router: every frame from the autopilot's UDP port, the GCS or the
    // serial line goes to the two others (frames from the serial line cut out of the byte
    // stream, one per datagram)
    let mut gcs = Gcs::bind();
    let vehicle_sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let router_vehicle = vehicle_sock.local_addr().unwrap();
    let locals = router::spawn(vec![
        End::Learn(vehicle_sock),
        End::Fixed(gcs.addr()),
        End::Serial(Box::new(master)),
    ])
    .await;
    let router_gcs_addr = locals[1].expect("the router's GCS socket");

    // the autopilot: a simulated ArduCopter without a camera of its own
    let sim = sim::autopilot_for_a_camera(None, Some(HOME), router_vehicle, 1.0).await;

    let (mut camera_heartbeat, mut captured, mut measured) = (false, Vec::new(), Vec::new());
    let deadline = tokio::time::Instant::now() + Duration::from_secs(40);
    let mut last_ask: Option<tokio::time::Instant> = None;
    // the GCS's socket blocks: this worker thread hands its tasks over while it waits
    tokio::task::block_in_place(|| {
        while measured.len() < 3 || captured.len() < 3 {
            assert!(
                tokio::time::Instant::now() < deadline,
                "in 40 s: camera heartbeat {camera_heartbeat}, {} captures, {} measurements",
                captured.len(),
                measured.len()
            );
            // Until the camera has the autopilot's position it refuses to shoot: ask until it
            // takes.
            if captured.is_empty() && last_ask.is_none_or(|t| t.elapsed() > Duration::from_secs(2))
            {
                gcs.send(&start_capture(3.0), router_gcs_addr);
                last_ask = Some(tokio::time::Instant::now());
            }
            let Some((_, frames)) = gcs.recv(Duration::from_millis(300)) else {
                continue;
            };
            for f in frames {
                if (f.header.system_id, f.header.component_id) != (1, 100) {
                    continue;
                }
                match f.message {
                    Ok(MavMessage::HEARTBEAT(h)) => {
                        camera_heartbeat |= h.mavtype == mav::MavType::MAV_TYPE_CAMERA;
                    }
                    Ok(MavMessage::CAMERA_IMAGE_CAPTURED(c)) => captured.push(c),
                    Ok(MavMessage::DEBUG_FLOAT_ARRAY(d)) => {
                        if let Some(m) = OnboardMeasurement::from_message(&d) {
                            measured.push(m);
                        }
                    }
                    _ => {}
                }
            }
        }
    });
    assert!(camera_heartbeat, "the camera's HEARTBEAT (MAV_TYPE_CAMERA)");
    for (i, c) in captured.iter().take(3).enumerate() {
        assert_eq!(c.image_index, i as i32);
        assert_eq!(c.capture_result, mav::MavBool::MAV_BOOL_TRUE, "{c:?}");
        let (lat, lon) = (f64::from(c.lat) * 1e-7, f64::from(c.lon) * 1e-7);
        assert!(
            (lat - HOME.0).abs() < 1e-3 && (lon - HOME.1).abs() < 1e-3,
            "{c:?}"
        );
    }
    for m in measured.iter().take(3) {
        assert!((m.value.share - 1.0).abs() < 0.02, "a green picture: {m:?}");
        assert!(m.picture_bytes > 0);
    }
    drop(slave);
    let _ = sim.stop().await;
}
