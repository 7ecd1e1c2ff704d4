//! The dataset: real (or simulated) drives prepared for the detector, each with its samples,
//! receiver profile and source (the folder under `drives/`, or the raw folder it came from).

use crate::detect;
use detector_core::profile::ReceiverProfile;
use detector_core::sample::{Sample, Signal};
use detector_core::sync::SyncConfig;
use gnss_data::input::{Format, Replay};
use gnss_data::replay;

/// A drive prepared for evaluation.
#[derive(Clone)]
pub struct Drive {
    pub name: String,
    pub source: String,
    pub replay: Replay,
    pub samples: Vec<Sample>,
    pub profile: &'static ReceiverProfile,
}

impl Drive {
    pub fn new(replay: Replay, sync: SyncConfig) -> Self {
        let (samples, _) = replay::synchronize(&replay, sync);
        let profile = detect::profile_of(&samples);
        let name = replay.path.file_stem().map_or("drive".into(), |s| s.to_string_lossy().into_owned());
        let source = if replay.format == Format::Simulated {
            "simulated".to_string()
        } else {
            replay.path.parent().and_then(|p| p.file_name()).map_or("?".into(), |s| s.to_string_lossy().into_owned())
        };
        Drive { name, source, replay, samples, profile }
    }

    /// The detector needs wheel speed for every strategy of this issue.
    pub fn has_wheel_speed(&self) -> bool {
        let n = self.samples.iter().filter(|s| s.signal(Signal::WheelSpeed).is_valid()).count();
        n * 2 > self.samples.len()
    }

    pub fn hours(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => (b.t - a.t) / 3600.0,
            _ => 0.0,
        }
    }
}

/// Every drive under `dir` (files, or folders searched recursively), loaded and synchronised
/// in parallel; an error names the first file that does not load.
pub fn load_drives(dir: &std::path::Path) -> Result<Vec<Drive>, gnss_data::input::InputError> {
    use rayon::prelude::*;
    let files = gnss_data::input::discover(dir).map_err(|e| gnss_data::input::InputError::file(dir, e.to_string()))?;
    if files.is_empty() {
        return Err(gnss_data::input::InputError::file(dir, "no drive found: expected .csv or .parquet drives, .jsonl traces, comma2k19 segments, HDD sessions or logs folders"));
    }
    let opts = gnss_data::input::LoadOptions::default();
    files.par_iter().map(|f| Ok(Drive::new(gnss_data::input::load(f, &opts)?, SyncConfig::default()))).collect()
}
