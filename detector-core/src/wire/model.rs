//! Strategy 1's LSTM model, the wire format (`GGLM`), validated in place ([`LstmModel::parse`],
//! an error value for every defect, never a panic) and written by the host's trainer
//! ([`BlobSpec`]).
//!
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
//! row.

use super::crc32::crc32;
use super::le;

/// The blob's magic.
pub const MAGIC: &[u8; 4] = b"GGLM";
/// The blob version this build reads.
pub const VERSION: u16 = 1;
/// Number of inputs per step.
pub const N_IN: usize = 4;
/// Largest layer sizes the fixed buffers hold (the paper's 128 and 64).
pub const MAX_H1: usize = 128;
/// Largest second layer the fixed buffers hold.
pub const MAX_H2: usize = 64;
const HEADER: usize = 12 + 14 * 4;
/// Fixed-point format of activations and cell state: Q4.12.
pub const Q: i32 = 4096;
/// Multiplier scale of int8 rows: `real weight = w * mult / 2^MULT_SHIFT`.
pub const MULT_SHIFT: u32 = 24;

/// Weight encoding of a blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightKind {
    /// 32-bit floats (the host's fidelity reference).
    F32 = 0,
    /// int8 weights with one multiplier per row (the deployed model).
    I8 = 1,
}

/// Why a model blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LstmError {
    /// Shorter than a header and a CRC.
    TooShort,
    /// The first four bytes are not `GGLM`.
    BadMagic,
    /// A version this build does not read.
    BadVersion,
    /// A weight kind other than f32 or int8.
    BadKind,
    /// Input count not 4, a layer size 0 or above the fixed buffers.
    BadShape,
    /// The length does not match the shapes.
    BadLength,
    /// The CRC over the blob does not match.
    BadCrc,
    /// A normalisation range or threshold term is not finite or empty.
    BadRange,
    /// The integer kernel needs an int8 blob.
    NotQuantized,
}

/// One layer's place in the blob: `rows x cols` weights at `w`, then (int8) one multiplier per
/// row at `mult`, then one bias per row at `bias`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Rows of the weight matrix (outputs).
    pub rows: usize,
    /// Columns of the weight matrix (inputs).
    pub cols: usize,
    w: usize,
    mult: usize,
    bias: usize,
}

/// A validated model blob (borrowed: in flash on the target).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LstmModel<'a> {
    bytes: &'a [u8],
    /// How the weights are stored.
    pub kind: WeightKind,
    /// Units of the first LSTM layer.
    pub h1: usize,
    /// Units of the second LSTM layer.
    pub h2: usize,
    /// Each input's minimum over the training set (min-max normalisation).
    pub in_min: [f32; N_IN],
    /// Each input's maximum over the training set.
    pub in_max: [f32; N_IN],
    /// The output's minimum over the training set, m/s.
    pub out_min: f32,
    /// The output's maximum over the training set, m/s.
    pub out_max: f32,
    /// Maximum absolute validation error, metres: `[10 Hz profile, 1 Hz profile]`.
    pub max_err_m: [f32; 2],
    /// Validation RMSE, metres: `[10 Hz profile, 1 Hz profile]`.
    pub rmse_m: [f32; 2],
    /// The two LSTM layers and the dense output layer.
    pub layers: [Layer; 3],
}

// Out of range reads as 0: `parse` checks every length first, so inside a validated blob no read
// is; this keeps the kernels free of panic paths.
fn u16_at(b: &[u8], o: usize) -> u16 {
    le::u16(b, o).unwrap_or(0)
}
fn u32_at(b: &[u8], o: usize) -> u32 {
    le::u32(b, o).unwrap_or(0)
}
fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_bits(u32_at(b, o))
}
fn i32_at(b: &[u8], o: usize) -> i32 {
    u32_at(b, o) as i32
}

impl<'a> LstmModel<'a> {
    /// Validates a blob (magic, version, kind, shapes, length, CRC, ranges) and reads it in place.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, LstmError> {
        if bytes.len() < HEADER + 4 {
            return Err(LstmError::TooShort);
        }
        if bytes.get(..4) != Some(&MAGIC[..]) {
            return Err(LstmError::BadMagic);
        }
        if u16_at(bytes, 4) != VERSION {
            return Err(LstmError::BadVersion);
        }
        let kind = match bytes.get(6).copied().unwrap_or(u8::MAX) {
            0 => WeightKind::F32,
            1 => WeightKind::I8,
            _ => return Err(LstmError::BadKind),
        };
        let (n_in, h1, h2) = (bytes.get(7).copied().unwrap_or(0) as usize, u16_at(bytes, 8) as usize, u16_at(bytes, 10) as usize);
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
        if crc32(bytes.get(..off).unwrap_or(&[])) != u32_at(bytes, off) {
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

    /// Row `r` of layer `l`'s int8 weights, as bytes (empty past the end).
    pub fn row_i8(&self, l: &Layer, r: usize) -> &'a [u8] {
        self.bytes.get(l.w + r * l.cols..l.w + (r + 1) * l.cols).unwrap_or(&[])
    }
    /// Layer `l`'s int8 weights, row-major.
    pub fn weights_i8(&self, l: &Layer) -> &'a [u8] {
        self.bytes.get(l.w..l.w + l.rows * l.cols).unwrap_or(&[])
    }
    /// Layer `l`'s row multipliers and biases of an int8 layer, as little-endian i32 bytes.
    pub fn mults_biases_i32(&self, l: &Layer) -> (&'a [u8], &'a [u8]) {
        (self.bytes.get(l.mult..l.mult + 4 * l.rows).unwrap_or(&[]), self.bytes.get(l.bias..l.bias + 4 * l.rows).unwrap_or(&[]))
    }

    /// Weight `(r, c)` of layer `l` as f32 (dequantised for int8 blobs), and the row's bias.
    pub fn w_f32(&self, l: &Layer, r: usize, c: usize) -> f32 {
        match self.kind {
            WeightKind::F32 => f32_at(self.bytes, l.w + 4 * (r * l.cols + c)),
            WeightKind::I8 => {
                self.bytes.get(l.w + r * l.cols + c).map_or(0.0, |&w| w as i8 as f32) * (i32_at(self.bytes, l.mult + 4 * r) as f32 / (1u32 << MULT_SHIFT) as f32)
            }
        }
    }
    /// Row `r`'s bias of layer `l`, as a real number.
    pub fn bias_f32(&self, l: &Layer, r: usize) -> f32 {
        match self.kind {
            WeightKind::F32 => f32_at(self.bytes, l.bias + 4 * r),
            WeightKind::I8 => i32_at(self.bytes, l.bias + 4 * r) as f32 / Q as f32,
        }
    }
}

/// Writes a blob (host tools and tests; the core only reads). `layers` are `(weights row-major,
/// bias)` for layer 1, layer 2 and the dense layer in f32; int8 blobs are quantised per row here.
pub struct BlobSpec<'s> {
    /// How to store the weights.
    pub kind: WeightKind,
    /// Units of the first LSTM layer.
    pub h1: usize,
    /// Units of the second LSTM layer.
    pub h2: usize,
    /// Each input's training minimum.
    pub in_min: [f32; N_IN],
    /// Each input's training maximum.
    pub in_max: [f32; N_IN],
    /// The output's training minimum, m/s.
    pub out_min: f32,
    /// The output's training maximum, m/s.
    pub out_max: f32,
    /// Maximum absolute validation error, metres: `[10 Hz, 1 Hz]`.
    pub max_err_m: [f32; 2],
    /// Validation RMSE, metres: `[10 Hz, 1 Hz]`.
    pub rmse_m: [f32; 2],
    /// `(weights row-major, bias)` of layer 1, layer 2 and the dense layer.
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
