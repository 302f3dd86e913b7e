//! Simulator speed: simulated flight time per CPU second (the 20-minute flight must take well
//! under a second) and camera images per second.

// REQUEST_DATA_STREAM is deprecated but is what ArduPilot GCSs send.
#![allow(deprecated)]

use criterion::{Criterion, criterion_group, criterion_main};
use fleetmap_camera::pose::CameraPose;
use fleetmap_camera::render::{Disturbances, render};
use fleetmap_core::time::Time;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_sim::harness::{Sim, SimConfig};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::hint::black_box;

fn command(sim: &mut Sim, sysid: u8, command: mav::MavCmd, p1: f32, p7: f32) {
    let h = MavHeader {
        system_id: fleetmap_core::proto::GCS_SYSID as u32,
        component_id: fleetmap_core::proto::GCS_COMPID,
        sequence: 0,
    };
    sim.send(
        sysid,
        &h,
        &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
            param1: p1,
            param7: p7,
            command,
            target_system: sysid,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            ..mav::COMMAND_LONG_DATA::default()
        }),
    );
}

/// Three ArduCopters arm, take off and hover for 20 simulated minutes (streams on).
fn twenty_minutes() -> Sim {
    let cfg =
        SimConfig::from_spec("3xcopter:ardupilot", None, Some((37.1965, -80.5785)), 1).unwrap();
    let mut sim = Sim::new(cfg, Time::ZERO).unwrap();
    sim.advance_to(Time::from_secs(20));
    for s in 1..=3 {
        let h = MavHeader {
            system_id: fleetmap_core::proto::GCS_SYSID as u32,
            component_id: fleetmap_core::proto::GCS_COMPID,
            sequence: 0,
        };
        sim.send(
            s,
            &h,
            &MavMessage::REQUEST_DATA_STREAM(mav::REQUEST_DATA_STREAM_DATA {
                req_message_rate: 4,
                target_system: s,
                target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
                req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
                start_stop: 1,
            }),
        );
        command(&mut sim, s, mav::MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 0.0);
    }
    sim.advance_to(Time::from_secs(21));
    for s in 1..=3 {
        let h = MavHeader {
            system_id: fleetmap_core::proto::GCS_SYSID as u32,
            component_id: fleetmap_core::proto::GCS_COMPID,
            sequence: 1,
        };
        sim.send(
            s,
            &h,
            &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param1: 1.0,
                param2: 4.0,
                command: mav::MavCmd::MAV_CMD_DO_SET_MODE,
                target_system: s,
                target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
                ..mav::COMMAND_LONG_DATA::default()
            }),
        );
        command(
            &mut sim,
            s,
            mav::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            1.0,
            0.0,
        );
        command(&mut sim, s, mav::MavCmd::MAV_CMD_NAV_TAKEOFF, 0.0, 10.0);
    }
    sim.advance_to(Time::from_secs(20 * 60 + 21));
    while sim.recv_bytes(1).is_some() {}
    sim
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("sim");
    g.sample_size(10);
    g.bench_function("three_copters_20_min", |b| {
        b.iter(|| black_box(twenty_minutes()))
    });
    let world = fleetmap_io::files::load_world(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/worlds/runway.toml"
    )))
    .unwrap();
    let (lat, lon) = world.default_home(1).unwrap();
    let pose = CameraPose {
        lat,
        lon,
        alt_agl_m: 12.0,
        heading_deg: 0.0,
        roll_deg: 0.0,
        pitch_deg: 0.0,
    };
    let cam = CameraModel::paper();
    g.bench_function("render_480", |b| {
        b.iter(|| black_box(render(&world, &pose, &cam, 0.0, &Disturbances::draw(3))))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
