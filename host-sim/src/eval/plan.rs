//! What an evaluation runs: its options, and the scenarios planned from the seed, spread
//! round-robin over the drives that can host each attack kind.

use super::fold::Protocol;
use crate::dataset::Drive;
use crate::detect::{self, PredictorKind};
use detector_core::fusion::Config;
use detector_core::sync::SyncConfig;
use gnss_data::attack::{self, AttackKind};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Seconds of clean drive replayed before each onset (at most: from the drive's start), so the
/// detector meets the attack in the state minutes of driving build, and judged after it.
pub const PRE_ONSET_S: f64 = 600.0;
pub const WINDOW_S: f64 = 120.0;

#[derive(Clone, Copy)]
pub struct EvalOptions {
    pub scenarios: usize,
    pub seed: u64,
    pub sync: SyncConfig,
    /// Changes the detector configuration (tests use it to disable strategies).
    pub tweak: Option<fn(&mut Config)>,
    /// Strategy 1's predictor.
    pub predictor: PredictorKind,
    /// How the data-derived numbers are fitted.
    pub protocol: Protocol,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self { scenarios: 10, seed: 1, sync: SyncConfig::default(), tweak: None, predictor: PredictorKind::Lstm, protocol: Protocol::LeaveOneSourceOut }
    }
}

/// The detector's configuration for drive `d`; `fold` sets the numbers fitted for its fold
/// before the options' tweak, so a tweak always has the last word.
pub fn config_for(d: &Drive, o: &EvalOptions, fold: Option<&dyn Fn(&mut Config)>) -> Config {
    let mut c = detect::config(d.profile, o.predictor);
    if let Some(f) = fold {
        f(&mut c);
    }
    if let Some(f) = o.tweak {
        f(&mut c);
    }
    c
}

/// Plans the scenarios: (kind, drive index, onset), spread round-robin over hosting drives.
pub fn plan(drives: &[Drive], o: &EvalOptions) -> Vec<(AttackKind, usize, f64, u64)> {
    let mut out = Vec::new();
    for (ki, kind) in AttackKind::ALL.into_iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(o.seed.wrapping_mul(1000).wrapping_add(ki as u64));
        let mut per_drive: Vec<(usize, Vec<f64>)> = drives
            .iter()
            .enumerate()
            .filter(|(_, d)| d.has_wheel_speed())
            .map(|(i, d)| {
                let mut c = attack::candidate_onsets(kind, &d.samples);
                c.shuffle(&mut rng);
                (i, c)
            })
            .filter(|(_, c)| !c.is_empty())
            .collect();
        per_drive.shuffle(&mut rng);
        let mut taken = 0;
        let mut round = 0;
        while taken < o.scenarios && per_drive.iter().any(|(_, c)| c.len() > round) {
            for (i, c) in &per_drive {
                if taken < o.scenarios && c.len() > round {
                    let seed = o.seed.wrapping_mul(7919).wrapping_add((ki * 1000 + taken) as u64);
                    out.push((kind, *i, c[round], seed));
                    taken += 1;
                }
            }
            round += 1;
        }
    }
    out
}

/// Drift rates of the sweep, m/s: from 0.2 m/s (the slowest the targets name) to 8 m/s.
pub const DRIFT_SWEEP_MPS: [f64; 7] = [0.2, 0.3, 0.5, 1.0, 2.0, 4.0, 8.0];

/// How many scenarios of `kind` the data can host: every candidate onset of every drive with
/// wheel speed.
pub fn capacity(drives: &[Drive], kind: AttackKind) -> usize {
    drives.iter().filter(|d| d.has_wheel_speed()).map(|d| attack::candidate_onsets(kind, &d.samples).len()).sum()
}
