//! Per-drive summary: what `host-sim inspect` prints.
//!
//! - `gnss_hz`: epochs per second over the drive.
//! - `fix_interval_s`, `fix_jitter_s`: the median time between consecutive fixes, and the
//!   standard deviation of the intervals within 30 % of it: how much the logger's stamps wander
//!   around the receiver's rate (a receiver computes its fixes on the GNSS second; a logger that
//!   stamps them on arrival adds its latency's spread: sddi_commuter 0.04 s, css_canedge 0.01 s).
//! - `distance_m`: sum of the haversine location shifts between consecutive fixes.
//! - `signals`: per signal, the fraction of epochs where it is valid after synchronisation.
//! - `stops`: runs of speed < 0.3 m/s lasting >= 1 s (wheel speed where valid, else GNSS speed,
//!   else the location shift over the epoch).
//! - `turns_left` / `turns_right`: the track is thinned to points >= 5 m apart; a turn is a net
//!   heading change > 60 degrees within 60 m of track (then the window moves past it).
//!   These follow the definitions of `../shared/data/index.csv` but are our own implementation:
//!   counts can differ from the index by a few.

use gnss_data::input::Replay;
use gnss_data::tracks::{stops, turns};
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
    pub fix_interval_s: f64,
    pub fix_jitter_s: f64,
    pub distance_m: f64,
    pub signals: BTreeMap<&'static str, f64>,
    pub stops: usize,
    pub turns_left: usize,
    pub turns_right: usize,
    pub skipped_rows: usize,
    pub notes: Vec<String>,
}

pub fn stats(r: &Replay, samples: &[Sample], earth_radius_m: f64) -> DriveStats {
    let n = samples.len();
    let duration_s = if n > 1 { samples[n - 1].t - samples[0].t } else { 0.0 };
    let gnss_hz = if duration_s > 0.0 { (n - 1) as f64 / duration_s } else { 0.0 };
    let (fix_interval_s, fix_jitter_s) = interval_and_jitter(samples);
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
        fix_interval_s,
        fix_jitter_s,
        distance_m,
        signals,
        stops: stops(samples),
        turns_left,
        turns_right,
        skipped_rows: r.skipped_rows,
        notes: r.notes.clone(),
    }
}

/// The median interval between consecutive epochs, and the standard deviation of the intervals
/// within 30 % of it (0, 0 with fewer than two intervals).
fn interval_and_jitter(samples: &[Sample]) -> (f64, f64) {
    let mut dt: Vec<f64> = samples.windows(2).map(|w| w[1].t - w[0].t).filter(|d| d.is_finite() && *d > 0.0).collect();
    if dt.len() < 2 {
        return (0.0, 0.0);
    }
    dt.sort_by(f64::total_cmp);
    let median = dt[dt.len() / 2];
    let near: Vec<f64> = dt.into_iter().filter(|d| (d - median).abs() <= 0.3 * median).collect();
    let mean = near.iter().sum::<f64>() / near.len() as f64;
    let var = near.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / near.len() as f64;
    (median, var.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_jitter_is_the_spread_of_the_stamps_around_the_rate() {
        let at = |t: f64| Sample { t, ..Sample::default() };
        // 1 Hz stamped +-0.05 s, one fix dropped (a 2 s interval, left out of the spread).
        let t = [0.0, 1.05, 1.95, 3.05, 5.0, 6.05, 6.95];
        let s: Vec<Sample> = t.iter().map(|&x| at(x)).collect();
        let (m, j) = interval_and_jitter(&s);
        assert!((m - 1.05).abs() < 1e-9, "{m}");
        assert!((j - 0.0837).abs() < 1e-3, "{j}");
        assert_eq!(interval_and_jitter(&s[..1]), (0.0, 0.0));
    }
}
