//! Image sources on the GCS side: MAVLink image transmission (DATA_TRANSMISSION_HANDSHAKE +
//! ENCAPSULATED_DATA reassembled into JPEG bytes), images announced by CAMERA_IMAGE_CAPTURED
//! file URLs, the metadata the simulated camera embeds in its JPEGs, and measurements a camera
//! makes on board ([`onboard`]).

pub mod meta;
pub mod onboard;
pub mod transfer;
