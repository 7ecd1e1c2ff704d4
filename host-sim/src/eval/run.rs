//! Running an evaluation: clean drives (false alarms) and attacked windows (detection) through
//! the detector, in parallel (rayon) and deterministically per seed; the drift sweep and the
//! nuisance suite.

use super::fold::{self, Fitted, LSTM_SOURCES};
use super::plan::{capacity, config_for, plan, EvalOptions, DRIFT_SWEEP_MPS, PRE_ONSET_S, WINDOW_S};
use super::results::*;
use super::stats::{alarm_episodes, decisions, decisions_to_alarm, digest, headroom, kind_stats, poisson_upper95, Persistence};
use crate::dataset::Drive;
use crate::detect::{self, PredictorKind};
use detector_core::fusion::{Config, Verdict};
use detector_core::sample::Sample;
use detector_core::strategy::track::calibration::Record;
use detector_core::strategy::turn::TemplateSet;
use detector_core::strategy::StrategyId;
use gnss_data::attack::{self, AttackKind, AttackParams};
use gnss_data::nuisance::{self, Nuisance, NuisanceKind};
use gnss_data::replay;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The fitted numbers each source is judged with.
pub type Folds = BTreeMap<String, Fitted>;

/// The detector's verdicts on samples of drive `d`, with the numbers of its source's fold.
pub fn verdicts(d: &Drive, samples: &[Sample], o: &EvalOptions, folds: &Folds) -> Vec<Verdict> {
    verdicts_calibrated(d, samples, o, folds, None).0
}

/// [`verdicts`] of a car whose calibration was stored, and the record to store after it.
pub fn verdicts_calibrated(d: &Drive, samples: &[Sample], o: &EvalOptions, folds: &Folds, record: Option<&Record>) -> (Vec<Verdict>, Option<Record>) {
    let fitted = folds.get(&d.source);
    let apply = |c: &mut Config| {
        if let Some(f) = fitted {
            f.apply(c, d.profile.nominal_dt_s, o.predictor == PredictorKind::Kinematic);
        }
    };
    let cfg = config_for(d, o, Some(&apply));
    let set: TemplateSet<'_> = match fitted.and_then(|f| TemplateSet::parse(&f.templates).ok()) {
        Some(s) => s,
        None => detect::default_templates(),
    };
    detect::run_calibrated(samples, cfg, o.predictor, set, record)
}

/// Hours of epochs at which at least one strategy ran.
fn hours_ran(v: &[Verdict]) -> f64 {
    v.windows(2).filter(|w| !w[1].ran.is_empty()).map(|w| (w[1].t - w[0].t).clamp(0.0, 3.0)).sum::<f64>() / 3600.0
}

/// Hours of epochs at which the track check judged a window.
fn hours_track_judged(v: &[Verdict]) -> f64 {
    v.windows(2)
        .filter(|w| w[1].track.is_some_and(|t| t.judging))
        .map(|w| (w[1].t - w[0].t).clamp(0.0, 3.0))
        .sum::<f64>()
        / 3600.0
}

/// How near the verdicts `v` on drive `d` came to an alarm.
fn room(d: &Drive, v: &[Verdict], o: &EvalOptions) -> Headroom {
    let cfg = config_for(d, o, None);
    headroom(v, &cfg, Persistence::of(&cfg, receiver_class(d) == "velocity"))
}

fn run_clean(d: &Drive, o: &EvalOptions, folds: &Folds) -> CleanDrive {
    let v = verdicts(d, &d.samples, o, folds);
    CleanDrive {
        drive: d.name.clone(),
        source: d.source.clone(),
        hours: d.hours(),
        profile: d.profile.name,
        judged: d.has_wheel_speed(),
        false_alarms: alarm_episodes(&v),
        s1_epochs: v.iter().filter(|x| x.ran.contains(StrategyId::LocationShift)).count(),
        s1_lstm_epochs: if o.predictor == PredictorKind::Kinematic { 0 } else { v.iter().filter(|x| x.shift.is_some_and(|s| !s.fallback)).count() },
        epochs: v.len(),
        degraded_epochs: StrategyId::ALL.iter().map(|s| (s.name(), v.iter().filter(|x| x.degraded.contains(*s)).count())).collect(),
        digest: digest(&v),
        decisions: decisions(&v),
        decisions_to_alarm: decisions_to_alarm(&v),
        headroom: room(d, &v, o),
    }
}

#[allow(clippy::too_many_arguments)]
pub fn run_scenario(d: &Drive, kind: AttackKind, onset: f64, seed: u64, idx: usize, o: &EvalOptions, folds: &Folds) -> Scenario {
    run_scenario_with(d, kind, onset, seed, idx, o, folds, &AttackParams::default())
}

/// [`run_scenario`] with some attack parameters fixed (see [`attack::apply_with`]).
#[allow(clippy::too_many_arguments)]
pub fn run_scenario_with(d: &Drive, kind: AttackKind, onset: f64, seed: u64, idx: usize, o: &EvalOptions, folds: &Folds, fixed: &AttackParams) -> Scenario {
    let mut window = d.replay.clone();
    window.events.retain(|e| e.t() >= onset - PRE_ONSET_S && e.t() <= onset + WINDOW_S);
    let a = attack::apply_with(&window, kind, seed, onset, fixed);
    let (samples, _) = replay::synchronize(&a.replay, o.sync);
    let v = verdicts(d, &samples, o, folds);
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

/// What a drive's receiver reports: `velocity` (speed and course) or `position` only.
pub fn receiver_class(d: &Drive) -> &'static str {
    if d.samples.iter().any(|s| s.gnss_speed.is_valid() && s.gnss_course.is_valid()) { "velocity" } else { "position" }
}

/// The slow-drift scenarios of the plan replayed at each rate of [`DRIFT_SWEEP_MPS`].
pub fn drift_sweep(drives: &[Drive], o: &EvalOptions, folds: &Folds) -> Vec<DriftSweepPoint> {
    let drifts: Vec<_> = plan(drives, o).into_iter().filter(|p| p.0 == AttackKind::SlowDrift).collect();
    DRIFT_SWEEP_MPS
        .iter()
        .map(|&rate| {
            // (along, class, source, time to detect)
            let runs: Vec<(bool, &'static str, String, Option<f64>)> = drifts
                .par_iter()
                .enumerate()
                .map(|(n, &(k, i, t, s))| {
                    let sc = run_scenario_with(&drives[i], k, t, s, n, o, folds, &AttackParams::drift(rate));
                    (sc.params.contains("along"), receiver_class(&drives[i]), drives[i].source.clone(), sc.ttd_s)
                })
                .collect();
            let mut by_class: BTreeMap<&'static str, SweepCounts> = BTreeMap::new();
            let mut by_source: BTreeMap<String, SweepCounts> = BTreeMap::new();
            for (along, class, source, ttd) in runs {
                for c in [by_class.entry(class).or_default(), by_source.entry(source).or_default()] {
                    if along { c.along.add(rate, ttd) } else { c.across.add(rate, ttd) }
                }
            }
            for c in by_class.values_mut().chain(by_source.values_mut()) {
                c.along.finish();
                c.across.finish();
            }
            DriftSweepPoint { rate_mps: rate, by_class, by_source }
        })
        .collect()
}

/// One nuisance run: its kind, (hours the track check judged, hours any strategy ran), alarm
/// episodes, what was applied, epochs each strategy fired, each reason given where one fired,
/// how near it came to an alarm.
type NuisanceRun = (NuisanceKind, (f64, f64), usize, String, BTreeMap<&'static str, usize>, BTreeMap<&'static str, usize>, Headroom);

/// The nuisance suite: every drive with wheel speed, `variants` draws of every nuisance kind
/// (seeded), judged with its source's fold. Returns per kind and in total.
pub fn nuisance_suite(drives: &[Drive], o: &EvalOptions, folds: &Folds, variants: usize, progress: &(dyn Fn() + Sync)) -> (BTreeMap<&'static str, NuisanceStats>, NuisanceTotal) {
    let jobs: Vec<(usize, NuisanceKind, usize)> = drives
        .iter()
        .enumerate()
        .filter(|(_, d)| d.has_wheel_speed())
        .flat_map(|(i, _)| NuisanceKind::ALL.into_iter().flat_map(move |k| (0..variants).map(move |v| (i, k, v))))
        .collect();
    let runs: Vec<NuisanceRun> = jobs
        .par_iter()
        .map(|&(i, k, v)| {
            let d = &drives[i];
            let seed = o.seed.wrapping_mul(1_000_003).wrapping_add((i * 1000 + k as usize * 100 + v) as u64);
            let hz = d.profile.nominal_dt_s.recip() as f64;
            let n = Nuisance::draw(k, seed, d.hours() * 3600.0, hz);
            let r = nuisance::apply(&d.replay, &n, seed);
            let (samples, _) = replay::synchronize(&r, o.sync);
            let v = verdicts(d, &samples, o, folds);
            progress();
            let mut fired = BTreeMap::new();
            let mut reasons = BTreeMap::new();
            for x in v.iter().filter(|x| !x.fired.is_empty()) {
                for st in x.fired.iter() {
                    *fired.entry(st.name()).or_insert(0) += 1;
                }
                for r in x.reasons.iter() {
                    *reasons.entry(r.name()).or_insert(0) += 1;
                }
            }
            let room = room(d, &v, o);
            (k, (hours_track_judged(&v), hours_ran(&v)), alarm_episodes(&v), format!("{} seed {seed}: {}", d.name, n.describe()), fired, reasons, room)
        })
        .collect();
    let mut per: BTreeMap<&'static str, NuisanceStats> = BTreeMap::new();
    let mut total = NuisanceTotal::default();
    for (k, h, fa, what, fired, reasons, room) in runs {
        let s = per.entry(k.name()).or_default();
        s.headroom = s.headroom.max(room);
        if let Some(x) = room.nearest().filter(|x| s.nearest_run.as_ref().is_none_or(|(_, m)| x > m)) {
            s.nearest_run = Some((what.clone(), x));
        }
        for (st, n) in fired {
            *s.fired_epochs.entry(st).or_insert(0) += n;
        }
        for (r, n) in reasons {
            *s.fired_reasons.entry(r).or_insert(0) += n;
        }
        s.runs += 1;
        s.hours += h.0;
        s.hours_any += h.1;
        s.false_alarms += fa;
        if fa > 0 {
            s.false_alarm_runs.push(what);
        }
        total.runs += 1;
        total.hours += h.0;
        total.hours_any += h.1;
        total.false_alarms += fa;
    }
    total.upper95_per_hour = poisson_upper95(total.false_alarms, total.hours);
    (per, total)
}

/// Each source judged with the numbers fitted without it: false alarms and detection.
pub fn cross_source(drives: &[Drive], clean: &[CleanDrive], scenarios: &[Scenario], folds: &Folds) -> BTreeMap<String, CrossSource> {
    fold::sources(drives)
        .into_iter()
        .filter_map(|src| {
            let f = folds.get(&src)?;
            let mut attacks: BTreeMap<&'static str, SourceAttack> = BTreeMap::new();
            for sc in scenarios.iter().filter(|s| s.source == src) {
                let a = attacks.entry(sc.kind.name()).or_default();
                a.scenarios += 1;
                a.detected += sc.detected as usize;
                a.within_10s += sc.ttd_s.is_some_and(|t| t <= 10.0) as usize;
            }
            let mine = clean.iter().filter(|c| c.source == src);
            Some((src.clone(), CrossSource {
                fitted_on: f.fitted_on.clone(),
                hours: mine.clone().map(|c| c.hours).sum(),
                hours_judged: mine.clone().filter(|c| c.judged).map(|c| c.hours).sum(),
                false_alarms: mine.map(|c| c.false_alarms).sum(),
                lstm_in_sample: LSTM_SOURCES.contains(&src.as_str()),
                kinematic_error_m: f.kinematic_error_m,
                templates: f.templates_count,
                attacks,
            }))
        })
        .collect()
}

/// Runs the whole evaluation. `progress` is called once per finished unit of work.
pub fn evaluate(drives: &[Drive], o: &EvalOptions, data: &str, data_dir: &str, folds: &Folds, progress: &(dyn Fn() + Sync)) -> Report {
    let clean: Vec<CleanDrive> = drives.par_iter().map(|d| {
        let r = run_clean(d, o, folds);
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
        let r = run_scenario(&drives[i], k, t, s, n, o, folds);
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
    let mut attacks = kind_stats(&scenarios, drives);
    for (k, st) in attacks.iter_mut() {
        st.requested = o.scenarios;
        st.capacity = AttackKind::from_name(k).map_or(0, |k| capacity(drives, k));
    }
    let cross = cross_source(drives, &clean_stats.per_drive, &scenarios, folds);
    let profiles: BTreeMap<&str, serde_json::Value> = drives.iter().map(|d| {
        let c = config_for(d, o, None);
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
        data_dir: data_dir.to_string(),
        protocol: o.protocol,
        cross_source: cross,
        nuisance: None,
        nuisance_total: None,
        drift_limit: None,
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
            "folds": folds,
        }),
        turns: None,
        paper_strategies_only: None,
        smallest_drift_detected_10s_mps: smallest_drift,
        drift_sweep: None,
        calibrated: None,
        predictors: None,
        quantization: None,
    }
}

/// The rate of a slow drift whose 10 s offset equals the track check's threshold, m/s: the
/// median over the judged epochs of the clean drives of `class` (`10hz`, `1hz`); `None` where the
/// check never ran.
pub fn track_bound_10s_mps(drives: &[Drive], class: &str, o: &EvalOptions, folds: &Folds) -> Option<f64> {
    let mut th: Vec<f64> = drives
        .par_iter()
        .filter(|d| d.has_wheel_speed() && receiver_class(d) == class)
        .flat_map(|d| verdicts(d, &d.samples, o, folds).into_iter().filter_map(|v| detect::track_threshold_m(&v)).map(|t| t as f64 / 10.0).collect::<Vec<_>>())
        .collect();
    th.sort_by(f64::total_cmp);
    th.get(th.len() / 2).copied()
}
