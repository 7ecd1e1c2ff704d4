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
//! Wheel speed along the heading (against it while the car reverses: `travel`), the heading
//! integrated from the gyro (its bias measured while the wheels stand) or, without a gyro,
//! taken from the GNSS track itself. Over a window of `T`
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
//! floors `s0`. All of it learns only while nothing is suspicious (a first drive's warm-up
//! freely, but never from pairs beyond the velocity test's gross path's bounds), within bounds
//! and rates once calibrated, and is kept across drives as a [`calibration::Record`]. One thing is not learnt
//! that way: a receiver that reports its velocity says how noisy its position is now (its
//! position against the integral of its own velocity over each window), and the windows take
//! that, up to 12 m, where it is above the learnt noise (`TrackCheck::gnss_noise`).
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
//!
//! # Where it lives
//! Lowest layer first: `state` (what the check keeps and has learnt, its start, restart and
//! reset), `dead_reckoning` (each epoch's integration into the history, the bound across a
//! gap), `windows` (the position windows) and `pairs` (the velocity pairs, their residuals,
//! the calibration's pairs); this file runs them per epoch (`step`), judges and learns. Below
//! them: `calibration`, `velocity`, `rotation`, `noise`, `travel` (the direction of travel: a
//! car reverses, and its wheel speed does not say so), `history`, `plane`.

pub mod calibration;
mod config;
mod dead_reckoning;
mod history;
mod noise;
mod outcome;
mod pairs;
mod plane;
mod rotation;
mod state;
mod travel;
pub mod velocity;
mod windows;

pub use self::config::{TrackConfig, WINDOWS_S};
pub use self::dead_reckoning::MAX_BRIDGE_S;
pub use self::outcome::{HeadingSource, TrackOutcome, WindowOutcome};
pub use self::state::TrackCheck;
pub use self::travel::{REVERSE_MAX_M, REVERSE_MAX_MPS};

use self::calibration::Source;
use self::history::{Entry, MAX_STEP_S};
use self::noise::NOISE_SPLIT_MPS;
use self::pairs::{Pair, PAIRS_PER_EPOCH};
use self::plane::{cmul, conj, norm2};
use self::rotation::wrap_pi;
use self::velocity::{VelocityOutcome, ACROSS};
use self::windows::Window;
use crate::geo::{to_local, EARTH_RADIUS_PAPER_M};
use crate::sample::Sample;

/// Windows shorter than this (metres driven) teach nothing about rotation.
const MIN_LEARN_DIST_M: f32 = 30.0;
/// The GNSS's own position noise over each window (see `TrackCheck::gnss_noise`): at most
/// this much, metres, is taken as noise; it rises with this time constant and falls with the
/// second, seconds.
const GNSS_NOISE_CAP_M: f32 = 12.0;
const GNSS_NOISE_RISE_S: f32 = 5.0;
const GNSS_NOISE_FALL_S: f32 = 30.0;

impl TrackCheck {
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
        out.rotation_sd_deg = gnss_guard_dsp::sqrtf(self.rot_var()).to_degrees();
        out.turn_scale = self.rot().map_or(1.0, |r| 1.0 + r.scale_error());
        out.gyro_bias_degps = match (source, self.rot()) {
            (HeadingSource::Gyro, Some(r)) => self.bias - r.omega().to_degrees(),
            _ => 0.0,
        };
        out.delay_s = self.cal.delay_s(Source::Position);
        out.delay_velocity_s = self.cal.record_base().1[1];
        out.delay_free_s = self.cal.free_delay_s(Source::Position);
        out.calibrated = self.cal.calibrated();
        out.reversing = self.travel.reversing();
        out.learning |= !out.calibrated;
        out.contradiction = self.cal.contradiction();
        if self.gap_jumped.take() == Some(s.t) {
            out.fired[0] = true;
            out.uninformative = false;
        }
        for wi in 0..WINDOWS_S.len() {
            let (s2, k2) = self.noise_params(wi);
            if let (Some(a), Some(b)) = (out.noise_s0_m.get_mut(wi), out.noise_k.get_mut(wi)) {
                *a = gnss_guard_dsp::sqrtf(s2);
                *b = gnss_guard_dsp::sqrtf(k2);
            }
        }
        Some(out)
    }

    fn judge_and_learn(&mut self, s: &Sample, t: f32, wheel: f32, out: &mut TrackOutcome) {
        let c = self.cfg;
        let dt = (s.dt_s as f64).min(3.0) as f32;
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let acc = s.gnss_h_acc.get().filter(|a| a.is_finite() && *a > 0.0).map_or(0.0, |a| 2.0 * a * a);
        let wins = [self.window(t, 0, acc), self.window(t, 1, acc)];
        // The 10 s window's rises only while that window is within its threshold (see
        // `gnss_noise`).
        for (wi, (n, w)) in self.gnss_noise.iter_mut().zip(&wins).enumerate() {
            let within = |w: &Window| wi > 0 || w.z <= self.c;
            if let Some(y) = w.filter(within).map(|w| w.gnss_e2).filter(|y| y.is_finite()) {
                let y = y.min(GNSS_NOISE_CAP_M * GNSS_NOISE_CAP_M);
                let tau = if y > *n { GNSS_NOISE_RISE_S } else { GNSS_NOISE_FALL_S };
                let k = (dt / tau).clamp(0.0, 1.0);
                *n += (y - *n) * k;
            }
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
            // pairs covered, floored by the receiver's own accuracy. The longer windows' whole
            // error is at least the receiver class's stated accuracy (as a reported one is
            // taken, `2 a^2`): their ends are far enough apart for a wander's two errors to be
            // independent, and what was learnt in metres on the road understates a wander in
            // time for a car that slows in town (sddi_commuter under GNSS noise of 6.5 to 8 m
            // correlated over 8 to 25 s: the 30 s window at 5.0 against 4.9 with 3.3 m learnt).
            let ends = (!p.reported).then(|| {
                let mut noise = [(0.0f32, 0.0f32); velocity::WINDOWS];
                let mut floor_m2 = [0.0f32; velocity::WINDOWS];
                for ((e, f), win) in noise.iter_mut().zip(floor_m2.iter_mut()).zip(velocity::WINDOWS_S) {
                    let (s2, k2) = if win <= WINDOWS_S[0] { *along0.get_or_insert_with(|| self.noise_params_along()) } else { *noise1.get_or_insert_with(|| self.noise_params(1)) };
                    *e = (s2.max(acc), k2);
                    if win > WINDOWS_S[0] {
                        *f = 2.0 * c.s0_prior_m * c.s0_prior_m;
                    }
                }
                velocity::Ends { noise, floor_m2, speed_mps: gnss_guard_dsp::sqrtf(norm2(p.d)) }
            });
            let mut o = self.vel.observe(p.t, r, ends);
            if self.vel.gross_live() {
                self.last_gross_t = p.t;
            }
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
        out.bound_10s_mps = Some(self.c * gnss_guard_dsp::sqrtf(s2.max(acc) + (k2 + self.rot_var()) * l * l) / WINDOWS_S[0]);
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
                    *o = Some(WindowOutcome { e_m: gnss_guard_dsp::sqrtf(w.e2), threshold_m: self.c * gnss_guard_dsp::sqrtf(w.var), dist_m: w.l, z: w.z });
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
        // Free, but not from pairs beyond the gross path's bounds: those are beyond what the
        // calibration's own uncertainty explains (a first drive's warm-up otherwise took a
        // drift of 10 m/s a minute in as a delay swinging from -1.5 to +3 and -3 s, and found
        // it 52 s later).
        let learns = moving && (free && !self.vel.gross_live() || !suspicious);
        if moving {
            // The calibration's pairs: learnt only when allowed, and never inside a gross
            // episode (they are seconds older than the pairs judged); this drive's own
            // estimate (the contradiction test) always.
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
        // own frame moved by 1.2 deg a minute under a new installation's timing and sensors,
        // and the roll-back undid that. What bounds the learning is the filter's rates (`q_rotation`,
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
        if let Some((phi, r)) = measured.filter(|_| self.rot().is_some()) {
            self.rot.update(phi, r, &c);
            if self.stored.is_some() {
                self.rot_own.update(wrap_pi(phi - self.own_offset), r, &c);
                self.check_gyro_scale();
            }
        }
    }
}
