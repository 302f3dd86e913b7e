//! Positions a few metres from a home, for missions written in a test.

/// The (latitude, longitude) in degrees `north` and `east` metres from `home` (degrees), on
/// the local tangent plane the core uses for short distances
/// ([`fleetmap_core::geo::local::offset`]).
pub fn at(home: (f64, f64), north: f64, east: f64) -> (f64, f64) {
    fleetmap_core::geo::local::offset(home.0, home.1, north, east)
}
