//! When each telemetry message leaves on the GCS link: ArduPilot's stream groups and message
//! buckets, PX4's streams and rate multiplier. Pure schedules (which message ids are due at
//! `now`); what the messages say is [`super::telemetry`]'s and [`super::messages`]'s.
//!
//! ArduPilot (`libraries/GCS_MAVLink`, V4.7.0-dev 90700977, read for this; the behaviour
//! below was measured on its SITL, see `docs/results/conformance.md`):
//! - each message has an interval; messages of equal interval share one of 10 buckets
//!   (`GCS_MAVLINK::set_ap_message_interval`: a message joins the bucket of the nearest
//!   interval, or a free bucket when none has its interval) and a due bucket sends all its
//!   messages, then moves its next time on by the interval, or to now when more than one
//!   interval late (`GCS_MAVLINK::update_send`);
//! - the stream groups (`GCS_MAVLink_Parameters.cpp`, the `STREAM_*_msgs` lists) set the
//!   interval of every message of the group to 1000/rate ms, or remove it at rate 0
//!   (`initialise_message_intervals_for_stream`), at boot from the MAVn_* rates (ArduCopter:
//!   all 0, ArduRover: all 1 Hz) and on each REQUEST_DATA_STREAM (`handle_request_data_stream`,
//!   GCS_Param.cpp; ALL sets every group but PARAMS; nothing is saved, so a reboot restores the
//!   defaults) — a later REQUEST_DATA_STREAM overrides SET_MESSAGE_INTERVAL for its messages;
//! - HEARTBEAT is kept apart (`deferred_message`), at 1 s, and is never slowed down;
//! - a bucket is rescheduled `stream_slowdown_ms` later than its interval, four times that
//!   while waypoints are being received (`get_reschedule_interval_ms`), at most 60 s;
//!   `stream_slowdown_ms` follows RADIO_STATUS.txbuf (`handle_radio_status`: below 20 % free
//!   +60 ms, below 50 % +20 ms while under 2 s; above 95 % −40 ms while over 200 ms; above
//!   90 % −20 ms down to 0);
//! - a TIMESYNC request every 10 s (`GCS_MAVLINK::update_receive`).
//!
//! PX4 (`src/modules/mavlink`, v1.16):
//! - each stream has an interval (`Mavlink::configure_streams_to_default`, Normal mode) and is
//!   sent when that interval divided by the rate multiplier has passed
//!   (`MavlinkStream::update`; HEARTBEAT and PING keep their rate);
//! - the rate multiplier is the smaller of the bandwidth multiplier, (data rate − constant-rate
//!   streams) / the other streams' bytes per second counted at their full length, at most 1,
//!   and, with software throttling (`-s`, MAV_x_RADIO_CTL), the radio multiplier, kept between
//!   5 % and 100 % (`Mavlink::update_rate_mult`);
//! - the radio multiplier: each RADIO_STATUS with txbuf below 25 % ×0.8, below 35 % ×0.975,
//!   above 50 % ×1.025, between 1 % and 100 % (`Mavlink::update_radio_status`), back to 1 when
//!   no RADIO_STATUS came for MAV_RADIO_TOUT (5 s);
//! - MISSION_CURRENT comes from the mission manager at 1 Hz, not from a stream (so
//!   SET_MESSAGE_INTERVAL refuses it).

use fleetmap_core::time::Time;
use std::time::Duration;

/// A message id, from the dialect's message type.
macro_rules! id {
    ($t:ident) => {
        <mavlink::dialects::ardupilotmega::$t as mavlink::MessageData>::ID
    };
}

/// Wire length of a message at its full payload (no trailing zeros cut), MAVLink 2 without
/// signature: what PX4 counts for a stream (`get_size`: the payload length plus
/// MAVLINK_NUM_NON_PAYLOAD_BYTES, 12).
macro_rules! full_len {
    ($t:ident) => {
        (<mavlink::dialects::ardupilotmega::$t as mavlink::MessageData>::ENCODED_LEN + 12) as u32
    };
}

mod ardupilot;
mod px4;

pub(crate) use ardupilot::{ApRefusal, ApSchedule};
pub use px4::Px4Link;
pub(crate) use px4::Px4Schedule;

pub(super) fn ms(v: u16) -> Duration {
    Duration::from_millis(u64::from(v))
}

/// The next send time after one due at `last`: an interval on, or `now` when that is still
/// more than an interval behind (no catching up), as ArduPilot and PX4 both keep their clocks.
pub(super) fn next_time(last: Time, interval: Duration, now: Time) -> Time {
    let next = last + interval;
    if now.saturating_since(next) > interval {
        now
    } else {
        next
    }
}

#[cfg(test)]
mod tests;
