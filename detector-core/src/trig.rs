//! Sine, cosine and tangent of an `f32` for the detector's angles: libm's (0.2.16) algorithms,
//! themselves FreeBSD msun's (`s_sinf.c`, `s_cosf.c`, `s_tanf.c`, `k_sinf.c`, `k_cosf.c`,
//! `k_tanf.c`, `e_rem_pio2f.c`; Copyright (C) 1993 by Sun Microsystems, Inc. All rights
//! reserved. Developed at SunPro, a Sun Microsystems, Inc. business. Permission to use, copy,
//! modify, and distribute this software is freely granted, provided that this notice is
//! preserved.), bit for bit for every `|x| < 2^28 pi/2`.
//!
//! Why not libm's own: beyond `2^28 pi/2` (4.2e8 radians) libm reduces the argument with
//! Payne-Hanek (`rem_pio2_large` and its table of `2/pi`), 2,360 bytes of the board's flash that
//! no angle of the detector reaches: latitudes, longitudes and their differences, headings and
//! steering angles are radians under `2 pi` (a dead-reckoned heading is wrapped). Only a hostile
//! input gets there, and for it a finite argument keeps a finite result, as with libm: it is
//! first taken as its remainder by the `f32` nearest `2 pi` (`libm::remainderf`, exact), which is
//! not the true sine of 4.2e8 radians (an argument that large knows its angle to no better than
//! 32 radians) but a value in `[-1, 1]`; infinities and NaN give NaN. Below the bound nothing
//! differs: the unit tests compare every 4,099th `f32` up to it (and the edges) with libm's, and
//! the QEMU run compares them on the board (`qemu-run`, `trig_parity`).
//! What libm's `force_eval!` does (raise the inexact and underflow flags) is left out: the
//! detector never reads the floating-point flags, and it needs `unsafe`.

// The constants as msun writes them: more digits than an f64 holds, each rounds to the same f64.
#![allow(clippy::excessive_precision)]

use core::f64::consts::FRAC_PI_2;

/// Multiples of pi/2 rounded to double precision (1 to 4).
const PIO2: [f64; 4] = [FRAC_PI_2, 2.0 * FRAC_PI_2, 3.0 * FRAC_PI_2, 4.0 * FRAC_PI_2];

/// `sin(x)` in `[-pi/4, pi/4]` (`k_sinf.c`).
#[inline(never)]
fn k_sinf(x: f64) -> f32 {
    const S1: f64 = -0.166666666416265235595;
    const S2: f64 = 0.0083333293858894631756;
    const S3: f64 = -0.000198393348360966317347;
    const S4: f64 = 0.0000027183114939898219064;
    let z = x * x;
    let w = z * z;
    let r = S3 + z * S4;
    let s = z * x;
    ((x + s * (S1 + z * S2)) + s * w * r) as f32
}

/// `cos(x)` in `[-pi/4, pi/4]` (`k_cosf.c`).
#[inline(never)]
fn k_cosf(x: f64) -> f32 {
    const C0: f64 = -0.499999997251031003120;
    const C1: f64 = 0.0416666233237390631894;
    const C2: f64 = -0.00138867637746099294692;
    const C3: f64 = 0.0000243904487962774090654;
    let z = x * x;
    let w = z * z;
    let r = C2 + z * C3;
    (((1.0 + z * C0) + w * C1) + (w * z) * r) as f32
}

/// `tan(x)` in `[-pi/4, pi/4]`, or `-1/tan(x)` when `odd` (`k_tanf.c`).
#[inline(never)]
fn k_tanf(x: f64, odd: bool) -> f32 {
    const T: [f64; 6] = [0.333331395030791399758, 0.133392002712976742718, 0.0533812378445670393523, 0.0245283181166547278873, 0.00297435743359967304927, 0.00946564784943673166728];
    let z = x * x;
    let mut r = T[4] + z * T[5];
    let t = T[2] + z * T[3];
    let w = z * z;
    let s = z * x;
    let u = T[0] + z * T[1];
    r = (x + s * u) + (s * w) * (t + w * r);
    (if odd { -1. / r } else { r }) as f32
}

/// The quadrant `n` and `x - n pi/2` (in `f64`) for `|x| < 2^28 pi/2`: up to `9 pi/4` by the
/// nearest multiple (msun's `s_sinf.c`, `s_cosf.c` and `s_tanf.c` write these four steps out in
/// each function; `a - b` and `-(b - a)` are the same `f64`, so one form serves all three), beyond
/// it by `e_rem_pio2f.c`'s medium path; `None` beyond that (see [`beyond`]).
#[inline(never)]
fn reduce(x: f32) -> Option<(i32, f64)> {
    const TOINT: f64 = 1.5 / f64::EPSILON;
    const INV_PIO2: f64 = core::f64::consts::FRAC_2_PI; // msun: 6.36619772367581382433e-01, the same f64
    const PIO2_1: f64 = 1.57079631090164184570e+00;
    const PIO2_1T: f64 = 1.58932547735281966916e-08;
    let (ix, x64) = (x.to_bits() & 0x7fff_ffff, x as f64);
    // |x| ~<= pi/4, 3 pi/4, 5 pi/4, 7 pi/4, 9 pi/4: the multiple of pi/2 nearest.
    let (k, p) = if ix <= 0x3f49_0fda {
        return Some((0, x64));
    } else if ix <= 0x4016_cbe3 {
        (1, PIO2[0])
    } else if ix <= 0x407b_53d1 {
        (2, PIO2[1])
    } else if ix <= 0x40af_eddf {
        (3, PIO2[2])
    } else if ix <= 0x40e2_31d5 {
        (4, PIO2[3])
    } else if ix < 0x4dc9_0fdb {
        let f_n = (x64 * INV_PIO2 + TOINT) - TOINT;
        return Some((f_n as i32, x64 - f_n * PIO2_1 - f_n * PIO2_1T));
    } else {
        return None;
    };
    Some(if x.is_sign_negative() { (-k, x64 + p) } else { (k, x64 - p) })
}

/// `f` of a finite `x` beyond `2^28 pi/2` taken as its remainder by the `f32` nearest `2 pi`
/// (within `pi`, so `f` takes it without coming back here; see the module documentation); NaN
/// for infinities and NaN.
fn beyond(x: f32, f: fn(f32) -> f32) -> f32 {
    if x.is_finite() { f(libm::remainderf(x, core::f32::consts::TAU)) } else { f32::NAN }
}

/// Below `2^-12` the sine and the tangent round to `x`, the cosine to 1.
fn tiny(x: f32) -> bool {
    x.to_bits() & 0x7fff_ffff < 0x3980_0000
}

/// The sine of `x` (radians): libm's `sinf` below `2^28 pi/2` (see the module documentation).
#[inline(never)]
pub fn sinf(x: f32) -> f32 {
    if tiny(x) {
        return x;
    }
    match reduce(x) {
        Some((n, y)) => match n & 3 {
            0 => k_sinf(y),
            1 => k_cosf(y),
            2 => k_sinf(-y),
            _ => -k_cosf(y),
        },
        None => beyond(x, sinf),
    }
}

/// The cosine of `x` (radians): libm's `cosf` below `2^28 pi/2`.
#[inline(never)]
pub fn cosf(x: f32) -> f32 {
    if tiny(x) {
        return 1.0;
    }
    match reduce(x) {
        Some((n, y)) => match n & 3 {
            0 => k_cosf(y),
            1 => k_sinf(-y),
            2 => -k_cosf(y),
            _ => k_sinf(y),
        },
        None => beyond(x, cosf),
    }
}

/// The sine and the cosine of `x` (radians) with one reduction: `(sinf(x), cosf(x))`, bit for
/// bit (a unit vector at an angle, the dead reckoning's step: one reduction, not two).
#[inline(never)]
pub fn sincosf(x: f32) -> (f32, f32) {
    if tiny(x) {
        return (x, 1.0);
    }
    match reduce(x) {
        Some((n, y)) => match n & 3 {
            0 => (k_sinf(y), k_cosf(y)),
            1 => (k_cosf(y), k_sinf(-y)),
            2 => (k_sinf(-y), -k_cosf(y)),
            _ => (-k_cosf(y), k_sinf(y)),
        },
        None if x.is_finite() => sincosf(libm::remainderf(x, core::f32::consts::TAU)),
        None => (f32::NAN, f32::NAN),
    }
}

/// The tangent of `x` (radians): libm's `tanf` below `2^28 pi/2`.
#[inline(never)]
pub fn tanf(x: f32) -> f32 {
    if tiny(x) {
        return x;
    }
    match reduce(x) {
        Some((n, y)) => k_tanf(y, n & 1 != 0),
        None => beyond(x, tanf),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same bits as libm's, NaN for NaN.
    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// Every 4,099th `f32` from 0 to `2^28 pi/2` and its negative, the ranges' edges and the
    /// special values: the same bits as libm's `sinf`, `cosf` and `tanf`, and `sincosf` as `sinf`
    /// and `cosf`. Beyond the bound a finite argument keeps a finite result (sine and cosine
    /// within `[-1, 1]`), as with libm; infinities and NaN give NaN.
    #[test]
    fn sin_cos_tan_are_libms_below_the_bound() {
        let edges = [0x3980_0000u32, 0x3f49_0fda, 0x4016_cbe3, 0x407b_53d1, 0x40af_eddf, 0x40e2_31d5, 0x4dc9_0fda];
        let bits = (0..0x4dc9_0fdbu32).step_by(4099).chain(edges.iter().flat_map(|e| e - 2..=e + 2)).chain([0, 1, 0x007f_ffff, 0x0080_0000]).filter(|b| *b < 0x4dc9_0fdb);
        let mut n = 0u32;
        for b in bits {
            for x in [f32::from_bits(b), -f32::from_bits(b)] {
                assert!(same(sinf(x), libm::sinf(x)), "sin({x:e}) {} vs {}", sinf(x), libm::sinf(x));
                assert!(same(cosf(x), libm::cosf(x)), "cos({x:e}) {} vs {}", cosf(x), libm::cosf(x));
                assert!(same(tanf(x), libm::tanf(x)), "tan({x:e}) {} vs {}", tanf(x), libm::tanf(x));
                let (sn, cs) = sincosf(x);
                assert!(same(sn, sinf(x)) && same(cs, cosf(x)), "sincos({x:e}) {sn} {cs}");
                n += 1;
            }
        }
        assert!(n > 600_000, "{n}");
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert!(sinf(x).is_nan() && cosf(x).is_nan() && tanf(x).is_nan(), "{x:e}");
            assert!(sincosf(x).0.is_nan() && sincosf(x).1.is_nan(), "{x:e}");
        }
        for b in (0x4dc9_0fdbu32..0x7f80_0000).step_by(65_537).chain([0x4dc9_0fdb, 0x7f7f_ffff]) {
            for x in [f32::from_bits(b), -f32::from_bits(b)] {
                let (s, c, t) = (sinf(x), cosf(x), tanf(x));
                assert!((-1.0..=1.0).contains(&s) && (-1.0..=1.0).contains(&c) && !t.is_nan(), "{x:e}: {s} {c} {t}");
                assert!(sincosf(x) == (s, c), "sincos({x:e})");
            }
        }
    }
}
