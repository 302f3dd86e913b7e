//! The GCS's listening TCP link (`tcpin:`) and its serial link (`serial:PATH:BAUD`, over a
//! pseudo-terminal pair standing in for a telemetry radio's USB serial port): a vehicle is
//! seen by its heartbeat, the GCS heartbeat reaches the vehicle, and a `tcpin:` link takes the
//! next vehicle connection after the first one goes away, and serves several
//! vehicles at once, each on its own connection.

use fleetmap::fleet::{self, FleetConfig};
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::transport::LinkOptions;
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
    assert_eq!(
        v.flavour,
        fleetmap_core::proto::flavour::Flavour::ARDU_COPTER
    );
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
    assert_eq!(
        v.flavour,
        fleetmap_core::proto::flavour::Flavour::ARDU_ROVER
    );
    gcs_frame_on(&mut s2).await;
    assert!(f.links()[0].status().connects >= 2);
    f.shutdown().await;
}

/// Read frames from `r` for `d`; returns (system id, message id, target system) of each.
async fn frames_for<R: AsyncRead + Unpin>(r: &mut R, d: Duration) -> Vec<(u8, u32, Option<u8>)> {
    use mavlink::Message;
    let mut codec = Codec::new();
    let mut buf = [0u8; 4096];
    let mut out = Vec::new();
    let _ = tokio::time::timeout(d, async {
        loop {
            match r.read(&mut buf).await {
                Ok(0) | Err(_) => return,
                Ok(n) => {
                    for f in codec.decode(&buf[..n], 0) {
                        let target = f.message.as_ref().ok().and_then(|m| m.target_system_id());
                        out.push((f.sysid(), f.msg_id, target));
                    }
                }
            }
        }
    })
    .await;
    out
}

/// A `tcpin:` link serves several clients at once (two vehicles, or MAVProxy and a
/// vehicle): both get the GCS heartbeat, and a message to one system goes only to the
/// connection that system speaks on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tcpin_serves_several_vehicles_at_once() {
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
    let mut a = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .unwrap();
    let mut b = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .unwrap();
    a.write_all(&c.encode(5, 1, &heartbeat(MavType::MAV_TYPE_QUADROTOR), 0))
        .await
        .unwrap();
    b.write_all(&c.encode(6, 1, &heartbeat(MavType::MAV_TYPE_QUADROTOR), 0))
        .await
        .unwrap();
    f.wait_vehicle(5, Duration::from_secs(3)).await.unwrap();
    f.wait_vehicle(6, Duration::from_secs(3)).await.unwrap();
    // A command to vehicle 6 (and the stream requests the fleet sends each vehicle).
    let sent = f
        .send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            target_system: 6,
            target_component: 1,
            command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
            param1: 242.0,
            ..Default::default()
        }))
        .await
        .unwrap();
    assert_eq!(sent, 1);
    let (on_a, on_b) = tokio::join!(
        frames_for(&mut a, Duration::from_millis(1500)),
        frames_for(&mut b, Duration::from_millis(1500))
    );
    for (name, frames, me, other) in [("a", &on_a, 5u8, 6u8), ("b", &on_b, 6, 5)] {
        assert!(
            frames.iter().any(|(s, id, _)| *s == 255 && *id == 0),
            "client {name}: no GCS heartbeat in {frames:?}"
        );
        assert!(
            frames.iter().any(|(_, _, t)| *t == Some(me)),
            "client {name}: nothing addressed to vehicle {me}"
        );
        assert!(
            !frames.iter().any(|(_, _, t)| *t == Some(other)),
            "client {name}: got frames addressed to vehicle {other}"
        );
    }
    let st = f.links()[0].status();
    assert_eq!(st.peers.len(), 2, "{:?}", st.peers);
    assert!(st.up);
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
    assert_eq!(
        v.flavour,
        fleetmap_core::proto::flavour::Flavour::ARDU_COPTER
    );
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
