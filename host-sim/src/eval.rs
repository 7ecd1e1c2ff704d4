//! `host-sim eval`: the detector against clean drives (false alarms) and attacked drives
//! (detection rate, time to detect, which strategies fired: the paper's Table 3).
//!
//! Every number comes from the detector's verdicts; the attack generator only supplies the
//! onset time (ground truth). Scenarios are drawn deterministically from the seed and spread
//! round-robin over the drives that can host each kind, and run in parallel (rayon), so a run is
//! reproducible whatever the thread count.

use crate::attack::{self, AttackKind};
use crate::detect::{self, PredictorKind};
use crate::lstm;
use crate::input::{Format, Replay};
use crate::replay;
use detector_core::fusion::{Config, Verdict};
use detector_core::geo::LatLon;
use detector_core::profile::ReceiverProfile;
use detector_core::sample::{Sample, Signal};
use detector_core::strategy::StrategyId;
use detector_core::sync::SyncConfig;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// Seconds of clean drive kept before each onset (detector warm-up) and judged after it.
pub const PRE_ONSET_S: f64 = 60.0;
pub const WINDOW_S: f64 = 120.0;

/// A drive prepared for evaluation.
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

#[derive(Clone, Copy)]
pub struct EvalOptions {
    pub scenarios: usize,
    pub seed: u64,
    pub sync: SyncConfig,
    /// Changes the detector configuration (tests use it to disable strategies).
    pub tweak: Option<fn(&mut Config)>,
    /// Strategy 1's predictor.
    pub predictor: PredictorKind,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self { scenarios: 10, seed: 1, sync: SyncConfig::default(), tweak: None, predictor: PredictorKind::Lstm }
    }
}

fn config_for(d: &Drive, o: &EvalOptions) -> Config {
    let mut c = detect::config(d.profile, o.predictor);
    if let Some(f) = o.tweak {
        f(&mut c);
    }
    c
}

/// Rising edges of "some strategy fired": one per alarm episode.
fn alarm_episodes(v: &[Verdict]) -> usize {
    let mut n = 0;
    let mut prev = false;
    for x in v {
        let f = !x.fired.is_empty();
        if f && !prev {
            n += 1;
        }
        prev = f;
    }
    n
}

#[derive(Clone, Debug, Serialize)]
pub struct CleanDrive {
    pub drive: String,
    pub source: String,
    pub hours: f64,
    pub profile: &'static str,
    pub judged: bool,
    pub false_alarms: usize,
    /// Epochs where strategy 1 ran, and where it ran on the LSTM itself (not its fallback).
    pub s1_epochs: usize,
    pub s1_lstm_epochs: usize,
    /// FNV-1a of every verdict (as the firmware's digest).
    pub digest: String,
    /// FNV-1a of the decisions only (ran, fired, degraded, reasons, alarm per epoch).
    pub decisions: String,
    /// The same up to the first alarm.
    pub decisions_to_alarm: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct CleanStats {
    pub drives: usize,
    pub hours: f64,
    /// Drives with wheel speed, where the strategies run, and their hours.
    pub drives_judged: usize,
    pub hours_judged: f64,
    pub false_alarms: usize,
    pub false_alarms_per_hour: f64,
    pub per_drive: Vec<CleanDrive>,
}

/// One point of a scenario's trace (for the figures).
#[derive(Clone, Debug, Serialize)]
pub struct TracePoint {
    pub t: f64,
    pub residual_m: Option<f32>,
    pub threshold_m: Option<f32>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Scenario {
    pub id: String,
    pub kind: AttackKind,
    pub drive: String,
    pub source: String,
    pub seed: u64,
    pub onset_t: f64,
    pub params: String,
    /// The attack's main parameter (offset m, drift m/s, rotation deg/s, delay s, step m).
    pub value: f64,
    pub detected: bool,
    pub ttd_s: Option<f64>,
    pub ttd_epochs: Option<usize>,
    /// Strategies that fired at any epoch from the onset to the end of the window.
    pub strategies: Vec<&'static str>,
    /// Alarm episodes before the onset (on clean data: false alarms).
    pub pre_onset_alarms: usize,
    /// FNV-1a of every verdict (as the firmware's digest).
    pub digest: String,
    /// FNV-1a of the decisions only (ran, fired, degraded, reasons, alarm per epoch).
    pub decisions: String,
    /// The same up to the first alarm.
    pub decisions_to_alarm: String,
    #[serde(skip)]
    pub trace: Vec<TracePoint>,
    #[serde(skip)]
    pub true_track: Vec<(f64, LatLon)>,
    #[serde(skip)]
    pub perceived: Vec<(f64, LatLon)>,
}

#[derive(Clone, Debug, Serialize)]
pub struct KindStats {
    pub scenarios: usize,
    pub detected: usize,
    pub detection_rate: f64,
    /// Detected within 10 s of the onset.
    pub detected_within_10s: usize,
    pub rate_within_10s: f64,
    pub ttd_median_s: Option<f64>,
    pub ttd_p95_s: Option<f64>,
    pub ttd_max_s: Option<f64>,
    pub ttd_median_epochs: Option<f64>,
    pub ttd_p95_epochs: Option<f64>,
    pub ttd_max_epochs: Option<f64>,
    /// Scenarios in which each strategy fired (a row of the paper's Table 3).
    pub strategies: BTreeMap<&'static str, usize>,
    pub sources: Vec<String>,
    pub missed: Vec<String>,
    pub hosting_drives: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// "real" or "simulated".
    pub data: String,
    pub clean: CleanStats,
    pub attacks: BTreeMap<&'static str, KindStats>,
    pub scenarios: Vec<Scenario>,
    pub config: serde_json::Value,
    /// Strategy 2's classifier on held-out turns (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turns: Option<crate::turns::TurnReport>,
    /// The same scenarios judged by the paper's three strategies alone (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_strategies_only: Option<BTreeMap<&'static str, KindStats>>,
    /// The smallest slow-drift rate detected within 10 s, m/s.
    pub smallest_drift_detected_10s_mps: Option<f64>,
    /// The slow-drift scenarios replayed at fixed rates (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_sweep: Option<Vec<DriftSweepPoint>>,
    /// Strategy 1's predictors side by side (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predictors: Option<BTreeMap<&'static str, PredictorStats>>,
    /// The int8 LSTM against its f32 original (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quantization: Option<Quantization>,
}

/// One predictor on the validation epochs of one receiver profile.
#[derive(Clone, Debug, Serialize)]
pub struct ProfileErr {
    pub validation_epochs: usize,
    /// Absent without validation epochs (simulated data).
    pub rmse_m: Option<f64>,
    pub max_abs_m: Option<f64>,
    /// Strategy 1's threshold at the nominal epoch: error term + GNSS error term.
    pub threshold_m: f64,
}

/// One predictor: accuracy on the validation drives (the LSTM never saw them) and what the
/// whole detector achieved with it.
#[derive(Clone, Debug, Serialize)]
pub struct PredictorStats {
    /// Pooled over the validation epochs of both profiles (absent without real data).
    pub rmse_m: Option<f64>,
    pub max_abs_m: Option<f64>,
    /// The largest nominal threshold of the profiles.
    pub threshold_m: f64,
    pub profiles: BTreeMap<&'static str, ProfileErr>,
    pub detection_rate: BTreeMap<&'static str, f64>,
    pub rate_within_10s: BTreeMap<&'static str, f64>,
    pub false_alarms: usize,
    /// Epochs of the clean drives where strategy 1 ran, and where the LSTM itself made the
    /// prediction (elsewhere it lacked an input and the kinematic fallback did).
    pub s1_epochs_clean: usize,
    pub s1_lstm_epochs_clean: usize,
}

/// The deployed int8 integer kernel against the f32 model it was quantised from.
#[derive(Clone, Debug, Serialize)]
pub struct Quantization {
    pub validation_epochs: usize,
    /// Largest |int - f32| predicted shift over the validation epochs, metres.
    pub max_abs_diff_m: Option<f64>,
    /// Largest |int - f32| / strategy-1 threshold of the epoch's profile.
    pub ratio_to_threshold: Option<f64>,
    /// Every clean drive and scenario gave the same decisions (ran, fired, degraded, reasons,
    /// alarm) at every epoch up to and including the first alarm: the same alarm, at the same
    /// epoch, for the same reasons.
    pub verdicts_identical: bool,
    pub streams_compared: usize,
    pub streams_differing: Vec<String>,
    /// Streams whose per-epoch decisions differ anywhere, also after the (latched) first alarm,
    /// where the spoofed inputs drive both kernels far outside the training range.
    pub streams_differing_after_alarm: Vec<String>,
}

const PROFILES: [&ReceiverProfile; 2] = [&detector_core::profile::UBLOX_10HZ, &detector_core::profile::LOGGER_1HZ];

fn thresholds(kind: PredictorKind) -> [f64; 2] {
    PROFILES.map(|p| detect::config(p, kind).shift.threshold_m(p.nominal_dt_s) as f64)
}

/// Signed validation errors `[10 Hz, 1 Hz]` of a predictor, metres.
fn validation_errors(kind: PredictorKind, runs: &[lstm::Run], drives: &[Drive]) -> [Vec<f64>; 2] {
    use detector_core::strategy::lstm::LstmPredictor;
    match kind {
        PredictorKind::Kinematic => lstm::kinematic_errors(runs, drives),
        PredictorKind::Lstm => lstm::lstm_errors(&mut LstmPredictor::int(detect::default_lstm()).expect("int8"), runs),
        PredictorKind::LstmF32 => lstm::lstm_errors(&mut LstmPredictor::reference(detect::default_lstm_f32()), runs),
    }
}

/// The validation runs of the default LSTM's split (empty on simulated data).
pub fn validation_runs(drives: &[Drive]) -> Vec<lstm::Run> {
    lstm::split(drives, &lstm::TrainOptions::default()).1
}

pub fn predictor_stats(kind: PredictorKind, drives: &[Drive], r: &Report) -> PredictorStats {
    let runs = validation_runs(drives);
    let e = validation_errors(kind, &runs, drives);
    let th = thresholds(kind);
    let all: Vec<f64> = e[0].iter().chain(&e[1]).copied().collect();
    let pooled = lstm::ErrStats::of(&all);
    let mut profiles = BTreeMap::new();
    for (i, p) in PROFILES.iter().enumerate() {
        let st = lstm::ErrStats::of(&e[i]);
        let some = |v: f64| (st.epochs > 0).then_some(v);
        profiles.insert(p.name, ProfileErr { validation_epochs: st.epochs, rmse_m: some(st.rmse_m), max_abs_m: some(st.max_abs_m), threshold_m: th[i] });
    }
    PredictorStats {
        rmse_m: (!all.is_empty()).then_some(pooled.rmse_m),
        max_abs_m: (!all.is_empty()).then_some(pooled.max_abs_m),
        threshold_m: th[0].max(th[1]),
        profiles,
        detection_rate: r.attacks.iter().map(|(k, s)| (*k, s.detection_rate)).collect(),
        rate_within_10s: r.attacks.iter().map(|(k, s)| (*k, s.rate_within_10s)).collect(),
        false_alarms: r.clean.false_alarms,
        s1_epochs_clean: r.clean.per_drive.iter().map(|c| c.s1_epochs).sum(),
        s1_lstm_epochs_clean: r.clean.per_drive.iter().map(|c| c.s1_lstm_epochs).sum(),
    }
}

/// Compares the int8 run with the f32 run: predictions on the validation epochs, and verdict
/// digests of every clean drive and scenario.
pub fn quantization(drives: &[Drive], int: &Report, f32r: &Report) -> Quantization {
    let runs = validation_runs(drives);
    let a = validation_errors(PredictorKind::Lstm, &runs, drives);
    let b = validation_errors(PredictorKind::LstmF32, &runs, drives);
    let th = thresholds(PredictorKind::Lstm);
    let (mut diff, mut ratio, mut n) = (None::<f64>, None::<f64>, 0);
    for c in 0..2 {
        for (x, y) in a[c].iter().zip(&b[c]) {
            let d = (x - y).abs();
            diff = Some(diff.map_or(d, |m| m.max(d)));
            ratio = Some(ratio.map_or(d / th[c], |m| m.max(d / th[c])));
            n += 1;
        }
    }
    let (mut differing, mut after) = (vec![], vec![]);
    for (x, y) in int.clean.per_drive.iter().zip(&f32r.clean.per_drive) {
        if x.decisions_to_alarm != y.decisions_to_alarm {
            differing.push(format!("clean {}", x.drive));
        } else if x.decisions != y.decisions {
            after.push(format!("clean {}", x.drive));
        }
    }
    for (x, y) in int.scenarios.iter().zip(&f32r.scenarios) {
        if x.decisions_to_alarm != y.decisions_to_alarm {
            differing.push(x.id.clone());
        } else if x.decisions != y.decisions {
            after.push(x.id.clone());
        }
    }
    Quantization {
        validation_epochs: n,
        max_abs_diff_m: diff,
        ratio_to_threshold: ratio,
        verdicts_identical: differing.is_empty(),
        streams_compared: int.clean.per_drive.len() + int.scenarios.len(),
        streams_differing: differing,
        streams_differing_after_alarm: after,
    }
}

fn pct(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    // Nearest rank.
    let i = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1;
    Some(sorted[i])
}

/// The firmware's verdict digest of a verdict stream, in hex.
pub fn digest(v: &[Verdict]) -> String {
    let mut d = gnss_guard_board::pipeline::Digest::default();
    for x in v {
        d.add(x);
    }
    format!("{:016x}", d.0)
}

/// [`decisions`] up to and including the first alarm (all of it without an alarm).
pub fn decisions_to_alarm(v: &[Verdict]) -> String {
    let n = v.iter().position(|x| x.alarm).map_or(v.len(), |i| i + 1);
    decisions(&v[..n])
}

/// FNV-1a of the decisions of a verdict stream, in hex.
pub fn decisions(v: &[Verdict]) -> String {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for x in v {
        for b in x.epoch.to_le_bytes().into_iter().chain([x.ran.0, x.fired.0, x.degraded.0, x.alarm as u8]).chain(x.reasons.0.to_le_bytes()) {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

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

/// Drift rates of the sweep, m/s: the range and beyond it, to find what is detected
/// within 10 s.
pub const DRIFT_SWEEP_MPS: [f64; 6] = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0];

/// One rate of the drift sweep: the planned slow-drift scenarios (same drives, onsets and
/// directions) replayed at this rate.
#[derive(Clone, Debug, Serialize)]
pub struct DriftSweepPoint {
    pub rate_mps: f64,
    pub along_scenarios: usize,
    pub along_within_10s: usize,
    pub across_scenarios: usize,
    pub across_within_10s: usize,
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
    let mut attacks = BTreeMap::new();
    for kind in AttackKind::ALL {
        let sc: Vec<&Scenario> = scenarios.iter().filter(|s| s.kind == kind).collect();
        let mut ttd: Vec<f64> = sc.iter().filter_map(|s| s.ttd_s).collect();
        ttd.sort_by(f64::total_cmp);
        let mut ep: Vec<f64> = sc.iter().filter_map(|s| s.ttd_epochs.map(|e| e as f64)).collect();
        ep.sort_by(f64::total_cmp);
        let mut strategies = BTreeMap::new();
        for st in StrategyId::ALL {
            strategies.insert(st.name(), sc.iter().filter(|s| s.strategies.contains(&st.name())).count());
        }
        let mut sources: Vec<String> = sc.iter().map(|s| s.source.clone()).collect();
        sources.sort();
        sources.dedup();
        let detected = sc.iter().filter(|s| s.detected).count();
        let within = sc.iter().filter(|s| s.ttd_s.is_some_and(|t| t <= 10.0)).count();
        attacks.insert(kind.name(), KindStats {
            scenarios: sc.len(),
            detected,
            detection_rate: if sc.is_empty() { 0.0 } else { detected as f64 / sc.len() as f64 },
            detected_within_10s: within,
            rate_within_10s: if sc.is_empty() { 0.0 } else { within as f64 / sc.len() as f64 },
            ttd_median_s: pct(&ttd, 0.5),
            ttd_p95_s: pct(&ttd, 0.95),
            ttd_max_s: ttd.last().copied(),
            ttd_median_epochs: pct(&ep, 0.5),
            ttd_p95_epochs: pct(&ep, 0.95),
            ttd_max_epochs: ep.last().copied(),
            strategies,
            sources,
            missed: sc.iter().filter(|s| !s.detected).map(|s| format!("{} ({}, t={:.1}, {})", s.id, s.drive, s.onset_t, s.params)).collect(),
            hosting_drives: drives.iter().filter(|d| d.has_wheel_speed() && !attack::candidate_onsets(kind, &d.samples).is_empty()).count(),
        });
    }
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
