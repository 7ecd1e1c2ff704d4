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
