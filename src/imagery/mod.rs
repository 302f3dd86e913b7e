//! Image sources on the GCS side: MAVLink image transmission (DATA_TRANSMISSION_HANDSHAKE +
//! ENCAPSULATED_DATA reassembled into JPEG bytes), images announced by CAMERA_IMAGE_CAPTURED
//! file URLs, the metadata the simulated camera embeds in its JPEGs, and measurements a camera
//! makes on board ([`onboard`]; both pure, in [`crate::vision`]).

pub mod transfer;

/// The capture metadata and the on-board measurement are pure (no I/O); they live in the
/// core's [`crate::vision`] and keep their old paths here.
pub use crate::vision::{meta, onboard};
