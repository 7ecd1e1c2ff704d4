//! Beyond the paper: the track check, for spoofing that stays under strategy 1's per-epoch
//! threshold (slow drift, many small biased steps, a rotated track, a delayed track). It
//! compares the GNSS track with the car's own dead reckoning, calibrated to the car, in two
//! ways that share that calibration:
//! - the **velocity test** ([`velocity`]): every epoch's GNSS velocity against the dead
//!   reckoning's, its evidence accumulated by a sequential test over a bank of windows. A
//!   drift is in every epoch's velocity at full size; this is the check that finds it;
//! - the **position windows**: the GNSS displacement over 10 s and 30 s against the dead
//!   reckoning's, a backstop for what changes the track without changing its velocity for long
//!   (a jump hidden in a GNSS gap, a replayed track).
//!
//! # The dead reckoning
//! Wheel speed along the heading, the heading integrated from the gyro (its bias measured while
//! the wheels stand) or, without a gyro, taken from the GNSS track itself. Over a window of `T`
//! seconds the GNSS displacement `G` (complex, east + i north) is compared with the DR
//! displacement `D` of the same window, `tau` earlier:
//!
//! ```text
//! e = G(t-T, t) - s e^{i theta} D(t-T-tau, t-tau)
//! ```
//!
//! What differs between installations is learnt on the car ([`calibration`]): `s` and `tau`
//! from the velocity pairs, with either sign of `tau`; `theta`, the rotation of the DR frame
//! against GNSS's, with the gyro's residual bias and scale error, by a three-state Kalman filter
//! (`rotation`) fed by each pair's course (receivers that report one) or each 10 s window's
//! angle; the noise of each position window, `E|e|^2 = s0^2 + (k L)^2 + P L^2` with `L = |D|`,
//! fitted robustly, apart for windows driven below and above 15 m/s (town and road: over a
//! motorway's long windows `s0` is hidden under `k L`, and one fit let it sink to its floor,
//! so town after the motorway was judged with the motorway's noise), and for the 10 s window
//! once more, its along-track error alone (what the velocity test's position differences sum
//! to; without a gyro the across-track error, the DR heading being the GNSS bearing, is most
//! of `|e|^2`).
//! The receiver's own accuracy (NMEA GST, UBX hAcc), when it reports one,
//! floors `s0`. All of it learns only while nothing is suspicious, within bounds and rates once
//! calibrated, and is kept across drives as a [`calibration::Record`]. One thing is not learnt
//! that way: a receiver that reports its velocity says how noisy its position is now (its
//! position against the integral of its own velocity), and the 30 s window takes that, up to
//! 12 m, where it is above the learnt noise (`TrackCheck::gnss_noise`).
//!
//! # The position windows' decision
//! `z = |e| / sigma(L)`. For a two-dimensional Gaussian `e`, `P(z > c) = exp(-c^2)`; with about
//! `3600/10 + 3600/30 = 480` windows per hour, the threshold for a budget of `B` false alarms
//! per hour is `c = sqrt(ln(480 / B))` (B = 0.01: c = 3.29). A window is judged while the car
//! drives (wheel speed over `min_speed_mps`, and at least half the window's length at that
//! speed covered). It fires when `z > c` holds for `persist_s`; when both windows are above `c`
//! and the 10 s one above `2c` for `fast_persist_s`; or at once when the 10 s window is above
//! `4c` and the 30 s one above `c` (a jump). Where the learnt noise makes the windows blind to
//! drifts below `max_bound_mps` within 10 s, they do not judge and say so (`uninformative`);
//! so does a frame that has not aligned after `give_up_s` of driving.
//!
//! # Gaps
//! A GNSS gap of up to [`MAX_BRIDGE_S`] is bridged by the DR alone when the gyro and the
//! synchroniser's integrals of wheel speed and yaw rate across it are valid: a window that
//! starts inside the gap starts at its first edge instead, so a jump hidden in the gap is judged
//! at the first fix after it, with the gap's extra variance; such windows are judged, never
//! learnt from. Without a gyro the DR heading is the GNSS track's own: a rotated track is then
//! invisible, the along-track part is still checked, and a gap restarts the windows; the chord
//! across the gap is still checked against the wheels' distance (`gap_jump`). Time going
//! backwards, an invalid sample or a longer gap starts the windows and the frame over; what was
//! learnt about the car is kept unless the detector restarts it.

pub mod calibration;
mod config;
mod history;
mod noise;
mod outcome;
mod plane;
mod rotation;
pub mod velocity;

use self::calibration::{Calibration, Record, Source, DELAYS, DELAY_MIN_S, DELAY_STEP_S};
use self::history::{Entry, History, MAX_STEP_S};
use self::noise::{NoiseFits, NOISE_SPLIT_MPS};
use self::plane::{cis, cmul, conj, norm2, scale2, sub};
use self::rotation::{wrap_pi, Rotation, MAX_BIAS_DEGPS};
pub use self::config::{TrackConfig, WINDOWS_S};
pub use self::outcome::{HeadingSource, TrackOutcome, WindowOutcome};
use self::velocity::{VelocityOutcome, VelocityTest, ACROSS};
use crate::geo::{to_local, LatLon, EARTH_RADIUS_PAPER_M};
use crate::sample::Sample;

/// Enough history for the longest window and delay, with a margin.
const SPAN_NEEDED_S: f64 = 30.0 + 3.0 + 0.5;
/// The local frame's origin follows the car every this many metres (keeps the flat-earth
/// error of a 30 s window under 0.2 m).
const REBASE_M: f32 = 1000.0;
/// Below this the car stands: the gyro reads its bias, m/s.
const STANDING_MPS: f32 = 0.1;
/// Windows shorter than this (metres driven) teach nothing about rotation.
const MIN_LEARN_DIST_M: f32 = 30.0;
/// Faster than any car, m/s: a wheel-speed integral beyond it is a sensor fault.
const MAX_SPEED_MPS: f32 = 150.0;
/// A GNSS gap up to this long is bridged by the dead reckoning when the synchroniser's
/// integrals of wheel speed and yaw rate span it (a spoofer can cause a gap: the track on the
/// other side is still compared with where the car went), seconds.
pub const MAX_BRIDGE_S: f64 = 60.0;
/// Across a gap the DR cannot bridge: the sustained lateral acceleration no car exceeds at
/// speed, m/s^2; the GNSS error at both ends, metres; the wheels' scale and timing error.
const GAP_LAT_MPS2: f32 = 5.0;
const GAP_ERR_M: f32 = 25.0;
const GAP_SCALE_TOL: f32 = 0.05;
/// The GNSS's own position noise over the 30 s window (see `TrackCheck::gnss_noise`): at most
/// this much, metres, is taken as noise; it rises with this time constant and falls with the
/// second, seconds.
const GNSS_NOISE_CAP_M: f32 = 12.0;
const GNSS_NOISE_RISE_S: f32 = 5.0;
const GNSS_NOISE_FALL_S: f32 = 30.0;
/// The span of a velocity pair, seconds: the receiver's velocity against the DR's over this
/// much centred on it, or both displacements over this much.
const PAIR_S: f32 = 1.0;
/// Velocity pairs judged per epoch at most (a backlog, see `next_pair`, is caught up), and
/// how far behind the newest ready entry a pair may be, seconds (older ones are skipped).
const PAIRS_PER_EPOCH: usize = 2;
const PAIR_BACKLOG_S: f32 = 2.0;
/// A pair whose DR second would end at most this long after the newest epoch is judged now,
/// seconds, on the DR's newest second carried forward at its change since the second before
/// (see `pair`); the DR's change of acceleration since the pair before, times the shift, is
/// added to the pair's variance (the carried second's error). At a 1 Hz epoch rate the DR
/// between epochs is an interpolation anyway, and waiting for the shift's share of the next
/// step cost a whole second: a receiver's velocity centred 0.38 s late (css_canedge) needs the
/// DR to 0.12 s past its fix, and a logger's 1 Hz fixes stamped 0.96 s apart under vehicle
/// signals 1 s late (sddi_commuter) need it 0.04 s past the next. At 10 Hz the newest fix is
/// judged before the history (one entry per 0.19 s) overwrites it.
const PAIR_EARLY_S: f32 = 0.5;
/// Calibration pairs are taken at most this often, seconds (their cost is one pair per delay
/// candidate).
const LEARN_EVERY_S: f32 = 0.45;
/// The DR grid a calibration pair needs (every delay candidate's pair, position and velocity):
/// from `-DELAY_MIN_S + PAIR_S` before the pair to `-DELAY_MIN_S + PAIR_S / 2` after it.
const GRID: usize = DELAYS + 12;
/// The grid points where candidate 0's position pair and velocity pair end.
const GRID_POS_END: usize = DELAYS + 7;
const GRID_VEL_END: usize = DELAYS + 11;
/// Grid points per pair.
const GRID_PAIR: usize = 8;

/// What the check kept of the previous epoch.
#[derive(Clone, Copy, Debug)]
struct Last {
    t: f64,
    wheel: f32,
    yaw: Option<f32>,
}

/// One position window computed at one epoch, before the decision.
#[derive(Clone, Copy, Debug)]
struct Window {
    /// GNSS displacement, and the DR displacement at the delay in use.
    g: (f32, f32),
    d: (f32, f32),
    l: f32,
    /// The window's error `G - s e^{i theta} D`, and its squared length.
    e: (f32, f32),
    e2: f32,
    /// The learnt noise, and with the rotation's uncertainty (and a bridged gap's).
    var0: f32,
    var: f32,
    /// The window spans a bridged gap: it is judged, nothing is learnt from it.
    bridged: bool,
    z: f32,
    /// The 30 s window's: the receiver's position against its own velocity over the window,
    /// squared, m^2 (NaN where it reports none, and for the 10 s window).
    gnss_e2: f32,
}

/// A velocity pair: the GNSS velocity and the DR's, m/s, and the seconds it covers.
#[derive(Clone, Copy, Debug)]
struct Pair {
    t: f32,
    g: (f32, f32),
    d: (f32, f32),
    /// The receiver reported the velocity (else it is a position difference).
    reported: bool,
    /// How much earlier than the delay says the DR's second ends, seconds (see `pair`).
    early: f32,
}

/// The streaming track check. See the module documentation.
#[derive(Clone, Debug)]
pub struct TrackCheck {
    cfg: TrackConfig,
    c: f32,
    // The stretch since the last (re)start.
    hist: History,
    origin: Option<LatLon>,
    base_t: f64,
    dr: (f32, f32),
    /// Variance the DR took on across bridged gaps since the (re)start, m^2.
    dr_var: f32,
    psi: f32,
    aligned: bool,
    source: Option<HeadingSource>,
    last: Option<Last>,
    /// The epoch (its time) after a gap whose chord the wheels' distance contradicts.
    gap_jumped: Option<f64>,
    heading_anchor: Option<(f32, f32)>,
    above_since: [Option<f64>; 2],
    fast_since: Option<f64>,
    alarm: [bool; 2],
    /// The last velocity pair judged and the last one learnt from (stretch time).
    last_pair_t: f32,
    last_learn_t: f32,
    vel: VelocityTest,
    /// The previous pair's predicted velocity (its time, value): the DR's acceleration.
    last_pred: Option<(f32, (f32, f32))>,
    /// The DR's acceleration at the previous pair: its change is a carried pair's error.
    last_acc: (f32, f32),
    /// The last judged pair's across-track prediction variance from the delay's uncertainty
    /// (and a carried pair's shift), (m/s)^2: its course is that much less certain as a
    /// rotation measurement.
    last_delay_var_across: f32,
    /// When the velocity test last judged a pair (stretch time).
    last_judged_t: f32,
    /// Whether the velocity test's last pair this stretch was blind (`None`: no pair yet).
    vel_blind: Option<bool>,
    /// The receiver's reported velocity integrated, metres, since `vi_since` (stretch time;
    /// infinite while it reports none).
    vi: (f32, f32),
    vi_since: f32,
    /// The receiver's own position noise over the 30 s window, m^2: its position against the
    /// integral of its own velocity (multipath and trees move the position by metres, not the
    /// Doppler velocity; a position error correlated over tens of seconds is what fired that
    /// window in town). It rises within seconds where the GNSS gets worse, falls within half a
    /// minute, and is at most `GNSS_NOISE_CAP_M` squared. It is the GNSS's alone, so a spoofer
    /// who moves position and velocity together (every drift) does not move it; one who moves
    /// the position alone buys at most that much slack in the 30 s window, none in the 10 s
    /// window or the velocity test. The 10 s window does not use it: there it cost detections
    /// (a drift across the road at 4 m/s found within 10 s 13 -> 12 of 13 on css_canedge) and
    /// no false alarm needed it.
    gnss_noise: f32,
    // Learnt about the car (kept across short gaps).
    bias: f32,
    bias_weight: f32,
    rot: Rotation,
    cal: Calibration,
    noise: [NoiseFits; 2],
    /// The 10 s window's along-track error alone (what the velocity test's position
    /// differences sum to over its 10 s window): without a gyro the DR's direction is the GNSS
    /// bearing of the last metres and the across-track error is most of `|e|^2`. (The 30 and
    /// 60 s windows keep the 30 s window's whole error: with its along-track part alone, GNSS
    /// noise of 7.9 m correlated over 26 s fired the 60 s window in the nuisance suite.)
    noise_along: NoiseFits,
    learnt_s: f32,
    /// The quiet velocity noise (along, across), averaged while calm: the record's.
    quiet_sigma: [f32; 2],
    /// Seconds driven without judging since the (re)start.
    unjudged_s: f32,
    /// The record the drive started from (a power-up restarts from it).
    stored: Option<Record>,
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
            vel_blind: None,
            vi: (0.0, 0.0),
            vi_since: f32::INFINITY,
            gnss_noise: 0.0,
            bias: 0.0,
            bias_weight: 0.0,
            rot: Rotation::new(&cfg),
            cal: Calibration::new(cfg.cal),
            noise: [NoiseFits::default(); 2],
            noise_along: NoiseFits::default(),
            learnt_s: 0.0,
            unjudged_s: 0.0,
            stored: None,
        }
    }

    /// A check that starts from a car's stored calibration (see [`calibration`]); a record
    /// that is not plausible is ignored (the caller reports it).
    pub fn with_record(cfg: TrackConfig, r: &Record) -> Self {
        let mut c = TrackCheck::new(cfg);
        if r.plausible().is_err() {
            return c;
        }
        c.stored = Some(*r);
        c.load_stored();
        c
    }

    fn load_stored(&mut self) {
        let Some(r) = self.stored else { return };
        self.cal = Calibration::from_record(self.cfg.cal, &r);
        if r.gyro_bias_degps.is_finite() {
            self.bias = r.gyro_bias_degps.clamp(-2.0 * MAX_BIAS_DEGPS, 2.0 * MAX_BIAS_DEGPS);
            self.bias_weight = r.gyro_bias_weight_s.min(10.0);
        }
        self.rot = Rotation::with_scale(&self.cfg, r.gyro_scale_error, r.gyro_scale_sd);
        self.bound_bias_by_standstill();
        // The same receiver class: its noise carries over as the prior.
        if libm::fabsf(r.nominal_dt_s - self.cfg_dt()) < 0.5 * r.nominal_dt_s {
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

    /// The receiver class the configuration is for (its prior's epoch).
    fn cfg_dt(&self) -> f32 {
        if self.cfg.s0_prior_m < 4.0 { 0.1 } else { 1.0 }
    }

    /// What was learnt about the car, to keep for its next drive: `None` before it is
    /// calibrated, and when this drive contradicts the stored record (never silently
    /// relearnt: the stored one stays).
    pub fn record(&self) -> Option<Record> {
        if !self.cal.calibrated() || self.cal.contradiction().is_some() {
            return None;
        }
        let (scale, delay_s, learnt_s) = self.cal.record_base();
        let stored = self.stored;
        let (s2a, k2a) = self.noise_params(0);
        let (s2b, k2b) = self.noise_params(1);
        let whole_bias = self.bias - self.rot.omega().to_degrees();
        let gyro = self.source == Some(HeadingSource::Gyro) || self.bias_weight > 0.0;
        Some(Record {
            scale,
            delay_s,
            learnt_s,
            drives: stored.map_or(1, |r| r.drives.saturating_add(1)),
            gyro_bias_degps: if gyro { whole_bias } else { stored.map_or(f32::NAN, |r| r.gyro_bias_degps) },
            gyro_bias_weight_s: self.bias_weight,
            gyro_scale_error: self.rot.scale_error(),
            gyro_scale_sd: libm::sqrtf(self.rot.var_scale()),
            noise_s0_m: [libm::sqrtf(s2a), libm::sqrtf(s2b)],
            noise_k: [libm::sqrtf(k2a), libm::sqrtf(k2b)],
            velocity_sigma_mps: self.quiet_sigma,
            nominal_dt_s: self.cfg_dt(),
        })
        .filter(|r| r.plausible().is_ok())
    }

    /// The noise of window `wi`, `(s0^2, k^2)`: the car's own fit, blended with the receiver
    /// profile's prior while the fit has little data.
    fn noise_params(&self, wi: usize) -> (f32, f32) {
        self.fit_params(self.noise.get(wi))
    }

    /// The 10 s window's along-track noise, `(s0^2, k^2)` (the same prior: the receiver's stated
    /// accuracy, both axes).
    fn noise_params_along(&self) -> (f32, f32) {
        self.fit_params(Some(&self.noise_along))
    }

    fn fit_params(&self, nf: Option<&NoiseFits>) -> (f32, f32) {
        let c = self.cfg;
        let prior = (2.0 * c.s0_prior_m * c.s0_prior_m, c.k_prior * c.k_prior);
        let Some(nf) = nf else { return prior };
        let w_p = c.prior_weight_s * libm::expf(-self.learnt_s / c.prior_weight_s.max(1.0));
        nf.blended(prior, w_p)
    }

    /// The time constant of the noise learning: growing with what was learnt.
    fn learn_tau(&self) -> f32 {
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
    fn gain(&self) -> (f32, f32) {
        let s = self.cal.scale();
        match self.rot() {
            Some(rot) => scale2(cis(rot.theta()), s),
            None => (s, 0.0),
        }
    }

    /// The rotation's variance, rad^2 (none without a gyro: the DR heading is GNSS's own).
    fn rot_var(&self) -> f32 {
        self.rot().map_or(0.0, Rotation::var_theta)
    }

    /// Once standstills have measured the gyro's bias (here or on a stored drive), the
    /// rotation filter's residual bias is the driving bias's offset from it, not the power-up
    /// uncertainty: the frame's uncertainty then grows by that offset over a stretch without
    /// GNSS course (a stop, a slow crawl, a gap), not by half a degree a second.
    fn bound_bias_by_standstill(&mut self) {
        // The filter itself, not `rot_mut`: a stored record is loaded before the heading's
        // source is known.
        if self.bias_weight >= rotation::STANDSTILL_MEASURED_S {
            let sd = rotation::STANDSTILL_BIAS_SD_DEGPS.to_radians();
            self.rot.bound_omega_var(sd * sd);
        }
    }

    /// The rotation filter of this stretch's heading source (none when GNSS is the heading).
    fn rot(&self) -> Option<&Rotation> {
        (self.source == Some(HeadingSource::Gyro)).then_some(&self.rot)
    }

    fn rot_mut(&mut self) -> Option<&mut Rotation> {
        (self.source == Some(HeadingSource::Gyro)).then_some(&mut self.rot)
    }

    /// The DR position at time `t` (the newest when `t` is now or later).
    fn dr_at(&self, t: f32, now: f32) -> Option<Entry> {
        if t >= now - 1e-4 {
            return self.hist.back().copied();
        }
        self.hist.at(t)
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
            self.gap_jumped = gap.is_some_and(|gp| self.gap_jump(s, g, gp, wheel)).then_some(s.t);
            self.restart();
            return self.step(s);
        }
        self.source = Some(source);
        let t = self.advance(s, g, wheel, yaw);
        let mut out = TrackOutcome { learning: true, ..Default::default() };
        if self.aligned {
            self.judge_and_learn(s, t, wheel, &mut out);
        }
        out.scale = self.cal.scale();
        out.heading = source;
        out.rotation_deg = self.rot().map_or(0.0, |r| r.theta().to_degrees());
        out.rotation_sd_deg = libm::sqrtf(self.rot_var()).to_degrees();
        out.turn_scale = self.rot().map_or(1.0, |r| 1.0 + r.scale_error());
        out.gyro_bias_degps = match (source, self.rot()) {
            (HeadingSource::Gyro, Some(r)) => self.bias - r.omega().to_degrees(),
            _ => 0.0,
        };
        out.delay_s = self.cal.delay_s(Source::Position);
        out.delay_velocity_s = self.cal.record_base().1[1];
        out.delay_free_s = self.cal.free_delay_s(Source::Position);
        out.calibrated = self.cal.calibrated();
        out.learning |= !out.calibrated;
        out.contradiction = self.cal.contradiction();
        if self.gap_jumped.take() == Some(s.t) {
            out.fired[0] = true;
            out.uninformative = false;
        }
        for wi in 0..WINDOWS_S.len() {
            let (s2, k2) = self.noise_params(wi);
            if let (Some(a), Some(b)) = (out.noise_s0_m.get_mut(wi), out.noise_k.get_mut(wi)) {
                *a = libm::sqrtf(s2);
                *b = libm::sqrtf(k2);
            }
        }
        Some(out)
    }

    /// A gap the DR cannot bridge (no gyro, or longer than [`MAX_BRIDGE_S`]) still bounds the
    /// GNSS displacement across it by the wheels' distance `w`: the chord is never longer than
    /// the path, and never shorter than a circular arc turning at [`GAP_LAT_MPS2`] all the way
    /// (a car at speed cannot turn tighter; heading change `psi <= a * gap / v`, chord `>= w
    /// sinc(psi / 2)`). Judged with [`GAP_ERR_M`] and [`GAP_SCALE_TOL`] of slack, only where the
    /// epoch's distance spans the gap. A jump hidden in the gap fires the 10 s window's flag.
    #[inline(never)]
    fn gap_jump(&self, s: &Sample, g: (f32, f32), gap: f64, wheel: f32) -> bool {
        let (Some(e), Some(last), Some(w)) = (self.hist.back(), self.last, s.dist_m.get()) else { return false };
        let gap = gap as f32;
        if !(libm::fabsf(s.dt_s - gap) < 0.5 && (0.0..=MAX_SPEED_MPS * gap).contains(&w)) {
            return false;
        }
        let w = w * self.cal.scale();
        let (dx, dy) = (g.0 - e.g.0, g.1 - e.g.1);
        let chord = libm::sqrtf(dx * dx + dy * dy);
        let slack = GAP_ERR_M + GAP_SCALE_TOL * w;
        let v = if last.wheel < wheel { last.wheel } else { wheel };
        let v = if w / gap < v { w / gap } else { v };
        // sin(h) / h >= 1 - h^2 / 6 for every h (and below zero, no bound, once a U-turn fits;
        // a car standing gives h = inf: no bound).
        let half = 0.5 * GAP_LAT_MPS2 * gap / v;
        let least = w * (1.0 - half * half * (1.0 / 6.0));
        chord > w + slack || chord < least - slack
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
        // epoch when the wheels stood at both). No GNSS is involved: a spoofer cannot teach it.
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
            // (`omega`); the innovation is against that whole.
            let whole = self.bias - self.rot().map_or(0.0, |r| r.omega().to_degrees());
            self.bias += (mean.clamp(-MAX_BIAS_DEGPS, MAX_BIAS_DEGPS) - whole) * k;
            self.bias = if self.bias.is_finite() { self.bias.clamp(-2.0 * MAX_BIAS_DEGPS, 2.0 * MAX_BIAS_DEGPS) } else { 0.0 };
            self.bound_bias_by_standstill();
        }
        // The DR heading: the gyro's integral (the synchroniser's, exact at any epoch rate; else
        // a trapezoid), or the GNSS track's own bearing.
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
            // heading. No car covers more than MAX_SPEED_MPS: a larger integral is a fault.
            let dist = s.dist_m.get().filter(|x| x.is_finite()).unwrap_or(0.5 * (l.wheel + wheel) * dt).max(0.0).min(MAX_SPEED_MPS * dt.max(0.0) + 1.0);
            let half = 0.5 * turn;
            let chord = if libm::fabsf(half) > 1e-4 { dist * libm::sinf(half) / half } else { dist };
            let mid = self.psi + half;
            self.dr.0 += chord * libm::cosf(mid);
            self.dr.1 += chord * libm::sinf(mid);
            if (dt as f64) > MAX_STEP_S {
                // Across a bridged gap the turn need not have been steady, and no GNSS corrects
                // the gyro meanwhile. Nor need it have been one bend: the turning undone within
                // the gap (`min` of left and right, from the yaw rate's magnitude), a heading
                // that rose to it and fell back, moves the end sideways by up to half of it
                // times the distance, which one arc of the net turn does not see (an S-bend
                // in a 12 s outage on css_canedge: 34 m off a 149 m chord).
                let undone = s.turn_abs_deg.get().zip(s.turn_deg.get()).map_or(0.0, |(a, r)| 0.5 * (a - libm::fabsf(r)));
                let undone = if undone.is_finite() { undone.clamp(0.0, 180.0).to_radians() } else { 0.0 };
                let sd = chord * (libm::fabsf(half) + 0.5 * undone) / 1.732;
                let drift = chord * (0.5 * c.gap_gyro_sd_degps * dt).to_radians();
                self.dr_var += sd * sd + drift * drift;
            }
        }
        self.psi = wrap_pi(self.psi + turn);
        // The origin follows the car.
        let mut g = g;
        if norm2(g) > REBASE_M * REBASE_M {
            let shift = g;
            self.hist.shift_g(shift);
            if let Some(a) = self.heading_anchor.as_mut() {
                *a = sub(*a, shift);
            }
            if let Some(o) = self.origin {
                self.origin = Some(crate::geo::from_local(o, shift.0 as f64, shift.1 as f64, EARTH_RADIUS_PAPER_M));
            }
            g = (0.0, 0.0);
        }
        self.last = Some(Last { t: s.t, wheel, yaw });
        // The receiver's velocity (east, north) where it reports speed and course.
        let v = match (s.gnss_speed.get(), s.gnss_course.get()) {
            (Some(sp), Some(co)) if sp.is_finite() && co.is_finite() && libm::fabsf(sp) < MAX_SPEED_MPS => {
                let b = co.to_radians();
                (sp * libm::sinf(b), sp * libm::cosf(b))
            }
            _ => (f32::NAN, f32::NAN),
        };
        // The reported velocity's integral: a new stretch of it where a velocity is missing or
        // the step is longer than consecutive epochs'.
        let prev = self.hist.back().copied();
        match prev {
            Some(p) if p.has_velocity() && v.0.is_finite() && v.1.is_finite() && ((t - p.t) as f64) <= MAX_STEP_S && self.vi_since.is_finite() => {
                let h = 0.5 * (t - p.t);
                self.vi = (self.vi.0 + (p.v.0 + v.0) * h, self.vi.1 + (p.v.1 + v.1) * h);
            }
            _ if v.0.is_finite() && v.1.is_finite() => {
                self.vi = (0.0, 0.0);
                self.vi_since = t;
            }
            _ => self.vi_since = f32::INFINITY,
        }
        self.hist.push(Entry { t, g, d: self.dr, u: self.dr_var, v, vi: self.vi });
        t
    }

    /// The position window `wi` ending at this epoch, at the delay in use, before any
    /// decision. With the GNSS late (`tau > 0`) the DR window ends `tau` before now; with the
    /// vehicle signals late the GNSS window ends `-tau` before now.
    fn window(&self, t: f32, wi: usize, gnss_acc_var: f32) -> Option<Window> {
        let win = *WINDOWS_S.get(wi)?;
        let oldest = self.hist.front().map_or(t, |e| e.t);
        if ((t - oldest) as f64) < (win as f64 + 3.0 + 0.2).min(SPAN_NEEDED_S) {
            return None;
        }
        let tau = self.cal.delay_s(Source::Position);
        let t_end = t - (-tau).max(0.0);
        // A window whose start falls inside a bridged GNSS gap starts at the gap's first edge
        // instead (it spans the whole gap), so a jump hidden in the gap is judged at the first
        // fix after it, not a window's length later.
        let ts = self.hist.gap_edge(t_end - win).unwrap_or(t_end - win);
        let start = self.hist.at(ts)?;
        let end = self.dr_at(t_end, t)?;
        let g = sub(end.g, start.g);
        let d = sub(self.dr_at(t_end - tau, t)?.d, self.hist.at(ts - tau)?.d);
        let extra = (self.dr_var - start.u).max(0.0);
        let l = libm::sqrtf(norm2(d));
        let e = sub(g, cmul(self.gain(), d));
        let e2 = norm2(e);
        let (s2, k2) = self.noise_params(wi);
        let var0 = s2.max(gnss_acc_var) + k2 * l * l;
        // The GNSS's own noise where it is above what was learnt (see `gnss_noise`).
        let own = if wi == 0 { 0.0 } else { self.gnss_noise - s2.max(gnss_acc_var) };
        let var = var0 + own.max(0.0) + self.rot_var() * l * l + extra;
        if !(l.is_finite() && e2.is_finite() && var.is_finite()) {
            return None;
        }
        let z = if var > 0.0 { libm::sqrtf(e2 / var) } else { 0.0 };
        // Over the window's own entries: shifting the velocity by its learnt lag against the
        // position took two more history searches per epoch and changed no figure of `eval`
        // (3 of 817 scenarios' verdict streams).
        let gnss_e2 = if wi == 1 && ts >= self.vi_since { norm2(sub(g, sub(end.vi, start.vi))) } else { f32::NAN };
        Some(Window { g, d, l, e, e2, var0, var, bridged: extra > 0.0, z, gnss_e2 })
    }

    /// The velocity pair of history entry `e`, the DR's velocity taken `tau` earlier: the
    /// receiver's velocity against the DR's over a second centred on it, or both position
    /// differences over the second before it. Where that second ends after the newest epoch
    /// (`now`; by `early`, at most [`PAIR_EARLY_S`], see `next_pair`), the DR's newest second
    /// is carried forward by `early` at its change since the second before (a steady turn or
    /// braking is then exact: the newest second alone was off by the acceleration times
    /// `early`, the same way at every pair of a bend, which a window adds up). `None` across a
    /// bridged gap.
    fn pair(&self, e: Entry, tau: f32, now: f32) -> Option<Pair> {
        let lead = if e.has_velocity() { 0.5 * PAIR_S } else { 0.0 };
        let end = e.t - tau + lead;
        let early = if end > now { end - now } else { 0.0 };
        let g = if e.has_velocity() {
            e.v
        } else {
            let s = self.hist.at(e.t - PAIR_S)?;
            scale2(sub(e.g, s.g), 1.0 / PAIR_S)
        };
        let end = end - early;
        let (d0, d1) = (self.dr_at(end - PAIR_S, now)?, self.dr_at(end, now)?);
        if d1.u != d0.u {
            return None;
        }
        let mut d = sub(d1.d, d0.d);
        if early > 0.0 {
            let before = self.dr_at(end - 2.0 * PAIR_S, now).filter(|b| b.u == d0.u)?;
            let change = sub(d, sub(d0.d, before.d));
            d = (d.0 + change.0 * early / PAIR_S, d.1 + change.1 * early / PAIR_S);
        }
        Some(Pair { t: e.t, g, d: scale2(d, 1.0 / PAIR_S), reported: e.has_velocity(), early })
    }

    /// The next velocity pair to judge: the oldest entry not judged yet whose DR velocity at
    /// the delay in use is known by now, or would be within [`PAIR_EARLY_S`], and not older
    /// than [`PAIR_BACKLOG_S`] before that limit. Oldest first: with the vehicle signals late,
    /// a 1 Hz fix often becomes ready only with the next one, and taking the newest would drop
    /// every other fix.
    fn next_pair(&mut self, t: f32) -> Option<Pair> {
        let reported = self.hist.back().is_some_and(Entry::has_velocity);
        let tau = self.cal.delay_s(if reported { Source::Velocity } else { Source::Position });
        let lead = if reported { 0.5 * PAIR_S } else { 0.0 };
        let limit = t.min(t + tau - lead + PAIR_EARLY_S);
        let e = self.hist.oldest_between(self.last_pair_t.max(limit - PAIR_BACKLOG_S), limit)?;
        self.last_pair_t = e.t;
        self.pair(e, tau, t)
    }

    /// The velocity test's residuals of a pair: (along, across), each with the prediction's
    /// own variance; `None` where the channel is not judged (too slow; across without a gyro).
    ///
    /// The prediction's variance: the scale's uncertainty times the speed, the frame rotation's
    /// times the speed (across), and the delay's times the DR's acceleration along and across
    /// (a delay known to 0.1 s is 0.2 m/s wrong while braking at 2 m/s^2), a carried pair's
    /// change of acceleration times its shift (see `pair`), and the wheel speed's rounding,
    /// `rounding` ((m/s)^2), along.
    fn residuals(&mut self, p: &Pair, rounding: f32) -> [Option<(f32, f32)>; 2] {
        let vc = self.cfg.velocity;
        let sd = self.cal.scale_sd(self.quiet_sigma[0], vc.kappa_s);
        let pred = match self.rot() {
            Some(_) => cmul(self.gain(), p.d),
            None => scale2(p.d, self.cal.scale()),
        };
        // The DR's acceleration since the previous pair (none across a longer pause).
        let acc = match self.last_pred {
            Some((t0, p0)) if p.t > t0 && p.t - t0 <= 2.0 => scale2(sub(pred, p0), 1.0 / (p.t - t0)),
            _ => (0.0, 0.0),
        };
        self.last_pred = Some((p.t, pred));
        // A pair carried forward by `early` (see `pair`) is off by the acceleration's change
        // times it.
        let jerk = scale2(sub(acc, self.last_acc), p.early);
        self.last_acc = acc;
        let sp = libm::sqrtf(norm2(pred));
        if sp.is_nan() || sp < if p.reported { velocity::MIN_SPEED_REPORTED_MPS } else { vc.min_speed_mps } {
            return [None, None];
        }
        let u = scale2(pred, 1.0 / sp);
        let tau_sd = self.cal.delay_sd_s(if p.reported { Source::Velocity } else { Source::Position }, self.quiet_sigma[0], vc.kappa_s);
        let a_along = acc.0 * u.0 + acc.1 * u.1;
        let a_across = u.0 * acc.1 - u.1 * acc.0;
        let (j_along, j_across) = (jerk.0 * u.0 + jerk.1 * u.1, u.0 * jerk.1 - u.1 * jerk.0);
        let va = (sd * sp) * (sd * sp) + (a_along * tau_sd) * (a_along * tau_sd) + j_along * j_along + rounding;
        self.last_delay_var_across = (a_across * tau_sd) * (a_across * tau_sd) + j_across * j_across;
        match self.rot() {
            Some(rot) => {
                let r = sub(p.g, pred);
                let along = r.0 * u.0 + r.1 * u.1;
                let across = u.0 * r.1 - u.1 * r.0;
                let vc_ = rot.var_theta() * sp * sp + self.last_delay_var_across;
                [Some((along, va)), (sp >= vc.min_speed_across_mps && self.aligned_frame()).then_some((across, vc_))]
            }
            None => [Some((libm::sqrtf(norm2(p.g)) - sp, va)), None],
        }
    }

    fn judge_and_learn(&mut self, s: &Sample, t: f32, wheel: f32, out: &mut TrackOutcome) {
        let c = self.cfg;
        let dt = (s.dt_s as f64).min(3.0) as f32;
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let acc = s.gnss_h_acc.get().filter(|a| a.is_finite() && *a > 0.0).map_or(0.0, |a| 2.0 * a * a);
        let wins = [self.window(t, 0, acc), self.window(t, 1, acc)];
        if let Some(y) = wins[1].map(|w| w.gnss_e2).filter(|y| y.is_finite()) {
            let y = y.min(GNSS_NOISE_CAP_M * GNSS_NOISE_CAP_M);
            let k = (dt / if y > self.gnss_noise { GNSS_NOISE_RISE_S } else { GNSS_NOISE_FALL_S }).clamp(0.0, 1.0);
            self.gnss_noise += (y - self.gnss_noise) * k;
        }
        let moving = wheel >= c.min_speed_mps;
        // The position windows judge with a gyro only: without one the DR's direction is the
        // GNSS bearing of the last metres, an epoch late, so a sideways excursion of the
        // receiver (20 m for 10 s on the sddi_commuter motorway) is an error of the windows,
        // no gap can be bridged, and the along-track part is the velocity test's, which sees
        // it sooner.
        let judging = !self.warming() && self.aligned_frame() && self.rot().is_some();
        // The velocity test.
        // The position windows' learnt noise (10 s, and 30 s once a pair needs it): read once
        // per epoch, not per pair and window (nothing below changes it before `learn`).
        let noise0 = self.noise_params(0);
        let (mut noise1, mut along0) = (None, None);
        let mut vel: Option<(Pair, VelocityOutcome)> = None;
        // A wheel speed rounded to its resolution `q` is off by up to `q / 2` (uniform: variance
        // `q^2 / 12`) for as long as the speed holds: an along-track error a window shares.
        // It is each pair's error too (so a drift's pairs are not clipped against a noise
        // without it).
        let q = s.wheel_step_mps;
        let rounding = if q.is_finite() { (q * q / 12.0).clamp(0.0, 1.0) } else { 0.0 };
        self.vel.set_common_var([rounding, 0.0]);
        for _ in 0..PAIRS_PER_EPOCH {
            let Some(p) = (if c.velocity.enabled { self.next_pair(t) } else { None }) else { break };
            let r = self.residuals(&p, rounding);
            // A position difference's window carries its ends' error: the learnt noise of the
            // position window of its length (the 10 s one's along-track part; the 30 s one's
            // whole error for the longer: the receiver's wander is correlated over tens of
            // seconds, so a 10 s window's noise understates a minute's) at the distance its
            // pairs covered, floored by the receiver's own accuracy.
            let ends = (!p.reported).then(|| {
                let mut noise = [(0.0f32, 0.0f32); velocity::WINDOWS];
                for (e, win) in noise.iter_mut().zip(velocity::WINDOWS_S) {
                    let (s2, k2) = if win <= WINDOWS_S[0] { *along0.get_or_insert_with(|| self.noise_params_along()) } else { *noise1.get_or_insert_with(|| self.noise_params(1)) };
                    *e = (s2.max(acc), k2);
                }
                velocity::Ends { noise, speed_mps: libm::sqrtf(norm2(p.d)) }
            });
            let mut o = self.vel.observe(p.t, r, ends);
            // An earlier pair of this epoch that fired or raised suspicion still counts.
            if let Some((_, prev)) = vel {
                for (f, pf) in o.fired.iter_mut().zip(prev.fired) {
                    *f |= pf;
                }
                o.suspicious |= prev.suspicious;
                o.pairs = o.pairs.saturating_add(prev.pairs);
            }
            vel = Some((p, o));
        }
        out.velocity = vel.map(|v| v.1);
        // The slowest drift the position windows see within 10 s at 150 m driven.
        let (s2, k2) = noise0;
        let l = 150.0;
        out.bound_10s_mps = Some(self.c * libm::sqrtf(s2.max(acc) + (k2 + self.rot_var()) * l * l) / WINDOWS_S[0]);
        if moving && !judging {
            self.unjudged_s += dt;
        } else if judging {
            self.unjudged_s = 0.0;
        }
        let gave_up = self.unjudged_s >= c.give_up_s;
        let windows_blind = (judging || gave_up) && out.bound_10s_mps.is_some_and(|b| b > c.max_bound_mps);
        // The velocity test cannot tell either when its noise hides drifts under the same bound:
        // it then says so (blind, so uninformative) and raises no suspicion, but a channel whose
        // noise is settled still fires: its statistic is in units of that noise, so what it sees
        // beyond it is evidence. (A spoofer's onset is one large difference of a 1 Hz
        // position-only receiver's residual, which raised the noise past the bound and silenced
        // drifts of 5 to 9 m/s that the test had found: sddi_commuter, `eval`'s small-biased
        // scenarios.) A channel whose noise is still being measured, or catching up with a
        // receiver ten times worse than it assumed, does not: its units are not yet the noise.
        if let Some(v) = out.velocity.as_mut() {
            if v.bound_10s_mps > c.max_bound_mps {
                for (f, settled) in v.fired.iter_mut().zip(v.settled) {
                    *f &= settled;
                }
                if !v.fired.iter().any(|f| *f) {
                    v.suspicious = false;
                    v.blind = true;
                }
            }
        }
        let velocity_judged = out.velocity.is_some_and(|v| !v.blind);
        if let Some(v) = out.velocity {
            self.last_judged_t = if v.blind { f32::NEG_INFINITY } else { t };
            self.vel_blind = Some(v.blind);
        }
        // The check cannot tell: the windows are blind and the velocity test judged nothing
        // now, or the windows do not judge (warm-up, no gyro) and the velocity test's last pair
        // was blind.
        out.uninformative = windows_blind && !velocity_judged || !judging && self.vel_blind == Some(true);
        let mut above = [false; 2];
        let mut z = [0.0f32; 2];
        let live = judging && !windows_blind && moving;
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
        out.judging = out.windows.iter().any(Option::is_some) || (!windows_blind || velocity_judged) && t - self.last_judged_t <= 1.5 && moving;
        let any_above = above.iter().any(|a| *a);
        let suspicious = any_above || self.alarm.iter().any(|a| *a) || out.velocity.is_some_and(|v| v.suspicious);
        // Learning while nothing of the check judges: not the position windows (warm-up, no
        // gyro, frame not aligned) and not the velocity test (no pair this stretch). A car
        // without a gyro is judged by the velocity test alone: once calibrated it is running
        // (or, where its noise hides drifts, uninformative), not learning all drive.
        out.learning = !judging && !windows_blind && self.vel_blind.is_none();
        // Learning: only while driving, and (once calibrated) while nothing is suspicious; a
        // first drive's warm-up learns freely and says so.
        let free = !self.cal.calibrated() || self.warming();
        let before = self.cal.contradiction();
        let learns = moving && (free || !suspicious);
        if moving {
            // The calibration's pairs: learnt only when allowed; this drive's own estimate (the
            // contradiction test) always.
            self.learn_calibration(t, learns);
        }
        if learns {
            self.learn(dt, &wins, vel.map(|v| v.0));
            if let Some(v) = out.velocity {
                let k = (dt / 600.0).clamp(0.0, 1.0);
                for (q, s) in self.quiet_sigma.iter_mut().zip(v.sigma_mps) {
                    *q += (s - *q) * k;
                }
            }
        }
        out.contradiction_found = before.is_none() && self.cal.contradiction().is_some();
        if !any_above {
            self.alarm = [false; 2];
        }
    }

    fn learn(&mut self, dt: f32, wins: &[Option<Window>; 2], pair: Option<Pair>) {
        let c = self.cfg;
        let keep = libm::expf(-dt / self.learn_tau());
        let aligned = self.aligned_frame();
        let floors = (c.s0_floor_m, c.k_floor);
        let reported = self.hist.back().is_some_and(Entry::has_velocity);
        // The noise of each window (the rotation's uncertainty taken out), only in an aligned
        // frame.
        for (wi, w) in wins.iter().enumerate() {
            let Some(w) = w else { continue };
            let win = WINDOWS_S.get(wi).copied().unwrap_or(10.0);
            if aligned && !w.bridged && w.l >= c.judge_dist_m(win) {
                let excess = (w.var - w.var0).max(0.0);
                let y = (w.e2 - excess).max(0.0).min(9.0 * w.var0);
                let weight = dt / (w.var0 * w.var0).max(1e-6);
                let split = NOISE_SPLIT_MPS * win;
                if let Some(nf) = self.noise.get_mut(wi) {
                    nf.add(split, w.l * w.l, y, dt, weight, keep, floors);
                }
                // The 10 s window's along-track part, for the velocity test's position
                // differences (only a receiver that reports no velocity has them).
                if wi == 0 && !reported {
                    let along = (w.e.0 * w.d.0 + w.e.1 * w.d.1) / w.l;
                    self.noise_along.add(split, w.l * w.l, (along * along).min(9.0 * w.var0), dt, weight, keep, floors);
                }
            }
        }
        if aligned {
            self.learnt_s += dt;
        }
        // The rotation: from the judged pair's course where the receiver reports one (its
        // variance the across-track noise over the speed squared, for the seconds the pair
        // stands for), else from the 10 s window's angle.
        let sigma_c = self.vel.sigma()[ACROSS];
        let kappa = c.velocity.kappa_s;
        // The rotation learns at once from each measurement: its course for a second's worth
        // (variance for a second, correlated over kappa), or the 10 s window's angle. Delaying it
        // (so that a spoofer's course step is judged against the rotation from before it) was
        // tried: by 60 s the frame was too stale to judge by on every drive, by 10 s delayed and
        // held GNSS courses raised 74 false alarms in the nuisance suite. So is rolling the filter
        // back, at the first suspicious epoch, to a copy from 15 to 30 s before: css_canedge's
        // own frame moved by 1.2 deg a minute under a nuisance and the roll-back undid it (2
        // false alarms, seed 1). What bounds the learning is the filter's rates (`q_rotation`,
        // `q_bias`): a drift across the road is still partly learnt before the freeze, and the
        // bias taken keeps turning the DR after it (docs/evaluation.md, "What is not reached").
        let measured = match (pair, wins.first().copied().flatten()) {
            (Some(p), _) if p.reported && self.rot().is_some() => {
                let sp2 = norm2(p.d) * self.cal.scale() * self.cal.scale();
                (sp2 >= c.velocity.min_speed_across_mps * c.velocity.min_speed_across_mps).then(|| {
                    let gd = cmul(p.g, conj(p.d));
                    (libm::atan2f(gd.1, gd.0), (sigma_c * sigma_c * kappa / dt.max(0.05) + self.last_delay_var_across) / sp2)
                })
            }
            (_, Some(w)) if w.l >= MIN_LEARN_DIST_M && !w.bridged => {
                let gd = cmul(w.g, conj(w.d));
                Some((libm::atan2f(gd.1, gd.0), 0.5 * w.var0 / (w.l * w.l) * (WINDOWS_S[0] / dt.max(0.01))))
            }
            _ => None,
        };
        if let (Some((phi, r)), Some(rot)) = (measured, self.rot_mut()) {
            rot.update(phi, r, &c);
        }
    }

    /// One calibration pair: a history entry old enough that the DR velocity is known at every
    /// delay candidate, at most every [`LEARN_EVERY_S`]: the position's delay from its position
    /// difference, the velocity's from the reported velocity where there is one. The DR is
    /// sampled once on the candidates' grid.
    fn learn_calibration(&mut self, t: f32, learns: bool) {
        let limit = t + DELAY_MIN_S - 0.5 * PAIR_S;
        let Some(e) = self.hist.newest_between(self.last_learn_t + LEARN_EVERY_S, limit) else { return };
        let dt = (e.t - self.last_learn_t).clamp(0.05, 1.0);
        self.last_learn_t = e.t;
        // Grid point j is at e.t + DELAY_MIN_S - PAIR_S + j/8 s: the position pair of candidate
        // k ends at point GRID_POS_END - k, the velocity pair at GRID_VEL_END - k, each
        // GRID_PAIR points long.
        let mut grid = [(0.0f32, 0.0f32); GRID];
        if !self.hist.dr_grid(e.t + DELAY_MIN_S - PAIR_S, DELAY_STEP_S, &mut grid) {
            return;
        }
        let Some(start) = self.hist.at(e.t - PAIR_S) else { return };
        let d_of = |k: usize, hi: usize| -> Option<(f32, f32)> {
            let (a, b) = (grid.get(hi.checked_sub(k + GRID_PAIR)?)?, grid.get(hi.checked_sub(k)?)?);
            Some(scale2(sub(*b, *a), 1.0 / PAIR_S))
        };
        // Only while driving at the delays in use.
        let cur = d_of(calibration::candidate(self.cal.delay_s(Source::Position)), GRID_POS_END).unwrap_or((0.0, 0.0));
        let v_min = self.cfg.velocity.min_speed_mps;
        if norm2(cur) < v_min * v_min {
            return;
        }
        let derot = self.rot().map_or((1.0, 0.0), |r| cis(-r.theta()));
        let gyro = self.rot().is_some();
        let (sigma, kappa) = (self.quiet_sigma[0], self.cfg.velocity.kappa_s);
        let learn = |src: Source, g: (f32, f32), hi: usize, cal: &mut Calibration| {
            let mut ds = [(0.0f32, 0.0f32); DELAYS];
            for (k, d) in ds.iter_mut().enumerate() {
                match d_of(k, hi) {
                    Some(x) => *d = x,
                    None => return,
                }
            }
            // Without a gyro the DR's direction is the GNSS bearing of the last metres, an epoch
            // late: only the speeds are compared (the direction would pull the delay toward it).
            let (g, derot) = if gyro {
                (g, derot)
            } else {
                let mag = |x: (f32, f32)| (libm::sqrtf(norm2(x)), 0.0);
                for d in ds.iter_mut() {
                    *d = mag(*d);
                }
                (mag(g), (1.0, 0.0))
            };
            if learns {
                cal.learn(src, g, &ds, derot, dt, sigma, kappa);
            }
            cal.learn_own(src, g, &ds, derot, dt, sigma, kappa);
        };
        learn(Source::Position, scale2(sub(e.g, start.g), 1.0 / PAIR_S), GRID_POS_END, &mut self.cal);
        if e.has_velocity() {
            learn(Source::Velocity, e.v, GRID_VEL_END, &mut self.cal);
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
