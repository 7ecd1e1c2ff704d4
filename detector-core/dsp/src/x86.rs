//! The x86-64 host kernel: AVX2, chosen at run time. Sixteen columns per iteration and row:
//! `VPMOVSXBW` widens sixteen weight bytes to halfwords, `VPMADDWD` multiplies them with sixteen
//! activations and adds neighbouring products into eight i32 lanes. Natural column order.

use core::arch::x86_64::*;

/// Whether this CPU has AVX2 (cached by the standard library).
pub fn has_avx2() -> bool {
    std::is_x86_feature_detected!("avx2")
}

/// Two rows against the same activations, over `min` of the three lengths. Call only where
/// [`has_avx2`] is true (it falls back to the portable kernel otherwise).
pub fn dot2(w0: &[u8], w1: &[u8], v: &[i16]) -> (i32, i32) {
    if !has_avx2() {
        return crate::portable::dot2(w0, w1, v);
    }
    // SAFETY: AVX2 is present (checked above).
    unsafe { dot2_avx2(w0, w1, v) }
}

/// Four consecutive rows of a row-major matrix with `S` columns times `v` (`v` holds at least
/// `S`): `out[r]` for the rows `w` holds whole, four per pass; returns the rows written (0
/// without AVX2).
pub fn matvec<const S: usize>(w: &[u8], v: &[i16], out: &mut [i32]) -> usize {
    if !has_avx2() || v.len() < S {
        return 0;
    }
    // SAFETY: AVX2 is present (checked above).
    unsafe { matvec_avx2::<S>(w, v, out) }
}

#[target_feature(enable = "avx2")]
fn matvec_avx2<const S: usize>(w: &[u8], v: &[i16], out: &mut [i32]) -> usize {
    let Some(v) = v.get(..S) else { return 0 };
    let chunks = S / 16;
    let mut rows = 0;
    for (o, wq) in out.chunks_exact_mut(4).zip(w.chunks_exact(4 * S)) {
        let mut acc = [_mm256_setzero_si256(); 4];
        for c in 0..chunks {
            let at = 16 * c;
            // SAFETY: at + 16 <= S: 16 halfwords of v (S of them) and 16 bytes of each of the
            // four rows (k * S + at + 16 <= 4 * S = wq.len()) are in bounds; unaligned loads.
            unsafe {
                let vv = _mm256_loadu_si256(v.as_ptr().add(at) as *const __m256i);
                for (k, a) in acc.iter_mut().enumerate() {
                    let wk = _mm_loadu_si128(wq.as_ptr().add(k * S + at) as *const __m128i);
                    *a = _mm256_add_epi32(*a, _mm256_madd_epi16(_mm256_cvtepi8_epi16(wk), vv));
                }
            }
        }
        let sums = hsum4(acc);
        let tail = v.get(chunks * 16..).unwrap_or(&[]);
        for (k, (ok, s)) in o.iter_mut().zip(sums).enumerate() {
            let row = wq.get(k * S..(k + 1) * S).unwrap_or(&[]);
            *ok = s + crate::portable::dot(row.get(chunks * 16..).unwrap_or(&[]), tail);
        }
        rows += 4;
    }
    rows
}

#[target_feature(enable = "avx2")]
fn dot2_avx2(w0: &[u8], w1: &[u8], v: &[i16]) -> (i32, i32) {
    let n = w0.len().min(w1.len()).min(v.len());
    let chunks = n / 16;
    let mut acc0 = _mm256_setzero_si256();
    let mut acc1 = _mm256_setzero_si256();
    for c in 0..chunks {
        let o = 16 * c;
        // SAFETY: o + 16 <= n, so 16 halfwords of v and 16 bytes of w0 and w1 from o are in
        // bounds; the loads are the unaligned forms.
        let (vv, a, b) = unsafe {
            (
                _mm256_loadu_si256(v.as_ptr().add(o) as *const __m256i),
                _mm_loadu_si128(w0.as_ptr().add(o) as *const __m128i),
                _mm_loadu_si128(w1.as_ptr().add(o) as *const __m128i),
            )
        };
        acc0 = _mm256_add_epi32(acc0, _mm256_madd_epi16(_mm256_cvtepi8_epi16(a), vv));
        acc1 = _mm256_add_epi32(acc1, _mm256_madd_epi16(_mm256_cvtepi8_epi16(b), vv));
    }
    let (mut s0, mut s1) = (hsum(acc0), hsum(acc1));
    let o = chunks * 16;
    let (t0, t1) = crate::portable::dot2(
        w0.get(o..n).unwrap_or(&[]),
        w1.get(o..n).unwrap_or(&[]),
        v.get(o..n).unwrap_or(&[]),
    );
    s0 += t0;
    s1 += t1;
    (s0, s1)
}

/// The lane sums of four vectors at once (two rounds of pairwise adds, then the halves).
#[target_feature(enable = "avx2")]
fn hsum4(a: [__m256i; 4]) -> [i32; 4] {
    let ab = _mm256_hadd_epi32(a[0], a[1]);
    let cd = _mm256_hadd_epi32(a[2], a[3]);
    let abcd = _mm256_hadd_epi32(ab, cd);
    let s = _mm_add_epi32(_mm256_castsi256_si128(abcd), _mm256_extracti128_si256::<1>(abcd));
    [_mm_extract_epi32::<0>(s), _mm_extract_epi32::<1>(s), _mm_extract_epi32::<2>(s), _mm_extract_epi32::<3>(s)]
}

/// Sum of the eight i32 lanes.
#[target_feature(enable = "avx2")]
fn hsum(a: __m256i) -> i32 {
    let s = _mm_add_epi32(_mm256_castsi256_si128(a), _mm256_extracti128_si256::<1>(a));
    let s = _mm_add_epi32(s, _mm_shuffle_epi32::<0b01_00_11_10>(s));
    let s = _mm_add_epi32(s, _mm_shuffle_epi32::<0b10_11_00_01>(s));
    _mm_cvtsi128_si32(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    proptest! {
        #[test]
        fn avx2_equals_the_reference(
            w0 in proptest::collection::vec(any::<u8>(), 0..300),
            w1 in proptest::collection::vec(any::<u8>(), 0..300),
            v in proptest::collection::vec(any::<i16>(), 0..300),
        ) {
            prop_assert_eq!(dot2(&w0, &w1, &v), crate::portable::dot2(&w0, &w1, &v));
        }
    }

    proptest! {
        #[test]
        fn avx2_matvec_equals_the_reference(
            w in proptest::collection::vec(any::<u8>(), 0..(9 * 37)),
            v in proptest::collection::vec(any::<i16>(), 37..60),
            rows in 0usize..10,
        ) {
            const S: usize = 37;
            let mut out = [0i32; 10];
            let done = matvec::<S>(&w, &v, &mut out[..rows]);
            prop_assert_eq!(done, (rows / 4 * 4).min(w.len() / (4 * S) * 4));
            for r in 0..done {
                prop_assert_eq!(out[r], crate::portable::dot(&w[r * S..(r + 1) * S], &v[..S]));
            }
        }
    }

    #[test]
    fn extremes() {
        let w: Vec<u8> = [0x80u8; 200].to_vec();
        let v: Vec<i16> = [i16::MIN; 200].to_vec();
        assert_eq!(dot2(&w, &w, &v), (200 << 22, 200 << 22));
    }
}
