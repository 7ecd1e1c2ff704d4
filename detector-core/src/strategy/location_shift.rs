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
    /// The last prediction came from the fallback (kinematic) predictor: judge it against
    /// [`ShiftConfig::fallback_error_m`].
    fn used_fallback(&self) -> bool {
        false
    }
}

/// A primary predictor with the kinematic predictor behind it: where the primary lacks its
/// inputs (an LSTM on a car without a pedal signal), the kinematic prediction is judged against
/// the kinematic error term ([`ShiftConfig::fallback_error_m`]) instead of leaving strategy 1
/// degraded.
#[derive(Clone, Debug)]
pub struct WithFallback<P> {
    pub primary: P,
    fallback: KinematicPredictor,
    used_fallback: bool,
}

impl<P: ShiftPredictor> WithFallback<P> {
    pub fn new(primary: P) -> Self {
        WithFallback { primary, fallback: KinematicPredictor::default(), used_fallback: false }
    }
}

impl<P: ShiftPredictor> ShiftPredictor for WithFallback<P> {
    fn predict(&mut self, s: &Sample) -> Option<f32> {
        // Both see every sample, so either is current when needed.
        let k = self.fallback.predict(s);
        let p = self.primary.predict(s);
        self.used_fallback = p.is_none() && k.is_some();
        p.or(k)
    }
    fn reset(&mut self) {
        self.primary.reset();
        self.fallback.reset();
        self.used_fallback = false;
    }
    fn name(&self) -> &'static str {
        if self.used_fallback { self.fallback.name() } else { self.primary.name() }
    }
    fn used_fallback(&self) -> bool {
        self.used_fallback
    }
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

/// The predictors a build can choose between at run time (no `dyn`, no allocation).
// No allocator to box the LSTM's 3 KB of state: the detector lives in static memory anyway.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Predictor<'m> {
    Kinematic(KinematicPredictor),
    /// The LSTM's integer kernel, with the kinematic predictor where the LSTM lacks inputs.
    Lstm(WithFallback<crate::strategy::lstm::LstmPredictor<'m, crate::strategy::lstm::IntKernel>>),
}

impl Predictor<'static> {
    /// The LSTM with the committed model when it is valid, else the kinematic predictor.
    pub fn default_lstm() -> Self {
        use crate::strategy::lstm::{LstmModel, LstmPredictor, DEFAULT_MODEL};
        match LstmModel::parse(DEFAULT_MODEL).and_then(LstmPredictor::int) {
            Ok(l) => Predictor::Lstm(WithFallback::new(l)),
            Err(_) => Predictor::Kinematic(KinematicPredictor::default()),
        }
    }
}

impl Predictor<'_> {
    /// The measured maximum prediction error of this predictor at this receiver profile: the
    /// first term of strategy 1's threshold.
    pub fn error_term_m(&self, p: &crate::profile::ReceiverProfile) -> f32 {
        match self {
            Predictor::Kinematic(_) => p.kinematic_max_error_m,
            Predictor::Lstm(l) => l.primary.model.max_error_m(p.nominal_dt_s),
        }
    }
}

impl ShiftPredictor for Predictor<'_> {
    fn predict(&mut self, s: &Sample) -> Option<f32> {
        match self {
            Predictor::Kinematic(p) => p.predict(s),
            Predictor::Lstm(p) => p.predict(s),
        }
    }
    fn reset(&mut self) {
        match self {
            Predictor::Kinematic(p) => p.reset(),
            Predictor::Lstm(p) => p.reset(),
        }
    }
    fn name(&self) -> &'static str {
        match self {
            Predictor::Kinematic(p) => p.name(),
            Predictor::Lstm(p) => p.name(),
        }
    }
    fn used_fallback(&self) -> bool {
        match self {
            Predictor::Kinematic(p) => p.used_fallback(),
            Predictor::Lstm(p) => p.used_fallback(),
        }
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
    pub gnss_shift_m: f32,
    pub predicted_m: f32,
    /// Signed: GNSS shift minus prediction (+ = GNSS moved further than the car).
    pub residual_m: f32,
    pub threshold_m: f32,
    pub fired: bool,
    /// The fallback (kinematic) predictor made this prediction.
    pub fallback: bool,
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
        ShiftOutcome { gnss_shift_m, predicted_m, residual_m, threshold_m, fired: residual_m.abs() > threshold_m, fallback: false }
    }
}
