//! The `fleetmap-camera` program on a serial link, as on a companion computer wired to the
//! autopilot's TELEM2: a pseudo-terminal pair stands in for the UART (the program opens the
//! slave by its path, as it would open /dev/ttyAMA0), the embedded simulated ArduCopter is
//! the autopilot, and a router in the test forwards between the autopilot's UDP port, the
//! serial line and the GCS (as an autopilot routes between its TELEM ports, or mavlink-router
//! does). The pictures come from a command run per shot (`command:cp PICTURE {out}`) and are
//! measured on board with a spatial-classification mission: the GCS must receive the
//! camera's HEARTBEAT, each CAMERA_IMAGE_CAPTURED with the autopilot's position, and the
//! green share measured on board right after it.

use fleetmap_core::time::Time;
use fleetmap_core::vision::onboard::OnboardMeasurement;
use fleetmap_io::link::codec::Codec;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::pace::Speed;
use fleetmap_sim::server::{self, GcsClock, ServeOptions, parse_connection};
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::UdpSocket;
use tokio::sync::mpsc;

const HOME: (f64, f64) = (37.195, -80.58);

/// The camera program, killed when the test ends however it ends.
struct Killed(std::process::Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Forward between the autopilot's UDP port (`vehicle`, learnt from its first datagram), the
/// GCS (`gcs_router`, sending to `gcs`) and the serial line's master end: every frame from
/// one goes to the two others. Frames from the serial line are cut out of the byte stream
/// and sent one per datagram.
fn route(
    vehicle: UdpSocket,
    gcs_router: UdpSocket,
    gcs: SocketAddr,
    master: tokio_serial::SerialStream,
) {
    let (vehicle, gcs_router) = (Arc::new(vehicle), Arc::new(gcs_router));
    let vehicle_peer: Arc<Mutex<Option<SocketAddr>>> = Arc::new(Mutex::new(None));
    let (mut rd, mut wr) = tokio::io::split(master);
    let (to_serial, mut serial_rx) = mpsc::unbounded_channel::<Vec<u8>>();
    tokio::spawn(async move {
        while let Some(b) = serial_rx.recv().await {
            if wr.write_all(&b).await.is_err() {
                break;
            }
        }
    });
    {
        let (v, g, peer, tx) = (
            vehicle.clone(),
            gcs_router.clone(),
            vehicle_peer.clone(),
            to_serial.clone(),
        );
        tokio::spawn(async move {
            let mut buf = vec![0u8; 65536];
            while let Ok((n, from)) = v.recv_from(&mut buf).await {
                *peer.lock().unwrap() = Some(from);
                let _ = g.send_to(&buf[..n], gcs).await;
                let _ = tx.send(buf[..n].to_vec());
            }
        });
    }
    {
        let (v, g, peer, tx) = (
            vehicle.clone(),
            gcs_router.clone(),
            vehicle_peer.clone(),
            to_serial,
        );
        tokio::spawn(async move {
            let mut buf = vec![0u8; 65536];
            while let Ok((n, _)) = g.recv_from(&mut buf).await {
                let to = *peer.lock().unwrap();
                if let Some(to) = to {
                    let _ = v.send_to(&buf[..n], to).await;
                }
                let _ = tx.send(buf[..n].to_vec());
            }
        });
    }
    tokio::spawn(async move {
        let mut codec = Codec::new();
        let mut buf = vec![0u8; 4096];
        while let Ok(n) = rd.read(&mut buf).await {
            if n == 0 {
                break;
            }
            for f in codec.decode(&buf[..n], 0) {
                let to = *vehicle_peer.lock().unwrap();
                if let Some(to) = to {
                    let _ = vehicle.send_to(&f.raw, to).await;
                }
                let _ = gcs_router.send_to(&f.raw, gcs).await;
            }
        }
    });
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
    let _camera = Killed(
        Command::new(env!("CARGO_BIN_EXE_fleetmap-camera"))
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
            .stdout(Stdio::null())
            .spawn()
            .expect("the camera program starts"),
    );

    // the GCS and the router
    let gcs = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let gcs_router = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let router_gcs_addr = gcs_router.local_addr().unwrap();
    let vehicle_sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let router_vehicle = vehicle_sock.local_addr().unwrap();
    route(vehicle_sock, gcs_router, gcs.local_addr().unwrap(), master);

    // the autopilot: a simulated ArduCopter without a camera of its own
    let mut cfg = SimConfig::from_spec("1xcopter:ardupilot", None, Some(HOME), 1).unwrap();
    cfg.vehicles[0].camera = None;
    let sim = server::spawn(
        Sim::new(cfg, Time::ZERO).unwrap(),
        ServeOptions {
            endpoints: vec![parse_connection(&format!("udpout:{router_vehicle}")).unwrap()],
            speed: Speed::times(1.0).unwrap(),
            gcs: GcsClock::Simulator,
            image_dir: None,
            duration_s: None,
        },
    )
    .await
    .unwrap();

    let mut codec = Codec::new();
    let send = |codec: &mut Codec, m: &MavMessage| codec.encode(255, 190, m, 0);
    let mut buf = vec![0u8; 65536];
    let (mut camera_heartbeat, mut captured, mut measured) = (false, Vec::new(), Vec::new());
    let deadline = tokio::time::Instant::now() + Duration::from_secs(40);
    let mut last_ask: Option<tokio::time::Instant> = None;
    while measured.len() < 3 || captured.len() < 3 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "in 40 s: camera heartbeat {camera_heartbeat}, {} captures, {} measurements",
            captured.len(),
            measured.len()
        );
        // Until the camera has the autopilot's position it refuses to shoot: ask until it
        // takes.
        if captured.is_empty() && last_ask.is_none_or(|t| t.elapsed() > Duration::from_secs(2)) {
            let frame = send(&mut codec, &start_capture(3.0));
            gcs.send_to(&frame, router_gcs_addr).await.unwrap();
            last_ask = Some(tokio::time::Instant::now());
        }
        let Ok(Ok((n, _))) =
            tokio::time::timeout(Duration::from_millis(300), gcs.recv_from(&mut buf)).await
        else {
            continue;
        };
        for f in codec.decode(&buf[..n], 0) {
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
