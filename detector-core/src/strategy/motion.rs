//! Strategy 3: motion state.
//!
//! Standstill vs moving is decided twice, independently: from the wheel speed, and from GNSS
//! (its reported speed over ground when it has one, else the location shift over the epoch).
//! Each decision has hysteresis: a state changes only when the speed crosses the far threshold
//! (below `stop` to become standing, above `move` to become moving), so noise around one
//! threshold does not flicker. The strategy fires when the two disagree for longer than
//! [`MotionConfig::persist_s`]:
//!
//! - GNSS moving while the wheels stand: the paper's *stop* attack;
//! - GNSS standing while the wheels turn faster than GNSS's own moving threshold: a frozen
//!   position, the *overshoot* attack. A crawl slower than that threshold is below the GNSS
//!   noise floor epoch by epoch, so there the evidence is distance: the wheels have covered
//!   [`CRAWL_MIN_M`] since GNSS stood while GNSS's position stayed within [`CRAWL_FRACTION`] of
//!   it of where it stood, all along (a frozen position at 2 m/s in a queue, which no single
//!   epoch shows; a receiver's wander that brings a real crawl back near its start is farther
//!   out on the way).

use crate::profile::ReceiverProfile;
use crate::sample::Sample;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
/// Standing or moving, by one source.
pub enum MotionState {
    /// No evidence yet (start-up, or the input is missing).
    Unknown,
    /// Below the source's standing threshold.
    Standing,
    /// Above the source's moving threshold.
    Moving,
}

/// Tuning of strategy 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionConfig {
    /// Wheel speed below which the car stands, m/s.
    pub wheel_stop_mps: f32,
    /// Wheel speed above which the car moves, m/s.
    pub wheel_move_mps: f32,
    /// GNSS reported speed below which GNSS says standing, m/s.
    pub gnss_stop_mps: f32,
    /// GNSS reported speed above which GNSS says moving, m/s.
    pub gnss_move_mps: f32,
    /// Same, from the position change when the receiver reports no speed (noisier), m/s.
    pub pos_stop_mps: f32,
    /// Moving above this speed from position change, m/s.
    pub pos_move_mps: f32,
    /// How long the two must disagree before the strategy fires, seconds.
    pub persist_s: f32,
}

impl MotionConfig {
    /// The configuration for a receiver profile: its GNSS speed thresholds, common wheel ones.
    pub fn for_profile(p: &ReceiverProfile) -> Self {
        MotionConfig {
            wheel_stop_mps: 0.3,
            wheel_move_mps: 1.0,
            gnss_stop_mps: p.gnss_speed_stop_mps,
            gnss_move_mps: p.gnss_speed_move_mps,
            pos_stop_mps: p.pos_speed_stop_mps,
            pos_move_mps: p.pos_speed_move_mps,
            persist_s: 3.0,
        }
    }
}

/// Which way the two sources disagree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Disagreement {
    /// GNSS says moving, the wheels stand.
    GnssMovingWheelsStanding,
    /// GNSS says standing, the wheels turn.
    GnssStandingWheelsMoving,
}

/// What strategy 3 concluded at one epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionOutcome {
    /// What the wheels say.
    pub wheel: MotionState,
    /// What GNSS says.
    pub gnss: MotionState,
    /// How long the current disagreement has lasted, seconds (0 when they agree).
    pub disagree_s: f32,
    /// Which way they disagree, if they do.
    pub disagreement: Option<Disagreement>,
    /// The disagreement lasted `persist_s`, or the wheels crawled on while GNSS stood.
    pub fired: bool,
}

fn hysteresis(state: MotionState, v: f32, stop: f32, mov: f32) -> MotionState {
    if v < stop {
        MotionState::Standing
    } else if v > mov {
        MotionState::Moving
    } else if state == MotionState::Unknown {
        // In the band with no history: closer to which?
        if v - stop < mov - v { MotionState::Standing } else { MotionState::Moving }
    } else {
        state
    }
}

/// Position-derived GNSS speed is taken over at least this baseline, seconds: one epoch's shift
/// of a 1 Hz receiver carries its position noise twice per second (0.7 m/s rms on the
/// sddi_commuter logger), a baseline of several epochs a fraction of it.
const POS_BASELINE_S: f64 = 3.0;
/// Positions kept for that baseline (enough at 1 Hz; at 10 Hz the baseline is the span kept).
const POS_KEPT: usize = 4;
/// A crawl is judged once the wheels covered this much while GNSS stood, metres: fifty times
/// the position noise of a 1 Hz logger at standstill (about 0.5 m).
pub const CRAWL_MIN_M: f32 = 25.0;
/// ... and GNSS's position was never farther than this fraction of the wheels' distance from
/// where it stood. The farthest, not the newest: a real crawl under GNSS noise correlated over
/// seconds can end near its start (sddi_commuter under 6 m of noise correlated over 6 s, the
/// nuisance suite's seed 35: 3.6 m from the start after the wheels' 29 m, 13.6 m on the way);
/// a frozen position never leaves it.
pub const CRAWL_FRACTION: f32 = 0.2;

#[derive(Clone, Debug)]
/// The streaming motion-state check (see the module documentation).
pub struct Motion {
    cfg: MotionConfig,
    wheel: MotionState,
    gnss: MotionState,
    since: Option<(f64, Disagreement)>,
    /// The last positions (time, position), oldest first.
    recent: [Option<(f64, crate::geo::LatLon)>; POS_KEPT],
    /// Mean square of the position-derived GNSS speed while the wheels stand, (m/s)^2: the
    /// receiver's position noise in speed (learnt only below the moving threshold, so a
    /// spoofer's motion is never learnt as noise).
    standing_ms: f32,
    /// While the wheels move and GNSS stands: GNSS's position then, the wheels' distance since,
    /// and the farthest GNSS has been from that position since.
    crawl: Option<(crate::geo::LatLon, f32, f32)>,
}

/// What the position-derived speed's mean square at standstill starts at, (m/s)^2: 0.75 m/s
/// rms, four times which is the moving threshold of 3 m/s.
const STANDING_MS_PRIOR: f32 = 0.75 * 0.75;
/// The position-derived moving threshold is at least this many times that rms.
const STANDING_RMS_FACTOR: f32 = 4.0;

impl Motion {
    /// A check with nothing seen yet.
    pub fn new(cfg: MotionConfig) -> Self {
        Self { cfg, wheel: MotionState::Unknown, gnss: MotionState::Unknown, since: None, recent: [None; POS_KEPT], standing_ms: STANDING_MS_PRIOR, crawl: None }
    }

    /// Starts over, keeping the receiver's noise at standstill (the receiver's, not the stretch's).
    pub fn reset(&mut self) {
        let standing_ms = self.standing_ms;
        *self = Motion::new(self.cfg);
        // The receiver's noise at standstill is the receiver's, not the stretch's.
        self.standing_ms = standing_ms;
    }

    /// The speed from the position change over the longest baseline kept, up to
    /// [`POS_BASELINE_S`] (at least one epoch): `None` without an earlier position.
    fn position_speed(&mut self, s: &Sample) -> Option<f32> {
        if !(s.t.is_finite() && s.pos.is_valid()) {
            self.recent = [None; POS_KEPT];
            return None;
        }
        // Positions kept must be earlier and within the baseline.
        for slot in self.recent.iter_mut() {
            if slot.is_some_and(|(t, _)| t.is_nan() || t >= s.t || s.t - t > POS_BASELINE_S + 1.5) {
                *slot = None;
            }
        }
        let oldest = self.recent.iter().flatten().find(|(t, _)| s.t - t <= POS_BASELINE_S + 1e-3).copied();
        self.recent.rotate_left(1);
        if let Some(last) = self.recent.last_mut() {
            *last = Some((s.t, s.pos));
        }
        let (t0, p0) = oldest?;
        let v = crate::geo::haversine_f32_m(p0, s.pos, crate::geo::EARTH_RADIUS_PAPER_M) / (s.t - t0) as f32;
        v.is_finite().then_some(v)
    }

    /// The distance evidence of a frozen position (see the module documentation).
    fn crawl_evidence(&mut self, s: &Sample, wv: f32) -> bool {
        let judged = self.wheel == MotionState::Moving && self.gnss == MotionState::Standing && s.pos.is_valid() && s.dt_s > 0.0 && s.dt_s <= 3.0;
        if !judged {
            self.crawl = None;
            return false;
        }
        match self.crawl.as_mut() {
            Some((p0, d, farthest)) => {
                *d += wv.max(0.0) * s.dt_s;
                let moved = crate::geo::haversine_f32_m(*p0, s.pos, crate::geo::EARTH_RADIUS_PAPER_M);
                // A distance that is not a number is no evidence of standing.
                *farthest = if moved.is_finite() { farthest.max(moved) } else { f32::INFINITY };
                *d >= CRAWL_MIN_M && *farthest < CRAWL_FRACTION * *d
            }
            None => {
                self.crawl = Some((s.pos, 0.0, 0.0));
                false
            }
        }
    }

    /// One epoch. `None` when an input is missing (degraded); the state is then forgotten, so a
    /// disagreement must build up again from fresh data.
    pub fn step(&mut self, s: &Sample) -> Option<MotionOutcome> {
        let c = self.cfg;
        let wheel_v = s.wheel_speed().get();
        // Only needed (and kept) where the receiver reports no speed.
        let pos_speed = if s.gnss_speed.is_valid() {
            self.recent = [None; POS_KEPT];
            None
        } else {
            self.position_speed(s)
        };
        // Without a reported speed: the epoch's shift and the baseline's speed must agree (both
        // above the moving threshold to move, both below the standing one to stand): position
        // noise must then fool both, and the baseline's lag touches only the transitions.
        let gnss = match (s.gnss_speed.get(), s.shift_m.get()) {
            (Some(v), _) => Some(((v, v), c.gnss_stop_mps, c.gnss_move_mps)),
            (None, Some(d)) if s.dt_s > 0.0 => {
                let v = d / s.dt_s;
                let b = pos_speed.unwrap_or(v);
                let mov = c.pos_move_mps.max(STANDING_RMS_FACTOR * gnss_guard_dsp::sqrtf(self.standing_ms));
                // While the wheels stand, the position-derived speed is the receiver's noise.
                if self.wheel == MotionState::Standing && v.is_finite() && v < mov {
                    let k = (s.dt_s / 30.0).clamp(0.0, 1.0);
                    self.standing_ms += (v * v - self.standing_ms) * k;
                    self.standing_ms = self.standing_ms.clamp(0.0, 100.0);
                }
                Some(((v.min(b), v.max(b)), c.pos_stop_mps, mov))
            }
            _ => None,
        };
        let (Some(wv), Some(((g_lo, g_hi), gstop, gmove))) = (wheel_v, gnss) else {
            self.reset();
            return None;
        };
        if !(wv.is_finite() && g_lo.is_finite() && g_hi.is_finite()) {
            self.reset();
            return None;
        }
        self.wheel = hysteresis(self.wheel, wv, c.wheel_stop_mps, c.wheel_move_mps);
        self.gnss = if g_hi < gstop {
            MotionState::Standing
        } else if g_lo > gmove {
            MotionState::Moving
        } else {
            hysteresis(self.gnss, 0.5 * (g_lo + g_hi), gstop, gmove)
        };
        // A disagreement needs evidence at this epoch, not a state the hysteresis holds: GNSS
        // above its moving threshold while the wheels stand (a receiver's noise keeps a
        // position-derived speed above 1 m/s for seconds after the car stops), or below its
        // standing threshold while the wheels turn faster than GNSS itself needs to call motion
        // (or a crawl below the GNSS noise floor would look like a frozen position).
        let crawled = self.crawl_evidence(s, wv);
        let now = match (self.wheel, self.gnss) {
            (MotionState::Standing, MotionState::Moving) if g_lo > gmove => Some(Disagreement::GnssMovingWheelsStanding),
            (MotionState::Moving, MotionState::Standing) if (wv > gmove && g_hi < gstop) || crawled => Some(Disagreement::GnssStandingWheelsMoving),
            _ => None,
        };
        let disagree_s = match (now, self.since) {
            (Some(d), Some((t0, d0))) if d == d0 && s.t >= t0 => (s.t - t0) as f32,
            (Some(d), _) => {
                self.since = Some((s.t, d));
                0.0
            }
            (None, _) => {
                self.since = None;
                0.0
            }
        };
        Some(MotionOutcome {
            wheel: self.wheel,
            gnss: self.gnss,
            disagree_s,
            disagreement: now,
            fired: now.is_some() && disagree_s >= c.persist_s,
        })
    }
}
