//! The GCS's listening TCP link (`tcpin:`) and its serial link (`serial:PATH:BAUD`, over a
//! pseudo-terminal pair standing in for a telemetry radio's USB serial port): a vehicle is
//! seen by its heartbeat, the GCS heartbeat reaches the vehicle, and a `tcpin:` link takes the
//! next vehicle connection after the first one goes away (issue 3).

use fleetmap::fleet::{self, FleetConfig};
use fleetmap::link::ConnSpec;
use fleetmap::link::codec::Codec;
use fleetmap::link::transport::LinkOptions;
use mavlink::dialects::ardupilotmega::*;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWriteExt};

fn heartbeat(mavtype: MavType) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: MavState::MAV_STATE_STANDBY,
        mavlink_version: 3,
    })
}

/// Read from `r` until a frame from the GCS (system 255) arrives.
async fn gcs_frame_on<R: AsyncRead + Unpin>(r: &mut R) {
    let mut codec = Codec::new();
    let mut buf = [0u8; 1024];
    let found = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            let n = r.read(&mut buf).await.expect("read");
            assert!(n > 0, "the GCS closed the link");
            if codec.decode(&buf[..n], 0).iter().any(|f| f.sysid() == 255) {
                return;
            }
        }
    })
    .await;
    assert!(found.is_ok(), "no GCS frame within 5 s");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcpin_takes_a_vehicle_and_the_next_one_after_it_goes() {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let spec: ConnSpec = format!("tcpin:127.0.0.1:{port}").parse().unwrap();
    let f = fleet::start(&[spec], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    let mut c = Codec::new();
    // A vehicle connects (as ArduPilot SITL's SERIAL0 in `tcpclient` mode, or a Wi-Fi bridge).
    let mut s1 = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .unwrap();
    s1.write_all(&c.encode(3, 1, &heartbeat(MavType::MAV_TYPE_QUADROTOR), 0))
        .await
        .unwrap();
    let v = f.wait_vehicle(3, Duration::from_secs(3)).await.unwrap();
    assert_eq!(v.flavour, fleetmap::proto::flavour::Flavour::ARDU_COPTER);
    gcs_frame_on(&mut s1).await;
    // It goes away; the next one is taken on the same link.
    drop(s1);
    let mut s2 = None;
    for _ in 0..50 {
        if let Ok(s) = tokio::net::TcpStream::connect(("127.0.0.1", port)).await {
            s2 = Some(s);
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let mut s2 = s2.expect("the tcpin link accepts a second connection");
    s2.write_all(&c.encode(4, 1, &heartbeat(MavType::MAV_TYPE_GROUND_ROVER), 1))
        .await
        .unwrap();
    let v = f.wait_vehicle(4, Duration::from_secs(3)).await.unwrap();
    assert_eq!(v.flavour, fleetmap::proto::flavour::Flavour::ARDU_ROVER);
    gcs_frame_on(&mut s2).await;
    assert!(f.links()[0].status().connects >= 2);
    f.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serial_link_over_a_pseudo_terminal() {
    use tokio_serial::SerialPort;
    // The master end plays the radio; the link opens the slave by its path, as it would open
    // /dev/ttyUSB0.
    let (mut master, slave) = tokio_serial::SerialStream::pair().expect("a pty pair");
    let path = slave.name().expect("the slave's path");
    let spec: ConnSpec = format!("serial:{path}:57600").parse().unwrap();
    let f = fleet::start(&[spec], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    drop(slave);
    let mut c = Codec::new();
    master
        .write_all(&c.encode(5, 1, &heartbeat(MavType::MAV_TYPE_QUADROTOR), 0))
        .await
        .unwrap();
    let v = f.wait_vehicle(5, Duration::from_secs(3)).await.unwrap();
    assert_eq!(v.flavour, fleetmap::proto::flavour::Flavour::ARDU_COPTER);
    gcs_frame_on(&mut master).await;
    // Per-link statistics (published once a second).
    let mut st = f.links()[0].status();
    for _ in 0..30 {
        if st.stats.frames_in >= 1 && st.stats.frames_out >= 1 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
        st = f.links()[0].status();
    }
    assert!(
        st.stats.frames_in >= 1 && st.stats.frames_out >= 1,
        "{st:?}"
    );
    f.shutdown().await;
}
