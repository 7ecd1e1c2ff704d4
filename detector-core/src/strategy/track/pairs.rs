//! Velocity pairs: each fix's GNSS velocity against the dead reckoning's at the learnt delay
//! (judged oldest first, carried forward when the DR is just short of it), their residuals
//! with the prediction's own variance for the velocity test, and the calibration's pairs over
//! every delay candidate.

use super::calibration::{self, Calibration, Source, DELAYS, DELAY_MIN_S, DELAY_STEP_S};
use super::history::Entry;
use super::plane::{cis, cmul, conj, norm2, scale2, sub};
use super::state::TrackCheck;
use super::velocity;

/// The span of a velocity pair, seconds: the receiver's velocity against the DR's over this
/// much centred on it (position differences span [`velocity::POSITION_SPAN_S`]; the
/// calibration's delay fits take both displacements over this much).
pub(super) const PAIR_S: f32 = 1.0;
/// Velocity pairs judged per epoch at most (a backlog, see `next_pair`, is caught up), and
/// how far behind the newest ready entry a pair may be, seconds (older ones are skipped).
pub(super) const PAIRS_PER_EPOCH: usize = 2;
pub(super) const PAIR_BACKLOG_S: f32 = 2.0;
/// A pair whose DR second would end at most this long after the newest epoch is judged now,
/// seconds, on the DR's newest second carried forward at its change since the second before
/// (see `pair`); the DR's change of acceleration since the pair before, times the shift, is
/// added to the pair's variance (the carried second's error). At a 1 Hz epoch rate the DR
/// between epochs is an interpolation anyway, and waiting for the shift's share of the next
/// step cost a whole second: a receiver's velocity centred 0.38 s late (css_canedge) needs the
/// DR to 0.12 s past its fix, and a logger's 1 Hz fixes stamped 0.96 s apart under vehicle
/// signals 1 s late (sddi_commuter) need it 0.04 s past the next. At 10 Hz the newest fix is
/// judged before the history (one entry per 0.19 s) overwrites it.
pub(super) const PAIR_EARLY_S: f32 = 0.5;
/// Calibration pairs are taken at most this often, seconds (their cost is one pair per delay
/// candidate).
pub(super) const LEARN_EVERY_S: f32 = 0.45;
/// The DR grid a calibration pair needs (every delay candidate's pair, position and velocity):
/// from `-DELAY_MIN_S + PAIR_S` before the pair to `-DELAY_MIN_S + PAIR_S / 2` after it.
pub(super) const GRID: usize = DELAYS + 12;
/// The grid points where candidate 0's position pair and velocity pair end.
pub(super) const GRID_POS_END: usize = DELAYS + 7;
pub(super) const GRID_VEL_END: usize = DELAYS + 11;
/// Grid points per pair.
pub(super) const GRID_PAIR: usize = 8;

/// A velocity pair: the GNSS velocity and the DR's, m/s, and the seconds it covers.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pair {
    pub(super) t: f32,
    pub(super) g: (f32, f32),
    pub(super) d: (f32, f32),
    /// The receiver reported the velocity (else it is a position difference).
    pub(super) reported: bool,
    /// How much earlier than the delay says the DR's second ends, seconds (see `pair`).
    pub(super) early: f32,
}

impl TrackCheck {
    /// The velocity pair of history entry `e`, the DR's velocity taken `tau` earlier: the
    /// receiver's velocity against the DR's over a second centred on it, or both position
    /// differences over the [`velocity::POSITION_SPAN_S`] before it. Where that span ends after
    /// the newest epoch (`now`; by `early`, at most [`PAIR_EARLY_S`], see `next_pair`), the DR's
    /// span is carried forward by `early` at its newest second's change since the second
    /// before, times the span (a steady turn or braking is then exact: the newest span alone
    /// was off by the acceleration times `early`, the same way at every pair of a bend, which a
    /// window adds up). `None` across a bridged gap.
    pub(super) fn pair(&self, e: Entry, tau: f32, now: f32) -> Option<Pair> {
        let lead = if e.has_velocity() { 0.5 * PAIR_S } else { 0.0 };
        let end = e.t - tau + lead;
        let early = if end > now { end - now } else { 0.0 };
        let span = if e.has_velocity() { PAIR_S } else { velocity::POSITION_SPAN_S };
        let g = if e.has_velocity() {
            e.v
        } else {
            let s = self.hist.at(e.t - span)?;
            scale2(sub(e.g, s.g), 1.0 / span)
        };
        let end = end - early;
        let (d0, d1) = (self.dr_at(end - span, now)?, self.dr_at(end, now)?);
        if d1.u != d0.u {
            return None;
        }
        let mut d = sub(d1.d, d0.d);
        if early > 0.0 {
            let mid = if span > PAIR_S { self.dr_at(end - PAIR_S, now).filter(|b| b.u == d0.u)? } else { d0 };
            let before = self.dr_at(end - 2.0 * PAIR_S, now).filter(|b| b.u == d0.u)?;
            let change = sub(sub(d1.d, mid.d), sub(mid.d, before.d));
            let f = early * span / (PAIR_S * PAIR_S);
            d = (d.0 + change.0 * f, d.1 + change.1 * f);
        }
        Some(Pair { t: e.t, g, d: scale2(d, 1.0 / span), reported: e.has_velocity(), early })
    }

    /// The next velocity pair to judge: the oldest entry not judged yet whose DR velocity at
    /// the delay in use is known by now, or would be within [`PAIR_EARLY_S`], and not older
    /// than [`PAIR_BACKLOG_S`] before that limit. Oldest first: with the vehicle signals late,
    /// a 1 Hz fix often becomes ready only with the next one, and taking the newest would drop
    /// every other fix.
    pub(super) fn next_pair(&mut self, t: f32) -> Option<Pair> {
        let reported = self.hist.back().is_some_and(Entry::has_velocity);
        let tau = self.cal.delay_s(if reported { Source::Velocity } else { Source::Position });
        let lead = if reported { 0.5 * PAIR_S } else { 0.0 };
        let limit = t.min(t + tau - lead + PAIR_EARLY_S);
        let e = self.hist.oldest_between(self.last_pair_t.max(limit - PAIR_BACKLOG_S), limit)?;
        self.last_pair_t = e.t;
        self.pair(e, tau, t)
    }

    /// The velocity test's residuals of a pair: (along, across), each with the prediction's
    /// own variance; `None` where the channel is not judged (too slow; across without a gyro;
    /// neither where the pair turned the DR around: the car reverses, see `travel`; without a
    /// gyro the DR's direction is the GNSS track's own).
    ///
    /// The prediction's variance: the scale's uncertainty times the speed, the frame rotation's
    /// times the speed (across), and the delay's times the DR's acceleration along and across
    /// (a delay known to 0.1 s is 0.2 m/s wrong while braking at 2 m/s^2), a carried pair's
    /// change of acceleration times its shift (see `pair`), and the wheel speed's rounding,
    /// `rounding` ((m/s)^2), along.
    pub(super) fn residuals(&mut self, p: &Pair, rounding: f32) -> [Option<(f32, f32)>; 2] {
        let vc = self.cfg.velocity;
        let sd = self.cal.scale_sd(self.quiet_sigma[0], vc.kappa_s);
        let pred = match self.rot() {
            Some(_) => cmul(self.gain(), p.d),
            None => scale2(p.d, self.cal.scale()),
        };
        if self.rot().is_some() && !self.travel.pair(p.g, pred, &mut self.hist, &mut self.dr) {
            self.last_pred = None;
            return [None, None];
        }
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
        let sp = gnss_guard_dsp::sqrtf(norm2(pred));
        if sp.is_nan() || sp < if p.reported { velocity::MIN_SPEED_REPORTED_MPS } else { vc.min_speed_mps } {
            return [None, None];
        }
        let u = scale2(pred, 1.0 / sp);
        let tau_sd = self.cal.delay_sd_s(if p.reported { Source::Velocity } else { Source::Position }, self.quiet_sigma[0], vc.kappa_s);
        // Along and across the predicted track: `x conj(u)`.
        let ((a_along, a_across), (j_along, j_across)) = (cmul(acc, conj(u)), cmul(jerk, conj(u)));
        let va = (sd * sp) * (sd * sp) + (a_along * tau_sd) * (a_along * tau_sd) + j_along * j_along + rounding;
        self.last_delay_var_across = (a_across * tau_sd) * (a_across * tau_sd) + j_across * j_across;
        match self.rot() {
            Some(rot) => {
                let (along, across) = cmul(sub(p.g, pred), conj(u));
                let vc_ = rot.var_theta() * sp * sp + self.last_delay_var_across;
                [Some((along, va)), (sp >= vc.min_speed_across_mps && self.aligned_frame()).then_some((across, vc_))]
            }
            None => [Some((gnss_guard_dsp::sqrtf(norm2(p.g)) - sp, va)), None],
        }
    }

    /// One calibration pair: a history entry old enough that the DR velocity is known at every
    /// delay candidate, at most every [`LEARN_EVERY_S`]: the position's delay from its position
    /// difference, the velocity's from the reported velocity where there is one. The DR is
    /// sampled once on the candidates' grid.
    pub(super) fn learn_calibration(&mut self, t: f32, learns: bool) {
        let limit = t + DELAY_MIN_S - 0.5 * PAIR_S;
        let Some(e) = self.hist.newest_between(self.last_learn_t + LEARN_EVERY_S, limit) else { return };
        let dt = (e.t - self.last_learn_t).clamp(0.05, 1.0);
        self.last_learn_t = e.t;
        let learns = learns && e.t - velocity::POSITION_SPAN_S > self.last_gross_t;
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
                let mag = |x: (f32, f32)| (gnss_guard_dsp::sqrtf(norm2(x)), 0.0);
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
}
