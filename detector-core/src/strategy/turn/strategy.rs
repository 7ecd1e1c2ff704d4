//! Strategy 2 itself: 5 Hz ticks from the epochs, the judgement of a segment (steering's class
//! by k-NN, the course change GNSS and the bicycle model say), and, in its child module
//! `heading`, the GNSS-only heading check (GNSS turns while the wheel stays straight). See the
//! [module documentation](super).

use super::dtw::resample;
use super::knn::classify;
use super::segmenter::{SegEvent, SegmentRule, Segmenter, Tick, MAX_LEAD, MAX_SEGMENT, TICK_S};
use crate::geo::{bearing_f32_deg, haversine_f32_m, LatLon, EARTH_RADIUS_PAPER_M};
use crate::sample::Sample;
use crate::vehicle::Bicycle;
use crate::wire::templates::{TemplateSet, TurnClass, QUERY_LEN};

/// The default templates, made by `host-sim train turns --data ../shared/data --out
/// detector-core/models/turn_templates.bin` (seed 1) from real and simulated drives. They stay
/// in flash; [`TemplateSet::parse`] validates them in place.
pub static DEFAULT_TEMPLATES: &[u8] = include_bytes!("../../../models/turn_templates.bin");

/// Without a reported course the GNSS heading is the bearing over at least this much track,
/// metres ...
const BEARING_BASELINE_M: f32 = 3.0;
/// ... driven within this long, seconds (1.2 m/s over the baseline; two fixes of a 1 Hz
/// receiver, with their jitter). A receiver's position error is correlated over seconds, so
/// over a short span it is nearly common to both ends and cancels in their bearing; a car
/// creeping the baseline over longer takes the error's wander into its bearing instead
/// (openxc_ford under GNSS noise of 4.7 m correlated over 5 s, nuisance seed 226: 3.4 m covered
/// in 4 s at a crawl read as a heading of 224 deg where the car pointed about 30, and the left
/// turn that followed as 72 deg right).
/// A slower baseline is dropped and measured again from where the car is, unless there is no
/// heading yet: a car that creeps out of its parking space would otherwise start its first
/// heading, and the warm-up after it, only at the road, and its first turn would go unjudged
/// (three of driveplotr_nds's held-out turns).
const BEARING_MAX_SPAN_S: f64 = 2.5;
/// The heading check also wants the wheel straight this long before its window, beyond the
/// GNSS lag allowance, seconds (one epoch of a 1 Hz receiver).
const HEADING_MARGIN_S: f32 = 1.0;

/// How late the vehicle signals may be behind the GNSS, seconds: the heading check judges the
/// GNSS course this long ago, so that the steering of its window has arrived (0.5 to 1.2 s on
/// the sddi_commuter car; the nuisance suite delays them by up to 1.5 s).
const VEHICLE_LATE_S: f32 = 1.5;

/// What the strategy keeps of the previous sample, to interpolate the ticks up to the next.
#[derive(Clone, Copy, Debug)]
struct LastSample {
    t: f64,
    steer: f32,
    heading: f32,
    speed: f32,
}

/// Tuning of strategy 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurnConfig {
    /// |steering wheel angle| that starts a segment, degrees.
    pub start_deg: f32,
    /// |steering wheel angle| below which the wheel is straight, degrees.
    pub settle_deg: f32,
    /// Shortest segment, 5 Hz ticks.
    pub min_ticks: usize,
    /// Least travel over a segment for it to be judged, metres.
    pub min_travel_m: f32,
    /// GNSS course change that makes a turn, degrees.
    pub gnss_turn_deg: f32,
    /// GNSS course change below which the track is straight, degrees.
    pub gnss_straight_deg: f32,
    /// Heading check: GNSS course change beyond the steering's by more than this, degrees ...
    pub straight_turn_deg: f32,
    /// ... within this window, seconds.
    pub heading_window_s: f32,
    /// Bicycle model for the steering proxy: wheelbase, metres, and steering ratio.
    pub wheelbase_m: f32,
    /// Steering ratio of the bicycle model (steering wheel over road wheel angle).
    pub steer_ratio: f32,
    /// Below this speed the proxy and GNSS headings mean nothing, m/s.
    pub min_speed_mps: f32,
    /// k of k-NN.
    pub k: usize,
    /// Epochs further apart than this restart the strategy, seconds.
    pub max_gap_s: f32,
    /// Nothing is judged until this much history has built up after a (re)start, seconds (a
    /// receiver's first headings are unsettled).
    pub warmup_s: f32,
    /// A measured steering angle bit-identical for this long while moving is a stuck sensor:
    /// strategy 2 is degraded until it changes, seconds ...
    pub stuck_s: f32,
    /// ... unless it is held within this of centre, degrees: a coarse sensor on a straight road
    /// reads one value for minutes (the sddi_commuter car's steps are 2.88 deg; it holds 0, one
    /// and two steps). Such a value is stuck only once the car turns under it: the GNSS course
    /// over `STUCK_TURN_S` changes at a rate the bicycle model gives more than three times this
    /// band of steering for.
    pub straight_band_deg: f32,
    /// How late the GNSS course may be behind the car's signals, seconds: a segment's course
    /// change is read this long past its end, and the heading check wants the wheel straight
    /// this long (and an epoch) before its window. Receivers and loggers lag by 0.2 to 1.8 s.
    pub gnss_lag_s: f32,
}

impl TurnConfig {
    /// The bicycle model of the steering proxy and of the heading change the steering implies.
    pub fn bicycle(&self) -> Bicycle {
        Bicycle { wheelbase_m: self.wheelbase_m, steer_ratio: self.steer_ratio, min_speed_mps: self.min_speed_mps }
    }
    fn rule(&self) -> SegmentRule {
        let trail_ticks = (self.gnss_lag_s.max(0.0) / TICK_S as f32 + 0.5) as usize;
        SegmentRule { start_deg: self.start_deg, settle_deg: self.settle_deg, min_ticks: self.min_ticks, warmup_s: self.warmup_s, trail_ticks: trail_ticks.min(MAX_LEAD) }
    }

    /// The heading check's margin before its window, seconds.
    fn heading_margin_s(&self) -> f32 {
        self.gnss_lag_s.max(0.0) + HEADING_MARGIN_S
    }
}

impl Default for TurnConfig {
    fn default() -> Self {
        TurnConfig {
            start_deg: 60.0,
            settle_deg: 20.0,
            min_ticks: 5,
            min_travel_m: 15.0,
            gnss_turn_deg: 60.0,
            gnss_straight_deg: 10.0,
            straight_turn_deg: 60.0,
            heading_window_s: 8.0,
            wheelbase_m: 2.7,
            steer_ratio: 15.0,
            min_speed_mps: 2.0,
            k: 1,
            max_gap_s: 3.0,
            warmup_s: 10.0,
            stuck_s: 10.0,
            straight_band_deg: 8.0,
            gnss_lag_s: 2.5,
        }
    }
}

/// How steering and GNSS disagree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TurnMismatch {
    /// Steering turned (left/right), GNSS went straight.
    SteeringTurnGnssStraight,
    /// Steering and GNSS turned opposite ways.
    Opposite,
    /// GNSS turned while the wheel stayed straight.
    GnssTurnWheelStraight,
}

/// A judgement of strategy 2, made when a segment ends or a GNSS-only turn is seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurnOutcome {
    /// Steering's class (None for the GNSS-only check).
    pub steering: TurnClass,
    /// DTW distance to the nearest template of that class (0 for the GNSS-only check).
    pub distance: f32,
    /// GNSS course change over the segment, degrees (+ = right).
    pub gnss_change_deg: f32,
    /// Course change the steering implies through the bicycle model, degrees (+ = right); NaN
    /// when the speed was unknown.
    pub steering_change_deg: f32,
    /// How steering and GNSS disagree, if they do (the strategy fired).
    pub mismatch: Option<TurnMismatch>,
    /// Steering came from the yaw-rate proxy.
    pub derived: bool,
    /// The segment's 5 Hz steering, resampled (for training and tests).
    pub query: [f32; QUERY_LEN],
    /// The segment's first tick, seconds.
    pub start_t: f64,
    /// The segment's last tick, seconds.
    pub end_t: f64,
}

/// What strategy 2 did at one epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TurnStep {
    /// Steering (or its yaw-rate proxy), time or position missing: not run.
    Degraded,
    /// Ran; nothing to judge at this epoch.
    Ran,
    /// A steering segment ended, or GNSS turned with the wheel straight: the judgement.
    Judged(TurnOutcome),
}

/// The streaming turn check. `templates = None` only segments (used to collect training turns).
#[derive(Clone, Debug)]
pub struct TurnStrategy<'a> {
    cfg: TurnConfig,
    templates: Option<TemplateSet<'a>>,
    seg: Segmenter,
    last: Option<LastSample>,
    /// Where the bearing's baseline starts, and when.
    heading_anchor: Option<(LatLon, f64)>,
    heading: Option<f32>,
    /// When `heading` was last measured (a course, or a bearing's newer end).
    heading_t: f64,
    /// When the wheels last rolled at `min_speed_mps` (see `step`, the heading).
    rolled_t: f64,
    dist: f32,
    next_tick: f64,
    last_gnss_only_alarm_t: f64,
    /// The heading check's largest share of its threshold over this epoch's ticks (see
    /// [`TurnStrategy::heading_share`]).
    heading_share: Option<f32>,
    /// The measured steering's value since when, for the stuck-sensor check.
    same_steer: Option<SameSteer>,
}

/// The GNSS course is compared over this long while a steering value near centre holds, seconds.
const STUCK_TURN_S: f64 = 4.0;

/// A measured steering value held bit-identical.
#[derive(Clone, Copy, Debug)]
struct SameSteer {
    value: f32,
    since: f64,
    /// The GNSS course (deg) at the start of the current comparison, and when.
    course: Option<(f32, f64)>,
    /// When the car was first seen turning under this value (a stuck sensor even near centre,
    /// once the heading check has had its windows over the turn).
    turned_at: Option<f64>,
}

impl<'a> TurnStrategy<'a> {
    /// A check with nothing seen yet, classifying with `templates`.
    pub fn new(cfg: TurnConfig, templates: Option<TemplateSet<'a>>) -> Self {
        Self {
            cfg,
            templates,
            seg: Segmenter::default(),
            last: None,
            heading_anchor: None,
            heading: None,
            heading_t: f64::NEG_INFINITY,
            rolled_t: f64::NEG_INFINITY,
            dist: 0.0,
            next_tick: 0.0,
            last_gnss_only_alarm_t: f64::NEG_INFINITY,
            heading_share: None,
            same_steer: None,
        }
    }

    /// Starts over (a time discontinuity).
    pub fn reset(&mut self) {
        *self = TurnStrategy::new(self.cfg, self.templates);
    }

    /// Steering for this sample: measured, else the yaw-rate proxy, `(value, derived)`; the
    /// value is NaN (unknown, internal only) when the proxy is undefined at low speed.
    fn steer_of(&self, s: &Sample) -> Option<(f32, bool)> {
        if let Some(v) = s.steering().get().filter(|v| v.is_finite()) {
            return Some((v, false));
        }
        let speed = s.wheel_speed().get().or(s.gnss_speed.get())?;
        let yaw = s.yaw_rate().get()?;
        Some((self.cfg.bicycle().steering_deg(yaw, speed).unwrap_or(f32::NAN), true))
    }

    /// Tracks how long the measured steering has stayed bit-identical while moving: stuck after
    /// `stuck_s` outside the straight band, or once the car turned under a value inside it.
    fn steering_stuck(&mut self, steer: f32, s: &Sample) -> bool {
        let speed = s.wheel_speed().get().or(s.gnss_speed.get()).filter(|v| *v >= self.cfg.min_speed_mps);
        let near_centre = libm::fabsf(steer) <= self.cfg.straight_band_deg;
        let (heading, bicycle, band) = (self.heading, self.cfg.bicycle(), self.cfg.straight_band_deg);
        let confirm_s = VEHICLE_LATE_S + self.cfg.heading_window_s + self.cfg.heading_margin_s();
        match &mut self.same_steer {
            Some(h) if h.value.to_bits() == steer.to_bits() && s.t >= h.since => {
                if let (Some(v), Some(course), true) = (speed, heading, near_centre) {
                    match h.course {
                        Some((c0, t0)) if s.t - t0 >= STUCK_TURN_S => {
                            let d = course - c0;
                            let d = d - 360.0 * libm::roundf(d / 360.0);
                            let implied = bicycle.steering_deg(d / (s.t - t0) as f32, v);
                            if implied.is_some_and(|a| libm::fabsf(a) > 3.0 * band) && h.turned_at.is_none() {
                                h.turned_at = Some(s.t);
                            }
                            h.course = Some((course, s.t));
                        }
                        Some(_) => {}
                        None => h.course = Some((course, s.t)),
                    }
                } else {
                    h.course = None;
                }
                // The turn under a straight-held wheel is first the heading check's to judge: the
                // GNSS turning where the wheel does not is also what a spoofed turn looks like,
                // so it must not make the strategy degraded before the check has seen it.
                let confirmed = h.turned_at.is_some_and(|ta| (s.t - ta) as f32 >= confirm_s);
                speed.is_some() && (s.t - h.since) as f32 >= self.cfg.stuck_s && (!near_centre || confirmed)
            }
            _ => {
                self.same_steer = Some(SameSteer { value: steer, since: s.t, course: None, turned_at: None });
                false
            }
        }
    }

    /// How near the heading check came to firing at the last epoch: over the windows it
    /// judged, the largest GNSS course change beyond what the steering implies, as a share of
    /// `straight_turn_deg` (at more than 1 it fires). `None`: it judged no window (the wheel
    /// turned, the car was slow, or a steering segment ran).
    pub fn heading_share(&self) -> Option<f32> {
        self.heading_share
    }

    /// One epoch.
    pub fn step(&mut self, s: &Sample) -> TurnStep {
        self.heading_share = None;
        let Some((steer, derived)) = self.steer_of(s) else {
            self.reset();
            return TurnStep::Degraded;
        };
        if !s.t.is_finite() || !s.pos.is_valid() {
            self.reset();
            return TurnStep::Degraded;
        }
        if !derived && self.steering_stuck(steer, s) {
            // Degraded, not reset: no segment or straight-wheel window may span a stuck sensor.
            self.seg.forget();
            self.last = None;
            return TurnStep::Degraded;
        }
        // Heading: reported course when moving, else the bearing over >= BEARING_BASELINE_M of
        // track, taken only until the wheels have stood (below `min_speed_mps`) for longer than
        // the GNSS may be late: standing, a receiver that wanders by metres in town makes
        // bearings of its own wander, and the heading the car then starts from is wrong
        // (openxc_ford with 2.9 m of GNSS noise at a junction: a left turn of 97 deg read as 68
        // deg to the right). The anchor follows the car meanwhile, so the first bearing after
        // it is of the road.
        let moving = s.gnss_speed.get().is_none_or(|v| v >= self.cfg.min_speed_mps);
        if s.wheel_speed().get().is_none_or(|v| v >= self.cfg.min_speed_mps) {
            self.rolled_t = s.t;
        }
        let stood = s.t - self.rolled_t > self.cfg.gnss_lag_s as f64;
        let (measured, reanchor) = match (s.gnss_course.get(), self.heading_anchor) {
            (Some(c), _) if moving && s.gnss_speed.is_valid() => (Some(c), false),
            (_, Some(_)) if stood => (None, true),
            (_, Some((a, t0))) => {
                let slow = s.t - t0 > BEARING_MAX_SPAN_S && self.heading.is_some();
                let far = haversine_f32_m(a, s.pos, EARTH_RADIUS_PAPER_M) >= BEARING_BASELINE_M;
                ((far && !slow).then(|| bearing_f32_deg(a, s.pos)), far || slow)
            }
            (_, None) => (None, true),
        };
        if measured.is_some() {
            self.heading = measured;
            self.heading_t = s.t;
        }
        if reanchor {
            self.heading_anchor = Some((s.pos, s.t));
        }
        let Some(heading) = self.heading else {
            // No heading yet: start over at the next sample.
            self.last = None;
            return TurnStep::Ran;
        };
        // The distance driven: the wheels' where they say (a receiver's noise adds metres to
        // every step of its track, and a car that creeps through a turn into a parking space
        // then reads as a judged turn), else the GNSS track's.
        let shift = s.dist_m.get().filter(|d| d.is_finite() && *d >= 0.0 && *d < 1e4)
            .or_else(|| s.shift_m.get().filter(|d| d.is_finite() && *d < 1e4))
            .unwrap_or(0.0);
        let speed = s.wheel_speed().get().or(s.gnss_speed.get()).filter(|v| v.is_finite()).unwrap_or(f32::NAN);
        // The GNSS's own speed: a bearing between fixes is as good as the track it spans.
        let gnss_speed = s.gnss_speed.get().or_else(|| s.shift_m.get().filter(|_| s.dt_s > 0.0).map(|d| d / s.dt_s)).filter(|v| v.is_finite()).unwrap_or(f32::NAN);
        let mut out = None;
        let bicycle = self.cfg.bicycle();
        match self.last {
            Some(LastSample { t: t0, steer: st0, heading: h0, speed: v0 }) if s.t > t0 && s.t - t0 <= self.cfg.max_gap_s as f64 => {
                let d0 = self.dist;
                self.dist += shift;
                // The tick clock lives within (t0, t]; never more than max_gap / tick ticks here.
                if self.next_tick <= t0 || self.next_tick > s.t + TICK_S {
                    self.next_tick = t0 + TICK_S;
                }
                // Bounded: at huge timestamps `t + TICK_S == t` in f64.
                let max_ticks = (self.cfg.max_gap_s as f64 / TICK_S) as usize + 2;
                let mut n = 0;
                while self.next_tick <= s.t && n < max_ticks {
                    n += 1;
                    let w = ((self.next_tick - t0) / (s.t - t0)) as f32;
                    let (steer, speed) = (st0 + (steer - st0) * w, v0 + (speed - v0) * w);
                    let tick = Tick {
                        t: self.next_tick,
                        steer,
                        heading: if w < 1.0 { h0 } else { heading },
                        dist: d0 + shift * w,
                        speed,
                        gnss_speed,
                        implied_deg: bicycle.heading_change_deg(steer, speed, TICK_S as f32),
                    };
                    if let Some(o) = self.on_tick(tick, derived) {
                        if out.is_none() || o.mismatch.is_some() {
                            out = Some(o);
                        }
                    }
                    self.next_tick += TICK_S;
                }
            }
            _ => {
                // Start or restart: the next tick is this sample.
                self.seg.restart(s.t);
                self.dist = 0.0;
                self.next_tick = s.t;
                let implied_deg = bicycle.heading_change_deg(steer, speed, TICK_S as f32);
                let tick = Tick { t: s.t, steer, heading, dist: 0.0, speed, gnss_speed, implied_deg };
                let _ = self.on_tick(tick, derived);
                self.next_tick = s.t + TICK_S;
            }
        }
        self.last = Some(LastSample { t: s.t, steer, heading, speed });
        out.map_or(TurnStep::Ran, TurnStep::Judged)
    }

    fn on_tick(&mut self, tick: Tick, derived: bool) -> Option<TurnOutcome> {
        match self.seg.push(tick, &self.cfg.rule()) {
            SegEvent::NoSegment => self.gnss_only_check(derived),
            SegEvent::Ended { start, end, gnss_end } => self.judge(start, end, gnss_end, derived, tick.dist),
            SegEvent::Nothing | SegEvent::InSegment => None,
        }
    }

    /// `now_dist`: the newest tick's distance (the trail's end, `gnss_end`).
    fn judge(&mut self, st: usize, end: usize, gnss_end: usize, derived: bool, now_dist: f32) -> Option<TurnOutcome> {
        // The segment's ticks, at most MAX_SEGMENT of them: the buffer bounds the copy, never an index.
        let mut raw = [0.0f32; MAX_SEGMENT];
        let n = (end + 1).saturating_sub(st).min(MAX_SEGMENT);
        let mut filled = 0;
        for (r, t) in raw.iter_mut().zip(self.seg.ticks().skip(st).take(n)) {
            *r = t.steer;
            filled += 1;
        }
        let mut q = [0.0f32; QUERY_LEN];
        resample(raw.get(..filled).unwrap_or(&[]), &mut q);
        let change = self.seg.course_change(st, gnss_end);
        let first = self.seg.tick(st)?;
        let last = self.seg.tick(end)?;
        let (start_t, end_t) = (first.t, last.t);
        if last.dist - first.dist < self.cfg.min_travel_m {
            return None; // wheel turned while (almost) standing: nothing for GNSS to show
        }
        if self.heading_t < last.t && now_dist - last.dist < BEARING_BASELINE_M {
            // No heading measured since the wheel came back, and the car has not driven the
            // baseline of one since: it crept out of the turn into a stop (a parking space, a
            // queue), and the heading held from before says nothing of the turn's end
            // (sddi_commuter's parking turn at 2262 to 2278 s of `nl_20210215_072115` under GNSS
            // noise of 5.8 m: read as straight). Not judged. A car that drove on while the GNSS
            // showed no heading (a position frozen or creeping) is judged: that is an attack's.
            return None;
        }
        // Heading change the steering implies (kinematic bicycle model, + = right like bearings).
        let mut implied = 0.0f32;
        for t in self.seg.ticks().skip(st).take(n) {
            implied += t.implied_deg;
        }
        let (class, distance) = match self.templates.as_ref().and_then(|set| classify(set, &q, self.cfg.k)) {
            Some(nb) => (nb.class, nb.distance),
            None => (TurnClass::None, f32::INFINITY),
        };
        let c = self.cfg;
        let gnss = if change > c.gnss_turn_deg {
            Some(TurnClass::Right)
        } else if change < -c.gnss_turn_deg {
            Some(TurnClass::Left)
        } else if libm::fabsf(change) < c.gnss_straight_deg {
            Some(TurnClass::None)
        } else {
            None // in between: not judged
        };
        // The steering must also imply a real turn the same way as its class (a roundabout's
        // steering can look like a turn while the net heading change is small).
        let implied_turn = match class {
            TurnClass::Left => implied < -c.gnss_turn_deg,
            TurnClass::Right => implied > c.gnss_turn_deg,
            TurnClass::None => false,
        };
        // A GNSS track that turned by more than half a circle while the steering implied less
        // than a quarter looped: a receiver without a course of its own, its position wandering
        // by metres at a crawl, makes bearings of its wander (sddi_commuter under GNSS noise of
        // 6 to 8 m, fresh nuisance seeds 44, 48, 49 and 56: right turns of about 90 deg read as
        // 215 to 244 deg left). No judged segment of the clean sddi_commuter, openxc_ford and
        // css_canedge drives turned by more than 131 deg.
        let looped = libm::fabsf(change) > 180.0 && libm::fabsf(implied) < 90.0;
        let mismatch = match (class, gnss) {
            _ if !implied_turn || looped => None,
            (TurnClass::Left | TurnClass::Right, Some(TurnClass::None)) => Some(TurnMismatch::SteeringTurnGnssStraight),
            (TurnClass::Left, Some(TurnClass::Right)) | (TurnClass::Right, Some(TurnClass::Left)) => Some(TurnMismatch::Opposite),
            _ => None,
        };
        Some(TurnOutcome { steering: class, distance, gnss_change_deg: change, steering_change_deg: implied, mismatch, derived, query: q, start_t, end_t })
    }
}

// The GNSS-only heading check, a child module: it reads the strategy's state.
mod heading;
