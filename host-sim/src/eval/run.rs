//! Running an evaluation: clean drives (false alarms) and attacked windows (detection) through
//! the detector, in parallel (rayon) and deterministically per seed; the drift sweep; and the
//! full evaluation the command line runs (both predictors, the paper's strategies alone, the
//! int8 fidelity, strategy 2's classifier).

use super::plan::{config_for, plan, EvalOptions, DRIFT_SWEEP_MPS, PRE_ONSET_S, WINDOW_S};
use super::results::*;
use super::stats::{alarm_episodes, decisions, decisions_to_alarm, digest, kind_stats, predictor_stats, quantization};
use crate::dataset::Drive;
use crate::detect::{self, PredictorKind};
use detector_core::fusion::Verdict;
use detector_core::strategy::StrategyId;
use gnss_data::attack::{self, AttackKind};
use gnss_data::replay;
use rayon::prelude::*;
use std::collections::BTreeMap;

fn run_clean(d: &Drive, o: &EvalOptions) -> CleanDrive {
    let v = detect::run_with(&d.samples, config_for(d, o), o.predictor);
    CleanDrive {
        drive: d.name.clone(),
        source: d.source.clone(),
        hours: d.hours(),
        profile: d.profile.name,
        judged: d.has_wheel_speed(),
        false_alarms: alarm_episodes(&v),
        s1_epochs: v.iter().filter(|x| x.ran.contains(StrategyId::LocationShift)).count(),
        s1_lstm_epochs: if o.predictor == PredictorKind::Kinematic { 0 } else { v.iter().filter(|x| x.shift.is_some_and(|s| !s.fallback)).count() },
        digest: digest(&v),
        decisions: decisions(&v),
        decisions_to_alarm: decisions_to_alarm(&v),
    }
}

pub fn run_scenario(d: &Drive, kind: AttackKind, onset: f64, seed: u64, idx: usize, o: &EvalOptions) -> Scenario {
    run_scenario_with(d, kind, onset, seed, idx, o, None)
}

/// [`run_scenario`] with the slow drift's rate forced (see [`attack::apply_with`]).
pub fn run_scenario_with(d: &Drive, kind: AttackKind, onset: f64, seed: u64, idx: usize, o: &EvalOptions, drift_mps: Option<f64>) -> Scenario {
    let mut window = d.replay.clone();
    window.events.retain(|e| e.t() >= onset - PRE_ONSET_S && e.t() <= onset + WINDOW_S);
    let a = attack::apply_with(&window, kind, seed, onset, drift_mps);
    let (samples, _) = replay::synchronize(&a.replay, o.sync);
    let v = detect::run_with(&samples, config_for(d, o), o.predictor);
    let first_attacked = v.iter().position(|x| x.t >= onset);
    let det = v.iter().position(|x| x.t >= onset && !x.fired.is_empty());
    let mut fired = detector_core::strategy::StrategySet::EMPTY;
    for x in v.iter().filter(|x| x.t >= onset) {
        fired = fired.union(x.fired);
    }
    let pre: Vec<Verdict> = v.iter().filter(|x| x.t < onset).copied().collect();
    Scenario {
        id: format!("{}-{:02}", kind.name(), idx),
        kind,
        drive: d.name.clone(),
        source: d.source.clone(),
        seed,
        onset_t: onset,
        params: a.spec.params.clone(),
        value: a.spec.value,
        detected: det.is_some(),
        ttd_s: det.map(|i| v[i].t - onset),
        ttd_epochs: det.zip(first_attacked).map(|(i, f)| i - f),
        strategies: fired.iter().map(StrategyId::name).collect(),
        pre_onset_alarms: alarm_episodes(&pre),
        digest: digest(&v),
        decisions: decisions(&v),
        decisions_to_alarm: decisions_to_alarm(&v),
        trace: v
            .iter()
            .map(|x| TracePoint { t: x.t - onset, residual_m: x.shift.map(|s| s.residual_m.abs()), threshold_m: x.shift.map(|s| s.threshold_m) })
            .collect(),
        true_track: a.true_track,
        perceived: a.perceived,
    }
}

/// The slow-drift scenarios of the plan replayed at each rate of [`DRIFT_SWEEP_MPS`].
pub fn drift_sweep(drives: &[Drive], o: &EvalOptions) -> Vec<DriftSweepPoint> {
    let drifts: Vec<_> = plan(drives, o).into_iter().filter(|p| p.0 == AttackKind::SlowDrift).collect();
    DRIFT_SWEEP_MPS
        .iter()
        .map(|&rate| {
            let runs: Vec<(bool, bool)> = drifts
                .par_iter()
                .enumerate()
                .map(|(n, &(k, i, t, s))| {
                    let sc = run_scenario_with(&drives[i], k, t, s, n, o, Some(rate));
                    (sc.params.contains("along"), sc.ttd_s.is_some_and(|x| x <= 10.0))
                })
                .collect();
            let count = |along: bool| (runs.iter().filter(|r| r.0 == along).count(), runs.iter().filter(|r| r.0 == along && r.1).count());
            let ((an, aw), (cn, cw)) = (count(true), count(false));
            DriftSweepPoint { rate_mps: rate, along_scenarios: an, along_within_10s: aw, across_scenarios: cn, across_within_10s: cw }
        })
        .collect()
}

/// Runs the whole evaluation. `progress` is called once per finished unit of work.
pub fn evaluate(drives: &[Drive], o: &EvalOptions, data: &str, progress: &(dyn Fn() + Sync)) -> Report {
    let clean: Vec<CleanDrive> = drives.par_iter().map(|d| {
        let r = run_clean(d, o);
        progress();
        r
    }).collect();
    let plan = plan(drives, o);
    let mut counters: BTreeMap<AttackKind, usize> = BTreeMap::new();
    let indexed: Vec<_> = plan.iter().map(|&(k, i, t, s)| {
        let n = counters.entry(k).or_default();
        *n += 1;
        (k, i, t, s, *n)
    }).collect();
    let scenarios: Vec<Scenario> = indexed.par_iter().map(|&(k, i, t, s, n)| {
        let r = run_scenario(&drives[i], k, t, s, n, o);
        progress();
        r
    }).collect();

    let smallest_drift = scenarios
        .iter()
        .filter(|s| s.kind == AttackKind::SlowDrift && s.ttd_s.is_some_and(|t| t <= 10.0))
        .map(|s| s.value)
        .min_by(f64::total_cmp);
    let hours: f64 = clean.iter().map(|c| c.hours).sum();
    let fa: usize = clean.iter().map(|c| c.false_alarms).sum();
    let clean_stats = CleanStats {
        drives: clean.len(),
        hours,
        drives_judged: clean.iter().filter(|c| c.judged).count(),
        hours_judged: clean.iter().filter(|c| c.judged).map(|c| c.hours).sum(),
        false_alarms: fa,
        false_alarms_per_hour: if hours > 0.0 { fa as f64 / hours } else { 0.0 },
        per_drive: clean,
    };
    let attacks = kind_stats(&scenarios, drives);
    let profiles: BTreeMap<&str, serde_json::Value> = drives.iter().map(|d| {
        let c = config_for(d, o);
        (d.profile.name, serde_json::json!({
            "s1_predictor": o.predictor.name(),
            "s1_predictor_error_m": c.shift.predictor_error_m,
            "s1_gnss_error_m": c.shift.gnss_error_m,
            "s1_threshold_m": c.shift.threshold_m(d.profile.nominal_dt_s),
            "s1_nominal_dt_s": c.shift.nominal_dt_s,
            "s1_max_dt_s": c.shift.max_dt_s,
            "motion": format!("{:?}", c.motion),
        }))
    }).collect();
    Report {
        data: data.to_string(),
        clean: clean_stats,
        attacks,
        scenarios,
        config: serde_json::json!({
            "seed": o.seed,
            "scenarios_per_kind": o.scenarios,
            "pre_onset_s": PRE_ONSET_S,
            "window_s": WINDOW_S,
            "sync_max_gap_s": o.sync.max_gap_s,
            "profiles": profiles,
        }),
        turns: None,
        paper_strategies_only: None,
        smallest_drift_detected_10s_mps: smallest_drift,
        drift_sweep: None,
        predictors: None,
        quantization: None,
    }
}

/// The evaluation the command line runs: [`evaluate`] with the chosen predictor, then the same
/// drives and scenarios judged by the paper's strategies alone, with each predictor side by side
/// and with the f32 LSTM (int8 fidelity), the slow drifts at fixed rates, and strategy 2's
/// classifier on the held-out turns (this run's real drives and the held-out simulated ones).
pub fn full(drives: Vec<Drive>, o: &EvalOptions, data: &str, progress: &(dyn Fn() + Sync)) -> Report {
    let mut r = evaluate(&drives, o, data, progress);
    let paper = EvalOptions { tweak: Some(|c| c.consistency.enabled = false), ..*o };
    r.paper_strategies_only = Some(evaluate(&drives, &paper, data, &|| {}).attacks);
    let runs: BTreeMap<PredictorKind, Report> = [PredictorKind::Kinematic, PredictorKind::Lstm, PredictorKind::LstmF32]
        .into_iter()
        .map(|k| (k, if k == o.predictor { r.clone() } else { evaluate(&drives, &EvalOptions { predictor: k, ..*o }, data, &|| {}) }))
        .collect();
    r.predictors = Some([PredictorKind::Kinematic, PredictorKind::Lstm].into_iter().map(|k| (k.name(), predictor_stats(k, &drives, &runs[&k]))).collect());
    r.quantization = Some(quantization(&drives, &runs[&PredictorKind::Lstm], &runs[&PredictorKind::LstmF32]));
    r.drift_sweep = Some(drift_sweep(&drives, o));
    let mut turn_drives = drives;
    turn_drives.extend(crate::turns::sim_drives().into_iter().filter(|d| d.name.contains("seed2")));
    r.turns = Some(crate::turns::evaluate_default(&turn_drives));
    r
}
