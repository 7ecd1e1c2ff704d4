//! The interface of an LSTM kernel: one step on normalised inputs, state carried.

use crate::wire::model::{LstmModel, N_IN};

/// One LSTM step on normalised inputs, returning the normalised output.
pub trait LstmKernel {
    /// Zero state: a new run starts.
    fn reset(&mut self);
    /// One step of model `m` on normalised inputs `x`, state carried; the normalised output.
    fn step(&mut self, m: &LstmModel, x: [f32; N_IN]) -> f32;
}
