//! The position windows' learnt noise: for each window the robust fit of
//! `E|e|^2 = s0^2 + k^2 L^2` at the distance `L` it covered, kept apart for town and road so
//! the motorway cannot teach town's noise away, and blended with the receiver profile's prior
//! while it has little data.

/// The position windows' noise is learnt apart below and above this speed over the window, m/s
/// (town and road: see `NoiseFits`).
pub(super) const NOISE_SPLIT_MPS: f32 = 15.0;

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

/// One window's noise fit, kept three ways: the windows driven slower than
/// [`NOISE_SPLIT_MPS`] (town), the faster ones (road), and all of them. Over long windows (the
/// motorway) `s0` is hidden under `k L`, so the fit of all let it sink to its floor within
/// minutes, and town after the motorway was judged with the motorway's `s0` (sddi_commuter:
/// 4.1 m in town, 1.0 m after fifteen minutes at 30 m/s). The two parts forget only as they
/// learn, and their line goes through the town's mean and the road's, so `s0` is the town's
/// until town teaches again. The noise is the larger of that line and the fit of all, parameter
/// by parameter: where the road's windows say more about the ends than the town's (css_canedge
/// under GNSS noise, its town windows learnt minutes before), that stays.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct NoiseFits {
    fits: [NoiseFit; 3],
    /// `(s0^2, k^2)` as of the last `add` (read several times an epoch, changed at most once).
    params: (f32, f32),
}

impl NoiseFits {
    /// One window's error `y` (m^2) at `x = L^2`; `floors` are `s0`'s and `k`'s.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn add(&mut self, split: f32, x: f32, y: f32, secs: f32, w: f32, keep: f32, floors: (f32, f32)) {
        if let Some(f) = self.fits.get_mut(usize::from(x >= split * split)) {
            f.add(x, y, secs, w, keep);
        }
        self.fits[2].add(x, y, secs, w, keep);
        let [town, road, all] = self.fits;
        // The parts' line: through both parts' means where both have data (the road's many
        // windows must not pull `s0`, which only the town's show, toward its floor), else the
        // one part's own fit.
        let (f0, f1) = (floors.0 * floors.0, floors.1 * floors.1);
        let parts = if town.w > 1e-9 && road.w > 1e-9 {
            let (xt, yt, xr, yr) = (town.x / town.w, town.y / town.w, road.x / road.w, road.y / road.w);
            let k2 = if xr - xt > 1e-3 { (yr - yt) / (xr - xt) } else { 0.0 };
            let k2 = k2.max(f1);
            ((yt - k2 * xt).max(f0), k2)
        } else if town.w > 1e-9 {
            town.params(floors.0, floors.1)
        } else {
            road.params(floors.0, floors.1)
        };
        let whole = all.params(floors.0, floors.1);
        self.params = (parts.0.max(whole.0), parts.1.max(whole.1));
    }
    fn secs(&self) -> f32 {
        self.fits[2].secs
    }
    /// `(s0^2, k^2)` blended with a `prior` that weighs `prior_s` seconds against the fit's
    /// seconds (the receiver profile's prior while the car's own fit has little data).
    pub(super) fn blended(&self, prior: (f32, f32), prior_s: f32) -> (f32, f32) {
        let w_d = self.secs().max(0.0);
        if w_d <= 0.0 {
            return prior;
        }
        let (s2, k2) = self.params();
        let a = prior_s / (prior_s + w_d);
        (a * prior.0 + (1.0 - a) * s2, a * prior.1 + (1.0 - a) * k2)
    }
    /// (s0^2, k^2), floored: the larger of the two parts' fit and the fit of all.
    fn params(&self) -> (f32, f32) {
        self.params
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strategy::track::WINDOWS_S;

    /// Twenty minutes of town (10 s windows over 60 to 100 m, 4 m of GNSS noise at the ends),
    /// then an hour of motorway (250 to 350 m, where the error grows as 1.5 % of the distance
    /// and no `s0` shows under it): the motorway cannot tell `s0`, so it must not teach the
    /// town's away. One fit for both (the old way) let it sink to its floor.
    #[test]
    fn the_motorway_does_not_overwrite_what_town_taught() {
        let (mut one, mut parts) = (NoiseFit::default(), NoiseFits::default());
        let split = NOISE_SPLIT_MPS * WINDOWS_S[0];
        let keep = libm::expf(-1.0 / 300.0);
        for i in 0..4800 {
            let l = if i < 1200 { 60.0 + (i % 5) as f32 * 10.0 } else { 250.0 + (i % 11) as f32 * 10.0 };
            let y = if i < 1200 { 16.0 + 1e-4 * l * l } else { 0.015 * 0.015 * l * l };
            let w = 1.0 / (y * y);
            one.add(l * l, y, 1.0, w, keep);
            parts.add(split, l * l, y, 1.0, w, keep, (1.0, 0.01));
        }
        let (s2_one, _) = one.params(1.0, 0.01);
        let (s2, k2) = parts.params();
        assert!(s2_one <= 1.0 + 1e-3, "one fit: s0 {} (the test's premise)", gnss_guard_dsp::sqrtf(s2_one));
        assert!(gnss_guard_dsp::sqrtf(s2) > 3.0, "s0 after the motorway {}, k {}", gnss_guard_dsp::sqrtf(s2), gnss_guard_dsp::sqrtf(k2));
        // And the motorway's own error is not understated: the model at 300 m against its 4.5 m.
        let road = s2 + k2 * 300.0 * 300.0;
        assert!(road >= 0.9 * 4.5 * 4.5, "{} m at 300 m", gnss_guard_dsp::sqrtf(road));
    }
}
