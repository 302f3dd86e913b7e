//! WGS84 latitude/longitude ↔ UTM (zones 1..=60, north and south), accurate to nanometres.
//!
//! The projection is Krüger's series to n⁶ (see `tm.rs`: Karney 2011 / GeographicLib
//! `TransverseMercator`, the same algorithm as PROJ's default "exact" tmerc), so the results
//! agree with PROJ (pyproj, EPSG:326zz/327zz) to a few nanometres; `tests/suite/geo.rs` checks
//! 8 878 reference points from `assets/golden/utm_pyproj.csv` to 1 mm in both directions.
//!
//! We do not use the `utm` crate (0.1.6) for conversions. Measured against the same golden
//! file (`tests/suite/geo.rs::utm_crate_against_proj` prints the numbers): its forward projection is
//! within 0.99 mm inside the standard zones but off by up to 2.2 m for points outside the
//! zone (a grid reaching into the next zone), and its inverse is off by up to 0.77 m inside
//! the standard zones (19 m outside, where it also rejects eastings beyond 100–1000 km).
//! It uses Snyder's truncated series (USGS PP 1395, eq. 8-9/8-10, 8-17/8-18) with GRS80's
//! flattening (1/298.257222101) and a rounded e², and does not wrap longitudes across the
//! antimeridian.
//!
//! Zone rules ([`zone_for`]) follow GeographicLib `UTMUPS::StandardZone`
//! (geographiclib/geographiclib, `src/UTMUPS.cpp`): zone = ⌊(λ + 180)/6⌋ + 1, with the Norway
//! exception (56°N ≤ φ < 64°N, 3°E ≤ λ < 12°E → 32) and the Svalbard exceptions
//! (72°N ≤ φ ≤ 84°N: 0–9°E → 31, 9–21°E → 33, 21–33°E → 35, 33–42°E → 37).
//! UTM is defined from 80°S to 84°N (inclusive); outside it every function returns
//! [`GeoError::OutsideUtm`].

use super::tm;
use super::{GeoError, Hemisphere, LatLon, Utm};

/// Southern limit of UTM, degrees.
pub(crate) const MIN_LAT: f64 = -80.0;
/// Northern limit of UTM, degrees.
pub(crate) const MAX_LAT: f64 = 84.0;
/// False easting, metres.
pub(crate) const FALSE_EASTING: f64 = 500_000.0;
/// The farthest a point may be from the central meridian of a forced zone, degrees
/// (12° beyond the zone's edge; the series stays nanometre-accurate far beyond this, but the
/// scale error there is already 2–3 %, so a grid that far from its zone is a mistake).
pub(crate) const MAX_ZONE_OFFSET_DEG: f64 = 15.0;
/// Slack for [`from_utm`] results on the domain limits, degrees (≈ 0.1 mm): a point computed
/// exactly on 84°N or 80°S may come back 1e-14° outside; within this slack the latitude is
/// clamped to the limit.
const DOMAIN_SLACK_DEG: f64 = 1e-9;

/// The central meridian of `zone`, degrees (zone 1: −177°, zone 60: 177°). No check of `zone`.
pub fn central_meridian(zone: u8) -> f64 {
    f64::from(zone) * 6.0 - 183.0
}

/// Check a position for UTM: finite, |lon| ≤ 180, 80°S ≤ lat ≤ 84°N.
fn check_utm_domain(p: LatLon) -> Result<LatLon, GeoError> {
    let p = p.validate()?;
    if !(MIN_LAT..=MAX_LAT).contains(&p.lat) {
        return Err(GeoError::OutsideUtm { lat: p.lat });
    }
    Ok(p)
}

fn check_zone(zone: u8) -> Result<u8, GeoError> {
    if (1..=60).contains(&zone) {
        Ok(zone)
    } else {
        Err(GeoError::InvalidZone { zone })
    }
}

/// Wrap a longitude difference into −180..180 degrees.
fn wrap180(d: f64) -> f64 {
    if d >= 180.0 {
        d - 360.0
    } else if d < -180.0 {
        d + 360.0
    } else {
        d
    }
}

/// The standard UTM zone (1..=60) of (`lat`, `lon`) degrees, with the Norway (32V) and
/// Svalbard (31X/33X/35X/37X) exceptions. Longitude 180° is −180° (zone 1).
pub fn zone_for(lat: f64, lon: f64) -> Result<u8, GeoError> {
    let p = check_utm_domain(LatLon::new(lat, lon))?;
    let lon = if p.lon >= 180.0 { p.lon - 360.0 } else { p.lon };
    let ilon = lon.floor() as i32; // −180..=179
    let mut zone = (ilon + 186) / 6;
    if (56.0..64.0).contains(&p.lat) && zone == 31 && ilon >= 3 {
        zone = 32;
    } else if (72.0..=84.0).contains(&p.lat) && (0..42).contains(&ilon) {
        zone = 2 * ((ilon + 183) / 12) + 1;
    }
    Ok(zone as u8)
}

#[cfg(test)]
/// The UTM latitude band letter (C..X, no I or O) of a latitude in the UTM domain.
pub(crate) fn band_letter(lat: f64) -> Result<char, GeoError> {
    let p = check_utm_domain(LatLon::new(lat, 0.0))?;
    const BANDS: &[u8; 20] = b"CDEFGHJKLMNPQRSTUVWX";
    let i = (((p.lat + 80.0) / 8.0).floor() as usize).min(19);
    Ok(BANDS[i] as char)
}

/// `p` in its standard zone ([`zone_for`]) and hemisphere (north for lat ≥ 0).
pub fn to_utm(p: LatLon) -> Result<Utm, GeoError> {
    let zone = zone_for(p.lat, p.lon)?;
    to_utm_in_zone(p, zone, Hemisphere::of_lat(p.lat))
}

/// `p` in a forced `zone` and `hemisphere` (a grid keeps its origin's zone for cells that
/// reach into the next one). `p` must be within `MAX_ZONE_OFFSET_DEG` of the zone's central
/// meridian; the hemisphere only selects the false northing, so a point south of the
/// equator in a northern frame has a negative northing.
pub fn to_utm_in_zone(p: LatLon, zone: u8, hemisphere: Hemisphere) -> Result<Utm, GeoError> {
    let p = check_utm_domain(p)?;
    let zone = check_zone(zone)?;
    let dlon = wrap180(p.lon - central_meridian(zone));
    if dlon.abs() > MAX_ZONE_OFFSET_DEG {
        return Err(GeoError::TooFarFromZone {
            lon: p.lon,
            zone,
            offset_deg: dlon.abs(),
            max_deg: MAX_ZONE_OFFSET_DEG,
        });
    }
    let f = tm::forward(p.lat, dlon);
    Ok(Utm {
        easting: FALSE_EASTING + f.x,
        northing: f.y + hemisphere.false_northing(),
        zone,
        hemisphere,
    })
}

/// The WGS84 position of a UTM coordinate. The result must lie in the UTM domain
/// (80°S..=84°N, clamped within 1e-9° of the limits) and within `MAX_ZONE_OFFSET_DEG` of
/// the zone's central meridian; longitudes are returned in −180..180.
pub fn from_utm(u: &Utm) -> Result<LatLon, GeoError> {
    if !u.easting.is_finite() {
        return Err(GeoError::NotFinite {
            what: "easting",
            value: u.easting,
        });
    }
    if !u.northing.is_finite() {
        return Err(GeoError::NotFinite {
            what: "northing",
            value: u.northing,
        });
    }
    let zone = check_zone(u.zone)?;
    let (mut lat, dlon) = raw_inverse(u);
    if !(MIN_LAT - DOMAIN_SLACK_DEG..=MAX_LAT + DOMAIN_SLACK_DEG).contains(&lat) {
        return Err(GeoError::OutsideUtm { lat });
    }
    lat = lat.clamp(MIN_LAT, MAX_LAT);
    let lon = wrap180(central_meridian(zone) + dlon);
    if dlon.abs() > MAX_ZONE_OFFSET_DEG + DOMAIN_SLACK_DEG {
        return Err(GeoError::TooFarFromZone {
            lon,
            zone,
            offset_deg: dlon.abs(),
            max_deg: MAX_ZONE_OFFSET_DEG,
        });
    }
    Ok(LatLon::new(lat, lon))
}

/// The inverse projection without domain checks: (latitude, longitude − central meridian)
/// in degrees. Total for finite input.
pub(crate) fn raw_inverse(u: &Utm) -> (f64, f64) {
    tm::reverse(
        u.easting - FALSE_EASTING,
        u.northing - u.hemisphere.false_northing(),
    )
}

/// [`raw_inverse`] as a position, longitude wrapped to −180..180 (no domain checks).
pub(crate) fn raw_from_utm(u: &Utm) -> LatLon {
    let (lat, dlon) = raw_inverse(u);
    LatLon::new(lat, wrap180(central_meridian(u.zone) + dlon))
}

/// Meridian convergence and point scale factor of `p` in `zone`: (γ degrees, k).
/// γ is the clockwise angle from true north to grid north (positive east of the central
/// meridian in the northern hemisphere): a heading of `h` degrees true is `h − γ` on the
/// grid. k is the UTM scale (grid metres per ground metre, 0.9996 on the central meridian).
pub fn convergence_and_scale(p: LatLon, zone: u8) -> Result<(f64, f64), GeoError> {
    let p = check_utm_domain(p)?;
    let zone = check_zone(zone)?;
    let dlon = wrap180(p.lon - central_meridian(zone));
    if dlon.abs() > MAX_ZONE_OFFSET_DEG {
        return Err(GeoError::TooFarFromZone {
            lon: p.lon,
            zone,
            offset_deg: dlon.abs(),
            max_deg: MAX_ZONE_OFFSET_DEG,
        });
    }
    let f = tm::forward(p.lat, dlon);
    Ok((f.gamma_deg, f.k))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_zones_and_exceptions() {
        assert_eq!(zone_for(0.0, 0.0), Ok(31));
        assert_eq!(zone_for(0.0, -180.0), Ok(1));
        assert_eq!(zone_for(0.0, 180.0), Ok(1));
        assert_eq!(zone_for(0.0, 179.999), Ok(60));
        assert_eq!(zone_for(-33.92, 18.42), Ok(34));
        assert_eq!(zone_for(37.1968, -80.5781), Ok(17));
        // Norway: 32V spans 3..12°E between 56 and 64°N.
        assert_eq!(zone_for(60.0, 2.999), Ok(31));
        assert_eq!(zone_for(60.0, 3.0), Ok(32));
        assert_eq!(zone_for(63.999, 5.5), Ok(32));
        assert_eq!(zone_for(64.0, 5.5), Ok(31));
        assert_eq!(zone_for(55.999, 5.5), Ok(31));
        assert_eq!(zone_for(60.0, 11.999), Ok(32));
        assert_eq!(zone_for(60.0, 12.0), Ok(33));
        // Svalbard: 31X 0..9, 33X 9..21, 35X 21..33, 37X 33..42 between 72 and 84°N.
        assert_eq!(zone_for(78.0, -0.001), Ok(30));
        assert_eq!(zone_for(78.0, 0.0), Ok(31));
        assert_eq!(zone_for(78.0, 8.999), Ok(31));
        assert_eq!(zone_for(78.0, 9.0), Ok(33));
        assert_eq!(zone_for(78.0, 20.999), Ok(33));
        assert_eq!(zone_for(78.0, 21.0), Ok(35));
        assert_eq!(zone_for(78.0, 32.999), Ok(35));
        assert_eq!(zone_for(78.0, 33.0), Ok(37));
        assert_eq!(zone_for(84.0, 41.999), Ok(37));
        assert_eq!(zone_for(78.0, 42.0), Ok(38));
        assert_eq!(zone_for(71.999, 10.0), Ok(32));
        assert_eq!(band_letter(78.0), Ok('X'));
        assert_eq!(band_letter(84.0), Ok('X'));
        assert_eq!(band_letter(-80.0), Ok('C'));
        assert_eq!(band_letter(60.0), Ok('V'));
    }

    #[test]
    fn domain_errors() {
        assert_eq!(
            zone_for(84.0001, 0.0),
            Err(GeoError::OutsideUtm { lat: 84.0001 })
        );
        assert_eq!(
            zone_for(-80.5, 0.0),
            Err(GeoError::OutsideUtm { lat: -80.5 })
        );
        assert_eq!(
            to_utm(LatLon::new(95.0, 0.0)),
            Err(GeoError::LatitudeOutOfRange { lat: 95.0 })
        );
        assert!(matches!(
            to_utm(LatLon::new(f64::NAN, 0.0)),
            Err(GeoError::NotFinite {
                what: "latitude",
                ..
            })
        ));
        assert!(matches!(
            to_utm(LatLon::new(0.0, 181.0)),
            Err(GeoError::LongitudeOutOfRange { .. })
        ));
        assert_eq!(
            to_utm_in_zone(LatLon::new(0.0, 0.0), 0, Hemisphere::North),
            Err(GeoError::InvalidZone { zone: 0 })
        );
        assert!(matches!(
            to_utm_in_zone(LatLon::new(0.0, 30.0), 31, Hemisphere::North),
            Err(GeoError::TooFarFromZone { zone: 31, .. })
        ));
        let far = Utm {
            easting: 500_000.0,
            northing: 9_500_000.0,
            zone: 31,
            hemisphere: Hemisphere::North,
        };
        assert!(matches!(from_utm(&far), Err(GeoError::OutsideUtm { .. })));
        let nan = Utm {
            easting: f64::NAN,
            ..far
        };
        assert!(matches!(
            from_utm(&nan),
            Err(GeoError::NotFinite {
                what: "easting",
                ..
            })
        ));
        // The messages say what was expected.
        let msg = to_utm(LatLon::new(85.0, 0.0)).unwrap_err().to_string();
        assert!(msg.contains("80°S to 84°N"), "{msg}");
    }

    #[test]
    fn forced_zone_across_the_antimeridian() {
        // Zone 60's central meridian is 177°E; −179° is 4° east of it.
        let u = to_utm_in_zone(LatLon::new(-10.0, -179.0), 60, Hemisphere::South).unwrap();
        let back = from_utm(&u).unwrap();
        assert!((back.lat + 10.0).abs() < 1e-12 && (back.lon + 179.0).abs() < 1e-11);
        assert!(u.easting > 900_000.0);
    }

    #[test]
    fn limits_round_trip() {
        for p in [LatLon::new(84.0, 17.0), LatLon::new(-80.0, -123.0)] {
            let u = to_utm(p).unwrap();
            let q = from_utm(&u).unwrap();
            assert!((q.lat - p.lat).abs() < 1e-12 && (q.lon - p.lon).abs() < 1e-12);
        }
    }
}
