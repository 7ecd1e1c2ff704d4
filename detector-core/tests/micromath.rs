//! Why the per-epoch geodesy uses libm's f32 functions and not `micromath` (the customer's design
//! card names it): measured here, printed, and asserted so that the README's figures stay true.
//!
//! The location shift between two 10 Hz epochs is 0.5 to 3 m: half-angles of about 1e-7 rad in
//! the haversine. micromath's `sin` is a polynomial with an absolute error of about 1e-3, which
//! is more than the angle itself; libm's `sinf` is within an ulp. (`cargo test -p detector-core
//! --test micromath -- --nocapture` prints the figures.)

use detector_core::geo::{haversine_f32_m, haversine_m, LatLon, EARTH_RADIUS_PAPER_M};
use micromath::F32Ext;

fn hav_micromath(a: LatLon, b: LatLon) -> f64 {
    let dp = ((b.lat_deg - a.lat_deg) as f32).to_radians();
    let dl = ((b.lon_deg - a.lon_deg) as f32).to_radians();
    let (p1, p2) = ((a.lat_deg as f32).to_radians(), (b.lat_deg as f32).to_radians());
    let (s1, s2) = (F32Ext::sin(dp * 0.5), F32Ext::sin(dl * 0.5));
    let h = s1 * s1 + F32Ext::cos(p1) * F32Ext::cos(p2) * s2 * s2;
    (2.0 * EARTH_RADIUS_PAPER_M as f32 * F32Ext::asin(F32Ext::sqrt(h.clamp(0.0, 1.0)))) as f64
}

#[test]
fn micromath_is_too_coarse_for_an_epochs_shift_and_libm_f32_is_not() {
    let mut sin_abs = 0.0f64;
    for i in 0..=100_000 {
        let x = -std::f64::consts::PI + std::f64::consts::TAU * i as f64 / 100_000.0;
        sin_abs = sin_abs.max((F32Ext::sin(x as f32) as f64 - x.sin()).abs());
    }
    let (mut mm_worst, mut libm_worst) = (0.0f64, 0.0f64);
    let mut seed = 12_345u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..20_000 {
        let a = LatLon::new(-60.0 + 120.0 * rnd(), -179.0 + 358.0 * rnd());
        let (d, brg) = (0.5 + 2.5 * rnd(), std::f64::consts::TAU * rnd());
        let b = LatLon::new(a.lat_deg + d * brg.cos() / 111_319.0, a.lon_deg + d * brg.sin() / (111_319.0 * a.lat_deg.to_radians().cos()));
        let truth = haversine_m(a, b, EARTH_RADIUS_PAPER_M);
        mm_worst = mm_worst.max((hav_micromath(a, b) - truth).abs());
        libm_worst = libm_worst.max((haversine_f32_m(a, b, EARTH_RADIUS_PAPER_M) as f64 - truth).abs());
    }
    eprintln!("micromath sin: worst absolute error over [-pi, pi] {sin_abs:.2e}");
    eprintln!("haversine of 0.5-3 m shifts: micromath worst error {mm_worst:.3} m, libm f32 worst error {libm_worst:.2e} m");
    assert!(mm_worst > 1.0, "micromath got accurate enough to reconsider: {mm_worst} m");
    assert!(libm_worst < 1e-5, "{libm_worst} m");
}
