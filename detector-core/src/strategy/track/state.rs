//! The track check's state: what it keeps of the stretch since its last (re)start and what it
//! has learnt about the car, how it starts, restarts and is reset, the stored record it keeps,
//! and the accessors every stage reads (the frame's rotation, the gain, the DR at a time).

use super::calibration::{Calibration, Contradiction, Record, Source};
use super::config::{TrackConfig, WINDOWS_S};
use super::history::{Entry, History};
use super::noise::{NoiseFits, NOISE_SPLIT_MPS};
use super::outcome::HeadingSource;
use super::plane::{cis, scale2};
use super::rotation::{self, Rotation, GYRO_SCALE_BOUND, GYRO_SCALE_WALK, MAX_BIAS_DEGPS};
use super::travel::Travel;
use super::velocity::VelocityTest;
use crate::geo::LatLon;

/// What the check kept of the previous epoch.
#[derive(Clone, Copy, Debug)]
pub(super) struct Last {
    pub(super) t: f64,
    pub(super) wheel: f32,
    pub(super) yaw: Option<f32>,
}

/// The noise a record keeps (the position windows' `s0` and `k`, the velocity channels' quiet
/// noise) rises by at most this factor from drive to drive. It is the prior the next drive's
/// first minutes are judged with, and a spoofer who only adds noise raises no alarm (the noise
/// follows the environment): a record whose noise was inflated (s0 8 m, k 0.05, 1 m/s, against
/// css_canedge's 1 m, 0.01, 0.14 m/s) held a drift of 1 m/s along found 12 s after an onset a
/// minute into the next drive until 35 s, one across 300 s in from 23 s to 189 s. Falls are
/// kept whole; what a drive's own data says rises within it.
pub(super) const NOISE_RISE_PER_DRIVE: f32 = 1.25;

/// A record's noise is at most this factor over the car's anchor (its first record's, of the
/// same receiver class), however many drives raised it by `NOISE_RISE_PER_DRIVE` each. The
/// honest records of sddi_commuter's and css_canedge's drives in turn (ten and six drives) stay
/// within 1.35 of their first and within 1.74 of their quietest (sddi_commuter's `s0` 2.65 to
/// 4.61 m, css_canedge's velocity noise 0.13 to 0.17 m/s); the live noise follows the
/// environment within the drive whatever the prior. On css_canedge session 1 a record at this
/// bound (twice session 0's noise) finds a drift of 1 m/s along a minute in and one across 300 s
/// in when the honest record does (12 and 23 s); one of the inflated record above (about what nine
/// drives at `NOISE_RISE_PER_DRIVE` reach) 35 and 189 s.
pub(super) const NOISE_ANCHOR_BAND: f32 = 2.0;

/// A record's noise as `[s0 x 2, k x 2, velocity sigma x 2]` and its anchors, in that order.
fn noise_of(r: &Record) -> ([f32; 6], [f32; 6]) {
    let n = [r.noise_s0_m[0], r.noise_s0_m[1], r.noise_k[0], r.noise_k[1], r.velocity_sigma_mps[0], r.velocity_sigma_mps[1]];
    let a = [r.anchor_noise_s0_m[0], r.anchor_noise_s0_m[1], r.anchor_noise_k[0], r.anchor_noise_k[1], r.anchor_velocity_sigma_mps[0], r.anchor_velocity_sigma_mps[1]];
    (n, a)
}

/// Each of `noise` held within `factor` of its bound in `by` (a bound of zero: unbounded). One
/// function for the three bounds (flash).
#[inline(never)]
fn cap(noise: &mut [f32; 6], by: &[f32; 6], factor: f32) {
    for (n, b) in noise.iter_mut().zip(by) {
        if *b > 0.0 {
            *n = n.min(b * factor);
        }
    }
}

/// The streaming track check. See the module documentation.
#[derive(Clone, Debug)]
pub struct TrackCheck {
    pub(super) cfg: TrackConfig,
    pub(super) c: f32,
    // The stretch since the last (re)start.
    pub(super) hist: History,
    pub(super) origin: Option<LatLon>,
    pub(super) base_t: f64,
    pub(super) dr: (f32, f32),
    /// Variance the DR took on across bridged gaps since the (re)start, m^2.
    pub(super) dr_var: f32,
    pub(super) psi: f32,
    /// The direction of travel since the last standstill (a car reverses; see `travel`).
    pub(super) travel: Travel,
    pub(super) aligned: bool,
    pub(super) source: Option<HeadingSource>,
    pub(super) last: Option<Last>,
    /// The epoch (its time) after a gap whose chord the wheels' distance contradicts.
    pub(super) gap_jumped: Option<f64>,
    pub(super) heading_anchor: Option<(f32, f32)>,
    pub(super) above_since: [Option<f64>; 2],
    pub(super) fast_since: Option<f64>,
    pub(super) alarm: [bool; 2],
    /// The last velocity pair judged and the last one learnt from (stretch time).
    pub(super) last_pair_t: f32,
    pub(super) last_learn_t: f32,
    pub(super) vel: VelocityTest,
    /// The previous pair's predicted velocity (its time, value): the DR's acceleration.
    pub(super) last_pred: Option<(f32, (f32, f32))>,
    /// The DR's acceleration at the previous pair: its change is a carried pair's error.
    pub(super) last_acc: (f32, f32),
    /// The last judged pair's across-track prediction variance from the delay's uncertainty
    /// (and a carried pair's shift), (m/s)^2: its course is that much less certain as a
    /// rotation measurement.
    pub(super) last_delay_var_across: f32,
    /// When the velocity test last judged a pair (stretch time).
    pub(super) last_judged_t: f32,
    /// When the last pair beyond the gross path's bounds was judged (stretch time): the
    /// calibration learns no entry up to [`POSITION_SPAN_S`](super::velocity::POSITION_SPAN_S)
    /// before it (its entries are seconds older than the pairs judged).
    pub(super) last_gross_t: f32,
    /// Whether the velocity test's last pair this stretch was blind (`None`: no pair yet).
    pub(super) vel_blind: Option<bool>,
    /// The receiver's reported velocity integrated, metres, since `vi_since` (stretch time;
    /// infinite while it reports none).
    pub(super) vi: (f32, f32),
    pub(super) vi_since: f32,
    /// The receiver's own position noise over each window (10 s, 30 s), m^2: its position
    /// against the integral of its own velocity (multipath and trees move the position by
    /// metres, not the Doppler velocity; a position error correlated over tens of seconds is
    /// what fired the windows in town). It rises within seconds where the GNSS gets worse,
    /// falls within half a minute, and is at most `GNSS_NOISE_CAP_M` squared. It is the GNSS's
    /// alone, so a spoofer who moves position and velocity together (every drift) does not
    /// move it; one who moves the position alone buys at most that much slack in the 30 s
    /// window, and in the 10 s window only what a wander that keeps that window within its
    /// threshold teaches (its own noise rises only then: a position-only step puts it beyond
    /// at once), none in the velocity test.
    /// The 10 s window takes only what exceeds its whole learnt noise (`s0^2 + k^2 L^2`): on a
    /// quiet receiver this noise is about that size, and on top of it cost wrong turns a
    /// second on css_canedge. Before the 10 s window took it, css_canedge entering town under
    /// GNSS noise of 4.7 and 6.8 m fired it (its town noise had had three seconds to learn
    /// before the window was suspicious and froze it); the same taken
    /// from the 30 s window's noise cost a drift across at 4 m/s within 10 s (13 -> 12 of 13).
    pub(super) gnss_noise: [f32; 2],
    // Learnt about the car (kept across short gaps).
    pub(super) bias: f32,
    pub(super) bias_weight: f32,
    pub(super) rot: Rotation,
    /// This drive's own estimate of the frame's rotation (its gyro scale error from the
    /// power-up uncertainty, unbounded), measured whenever `rot` is (while the check learns),
    /// and only on a drive from a stored record: compared with the record's, which bounds
    /// `rot`'s (see [`TrackCheck::check_gyro_scale`]).
    pub(super) rot_own: Rotation,
    /// How far the DR heading with `rot_own`'s corrections would have turned from the DR's
    /// (with `rot`'s) since the frame's alignment, radians: `rot_own` measures its own frame.
    pub(super) own_offset: f32,
    pub(super) cal: Calibration,
    pub(super) noise: [NoiseFits; 2],
    /// The 10 s window's along-track error alone (what the velocity test's position
    /// differences sum to over its 10 s window): without a gyro the DR's direction is the GNSS
    /// bearing of the last metres and the across-track error is most of `|e|^2`. (The 30 and
    /// 60 s windows keep the 30 s window's whole error: with its along-track part alone, GNSS
    /// noise of 7.9 m correlated over 26 s fired the 60 s window in the nuisance suite.)
    pub(super) noise_along: NoiseFits,
    pub(super) learnt_s: f32,
    /// The quiet velocity noise (along, across), averaged while calm: the record's.
    pub(super) quiet_sigma: [f32; 2],
    /// Seconds driven without judging since the (re)start.
    pub(super) unjudged_s: f32,
    /// The record the drive started from (a power-up restarts from it).
    pub(super) stored: Option<Record>,
}

impl TrackCheck {
    /// A check on a car it knows nothing about: it learns it (see the module documentation).
    pub fn new(cfg: TrackConfig) -> Self {
        let vel = VelocityTest::new(cfg.velocity);
        TrackCheck {
            cfg,
            c: cfg.threshold(),
            hist: History::default(),
            origin: None,
            base_t: 0.0,
            dr: (0.0, 0.0),
            dr_var: 0.0,
            psi: 0.0,
            travel: Travel::default(),
            aligned: false,
            source: None,
            last: None,
            gap_jumped: None,
            heading_anchor: None,
            above_since: [None; 2],
            fast_since: None,
            alarm: [false; 2],
            last_pair_t: f32::NEG_INFINITY,
            last_learn_t: f32::NEG_INFINITY,
            quiet_sigma: vel.sigma(),
            vel,
            last_pred: None,
            last_acc: (0.0, 0.0),
            last_delay_var_across: 0.0,
            last_judged_t: f32::NEG_INFINITY,
            last_gross_t: f32::NEG_INFINITY,
            vel_blind: None,
            vi: (0.0, 0.0),
            vi_since: f32::INFINITY,
            gnss_noise: [0.0; 2],
            bias: 0.0,
            bias_weight: 0.0,
            rot: Rotation::new(&cfg),
            rot_own: Rotation::new(&cfg),
            own_offset: 0.0,
            cal: Calibration::new(cfg.cal),
            noise: [NoiseFits::default(); 2],
            noise_along: NoiseFits::default(),
            learnt_s: 0.0,
            unjudged_s: 0.0,
            stored: None,
        }
    }

    /// A check that starts from a car's stored calibration (see
    /// [`calibration`](super::calibration)); a record that is not plausible is ignored (the
    /// caller reports it).
    pub fn with_record(cfg: TrackConfig, r: &Record) -> Self {
        let mut c = TrackCheck::new(cfg);
        if r.plausible().is_err() {
            return c;
        }
        c.stored = Some(*r);
        c.load_stored();
        c
    }

    /// Out of line: a power-up's work, inlined into `reset` it took 350 bytes more flash.
    #[inline(never)]
    pub(super) fn load_stored(&mut self) {
        let Some(r) = self.stored else { return };
        self.cal = Calibration::from_record(self.cfg.cal, &r);
        if r.gyro_bias_degps.is_finite() {
            self.bias = r.gyro_bias_degps.clamp(-2.0 * MAX_BIAS_DEGPS, 2.0 * MAX_BIAS_DEGPS);
            self.bias_weight = r.gyro_bias_weight_s.min(10.0);
        }
        self.rot = Rotation::with_scale(&self.cfg, r.gyro_scale_error, r.gyro_scale_sd);
        self.rot_own = Rotation::with_scale(&self.cfg, r.gyro_scale_error, self.cfg.gyro_scale_sd);
        // Within the bound of the record's scale error and the walk from the car's anchor
        // (the anchor's alone where they do not meet: a record this code did not write).
        let (e, a) = (r.gyro_scale_error, r.anchor_gyro_scale_error);
        let (lo, hi) = ((e - GYRO_SCALE_BOUND).max(a - GYRO_SCALE_WALK), (e + GYRO_SCALE_BOUND).min(a + GYRO_SCALE_WALK));
        if lo <= hi {
            self.rot.bound_scale(lo, hi);
        } else {
            self.rot.bound_scale(a - GYRO_SCALE_WALK, a + GYRO_SCALE_WALK);
            self.cal.contradict(Contradiction::GyroScale);
        }
        self.bound_bias_by_standstill();
        // The same receiver class: its noise carries over as the prior.
        if self.same_class(&r) {
            self.vel.set_sigma(r.velocity_sigma_mps);
            self.quiet_sigma = self.vel.sigma();
            let floors = (self.cfg.s0_floor_m, self.cfg.k_floor);
            for (wi, nf) in self.noise.iter_mut().chain(core::iter::once(&mut self.noise_along)).enumerate() {
                // The along-track fit (the third) starts from the 10 s window's whole error.
                let wi = wi % 2;
                let (s0, k) = (r.noise_s0_m.get(wi).copied().unwrap_or(1.0), r.noise_k.get(wi).copied().unwrap_or(0.01));
                // Worth the prior's weight of a window's data at zero distance and 150 m.
                let secs = self.cfg.prior_weight_s;
                let v0 = s0 * s0;
                let v1 = v0 + k * k * 150.0 * 150.0;
                let split = NOISE_SPLIT_MPS * WINDOWS_S.get(wi).copied().unwrap_or(10.0);
                nf.add(split, 0.0, v0, 0.5 * secs, 0.5 * secs / (v0 * v0).max(1e-6), 1.0, floors);
                nf.add(split, 150.0 * 150.0, v1, 0.5 * secs, 0.5 * secs / (v1 * v1).max(1e-6), 1.0, floors);
            }
            self.learnt_s = self.cfg.warmup_s;
        }
    }

    /// This drive's own gyro scale error (its own filter, from the power-up uncertainty)
    /// beyond the bound from the stored record's, or the walk from the car's anchor, by more
    /// than three of its standard deviations: the record is contradicted, not relearnt.
    pub(super) fn check_gyro_scale(&mut self) {
        let Some(r) = self.stored else { return };
        let (e, sd) = (self.rot_own.scale_error(), gnss_guard_dsp::sqrtf(self.rot_own.var_scale()));
        let beyond = |centre: f32, bound: f32| libm::fabsf(e - centre) > bound + 3.0 * sd;
        if beyond(r.gyro_scale_error, GYRO_SCALE_BOUND) || beyond(r.anchor_gyro_scale_error, GYRO_SCALE_WALK) {
            self.cal.contradict(Contradiction::GyroScale);
        }
    }

    /// A record of the receiver class this configuration is for (its noise is this one's).
    pub(super) fn same_class(&self, r: &Record) -> bool {
        libm::fabsf(r.nominal_dt_s - self.cfg_dt()) < 0.5 * r.nominal_dt_s
    }

    /// The receiver class the configuration is for (its prior's epoch).
    pub(super) fn cfg_dt(&self) -> f32 {
        if self.cfg.s0_prior_m < 4.0 { 0.1 } else { 1.0 }
    }

    /// What was learnt about the car, to keep for its next drive (its noise risen by at most
    /// `NOISE_RISE_PER_DRIVE` over the stored record's, and at most `NOISE_ANCHOR_BAND` over
    /// the car's anchor): `None` before it is
    /// calibrated, and when this drive contradicts the stored record (never silently
    /// relearnt: the stored one stays).
    pub fn record(&self) -> Option<Record> {
        if !self.cal.calibrated() || self.cal.contradiction().is_some() {
            return None;
        }
        let (scale, delay_s, learnt_s) = self.cal.record_base();
        let (anchor_scale, anchor_delay_s) = self.cal.anchors();
        let stored = self.stored;
        let (s2a, k2a) = self.noise_params(0);
        let (s2b, k2b) = self.noise_params(1);
        let whole_bias = self.bias - self.rot.omega().to_degrees();
        let gyro = self.source == Some(HeadingSource::Gyro) || self.bias_weight > 0.0;
        // The noise kept for the next drive rises by at most NOISE_RISE_PER_DRIVE over the
        // stored record's (the same receiver class's): see there.
        let same = stored.filter(|r| self.same_class(r));
        let mut noise = [gnss_guard_dsp::sqrtf(s2a), gnss_guard_dsp::sqrtf(s2b), gnss_guard_dsp::sqrtf(k2a), gnss_guard_dsp::sqrtf(k2b), self.quiet_sigma[0], self.quiet_sigma[1]];
        // The first record of this receiver class is its own anchor.
        let mut anchors = noise;
        if let Some(r) = same {
            let (before, a) = noise_of(&r);
            cap(&mut noise, &before, NOISE_RISE_PER_DRIVE);
            cap(&mut noise, &a, NOISE_ANCHOR_BAND);
            anchors = a;
        }
        Some(Record {
            scale,
            delay_s,
            learnt_s,
            drives: stored.map_or(1, |r| r.drives.saturating_add(1)),
            gyro_bias_degps: if gyro { whole_bias } else { stored.map_or(f32::NAN, |r| r.gyro_bias_degps) },
            gyro_bias_weight_s: self.bias_weight,
            gyro_scale_error: self.rot.scale_error(),
            anchor_gyro_scale_error: stored.map_or(self.rot.scale_error(), |r| r.anchor_gyro_scale_error),
            gyro_scale_sd: gnss_guard_dsp::sqrtf(self.rot.var_scale()),
            noise_s0_m: [noise[0], noise[1]],
            noise_k: [noise[2], noise[3]],
            velocity_sigma_mps: [noise[4], noise[5]],
            nominal_dt_s: self.cfg_dt(),
            anchor_scale,
            anchor_delay_s,
            anchor_noise_s0_m: [anchors[0], anchors[1]],
            anchor_noise_k: [anchors[2], anchors[3]],
            anchor_velocity_sigma_mps: [anchors[4], anchors[5]],
        })
        .filter(|r| r.plausible().is_ok())
    }

    /// The noise of window `wi`, `(s0^2, k^2)`: the car's own fit, blended with the receiver
    /// profile's prior while the fit has little data; from a stored record of this receiver
    /// class, whose noise seeded the fits at power-up, the fit alone (the profile's prior is in
    /// the record already: blended in again, every drive that learnt nothing raised the
    /// stored noise).
    pub(super) fn noise_params(&self, wi: usize) -> (f32, f32) {
        self.fit_params(self.noise.get(wi))
    }

    /// The 10 s window's along-track noise, `(s0^2, k^2)` (the same prior: the receiver's stated
    /// accuracy, both axes).
    pub(super) fn noise_params_along(&self) -> (f32, f32) {
        self.fit_params(Some(&self.noise_along))
    }

    pub(super) fn fit_params(&self, nf: Option<&NoiseFits>) -> (f32, f32) {
        let c = self.cfg;
        let prior = (2.0 * c.s0_prior_m * c.s0_prior_m, c.k_prior * c.k_prior);
        let Some(nf) = nf else { return prior };
        if self.stored.is_some_and(|r| self.same_class(&r)) {
            return nf.blended(prior, 0.0);
        }
        let w_p = c.prior_weight_s * libm::expf(-self.learnt_s / c.prior_weight_s.max(1.0));
        nf.blended(prior, w_p)
    }

    /// The time constant of the noise learning: growing with what was learnt.
    pub(super) fn learn_tau(&self) -> f32 {
        let c = self.cfg;
        // max/min, not clamp: clamp panics on bounds it cannot prove ordered.
        let lo = c.warmup_s.max(1.0);
        self.learnt_s.max(lo).min(c.learn_tau_s.max(lo))
    }

    /// The check made afresh from a stored record (or none: the car is learnt), in place.
    pub fn load(&mut self, r: Option<&Record>) {
        self.stored = r.filter(|r| r.plausible().is_ok()).copied();
        self.reset();
    }

    /// A check made afresh for this configuration, in place (no stored record): as
    /// [`TrackCheck::new`] without building an 11 KB one on the stack.
    pub fn reinit(&mut self, cfg: TrackConfig) {
        self.cfg = cfg;
        self.stored = None;
        self.reset();
    }

    /// Power-up: forgets what this drive learnt (back to the stored record, if any).
    pub fn reset(&mut self) {
        let cfg = self.cfg;
        self.c = cfg.threshold();
        self.restart();
        self.vel = VelocityTest::new(cfg.velocity);
        self.quiet_sigma = self.vel.sigma();
        self.last_delay_var_across = 0.0;
        self.bias = 0.0;
        self.bias_weight = 0.0;
        self.rot = Rotation::new(&cfg);
        self.rot_own = Rotation::new(&cfg);
        self.cal = Calibration::new(cfg.cal);
        self.noise = [NoiseFits::default(); 2];
        self.noise_along = NoiseFits::default();
        self.learnt_s = 0.0;
        self.load_stored();
    }

    /// After a short gap or a missing input: the windows and the frame's alignment start
    /// over, what was learnt about the car stays.
    pub fn restart(&mut self) {
        self.hist.clear();
        self.origin = None;
        self.dr = (0.0, 0.0);
        self.dr_var = 0.0;
        self.psi = 0.0;
        self.travel = Travel::default();
        self.aligned = false;
        self.source = None;
        self.last = None;
        self.heading_anchor = None;
        self.above_since = [None; 2];
        self.fast_since = None;
        self.alarm = [false; 2];
        self.unjudged_s = 0.0;
        self.last_pair_t = f32::NEG_INFINITY;
        self.last_learn_t = f32::NEG_INFINITY;
        self.last_pred = None;
        self.last_acc = (0.0, 0.0);
        self.last_judged_t = f32::NEG_INFINITY;
        self.last_gross_t = f32::NEG_INFINITY;
        self.vel_blind = None;
        self.vi_since = f32::INFINITY;
        self.vel.restart();
    }

    /// Still in the position windows' warm-up.
    pub fn warming(&self) -> bool {
        self.learnt_s < self.cfg.warmup_s
    }

    /// The delay in use for the GNSS position, seconds.
    pub fn delay_s(&self) -> f32 {
        self.cal.delay_s(Source::Position)
    }

    /// The car's calibration.
    pub fn calibration(&self) -> &Calibration {
        &self.cal
    }

    /// The gain mapping DR displacements onto GNSS ones: the scale, rotated (gyro mode).
    pub(super) fn gain(&self) -> (f32, f32) {
        let s = self.cal.scale();
        match self.rot() {
            Some(rot) => scale2(cis(rot.theta()), s),
            None => (s, 0.0),
        }
    }

    /// The rotation's variance, rad^2 (none without a gyro: the DR heading is GNSS's own).
    pub(super) fn rot_var(&self) -> f32 {
        self.rot().map_or(0.0, Rotation::var_theta)
    }

    /// Once standstills have measured the gyro's bias (here or on a stored drive), the
    /// rotation filter's residual bias is the driving bias's offset from it, not the power-up
    /// uncertainty: the frame's uncertainty then grows by that offset over a stretch without
    /// GNSS course (a stop, a slow crawl, a gap), not by half a degree a second.
    pub(super) fn bound_bias_by_standstill(&mut self) {
        // The filters themselves, not `rot`: a stored record is loaded before the heading's
        // source is known. The correction's band only where no record gave the bias (see
        // `rotation::STANDSTILL_BIAS_BAND_SD`).
        if self.bias_weight >= rotation::STANDSTILL_MEASURED_S {
            let (sd, own) = (rotation::STANDSTILL_BIAS_SD_DEGPS.to_radians(), self.stored.is_none());
            self.rot.bound_omega_var(sd * sd, own);
            self.rot_own.bound_omega_var(sd * sd, own);
        }
    }

    /// The rotation filter of this stretch's heading source (none when GNSS is the heading).
    pub(super) fn rot(&self) -> Option<&Rotation> {
        (self.source == Some(HeadingSource::Gyro)).then_some(&self.rot)
    }

    /// The DR position at time `t` (the newest when `t` is now or later).
    pub(super) fn dr_at(&self, t: f32, now: f32) -> Option<Entry> {
        if t >= now - 1e-4 {
            return self.hist.back().copied();
        }
        self.hist.at(t)
    }

    /// The DR frame's rotation is known well enough to judge.
    pub(super) fn aligned_frame(&self) -> bool {
        let a = self.cfg.aligned_sd_deg.to_radians();
        self.rot_var() <= a * a
    }
}
