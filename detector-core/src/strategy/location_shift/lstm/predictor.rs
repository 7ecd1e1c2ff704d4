//! The LSTM as strategy 1's [`ShiftPredictor`]: inputs, a kernel, and the model, one step per
//! epoch with the state carried; a missing input or a restart ends the run and zeroes the state.

use super::inputs::LstmInputs;
use super::integer::IntKernel;
use super::kernel::LstmKernel;
use super::reference::RefKernel;
use crate::sample::Sample;
use crate::strategy::location_shift::judge::ShiftPredictor;
use crate::wire::model::{LstmError, LstmModel, WeightKind, N_IN};

/// The trained default model (int8), produced by `host-sim train lstm` (see the README).
pub const DEFAULT_MODEL: &[u8] = include_bytes!("../../../../models/lstm.bin");

/// The LSTM as strategy 1's [`ShiftPredictor`].
#[derive(Clone, Debug)]
pub struct LstmPredictor<'a, K: LstmKernel> {
    /// The model, read in place from its blob.
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

    /// The integer kernel on the reference dot product (benchmarks and parity tests: the same
    /// outputs, bit for bit, as [`LstmPredictor::int`]).
    pub fn int_portable(model: LstmModel<'a>) -> Result<Self, LstmError> {
        let mut p = Self::int(model)?;
        p.kernel = IntKernel::portable();
        Ok(p)
    }
}

impl<'a> LstmPredictor<'a, RefKernel> {
    /// The f32 reference on any blob.
    pub fn reference(model: LstmModel<'a>) -> Self {
        LstmPredictor { model, kernel: RefKernel::default(), inputs: LstmInputs::default() }
    }
}

impl<K: LstmKernel> LstmPredictor<'_, K> {
    /// Strategy 1's first threshold term for a receiver of this nominal epoch duration: the
    /// model's maximum validation error, stored in its blob.
    pub fn max_error_m(&self, nominal_dt_s: f32) -> f32 {
        self.model.max_error_m(nominal_dt_s)
    }

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
