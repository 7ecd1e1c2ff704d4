//! What a drive's track shows: its best speed per epoch, its stops and its real turns (as
//! `inspect` counts them and the attacks place their onsets).

use detector_core::geo::{angle_diff_deg, haversine_m, initial_bearing_deg, LatLon};
use detector_core::sample::Sample;

pub const STOP_SPEED_MPS: f32 = 0.3;
pub const STOP_MIN_S: f64 = 1.0;
pub const TURN_MIN_DEG: f64 = 60.0;
pub const TURN_WINDOW_M: f64 = 60.0;
pub const TRACK_STEP_M: f64 = 5.0;

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
