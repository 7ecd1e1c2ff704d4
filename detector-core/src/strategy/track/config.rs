//! The track check's tuning: what is fixed by design (budgets, priors, the gyro's process
//! noises) and what bounds the learning. Nothing here is fitted on a drive.

use super::calibration::CalLimits;
use super::velocity::VelocityConfig;
use crate::profile::ReceiverProfile;

/// The window lengths, seconds.
pub const WINDOWS_S: [f32; 2] = [10.0, 30.0];

/// Tuning of the track check. See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackConfig {
    /// The check runs at all.
    pub enabled: bool,
    /// False alarms per hour of driving the position windows' threshold is derived from.
    pub budget_per_hour: f32,
    /// Prior noise of a window's GNSS ends, metres (the receiver class's stated accuracy), and
    /// prior relative DR error.
    pub s0_prior_m: f32,
    /// Prior relative DR error (of the distance driven).
    pub k_prior: f32,
    /// How many seconds of data the priors weigh as.
    pub prior_weight_s: f32,
    /// Floors of the learnt noise: metres, and relative.
    pub s0_floor_m: f32,
    /// Floor of the learnt relative DR error.
    pub k_floor: f32,
    /// Time constant of the noise learning after the warm-up, seconds.
    pub learn_tau_s: f32,
    /// Seconds of driving (windows of at least 30 m) learnt before the windows judge.
    pub warmup_s: f32,
    /// The car drives (learns, is judged) above this wheel speed, m/s.
    pub min_speed_mps: f32,
    /// How long `z` must stay above the threshold to fire, seconds: longer than a GNSS
    /// multipath excursion lasts (it returns; a spoofer's offset does not).
    pub persist_s: f32,
    /// The fast path: both windows above their thresholds, the 10 s window above twice its
    /// own, for this long, seconds.
    pub fast_persist_s: f32,
    /// The windows do not judge when they cannot see a drift slower than this within 10 s, m/s.
    pub max_bound_mps: f32,
    /// Random walk of the DR frame's rotation (gyro noise, scale error in turns), deg^2/s:
    /// how fast the frame may turn against GNSS, so how fast a spoofer's course step is taken
    /// as rotation. 0.001 is an angle random walk of 1.9 deg/sqrt(h), several times an
    /// automotive yaw-rate sensor's. 0.01 (before) took 1.2 deg of a 2.3 deg step (a drift
    /// across the road at 1 m/s on css_canedge) within 6 s.
    pub q_rotation: f32,
    /// Random walk of the gyro's residual bias, (deg/s)^2/s: 3e-6 lets it move by 0.04 deg/s in
    /// ten minutes, the drift of an automotive MEMS gyro's bias with temperature over a drive
    /// (css_canedge's gyro needs that much: at a tenth of it the nuisance suite raised false
    /// alarms on it; ten times it takes a course step as bias within seconds).
    pub q_bias: f32,
    /// Uncertainty of the frame's alignment from the GNSS heading after a (re)start, deg.
    pub align_sd_deg: f32,
    /// Uncertainty of the gyro's bias at power-up, before any standstill, deg/s.
    pub bias_sd_degps: f32,
    /// Uncertainty of the gyro's scale at power-up (relative), and its random walk, 1/s.
    pub gyro_scale_sd: f32,
    /// Random walk of the gyro's scale, 1/s.
    pub q_gyro_scale: f32,
    /// The frame counts as aligned (windows are judged) below this rotation uncertainty, deg.
    pub aligned_sd_deg: f32,
    /// The gyro's residual bias while a GNSS gap is bridged, deg/s.
    pub gap_gyro_sd_degps: f32,
    /// Seconds of driving after which a check that still cannot judge stops saying `learning`
    /// and, if its bound says it cannot tell, is degraded.
    pub give_up_s: f32,
    /// The velocity test.
    pub velocity: VelocityConfig,
    /// The limits of what is learnt about the car.
    pub cal: CalLimits,
}

impl TrackConfig {
    /// The configuration for a receiver profile: its stated accuracy as the prior. The
    /// process noises are a MEMS gyro's (angle random walk and bias instability of automotive
    /// yaw-rate sensors, with margin); the bias's was checked against css_canedge's gyro (see
    /// `q_bias`).
    pub fn for_profile(p: &ReceiverProfile) -> Self {
        TrackConfig {
            enabled: true,
            budget_per_hour: 0.01,
            s0_prior_m: p.gnss_error_m,
            k_prior: 0.03,
            prior_weight_s: 20.0,
            s0_floor_m: 1.0,
            k_floor: 0.01,
            learn_tau_s: 300.0,
            warmup_s: 30.0,
            min_speed_mps: 3.0,
            persist_s: 10.0,
            fast_persist_s: 3.0,
            max_bound_mps: 5.0,
            q_rotation: 0.001,
            q_bias: 3.0e-6,
            align_sd_deg: 20.0,
            bias_sd_degps: 0.5,
            gyro_scale_sd: 0.05,
            q_gyro_scale: 1.0e-8,
            aligned_sd_deg: 2.0,
            give_up_s: 300.0,
            gap_gyro_sd_degps: 0.2,
            velocity: VelocityConfig::default(),
            cal: CalLimits::default(),
        }
    }

    /// The position windows' threshold on `z` for the budget (see the module documentation).
    pub fn threshold(&self) -> f32 {
        let tests_per_hour = 3600.0 / WINDOWS_S[0] + 3600.0 / WINDOWS_S[1];
        gnss_guard_dsp::sqrtf(libm::logf(tests_per_hour / self.budget_per_hour.max(1e-9)).max(1.0))
    }

    /// The distance a window must cover to be judged: half its length at the minimum speed.
    pub(super) fn judge_dist_m(&self, win_s: f32) -> f32 {
        0.5 * win_s * self.min_speed_mps
    }
}
