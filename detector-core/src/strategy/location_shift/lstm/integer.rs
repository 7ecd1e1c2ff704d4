//! The integer kernel: int8 weights with one scale per output row, int16 Q4.12 activations and
//! cell state, i32 accumulation, sigmoid and tanh from one 257-entry tanh table with linear
//! interpolation. Only the input normalisation and output scaling (in the predictor) are f32.
//! Every index is proven in range or read through `get`: no panic path (the firmware's
//! no-panic link checks it).

use super::kernel::LstmKernel;
use crate::wire::model::{Layer, LstmModel, WeightKind, MAX_H1, MAX_H2, MULT_SHIFT, N_IN, Q};

/// The integer kernel (int8 blobs only).
#[derive(Clone, Debug)]
pub struct IntKernel {
    h1: [i16; MAX_H1],
    c1: [i16; MAX_H1],
    h2: [i16; MAX_H2],
    c2: [i16; MAX_H2],
    gates: [i32; 4 * MAX_H1],
}

impl Default for IntKernel {
    fn default() -> Self {
        IntKernel { h1: [0; MAX_H1], c1: [0; MAX_H1], h2: [0; MAX_H2], c2: [0; MAX_H2], gates: [0; 4 * MAX_H1] }
    }
}

/// tanh(i / 32) in Q15 for i = 0..=256 (x in [0, 8]); `tanh_table_matches_libm` checks it.
#[rustfmt::skip]
const TANH_Q15: [u16; 257] = [
    0, 1024, 2045, 3063, 4075, 5079, 6073, 7056, 8025, 8980, 9919, 10840, 11742, 12625, 13486, 14325,
    15142, 15936, 16706, 17451, 18173, 18869, 19541, 20189, 20812, 21411, 21986, 22537, 23065, 23570, 24053, 24515,
    24955, 25375, 25775, 26156, 26518, 26863, 27190, 27501, 27796, 28075, 28340, 28592, 28829, 29054, 29267, 29469,
    29659, 29839, 30009, 30169, 30321, 30464, 30599, 30726, 30846, 30959, 31066, 31166, 31261, 31350, 31435, 31514,
    31588, 31658, 31725, 31787, 31845, 31900, 31952, 32001, 32047, 32090, 32131, 32169, 32205, 32239, 32270, 32300,
    32328, 32355, 32380, 32403, 32425, 32446, 32465, 32483, 32500, 32516, 32531, 32546, 32559, 32572, 32583, 32595,
    32605, 32615, 32624, 32633, 32641, 32648, 32656, 32662, 32669, 32675, 32680, 32685, 32690, 32695, 32699, 32703,
    32707, 32711, 32714, 32717, 32720, 32723, 32726, 32728, 32731, 32733, 32735, 32737, 32739, 32740, 32742, 32744,
    32745, 32746, 32748, 32749, 32750, 32751, 32752, 32753, 32754, 32754, 32755, 32756, 32757, 32757, 32758, 32758,
    32759, 32759, 32760, 32760, 32761, 32761, 32761, 32762, 32762, 32762, 32763, 32763, 32763, 32763, 32764, 32764,
    32764, 32764, 32764, 32765, 32765, 32765, 32765, 32765, 32765, 32765, 32765, 32766, 32766, 32766, 32766, 32766,
    32766, 32766, 32766, 32766, 32766, 32766, 32766, 32766, 32766, 32766, 32766, 32766, 32766, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767,
    32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767, 32767,
    32767,
];

/// tanh of a Q4.12 value (any i32; saturates beyond +-8), in Q15.
fn tanh_q15(x: i32) -> i32 {
    let a = x.unsigned_abs().min(32767) as usize;
    let (i, frac) = (a >> 7, (a & 127) as i32);
    let (y0, y1) = (TANH_Q15[i] as i32, TANH_Q15[i + 1] as i32);
    let y = y0 + (((y1 - y0) * frac + 64) >> 7);
    if x < 0 { -y } else { y }
}

/// tanh in Q4.12.
fn tanh_q12(x: i32) -> i32 {
    let y = tanh_q15(x);
    let r = (y.abs() + 4) >> 3;
    if y < 0 { -r } else { r }
}

/// sigmoid in Q4.12 (0..=4096).
fn sigmoid_q12(x: i32) -> i32 {
    (32768 + tanh_q15(x / 2) + 8) >> 4
}

fn sat16(v: i32) -> i16 {
    v.clamp(i16::MIN as i32, i16::MAX as i32) as i16
}

/// `sum w[i] * v[i]` of int8 weights (as bytes) and Q4.12 values; four at a time, which the
/// compiler turns into straight-line multiply-accumulates on the Cortex-M4.
fn dot(w: &[u8], v: &[i16]) -> i32 {
    let n = w.len().min(v.len());
    let (w, v) = (&w[..n], &v[..n]);
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

/// One row's pre-activation in Q4.12: `(sum w * v) * mult / 2^24 + bias`.
fn row_q12(m: &LstmModel, l: &Layer, r: usize, x: &[i16], h: &[i16]) -> i32 {
    let w = m.row_i8(l, r);
    // |w| <= 128, |v| <= 32768, cols <= 192: |acc| < 2^30, no overflow.
    let (wx, wh) = w.split_at(x.len().min(w.len()));
    let acc = dot(wx, x) + dot(wh, h);
    let mult = m.mult_i32(l, r) as i64;
    let bias = m.bias_i32(l, r) as i64;
    (((acc as i64 * mult) >> MULT_SHIFT) + bias).clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

fn int_layer(m: &LstmModel, l: &Layer, x: &[i16], h: &mut [i16], c: &mut [i16], gates: &mut [i32]) {
    let n = h.len();
    let Some(gates) = gates.get_mut(..4 * n) else { return };
    for (r, g) in gates.iter_mut().enumerate() {
        *g = row_q12(m, l, r, x, h);
    }
    // The gates in the order input, forget, cell, output.
    let (Some(gi), Some(gf), Some(gg), Some(go)) = (gates.get(..n), gates.get(n..2 * n), gates.get(2 * n..3 * n), gates.get(3 * n..4 * n)) else {
        return;
    };
    for ((((ck, hk), &xi), &xf), (&xg, &xo)) in c.iter_mut().zip(h.iter_mut()).zip(gi).zip(gf).zip(gg.iter().zip(go)) {
        let i = sigmoid_q12(xi);
        let f = sigmoid_q12(xf);
        let g = tanh_q12(xg);
        let o = sigmoid_q12(xo);
        let cn = sat16((f * *ck as i32 + i * g + 2048) >> 12);
        *ck = cn;
        *hk = sat16((o * tanh_q12(cn as i32) + 2048) >> 12);
    }
}

impl LstmKernel for IntKernel {
    fn reset(&mut self) {
        *self = IntKernel::default();
    }
    fn step(&mut self, m: &LstmModel, x: [f32; N_IN]) -> f32 {
        if m.kind != WeightKind::I8 {
            return f32::NAN;
        }
        let mut xq = [0i16; N_IN];
        for (q, v) in xq.iter_mut().zip(x) {
            *q = sat16(libm::roundf(v.clamp(-7.9, 7.9) * Q as f32) as i32);
        }
        let [l1, l2, d] = m.layers;
        let (Some(h1), Some(c1), Some(h2), Some(c2)) = (self.h1.get_mut(..m.h1), self.c1.get_mut(..m.h1), self.h2.get_mut(..m.h2), self.c2.get_mut(..m.h2)) else {
            return f32::NAN;
        };
        int_layer(m, &l1, &xq, h1, c1, &mut self.gates);
        int_layer(m, &l2, h1, h2, c2, &mut self.gates);
        row_q12(m, &d, 0, &[], h2) as f32 / Q as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tanh_table_matches_libm() {
        for (i, t) in TANH_Q15.iter().enumerate() {
            assert_eq!(*t as f64, libm::round(libm::tanh(i as f64 / 32.0) * 32767.0), "entry {i}");
        }
    }

    #[test]
    fn activations_within_one_q12_step() {
        let mut worst = (0.0f32, 0.0f32);
        for x in (-40000..40000).step_by(7) {
            let xf = x as f32 / Q as f32;
            let et = (tanh_q12(x) as f32 / Q as f32 - libm::tanhf(xf)).abs();
            let es = (sigmoid_q12(x) as f32 / Q as f32 - super::super::reference::sigmoid(xf)).abs();
            worst = (worst.0.max(et), worst.1.max(es));
        }
        // One Q12 step is 2.44e-4.
        assert!(worst.0 < 2.5e-4 && worst.1 < 2.5e-4, "{worst:?}");
    }

}
