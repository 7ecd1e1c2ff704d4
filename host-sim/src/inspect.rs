//! Per-drive summary: what `host-sim inspect` prints.
//!
//! - `gnss_hz`: epochs per second over the drive.
//! - `distance_m`: sum of the haversine location shifts between consecutive fixes.
//! - `signals`: per signal, the fraction of epochs where it is valid after synchronisation.
//! - `stops`: runs of speed < 0.3 m/s lasting >= 1 s (wheel speed where valid, else GNSS speed,
//!   else the location shift over the epoch).
//! - `turns_left` / `turns_right`: the track is thinned to points >= 5 m apart; a turn is a net
//!   heading change > 60 degrees within 60 m of track (then the window moves past it).
//!   These follow the definitions of `../shared/data/index.csv` but are our own implementation:
//!   counts can differ from the index by a few.

use crate::input::Replay;
use detector_core::geo::{angle_diff_deg, haversine_m, initial_bearing_deg, LatLon};
use detector_core::sample::{Reading, Sample, Signal};
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Clone, Debug, Serialize)]
pub struct DriveStats {
    pub path: String,
    pub format: &'static str,
    pub epochs: usize,
    pub duration_s: f64,
    pub gnss_hz: f64,
    pub distance_m: f64,
    pub signals: BTreeMap<&'static str, f64>,
    pub stops: usize,
    pub turns_left: usize,
    pub turns_right: usize,
    pub skipped_rows: usize,
    pub notes: Vec<String>,
}

pub const STOP_SPEED_MPS: f32 = 0.3;
pub const STOP_MIN_S: f64 = 1.0;
pub const TURN_MIN_DEG: f64 = 60.0;
pub const TURN_WINDOW_M: f64 = 60.0;
pub const TRACK_STEP_M: f64 = 5.0;

pub fn stats(r: &Replay, samples: &[Sample], earth_radius_m: f64) -> DriveStats {
    let n = samples.len();
    let duration_s = if n > 1 { samples[n - 1].t - samples[0].t } else { 0.0 };
    let gnss_hz = if duration_s > 0.0 { (n - 1) as f64 / duration_s } else { 0.0 };
    let distance_m: f64 = samples.iter().filter_map(|s| s.shift_m.get()).map(f64::from).sum();
    let frac = |f: &dyn Fn(&Sample) -> Reading| {
        if n == 0 { 0.0 } else { samples.iter().filter(|s| f(s).is_valid()).count() as f64 / n as f64 }
    };
    let mut signals = BTreeMap::new();
    signals.insert("gnss_speed", frac(&|s| s.gnss_speed));
    signals.insert("gnss_course", frac(&|s| s.gnss_course));
    for sig in Signal::ALL {
        signals.insert(sig.name(), frac(&|s| s.signal(sig)));
    }
    let (turns_left, turns_right) = turns(samples, earth_radius_m);
    DriveStats {
        path: r.path.display().to_string(),
        format: r.format.name(),
        epochs: n,
        duration_s,
        gnss_hz,
        distance_m,
        signals,
        stops: stops(samples),
        turns_left,
        turns_right,
        skipped_rows: r.skipped_rows,
        notes: r.notes.clone(),
    }
}

/// Best available speed at an epoch.
pub fn speed_of(s: &Sample) -> Option<f32> {
    s.wheel_speed().get().or(s.gnss_speed.get()).or_else(|| match (s.shift_m.get(), s.dt_s) {
        (Some(d), dt) if dt > 0.0 => Some(d / dt),
        _ => None,
    })
}

pub fn stops(samples: &[Sample]) -> usize {
    let mut count = 0;
    let mut start: Option<f64> = None;
    let mut counted = false;
    for s in samples {
        match speed_of(s) {
            Some(v) if v < STOP_SPEED_MPS => {
                let t0 = *start.get_or_insert(s.t);
                if !counted && s.t - t0 >= STOP_MIN_S {
                    count += 1;
                    counted = true;
                }
            }
            _ => {
                start = None;
                counted = false;
            }
        }
    }
    count
}

/// Real turns: start time and sign (+ = right) of every net heading change over
/// `TURN_MIN_DEG` within `TURN_WINDOW_M` of track thinned to `TRACK_STEP_M`.
pub fn turn_events(samples: &[Sample], r_m: f64) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64, f64)> = Vec::new(); // (t, cumulative distance, heading)
    let mut last: Option<LatLon> = None;
    let mut cum = 0.0;
    for s in samples {
        match last {
            None => last = Some(s.pos),
            Some(p) => {
                let d = haversine_m(p, s.pos, r_m);
                if d >= TRACK_STEP_M {
                    cum += d;
                    pts.push((s.t, cum, initial_bearing_deg(p, s.pos)));
                    last = Some(s.pos);
                }
            }
        }
    }
    let mut out = Vec::new();
    let mut i = 0;
    while i + 1 < pts.len() {
        let (mut net, mut j, mut hit) = (0.0, i + 1, false);
        while j < pts.len() && pts[j].1 - pts[i].1 <= TURN_WINDOW_M {
            net += angle_diff_deg(pts[j - 1].2, pts[j].2);
            if net.abs() > TURN_MIN_DEG {
                out.push((pts[i].0, net.signum()));
                hit = true;
                break;
            }
            j += 1;
        }
        i = if hit { j } else { i + 1 };
    }
    out
}

pub fn turns(samples: &[Sample], r_m: f64) -> (usize, usize) {
    let ev = turn_events(samples, r_m);
    let right = ev.iter().filter(|e| e.1 > 0.0).count();
    (ev.len() - right, right)
}
