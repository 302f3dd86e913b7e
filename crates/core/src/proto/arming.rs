//! When a vehicle may be armed, and the arm / disarm command.
//!
//! Arming for real: a flag is not enough. We require a heartbeat in STANDBY or later, a
//! 3D GPS fix, a position estimate (GLOBAL_POSITION_INT with a position; ArduPilot's
//! EKF_STATUS_REPORT with an absolute horizontal position and not in constant-position
//! mode when it is sent), a home position (HOME_POSITION), the SYS_STATUS
//! MAV_SYS_STATUS_PREARM_CHECK health bit when the autopilot reports it (ArduPilot
//! `GCS_MAVLINK::send_sys_status` sets it from the last pre-arm result, PX4 from its
//! health and arming checks), and no pre-arm failure in STATUSTEXT ("PreArm: …" from
//! ArduPilot `AP_Arming::check_failed`, "Preflight Fail: …" from PX4) when the bit is
//! not reported.

use super::Endpoint;
use super::command::Command;
use super::flavour::Flavour;
use mavlink::dialects::ardupilotmega::{EkfStatusFlags, MavCmd};

/// What the arming check looks at (filled from telemetry by the fleet).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ArmInputs {
    /// HEARTBEAT system_status (MAV_STATE).
    pub system_status: u8,
    /// Already armed.
    pub armed: bool,
    /// GPS_RAW_INT fix_type, if received.
    pub gps_fix: Option<u8>,
    /// A position estimate: GLOBAL_POSITION_INT received recently with lat/lon ≠ 0.
    pub position: bool,
    /// HOME_POSITION received.
    pub home: bool,
    /// ArduPilot EKF_STATUS_REPORT flags, if received.
    pub ekf_flags: Option<u16>,
    /// SYS_STATUS pre-arm health bit: `None` when the autopilot does not report it.
    pub prearm_ok: Option<bool>,
    /// A recent pre-arm failure STATUSTEXT, if any.
    pub prearm_text: Option<String>,
}

/// EKF_STATUS_REPORT flags (ardupilotmega.xml EKF_STATUS_FLAGS).
const EKF_POS_HORIZ_ABS: u16 = EkfStatusFlags::EKF_POS_HORIZ_ABS.bits();
const EKF_CONST_POS_MODE: u16 = EkfStatusFlags::EKF_CONST_POS_MODE.bits();
const EKF_UNINITIALIZED: u16 = EkfStatusFlags::EKF_UNINITIALIZED.bits();

impl Flavour {
    /// The arm / disarm command (param2 = 0: no force).
    pub fn arm_command(&self, target: Endpoint, arm: bool) -> Command {
        Command::long(
            target,
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [f32::from(u8::from(arm)), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    /// Why the vehicle cannot be armed yet (empty when it can). See the module docs.
    pub fn arm_blockers(&self, s: &ArmInputs) -> Vec<String> {
        let mut why = Vec::new();
        if s.system_status < 3 {
            why.push(format!(
                "autopilot not ready (MAV_STATE {}: still booting or calibrating)",
                s.system_status
            ));
        }
        match s.gps_fix {
            None => why.push("no GPS_RAW_INT received".into()),
            Some(f) if f < 3 => why.push(format!("GPS fix type {f} (a 3D fix is needed)")),
            _ => {}
        }
        if !s.position {
            why.push("no position estimate (GLOBAL_POSITION_INT without a position)".into());
        }
        if let Some(flags) = s.ekf_flags
            && (flags & EKF_POS_HORIZ_ABS == 0
                || flags & EKF_CONST_POS_MODE != 0
                || flags & EKF_UNINITIALIZED != 0)
        {
            why.push(format!(
                "EKF has no absolute horizontal position yet (EKF_STATUS_REPORT flags 0x{flags:04x})"
            ));
        }
        if !s.home {
            why.push("home position not set (no HOME_POSITION)".into());
        }
        match (s.prearm_ok, &s.prearm_text) {
            (Some(false), t) => why.push(format!(
                "pre-arm checks failing{}",
                t.as_ref().map(|t| format!(": {t}")).unwrap_or_default()
            )),
            (None, Some(t)) => why.push(format!("pre-arm failure reported: {t}")),
            _ => {}
        }
        why
    }

    /// Whether a STATUSTEXT reports a pre-arm / pre-flight failure.
    pub fn is_prearm_failure_text(text: &str) -> bool {
        let t = text.trim_start();
        t.starts_with("PreArm:")
            || t.starts_with("Arm:")
            || t.starts_with("Preflight Fail")
            || t.starts_with("Arming denied")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arming_needs_more_than_a_flag() {
        let f = Flavour::ARDU_COPTER;
        let mut s = ArmInputs {
            system_status: 3,
            gps_fix: Some(3),
            position: true,
            home: true,
            prearm_ok: Some(true),
            ..Default::default()
        };
        assert!(f.arm_blockers(&s).is_empty());
        s.ekf_flags = Some(EKF_CONST_POS_MODE | EKF_POS_HORIZ_ABS);
        assert_eq!(f.arm_blockers(&s).len(), 1);
        s.ekf_flags = None;
        s.home = false;
        s.gps_fix = Some(2);
        assert_eq!(f.arm_blockers(&s).len(), 2);
        s = ArmInputs {
            system_status: 3,
            gps_fix: Some(3),
            position: true,
            home: true,
            prearm_ok: None,
            prearm_text: Some("PreArm: Compass not calibrated".into()),
            ..Default::default()
        };
        assert!(f.arm_blockers(&s)[0].contains("Compass"));
        assert!(Flavour::is_prearm_failure_text("PreArm: Need 3D Fix"));
        assert!(Flavour::is_prearm_failure_text(
            "Preflight Fail: ekf2 missing data"
        ));
    }
}
