//! PX4's schedule: Normal-mode streams and the rate multiplier (see the parent module).

use super::next_time;
use fleetmap_core::time::Time;
use std::time::Duration;

/// The PX4 MAVLink instance the GCS talks to: the options of its `mavlink start`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Px4Link {
    /// `-r`: the most bytes per second its streams may use (MAV_x_RATE).
    pub rate_bps: u32,
    /// `-s`: streams slow down by RADIO_STATUS.txbuf (MAV_x_RADIO_CTL).
    pub radio_ctl: bool,
    /// The `mavlink stream -r 50 …` lines of the SITL's startup (`px4-rc.mavlink`): seven
    /// streams at 50 Hz on the GCS link, for its 3-D viewers.
    pub sitl_overrides: bool,
}

impl Px4Link {
    /// A telemetry radio on TELEM1: MAV_0_RATE 1200 B/s, MAV_0_RADIO_CTL on (PX4's defaults,
    /// `src/modules/mavlink/module.yaml`). What a field vehicle has.
    pub const TELEM1: Px4Link = Px4Link {
        rate_bps: 1200,
        radio_ctl: true,
        sitl_overrides: false,
    };
    /// A Normal-mode instance on a network link (MAV_x_RATE 0 on Ethernet: 100 000 B/s, so its
    /// streams keep their rates; MAV_x_RADIO_CTL on): the simulator's default, what its PX4
    /// vehicles did before radios were modelled.
    pub const NETWORK: Px4Link = Px4Link {
        rate_bps: 100_000,
        radio_ctl: true,
        sitl_overrides: false,
    };
    /// The SITL's GCS link on UDP: `-r 4000000`, no `-s`, the 50 Hz overrides
    /// (`ROMFS/px4fmu_common/init.d-posix/px4-rc.mavlink`).
    pub const SITL_UDP: Px4Link = Px4Link {
        rate_bps: 4_000_000,
        radio_ctl: false,
        sitl_overrides: true,
    };
}

/// One PX4 stream.
#[derive(Clone, Copy, Debug)]
struct Px4Stream {
    /// The message it sends.
    id: u32,
    /// Interval, µs (> 0).
    interval_us: u32,
    /// When it was last (due to be) sent.
    last_sent: Time,
    /// Not sent yet: a new stream sends its first message at once (`MavlinkStream::update`).
    fresh: bool,
    /// Bytes counted for it: the full message length (0: it has no data yet).
    size: u32,
    /// HEARTBEAT and PING are not scaled by the rate multiplier (`const_rate`).
    const_rate: bool,
}

/// PX4's Normal-mode streams that SIH produces data for, Hz
/// (`Mavlink::configure_streams_to_default`, MAVLINK_MODE_NORMAL): the rest of the list
/// (ADSB_VEHICLE, ESC_STATUS, GPS2_RAW, RC_CHANNELS without RC, …) sends nothing and counts
/// nothing. GPS_GLOBAL_ORIGIN, NAV_CONTROLLER_OUTPUT and POSITION_TARGET_GLOBAL_INT count for
/// the bandwidth multiplier but send only on a change, in AUTO modes, or in flight.
fn px4_normal_streams() -> [(u32, f32, u32); 27] {
    [
        (id!(HEARTBEAT_DATA), 1.0, full_len!(HEARTBEAT_DATA)),
        (id!(ALTITUDE_DATA), 1.0, full_len!(ALTITUDE_DATA)),
        (id!(ATTITUDE_DATA), 15.0, full_len!(ATTITUDE_DATA)),
        (
            id!(ATTITUDE_QUATERNION_DATA),
            10.0,
            full_len!(ATTITUDE_QUATERNION_DATA),
        ),
        (
            id!(ATTITUDE_TARGET_DATA),
            2.0,
            full_len!(ATTITUDE_TARGET_DATA),
        ),
        (
            id!(BATTERY_STATUS_DATA),
            0.5,
            full_len!(BATTERY_STATUS_DATA),
        ),
        (
            id!(DISTANCE_SENSOR_DATA),
            0.5,
            full_len!(DISTANCE_SENSOR_DATA),
        ),
        (
            id!(ESTIMATOR_STATUS_DATA),
            0.5,
            full_len!(ESTIMATOR_STATUS_DATA),
        ),
        (
            id!(EXTENDED_SYS_STATE_DATA),
            1.0,
            full_len!(EXTENDED_SYS_STATE_DATA),
        ),
        (
            id!(GLOBAL_POSITION_INT_DATA),
            5.0,
            full_len!(GLOBAL_POSITION_INT_DATA),
        ),
        (
            id!(GPS_GLOBAL_ORIGIN_DATA),
            1.0,
            full_len!(GPS_GLOBAL_ORIGIN_DATA),
        ),
        (id!(GPS_RAW_INT_DATA), 5.0, full_len!(GPS_RAW_INT_DATA)),
        (id!(HOME_POSITION_DATA), 0.5, full_len!(HOME_POSITION_DATA)),
        (
            id!(LINK_NODE_STATUS_DATA),
            1.0,
            full_len!(LINK_NODE_STATUS_DATA),
        ),
        (
            id!(LOCAL_POSITION_NED_DATA),
            1.0,
            full_len!(LOCAL_POSITION_NED_DATA),
        ),
        (
            id!(NAV_CONTROLLER_OUTPUT_DATA),
            1.0,
            full_len!(NAV_CONTROLLER_OUTPUT_DATA),
        ),
        (
            id!(OPEN_DRONE_ID_LOCATION_DATA),
            1.0,
            full_len!(OPEN_DRONE_ID_LOCATION_DATA),
        ),
        (
            id!(OPEN_DRONE_ID_SYSTEM_DATA),
            1.0,
            full_len!(OPEN_DRONE_ID_SYSTEM_DATA),
        ),
        (id!(PING_DATA), 0.1, full_len!(PING_DATA)),
        (
            id!(POSITION_TARGET_GLOBAL_INT_DATA),
            1.0,
            full_len!(POSITION_TARGET_GLOBAL_INT_DATA),
        ),
        (
            id!(POSITION_TARGET_LOCAL_NED_DATA),
            1.5,
            full_len!(POSITION_TARGET_LOCAL_NED_DATA),
        ),
        (
            id!(SCALED_PRESSURE_DATA),
            1.0,
            full_len!(SCALED_PRESSURE_DATA),
        ),
        (
            id!(SERVO_OUTPUT_RAW_DATA),
            1.0,
            full_len!(SERVO_OUTPUT_RAW_DATA),
        ),
        (id!(SYS_STATUS_DATA), 1.0, full_len!(SYS_STATUS_DATA)),
        (id!(VFR_HUD_DATA), 4.0, full_len!(VFR_HUD_DATA)),
        (id!(VIBRATION_DATA), 0.1, full_len!(VIBRATION_DATA)),
        (id!(WIND_COV_DATA), 0.0, full_len!(WIND_COV_DATA)),
    ]
}

/// The streams `px4-rc.mavlink` sets to 50 Hz on the SITL's GCS link (RC_CHANNELS at 20 Hz and
/// OPTICAL_FLOW_RAD at 10 Hz send nothing in SIH).
const PX4_SITL_50HZ: [u32; 7] = [
    id!(POSITION_TARGET_LOCAL_NED_DATA),
    id!(LOCAL_POSITION_NED_DATA),
    id!(GLOBAL_POSITION_INT_DATA),
    id!(ATTITUDE_DATA),
    id!(ATTITUDE_QUATERNION_DATA),
    id!(ATTITUDE_TARGET_DATA),
    id!(SERVO_OUTPUT_RAW_DATA),
];

/// Message ids PX4 has a stream for that the simulator produces nothing for (no sensor or
/// state behind them in SIH): SET_MESSAGE_INTERVAL accepts them (and they send nothing);
/// an id in neither list is refused with FAILED, as MISSION_CURRENT or EKF_STATUS_REPORT are.
const PX4_SILENT: &[u32] = &[
    id!(ADSB_VEHICLE_DATA),
    id!(ACTUATOR_OUTPUT_STATUS_DATA),
    id!(CAMERA_TRIGGER_DATA),
    id!(ESC_INFO_DATA),
    id!(ESC_STATUS_DATA),
    id!(GPS2_RAW_DATA),
    id!(GPS_STATUS_DATA),
    id!(HIGHRES_IMU_DATA),
    id!(HIL_ACTUATOR_CONTROLS_DATA),
    id!(MOUNT_ORIENTATION_DATA),
    id!(OBSTACLE_DISTANCE_DATA),
    id!(OPTICAL_FLOW_RAD_DATA),
    id!(ORBIT_EXECUTION_STATUS_DATA),
    id!(RAW_RPM_DATA),
    id!(RC_CHANNELS_DATA),
    id!(SCALED_IMU_DATA),
    id!(SCALED_IMU2_DATA),
    id!(SCALED_IMU3_DATA),
    id!(SCALED_PRESSURE2_DATA),
    id!(SYSTEM_TIME_DATA),
    id!(TIMESYNC_DATA),
    id!(UTM_GLOBAL_POSITION_DATA),
    id!(WIND_COV_DATA),
    id!(ODOMETRY_DATA),
    id!(DEBUG_DATA),
    id!(NAMED_VALUE_FLOAT_DATA),
    id!(GIMBAL_DEVICE_ATTITUDE_STATUS_DATA),
    id!(GIMBAL_MANAGER_STATUS_DATA),
    id!(COMPONENT_INFORMATION_DATA),
];

/// PX4's MAV_RADIO_TOUT default: without RADIO_STATUS for this long the radio multiplier is
/// reset.
const PX4_RADIO_TIMEOUT: Duration = Duration::from_secs(5);

/// PX4's message schedule on one MAVLink instance (`Mavlink`, `MavlinkStream`).
#[derive(Clone, Debug)]
pub(crate) struct Px4Schedule {
    /// The instance's options.
    link: Px4Link,
    /// Configured streams.
    streams: Vec<Px4Stream>,
    /// The radio multiplier (`_radio_status_mult`) and the last RADIO_STATUS.
    radio_mult: f32,
    radio_at: Option<Time>,
    /// The rate multiplier in force.
    rate_mult: f32,
    /// MISSION_CURRENT's 1 Hz (the mission manager's own timer).
    mission_current_at: Time,
    /// The earliest time any stream is due (a cache; None: recompute).
    next_due: Option<Time>,
}

impl Px4Schedule {
    /// The streams of a Normal-mode instance with `link`'s options, from `now`.
    pub(crate) fn new(link: Px4Link, now: Time) -> Px4Schedule {
        let mut s = Px4Schedule {
            link,
            streams: Vec::new(),
            radio_mult: 1.0,
            radio_at: None,
            rate_mult: 1.0,
            mission_current_at: now,
            next_due: None,
        };
        for (id, hz, size) in px4_normal_streams() {
            if hz > 0.0 {
                s.configure(id, hz_to_us(hz), size, now);
            }
        }
        if link.sitl_overrides {
            for id in PX4_SITL_50HZ {
                s.configure(id, 20_000, 0, now);
            }
        }
        s.update_rate_mult(now);
        s
    }

    fn configure(&mut self, id: u32, interval_us: u32, size: u32, now: Time) {
        self.next_due = None;
        if let Some(st) = self.streams.iter_mut().find(|s| s.id == id) {
            st.interval_us = interval_us;
            return;
        }
        let size = if size > 0 {
            size
        } else {
            px4_normal_streams()
                .iter()
                .find(|(i, _, _)| *i == id)
                .map_or(0, |(_, _, s)| *s)
        };
        self.streams.push(Px4Stream {
            id,
            interval_us,
            last_sent: now,
            fresh: true,
            size,
            const_rate: id == id!(HEARTBEAT_DATA) || id == id!(PING_DATA),
        });
    }

    /// Whether PX4 has a stream for `id`.
    fn knows(id: u32) -> bool {
        px4_normal_streams().iter().any(|(i, _, _)| *i == id) || PX4_SILENT.contains(&id)
    }

    /// SET_MESSAGE_INTERVAL (`MavlinkReceiver::set_message_interval`): −1 (or any negative)
    /// stops the stream, 0 restores its Normal-mode rate (none: stops it), else the interval in
    /// µs; false (FAILED) for an id PX4 streams nothing for.
    pub(crate) fn set_message_interval(&mut self, id: u32, interval_us: f32, now: Time) -> bool {
        if !Self::knows(id) {
            return false;
        }
        if interval_us < 0.0 {
            self.streams.retain(|s| s.id != id);
            self.next_due = None;
        } else if interval_us == 0.0 {
            match px4_normal_streams().iter().find(|(i, _, _)| *i == id) {
                Some(&(_, hz, size)) if hz > 0.0 => self.configure(id, hz_to_us(hz), size, now),
                _ => {
                    self.streams.retain(|s| s.id != id);
                    self.next_due = None;
                }
            }
        } else {
            self.configure(id, interval_us.max(1.0) as u32, 0, now);
        }
        self.update_rate_mult(now);
        true
    }

    /// GET_MESSAGE_INTERVAL: the configured interval in µs, 0 for a message not streamed
    /// (PX4 answers 0, also for an unknown id, and accepts the command).
    pub(crate) fn get_message_interval(&self, id: u32) -> i32 {
        self.streams
            .iter()
            .find(|s| s.id == id)
            .map_or(0, |s| s.interval_us.min(i32::MAX as u32) as i32)
    }

    /// A RADIO_STATUS arrived (`Mavlink::update_radio_status`).
    pub(crate) fn radio_status(&mut self, txbuf: u8, now: Time) {
        self.radio_at = Some(now);
        if self.link.radio_ctl {
            if txbuf < 25 {
                self.radio_mult *= 0.8;
            } else if txbuf < 35 {
                self.radio_mult *= 0.975;
            } else if txbuf > 50 {
                self.radio_mult *= 1.025;
            }
            self.radio_mult = self.radio_mult.clamp(0.01, 1.0);
        }
        self.update_rate_mult(now);
    }

    /// `Mavlink::update_rate_mult`.
    fn update_rate_mult(&mut self, now: Time) {
        let (mut const_bps, mut var_bps) = (0.0f32, 0.0f32);
        for s in &self.streams {
            let bps = s.size as f32 * 1e6 / s.interval_us as f32;
            if s.const_rate {
                const_bps += bps;
            } else {
                var_bps += bps;
            }
        }
        let bandwidth = if var_bps > 0.0 {
            ((self.link.rate_bps as f32 - const_bps) / var_bps).min(1.0)
        } else {
            1.0
        };
        let mut hardware = 1.0f32;
        if let Some(t) = self.radio_at {
            if now.saturating_since(t) > PX4_RADIO_TIMEOUT {
                self.radio_at = None;
                if self.link.radio_ctl {
                    self.radio_mult = 1.0;
                }
            } else {
                hardware = self.radio_mult;
            }
        }
        let m = bandwidth.min(hardware).clamp(0.05, 1.0);
        if m != self.rate_mult {
            self.rate_mult = m;
            self.next_due = None;
        }
    }

    /// The rate multiplier in force (0.05–1).
    #[cfg(test)]
    pub(crate) fn rate_mult(&self) -> f32 {
        self.rate_mult
    }

    /// The messages due at `now`, in `out`. PX4's loop runs faster than the simulator's 20 Hz
    /// step, so a stream sends as many as have come due since the last step (at most three)
    /// and keeps its average rate; one still a whole interval late after that starts again
    /// from now.
    pub(crate) fn due(&mut self, now: Time, out: &mut Vec<u32>) {
        if self.radio_at.is_some() {
            self.update_rate_mult(now);
        }
        if now.saturating_since(self.mission_current_at) >= Duration::from_secs(1) {
            self.mission_current_at =
                next_time(self.mission_current_at, Duration::from_secs(1), now);
            out.push(id!(MISSION_CURRENT_DATA));
        }
        if self.next_due.is_some_and(|t| now < t) {
            return;
        }
        let mut next: Option<Time> = None;
        for s in &mut self.streams {
            let us = if s.const_rate {
                s.interval_us as f32
            } else {
                s.interval_us as f32 / self.rate_mult
            };
            let iv = Duration::from_micros(us.max(1.0) as u64);
            let mut n = 0;
            if s.fresh {
                s.fresh = false;
                s.last_sent = now;
                out.push(s.id);
                n = 1;
            }
            while now.saturating_since(s.last_sent) >= iv && n < 3 {
                n += 1;
                out.push(s.id);
                s.last_sent += iv;
            }
            if n > 0 && now.saturating_since(s.last_sent) >= iv {
                s.last_sent = now;
            }
            let due = s.last_sent + iv;
            next = Some(next.map_or(due, |t| t.min(due)));
        }
        self.next_due = next;
    }
}

fn hz_to_us(hz: f32) -> u32 {
    (1e6 / hz) as u32
}
