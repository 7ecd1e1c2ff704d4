//! The kinematic predictor: wheel-speed dead reckoning over the epoch.

use super::judge::ShiftPredictor;
use crate::sample::Sample;
use crate::vehicle::dead_reckoning_m;

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
        Some(dead_reckoning_m(v0, v1, s.dt_s))
    }
    fn reset(&mut self) {
        self.prev_speed = None;
    }
    fn name(&self) -> &'static str {
        "kinematic"
    }
}
