//! What the camera answers a GCS besides taking pictures: MAV_CMD_REQUEST_MESSAGE for
//! CAMERA_INFORMATION, CAMERA_CAPTURE_STATUS and — a capture the GCS missed — its
//! CAMERA_IMAGE_CAPTURED again, and a single capture's sequence number, so that a command
//! sent again because its ACK was lost takes no second picture.
//!
//! **A capture again.** The MAVLink camera protocol lets a GCS ask for a capture's
//! announcement it missed: MAV_CMD_REQUEST_MESSAGE with param1 = CAMERA_IMAGE_CAPTURED (263),
//! param2 = the image index (−1: every capture kept) and param3 = 0 for that one, −1 for it
//! and all the following, or the last index of a range (common.xml, CAMERA_IMAGE_CAPTURED;
//! MAVSDK's camera plugin asks for its missing indexes this way). Over a lossy radio both
//! halves of a picture measured on board — the announcement, which carries the pose, and the
//! result right after it — must arrive; so the camera sends each kept capture's
//! announcement again *followed by its on-board result*, as when it was taken. It keeps the
//! last [`KEPT_CAPTURES`]; a request for none of them is answered MAV_RESULT_FAILED.
//!
//! **Sequence numbers.** MAV_CMD_IMAGE_START_CAPTURE's param4 numbers single captures
//! (param3 = 1) "to prevent double captures when a command is re-transmitted" (common.xml):
//! the same number again is acknowledged and takes nothing.

use super::SimCamera;
use fleetmap_core::time::Time;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;

/// How many captures' announcements (and on-board results) a camera keeps to send again.
pub(crate) const KEPT_CAPTURES: usize = 64;

/// CAMERA_INFORMATION's message id (259).
const CAMERA_INFORMATION: u32 = <mav::CAMERA_INFORMATION_DATA as MessageData>::ID;
/// CAMERA_CAPTURE_STATUS's message id (262).
const CAMERA_CAPTURE_STATUS: u32 = <mav::CAMERA_CAPTURE_STATUS_DATA as MessageData>::ID;
/// CAMERA_IMAGE_CAPTURED's message id (263).
const CAMERA_IMAGE_CAPTURED: u32 = <mav::CAMERA_IMAGE_CAPTURED_DATA as MessageData>::ID;

/// One capture as announced: its image index, the announcement and the on-board result.
#[derive(Debug, Clone)]
pub(super) struct KeptCapture {
    index: i32,
    messages: Vec<MavMessage>,
}

impl SimCamera {
    /// Keep the capture `index`'s announcement and result (`messages`, in the order sent).
    pub(super) fn keep_capture(&mut self, index: i32, messages: Vec<MavMessage>) {
        self.kept.push_back(KeptCapture { index, messages });
        if self.kept.len() > KEPT_CAPTURES {
            self.kept.pop_front();
        }
    }

    /// MAV_CMD_IMAGE_START_CAPTURE with params 2–4 (`interval_s`, `count`, `seq`) at `now`.
    /// A single capture (`count` 1) whose sequence number is the last one taken is a command
    /// sent again: nothing more is taken.
    pub fn capture_command(&mut self, interval_s: f64, count: u32, seq: u32, now: Time) {
        if count == 1 && seq > 0 {
            if self.last_capture_seq == Some(seq) {
                return;
            }
            self.last_capture_seq = Some(seq);
        }
        self.start_capture(interval_s, count, now);
    }

    /// MAV_CMD_REQUEST_MESSAGE with params 1–3 at `time_boot_ms`: the command's result and
    /// what is asked for, to send right after the ACK.
    pub fn request_message(
        &mut self,
        params: [f32; 3],
        time_boot_ms: u32,
    ) -> (mav::MavResult, Vec<MavMessage>) {
        let [id, p2, p3] = params;
        let answer = match id as u32 {
            CAMERA_INFORMATION => vec![self.information(time_boot_ms)],
            CAMERA_CAPTURE_STATUS => vec![self.capture_status(time_boot_ms)],
            CAMERA_IMAGE_CAPTURED => {
                let (first, last) = (p2 as i32, p3 as i32);
                let wanted = |i: i32| match (first, last) {
                    (-1, _) => true,
                    (f, 0) => i == f,
                    (f, -1) => i >= f,
                    (f, l) => (f..=l).contains(&i),
                };
                let again: Vec<MavMessage> = self
                    .kept
                    .iter()
                    .filter(|k| wanted(k.index))
                    .flat_map(|k| k.messages.iter().cloned())
                    .collect();
                if again.is_empty() {
                    return (mav::MavResult::MAV_RESULT_FAILED, again);
                }
                again
            }
            _ => return (mav::MavResult::MAV_RESULT_UNSUPPORTED, Vec::new()),
        };
        (mav::MavResult::MAV_RESULT_ACCEPTED, answer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraConfig;

    fn announcement(index: i32) -> MavMessage {
        MavMessage::CAMERA_IMAGE_CAPTURED(mav::CAMERA_IMAGE_CAPTURED_DATA {
            image_index: index,
            ..Default::default()
        })
    }

    /// The request's result and the image indexes of the announcements it sends again.
    fn ask(cam: &mut SimCamera, params: [f32; 3]) -> (mav::MavResult, Vec<i32>) {
        let (r, msgs) = cam.request_message(params, 0);
        let indexes = msgs
            .into_iter()
            .filter_map(|m| match m {
                MavMessage::CAMERA_IMAGE_CAPTURED(c) => Some(c.image_index),
                _ => None,
            })
            .collect();
        (r, indexes)
    }

    #[test]
    fn captures_are_sent_again_by_index_range_or_all() {
        let mut cam = SimCamera::new(1, CameraConfig::default(), 1);
        for i in 0..(KEPT_CAPTURES as i32 + 5) {
            let result = MavMessage::HEARTBEAT(Default::default());
            cam.keep_capture(i, vec![announcement(i), result]);
        }
        let ok = mav::MavResult::MAV_RESULT_ACCEPTED;
        // the announcement and the result after it
        assert_eq!(cam.request_message([263.0, 30.0, 0.0], 0).1.len(), 2);
        assert_eq!(ask(&mut cam, [263.0, 30.0, 0.0]), (ok, vec![30]));
        assert_eq!(ask(&mut cam, [263.0, 66.0, -1.0]), (ok, vec![66, 67, 68]));
        assert_eq!(ask(&mut cam, [263.0, 10.0, 12.0]), (ok, vec![10, 11, 12]));
        assert_eq!(ask(&mut cam, [263.0, -1.0, 0.0]).1.len(), KEPT_CAPTURES);
        // forgotten, or not taken yet
        let failed = mav::MavResult::MAV_RESULT_FAILED;
        assert_eq!(ask(&mut cam, [263.0, 2.0, 0.0]), (failed, vec![]));
        assert_eq!(ask(&mut cam, [263.0, 69.0, -1.0]), (failed, vec![]));
        // the camera's information and status
        let (r, m) = cam.request_message([259.0, 0.0, 0.0], 0);
        assert!(r == ok && matches!(m[..], [MavMessage::CAMERA_INFORMATION(_)]));
        let (r, m) = cam.request_message([262.0, 0.0, 0.0], 0);
        assert!(r == ok && matches!(m[..], [MavMessage::CAMERA_CAPTURE_STATUS(_)]));
        assert_eq!(
            cam.request_message([33.0, 0.0, 0.0], 0).0,
            mav::MavResult::MAV_RESULT_UNSUPPORTED
        );
    }

    #[test]
    fn a_single_capture_sent_again_takes_no_second_picture() {
        let mut cam = SimCamera::new(1, CameraConfig::default(), 1);
        cam.capture_command(0.0, 1, 7, Time::ZERO);
        cam.capture_command(0.0, 1, 7, Time::ZERO);
        assert_eq!(cam.pending, 1);
        cam.capture_command(0.0, 1, 8, Time::ZERO);
        assert_eq!(cam.pending, 2);
        // unnumbered captures are all taken
        cam.capture_command(0.0, 1, 0, Time::ZERO);
        cam.capture_command(0.0, 1, 0, Time::ZERO);
        assert_eq!(cam.pending, 4);
    }
}
