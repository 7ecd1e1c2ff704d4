//! Beyond the paper: detectors for stealthy spoofing that stays under strategy 1's per-epoch
//! threshold (slow drift, many small biased shifts, heading-only changes, replay).
//!
//! - [`ResidualCusum`]: a two-sided CUSUM on strategy 1's signed residual, after removing the
//!   wheel-speed scale error (tyre radius) that a slow estimate `ŝ = EMA(shift / prediction)`
//!   tracks (time constant [`ConsistencyConfig::scale_tau_s`]; nothing is accumulated during the
//!   first [`ConsistencyConfig::warmup_s`] after a restart, while the estimate settles). `S+ = max(0, S+ + r - k)`,
//!   `S- = max(0, S- - r - k)`; fires when either exceeds `h`. `k` and `h` per receiver profile
//!   are derived from the residuals of the clean real drives (`host-sim calibrate`).
//! - [`SpeedCheck`]: GNSS-reported speed against wheel speed (scaled by its own slow estimate);
//!   fires when the difference exceeds `speed_tol_mps + speed_tol_rel * v` for `persist_s`.
//! - [`HeadingCheck`]: GNSS course change against the yaw-rate integral over `heading_window_s`;
//!   fires when they differ by more than `heading_tol_deg` (moving, >= `min_speed_mps`).
//!
//! Each is degraded (never alarms) without its inputs and restarts after a discontinuity.

use crate::sample::Sample;
use heapless::Deque;

/// Tuning of the consistency detectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConsistencyConfig {
    /// Enables the three detectors (disable to run the paper's strategies only).
    pub enabled: bool,
    pub cusum_k_m: f32,
    pub cusum_h_m: f32,
    pub scale_tau_s: f32,
    /// The CUSUM and the speed check only learn their scale estimate for this long after a
    /// (re)start, seconds.
    pub warmup_s: f32,
    pub speed_tol_mps: f32,
    pub speed_tol_rel: f32,
    pub persist_s: f32,
    pub heading_window_s: f32,
    pub heading_tol_deg: f32,
    pub min_speed_mps: f32,
}

fn ema(prev: Option<f32>, x: f32, dt: f32, tau: f32) -> f32 {
    match prev {
        None => x,
        Some(p) => p + (x - p) * (dt / tau).clamp(0.0, 1.0),
    }
}

/// CUSUM on the scale-corrected strategy-1 residual.
#[derive(Clone, Debug, Default)]
pub struct ResidualCusum {
    scale: Option<f32>,
    warm_s: f32,
    pos: f32,
    neg: f32,
}

impl ResidualCusum {
    pub fn reset(&mut self) {
        *self = ResidualCusum::default();
    }
    /// The scale-corrected residual the next [`ResidualCusum::step`] will accumulate.
    pub fn corrected(&self, gnss_shift_m: f32, predicted_m: f32) -> f32 {
        gnss_shift_m - self.scale.unwrap_or(1.0) * predicted_m
    }

    /// One judged epoch of strategy 1. Returns `(statistic, fired)`.
    pub fn step(&mut self, c: &ConsistencyConfig, gnss_shift_m: f32, predicted_m: f32, dt_s: f32) -> (f32, bool) {
        let s = self.scale.unwrap_or(1.0);
        let r = gnss_shift_m - s * predicted_m;
        if predicted_m > 0.5 && gnss_shift_m.is_finite() {
            let ratio = (gnss_shift_m / predicted_m).clamp(0.8, 1.2);
            self.scale = Some(ema(self.scale, ratio, dt_s, c.scale_tau_s));
        }
        self.warm_s += dt_s.max(0.0);
        if !r.is_finite() || self.warm_s < c.warmup_s {
            return (0.0, false);
        }
        self.pos = (self.pos + r - c.cusum_k_m).max(0.0);
        self.neg = (self.neg - r - c.cusum_k_m).max(0.0);
        let stat = self.pos.max(self.neg);
        (stat, stat > c.cusum_h_m)
    }
}

/// GNSS speed against wheel speed.
#[derive(Clone, Debug, Default)]
pub struct SpeedCheck {
    scale: Option<f32>,
    warm_s: f32,
    since: Option<f64>,
}

impl SpeedCheck {
    pub fn reset(&mut self) {
        *self = SpeedCheck::default();
    }
    /// `None` without both speeds (degraded). Else `(difference m/s, fired)`.
    pub fn step(&mut self, c: &ConsistencyConfig, s: &Sample) -> Option<(f32, bool)> {
        let (Some(w), Some(g)) = (s.wheel_speed().get(), s.gnss_speed.get()) else {
            self.since = None;
            return None;
        };
        if !(w.is_finite() && g.is_finite()) {
            return None;
        }
        let k = self.scale.unwrap_or(1.0);
        let diff = g - k * w;
        if w > c.min_speed_mps && g > c.min_speed_mps {
            self.scale = Some(ema(self.scale, (g / w).clamp(0.9, 1.1), s.dt_s.max(0.0), c.scale_tau_s));
        }
        self.warm_s += s.dt_s.max(0.0);
        if self.warm_s < c.warmup_s {
            return Some((diff, false));
        }
        let tol = c.speed_tol_mps + c.speed_tol_rel * w.max(g);
        if libm::fabsf(diff) > tol {
            let t0 = *self.since.get_or_insert(s.t);
            Some((diff, (s.t - t0) as f32 >= c.persist_s))
        } else {
            self.since = None;
            Some((diff, false))
        }
    }
}

/// GNSS course change against the yaw-rate integral.
#[derive(Clone, Debug, Default)]
pub struct HeadingCheck {
    /// (t, unwrapped GNSS course, integrated yaw heading) per epoch.
    hist: Deque<(f64, f32, f32), 128>,
    yaw_heading: f32,
    last_course: Option<f32>,
    course_unwrapped: f32,
}

/// Smallest signed difference `to - from`, degrees, in f32 (the M4 has no f64 FPU).
fn diff_deg(from: f32, to: f32) -> f32 {
    let d = libm::fmodf(to - from, 360.0);
    if d > 180.0 {
        d - 360.0
    } else if d <= -180.0 {
        d + 360.0
    } else {
        d
    }
}

impl HeadingCheck {
    pub fn reset(&mut self) {
        *self = HeadingCheck::default();
    }
    /// `None` without yaw rate, course or speed (degraded). Else `(difference deg, fired)`.
    pub fn step(&mut self, c: &ConsistencyConfig, s: &Sample) -> Option<(f32, bool)> {
        let speed = s.wheel_speed().get().or(s.gnss_speed.get());
        let (Some(yaw), Some(course), Some(v)) = (s.yaw_rate().get(), s.gnss_course.get(), speed) else {
            self.reset();
            return None;
        };
        if !(yaw.is_finite() && course.is_finite() && v.is_finite()) || v < c.min_speed_mps {
            self.reset(); // slow: courses mean nothing; restart the window
            return Some((0.0, false));
        }
        // Yaw + left = counter-clockwise: the bearing decreases.
        self.yaw_heading -= yaw * s.dt_s.max(0.0);
        // GNSS course unwrapped as it goes (handles turns over 180 deg), O(1) per epoch.
        if let Some(p) = self.last_course {
            self.course_unwrapped += diff_deg(p, course);
        }
        self.last_course = Some(course);
        if self.hist.is_full() {
            self.hist.pop_front();
        }
        let _ = self.hist.push_back((s.t, self.course_unwrapped, self.yaw_heading));
        // The oldest entry inside the window.
        let first = *self.hist.iter().find(|h| s.t - h.0 <= c.heading_window_s as f64)?;
        if ((s.t - first.0) as f32) < c.heading_window_s * 0.8 {
            return Some((0.0, false));
        }
        let gnss = self.course_unwrapped - first.1;
        let yaw_change = self.yaw_heading - first.2;
        let d = gnss - yaw_change;
        Some((d, libm::fabsf(d) > c.heading_tol_deg))
    }
}
