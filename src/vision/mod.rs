//! The sensing models of both papers: the runway classifier and green-pixel measurements.

pub mod camera;
