//! Strategy 1's learned predictor: the paper's 2-layer stacked LSTM (Dasgupta et al., Table 1),
//! run one step per GNSS epoch with its state carried.
//!
//! # What it predicts
//! At each epoch the step consumes four inputs and predicts the GNSS shift of that epoch:
//!
//! | input | unit |
//! |---|---|
//! | location shift of the *previous* epoch / its duration (an epoch under 50 ms is added to the one before: [`inputs::MIN_RATE_DT_S`]) | m/s |
//! | accelerator pedal at this epoch | % |
//! | steering wheel angle at this epoch (measured, else the yaw-rate bicycle proxy) | deg |
//! | wheel speed at this epoch | m/s |
//!
//! The output is this epoch's shift divided by its duration (m/s); the predictor multiplies by
//! `dt`. Working per second rather than per epoch makes one model valid for 1 Hz and 10 Hz
//! receivers; the threshold term (maximum validation error) is still kept per receiver profile
//! in metres. The GNSS shift being judged never enters its own prediction. [`inputs::LstmInputs`] is the
//! one definition of the inputs: the trainer (host-sim) builds its windows with it, so training
//! sees exactly what the streaming step sees. A run of valid inputs starts from zero state; any
//! missing input, bad `dt` or detector restart ends the run and zeroes the state.
//!
//! # Kernels (the CMSIS-NN / TFLite Micro pattern)
//! - [`reference::RefKernel`]: plain f32 (`libm` sigmoid/tanh), on float weights or on dequantised int8
//!   weights. The reference.
//! - [`integer::IntKernel`]: pure integer. int8 weights with one scale per output row (per channel), int16
//!   Q4.12 activations and cell state, i32 accumulation, sigmoid and tanh from one 257-entry
//!   table of tanh with linear interpolation (`sigmoid(x) = (1 + tanh(x/2)) / 2`). Only the
//!   input normalisation and the output de-normalisation are f32, at the boundary.
//!
//! # Model
//! The model blob's format and its validation are [`crate::wire::model`]'s.
//!
//! # Files
//! [`inputs`] (the four inputs), [`kernel`] (the kernel interface), [`reference`](mod@reference) and
//! [`integer`] (the two kernels), [`predictor`] (strategy 1's predictor on a kernel).

pub mod inputs;
pub mod integer;
pub mod kernel;
pub mod predictor;
pub mod reference;

pub use crate::wire::model::{BlobSpec, LstmError, LstmModel, WeightKind, MAGIC, MAX_H1, MAX_H2, MULT_SHIFT, N_IN, Q, VERSION};
pub use inputs::LstmInputs;
pub use integer::IntKernel;
pub use kernel::LstmKernel;
pub use predictor::{LstmPredictor, DEFAULT_MODEL};
pub use reference::RefKernel;
