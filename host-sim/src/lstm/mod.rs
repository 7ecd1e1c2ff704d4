//! `host-sim train lstm`: trains strategy 1's LSTM (Dasgupta et al., Table 1) with `burn` on the
//! real drives, and exports it as the core's model blob (f32 and int8).
//!
//! - Inputs and target come from `detector_core::strategy::location_shift::lstm::LstmInputs`, the type the
//!   streaming predictor uses, over the synchronised samples of each drive. A *run* is a stretch
//!   of consecutive epochs with every input valid; the streaming step starts each run from zero
//!   state, so training windows also start from zero state.
//! - Train and validation are split by drive. Validation runs are evaluated whole (one sequence
//!   per run, from zero state), which is what the streaming step does on the car; early stopping
//!   watches the validation MAE, and the threshold terms (maximum absolute validation error per
//!   receiver profile, in metres) are measured by the core's own f32 step on the exported blob.
//! - 2 LSTM layers (128, 64) and a dense output; min-max normalisation from the training set;
//!   MAE loss, Adam lr 0.01, batch 50, up to 500 epochs.
//!
//! Files: [`runs`] (the runs of inputs per drive, the train/validation split, the errors of a
//! predictor over runs: no burn, used by `eval`), and `train` (the burn net, its training and
//! export; only with the `train` feature).

pub mod runs;
#[cfg(feature = "train")]
pub mod train;

pub use runs::{kinematic_errors, lstm_errors, runs_of, split, stats, stream_predict, ErrStats, Run, TrainOptions};
#[cfg(feature = "train")]
pub use train::{batch_predict, export, train, Net, Ranges, TrainReport};
