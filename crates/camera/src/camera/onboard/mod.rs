//! Pictures measured on board ([`CameraConfig::onboard`]): the measurement the camera was
//! given, made on each picture and sent right after its CAMERA_IMAGE_CAPTURED, and what the
//! measurement needs of the GCS's messages and of the camera's clock.
//!
//! Each measurement is a `Measurer` in its own module (the green share: [`green`]; the
//! runway's cell and 3 × 3 regions, with the grid the GCS announces: [`runway`]), made from
//! the definition by `measurer`; the modules and `measurer` come from the core's list of kinds
//! ([`fleetmap_core::for_each_kind!`]).

use super::{CameraConfig, SimCamera};
use anyhow::Context;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::time::Time;
use fleetmap_core::vision::onboard::OnboardSpec;
use image::RgbImage;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::path::Path;

/// One picture, as the camera has it when it measures it.
pub(crate) struct Picture<'a> {
    /// The picture as rendered or read.
    pub image: &'a RgbImage,
    /// The JPEG the camera sends (the picture the GCS would decode).
    pub jpeg: &'a [u8],
    /// Its announcement (pose, time and index).
    pub captured: &'a mav::CAMERA_IMAGE_CAPTURED_DATA,
    /// The altitude above home the announcement reports, metres (before rounding to mm).
    pub alt_rel_m: f64,
}

/// One kind of on-board measurement, as a camera makes it.
pub(crate) trait Measurer: std::fmt::Debug + Send + Sync {
    /// The message with the result of `p` (`None`: nothing to send).
    fn measure(&self, p: &Picture<'_>) -> Option<MavMessage>;

    /// A DEBUG_FLOAT_ARRAY from a GCS: the answer to send, if any.
    fn handle_gcs_message(&mut self, _d: &mav::DEBUG_FLOAT_ARRAY_DATA) -> Option<MavMessage> {
        None
    }

    /// At `now` (the camera's clock): a status to send, if one is due.
    fn status_tick(&mut self, _now: Time) -> Option<MavMessage> {
        None
    }

    /// The fingerprint of the definition it measures with (`None`: it cannot measure yet).
    fn fingerprint(&self) -> Option<u32>;
}

/// Each kind's measurement, in its own module (named by the list of kinds,
/// [`fleetmap_core::for_each_kind!`]), which supplies `measurer` (a camera starting with the
/// definition) and `onboard_spec` (the definition a mission file gives, if any).
macro_rules! measurers {
    ($([$(#[$doc:meta])*] [$name:ident ($spec:path) ($msg:path) $module:ident])+) => {
        $(pub mod $module;)+

        /// The measurer of `config`'s on-board definition, as the camera starts with it.
        pub(super) fn measurer(config: &CameraConfig) -> Option<Box<dyn Measurer>> {
            Some(match config.onboard.as_ref()? {
                $(OnboardSpec::$name(d) => $module::measurer(d),)+
            })
        }

        /// What the mission `def` (read from `path`) has a camera measure on board: the
        /// first measurement of the list that reads one from it. An error for a mission
        /// whose measurement a camera cannot make.
        pub(crate) fn spec_of(def: &MissionDef, path: &Path) -> anyhow::Result<Option<OnboardSpec>> {
            $(if let Some(s) = $module::onboard_spec(def, path)? {
                return Ok(Some(s));
            })+
            Ok(None)
        }
    };
}
fleetmap_core::for_each_kind!(onboard => measurers);

/// [`spec_of`], `None` being an error.
pub(crate) fn required_spec_of(def: &MissionDef, path: &Path) -> anyhow::Result<OnboardSpec> {
    spec_of(def, path)?.with_context(|| format!("{}: nothing to measure on board", path.display()))
}

impl SimCamera {
    /// A message from a GCS (any component but the vehicle's own): a request to send a
    /// picture again (DATA_TRANSMISSION_HANDSHAKE, `SimCamera::handle_handshake_request`)
    /// or one for the on-board measurement (DEBUG_FLOAT_ARRAY: the runway run's grid, which
    /// a camera classifying runway pictures takes and answers with its status). Anything
    /// else is ignored.
    pub fn handle_gcs_message(&mut self, msg: &MavMessage) {
        match msg {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => self.handle_handshake_request(h.size),
            MavMessage::DEBUG_FLOAT_ARRAY(d) => {
                if let Some(answer) = self.onboard.as_mut().and_then(|m| m.handle_gcs_message(d)) {
                    self.outbox.push_back(answer);
                }
            }
            _ => {}
        }
    }

    /// The fingerprint of the definition the camera measures on board with (`None`: it does
    /// not measure on board, or cannot yet: a runway camera without the grid).
    pub fn onboard_fingerprint(&self) -> Option<u32> {
        self.onboard.as_ref().and_then(|m| m.fingerprint())
    }

    /// At `now`: a status the measurement says is due.
    pub(super) fn status_tick(&mut self, now: Time) {
        if let Some(m) = self.onboard.as_mut().and_then(|m| m.status_tick(now)) {
            self.outbox.push_back(m);
        }
    }

    /// The on-board result of `p`. `None`: the camera does not measure on board.
    pub(super) fn onboard_result(&self, p: &Picture<'_>) -> Option<MavMessage> {
        self.onboard.as_ref()?.measure(p)
    }
}
