//! Transverse Mercator on the WGS84 ellipsoid with Krüger's series to order n⁶.
//!
//! This is the algorithm of Karney, "Transverse Mercator with an accuracy of a few
//! nanometers" (J. Geodesy 85, 2011) as implemented in GeographicLib's `TransverseMercator`
//! (geographiclib/geographiclib, `src/TransverseMercator.cpp`, `TM_TX_MAXPOW = 6`, and
//! `Math::taupf` / `Math::tauf` in `src/Math.cpp`), which is also what PROJ evaluates for UTM
//! (OSGeo/PROJ, `src/projections/tmerc.cpp`, the Poder/Engsager "exact" algorithm: its
//! `gtu`/`utg` coefficients are GeographicLib's α/−β below, and `Qn` is `k0·b1`).
//!
//! Steps (forward): geodetic latitude φ → conformal latitude φ′ (via τ′ = tan φ′ from
//! τ = tan φ, Karney eq. 7–9); the Gauss–Schreiber projection of the conformal sphere
//! ζ′ = ξ′ + iη′ (eq. 10); Krüger's series ζ = ζ′ + Σ αⱼ sin 2jζ′ (eq. 11, j = 1..6), summed by
//! complex Clenshaw recurrence; then y = k₀·A·ξ, x = k₀·A·η with the rectifying radius
//! A = a·b₁. The inverse reverts the series with βⱼ and solves τ from τ′ with Newton's method.
//! The series error is below 5 nm within 3900 km of the central meridian (Karney §4), far
//! more than UTM ever needs.
//!
//! These functions are total (any finite input gives a finite output, the parity and
//! "backside" handling of GeographicLib included); the UTM layer (`geo::utm`) adds false
//! origins, zones and the domain checks.

use super::local::{WGS84_A, WGS84_F};

/// UTM central scale factor.
pub(crate) const K0: f64 = 0.9996;

/// Third flattening n = f / (2 − f).
const N: f64 = WGS84_F / (2.0 - WGS84_F);
/// First eccentricity squared e² = f (2 − f).
const E2: f64 = WGS84_F * (2.0 - WGS84_F);
/// 1 − e².
const E2M: f64 = 1.0 - E2;

/// b₁ = A / a, the rectifying radius over the equatorial radius, to n⁶ (GeographicLib
/// `_b1`; PROJ `Qn / k0`).
const B1: f64 = 1.0 / (1.0 + N) * (N * N * (N * N * (N * N + 4.0) + 64.0) + 256.0) / 256.0;

const N2: f64 = N * N;
const N3: f64 = N2 * N;
const N4: f64 = N3 * N;
const N5: f64 = N4 * N;
const N6: f64 = N5 * N;

/// Krüger's forward coefficients α₁..α₆ (index 0 unused), GeographicLib `_alp` for
/// `maxpow = 6`; PROJ's `gtu[0..6]`.
const ALP: [f64; 7] = [
    0.0,
    N * (N * (N * (N * (N * (31564.0 * N - 66675.0) + 34440.0) + 47250.0) - 100800.0) + 75600.0)
        / 151200.0,
    N2 * (N * (N * ((863232.0 - 1983433.0 * N) * N + 748608.0) - 1161216.0) + 524160.0) / 1935360.0,
    N3 * (N * (N * (670412.0 * N + 406647.0) - 533952.0) + 184464.0) / 725760.0,
    N4 * (N * (6601661.0 * N - 7732800.0) + 2230245.0) / 7257600.0,
    (3438171.0 - 13675556.0 * N) * N5 / 7983360.0,
    212378941.0 * N6 / 319334400.0,
];

/// Krüger's inverse coefficients β₁..β₆ (index 0 unused), GeographicLib `_bet`; PROJ's
/// `utg[0..6]` are −βⱼ.
const BET: [f64; 7] = [
    0.0,
    N * (N * (N * (N * (N * (384796.0 * N - 382725.0) - 6720.0) + 932400.0) - 1612800.0)
        + 1209600.0)
        / 2419200.0,
    N2 * (N * (N * ((1695744.0 - 1118711.0 * N) * N - 1174656.0) + 258048.0) + 80640.0) / 3870720.0,
    N3 * (N * (N * (22276.0 * N - 16929.0) - 15984.0) + 12852.0) / 362880.0,
    N4 * ((-830251.0 * N - 158400.0) * N + 197865.0) / 7257600.0,
    (453717.0 - 435388.0 * N) * N5 / 15966720.0,
    20648693.0 * N6 / 638668800.0,
];

/// First eccentricity e (not a `const`: `sqrt` is not const-evaluable).
fn ecc() -> f64 {
    E2.sqrt()
}

/// e·atanh(e·x) (GeographicLib `Math::eatanhe`, e > 0).
fn eatanhe(x: f64) -> f64 {
    let e = ecc();
    e * (e * x).atanh()
}

/// τ′ = tan φ′ (conformal latitude) from τ = tan φ (GeographicLib `Math::taupf`).
fn taupf(tau: f64) -> f64 {
    if !tau.is_finite() {
        return tau;
    }
    let tau1 = 1f64.hypot(tau);
    let sig = eatanhe(tau / tau1).sinh();
    1f64.hypot(sig) * tau - sig * tau1
}

/// τ = tan φ from τ′ = tan φ′ by Newton's method (GeographicLib `Math::tauf`: one or two
/// iterations reach full double precision).
fn tauf(taup: f64) -> f64 {
    const NUMIT: usize = 5;
    let tol = f64::EPSILON.sqrt() / 10.0;
    let taumax = 2.0 / f64::EPSILON.sqrt();
    let mut tau = if taup.abs() > 70.0 {
        taup * eatanhe(1.0).exp()
    } else {
        taup / E2M
    };
    let stol = tol * 1f64.max(taup.abs());
    if tau.is_nan() || tau.abs() >= taumax {
        return tau;
    }
    for _ in 0..NUMIT {
        let taupa = taupf(tau);
        let dtau =
            (taup - taupa) * (1.0 + E2M * tau * tau) / (E2M * 1f64.hypot(tau) * 1f64.hypot(taupa));
        tau += dtau;
        if dtau.is_nan() || dtau.abs() < stol {
            break;
        }
    }
    tau
}

/// A complex number (re, im) for the Clenshaw sums over ζ = ξ + iη.
#[derive(Clone, Copy, Debug)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
}

/// For ζ = ξ + iη and coefficients c₁..c₆ (`c[0]` unused), returns
/// (S, D) = (Σ cⱼ sin 2jζ, 1 + Σ 2j·cⱼ cos 2jζ) by Clenshaw's recurrence
/// (b_j = c_j + 2cos(2ζ)·b_{j+1} − b_{j+2}; S = b₁ sin 2ζ; the cosine series likewise with
/// S′ = u₁ cos 2ζ − u₂), as in GeographicLib's Forward/Reverse.
fn clenshaw(c: &[f64; 7], xi: f64, eta: f64) -> (C, C) {
    let (s0, c0) = (2.0 * xi).sin_cos();
    let (sh0, ch0) = ((2.0 * eta).sinh(), (2.0 * eta).cosh());
    let cos2z = C(c0 * ch0, -s0 * sh0);
    let sin2z = C(s0 * ch0, c0 * sh0);
    let a = C(2.0 * cos2z.0, 2.0 * cos2z.1);
    let (mut b1, mut b2) = (C(0.0, 0.0), C(0.0, 0.0));
    let (mut u1, mut u2) = (C(0.0, 0.0), C(0.0, 0.0));
    for j in (1..c.len()).rev() {
        let b0 = a.mul(b1).sub(b2).add(C(c[j], 0.0));
        b2 = b1;
        b1 = b0;
        let u0 = a.mul(u1).sub(u2).add(C(2.0 * j as f64 * c[j], 0.0));
        u2 = u1;
        u1 = u0;
    }
    let s = b1.mul(sin2z);
    let d = C(1.0, 0.0).add(u1.mul(cos2z)).sub(u2);
    (s, d)
}

/// Forward transverse Mercator result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Forward {
    /// Easting from the central meridian, metres (scaled by [`K0`]).
    pub x: f64,
    /// Northing from the equator, metres (scaled by [`K0`]).
    pub y: f64,
    /// Meridian convergence γ in degrees: the angle from true north to grid north,
    /// measured clockwise (positive east of the central meridian in the north).
    pub(crate) gamma_deg: f64,
    /// Point scale factor k (dimensionless; [`K0`] on the central meridian).
    pub k: f64,
}

/// Geodetic (`lat_deg`, `dlon_deg` = longitude minus the central meridian, in −180..=180)
/// → transverse Mercator (x, y) in metres with scale [`K0`] on the central meridian.
pub(crate) fn forward(lat_deg: f64, dlon_deg: f64) -> Forward {
    let mut latsign = if lat_deg < 0.0 { -1.0 } else { 1.0 };
    let lonsign = if dlon_deg < 0.0 { -1.0 } else { 1.0 };
    let lat = lat_deg.abs();
    let mut lon = dlon_deg.abs();
    let backside = lon > 90.0;
    if backside {
        if lat == 0.0 {
            latsign = -1.0;
        }
        lon = 180.0 - lon;
    }
    let phi = lat.to_radians();
    let lam = lon.to_radians();
    let (xip, etap, mut gamma, mut k);
    if lat != 90.0 {
        let (sin_lam, cos_lam) = lam.sin_cos();
        let c = cos_lam.max(0.0);
        let tau = phi.tan();
        let secphi = 1f64.hypot(tau);
        let taup = taupf(tau);
        xip = taup.atan2(c);
        etap = (sin_lam / taup.hypot(c)).asinh();
        // Gauss–Schreiber convergence and scale (Krüger p. 22 (44), via GeographicLib).
        gamma = (lam.tan() * taup / 1f64.hypot(taup)).atan();
        let cos_phi = phi.cos();
        k = (E2M + E2 * cos_phi * cos_phi).sqrt() * secphi / taup.hypot(c);
    } else {
        xip = std::f64::consts::FRAC_PI_2;
        etap = 0.0;
        gamma = lam;
        k = E2M.sqrt() * eatanhe(1.0).exp();
    }
    let (s, d) = clenshaw(&ALP, xip, etap);
    let xi = xip + s.0;
    let eta = etap + s.1;
    gamma -= d.1.atan2(d.0);
    k *= B1 * d.0.hypot(d.1);
    let mut gamma_deg = gamma.to_degrees();
    let a1 = WGS84_A * B1;
    let y = a1
        * K0
        * (if backside {
            std::f64::consts::PI - xi
        } else {
            xi
        })
        * latsign;
    let x = a1 * K0 * eta * lonsign;
    if backside {
        gamma_deg = 180.0 - gamma_deg;
    }
    gamma_deg *= latsign * lonsign;
    Forward {
        x,
        y,
        gamma_deg,
        k: k * K0,
    }
}

/// Inverse of [`forward`]: (x, y) metres from the central meridian and the equator →
/// (latitude, longitude − central meridian) in degrees.
pub(crate) fn reverse(x: f64, y: f64) -> (f64, f64) {
    let a1 = WGS84_A * B1;
    let mut xi = y / (a1 * K0);
    let mut eta = x / (a1 * K0);
    let xisign = if xi < 0.0 { -1.0 } else { 1.0 };
    let etasign = if eta < 0.0 { -1.0 } else { 1.0 };
    xi *= xisign;
    eta *= etasign;
    let backside = xi > std::f64::consts::FRAC_PI_2;
    if backside {
        xi = std::f64::consts::PI - xi;
    }
    let neg_bet = BET.map(|b| -b);
    let (s, _d) = clenshaw(&neg_bet, xi, eta);
    let xip = xi + s.0;
    let etap = eta + s.1;
    let sh = etap.sinh();
    let c = xip.cos().max(0.0);
    let r = sh.hypot(c);
    let (phi, lam) = if r != 0.0 {
        let lam = sh.atan2(c);
        let taup = xip.sin() / r;
        let tau = tauf(taup);
        (tau.atan(), lam)
    } else {
        (std::f64::consts::FRAC_PI_2, 0.0)
    };
    let lat = phi.to_degrees() * xisign;
    let mut lon = lam.to_degrees();
    if backside {
        lon = 180.0 - lon;
    }
    (lat, lon * etasign)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn central_meridian_is_the_scaled_meridian_arc() {
        // On the central meridian x = 0 and y = k0 · (meridian arc); at the equator y = 0.
        let f = forward(0.0, 0.0);
        assert_eq!((f.x, f.y), (0.0, 0.0));
        assert!((f.k - K0).abs() < 1e-15);
        // Quarter meridian of WGS84: 10 001 965.729 m (GeographicLib / Karney 2011).
        let pole = forward(90.0, 0.0);
        assert!(
            (pole.y / K0 - 10_001_965.729_2).abs() < 1e-3,
            "{}",
            pole.y / K0
        );
    }

    #[test]
    fn reverse_inverts_forward() {
        for &lat in &[-80.0, -45.3, -0.001, 0.0, 0.3, 33.3, 60.0, 84.0, 89.9] {
            for &dlon in &[-15.0, -3.0, -0.2, 0.0, 1e-9, 2.9, 3.0, 7.5] {
                let f = forward(lat, dlon);
                let (la, lo) = reverse(f.x, f.y);
                assert!((la - lat).abs() < 1e-12, "{lat} {dlon}: {la}");
                assert!((lo - dlon).abs() < 1e-11, "{lat} {dlon}: {lo}");
            }
        }
    }

    #[test]
    fn odd_symmetry() {
        let a = forward(40.0, 2.0);
        let b = forward(-40.0, -2.0);
        assert_eq!((a.x, a.y), (-b.x, -b.y));
        assert!(a.gamma_deg > 0.0 && (a.gamma_deg - b.gamma_deg).abs() < 1e-12);
    }

    #[test]
    fn convergence_and_scale_match_closed_forms_to_first_order() {
        // γ ≈ Δλ·sin φ close to the central meridian; on the equator
        // k = k0·(1 + (1 + e′²)λ²/2 + (5 + 14e′²)λ⁴/24 + O(λ⁶)) (Snyder 1987, eq. 8-11).
        let f = forward(45.0, 0.01);
        assert!((f.gamma_deg - 0.01 * 45f64.to_radians().sin()).abs() < 1e-8);
        let g = forward(0.0, 3.0);
        let ep2 = E2 / E2M;
        let l2 = 3f64.to_radians().powi(2);
        let kk = K0 * (1.0 + (1.0 + ep2) * l2 / 2.0 + (5.0 + 14.0 * ep2) * l2 * l2 / 24.0);
        assert!((g.k - kk).abs() < 1e-8, "{} {}", g.k, kk);
    }
}
