//! Comparing times without the soft-float library.
//!
//! Times are `f64` seconds, and the Cortex-M4F has no double-precision unit: every `a < b` on
//! them is a call into the compiler's soft-float library (`__aeabi_dcmplt`, some thirty
//! instructions), and the paths that run once per CAN frame compare times several times. For
//! numbers that are not NaN, the order of `f64` values is the order of their bits read as
//! sign and magnitude, which integer instructions compare in a handful (`f64::total_cmp`, which
//! [`before`] uses). [`before`] is `a < b` exactly, zeros of either sign included, for every
//! pair that is not NaN.

/// `a < b`, by the bits: exactly `<` for every pair of `f64` that is not NaN (the times this
/// crate compares are checked finite where they enter). A NaN is ordered by its bits, as in
/// `f64::total_cmp`: never a panic, and no caller here meets one.
#[inline]
pub fn before(a: f64, b: f64) -> bool {
    // `total_cmp` orders -0 before +0; `<` calls them equal.
    (a.to_bits() | b.to_bits()) << 1 != 0 && a.total_cmp(&b).is_lt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn before_is_less_than_for_every_pair() {
        let mut v = [
            0.0, -0.0, 1.0, -1.0, f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 5e-324, -5e-324, f64::MAX, f64::MIN, f64::INFINITY,
            f64::NEG_INFINITY, f64::NAN, -f64::NAN, 1.7e9, 1.7e9 + 1e-6, 0.1, 0.30000000000000004, 1e12, -1e12,
        ]
        .to_vec();
        // And a deterministic scatter over magnitudes and signs.
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..400 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            v.push(f64::from_bits(s));
            v.push((s % 100_000) as f64 * 1e-3 - 50.0);
        }
        v.retain(|x| !x.is_nan());
        for &a in &v {
            for &b in &v {
                assert_eq!(before(a, b), a < b, "{a:e} < {b:e}");
            }
        }
        // A NaN is ordered by its bits (as `total_cmp`), and never panics.
        assert!(before(1.0, f64::NAN) && before(-f64::NAN, 1.0));
    }
}
