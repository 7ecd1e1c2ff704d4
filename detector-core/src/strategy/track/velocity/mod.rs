//! The velocity-domain sequential test: GNSS velocity against the calibrated dead reckoning's,
//! epoch by epoch, with the evidence accumulated over a bank of windows.
//!
//! # Why velocity
//! A spoofer who drifts the position keeps the reported velocity consistent with it, so the
//! drift is in every epoch's GNSS velocity at full size, while a position window needs the
//! offset to outgrow the integrated dead-reckoning error (Tanil, Khanafseh, Joerger & Pervan,
//! IEEE TAES 2018, on INS monitors against spoofers that track the vehicle; PX4 issue 27340, a
//! 5 m/s drift fused for 34 s and 230 m by per-epoch gates).
//!
//! # The statistic
//! Each judged pair gives a residual `r = G - s e^{i theta} D` (GNSS velocity: the receiver's
//! speed and course where it reports them, else its position difference over
//! [`POSITION_SPAN_S`]; `D` the
//! dead reckoning's velocity at the learnt delay), split into an along-track and, with a gyro,
//! an across-track channel. Each is normalised, `z = r / sqrt(sigma^2 + v)`, by
//! - `sigma`, the channel's noise *as it is now*: `sqrt(pi) / 2` times the mean absolute first
//!   difference of the residual one second apart ([`POSITION_SPAN_S`] for position
//!   differences), over the last [`DIFFS`] differences (each
//!   difference clipped at five times the noise before it). It rises within seconds when the
//!   receiver gets worse (town, trees, multipath, a receiver's own excursions, which last up to
//!   ten seconds on the css_canedge logger) and falls slowly ([`VelocityConfig::fall_s`]); a
//!   drift, smooth by nature, changes the residual's level, not its differences, so it cannot
//!   teach it;
//! - `v`, the uncertainty of the prediction itself (the scale's, and the frame rotation's).
//!
//! `z` is clipped at [`VelocityConfig::clip`] (a single bad fix or a short glitch moves a window
//! by a bounded amount) and summed, weighted by the seconds each pair covers, in one-second
//! bins. Over each window `W` of [`WINDOWS_S`] the test is the mean `z` over the window in units
//! of its standard error, `T = |m| / sqrt(kappa / W + e / (sigma W)^2)`, where `kappa` seconds is
//! the correlation time of the residual (a one-second sample is not independent of the next)
//! and `e` the position error of the window's two ends where the GNSS velocity is a position
//! difference (the sum of a window's position differences is its displacement: a receiver's
//! position wandering by metres in town looks like a short drift otherwise): the learnt
//! along-track noise `s0^2 + k^2 L^2` at the distance `L` the window's pairs covered (each bin
//! keeps its metres; the newest pair's speed times the window's length made a car slowing to a
//! stop shrink the 60 s window's error and fire it with no new residual), at least
//! [`Ends::floor_m2`] (the caller's: for the 30 and 60 s windows the receiver class's stated
//! accuracy, since a wander's error grows with the time a window spans, not with the metres
//! driven, and what was learnt in metres on the road understates it in town). An error every
//! pair of a window shares, `c` ((m/s)^2: a wheel speed in whole km/h is up to 0.14 m/s off
//! for as long as the speed holds, variance `q^2 / 12` at resolution `q`), adds
//! `c mean(1/sd)^2` under the root: no window averages it away. With
//! `N = 2 sum_W 3600 / W` tests per hour (both channels), a budget of `B` false alarms per hour
//! gives the threshold `h = Phi^-1(1 - B / 2N)`. A window fires once it has stayed above `h` for
//! [`VelocityConfig::persist_s`], or [`VelocityConfig::persist_position_s`] (less
//! [`PERSIST_JITTER_S`]) for position differences, whose residual is correlated over less
//! time (the banks of finite cumulative
//! monitors of Quartararo & Langel, NAVIGATION 2022, in their simplest form); pairs beyond
//! [`VelocityConfig::gross`] (and beyond [`VelocityConfig::gross_mps`] along the road,
//! [`GROSS_ACROSS_MPS`] across it) in the same direction for [`VelocityConfig::gross_s`],
//! beyond [`GROSS_FAST_MPS`] for [`GROSS_FAST_S`] (less [`PERSIST_JITTER_S`] where the
//! receiver reports its velocity), or along the road beyond
//! [`GROSS_SLOW_MPS`] for [`GROSS_SLOW_S`], fire at once (a drift of metres per second, a
//! frozen position: the smaller the run, the longer it must last), once the channel's noise is
//! measured (four differences since the power-up: before them `z` is in the prior's units). Every fix is judged, oldest
//! first, once the DR's velocity at the learnt delay is known for it (none is skipped when the
//! vehicle signals are late), or would be within half a second: then on the DR's newest second
//! carried forward at its last change (a 1 Hz receiver's pair otherwise waits a whole epoch for
//! a tenth of a second of the next step).
//! No window is shorter than 10 s: the receivers and cars of our data disagree by 2 m/s for up
//! to three fixes and by 0.6 m/s for up to ten seconds on their own (css_canedge: the OBD speed
//! held for 13 s while GNSS slowed), which a shorter window cannot tell from a drift.
//!
//! Above `freeze` times `h` the evidence is accumulating: the caller freezes the calibration.
//!
//! # Limits
//! Without a gyro there is no across-track channel: a drift across the road changes the speed
//! only by `d^2 / 2v` and is invisible until the road turns. Velocity from position differences
//! is noisier than the receiver's Doppler velocity, so position-only receivers see only faster
//! drifts. A drift that ramps its velocity up slowly enough is learnt by no one here but is
//! bounded by the calibration's rates (see `calibration`).

mod channel;
mod config;
mod gross;

use channel::{Bin, Channel};
use config::BINS;
pub use config::{upper_quantile, VelocityConfig, DIFFS, MIN_SPEED_REPORTED_MPS, PERSIST_JITTER_S, POSITION_SPAN_S, WINDOWS, WINDOWS_S};
use gross::GrossRun;
pub use gross::{GROSS_ACROSS_MPS, GROSS_FAST_MPS, GROSS_FAST_S, GROSS_SLOW_MPS, GROSS_SLOW_S};

/// Where the pairs are position differences: the noise of a window's two ends, per window
/// `(s0^2, k^2)` of `s0^2 + k^2 L^2` (m^2) at the distance `L` its pairs covered, at least
/// `floor_m2`, and the distance the pair covered per second, m/s.
#[derive(Clone, Copy, Debug)]
pub struct Ends {
    /// Per window, `(s0^2, k^2)`.
    pub noise: [(f32, f32); WINDOWS],
    /// Per window, the least error of its ends, m^2, whatever the distance (see the module
    /// documentation, "The statistic").
    pub floor_m2: [f32; WINDOWS],
    /// The pair's speed, m/s: the metres it covers per second of weight.
    pub speed_mps: f32,
}

/// The channels.
pub const ALONG: usize = 0;
/// The across-track channel.
pub const ACROSS: usize = 1;

/// One judged pair's numbers, for the verdict.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VelocityOutcome {
    /// The pair's residual (along, across), m/s, where judged.
    pub residual_mps: [Option<f32>; 2],
    /// The channels' noise now, m/s.
    pub sigma_mps: [f32; 2],
    /// The largest window statistic per channel, every window's, and the threshold.
    pub t: [f32; 2],
    /// Every window's statistic per channel (0 where not judged).
    pub t_windows: [[f32; WINDOWS]; 2],
    /// The threshold `h` the statistics are compared with.
    pub h: f32,
    /// Which channel fired.
    pub fired: [bool; 2],
    /// Evidence is accumulating (above `freeze h`): learning is frozen.
    pub suspicious: bool,
    /// The slowest drift (m/s) this test sees within 10 s at the along channel's noise now.
    pub bound_10s_mps: f32,
    /// Per channel: its noise is measured and not catching up (see `Channel::settled`).
    pub settled: [bool; 2],
    /// The noise hides drifts under the track check's bound (set by the check): the test says
    /// it cannot tell, and only a channel whose noise is settled fires.
    pub blind: bool,
    /// The fixes judged at this epoch (with the vehicle signals late, an epoch may judge none
    /// and the next two; the residual is the last one's).
    pub pairs: u8,
}

/// The test's state: two channels.
#[derive(Clone, Copy, Debug)]
pub struct VelocityTest {
    cfg: VelocityConfig,
    h: f32,
    ch: [Channel; 2],
    last_t: Option<f32>,
    /// Per channel, the error every pair of a window shares, (m/s)^2 (see `Channel::statistic`).
    common_var: [f32; 2],
}

impl VelocityTest {
    /// A test with no pairs yet, its noise at the prior.
    pub fn new(cfg: VelocityConfig) -> Self {
        VelocityTest { cfg, h: cfg.threshold(), ch: [Channel::new(cfg.floor_mps[0].max(cfg.prior_mps)), Channel::new(cfg.floor_mps[1].max(cfg.prior_mps))], last_t: None, common_var: [0.0; 2] }
    }
    /// Its configuration.
    pub fn config(&self) -> &VelocityConfig {
        &self.cfg
    }
    /// The threshold from the budget (see [`VelocityConfig::threshold`]).
    pub fn h(&self) -> f32 {
        self.h
    }

    /// A new stretch: the windows start over; the noise as it is now is kept (the
    /// environment did not change because the GNSS paused), the pair history is not.
    pub fn restart(&mut self) {
        for c in self.ch.iter_mut() {
            c.bins = [Bin::default(); BINS];
            c.head = i32::MIN;
            c.last = None;
            c.last_sigma_t = None;
            c.gross_run = None;
            c.above_since = None;
        }
        self.last_t = None;
    }

    /// The quiet noise a stored record starts the channels with.
    pub fn set_sigma(&mut self, sigma: [f32; 2]) {
        for ((c, s), f) in self.ch.iter_mut().zip(sigma).zip(self.cfg.floor_mps) {
            if s.is_finite() {
                c.sigma = s.max(f);
            }
        }
    }
    /// The error every pair of a window shares, per channel, (m/s)^2: a wheel speed's rounding
    /// to its resolution `q` is `q^2 / 12` along the track and stays while the speed holds.
    pub fn set_common_var(&mut self, var: [f32; 2]) {
        for (c, v) in self.common_var.iter_mut().zip(var) {
            *c = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
        }
    }
    /// A channel's newest pairs are beyond the gross path's bounds (a run, fired or not).
    pub fn gross_live(&self) -> bool {
        self.ch.iter().any(|c| c.gross_run.is_some())
    }
    /// The channels' noise now (along, across), m/s.
    pub fn sigma(&self) -> [f32; 2] {
        [self.ch[ALONG].sigma, self.ch[ACROSS].sigma]
    }

    /// One judged pair at time `t` (seconds of the stretch): per channel the residual (m/s)
    /// and the prediction's own variance ((m/s)^2), `None` where that channel is not judged.
    ///
    /// `ends`: where the pairs are position differences, the noise of a window's two ends and
    /// the pair's speed, whose metres each bin keeps (see the module documentation, "The
    /// statistic");
    /// `None` when the receiver reports its velocity.
    pub fn observe(&mut self, t: f32, pairs: [Option<(f32, f32)>; 2], ends: Option<Ends>) -> VelocityOutcome {
        let cfg = self.cfg;
        let w = self.last_t.map_or(1.0, |l| (t - l).clamp(0.05, 1.0));
        self.last_t = Some(t);
        let mut out = VelocityOutcome { h: self.h, pairs: 1, ..Default::default() };
        for (k, pair) in pairs.iter().enumerate() {
            let (Some(ch), Some(&floor)) = (self.ch.get_mut(k), cfg.floor_mps.get(k)) else { continue };
            let Some((r, v)) = pair.filter(|(r, v)| r.is_finite() && v.is_finite()) else {
                // No pair for this channel now: its windows still move on with time, so
                // their statistic is of the last seconds only, never a stale one kept while the
                // channel is not judged (a stale statistic above `freeze h` froze learning for
                // good: the frozen rotation's uncertainty grew until the across channel was
                // no longer judged, and its last statistic stayed).
                let _ = ch.bin_for(t);
                continue;
            };
            ch.update_sigma(t, r, &cfg, floor, if ends.is_some() { POSITION_SPAN_S } else { 1.0 });
            let sd = gnss_guard_dsp::sqrtf(ch.sigma * ch.sigma + v.max(0.0));
            let z = r / sd;
            // max/min, not clamp: clamp panics on bounds it cannot prove ordered.
            let zc = z.max(-cfg.clip).min(cfg.clip);
            if let Some(b) = ch.bin_for(t) {
                b.zw += zc * w;
                b.w += w;
                b.iw += w / sd.max(1e-6);
                b.dist += ends.map_or(0.0, |e| e.speed_mps.max(0.0) * w);
            }
            let floors = if k == ALONG { (GROSS_SLOW_MPS, cfg.gross_mps) } else { (GROSS_ACROSS_MPS, GROSS_ACROSS_MPS) };
            ch.gross_run = GrossRun::after(ch.gross_run, t, z, r, cfg.gross, floors, ch.n_diffs >= 4);
            if let Some(o) = out.residual_mps.get_mut(k) {
                *o = Some(r);
            }
        }
        let h = self.h;
        for ((k, ch), common) in self.ch.iter_mut().enumerate().zip(self.common_var) {
            let kappa = if ends.is_some() { cfg.kappa_position_s } else { cfg.kappa_s };
            let tw = ch.statistic(&cfg, ends.as_ref().map(|e| (&e.noise, &e.floor_m2)), kappa, common);
            let t_w = tw.iter().fold(0.0f32, |a, b| a.max(*b));
            if let Some(o) = out.t_windows.get_mut(k) {
                *o = tw;
            }
            let fast_s = if ends.is_some() { GROSS_FAST_S } else { GROSS_FAST_S - PERSIST_JITTER_S };
            let gross = ch.gross_run.is_some_and(|g| g.fires(cfg.gross_s, fast_s));
            let held = if t_w > h { t - *ch.above_since.get_or_insert(t) } else {
                ch.above_since = None;
                -1.0
            };
            if let Some(o) = out.settled.get_mut(k) {
                *o = ch.settled();
            }
            if let (Some(o), Some(f), Some(s)) = (out.t.get_mut(k), out.fired.get_mut(k), out.sigma_mps.get_mut(k)) {
                *o = t_w;
                *f = held >= if ends.is_some() { cfg.persist_position_s - PERSIST_JITTER_S } else { cfg.persist_s } || gross;
                *s = ch.sigma;
            }
            out.suspicious |= t_w > cfg.freeze * h || gross;
        }
        // The shortest window's bound at the residual's own correlation time (the 30 s window's
        // before: at `kappa_s`, 0.58 times the 10 s bound of a receiver's own velocity; the same
        // number for position differences, whose `kappa_position_s / 10` is `kappa_s / 30`).
        let kappa = if ends.is_some() { cfg.kappa_position_s } else { cfg.kappa_s };
        out.bound_10s_mps = self.h * gnss_guard_dsp::sqrtf(kappa / WINDOWS_S[0]) * self.ch[ALONG].sigma;
        out
    }
}

#[cfg(test)]
mod tests;
