//! The predictor a build chooses at run time (no `dyn`, no allocation): kinematic, or the LSTM's
//! integer kernel with the kinematic predictor behind it.

use super::fallback::WithFallback;
use super::judge::ShiftPredictor;
use super::kinematic::KinematicPredictor;
use super::lstm::integer::IntKernel;
use super::lstm::predictor::{LstmPredictor, DEFAULT_MODEL};
use crate::profile::ReceiverProfile;
use crate::sample::Sample;
use crate::wire::model::LstmModel;

/// The predictors a build can choose between at run time (no `dyn`, no allocation).
// No allocator to box the LSTM's 3 KB of state: the detector lives in static memory anyway.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Predictor<'m> {
    /// Wheel-speed dead reckoning over the epoch.
    Kinematic(KinematicPredictor),
    /// The LSTM's integer kernel, with the kinematic predictor where the LSTM lacks inputs.
    Lstm(WithFallback<LstmPredictor<'m, IntKernel>>),
}

impl Predictor<'static> {
    /// The LSTM with the committed model when it is valid, else the kinematic predictor.
    pub fn default_lstm() -> Self {
        match LstmModel::parse(DEFAULT_MODEL).and_then(LstmPredictor::int) {
            Ok(l) => Predictor::Lstm(WithFallback::new(l)),
            Err(_) => Predictor::Kinematic(KinematicPredictor::default()),
        }
    }
}

impl Predictor<'_> {
    /// The measured maximum prediction error of this predictor at this receiver profile: the
    /// first term of strategy 1's threshold.
    pub fn error_term_m(&self, p: &ReceiverProfile) -> f32 {
        match self {
            Predictor::Kinematic(_) => p.kinematic_max_error_m,
            Predictor::Lstm(l) => l.primary.max_error_m(p.nominal_dt_s),
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
