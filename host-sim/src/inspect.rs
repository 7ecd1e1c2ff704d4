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

