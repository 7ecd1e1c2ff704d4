//! Calibrated cars: a car's calibration learnt from its earlier drives, kept as the board keeps
//! it (a [`Record`] carried from drive to drive), then its last drive judged with it: clean
//! (false alarms, a contradiction of the record), and under slow drifts at fixed rates with
//! onsets from its first minute (a car that starts calibrated needs no warm-up); once more
//! on tyres 3 % larger, which must contradict the record (reason `calibration_contradicted`);
//! and under draws of every kind of the nuisance suite, another installation meeting the
//! record, which must pass or contradict it and raise no other alarm.
//!
//! A source's drives with wheel speed are taken in the order of their names (the sources name
//! them by date): all but the last learn, in turn, each from the record the one before left;
//! the last is judged. Then every drive is judged the same way, clean and on the larger tyres,
//! with the record learnt over all the others in order (a car's later drives, which we do not
//! have, will meet a record learnt before them). The drives' own fold numbers (strategy 1's
//! term, strategy 2's templates) are the source's held-out fold, as everywhere in the
//! evaluation.

use super::plan::{EvalOptions, DRIFT_SWEEP_MPS, WINDOW_S};
use super::results::{CalibratedCar, CalibratedNuisance, CalibratedRate, HeldOutDrive, SweepCounts};
use super::run::{receiver_class, verdicts_calibrated, Folds};
use super::stats::alarm_episodes;
use crate::dataset::Drive;
use detector_core::fusion::Reason;
use detector_core::strategy::StrategyId;
use detector_core::strategy::track::calibration::Record;
use gnss_data::attack::{self, AttackKind, AttackParams};
use gnss_data::nuisance::{self, Nuisance, NuisanceKind};
use gnss_data::replay;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The earliest onset on a calibrated car, seconds into the drive.
pub const CALIBRATED_FIRST_ONSET_S: f64 = 20.0;
/// The tyre change the judged drive is also replayed with: the wheels' circumference this many
/// times the calibrated one (the wheel speed reads low by as much).
pub const TYRE_CHANGE: f64 = 1.03;
/// Scenarios per rate and direction on the judged drive (spread over its candidate onsets).
pub const CALIBRATED_SCENARIOS: usize = 20;
/// Draws of each nuisance kind on the judged drive, from the record.
pub const CALIBRATED_NUISANCE_DRAWS: usize = 4;

/// Every source with two or more drives with wheel speed: its last drive judged calibrated.
pub fn calibrated_cars(drives: &[Drive], o: &EvalOptions, folds: &Folds) -> BTreeMap<String, CalibratedCar> {
    let mut by_source: BTreeMap<&str, Vec<&Drive>> = BTreeMap::new();
    for d in drives.iter().filter(|d| d.has_wheel_speed()) {
        by_source.entry(d.source.as_str()).or_default().push(d);
    }
    by_source
        .into_iter()
        .filter(|(_, v)| v.len() >= 2)
        .map(|(src, mut v)| {
            v.sort_by(|a, b| a.name.cmp(&b.name));
            (src.to_string(), car(&v, o, folds))
        })
        .collect()
}

/// The record the drives leave, learnt in turn, each from the record the one before left.
fn learn(drives: &[&Drive], o: &EvalOptions, folds: &Folds) -> Option<Record> {
    let mut record: Option<Record> = None;
    for d in drives {
        let (_, r) = verdicts_calibrated(d, &d.samples, o, folds, record.as_ref());
        // A drive that ends uncalibrated or contradicts the record leaves the record as it was.
        record = r.or(record);
    }
    record
}

/// A drive judged clean with `record`: its alarm episodes, whether it contradicted the record,
/// and when the same drive on tyres 3 % larger contradicted it (which it must, and say so).
fn judge_clean(d: &Drive, o: &EvalOptions, folds: &Folds, record: Option<&Record>) -> (usize, bool, Option<f64>) {
    let (clean, _) = verdicts_calibrated(d, &d.samples, o, folds, record);
    let contradicted = clean.iter().any(|v| v.reasons.contains(Reason::CalibrationContradicted));
    let tyres = nuisance::apply(&d.replay, &Nuisance { wheel_scale: Some(1.0 / TYRE_CHANGE), ..Default::default() }, o.seed);
    let (tyre_samples, _) = replay::synchronize(&tyres, o.sync);
    let (tv, _) = verdicts_calibrated(d, &tyre_samples, o, folds, record);
    let t0 = tv.first().map_or(0.0, |v| v.t);
    let found = tv.iter().find(|v| v.reasons.contains(Reason::CalibrationContradicted)).map(|v| v.t - t0);
    (alarm_episodes(&clean), contradicted, found)
}

/// The judged drive `d` under [`CALIBRATED_NUISANCE_DRAWS`] draws of every nuisance kind (seeds
/// of their own), each judged from `record`: alarms, contradictions, and alarms without one.
fn nuisance_from_record(d: &Drive, o: &EvalOptions, folds: &Folds, record: Option<&Record>) -> Vec<CalibratedNuisance> {
    let hz = d.profile.nominal_dt_s.recip() as f64;
    NuisanceKind::ALL
        .par_iter()
        .map(|&k| {
            let runs: Vec<(bool, bool, bool)> = (0..CALIBRATED_NUISANCE_DRAWS)
                .into_par_iter()
                .map(|v| {
                    let seed = o.seed.wrapping_mul(1_000_003).wrapping_add((500_000 + k as usize * 100 + v) as u64);
                    let n = Nuisance::draw(k, seed, d.hours() * 3600.0, hz);
                    let (samples, _) = replay::synchronize(&nuisance::apply(&d.replay, &n, seed), o.sync);
                    let (v, _) = verdicts_calibrated(d, &samples, o, folds, record);
                    let contradicted = v.iter().any(|x| x.reasons.contains(Reason::CalibrationContradicted));
                    // A check that fired: any strategy but the track check, whose contradiction
                    // fires it too, or the track check's own windows and velocity test.
                    let checks = [Reason::Track10s, Reason::Track30s, Reason::VelocityAlong, Reason::VelocityAcross];
                    let other = v.iter().any(|x| x.fired.iter().any(|st| st != StrategyId::Track) || checks.iter().any(|&r| x.reasons.contains(r)));
                    (v.iter().any(|x| x.alarm), contradicted, other)
                })
                .collect();
            CalibratedNuisance {
                kind: k.name(),
                runs: runs.len(),
                alarmed: runs.iter().filter(|r| r.0).count(),
                contradicted: runs.iter().filter(|r| r.1).count(),
                uncontradicted_alarms: runs.iter().filter(|r| r.0 && !r.1).count(),
                other_checks_fired: runs.iter().filter(|r| r.2).count(),
            }
        })
        .collect()
}

fn car(drives: &[&Drive], o: &EvalOptions, folds: &Folds) -> CalibratedCar {
    // Every drive judged with the record its other drives leave; the last one's is the car's
    // record (learnt over the drives before it), which the drift sweep below starts from.
    let held_out: Vec<(HeldOutDrive, Option<Record>)> = (0..drives.len())
        .into_par_iter()
        .map(|i| {
            let others: Vec<&Drive> = drives.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, d)| *d).collect();
            let r = learn(&others, o, folds);
            let (false_alarms, contradicted, tyre_change_found_s) = judge_clean(drives[i], o, folds, r.as_ref());
            (HeldOutDrive { judged: drives[i].name.clone(), learnt_on: others.iter().map(|d| d.name.clone()).collect(), recorded: r.is_some(), false_alarms, contradicted, tyre_change_found_s }, r)
        })
        .collect();
    let (learn_on, judged) = drives.split_at(drives.len() - 1);
    let d = judged[0];
    let record = held_out.last().and_then(|(_, r)| *r);
    let every_drive: Vec<HeldOutDrive> = held_out.into_iter().map(|(h, _)| h).collect();
    let (false_alarms, contradicted, tyre_change_found_s) = every_drive.last().map_or((0, false, None), |h| (h.false_alarms, h.contradicted, h.tyre_change_found_s));
    // Onsets spread evenly over the candidates from the first minute on, both directions.
    let cands = attack::candidate_onsets_from(AttackKind::SlowDrift, &d.samples, Some(CALIBRATED_FIRST_ONSET_S));
    let n = cands.len().min(CALIBRATED_SCENARIOS);
    let onsets: Vec<f64> = (0..n).map(|i| cands[i * cands.len() / n.max(1)]).collect();
    let rates: Vec<CalibratedRate> = DRIFT_SWEEP_MPS
        .iter()
        .map(|&rate| {
            let runs: Vec<(bool, Option<f64>, bool)> = onsets
                .par_iter()
                .enumerate()
                .flat_map(|(i, &t)| [false, true].into_par_iter().map(move |across| (i, t, across)))
                .map(|(i, onset, across)| {
                    let mut window = d.replay.clone();
                    window.events.retain(|e| e.t() <= onset + WINDOW_S);
                    let fixed = AttackParams { rate_mps: Some(rate), across: Some(across), ..Default::default() };
                    let a = attack::apply_with(&window, AttackKind::SlowDrift, o.seed.wrapping_add(i as u64), onset, &fixed);
                    let (samples, _) = replay::synchronize(&a.replay, o.sync);
                    let (v, _) = verdicts_calibrated(d, &samples, o, folds, record.as_ref());
                    let ttd = v.iter().find(|x| x.t >= onset && !x.fired.is_empty()).map(|x| x.t - onset);
                    let pre = v.iter().any(|x| x.t < onset && !x.fired.is_empty());
                    (across, ttd, pre)
                })
                .collect();
            let mut c = SweepCounts::default();
            let mut pre_onset = 0;
            for (across, ttd, pre) in runs {
                if across { c.across.add(rate, ttd) } else { c.along.add(rate, ttd) }
                pre_onset += pre as usize;
            }
            c.along.finish();
            c.across.finish();
            CalibratedRate { rate_mps: rate, counts: c, pre_onset_alarms: pre_onset }
        })
        .collect();
    CalibratedCar {
        learnt_on: learn_on.iter().map(|d| d.name.clone()).collect(),
        judged: d.name.clone(),
        receiver: receiver_class(d),
        record,
        false_alarms,
        contradicted,
        tyre_change_found_s,
        first_onset_s: CALIBRATED_FIRST_ONSET_S,
        onsets: onsets.len(),
        sweep: rates,
        every_drive,
        nuisance: nuisance_from_record(d, o, folds, record.as_ref()),
    }
}
