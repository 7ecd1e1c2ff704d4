//! The integer kernel: int8 weights with one scale per output row, int16 Q4.12 activations and
//! cell state, i32 accumulation, sigmoid and tanh from one 257-entry tanh table with linear
//! interpolation. Only the input normalisation and output scaling (in the predictor) are f32.
//! Every index is proven in range or read through `get`: no panic path (the firmware's
//! no-panic link checks it).
//!
//! The multiply-accumulates (all but a few thousand of the step's instructions) run in
//! `gnss-guard-dsp`: its optimised kernel for the build (Cortex-M4 DSP extension, AVX2 on the
//! host) or, with [`IntKernel::portable`], its plain reference. Both sum the same integers
//! exactly, so every output is the same bit for bit.

use super::kernel::LstmKernel;
use crate::wire::model::{Layer, LstmModel, WeightKind, MAX_H1, MAX_H2, MULT_SHIFT, N_IN, Q};
use gnss_guard_dsp::{portable::dot, Activations};

/// Layer 1's and layer 2's row lengths in the paper's 128/64 net: the shapes with a four-row
/// kernel (other sizes run two rows at a time).
const L1_COLS: usize = N_IN + MAX_H1;
const L2_COLS: usize = MAX_H1 + MAX_H2;

/// The longest layer input: `N_IN + MAX_H1` (layer 1) or `MAX_H1 + MAX_H2` (layer 2).
const MAX_COLS: usize = if N_IN + MAX_H1 > MAX_H1 + MAX_H2 { N_IN + MAX_H1 } else { MAX_H1 + MAX_H2 };

/// The integer kernel (int8 blobs only).
#[derive(Clone, Debug)]
pub struct IntKernel {
    h1: [i16; MAX_H1],
    c1: [i16; MAX_H1],
    h2: [i16; MAX_H2],
    c2: [i16; MAX_H2],
    gates: [i32; 4 * MAX_H1],
    /// A layer's input (step input or lower hidden state, then own hidden state) in the
    /// optimised kernel's layout.
    acts: Activations<MAX_COLS>,
    /// Use the reference dot product instead of the optimised one (benchmarks, parity tests).
    portable: bool,
}

impl Default for IntKernel {
    fn default() -> Self {
        IntKernel {
            h1: [0; MAX_H1],
            c1: [0; MAX_H1],
            h2: [0; MAX_H2],
            c2: [0; MAX_H2],
            gates: [0; 4 * MAX_H1],
            acts: Activations::default(),
            portable: false,
        }
    }
}

impl IntKernel {
    /// The same kernel on the plain reference dot product (`gnss_guard_dsp::portable`).
    pub fn portable() -> Self {
        IntKernel { portable: true, ..IntKernel::default() }
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

/// The table as `y0 | (y1 - y0) << 16` per segment: one load per interpolation.
const TANH_SEGMENTS: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        t[i] = TANH_Q15[i] as u32 | ((TANH_Q15[i + 1] - TANH_Q15[i]) as u32) << 16;
        i += 1;
    }
    t
};

/// tanh(|x|) in Q15 for `a = |x|` in Q4.12 (saturates beyond 8).
fn tanh_abs_q15(a: u32) -> i32 {
    let a = a.min(32767);
    let e = TANH_SEGMENTS[(a >> 7) as usize & 255];
    (e & 0xffff) as i32 + ((((e >> 16) * (a & 127)) as i32 + 64) >> 7)
}

/// tanh of a Q4.12 value (any i32), in Q15 (kept for the accuracy tests).
#[cfg(test)]
fn tanh_q15(x: i32) -> i32 {
    let y = tanh_abs_q15(x.unsigned_abs());
    if x < 0 { -y } else { y }
}

/// `|x|` and the sign mask of `x` (all ones when negative), without a branch: the signs of
/// the gates are random, and a mispredicted branch per activation costs more than the
/// activation on the host.
fn abs_and_mask(x: i32) -> (u32, i32) {
    let m = x >> 31;
    ((x ^ m).wrapping_sub(m) as u32, m)
}

/// tanh in Q4.12: the Q15 value rounded.
fn tanh_q12(x: i32) -> i32 {
    let (a, m) = abs_and_mask(x);
    let r = (tanh_abs_q15(a) + 4) >> 3;
    (r ^ m) - m
}

/// sigmoid in Q4.12 (0..=4096): `(1 + tanh(x / 2)) / 2`, with `x / 2` rounded toward zero.
fn sigmoid_q12(x: i32) -> i32 {
    let (a, m) = abs_and_mask(x);
    let t = tanh_abs_q15(a >> 1);
    (32776 + ((t ^ m) - m)) >> 4
}

fn sat16(v: i32) -> i16 {
    v.clamp(i16::MIN as i32, i16::MAX as i32) as i16
}

/// Rows' dot products to pre-activations in Q4.12: `acc * mult / 2^24 + bias`, saturated to
/// i32, in place.
fn scale_rows(m: &LstmModel, l: &Layer, gates: &mut [i32]) {
    let (mults, biases) = m.mults_biases_i32(l);
    let word = |b: &[u8]| <[u8; 4]>::try_from(b).map_or(0, i32::from_le_bytes);
    for (g, (mu, b)) in gates.iter_mut().zip(mults.chunks_exact(4).zip(biases.chunks_exact(4))) {
        let r = ((*g as i64 * word(mu) as i64) >> MULT_SHIFT) + word(b) as i64;
        *g = i32::try_from(r).unwrap_or(if r < 0 { i32::MIN } else { i32::MAX });
    }
}

/// One row's dot product over `[x, h]` with the reference kernel.
/// |w| <= 128, |v| <= 32768, cols <= 192: |acc| < 2^30, no overflow.
fn row_dot_portable(m: &LstmModel, l: &Layer, r: usize, x: &[i16], h: &[i16]) -> i32 {
    let w = m.row_i8(l, r);
    let (wx, wh) = w.split_at(x.len().min(w.len()));
    dot(wx, x) + dot(wh, h)
}

/// The pre-activations of rows `0..gates.len()` over `[x, h]`: the dot products through the
/// optimised kernel (four rows at a time for the 128/64 shapes, else two) or the reference,
/// then scaled.
#[allow(clippy::too_many_arguments)]
fn gate_rows(m: &LstmModel, l: &Layer, x: &[i16], h: &[i16], gates: &mut [i32], acts: &mut Activations<MAX_COLS>, portable: bool) {
    if portable {
        for (r, g) in gates.iter_mut().enumerate() {
            *g = row_dot_portable(m, l, r, x, h);
        }
    } else {
        acts.load(&[x, h]);
        let w = m.weights_i8(l);
        match l.cols {
            L1_COLS => acts.matvec::<L1_COLS>(w, gates),
            L2_COLS => acts.matvec::<L2_COLS>(w, gates),
            _ => {
                for (p, g) in gates.chunks_mut(2).enumerate() {
                    let r = 2 * p;
                    let w0 = m.row_i8(l, r);
                    // An odd last row (the dense layer's one row) is paired with itself.
                    let w1 = if g.len() > 1 { m.row_i8(l, r + 1) } else { w0 };
                    let (a0, a1) = acts.dot2(w0, w1);
                    for (g, a) in g.iter_mut().zip([a0, a1]) {
                        *g = a;
                    }
                }
            }
        }
    }
    scale_rows(m, l, gates);
}

#[allow(clippy::too_many_arguments)]
fn int_layer(m: &LstmModel, l: &Layer, x: &[i16], h: &mut [i16], c: &mut [i16], gates: &mut [i32], acts: &mut Activations<MAX_COLS>, portable: bool) {
    let n = h.len();
    let Some(gates) = gates.get_mut(..4 * n) else { return };
    gate_rows(m, l, x, h, gates, acts, portable);
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
        *self = IntKernel { portable: self.portable, ..IntKernel::default() };
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
        let (gates, acts, portable) = (&mut self.gates, &mut self.acts, self.portable);
        int_layer(m, &l1, &xq, h1, c1, gates, acts, portable);
        int_layer(m, &l2, h1, h2, c2, gates, acts, portable);
        let mut out = [0i32; 1];
        gate_rows(m, &d, &[], h2, &mut out, acts, portable);
        out[0] as f32 / Q as f32
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

    /// The activations as they were first written (table lookup on the signed value, `x / 2`
    /// in i32): the faster forms above must give the same integers everywhere.
    #[test]
    fn activations_equal_their_first_form() {
        fn tanh_q15_first(x: i32) -> i32 {
            let a = x.unsigned_abs().min(32767) as usize;
            let (i, frac) = (a >> 7, (a & 127) as i32);
            let (y0, y1) = (TANH_Q15[i] as i32, TANH_Q15[i + 1] as i32);
            let y = y0 + (((y1 - y0) * frac + 64) >> 7);
            if x < 0 { -y } else { y }
        }
        let tanh_q12_first = |x: i32| {
            let y = tanh_q15_first(x);
            let r = (y.abs() + 4) >> 3;
            if y < 0 { -r } else { r }
        };
        let sigmoid_q12_first = |x: i32| (32768 + tanh_q15_first(x / 2) + 8) >> 4;
        let edges = [i32::MIN, i32::MIN + 1, -65536, -65535, 65535, 65536, i32::MAX - 1, i32::MAX];
        for x in (-70000..70000).chain(edges) {
            assert_eq!(tanh_q15(x), tanh_q15_first(x), "tanh_q15({x})");
            assert_eq!(tanh_q12(x), tanh_q12_first(x), "tanh_q12({x})");
            assert_eq!(sigmoid_q12(x), sigmoid_q12_first(x), "sigmoid_q12({x})");
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
