//! Telemetry: the outbox, status texts, message streams (REQUEST_DATA_STREAM,
//! SET_MESSAGE_INTERVAL) and the messages they carry.

use super::*;

/// The message ids the vehicle streams or answers, named from the dialect's message types,
/// and ArduPilot's REQUEST_DATA_STREAM stream groups (MAV_DATA_STREAM).
pub(super) mod id {
    use mavlink::MessageData;
    use mavlink::dialects::ardupilotmega as mav;
    /// HEARTBEAT (message id 0).
    pub(crate) const HEARTBEAT: u32 = <mav::HEARTBEAT_DATA as MessageData>::ID;
    /// SYS_STATUS (message id 1).
    pub(crate) const SYS_STATUS: u32 = <mav::SYS_STATUS_DATA as MessageData>::ID;
    /// SYSTEM_TIME (message id 2).
    pub(crate) const SYSTEM_TIME: u32 = <mav::SYSTEM_TIME_DATA as MessageData>::ID;
    /// GPS_RAW_INT (message id 24).
    pub(crate) const GPS_RAW_INT: u32 = <mav::GPS_RAW_INT_DATA as MessageData>::ID;
    /// ATTITUDE (message id 30).
    pub(crate) const ATTITUDE: u32 = <mav::ATTITUDE_DATA as MessageData>::ID;
    /// GLOBAL_POSITION_INT (message id 33).
    pub(crate) const GLOBAL_POSITION_INT: u32 = <mav::GLOBAL_POSITION_INT_DATA as MessageData>::ID;
    /// MISSION_CURRENT (message id 42).
    pub(crate) const MISSION_CURRENT: u32 = <mav::MISSION_CURRENT_DATA as MessageData>::ID;
    /// VFR_HUD (message id 74).
    pub(crate) const VFR_HUD: u32 = <mav::VFR_HUD_DATA as MessageData>::ID;
    /// BATTERY_STATUS (message id 147).
    pub(crate) const BATTERY_STATUS: u32 = <mav::BATTERY_STATUS_DATA as MessageData>::ID;
    /// AUTOPILOT_VERSION (message id 148).
    pub(crate) const AUTOPILOT_VERSION: u32 = <mav::AUTOPILOT_VERSION_DATA as MessageData>::ID;
    /// HOME_POSITION (message id 242).
    pub(crate) const HOME_POSITION: u32 = <mav::HOME_POSITION_DATA as MessageData>::ID;
    /// EXTENDED_SYS_STATE (message id 245).
    pub(crate) const EXTENDED_SYS_STATE: u32 = <mav::EXTENDED_SYS_STATE_DATA as MessageData>::ID;
    /// CAMERA_INFORMATION (message id 259), answered by the camera component.
    pub(crate) const CAMERA_INFORMATION: u32 = <mav::CAMERA_INFORMATION_DATA as MessageData>::ID;
    /// CAMERA_CAPTURE_STATUS (message id 262), answered by the camera component.
    pub(crate) const CAMERA_CAPTURE_STATUS: u32 =
        <mav::CAMERA_CAPTURE_STATUS_DATA as MessageData>::ID;
    /// MAV_DATA_STREAM_ALL.
    pub(crate) const STREAM_ALL: u8 = mav::MavDataStream::MAV_DATA_STREAM_ALL as u8;
    /// MAV_DATA_STREAM_EXTENDED_STATUS.
    pub(crate) const STREAM_EXTENDED_STATUS: u8 =
        mav::MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS as u8;
    /// MAV_DATA_STREAM_POSITION.
    pub(crate) const STREAM_POSITION: u8 = mav::MavDataStream::MAV_DATA_STREAM_POSITION as u8;
    /// MAV_DATA_STREAM_EXTRA1.
    pub(crate) const STREAM_EXTRA1: u8 = mav::MavDataStream::MAV_DATA_STREAM_EXTRA1 as u8;
    /// MAV_DATA_STREAM_EXTRA2.
    pub(crate) const STREAM_EXTRA2: u8 = mav::MavDataStream::MAV_DATA_STREAM_EXTRA2 as u8;
    /// MAV_DATA_STREAM_EXTRA3.
    pub(crate) const STREAM_EXTRA3: u8 = mav::MavDataStream::MAV_DATA_STREAM_EXTRA3 as u8;
}

/// What leaves the vehicle: message sequence numbers, streams, the outbox and events.
#[derive(Debug)]
pub(super) struct Telemetry {
    /// Next sequence number per component (autopilot, camera).
    pub(super) seq: [u8; 2],
    /// Streamed message ids: (interval, next send time).
    pub(super) streams: BTreeMap<u32, (Duration, Time)>,
    /// Messages waiting to be sent, with their component id.
    pub(super) outbox: VecDeque<(u8, MavMessage)>,
    /// Events for the harness.
    pub(super) events: VecDeque<VehicleEvent>,
}

impl SimVehicle {
    // ------------------------------------------------------------------ telemetry

    pub(super) fn queue(&mut self, comp: u8, msg: MavMessage) {
        if self.power.powered {
            self.telemetry.outbox.push_back((comp, msg));
        }
    }

    /// ArduPilot's answer to SETUP_SIGNING while armed (`GCS_MAVLINK::handle_setup_signing`
    /// ignores it): the warning it sends. The signing itself lives in the harness.
    pub(crate) fn refuse_signing_setup(&mut self) {
        self.text(
            mav::MavSeverity::MAV_SEVERITY_WARNING,
            "ERROR: Won't setup signing when armed",
        );
    }

    pub(super) fn text(&mut self, severity: mav::MavSeverity, s: &str) {
        let t: String = s.chars().take(50).collect();
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::STATUSTEXT(mav::STATUSTEXT_DATA {
                severity,
                text: t.as_str().into(),
                id: 0,
                chunk_seq: 0,
            }),
        );
    }

    pub(super) fn default_streams(&mut self, now: Time) {
        let f = self.cfg.flavour;
        let mut set = |id: u32, hz: f64| {
            if hz > 0.0 {
                self.telemetry
                    .streams
                    .insert(id, (Duration::from_secs_f64(1.0 / hz), now));
            }
        };
        set(id::HEARTBEAT, 1.0); // HEARTBEAT
        match (f.autopilot, f.kind) {
            (SimAutopilot::ArduPilot, VehicleKind::Copter) => {}
            (SimAutopilot::ArduPilot, VehicleKind::Rover) => {
                for id in [
                    id::SYS_STATUS,
                    id::GPS_RAW_INT,
                    id::MISSION_CURRENT,
                    id::GLOBAL_POSITION_INT,
                    id::ATTITUDE,
                    id::VFR_HUD,
                    id::BATTERY_STATUS,
                    id::EXTENDED_SYS_STATE,
                ] {
                    set(id, 1.0);
                }
            }
            (SimAutopilot::Px4, _) => {
                set(id::SYS_STATUS, 1.0); // SYS_STATUS
                set(id::GPS_RAW_INT, 1.0); // GPS_RAW_INT
                set(id::ATTITUDE, 15.0); // ATTITUDE
                set(id::GLOBAL_POSITION_INT, 5.0); // GLOBAL_POSITION_INT
                set(id::MISSION_CURRENT, 1.0); // MISSION_CURRENT (mission manager, 1 Hz)
                set(id::VFR_HUD, 4.0); // VFR_HUD
                set(id::BATTERY_STATUS, 0.5); // BATTERY_STATUS
                set(id::HOME_POSITION, 0.5); // HOME_POSITION
                set(id::EXTENDED_SYS_STATE, 1.0); // EXTENDED_SYS_STATE
            }
        }
        if let Some(c) = self.camera.as_ref() {
            let _ = c;
        }
    }

    /// REQUEST_DATA_STREAM (ArduPilot): set a stream group's rate (Hz; 0 stops).
    pub(super) fn request_data_stream(&mut self, stream: u8, rate: u16, start: bool, now: Time) {
        // GCS_MAVLink stream groups (ArduCopter GCS_Mavlink.cpp STREAM_* lists)
        let ids: &[u32] = match stream {
            id::STREAM_ALL => &[
                id::SYS_STATUS,
                id::GPS_RAW_INT,
                id::MISSION_CURRENT,
                id::EXTENDED_SYS_STATE,
                id::GLOBAL_POSITION_INT,
                id::ATTITUDE,
                id::VFR_HUD,
                id::SYSTEM_TIME,
                id::BATTERY_STATUS,
            ],
            id::STREAM_EXTENDED_STATUS => &[
                id::SYS_STATUS,
                id::GPS_RAW_INT,
                id::MISSION_CURRENT,
                id::EXTENDED_SYS_STATE,
            ], // EXTENDED_STATUS (+ EXTENDED_SYS_STATE)
            id::STREAM_POSITION => &[id::GLOBAL_POSITION_INT], // POSITION
            id::STREAM_EXTRA1 => &[id::ATTITUDE],              // EXTRA1
            id::STREAM_EXTRA2 => &[id::VFR_HUD],               // EXTRA2
            id::STREAM_EXTRA3 => &[id::SYSTEM_TIME, id::BATTERY_STATUS], // EXTRA3: SYSTEM_TIME, BATTERY_STATUS
            _ => &[],
        };
        for &id in ids {
            if start && rate > 0 {
                self.telemetry
                    .streams
                    .insert(id, (Duration::from_secs_f64(1.0 / f64::from(rate)), now));
            } else {
                self.telemetry.streams.remove(&id);
            }
        }
    }

    pub(super) fn cmd_message_interval(
        &mut self,
        id: u32,
        interval_us: f32,
        now: Time,
    ) -> mav::MavResult {
        if !self.message_supported(id) {
            if self.cfg.flavour.is_ardupilot() {
                let msg = format!("No ap_message for mavlink id ({id})");
                self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
            }
            return mav::MavResult::MAV_RESULT_DENIED;
        }
        if interval_us < 0.0 {
            self.telemetry.streams.remove(&id);
        } else if interval_us == 0.0 {
            // default rate: restore the boot default (or stop when there is none)
            self.telemetry.streams.remove(&id);
            let mut probe = BTreeMap::new();
            std::mem::swap(&mut probe, &mut self.telemetry.streams);
            self.default_streams(now);
            let default = self.telemetry.streams.get(&id).copied();
            std::mem::swap(&mut probe, &mut self.telemetry.streams);
            if let Some(d) = default {
                self.telemetry.streams.insert(id, d);
            }
        } else {
            let us = f64::from(interval_us).max(10_000.0); // at most 100 Hz
            self.telemetry
                .streams
                .insert(id, (Duration::from_secs_f64(us / 1e6), now));
        }
        mav::MavResult::MAV_RESULT_ACCEPTED
    }

    pub(super) fn message_supported(&self, id: u32) -> bool {
        matches!(
            id,
            id::HEARTBEAT
                | id::SYS_STATUS
                | id::SYSTEM_TIME
                | id::GPS_RAW_INT
                | id::ATTITUDE
                | id::GLOBAL_POSITION_INT
                | id::MISSION_CURRENT
                | id::VFR_HUD
                | id::BATTERY_STATUS
                | id::AUTOPILOT_VERSION
                | id::HOME_POSITION
                | id::EXTENDED_SYS_STATE
        )
    }

    pub(super) fn cmd_request_message(&mut self, id: u32, now: Time) -> mav::MavResult {
        if id == 242 && self.flight.home.is_none() {
            return mav::MavResult::MAV_RESULT_FAILED;
        }
        match self.telemetry(id, now) {
            Some(m) => {
                self.queue(AUTOPILOT_COMPID, m);
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            None => mav::MavResult::MAV_RESULT_DENIED,
        }
    }

    pub(super) fn emit_streams(&mut self, now: Time) {
        let due: Vec<u32> = self
            .telemetry
            .streams
            .iter()
            .filter(|(_, (_, next))| *next <= now)
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            if let Some((period, next)) = self.telemetry.streams.get_mut(&id) {
                let mut n = *next + *period;
                if n <= now {
                    n = now + *period;
                }
                *next = n;
            }
            if id == 242 && self.flight.home.is_none() {
                continue;
            }
            if let Some(m) = self.telemetry(id, now) {
                self.queue(AUTOPILOT_COMPID, m);
            }
            if id == 0
                && let Some(c) = self.camera.as_ref()
            {
                let _ = c;
                self.queue(
                    CAMERA_COMPID,
                    MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                        custom_mode: 0,
                        mavtype: mav::MavType::MAV_TYPE_CAMERA,
                        autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
                        base_mode: mav::MavModeFlag::empty(),
                        system_status: mav::MavState::MAV_STATE_ACTIVE,
                        mavlink_version: 3,
                    }),
                );
            }
        }
        // ArduPilot prints the failing pre-arm check every 30 s while disarmed
        if self.cfg.flavour.is_ardupilot()
            && !self.arming.armed
            && self
                .arming
                .last_prearm_report
                .is_none_or(|t| now.saturating_since(t) >= Duration::from_secs(30))
            && self.boot_s(now) > 1.0
        {
            self.arming.last_prearm_report = Some(now);
            if let Some(m) = self.prearm_failure(now) {
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, m);
            }
        }
    }

    pub(super) fn send_heartbeat(&mut self, now: Time) {
        if let Some(m) = self.telemetry(id::HEARTBEAT, now) {
            self.queue(AUTOPILOT_COMPID, m);
        }
    }

    pub(super) fn send_mission_current(&mut self, now: Time) {
        if let Some(m) = self.telemetry(id::MISSION_CURRENT, now) {
            self.queue(AUTOPILOT_COMPID, m);
        }
    }

    pub(super) fn home_position_msg(&self, _now: Time) -> MavMessage {
        let h = self.flight.home.unwrap_or(Home {
            lat: 0.0,
            lon: 0.0,
            alt_amsl: 0.0,
            e: 0.0,
            n: 0.0,
        });
        let (ee, en) = self.est();
        MavMessage::HOME_POSITION(mav::HOME_POSITION_DATA {
            latitude: (h.lat * 1e7).round() as i32,
            longitude: (h.lon * 1e7).round() as i32,
            altitude: (h.alt_amsl * 1000.0).round() as i32,
            x: (h.n - en) as f32,
            y: (h.e - ee) as f32,
            z: 0.0,
            q: [1.0, 0.0, 0.0, 0.0],
            approach_x: 0.0,
            approach_y: 0.0,
            approach_z: 0.0,
            time_usec: 0,
        })
    }

    pub(super) fn autopilot_version_msg(&self) -> MavMessage {
        let caps = mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
            | mav::MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_RALLY;
        let version = match self.cfg.flavour.autopilot {
            SimAutopilot::ArduPilot => (4 << 24) | (5 << 16) | (7 << 8) | 255,
            SimAutopilot::Px4 => (1 << 24) | (15 << 16) | (4 << 8) | 255,
        };
        MavMessage::AUTOPILOT_VERSION(mav::AUTOPILOT_VERSION_DATA {
            capabilities: caps,
            uid: u64::from(self.cfg.sysid),
            flight_sw_version: version,
            middleware_sw_version: 0,
            os_sw_version: 0,
            board_version: 0,
            vendor_id: 0,
            product_id: 0,
            flight_custom_version: [0; 8],
            middleware_custom_version: [0; 8],
            os_custom_version: [0; 8],
            uid2: [0; 18],
        })
    }

    pub(super) fn landed_state(&self) -> mav::MavLandedState {
        use mav::MavLandedState as L;
        if self.cfg.flavour.kind == VehicleKind::Rover || self.arming.landed {
            L::MAV_LANDED_STATE_ON_GROUND
        } else if matches!(self.flight.nav, Nav::Takeoff(_))
            || self.missions.exec.px4_takeoff.is_some()
        {
            L::MAV_LANDED_STATE_TAKEOFF
        } else if matches!(
            self.flight.nav,
            Nav::Land {
                descending: true,
                ..
            }
        ) || matches!(
            self.flight.nav,
            Nav::Rtl {
                phase: RtlPhase::Land,
                ..
            }
        ) {
            L::MAV_LANDED_STATE_LANDING
        } else {
            L::MAV_LANDED_STATE_IN_AIR
        }
    }

    pub(super) fn telemetry(&self, id: u32, now: Time) -> Option<MavMessage> {
        let f = self.cfg.flavour;
        let tb = self.time_boot_ms(now);
        let (lat, lon, u) = self.reported_position();
        let amsl = self.ground_amsl() + u;
        let home_amsl = self
            .flight
            .home
            .map(|h| h.alt_amsl)
            .unwrap_or(self.ground_amsl());
        Some(match id {
            id::HEARTBEAT => {
                let mut base = mav::MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
                match f.autopilot {
                    SimAutopilot::ArduPilot => {
                        base |= mav::MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED
                            | mav::MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED;
                        if self.modes.mode.requires_position() && !self.arming.landed {
                            base |= mav::MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
                        }
                    }
                    SimAutopilot::Px4 => {
                        base |= mav::MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED;
                        if self.modes.mode.requires_position() {
                            base |= mav::MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
                        }
                        if matches!(
                            self.modes.mode,
                            Mode::Auto | Mode::Rtl | Mode::Land | Mode::Takeoff | Mode::Hold
                        ) {
                            base |= mav::MavModeFlag::MAV_MODE_FLAG_AUTO_ENABLED;
                        }
                    }
                }
                if self.arming.armed {
                    base |= mav::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
                }
                let status = if self.modes.failsafe_level > 0 && self.arming.armed {
                    mav::MavState::MAV_STATE_CRITICAL
                } else if f.is_ardupilot() {
                    if self.arming.landed && !(self.arming.armed && f.kind == VehicleKind::Rover) {
                        if self.ardupilot_booting(now) {
                            mav::MavState::MAV_STATE_BOOT
                        } else {
                            mav::MavState::MAV_STATE_STANDBY
                        }
                    } else {
                        mav::MavState::MAV_STATE_ACTIVE
                    }
                } else if self.arming.armed {
                    mav::MavState::MAV_STATE_ACTIVE
                } else if self.position_ok(now) {
                    mav::MavState::MAV_STATE_STANDBY
                } else {
                    mav::MavState::MAV_STATE_UNINIT
                };
                MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                    custom_mode: f.custom_mode(self.modes.mode).unwrap_or(0),
                    mavtype: mav::MavType::from_u8(f.mav_type())
                        .unwrap_or(mav::MavType::MAV_TYPE_QUADROTOR),
                    autopilot: mav::MavAutopilot::from_u8(f.mav_autopilot())
                        .unwrap_or(mav::MavAutopilot::MAV_AUTOPILOT_GENERIC),
                    base_mode: base,
                    system_status: status,
                    mavlink_version: 3,
                })
            }
            id::SYS_STATUS => {
                use mav::MavSysStatusSensor as S;
                let present = S::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | S::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | S::MAV_SYS_STATUS_SENSOR_3D_MAG
                    | S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                    | S::MAV_SYS_STATUS_SENSOR_GPS
                    | S::MAV_SYS_STATUS_AHRS
                    | S::MAV_SYS_STATUS_SENSOR_BATTERY;
                let mut health = present;
                if !self.gps_fix(now) {
                    health.remove(S::MAV_SYS_STATUS_SENSOR_GPS);
                }
                if !self.position_ok(now) {
                    health.remove(S::MAV_SYS_STATUS_AHRS);
                }
                if self.modes.failsafe_level > 0 {
                    health.remove(S::MAV_SYS_STATUS_SENSOR_BATTERY);
                }
                MavMessage::SYS_STATUS(mav::SYS_STATUS_DATA {
                    onboard_control_sensors_present: present,
                    onboard_control_sensors_enabled: present,
                    onboard_control_sensors_health: health,
                    load: 250,
                    voltage_battery: (self.power.battery.voltage() * 1000.0)
                        .round()
                        .clamp(0.0, 65534.0) as u16,
                    current_battery: (self.power.battery.current_a * 100.0)
                        .round()
                        .clamp(-32767.0, 32767.0) as i16,
                    drop_rate_comm: 0,
                    errors_comm: 0,
                    errors_count1: 0,
                    errors_count2: 0,
                    errors_count3: 0,
                    errors_count4: 0,
                    battery_remaining: self.power.battery.percent(),
                    onboard_control_sensors_present_extended:
                        mav::MavSysStatusSensorExtended::empty(),
                    onboard_control_sensors_enabled_extended:
                        mav::MavSysStatusSensorExtended::empty(),
                    onboard_control_sensors_health_extended: mav::MavSysStatusSensorExtended::empty(
                    ),
                })
            }
            id::SYSTEM_TIME => MavMessage::SYSTEM_TIME(mav::SYSTEM_TIME_DATA {
                time_unix_usec: 0,
                time_boot_ms: tb,
            }),
            id::GPS_RAW_INT => {
                let fix = self.gps_fix(now);
                MavMessage::GPS_RAW_INT(mav::GPS_RAW_INT_DATA {
                    time_usec: u64::from(tb) * 1000,
                    lat: if fix { (lat * 1e7).round() as i32 } else { 0 },
                    lon: if fix { (lon * 1e7).round() as i32 } else { 0 },
                    alt: if fix {
                        (amsl * 1000.0).round() as i32
                    } else {
                        0
                    },
                    eph: if fix { 80 } else { u16::MAX },
                    epv: if fix { 120 } else { u16::MAX },
                    vel: (self.flight.m.ground_speed() * 100.0).round() as u16,
                    cog: (self
                        .flight
                        .m
                        .ve
                        .atan2(self.flight.m.vn)
                        .to_degrees()
                        .rem_euclid(360.0)
                        * 100.0) as u16,
                    fix_type: if fix {
                        mav::GpsFixType::GPS_FIX_TYPE_3D_FIX
                    } else {
                        mav::GpsFixType::GPS_FIX_TYPE_NO_FIX
                    },
                    satellites_visible: if fix { 14 } else { 3 },
                    alt_ellipsoid: 0,
                    h_acc: if fix { 600 } else { 0 },
                    v_acc: if fix { 900 } else { 0 },
                    vel_acc: if fix { 200 } else { 0 },
                    hdg_acc: 0,
                    yaw: 0,
                })
            }
            id::ATTITUDE => MavMessage::ATTITUDE(mav::ATTITUDE_DATA {
                time_boot_ms: tb,
                roll: self.flight.m.roll_deg.to_radians() as f32,
                pitch: self.flight.m.pitch_deg.to_radians() as f32,
                yaw: {
                    let y = self.flight.m.heading_deg.to_radians();
                    (if y > std::f64::consts::PI {
                        y - 2.0 * std::f64::consts::PI
                    } else {
                        y
                    }) as f32
                },
                rollspeed: 0.0,
                pitchspeed: 0.0,
                yawspeed: 0.0,
            }),
            id::GLOBAL_POSITION_INT => {
                if !self.position_ok(now) && f.is_ardupilot() {
                    // no global position before the EKF origin is set
                    return None;
                }
                MavMessage::GLOBAL_POSITION_INT(mav::GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: tb,
                    lat: (lat * 1e7).round() as i32,
                    lon: (lon * 1e7).round() as i32,
                    alt: (amsl * 1000.0).round() as i32,
                    relative_alt: ((amsl - home_amsl) * 1000.0).round() as i32,
                    vx: (self.flight.m.vn * 100.0).round() as i16,
                    vy: (self.flight.m.ve * 100.0).round() as i16,
                    vz: (-self.flight.m.vu * 100.0).round() as i16,
                    hdg: (self.flight.m.heading_deg * 100.0).round() as u16 % 36000,
                })
            }
            id::MISSION_CURRENT => {
                let n = self.missions.server.items(MissionType::Mission).len() as u16;
                let ap = f.is_ardupilot();
                let total = if ap {
                    n.saturating_sub(1)
                } else if n == 0 {
                    u16::MAX
                } else {
                    n
                };
                let state = if (ap && n <= 1) || (!ap && n == 0) {
                    mav::MissionState::MISSION_STATE_NO_MISSION
                } else if self.missions.exec.complete {
                    mav::MissionState::MISSION_STATE_COMPLETE
                } else if self.missions.exec.running {
                    mav::MissionState::MISSION_STATE_ACTIVE
                } else if !ap
                    && self.missions.exec.nav_index.is_some()
                    && self.modes.mode == Mode::Auto
                {
                    // PX4 only. ArduPilot never reports PAUSED: `GCS_MAVLINK::mission_state`
                    // (libraries/GCS_MAVLink/GCS_Common.cpp) maps AP_Mission's STOPPED to
                    // NOT_STARTED, RUNNING to ACTIVE, COMPLETE to COMPLETE — e.g. an ArduRover
                    // left in AUTO whose new mission MISSION_START did not start reports
                    // NOT_STARTED (SITL V4.7.0-dev 90700977).
                    mav::MissionState::MISSION_STATE_PAUSED
                } else {
                    mav::MissionState::MISSION_STATE_NOT_STARTED
                };
                MavMessage::MISSION_CURRENT(mav::MISSION_CURRENT_DATA {
                    seq: self.missions.server.current(),
                    total,
                    mission_state: state,
                    mission_mode: u8::from(self.modes.mode == Mode::Auto),
                    mission_id: self.missions.server.opaque_id(MissionType::Mission),
                    fence_id: self.missions.server.opaque_id(MissionType::Fence),
                    rally_points_id: self.missions.server.opaque_id(MissionType::Rally),
                })
            }
            id::VFR_HUD => MavMessage::VFR_HUD(mav::VFR_HUD_DATA {
                airspeed: self.flight.m.ground_speed() as f32,
                groundspeed: self.flight.m.ground_speed() as f32,
                alt: amsl as f32,
                climb: self.flight.m.vu as f32,
                heading: self.flight.m.heading_deg.round() as i16 % 360,
                throttle: if self.arming.armed && !self.arming.landed {
                    50
                } else {
                    0
                },
            }),
            id::BATTERY_STATUS => {
                let mut voltages = [u16::MAX; 10];
                let cells = self.cfg.battery.cells.clamp(1, 10) as usize;
                let cell_mv = (self.power.battery.voltage() * 1000.0 / cells as f64).round() as u16;
                for v in voltages.iter_mut().take(cells) {
                    *v = cell_mv;
                }
                let rate = self.power.battery.current_a.max(0.1);
                let remaining_s = (self.cfg.battery.capacity_mah - self.power.battery.consumed_mah)
                    / 1000.0
                    / rate
                    * 3600.0;
                MavMessage::BATTERY_STATUS(mav::BATTERY_STATUS_DATA {
                    current_consumed: self.power.battery.consumed_mah.round() as i32,
                    energy_consumed: -1,
                    temperature: i16::MAX,
                    voltages,
                    current_battery: (self.power.battery.current_a * 100.0)
                        .round()
                        .clamp(-32767.0, 32767.0) as i16,
                    id: 0,
                    battery_function: mav::MavBatteryFunction::MAV_BATTERY_FUNCTION_ALL,
                    mavtype: mav::MavBatteryType::MAV_BATTERY_TYPE_LIPO,
                    battery_remaining: self.power.battery.percent(),
                    time_remaining: remaining_s.round() as i32,
                    charge_state: if self.power.charging {
                        mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CHARGING
                    } else {
                        match self.modes.failsafe_level {
                            0 => mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK,
                            1 => mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_LOW,
                            _ => mav::MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CRITICAL,
                        }
                    },
                    voltages_ext: [0; 4],
                    mode: mav::MavBatteryMode::MAV_BATTERY_MODE_UNKNOWN,
                    fault_bitmask: mav::MavBatteryFault::empty(),
                })
            }
            id::AUTOPILOT_VERSION => self.autopilot_version_msg(),
            id::HOME_POSITION => self.home_position_msg(now),
            id::EXTENDED_SYS_STATE => {
                MavMessage::EXTENDED_SYS_STATE(mav::EXTENDED_SYS_STATE_DATA {
                    vtol_state: mav::MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                    landed_state: self.landed_state(),
                })
            }
            _ => return None,
        })
    }
}
