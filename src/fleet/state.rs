//! Per-vehicle telemetry state, updated from received messages (pure: time is a parameter),
//! and the snapshot types the TUI and the runners read.

use fleetmap_core::budget::LinkBudget;
use fleetmap_core::proto::arming::ArmInputs;
use fleetmap_core::proto::flavour::Flavour;
use fleetmap_core::proto::heartbeat::Beat;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use fleetmap_io::link::codec::SourceStats;
use mavlink::dialects::ardupilotmega::{
    GLOBAL_POSITION_INT_DATA, MavLandedState, MavMessage, MissionState,
};
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::Duration;

/// A geographic position.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct GeoPoint {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude above mean sea level, metres.
    pub alt_amsl: f32,
}

impl GeoPoint {
    /// The position a GLOBAL_POSITION_INT reports (1e-7 degrees, millimetres AMSL).
    pub(crate) fn of_global_position(p: &GLOBAL_POSITION_INT_DATA) -> GeoPoint {
        GeoPoint {
            lat: f64::from(p.lat) / 1e7,
            lon: f64::from(p.lon) / 1e7,
            alt_amsl: p.alt as f32 / 1000.0,
        }
    }
}

/// A STATUSTEXT.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StatusText {
    /// MAV_SEVERITY (written as its number, 0 emergency … 7 debug, in JSON).
    #[serde(serialize_with = "severity_number")]
    pub severity: Severity,
    /// The text.
    pub text: String,
    /// When it arrived (fleet clock).
    pub at: Time,
}

/// Link quality seen from one vehicle's autopilot, and what its link carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LinkQuality {
    /// Frames received from the autopilot.
    pub frames: u64,
    /// Frames missing from sequence-number gaps.
    pub lost: u64,
    /// Loss, percent (0–100).
    pub(crate) loss_pct: f64,
    /// Frames per second over the last few seconds.
    pub(crate) rate_hz: f64,
    /// Bytes per second of the fleet's clock received from this system (every component:
    /// autopilot, camera), over the last few seconds.
    pub down_bytes_per_s: f64,
    /// Bytes per second of the fleet's clock sent to this system, over the last few seconds.
    pub up_bytes_per_s: f64,
    /// What the GCS plans this vehicle's link for.
    pub budget: LinkBudget,
    /// Whether `budget` was assumed because a radio reported itself (RADIO_STATUS) on a
    /// link the GCS was told nothing about.
    pub budget_assumed: bool,
    /// The telemetry radio's last report, when one is heard on this vehicle's link.
    pub radio: Option<RadioReport>,
}

/// What a telemetry radio reports about itself (RADIO_STATUS, sent by a SiK radio with
/// MAVLink framing into the serial side it is plugged into: the GCS's radio into the GCS, so
/// `rssi`, `txbuf` and `rxerrors` are the GCS radio's, `remrssi` the vehicle radio's as it
/// last heard it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RadioReport {
    /// The report's fields.
    #[serde(flatten)]
    pub status: fleetmap_io::link::radio::RadioStatus,
    /// Seconds since the report arrived (fleet clock).
    pub age_s: f64,
}

impl LinkQuality {
    /// The loss from the autopilot's sequence numbers: `s`, at `rate_hz` frames per second.
    pub(crate) fn set_source(&mut self, s: &SourceStats, rate_hz: f64) {
        self.frames = s.frames;
        self.lost = s.lost;
        self.loss_pct = s.loss_ratio() * 100.0;
        self.rate_hz = rate_hz;
    }
}

/// Everything the fleet knows about one vehicle (the autopilot component of a system).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VehicleSnapshot {
    /// System id.
    pub sysid: u8,
    /// Autopilot component id.
    pub compid: u8,
    /// Autopilot and vehicle class, from HEARTBEAT.autopilot (MAV_AUTOPILOT:
    /// `flavour.autopilot.mav_autopilot()`) and HEARTBEAT.type.
    pub flavour: Flavour,
    /// MAV_TYPE.
    pub mav_type: u8,
    /// The mode's name for this flavour (`MODE(n)` if unknown).
    pub mode: String,
    /// HEARTBEAT custom_mode.
    pub custom_mode: u32,
    /// Armed (HEARTBEAT base_mode).
    pub armed: bool,
    /// HEARTBEAT system_status (MAV_STATE).
    pub system_status: u8,
    /// Still booting: its heartbeat says MAV_STATE_BOOT (ArduPilot, for about 2 s after
    /// power-up, while it refuses MISSION_COUNT with MAV_MISSION_NO_SPACE), or it rebooted
    /// (a battery swap is a power cycle) and has not sent a heartbeat since. Operations
    /// wait for it to end ([`crate::fleet::FleetHandle::wait_booted`]). PX4 has no boot
    /// state on MAVLink: its MAV_STATE_UNINIT means "pre-flight checks not passed", not
    /// booting (`streams/HEARTBEAT.hpp`).
    pub(crate) booting: bool,
    /// When the vehicle was first heard out of boot in its current power cycle (fleet
    /// clock); `None` while it boots.
    pub(crate) ready_since: Option<Time>,
    /// Heard within the liveness window.
    pub alive: bool,
    /// Seconds since the last heartbeat.
    pub(crate) heartbeat_age_s: f64,
    /// Times a reboot was detected.
    pub(crate) reboots: u32,
    /// Position (GLOBAL_POSITION_INT), if received.
    pub position: Option<GeoPoint>,
    /// Altitude above home, metres.
    pub alt_rel: Option<f32>,
    /// Heading, degrees (0–360).
    pub heading_deg: Option<f32>,
    /// Ground speed, m/s.
    pub groundspeed: Option<f32>,
    /// Climb rate, m/s (up positive).
    pub climb: Option<f32>,
    /// GPS_RAW_INT fix type (0–1 none, 2 2D, 3 3D, 4+ DGPS/RTK).
    pub gps_fix: Option<u8>,
    /// Satellites visible.
    pub satellites: Option<u8>,
    /// Battery remaining, percent.
    pub battery_pct: Option<i8>,
    /// Battery voltage, volts.
    pub battery_v: Option<f32>,
    /// Whether the battery is being charged (BATTERY_STATUS charge_state CHARGING), when
    /// the autopilot reports a charge state.
    pub charging: Option<bool>,
    /// Home (HOME_POSITION).
    pub home: Option<GeoPoint>,
    /// Current mission item (user numbering: ArduPilot's home not counted).
    pub mission_current: Option<u16>,
    /// Mission items (user numbering).
    pub mission_total: Option<u16>,
    /// MISSION_CURRENT mission_state, if reported (and not MISSION_STATE_UNKNOWN). Written
    /// as its MAVLink number in JSON.
    #[serde(serialize_with = "number_or_null")]
    pub mission_state: Option<MissionState>,
    /// Last MISSION_ITEM_REACHED (user numbering).
    pub last_reached: Option<u16>,
    /// Every user item reported reached since the last mission upload or start.
    pub reached: Vec<u16>,
    /// EXTENDED_SYS_STATE landed state (0 unknown, 1 on ground, 2 in air, 3 taking off,
    /// 4 landing).
    #[serde(serialize_with = "number_or_null")]
    pub(crate) landed_state: Option<MavLandedState>,
    /// Last STATUSTEXT.
    pub last_text: Option<StatusText>,
    /// Last pre-arm failure text (ArduPilot "PreArm: …", PX4 "Preflight Fail: …").
    pub(crate) prearm_text: Option<StatusText>,
    /// SYS_STATUS pre-arm health bit (None if not reported).
    pub(crate) prearm_ok: Option<bool>,
    /// ArduPilot EKF_STATUS_REPORT flags.
    pub(crate) ekf_flags: Option<u16>,
    /// A camera component (MAV_COMP_ID_CAMERA…) was heard on this system.
    pub camera_compid: Option<u8>,
    /// When the camera component's heartbeat last arrived (fleet clock).
    pub(crate) camera_heard_at: Option<Time>,
    /// When the camera's current run of heartbeats began (fleet clock): its first heartbeat,
    /// or the first after a silence of more than [`CAMERA_SILENCE_S`] (a camera that was off,
    /// rebooted or unplugged, and is back).
    pub(crate) camera_since: Option<Time>,
    /// Seconds from the camera's last heartbeat to the last refresh; `None` when no camera
    /// was ever heard on this system.
    pub camera_age_s: Option<f64>,
    /// Pictures the camera took, each counted once
    /// ([`fleetmap_core::proto::camera_tally::CameraTally::pictures`]).
    pub camera_pictures: u32,
    /// Measurements the camera made on board and sent
    /// ([`fleetmap_core::proto::camera_tally::CameraTally::measurements`]).
    pub camera_measurements: u32,
    /// Link carrying this vehicle (index of `--connect`).
    pub link: usize,
    /// Link quality from the autopilot's sequence numbers.
    pub link_quality: LinkQuality,
    /// When any message from the autopilot last arrived (fleet clock).
    pub(crate) last_message: Time,
    /// When the last GLOBAL_POSITION_INT arrived (fleet clock).
    pub(crate) position_at: Option<Time>,
    /// Two (or more) autopilots answer as this system id on its link
    /// ([`fleetmap_core::proto::sysid_conflict`]): nothing is sent to it any more
    /// ([`crate::fleet::FleetError::SysidConflict`]) until fleetmap is restarted.
    pub sysid_conflict: Option<SysidConflict>,
    /// It has been heard long enough to say that no second autopilot shares its id
    /// ([`fleetmap_core::proto::sysid_conflict::SysidWatch::checked`]), or a conflict was
    /// seen.
    pub sysid_checked: bool,
}

/// Two autopilots seen behind one system id, as the operator is told.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SysidConflict {
    /// What showed it.
    pub evidence: String,
    /// The link it was seen on (index of `--connect`).
    pub link: usize,
    /// Seconds from the first frame heard from that system on that link to the decision.
    pub detect_s: f64,
}

impl SysidConflict {
    /// What the operator must do, said once for every message.
    pub const FIX: &'static str = "give each autopilot its own system id (ArduPilot: \
        SYSID_THISMAV, PX4: MAV_SYS_ID), reboot them, then restart fleetmap";
}

/// A camera's heartbeat (1 Hz in the MAVLink camera protocol) missing for longer than this
/// is a camera that went silent, seconds: the next one starts a new run
/// ([`VehicleSnapshot::camera_since`]). Three beats, as the GCS's own liveness window counts.
pub(crate) const CAMERA_SILENCE_S: f64 = 3.0;

impl VehicleSnapshot {
    /// The camera component's heartbeat arrived at `now`.
    pub(crate) fn camera_heard(&mut self, compid: u8, now: Time) {
        self.camera_compid = Some(compid);
        let silent = self
            .camera_heard_at
            .is_none_or(|t| now.saturating_since(t).as_secs_f64() > CAMERA_SILENCE_S);
        if silent {
            self.camera_since = Some(now);
        }
        self.camera_heard_at = Some(now);
    }

    /// Whether the camera has gone silent: heard once, and not for more than
    /// [`CAMERA_SILENCE_S`] at the last refresh.
    pub(crate) fn camera_silent(&self) -> bool {
        self.camera_age_s.is_some_and(|a| a > CAMERA_SILENCE_S)
    }

    /// Whether the camera has been heard within [`CAMERA_SILENCE_S`] of `now`, in a run of
    /// heartbeats that began at or after `since` (`None`: any).
    pub(crate) fn camera_heard_since(&self, since: Option<Time>, now: Time) -> bool {
        let recent = self
            .camera_heard_at
            .is_some_and(|t| now.saturating_since(t).as_secs_f64() <= CAMERA_SILENCE_S);
        recent
            && self
                .camera_since
                .is_some_and(|s| since.is_none_or(|at| s >= at))
    }

    /// Whether the autopilot says it is on the ground: EXTENDED_SYS_STATE when reported,
    /// otherwise disarmed.
    pub fn on_ground(&self) -> bool {
        use MavLandedState::*;
        match self.landed_state {
            Some(MAV_LANDED_STATE_ON_GROUND) => true,
            Some(MAV_LANDED_STATE_IN_AIR | MAV_LANDED_STATE_TAKEOFF | MAV_LANDED_STATE_LANDING) => {
                false
            }
            _ => !self.armed,
        }
    }

    /// The mode of the last heartbeat, when its flavour's table has it
    /// ([`Flavour::mode_of`]); [`VehicleSnapshot::mode`] is its name.
    pub(crate) fn flight_mode(&self) -> Option<fleetmap_core::proto::mode::Mode> {
        self.flavour.mode_of(self.custom_mode)
    }

    /// Whether the autopilot reports its mission as being flown (MISSION_STATE_ACTIVE).
    pub(crate) fn mission_active(&self) -> bool {
        self.mission_state == Some(MissionState::MISSION_STATE_ACTIVE)
    }

    /// Whether the autopilot reports its mission as flown to the end
    /// (MISSION_STATE_COMPLETE).
    pub(crate) fn mission_complete(&self) -> bool {
        self.mission_state == Some(MissionState::MISSION_STATE_COMPLETE)
    }

    /// The inputs of the arming check at time `now` (see [`Flavour::arm_blockers`]).
    pub(crate) fn arm_inputs(&self, now: Time) -> ArmInputs {
        let fresh = |t: Option<Time>, secs: u64| {
            t.is_some_and(|t| now.saturating_since(t) <= Duration::from_secs(secs))
        };
        ArmInputs {
            system_status: self.system_status,
            armed: self.armed,
            gps_fix: self.gps_fix,
            position: self.position.is_some_and(|p| p.lat != 0.0 || p.lon != 0.0)
                && fresh(self.position_at, 5),
            home: self.home.is_some(),
            ekf_flags: self.ekf_flags,
            prearm_ok: self.prearm_ok,
            prearm_text: self
                .prearm_text
                .as_ref()
                .filter(|t| now.saturating_since(t.at) <= Duration::from_secs(35))
                .map(|t| t.text.clone()),
        }
    }

    /// Why arming is not possible now (empty when it is).
    pub(crate) fn arm_blockers(&self, now: Time) -> Vec<String> {
        self.flavour.arm_blockers(&self.arm_inputs(now))
    }
}

/// A link's published state, as in the snapshot.
pub(crate) type LinkSnapshot = fleetmap_io::link::transport::LinkStatus;

/// The whole fleet at one instant.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FleetSnapshot {
    /// Fleet clock time of the snapshot.
    pub time: Time,
    /// Vehicles by system id.
    pub vehicles: BTreeMap<u8, VehicleSnapshot>,
    /// Links, in `--connect` order.
    pub links: Vec<LinkSnapshot>,
}

/// MAV_STATE_BOOT (HEARTBEAT system_status).
const MAV_STATE_BOOT: u8 = mavlink::dialects::ardupilotmega::MavState::MAV_STATE_BOOT as u8;

/// MAV_SYS_STATUS_PREARM_CHECK (SYS_STATUS sensor bit 28).
const PREARM_BIT: u32 = 0x1000_0000;

impl VehicleSnapshot {
    /// An ArduCopter (MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_ARDUPILOTMEGA, active) first heard at
    /// time zero on link 0, for tests.
    #[cfg(test)]
    pub(crate) fn test_copter(sysid: u8) -> VehicleSnapshot {
        let beat = Beat {
            custom_mode: 0,
            mav_type: mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_QUADROTOR as u8,
            autopilot: 3,
            base_mode: 0,
            system_status: 3,
        };
        VehicleSnapshot::new(sysid, 1, &beat, 0, Time::ZERO)
    }

    /// A vehicle first heard with heartbeat `beat` from `sysid`/`compid` on `link`.
    pub fn new(sysid: u8, compid: u8, beat: &Beat, link: usize, now: Time) -> VehicleSnapshot {
        let flavour = Flavour::from_heartbeat(beat.autopilot, beat.mav_type);
        VehicleSnapshot {
            sysid,
            compid,
            flavour,
            mav_type: beat.mav_type,
            mode: flavour.mode_name(beat.custom_mode),
            custom_mode: beat.custom_mode,
            armed: beat.armed(),
            system_status: beat.system_status,
            booting: beat.system_status == MAV_STATE_BOOT,
            ready_since: (beat.system_status != MAV_STATE_BOOT).then_some(now),
            alive: true,
            heartbeat_age_s: 0.0,
            reboots: 0,
            position: None,
            alt_rel: None,
            heading_deg: None,
            groundspeed: None,
            climb: None,
            gps_fix: None,
            satellites: None,
            battery_pct: None,
            battery_v: None,
            charging: None,
            home: None,
            mission_current: None,
            mission_total: None,
            mission_state: None,
            last_reached: None,
            reached: Vec::new(),
            landed_state: None,
            last_text: None,
            prearm_text: None,
            prearm_ok: None,
            ekf_flags: None,
            camera_compid: None,
            camera_heard_at: None,
            camera_since: None,
            camera_age_s: None,
            camera_pictures: 0,
            camera_measurements: 0,
            link,
            link_quality: LinkQuality::default(),
            last_message: now,
            position_at: None,
            sysid_conflict: None,
            sysid_checked: false,
        }
    }

    /// A heartbeat from the autopilot, received at `now`.
    pub(crate) fn apply_heartbeat(&mut self, beat: &Beat, now: Time) {
        if beat.system_status == MAV_STATE_BOOT {
            self.booting = true;
            self.ready_since = None;
        } else if self.booting || self.ready_since.is_none() {
            self.booting = false;
            self.ready_since = Some(now);
        }
        self.flavour = Flavour::from_heartbeat(beat.autopilot, beat.mav_type);
        self.mav_type = beat.mav_type;
        self.custom_mode = beat.custom_mode;
        self.mode = self.flavour.mode_name(beat.custom_mode);
        self.armed = beat.armed();
        self.system_status = beat.system_status;
    }

    /// Update from a message of the autopilot.
    pub(crate) fn apply(&mut self, msg: &MavMessage, now: Time) {
        self.last_message = now;
        match msg {
            MavMessage::GLOBAL_POSITION_INT(p) => {
                self.position = Some(GeoPoint::of_global_position(p));
                self.position_at = Some(now);
                self.alt_rel = Some(p.relative_alt as f32 / 1000.0);
                if p.hdg != u16::MAX {
                    self.heading_deg = Some(f32::from(p.hdg) / 100.0);
                }
                let (vx, vy) = (f32::from(p.vx) / 100.0, f32::from(p.vy) / 100.0);
                self.groundspeed = Some((vx * vx + vy * vy).sqrt());
                self.climb = Some(-f32::from(p.vz) / 100.0);
            }
            MavMessage::VFR_HUD(v) => {
                self.groundspeed = Some(v.groundspeed);
                self.climb = Some(v.climb);
                self.heading_deg = Some(f32::from(v.heading).rem_euclid(360.0));
            }
            MavMessage::GPS_RAW_INT(g) => {
                self.gps_fix = Some(g.fix_type as u8);
                if g.satellites_visible != u8::MAX {
                    self.satellites = Some(g.satellites_visible);
                }
            }
            MavMessage::SYS_STATUS(s) => {
                if s.battery_remaining >= 0 {
                    self.battery_pct = Some(s.battery_remaining);
                }
                if s.voltage_battery != u16::MAX {
                    self.battery_v = Some(f32::from(s.voltage_battery) / 1000.0);
                }
                if s.onboard_control_sensors_present.bits() & PREARM_BIT != 0 {
                    self.prearm_ok =
                        Some(s.onboard_control_sensors_health.bits() & PREARM_BIT != 0);
                }
            }
            MavMessage::BATTERY_STATUS(b) => {
                if b.battery_remaining >= 0 {
                    self.battery_pct = Some(b.battery_remaining);
                }
                use mavlink::dialects::ardupilotmega::MavBatteryChargeState as Cs;
                self.charging = match b.charge_state {
                    Cs::MAV_BATTERY_CHARGE_STATE_UNDEFINED => None,
                    Cs::MAV_BATTERY_CHARGE_STATE_CHARGING => Some(true),
                    _ => Some(false),
                };
                let cells: u32 = b
                    .voltages
                    .iter()
                    .take_while(|v| **v != u16::MAX)
                    .map(|v| u32::from(*v))
                    .sum();
                if cells > 0 {
                    self.battery_v = Some(cells as f32 / 1000.0);
                }
            }
            MavMessage::HOME_POSITION(h) => {
                self.home = Some(GeoPoint {
                    lat: f64::from(h.latitude) / 1e7,
                    lon: f64::from(h.longitude) / 1e7,
                    alt_amsl: h.altitude as f32 / 1000.0,
                });
            }
            MavMessage::MISSION_CURRENT(c) => {
                self.mission_current = self.flavour.user_seq(c.seq);
                // PX4 sends total = UINT16_MAX without a mission; ArduPilot counts home.
                if c.total != u16::MAX && c.total != 0 {
                    self.mission_total = Some(if self.flavour.home_item() {
                        c.total.saturating_sub(1)
                    } else {
                        c.total
                    });
                } else if c.total == u16::MAX {
                    self.mission_total = Some(0);
                }
                if c.mission_state != MissionState::MISSION_STATE_UNKNOWN {
                    self.mission_state = Some(c.mission_state);
                }
            }
            MavMessage::MISSION_ITEM_REACHED(r) => {
                if let Some(u) = self.flavour.user_seq(r.seq) {
                    self.last_reached = Some(u);
                    if !self.reached.contains(&u) {
                        self.reached.push(u);
                    }
                }
            }
            MavMessage::EXTENDED_SYS_STATE(e) => {
                self.landed_state = Some(e.landed_state);
            }
            MavMessage::EKF_STATUS_REPORT(e) => {
                self.ekf_flags = Some(e.flags.bits());
            }
            MavMessage::STATUSTEXT(t) => {
                let text = t
                    .text
                    .to_str()
                    .map(|s| s.trim_end_matches('\0').to_string())
                    .unwrap_or_else(|_| String::from_utf8_lossy(&t.text[..]).into_owned());
                let st = StatusText {
                    severity: Severity::from_mav(t.severity as u8),
                    text: text.trim_end_matches('\0').to_string(),
                    at: now,
                };
                if Flavour::is_prearm_failure_text(&st.text) {
                    self.prearm_text = Some(st.clone());
                }
                self.last_text = Some(st);
            }
            _ => {}
        }
    }

    /// The vehicle rebooted: it counts as booting until its next heartbeat.
    pub(crate) fn rebooted(&mut self) {
        self.booting = true;
        self.ready_since = None;
    }

    /// Forget mission progress (a new mission was uploaded or started).
    pub(crate) fn reset_progress(&mut self) {
        self.reached.clear();
        self.last_reached = None;
        self.mission_state = None;
    }

    /// Refresh liveness and link-quality fields.
    pub(crate) fn refresh(
        &mut self,
        alive: bool,
        last_beat: Option<Time>,
        src: Option<&SourceStats>,
        rate_hz: f64,
        now: Time,
    ) {
        self.alive = alive;
        self.heartbeat_age_s =
            last_beat.map_or(f64::INFINITY, |t| now.saturating_since(t).as_secs_f64());
        self.camera_age_s = self
            .camera_heard_at
            .map(|t| now.saturating_since(t).as_secs_f64());
        if let Some(s) = src {
            self.link_quality.set_source(s, rate_hz);
        }
    }
}

/// Serialises a severity as its MAVLink number (as the snapshot's JSON always had it).
fn severity_number<S: serde::Serializer>(v: &Severity, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_u8(v.to_mav())
}

/// Serialises a MAVLink enum value as its number (the JSON of `fleetmap vehicles --json` and
/// the run files keep the wire's numbers), `null` when absent.
fn number_or_null<E, S>(v: &Option<E>, s: S) -> Result<S::Ok, S::Error>
where
    E: Copy + num_traits::ToPrimitive,
    S: serde::Serializer,
{
    match v.and_then(|e| e.to_u8()) {
        Some(n) => s.serialize_some(&n),
        None => s.serialize_none(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera heard at 1 Hz is one run of heartbeats; one silent for longer than
    /// [`CAMERA_SILENCE_S`] starts a new run when it is heard again, and only a run that began
    /// after a given moment counts as heard since then.
    #[test]
    fn a_camera_silent_and_heard_again_starts_a_new_run() {
        let mut v = VehicleSnapshot::test_copter(1);
        assert!(!v.camera_heard_since(None, Time::ZERO));
        for s in 0..10 {
            v.camera_heard(100, Time::from_secs(s));
        }
        assert_eq!(v.camera_since, Some(Time::ZERO));
        assert!(v.camera_heard_since(None, Time::from_secs(11)));
        // silent: not heard within the window
        assert!(!v.camera_heard_since(None, Time::from_secs(20)));
        // a camera heartbeating on is not heard "since" a later moment
        assert!(!v.camera_heard_since(Some(Time::from_secs(5)), Time::from_secs(9)));
        // back after a silence: a new run
        v.camera_heard(100, Time::from_secs(30));
        assert_eq!(v.camera_since, Some(Time::from_secs(30)));
        assert!(v.camera_heard_since(Some(Time::from_secs(5)), Time::from_secs(31)));
    }
}
