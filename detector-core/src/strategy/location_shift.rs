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
//! The predictor is a trait, [`ShiftPredictor`]. [`KinematicPredictor`] integrates wheel speed
//! over the epoch (trapezoid of the interpolated speeds at both ends). The LSTM predictor
//! implements the same trait.

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
}

/// Wheel-speed dead reckoning: `(v_prev + v_cur) / 2 * dt`.
#[derive(Clone, Debug, Default)]
pub struct KinematicPredictor {
    prev_speed: Option<f32>,
}

impl ShiftPredictor for KinematicPredictor {
    fn predict(&mut self, s: &Sample) -> Option<f32> {
        let v = s.wheel_speed().get().filter(|v| v.is_finite());
        let prev = self.prev_speed;
        self.prev_speed = v;
        let (v0, v1) = (prev?, v?);
        if !(s.dt_s.is_finite() && s.dt_s > 0.0) {
            return None;
        }
        // Wheel speed never runs backwards in our data; a negative reading is a sensor fault.
        Some(0.5 * (v0.max(0.0) + v1.max(0.0)) * s.dt_s)
    }
    fn reset(&mut self) {
        self.prev_speed = None;
    }
    fn name(&self) -> &'static str {
        "kinematic"
    }
}

/// Tuning of strategy 1. See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftConfig {
    /// Maximum absolute prediction error at the nominal epoch duration, metres.
    pub predictor_error_m: f32,
    /// GNSS positioning error term, metres (epoch-to-epoch, from the receiver profile).
    pub gnss_error_m: f32,
    /// Nominal epoch duration of the receiver, seconds.
    pub nominal_dt_s: f32,
    /// Epochs longer than this are a discontinuity: not judged. Seconds.
    pub max_dt_s: f32,
}

/// What strategy 1 concluded at one epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShiftOutcome {
    pub gnss_shift_m: f32,
    pub predicted_m: f32,
    /// Signed: GNSS shift minus prediction (+ = GNSS moved further than the car).
    pub residual_m: f32,
    pub threshold_m: f32,
    pub fired: bool,
}

impl ShiftConfig {
    pub fn threshold_m(&self, dt_s: f32) -> f32 {
        let scale = if self.nominal_dt_s > 0.0 { (dt_s / self.nominal_dt_s).max(1.0) } else { 1.0 };
        self.predictor_error_m * scale + self.gnss_error_m
    }

    /// Judges one epoch given the GNSS shift and the prediction.
    pub fn judge(&self, gnss_shift_m: f32, predicted_m: f32, dt_s: f32) -> ShiftOutcome {
        let residual_m = gnss_shift_m - predicted_m;
        let threshold_m = self.threshold_m(dt_s);
        ShiftOutcome { gnss_shift_m, predicted_m, residual_m, threshold_m, fired: residual_m.abs() > threshold_m }
    }
}
