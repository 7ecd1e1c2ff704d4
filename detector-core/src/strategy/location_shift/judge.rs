//! Strategy 1's judgement: the residual against the paper's threshold (equation 2), and the
//! interface every shift predictor implements.

use crate::profile::ReceiverProfile;
use crate::sample::Sample;

/// Predicts the location shift of the epoch ending at a sample.
pub trait ShiftPredictor {
    /// Called once per epoch, in order. Returns the predicted distance in metres travelled from
    /// the previous epoch to `s`, or `None` when the inputs it needs are not valid (degraded).
    fn predict(&mut self, s: &Sample) -> Option<f32>;
    /// Forgets all state (after a time discontinuity).
    fn reset(&mut self);
    /// Short name for reports.
    fn name(&self) -> &'static str;
    /// The last prediction came from the fallback (kinematic) predictor: judge it against
    /// [`ShiftConfig::fallback_error_m`].
    fn used_fallback(&self) -> bool {
        false
    }
}

/// Tuning of strategy 1. See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftConfig {
    /// Maximum absolute prediction error at the nominal epoch duration, metres.
    pub predictor_error_m: f32,
    /// The same for the fallback (kinematic) predictor, used where it made the prediction.
    pub fallback_error_m: f32,
    /// GNSS positioning error term, metres (epoch-to-epoch, from the receiver profile).
    pub gnss_error_m: f32,
    /// Nominal epoch duration of the receiver, seconds.
    pub nominal_dt_s: f32,
    /// Epochs longer than this are a discontinuity: not judged. Seconds.
    pub max_dt_s: f32,
    /// Nothing is judged until the receiver has reported for this long after the detector's
    /// first epoch (a receiver's first fixes are unsettled: css session0 steps 16 to 18 m within
    /// its first 5 s). Only at start-up, never after a restart. Seconds.
    pub settle_s: f32,
}

/// What strategy 1 concluded at one epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShiftOutcome {
    /// The GNSS shift since the previous epoch, metres.
    pub gnss_shift_m: f32,
    /// The predictor's shift for the same epoch, metres.
    pub predicted_m: f32,
    /// Signed: GNSS shift minus prediction (+ = GNSS moved further than the car).
    pub residual_m: f32,
    /// The threshold at this epoch's duration, metres.
    pub threshold_m: f32,
    /// `|residual_m| > threshold_m`.
    pub fired: bool,
    /// The fallback (kinematic) predictor made this prediction.
    pub fallback: bool,
}

impl ShiftConfig {
    /// Strategy 1's configuration for a receiver profile, with the kinematic predictor's error
    /// term (a detector with another predictor puts that one's in `predictor_error_m`).
    pub fn for_profile(p: &ReceiverProfile) -> Self {
        ShiftConfig {
            predictor_error_m: p.kinematic_max_error_m,
            fallback_error_m: p.kinematic_max_error_m,
            gnss_error_m: p.gnss_error_m,
            nominal_dt_s: p.nominal_dt_s,
            max_dt_s: 3.0,
            settle_s: 5.0,
        }
    }

    /// The threshold for an epoch of `dt_s` seconds: the error term scaled by `dt / nominal dt` (never below 1) plus the GNSS error term, metres.
    pub fn threshold_m(&self, dt_s: f32) -> f32 {
        let scale = if self.nominal_dt_s > 0.0 { (dt_s / self.nominal_dt_s).max(1.0) } else { 1.0 };
        self.predictor_error_m * scale + self.gnss_error_m
    }

    /// Judges one epoch given the GNSS shift and the prediction.
    pub fn judge(&self, gnss_shift_m: f32, predicted_m: f32, dt_s: f32) -> ShiftOutcome {
        let residual_m = gnss_shift_m - predicted_m;
        let threshold_m = self.threshold_m(dt_s);
        ShiftOutcome { gnss_shift_m, predicted_m, residual_m, threshold_m, fired: residual_m.abs() > threshold_m, fallback: false }
    }
}
