//! The telemetry messages beyond the basic ones of [`super::telemetry`]: what ArduPilot's
//! stream groups and PX4's Normal-mode streams carry besides position, status and battery.
//!
//! Their contents are plausible, not exact: they follow the vehicle's state where there is
//! one (attitude, position, velocity, battery, arming) and otherwise carry what ArduCopter /
//! ArduRover 4.7 SITL and PX4 1.16 SIH were seen to send (the sample values measured for
//! `docs/results/conformance.md`). What matters on a radio is their size: MAVLink 2 cuts the
//! trailing zero bytes of a payload, so which fields are zero decides how many bytes a
//! message takes, and the fields below are set so that each message is as long on the wire as
//! the real one (a zero where the real autopilot sends a zero, a value where it sends one; the
//! unit tests compare them with the measured lengths).

use super::*;
use mavlink::MessageData;

/// A message id, from the dialect's message type.
macro_rules! id {
    ($t:ident) => {
        <mav::$t as MessageData>::ID
    };
}

/// A small deterministic wobble (sensor noise, estimator jitter), never zero: a value of
/// about `scale` that changes with time; `k` tells apart the quantities. It draws on no random
/// stream, so the simulation's seeded processes are the same whatever is streamed.
pub(super) fn wobble(now: Time, k: f64, scale: f64) -> f32 {
    let t = now.as_secs_f64();
    (scale * (1.5 + (t * (0.37 + 0.113 * k) + k).sin())) as f32
}

impl SimVehicle {
    /// The message `id` as a stream sends it now, or None when the vehicle has nothing to say
    /// (no such sensor, not in a state where the autopilot sends it).
    pub(super) fn stream_message(&mut self, id: u32, now: Time) -> Option<MavMessage> {
        let f = self.cfg.flavour;
        let ap = f.is_ardupilot();
        let copter = f.is_copter();
        let tb = self.time_boot_ms(now);
        let t_us = u64::from(tb) * 1000;
        let m = self.flight.m;
        let (roll, pitch, yaw) = (
            m.roll_deg.to_radians() as f32,
            m.pitch_deg.to_radians() as f32,
            wrap_pi(m.heading_deg.to_radians()) as f32,
        );
        let (lat, lon, u) = self.reported_position();
        let (lat_e7, lon_e7) = ((lat * 1e7).round() as i32, (lon * 1e7).round() as i32);
        let amsl = self.ground_amsl() + u;
        let home = self.flight.home;
        let armed = self.arming.armed;
        let flying = !self.arming.landed;
        Some(match id {
            // ---------------------------------------------------------------- both
            x if x == id!(LOCAL_POSITION_NED_DATA) => {
                // ArduCopter sends no local position (nor WIND) before its EKF has one
                // (SITL: neither came until "EKF3 IMU0 is using GPS")
                if ap && copter && !self.position_ok(now) {
                    return None;
                }
                let (e, n) = self.est();
                let (he, hn) = home.map_or((e, n), |h| (h.e, h.n));
                MavMessage::LOCAL_POSITION_NED(mav::LOCAL_POSITION_NED_DATA {
                    time_boot_ms: tb,
                    x: (n - hn) as f32,
                    y: (e - he) as f32,
                    z: -u as f32,
                    vx: m.vn as f32,
                    vy: m.ve as f32,
                    // the estimator's vertical velocity is never exactly 0
                    vz: (-m.vu) as f32 + wobble(now, 1.0, 1e-4),
                })
            }
            x if x == id!(VIBRATION_DATA) => MavMessage::VIBRATION(mav::VIBRATION_DATA {
                time_usec: t_us,
                vibration_x: wobble(now, 2.0, 3e-3),
                vibration_y: wobble(now, 3.0, 3e-3),
                vibration_z: wobble(now, 4.0, 5e-3),
                clipping_0: 0,
                clipping_1: 0,
                clipping_2: 0,
            }),
            x if x == id!(SCALED_PRESSURE_DATA) || x == id!(SCALED_PRESSURE2_DATA) => {
                // ISA pressure at the altitude, hPa; 45 °C board temperature (SITL's)
                let press = (1013.25 * (1.0 - 2.25577e-5 * amsl).powf(5.25588)) as f32;
                let d = mav::SCALED_PRESSURE_DATA {
                    time_boot_ms: tb,
                    press_abs: press,
                    press_diff: 0.0,
                    temperature: if ap { 4500 } else { 1181 },
                    temperature_press_diff: 0,
                };
                if x == id!(SCALED_PRESSURE_DATA) {
                    MavMessage::SCALED_PRESSURE(d)
                } else {
                    MavMessage::SCALED_PRESSURE2(mav::SCALED_PRESSURE2_DATA {
                        time_boot_ms: d.time_boot_ms,
                        press_abs: d.press_abs,
                        press_diff: d.press_diff,
                        temperature: d.temperature,
                        temperature_press_diff: 0,
                    })
                }
            }
            x if x == id!(SERVO_OUTPUT_RAW_DATA) => {
                // motors (copter: 1–4) or steering and throttle (rover: 1 and 3)
                let spin = if armed && flying {
                    1500
                } else if armed {
                    1150
                } else {
                    1000
                };
                let mut s = [0u16; 16];
                if !ap {
                    s = [900; 16];
                    if armed {
                        s[..4].fill(spin);
                    }
                } else if copter {
                    s[..4].fill(spin);
                } else {
                    s[0] = 1500;
                    s[2] = 1500;
                }
                MavMessage::SERVO_OUTPUT_RAW(mav::SERVO_OUTPUT_RAW_DATA {
                    time_usec: t_us as u32,
                    servo1_raw: s[0],
                    servo2_raw: s[1],
                    servo3_raw: s[2],
                    servo4_raw: s[3],
                    servo5_raw: s[4],
                    servo6_raw: s[5],
                    servo7_raw: s[6],
                    servo8_raw: s[7],
                    port: 0,
                    servo9_raw: s[8],
                    servo10_raw: s[9],
                    servo11_raw: s[10],
                    servo12_raw: s[11],
                    servo13_raw: s[12],
                    servo14_raw: s[13],
                    servo15_raw: s[14],
                    servo16_raw: s[15],
                })
            }
            x if x == id!(NAV_CONTROLLER_OUTPUT_DATA) => {
                // ArduCopter always (once initialised); ArduRover and PX4 only while the
                // autopilot navigates
                let navigating = matches!(
                    self.modes.mode,
                    SimMode::Auto | SimMode::Guided | SimMode::Rtl
                );
                if !(navigating || ap && copter) {
                    return None;
                }
                let (bearing, dist) = self.nav_target_bearing_distance();
                MavMessage::NAV_CONTROLLER_OUTPUT(mav::NAV_CONTROLLER_OUTPUT_DATA {
                    nav_roll: m.roll_deg as f32 + wobble(now, 5.0, 0.05),
                    nav_pitch: m.pitch_deg as f32 + wobble(now, 6.0, 0.05),
                    alt_error: wobble(now, 7.0, 5e-4),
                    aspd_error: 0.0,
                    xtrack_error: wobble(now, 8.0, 1e-4),
                    nav_bearing: (m.heading_deg.round() as i16 + 180).rem_euclid(360) - 180,
                    target_bearing: bearing,
                    wp_dist: dist,
                })
            }
            x if x == id!(POSITION_TARGET_GLOBAL_INT_DATA) => {
                let target = self.guided_target()?;
                let (tlat, tlon) = local::offset(
                    self.cfg.reference.0,
                    self.cfg.reference.1,
                    target.n,
                    target.e,
                );
                let talt = home.map_or(self.ground_amsl(), |h| h.alt_amsl) + target.u;
                MavMessage::POSITION_TARGET_GLOBAL_INT(mav::POSITION_TARGET_GLOBAL_INT_DATA {
                    time_boot_ms: tb,
                    lat_int: (tlat * 1e7).round() as i32,
                    lon_int: (tlon * 1e7).round() as i32,
                    alt: talt as f32,
                    // ArduPilot: position only (type mask 0xFFF8, frame GLOBAL); PX4 fills
                    // everything (frame GLOBAL_INT)
                    vx: if ap { 0.0 } else { m.vn as f32 },
                    vy: if ap { 0.0 } else { m.ve as f32 },
                    vz: if ap { 0.0 } else { -m.vu as f32 },
                    afx: 0.0,
                    afy: 0.0,
                    afz: 0.0,
                    yaw: if ap { 0.0 } else { yaw },
                    yaw_rate: if ap { 0.0 } else { f32::from_bits(4) },
                    type_mask: if ap {
                        mav::PositionTargetTypemask::from_bits_truncate(0xFFF8)
                    } else {
                        mav::PositionTargetTypemask::empty()
                    },
                    coordinate_frame: if ap {
                        mav::MavFrame::MAV_FRAME_GLOBAL
                    } else {
                        mav::MavFrame::MAV_FRAME_GLOBAL_INT
                    },
                })
            }
            // ---------------------------------------------------------------- ArduPilot
            x if x == id!(POWER_STATUS_DATA) => MavMessage::POWER_STATUS(mav::POWER_STATUS_DATA {
                Vcc: 5000,
                Vservo: 0,
                flags: mav::MavPowerStatus::empty(),
            }),
            x if x == id!(MEMINFO_DATA) => MavMessage::MEMINFO(mav::MEMINFO_DATA {
                brkval: 0,
                freemem: 65535,
                freemem32: 524_288,
            }),
            x if x == id!(SIMSTATE_DATA) => {
                let (tlat, tlon, _) = self.true_position();
                MavMessage::SIMSTATE(mav::SIMSTATE_DATA {
                    roll,
                    pitch,
                    yaw,
                    xacc: wobble(now, 9.0, 2e-4),
                    yacc: wobble(now, 10.0, 2e-4),
                    zacc: -motion::G as f32,
                    xgyro: wobble(now, 11.0, 1e-3),
                    ygyro: wobble(now, 12.0, 1e-3),
                    zgyro: wobble(now, 13.0, 1e-4),
                    lat: (tlat * 1e7).round() as i32,
                    lng: (tlon * 1e7).round() as i32,
                })
            }
            x if x == id!(AHRS_DATA) => MavMessage::AHRS(mav::AHRS_DATA {
                omegaIx: -wobble(now, 14.0, 1.5e-3),
                omegaIy: -wobble(now, 15.0, 1.5e-3),
                omegaIz: -wobble(now, 16.0, 1.0e-3),
                accel_weight: 0.0,
                renorm_val: 0.0,
                error_rp: wobble(now, 17.0, 1.5e-3),
                error_yaw: wobble(now, 18.0, 1.0e-3),
            }),
            x if x == id!(AHRS2_DATA) => MavMessage::AHRS2(mav::AHRS2_DATA {
                roll,
                pitch,
                yaw,
                altitude: amsl as f32,
                lat: lat_e7,
                lng: lon_e7,
            }),
            x if x == id!(ESC_TELEMETRY_1_TO_4_DATA) => {
                // SITL's simulated ESCs (copters only)
                if !(ap && copter) {
                    return None;
                }
                let volts = (self.power.battery.voltage() * 100.0).round() as u16;
                let amps = (self.power.battery.current_a * 25.0).round() as u16;
                MavMessage::ESC_TELEMETRY_1_TO_4(mav::ESC_TELEMETRY_1_TO_4_DATA {
                    voltage: [volts; 4],
                    current: [amps; 4],
                    totalcurrent: [(self.power.battery.consumed_mah / 4.0).round() as u16; 4],
                    rpm: [0; 4],
                    count: [(tb / 400) as u16; 4],
                    temperature: [32; 4],
                })
            }
            x if x == id!(WIND_DATA) => {
                if !(ap && copter && self.position_ok(now)) {
                    return None;
                }
                let (wn, we) = self.wind_ne();
                let speed = we.hypot(wn);
                MavMessage::WIND(mav::WIND_DATA {
                    // the direction the wind comes from, degrees; −180 in calm air
                    direction: if speed > 0.0 {
                        (-we).atan2(-wn).to_degrees() as f32
                    } else {
                        -180.0
                    },
                    speed: speed as f32,
                    speed_z: 0.0,
                })
            }
            x if x == id!(TERRAIN_REPORT_DATA) => {
                if !(ap && copter) {
                    return None;
                }
                // one block: its squares pending and loaded (a real ArduCopter counts 9 and
                // more, `AP_Terrain::get_statistics`)
                self.telemetry.terrain.at(lat_e7, lon_e7);
                let t = self.telemetry.terrain;
                let loaded = t.have.count_ones() as u16;
                MavMessage::TERRAIN_REPORT(mav::TERRAIN_REPORT_DATA {
                    lat: lat_e7,
                    lon: lon_e7,
                    terrain_height: 0.0,
                    current_height: amsl as f32,
                    spacing: if t.complete() {
                        super::terrain::Terrain::SPACING
                    } else {
                        0
                    },
                    pending: u16::from(fleetmap_core::terrain::grid::BITS) - loaded,
                    loaded,
                })
            }
            x if x == id!(TERRAIN_REQUEST_DATA) => {
                // AP_Terrain asks the GCS for the squares of its block it lacks, at most every
                // 2 s (measured: 0.5 Hz with EXTRA3 at 2 Hz), and nothing once it has them
                if !(ap && copter)
                    || self
                        .telemetry
                        .terrain_request_at
                        .is_some_and(|t| now.saturating_since(t) < Duration::from_secs(2))
                {
                    return None;
                }
                let (lat, lon) = self.telemetry.terrain.at(lat_e7, lon_e7);
                let mask = super::terrain::Terrain::ALL & !self.telemetry.terrain.have;
                if mask == 0 {
                    return None;
                }
                self.telemetry.terrain_request_at = Some(now);
                MavMessage::TERRAIN_REQUEST(mav::TERRAIN_REQUEST_DATA {
                    mask,
                    lat,
                    lon,
                    grid_spacing: super::terrain::Terrain::SPACING,
                })
            }
            x if x == id!(EKF_STATUS_REPORT_DATA) => {
                let flags = if self.position_ok(now) { 0x33F } else { 0x0A7 };
                MavMessage::EKF_STATUS_REPORT(mav::EKF_STATUS_REPORT_DATA {
                    velocity_variance: wobble(now, 19.0, 4e-3),
                    pos_horiz_variance: wobble(now, 20.0, 2e-3),
                    pos_vert_variance: wobble(now, 21.0, 1e-4),
                    compass_variance: wobble(now, 22.0, 1.5e-2),
                    terrain_alt_variance: 0.0,
                    flags: mav::EkfStatusFlags::from_bits_truncate(flags),
                    airspeed_variance: 0.0,
                })
            }
            x if x == id!(RAW_IMU_DATA) => MavMessage::RAW_IMU(mav::RAW_IMU_DATA {
                time_usec: t_us,
                xacc: 0,
                yacc: 0,
                zacc: -1000,
                xgyro: 1,
                ygyro: 1,
                zgyro: 1,
                xmag: 195,
                ymag: 18,
                zmag: -510,
                id: 0,
                temperature: 4500,
            }),
            x if x == id!(SCALED_IMU2_DATA) => MavMessage::SCALED_IMU2(mav::SCALED_IMU2_DATA {
                time_boot_ms: tb,
                xacc: 0,
                yacc: 0,
                zacc: -1000,
                xgyro: 1,
                ygyro: 1,
                zgyro: 1,
                xmag: 195,
                ymag: 18,
                zmag: -510,
                temperature: 4500,
            }),
            x if x == id!(SCALED_IMU3_DATA) => MavMessage::SCALED_IMU3(mav::SCALED_IMU3_DATA {
                time_boot_ms: tb,
                xacc: 0,
                yacc: 0,
                zacc: -1000,
                xgyro: 1,
                ygyro: 1,
                zgyro: 1,
                xmag: 195,
                ymag: 18,
                zmag: -510,
                temperature: 0,
            }),
            x if x == id!(RC_CHANNELS_DATA) => {
                if !ap {
                    return None; // PX4 SIH has no RC
                }
                MavMessage::RC_CHANNELS(mav::RC_CHANNELS_DATA {
                    time_boot_ms: tb,
                    chan1_raw: 1500,
                    chan2_raw: 1500,
                    chan3_raw: if copter { 1000 } else { 1500 },
                    chan4_raw: 1500,
                    chan5_raw: 1800,
                    chan6_raw: 1000,
                    chan7_raw: 1000,
                    chan8_raw: 1800,
                    chan9_raw: 0,
                    chan10_raw: 0,
                    chan11_raw: 0,
                    chan12_raw: 0,
                    chan13_raw: 0,
                    chan14_raw: 0,
                    chan15_raw: 0,
                    chan16_raw: 0,
                    chan17_raw: 0,
                    chan18_raw: 0,
                    chancount: 16,
                    rssi: 255,
                })
            }
            x if x == id!(RC_CHANNELS_SCALED_DATA) => {
                if !ap || copter {
                    return None; // ArduRover's SERVO_OUT
                }
                MavMessage::RC_CHANNELS_SCALED(mav::RC_CHANNELS_SCALED_DATA {
                    time_boot_ms: tb,
                    port: 0,
                    rssi: 255,
                    ..mav::RC_CHANNELS_SCALED_DATA::default()
                })
            }
            x if x == id!(FENCE_STATUS_DATA) => {
                if !self.geofence.enabled {
                    return None;
                }
                MavMessage::FENCE_STATUS(mav::FENCE_STATUS_DATA {
                    breach_time: 0,
                    breach_count: 0,
                    breach_status: u8::from(self.geofence.breached),
                    breach_type: mav::FenceBreach::FENCE_BREACH_NONE,
                    breach_mitigation: mav::FenceMitigate::FENCE_MITIGATE_NONE,
                })
            }
            // ---------------------------------------------------------------- PX4
            x if x == id!(ALTITUDE_DATA) => MavMessage::ALTITUDE(mav::ALTITUDE_DATA {
                time_usec: t_us,
                altitude_monotonic: amsl as f32,
                altitude_amsl: amsl as f32,
                altitude_local: u as f32,
                altitude_relative: (amsl - home.map_or(self.ground_amsl(), |h| h.alt_amsl)) as f32,
                altitude_terrain: wobble(now, 23.0, 0.02),
                bottom_clearance: u as f32 + wobble(now, 24.0, 0.02),
            }),
            x if x == id!(ATTITUDE_QUATERNION_DATA) => {
                let q = quaternion(m.roll_deg, m.pitch_deg, m.heading_deg);
                MavMessage::ATTITUDE_QUATERNION(mav::ATTITUDE_QUATERNION_DATA {
                    time_boot_ms: tb,
                    q1: q[0],
                    q2: q[1],
                    q3: q[2],
                    q4: q[3],
                    rollspeed: wobble(now, 25.0, 1e-3),
                    pitchspeed: wobble(now, 26.0, 1e-3),
                    yawspeed: wobble(now, 27.0, 1e-3),
                    repr_offset_q: [0.0; 4],
                })
            }
            x if x == id!(ATTITUDE_TARGET_DATA) => {
                MavMessage::ATTITUDE_TARGET(mav::ATTITUDE_TARGET_DATA {
                    time_boot_ms: tb,
                    q: quaternion(m.roll_deg, m.pitch_deg, m.heading_deg),
                    body_roll_rate: wobble(now, 28.0, 1e-3),
                    body_pitch_rate: wobble(now, 29.0, 1e-3),
                    body_yaw_rate: wobble(now, 30.0, 1e-3),
                    thrust: if armed { 0.48 } else { 0.0 } + wobble(now, 31.0, 1e-3),
                    type_mask: mav::AttitudeTargetTypemask::empty(),
                })
            }
            x if x == id!(POSITION_TARGET_LOCAL_NED_DATA) => {
                let (e, n) = self.est();
                let (he, hn) = home.map_or((e, n), |h| (h.e, h.n));
                let t = self.guided_target().unwrap_or(Point { e, n, u });
                MavMessage::POSITION_TARGET_LOCAL_NED(mav::POSITION_TARGET_LOCAL_NED_DATA {
                    time_boot_ms: tb,
                    x: (t.n - hn) as f32,
                    y: (t.e - he) as f32,
                    z: -t.u as f32,
                    vx: m.vn as f32,
                    vy: m.ve as f32,
                    vz: -m.vu as f32,
                    afx: wobble(now, 32.0, 0.01),
                    afy: wobble(now, 33.0, 0.01),
                    afz: wobble(now, 34.0, 0.01),
                    yaw,
                    yaw_rate: f32::from_bits(4),
                    type_mask: mav::PositionTargetTypemask::empty(),
                    coordinate_frame: mav::MavFrame::MAV_FRAME_LOCAL_NED,
                })
            }
            x if x == id!(ESTIMATOR_STATUS_DATA) => {
                MavMessage::ESTIMATOR_STATUS(mav::ESTIMATOR_STATUS_DATA {
                    time_usec: t_us,
                    vel_ratio: wobble(now, 35.0, 0.1),
                    pos_horiz_ratio: wobble(now, 36.0, 0.03),
                    pos_vert_ratio: wobble(now, 37.0, 0.03),
                    mag_ratio: wobble(now, 38.0, 0.1),
                    hagl_ratio: wobble(now, 39.0, 0.01),
                    tas_ratio: f32::NAN,
                    pos_horiz_accuracy: 0.28,
                    pos_vert_accuracy: 0.28,
                    flags: mav::EstimatorStatusFlags::from_bits_truncate(
                        if self.position_ok(now) { 895 } else { 0x27 },
                    ),
                })
            }
            x if x == id!(OPEN_DRONE_ID_LOCATION_DATA) => {
                MavMessage::OPEN_DRONE_ID_LOCATION(mav::OPEN_DRONE_ID_LOCATION_DATA {
                    latitude: lat_e7,
                    longitude: lon_e7,
                    altitude_barometric: amsl as f32,
                    altitude_geodetic: amsl.round() as f32,
                    height: u as f32,
                    timestamp: 65535.0,
                    direction: (m.heading_deg * 100.0).round() as u16 % 36000,
                    speed_horizontal: (m.ground_speed() * 100.0).round() as u16,
                    speed_vertical: (m.vu * 100.0).round() as i16,
                    target_system: 0,
                    target_component: 0,
                    id_or_mac: [0; 20],
                    status: if flying {
                        mav::MavOdidStatus::MAV_ODID_STATUS_AIRBORNE
                    } else {
                        mav::MavOdidStatus::MAV_ODID_STATUS_GROUND
                    },
                    height_reference: mav::MavOdidHeightRef::MAV_ODID_HEIGHT_REF_OVER_TAKEOFF,
                    horizontal_accuracy: mav::MavOdidHorAcc::MAV_ODID_HOR_ACC_1_METER,
                    vertical_accuracy: mav::MavOdidVerAcc::MAV_ODID_VER_ACC_3_METER,
                    barometer_accuracy: mav::MavOdidVerAcc::MAV_ODID_VER_ACC_UNKNOWN,
                    speed_accuracy: mav::MavOdidSpeedAcc::MAV_ODID_SPEED_ACC_1_METERS_PER_SECOND,
                    timestamp_accuracy: mav::MavOdidTimeAcc::MAV_ODID_TIME_ACC_UNKNOWN,
                })
            }
            x if x == id!(OPEN_DRONE_ID_SYSTEM_DATA) => {
                let (hlat, hlon, halt) =
                    home.map_or((lat, lon, amsl), |h| (h.lat, h.lon, h.alt_amsl));
                MavMessage::OPEN_DRONE_ID_SYSTEM(mav::OPEN_DRONE_ID_SYSTEM_DATA {
                    operator_latitude: (hlat * 1e7).round() as i32,
                    operator_longitude: (hlon * 1e7).round() as i32,
                    area_ceiling: -1000.0,
                    area_floor: -1000.0,
                    operator_altitude_geo: halt as f32,
                    timestamp: (tb / 1000).wrapping_add(0xA3D7_0000),
                    area_count: 1,
                    area_radius: 0,
                    ..mav::OPEN_DRONE_ID_SYSTEM_DATA::default()
                })
            }
            x if x == id!(DISTANCE_SENSOR_DATA) => {
                if ap {
                    return None; // SIH's rangefinder; ArduPilot SITL has none configured
                }
                MavMessage::DISTANCE_SENSOR(mav::DISTANCE_SENSOR_DATA {
                    time_boot_ms: tb,
                    min_distance: 0,
                    max_distance: 10_000,
                    current_distance: (u * 100.0).round().clamp(1.0, 10_000.0) as u16,
                    mavtype: mav::MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER,
                    id: 0,
                    orientation: mav::MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_270,
                    covariance: 0,
                    ..mav::DISTANCE_SENSOR_DATA::default()
                })
            }
            x if x == id!(PING_DATA) => {
                self.telemetry.ping_seq = self.telemetry.ping_seq.wrapping_add(1);
                MavMessage::PING(mav::PING_DATA {
                    time_usec: t_us,
                    seq: self.telemetry.ping_seq,
                    target_system: 0,
                    target_component: 0,
                })
            }
            x if x == id!(LINK_NODE_STATUS_DATA) => {
                // PX4's own link statistics: rates from the counts since the last report
                // (about 30 bytes a message)
                let c = self.telemetry.link_counts;
                let (tx_rate, rx_rate) = match c.last {
                    Some((t, s, r)) if now > t => {
                        let dt = now.saturating_since(t).as_secs_f64();
                        (
                            (f64::from(c.sent.wrapping_sub(s)) * 30.0 / dt) as u32,
                            (f64::from(c.received.wrapping_sub(r)) * 30.0 / dt) as u32,
                        )
                    }
                    _ => (0, 0),
                };
                self.telemetry.link_counts.last = Some((now, c.sent, c.received));
                MavMessage::LINK_NODE_STATUS(mav::LINK_NODE_STATUS_DATA {
                    timestamp: t_us,
                    tx_rate,
                    rx_rate,
                    messages_sent: c.sent,
                    messages_received: c.received,
                    messages_lost: 0,
                    rx_parse_err: 0,
                    tx_overflows: 0,
                    rx_overflows: 0,
                    tx_buf: 0,
                    rx_buf: 0,
                })
            }
            // GPS_GLOBAL_ORIGIN is sent once, when the origin is set ([`Self::origin_msg`])
            _ => return None,
        })
    }

    /// GPS_GLOBAL_ORIGIN: where the estimator's origin was set (once the position estimate
    /// is ready; ArduPilot and PX4 send it then, not as a stream).
    pub(super) fn origin_msg(&self, now: Time) -> MavMessage {
        let h = self.flight.home;
        let (lat, lon, alt) = h.map_or((0.0, 0.0, 0.0), |h| (h.lat, h.lon, h.alt_amsl));
        MavMessage::GPS_GLOBAL_ORIGIN(mav::GPS_GLOBAL_ORIGIN_DATA {
            latitude: (lat * 1e7).round() as i32,
            longitude: (lon * 1e7).round() as i32,
            altitude: (alt * 1000.0).round() as i32,
            time_usec: now.saturating_since(self.power.boot_time).as_micros() as u64,
        })
    }

    /// ArduPilot's TIMESYNC request (tc1 0, ts1 its time since boot in ns).
    pub(super) fn timesync_msg(&self, now: Time) -> MavMessage {
        MavMessage::TIMESYNC(mav::TIMESYNC_DATA {
            tc1: 0,
            ts1: now.saturating_since(self.power.boot_time).as_nanos() as i64,
            target_system: 0,
            target_component: 0,
        })
    }

    /// Where the vehicle is being flown to (a guided or mission target), if anywhere.
    fn guided_target(&self) -> Option<Point> {
        match self.flight.nav {
            Nav::Goto { p, .. } => Some(p),
            _ => None,
        }
    }

    /// Bearing (degrees, −180..180) and distance (m) to the navigation target; 0, 0 without.
    fn nav_target_bearing_distance(&self) -> (i16, u16) {
        match self.guided_target() {
            Some(t) => {
                let (e, n) = self.est();
                let (de, dn) = (t.e - e, t.n - n);
                (
                    de.atan2(dn).to_degrees().round() as i16,
                    de.hypot(dn).round().min(65_535.0) as u16,
                )
            }
            None => (0, 0),
        }
    }
}

/// An angle in (−π, π].
fn wrap_pi(a: f64) -> f64 {
    use std::f64::consts::PI;
    let r = a.rem_euclid(2.0 * PI);
    if r > PI { r - 2.0 * PI } else { r }
}

/// The attitude quaternion (w, x, y, z) of roll, pitch and yaw in degrees.
fn quaternion(roll_deg: f64, pitch_deg: f64, yaw_deg: f64) -> [f32; 4] {
    let (sr, cr) = (roll_deg.to_radians() / 2.0).sin_cos();
    let (sp, cp) = (pitch_deg.to_radians() / 2.0).sin_cos();
    let (sy, cy) = (wrap_pi(yaw_deg.to_radians()) / 2.0).sin_cos();
    [
        (cr * cp * cy + sr * sp * sy) as f32,
        (sr * cp * cy - cr * sp * sy) as f32,
        (cr * sp * cy + sr * cp * sy) as f32,
        (cr * cp * sy - sr * sp * cy) as f32,
    ]
}
