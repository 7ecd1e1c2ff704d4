//! Strategy 1's learned predictor: the paper's 2-layer stacked LSTM (Dasgupta et al., Table 1),
//! run one step per GNSS epoch with its state carried.
//!
//! # What it predicts
//! At each epoch the step consumes four inputs and predicts the GNSS shift of that epoch:
//!
//! | input | unit |
//! |---|---|
//! | location shift of the *previous* epoch / its duration | m/s |
//! | accelerator pedal at this epoch | % |
//! | steering wheel angle at this epoch (measured, else the yaw-rate bicycle proxy) | deg |
//! | wheel speed at this epoch | m/s |
//!
//! The output is this epoch's shift divided by its duration (m/s); the predictor multiplies by
//! `dt`. Working per second rather than per epoch makes one model valid for 1 Hz and 10 Hz
//! receivers; the threshold term (maximum validation error) is still kept per receiver profile
//! in metres. The GNSS shift being judged never enters its own prediction. [`LstmInputs`] is the
//! one definition of the inputs: the trainer (host-sim) builds its windows with it, so training
//! sees exactly what the streaming step sees. A run of valid inputs starts from zero state; any
//! missing input, bad `dt` or detector restart ends the run and zeroes the state.
//!
//! # Kernels (the CMSIS-NN / TFLite Micro pattern)
//! - [`RefKernel`]: plain f32 (`libm` sigmoid/tanh), on float weights or on dequantised int8
//!   weights. The reference.
//! - [`IntKernel`]: pure integer. int8 weights with one scale per output row (per channel), int16
//!   Q4.12 activations and cell state, i32 accumulation, sigmoid and tanh from one 257-entry
//!   table of tanh with linear interpolation (`sigmoid(x) = (1 + tanh(x/2)) / 2`). Only the
//!   input normalisation and the output de-normalisation are f32, at the boundary.
//!
//! # Blob (little endian)
//! ```text
//! "GGLM" | version u16 = 1 | kind u8 (0 = f32, 1 = int8) | n_in u8 (= 4) | h1 u16 | h2 u16 |
//! in_min f32 x4 | in_max f32 x4 | out_min f32 | out_max f32 |
//! max_err_m f32 x2 (10 Hz, 1 Hz profile) | rmse_m f32 x2 (10 Hz, 1 Hz) |
//! layer 1 | layer 2 | dense | crc32 u32 (over all bytes before it)
//! layer, kind f32:  rows x cols f32 weights | rows f32 bias
//! layer, kind int8: rows x cols i8 weights | rows i32 multiplier (scale * 2^24) | rows i32 bias (Q12)
//! ```
//! An LSTM layer has `rows = 4 h` (gates in the order input, forget, cell, output) and
//! `cols = inputs + h` (the layer's input, then its own previous output); the dense layer has one
//! row. [`LstmModel::parse`] checks everything and returns an [`LstmError`], never panics.

use crate::crc32::crc32;
use crate::sample::Sample;
use crate::strategy::location_shift::ShiftPredictor;
use crate::strategy::turn::{steering_proxy_deg, TurnConfig};

pub const MAGIC: &[u8; 4] = b"GGLM";
pub const VERSION: u16 = 1;
/// Number of inputs per step.
pub const N_IN: usize = 4;
/// Largest layer sizes the fixed buffers hold (the paper's 128 and 64).
pub const MAX_H1: usize = 128;
pub const MAX_H2: usize = 64;
const HEADER: usize = 12 + 14 * 4;
/// Fixed-point format of activations and cell state: Q4.12.
pub const Q: i32 = 4096;
/// Multiplier scale of int8 rows: `real weight = w * mult / 2^MULT_SHIFT`.
pub const MULT_SHIFT: u32 = 24;

/// Weight encoding of a blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightKind {
    F32 = 0,
    I8 = 1,
}

/// Why a model blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LstmError {
    TooShort,
    BadMagic,
    BadVersion,
    BadKind,
    /// Input count not 4, a layer size 0 or above the fixed buffers.
    BadShape,
    /// The length does not match the shapes.
    BadLength,
    BadCrc,
    /// A normalisation range or threshold term is not finite or empty.
    BadRange,
    /// The integer kernel needs an int8 blob.
    NotQuantized,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Layer {
    rows: usize,
    cols: usize,
    w: usize,
    mult: usize,
    bias: usize,
}

/// A validated model blob (borrowed: in flash on the target).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LstmModel<'a> {
    bytes: &'a [u8],
    pub kind: WeightKind,
    pub h1: usize,
    pub h2: usize,
    pub in_min: [f32; N_IN],
    pub in_max: [f32; N_IN],
    pub out_min: f32,
    pub out_max: f32,
    /// Maximum absolute validation error, metres: `[10 Hz profile, 1 Hz profile]`.
    pub max_err_m: [f32; 2],
    /// Validation RMSE, metres: `[10 Hz profile, 1 Hz profile]`.
    pub rmse_m: [f32; 2],
    layers: [Layer; 3],
}

// Byte readers: out of range reads as 0 (`parse` checks every length first, so inside a
// validated blob they never are; this keeps the kernels free of panic paths).
fn u16_at(b: &[u8], o: usize) -> u16 {
    b.get(o..o.wrapping_add(2)).and_then(|x| x.try_into().ok()).map_or(0, u16::from_le_bytes)
}
fn u32_at(b: &[u8], o: usize) -> u32 {
    b.get(o..o.wrapping_add(4)).and_then(|x| x.try_into().ok()).map_or(0, u32::from_le_bytes)
}
fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_bits(u32_at(b, o))
}
fn i32_at(b: &[u8], o: usize) -> i32 {
    u32_at(b, o) as i32
}

impl<'a> LstmModel<'a> {
    pub fn parse(bytes: &'a [u8]) -> Result<Self, LstmError> {
        if bytes.len() < HEADER + 4 {
            return Err(LstmError::TooShort);
        }
        if &bytes[0..4] != MAGIC {
            return Err(LstmError::BadMagic);
        }
        if u16_at(bytes, 4) != VERSION {
            return Err(LstmError::BadVersion);
        }
        let kind = match bytes[6] {
            0 => WeightKind::F32,
            1 => WeightKind::I8,
            _ => return Err(LstmError::BadKind),
        };
        let (n_in, h1, h2) = (bytes[7] as usize, u16_at(bytes, 8) as usize, u16_at(bytes, 10) as usize);
        if n_in != N_IN || h1 == 0 || h1 > MAX_H1 || h2 == 0 || h2 > MAX_H2 {
            return Err(LstmError::BadShape);
        }
        let f = |i: usize| f32_at(bytes, 12 + 4 * i);
        let mut in_min = [0.0; N_IN];
        let mut in_max = [0.0; N_IN];
        for i in 0..N_IN {
            in_min[i] = f(i);
            in_max[i] = f(N_IN + i);
        }
        let (out_min, out_max) = (f(8), f(9));
        let max_err_m = [f(10), f(11)];
        let rmse_m = [f(12), f(13)];
        let range_ok = |lo: f32, hi: f32| lo.is_finite() && hi.is_finite() && hi > lo;
        if !(0..N_IN).all(|i| range_ok(in_min[i], in_max[i]))
            || !range_ok(out_min, out_max)
            || !max_err_m.iter().chain(&rmse_m).all(|e| e.is_finite() && *e >= 0.0)
        {
            return Err(LstmError::BadRange);
        }
        let mut off = HEADER;
        let mut layer = |rows: usize, cols: usize| {
            let w = off;
            let (wbytes, extra) = match kind {
                WeightKind::F32 => (4 * rows * cols, 4 * rows),
                WeightKind::I8 => (rows * cols, 8 * rows),
            };
            let l = Layer { rows, cols, w, mult: w + wbytes, bias: w + wbytes + if kind == WeightKind::I8 { 4 * rows } else { 0 } };
            off += wbytes + extra;
            l
        };
        let layers = [layer(4 * h1, N_IN + h1), layer(4 * h2, h1 + h2), layer(1, h2)];
        if bytes.len() != off + 4 {
            return Err(LstmError::BadLength);
        }
        if crc32(&bytes[..off]) != u32_at(bytes, off) {
            return Err(LstmError::BadCrc);
        }
        Ok(LstmModel { bytes, kind, h1, h2, in_min, in_max, out_min, out_max, max_err_m, rmse_m, layers })
    }

    /// The threshold term for a receiver of this nominal epoch duration (10 Hz class below 0.5 s).
    pub fn max_error_m(&self, nominal_dt_s: f32) -> f32 {
        self.max_err_m[if nominal_dt_s < 0.5 { 0 } else { 1 }]
    }

    /// Inputs mapped to the training set's `[0, 1]`, clamped to `[-7.9, 7.9]` (the Q4.12 range).
    pub fn normalise(&self, x: [f32; N_IN]) -> [f32; N_IN] {
        let mut o = [0.0; N_IN];
        for i in 0..N_IN {
            o[i] = ((x[i] - self.in_min[i]) / (self.in_max[i] - self.in_min[i])).clamp(-7.9, 7.9);
        }
        o
    }

    /// A normalised output back to m/s.
    pub fn denormalise(&self, y: f32) -> f32 {
        self.out_min + y * (self.out_max - self.out_min)
    }

    /// Weight `(r, c)` of layer `l` as f32 (dequantised for int8 blobs), and the row's bias.
    fn w_f32(&self, l: &Layer, r: usize, c: usize) -> f32 {
        match self.kind {
            WeightKind::F32 => f32_at(self.bytes, l.w + 4 * (r * l.cols + c)),
            WeightKind::I8 => {
                self.bytes.get(l.w + r * l.cols + c).map_or(0.0, |&w| w as i8 as f32) * (i32_at(self.bytes, l.mult + 4 * r) as f32 / (1u32 << MULT_SHIFT) as f32)
            }
        }
    }
    fn bias_f32(&self, l: &Layer, r: usize) -> f32 {
        match self.kind {
            WeightKind::F32 => f32_at(self.bytes, l.bias + 4 * r),
            WeightKind::I8 => i32_at(self.bytes, l.bias + 4 * r) as f32 / Q as f32,
        }
    }
}

/// The predictor's inputs, from synchronised samples (see the module documentation). The host
/// trainer uses this same type, so training windows are exactly what the streaming step sees.
#[derive(Clone, Copy, Debug)]
pub struct LstmInputs {
    prev_shift_mps: Option<f32>,
    /// Epochs longer than this break the run (the detector restarts on them too), seconds.
    pub max_dt_s: f32,
    proxy: TurnConfig,
}

impl Default for LstmInputs {
    fn default() -> Self {
        LstmInputs { prev_shift_mps: None, max_dt_s: 3.0, proxy: TurnConfig::default() }
    }
}

impl LstmInputs {
    fn dt_ok(&self, s: &Sample) -> bool {
        s.dt_s.is_finite() && s.dt_s > 0.0 && s.dt_s <= self.max_dt_s
    }

    /// This epoch's GNSS shift per second, the training target (and next epoch's first input).
    pub fn shift_mps(&self, s: &Sample) -> Option<f32> {
        let d = s.shift_m.get().filter(|d| d.is_finite() && *d >= 0.0)?;
        self.dt_ok(s).then(|| d / s.dt_s).filter(|v| v.is_finite())
    }

    /// The four inputs of this epoch, or `None` when the run breaks here. Call once per epoch.
    pub fn next(&mut self, s: &Sample) -> Option<[f32; N_IN]> {
        let cur = self.shift_mps(s);
        let prev = core::mem::replace(&mut self.prev_shift_mps, cur);
        if !self.dt_ok(s) {
            return None;
        }
        let finite = |v: Option<f32>| v.filter(|x| x.is_finite());
        let speed = finite(s.wheel_speed().get())?;
        let pedal = finite(s.pedal().get())?;
        let steer = match s.steering() {
            crate::sample::Reading::Valid(v) => finite(Some(v))?,
            crate::sample::Reading::Stale => return None,
            // No steering sensor: the bicycle-model proxy from yaw rate (0 below its minimum speed).
            crate::sample::Reading::Missing => {
                let yaw = finite(s.yaw_rate().get())?;
                steering_proxy_deg(yaw, speed, &self.proxy).unwrap_or(0.0)
            }
        };
        Some([prev?, pedal, steer, speed])
    }

    pub fn reset(&mut self) {
        self.prev_shift_mps = None;
    }
}

/// One LSTM step on normalised inputs, returning the normalised output.
pub trait LstmKernel {
    fn reset(&mut self);
    fn step(&mut self, m: &LstmModel, x: [f32; N_IN]) -> f32;
}

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

fn sigmoid(x: f32) -> f32 {
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
    let w = m.bytes.get(l.w + r * l.cols..l.w + (r + 1) * l.cols).unwrap_or(&[]);
    // |w| <= 128, |v| <= 32768, cols <= 192: |acc| < 2^30, no overflow.
    let (wx, wh) = w.split_at(x.len().min(w.len()));
    let acc = dot(wx, x) + dot(wh, h);
    let mult = i32_at(m.bytes, l.mult + 4 * r) as i64;
    let bias = i32_at(m.bytes, l.bias + 4 * r) as i64;
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

/// The trained default model (int8), produced by `host-sim train lstm` (see the README).
pub const DEFAULT_MODEL: &[u8] = include_bytes!("../../models/lstm.bin");

/// The LSTM as strategy 1's [`ShiftPredictor`].
#[derive(Clone, Debug)]
pub struct LstmPredictor<'a, K: LstmKernel> {
    pub model: LstmModel<'a>,
    kernel: K,
    inputs: LstmInputs,
}

impl<'a> LstmPredictor<'a, IntKernel> {
    /// The deployed predictor: the integer kernel on an int8 blob.
    pub fn int(model: LstmModel<'a>) -> Result<Self, LstmError> {
        if model.kind != WeightKind::I8 {
            return Err(LstmError::NotQuantized);
        }
        Ok(LstmPredictor { model, kernel: IntKernel::default(), inputs: LstmInputs::default() })
    }
}

impl<'a> LstmPredictor<'a, RefKernel> {
    /// The f32 reference on any blob.
    pub fn reference(model: LstmModel<'a>) -> Self {
        LstmPredictor { model, kernel: RefKernel::default(), inputs: LstmInputs::default() }
    }
}

impl<K: LstmKernel> LstmPredictor<'_, K> {
    /// One step on raw inputs (m/s, %, deg, m/s), returning the predicted shift per second.
    pub fn step_raw(&mut self, x: [f32; N_IN]) -> f32 {
        let xn = self.model.normalise(x);
        self.model.denormalise(self.kernel.step(&self.model, xn))
    }
}

impl<K: LstmKernel> ShiftPredictor for LstmPredictor<'_, K> {
    fn predict(&mut self, s: &Sample) -> Option<f32> {
        let Some(x) = self.inputs.next(s) else {
            self.kernel.reset();
            return None;
        };
        let v = self.step_raw(x);
        v.is_finite().then(|| v.max(0.0) * s.dt_s)
    }
    fn reset(&mut self) {
        self.kernel.reset();
        self.inputs.reset();
    }
    fn name(&self) -> &'static str {
        "lstm"
    }
}

/// Writes a blob (host tools and tests; the core only reads). `layers` are `(weights row-major,
/// bias)` for layer 1, layer 2 and the dense layer in f32; int8 blobs are quantised per row here.
pub struct BlobSpec<'s> {
    pub kind: WeightKind,
    pub h1: usize,
    pub h2: usize,
    pub in_min: [f32; N_IN],
    pub in_max: [f32; N_IN],
    pub out_min: f32,
    pub out_max: f32,
    pub max_err_m: [f32; 2],
    pub rmse_m: [f32; 2],
    pub layers: [(&'s [f32], &'s [f32]); 3],
}

impl BlobSpec<'_> {
    /// The blob's size in bytes.
    pub fn byte_len(&self) -> usize {
        let shapes = [(4 * self.h1, N_IN + self.h1), (4 * self.h2, self.h1 + self.h2), (1, self.h2)];
        HEADER + 4 + shapes.iter().map(|(r, c)| match self.kind {
            WeightKind::F32 => 4 * r * c + 4 * r,
            WeightKind::I8 => r * c + 8 * r,
        }).sum::<usize>()
    }

    /// Fills `out` (exactly [`BlobSpec::byte_len`] bytes) with the blob; `false` if the size or shapes are wrong.
    pub fn write(&self, out: &mut [u8]) -> bool {
        let shapes = [(4 * self.h1, N_IN + self.h1), (4 * self.h2, self.h1 + self.h2), (1, self.h2)];
        if out.len() != self.byte_len() || shapes.iter().zip(&self.layers).any(|((r, c), (w, b))| w.len() != r * c || b.len() != *r) {
            return false;
        }
        let mut o = 0;
        let put = |out: &mut [u8], o: &mut usize, b: &[u8]| {
            out[*o..*o + b.len()].copy_from_slice(b);
            *o += b.len();
        };
        put(out, &mut o, MAGIC);
        put(out, &mut o, &VERSION.to_le_bytes());
        put(out, &mut o, &[self.kind as u8, N_IN as u8]);
        put(out, &mut o, &(self.h1 as u16).to_le_bytes());
        put(out, &mut o, &(self.h2 as u16).to_le_bytes());
        for v in self.in_min.iter().chain(&self.in_max).chain(&[self.out_min, self.out_max]).chain(&self.max_err_m).chain(&self.rmse_m) {
            put(out, &mut o, &v.to_le_bytes());
        }
        for ((rows, cols), (w, b)) in shapes.iter().zip(&self.layers) {
            match self.kind {
                WeightKind::F32 => {
                    for v in w.iter().chain(b.iter()) {
                        put(out, &mut o, &v.to_le_bytes());
                    }
                }
                WeightKind::I8 => {
                    let mut mults = [0i32; 4 * MAX_H1];
                    for r in 0..*rows {
                        let row = &w[r * cols..(r + 1) * cols];
                        let amax = row.iter().fold(0.0f32, |a, v| a.max(libm::fabsf(*v)));
                        let scale = if amax > 0.0 { amax / 127.0 } else { 1.0 / 127.0 };
                        mults[r] = libm::roundf(scale * (1u32 << MULT_SHIFT) as f32) as i32;
                        // Quantise against the multiplier actually stored.
                        let s = mults[r] as f32 / (1u32 << MULT_SHIFT) as f32;
                        for v in row {
                            put(out, &mut o, &[(libm::roundf(v / s).clamp(-127.0, 127.0) as i8) as u8]);
                        }
                    }
                    for m in &mults[..*rows] {
                        put(out, &mut o, &m.to_le_bytes());
                    }
                    for v in b.iter() {
                        put(out, &mut o, &(libm::roundf(v * Q as f32) as i32).to_le_bytes());
                    }
                }
            }
        }
        let crc = crc32(&out[..o]);
        put(out, &mut o, &crc.to_le_bytes());
        true
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
            let es = (sigmoid_q12(x) as f32 / Q as f32 - sigmoid(xf)).abs();
            worst = (worst.0.max(et), worst.1.max(es));
        }
        // One Q12 step is 2.44e-4.
        assert!(worst.0 < 2.5e-4 && worst.1 < 2.5e-4, "{worst:?}");
    }

}
