//! Strategy 2's segmenter: the 5 Hz ticks of the last 25.6 s, and the steering segments in them,
//! as an explicit state machine.
//!
//! ```text
//!   Idle { quiet }  --|steer| < settle-->  Idle { quiet: now }
//!   Idle { quiet }  --|steer| > start--->  Segment { start: max(quiet, now - MAX_LEAD), or now }
//!   Segment { start } --|steer| < settle, or MAX_SEGMENT ticks-->
//!                 Trailing { start, end: now, left: trail }   (when at least `min_ticks` long)
//!                 Idle { quiet: now }                          (else)
//!   Trailing { .., left } --a tick-->  Trailing { .., left - 1 }
//!   Trailing { .., left: 0 }  -->  Ended, then Idle { quiet }, or Segment if the wheel is
//!                                  turned again by then
//!   any  --steering unknown (NaN), a stuck sensor-->  Idle { quiet: None }
//! ```
//! The trail (`trail_ticks`) lets a late GNSS course (a receiver or logger that lags the car's
//! signals by a second or two) finish showing the turn before it is judged.
//! `quiet` is the last tick with the wheel straight: a segment starts there, so the turn's
//! approach is in it, but at most [`MAX_LEAD`] ticks back (the wheel can rest between `settle`
//! and `start` for minutes). During the warm-up after a (re)start nothing starts; `quiet` is
//! kept. Indices are ring positions; they move down as old ticks leave.

use crate::geo::angle_diff_f32_deg;
use heapless::Deque;

/// Longest segment, 5 Hz ticks (16 s).
pub const MAX_SEGMENT: usize = 80;
/// The most ticks a segment reaches back before |steer| rose above `start_deg` (8 s). The wheel
/// can rest between `settle_deg` and `start_deg` for minutes (a long bend, a loop ramp, waiting
/// at a light with the wheel pre-turned); the segment keeps the last 8 s of that, so the turn
/// itself always has at least as many ticks before [`MAX_SEGMENT`] ends it.
pub const MAX_LEAD: usize = MAX_SEGMENT / 2;
/// Ticks kept (25.6 s).
pub const RING: usize = 128;
/// Tick period, seconds (5 Hz, as in the paper).
pub const TICK_S: f64 = 0.2;

/// One 5 Hz tick, interpolated from the epochs around it.
#[derive(Clone, Copy, Debug)]
pub struct Tick {
    /// The tick's time, seconds.
    pub t: f64,
    /// Steering wheel angle (measured or the yaw-rate proxy), degrees + left; NaN when unknown.
    pub steer: f32,
    /// GNSS heading, degrees.
    pub heading: f32,
    /// Distance travelled since the (re)start, metres.
    pub dist: f32,
    /// Wheel speed (else GNSS speed), m/s; NaN when unknown.
    pub speed: f32,
    /// The GNSS's own speed (reported, else its track's over the epoch), m/s; NaN when unknown.
    pub gnss_speed: f32,
    /// The heading change over this tick that the steering implies (bicycle model), degrees;
    /// computed once per tick (a tangent) instead of at every look back over the window.
    pub implied_deg: f32,
}

/// Where the segmenter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// No segment.
    Idle {
        /// The ring index of the last tick with the wheel straight.
        quiet: Option<usize>,
    },
    /// A segment is open.
    Segment {
        /// Its first tick's ring index.
        start: usize,
    },
    /// A segment ended; more ticks of GNSS course are awaited.
    Trailing {
        /// Its first tick's ring index.
        start: usize,
        /// Its last tick's ring index.
        end: usize,
        /// Ticks of GNSS course still awaited.
        left: usize,
        /// As in `Idle`, for a segment that starts right after.
        quiet: Option<usize>,
    },
}

/// What one tick did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegEvent {
    /// Still warming up after a (re)start, or steering unknown: nothing to judge.
    Nothing,
    /// No segment: the wheel is not turned (the GNSS-only heading check may run).
    NoSegment,
    /// In a segment (started or continuing), or one ended too short to judge.
    InSegment,
    /// A segment ended, long enough to judge.
    Ended {
        /// Its first tick's ring index.
        start: usize,
        /// Its last tick's ring index.
        end: usize,
        /// The GNSS course is judged up to this ring index (the trail after the segment).
        gnss_end: usize,
    },
}

/// The thresholds the segmenter needs (from `TurnConfig`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentRule {
    /// A segment starts when |steering| rises above this, degrees.
    pub start_deg: f32,
    /// ... and ends when it settles below this, degrees.
    pub settle_deg: f32,
    /// Segments shorter than this many ticks are not judged.
    pub min_ticks: usize,
    /// Nothing is judged this long after a (re)start, seconds.
    pub warmup_s: f32,
    /// Ticks of GNSS course awaited after a segment ends.
    pub trail_ticks: usize,
}

/// The tick ring and the state machine. See the module documentation.
#[derive(Clone, Debug)]
pub struct Segmenter {
    ring: Deque<Tick, RING>,
    phase: Phase,
    /// Time of the (re)start; nothing is judged within the warm-up after it.
    since: f64,
}

impl Default for Segmenter {
    fn default() -> Self {
        Segmenter { ring: Deque::new(), phase: Phase::Idle { quiet: None }, since: f64::NAN }
    }
}

impl Segmenter {
    /// Starts over at time `t`: no ticks, no segment.
    pub fn restart(&mut self, t: f64) {
        self.ring.clear();
        self.phase = Phase::Idle { quiet: None };
        self.since = t;
    }

    /// No segment and no straight wheel may span what just happened (a stuck sensor).
    pub fn forget(&mut self) {
        self.phase = Phase::Idle { quiet: None };
    }

    /// Where the state machine is.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The ticks, oldest first.
    pub fn ticks(&self) -> impl DoubleEndedIterator<Item = &Tick> + ExactSizeIterator {
        self.ring.iter()
    }

    /// The tick at ring index `i` (0 the oldest).
    pub fn tick(&self, i: usize) -> Option<&Tick> {
        self.ring.iter().nth(i)
    }

    /// Ticks held.
    pub fn len(&self) -> usize {
        self.ring.len()
    }

    /// No tick held.
    pub fn is_empty(&self) -> bool {
        self.ring.is_empty()
    }

    /// Net GNSS course change over ring indices `from..=to`, degrees (+ = right).
    pub fn course_change(&self, from: usize, to: usize) -> f32 {
        let mut net = 0.0f32;
        let mut prev: Option<f32> = None;
        for t in self.ring.iter().skip(from).take((to + 1).saturating_sub(from)) {
            if let Some(p) = prev {
                net += angle_diff_f32_deg(p, t.heading);
            }
            prev = Some(t.heading);
        }
        net
    }

    /// Adds a tick and moves the state machine.
    pub fn push(&mut self, tick: Tick, rule: &SegmentRule) -> SegEvent {
        if self.ring.is_full() {
            self.ring.pop_front();
            self.phase = match self.phase {
                Phase::Idle { quiet } => Phase::Idle { quiet: quiet.and_then(|i| i.checked_sub(1)) },
                Phase::Segment { start } => match start.checked_sub(1) {
                    Some(start) => Phase::Segment { start },
                    None => Phase::Idle { quiet: None },
                },
                Phase::Trailing { start, end, left, quiet } => match (start.checked_sub(1), end.checked_sub(1)) {
                    (Some(start), Some(end)) => Phase::Trailing { start, end, left, quiet: quiet.and_then(|i| i.checked_sub(1)) },
                    _ => Phase::Idle { quiet: None },
                },
            };
        }
        let _ = self.ring.push_back(tick);
        let idx = self.ring.len() - 1;
        let a = libm::fabsf(tick.steer);
        if self.since.is_nan() {
            self.since = tick.t;
        }
        if tick.t - self.since < rule.warmup_s as f64 {
            self.phase = Phase::Idle { quiet: (a < rule.settle_deg).then_some(idx) };
            return SegEvent::Nothing;
        }
        if a.is_nan() {
            // Steering unknown: no segment and no straight wheel can span this tick.
            self.phase = Phase::Idle { quiet: None };
            return SegEvent::Nothing;
        }
        match self.phase {
            Phase::Idle { quiet } => {
                if a < rule.settle_deg {
                    self.phase = Phase::Idle { quiet: Some(idx) };
                    SegEvent::NoSegment
                } else if a > rule.start_deg {
                    let earliest = idx.saturating_sub(MAX_LEAD);
                    self.phase = Phase::Segment { start: quiet.map_or(idx, |q| q.max(earliest)) };
                    SegEvent::InSegment
                } else {
                    SegEvent::NoSegment
                }
            }
            Phase::Segment { start } => {
                let len = (idx + 1).saturating_sub(start);
                if a < rule.settle_deg || len >= MAX_SEGMENT {
                    let quiet = (a < rule.settle_deg).then_some(idx);
                    self.phase = if len >= rule.min_ticks {
                        Phase::Trailing { start, end: idx, left: rule.trail_ticks, quiet }
                    } else {
                        Phase::Idle { quiet }
                    };
                    if len >= rule.min_ticks && rule.trail_ticks == 0 {
                        self.phase = Phase::Idle { quiet };
                        return SegEvent::Ended { start, end: idx, gnss_end: idx };
                    }
                }
                SegEvent::InSegment
            }
            Phase::Trailing { start, end, left, quiet } => {
                let quiet = if a < rule.settle_deg { Some(idx) } else { quiet };
                if left > 1 {
                    self.phase = Phase::Trailing { start, end, left: left - 1, quiet };
                    return SegEvent::InSegment;
                }
                // The trail is complete: judge; the wheel may already be in the next turn.
                self.phase = if a > rule.start_deg {
                    let earliest = idx.saturating_sub(MAX_LEAD);
                    Phase::Segment { start: quiet.map_or(idx, |q| q.max(earliest).max(end)) }
                } else {
                    Phase::Idle { quiet }
                };
                SegEvent::Ended { start, end, gnss_end: idx }
            }
        }
    }
}
