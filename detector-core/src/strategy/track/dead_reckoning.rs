//! Dead reckoning: the wheel speed and yaw rate integrated into the history each epoch (the
//! frame, its rebasing, bridged gaps), and the bound on a gap the dead reckoning cannot bridge.

use super::calibration::Source;
use super::history::{Entry, MAX_STEP_S};
use super::plane::{norm2, sub};
use super::rotation::{wrap_pi, MAX_BIAS_DEGPS};
use super::state::{Last, TrackCheck};
use crate::geo::EARTH_RADIUS_PAPER_M;
use crate::sample::Sample;

/// Enough history for the longest window and delay, with a margin.
pub(super) const SPAN_NEEDED_S: f64 = 30.0 + 3.0 + 0.5;
/// The local frame's origin follows the car every this many metres (keeps the flat-earth
/// error of a 30 s window under 0.2 m).
pub(super) const REBASE_M: f32 = 1000.0;
/// Below this the car stands: the gyro reads its bias, m/s.
pub(super) const STANDING_MPS: f32 = 0.1;
/// Faster than any car, m/s: a wheel-speed integral beyond it is a sensor fault.
pub(super) const MAX_SPEED_MPS: f32 = 150.0;
/// A GNSS gap up to this long is bridged by the dead reckoning when the synchroniser's
/// integrals of wheel speed and yaw rate span it (a spoofer can cause a gap: the track on the
/// other side is still compared with where the car went), seconds.
pub const MAX_BRIDGE_S: f64 = 60.0;
/// Across a gap the DR cannot bridge: the sustained lateral acceleration no car exceeds at
/// speed, m/s^2; the GNSS error at both ends, metres (at least: see `gap_jump`); the wheels'
/// scale and timing error.
pub(super) const GAP_LAT_MPS2: f32 = 5.0;
pub(super) const GAP_ERR_M: f32 = 25.0;
pub(super) const GAP_SCALE_TOL: f32 = 0.05;

impl TrackCheck {
    /// A gap the DR cannot bridge (no gyro, or longer than [`MAX_BRIDGE_S`]) still bounds the
    /// GNSS displacement across it by the wheels' distance `w`: the chord is never longer than
    /// the path, and never shorter than a circular arc turning at [`GAP_LAT_MPS2`] all the way
    /// (a car at speed cannot turn tighter; heading change `psi <= a * gap / v`, chord `>= w
    /// sinc(psi / 2)`). Judged with [`GAP_SCALE_TOL`] of the distance and the GNSS error at
    /// both ends as slack, only where the epoch's distance spans the gap. The ends' error is
    /// [`GAP_ERR_M`] or, where the receiver wanders more, the 30 s window's learnt noise at the
    /// windows' threshold (the two ends of a gap are a window's: its `|e|^2` has the learnt
    /// `s0^2` as its mean). A receiver wandering by 8 m for tens of seconds in town moves its
    /// two ends of a 13 s outage by 20 m and more while the car stands (sddi_commuter under a
    /// wander of 8 m: 28.7 m, its learnt `s0` 11.9 m). The
    /// fixes at both ends are where the car was the delay in use `tau` before them, so the
    /// path between them is the wheels' less `tau` times the speed gained across the gap, and
    /// the delay's uncertainty times that speed change is slack too (a car slowing from 10 m/s
    /// to a stop within a 24 s outage, its GNSS 1.21 s late: 12 m). That shifted path is
    /// one the car drove, so the arc's bound holds for it as well. A jump hidden in the gap
    /// fires the 10 s window's flag.
    #[inline(never)]
    pub(super) fn gap_jump(&self, s: &Sample, g: (f32, f32), gap: f64, wheel: f32) -> bool {
        let (Some(e), Some(last), Some(w)) = (self.hist.back(), self.last, s.dist_m.get()) else { return false };
        let gap = gap as f32;
        if !(libm::fabsf(s.dt_s - gap) < 0.5 && (0.0..=MAX_SPEED_MPS * gap).contains(&w)) {
            return false;
        }
        let scale = self.cal.scale();
        let (va, vb) = (last.wheel * scale, wheel * scale);
        let tau = self.cal.delay_s(Source::Position);
        let tau_sd = self.cal.delay_sd_s(Source::Position, self.quiet_sigma[0], self.cfg.velocity.kappa_s);
        let w = w * scale - tau * (vb - va);
        let w = if w > 0.0 { w } else { 0.0 };
        let (dx, dy) = (g.0 - e.g.0, g.1 - e.g.1);
        let chord = gnss_guard_dsp::sqrtf(dx * dx + dy * dy);
        let ends = self.c * gnss_guard_dsp::sqrtf(self.noise_params(1).0);
        let slack = if ends > GAP_ERR_M { ends } else { GAP_ERR_M } + GAP_SCALE_TOL * w + tau_sd * libm::fabsf(vb - va);
        let v = if last.wheel < wheel { last.wheel } else { wheel };
        let v = if w / gap < v { w / gap } else { v };
        // sin(h) / h >= 1 - h^2 / 6 for every h (and below zero, no bound, once a U-turn fits;
        // a car standing gives h = inf: no bound).
        let half = 0.5 * GAP_LAT_MPS2 * gap / v;
        let least = w * (1.0 - half * half * (1.0 / 6.0));
        chord > w + slack || chord < least - slack
    }

    /// Dead reckoning and the history: the epoch's time since `base_t`.
    pub(super) fn advance(&mut self, s: &Sample, g: (f32, f32), wheel: f32, yaw: Option<f32>) -> f32 {
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
        let turn = match dpsi {
            Some(dpsi) if dpsi.is_finite() && self.rot().is_some() => {
                self.rot.predict(dt, dpsi, &c);
                let turn = self.rot.corrected_turn(dt, dpsi);
                // The drive's own estimate only has a stored record to be compared with.
                if self.stored.is_some() {
                    self.rot_own.predict(dt, dpsi, &c);
                    self.own_offset = wrap_pi(self.own_offset + self.rot_own.corrected_turn(dt, dpsi) - turn);
                }
                turn
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
                if self.rot().is_some() {
                    self.rot.realign(&c);
                    self.rot_own.realign(&c);
                    self.own_offset = 0.0;
                }
                self.aligned = true;
            }
        }
        let mut dist = 0.0;
        if let Some(l) = last {
            // An arc of constant curvature: its chord is `dist sinc(turn / 2)` along the mid
            // heading (reversed while the car reverses: see `travel`). No car covers more than
            // MAX_SPEED_MPS: a larger integral is a fault.
            dist = s.dist_m.get().filter(|x| x.is_finite()).unwrap_or(0.5 * (l.wheel + wheel) * dt).max(0.0).min(MAX_SPEED_MPS * dt.max(0.0) + 1.0);
            let half = 0.5 * turn;
            let chord = if libm::fabsf(half) > 1e-4 { dist * crate::trig::sinf(half) / half } else { dist };
            let mid = self.psi + half + self.travel.offset();
            let (sin_mid, cos_mid) = crate::trig::sincosf(mid);
            self.dr.0 += chord * cos_mid;
            self.dr.1 += chord * sin_mid;
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
                let (sin_b, cos_b) = crate::trig::sincosf(b);
                (sp * sin_b, sp * cos_b)
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
        if self.travel.epoch(t, wheel, dist, &mut self.hist, &mut self.dr) {
            // The DR turned around: the prediction's change since the last pair is not an
            // acceleration (as where a pair turns it, `residuals`).
            self.last_pred = None;
        }
        t
    }

    /// The GNSS track's heading (math angle, radians, counter-clockwise from east) over the
    /// last 5 m or more.
    pub(super) fn gnss_heading(&mut self, g: (f32, f32)) -> Option<f32> {
        let a = *self.heading_anchor.get_or_insert(g);
        let d = sub(g, a);
        if norm2(d) >= 25.0 {
            self.heading_anchor = Some(g);
            return Some(libm::atan2f(d.1, d.0));
        }
        None
    }
}
