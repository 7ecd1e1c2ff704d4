//! Strategy 2: turns. Steering says the car turned left or right; GNSS must agree.
//!
//! Steering wheel angle is resampled to 5 Hz (as in the paper) from the per-epoch samples. When
//! no steering is measured, a proxy is derived from yaw rate and wheel speed with a kinematic
//! bicycle model, `steer = ratio * atan(wheelbase * yaw_rate / speed)` ([`TurnConfig`]); the
//! outcome says which was used.
//!
//! A *steering segment* starts when |steer| rises above `start_deg` (taken from the last 5 Hz
//! tick below `settle_deg`, but at most [`MAX_LEAD`] ticks before the rise) and ends when it
//! settles below `settle_deg` again (or after [`MAX_SEGMENT`] ticks). The segment, resampled to [`QUERY_LEN`] points, is classified
//! left / right / none by k-NN with exact banded DTW against templates learned from real drives
//! ([`TemplateSet`], read in place from a CRC-checked blob in flash). Over the same ticks, the
//! GNSS course change says left (< -`gnss_turn_deg`), right (> +`gnss_turn_deg`) or straight
//! (|change| < `gnss_straight_deg`). The strategy fires when
//! - steering says a turn and GNSS says straight or the other way, or
//! - within the last `heading_window_s`, with the wheel below `settle_deg` all along (and 2 s
//!   before), GNSS turned
//!   by more than `straight_turn_deg` beyond the course change the steering implies through the
//!   bicycle model (GNSS turns where the wheel does not).
//!
//! A segment's turn must also be implied by the steering itself (integrated through the bicycle
//! model, more than `gnss_turn_deg` the same way): a roundabout's steering can look like a turn
//! while the net heading change is small.

use super::dtw::{dtw_pruned, dtw_reference, envelope, lb_keogh, resample};
use crate::crc32::crc32;
use crate::geo::{angle_diff_deg, haversine_m, initial_bearing_deg, LatLon, EARTH_RADIUS_PAPER_M};
use crate::sample::Sample;
use heapless::Deque;

/// The default templates, made by `host-sim train turns --data ../shared/data --out
/// detector-core/models/turn_templates.bin` (seed 1) from real and simulated drives. They stay
/// in flash; [`TemplateSet::parse`] validates them in place.
pub static DEFAULT_TEMPLATES: &[u8] = include_bytes!("../../models/turn_templates.bin");

/// Points of a classified segment (and of every template).
pub const QUERY_LEN: usize = 32;
/// Longest segment, 5 Hz ticks (16 s).
pub const MAX_SEGMENT: usize = 80;
/// The most ticks a segment reaches back before |steer| rose above `start_deg` (8 s). The wheel
/// can rest between `settle_deg` and `start_deg` for minutes (a long bend, a loop ramp, waiting
/// at a light with the wheel pre-turned); the segment keeps the last 8 s of that, so the turn
/// itself always has at least as many ticks before [`MAX_SEGMENT`] ends it.
pub const MAX_LEAD: usize = MAX_SEGMENT / 2;
const RING: usize = 128;
const TICK_S: f64 = 0.2;
/// The heading check also wants the wheel straight this long before its window, seconds.
const HEADING_MARGIN_S: f32 = 2.0;
/// Largest `k` for k-NN.
pub const MAX_K: usize = 7;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum TurnClass {
    None = 0,
    Left = 1,
    Right = 2,
}

impl TurnClass {
    pub fn from_u8(x: u8) -> Option<Self> {
        match x {
            0 => Some(TurnClass::None),
            1 => Some(TurnClass::Left),
            2 => Some(TurnClass::Right),
            _ => None,
        }
    }
    pub const fn name(self) -> &'static str {
        match self {
            TurnClass::None => "none",
            TurnClass::Left => "left",
            TurnClass::Right => "right",
        }
    }
}

/// Where a template's steering came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Provenance {
    Measured = 0,
    Derived = 1,
    Simulated = 2,
}

impl Provenance {
    pub fn from_u8(x: u8) -> Option<Self> {
        match x {
            0 => Some(Provenance::Measured),
            1 => Some(Provenance::Derived),
            2 => Some(Provenance::Simulated),
            _ => None,
        }
    }
    pub const fn name(self) -> &'static str {
        match self {
            Provenance::Measured => "measured",
            Provenance::Derived => "derived",
            Provenance::Simulated => "simulated",
        }
    }
}

/// Why a template blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlobError {
    TooShort,
    BadMagic,
    BadVersion,
    BadShape,
    BadCrc,
    BadRecord,
}

/// The template blob: little-endian
/// `"GGTT" | version u16 = 1 | len u16 (= QUERY_LEN) | band u16 | count u16 | reserved u16 |
/// count x (class u8 | provenance u8 | len x i16 steering in 0.1 deg) | crc32 u32` (CRC over all
/// bytes before it).
pub const MAGIC: &[u8; 4] = b"GGTT";
pub const VERSION: u16 = 1;
const HEADER: usize = 14;

/// A validated view of a template blob. The templates stay where the bytes are (flash).
#[derive(Clone, Copy, Debug)]
pub struct TemplateSet<'a> {
    bytes: &'a [u8],
    count: usize,
    band: usize,
}

fn u16_at(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}

impl<'a> TemplateSet<'a> {
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        if bytes.len() < HEADER + 4 {
            return Err(BlobError::TooShort);
        }
        if &bytes[0..4] != MAGIC {
            return Err(BlobError::BadMagic);
        }
        if u16_at(bytes, 4) != VERSION {
            return Err(BlobError::BadVersion);
        }
        let len = u16_at(bytes, 6) as usize;
        let band = u16_at(bytes, 8) as usize;
        let count = u16_at(bytes, 10) as usize;
        if len != QUERY_LEN || band > QUERY_LEN {
            return Err(BlobError::BadShape);
        }
        let rec = 2 + 2 * len;
        if bytes.len() != HEADER + count * rec + 4 {
            return Err(BlobError::BadShape);
        }
        let body = bytes.len() - 4;
        let want = u32::from_le_bytes([bytes[body], bytes[body + 1], bytes[body + 2], bytes[body + 3]]);
        if crc32(&bytes[..body]) != want {
            return Err(BlobError::BadCrc);
        }
        let set = TemplateSet { bytes, count, band };
        for i in 0..count {
            let r = set.record(i);
            if r.first().copied().and_then(TurnClass::from_u8).is_none() || r.get(1).copied().and_then(Provenance::from_u8).is_none() {
                return Err(BlobError::BadRecord);
            }
        }
        Ok(set)
    }

    pub fn len(&self) -> usize {
        self.count
    }
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
    pub fn band(&self) -> usize {
        self.band
    }

    /// Template `i`'s bytes (empty past the end: `parse` checked the length).
    fn record(&self, i: usize) -> &'a [u8] {
        let rec = 2 + 2 * QUERY_LEN;
        self.bytes.get(HEADER + i * rec..HEADER + (i + 1) * rec).unwrap_or(&[])
    }

    /// Template `i`: class, provenance, and its series in degrees.
    pub fn get(&self, i: usize) -> (TurnClass, Provenance, [f32; QUERY_LEN]) {
        let r = self.record(i);
        let mut v = [0.0f32; QUERY_LEN];
        for (x, b) in v.iter_mut().zip(r.get(2..).unwrap_or(&[]).chunks_exact(2)) {
            *x = i16::from_le_bytes([b.first().copied().unwrap_or(0), b.get(1).copied().unwrap_or(0)]) as f32 * 0.1;
        }
        let class = r.first().copied().and_then(TurnClass::from_u8).unwrap_or(TurnClass::None);
        let provenance = r.get(1).copied().and_then(Provenance::from_u8).unwrap_or(Provenance::Measured);
        (class, provenance, v)
    }

    /// Writes a blob (host tools use this; no allocation: into `out`, returns the length).
    pub fn encode(band: u16, templates: &[(TurnClass, Provenance, [f32; QUERY_LEN])], out: &mut [u8]) -> Option<usize> {
        let rec = 2 + 2 * QUERY_LEN;
        let n = HEADER + templates.len() * rec + 4;
        if out.len() < n || templates.len() > u16::MAX as usize {
            return None;
        }
        out[0..4].copy_from_slice(MAGIC);
        out[4..6].copy_from_slice(&VERSION.to_le_bytes());
        out[6..8].copy_from_slice(&(QUERY_LEN as u16).to_le_bytes());
        out[8..10].copy_from_slice(&band.to_le_bytes());
        out[10..12].copy_from_slice(&(templates.len() as u16).to_le_bytes());
        out[12..14].copy_from_slice(&0u16.to_le_bytes());
        for (i, (c, p, v)) in templates.iter().enumerate() {
            let o = HEADER + i * rec;
            out[o] = *c as u8;
            out[o + 1] = *p as u8;
            for (k, x) in v.iter().enumerate() {
                let q = libm::roundf(x * 10.0).clamp(i16::MIN as f32, i16::MAX as f32) as i16;
                out[o + 2 + 2 * k..o + 4 + 2 * k].copy_from_slice(&q.to_le_bytes());
            }
        }
        let crc = crc32(&out[..n - 4]);
        out[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        Some(n)
    }
}

/// Result of a k-NN query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    pub class: TurnClass,
    /// Distance to the nearest template of the winning class.
    pub distance: f32,
    pub index: usize,
}

fn vote(top: &[(f32, usize, TurnClass)]) -> Option<Neighbour> {
    let mut counts = [0usize; 3];
    for t in top {
        counts[t.2 as usize] += 1;
    }
    let best = (0..3).max_by_key(|&c| (counts[c], core::cmp::Reverse(top.iter().position(|t| t.2 as usize == c).unwrap_or(usize::MAX))))?;
    let t = top.iter().find(|t| t.2 as usize == best)?;
    Some(Neighbour { class: t.2, distance: t.0, index: t.1 })
}

/// Inserts a neighbour into `top` (sorted by distance, at most `k`), after the equal ones.
fn insert(top: &mut heapless::Vec<(f32, usize, TurnClass), MAX_K>, k: usize, d: f32, i: usize, c: TurnClass) {
    if top.len() >= k && top.last().is_some_and(|l| d >= l.0) {
        return;
    }
    if top.len() >= k {
        top.pop();
    }
    // Walk to the first strictly greater entry, then shift the rest by one.
    let mut item = (d, i, c);
    let mut placed = false;
    for slot in top.iter_mut() {
        if placed || item.0 < slot.0 {
            core::mem::swap(slot, &mut item);
            placed = true;
        }
    }
    let _ = top.push(item);
}

/// k-NN with pruning (LB_Keogh on the query's envelope, early-abandoning DTW).
pub fn classify(set: &TemplateSet, q: &[f32; QUERY_LEN], k: usize) -> Option<Neighbour> {
    let k = k.clamp(1, MAX_K);
    let band = set.band();
    let (mut u, mut l) = ([0.0f32; QUERY_LEN], [0.0f32; QUERY_LEN]);
    envelope(q, band, &mut u, &mut l);
    let mut top: heapless::Vec<(f32, usize, TurnClass), MAX_K> = heapless::Vec::new();
    for i in 0..set.len() {
        let (c, _, t) = set.get(i);
        let bound = match top.last() {
            Some(l) if top.len() == k => l.0,
            _ => f32::INFINITY,
        };
        if lb_keogh(&t, &u, &l, bound) > bound {
            continue;
        }
        let d = dtw_pruned(q, &t, band, bound);
        if d.is_finite() {
            insert(&mut top, k, d, i, c);
        }
    }
    vote(&top)
}

/// The same k-NN by plain full banded DTW against every template: the reference.
pub fn classify_reference(set: &TemplateSet, q: &[f32; QUERY_LEN], k: usize) -> Option<Neighbour> {
    let k = k.clamp(1, MAX_K);
    let mut top: heapless::Vec<(f32, usize, TurnClass), MAX_K> = heapless::Vec::new();
    for i in 0..set.len() {
        let (c, _, t) = set.get(i);
        insert(&mut top, k, dtw_reference(q, &t, set.band()), i, c);
    }
    vote(&top)
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
    /// strategy 2 is degraded until it changes, seconds.
    pub stuck_s: f32,
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
        }
    }
}

/// Steering wheel angle from yaw rate and speed by the kinematic bicycle model, degrees + left.
pub fn steering_proxy_deg(yaw_rate_degps: f32, speed_mps: f32, cfg: &TurnConfig) -> Option<f32> {
    if !(yaw_rate_degps.is_finite() && speed_mps.is_finite()) {
        return None;
    }
    if speed_mps < cfg.min_speed_mps {
        return None; // yaw rate over a tiny speed says nothing about the wheel
    }
    let curvature = yaw_rate_degps.to_radians() / speed_mps;
    Some(cfg.steer_ratio * libm::atanf(cfg.wheelbase_m * curvature).to_degrees())
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
    pub distance: f32,
    /// GNSS course change over the segment, degrees (+ = right).
    pub gnss_change_deg: f32,
    /// Course change the steering implies through the bicycle model, degrees (+ = right); NaN
    /// when the speed was unknown.
    pub steering_change_deg: f32,
    pub mismatch: Option<TurnMismatch>,
    /// Steering came from the yaw-rate proxy.
    pub derived: bool,
    /// The segment's 5 Hz steering, resampled (for training and tests).
    pub query: [f32; QUERY_LEN],
    pub start_t: f64,
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

#[derive(Clone, Copy, Debug)]
struct Tick {
    t: f64,
    steer: f32,
    heading: f32,
    dist: f32,
    /// Wheel speed (else GNSS speed), m/s; NaN when unknown.
    speed: f32,
}

/// The streaming turn check. `templates = None` only segments (used to collect training turns).
#[derive(Clone, Debug)]
pub struct TurnStrategy<'a> {
    cfg: TurnConfig,
    templates: Option<TemplateSet<'a>>,
    ring: Deque<Tick, RING>,
    last: Option<(f64, f32, LatLon, f32, f32)>, // (t, steer, pos, heading, speed)
    heading_anchor: Option<LatLon>,
    heading: Option<f32>,
    dist: f32,
    next_tick: f64,
    seg_start: Option<usize>,
    quiet: Option<usize>,
    ticks: u64,
    since: f64,
    last_gnss_only_alarm_t: f64,
    /// (value, since when) of the measured steering, for the stuck-sensor check.
    same_steer: Option<(f32, f64)>,
}

impl<'a> TurnStrategy<'a> {
    pub fn new(cfg: TurnConfig, templates: Option<TemplateSet<'a>>) -> Self {
        Self {
            cfg,
            templates,
            ring: Deque::new(),
            last: None,
            heading_anchor: None,
            heading: None,
            dist: 0.0,
            next_tick: 0.0,
            seg_start: None,
            quiet: None,
            ticks: 0,
            since: f64::NAN,
            last_gnss_only_alarm_t: f64::NEG_INFINITY,
            same_steer: None,
        }
    }

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
        Some((steering_proxy_deg(yaw, speed, &self.cfg).unwrap_or(f32::NAN), true))
    }

    /// Tracks how long the measured steering has stayed bit-identical while moving.
    fn steering_stuck(&mut self, steer: f32, s: &Sample) -> bool {
        let moving = s.wheel_speed().get().or(s.gnss_speed.get()).is_some_and(|v| v >= self.cfg.min_speed_mps);
        match self.same_steer {
            Some((v, t0)) if v.to_bits() == steer.to_bits() && s.t >= t0 => moving && (s.t - t0) as f32 >= self.cfg.stuck_s,
            _ => {
                self.same_steer = Some((steer, s.t));
                false
            }
        }
    }

    /// One epoch.
    pub fn step(&mut self, s: &Sample) -> TurnStep {
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
            self.seg_start = None;
            self.quiet = None;
            self.last = None;
            return TurnStep::Degraded;
        }
        // Heading: reported course when moving, else the bearing over >= 3 m of track.
        let moving = s.gnss_speed.get().is_none_or(|v| v >= self.cfg.min_speed_mps);
        match (s.gnss_course.get(), self.heading_anchor) {
            (Some(c), _) if moving && s.gnss_speed.is_valid() => self.heading = Some(c),
            (_, Some(a)) => {
                if haversine_m(a, s.pos, EARTH_RADIUS_PAPER_M) >= 3.0 {
                    self.heading = Some(initial_bearing_deg(a, s.pos) as f32);
                    self.heading_anchor = Some(s.pos);
                }
            }
            (_, None) => self.heading_anchor = Some(s.pos),
        }
        let Some(heading) = self.heading else {
            // No heading yet: start over at the next sample.
            self.last = None;
            return TurnStep::Ran;
        };
        let shift = s.shift_m.get().filter(|d| d.is_finite() && *d < 1e4).unwrap_or(0.0);
        let speed = s.wheel_speed().get().or(s.gnss_speed.get()).filter(|v| v.is_finite()).unwrap_or(f32::NAN);
        let mut out = None;
        match self.last {
            Some((t0, st0, _, h0, v0)) if s.t > t0 && s.t - t0 <= self.cfg.max_gap_s as f64 => {
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
                    let tick = Tick {
                        t: self.next_tick,
                        steer: st0 + (steer - st0) * w,
                        heading: if w < 1.0 { h0 } else { heading },
                        dist: d0 + shift * w,
                        speed: v0 + (speed - v0) * w,
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
                self.ring.clear();
                self.seg_start = None;
                self.quiet = None;
                self.dist = 0.0;
                self.since = s.t;
                self.next_tick = s.t;
                let tick = Tick { t: s.t, steer, heading, dist: 0.0, speed };
                let _ = self.on_tick(tick, derived);
                self.next_tick = s.t + TICK_S;
            }
        }
        self.last = Some((s.t, steer, s.pos, heading, speed));
        out.map_or(TurnStep::Ran, TurnStep::Judged)
    }

    fn on_tick(&mut self, tick: Tick, derived: bool) -> Option<TurnOutcome> {
        if self.ring.is_full() {
            self.ring.pop_front();
            self.seg_start = self.seg_start.and_then(|i| i.checked_sub(1));
            self.quiet = self.quiet.and_then(|i| i.checked_sub(1));
        }
        let _ = self.ring.push_back(tick);
        self.ticks = self.ticks.wrapping_add(1);
        let idx = self.ring.len() - 1;
        let a = libm::fabsf(tick.steer);
        let c = self.cfg;
        if self.since.is_nan() {
            self.since = tick.t;
        }
        if tick.t - self.since < c.warmup_s as f64 {
            self.quiet = if a < c.settle_deg { Some(idx) } else { None };
            return None;
        }
        if a.is_nan() {
            // Steering unknown: no segment and no straight wheel can span this tick.
            self.seg_start = None;
            self.quiet = None;
            return None;
        }
        match self.seg_start {
            None => {
                if a < c.settle_deg {
                    self.quiet = Some(idx);
                } else if a > c.start_deg {
                    let earliest = idx.saturating_sub(MAX_LEAD);
                    self.seg_start = Some(self.quiet.map_or(idx, |q| q.max(earliest)));
                }
                if self.seg_start.is_none() {
                    return self.gnss_only_check(derived);
                }
                None
            }
            Some(st) => {
                let len = (idx + 1).saturating_sub(st);
                if a < c.settle_deg || len >= MAX_SEGMENT {
                    self.seg_start = None;
                    self.quiet = Some(idx);
                    if len >= c.min_ticks {
                        return self.judge(st, idx, derived);
                    }
                }
                None
            }
        }
    }

    fn course_change(&self, from: usize, to: usize) -> f32 {
        let mut net = 0.0f32;
        let mut prev: Option<f32> = None;
        for t in self.ring.iter().skip(from).take((to + 1).saturating_sub(from)) {
            if let Some(p) = prev {
                net += angle_diff_deg(p as f64, t.heading as f64) as f32;
            }
            prev = Some(t.heading);
        }
        net
    }

    fn judge(&mut self, st: usize, end: usize, derived: bool) -> Option<TurnOutcome> {
        // The segment's ticks, at most MAX_SEGMENT of them: the buffer bounds the copy, never an index.
        let mut raw = [0.0f32; MAX_SEGMENT];
        let n = (end + 1).saturating_sub(st).min(MAX_SEGMENT);
        let mut filled = 0;
        for (r, t) in raw.iter_mut().zip(self.ring.iter().skip(st).take(n)) {
            *r = t.steer;
            filled += 1;
        }
        let mut q = [0.0f32; QUERY_LEN];
        resample(raw.get(..filled).unwrap_or(&[]), &mut q);
        let change = self.course_change(st, end);
        let first = self.ring.iter().nth(st)?;
        let last = self.ring.iter().nth(end)?;
        let (start_t, end_t) = (first.t, last.t);
        if last.dist - first.dist < self.cfg.min_travel_m {
            return None; // wheel turned while (almost) standing: nothing for GNSS to show
        }
        // Heading change the steering implies (kinematic bicycle model, + = right like bearings).
        let mut implied = 0.0f32;
        for t in self.ring.iter().skip(st).take(n) {
            let curv = libm::tanf((t.steer / self.cfg.steer_ratio).to_radians()) / self.cfg.wheelbase_m;
            implied -= (t.speed * curv * TICK_S as f32).to_degrees();
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
        let mismatch = match (class, gnss) {
            _ if !implied_turn => None,
            (TurnClass::Left | TurnClass::Right, Some(TurnClass::None)) => Some(TurnMismatch::SteeringTurnGnssStraight),
            (TurnClass::Left, Some(TurnClass::Right)) | (TurnClass::Right, Some(TurnClass::Left)) => Some(TurnMismatch::Opposite),
            _ => None,
        };
        Some(TurnOutcome { steering: class, distance, gnss_change_deg: change, steering_change_deg: implied, mismatch, derived, query: q, start_t, end_t })
    }

    /// Over the last `heading_window_s` of driving (every tick at known steering and at least
    /// `min_speed_mps`), GNSS turned by more than `straight_turn_deg` beyond what the steering
    /// implies: the wheel did not do that turn.
    fn gnss_only_check(&mut self, derived: bool) -> Option<TurnOutcome> {
        let c = self.cfg;
        let last = *self.ring.back()?;
        let end = self.ring.len() - 1;
        let mut from = end;
        let mut implied = 0.0f32;
        for (i, t) in self.ring.iter().enumerate().rev() {
            let age = last.t - t.t;
            if age > (c.heading_window_s + HEADING_MARGIN_S) as f64 {
                break;
            }
            // The wheel straight over the window and a margin before it (GNSS headings lag a
            // finished turn by up to an epoch). Unknown (NaN) steering or speed fails too.
            if !(libm::fabsf(t.steer) < c.settle_deg && t.speed >= c.min_speed_mps) {
                return None;
            }
            if age > c.heading_window_s as f64 {
                continue;
            }
            if i < end {
                let curv = libm::tanf((t.steer / c.steer_ratio).to_radians()) / c.wheelbase_m;
                implied -= (t.speed * curv * TICK_S as f32).to_degrees();
            }
            from = i;
        }
        let first = self.ring.iter().nth(from)?;
        let oldest = self.ring.front()?;
        if ((last.t - oldest.t) as f32) < c.heading_window_s + HEADING_MARGIN_S - 0.5 {
            return None; // not enough history yet
        }
        let change = self.course_change(from, end);
        // One alarm per window.
        if libm::fabsf(change - implied) > c.straight_turn_deg && last.t - self.last_gnss_only_alarm_t > c.heading_window_s as f64 {
            self.last_gnss_only_alarm_t = last.t;
            return Some(TurnOutcome {
                steering: TurnClass::None,
                distance: 0.0,
                gnss_change_deg: change,
                steering_change_deg: implied,
                mismatch: Some(TurnMismatch::GnssTurnWheelStraight),
                derived,
                query: [0.0; QUERY_LEN],
                start_t: first.t,
                end_t: last.t,
            });
        }
        None
    }
}
