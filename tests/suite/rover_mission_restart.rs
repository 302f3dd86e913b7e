//! A station's second mission: ArduRover stays in AUTO after its mission is done
//! (MIS_DONE_BEHAVE 0), and there MAV_CMD_MISSION_START is accepted but starts nothing —
//! its handler only asks for AUTO (`GCS_MAVLINK_Rover::handle_command_int_packet`,
//! ArduPilot/ardupilot Rover/GCS_MAVLink_Rover.cpp) and `Rover::set_mode` returns at once for
//! the mode it is in, so `ModeAuto::_enter` / `mission.start_or_resume()` do not run. Seen on
//! ArduRover SITL V4.7.0-dev (90700977): after "Mission Complete" and MISSION_CURRENT seq 2
//! COMPLETE, a new upload, DO_SET_MISSION_CURRENT 1 (MISSION_CURRENT seq 2 NOT_STARTED) and
//! MISSION_START (ACCEPTED) were followed by nothing at all; HOLD, then MISSION_START, ran
//! the mission ("Mission: 1 ChangeSpeed", MISSION_ITEM_REACHED 1, ACTIVE, MISSION_ITEM_REACHED
//! 2, "Mission Complete", COMPLETE).
//!
//! The simulated ArduRover does the same (`ardurover_in_auto_ignores_mission_start_until_it_
//! leaves_auto` in tests/suite/sim_vehicle.rs); here the fleet's `start_mission` starts a rover's
//! second mission (HOLD first), as the bandit runner's stations need from the second sortie on.

use fleetmap::fleet::{self, FleetConfig};
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::transport::LinkOptions;
use fleetmap_sim::harness::SimConfig;
use fleetmap_sim::server::GcsClock;
use fleetmap_test_kit::{at, sim};
use std::time::Duration;

const HOME: (f64, f64) = (37.195135, -80.579943);

/// A station mission as fleetmap builds it: DO_CHANGE_SPEED, then one waypoint.
fn station_mission(to: (f64, f64)) -> Vec<MissionItem> {
    vec![
        MissionItem::change_speed(1.0),
        MissionItem::waypoint(to.0, to.1, 0.0),
    ]
}

/// The fleet starts a rover's mission a second time although the first left it in AUTO.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_fleet_starts_a_rovers_second_mission() {
    let listen: ConnSpec = "udpin:127.0.0.1:0".parse().unwrap();
    let f = fleet::start(&[listen], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    let gcs = f.links()[0].local.expect("the port the GCS listens on");
    let _served = sim::serve(
        SimConfig::from_spec("1xrover:ardupilot", None, Some(HOME), 5).unwrap(),
        vec![sim::udpout(gcs)],
        5.0,
        GcsClock::Wall,
    )
    .await;
    let wait = Duration::from_secs(60);
    f.wait_until(1, wait, |v| v.home.is_some())
        .await
        .expect("the rover and its home");
    let last = 1u16; // user numbering: DO_CHANGE_SPEED 0, the waypoint 1
    for (k, to) in [at(HOME, 0.0, 5.0), at(HOME, 0.0, 0.0)]
        .into_iter()
        .enumerate()
    {
        f.upload_mission(1, MissionType::Mission, station_mission(to))
            .await
            .unwrap();
        f.set_mission_current(1, 0).await.unwrap();
        f.arm(1).await.unwrap();
        f.start_mission(1).await.unwrap();
        // The fleet resets the progress before the start, and `start_mission` returns once the
        // rover is seen in its mission mode, in a snapshot after that reset: the last waypoint
        // is not reached yet (a fast simulated rover may have passed its DO_CHANGE_SPEED), so
        // reaching it below is this mission's doing.
        f.wait_until(1, Duration::from_secs(5), |v| !v.reached.contains(&last))
            .await
            .expect("the progress is reset on start");
        f.wait_until(1, wait, |v| v.reached.contains(&last))
            .await
            .unwrap_or_else(|v| {
                panic!(
                    "mission {k}: the rover never reached its waypoint: reached {:?}, current \
                     {:?}, state {:?}",
                    v.as_ref().map(|v| v.reached.clone()),
                    v.as_ref().and_then(|v| v.mission_current),
                    v.as_ref().and_then(|v| v.mission_state),
                )
            });
    }
}
