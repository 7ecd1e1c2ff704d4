//! Fusion: one [`Verdict`] per epoch from all strategies, and the latched alarm.
//!
//! A strategy whose inputs are stale or missing is *degraded* at that epoch: it does not run,
//! the verdict says so with a reason code, and it can never raise an alarm. A time discontinuity
//! (time not increasing, or an epoch longer than [`ShiftConfig::max_dt_s`]) or an invalid sample
//! resets every strategy's memory, so old state is never compared with new data. What the
//! track check learnt about the car itself (delay, wheel-speed scale, gyro bias, noise) is kept
//! across a forward gap of up to [`KEEP_LEARNT_GAP_S`].
//!
//! The alarm latches: once any strategy fires, `alarm` stays true, with the first alarm's epoch,
//! until [`Detector::clear_alarm`]. Per-epoch `fired` sets are kept separately, so which
//! strategies detected which attack (the paper's Table 3) is derived from verdicts directly.

use crate::stage::{NoStopwatch, Stage, Stopwatch};
use crate::profile::ReceiverProfile;
use crate::sample::Sample;
use crate::strategy::track::calibration::Record;
use crate::strategy::track::velocity::{ACROSS, ALONG};
use crate::strategy::track::{TrackCheck, TrackConfig, TrackOutcome};
use crate::strategy::location_shift::judge::{ShiftConfig, ShiftOutcome, ShiftPredictor};
use crate::strategy::location_shift::predictor::Predictor;
use crate::strategy::motion::{Disagreement, Motion, MotionConfig, MotionOutcome};
use crate::strategy::turn::strategy::{TurnConfig, TurnOutcome, TurnStep, TurnStrategy};
use crate::strategy::{StrategyId, StrategySet};
use crate::wire::templates::TemplateSet;

/// All tuning of the detector, with documented defaults ([`Config::for_profile`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Strategy 1, location shift.
    pub shift: ShiftConfig,
    /// Strategy 3, motion state.
    pub motion: MotionConfig,
    /// Strategy 2, turns.
    pub turn: TurnConfig,
    /// Beyond the paper: the track check.
    pub track: TrackConfig,
}

impl Config {
    /// The configuration for a receiver profile: every strategy's own for it (strategy 1 with
    /// the kinematic predictor's error term).
    pub fn for_profile(p: &ReceiverProfile) -> Self {
        Config {
            shift: ShiftConfig::for_profile(p),
            motion: MotionConfig::for_profile(p),
            turn: TurnConfig::default(),
            track: TrackConfig::for_profile(p),
        }
    }

    /// [`Config::for_profile`] with strategy 1's error term of this predictor.
    pub fn for_predictor(p: &ReceiverProfile, predictor: &Predictor) -> Self {
        let mut c = Config::for_profile(p);
        c.shift.predictor_error_m = predictor.error_term_m(p);
        c
    }
}

/// The longest forward gap in the epochs across which the track check keeps what it
/// learnt about the car, seconds (tunnels, jamming; a longer gap is taken as another trip).
pub const KEEP_LEARNT_GAP_S: f64 = 60.0;

/// Why a verdict looks the way it does. A bit set; see [`Reasons`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// S1: GNSS moved further than the car could have.
    ShiftExceedsPrediction = 0,
    /// S1: GNSS moved less than the car did.
    ShiftBelowPrediction = 1,
    /// S3: GNSS moving while the wheels stand.
    GnssMovingWheelsStanding = 2,
    /// S3: GNSS standing while the wheels turn.
    GnssStandingWheelsMoving = 3,
    /// S2: steering and GNSS disagree about a turn.
    TurnMismatch = 4,
    /// Beyond the paper: the GNSS track and the car's dead reckoning disagree over 10 s.
    Track10s = 5,
    /// Beyond the paper: the same over 30 s (slower drifts).
    Track30s = 6,
    /// Degraded: the track check lacks wheel speed or a valid position.
    NoTrackInputs = 7,
    /// Degraded: the predictor lacks its inputs (e.g. wheel speed stale or missing).
    NoPrediction = 8,
    /// Degraded: no location shift (first epoch, or after a reset).
    NoGnssShift = 9,
    /// Degraded: S3 lacks wheel speed or any GNSS speed.
    NoMotionInputs = 10,
    /// Time did not increase, or the epoch was too long: all strategies restarted.
    TimeDiscontinuity = 11,
    /// The sample had an invalid time or position: all strategies restarted.
    InvalidSample = 12,
    /// Degraded: S2 lacks steering or a GNSS course.
    NoTurnInputs = 13,
    /// Degraded: S1 waits for the receiver to settle after start-up.
    GnssSettling = 14,
    /// Degraded: the track check's learnt noise leaves it blind to drifts slower than its bound:
    /// it does not judge.
    TrackUninformative = 15,
    /// Supporting: the receiver's own spoofing detection says spoofing. Never fires a strategy
    /// or raises the alarm by itself (receivers raise it on benign events); it tells whoever
    /// reads an alarm that the receiver saw it too.
    ReceiverSpoofing = 16,
    /// Beyond the paper: the GNSS velocity disagrees with the car's along the track (the
    /// velocity test; a drift along the road, a scaled speed).
    VelocityAlong = 17,
    /// Beyond the paper: the same across the track (a drift across the road, a rotated track).
    VelocityAcross = 18,
    /// This drive contradicts the car's stored calibration beyond its bounds (a tyre change,
    /// another installation, or GNSS spoofed since before the drive): it fires once, and the
    /// stored calibration is kept, not relearnt.
    CalibrationContradicted = 19,
}

impl Reason {
    /// Every reason, in bit order.
    pub const ALL: [Reason; 20] = [
        Reason::ShiftExceedsPrediction,
        Reason::ShiftBelowPrediction,
        Reason::GnssMovingWheelsStanding,
        Reason::GnssStandingWheelsMoving,
        Reason::TurnMismatch,
        Reason::Track10s,
        Reason::Track30s,
        Reason::NoTrackInputs,
        Reason::NoPrediction,
        Reason::NoGnssShift,
        Reason::NoMotionInputs,
        Reason::TimeDiscontinuity,
        Reason::InvalidSample,
        Reason::NoTurnInputs,
        Reason::GnssSettling,
        Reason::TrackUninformative,
        Reason::ReceiverSpoofing,
        Reason::VelocityAlong,
        Reason::VelocityAcross,
        Reason::CalibrationContradicted,
    ];
    /// The reason's name in JSON and reports (`shift_exceeds_prediction`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            Reason::ShiftExceedsPrediction => "shift_exceeds_prediction",
            Reason::ShiftBelowPrediction => "shift_below_prediction",
            Reason::GnssMovingWheelsStanding => "gnss_moving_wheels_standing",
            Reason::GnssStandingWheelsMoving => "gnss_standing_wheels_moving",
            Reason::TurnMismatch => "turn_mismatch",
            Reason::Track10s => "track_10s",
            Reason::Track30s => "track_30s",
            Reason::NoTrackInputs => "no_track_inputs",
            Reason::NoPrediction => "no_prediction",
            Reason::NoGnssShift => "no_gnss_shift",
            Reason::NoMotionInputs => "no_motion_inputs",
            Reason::TimeDiscontinuity => "time_discontinuity",
            Reason::InvalidSample => "invalid_sample",
            Reason::NoTurnInputs => "no_turn_inputs",
            Reason::GnssSettling => "gnss_settling",
            Reason::TrackUninformative => "track_uninformative",
            Reason::ReceiverSpoofing => "receiver_spoofing",
            Reason::VelocityAlong => "velocity_along",
            Reason::VelocityAcross => "velocity_across",
            Reason::CalibrationContradicted => "calibration_contradicted",
        }
    }
}

/// A set of [`Reason`]s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reasons(pub u32);

impl Reasons {
    /// Adds `r`.
    pub fn insert(&mut self, r: Reason) {
        self.0 |= 1 << r as u32;
    }
    /// Whether `r` is in the set.
    pub fn contains(self, r: Reason) -> bool {
        self.0 & (1 << r as u32) != 0
    }
    /// The reasons in the set, in bit order.
    pub fn iter(self) -> impl Iterator<Item = Reason> {
        Reason::ALL.into_iter().filter(move |r| self.contains(*r))
    }
}

/// The first alarm since start or the last [`Detector::clear_alarm`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstAlarm {
    /// The epoch of the first alarm.
    pub epoch: u32,
    /// Its time, seconds.
    pub t: f64,
}

/// The detector's output for one epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verdict {
    /// Epoch counter since start (every call to [`Detector::step`] is one epoch).
    pub epoch: u32,
    /// Epoch time, seconds (the sample's).
    pub t: f64,
    /// Strategies that ran at this epoch.
    pub ran: StrategySet,
    /// Strategies that fired at this epoch.
    pub fired: StrategySet,
    /// Strategies that could not run for lack of valid inputs.
    pub degraded: StrategySet,
    /// Why: what fired, what was degraded and why, what restarted.
    pub reasons: Reasons,
    /// Strategy 1's numbers, when it ran.
    pub shift: Option<ShiftOutcome>,
    /// Strategy 3's numbers, when it ran.
    pub motion: Option<MotionOutcome>,
    /// Strategy 2's judgement, at the epochs where a steering segment ended or GNSS turned.
    pub turn: Option<TurnOutcome>,
    /// Strategy 2's heading check, at the epochs it judged a window: how near it came to
    /// firing ([`TurnStrategy::heading_share`]). Not in the board's verdict digest.
    pub turn_heading: Option<f32>,
    /// Beyond the paper: the track check's windows, learnt delay and scale, when it ran.
    pub track: Option<TrackOutcome>,
    /// A strategy that ran is still in its start-up warm-up: strategy 1 waiting for the receiver
    /// to settle, or a beyond-the-paper detector still learning the car (its scale, its gyro).
    pub learning: bool,
    /// Latched alarm.
    pub alarm: bool,
    /// The first alarm since start or the last [`Detector::clear_alarm`].
    pub first_alarm: Option<FirstAlarm>,
}

/// The streaming detector: one [`Sample`] in per epoch, one [`Verdict`] out. No allocation,
/// no panic on any input.
#[derive(Clone, Debug)]
pub struct Detector<'t, P: ShiftPredictor> {
    cfg: Config,
    predictor: P,
    motion: Motion,
    turn: Option<TurnStrategy<'t>>,
    track: TrackCheck,
    prev_t: Option<f64>,
    epoch: u32,
    first_alarm: Option<FirstAlarm>,
    /// Time of the first valid epoch; S1 waits until `settle_s` after it (only at start-up).
    settling_since: Option<f64>,
    settled: bool,
}

impl<'t, P: ShiftPredictor> Detector<'t, P> {
    /// A detector with strategies 1 and 3 only.
    pub fn new(cfg: Config, predictor: P) -> Self {
        Self {
            cfg,
            predictor,
            motion: Motion::new(cfg.motion),
            turn: None,
            track: TrackCheck::new(cfg.track),
            prev_t: None,
            epoch: 0,
            first_alarm: None,
            settling_since: None,
            settled: false,
        }
    }

    /// The detector made afresh, in place, as [`Detector::new`] then [`Detector::with_turns`]
    /// would make it (each part built in turn: no whole detector of 20 KB on the stack).
    pub fn reinit(&mut self, cfg: Config, predictor: P, templates: Option<TemplateSet<'t>>) {
        self.cfg = cfg;
        self.predictor = predictor;
        self.motion = Motion::new(cfg.motion);
        self.turn = templates.map(|t| TurnStrategy::new(cfg.turn, Some(t)));
        self.track.reinit(cfg.track);
        self.prev_t = None;
        self.epoch = 0;
        self.first_alarm = None;
        self.settling_since = None;
        self.settled = false;
    }

    /// Adds strategy 2 with these turn templates.
    pub fn with_turns(mut self, templates: TemplateSet<'t>) -> Self {
        self.turn = Some(TurnStrategy::new(self.cfg.turn, Some(templates)));
        self
    }

    /// The configuration the detector runs with.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Starts the track check from the car's stored calibration (see
    /// [`crate::strategy::track::calibration`]): calibrated from the first epoch, its learning
    /// bounded around the record. A record that is not plausible is ignored (check
    /// [`Record::plausible`] first to report it).
    pub fn with_calibration(mut self, r: &Record) -> Self {
        self.track = TrackCheck::with_record(self.cfg.track, r);
        self
    }

    /// [`Detector::with_calibration`] in place (`None`: forget it, the car is learnt afresh);
    /// the track check restarts.
    pub fn set_calibration(&mut self, r: Option<&Record>) {
        self.track.load(r);
    }

    /// What this drive learnt about the car, to store for its next drive: `None` before it is
    /// calibrated and when this drive contradicts the stored record (kept, never silently
    /// relearnt).
    pub fn calibration_record(&self) -> Option<Record> {
        self.track.record()
    }

    /// The track check (its calibration, for status reports).
    pub fn track(&self) -> &TrackCheck {
        &self.track
    }

    /// Clears the latched alarm (strategies keep running; the next firing latches it again).
    pub fn clear_alarm(&mut self) {
        self.first_alarm = None;
    }

    /// Restarts every strategy. With `keep_learnt` (a forward gap of at most
    /// [`KEEP_LEARNT_GAP_S`]) the track check keeps what it learnt about the car (delay,
    /// wheel-speed scale, gyro bias, noise) and bridges the gap by dead reckoning where the
    /// vehicle signals span it: a GNSS gap, which a spoofer can cause, must neither reopen its
    /// warm-up nor hide a jump. After a longer gap (another trip), time going backwards or an
    /// invalid sample it learns afresh.
    fn restart(&mut self, keep_learnt: bool) {
        self.predictor.reset();
        self.motion.reset();
        if let Some(t) = self.turn.as_mut() {
            t.reset();
        }
        // A forward gap the track check handles itself: it bridges it by dead reckoning when
        // it can, else starts its windows over keeping what it learnt.
        if !keep_learnt {
            self.track.reset();
        }
    }

    /// Judges one epoch: one synchronised sample in, one verdict out.
    pub fn step(&mut self, s: &Sample) -> Verdict {
        self.step_timed(s, &mut NoStopwatch)
    }

    /// [`Detector::step`], telling `w` where each stage ends (the QEMU run's breakdown).
    pub fn step_timed<W: Stopwatch + ?Sized>(&mut self, s: &Sample, w: &mut W) -> Verdict {
        let epoch = self.epoch;
        self.epoch = self.epoch.wrapping_add(1);
        let mut v = Verdict {
            epoch,
            t: s.t,
            ran: StrategySet::EMPTY,
            fired: StrategySet::EMPTY,
            degraded: StrategySet::EMPTY,
            reasons: Reasons::default(),
            shift: None,
            motion: None,
            turn: None,
            turn_heading: None,
            track: None,
            learning: false,
            alarm: false,
            first_alarm: self.first_alarm,
        };
        let has_turn = self.turn.is_some();
        let track_on = self.cfg.track.enabled;
        let all_degraded = |v: &mut Verdict| {
            v.degraded.insert(StrategyId::LocationShift);
            v.degraded.insert(StrategyId::Motion);
            if has_turn {
                v.degraded.insert(StrategyId::Turn);
            }
            if track_on {
                v.degraded.insert(StrategyId::Track);
            }
        };
        if s.receiver_spoofing {
            v.reasons.insert(Reason::ReceiverSpoofing);
        }
        if !s.t.is_finite() || !s.pos.is_valid() {
            self.restart(false);
            self.prev_t = None;
            v.reasons.insert(Reason::InvalidSample);
            all_degraded(&mut v);
            v.alarm = self.first_alarm.is_some();
            return v;
        }
        let max_dt = self.cfg.shift.max_dt_s;
        let continuous = match self.prev_t {
            Some(p) => s.t > p && s.t - p <= max_dt as f64,
            None => true,
        };
        if !continuous {
            let gap_s = self.prev_t.map_or(f64::INFINITY, |p| s.t - p);
            self.restart(gap_s > 0.0 && gap_s <= KEEP_LEARNT_GAP_S);
            v.reasons.insert(Reason::TimeDiscontinuity);
        }
        self.prev_t = Some(s.t);
        if !self.settled {
            let since = *self.settling_since.get_or_insert(s.t);
            // Time going backwards ends the wait too: it must never last. (`s.t` is finite here.)
            // A 1 ms margin: `(t0 + 5) - t0` may round to 4.9999999 s, and the wait must not
            // depend on how the timestamps round (the synchroniser's margins are 1 ms too).
            self.settled = s.t < since || s.t - since >= self.cfg.shift.settle_s as f64 - 1e-3;
        }

        // Strategy 1. The predictor sees every sample so its state stays current.
        let predicted = self.predictor.predict(s);
        w.lap(Stage::Predictor);
        let mut shift_cfg = self.cfg.shift;
        let fallback = self.predictor.used_fallback();
        if fallback {
            shift_cfg.predictor_error_m = shift_cfg.fallback_error_m;
        }
        let dt_ok = continuous && s.dt_s.is_finite() && s.dt_s > 0.0 && s.dt_s <= max_dt;
        if !self.settled {
            v.reasons.insert(Reason::GnssSettling);
        }
        match (s.shift_m.get().filter(|d| d.is_finite() && *d >= 0.0), predicted.filter(|p| p.is_finite())) {
            (Some(shift), Some(pred)) if dt_ok && self.settled => {
                let mut o = shift_cfg.judge(shift, pred, s.dt_s);
                o.fallback = fallback;
                v.ran.insert(StrategyId::LocationShift);
                if o.fired {
                    v.fired.insert(StrategyId::LocationShift);
                    v.reasons.insert(if o.residual_m > 0.0 { Reason::ShiftExceedsPrediction } else { Reason::ShiftBelowPrediction });
                }
                v.shift = Some(o);
            }
            (shift, pred) => {
                v.degraded.insert(StrategyId::LocationShift);
                if pred.is_none() {
                    v.reasons.insert(Reason::NoPrediction);
                }
                if shift.is_none() || !dt_ok {
                    v.reasons.insert(Reason::NoGnssShift);
                }
            }
        }

        w.lap(Stage::ShiftJudge);

        // Strategy 3.
        match self.motion.step(s) {
            Some(o) => {
                v.ran.insert(StrategyId::Motion);
                if o.fired {
                    v.fired.insert(StrategyId::Motion);
                    v.reasons.insert(match o.disagreement {
                        Some(Disagreement::GnssMovingWheelsStanding) => Reason::GnssMovingWheelsStanding,
                        _ => Reason::GnssStandingWheelsMoving,
                    });
                }
                v.motion = Some(o);
            }
            None => {
                v.degraded.insert(StrategyId::Motion);
                v.reasons.insert(Reason::NoMotionInputs);
            }
        }

        w.lap(Stage::Motion);

        // Strategy 2.
        if let Some(ts) = self.turn.as_mut() {
            match ts.step(s) {
                step @ (TurnStep::Ran | TurnStep::Judged(_)) => {
                    v.ran.insert(StrategyId::Turn);
                    v.turn_heading = ts.heading_share();
                    if let TurnStep::Judged(o) = step {
                        if o.mismatch.is_some() {
                            v.fired.insert(StrategyId::Turn);
                            v.reasons.insert(Reason::TurnMismatch);
                        }
                        v.turn = Some(o);
                    }
                }
                TurnStep::Degraded => {
                    v.degraded.insert(StrategyId::Turn);
                    v.reasons.insert(Reason::NoTurnInputs);
                }
            }
        }

        w.lap(if v.turn.is_some() { Stage::TurnQuery } else { Stage::Turn });

        // Beyond the paper: the track check.
        if track_on {
            match self.track.step(s) {
                Some(o) if o.uninformative => {
                    v.degraded.insert(StrategyId::Track);
                    v.reasons.insert(Reason::TrackUninformative);
                    v.track = Some(o);
                }
                Some(o) => {
                    v.ran.insert(StrategyId::Track);
                    if o.any_fired() {
                        v.fired.insert(StrategyId::Track);
                    }
                    if o.fired[0] {
                        v.reasons.insert(Reason::Track10s);
                    }
                    if o.fired[1] {
                        v.reasons.insert(Reason::Track30s);
                    }
                    if let Some(f) = o.velocity.map(|x| x.fired) {
                        if f[ALONG] {
                            v.reasons.insert(Reason::VelocityAlong);
                        }
                        if f[ACROSS] {
                            v.reasons.insert(Reason::VelocityAcross);
                        }
                    }
                    if o.contradiction.is_some() {
                        v.reasons.insert(Reason::CalibrationContradicted);
                    }
                    v.track = Some(o);
                }
                None => {
                    v.degraded.insert(StrategyId::Track);
                    v.reasons.insert(Reason::NoTrackInputs);
                }
            }
        }

        w.lap(Stage::Track);

        v.learning = !self.settled || v.track.is_some_and(|t| t.learning);
        if !v.fired.is_empty() && self.first_alarm.is_none() {
            self.first_alarm = Some(FirstAlarm { epoch, t: s.t });
        }
        v.first_alarm = self.first_alarm;
        v.alarm = self.first_alarm.is_some();
        w.lap(Stage::Fusion);
        v
    }
}
