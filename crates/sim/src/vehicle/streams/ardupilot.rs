//! ArduPilot's schedule: stream groups, buckets, `stream_slowdown_ms` (see the parent module).

use super::{ms, next_time};
use crate::flavour::SimVehicleClass;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega as mav;
use std::time::Duration;

/// ArduPilot's stream groups, in `GCS_MAVLINK::streams` order (its MAVn_* rate parameters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ApGroup {
    /// MAVn_RAW_SENS.
    RawSensors,
    /// MAVn_EXT_STAT.
    ExtendedStatus,
    /// MAVn_RC_CHAN.
    RcChannels,
    /// MAVn_RAW_CTRL.
    RawController,
    /// MAVn_POSITION.
    Position,
    /// MAVn_EXTRA1.
    Extra1,
    /// MAVn_EXTRA2.
    Extra2,
    /// MAVn_EXTRA3.
    Extra3,
    /// MAVn_PARAMS.
    Params,
    /// MAVn_ADSB.
    Adsb,
}

impl ApGroup {
    /// Every group, in parameter order.
    pub(crate) const ALL: [ApGroup; 10] = [
        ApGroup::RawSensors,
        ApGroup::ExtendedStatus,
        ApGroup::RcChannels,
        ApGroup::RawController,
        ApGroup::Position,
        ApGroup::Extra1,
        ApGroup::Extra2,
        ApGroup::Extra3,
        ApGroup::Params,
        ApGroup::Adsb,
    ];

    /// The group a REQUEST_DATA_STREAM stream id names (None: ALL or unknown).
    pub(crate) fn of_stream_id(stream: u8) -> Option<ApGroup> {
        use mav::MavDataStream as S;
        Some(match stream {
            s if s == S::MAV_DATA_STREAM_RAW_SENSORS as u8 => ApGroup::RawSensors,
            s if s == S::MAV_DATA_STREAM_EXTENDED_STATUS as u8 => ApGroup::ExtendedStatus,
            s if s == S::MAV_DATA_STREAM_RC_CHANNELS as u8 => ApGroup::RcChannels,
            s if s == S::MAV_DATA_STREAM_RAW_CONTROLLER as u8 => ApGroup::RawController,
            s if s == S::MAV_DATA_STREAM_POSITION as u8 => ApGroup::Position,
            s if s == S::MAV_DATA_STREAM_EXTRA1 as u8 => ApGroup::Extra1,
            s if s == S::MAV_DATA_STREAM_EXTRA2 as u8 => ApGroup::Extra2,
            s if s == S::MAV_DATA_STREAM_EXTRA3 as u8 => ApGroup::Extra3,
            _ => return None,
        })
    }

    /// The MAVLink messages of the group (the `STREAM_*_msgs` lists of
    /// `GCS_MAVLink_Parameters.cpp` as built for SITL). Some send nothing on a vehicle
    /// without the sensor or state (GPS_RTK, FENCE_STATUS without a fence, …), as there.
    fn messages(self) -> &'static [u32] {
        const RAW_SENSORS: &[u32] = &[
            id!(RAW_IMU_DATA),
            id!(SCALED_IMU2_DATA),
            id!(SCALED_IMU3_DATA),
            id!(SCALED_PRESSURE_DATA),
            id!(SCALED_PRESSURE2_DATA),
            id!(SCALED_PRESSURE3_DATA),
        ];
        const EXTENDED_STATUS: &[u32] = &[
            id!(SYS_STATUS_DATA),
            id!(POWER_STATUS_DATA),
            id!(MEMINFO_DATA),
            id!(MISSION_CURRENT_DATA),
            id!(GPS_RAW_INT_DATA),
            id!(GPS_RTK_DATA),
            id!(GPS2_RAW_DATA),
            id!(GPS2_RTK_DATA),
            id!(NAV_CONTROLLER_OUTPUT_DATA),
            id!(FENCE_STATUS_DATA),
            id!(POSITION_TARGET_GLOBAL_INT_DATA),
        ];
        const RC_CHANNELS: &[u32] = &[
            id!(SERVO_OUTPUT_RAW_DATA),
            id!(RC_CHANNELS_DATA),
            id!(RC_CHANNELS_RAW_DATA),
        ];
        const RAW_CONTROLLER: &[u32] = &[id!(RC_CHANNELS_SCALED_DATA)];
        const POSITION: &[u32] = &[id!(GLOBAL_POSITION_INT_DATA), id!(LOCAL_POSITION_NED_DATA)];
        const EXTRA1: &[u32] = &[
            id!(ATTITUDE_DATA),
            id!(SIMSTATE_DATA),
            id!(AHRS2_DATA),
            id!(RPM_DATA),
            id!(PID_TUNING_DATA),
            id!(ESC_TELEMETRY_1_TO_4_DATA),
        ];
        const EXTRA2: &[u32] = &[id!(VFR_HUD_DATA)];
        const EXTRA3: &[u32] = &[
            id!(AHRS_DATA),
            id!(WIND_DATA),
            id!(RANGEFINDER_DATA),
            id!(DISTANCE_SENSOR_DATA),
            id!(SYSTEM_TIME_DATA),
            id!(TERRAIN_REPORT_DATA),
            id!(TERRAIN_REQUEST_DATA),
            id!(BATTERY_STATUS_DATA),
            id!(OPTICAL_FLOW_DATA),
            id!(MAG_CAL_REPORT_DATA),
            id!(MAG_CAL_PROGRESS_DATA),
            id!(EKF_STATUS_REPORT_DATA),
            id!(VIBRATION_DATA),
        ];
        const PARAMS: &[u32] = &[id!(PARAM_VALUE_DATA)];
        const ADSB: &[u32] = &[id!(ADSB_VEHICLE_DATA)];
        match self {
            ApGroup::RawSensors => RAW_SENSORS,
            ApGroup::ExtendedStatus => EXTENDED_STATUS,
            ApGroup::RcChannels => RC_CHANNELS,
            ApGroup::RawController => RAW_CONTROLLER,
            ApGroup::Position => POSITION,
            ApGroup::Extra1 => EXTRA1,
            ApGroup::Extra2 => EXTRA2,
            ApGroup::Extra3 => EXTRA3,
            ApGroup::Params => PARAMS,
            ApGroup::Adsb => ADSB,
        }
    }
}

/// The MAVLink ids ArduPilot can schedule (`GCS_MAVLINK::mavlink_id_to_ap_message_id`, the
/// ones of this dialect). SET_MESSAGE_INTERVAL of any other id is DENIED with "No ap_message
/// for mavlink id (N)". The simulator produces only some of them; the rest are scheduled and
/// send nothing, as on a vehicle without that sensor.
const AP_KNOWN: &[u32] = &[
    id!(HEARTBEAT_DATA),
    id!(HOME_POSITION_DATA),
    id!(GPS_GLOBAL_ORIGIN_DATA),
    id!(SYS_STATUS_DATA),
    id!(POWER_STATUS_DATA),
    id!(MEMINFO_DATA),
    id!(NAV_CONTROLLER_OUTPUT_DATA),
    id!(MISSION_CURRENT_DATA),
    id!(SERVO_OUTPUT_RAW_DATA),
    id!(RC_CHANNELS_DATA),
    id!(RC_CHANNELS_RAW_DATA),
    id!(RAW_IMU_DATA),
    id!(SCALED_IMU_DATA),
    id!(SCALED_IMU2_DATA),
    id!(SCALED_IMU3_DATA),
    id!(HIGHRES_IMU_DATA),
    id!(SCALED_PRESSURE_DATA),
    id!(SCALED_PRESSURE2_DATA),
    id!(SCALED_PRESSURE3_DATA),
    id!(GPS_RAW_INT_DATA),
    id!(GPS_RTK_DATA),
    id!(GPS2_RAW_DATA),
    id!(GPS2_RTK_DATA),
    id!(SYSTEM_TIME_DATA),
    id!(RC_CHANNELS_SCALED_DATA),
    id!(PARAM_VALUE_DATA),
    id!(FENCE_STATUS_DATA),
    id!(SIMSTATE_DATA),
    id!(SIM_STATE_DATA),
    id!(AHRS2_DATA),
    id!(AHRS_DATA),
    id!(ATTITUDE_DATA),
    id!(ATTITUDE_QUATERNION_DATA),
    id!(GLOBAL_POSITION_INT_DATA),
    id!(LOCAL_POSITION_NED_DATA),
    id!(VFR_HUD_DATA),
    id!(HWSTATUS_DATA),
    id!(WIND_DATA),
    id!(RANGEFINDER_DATA),
    id!(DISTANCE_SENSOR_DATA),
    id!(TERRAIN_REQUEST_DATA),
    id!(TERRAIN_REPORT_DATA),
    id!(CAMERA_FEEDBACK_DATA),
    id!(OPTICAL_FLOW_DATA),
    id!(MAG_CAL_PROGRESS_DATA),
    id!(MAG_CAL_REPORT_DATA),
    id!(EKF_STATUS_REPORT_DATA),
    id!(PID_TUNING_DATA),
    id!(VIBRATION_DATA),
    id!(RPM_DATA),
    id!(MISSION_ITEM_REACHED_DATA),
    id!(ATTITUDE_TARGET_DATA),
    id!(POSITION_TARGET_GLOBAL_INT_DATA),
    id!(POSITION_TARGET_LOCAL_NED_DATA),
    id!(ADSB_VEHICLE_DATA),
    id!(BATTERY_STATUS_DATA),
    id!(AOA_SSA_DATA),
    id!(DEEPSTALL_DATA),
    id!(EXTENDED_SYS_STATE_DATA),
    id!(AUTOPILOT_VERSION_DATA),
    id!(EFI_STATUS_DATA),
    id!(GENERATOR_STATUS_DATA),
    id!(WINCH_STATUS_DATA),
    id!(WATER_DEPTH_DATA),
    id!(HIGH_LATENCY2_DATA),
    id!(AIS_VESSEL_DATA),
    id!(ESC_TELEMETRY_1_TO_4_DATA),
    id!(NAMED_VALUE_FLOAT_DATA),
    id!(UAVIONIX_ADSB_OUT_STATUS_DATA),
    id!(RELAY_STATUS_DATA),
    id!(AVAILABLE_MODES_DATA),
    id!(CURRENT_MODE_DATA),
    id!(AIRSPEED_DATA),
    id!(WHEEL_DISTANCE_DATA),
];

/// The index of `id` in [`AP_KNOWN`] (the bit of a bucket's set).
fn ap_bit(id: u32) -> Option<u32> {
    AP_KNOWN.iter().position(|&k| k == id).map(|i| i as u32)
}

/// ArduPilot's HEARTBEAT id.
const HEARTBEAT: u32 = id!(HEARTBEAT_DATA);

/// The default rate of each group, Hz (the `AP_MAV_DEFAULT_STREAM_RATE_*` defaults of
/// `GCS_MAVLink_Parameters.cpp`): ArduCopter streams nothing, ArduRover everything at 1 Hz
/// and parameters at 10 Hz (which send only while a parameter list is requested).
fn ap_default_rates(kind: SimVehicleClass) -> [u16; 10] {
    match kind {
        SimVehicleClass::Copter => [0; 10],
        SimVehicleClass::Rover => [1, 1, 1, 1, 1, 1, 1, 1, 10, 0],
    }
}

/// One of ArduPilot's message buckets (`deferred_message_bucket_t`).
#[derive(Clone, Copy, Debug, Default)]
struct Bucket {
    /// Interval of every message in it, ms (0: the bucket is free).
    interval_ms: u16,
    /// When it was last (due to be) sent.
    last_sent: Time,
    /// Its messages: bits of [`AP_KNOWN`].
    ids: u128,
}

/// ArduPilot's message schedule on one GCS link (`GCS_MAVLINK`).
#[derive(Clone, Debug)]
pub(crate) struct ApSchedule {
    /// Rate of each stream group, Hz (the MAVn_* parameters, changed but not saved by
    /// REQUEST_DATA_STREAM).
    rates: [u16; 10],
    /// The ten buckets.
    buckets: [Bucket; 10],
    /// HEARTBEAT's own interval, ms (0: not sent) and last time.
    heartbeat: (u16, Time),
    /// No HEARTBEAT sent yet since boot: the first leaves at once.
    first_heartbeat: bool,
    /// Extra delay of every bucket, ms (RADIO_STATUS).
    slowdown_ms: u16,
    /// The last TIMESYNC request.
    timesync_at: Time,
    /// The shortest interval the scheduler can keep, ms: 0.8 × its loop rate
    /// (`cap_message_interval`; ArduCopter 400 Hz, ArduRover 50 Hz).
    min_interval_ms: u16,
}

/// Why ArduPilot refuses a SET_MESSAGE_INTERVAL (MAV_RESULT_DENIED).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ApRefusal {
    /// No ap_message for that MAVLink id (SITL says so in a STATUSTEXT).
    Unknown,
    /// A negative interval other than −1.
    Negative,
    /// Faster than the scheduler can keep ("Requested rate for message ID N too fast.
    /// Increase SCHED_LOOP_RATE").
    TooFast,
}

impl ApSchedule {
    /// The schedule at boot: the vehicle's default group rates, HEARTBEAT at 1 Hz.
    pub(crate) fn new(kind: SimVehicleClass, now: Time) -> ApSchedule {
        let mut s = ApSchedule {
            rates: ap_default_rates(kind),
            buckets: [Bucket::default(); 10],
            heartbeat: (1000, now),
            first_heartbeat: true,
            slowdown_ms: 0,
            timesync_at: now,
            min_interval_ms: match kind {
                SimVehicleClass::Copter => 4,
                SimVehicleClass::Rover => 25,
            },
        };
        for g in ApGroup::ALL {
            s.init_group(g, now);
        }
        s
    }

    /// The interval of a group at its rate, ms (`get_interval_for_stream`).
    fn group_interval_ms(&self, g: ApGroup) -> u16 {
        match self.rates[g as usize] {
            0 => 0,
            r => (1000 / u32::from(r)).min(60_000) as u16,
        }
    }

    /// `initialise_message_intervals_for_stream`.
    fn init_group(&mut self, g: ApGroup, now: Time) {
        let ms = self.group_interval_ms(g);
        for &id in g.messages() {
            self.set_interval_ms(id, ms, now);
        }
    }

    /// REQUEST_DATA_STREAM: a group's rate (or every group's but PARAMS for ALL); start_stop 0
    /// stops, other values than 0 and 1 are ignored.
    pub(crate) fn request_data_stream(&mut self, stream: u8, rate: u16, start_stop: u8, now: Time) {
        let hz = match start_stop {
            0 => 0,
            1 => rate,
            _ => return,
        };
        if stream == mav::MavDataStream::MAV_DATA_STREAM_ALL as u8 {
            for g in ApGroup::ALL {
                if g != ApGroup::Params {
                    self.rates[g as usize] = hz;
                    self.init_group(g, now);
                }
            }
        } else if let Some(g) = ApGroup::of_stream_id(stream) {
            self.rates[g as usize] = hz;
            self.init_group(g, now);
        }
    }

    /// The default interval of a message (`get_default_interval_for_ap_message`): HEARTBEAT
    /// 1 s, else its group's current interval, else none.
    fn default_interval_ms(&self, id: u32) -> u16 {
        if id == HEARTBEAT {
            return 1000;
        }
        ApGroup::ALL
            .iter()
            .find(|g| g.messages().contains(&id))
            .map_or(0, |&g| self.group_interval_ms(g))
    }

    /// SET_MESSAGE_INTERVAL (`GCS_MAVLINK::set_message_interval`): interval in µs, 0 the
    /// default, −1 off.
    pub(crate) fn set_message_interval(
        &mut self,
        id: u32,
        interval_us: f32,
        now: Time,
    ) -> Result<(), ApRefusal> {
        if ap_bit(id).is_none() {
            return Err(ApRefusal::Unknown);
        }
        let us = interval_us as i64;
        let ms = if us == 0 {
            self.default_interval_ms(id)
        } else if us == -1 {
            0
        } else if us < 0 {
            return Err(ApRefusal::Negative);
        } else if us < 1000 {
            1
        } else {
            (us / 1000).min(60_000) as u16
        };
        if ms != 0 && ms < self.min_interval_ms {
            return Err(ApRefusal::TooFast);
        }
        self.set_interval_ms(id, ms, now);
        Ok(())
    }

    /// `set_ap_message_interval`: HEARTBEAT apart; others into the bucket of the nearest
    /// interval, a free bucket when none has exactly theirs; 0 takes the message out.
    fn set_interval_ms(&mut self, id: u32, ms: u16, now: Time) {
        if id == HEARTBEAT {
            self.heartbeat = (ms, now);
            return;
        }
        let Some(bit) = ap_bit(id) else { return };
        let mask = 1u128 << bit;
        let mut closest: Option<(usize, u16)> = None;
        let mut free = None;
        let mut inside = None;
        for (i, b) in self.buckets.iter().enumerate() {
            if b.interval_ms == 0 {
                free = free.or(Some(i));
                continue;
            }
            if b.ids & mask != 0 {
                inside = Some(i);
            }
            let delta = b.interval_ms.abs_diff(ms);
            if closest.is_none_or(|(_, d)| delta < d) {
                closest = Some((i, delta));
            }
        }
        if let Some(i) = inside {
            if ms != 0 && closest == Some((i, 0)) {
                return;
            }
            self.remove_from(i, mask);
            if free.is_none() && self.buckets[i].interval_ms == 0 {
                free = Some(i);
            }
        }
        if ms == 0 {
            return;
        }
        let target = match (closest, free) {
            (Some((i, 0)), _) if self.buckets[i].interval_ms != 0 => i,
            (_, Some(f)) => {
                self.buckets[f] = Bucket {
                    interval_ms: ms,
                    last_sent: now,
                    ids: 0,
                };
                f
            }
            (Some((i, _)), None) => i,
            (None, None) => return,
        };
        self.buckets[target].ids |= mask;
    }

    fn remove_from(&mut self, i: usize, mask: u128) {
        let b = &mut self.buckets[i];
        b.ids &= !mask;
        if b.ids == 0 {
            *b = Bucket::default();
        }
    }

    /// The interval a message is sent at, ms (`get_ap_message_interval`); None when it is in
    /// no bucket.
    pub(crate) fn interval_ms(&self, id: u32) -> Option<u16> {
        if id == HEARTBEAT {
            return Some(self.heartbeat.0);
        }
        let mask = 1u128 << ap_bit(id)?;
        self.buckets
            .iter()
            .find(|b| b.ids & mask != 0)
            .map(|b| b.interval_ms)
    }

    /// GET_MESSAGE_INTERVAL: the MESSAGE_INTERVAL's interval and the command's result. An
    /// unknown id gets 0 and FAILED, a message not being sent −1, others their interval in µs.
    pub(crate) fn get_message_interval(&self, id: u32) -> (i32, mav::MavResult) {
        use mav::MavResult as R;
        if id >= 1 << 16 || ap_bit(id).is_none() {
            return (0, R::MAV_RESULT_FAILED);
        }
        match self.interval_ms(id) {
            Some(ms) if ms > 0 => (i32::from(ms) * 1000, R::MAV_RESULT_ACCEPTED),
            _ => (-1, R::MAV_RESULT_ACCEPTED),
        }
    }

    /// RADIO_STATUS.txbuf (percent of the radio's buffer free) in `stream_slowdown_ms`.
    pub(crate) fn radio_status(&mut self, txbuf: u8) {
        let s = &mut self.slowdown_ms;
        if txbuf < 20 && *s < 2000 {
            *s += 60;
        } else if txbuf < 50 && *s < 2000 {
            *s += 20;
        } else if txbuf > 95 && *s > 200 {
            *s -= 40;
        } else if txbuf > 90 && *s != 0 {
            *s = s.saturating_sub(20);
            if *s < 20 {
                *s = 0;
            }
        }
    }

    /// The current extra delay of every bucket, ms.
    #[cfg(test)]
    pub(crate) fn slowdown_ms(&self) -> u16 {
        self.slowdown_ms
    }

    /// The messages due at `now`, in `out` (bucket by bucket); `receiving_mission`: waypoints
    /// are being received on this link (intervals ×4). Also whether a TIMESYNC request is due.
    pub(crate) fn due(&mut self, now: Time, receiving_mission: bool, out: &mut Vec<u32>) -> bool {
        let (hb_ms, hb_last) = self.heartbeat;
        if self.first_heartbeat && hb_ms > 0 {
            self.first_heartbeat = false;
            out.push(HEARTBEAT);
            self.heartbeat.1 = now;
        } else if hb_ms > 0 && now.saturating_since(hb_last) >= ms(hb_ms) {
            out.push(HEARTBEAT);
            self.heartbeat.1 = next_time(hb_last, ms(hb_ms), now);
        }
        for b in &mut self.buckets {
            if b.ids == 0 {
                continue;
            }
            let mut iv = u32::from(b.interval_ms) + u32::from(self.slowdown_ms);
            if receiving_mission {
                iv *= 4;
            }
            let iv = ms(iv.min(60_000) as u16);
            if now.saturating_since(b.last_sent) < iv {
                continue;
            }
            let mut ids = b.ids;
            while ids != 0 {
                let bit = ids.trailing_zeros();
                ids &= ids - 1;
                out.push(AP_KNOWN[bit as usize]);
            }
            b.last_sent = next_time(b.last_sent, iv, now);
        }
        if now.saturating_since(self.timesync_at) > Duration::from_secs(10) {
            self.timesync_at = now;
            return true;
        }
        false
    }
}
