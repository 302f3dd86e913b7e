//! Arming and take-off when commands arrive late or twice, as ArduCopter 4.7 SITL and PX4 1.16
//! SIH answered them (measured; docs/results/conformance.md, "Arming and take-off").

use crate::flavour::{SimFlavour, SimMode};
use crate::vehicle::test_probe::Probe;
use mavlink::dialects::ardupilotmega::{MavCmd as C, MavResult as R};

const NAN: f32 = f32::NAN;

fn mode(p: &mut Probe, custom: &[f32]) -> Option<R> {
    let mut a = [0.0; 7];
    a[0] = 1.0;
    a[1..=custom.len()].copy_from_slice(custom);
    p.command(C::MAV_CMD_DO_SET_MODE, a)
}

fn arm(p: &mut Probe) -> Option<R> {
    p.command(
        C::MAV_CMD_COMPONENT_ARM_DISARM,
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
}

fn takeoff(p: &mut Probe, alt: f32) -> Option<R> {
    p.command(C::MAV_CMD_NAV_TAKEOFF, [0.0, 0.0, 0.0, NAN, NAN, NAN, alt])
}

#[test]
fn arducopter_auto_disarms_and_refuses_a_take_off_that_comes_late_or_twice() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(20.0);
    assert_eq!(mode(&mut p, &[4.0]), Some(R::MAV_RESULT_ACCEPTED)); // GUIDED
    assert_eq!(mode(&mut p, &[4.0]), Some(R::MAV_RESULT_ACCEPTED)); // the same mode again
    assert_eq!(takeoff(&mut p, 10.0), Some(R::MAV_RESULT_FAILED)); // disarmed
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED)); // armed already
    // DISARM_DELAY 10 s without a take-off (measured 10.1 s after the ARM's ACK)
    p.run(9.8);
    assert!(p.v.armed());
    p.run(0.4);
    assert!(!p.v.armed());
    assert!(p.texts.iter().any(|t| t == "Disarming motors"));
    assert_eq!(takeoff(&mut p, 10.0), Some(R::MAV_RESULT_FAILED)); // too late
    // in time: accepted; the same take-off again while climbing: FAILED
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    p.run(7.0);
    assert_eq!(takeoff(&mut p, 10.0), Some(R::MAV_RESULT_ACCEPTED));
    p.run(1.5);
    assert!(!p.v.landed());
    assert_eq!(takeoff(&mut p, 10.0), Some(R::MAV_RESULT_FAILED));
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED)); // armed in the air
    p.run(10.0);
    assert_eq!(takeoff(&mut p, 15.0), Some(R::MAV_RESULT_FAILED));
    assert_eq!(mode(&mut p, &[4.0]), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(mode(&mut p, &[5.0]), Some(R::MAV_RESULT_ACCEPTED)); // LOITER
    assert_eq!(takeoff(&mut p, 15.0), Some(R::MAV_RESULT_FAILED));
}

#[test]
fn arducopter_takes_off_only_in_a_user_take_off_mode() {
    let mut p = Probe::new(SimFlavour::ARDU_COPTER, None);
    p.run(20.0);
    assert_eq!(mode(&mut p, &[0.0]), Some(R::MAV_RESULT_ACCEPTED)); // STABILIZE
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(takeoff(&mut p, 10.0), Some(R::MAV_RESULT_FAILED));
    p.run(10.5);
    assert!(!p.v.armed(), "auto-disarm in STABILIZE too");
    assert_eq!(mode(&mut p, &[5.0]), Some(R::MAV_RESULT_ACCEPTED)); // LOITER
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(takeoff(&mut p, 5.0), Some(R::MAV_RESULT_ACCEPTED));
}

#[test]
fn px4_takes_a_take_off_disarmed_twice_and_in_the_air() {
    let mut p = Probe::new(SimFlavour::PX4_COPTER, None);
    p.run(15.0);
    let hold = [4.0, 3.0]; // AUTO_LOITER
    assert_eq!(mode(&mut p, &hold), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(mode(&mut p, &hold), Some(R::MAV_RESULT_ACCEPTED));
    // disarmed: AUTO_TAKEOFF, waiting for the arming
    assert_eq!(takeoff(&mut p, NAN), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(p.v.mode(), SimMode::Takeoff);
    assert!(
        p.texts
            .iter()
            .any(|t| t == "Using default takeoff altitude: 2.5 m")
    );
    assert_eq!(mode(&mut p, &hold), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    // COM_DISARM_PRFLT 10 s from the land detector's "landed" (measured 10.9–11.6 s after
    // the ACK)
    p.run(10.8);
    assert!(p.v.armed());
    p.run(0.4);
    assert!(!p.v.armed());
    assert!(
        p.texts
            .iter()
            .any(|t| t == "Disarmed by auto preflight disarming")
    );
    assert_eq!(takeoff(&mut p, NAN), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(mode(&mut p, &hold), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(takeoff(&mut p, NAN), Some(R::MAV_RESULT_ACCEPTED));
    p.run(1.0);
    assert!(!p.v.landed());
    assert_eq!(takeoff(&mut p, NAN), Some(R::MAV_RESULT_ACCEPTED)); // again while climbing
    p.run(10.0);
    let (_, _, u) = p.v.true_position();
    assert!(u > 1.5, "{u}");
    assert_eq!(arm(&mut p), Some(R::MAV_RESULT_ACCEPTED));
    assert_eq!(takeoff(&mut p, NAN), Some(R::MAV_RESULT_ACCEPTED)); // again at altitude
    p.run(5.0);
    let (_, _, u2) = p.v.true_position();
    assert!(
        u2 > 1.5 && (u2 - u).abs() < 0.5,
        "{u} → {u2}: holds its altitude"
    );
}
