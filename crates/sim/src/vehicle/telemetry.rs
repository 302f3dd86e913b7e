//! Telemetry: the outbox, status texts, message streams (REQUEST_DATA_STREAM,
//! SET_MESSAGE_INTERVAL) and the messages they carry.

use super::messages::wobble;
use super::streams::{ApRefusal, ApSchedule, Px4Schedule};
use super::terrain::Terrain;
use super::*;

/// The camera component's HEARTBEAT (MAV_TYPE_CAMERA), sent with the autopilot's.
fn camera_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: mav::MavType::MAV_TYPE_CAMERA,
        autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: mav::MavModeFlag::empty(),
        system_status: mav::MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

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
    /// MESSAGE_INTERVAL (message id 244).
    pub(crate) const MESSAGE_INTERVAL: u32 = <mav::MESSAGE_INTERVAL_DATA as MessageData>::ID;
}

/// What leaves the vehicle: message sequence numbers, the stream schedule, the outbox and
/// events.
#[derive(Debug)]
pub(super) struct Telemetry {
    /// Next sequence number per component (autopilot, camera).
    pub(super) seq: [u8; 2],
    /// When each streamed message is due ([`super::streams`]).
    pub(super) schedule: Schedule,
    /// The message ids due this step (kept to save an allocation per step).
    pub(super) due: Vec<u32>,
    /// Messages waiting to be sent, with their component id.
    pub(super) outbox: VecDeque<(u8, MavMessage)>,
    /// Events for the harness.
    pub(super) events: VecDeque<VehicleEvent>,
    /// PX4's PING stream's sequence number.
    pub(super) ping_seq: u32,
    /// Messages sent and received on the GCS link since boot, and the counts at the last
    /// LINK_NODE_STATUS (its rates).
    pub(super) link_counts: LinkCounts,
    /// ArduCopter's last TERRAIN_REQUEST.
    pub(super) terrain_request_at: Option<Time>,
    /// ArduCopter's terrain: the block it keeps for where it is and the squares of it it has.
    pub(super) terrain: Terrain,
}

/// What PX4's LINK_NODE_STATUS reports of the GCS link.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct LinkCounts {
    /// Messages sent since boot.
    pub(super) sent: u32,
    /// Messages received since boot.
    pub(super) received: u32,
    /// (when, sent, received) at the last LINK_NODE_STATUS.
    pub(super) last: Option<(Time, u32, u32)>,
}

/// The flavour's message schedule.
#[derive(Debug)]
pub(super) enum Schedule {
    /// ArduPilot's stream groups and buckets.
    ArduPilot(Box<ApSchedule>),
    /// PX4's streams and rate multiplier.
    Px4(Px4Schedule),
}

impl Schedule {
    /// The schedule a vehicle boots with.
    pub(super) fn at_boot(cfg: &VehicleConfig, now: Time) -> Schedule {
        match cfg.flavour.autopilot {
            SimAutopilot::ArduPilot => {
                Schedule::ArduPilot(Box::new(ApSchedule::new(cfg.flavour.kind, now)))
            }
            SimAutopilot::Px4 => Schedule::Px4(Px4Schedule::new(cfg.px4_link, now)),
        }
    }
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

    /// The streams a vehicle boots with: ArduCopter only HEARTBEAT, ArduRover every group at
    /// 1 Hz, PX4 its Normal mode ([`super::streams`]).
    pub(super) fn reset_schedule(&mut self, now: Time) {
        self.telemetry.schedule = Schedule::at_boot(&self.cfg, now);
    }

    /// REQUEST_DATA_STREAM (ArduPilot; PX4 ignores it): a stream group's rate, Hz.
    pub(super) fn request_data_stream(&mut self, stream: u8, rate: u16, start_stop: u8, now: Time) {
        if let Schedule::ArduPilot(s) = &mut self.telemetry.schedule {
            s.request_data_stream(stream, rate, start_stop, now);
        }
    }

    /// RADIO_STATUS from the radio on the GCS link: ArduPilot's `stream_slowdown_ms`, PX4's
    /// radio multiplier.
    pub(super) fn radio_status(&mut self, txbuf: u8, now: Time) {
        match &mut self.telemetry.schedule {
            Schedule::ArduPilot(s) => s.radio_status(txbuf),
            Schedule::Px4(s) => s.radio_status(txbuf, now),
        }
    }

    /// SET_MESSAGE_INTERVAL: param1 the message id, param2 the interval in µs (0 default,
    /// −1 off).
    pub(super) fn cmd_message_interval(
        &mut self,
        id: u32,
        interval_us: f32,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        match &mut self.telemetry.schedule {
            Schedule::ArduPilot(s) => match s.set_message_interval(id, interval_us, now) {
                Ok(()) => R::MAV_RESULT_ACCEPTED,
                Err(why) => {
                    let text = match why {
                        ApRefusal::Unknown => Some(format!("No ap_message for mavlink id ({id})")),
                        ApRefusal::TooFast => Some(format!(
                            "Requested rate for message ID {id} too fast. Increase SCHED_LOOP_RATE"
                        )),
                        ApRefusal::Negative => None,
                    };
                    if let Some(t) = text {
                        self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &t);
                    }
                    R::MAV_RESULT_DENIED
                }
            },
            Schedule::Px4(s) => {
                if s.set_message_interval(id, interval_us, now) {
                    R::MAV_RESULT_ACCEPTED
                } else {
                    R::MAV_RESULT_FAILED
                }
            }
        }
    }

    /// GET_MESSAGE_INTERVAL (and REQUEST_MESSAGE of MESSAGE_INTERVAL): a MESSAGE_INTERVAL
    /// with the message's interval, µs. ArduPilot: −1 when not sent, 0 and FAILED for an id
    /// it has no message for; PX4: 0 when not streamed, always ACCEPTED.
    pub(super) fn cmd_get_message_interval(&mut self, id: u32) -> mav::MavResult {
        let (interval_us, result) = match &self.telemetry.schedule {
            Schedule::ArduPilot(s) => s.get_message_interval(id),
            Schedule::Px4(s) => (
                s.get_message_interval(id),
                mav::MavResult::MAV_RESULT_ACCEPTED,
            ),
        };
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::MESSAGE_INTERVAL(mav::MESSAGE_INTERVAL_DATA {
                interval_us,
                message_id: id.min(u32::from(u16::MAX)) as u16,
            }),
        );
        result
    }

    /// REQUEST_MESSAGE: the message once (param1 its id; MESSAGE_INTERVAL with param2 the
    /// message asked about).
    pub(super) fn cmd_request_message(
        &mut self,
        id: u32,
        param2: f32,
        now: Time,
    ) -> mav::MavResult {
        if id == self::id::MESSAGE_INTERVAL {
            return self.cmd_get_message_interval(param2 as u32);
        }
        if id == self::id::HOME_POSITION && self.flight.home.is_none() {
            return mav::MavResult::MAV_RESULT_FAILED;
        }
        match self.message_now(id, now) {
            Some(m) => {
                self.queue(AUTOPILOT_COMPID, m);
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            None => mav::MavResult::MAV_RESULT_DENIED,
        }
    }

    /// Message `id` as the vehicle would send it now, if it has one.
    pub(super) fn message_now(&mut self, id: u32, now: Time) -> Option<MavMessage> {
        match self.telemetry(id, now) {
            Some(m) => Some(m),
            None => self.stream_message(id, now),
        }
    }

    /// Send what the schedule says is due at `now` (one 20 Hz step).
    pub(super) fn emit_streams(&mut self, now: Time) {
        let mut due = std::mem::take(&mut self.telemetry.due);
        due.clear();
        let receiving = self.missions.server.receiving();
        let timesync = match &mut self.telemetry.schedule {
            Schedule::ArduPilot(s) => s.due(now, receiving, &mut due),
            Schedule::Px4(s) => {
                s.due(now, &mut due);
                false
            }
        };
        for &id in &due {
            if id == self::id::HEARTBEAT {
                self.send_heartbeat(now);
                if self.camera.is_some() && !self.faults.camera_failed {
                    self.queue(CAMERA_COMPID, camera_heartbeat());
                }
                continue;
            }
            if id == self::id::HOME_POSITION && self.flight.home.is_none() {
                continue;
            }
            if let Some(m) = self.message_now(id, now) {
                self.queue(AUTOPILOT_COMPID, m);
            }
        }
        self.telemetry.due = due;
        if timesync {
            let m = self.timesync_msg(now);
            self.queue(AUTOPILOT_COMPID, m);
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

    pub(super) fn home_position_msg(&self, now: Time) -> MavMessage {
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
            // ArduPilot leaves the orientation unset (NaN), PX4 gives its heading at home
            q: if self.cfg.flavour.is_ardupilot() {
                [f32::NAN; 4]
            } else {
                let (s, c) = (self.flight.m.heading_deg.to_radians() / 2.0).sin_cos();
                [c as f32, 0.0, 0.0, s as f32]
            },
            approach_x: 0.0,
            approach_y: 0.0,
            approach_z: 0.0,
            time_usec: now.saturating_since(self.power.boot_time).as_micros() as u64,
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
        if self.cfg.flavour.kind == SimVehicleClass::Rover || self.arming.landed {
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
                            SimMode::Auto
                                | SimMode::Rtl
                                | SimMode::Land
                                | SimMode::Takeoff
                                | SimMode::Hold
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
                    if self.arming.landed
                        && !(self.arming.armed && f.kind == SimVehicleClass::Rover)
                    {
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
                    // PX4 reports its (absent) recovery system as healthy
                    onboard_control_sensors_health_extended: if f.is_ardupilot() {
                        mav::MavSysStatusSensorExtended::empty()
                    } else {
                        mav::MavSysStatusSensorExtended::MAV_SYS_STATUS_RECOVERY_SYSTEM
                    },
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
                    // accuracies as SITL / SIH report them: ArduPilot leaves the speed
                    // accuracy 0, PX4 fills it (40 and 44 payload bytes)
                    alt_ellipsoid: if fix {
                        (amsl * 1000.0).round() as i32
                    } else {
                        0
                    },
                    h_acc: match (fix, f.is_ardupilot()) {
                        (false, _) => 0,
                        (true, true) => 300,
                        (true, false) => 900,
                    },
                    v_acc: match (fix, f.is_ardupilot()) {
                        (false, _) => 0,
                        (true, true) => 300,
                        (true, false) => 1780,
                    },
                    vel_acc: if fix && !f.is_ardupilot() { 400 } else { 0 },
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
                // gyro noise: never exactly zero, so the message is its full 28 bytes
                rollspeed: wobble(now, 40.0, 1e-3),
                pitchspeed: wobble(now, 41.0, 1e-3),
                yawspeed: wobble(now, 42.0, 1e-3),
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
                    // the estimator's heading: the true one within a few hundredths of a
                    // degree (so never exactly 0, the last field; a real EKF's never is)
                    hdg: ((self.flight.m.heading_deg + f64::from(wobble(now, 43.0, 0.01))) * 100.0)
                        .round() as u16
                        % 36000,
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
                    && self.modes.mode == SimMode::Auto
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
                    mission_mode: u8::from(self.modes.mode == SimMode::Auto),
                    // PX4 sends the lists' ids; ArduPilot 4.7 leaves them out
                    // (`GCS_MAVLINK::send_mission_current`)
                    mission_id: if ap {
                        0
                    } else {
                        self.missions.server.opaque_id(MissionType::Mission)
                    },
                    fence_id: if ap {
                        0
                    } else {
                        self.missions.server.opaque_id(MissionType::Fence)
                    },
                    rally_points_id: if ap {
                        0
                    } else {
                        self.missions.server.opaque_id(MissionType::Rally)
                    },
                })
            }
            id::VFR_HUD => MavMessage::VFR_HUD(mav::VFR_HUD_DATA {
                // estimates: never exactly zero
                airspeed: self.flight.m.ground_speed() as f32 + wobble(now, 44.0, 1e-2),
                groundspeed: self.flight.m.ground_speed() as f32 + wobble(now, 45.0, 1e-2),
                alt: amsl as f32,
                climb: self.flight.m.vu as f32 + wobble(now, 46.0, 5e-4),
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
                // ArduCopter says MC, ArduRover has no landed state (`GCS_MAVLINK::landed_state`
                // is UNDEFINED unless a vehicle overrides it; Rover does not)
                let (vtol_state, landed_state) = match (f.autopilot, f.kind) {
                    (SimAutopilot::ArduPilot, SimVehicleClass::Copter) => {
                        (mav::MavVtolState::MAV_VTOL_STATE_MC, self.landed_state())
                    }
                    (SimAutopilot::ArduPilot, SimVehicleClass::Rover) => (
                        mav::MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                        mav::MavLandedState::MAV_LANDED_STATE_UNDEFINED,
                    ),
                    (SimAutopilot::Px4, _) => (
                        mav::MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                        self.landed_state(),
                    ),
                };
                MavMessage::EXTENDED_SYS_STATE(mav::EXTENDED_SYS_STATE_DATA {
                    vtol_state,
                    landed_state,
                })
            }
            _ => return None,
        })
    }
}
