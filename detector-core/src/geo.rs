//! Geodesy on a spherical Earth.
//!
//! Positions are `f64` degrees: at 10 Hz a car moves 1 to 3 m per epoch, and an `f32` longitude
//! near 122 degrees resolves only about 0.85 m, which would swamp the location-shift check.
//!
//! The Cortex-M4F has no double-precision FPU: an `f64` haversine costs about 12,000
//! instructions there and an `f64` bearing 19,000 (QEMU). The per-epoch path therefore uses
//! [`haversine_f32_m`], [`bearing_f32_deg`] and the local projections, which take only the
//! coordinate *differences* in `f64` (a subtraction, exact to well under a millimetre) and do
//! the trigonometry in `f32` on the hardware FPU, arranged so that nothing small is found by
//! subtracting two large numbers. Their error against the `f64` forms is tested (relative 1e-6
//! and 1e-3 degrees); the `f64` forms stay for host tools and as the reference.

/// Mean Earth radius (IUGG), metres.
pub const EARTH_RADIUS_MEAN_M: f64 = 6_371_008.8;
/// The radius Dasgupta et al. use in their haversine (6378 km, the equatorial radius rounded).
pub const EARTH_RADIUS_PAPER_M: f64 = 6_378_000.0;

/// A WGS84 position in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct LatLon {
    /// Latitude, degrees, + = north.
    pub lat_deg: f64,
    /// Longitude, degrees, + = east.
    pub lon_deg: f64,
}

impl LatLon {
    /// A position from latitude and longitude, degrees.
    pub const fn new(lat_deg: f64, lon_deg: f64) -> Self {
        Self { lat_deg, lon_deg }
    }

    /// Finite, latitude within [-90, 90] and longitude within [-180, 180].
    pub fn is_valid(&self) -> bool {
        self.lat_deg.is_finite()
            && self.lon_deg.is_finite()
            && (-90.0..=90.0).contains(&self.lat_deg)
            && (-180.0..=180.0).contains(&self.lon_deg)
    }
}

/// Great-circle distance in metres by the haversine formula on a sphere of `radius_m`.
pub fn haversine_m(a: LatLon, b: LatLon, radius_m: f64) -> f64 {
    let (p1, p2) = (a.lat_deg.to_radians(), b.lat_deg.to_radians());
    let dp = p2 - p1;
    let dl = (b.lon_deg - a.lon_deg).to_radians();
    let s1 = libm::sin(dp * 0.5);
    let s2 = libm::sin(dl * 0.5);
    let h = s1 * s1 + libm::cos(p1) * libm::cos(p2) * s2 * s2;
    // Rounding can push h a hair above 1 for antipodal points; asin would return NaN.
    2.0 * radius_m * libm::asin(libm::sqrt(h.clamp(0.0, 1.0)))
}

/// `b`'s longitude minus `a`'s, wrapped into [-180, 180] degrees in `f64` (so that the `f32`
/// sines across the antimeridian see a small angle), in radians.
fn lon_diff_rad(a: LatLon, b: LatLon) -> f32 {
    let d = b.lon_deg - a.lon_deg;
    let d = if d > 180.0 { d - 360.0 } else if d < -180.0 { d + 360.0 } else { d };
    (d as f32).to_radians()
}

/// [`haversine_m`] with the latitude and longitude differences taken in `f64` and the
/// trigonometry in `f32` (see the module documentation): what the detector runs per epoch.
pub fn haversine_f32_m(a: LatLon, b: LatLon, radius_m: f64) -> f32 {
    let dp = ((b.lat_deg - a.lat_deg) as f32).to_radians();
    let dl = lon_diff_rad(a, b);
    let (p1, p2) = ((a.lat_deg as f32).to_radians(), (b.lat_deg as f32).to_radians());
    let s1 = crate::trig::sinf(dp * 0.5);
    let s2 = crate::trig::sinf(dl * 0.5);
    let h = s1 * s1 + crate::trig::cosf(p1) * crate::trig::cosf(p2) * s2 * s2;
    // Rounding can push h a hair above 1 for antipodal points; asin would return NaN.
    #[allow(clippy::manual_clamp)] // max/min: no bounds assertion in the no-panic link
    let h = h.max(0.0).min(1.0);
    2.0 * radius_m as f32 * libm::asinf(gnss_guard_dsp::sqrtf(h))
}

/// [`initial_bearing_deg`] in `f32` on the coordinate differences: with
/// `cos p1 sin p2 - sin p1 cos p2 cos dl = sin(p2 - p1) + sin p1 cos p2 * 2 sin^2(dl / 2)`
/// nothing cancels for nearby points. Degrees in [0, 360).
pub fn bearing_f32_deg(a: LatLon, b: LatLon) -> f32 {
    let dp = ((b.lat_deg - a.lat_deg) as f32).to_radians();
    let dl = lon_diff_rad(a, b);
    let (p1, p2) = ((a.lat_deg as f32).to_radians(), (b.lat_deg as f32).to_radians());
    let h = crate::trig::sinf(dl * 0.5);
    let y = crate::trig::sinf(dl) * crate::trig::cosf(p2);
    let x = crate::trig::sinf(dp) + crate::trig::sinf(p1) * crate::trig::cosf(p2) * 2.0 * h * h;
    let d = libm::atan2f(y, x).to_degrees();
    let r = if d < 0.0 { d + 360.0 } else { d };
    if r >= 360.0 { 0.0 } else { r }
}

/// Initial bearing (forward azimuth) from `a` to `b`, degrees in [0, 360), 0 = north, clockwise.
pub fn initial_bearing_deg(a: LatLon, b: LatLon) -> f64 {
    let (p1, p2) = (a.lat_deg.to_radians(), b.lat_deg.to_radians());
    let dl = (b.lon_deg - a.lon_deg).to_radians();
    let y = libm::sin(dl) * libm::cos(p2);
    let x = libm::cos(p1) * libm::sin(p2) - libm::sin(p1) * libm::cos(p2) * libm::cos(dl);
    wrap_360(libm::atan2(y, x).to_degrees())
}

/// Wraps an angle in degrees to [0, 360).
pub fn wrap_360(deg: f64) -> f64 {
    let r = deg - 360.0 * libm::floor(deg / 360.0);
    if r >= 360.0 { 0.0 } else { r }
}

/// Signed smallest difference `to - from` in degrees, in (-180, 180]; + = clockwise (right turn).
pub fn angle_diff_deg(from: f64, to: f64) -> f64 {
    let d = wrap_360(to - from);
    if d > 180.0 { d - 360.0 } else { d }
}

/// [`angle_diff_deg`] in `f32` for the per-epoch path (headings are `f32`): within
/// `ulp(360)` (3e-5 degrees) of the `f64` form; no soft-float division on the Cortex-M4 for
/// differences within +-540 degrees. NaN in, NaN out.
pub fn angle_diff_f32_deg(from: f32, to: f32) -> f32 {
    let d = to - from;
    if d > 180.0 && d <= 540.0 {
        d - 360.0
    } else if d <= -180.0 && d > -540.0 {
        d + 360.0
    } else if d > -180.0 && d <= 180.0 {
        d
    } else {
        // Far outside (or NaN): the general form.
        angle_diff_deg(from as f64, to as f64) as f32
    }
}

/// The point reached from `a` after `dist_m` along `bearing_deg` (spherical direct problem).
pub fn destination(a: LatLon, bearing_deg: f64, dist_m: f64, radius_m: f64) -> LatLon {
    let d = dist_m / radius_m;
    let th = bearing_deg.to_radians();
    let p1 = a.lat_deg.to_radians();
    let l1 = a.lon_deg.to_radians();
    let p2 = libm::asin(libm::sin(p1) * libm::cos(d) + libm::cos(p1) * libm::sin(d) * libm::cos(th));
    let l2 = l1
        + libm::atan2(
            libm::sin(th) * libm::sin(d) * libm::cos(p1),
            libm::cos(d) - libm::sin(p1) * libm::sin(p2),
        );
    LatLon::new(p2.to_degrees(), wrap_360(l2.to_degrees() + 180.0) - 180.0)
}

/// East/north metres of `p` from `origin` (equirectangular; good to ~0.1 % within 10 km).
pub fn to_local(origin: LatLon, p: LatLon, radius_m: f64) -> (f64, f64) {
    let k = radius_m * core::f64::consts::PI / 180.0;
    let e = (p.lon_deg - origin.lon_deg) * k * cos_lat(origin.lat_deg);
    let n = (p.lat_deg - origin.lat_deg) * k;
    (e, n)
}

/// The cosine of a latitude for the local projections: `f32` on the FPU (relative error about
/// 1e-7, far below the projection's own 0.1 %).
fn cos_lat(lat_deg: f64) -> f64 {
    crate::trig::cosf((lat_deg as f32).to_radians()) as f64
}

/// Inverse of [`to_local`].
pub fn from_local(origin: LatLon, east_m: f64, north_m: f64, radius_m: f64) -> LatLon {
    let k = radius_m * core::f64::consts::PI / 180.0;
    let c = cos_lat(origin.lat_deg).max(1e-9);
    LatLon::new(origin.lat_deg + north_m / k, origin.lon_deg + east_m / (k * c))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `f32` per-epoch forms against the `f64` ones: relative 3e-6 for distances from a
    /// decimetre to 200 km (1e-6 but near the poles, where the `f32` latitude's rounding weighs
    /// on its cosine), 1e-3 degrees of bearing from a metre, anywhere on Earth including across
    /// the antimeridian (LCG points, latitudes within 85 degrees).
    #[test]
    fn f32_forms_agree_with_f64() {
        let mut seed = 0x9e37_79b9u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f64 / (1u32 << 24) as f64
        };
        let (mut worst_rel, mut worst_brg) = (0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let a = LatLon::new(-85.0 + 170.0 * rnd(), -180.0 + 360.0 * rnd());
            let d = libm::pow(10.0, -1.0 + 6.3 * rnd());
            let b = destination(a, 360.0 * rnd(), d, EARTH_RADIUS_PAPER_M);
            let (h64, h32) = (haversine_m(a, b, EARTH_RADIUS_PAPER_M), haversine_f32_m(a, b, EARTH_RADIUS_PAPER_M) as f64);
            worst_rel = worst_rel.max((h32 - h64).abs() / h64);
            if d >= 1.0 {
                worst_brg = worst_brg.max(angle_diff_deg(initial_bearing_deg(a, b), bearing_f32_deg(a, b) as f64).abs());
            }
        }
        assert!(worst_rel < 3e-6, "haversine: worst relative error {worst_rel:e}");
        assert!(worst_brg < 1e-3, "bearing: worst error {worst_brg:e} deg");
        assert_eq!(haversine_f32_m(LatLon::new(1.0, 2.0), LatLon::new(1.0, 2.0), EARTH_RADIUS_PAPER_M), 0.0);
    }

    #[test]
    fn f32_angle_difference_agrees_with_f64() {
        let mut worst = 0.0f64;
        for i in 0..=3600 {
            for j in [-900.5f32, -360.0, -180.0, -0.25, 0.0, 0.1, 90.0, 179.99, 180.0, 180.01, 359.9, 360.0, 541.0, 1234.5] {
                let (a, b) = (i as f32 * 0.1, j);
                let (d32, d64) = (angle_diff_f32_deg(a, b) as f64, angle_diff_deg(a as f64, b as f64));
                // (-180, 180] both; compare on the circle.
                assert!(d32 > -180.0 && d32 <= 180.0, "{a} -> {b}: {d32}");
                worst = worst.max(angle_diff_deg(d64, d32).abs());
            }
        }
        assert!(worst < 1e-4, "worst {worst}");
        assert!(angle_diff_f32_deg(f32::NAN, 1.0).is_nan());
    }

    #[test]
    fn one_degree_of_latitude() {
        let d = haversine_m(LatLon::new(0.0, 0.0), LatLon::new(1.0, 0.0), EARTH_RADIUS_PAPER_M);
        // 2*pi*R/360
        assert!((d - 111_317.1).abs() < 0.5, "{d}");
    }

    #[test]
    fn known_city_pair() {
        // Paris (48.8566, 2.3522) to London (51.5074, -0.1278): 343.5 km on the mean sphere.
        let d = haversine_m(
            LatLon::new(48.8566, 2.3522),
            LatLon::new(51.5074, -0.1278),
            EARTH_RADIUS_MEAN_M,
        );
        assert!((d / 1000.0 - 343.5).abs() < 0.6, "{d}");
    }

    #[test]
    fn bearings_of_the_cardinal_directions() {
        let o = LatLon::new(10.0, 10.0);
        assert!((initial_bearing_deg(o, LatLon::new(11.0, 10.0)) - 0.0).abs() < 1e-9);
        assert!((initial_bearing_deg(o, LatLon::new(10.0, 11.0)) - 89.9).abs() < 0.2);
        assert!((initial_bearing_deg(o, LatLon::new(9.0, 10.0)) - 180.0).abs() < 1e-9);
        assert!((initial_bearing_deg(o, LatLon::new(10.0, 9.0)) - 270.1).abs() < 0.2);
    }

    #[test]
    fn destination_round_trips_with_distance_and_bearing() {
        let a = LatLon::new(37.72, -122.47);
        for &brg in &[0.0, 45.0, 135.0, 270.0, 359.0] {
            let b = destination(a, brg, 250.0, EARTH_RADIUS_PAPER_M);
            assert!((haversine_m(a, b, EARTH_RADIUS_PAPER_M) - 250.0).abs() < 1e-6);
            assert!(angle_diff_deg(brg, initial_bearing_deg(a, b)).abs() < 1e-3);
        }
    }

    #[test]
    fn local_round_trip() {
        let o = LatLon::new(56.1, 10.2);
        let p = from_local(o, 120.0, -80.0, EARTH_RADIUS_PAPER_M);
        let (e, n) = to_local(o, p, EARTH_RADIUS_PAPER_M);
        assert!((e - 120.0).abs() < 1e-6 && (n + 80.0).abs() < 1e-6);
        assert!((haversine_m(o, p, EARTH_RADIUS_PAPER_M) - 144.22).abs() < 0.1);
    }

    #[test]
    fn angle_helpers() {
        assert_eq!(wrap_360(-10.0), 350.0);
        assert_eq!(wrap_360(720.0), 0.0);
        assert_eq!(angle_diff_deg(350.0, 10.0), 20.0);
        assert_eq!(angle_diff_deg(10.0, 350.0), -20.0);
    }

    #[test]
    fn degenerate_inputs_do_not_produce_nan() {
        let a = LatLon::new(0.0, 0.0);
        assert_eq!(haversine_m(a, a, EARTH_RADIUS_PAPER_M), 0.0);
        let d = haversine_m(a, LatLon::new(0.0, 180.0), EARTH_RADIUS_PAPER_M);
        assert!(d.is_finite());
        assert!(!LatLon::new(f64::NAN, 0.0).is_valid());
        assert!(!LatLon::new(91.0, 0.0).is_valid());
    }
}
