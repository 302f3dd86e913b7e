//! Missions: the items uploaded to autopilots, the mission definition files (TOML) that
//! field teams edit, and the QGroundControl file formats.

pub mod definition;
pub mod item;
pub mod plan;
pub(crate) mod strategy;
pub mod wire;
pub mod wpl;
