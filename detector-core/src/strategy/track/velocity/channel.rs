//! One channel of the velocity test (along or across the road): its noise as it is now,
//! from the residual's first differences, the one-second bins its pairs' clipped `z` are summed
//! in, and the windows' statistic over them (see the parent module's documentation).

use super::gross::GrossRun;
use super::config::{VelocityConfig, BINS, DIFFS, WINDOWS, WINDOWS_S};

/// One second of a channel's pairs: the sum of clipped `z` times weight, of the weights, of
/// weight over the noise the `z` was taken with (the ends' error is in metres: see
/// `Channel::statistic`), and the metres the pairs covered (their speed times weight).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Bin {
    pub(super) zw: f32,
    pub(super) w: f32,
    pub(super) iw: f32,
    pub(super) dist: f32,
}

/// Per window, the ends' `(s0^2, k^2)` and the least their error is, m^2 (see
/// `Channel::statistic`).
pub(super) type EndsNoise<'a> = (&'a [(f32, f32); WINDOWS], &'a [f32; WINDOWS]);

/// One channel's state.
#[derive(Clone, Copy, Debug)]
pub(super) struct Channel {
    /// Per second (see `Bin`).
    pub(super) bins: [Bin; BINS],
    /// The second of the newest bin (seconds after the stretch's start).
    pub(super) head: i32,
    pub(super) diffs: [f32; DIFFS],
    pub(super) n_diffs: usize,
    pub(super) next_diff: usize,
    /// The last pair the noise was measured from: time, residual.
    pub(super) last: Option<(f32, f32)>,
    pub(super) last_sigma_t: Option<f32>,
    /// The run of gross pairs.
    pub(super) gross_run: Option<GrossRun>,
    /// Since when the largest window statistic has been above the threshold.
    pub(super) above_since: Option<f32>,
    pub(super) sigma: f32,
    /// Which of the stored differences were clipped (bit per slot).
    pub(super) clipped: u8,
}

impl Channel {
    pub(super) fn new(floor: f32) -> Self {
        Channel { bins: [Bin::default(); BINS], head: i32::MIN, diffs: [0.0; DIFFS], n_diffs: 0, next_diff: 0, last: None, last_sigma_t: None, gross_run: None, above_since: None, sigma: floor, clipped: 0 }
    }

    /// The residual's noise now (see the module documentation): never below what it was less
    /// its fall, never below the floor. Differences are taken against the residual of about
    /// `lag` before: a second, so a 10 Hz receiver's correlated residuals count as a 1 Hz
    /// one's; a position difference's span, whose pairs a second apart share a fix.
    pub(super) fn update_sigma(&mut self, t: f32, r: f32, cfg: &VelocityConfig, floor: f32, lag: f32) {
        let dt = self.last_sigma_t.map_or(1.0, |l| t - l);
        self.last_sigma_t = Some(t);
        match self.last {
            Some((tl, rl)) if t - tl >= lag - 0.1 && t - tl <= lag + 1.5 => {
                if let Some(slot) = self.diffs.get_mut(self.next_diff) {
                    let (d, cap) = (libm::fabsf(r - rl), 5.0 * self.sigma);
                    *slot = d.min(cap);
                    let bit = 1u8 << (self.next_diff % DIFFS);
                    self.clipped = if d > cap { self.clipped | bit } else { self.clipped & !bit };
                }
                self.next_diff = (self.next_diff + 1) % DIFFS;
                self.n_diffs = (self.n_diffs + 1).min(DIFFS);
                self.last = Some((t, r));
            }
            Some((tl, _)) if t - tl > 0.0 && t - tl < lag - 0.1 => {}
            _ => self.last = Some((t, r)),
        }
        let fallen = self.sigma * libm::expf(-dt.clamp(0.0, 10.0) / cfg.fall_s.max(1.0));
        let n = self.n_diffs.min(DIFFS);
        let now = if n >= 4 { 0.886_226_9 * self.diffs.iter().take(n).sum::<f32>() / n as f32 } else { 0.0 };
        self.sigma = now.max(fallen).max(floor);
        if !self.sigma.is_finite() {
            self.sigma = floor;
        }
    }

    /// The noise is measured (four differences at least) and not catching up: at most one of
    /// those kept clipped at five times the noise before it (a level's step, as a spoofer's
    /// onset, is one large difference; a receiver far worse than the noise assumed clips one
    /// difference after another). One, not none: a spoofer's onset is a single large
    /// difference (a step of 8.94 m/s against 1.69 m/s of noise), which must not un-settle it;
    /// chosen on the attacks that judge it, not derived.
    pub(super) fn settled(&self) -> bool {
        self.n_diffs >= 4 && self.clipped.count_ones() <= 1
    }

    pub(super) fn bin_for(&mut self, t: f32) -> Option<&mut Bin> {
        let sec = libm::floorf(t);
        if !sec.is_finite() || libm::fabsf(sec) > 1.0e9 {
            return None;
        }
        let sec = sec as i32;
        if self.head == i32::MIN || sec < self.head || sec - self.head >= BINS as i32 {
            self.bins = [Bin::default(); BINS];
            self.head = sec;
        }
        while self.head < sec {
            self.head += 1;
            if let Some(b) = self.bins.get_mut(self.head.rem_euclid(BINS as i32) as usize) {
                *b = Bin::default();
            }
        }
        self.bins.get_mut(sec.rem_euclid(BINS as i32) as usize)
    }

    /// `T` of every window (0 where it is not judged). `ends` is the position error of a
    /// window's two ends where the pairs are position differences (their sum over a window is
    /// the window's displacement, so its error is the ends' error, not a sum of independent
    /// ones): per window `(s0^2, k^2)` of `s0^2 + k^2 L^2` (m^2), `L` the distance the
    /// window's pairs covered, and the least it is (m^2); `None` for a receiver's own velocity.
    ///
    /// `common` ((m/s)^2) is an error every pair of a window shares (a coarse wheel speed's
    /// rounding while the speed holds): no window averages it away.
    pub(super) fn statistic(&self, cfg: &VelocityConfig, ends: Option<EndsNoise<'_>>, kappa: f32, common: f32) -> [f32; WINDOWS] {
        let (mut zw, mut w, mut iw, mut l) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let mut best = [0.0f32; WINDOWS];
        if self.head == i32::MIN {
            return best;
        }
        let mut wi = 0usize;
        for age in 0..BINS as i32 {
            let Some(b) = self.bins.get(self.head.wrapping_sub(age).rem_euclid(BINS as i32) as usize) else { break };
            zw += b.zw;
            w += b.w;
            iw += b.iw;
            if ends.is_some() {
                l += b.dist;
            }
            let Some(&win) = WINDOWS_S.get(wi) else { break };
            if (age + 1) as f32 >= win {
                if w >= cfg.min_cover * win && w > 0.0 {
                    if let Some(b) = best.get_mut(wi) {
                        // The mean z's variance: kappa / w, and the ends' error in z units:
                        // metres over the window, each second divided by the noise its z was
                        // taken with (not the noise now: a noise that rose since would shrink
                        // the ends' share while the older z stay large).
                        let e = ends.and_then(|(n, f)| Some((n.get(wi)?, f.get(wi)?))).map_or(0.0, |((s2, k2), f)| (s2 + k2 * l * l).max(*f).max(0.0));
                        let ends = e * (iw / w) * (iw / w) / (w * w);
                        let shared = common * (iw / w) * (iw / w);
                        *b = libm::fabsf(zw / w) / gnss_guard_dsp::sqrtf(kappa.max(0.1) / w + ends + shared);
                    }
                }
                wi += 1;
            }
        }
        best
    }
}
