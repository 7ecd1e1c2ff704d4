//! What the track check learns about the car, and the limits on that learning.
//!
//! Calibration is state a spoofer can target: a drift slow enough to stay under a threshold
//! would otherwise be learnt as a change of the car. So everything here is
//! - **bounded**: a drive that starts from a stored record moves the wheel-speed scale by at
//!   most [`CalLimits::scale_bound`] and the delay by at most [`CalLimits::delay_bound_s`] from
//!   it (a tyre's radius changes by tenths of a percent over weeks);
//! - **anchored**: over all its drives a car's scale stays within [`CalLimits::scale_bound`]
//!   plus the wear its hours of driving allow ([`CalLimits::wear_per_h`], at most
//!   [`CalLimits::walk_max`]) of its first record's, and its delays within
//!   [`CalLimits::delay_bound_s`] of the first record's: a spoofer on drive after drive cannot
//!   walk the record a bound per drive (0.8 % per drive took sddi_commuter's record from 1.000
//!   to 1.073 in ten drives, unreported, before the anchor);
//! - **physical**: every scale stays within [`SCALE_MIN`] to [`SCALE_MAX`], and a first drive's
//!   starts from a prior of 1 worth [`SCALE_PRIOR_WEIGHT_S`] (its first slow pairs say little);
//! - **rate-limited** once calibrated: the scale by [`CalLimits::scale_rate_per_s`], the delay by
//!   one candidate per [`CalLimits::delay_dwell_s`];
//! - **frozen** while evidence accumulates (the caller does not call [`Calibration::learn`]
//!   then), and never taught by a pair beyond the velocity test's gross path's bounds, not even
//!   in a first drive's free warm-up (what the calibration's own uncertainty cannot explain is
//!   not the car's: a drift of 10 m/s a minute into sddi_commuter's drive swung the delay from
//!   -1.5 to +3 and -3 s before);
//! - **kept across drives** as a [`Record`] (its byte format is `wire::calibration`);
//! - **never silently relearnt**: this drive's own estimate, made beside the bounded one, that
//!   contradicts the stored record beyond the bounds is reported ([`Calibration::contradiction`]).
//!
//! The delay is learnt with either sign among [`DELAYS`] candidates from [`DELAY_MIN_S`] to
//! `-DELAY_MIN_S`: positive when the GNSS is late (receiver latency), negative when the vehicle
//! signals are (a logger that stamps CAN frames late, a slow bus). It is learnt twice, once for
//! each thing the receiver reports ([`Source`]): its position (through position differences)
//! and its velocity, which receivers filter, and some take from a second, slower receiver, so
//! its latency is its own. For each candidate the exponentially weighted least squares of the
//! GNSS velocity on the dead reckoning's velocity that much earlier (`sum G conj(D)
//! e^{-i theta}`, `sum |D|^2`, rotation removed so they survive a re-alignment) gives a scale;
//! the candidate whose fit explains the most wins.

use super::plane::{cmul, conj, norm2};

/// Delay candidates: -3, -2.875, ..., +3 s (a velocity held from a second, 1 Hz receiver that
/// lags by 1.8 s is up to 2.8 s late).
pub const DELAYS: usize = 49;
/// The step between delay candidates, seconds.
pub const DELAY_STEP_S: f32 = 0.125;
/// The first candidate's delay, seconds (negative: the vehicle signals late).
pub const DELAY_MIN_S: f32 = -3.0;
/// The candidate of zero delay.
const ZERO: usize = 24;

/// The delay of candidate `k`, seconds.
pub fn delay_of(k: usize) -> f32 {
    DELAY_MIN_S + k as f32 * DELAY_STEP_S
}

/// The candidate nearest to a delay.
pub fn candidate(delay_s: f32) -> usize {
    let k = libm::roundf((delay_s - DELAY_MIN_S) / DELAY_STEP_S);
    if k.is_finite() { (k.max(0.0) as usize).min(DELAYS - 1) } else { ZERO }
}

/// A first drive: what the prior scale of 1 weighs against the fit, seconds of driving at 15 m/s
/// (the fit of a first few slow pairs at a delay not yet found says little).
pub const SCALE_PRIOR_WEIGHT_S: f32 = 2.0;

/// The bounds and rates of the learning. See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalLimits {
    /// Seconds of driving (velocity pairs above the learning speed) before a car without a
    /// stored record counts as calibrated; until then its learning is free and it says so.
    pub warmup_s: f32,
    /// Time constant of the exponentially weighted fits once calibrated, seconds: the delay is
    /// the installation's and its information comes only from accelerations, so its fits
    /// remember about a drive (the scale follows them within its rate).
    pub tau_s: f32,
    /// How far the scale may move from the stored record within one drive (relative).
    pub scale_bound: f32,
    /// How fast the scale may move once calibrated, per second of driving (relative).
    pub scale_rate_per_s: f32,
    /// How far the delay may move from the stored record within one drive, seconds.
    pub delay_bound_s: f32,
    /// Once calibrated the delay moves by one candidate at most once per this many seconds.
    pub delay_dwell_s: f32,
    /// Seconds of this drive's own data before it may contradict the stored record.
    pub contradict_after_s: f32,
    /// What a stored record's fit weighs at the start of a drive, seconds of driving.
    pub stored_weight_s: f32,
    /// How far the scale may move from the car's anchor, relative, per hour of driving
    /// learnt, beyond [`CalLimits::scale_bound`]: tyre wear (a tread's 6 mm of a 315 mm radius,
    /// 2 %, over about 50,000 km, 1,000 h) five times over.
    pub wear_per_h: f32,
    /// The most the scale may ever move from the car's anchor, relative: a worn-out tyre and
    /// its pressure. Beyond it is another tyre: the record is contradicted, and its owner
    /// starts the car's calibration anew.
    pub walk_max: f32,
}

impl Default for CalLimits {
    fn default() -> Self {
        CalLimits {
            warmup_s: 120.0,
            tau_s: 3600.0,
            scale_bound: 0.01,
            scale_rate_per_s: 1.0e-5,
            delay_bound_s: 1.0,
            delay_dwell_s: 30.0,
            contradict_after_s: 180.0,
            stored_weight_s: 120.0,
            wear_per_h: 1.0e-4,
            walk_max: 0.03,
        }
    }
}

/// What the receiver reports that a delay is learnt for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Its position (compared through position differences over a second).
    Position = 0,
    /// Its velocity (speed and course).
    Velocity = 1,
}

pub use crate::wire::calibration::{Record, RecordError, RECORD_LEN, SCALE_MAX, SCALE_MIN};

/// What of the stored record this drive contradicts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Contradiction {
    /// This drive's wheel-speed scale is beyond the bound from the stored one (a tyre change,
    /// another car, or GNSS spoofed since before the drive began).
    Scale,
    /// This drive's delay (of the position or the velocity) is beyond the bound from the
    /// stored one.
    Delay,
    /// This drive's gyro scale error is beyond the bound from the stored one (or from the car's
    /// anchor).
    GyroScale,
    // A walk away from the car's anchor is one of these too: its scale beyond the anchor's
    // allowance is `Scale`, its delay beyond the anchor's bound `Delay`, its gyro scale error
    // beyond the anchor's walk `GyroScale`.
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
    fn scale(&self) -> Option<f32> {
        (self.b > 1.0 && self.a.0 > 0.0).then(|| self.a.0 / self.b).filter(|s| s.is_finite())
    }
    fn add(&mut self, g: (f32, f32), d: (f32, f32), derot: (f32, f32), dt: f32, keep: f32) {
        let gd = cmul(cmul(g, conj(d)), derot);
        self.a = (self.a.0 * keep + dt * gd.0, self.a.1 * keep + dt * gd.1);
        self.b = self.b * keep + dt * norm2(d);
    }
}

/// One delay's fits: per candidate, the one in use, and this drive's own fit at the stored one.
#[derive(Clone, Copy, Debug)]
struct DelaySet {
    fits: [DelayFit; DELAYS],
    best: usize,
    /// The candidate whose fit explains the most, as of the last learning (the fits change
    /// nowhere else): read per judged pair, so not searched again there.
    free: usize,
    /// Seconds since the delay last moved (once calibrated), and seconds learnt.
    dwell_s: f32,
    learnt_s: f32,
    /// The stored record's candidate (the bounds' centre), and this drive's own fit there.
    anchor: Option<usize>,
    /// The car's anchor's candidate (its first record's delay): bounds too.
    car: Option<usize>,
    own: DelayFit,
    own_s: f32,
}

impl DelaySet {
    fn new() -> Self {
        DelaySet { fits: [DelayFit::default(); DELAYS], best: ZERO, free: ZERO, dwell_s: 0.0, learnt_s: 0.0, anchor: None, car: None, own: DelayFit::default(), own_s: 0.0 }
    }
    /// A set that starts from a stored delay and scale: every candidate with the stored fit's
    /// weight (a speed of 15 m/s for `weight_s`), so this drive's data decides between them.
    fn stored(delay_s: f32, scale: f32, weight_s: f32) -> Self {
        let mut d = DelaySet::new();
        d.best = candidate(delay_s);
        // Every candidate's fit alike: the search keeps the one in use.
        d.free = d.best;
        d.anchor = Some(d.best);
        let b = weight_s * 225.0;
        fill(&mut d.fits, DelayFit { a: (scale * b, 0.0), b });
        d
    }
    /// The candidate whose fit explains the most (ties keep the one in use).
    fn search(&self) -> usize {
        self.fits
            .iter()
            .enumerate()
            .fold((self.best, self.fits.get(self.best).map_or(0.0, DelayFit::explained)), |acc, (k, f)| if f.explained() > acc.1 { (k, f.explained()) } else { acc })
            .0
    }
    fn scale(&self) -> Option<f32> {
        self.fits.get(self.best).and_then(DelayFit::scale)
    }
    /// The candidates a calibrated delay may take: within `span` of the stored record's and of
    /// the car's anchor (the anchor's alone where the two do not meet).
    fn band(&self, span: usize) -> (usize, usize) {
        let around = |k: usize| (k.saturating_sub(span), (k + span).min(DELAYS - 1));
        match (self.anchor.map(around), self.car.map(around)) {
            (Some(s), Some(c)) if s.0.max(c.0) <= s.1.min(c.1) => (s.0.max(c.0), s.1.min(c.1)),
            (_, Some(c)) => c,
            (Some(s), None) => s,
            (None, None) => (0, DELAYS - 1),
        }
    }
    /// The free delay is beyond `span` (and a candidate) of the stored one or the car's anchor.
    fn contradicts(&self, span: usize) -> bool {
        [self.anchor, self.car].iter().flatten().any(|k| self.free.abs_diff(*k) > span + 1)
    }
}

/// Every fit set to `f`. Not inlined, on a slice: over the array, loop or literal alike, the
/// compiler wrote out all 147 stores in place, twice (1.2 KB of flash in `TrackCheck::reset`).
#[inline(never)]
fn fill(fits: &mut [DelayFit], f: DelayFit) {
    for x in fits.iter_mut() {
        *x = f;
    }
}

/// The wheel-speed scale and the delays, learnt within limits. See the module documentation.
#[derive(Clone, Debug)]
pub struct Calibration {
    lim: CalLimits,
    sets: [DelaySet; 2],
    /// The scale in use.
    scale: f32,
    /// Seconds of driving learnt from (a stored record's included).
    learnt_s: f32,
    /// Learnt enough to judge small drifts (a stored record, or a first drive's warm-up done).
    calibrated: bool,
    /// The stored record this drive started from: the centre of the bounds (a first drive has
    /// rates only: its first minutes are not trusted to bound the rest of it).
    stored: Option<Record>,
    contradiction: Option<Contradiction>,
}

impl Calibration {
    /// A first drive's calibration: nothing learnt, learning within `lim`'s rates.
    pub fn new(lim: CalLimits) -> Self {
        Calibration { lim, sets: [DelaySet::new(); 2], scale: 1.0, learnt_s: 0.0, calibrated: false, stored: None, contradiction: None }
    }

    /// A calibration that starts from a stored record: calibrated from the first epoch, its
    /// bounds centred on the record.
    #[inline(never)]
    pub fn from_record(lim: CalLimits, r: &Record) -> Self {
        let mut c = Calibration::new(lim);
        if r.plausible().is_err() {
            return c;
        }
        c.sets[0] = DelaySet::stored(r.delay_s[0], r.scale, lim.stored_weight_s);
        if r.delay_s[1].is_finite() {
            c.sets[1] = DelaySet::stored(r.delay_s[1], r.scale, lim.stored_weight_s);
        }
        for (set, a) in c.sets.iter_mut().zip(r.anchor_delay_s) {
            set.car = a.is_finite().then(|| candidate(a));
        }
        c.learnt_s = r.learnt_s.max(lim.warmup_s);
        c.stored = Some(*r);
        c.calibrated = true;
        c.scale = r.scale;
        if let Some((lo, hi)) = c.scale_band() {
            // A record already beyond its anchor's allowance (not one this code wrote):
            // reported at once, and the scale in use within the allowance.
            if !(lo..=hi).contains(&r.scale) {
                c.contradiction = Some(Contradiction::Scale);
                c.scale = r.scale.max(lo).min(hi);
            }
        }
        c
    }

    /// How far the scale may be from the car's anchor, relative, after the driving of `r`:
    /// [`CalLimits::scale_bound`] and [`CalLimits::wear_per_h`] per hour learnt, at most
    /// [`CalLimits::walk_max`].
    pub fn walk_allowance(&self, r: &Record) -> f32 {
        let a = self.lim.scale_bound + self.lim.wear_per_h * r.learnt_s / 3600.0;
        if a.is_finite() { a.min(self.lim.walk_max) } else { self.lim.walk_max }
    }

    /// The scales a drive that started from a stored record may take: within
    /// [`CalLimits::scale_bound`] of the record's and within [`Calibration::walk_allowance`]
    /// of the car's anchor (the anchor's alone where the two do not meet).
    fn scale_band(&self) -> Option<(f32, f32)> {
        let r = self.stored?;
        let (b, a) = (self.lim.scale_bound * r.scale, self.walk_allowance(&r) * r.anchor_scale);
        let (lo, hi) = ((r.scale - b).max(r.anchor_scale - a), (r.scale + b).min(r.anchor_scale + a));
        Some(if lo <= hi { (lo, hi) } else { (r.anchor_scale - a, r.anchor_scale + a) })
    }

    /// The bounds and rates it learns within.
    pub fn limits(&self) -> &CalLimits {
        &self.lim
    }
    fn set(&self, src: Source) -> &DelaySet {
        &self.sets[src as usize]
    }
    /// The delay in use for what the receiver reports, seconds.
    pub fn delay_s(&self, src: Source) -> f32 {
        delay_of(self.set(src).best)
    }
    /// The delay the fits alone say (the candidate that explains most), seconds.
    pub fn free_delay_s(&self, src: Source) -> f32 {
        delay_of(self.set(src).free)
    }
    /// The scale in use.
    pub fn scale(&self) -> f32 {
        self.scale
    }
    /// The scale's relative uncertainty: its fit's standard error, `sqrt(sigma^2 kappa / sum
    /// |D|^2)` for velocity residuals of noise `sigma` (m/s) correlated over `kappa` seconds, a
    /// stored record's weight counted as `learnt_s` at 15 m/s; at least 0.1 %, at most the
    /// prior's 5 %.
    pub fn scale_sd(&self, sigma: f32, kappa: f32) -> f32 {
        let src = if self.sets[Source::Velocity as usize].learnt_s > 0.0 { Source::Velocity } else { Source::Position };
        let b = self.set(src).fits.get(self.set(src).best).map_or(0.0, |f| f.b)
            + self.stored.map_or(0.0, |r| r.learnt_s.min(self.lim.tau_s) * 225.0);
        if b.is_nan() || b <= 0.0 {
            return 0.05;
        }
        let sd = gnss_guard_dsp::sqrtf(sigma * sigma * kappa.max(1.0) / b) / self.scale.max(0.5);
        if sd.is_finite() { sd.clamp(0.001, 0.05) } else { 0.05 }
    }
    /// The delay's uncertainty, seconds, never below 0.1 s (a delay is the model of a filter,
    /// not a constant) nor above 0.5 s: 0.5 s for a first drive's first two minutes; then the
    /// smaller of
    /// - the fits' own: the delay is resolved by the accelerations in them, and how well is the
    ///   curvature of what the candidates' fits explain around the one in use, `c` in
    ///   `E(tau) = E_best - c (tau - tau_best)^2` ((m/s)^2 s per s^2), against the residual's
    ///   noise `sigma` (m/s) correlated over `kappa` seconds: `sqrt(sigma^2 kappa / c)`, with
    ///   the distance to the candidate the fits alone prefer added (a calibrated delay moves
    ///   one candidate per dwell);
    /// - 0.5 s shrinking with the square root of the minutes learnt (a stored record's
    ///   included) to 0.1 s after 50 minutes.
    ///
    /// A braking car's velocity is wrong by its deceleration times the delay's error, so an
    /// uncertainty left at the minutes' 0.4 s after five minutes of town driving (css_canedge)
    /// held a drift of 0.5 m/s under 0.6 m/s of the prediction's own error at every stop.
    #[inline(never)]
    pub fn delay_sd_s(&self, src: Source, sigma: f32, kappa: f32) -> f32 {
        let set = self.set(src);
        let minutes = set.learnt_s.max(if self.stored.is_some() { self.learnt_s } else { 0.0 }) / 60.0;
        if minutes <= 2.0 {
            return 0.5;
        }
        let by_time = 0.5 * gnss_guard_dsp::sqrtf(2.0 / minutes);
        let e = |k: Option<usize>| k.and_then(|k| set.fits.get(k)).map(DelayFit::explained);
        let by_fit = match (e(set.best.checked_sub(1)), e(Some(set.best)), e(Some(set.best + 1))) {
            (Some(lo), Some(mid), Some(hi)) => {
                let c = (2.0 * mid - lo - hi) / (2.0 * DELAY_STEP_S * DELAY_STEP_S);
                let off = delay_of(set.free) - delay_of(set.best);
                let var = sigma * sigma * kappa.max(1.0) / c + off * off;
                if c > 0.0 && var.is_finite() { gnss_guard_dsp::sqrtf(var) } else { 0.5 }
            }
            _ => 0.5,
        };
        let sd = by_time.min(by_fit);
        if sd.is_finite() { sd.clamp(0.1, 0.5) } else { 0.5 }
    }
    /// Learnt enough to judge small drifts: a stored record, or `warmup_s` of this drive.
    pub fn calibrated(&self) -> bool {
        self.calibrated
    }
    /// The stored record this drive started from, if any.
    pub fn stored(&self) -> Option<&Record> {
        self.stored.as_ref()
    }
    /// Seconds of driving learnt from (a stored record's included).
    pub fn learnt_s(&self) -> f32 {
        self.learnt_s
    }
    /// The stored record this drive contradicts, once found.
    pub fn contradiction(&self) -> Option<Contradiction> {
        self.contradiction
    }
    /// Reports a contradiction found outside the calibration (the gyro's scale, which the
    /// frame's rotation learns), unless one was found before.
    pub fn contradict(&mut self, c: Contradiction) {
        if self.stored.is_some() && self.contradiction.is_none() {
            self.contradiction = Some(c);
        }
    }
    /// Per delay candidate of `src`: the delay, how much of the GNSS velocity its fit explains
    /// and its scale (diagnostics).
    pub fn fits(&self, src: Source) -> [(f32, f32, f32); DELAYS] {
        let mut out = [(0.0, 0.0, 0.0); DELAYS];
        for (k, (o, f)) in out.iter_mut().zip(self.set(src).fits.iter()).enumerate() {
            *o = (delay_of(k), f.explained(), f.scale().unwrap_or(f32::NAN));
        }
        out
    }

    /// One velocity pair's worth of learning for `src`, `dt` seconds of driving: the GNSS
    /// velocity `g` and, per delay candidate, the dead reckoning's velocity `d[k]` that much
    /// earlier, with the DR frame's rotation removed by `derot` (`e^{-i theta}`). The scale
    /// follows the velocity's fits where the receiver reports a velocity, else the position's.
    ///
    /// `sigma` and `kappa` are the velocity residual's noise and correlation time: the scale
    /// moves, once calibrated, by at most its own uncertainty per minute (at least
    /// [`CalLimits::scale_rate_per_s`]): a young calibration converges, an old one barely moves.
    #[allow(clippy::too_many_arguments)]
    pub fn learn(&mut self, src: Source, g: (f32, f32), d: &[(f32, f32); DELAYS], derot: (f32, f32), dt: f32, sigma: f32, kappa: f32) {
        if !(dt.is_finite() && dt > 0.0 && g.0.is_finite() && g.1.is_finite() && d.iter().all(|x| x.0.is_finite() && x.1.is_finite())) {
            return;
        }
        let lim = self.lim;
        let calibrated = self.calibrated;
        let Some(set) = self.sets.get_mut(src as usize) else { return };
        let tau = if calibrated { lim.tau_s } else { set.learnt_s.max(lim.warmup_s * 0.25).min(lim.tau_s) };
        let keep = libm::expf(-dt / tau.max(1.0));
        for (f, dk) in set.fits.iter_mut().zip(d.iter()) {
            f.add(g, *dk, derot, dt, keep);
        }
        set.learnt_s += dt;
        set.dwell_s += dt;
        let free = set.search();
        set.free = free;
        let span = libm::roundf(lim.delay_bound_s / DELAY_STEP_S).max(0.0) as usize;
        if !calibrated {
            set.best = free;
        } else {
            // Calibrated: the delay moves one candidate per dwell, within its bound around a
            // stored record and the car's anchor; on a drive from a stored record, for its
            // first warm-up of learning, to the fits' choice within that bound at once (a
            // logger's latency differs from boot to boot: sddi_commuter's 0.5 to 1.25 s).
            let (lo, hi) = set.band(span);
            // max/min, not clamp: clamp panics on bounds it cannot prove ordered.
            let target = free.max(lo).min(hi);
            let starting = set.anchor.is_some() && set.learnt_s <= lim.warmup_s;
            if starting {
                set.best = target;
            } else if target != set.best && set.dwell_s >= lim.delay_dwell_s {
                set.best = if target > set.best { set.best + 1 } else { set.best - 1 };
                set.dwell_s = 0.0;
            }
            // The delay's information is in the accelerations only: ten minutes of them.
            if set.anchor.is_some() && set.own_s >= (3.0 * lim.contradict_after_s).max(600.0) && set.contradicts(span) && self.contradiction.is_none() {
                self.contradiction = Some(Contradiction::Delay);
            }
        }
        // The scale: from the velocity's fits where there are any, else the position's.
        let leads = src == Source::Velocity || self.sets[Source::Velocity as usize].learnt_s <= 0.0;
        if leads {
            self.learnt_s += dt;
            let rate = self.lim.scale_rate_per_s.max(self.scale_sd(sigma, kappa) / 60.0);
            self.learn_scale(src, dt, rate, sigma * sigma * kappa.max(1.0));
        }
        if !self.calibrated && self.learnt_s >= lim.warmup_s {
            self.calibrated = true;
        }
    }

    /// `noise` is the velocity residual's variance times its correlation time, (m/s)^2 s: the
    /// own estimate's standard error is `sqrt(noise / sum |D|^2)`.
    /// This drive's own fit at the stored delay, never forgotten, and learnt whatever the check
    /// says (it steers no judgement: it is only compared with the stored record, so a record the
    /// car contradicts is found even while the evidence freezes everything else): then the
    /// contradiction test of the scale.
    #[allow(clippy::too_many_arguments)]
    pub fn learn_own(&mut self, src: Source, g: (f32, f32), d: &[(f32, f32); DELAYS], derot: (f32, f32), dt: f32, sigma: f32, kappa: f32) {
        if !(dt.is_finite() && dt > 0.0 && g.0.is_finite() && g.1.is_finite()) {
            return;
        }
        let Some(set) = self.sets.get_mut(src as usize) else { return };
        let Some(k0) = set.anchor else { return };
        let Some(dk) = d.get(k0).filter(|x| x.0.is_finite() && x.1.is_finite()) else { return };
        set.own.add(g, *dk, derot, dt, 1.0);
        set.own_s += dt;
        let leads = src == Source::Velocity || self.sets[Source::Velocity as usize].own_s <= 0.0;
        if leads {
            self.check_scale(src, sigma * sigma * kappa.max(1.0));
        }
    }

    /// A stored record that this drive's own data contradicts beyond the bound (from the
    /// record's scale, or the allowance from the car's anchor), by more than three of the own
    /// estimate's standard errors, is reported, not relearnt (the scale in use stays at its
    /// bound). Minutes of town driving resolve the scale to about 1 %. `noise` is the velocity
    /// residual's variance times its correlation time, (m/s)^2 s.
    fn check_scale(&mut self, src: Source, noise: f32) {
        let set = &self.sets[src as usize];
        if let (Some(r), None) = (self.stored, self.contradiction) {
            if let Some(own) = set.own.scale().filter(|_| set.own_s >= self.lim.contradict_after_s) {
                let sd = gnss_guard_dsp::sqrtf(noise / set.own.b.max(1e-6)) / r.scale;
                let beyond = |centre: f32, bound: f32| libm::fabsf(own / centre - 1.0) > bound + 3.0 * sd;
                if beyond(r.scale, self.lim.scale_bound) || beyond(r.anchor_scale, self.walk_allowance(&r)) {
                    self.contradiction = Some(Contradiction::Scale);
                }
            }
        }
    }

    fn learn_scale(&mut self, src: Source, dt: f32, rate: f32, noise: f32) {
        let set = &self.sets[src as usize];
        if !self.calibrated {
            // Free, but drawn to the prior of 1 by `SCALE_PRIOR_WEIGHT_S` (a few slow pairs right
            // after the first fix gave 0.54 on openxc_ford and 0.61 on sddi_commuter, whose
            // wheels are within 5 %), and within what is physically possible.
            let b0 = SCALE_PRIOR_WEIGHT_S * 225.0;
            if let Some(f) = set.fits.get(set.best) {
                let s = (f.a.0 + b0) / (f.b + b0);
                if s.is_finite() {
                    self.scale = s.clamp(SCALE_MIN, SCALE_MAX);
                }
            }
            return;
        }
        let Some(s) = set.scale() else { return };
        let step = rate * dt * self.scale;
        let moved = (self.scale + (s - self.scale).max(-step).min(step)).clamp(SCALE_MIN, SCALE_MAX);
        self.scale = match self.scale_band() {
            Some((lo, hi)) => moved.max(lo).min(hi),
            None => moved,
        };
        self.check_scale(src, noise);
    }

    /// The record's part of what was learnt: the scale, the delays (the velocity's NaN where
    /// none was learnt) and the seconds learnt. A drive from a stored record keeps the
    /// record's delay while it is still in its first warm-up of learning: the delay it judges
    /// with is then its fits' choice after seconds of data (every candidate starts alike), not
    /// yet the car's (css_canedge, 7 s of driving took the stored 0.375 s to 0). Out of line:
    /// a save's work (inlined in the board's `judge` it took 128 bytes more).
    #[inline(never)]
    pub fn record_base(&self) -> (f32, [f32; 2], f32) {
        let kept = |set: &DelaySet| delay_of(set.anchor.filter(|_| set.learnt_s <= self.lim.warmup_s).unwrap_or(set.best));
        let vel = &self.sets[Source::Velocity as usize];
        let dv = if vel.learnt_s > 0.0 || vel.anchor.is_some() { kept(vel) } else { f32::NAN };
        (self.scale, [kept(&self.sets[Source::Position as usize]), dv], self.learnt_s)
    }

    /// The record's anchors (see [`Record::anchor_scale`]): the stored record's, and this
    /// drive's scale and delays where there is none (a first drive: they become the car's);
    /// the velocity's delay from the first drive that learnt one.
    pub fn anchors(&self) -> (f32, [f32; 2]) {
        let (scale, delay_s, _) = self.record_base();
        match self.stored {
            Some(r) => (r.anchor_scale, [r.anchor_delay_s[0], if r.anchor_delay_s[1].is_finite() { r.anchor_delay_s[1] } else { delay_s[1] }]),
            None => (scale, delay_s),
        }
    }
}

#[cfg(test)]
mod tests;
