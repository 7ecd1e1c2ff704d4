//! Strategy 1: location shift.
//!
//! Between two GNSS epochs the receiver's position moves by the *GNSS shift* (haversine distance
//! between the fixes). A predictor estimates the same distance from the vehicle's own sensors.
//! The residual `|GNSS shift - predicted shift|` is compared against the paper's threshold
//! (Dasgupta et al., equation 2):
//!
//! ```text
//! threshold = maximum absolute prediction error (measured on real drives) + GNSS positioning error
//! ```
//!
//! Both terms come from [`ShiftConfig`], which the integrator fills from a receiver profile
//! ([`crate::profile`]). The prediction error grows with the epoch duration, so where an epoch is
//! longer than the profile's nominal one (a dropped fix) the error term is scaled by
//! `dt / nominal_dt`; epochs longer than [`ShiftConfig::max_dt_s`] are not judged at all.
//!
//! Files: [`judge`] (the threshold, the judgement and the [`ShiftPredictor`] trait),
//! [`kinematic`] (wheel-speed dead reckoning over the epoch, trapezoid of the interpolated speeds
//! at both ends), [`lstm`] (the paper's LSTM: inputs, f32 reference and integer kernels, the
//! predictor), [`fallback`] (a primary predictor with the kinematic one behind it), and
//! [`predictor`] (the [`Predictor`] a build chooses at run time).

pub mod fallback;
pub mod judge;
pub mod kinematic;
pub mod lstm;
pub mod predictor;

pub use fallback::WithFallback;
pub use judge::{ShiftConfig, ShiftOutcome, ShiftPredictor};
pub use kinematic::KinematicPredictor;
pub use predictor::Predictor;
