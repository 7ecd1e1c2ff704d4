//! The plane as complex numbers: a 2-D vector (east, north) is `x + i y`, so rotating by
//! `theta` is multiplying by `cis(theta)` and `G conj(D)` carries the angle from `D` to `G`.
//! Leaf helpers for the track check's files.

/// `a b`, complex.
pub(super) fn cmul(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}
/// The conjugate: `a` mirrored across the east axis.
pub(super) fn conj(a: (f32, f32)) -> (f32, f32) {
    (a.0, -a.1)
}
/// `a - b`.
pub(super) fn sub(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0 - b.0, a.1 - b.1)
}
/// `k a`.
pub(super) fn scale2(a: (f32, f32), k: f32) -> (f32, f32) {
    (a.0 * k, a.1 * k)
}
/// `|a|^2`.
pub(super) fn norm2(a: (f32, f32)) -> f32 {
    a.0 * a.0 + a.1 * a.1
}
/// `e^{i x}`: the unit vector at math angle `x`.
pub(super) fn cis(x: f32) -> (f32, f32) {
    let (s, c) = crate::trig::sincosf(x);
    (c, s)
}

