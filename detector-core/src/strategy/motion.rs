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
//!   position, the *overshoot* attack. (A crawl slower than that threshold is below the GNSS
//!   noise floor and is not judged.)

use crate::profile::ReceiverProfile;
use crate::sample::Sample;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionState {
    Unknown,
    Standing,
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
    pub wheel: MotionState,
    pub gnss: MotionState,
    /// How long the current disagreement has lasted, seconds (0 when they agree).
    pub disagree_s: f32,
    pub disagreement: Option<Disagreement>,
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

/// The streaming motion-state check.
#[derive(Clone, Debug)]
pub struct Motion {
    cfg: MotionConfig,
    wheel: MotionState,
    gnss: MotionState,
    since: Option<(f64, Disagreement)>,
}

impl Motion {
    pub fn new(cfg: MotionConfig) -> Self {
        Self { cfg, wheel: MotionState::Unknown, gnss: MotionState::Unknown, since: None }
    }

    pub fn reset(&mut self) {
        *self = Motion::new(self.cfg);
    }

    /// One epoch. `None` when an input is missing (degraded); the state is then forgotten, so a
    /// disagreement must build up again from fresh data.
    pub fn step(&mut self, s: &Sample) -> Option<MotionOutcome> {
        let c = self.cfg;
        let wheel_v = s.wheel_speed().get();
        let gnss = match (s.gnss_speed.get(), s.shift_m.get()) {
            (Some(v), _) => Some((v, c.gnss_stop_mps, c.gnss_move_mps)),
            (None, Some(d)) if s.dt_s > 0.0 => Some((d / s.dt_s, c.pos_stop_mps, c.pos_move_mps)),
            _ => None,
        };
        let (Some(wv), Some((gv, gstop, gmove))) = (wheel_v, gnss) else {
            self.reset();
            return None;
        };
        if !(wv.is_finite() && gv.is_finite()) {
            self.reset();
            return None;
        }
        self.wheel = hysteresis(self.wheel, wv, c.wheel_stop_mps, c.wheel_move_mps);
        self.gnss = hysteresis(self.gnss, gv, gstop, gmove);
        let now = match (self.wheel, self.gnss) {
            (MotionState::Standing, MotionState::Moving) => Some(Disagreement::GnssMovingWheelsStanding),
            // The wheels must also be faster than GNSS itself needs to call motion, or a crawl
            // below the GNSS noise floor would look like a frozen position.
            (MotionState::Moving, MotionState::Standing) if wv > gmove => Some(Disagreement::GnssStandingWheelsMoving),
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
