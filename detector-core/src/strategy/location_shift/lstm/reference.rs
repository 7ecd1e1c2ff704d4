//! The f32 reference kernel (`libm` sigmoid and tanh) on float weights, or on int8 weights
//! dequantised: what the integer kernel is checked against (the CMSIS-NN / TFLite Micro pattern).

use super::kernel::LstmKernel;
use crate::wire::model::{Layer, LstmModel, MAX_H1, MAX_H2, N_IN};

/// The f32 reference kernel.
#[derive(Clone, Debug)]
pub struct RefKernel {
    h1: [f32; MAX_H1],
    c1: [f32; MAX_H1],
    h2: [f32; MAX_H2],
    c2: [f32; MAX_H2],
    gates: [f32; 4 * MAX_H1],
}

impl Default for RefKernel {
    fn default() -> Self {
        RefKernel { h1: [0.0; MAX_H1], c1: [0.0; MAX_H1], h2: [0.0; MAX_H2], c2: [0.0; MAX_H2], gates: [0.0; 4 * MAX_H1] }
    }
}

/// The logistic function, `1 / (1 + e^-x)`.
pub fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + libm::expf(-x))
}

fn ref_layer(m: &LstmModel, l: &Layer, x: &[f32], h: &mut [f32], c: &mut [f32], gates: &mut [f32]) {
    let n = h.len();
    for (r, g) in gates[..l.rows].iter_mut().enumerate() {
        let mut acc = m.bias_f32(l, r);
        for (j, v) in x.iter().chain(h.iter()).enumerate() {
            acc += m.w_f32(l, r, j) * v;
        }
        *g = acc;
    }
    for k in 0..n {
        let (i, f, g, o) = (sigmoid(gates[k]), sigmoid(gates[n + k]), libm::tanhf(gates[2 * n + k]), sigmoid(gates[3 * n + k]));
        c[k] = f * c[k] + i * g;
        h[k] = o * libm::tanhf(c[k]);
    }
}

impl LstmKernel for RefKernel {
    fn reset(&mut self) {
        *self = RefKernel::default();
    }
    fn step(&mut self, m: &LstmModel, x: [f32; N_IN]) -> f32 {
        let [l1, l2, d] = m.layers;
        ref_layer(m, &l1, &x, &mut self.h1[..m.h1], &mut self.c1[..m.h1], &mut self.gates);
        let x2 = self.h1;
        ref_layer(m, &l2, &x2[..m.h1], &mut self.h2[..m.h2], &mut self.c2[..m.h2], &mut self.gates);
        let mut y = m.bias_f32(&d, 0);
        for (j, v) in self.h2[..m.h2].iter().enumerate() {
            y += m.w_f32(&d, 0, j) * v;
        }
        y
    }
}
