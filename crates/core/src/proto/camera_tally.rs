//! What a vehicle's camera has done, counted from its own messages: the pictures it took
//! (CAMERA_IMAGE_CAPTURED) and the measurements it made on board and sent (any of
//! [`crate::vision::onboard::Onboard`]'s: `"fm.green"`, `"fm.rwy"`).
//!
//! A GCS hears some of these more than once: it asks again for a capture record or a result
//! it missed (MAV_CMD_REQUEST_MESSAGE with the image index, as the MAVLink camera protocol
//! recovers lost CAMERA_IMAGE_CAPTURED; `proto::captures`' range requests), and the camera
//! answers with the same message. The tally counts each capture once by its
//! (time_boot_ms, image_index), and each measurement once by its capture and kind, within a
//! window of the last [`REMEMBERED`] keys of each: a resend arrives within seconds, long
//! before that many newer pictures are taken.

use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;

use crate::vision::onboard::{Onboard, OnboardKind};

/// How many recent keys are remembered to tell a resend from a new picture.
pub const REMEMBERED: usize = 256;

/// What the measurement was of: the capture's (time_boot_ms, image index) and which kind.
type MeasurementKey = (u32, u16, OnboardKind);

/// The counts of one camera, from every message its component sent.
#[derive(Clone, Debug, Default)]
pub struct CameraTally {
    pictures: u32,
    measurements: u32,
    recent_pictures: VecDeque<(u32, i32)>,
    recent_measurements: VecDeque<MeasurementKey>,
}

/// Remember `key` in `recent` (bounded to [`REMEMBERED`]); whether it was new.
fn first_time<K: PartialEq>(recent: &mut VecDeque<K>, key: K) -> bool {
    if recent.contains(&key) {
        return false;
    }
    if recent.len() == REMEMBERED {
        recent.pop_front();
    }
    recent.push_back(key);
    true
}

impl CameraTally {
    /// Count `msg`, a message from the camera component; anything that is neither a capture
    /// record nor a measurement (its heartbeat, statuses, image data) is not counted.
    pub fn handle_message(&mut self, msg: &MavMessage) {
        match msg {
            MavMessage::CAMERA_IMAGE_CAPTURED(c) => {
                let new = first_time(&mut self.recent_pictures, (c.time_boot_ms, c.image_index));
                self.pictures = self.pictures.saturating_add(u32::from(new));
            }
            MavMessage::DEBUG_FLOAT_ARRAY(d) => {
                let Some(m) = Onboard::from_message(d) else {
                    return;
                };
                let Some((time_boot_ms, index_lo)) = m.capture() else {
                    return; // a status: about no picture
                };
                let key = (time_boot_ms, index_lo, m.kind());
                let new = first_time(&mut self.recent_measurements, key);
                self.measurements = self.measurements.saturating_add(u32::from(new));
            }
            _ => {}
        }
    }

    /// Pictures the camera took (distinct capture records heard).
    pub fn pictures(&self) -> u32 {
        self.pictures
    }

    /// Measurements the camera made on board and sent (distinct results heard; statuses,
    /// which carry no picture, are not measurements).
    pub fn measurements(&self) -> u32 {
        self.measurements
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::onboard::{GreenShare, OnboardMeasurement};
    use crate::vision::runway::onboard::RunwayMeasurement;
    use mavlink::dialects::ardupilotmega as mav;

    fn captured(time_boot_ms: u32, image_index: i32) -> MavMessage {
        MavMessage::CAMERA_IMAGE_CAPTURED(mav::CAMERA_IMAGE_CAPTURED_DATA {
            time_boot_ms,
            image_index,
            ..Default::default()
        })
    }

    fn green(time_boot_ms: u32, image_index_lo: u16) -> MavMessage {
        OnboardMeasurement {
            time_boot_ms,
            image_index_lo,
            spec: 7,
            picture_bytes: 1000,
            value: GreenShare {
                share: 0.5,
                pixels: 100,
            },
        }
        .to_message()
    }

    #[test]
    fn resends_count_once_and_new_captures_count() {
        let mut t = CameraTally::default();
        for m in [captured(1000, 0), captured(2000, 1), captured(1000, 0)] {
            t.handle_message(&m);
        }
        for m in [green(1000, 0), green(1000, 0), green(2000, 1)] {
            t.handle_message(&m);
        }
        assert_eq!((t.pictures(), t.measurements()), (2, 2));
    }

    #[test]
    fn a_reboot_restarting_the_index_is_a_new_picture() {
        // After a power cycle the index starts again; the boot time tells them apart.
        let mut t = CameraTally::default();
        t.handle_message(&captured(50_000, 0));
        t.handle_message(&captured(900, 0));
        assert_eq!(t.pictures(), 2);
    }

    #[test]
    fn runway_statuses_and_other_messages_are_not_counted() {
        let mut t = CameraTally::default();
        t.handle_message(&RunwayMeasurement::status(0).to_message());
        t.handle_message(&MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA::default()));
        let mut other = green(1, 1);
        if let MavMessage::DEBUG_FLOAT_ARRAY(d) = &mut other {
            d.name = "other".into();
        }
        t.handle_message(&other);
        assert_eq!((t.pictures(), t.measurements()), (0, 0));
    }

    #[test]
    fn the_window_is_bounded() {
        let mut t = CameraTally::default();
        for i in 0..(REMEMBERED as i32 + 10) {
            t.handle_message(&captured(i as u32, i));
        }
        assert_eq!(t.recent_pictures.len(), REMEMBERED);
        assert_eq!(t.pictures(), REMEMBERED as u32 + 10);
    }
}
