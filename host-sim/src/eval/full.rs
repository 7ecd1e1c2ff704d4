//! The whole evaluation the command line runs: [`run::evaluate`] with the chosen predictor,
//! then the paper's strategies alone, each predictor side by side, the int8 fidelity, the drift
//! sweep and its limits, the calibrated cars, the nuisance suite, and strategy 2's classifier.

use super::calibrated::calibrated_cars;
use super::fold;
use super::plan::EvalOptions;
use super::results::Report;
use super::run::{drift_sweep, evaluate, nuisance_suite, track_bound_10s_mps};
use super::stats::{drift_limits, predictor_stats, quantization};
use crate::dataset::Drive;
use crate::detect::PredictorKind;
use std::collections::BTreeMap;

/// The evaluation the command line runs: the folds fitted (leave-one-source-out unless asked
/// otherwise), [`evaluate`] with the chosen predictor, then the same drives and scenarios judged
/// by the paper's strategies alone, with each predictor side by side and with the f32 LSTM
/// (int8 fidelity), the slow drifts at fixed rates and their limits, the nuisance suite
/// (`nuisance_variants` draws per kind and drive; 0 skips it), and strategy 2's classifier on
/// the held-out turns.
pub fn full(drives: Vec<Drive>, o: &EvalOptions, data: &str, data_dir: &str, nuisance_variants: usize, progress: &(dyn Fn() + Sync)) -> Report {
    let folds = fold::folds(&drives, o.protocol);
    let mut r = evaluate(&drives, o, data, data_dir, &folds, progress);
    let paper = EvalOptions { tweak: Some(|c| c.track.enabled = false), ..*o };
    r.paper_strategies_only = Some(evaluate(&drives, &paper, data, data_dir, &folds, &|| {}).attacks);
    let runs: BTreeMap<PredictorKind, Report> = [PredictorKind::Kinematic, PredictorKind::Lstm, PredictorKind::LstmF32]
        .into_iter()
        .map(|k| (k, if k == o.predictor { r.clone() } else { evaluate(&drives, &EvalOptions { predictor: k, ..*o }, data, data_dir, &folds, &|| {}) }))
        .collect();
    r.predictors = Some([PredictorKind::Kinematic, PredictorKind::Lstm].into_iter().map(|k| (k.name(), predictor_stats(k, &drives, &runs[&k]))).collect());
    r.quantization = Some(quantization(&drives, &runs[&PredictorKind::Lstm], &runs[&PredictorKind::LstmF32]));
    let sweep = drift_sweep(&drives, o, &folds);
    r.drift_limit = Some(drift_limits(&sweep, |class| track_bound_10s_mps(&drives, class, o, &folds)));
    r.drift_sweep = Some(sweep);
    r.calibrated = Some(calibrated_cars(&drives, o, &folds));
    if nuisance_variants > 0 {
        let (per, total) = nuisance_suite(&drives, o, &folds, nuisance_variants, progress);
        r.nuisance = Some(per);
        r.nuisance_total = Some(total);
    }
    let mut turn_drives = drives;
    turn_drives.extend(crate::turns::sim_drives().into_iter().filter(|d| d.name.contains("seed2")));
    r.turns = Some(crate::turns::evaluate_default(&turn_drives));
    r
}

