//! Shared by the end-to-end tests that fly the runway mission over a small world.

#[allow(dead_code)] // not every test binary drives a pseudo-terminal
pub mod pty;

/// A 20 m × 12 m asphalt strip aligned with the grid: five by three 4 m cells whose edges lie
/// on cell boundaries, with the default homes 12 m south of its centre.
#[allow(dead_code)] // the pseudo-terminal helpers are shared more widely
pub const WORLD: &str = r#"
name = "strip"
description = "A 20 m x 12 m asphalt strip aligned with the grid (test world)"
background = "grass"
ground_alt_amsl_m = 600.0

[[region]]
name = "strip"
surface = "asphalt"
rectangle = { center = [37.196800, -80.578100], length_m = 20.0, width_m = 12.0, heading_deg = 90.0 }
markings = false

[homes]
reference = [37.196800, -80.578100]
first_north_m = -12.0
first_east_m = 0.0
step_north_m = 0.0
step_east_m = 3.0
"#;
