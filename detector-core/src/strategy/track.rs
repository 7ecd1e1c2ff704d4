//! Beyond the paper: the track check, for spoofing that stays under strategy 1's per-epoch
//! threshold (slow drift, many small biased steps, a rotated track, a delayed track). One
//! statistic that calibrates itself to the car instead of thresholds fitted on other cars.
//!
//! # The model
//! The car's own sensors give a dead-reckoning (DR) track: wheel speed along the heading, the
//! heading integrated from the gyro (its bias measured while the wheels stand) or, without a
//! gyro, taken from the GNSS track itself. Over a window of `T` seconds (10 s and 30 s) the GNSS
//! displacement `G` (complex, east + i north) is compared with the DR displacement `D` of the
//! same window, `tau` earlier:
//!
//! ```text
//! e = G(t-T, t) - s e^{i theta} D(t-T-tau, t-tau)
//! ```
//!
//! What differs between installations, or drifts, is learnt on the car while nothing is above
//! its threshold (during a warm-up without that condition):
//! - `theta`, the rotation of the DR frame against the GNSS frame. It is set from the GNSS
//!   heading when the car first moves after a (re)start (uncertainty `align_sd_deg`), then
//!   tracked by a three-state error-state Kalman filter (rotation; its rate, the gyro's residual
//!   bias; the gyro's scale error, observable in turns) from each 10 s window's angle
//!   `arg(G conj(D))`, whose variance is the window's noise over `L^2`. The filter's bias and
//!   scale are fed back into the DR's turn. Its uncertainty `P` enters the decision, and a frame
//!   that has not converged (`sqrt(P)` over `aligned_sd_deg`) is not judged at all. The gyro's
//!   bias is also read while the wheels stand (the innovation taken against the filter's whole
//!   bias, so the part learnt while driving is not counted twice).
//! - `s` and `tau`, the wheel-speed scale (tyre radius) and the delay between GNSS and the
//!   vehicle signals (receiver and logger latency), among 17 candidates from 0 to 2 s:
//!   exponentially weighted sums (time constant growing from the warm-up to `learn_tau_s`) of
//!   `G conj(D) e^{-i theta}` and `|D|^2` per candidate, rotation removed so they survive a
//!   re-alignment; the delay whose least-squares fit explains the most wins.
//! - the noise of `e`: `E|e|^2 = s0^2 + (k L)^2 + P L^2`, with `L = |D|` the distance driven,
//!   `s0` the GNSS noise of a window's two ends and `k` the relative DR error (speed
//!   quantisation, heading noise, timing), fitted per window length by weighted least squares
//!   on `|e|^2` clipped at 3 sigma (robust to the receiver's occasional jumps). The receiver's
//!   own accuracy (NMEA GST, UBX hAcc), when it reports one, floors `s0`. `s0` and `k` start
//!   from the receiver profile's stated accuracy: a prior worth `prior_weight_s` seconds, not
//!   fitted on any drive, whose weight fades as the car's own data comes in.
//!
//! # The decision
//! `z = |e| / sigma(L)`. For a two-dimensional Gaussian `e`, `P(z > c) = exp(-c^2)`; with about
//! `3600/10 + 3600/30 = 480` windows per hour, the threshold for a budget of `B` false alarms
//! per hour is `c = sqrt(ln(480 / B))` (B = 0.01: c = 3.29). A window is judged while the car
//! drives (wheel speed over `min_speed_mps`, and at least half the window's length at that
//! speed covered). It fires when `z > c` holds for `persist_s` (a single bad fix or a multipath
//! excursion affects a window only for a while: it returns, a spoofer's offset does not); when
//! both windows are above `c` and the 10 s one above `2c` for `fast_persist_s`; or at once when
//! the 10 s window is above `4c` and the 30 s one above `c` (a jump). Where the learnt noise
//! makes the check blind to drifts below `max_bound_mps` within 10 s, it is degraded and says
//! so (`uninformative`) instead of judging; so is a frame that has not aligned after
//! `give_up_s` of driving.
//!
//! # Gaps
//! A GNSS gap of up to `MAX_BRIDGE_S` is bridged by the DR alone when the gyro and the
//! synchroniser's integrals of wheel speed and yaw rate across it are valid: a window that
//! starts inside the gap starts at its first edge instead, so a jump hidden in the gap is judged
//! at the first fix after it, with the gap's extra variance (the turn's shape, a residual gyro
//! bias of `gap_gyro_sd_degps`); such windows are judged, never learnt from. Without a gyro the
//! DR heading is the GNSS track's own: a rotated track is then invisible (there is no
//! independent heading), the along-track part is still checked, and a gap restarts the windows.
//! Time going backwards, an invalid sample or a longer gap starts the windows and the frame
//! over; what was learnt about the car (scale, delay, noise, bias) is kept unless the detector
//! restarts it.

use crate::geo::{to_local, LatLon, EARTH_RADIUS_PAPER_M};
use crate::profile::ReceiverProfile;
use crate::sample::Sample;
use core::f32::consts::PI;
use heapless::Deque;

/// The window lengths, seconds.
pub const WINDOWS_S: [f32; 2] = [10.0, 30.0];
/// Delay candidates: 0, 0.125, ..., 2 s.
pub const DELAYS: usize = 17;
pub const DELAY_STEP_S: f32 = 0.125;
/// History kept (at most one entry per 0.19 s: over 48 s at any rate).
const HISTORY: usize = 256;
const MIN_SPACING_S: f64 = 0.19;
/// Enough history for the longest window and delay, with a margin.
const SPAN_NEEDED_S: f64 = 30.0 + 2.0 + 0.5;
/// The local frame's origin follows the car every this many metres (keeps the flat-earth
/// error of a 30 s window under 0.2 m).
const REBASE_M: f32 = 1000.0;
/// Below this the car stands: the gyro reads its bias, m/s.
const STANDING_MPS: f32 = 0.1;
/// The largest gyro bias believed, deg/s.
const MAX_BIAS_DEGPS: f32 = 2.0;
/// Windows shorter than this (metres driven) teach nothing about scale, rotation or delay.
const MIN_LEARN_DIST_M: f32 = 30.0;
/// Epochs at most this far apart are consecutive, seconds.
const MAX_STEP_S: f64 = 3.0;
/// Faster than any car, m/s: a wheel-speed integral beyond it is a sensor fault.
const MAX_SPEED_MPS: f32 = 150.0;
/// A GNSS gap up to this long is bridged by the dead reckoning when the synchroniser's
/// integrals of wheel speed and yaw rate span it (a spoofer can cause a gap: the track on the
/// other side is still compared with where the car went), seconds.
pub const MAX_BRIDGE_S: f64 = 60.0;

/// Tuning of the track check. See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackConfig {
    pub enabled: bool,
    /// False alarms per hour of driving the threshold is derived from.
    pub budget_per_hour: f32,
    /// Prior noise of a window's GNSS ends, metres (the receiver class's stated accuracy), and
    /// prior relative DR error.
    pub s0_prior_m: f32,
    pub k_prior: f32,
    /// How many seconds of data the priors weigh as.
    pub prior_weight_s: f32,
    /// Floors of the learnt noise: metres, and relative.
    pub s0_floor_m: f32,
    pub k_floor: f32,
    /// Time constant of the scale, delay and noise learning after the warm-up, seconds.
    pub learn_tau_s: f32,
    /// Seconds of driving (windows of at least 30 m) learnt before anything is judged.
    pub warmup_s: f32,
    /// The car drives (learns, is judged) above this wheel speed, m/s.
    pub min_speed_mps: f32,
    /// How long `z` must stay above the threshold to fire, seconds: longer than a GNSS
    /// multipath excursion lasts (it returns; a spoofer's offset does not).
    pub persist_s: f32,
    /// The fast path: both windows above their thresholds, the 10 s window above twice its
    /// own, for this long, seconds.
    pub fast_persist_s: f32,
    /// The check is degraded when it cannot see a drift slower than this within 10 s, m/s.
    pub max_bound_mps: f32,
    /// Random walk of the DR frame's rotation (gyro noise, scale error in turns), deg^2/s.
    pub q_rotation: f32,
    /// Random walk of the gyro's residual bias, (deg/s)^2/s.
    pub q_bias: f32,
    /// Uncertainty of the frame's alignment from the GNSS heading after a (re)start, deg.
    pub align_sd_deg: f32,
    /// Uncertainty of the gyro's bias at power-up, before any standstill, deg/s.
    pub bias_sd_degps: f32,
    /// Uncertainty of the gyro's scale at power-up (relative), and its random walk, 1/s.
    pub gyro_scale_sd: f32,
    pub q_gyro_scale: f32,
    /// The frame counts as aligned (windows are judged) below this rotation uncertainty, deg.
    pub aligned_sd_deg: f32,
    /// The gyro's residual bias while a GNSS gap is bridged (what the learnt bias may be off
    /// by: automotive MEMS yaw-rate sensors drift by tenths of a degree per second with
    /// temperature), deg/s.
    pub gap_gyro_sd_degps: f32,
    /// Seconds of driving after which a check that still cannot judge (its frame never
    /// aligned) stops saying `learning` and, if its bound says it cannot tell, is degraded.
    pub give_up_s: f32,
}

impl TrackConfig {
    /// The configuration for a receiver profile: its stated accuracy as the prior. The
    /// process noises are a MEMS gyro's (angle random walk and bias instability of automotive
    /// yaw-rate sensors, with margin), not fitted on any drive.
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
            q_rotation: 0.01,
            q_bias: 1.0e-5,
            align_sd_deg: 20.0,
            bias_sd_degps: 0.5,
            gyro_scale_sd: 0.05,
            q_gyro_scale: 1.0e-8,
            aligned_sd_deg: 2.0,
            give_up_s: 300.0,
            gap_gyro_sd_degps: 0.2,
        }
    }

    /// The threshold on `z` for the budget (see the module documentation).
    pub fn threshold(&self) -> f32 {
        let tests_per_hour = 3600.0 / WINDOWS_S[0] + 3600.0 / WINDOWS_S[1];
        libm::sqrtf(libm::logf(tests_per_hour / self.budget_per_hour.max(1e-9)).max(1.0))
    }

    /// The distance a window must cover to be judged: half its length at the minimum speed.
    fn judge_dist_m(&self, win_s: f32) -> f32 {
        0.5 * win_s * self.min_speed_mps
    }
}

/// One history entry: the GNSS position and the DR position, in the local frames.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    /// Seconds after `base_t`.
    t: f32,
    /// GNSS position, metres east and north of the origin.
    g: (f32, f32),
    /// Cumulative DR position, metres, in the DR frame.
    d: (f32, f32),
    /// Cumulative variance the DR took on across bridged GNSS gaps, m^2.
    u: f32,
}

/// Exponentially weighted sums of the scale fit for one delay candidate: `sum G conj(D)
/// e^{-i theta}` (re, im) and `sum |D|^2`.
#[derive(Clone, Copy, Debug, Default)]
struct DelayFit {
    a: (f32, f32),
    b: f32,
}

impl DelayFit {
    /// The residual the fit removes (larger is better): `Re(a)^2 / b` for a positive scale.
    fn explained(&self) -> f32 {
        if self.b > 0.0 && self.a.0 > 0.0 {
            self.a.0 * self.a.0 / self.b
        } else {
            0.0
        }
    }
}

/// Exponentially weighted least squares of `|e|^2 = s0^2 + k^2 L^2` (x = L^2, y = |e|^2).
/// `|e|^2`'s own spread grows with its mean, so each window weighs `1 / sigma^4(L)` (the
/// model's current variance): the short windows, not extrapolation from the long ones, decide
/// `s0`. `secs` counts the seconds of data in the fit.
#[derive(Clone, Copy, Debug, Default)]
struct NoiseFit {
    secs: f32,
    w: f32,
    x: f32,
    y: f32,
    xx: f32,
    xy: f32,
}

impl NoiseFit {
    fn add(&mut self, x: f32, y: f32, secs: f32, w: f32, keep: f32) {
        self.secs = self.secs * keep + secs;
        self.w = self.w * keep + w;
        self.x = self.x * keep + w * x;
        self.y = self.y * keep + w * y;
        self.xx = self.xx * keep + w * x * x;
        self.xy = self.xy * keep + w * x * y;
    }
    /// (s0^2, k^2), floored.
    fn params(&self, s0_floor: f32, k_floor: f32) -> (f32, f32) {
        let w = self.w.max(1e-6);
        let (mx, my) = (self.x / w, self.y / w);
        let var = self.xx / w - mx * mx;
        let slope = if var > 1e-3 { (self.xy / w - mx * my) / var } else { 0.0 };
        let k2 = slope.max(k_floor * k_floor);
        let s2 = (my - k2 * mx).max(s0_floor * s0_floor);
        (s2, k2)
    }
}

/// The DR frame's rotation against GNSS, a three-state Kalman filter in error-state form:
/// the rotation `theta` (rad) left between the frames, the correction `omega` (rad/s) to the
/// gyro's standstill bias and the correction `eps` to its scale. The dead reckoning turns by
/// `(1 + eps) dpsi + omega dt` for a gyro turn `dpsi` (bias removed), with the current
/// estimates, so `theta` stays put on average; an error `d omega`, `d eps` in them turns it by
/// `d omega dt + d eps dpsi`, which is how the covariance grows.
#[derive(Clone, Copy, Debug)]
struct Rotation {
    x: [f32; 3],
    p: [[f32; 3]; 3],
}

/// The angle in [-pi, pi]. One remainder, not a loop: a loop that subtracts 2 pi never ends
/// on a huge angle (hostile input), where `x - 2 pi == x`.
fn wrap_pi(x: f32) -> f32 {
    if !x.is_finite() {
        return 0.0;
    }
    let r = libm::remainderf(x, 2.0 * PI);
    if r.is_finite() { r.clamp(-PI, PI) } else { 0.0 }
}

/// The largest gyro scale error believed.
const MAX_SCALE_ERROR: f32 = 0.2;

impl Rotation {
    fn new(cfg: &TrackConfig) -> Self {
        let a = cfg.align_sd_deg.to_radians();
        let b = cfg.bias_sd_degps.to_radians();
        let e = cfg.gyro_scale_sd;
        Rotation { x: [0.0; 3], p: [[a * a, 0.0, 0.0], [0.0, b * b, 0.0], [0.0, 0.0, e * e]] }
    }
    fn theta(&self) -> f32 {
        self.x[0]
    }
    fn omega(&self) -> f32 {
        self.x[1]
    }
    fn scale_error(&self) -> f32 {
        self.x[2]
    }
    fn var_theta(&self) -> f32 {
        self.p[0][0].max(0.0)
    }
    /// A new alignment: the rotation unknown to `align_sd_deg`, drift and scale error kept.
    fn realign(&mut self, cfg: &TrackConfig) {
        let a = cfg.align_sd_deg.to_radians();
        self.x[0] = 0.0;
        for k in 0..3 {
            self.p[0][k] = 0.0;
            self.p[k][0] = 0.0;
        }
        self.p[0][0] = a * a;
    }
    /// The DR's turn over `dt` seconds for a gyro turn `dpsi` (bias removed), radians.
    fn corrected_turn(&self, dt: f32, dpsi: f32) -> f32 {
        (1.0 + self.x[2]) * dpsi + self.x[1] * dt
    }
    /// Time update over `dt` seconds in which the gyro turned by `dpsi` radians.
    fn predict(&mut self, dt: f32, dpsi: f32, cfg: &TrackConfig) {
        let f = [[1.0, dt, dpsi], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        // P = F P F^T + Q
        let mut fp = [[0.0f32; 3]; 3];
        for (i, row) in fp.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| f[i][k] * self.p[k][j]).sum();
            }
        }
        for (prow, fprow) in self.p.iter_mut().zip(fp.iter()) {
            for (v, frow) in prow.iter_mut().zip(f.iter()) {
                *v = fprow.iter().zip(frow.iter()).map(|(a, b)| a * b).sum();
            }
        }
        let d2r = (PI / 180.0) * (PI / 180.0);
        self.p[0][0] += cfg.q_rotation * d2r * dt;
        self.p[1][1] += cfg.q_bias * d2r * dt;
        self.p[2][2] += cfg.q_gyro_scale * dt;
    }
    /// One measurement of the rotation with variance `r`.
    fn update(&mut self, phi: f32, r: f32, cfg: &TrackConfig) {
        let s = self.p[0][0] + r;
        if !(s > 0.0 && s.is_finite() && phi.is_finite()) {
            return;
        }
        let innov = wrap_pi(phi - self.x[0]);
        let k = [self.p[0][0] / s, self.p[1][0] / s, self.p[2][0] / s];
        for (x, g) in self.x.iter_mut().zip(k.iter()) {
            *x += g * innov;
        }
        self.x[0] = wrap_pi(self.x[0]);
        let max_omega = MAX_BIAS_DEGPS.to_radians();
        self.x[1] = self.x[1].max(-max_omega).min(max_omega);
        self.x[2] = self.x[2].clamp(-MAX_SCALE_ERROR, MAX_SCALE_ERROR);
        // P = (I - K H) P, H = [1 0 0]
        let row0 = self.p[0];
        for (i, gi) in k.iter().enumerate() {
            for (j, r0) in row0.iter().enumerate() {
                self.p[i][j] -= gi * r0;
            }
        }
        // Keep P symmetric and its diagonal non-negative.
        for i in 0..3 {
            self.p[i][i] = self.p[i][i].max(0.0);
            for j in 0..i {
                let m = 0.5 * (self.p[i][j] + self.p[j][i]);
                self.p[i][j] = m;
                self.p[j][i] = m;
            }
        }
        if !self.p.iter().flatten().chain(self.x.iter()).all(|v| v.is_finite()) {
            *self = Rotation::new(cfg);
        }
    }
}

/// Where the dead reckoning's heading comes from.
///
/// A heading from steering and wheel speed (the bicycle model, its scale and offset learnt by
/// the same filter) was tried on the two drives with steering and no gyro (openxc_ford,
/// udacity_ch2): its rotation never settled within 2 degrees, so the check would only ever
/// learn there. It is not offered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HeadingSource {
    /// Yaw rate (gyro), bias and scale learnt.
    Gyro,
    /// The GNSS track itself: no independent heading (a rotated track is invisible).
    #[default]
    Gnss,
}

impl HeadingSource {
    pub const fn name(self) -> &'static str {
        match self {
            HeadingSource::Gyro => "gyro",
            HeadingSource::Gnss => "gnss",
        }
    }
}

/// One window's judgement.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WindowOutcome {
    /// |e|, metres, and the threshold on it (c sigma(L)), metres.
    pub e_m: f32,
    pub threshold_m: f32,
    /// Distance driven over the window (DR), metres.
    pub dist_m: f32,
    pub z: f32,
}

/// One epoch of the track check.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackOutcome {
    /// The 10 s and 30 s windows, when judged at this epoch.
    pub windows: [Option<WindowOutcome>; 2],
    /// Which window fired.
    pub fired: [bool; 2],
    /// The learnt delay, s, wheel-speed scale, rotation of the DR frame (deg) and gyro bias
    /// (deg/s).
    pub delay_s: f32,
    pub scale: f32,
    pub rotation_deg: f32,
    pub gyro_bias_degps: f32,
    /// The heading source, and its learnt scale (true turn over measured turn).
    pub heading: HeadingSource,
    pub turn_scale: f32,
    /// Still learning (warm-up, or the frame not yet aligned): nothing is judged.
    pub learning: bool,
    /// The learnt noise leaves the check blind to drifts under `max_bound_mps` within 10 s.
    pub uninformative: bool,
    /// The slowest drift visible within 10 s at this epoch's threshold, m/s.
    pub bound_10s_mps: Option<f32>,
    /// The learnt noise per window: `s0` (metres) and `k`.
    pub noise_s0_m: [f32; 2],
    pub noise_k: [f32; 2],
}

/// What the check kept of the previous epoch.
#[derive(Clone, Copy, Debug)]
struct Last {
    t: f64,
    wheel: f32,
    yaw: Option<f32>,
}

/// One window computed at one epoch, before the decision.
#[derive(Clone, Copy, Debug)]
struct Window {
    /// GNSS displacement, and the DR displacement at the best delay.
    g: (f32, f32),
    d: (f32, f32),
    l: f32,
    e2: f32,
    /// The learnt noise, and with the rotation's uncertainty (and a bridged gap's).
    var0: f32,
    var: f32,
    /// The window spans a bridged gap: it is judged, nothing is learnt from it.
    bridged: bool,
    z: f32,
}

/// The streaming track check. See the module documentation.
#[derive(Clone, Debug)]
pub struct TrackCheck {
    cfg: TrackConfig,
    c: f32,
    // The stretch since the last (re)start.
    hist: Deque<Entry, HISTORY>,
    origin: Option<LatLon>,
    base_t: f64,
    dr: (f32, f32),
    /// Variance the DR took on across bridged gaps since the (re)start, m^2.
    dr_var: f32,
    psi: f32,
    aligned: bool,
    source: Option<HeadingSource>,
    last: Option<Last>,
    heading_anchor: Option<(f32, f32)>,
    above_since: [Option<f64>; 2],
    fast_since: Option<f64>,
    alarm: [bool; 2],
    // Learnt about the car (kept across short gaps).
    bias: f32,
    bias_weight: f32,
    /// The gyro frame's rotation filter.
    rot: Rotation,
    delays: [DelayFit; DELAYS],
    best: usize,
    noise: [NoiseFit; 2],
    learnt_s: f32,
    /// Seconds driven without judging since the (re)start.
    unjudged_s: f32,
}

fn cmul(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}
fn conj(a: (f32, f32)) -> (f32, f32) {
    (a.0, -a.1)
}
fn sub(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0 - b.0, a.1 - b.1)
}
fn norm2(a: (f32, f32)) -> f32 {
    a.0 * a.0 + a.1 * a.1
}
fn cis(x: f32) -> (f32, f32) {
    (libm::cosf(x), libm::sinf(x))
}

impl TrackCheck {
    pub fn new(cfg: TrackConfig) -> Self {
        TrackCheck {
            cfg,
            c: cfg.threshold(),
            hist: Deque::new(),
            origin: None,
            base_t: 0.0,
            dr: (0.0, 0.0),
            dr_var: 0.0,
            psi: 0.0,
            aligned: false,
            source: None,
            last: None,
            heading_anchor: None,
            above_since: [None; 2],
            fast_since: None,
            alarm: [false; 2],
            bias: 0.0,
            bias_weight: 0.0,
            rot: Rotation::new(&cfg),
            delays: [DelayFit::default(); DELAYS],
            best: 0,
            noise: [NoiseFit::default(); 2],
            learnt_s: 0.0,
            unjudged_s: 0.0,
        }
    }

    /// The noise of window `wi`, `(s0^2, k^2)`: the car's own fit, blended with the receiver
    /// profile's prior while the fit has little data (the prior's weight fades over the first
    /// `prior_weight_s` seconds of learning).
    fn noise_params(&self, wi: usize) -> (f32, f32) {
        let c = self.cfg;
        let prior = (2.0 * c.s0_prior_m * c.s0_prior_m, c.k_prior * c.k_prior);
        let Some(nf) = self.noise.get(wi) else { return prior };
        let w_p = c.prior_weight_s * libm::expf(-self.learnt_s / c.prior_weight_s.max(1.0));
        let w_d = nf.secs.max(0.0);
        if w_d <= 0.0 {
            return prior;
        }
        let (s2, k2) = nf.params(c.s0_floor_m, c.k_floor);
        let a = w_p / (w_p + w_d);
        (a * prior.0 + (1.0 - a) * s2, a * prior.1 + (1.0 - a) * k2)
    }

    /// The time constant of the learning: growing with what was learnt, from the warm-up's
    /// length to `learn_tau_s` (early, poorly aligned data is forgotten soon).
    fn learn_tau(&self) -> f32 {
        let c = self.cfg;
        // max/min, not clamp: clamp panics on bounds it cannot prove ordered.
        let lo = c.warmup_s.max(1.0);
        self.learnt_s.max(lo).min(c.learn_tau_s.max(lo))
    }

    /// Power-up: forgets everything.
    pub fn reset(&mut self) {
        *self = TrackCheck::new(self.cfg);
    }

    /// After a short gap or a missing input: the windows and the frame's alignment start
    /// over, what was learnt about the car stays.
    pub fn restart(&mut self) {
        self.hist.clear();
        self.origin = None;
        self.dr = (0.0, 0.0);
        self.dr_var = 0.0;
        self.psi = 0.0;
        self.aligned = false;
        self.source = None;
        self.last = None;
        self.heading_anchor = None;
        self.above_since = [None; 2];
        self.fast_since = None;
        self.alarm = [false; 2];
        self.unjudged_s = 0.0;
    }

    /// Still in the warm-up after power-up.
    pub fn warming(&self) -> bool {
        self.learnt_s < self.cfg.warmup_s
    }

    pub fn delay_s(&self) -> f32 {
        self.best as f32 * DELAY_STEP_S
    }

    /// The learnt wheel-speed scale (at the best delay).
    fn scale(&self) -> f32 {
        match self.delays.get(self.best) {
            Some(f) if f.b > 1.0 && f.a.0 > 0.0 => f.a.0 / f.b,
            _ => 1.0,
        }
    }

    /// The gain mapping DR displacements onto GNSS ones: the scale, rotated (gyro mode).
    fn gain(&self) -> (f32, f32) {
        let s = self.scale();
        match self.rot() {
            Some(rot) => {
                let r = cis(rot.theta());
                (s * r.0, s * r.1)
            }
            None => (s, 0.0),
        }
    }

    /// The rotation's variance, rad^2 (none without a gyro: the DR heading is GNSS's own).
    fn rot_var(&self) -> f32 {
        self.rot().map_or(0.0, Rotation::var_theta)
    }

    /// The rotation filter of this stretch's heading source (none when GNSS is the heading).
    fn rot(&self) -> Option<&Rotation> {
        (self.source == Some(HeadingSource::Gyro)).then_some(&self.rot)
    }

    fn rot_mut(&mut self) -> Option<&mut Rotation> {
        (self.source == Some(HeadingSource::Gyro)).then_some(&mut self.rot)
    }

    /// The history interpolated at time `t` (seconds after `base_t`).
    fn entry_at(&self, t: f32) -> Option<Entry> {
        let (a, b) = self.hist.as_slices();
        let n = a.len() + b.len();
        let get = |i: usize| if i < a.len() { a.get(i) } else { b.get(i - a.len()) };
        // First entry with time >= t.
        let (mut lo, mut hi) = (0usize, n);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if get(mid)?.t < t {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        let after = get(lo)?;
        if lo == 0 {
            return (after.t - t <= 1e-3).then_some(*after);
        }
        let before = get(lo - 1)?;
        let span = after.t - before.t;
        // Inside a bridged gap there is no GNSS position to interpolate.
        if (span as f64) > MAX_STEP_S + 1e-3 && t - before.t > 1e-3 && after.t - t > 1e-3 {
            return None;
        }
        let w = if span > 0.0 { ((t - before.t) / span).clamp(0.0, 1.0) } else { 0.0 };
        let lerp = |x: (f32, f32), y: (f32, f32)| (x.0 + (y.0 - x.0) * w, x.1 + (y.1 - x.1) * w);
        Some(Entry { t, g: lerp(before.g, after.g), d: lerp(before.d, after.d), u: before.u + (after.u - before.u) * w })
    }

    /// The time of the last fix before the bridged GNSS gap that holds time `t`, if one does.
    fn gap_edge(&self, t: f32) -> Option<f32> {
        let mut prev: Option<f32> = None;
        for e in self.hist.iter() {
            if e.t >= t {
                let b = prev?;
                let inside = ((e.t - b) as f64) > MAX_STEP_S + 1e-3 && t - b > 1e-3 && e.t - t > 1e-3;
                return inside.then_some(b);
            }
            prev = Some(e.t);
        }
        None
    }

    /// The DR displacement over `win` seconds ending `tau` seconds ago.
    fn dr_over(&self, t: f32, tau: f32, win: f32) -> Option<(f32, f32)> {
        let end = if tau <= 0.0 { Some(self.dr) } else { self.entry_at(t - tau).map(|en| en.d) }?;
        let start = self.entry_at(t - tau - win)?.d;
        Some(sub(end, start))
    }

    /// One epoch. `None`: the check lacks its inputs (degraded).
    pub fn step(&mut self, s: &Sample) -> Option<TrackOutcome> {
        let wheel = s.wheel_speed().get().filter(|v| v.is_finite())?;
        if !s.t.is_finite() || !s.pos.is_valid() {
            self.restart();
            return None;
        }
        let yaw = s.yaw_rate().get().filter(|v| v.is_finite());
        let source = if yaw.is_some() { HeadingSource::Gyro } else { HeadingSource::Gnss };
        // A stretch has one heading source; a change starts the windows over.
        if self.source.is_some_and(|x| x != source) {
            self.restart();
        }
        // The local frame.
        let origin = *self.origin.get_or_insert(s.pos);
        let (e, n) = to_local(origin, s.pos, EARTH_RADIUS_PAPER_M);
        let g = (e as f32, n as f32);
        if !(g.0.is_finite() && g.1.is_finite()) || libm::fabsf(g.0) > 1e6 || libm::fabsf(g.1) > 1e6 {
            self.restart();
            return None;
        }
        let gap = self.last.map(|l| s.t - l.t);
        let continuous = gap.is_some_and(|g| g > 0.0 && g <= MAX_STEP_S);
        let bridged = gap.is_some_and(|g| g > MAX_STEP_S && g <= MAX_BRIDGE_S)
            && source == HeadingSource::Gyro
            && self.source == Some(HeadingSource::Gyro)
            && s.dist_m.get().is_some_and(f32::is_finite)
            && s.turn_deg.get().is_some_and(f32::is_finite);
        if !continuous && !bridged && self.last.is_some() {
            self.restart();
            return self.step(s);
        }
        self.source = Some(source);
        let t = self.advance(s, g, wheel, yaw);
        let mut out = TrackOutcome { delay_s: self.delay_s(), learning: true, ..Default::default() };
        if self.aligned {
            self.judge_and_learn(s, t, wheel, &mut out);
        }
        out.scale = self.scale();
        out.heading = source;
        out.rotation_deg = self.rot().map_or(0.0, |r| r.theta().to_degrees());
        out.turn_scale = self.rot().map_or(1.0, |r| 1.0 + r.scale_error());
        out.gyro_bias_degps = match (source, self.rot()) {
            (HeadingSource::Gyro, Some(r)) => self.bias - r.omega().to_degrees(),
            _ => 0.0,
        };
        out.delay_s = self.delay_s();
        for wi in 0..WINDOWS_S.len() {
            let (s2, k2) = self.noise_params(wi);
            if let (Some(a), Some(b)) = (out.noise_s0_m.get_mut(wi), out.noise_k.get_mut(wi)) {
                *a = libm::sqrtf(s2);
                *b = libm::sqrtf(k2);
            }
        }
        Some(out)
    }

    /// Dead reckoning and the history: the epoch's time since `base_t`.
    fn advance(&mut self, s: &Sample, g: (f32, f32), wheel: f32, yaw: Option<f32>) -> f32 {
        let c = self.cfg;
        let last = self.last;
        if self.hist.is_empty() {
            self.base_t = s.t;
        }
        let t = (s.t - self.base_t) as f32;
        let dt = last.map_or(0.0, |l| (s.t - l.t) as f32);
        // The gyro's bias: while the wheels stand the gyro reads it (its mean since the last
        // epoch when the wheels stood at both).
        let stood = last.is_some_and(|l| l.wheel < STANDING_MPS) && wheel < STANDING_MPS;
        if let (Some(w), true) = (yaw, stood) {
            let mean = s.turn_deg.get().filter(|x| x.is_finite() && dt > 0.0).map_or(w, |x| x / dt);
            let dt_b = dt.min(MAX_STEP_S as f32);
            self.bias_weight += dt_b;
            let k = if self.bias_weight < 10.0 {
                (dt_b / self.bias_weight.max(dt_b)).clamp(0.0, 1.0)
            } else {
                (dt_b / (c.learn_tau_s * 0.1)).clamp(0.0, 1.0)
            };
            // The standstill mean measures the gyro's whole bias: the part removed before the
            // rotation filter (`bias`) less the residual the filter tracks while driving
            // (`omega`). The innovation is against that whole, or a bias the filter already
            // learnt while driving would be counted twice.
            let whole = self.bias - self.rot().map_or(0.0, |r| r.omega().to_degrees());
            self.bias += (mean.clamp(-MAX_BIAS_DEGPS, MAX_BIAS_DEGPS) - whole) * k;
            self.bias = if self.bias.is_finite() { self.bias.clamp(-2.0 * MAX_BIAS_DEGPS, 2.0 * MAX_BIAS_DEGPS) } else { 0.0 };
        }
        // The DR heading: the gyro's integral (the synchroniser's integral since the previous
        // epoch when it has one: exact at any epoch rate; else a trapezoid of this epoch's and
        // the previous epoch's rates), or the GNSS track's own bearing.
        let gnss_heading = self.gnss_heading(g);
        let dpsi = match (yaw, last) {
            (Some(w), Some(l)) => {
                let raw = s.turn_deg.get().filter(|x| x.is_finite()).unwrap_or_else(|| 0.5 * (l.yaw.unwrap_or(w) + w) * dt);
                Some((raw - self.bias * dt).to_radians())
            }
            _ => None,
        };
        let turn = match (dpsi, self.rot_mut()) {
            (Some(dpsi), Some(rot)) if dpsi.is_finite() => {
                rot.predict(dt, dpsi, &c);
                rot.corrected_turn(dt, dpsi)
            }
            _ => 0.0,
        };
        if self.rot().is_none() {
            if let Some(h) = gnss_heading {
                self.psi = h;
            }
        }
        if !self.aligned && wheel >= c.min_speed_mps {
            if let Some(h) = gnss_heading {
                // The DR frame starts on the GNSS heading; its rotation is learnt afresh.
                self.psi = h - turn;
                if let Some(rot) = self.rot_mut() {
                    rot.realign(&c);
                }
                self.aligned = true;
            }
        }
        if let Some(l) = last {
            // An arc of constant curvature: its chord is `dist sinc(turn / 2)` along the mid
            // heading (exact for a steady turn, and across a bridged gap).
            // No car covers more than MAX_SPEED_MPS: a larger integral is a sensor fault.
            let dist = s.dist_m.get().filter(|x| x.is_finite()).unwrap_or(0.5 * (l.wheel + wheel) * dt).max(0.0).min(MAX_SPEED_MPS * dt.max(0.0) + 1.0);
            let half = 0.5 * turn;
            let chord = if libm::fabsf(half) > 1e-4 { dist * libm::sinf(half) / half } else { dist };
            let mid = self.psi + half;
            self.dr.0 += chord * libm::cosf(mid);
            self.dr.1 += chord * libm::sinf(mid);
            if (dt as f64) > MAX_STEP_S {
                // Across a bridged gap the turn need not have been steady: the chord's
                // direction is uncertain by up to half the turn (uniformly). And no GNSS
                // corrects the gyro meanwhile: a residual bias of `gap_gyro_sd_degps` turns
                // the heading by that rate times the gap, half of it on average over the chord.
                let sd = chord * libm::fabsf(half) / 1.732;
                let drift = chord * (0.5 * c.gap_gyro_sd_degps * dt).to_radians();
                self.dr_var += sd * sd + drift * drift;
            }
        }
        self.psi = wrap_pi(self.psi + turn);
        // The origin follows the car.
        let mut g = g;
        if norm2(g) > REBASE_M * REBASE_M {
            let shift = g;
            for en in self.hist.iter_mut() {
                en.g = sub(en.g, shift);
            }
            if let Some(a) = self.heading_anchor.as_mut() {
                *a = sub(*a, shift);
            }
            if let Some(o) = self.origin {
                self.origin = Some(crate::geo::from_local(o, shift.0 as f64, shift.1 as f64, EARTH_RADIUS_PAPER_M));
            }
            g = (0.0, 0.0);
        }
        self.last = Some(Last { t: s.t, wheel, yaw });
        // History: the newest entry is always this epoch; the ones before it are kept at least
        // MIN_SPACING_S apart (the newest replaces its predecessor while that is too close to
        // the entry before it).
        let entry = Entry { t, g, d: self.dr, u: self.dr_var };
        let committed_t = self.hist.iter().rev().nth(1).map(|e| e.t);
        match (self.hist.back_mut(), committed_t) {
            (Some(b), Some(c)) if ((b.t - c) as f64) < MIN_SPACING_S => *b = entry,
            _ => {
                if self.hist.is_full() {
                    self.hist.pop_front();
                }
                let _ = self.hist.push_back(entry);
            }
        }
        t
    }

    /// The windows ending at this epoch, at the best delay, before any decision.
    fn window(&self, t: f32, wi: usize, g_now: (f32, f32), gnss_acc_var: f32) -> Option<Window> {
        let win = *WINDOWS_S.get(wi)?;
        let oldest = self.hist.front().map_or(t, |e| e.t);
        if ((t - oldest) as f64) < (win as f64 + 2.0 + 0.2).min(SPAN_NEEDED_S) {
            return None;
        }
        // A window whose start falls inside a bridged GNSS gap starts at the gap's first edge
        // instead (it spans the whole gap), so a jump hidden in the gap is judged at the first
        // fix after it, not a window's length later.
        let ts = self.gap_edge(t - win).unwrap_or(t - win);
        let start = self.entry_at(ts)?;
        let g = sub(g_now, start.g);
        let tau = self.delay_s();
        let end_d = if tau <= 0.0 { self.dr } else { self.entry_at(t - tau)?.d };
        let d = sub(end_d, self.entry_at(ts - tau)?.d);
        let extra = (self.dr_var - start.u).max(0.0);
        let l = libm::sqrtf(norm2(d));
        let e2 = norm2(sub(g, cmul(self.gain(), d)));
        let (s2, k2) = self.noise_params(wi);
        let var0 = s2.max(gnss_acc_var) + k2 * l * l;
        let var = var0 + self.rot_var() * l * l + extra;
        if !(l.is_finite() && e2.is_finite() && var.is_finite()) {
            return None;
        }
        let z = if var > 0.0 { libm::sqrtf(e2 / var) } else { 0.0 };
        Some(Window { g, d, l, e2, var0, var, bridged: extra > 0.0, z })
    }

    fn judge_and_learn(&mut self, s: &Sample, t: f32, wheel: f32, out: &mut TrackOutcome) {
        let c = self.cfg;
        let dt = (s.dt_s as f64).min(3.0) as f32;
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let g_now = self.hist.back().map_or((0.0, 0.0), |e| e.g);
        let acc = s.gnss_h_acc.get().filter(|a| a.is_finite() && *a > 0.0).map_or(0.0, |a| 2.0 * a * a);
        let wins = [self.window(t, 0, g_now, acc), self.window(t, 1, g_now, acc)];
        let moving = wheel >= c.min_speed_mps;
        let judging = !self.warming() && self.aligned_frame();
        // The slowest drift visible within 10 s at 150 m driven.
        let (s2, k2) = self.noise_params(0);
        let l = 150.0;
        out.bound_10s_mps = Some(self.c * libm::sqrtf(s2.max(acc) + (k2 + self.rot_var()) * l * l) / WINDOWS_S[0]);
        if moving && !judging {
            self.unjudged_s += dt;
        } else if judging {
            self.unjudged_s = 0.0;
        }
        let gave_up = self.unjudged_s >= c.give_up_s;
        out.uninformative = (judging || gave_up) && out.bound_10s_mps.is_some_and(|b| b > c.max_bound_mps);
        let mut above = [false; 2];
        let mut z = [0.0f32; 2];
        let live = judging && !out.uninformative && moving;
        for (wi, w) in wins.iter().enumerate() {
            let Some(w) = w else { continue };
            let win = WINDOWS_S.get(wi).copied().unwrap_or(10.0);
            if !(moving && w.l >= c.judge_dist_m(win)) {
                continue;
            }
            above[wi] = w.z > self.c;
            z[wi] = w.z;
            if live {
                if let Some(o) = out.windows.get_mut(wi) {
                    *o = Some(WindowOutcome { e_m: libm::sqrtf(w.e2), threshold_m: self.c * libm::sqrtf(w.var), dist_m: w.l, z: w.z });
                }
            }
        }
        // How long each condition has held (reset while the car stands or nothing is judged).
        let held = |since: &mut Option<f64>, cond: bool| -> f64 {
            if cond && live {
                s.t - *since.get_or_insert(s.t)
            } else {
                *since = None;
                -1.0
            }
        };
        let fast = above[0] && above[1] && z[0] > 2.0 * self.c;
        let fast_held = held(&mut self.fast_since, fast);
        // Far beyond anything the sensors do (a jump, a jump hidden in a GNSS gap): at once.
        let gross = live && above[1] && z[0] > 4.0 * self.c;
        for (wi, &is_above) in above.iter().enumerate() {
            let Some(since) = self.above_since.get_mut(wi) else { continue };
            let h = held(since, is_above);
            let mut fire = h >= c.persist_s as f64;
            if wi == 0 {
                fire |= fast_held >= c.fast_persist_s as f64 || gross;
            }
            if let (Some(f), Some(a)) = (out.fired.get_mut(wi), self.alarm.get_mut(wi)) {
                *f = fire;
                *a |= fire;
            }
        }
        let any_above = above.iter().any(|a| *a);
        let calm = !any_above;
        out.learning = !judging && !out.uninformative;
        // Learning: only while driving, and (after the warm-up) while nothing is above its
        // threshold nor the alarm standing.
        let may_learn = moving && (self.warming() || (calm && !self.alarm.iter().any(|a| *a)));
        if may_learn {
            self.learn(t, dt, &wins);
        }
        if !any_above {
            self.alarm = [false; 2];
        }
    }

    fn learn(&mut self, t: f32, dt: f32, wins: &[Option<Window>; 2]) {
        let c = self.cfg;
        let keep = libm::expf(-dt / self.learn_tau());
        let aligned = self.aligned_frame();
        // The noise of each window (the rotation's uncertainty taken out), only in an aligned
        // frame.
        for (wi, w) in wins.iter().enumerate() {
            let (Some(w), Some(nf)) = (w, self.noise.get_mut(wi)) else { continue };
            let win = WINDOWS_S.get(wi).copied().unwrap_or(10.0);
            if aligned && !w.bridged && w.l >= c.judge_dist_m(win) {
                let excess = (w.var - w.var0).max(0.0);
                let y = (w.e2 - excess).max(0.0).min(9.0 * w.var0);
                // Weights relative to a 1 m^2 window.
                let weight = dt / (w.var0 * w.var0).max(1e-6);
                nf.add(w.l * w.l, y, dt, weight, keep);
            }
        }
        // Rotation, scale and delay from the 10 s window.
        let Some(w) = wins.first().copied().flatten() else { return };
        if w.l < MIN_LEARN_DIST_M || w.bridged {
            return;
        }
        if let Some(rot) = self.rot_mut() {
            // The window's angle; its variance is the across-track noise over L^2, spread over
            // the window's length (consecutive windows overlap).
            let gd = cmul(w.g, conj(w.d));
            let phi = libm::atan2f(gd.1, gd.0);
            let r = 0.5 * w.var0 / (w.l * w.l) * (WINDOWS_S[0] / dt.max(0.01));
            rot.update(phi, r, &c);
        }
        let derot = self.rot().map_or((1.0, 0.0), |r| cis(-r.theta()));
        let win = WINDOWS_S[0];
        // Every candidate learns from the same windows, or none does (one missing inside a
        // bridged gap would otherwise fall behind the others).
        let mut ds = [(0.0f32, 0.0f32); DELAYS];
        for (k, d) in ds.iter_mut().enumerate() {
            match self.dr_over(t, k as f32 * DELAY_STEP_S, win) {
                Some(x) => *d = x,
                None => return,
            }
        }
        for (f, d) in self.delays.iter_mut().zip(ds.iter()) {
            let gc = cmul(cmul(w.g, conj(*d)), derot);
            f.a = (f.a.0 * keep + dt * gc.0, f.a.1 * keep + dt * gc.1);
            f.b = f.b * keep + dt * norm2(*d);
        }
        self.best = self
            .delays
            .iter()
            .enumerate()
            .fold((0usize, 0.0f32), |acc, (k, f)| if f.explained() > acc.1 { (k, f.explained()) } else { acc })
            .0;
        if aligned {
            self.learnt_s += dt;
        }
    }

    /// The DR frame's rotation is known well enough to judge.
    fn aligned_frame(&self) -> bool {
        let a = self.cfg.aligned_sd_deg.to_radians();
        self.rot_var() <= a * a
    }

    /// The GNSS track's heading (math angle, radians, counter-clockwise from east) over the
    /// last 5 m or more.
    fn gnss_heading(&mut self, g: (f32, f32)) -> Option<f32> {
        let a = *self.heading_anchor.get_or_insert(g);
        let d = sub(g, a);
        if norm2(d) >= 25.0 {
            self.heading_anchor = Some(g);
            return Some(libm::atan2f(d.1, d.0));
        }
        None
    }
}
