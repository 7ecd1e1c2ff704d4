//! A primary predictor (the LSTM) with the kinematic predictor behind it.

use super::judge::ShiftPredictor;
use super::kinematic::KinematicPredictor;
use crate::sample::Sample;

/// A primary predictor with the kinematic predictor behind it: where the primary lacks its
/// inputs (an LSTM on a car without a pedal signal), the kinematic prediction is judged against
/// the kinematic error term ([`ShiftConfig::fallback_error_m`](super::judge::ShiftConfig::fallback_error_m)) instead of leaving strategy 1
/// degraded.
#[derive(Clone, Debug)]
pub struct WithFallback<P> {
    /// The predictor used wherever it has its inputs.
    pub primary: P,
    fallback: KinematicPredictor,
    used_fallback: bool,
}

impl<P: ShiftPredictor> WithFallback<P> {
    /// `primary`, with the kinematic predictor where it lacks an input.
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
