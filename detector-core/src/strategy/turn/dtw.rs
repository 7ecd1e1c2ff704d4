//! Dynamic time warping under a Sakoe-Chiba band, with LB_Keogh lower bounds and early
//! abandoning, for k-NN over short fixed-length series. Exact: pruning never changes the
//! result (see the parity tests against [`dtw_reference`]).
//!
//! Cost: squared difference per cell; the distance is the square root of the path cost.
//! Memory: two rolling rows of `MAX_LEN + 1` values on the stack.

/// Longest series handled.
pub const MAX_LEN: usize = 64;

/// Plain banded DTW with the full cost matrix: the reference kernel.
pub fn dtw_reference(a: &[f32], b: &[f32], band: usize) -> f32 {
    let (n, m) = (a.len().min(MAX_LEN), b.len().min(MAX_LEN));
    if n == 0 || m == 0 {
        return f32::INFINITY;
    }
    let mut d = [[f32::INFINITY; MAX_LEN + 1]; MAX_LEN + 1];
    d[0][0] = 0.0;
    for i in 1..=n {
        for j in 1..=m {
            if i.abs_diff(j) > band {
                continue;
            }
            let c = (a[i - 1] - b[j - 1]) * (a[i - 1] - b[j - 1]);
            d[i][j] = c + d[i - 1][j].min(d[i][j - 1]).min(d[i - 1][j - 1]);
        }
    }
    gnss_guard_dsp::sqrtf(d[n][m])
}

/// Banded DTW with two rolling rows; abandons and returns `INFINITY` as soon as every cell of a
/// row exceeds `best` (squared), since path costs only grow.
pub fn dtw_pruned(a: &[f32], b: &[f32], band: usize, best: f32) -> f32 {
    let a = a.get(..MAX_LEN).unwrap_or(a);
    let b = b.get(..MAX_LEN).unwrap_or(b);
    let m = b.len();
    if a.is_empty() || m == 0 {
        return f32::INFINITY;
    }
    let best2 = if best.is_finite() { best * best } else { f32::INFINITY };
    let mut prev = [f32::INFINITY; MAX_LEN + 1];
    let mut cur = [f32::INFINITY; MAX_LEN + 1];
    prev[0] = 0.0;
    for (i0, &ai) in a.iter().enumerate() {
        let i = i0 + 1;
        cur.iter_mut().for_each(|x| *x = f32::INFINITY);
        let lo = i.saturating_sub(band).max(1);
        let hi = (i + band).min(m);
        let mut row_min = f32::INFINITY;
        for j in lo..=hi {
            // Every index is in range (j <= m <= MAX_LEN); `get` lets the compiler see it.
            let (Some(&bj), Some(&up), Some(&diag), Some(&left)) = (b.get(j - 1), prev.get(j), prev.get(j - 1), cur.get(j - 1)) else {
                break;
            };
            let c = (ai - bj) * (ai - bj);
            let v = c + up.min(left).min(diag);
            if let Some(x) = cur.get_mut(j) {
                *x = v;
            }
            row_min = row_min.min(v);
        }
        if row_min > best2 {
            return f32::INFINITY;
        }
        core::mem::swap(&mut prev, &mut cur);
    }
    gnss_guard_dsp::sqrtf(prev.get(m).copied().unwrap_or(f32::INFINITY))
}

/// LB_Keogh: a lower bound of banded DTW between `q` and the series whose band envelope is
/// `(upper, lower)`. Equal lengths only. Abandons past `best`.
pub fn lb_keogh(q: &[f32], upper: &[f32], lower: &[f32], best: f32) -> f32 {
    let best2 = if best.is_finite() { best * best } else { f32::INFINITY };
    let mut s = 0.0f32;
    for ((x, u), l) in q.iter().zip(upper).zip(lower) {
        let d = if x > u { x - u } else if x < l { l - x } else { 0.0 };
        s += d * d;
        if s > best2 {
            return f32::INFINITY;
        }
    }
    gnss_guard_dsp::sqrtf(s)
}

/// The band envelope of `t`: running max and min over `[i - band, i + band]`.
pub fn envelope(t: &[f32], band: usize, upper: &mut [f32], lower: &mut [f32]) {
    let n = t.len().min(upper.len()).min(lower.len());
    for i in 0..n {
        let lo = i.saturating_sub(band);
        let hi = (i + band).min(n - 1);
        let (mut u, mut l) = (f32::NEG_INFINITY, f32::INFINITY);
        for &x in t.get(lo..=hi).unwrap_or(&[]) {
            u = u.max(x);
            l = l.min(x);
        }
        upper[i] = u;
        lower[i] = l;
    }
}

/// Resamples `src` linearly to `dst.len()` points (first and last kept).
pub fn resample(src: &[f32], dst: &mut [f32]) {
    let (n, m) = (src.len(), dst.len());
    if n == 0 {
        dst.iter_mut().for_each(|x| *x = 0.0);
        return;
    }
    for (k, d) in dst.iter_mut().enumerate() {
        let x = if m > 1 { k as f32 * (n - 1) as f32 / (m - 1) as f32 } else { 0.0 };
        let i = (x as usize).min(n - 1);
        let j = (i + 1).min(n - 1);
        let w = x - i as f32;
        // In range (i, j < n); read through `get` so that no optimisation level leaves a
        // bounds check (a panic path) behind.
        let (a, b) = (src.get(i).copied().unwrap_or(0.0), src.get(j).copied().unwrap_or(0.0));
        *d = a + (b - a) * w;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_series_have_zero_distance_and_shift_is_absorbed() {
        let a: [f32; 10] = [0., 1., 2., 3., 4., 5., 4., 3., 2., 1.];
        assert_eq!(dtw_reference(&a, &a, 2), 0.0);
        let b: [f32; 10] = [0., 0., 1., 2., 3., 4., 5., 4., 3., 2.];
        assert!(dtw_reference(&a, &b, 2) < 1.5);
        assert_eq!(dtw_pruned(&a, &b, 2, f32::INFINITY), dtw_reference(&a, &b, 2));
    }

    #[test]
    fn lb_keogh_is_a_lower_bound() {
        let a: [f32; 8] = [0., 3., 1., 4., 1., 5., 9., 2.];
        let b: [f32; 8] = [2., 7., 1., 8., 2., 8., 1., 8.];
        let (mut u, mut l) = ([0.0; 8], [0.0; 8]);
        envelope(&b, 2, &mut u, &mut l);
        assert!(lb_keogh(&a, &u, &l, f32::INFINITY) <= dtw_reference(&a, &b, 2) + 1e-5);
    }

    #[test]
    fn resample_keeps_ends() {
        let mut d = [0.0; 5];
        resample(&[0.0, 10.0], &mut d);
        assert_eq!(d, [0.0, 2.5, 5.0, 7.5, 10.0]);
    }
}
