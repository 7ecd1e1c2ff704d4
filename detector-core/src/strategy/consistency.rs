//! Beyond the paper: detectors for stealthy spoofing that stays under strategy 1's per-epoch
//! threshold (slow drift, many small biased shifts, heading-only changes, replay).
//!
//! Each compares GNSS with the vehicle's own sensors and sums the per-epoch disagreement over
//! the last [`ConsistencyConfig::window_s`] ([`MovingSum`]): a spoofer who stays under a per-epoch
//! threshold still has to add up to the offset they want, and over a window the sensors' own
//! noise (GNSS position noise, timing offsets between loggers) averages out instead of piling up.
//!
//! - [`ResidualCusum`]: strategy 1's signed residual after removing the wheel-speed scale error
//!   (tyre radius) that a slow estimate of `shift / prediction` tracks (time constant
//!   [`ConsistencyConfig::scale_tau_s`]). Two tests on it: the sum over the window (fires above
//!   `window_h_m`: fast), and a two-sided CUSUM `S+ = max(0, S+ + r - k)`,
//!   `S- = max(0, S- - r - k)` (fires above `cusum_h_m`: slow biases over minutes). Only while
//!   the wheels turn at >= `min_speed_mps`.
//! - [`SpeedCheck`]: GNSS-reported speed against wheel speed (scaled by its own slow estimate);
//!   fires when the mean difference over the window exceeds `speed_tol_mps + speed_tol_rel * v`.
//! - [`HeadingCheck`]: GNSS course change against the bias-corrected yaw-rate integral over the
//!   window; fires when they differ by more than `heading_tol_deg + heading_tol_rel * the angle
//!   turned`. The wheels, not GNSS, decide whether the car moves (the spoofer controls GNSS).
//!
//! `k` and the thresholds per receiver profile are derived from the clean real drives (`host-sim
//! calibrate`). The scale estimates and the gyro bias are properties of the car: they are learnt
//! during the first [`ConsistencyConfig::warmup_s`] after power-up (nothing is judged before) and
//! survive a `restart` (a short gap, a missing input); only a `reset` forgets them. Each detector
//! is degraded (never alarms) without its inputs.

use crate::profile::ReceiverProfile;
use crate::sample::Sample;
use heapless::Deque;

/// Tuning of the consistency detectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConsistencyConfig {
    /// Enables the three detectors (disable to run the paper's strategies only).
    pub enabled: bool,
    pub cusum_k_m: f32,
    pub cusum_h_m: f32,
    /// Threshold on the strategy-1 residual summed over the window, metres.
    pub window_h_m: f32,
    pub scale_tau_s: f32,
    /// Nothing is judged for this long after power-up while the scale estimates and the gyro
    /// bias are learnt, seconds.
    pub warmup_s: f32,
    pub speed_tol_mps: f32,
    pub speed_tol_rel: f32,
    /// The window of the moving sums (residual, speed, heading), seconds.
    pub window_s: f32,
    pub heading_tol_deg: f32,
    /// Heading tolerance as a fraction of the angle the gyro turned in the window (its scale
    /// error, and the integration error of a yaw rate sampled at the GNSS epochs).
    pub heading_tol_rel: f32,
    pub min_speed_mps: f32,
}

impl ConsistencyConfig {
    /// The configuration for a receiver profile: its measured thresholds, the common rest.
    pub fn for_profile(p: &ReceiverProfile) -> Self {
        ConsistencyConfig {
            enabled: true,
            cusum_k_m: p.cusum_k_m,
            cusum_h_m: p.cusum_h_m,
            window_h_m: p.window_h_m,
            scale_tau_s: 120.0,
            warmup_s: 30.0,
            speed_tol_mps: p.speed_tol_mps,
            speed_tol_rel: 0.03,
            window_s: WINDOW_S,
            heading_tol_deg: p.heading_tol_deg,
            heading_tol_rel: HEADING_TOL_REL,
            min_speed_mps: 5.0,
        }
    }
}

/// The default window of the moving sums: the 10 s within which stealthy spoofing should be
/// detected (the goal of our evaluation).
pub const WINDOW_S: f32 = 10.0;

/// The heading check's tolerance grows by this fraction of the angle turned in the window.
pub const HEADING_TOL_REL: f32 = 0.2;

/// Below this reported speed a receiver's course over ground is noise (m/s).
const COURSE_MIN_SPEED_MPS: f32 = 1.5;

/// The longest epoch the detectors learn from, seconds (the detector's longest epoch): a
/// sample claiming a longer one must not buy a warm-up or outweigh everything learnt.
const MAX_LEARN_DT_S: f32 = 3.0;

/// `dt` when it is a plausible epoch duration, else 0 (nothing learnt from it).
fn learn_dt(dt: f32) -> f32 {
    if dt > 0.0 && dt <= MAX_LEARN_DT_S { dt } else { 0.0 }
}

/// A slow scale estimate: an exponential average with time constant `tau` that starts as the
/// plain mean of what it has seen, so one noisy first value does not bias it for minutes.
#[derive(Clone, Copy, Debug, Default)]
struct SlowMean {
    value: Option<f32>,
    /// Seconds of data behind `value`.
    age_s: f32,
}

impl SlowMean {
    fn get(&self) -> f32 {
        self.value.unwrap_or(1.0)
    }
    fn update(&mut self, x: f32, dt: f32, tau: f32) {
        let dt = learn_dt(dt);
        if dt == 0.0 || !x.is_finite() {
            return;
        }
        self.age_s += dt;
        self.value = Some(match self.value {
            None => x,
            Some(p) => p + (x - p) * (dt / tau.min(self.age_s)).clamp(0.0, 1.0),
        });
    }
}

/// The sum of per-epoch increments over the last `window_s` seconds, in bounded memory
/// (128 epochs: 12.8 s at 10 Hz, 1.5 KiB), with the sum of an auxiliary magnitude beside it.
#[derive(Clone, Debug, Default)]
pub struct MovingSum {
    /// (epoch duration, increment, auxiliary), oldest first; the newest epoch ends now.
    buf: Deque<(f32, f32, f32), 128>,
}

impl MovingSum {
    pub fn reset(&mut self) {
        self.buf.clear();
    }
    /// Adds the increment `x` (and auxiliary `aux`) of the epoch of `dt` seconds that ends
    /// now. Returns the sums of both over the window once the entries cover at least 80 % of
    /// it (or the buffer is full), else `None`.
    pub fn push(&mut self, dt: f32, x: f32, aux: f32, window_s: f32) -> Option<(f32, f32)> {
        if self.buf.is_full() {
            self.buf.pop_front();
        }
        let _ = self.buf.push_back((dt.max(0.0), x, aux));
        // The oldest entry leaves once it ended a whole window ago.
        let mut span = self.span();
        while let Some(&(d, _, _)) = self.buf.front().filter(|f| span - f.0 >= window_s) {
            span -= d;
            self.buf.pop_front();
        }
        (span >= 0.8 * window_s || self.buf.is_full())
            .then(|| self.buf.iter().fold((0.0, 0.0), |(a, b), e| (a + e.1, b + e.2)))
    }
    /// The time the entries cover, seconds.
    fn span(&self) -> f32 {
        self.buf.iter().map(|e| e.0).sum()
    }
}

/// One epoch of the speed or heading check.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Check {
    /// The difference over the window (0 until the window is full).
    pub diff: f32,
    /// The part of the tolerance that scales with the driving (a fraction of the speed, or of
    /// the angle turned); the whole tolerance is the fixed part plus this.
    pub allowance: f32,
    pub fired: bool,
}

/// Strategy 1's scale-corrected residual: its sum over the window and its CUSUM.
#[derive(Clone, Debug, Default)]
pub struct ResidualCusum {
    scale: SlowMean,
    warm_s: f32,
    pos: f32,
    neg: f32,
    window: MovingSum,
}

/// One epoch of [`ResidualCusum`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResidualOutcome {
    /// CUSUM statistic, metres.
    pub cusum_m: f32,
    /// Residual summed over the window (signed), metres, once the window is full.
    pub window_m: Option<f32>,
    pub cusum_fired: bool,
    pub window_fired: bool,
}

impl ResidualCusum {
    /// Power-up: forgets everything, the scale estimate included.
    pub fn reset(&mut self) {
        *self = ResidualCusum::default();
    }
    /// After a gap or a bad sample: the statistics start over, the learnt scale (a property of
    /// the car, not of the GNSS stream) stays, so no new warm-up opens a blind spot.
    pub fn restart(&mut self) {
        *self = ResidualCusum { scale: self.scale, warm_s: self.warm_s, ..ResidualCusum::default() };
    }
    /// Still in the warm-up after power-up: nothing is judged yet.
    pub fn warming(&self, c: &ConsistencyConfig) -> bool {
        self.warm_s < c.warmup_s
    }
    /// The scale-corrected residual the next [`ResidualCusum::step`] will accumulate.
    pub fn corrected(&self, gnss_shift_m: f32, predicted_m: f32) -> f32 {
        gnss_shift_m - self.scale.get() * predicted_m
    }

    /// One judged epoch of strategy 1; `wheel_mps` is the car's own speed. Below
    /// [`ConsistencyConfig::min_speed_mps`] nothing is summed (the statistics start over): there
    /// a step's length is mostly the receiver's noise, whose magnitude is always positive and
    /// would add up to a drift of its own; standing still is strategy 3's to judge.
    pub fn step(&mut self, c: &ConsistencyConfig, gnss_shift_m: f32, predicted_m: f32, dt_s: f32, wheel_mps: f32) -> ResidualOutcome {
        let r = gnss_shift_m - self.scale.get() * predicted_m;
        if predicted_m > 0.5 && gnss_shift_m.is_finite() {
            self.scale.update((gnss_shift_m / predicted_m).clamp(0.8, 1.2), dt_s, c.scale_tau_s);
        }
        self.warm_s += learn_dt(dt_s);
        if wheel_mps.is_nan() || wheel_mps < c.min_speed_mps {
            self.restart();
            return ResidualOutcome::default();
        }
        if !r.is_finite() || self.warm_s < c.warmup_s {
            return ResidualOutcome::default();
        }
        self.pos = (self.pos + r - c.cusum_k_m).max(0.0);
        self.neg = (self.neg - r - c.cusum_k_m).max(0.0);
        let cusum_m = self.pos.max(self.neg);
        let window_m = self.window.push(dt_s, r, 0.0, c.window_s).map(|w| w.0);
        ResidualOutcome {
            cusum_m,
            window_m,
            cusum_fired: cusum_m > c.cusum_h_m,
            window_fired: window_m.is_some_and(|w| libm::fabsf(w) > c.window_h_m),
        }
    }
}

/// GNSS speed against wheel speed, averaged over the window.
#[derive(Clone, Debug, Default)]
pub struct SpeedCheck {
    scale: SlowMean,
    warm_s: f32,
    window: MovingSum,
}

impl SpeedCheck {
    /// Power-up: forgets everything, the scale estimate included.
    pub fn reset(&mut self) {
        *self = SpeedCheck::default();
    }
    /// After a gap or a bad sample: the window starts over, the learnt scale stays.
    pub fn restart(&mut self) {
        *self = SpeedCheck { scale: self.scale, warm_s: self.warm_s, ..SpeedCheck::default() };
    }
    /// Still in the warm-up after power-up: nothing is judged yet.
    pub fn warming(&self, c: &ConsistencyConfig) -> bool {
        self.warm_s < c.warmup_s
    }
    /// `None` without both speeds (degraded). Else the mean difference over the window, m/s.
    pub fn step(&mut self, c: &ConsistencyConfig, s: &Sample) -> Option<Check> {
        let (Some(w), Some(g)) = (s.wheel_speed().get(), s.gnss_speed.get()) else {
            self.window.reset();
            return None;
        };
        if !(w.is_finite() && g.is_finite()) {
            self.window.reset();
            return None;
        }
        let diff = g - self.scale.get() * w;
        if w > c.min_speed_mps && g > c.min_speed_mps {
            self.scale.update((g / w).clamp(0.9, 1.1), s.dt_s, c.scale_tau_s);
        }
        let dt = s.dt_s.max(0.0);
        self.warm_s += learn_dt(dt);
        if w < c.min_speed_mps {
            // Standing or crawling: strategy 3's to judge; the window starts over.
            self.window.reset();
            return Some(Check::default());
        }
        if self.warm_s < c.warmup_s || learn_dt(dt) == 0.0 {
            return Some(Check::default());
        }
        // The auxiliary sum is the time covered: the mean without a second pass over the window.
        let Some((sum, span)) = self.window.push(dt, diff * dt, dt, c.window_s) else { return Some(Check::default()) };
        let mean = if span > 0.0 { sum / span } else { 0.0 };
        let allowance = c.speed_tol_rel * w.max(g);
        Some(Check { diff: mean, allowance, fired: libm::fabsf(mean) > c.speed_tol_mps + allowance })
    }
}

/// GNSS course change against the yaw-rate integral, over the window.
///
/// While the car is slow the course means nothing, but the gyro still works: the check keeps
/// the last course taken at speed and integrates the yaw rate until the car is back at speed
/// (for at most [`MAX_BRIDGE_S`]), then compares the two headings across the slow stretch. A
/// heading offset built up during a stop or a slow turn is seen when driving resumes.
#[derive(Clone, Debug, Default)]
pub struct HeadingCheck {
    /// The last course taken at speed, degrees.
    ref_course: Option<f32>,
    /// The yaw rate at the previous sample, deg/s.
    last_yaw: Option<f32>,
    /// Yaw-rate integral (deg), the angle turned either way (deg) and time (s) since `ref_course`.
    yaw_deg: f32,
    turned_deg: f32,
    since_s: f32,
    /// The gyro's bias, deg/s: a slow mean of the yaw rate while the wheels stand, and of
    /// course rate + yaw rate between consecutive epochs at speed.
    bias: SlowMean,
    window: MovingSum,
}

/// The longest slow stretch the heading check bridges with the gyro alone, seconds.
pub const MAX_BRIDGE_S: f32 = 120.0;
/// Wheel speed below which the car stands (the gyro then reads its bias), m/s.
const STANDING_MPS: f32 = 0.1;
/// The largest gyro bias the estimate accepts, deg/s (automotive MEMS yaw sensors: about 1).
const MAX_BIAS_DEGPS: f32 = 2.0;

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
    /// Power-up: forgets everything, the gyro bias included.
    pub fn reset(&mut self) {
        *self = HeadingCheck::default();
    }
    /// After a gap, a bad sample or a missing input: the window starts over, the learnt gyro
    /// bias stays.
    pub fn restart(&mut self) {
        *self = HeadingCheck { bias: self.bias, ..HeadingCheck::default() };
    }
    /// Still learning the gyro bias after power-up: nothing is judged yet.
    pub fn warming(&self, c: &ConsistencyConfig) -> bool {
        self.bias.age_s < c.warmup_s
    }
    /// `None` without yaw rate, course or wheel speed (degraded). Else the course change minus
    /// the yaw integral over the window, degrees.
    pub fn step(&mut self, c: &ConsistencyConfig, s: &Sample) -> Option<Check> {
        let (Some(yaw), Some(course), Some(v)) = (s.yaw_rate().get(), s.gnss_course.get(), s.wheel_speed().get()) else {
            self.restart();
            return None;
        };
        if !(yaw.is_finite() && course.is_finite() && v.is_finite()) || learn_dt(s.dt_s) == 0.0 {
            self.restart();
            return None;
        }
        // Yaw + = left = counter-clockwise: the bearing decreases. Trapezoid rule: at 1 Hz the
        // yaw rate changes a lot within an epoch while turning.
        if let Some(yp) = self.last_yaw.replace(yaw) {
            let d = 0.5 * (yaw + yp) * s.dt_s;
            self.yaw_deg += d;
            self.turned_deg += libm::fabsf(d);
            self.since_s += s.dt_s;
        }
        if v < STANDING_MPS {
            // Wheels standing: the car does not turn, the gyro reads its bias.
            self.bias.update(yaw.clamp(-MAX_BIAS_DEGPS, MAX_BIAS_DEGPS), s.dt_s, c.scale_tau_s);
        }
        // The course means something at a reported speed, and the car moves by its wheels.
        let course_valid = s.gnss_speed.get().is_none_or(|g| g >= COURSE_MIN_SPEED_MPS);
        if v < c.min_speed_mps || !course_valid {
            if self.since_s > MAX_BRIDGE_S {
                // Too long on the gyro alone: start over (the bias stays learnt).
                self.restart();
            }
            return Some(Check::default());
        }
        let (yaw_deg, turned_deg, since_s) = (self.yaw_deg, self.turned_deg, self.since_s);
        let prev = self.ref_course.replace(course);
        (self.yaw_deg, self.turned_deg, self.since_s) = (0.0, 0.0, 0.0);
        let Some(p) = prev.filter(|_| since_s > 0.0) else { return Some(Check::default()) };
        let x = diff_deg(p, course) + yaw_deg;
        let b = self.bias.value.unwrap_or(0.0);
        if since_s <= s.dt_s {
            self.bias.update((x / since_s).clamp(-MAX_BIAS_DEGPS, MAX_BIAS_DEGPS), since_s, c.scale_tau_s);
        }
        let x = x - b * since_s;
        if self.bias.age_s < c.warmup_s {
            return Some(Check::default());
        }
        Some(match self.window.push(since_s, x, turned_deg, c.window_s) {
            Some((d, turned)) => {
                let allowance = c.heading_tol_rel * turned;
                Check { diff: d, allowance, fired: libm::fabsf(d) > c.heading_tol_deg + allowance }
            }
            None => Check::default(),
        })
    }
}
