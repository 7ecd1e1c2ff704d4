//! The LSTM's data: runs of consecutive epochs with every input valid, the split by drive into
//! training and validation, and a predictor's errors over runs (what `eval` and `train` share).

use crate::dataset::Drive;
use detector_core::sample::Sample;
use detector_core::strategy::location_shift::lstm::{LstmInputs, LstmKernel, LstmPredictor, N_IN};
use detector_core::strategy::location_shift::{KinematicPredictor, ShiftPredictor};
use serde::Serialize;

/// Consecutive epochs with every input valid.
#[derive(Clone, Debug)]
pub struct Run {
    pub drive: String,
    /// 0 = 10 Hz profile, 1 = 1 Hz profile.
    pub class: usize,
    /// Index of each step's sample in the drive.
    pub idx: Vec<usize>,
    pub x: Vec<[f32; N_IN]>,
    /// Target: this epoch's GNSS shift per second.
    pub y: Vec<f32>,
    pub dt: Vec<f32>,
}

/// The runs of a drive, exactly as the streaming predictor sees its samples.
pub fn runs_of(name: &str, samples: &[Sample], class: usize) -> Vec<Run> {
    let mut inputs = LstmInputs::default();
    let mut out = Vec::new();
    let mut cur: Option<Run> = None;
    let mut prev_t: Option<f64> = None;
    for (i, s) in samples.iter().enumerate() {
        // The detector restarts its predictor on the same discontinuities.
        let continuous = prev_t.is_none_or(|p| s.t > p && s.t - p <= inputs.max_dt_s as f64);
        prev_t = Some(s.t);
        if !continuous {
            inputs.reset();
        }
        let x = inputs.next(s);
        let y = inputs.shift_mps(s);
        match (x, y, continuous) {
            (Some(x), Some(y), true) => {
                let r = cur.get_or_insert_with(|| Run { drive: name.into(), class, idx: vec![], x: vec![], y: vec![], dt: vec![] });
                r.idx.push(i);
                r.x.push(x);
                r.y.push(y);
                r.dt.push(s.dt_s);
            }
            _ => out.extend(cur.take()),
        }
    }
    out.extend(cur);
    out
}

#[derive(Clone, Debug)]
pub struct TrainOptions {
    pub h1: usize,
    pub h2: usize,
    pub max_epochs: usize,
    pub patience: usize,
    pub batch: usize,
    pub lr: f64,
    /// Training window length, epochs.
    pub window: usize,
    pub seed: u64,
    /// Drives held out for validation: a source folder name, or part of a file stem.
    pub val: Vec<String>,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            h1: 128,
            h2: 64,
            max_epochs: 500,
            patience: 25,
            batch: 50,
            lr: 0.01,
            window: 32,
            seed: 42,
            val: vec!["comma2k19".into(), "session1".into()],
        }
    }
}

/// Errors in metres of one predictor over the same validation epochs of one profile.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ErrStats {
    pub epochs: usize,
    pub rmse_m: f64,
    pub max_abs_m: f64,
    pub mae_m: f64,
}

impl ErrStats {
    pub fn of(e: &[f64]) -> Self {
        let n = e.len().max(1) as f64;
        ErrStats {
            epochs: e.len(),
            rmse_m: (e.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
            max_abs_m: e.iter().fold(0.0, |a, v| a.max(v.abs())),
            mae_m: e.iter().map(|v| v.abs()).sum::<f64>() / n,
        }
    }
}

/// The core's streaming step over a run (state carried), predicted shift per second.
pub fn stream_predict<K: LstmKernel>(p: &mut LstmPredictor<K>, run: &Run) -> Vec<f32> {
    ShiftPredictor::reset(p);
    run.x.iter().map(|x| p.step_raw(*x)).collect()
}

/// Signed errors in metres `[10 Hz, 1 Hz]` of an LSTM kernel's streaming step over the runs.
pub fn lstm_errors<K: LstmKernel>(p: &mut LstmPredictor<K>, runs: &[Run]) -> [Vec<f64>; 2] {
    let mut e: [Vec<f64>; 2] = Default::default();
    for run in runs {
        let pred = stream_predict(p, run);
        for (j, v) in pred.iter().enumerate() {
            let dt = run.dt[j] as f64;
            e[run.class].push(v.max(0.0) as f64 * dt - run.y[j] as f64 * dt);
        }
    }
    e
}

/// Signed errors in metres `[10 Hz, 1 Hz]` of the kinematic predictor on the same epochs.
pub fn kinematic_errors(runs: &[Run], drives: &[Drive]) -> [Vec<f64>; 2] {
    let mut e: [Vec<f64>; 2] = Default::default();
    for run in runs {
        let Some(d) = drives.iter().find(|d| d.name == run.drive) else { continue };
        let mut kin = KinematicPredictor::default();
        let pred: Vec<Option<f32>> = d.samples.iter().map(|s| kin.predict(s)).collect();
        for (j, &i) in run.idx.iter().enumerate() {
            if let Some(kp) = pred[i] {
                e[run.class].push(kp as f64 - run.y[j] as f64 * run.dt[j] as f64);
            }
        }
    }
    e
}

pub fn stats(e: &[Vec<f64>; 2]) -> [ErrStats; 2] {
    [ErrStats::of(&e[0]), ErrStats::of(&e[1])]
}

/// Runs of the drives that have every input, split into (train, validation).
pub fn split(drives: &[Drive], o: &TrainOptions) -> (Vec<Run>, Vec<Run>, Vec<String>) {
    let (mut train, mut val, mut skipped) = (vec![], vec![], vec![]);
    for d in drives {
        let class = if d.profile.nominal_dt_s < 0.5 { 0 } else { 1 };
        let runs = runs_of(&d.name, &d.samples, class);
        if runs.iter().map(|r| r.x.len()).sum::<usize>() < 10 {
            skipped.push(d.name.clone());
            continue;
        }
        if o.val.iter().any(|v| d.name.contains(v.as_str()) || d.source == *v) {
            val.extend(runs);
        } else {
            train.extend(runs);
        }
    }
    (train, val, skipped)
}
