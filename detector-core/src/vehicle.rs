//! The vehicle's own motion models, shared by the strategies: the kinematic bicycle model that
//! links steering wheel angle, yaw rate and speed, and wheel-speed dead reckoning.

/// The kinematic bicycle model: a steering wheel angle turns the front wheels by `angle / ratio`,
/// and the car then follows a circle of curvature `tan(front) / wheelbase`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bicycle {
    /// Wheelbase, metres.
    pub wheelbase_m: f32,
    /// Steering ratio (steering wheel angle / front wheel angle).
    pub steer_ratio: f32,
    /// Below this speed a yaw rate says nothing about the wheel, m/s.
    pub min_speed_mps: f32,
}

impl Default for Bicycle {
    /// A mid-size car: wheelbase 2.7 m, steering ratio 15, 2 m/s.
    fn default() -> Self {
        Bicycle { wheelbase_m: 2.7, steer_ratio: 15.0, min_speed_mps: 2.0 }
    }
}

impl Bicycle {
    /// The steering wheel angle that makes this yaw rate at this speed, degrees + left; `None`
    /// for non-finite inputs or below `min_speed_mps`.
    pub fn steering_deg(&self, yaw_rate_degps: f32, speed_mps: f32) -> Option<f32> {
        if !(yaw_rate_degps.is_finite() && speed_mps.is_finite()) {
            return None;
        }
        if speed_mps < self.min_speed_mps {
            return None; // yaw rate over a tiny speed says nothing about the wheel
        }
        let curvature = yaw_rate_degps.to_radians() / speed_mps;
        Some(self.steer_ratio * libm::atanf(self.wheelbase_m * curvature).to_degrees())
    }

    /// The heading change, degrees + right (as bearings), of driving `dt_s` at `speed_mps` with
    /// the wheel at `steer_deg` (+ left).
    pub fn heading_change_deg(&self, steer_deg: f32, speed_mps: f32, dt_s: f32) -> f32 {
        let curvature = crate::trig::tanf((steer_deg / self.steer_ratio).to_radians()) / self.wheelbase_m;
        -(speed_mps * curvature * dt_s).to_degrees()
    }
}

/// Distance driven over an epoch from the wheel speeds at its two ends (trapezoid rule), metres.
/// A negative reading is a sensor fault (wheel speed never runs backwards in our data) and
/// counts as 0.
pub fn dead_reckoning_m(v0_mps: f32, v1_mps: f32, dt_s: f32) -> f32 {
    0.5 * (v0_mps.max(0.0) + v1_mps.max(0.0)) * dt_s
}
