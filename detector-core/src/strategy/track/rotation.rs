//! The DR frame's rotation against GNSS: a three-state Kalman filter in error-state form.
//!
//! The state is the rotation `theta` (rad) left between the dead reckoning's frame and GNSS's,
//! the correction `omega` (rad/s) to the gyro's standstill bias and the correction `eps` to its
//! scale. The dead reckoning turns by `(1 + eps) dpsi + omega dt` for a gyro turn `dpsi` (bias
//! removed), with the current estimates, so `theta` stays put on average; an error `d omega`,
//! `d eps` in them turns it by `d omega dt + d eps dpsi`, which is how the covariance grows.
//! `theta` belongs to one stretch of driving (it is the integration constant of the heading);
//! `omega` and `eps` belong to the car and are part of its calibration: a drive that starts
//! from a stored record keeps `eps` within [`GYRO_SCALE_BOUND`] of the record's and
//! [`GYRO_SCALE_WALK`] of the car's anchor, while a second filter, from the power-up
//! uncertainty, says what this drive alone finds (the record's contradiction test).

use super::config::TrackConfig;
use core::f32::consts::PI;

/// The largest gyro scale error believed.
pub(super) const MAX_SCALE_ERROR: f32 = 0.2;
/// The largest gyro bias believed, deg/s.
pub(super) const MAX_BIAS_DEGPS: f32 = 2.0;
/// How far the gyro's bias while driving is believed to lie from the bias a standstill of at
/// least [`STANDSTILL_MEASURED_S`] measured, deg/s (css_canedge's: 0.05 deg/s between its
/// first standstill and its first minute of driving). Before a standstill the power-up
/// uncertainty ([`TrackConfig::bias_sd_degps`], 0.5 deg/s) holds.
pub(super) const STANDSTILL_BIAS_SD_DEGPS: f32 = 0.1;
/// Once a standstill of this drive has measured the bias, the filter's correction to it moves at
/// most this many [`STANDSTILL_BIAS_SD_DEGPS`] from its value at that standstill, however the
/// GNSS courses pull: a gyro's bias does not wander by half a degree a second within a minute,
/// and a GNSS course rotating steadily while the gyro reads straight is what a first drive's
/// warm-up otherwise took in as bias (css_canedge under a course turned at 3.3 deg/s from
/// 85 s into its first drive: the bias went from 0.30 to 0.85 deg/s in 20 s, and the DR turned
/// with it). Not from a stored record's bias: a MEMS gyro's bias moves from one power-up to the
/// next by more than this (the comma2k19 drive from the QEMU run's stored record, whose bias
/// is plausible, not the RAV4's, needed its correction beyond the band and alarmed), and a
/// drive's own standstill takes that record's bias in only slowly.
pub(super) const STANDSTILL_BIAS_BAND_SD: f32 = 3.0;
/// Seconds of standstill after which the bias counts as measured.
pub(super) const STANDSTILL_MEASURED_S: f32 = 5.0;
/// Innovations beyond this many standard deviations count as if they lay on it (see
/// [`Rotation::update`]).
pub(super) const GATE_SD: f32 = 3.0;
/// How far a drive that starts from a stored record may move the gyro's scale error from the
/// record's: twice the wheels' bound, for a sensitivity that changes with temperature. Not
/// measured here: our gyro drives are one car's on one day (css_canedge: -0.0017, -0.0018).
pub(super) const GYRO_SCALE_BOUND: f32 = 0.02;
/// How far the gyro's scale error may ever move from the car's anchor (its first record's):
/// drive after drive, a spoofer who makes every turn a little larger would otherwise walk it a
/// bound per drive (2 % per drive took css_canedge's from -0.002 to 0.153 in eight drives with
/// no alarm: every GNSS turn 15 % larger than the gyro's, then, taken as the car's).
pub(super) const GYRO_SCALE_WALK: f32 = 0.03;

/// The angle in [-pi, pi]. One remainder, not a loop: a loop that subtracts 2 pi never ends
/// on a huge angle (hostile input), where `x - 2 pi == x`.
pub(super) fn wrap_pi(x: f32) -> f32 {
    if !x.is_finite() {
        return 0.0;
    }
    let r = libm::remainderf(x, 2.0 * PI);
    if r.is_finite() { r.clamp(-PI, PI) } else { 0.0 }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Rotation {
    x: [f32; 3],
    p: [[f32; 3]; 3],
    /// The scale errors the estimate may take (see [`Rotation::bound_scale`]).
    eps_band: (f32, f32),
    /// The bias corrections the estimate may take, rad/s (see [`Rotation::bound_omega_var`]).
    omega_band: (f32, f32),
}

impl Rotation {
    pub(super) fn new(cfg: &TrackConfig) -> Self {
        let a = cfg.align_sd_deg.to_radians();
        let b = cfg.bias_sd_degps.to_radians();
        let e = cfg.gyro_scale_sd;
        let m = MAX_BIAS_DEGPS.to_radians();
        Rotation { x: [0.0; 3], p: [[a * a, 0.0, 0.0], [0.0, b * b, 0.0], [0.0, 0.0, e * e]], eps_band: (-MAX_SCALE_ERROR, MAX_SCALE_ERROR), omega_band: (-m, m) }
    }
    /// The scale error stays within `lo..=hi` from now on (a stored record's bounds, see
    /// [`GYRO_SCALE_BOUND`]): clamped there, its uncertainty kept.
    pub(super) fn bound_scale(&mut self, lo: f32, hi: f32) {
        if lo.is_finite() && hi.is_finite() && lo <= hi {
            self.eps_band = (lo.max(-MAX_SCALE_ERROR), hi.min(MAX_SCALE_ERROR));
            self.x[2] = self.x[2].max(self.eps_band.0).min(self.eps_band.1);
        }
    }
    /// A filter that starts from a car's stored gyro scale error and its uncertainty
    /// (the bias is the standstill bias's business, stored beside it).
    pub(super) fn with_scale(cfg: &TrackConfig, eps: f32, eps_sd: f32) -> Self {
        let mut r = Rotation::new(cfg);
        if eps.is_finite() && eps_sd.is_finite() {
            r.x[2] = eps.clamp(-MAX_SCALE_ERROR, MAX_SCALE_ERROR);
            // max/min, not clamp: clamp panics on bounds it cannot prove ordered.
            let sd = eps_sd.max(1e-4).min(cfg.gyro_scale_sd.max(1e-4));
            r.p[2][2] = sd * sd;
        }
        r
    }
    pub(super) fn theta(&self) -> f32 {
        self.x[0]
    }
    pub(super) fn omega(&self) -> f32 {
        self.x[1]
    }
    pub(super) fn scale_error(&self) -> f32 {
        self.x[2]
    }
    pub(super) fn var_theta(&self) -> f32 {
        self.p[0][0].max(0.0)
    }
    pub(super) fn var_scale(&self) -> f32 {
        self.p[2][2].max(0.0)
    }
    /// A standstill has measured the gyro's bias: the residual bias's variance is at most `var`
    /// (rad/s)^2, its correlations with the rotation and the scale kept (so `P` stays positive
    /// semi-definite); where this drive's own standstill measured it (`own`), the correction
    /// also stays within [`STANDSTILL_BIAS_BAND_SD`] of `sqrt(var)` of where it is now.
    pub(super) fn bound_omega_var(&mut self, var: f32, own: bool) {
        let (m, w) = (MAX_BIAS_DEGPS.to_radians(), STANDSTILL_BIAS_BAND_SD * gnss_guard_dsp::sqrtf(var.max(0.0)));
        if own && w.is_finite() && w > 0.0 {
            self.omega_band = ((self.x[1] - w).max(-m), (self.x[1] + w).min(m));
        }
        let p = self.p[1][1];
        if !(var > 0.0 && var.is_finite() && p > var) {
            return;
        }
        let f = gnss_guard_dsp::sqrtf(var / p);
        for j in [0, 2] {
            self.p[1][j] *= f;
            self.p[j][1] *= f;
        }
        self.p[1][1] = var;
    }
    /// A new alignment: the rotation unknown to `align_sd_deg`, drift and scale error kept.
    pub(super) fn realign(&mut self, cfg: &TrackConfig) {
        let a = cfg.align_sd_deg.to_radians();
        self.x[0] = 0.0;
        for k in 0..3 {
            self.p[0][k] = 0.0;
            self.p[k][0] = 0.0;
        }
        self.p[0][0] = a * a;
    }
    /// The DR's turn over `dt` seconds for a gyro turn `dpsi` (bias removed), radians.
    pub(super) fn corrected_turn(&self, dt: f32, dpsi: f32) -> f32 {
        (1.0 + self.x[2]) * dpsi + self.x[1] * dt
    }
    /// Time update over `dt` seconds in which the gyro turned by `dpsi` radians. Not inlined:
    /// one copy for both filters (the drive's and its own).
    #[inline(never)]
    pub(super) fn predict(&mut self, dt: f32, dpsi: f32, cfg: &TrackConfig) {
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
    /// The innovation of a rotation measurement `phi` and its variance with measurement
    /// variance `r`.
    pub(super) fn innovation(&self, phi: f32, r: f32) -> (f32, f32) {
        (wrap_pi(phi - self.x[0]), self.p[0][0] + r)
    }
    /// One measurement of the rotation with variance `r`.
    ///
    /// In an aligned frame, an innovation beyond [`GATE_SD`] standard deviations is taken with
    /// the variance that puts it there (a Huber step: its direction kept, its size bounded).
    /// A receiver's course excursion of a few fixes is such an outlier where the noise before
    /// it was not seen: right after a GNSS outage the across-track noise is the one from before
    /// the outage. On css_canedge one course 5.6 deg off (6.4 sd) after a 10.6 s outage turned
    /// the frame by 2.6 deg; the check's suspicion then froze it there and the across-track
    /// error stayed for the rest of the drive. A frame that is really off gives such
    /// innovations fix after fix and follows them, more slowly (3 deg within 30 s in the unit
    /// test `a_course_excursion_right_after_an_outage_does_not_turn_the_frame`).
    #[inline(never)]
    pub(super) fn update(&mut self, phi: f32, r: f32, cfg: &TrackConfig) {
        let (innov, s) = self.innovation(phi, r);
        if !(s > 0.0 && s.is_finite() && phi.is_finite()) {
            return;
        }
        // Only once the frame is aligned: before that its prior is no bound (the frame starts
        // on whatever heading the first metres gave, 114 deg off on one css_canedge start).
        let aligned = cfg.aligned_sd_deg.to_radians();
        let s = if self.p[0][0] <= aligned * aligned { s.max(innov * innov * (1.0 / (GATE_SD * GATE_SD))) } else { s };
        let k = [self.p[0][0] / s, self.p[1][0] / s, self.p[2][0] / s];
        for (x, g) in self.x.iter_mut().zip(k.iter()) {
            *x += g * innov;
        }
        self.x[0] = wrap_pi(self.x[0]);
        self.x[1] = self.x[1].max(self.omega_band.0).min(self.omega_band.1);
        // max/min, not clamp: clamp panics on bounds it cannot prove ordered.
        self.x[2] = self.x[2].max(self.eps_band.0).min(self.eps_band.1);
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
            let (band, omega_band) = (self.eps_band, self.omega_band);
            *self = Rotation::new(cfg);
            self.bound_scale(band.0, band.1);
            self.omega_band = omega_band;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::LOGGER_1HZ;

    /// A bounded scale error stays in its band however the measurements pull, also after a
    /// filter gone non-finite starts afresh; an unbounded one follows them.
    #[test]
    fn a_bounded_scale_error_stays_in_its_band() {
        let cfg = TrackConfig::for_profile(&LOGGER_1HZ);
        let (mut bounded, mut free) = (Rotation::with_scale(&cfg, 0.0, 0.01), Rotation::with_scale(&cfg, 0.0, 0.01));
        bounded.bound_scale(-0.02, 0.02);
        // Twenty turns of 90 deg, 2 deg a second, left and right, a minute straight after each,
        // whose GNSS course changes 10 % more than the gyro's: each filter's DR turns by its
        // corrected turn, and it measures the rotation left against GNSS once a second.
        for r in [&mut bounded, &mut free] {
            let (mut gnss, mut dr) = (0.0f32, 0.0f32);
            for k in 0..20 * 105 {
                let dpsi = if k % 105 < 45 { 2.0f32.to_radians() * if (k / 105) % 2 == 0 { 1.0 } else { -1.0 } } else { 0.0 };
                gnss += 1.1 * dpsi;
                dr += r.corrected_turn(1.0, dpsi);
                r.predict(1.0, dpsi, &cfg);
                r.update(wrap_pi(gnss - dr), 1e-4, &cfg);
            }
        }
        assert!(free.scale_error() > 0.05, "free {}", free.scale_error());
        assert!(bounded.scale_error() <= 0.02 && bounded.scale_error() > 0.015, "bounded {}", bounded.scale_error());
        bounded.update(f32::INFINITY, f32::NAN, &cfg);
        bounded.update(0.0, -1.0, &cfg);
        bounded.p[2][2] = f32::NAN;
        bounded.update(1.0, 1e-4, &cfg);
        assert!(bounded.x.iter().all(|v| v.is_finite()) && bounded.eps_band == (-0.02, 0.02));
    }

    /// A GNSS course rotating steadily while the gyro reads straight moves the bias correction
    /// no further than the standstill's band once a standstill has measured the bias, however
    /// long it goes on; before a standstill the filter follows it beyond that band (the same
    /// courses, the same filter otherwise).
    #[test]
    fn a_rotating_course_cannot_teach_the_bias_beyond_the_standstills_band() {
        let cfg = TrackConfig::for_profile(&LOGGER_1HZ);
        let sd = STANDSTILL_BIAS_SD_DEGPS.to_radians();
        let (mut measured, mut unmeasured) = (Rotation::new(&cfg), Rotation::new(&cfg));
        measured.bound_omega_var(sd * sd, true);
        for r in [&mut measured, &mut unmeasured] {
            let mut dr = 0.0f32;
            for k in 1..=60 {
                let gnss = (3.3f32 * k as f32).to_radians();
                dr += r.corrected_turn(1.0, 0.0);
                r.predict(1.0, 0.0, &cfg);
                r.update(wrap_pi(gnss - dr), 1e-4, &cfg);
            }
        }
        let band = STANDSTILL_BIAS_BAND_SD * sd;
        assert!(libm::fabsf(measured.omega()) <= band * 1.0001, "measured {}", measured.omega().to_degrees());
        assert!(libm::fabsf(unmeasured.omega()) > 2.0 * band, "unmeasured {}", unmeasured.omega().to_degrees());
        // Non-finite numbers start the filter afresh inside the band.
        measured.p[1][1] = f32::NAN;
        measured.update(0.5, 1e-4, &cfg);
        measured.update(0.5, 1e-4, &cfg);
        assert!(libm::fabsf(measured.omega()) <= band * 1.0001);
    }

    /// Bounding the residual bias's variance keeps the covariance a covariance: symmetric, its
    /// minors non-negative, the rotation's own variance unchanged.
    #[test]
    fn bounding_the_bias_variance_keeps_a_covariance() {
        let cfg = TrackConfig::for_profile(&LOGGER_1HZ);
        let mut r = Rotation::new(&cfg);
        // Turns and time correlate the rotation with the bias and the scale.
        for k in 0..40 {
            r.predict(1.0, if k % 10 < 3 { 0.15 } else { 0.0 }, &cfg);
        }
        r.update(0.01, 1e-4, &cfg);
        let theta = r.p[0][0];
        let var = 0.1f32.to_radians().powi(2);
        assert!(r.p[1][1] > var);
        r.bound_omega_var(var, true);
        assert_eq!(r.p[1][1], var);
        assert_eq!(r.p[0][0], theta);
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(r.p[i][j], r.p[j][i]);
                assert!(r.p[i][i] * r.p[j][j] - r.p[i][j] * r.p[j][i] >= -1e-12, "minor {i}{j}");
            }
        }
        let p = r.p;
        let det = p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
        assert!(det >= -1e-18, "det {det}");
        // A larger bound changes nothing.
        let before = r.p;
        r.bound_omega_var(1.0, true);
        assert_eq!(r.p, before);
    }
}
