//! Synchronisation: GNSS epochs are the reference clock.
//!
//! As in Dasgupta et al., each vehicle signal is linearly interpolated to every GNSS epoch from
//! its two nearest observations (the last at or before the epoch and the first at or after it).
//! Both must lie within [`SyncConfig::max_gap_s`] of the epoch, otherwise the signal is
//! [`Reading::Stale`] at that epoch: nothing is ever extrapolated. A signal never observed since
//! the start (or the last reset) is [`Reading::Missing`] and costs no waiting.
//!
//! This is a streaming component used unchanged by the firmware and by the host replays: feed
//! fixes and observations in arrival order; a [`Sample`] is emitted once every signal of its
//! epoch is resolved, that is, once an observation after the epoch has arrived or the clock
//! (the latest accepted timestamp of any input) has passed the epoch by more than the gap.
//! The latency of an epoch is therefore at most `max_gap_s`.
//!
//! Bad input never panics and never poisons the state: non-finite values and invalid positions
//! are dropped and counted; an observation older than its signal's latest one, or a fix not
//! newer than the latest fix, is dropped and counted, unless time jumped back by more than
//! [`SyncConfig::reset_backjump_s`]. All inputs share one clock, so that is taken as a clock
//! reset and restarts synchronisation (pending epochs are emitted first, with unresolved
//! signals stale).
//!
//! Dead reckoning needs more than a value at each epoch: a gyro sampled at 100 Hz and read at a
//! 1 Hz epoch aliases its noise into degrees of heading per second. So the synchroniser also
//! integrates wheel speed and yaw rate over their observations (trapezoids) and gives each
//! sample the distance driven and the heading change since the previous epoch
//! ([`Sample::dist_m`], [`Sample::turn_deg`]): exact whatever the epoch rate, and across a GNSS
//! outage too as long as the signal itself has no gap over `max_gap_s`. The yaw rate's magnitude
//! is integrated beside it ([`Sample::turn_abs_deg`]): across an outage the net turn alone
//! cannot tell one steady bend from an S-bend, whose end lies metres to the side.

use crate::geo::{haversine_f32_m, EARTH_RADIUS_PAPER_M};
use crate::sample::{Fix, Reading, Sample, Signal};
use crate::time::before;
use heapless::Deque;

/// Observations kept per signal. CAN signals arrive at up to ~100 Hz and a GNSS sentence can be
/// late by a few hundred ms, so 32 covers the latest observation before a late epoch.
pub const HISTORY: usize = 32;
/// Epochs that may wait for their signals at once (10 Hz x 1 s gap needs 10; twice that spare).
pub const PENDING: usize = 24;

/// Tuning of the synchroniser.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SyncConfig {
    /// Largest distance in time, seconds, between an epoch and each of the two observations it is
    /// interpolated from. Default 1.0 s: OBD speed at 2 Hz and event-driven OpenXC signals at 3 Hz
    /// are always bracketed; a signal silent for longer is stale.
    pub max_gap_s: f64,
    /// A jump back in time larger than this, seconds, is a clock reset. Default 5.0 s.
    pub reset_backjump_s: f64,
    /// Earth radius for the location shift, metres. Default: the paper's 6378 km.
    pub earth_radius_m: f64,
}

impl Default for SyncConfig {
    fn default() -> Self {
        Self { max_gap_s: 1.0, reset_backjump_s: 5.0, earth_radius_m: EARTH_RADIUS_PAPER_M }
    }
}

/// What the synchroniser dropped or repaired, for diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SyncCounters {
    /// Fixes with a non-finite time or an invalid position, dropped.
    pub fixes_invalid: u32,
    /// Fixes not later than the previous one, dropped.
    pub fixes_out_of_order: u32,
    /// Vehicle observations with a non-finite time or value, dropped.
    pub obs_invalid: u32,
    /// Vehicle observations older than that signal's last, dropped.
    pub obs_out_of_order: u32,
    /// Times an input jumped back in time by more than `reset_backjump_s`: the synchroniser started over.
    pub resets: u32,
    /// Epochs emitted early because the pending queue was full.
    pub overflow_emits: u32,
}

#[derive(Clone, Copy, Debug)]
struct Obs {
    t: f64,
    v: f32,
    /// The signal's integral from its first observation to `t` (trapezoids), and the stretch
    /// it belongs to (a gap over `max_gap_s` between observations starts a new stretch).
    cum: Integral,
}

/// A running integral of a signal, within one stretch of gap-free observations.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Integral {
    value: f64,
    stretch: u32,
    /// The integral of the signal's magnitude, modulo [`ABS_WRAP`]: only its differences
    /// between epochs are read, so an `f32` that wraps keeps hours to the same precision.
    abs: f32,
}

/// Where the integral of a signal's magnitude wraps (degrees for the yaw rate): far more than
/// any epoch's turning, small enough that an `f32` keeps 0.004 of a degree.
const ABS_WRAP: f32 = 65_536.0;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    /// The reading, and the signal's integral up to the epoch when the epoch lies inside a
    /// stretch of observations.
    Done(Reading, Option<Integral>),
    Waiting,
}

struct Pending {
    fix: Fix,
    slots: [Slot; Signal::COUNT],
    /// A clock below this has certainly not passed the epoch by more than the gap: one
    /// comparison instead of a soft-float subtraction per observation on the Cortex-M4 (see
    /// [`Synchronizer::tick`]).
    within_gap_below: f64,
}

impl Pending {
    fn ready(&self) -> bool {
        self.slots.iter().all(|s| matches!(s, Slot::Done(..)))
    }
}

/// The streaming synchroniser. See the module documentation.
pub struct Synchronizer {
    cfg: SyncConfig,
    hist: [Deque<Obs, HISTORY>; Signal::COUNT],
    pending: Deque<Pending, PENDING>,
    clock: Option<f64>,
    last_fix_t: Option<f64>,
    prev_emitted: Option<Fix>,
    /// The integrals at the previously emitted epoch.
    prev_integrals: [Option<Integral>; Signal::COUNT],
    /// The wheel speed's smallest change between consecutive observations so far, m/s
    /// (infinite before any): its resolution (see [`Sample::wheel_step_mps`]).
    wheel_step: f32,
    counters: SyncCounters,
}

impl Synchronizer {
    /// A synchroniser with nothing seen yet.
    pub fn new(cfg: SyncConfig) -> Self {
        Self {
            cfg,
            hist: core::array::from_fn(|_| Deque::new()),
            pending: Deque::new(),
            clock: None,
            last_fix_t: None,
            prev_emitted: None,
            prev_integrals: [None; Signal::COUNT],
            wheel_step: f32::INFINITY,
            counters: SyncCounters::default(),
        }
    }

    /// Its configuration.
    pub fn config(&self) -> &SyncConfig {
        &self.cfg
    }

    /// What it dropped or repaired so far.
    pub fn counters(&self) -> SyncCounters {
        self.counters
    }

    /// Epochs waiting for their signals.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Feeds one vehicle-signal observation.
    pub fn push_obs(&mut self, sig: Signal, t: f64, v: f32, emit: &mut impl FnMut(&Sample)) {
        if !t.is_finite() || !v.is_finite() {
            self.counters.obs_invalid = self.counters.obs_invalid.wrapping_add(1);
            return;
        }
        self.check_clock_reset(t, emit);
        let gap = self.cfg.max_gap_s;
        let hist = &mut self.hist[sig.index()];
        if let Some(last) = hist.back().copied() {
            if before(t, last.t) {
                self.counters.obs_out_of_order = self.counters.obs_out_of_order.wrapping_add(1);
                return;
            } else if !before(last.t, t) {
                // Repeated timestamp: the newest value wins, and the integral to it follows.
                let prior = hist.iter().rev().nth(1).copied();
                let cum = match prior {
                    Some(b) if sig.integrated() => integrate(b, t, v, gap),
                    _ => last.cum,
                };
                if let Some(l) = hist.back_mut() {
                    l.v = v;
                    l.cum = cum;
                }
                self.resolve_waiting(sig);
                self.tick(emit);
                return;
            }
        }
        let cum = match hist.back() {
            Some(b) if sig.integrated() => integrate(*b, t, v, gap),
            _ => Integral { value: 0.0, stretch: 0, abs: 0.0 },
        };
        if let (Signal::WheelSpeed, Some(b)) = (sig, hist.back()) {
            // A sensor's resolution does not change: kept across resets. Changes under 1 mm/s
            // are rounding of a fine signal, not its step.
            let d = libm::fabsf(v - b.v);
            if d > 1e-3 && d < self.wheel_step {
                self.wheel_step = d;
            }
        }
        if hist.is_full() {
            hist.pop_front();
        }
        let _ = hist.push_back(Obs { t, v, cum });
        self.advance_clock(t);
        self.resolve_waiting(sig);
        self.tick(emit);
    }

    /// Feeds one GNSS fix: a new epoch.
    pub fn push_fix(&mut self, fix: Fix, emit: &mut impl FnMut(&Sample)) {
        if !fix.t.is_finite() || !fix.pos.is_valid() {
            self.counters.fixes_invalid = self.counters.fixes_invalid.wrapping_add(1);
            return;
        }
        self.check_clock_reset(fix.t, emit);
        if let Some(last) = self.last_fix_t {
            if !before(last, fix.t) {
                self.counters.fixes_out_of_order = self.counters.fixes_out_of_order.wrapping_add(1);
                return;
            }
        }
        let fix = Fix {
            speed_mps: fix.speed_mps.filter(|v| v.is_finite()),
            course_deg: fix.course_deg.filter(|v| v.is_finite()),
            h_acc_m: fix.h_acc_m.filter(|v| v.is_finite() && *v > 0.0),
            ..fix
        };
        self.last_fix_t = Some(fix.t);
        self.advance_clock(fix.t);
        let mut slots = [Slot::Waiting; Signal::COUNT];
        for sig in Signal::ALL {
            slots[sig.index()] = self.resolve(sig, fix.t);
        }
        if self.pending.is_full() {
            self.force_front(emit);
        }
        // `c < t + (gap - 1 ms)` implies `c - t < gap` exactly when the rounding of `t + ...`
        // stays under 1 ms (|t| < 1e12 s); beyond that the exact test always runs.
        let within_gap_below = if libm::fabs(fix.t) < 1e12 { fix.t + (self.cfg.max_gap_s - 1e-3) } else { f64::NEG_INFINITY };
        let _ = self.pending.push_back(Pending { fix, slots, within_gap_below });
        self.tick(emit);
    }

    /// Emits every pending epoch now, with unresolved signals stale (end of a replay).
    pub fn flush(&mut self, emit: &mut impl FnMut(&Sample)) {
        while !self.pending.is_empty() {
            self.force_front(emit);
        }
    }

    /// Emits what is pending and forgets all history, as after a power-up.
    pub fn reset(&mut self, emit: &mut impl FnMut(&Sample)) {
        self.flush(emit);
        for h in self.hist.iter_mut() {
            h.clear();
        }
        self.clock = None;
        self.last_fix_t = None;
        self.prev_emitted = None;
        self.prev_integrals = [None; Signal::COUNT];
    }

    /// All inputs share one clock: an input far behind the latest time is a clock reset.
    fn check_clock_reset(&mut self, t: f64, emit: &mut impl FnMut(&Sample)) {
        // `t >= c` (the usual case: inputs arrive in time order) settles it with one comparison
        // (`before`: integer instructions, the times are finite), the subtraction only after.
        if let Some(c) = self.clock.filter(|c| before(t, *c)) {
            self.backjump(t, c, emit);
        }
    }

    #[cold]
    #[inline(never)]
    fn backjump(&mut self, t: f64, c: f64, emit: &mut impl FnMut(&Sample)) {
        if t < c - self.cfg.reset_backjump_s {
            self.reset(emit);
            self.counters.resets = self.counters.resets.wrapping_add(1);
        }
    }

    fn advance_clock(&mut self, t: f64) {
        self.clock = Some(match self.clock {
            Some(c) if !before(c, t) => c,
            _ => t,
        });
    }

    /// The reading of `sig` at epoch `te` if it can be decided now, else `Slot::Waiting`.
    fn resolve(&self, sig: Signal, te: f64) -> Slot {
        resolve(&self.hist[sig.index()], sig.integrated(), self.cfg.max_gap_s, self.clock, te)
    }

    fn resolve_waiting(&mut self, sig: Signal) {
        let i = sig.index();
        let (hist, gap, clock) = (&self.hist[i], self.cfg.max_gap_s, self.clock);
        for p in self.pending.iter_mut() {
            if let Some(slot) = p.slots.get_mut(i) {
                if *slot == Slot::Waiting {
                    *slot = resolve(hist, sig.integrated(), gap, clock, p.fix.t);
                }
            }
        }
    }

    /// Times out waiting signals against the clock and emits every ready epoch in order.
    fn tick(&mut self, emit: &mut impl FnMut(&Sample)) {
        if let Some(c) = self.clock {
            let gap = self.cfg.max_gap_s;
            // Pending epochs are in time order, so once one is within the gap of the clock all
            // later ones are (`c - t` is monotone in `t`, rounding included).
            for p in self.pending.iter_mut().filter(|p| !p.ready()) {
                let timed_out = !before(c, p.within_gap_below) && c - p.fix.t > gap;
                if !timed_out {
                    break;
                }
                for s in p.slots.iter_mut() {
                    if *s == Slot::Waiting {
                        *s = Slot::Done(Reading::Stale, None);
                    }
                }
            }
        }
        while self.pending.front().is_some_and(Pending::ready) {
            self.force_front(emit);
        }
    }

    fn force_front(&mut self, emit: &mut impl FnMut(&Sample)) {
        let Some(p) = self.pending.pop_front() else { return };
        if !p.ready() {
            self.counters.overflow_emits = self.counters.overflow_emits.wrapping_add(1);
        }
        let mut signals = [Reading::Missing; Signal::COUNT];
        let mut integrals = [None; Signal::COUNT];
        for ((r, i), s) in signals.iter_mut().zip(integrals.iter_mut()).zip(p.slots.iter()) {
            (*r, *i) = match s {
                Slot::Done(r, i) => (*r, *i),
                Slot::Waiting => (Reading::Stale, None),
            };
        }
        let first = self.prev_emitted.is_none();
        // The integral since the previous epoch: within one stretch of observations only.
        let since_prev = |sig: Signal| -> Reading {
            let i = sig.index();
            match (signals[i], integrals[i], self.prev_integrals[i]) {
                (Reading::Missing, _, _) => Reading::Missing,
                (_, Some(now), Some(prev)) if !first && now.stretch == prev.stretch => {
                    let d = now.value - prev.value;
                    if d.is_finite() {
                        Reading::Valid(d as f32)
                    } else {
                        Reading::Stale
                    }
                }
                _ => Reading::Stale,
            }
        };
        let dist_m = since_prev(Signal::WheelSpeed);
        let turn_deg = since_prev(Signal::YawRate);
        let turn_abs_deg = match (turn_deg, integrals[Signal::YawRate.index()], self.prev_integrals[Signal::YawRate.index()]) {
            (Reading::Valid(_), Some(now), Some(prev)) => Reading::Valid(if now.abs >= prev.abs { now.abs - prev.abs } else { now.abs - prev.abs + ABS_WRAP }),
            (r, _, _) => r,
        };
        let (dt_s, shift_m) = match self.prev_emitted {
            Some(prev) if p.fix.t > prev.t => (
                (p.fix.t - prev.t) as f32,
                Reading::Valid(haversine_f32_m(prev.pos, p.fix.pos, self.cfg.earth_radius_m)),
            ),
            _ => (0.0, Reading::Missing),
        };
        let sample = Sample {
            t: p.fix.t,
            dt_s,
            pos: p.fix.pos,
            shift_m,
            gnss_speed: Reading::from_opt(p.fix.speed_mps),
            gnss_course: Reading::from_opt(p.fix.course_deg),
            gnss_h_acc: Reading::from_opt(p.fix.h_acc_m),
            receiver_spoofing: p.fix.receiver_spoofing,
            signals,
            dist_m,
            turn_deg,
            turn_abs_deg,
            wheel_step_mps: if self.wheel_step.is_finite() { self.wheel_step } else { 0.0 },
        };
        self.prev_emitted = Some(p.fix);
        self.prev_integrals = integrals;
        emit(&sample);
    }
}

/// The reading of a signal with history `hist` at epoch `te` if it can be decided now (the
/// clock at `clock`), else `Slot::Waiting`.
/// Only signals with `integrated` get the integral to the epoch (the others' is never read).
fn resolve(hist: &Deque<Obs, HISTORY>, integrated: bool, gap: f64, clock: Option<f64>, te: f64) -> Slot {
    if hist.is_empty() {
        return Slot::Done(Reading::Missing, None);
    }
    // Last observation at or before the epoch, and the one after it.
    let mut prior: Option<Obs> = None;
    let mut next: Option<Obs> = None;
    for o in hist.iter().rev() {
        if !before(te, o.t) {
            prior = Some(*o);
            break;
        }
        next = Some(*o);
    }
    match (prior, next) {
        (Some(b), _) if !before(b.t, te) => Slot::Done(Reading::Valid(b.v), integrated.then_some(b.cum)),
        (Some(b), _) if te - b.t > gap => Slot::Done(Reading::Stale, None),
        (Some(b), Some(a)) => {
            if a.t - te > gap {
                Slot::Done(Reading::Stale, None)
            } else {
                let w = ((te - b.t) / (a.t - b.t)) as f32;
                let v = b.v + (a.v - b.v) * w;
                Slot::Done(Reading::Valid(v), integrated.then(|| integrate(b, te, v, gap)))
            }
        }
        (Some(_), None) => match clock {
            Some(c) if c - te > gap => Slot::Done(Reading::Stale, None),
            _ => Slot::Waiting,
        },
        // Every kept observation is after the epoch: its predecessor is gone or never was.
        (None, _) => Slot::Done(Reading::Stale, None),
    }
}

/// The integral at `t` from the observation `b` before it, `v` the value at `t`: a new stretch
/// when `t` is more than `gap` after `b`.
fn integrate(b: Obs, t: f64, v: f32, gap: f64) -> Integral {
    let dt = t - b.t;
    if dt > gap {
        Integral { value: b.cum.value, stretch: b.cum.stretch.wrapping_add(1), abs: b.cum.abs }
    } else {
        // The trapezoid in f32 on the FPU (an epoch's few metres or degrees to seven digits),
        // accumulated in f64 so that hours of driving lose nothing.
        let abs = b.cum.abs + dt as f32 * 0.5 * (libm::fabsf(b.v) + libm::fabsf(v));
        let abs = match abs {
            a if a < ABS_WRAP => a,
            a if a < 2.0 * ABS_WRAP => a - ABS_WRAP,
            // Only a hostile value turns this far in one step.
            a if a.is_finite() => libm::fmodf(a, ABS_WRAP),
            _ => b.cum.abs,
        };
        Integral { value: b.cum.value + (dt as f32 * 0.5 * (b.v + v)) as f64, stretch: b.cum.stretch, abs }
    }
}

#[cfg(test)]
mod tests;
