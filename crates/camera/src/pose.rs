//! Where a camera is and how it is oriented when it takes a picture: what the renderer draws
//! from and what a capture's announcement reports.

use serde::{Deserialize, Serialize};

/// Where the camera is and how it is oriented.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraPose {
    /// Latitude of the camera, degrees.
    pub lat: f64,
    /// Longitude of the camera, degrees.
    pub lon: f64,
    /// Height above the ground, metres.
    pub alt_agl_m: f64,
    /// Heading (image up), degrees clockwise from north.
    pub heading_deg: f64,
    /// Roll, degrees (right side down positive).
    pub roll_deg: f64,
    /// Pitch, degrees (nose up positive).
    pub pitch_deg: f64,
}
