//! How verdicts become the report's numbers: alarm episodes, percentiles, verdict digests, the
//! per-kind statistics, the predictors on their validation epochs, the int8 fidelity.

use super::results::*;
use crate::dataset::Drive;
use crate::detect::{self, PredictorKind};
use crate::lstm;
use detector_core::fusion::Verdict;
use detector_core::profile::ReceiverProfile;
use detector_core::strategy::StrategyId;
use gnss_data::attack::{self, AttackKind};
use std::collections::BTreeMap;

/// Rising edges of "some strategy fired": one per alarm episode.
pub fn alarm_episodes(v: &[Verdict]) -> usize {
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

/// The largest `x` the ratios `(t, r)` stayed at or above for `persist_s` in one run of
/// judged epochs (`None` where the check did not judge: the run breaks, as a check's
/// persistence resets).
fn held_peak(series: &[(f64, Option<f32>)], persist_s: f64) -> Option<f64> {
    let mut best: Option<f64> = None;
    let mut start = 0usize;
    for (i, &(t, r)) in series.iter().enumerate() {
        if r.is_none_or(|x| !x.is_finite()) {
            start = i + 1;
            continue;
        }
        // Held since the newest epoch at or before `t - persist_s` of this run: the least
        // ratio from there to now.
        let Some(from) = (start..=i).rev().find(|&j| series[j].0 <= t - persist_s) else { continue };
        let lo = series[from..=i].iter().filter_map(|(_, r)| *r).fold(f32::INFINITY, f32::min) as f64;
        best = Some(best.map_or(lo, |m| m.max(lo)));
    }
    best
}

/// Each check's persistence: how long its statistic must stay above its threshold to fire.
#[derive(Clone, Copy, Debug)]
pub struct Persistence {
    /// The track check's position windows, and their fast path (both windows above, the
    /// 10 s one twice over) in seconds.
    pub windows_s: f32,
    pub windows_fast_s: f32,
    /// The velocity test's windows (a receiver's own velocity, or position differences).
    pub velocity_s: f32,
}

impl Persistence {
    /// The persistence of `cfg`, for a receiver that reports its velocity or not.
    pub fn of(cfg: &detector_core::fusion::Config, reported: bool) -> Self {
        let v = &cfg.track.velocity;
        Persistence {
            windows_s: cfg.track.persist_s,
            windows_fast_s: cfg.track.fast_persist_s,
            velocity_s: if reported { v.persist_s } else { v.persist_position_s - detector_core::strategy::track::velocity::PERSIST_JITTER_S },
        }
    }
}

/// How near a run came to an alarm ([`Headroom`]): each check's statistic as a share of its
/// threshold, the largest it held for the check's persistence; strategy 3's disagreement
/// length over its persistence; strategy 2's heading check, the largest share it judged.
pub fn headroom(v: &[Verdict], cfg: &detector_core::fusion::Config, p: Persistence) -> Headroom {
    let series = |f: &dyn Fn(&Verdict) -> Option<f32>| v.iter().map(|x| (x.t, f(x))).collect::<Vec<_>>();
    let shift = series(&|x| x.shift.filter(|s| s.threshold_m > 0.0).map(|s| s.residual_m.abs() / s.threshold_m));
    let motion = v.iter().filter_map(|x| x.motion).map(|m| (m.disagree_s / cfg.motion.persist_s.max(1e-3)) as f64).fold(None, |a: Option<f64>, x| Some(a.map_or(x, |m| m.max(x))));
    let win = |i: usize| series(&|x| x.track.and_then(|t| t.windows[i]).filter(|w| w.threshold_m > 0.0).map(|w| w.e_m / w.threshold_m));
    let (w10, w30) = (win(0), win(1));
    let windows = [held_peak(&w10, p.windows_s as f64), held_peak(&w30, p.windows_s as f64), held_peak(&w10, p.windows_fast_s as f64).map(|x| x / 2.0)]
        .into_iter()
        .flatten()
        .reduce(f64::max);
    // The velocity test's persistence runs on over epochs that judged no pair (its windows
    // hold their statistic), so only the epochs that judged one are its series; a channel
    // that never judged a pair (across, without a gyro) has no peak.
    let vel = |k: usize| {
        let s: Vec<(f64, Option<f32>)> = v.iter().filter_map(|x| Some((x.t, x.track?.velocity.filter(|vel| vel.h > 0.0)?))).map(|(t, vel)| (t, Some(vel.t[k] / vel.h))).collect();
        let judged = v.iter().any(|x| x.track.and_then(|t| t.velocity).is_some_and(|vel| vel.residual_mps[k].is_some()));
        if judged { held_peak(&s, p.velocity_s as f64) } else { None }
    };
    Headroom {
        shift: held_peak(&shift, 0.0),
        motion,
        windows,
        velocity_along: vel(0),
        velocity_across: vel(1),
        turn_heading: v.iter().filter_map(|x| x.turn_heading).map(f64::from).reduce(f64::max),
    }
}

const PROFILES: [&ReceiverProfile; 2] = [&detector_core::profile::UBLOX_10HZ, &detector_core::profile::LOGGER_1HZ];

pub fn thresholds(kind: PredictorKind) -> [f64; 2] {
    PROFILES.map(|p| detect::config(p, kind).shift.threshold_m(p.nominal_dt_s) as f64)
}

/// Signed validation errors `[10 Hz, 1 Hz]` of a predictor, metres.
fn validation_errors(kind: PredictorKind, runs: &[lstm::Run], drives: &[Drive]) -> [Vec<f64>; 2] {
    use detector_core::strategy::location_shift::lstm::LstmPredictor;
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

pub fn pct(sorted: &[f64], q: f64) -> Option<f64> {
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

/// Per attack kind: detection, time to detect, which strategies fired (a row of Table 3).
pub fn kind_stats(scenarios: &[Scenario], drives: &[Drive]) -> BTreeMap<&'static str, KindStats> {
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
            requested: 0,
            capacity: 0,
        });
    }
    attacks
}

/// The 95 % upper confidence bound of a Poisson rate with `k` events in `hours` (exact:
/// chi-square with 2(k + 1) degrees of freedom), per hour; infinite without hours.
pub fn poisson_upper95(k: usize, hours: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if hours <= 0.0 {
        return f64::INFINITY;
    }
    ChiSquared::new(2.0 * (k as f64 + 1.0)).map_or(f64::INFINITY, |c| c.inverse_cdf(0.95) / (2.0 * hours))
}

/// The smallest swept rate detected in at least 95 % of its scenarios within `within` seconds,
/// every faster swept rate too.
fn rate_95(sweep: &[DriftSweepPoint], class: &str, along: bool, within: u32) -> Option<f64> {
    let mut pts: Vec<&DriftSweepPoint> = sweep.iter().collect();
    pts.sort_by(|a, b| a.rate_mps.total_cmp(&b.rate_mps));
    let ok = |p: &DriftSweepPoint| -> Option<bool> {
        let c = p.by_class.get(class)?;
        let d = if along { &c.along } else { &c.across };
        let hit = match within {
            10 => d.within_10s,
            30 => d.within_30s,
            _ => d.within_60s,
        };
        (d.scenarios > 0).then_some(hit as f64 >= 0.95 * d.scenarios as f64)
    };
    let mut best = None;
    for p in pts.iter().rev() {
        match ok(p) {
            Some(true) => best = Some(p.rate_mps),
            Some(false) => break,
            None => {}
        }
    }
    best
}

/// The slow drift's limits per receiver class (`velocity`, `position`) and direction, with the
/// bound the position windows' thresholds on the class's clean drives allow (`bound(class)`).
pub fn drift_limits(sweep: &[DriftSweepPoint], bound: impl Fn(&str) -> Option<f64>) -> BTreeMap<&'static str, BTreeMap<&'static str, DriftLimit>> {
    let mut out = BTreeMap::new();
    for class in ["velocity", "position"] {
        let bound = bound(class);
        let mut m = BTreeMap::new();
        for (dir, along) in [("along", true), ("across", false)] {
            let pick = |p: &DriftSweepPoint| p.by_class.get(class).map(|c| if along { c.along.clone() } else { c.across.clone() });
            let n = sweep.first().and_then(pick).map_or(0, |d| d.scenarios);
            let p95: Vec<Option<f64>> = sweep.iter().filter(|p| p.rate_mps >= 0.2 - 1e-9).filter_map(pick).filter(|d| d.scenarios > 0).map(|d| d.pull_off_p95_m).collect();
            let pull_off_p95_max_m = if p95.is_empty() || p95.iter().any(Option::is_none) { None } else { p95.into_iter().flatten().fold(None, |a: Option<f64>, b| Some(a.map_or(b, |a| a.max(b)))) };
            m.insert(dir, DriftLimit {
                rate_95_within_10s_mps: rate_95(sweep, class, along, 10),
                rate_95_within_30s_mps: rate_95(sweep, class, along, 30),
                rate_95_within_60s_mps: rate_95(sweep, class, along, 60),
                pull_off_p95_max_m,
                bound_10s_mps: bound,
                scenarios_per_rate: n,
            });
        }
        out.insert(class, m);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::held_peak;

    #[test]
    fn a_peak_counts_only_as_long_as_it_held() {
        let s: Vec<(f64, Option<f32>)> = [0.5, 1.2, 1.2, 0.3].iter().enumerate().map(|(t, r)| (t as f64, Some(*r))).collect();
        assert_eq!(held_peak(&s, 0.0), Some(1.2f32 as f64));
        // 1.2 at 1 and 2 s: held for one second, not for two.
        assert_eq!(held_peak(&s, 1.0), Some(1.2f32 as f64));
        assert_eq!(held_peak(&s, 2.0), Some(0.5f32 as f64));
        assert_eq!(held_peak(&s, 4.0), None);
    }

    #[test]
    fn an_epoch_the_check_did_not_judge_breaks_the_run() {
        let s = [(0.0, Some(1.0)), (1.0, None), (2.0, Some(1.0)), (3.0, Some(0.8))];
        assert_eq!(held_peak(&s, 2.0), None);
        assert_eq!(held_peak(&s, 1.0), Some(0.8f32 as f64));
    }
}
