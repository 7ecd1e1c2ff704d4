//! GNSS spoofing attacks on a replay.
//!
//! A spoofer controls everything the receiver reports, so every attack rewrites the fixes'
//! position AND their reported speed and course, consistently with the spoofed track. Vehicle
//! signals are never touched. Every attack has an onset time and a seed; from the onset to the
//! end of the replay the attack is active (the ground truth per epoch).
//!
//! | kind | what the receiver reports from the onset | parameters (seeded) |
//! |---|---|---|
//! | `turn-by-turn` | the true track translated by a fixed offset: a different route that keeps the true route's turn sequence | offset 30 to 300 m, bearing 0 to 360 deg |
//! | `overshoot` | the position frozen at the onset (speed 0, course held) while the car drives on | onset while moving, 5 to 15 s before a real turn |
//! | `stop` | the position moving on along the road ahead (the car's own later track) at a plausible speed while the car stands | onset 1 s into a real standstill of >= 6 s; speed 5 to 15 m/s |
//! | `wrong-turn` | where the car turns: the track mirrored about the onset heading (it turns the other way); where it goes straight: a 90 deg turn over 6 s, left or right | onset while moving |
//! | `slow-drift` | an offset growing at 0.05 to 1 m/s along or across the road; speed and course include the drift velocity | onset while moving |
//! | `small-biased` | every epoch a further shift of 20 to 60 % of strategy 1's threshold (for the drive's receiver profile), same direction (the onset heading) | onset while moving |
//! | `direction` | same speed, the steps rotated by an angle growing at 1 to 5 deg/s (up to 90 deg) | onset while moving |
//! | `replay` | the true track delayed by 1 to 10 s (meaconing) | onset while moving |
//! | `jump` | a single offset of 300 to 1000 m in a random direction | onset while moving |

use crate::input::{Event, Replay};
use crate::tracks;
use detector_core::geo::{
    angle_diff_deg, destination, from_local, haversine_m, initial_bearing_deg, to_local, wrap_360, LatLon,
    EARTH_RADIUS_PAPER_M,
};
use detector_core::sample::{Fix, Sample};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

const R: f64 = EARTH_RADIUS_PAPER_M;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AttackKind {
    TurnByTurn,
    Overshoot,
    Stop,
    WrongTurn,
    SlowDrift,
    SmallBiased,
    Direction,
    Replay,
    Jump,
}

impl AttackKind {
    pub const ALL: [AttackKind; 9] = [
        AttackKind::TurnByTurn,
        AttackKind::Overshoot,
        AttackKind::Stop,
        AttackKind::WrongTurn,
        AttackKind::SlowDrift,
        AttackKind::SmallBiased,
        AttackKind::Direction,
        AttackKind::Replay,
        AttackKind::Jump,
    ];
    /// The stealthy kinds (beyond the paper).
    pub const STEALTHY: [AttackKind; 4] = [AttackKind::SlowDrift, AttackKind::SmallBiased, AttackKind::Direction, AttackKind::Replay];
    /// The kind of a command-line name.
    pub fn from_name(name: &str) -> Option<AttackKind> {
        AttackKind::ALL.into_iter().find(|k| k.name() == name)
    }
    pub fn name(self) -> &'static str {
        match self {
            AttackKind::TurnByTurn => "turn-by-turn",
            AttackKind::Overshoot => "overshoot",
            AttackKind::Stop => "stop",
            AttackKind::WrongTurn => "wrong-turn",
            AttackKind::SlowDrift => "slow-drift",
            AttackKind::SmallBiased => "small-biased",
            AttackKind::Direction => "direction",
            AttackKind::Replay => "replay",
            AttackKind::Jump => "jump",
        }
    }
}

/// The attack actually applied, with its drawn parameters.
#[derive(Clone, Debug, Serialize)]
pub struct AttackSpec {
    pub kind: AttackKind,
    pub seed: u64,
    pub onset_t: f64,
    /// Human-readable parameters (offset, speed, mode).
    pub params: String,
    /// The main parameter as a number (offset m, drift m/s, rotation deg/s, delay s, ...).
    pub value: f64,
}

/// An attacked replay with its ground truth.
#[derive(Clone, Debug)]
pub struct Attacked {
    pub replay: Replay,
    pub spec: AttackSpec,
    /// True and perceived positions of every fix (same order as the replay's fixes).
    pub true_track: Vec<(f64, LatLon)>,
    pub perceived: Vec<(f64, LatLon)>,
}

impl Attacked {
    /// Ground truth at time `t`: is the attack active?
    pub fn active(&self, t: f64) -> bool {
        t >= self.spec.onset_t
    }
}

fn speed(s: &Sample) -> Option<f32> {
    s.wheel_speed().get()
}

/// Times where `kind` makes sense on this drive (synchronised clean samples), in order.
/// The stealthy kinds start no earlier than this into a drive, seconds: the track check learns
/// the car during its first 30 s of driving and says so (`learning`) instead of judging.
pub const STEALTHY_FIRST_ONSET_S: f64 = 60.0;

pub fn candidate_onsets(kind: AttackKind, samples: &[Sample]) -> Vec<f64> {
    candidate_onsets_from(kind, samples, None)
}

/// [`candidate_onsets`] with the earliest onset of the moving kinds `first_s` into the drive
/// (a car that starts calibrated can be attacked from its first minute).
pub fn candidate_onsets_from(kind: AttackKind, samples: &[Sample], first_s: Option<f64>) -> Vec<f64> {
    let moving = |s: &Sample| speed(s).is_some_and(|v| v > 3.0);
    let mut out = Vec::new();
    if samples.len() < 20 {
        return out;
    }
    let t_end = samples[samples.len() - 1].t;
    match kind {
        AttackKind::TurnByTurn
        | AttackKind::WrongTurn
        | AttackKind::SlowDrift
        | AttackKind::SmallBiased
        | AttackKind::Direction
        | AttackKind::Replay
        | AttackKind::Jump => {
            // Every 20 s of driving with at least 15 s of drive left; the stealthy kinds, which
            // only the track check can see, after its warm-up.
            let first = first_s.unwrap_or(if AttackKind::STEALTHY.contains(&kind) { STEALTHY_FIRST_ONSET_S } else { 10.0 });
            let mut next = samples[0].t + first;
            for s in samples {
                if s.t >= next && moving(s) && t_end - s.t > 15.0 {
                    out.push(s.t);
                    next = s.t + 20.0;
                }
            }
        }
        AttackKind::Overshoot => {
            for turn_t in turn_starts(samples) {
                for lead in [12.0, 8.0] {
                    if let Some(s) = samples.iter().find(|s| s.t >= turn_t - lead) {
                        if moving(s) && s.t > samples[0].t + 5.0 && !out.contains(&s.t) {
                            out.push(s.t);
                            break;
                        }
                    }
                }
            }
        }
        AttackKind::Stop => {
            let mut start: Option<f64> = None;
            for s in samples {
                match speed(s) {
                    Some(v) if v < 0.3 => {
                        let t0 = *start.get_or_insert(s.t);
                        if s.t - t0 >= 6.0 && out.last().is_none_or(|&o| o < t0) {
                            out.push(t0 + 1.0);
                        }
                    }
                    _ => start = None,
                }
            }
            // The spoofed track runs along the road ahead: there must be road ahead, in time and
            // in distance (a drive that ends parked has none after its last stop: the "attack"
            // would leave the position where it is, which is no attack).
            out.retain(|&t| t_end - t > 10.0 && road_ahead_m(samples, t) >= STOP_ROAD_AHEAD_M);
        }
    }
    out
}

/// A stop attack needs this much of the car's own later track to move the spoofed car along,
/// metres (a standstill of 10 s or more at up to 15 m/s, with room).
const STOP_ROAD_AHEAD_M: f64 = 200.0;

/// The length of the car's track after `t`, metres (steps under 2 m, standing jitter, ignored).
fn road_ahead_m(samples: &[Sample], t: f64) -> f64 {
    let mut last: Option<LatLon> = None;
    let mut d = 0.0;
    for s in samples.iter().filter(|s| s.t >= t && s.pos.is_valid()) {
        match last {
            Some(q) => {
                let step = haversine_m(q, s.pos, R);
                if step >= 2.0 {
                    d += step;
                    last = Some(s.pos);
                }
            }
            None => last = Some(s.pos),
        }
    }
    d
}

/// Start times of real turns (> 60 deg within 60 m of track, as `inspect` counts them).
pub fn turn_starts(samples: &[Sample]) -> Vec<f64> {
    tracks::turn_events(samples, R).into_iter().map(|e| e.0).collect()
}

/// Parameters fixed instead of drawn from the seed (the others are drawn as always, so fixing
/// one changes nothing else): one case reproduced from the command line, or a sweep.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct AttackParams {
    /// `turn-by-turn`, `jump`: the offset, metres, and its bearing, degrees.
    pub offset_m: Option<f64>,
    pub bearing_deg: Option<f64>,
    /// `stop`: the spoofed speed, m/s.
    pub speed_mps: Option<f64>,
    /// `slow-drift`: the rate, m/s, and whether across the road (else along it).
    pub rate_mps: Option<f64>,
    pub across: Option<bool>,
    /// `small-biased`: the step per epoch, metres.
    pub step_m: Option<f64>,
    /// `direction`: the rotation rate, deg/s (+ = clockwise).
    pub deg_per_s: Option<f64>,
    /// `replay`: the delay, seconds.
    pub delay_s: Option<f64>,
    /// `wrong-turn` on a straight road: turn right (else left).
    pub right: Option<bool>,
}

impl AttackParams {
    /// Only the slow drift's rate fixed.
    pub fn drift(rate_mps: f64) -> Self {
        AttackParams { rate_mps: Some(rate_mps), ..Default::default() }
    }
}

/// Applies `kind` at `onset_t` with parameters drawn from `seed`.
pub fn apply(replay: &Replay, kind: AttackKind, seed: u64, onset_t: f64) -> Attacked {
    apply_with(replay, kind, seed, onset_t, &AttackParams::default())
}

/// [`apply`], with the parameters `fixed` sets taken instead of drawn.
pub fn apply_with(replay: &Replay, kind: AttackKind, seed: u64, onset_t: f64, fixed: &AttackParams) -> Attacked {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6e55_5f61_7474_6163);
    let fixes: Vec<Fix> = replay.fixes().copied().collect();
    let k0 = fixes.iter().position(|f| f.t >= onset_t).unwrap_or(fixes.len());
    let mut new = fixes.clone();
    let has_speed = fixes.iter().any(|f| f.speed_mps.is_some());
    let has_course = fixes.iter().any(|f| f.course_deg.is_some());
    let params;
    let mut value = f64::NAN;
    match kind {
        AttackKind::TurnByTurn | AttackKind::Jump => {
            let (lo, hi) = if kind == AttackKind::Jump { (300.0, 1000.0) } else { (30.0, 300.0) };
            let d: f64 = fixed.offset_m.unwrap_or(rng.random_range(lo..hi));
            let b: f64 = fixed.bearing_deg.unwrap_or(rng.random_range(0.0..360.0));
            value = d;
            params = format!("offset {d:.0} m toward {b:.0} deg");
            for f in new.iter_mut().skip(k0) {
                f.pos = destination(f.pos, b, d, R);
            }
        }
        AttackKind::Overshoot => {
            params = "position frozen, speed 0".into();
            if let Some(p) = fixes.get(k0) {
                let course = fixes[..=k0].iter().rev().find_map(|f| f.course_deg);
                for f in new.iter_mut().skip(k0) {
                    f.pos = p.pos;
                    f.speed_mps = has_speed.then_some(0.0);
                    f.course_deg = if has_course { course } else { None };
                }
            }
        }
        AttackKind::Stop => {
            let v: f64 = fixed.speed_mps.unwrap_or(rng.random_range(5.0..15.0));
            params = format!("moves on along the road at {v:.1} m/s");
            // The road ahead: the car's own later track, as a polyline with arc lengths.
            // Points under 2 m apart (standing jitter) are dropped so bearings mean something.
            let mut road: Vec<LatLon> = Vec::new();
            for f in &fixes[k0.min(fixes.len())..] {
                if road.last().is_none_or(|&q| haversine_m(q, f.pos, R) >= 2.0) {
                    road.push(f.pos);
                }
            }
            let mut arc = vec![0.0];
            for w in road.windows(2) {
                arc.push(arc.last().unwrap() + haversine_m(w[0], w[1], R));
            }
            for f in new.iter_mut().skip(k0) {
                let a = v * (f.t - onset_t).max(0.0);
                let (pos, brg) = along(&road, &arc, a);
                f.pos = pos;
                f.speed_mps = has_speed.then_some(v as f32);
                if has_course {
                    f.course_deg = Some(brg as f32);
                }
            }
        }
        AttackKind::WrongTurn => {
            let turn_soon = has_turn_within(&fixes, k0, 20.0);
            let origin = fixes.get(k0).map(|f| f.pos).unwrap_or_default();
            let h0 = heading_at(&fixes, k0);
            if turn_soon {
                params = format!("mirrored about the onset heading {h0:.0} deg (turns the other way)");
                let (ue, un) = (h0.to_radians().sin(), h0.to_radians().cos());
                for f in new.iter_mut().skip(k0) {
                    let (e, n) = to_local(origin, f.pos, R);
                    let dot = e * ue + n * un;
                    f.pos = from_local(origin, 2.0 * dot * ue - e, 2.0 * dot * un - n, R);
                    if let Some(c) = f.course_deg {
                        f.course_deg = Some(wrap_360(2.0 * h0 - c as f64) as f32);
                    }
                }
            } else {
                let drawn = rng.random_bool(0.5);
                let sign = if fixed.right.unwrap_or(drawn) { 1.0 } else { -1.0 };
                params = format!("turns {} by 90 deg over 6 s where the car goes straight", if sign > 0.0 { "right" } else { "left" });
                rotate_steps(&fixes, &mut new, k0, |t| sign * 90.0 * ((t - onset_t) / 6.0).clamp(0.0, 1.0));
            }
        }
        AttackKind::SlowDrift => {
            let drawn: f64 = rng.random_range(0.05..1.0);
            let r = fixed.rate_mps.unwrap_or(drawn);
            let drawn_across = rng.random_bool(0.5);
            let across = fixed.across.unwrap_or(drawn_across);
            let b = heading_at(&fixes, k0) + if across { 90.0 } else { 0.0 };
            value = r;
            params = format!("drift {r:.2} m/s {} the road", if across { "across" } else { "along" });
            for (k, f) in new.iter_mut().enumerate().skip(k0) {
                f.pos = destination(fixes[k].pos, b, r * (f.t - onset_t).max(0.0), R);
                add_velocity(f, &fixes, k, b, r);
            }
        }
        AttackKind::SmallBiased => {
            let frac: f64 = rng.random_range(0.2..0.6);
            let dts: Vec<f64> = fixes.windows(2).map(|w| w[1].t - w[0].t).filter(|d| *d > 0.0).collect();
            let mut sorted = dts.clone();
            sorted.sort_by(f64::total_cmp);
            let dt = sorted.get(sorted.len() / 2).copied().unwrap_or(1.0);
            let p = detector_core::profile::for_rate(1.0 / dt);
            let step = fixed.step_m.unwrap_or(frac * (p.kinematic_max_error_m + p.gnss_error_m) as f64);
            let b = heading_at(&fixes, k0);
            value = step;
            params = format!("{step:.2} m per epoch ({:.0} % of the {} threshold) along {b:.0} deg", step / (p.kinematic_max_error_m + p.gnss_error_m) as f64 * 100.0, p.name);
            for (n, (k, f)) in new.iter_mut().enumerate().skip(k0).enumerate() {
                f.pos = destination(fixes[k].pos, b, step * (n + 1) as f64, R);
                add_velocity(f, &fixes, k, b, step / dt);
            }
        }
        AttackKind::Direction => {
            let drawn_w: f64 = rng.random_range(1.0..5.0);
            let drawn_sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let (w, sign) = match fixed.deg_per_s {
                Some(x) => (x.abs(), if x < 0.0 { -1.0 } else { 1.0 }),
                None => (drawn_w, drawn_sign),
            };
            value = w;
            params = format!("steps rotated at {:.1} deg/s (up to 90 deg)", sign * w);
            rotate_steps(&fixes, &mut new, k0, |t| sign * (w * (t - onset_t)).clamp(0.0, 90.0));
        }
        AttackKind::Replay => {
            let d: f64 = fixed.delay_s.unwrap_or(rng.random_range(1.0..10.0));
            value = d;
            params = format!("true track delayed by {d:.1} s");
            for f in new.iter_mut().skip(k0) {
                let t = f.t - d;
                let j = fixes.partition_point(|x| x.t <= t);
                let (a, b) = (fixes[j.saturating_sub(1)], fixes[j.min(fixes.len() - 1)]);
                let w = if b.t > a.t { ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 0.0 };
                let (e, n) = to_local(a.pos, b.pos, R);
                f.pos = from_local(a.pos, e * w, n * w, R);
                f.speed_mps = a.speed_mps;
                f.course_deg = a.course_deg;
            }
        }
    }
    let mut events = Vec::with_capacity(replay.events.len());
    let mut it = new.iter();
    for e in &replay.events {
        events.push(match e {
            Event::Fix(_) => Event::Fix(*it.next().expect("same number of fixes")),
            o => *o,
        });
    }
    let mut r = replay.clone();
    r.events = events;
    Attacked {
        replay: r,
        spec: AttackSpec { kind, seed, onset_t, params, value },
        true_track: fixes.iter().map(|f| (f.t, f.pos)).collect(),
        perceived: new.iter().map(|f| (f.t, f.pos)).collect(),
    }
}

/// From fix `k0` on, the true steps rotated clockwise by `phi(t)` degrees (bearings grow
/// clockwise), chained from the onset position; the course turns with them.
fn rotate_steps(truth: &[Fix], new: &mut [Fix], k0: usize, phi: impl Fn(f64) -> f64) {
    let origin = truth.get(k0).map(|f| f.pos).unwrap_or_default();
    let (mut prev_true, mut prev_new) = (origin, origin);
    for (k, f) in new.iter_mut().enumerate().skip(k0) {
        let a = phi(f.t);
        let (e, n) = to_local(prev_true, truth[k].pos, R);
        let (sn, cs) = a.to_radians().sin_cos();
        let p = from_local(prev_new, e * cs + n * sn, -e * sn + n * cs, R);
        prev_true = truth[k].pos;
        prev_new = p;
        f.pos = p;
        if let Some(cd) = f.course_deg {
            f.course_deg = Some(wrap_360(cd as f64 + a) as f32);
        }
    }
}

/// Adds a drift velocity (`rate` m/s toward `bearing`) to a fix's reported speed and course.
fn add_velocity(f: &mut Fix, truth: &[Fix], k: usize, bearing: f64, rate: f64) {
    let course = truth[k].course_deg.map(f64::from).or_else(|| {
        let p = truth.get(k.checked_sub(1)?)?;
        (haversine_m(p.pos, truth[k].pos, R) > 0.5).then(|| initial_bearing_deg(p.pos, truth[k].pos))
    });
    let (Some(v), Some(c)) = (truth[k].speed_mps.map(f64::from), course) else { return };
    let (ve, vn) = (v * c.to_radians().sin() + rate * bearing.to_radians().sin(), v * c.to_radians().cos() + rate * bearing.to_radians().cos());
    f.speed_mps = Some((ve * ve + vn * vn).sqrt() as f32);
    if f.course_deg.is_some() {
        f.course_deg = Some(wrap_360(ve.atan2(vn).to_degrees()) as f32);
    }
}

fn along(road: &[LatLon], arc: &[f64], a: f64) -> (LatLon, f64) {
    if road.len() < 2 {
        return (road.first().copied().unwrap_or_default(), 0.0);
    }
    let i = arc.partition_point(|&x| x <= a).clamp(1, road.len() - 1);
    let brg = initial_bearing_deg(road[i - 1], road[i]);
    if a >= arc[arc.len() - 1] {
        let last_brg = initial_bearing_deg(road[road.len() - 2], road[road.len() - 1]);
        return (destination(road[road.len() - 1], last_brg, a - arc[arc.len() - 1], R), last_brg);
    }
    let seg = arc[i] - arc[i - 1];
    let w = if seg > 0.0 { (a - arc[i - 1]) / seg } else { 0.0 };
    (destination(road[i - 1], brg, w * seg, R), brg)
}

fn heading_at(fixes: &[Fix], k0: usize) -> f64 {
    // Bearing over the last ~20 m of track before the onset.
    let Some(p) = fixes.get(k0) else { return 0.0 };
    for f in fixes[..k0].iter().rev() {
        if haversine_m(f.pos, p.pos, R) > 20.0 {
            return initial_bearing_deg(f.pos, p.pos);
        }
    }
    fixes.get(k0).and_then(|f| f.course_deg).map_or(0.0, |c| c as f64)
}

fn has_turn_within(fixes: &[Fix], k0: usize, secs: f64) -> bool {
    let Some(f0) = fixes.get(k0) else { return false };
    let h0 = heading_at(fixes, k0);
    fixes[k0..].iter().take_while(|f| f.t - f0.t <= secs).any(|f| {
        haversine_m(f0.pos, f.pos, R) > 20.0 && angle_diff_deg(h0, initial_bearing_deg(f0.pos, f.pos)).abs() > 30.0
    })
}
