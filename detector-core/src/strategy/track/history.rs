//! The track check's memory of the last minute: per epoch (at most one every
//! [`MIN_SPACING_S`]) where GNSS put the car, where the dead reckoning put it, and the velocity
//! the receiver reported; read back at any time by linear interpolation.

use heapless::Deque;

/// History kept (at most one entry per 0.19 s: over 48 s at any rate).
pub(super) const HISTORY: usize = 256;
const MIN_SPACING_S: f64 = 0.19;
/// Epochs at most this far apart are consecutive, seconds.
pub(super) const MAX_STEP_S: f64 = 3.0;

/// One history entry: the GNSS position and the DR position, in the local frames.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Entry {
    /// Seconds after the stretch's start.
    pub t: f32,
    /// GNSS position, metres east and north of the origin.
    pub g: (f32, f32),
    /// Cumulative DR position, metres, in the DR frame.
    pub d: (f32, f32),
    /// Cumulative variance the DR took on across bridged GNSS gaps, m^2.
    pub u: f32,
    /// The velocity the receiver reported (east, north), m/s; NaN when it reported none.
    pub v: (f32, f32),
    /// Its integral since the check's `vi_since`, metres (see `TrackCheck::gnss_noise`).
    pub vi: (f32, f32),
}

impl Entry {
    pub(super) fn has_velocity(&self) -> bool {
        self.v.0.is_finite() && self.v.1.is_finite()
    }
}

#[derive(Clone, Debug, Default)]
pub(super) struct History {
    q: Deque<Entry, HISTORY>,
}

impl History {
    pub(super) fn clear(&mut self) {
        self.q.clear();
    }
    pub(super) fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
    pub(super) fn front(&self) -> Option<&Entry> {
        self.q.front()
    }
    pub(super) fn back(&self) -> Option<&Entry> {
        self.q.back()
    }

    /// Moves every GNSS position by `-shift` (the local frame's origin follows the car).
    pub(super) fn shift_g(&mut self, shift: (f32, f32)) {
        for en in self.q.iter_mut() {
            en.g = (en.g.0 - shift.0, en.g.1 - shift.1);
        }
    }

    /// Every DR position after time `t` reflected through `at` (the car reversed from there:
    /// see `travel`).
    pub(super) fn reflect_d_after(&mut self, t: f32, at: (f32, f32)) {
        let (a, b) = self.q.as_mut_slices();
        for en in a.iter_mut().chain(b.iter_mut()) {
            if en.t > t {
                en.d = (2.0 * at.0 - en.d.0, 2.0 * at.1 - en.d.1);
            }
        }
    }

    /// The newest entry is always this epoch; the ones before it are kept at least
    /// `MIN_SPACING_S` apart (the newest replaces its predecessor while that is too close to
    /// the entry before it).
    pub(super) fn push(&mut self, entry: Entry) {
        let committed_t = self.q.iter().rev().nth(1).map(|e| e.t);
        match (self.q.back_mut(), committed_t) {
            (Some(b), Some(c)) if ((b.t - c) as f64) < MIN_SPACING_S => *b = entry,
            _ => {
                if self.q.is_full() {
                    self.q.pop_front();
                }
                let _ = self.q.push_back(entry);
            }
        }
    }

    fn get(&self, i: usize) -> Option<&Entry> {
        let (a, b) = self.q.as_slices();
        if i < a.len() { a.get(i) } else { b.get(i - a.len()) }
    }

    /// The index of the first entry for which `before` is false (the length when there is
    /// none); `before` must hold for a prefix of the entries, as a time bound does.
    fn partition_point(&self, before: impl Fn(&Entry) -> bool) -> Option<usize> {
        let (mut lo, mut hi) = (0usize, self.q.len());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if before(self.get(mid)?) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        Some(lo)
    }

    /// The index of the first entry with time >= t (the length when there is none).
    fn first_at_or_after(&self, t: f32) -> Option<usize> {
        self.partition_point(|e| e.t < t)
    }

    /// The history interpolated at time `t`. `None` before the oldest entry, after the newest,
    /// and inside a bridged GNSS gap (there is no GNSS position to interpolate there).
    pub(super) fn at(&self, t: f32) -> Option<Entry> {
        let lo = self.first_at_or_after(t)?;
        let after = self.get(lo)?;
        if lo == 0 {
            return (after.t - t <= 1e-3).then_some(*after);
        }
        let before = self.get(lo - 1)?;
        let span = after.t - before.t;
        if (span as f64) > MAX_STEP_S + 1e-3 && t - before.t > 1e-3 && after.t - t > 1e-3 {
            return None;
        }
        let w = if span > 0.0 { ((t - before.t) / span).clamp(0.0, 1.0) } else { 0.0 };
        let lerp = |x: (f32, f32), y: (f32, f32)| (x.0 + (y.0 - x.0) * w, x.1 + (y.1 - x.1) * w);
        Some(Entry { t, g: lerp(before.g, after.g), d: lerp(before.d, after.d), u: before.u + (after.u - before.u) * w, v: lerp(before.v, after.v), vi: lerp(before.vi, after.vi) })
    }

    /// The newest entry at or before time `t` that is newer than `after` (exclusive).
    pub(super) fn newest_between(&self, after: f32, t: f32) -> Option<Entry> {
        let i = self.first_after(t)?;
        let e = *self.get(i.checked_sub(1)?)?;
        (e.t > after).then_some(e)
    }

    /// The index of the first entry newer than `t` (strictly: not `t + epsilon`, which is `t`
    /// itself once `t` passes 2048 s, where an `f32`'s step is 2.4e-4 s).
    fn first_after(&self, t: f32) -> Option<usize> {
        self.partition_point(|e| e.t <= t)
    }

    /// The oldest entry newer than `after` (exclusive) and at or before time `t`.
    pub(super) fn oldest_between(&self, after: f32, t: f32) -> Option<Entry> {
        let e = *self.get(self.first_after(after)?)?;
        (e.t <= t + 1e-4).then_some(e)
    }

    /// The DR position at `N` times `t0, t0 + step, ...` (one walk through the history, not a
    /// search per time). `false` when a time falls outside the history or the times span a
    /// bridged gap.
    pub(super) fn dr_grid<const N: usize>(&self, t0: f32, step: f32, out: &mut [(f32, f32); N]) -> bool {
        let Some(mut i) = self.first_at_or_after(t0) else { return false };
        if i == 0 {
            // Only an entry at t0 itself will do.
            if self.get(0).is_none_or(|e| e.t - t0 > 1e-3) {
                return false;
            }
            i = 1;
        }
        for (k, o) in out.iter_mut().enumerate() {
            let t = t0 + k as f32 * step;
            while self.get(i).is_some_and(|e| e.t < t) {
                i += 1;
            }
            let (Some(a), Some(b)) = (self.get(i - 1), self.get(i)) else {
                // Past the newest entry: only the newest itself.
                match self.get(i - 1) {
                    Some(a) if t - a.t <= 1e-3 => {
                        *o = a.d;
                        continue;
                    }
                    _ => return false,
                }
            };
            let span = b.t - a.t;
            if (span as f64) > MAX_STEP_S + 1e-3 {
                return false;
            }
            let w = if span > 0.0 { ((t - a.t) / span).clamp(0.0, 1.0) } else { 0.0 };
            *o = (a.d.0 + (b.d.0 - a.d.0) * w, a.d.1 + (b.d.1 - a.d.1) * w);
        }
        true
    }

    /// The time of the last fix before the bridged GNSS gap that holds time `t`, if one does.
    pub(super) fn gap_edge(&self, t: f32) -> Option<f32> {
        let i = self.first_at_or_after(t)?;
        let (b, e) = (self.get(i.checked_sub(1)?)?.t, self.get(i)?.t);
        let inside = ((e - b) as f64) > MAX_STEP_S + 1e-3 && t - b > 1e-3 && e - t > 1e-3;
        inside.then_some(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past 2048 s an `f32` time's step is 2.4e-4 s: "newer than" and "at or before" must be
    /// exact comparisons, not `t +- 1e-4` (which is `t` itself there).
    #[test]
    fn between_is_exact_past_2048_s() {
        for base in [10.0f32, 3000.0, 9000.0] {
            let mut h = History::default();
            for k in 0..4 {
                h.push(Entry { t: base + k as f32, ..Default::default() });
            }
            let t = |e: Option<Entry>| e.map(|e| e.t - base);
            assert_eq!(t(h.oldest_between(base + 1.0, base + 3.0)), Some(2.0), "at {base}: the entry at `after` is not newer than it");
            assert_eq!(t(h.newest_between(base, base + 2.0)), Some(2.0), "at {base}: the entry at `t` is at or before it");
            assert_eq!(t(h.newest_between(base + 2.0, base + 2.0)), None, "at {base}");
        }
    }
}
