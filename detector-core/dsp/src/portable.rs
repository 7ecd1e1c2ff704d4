//! The reference kernel: plain Rust, natural column order, four columns per iteration (the shape
//! the integer LSTM kernel always had). Every other kernel is tested against it.

/// `sum w[i] * v[i]` over `i < min(w.len(), v.len())`, weights read as i8.
pub fn dot(w: &[u8], v: &[i16]) -> i32 {
    let n = w.len().min(v.len());
    let (w, v) = (w.get(..n).unwrap_or(&[]), v.get(..n).unwrap_or(&[]));
    let mut acc = 0i32;
    let mut wc = w.chunks_exact(4);
    let mut vc = v.chunks_exact(4);
    for (a, b) in (&mut wc).zip(&mut vc) {
        acc += a[0] as i8 as i32 * b[0] as i32
            + a[1] as i8 as i32 * b[1] as i32
            + a[2] as i8 as i32 * b[2] as i32
            + a[3] as i8 as i32 * b[3] as i32;
    }
    for (a, b) in wc.remainder().iter().zip(vc.remainder()) {
        acc += *a as i8 as i32 * *b as i32;
    }
    acc
}

/// Two rows against the same activations, over `i < min` of the three lengths.
pub fn dot2(w0: &[u8], w1: &[u8], v: &[i16]) -> (i32, i32) {
    let v = v.get(..w0.len().min(w1.len()).min(v.len())).unwrap_or(&[]);
    (dot(w0, v), dot(w1, v))
}
