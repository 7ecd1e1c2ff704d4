//! Turn data for strategy 2: segments real (and simulated) drives into turns with the core's own
//! segmenter, labels them by the GNSS course change, selects templates, and evaluates the
//! classifier on held-out drives.
//!
//! Provenance of the steering: `measured` (a steering wheel angle signal: openxc_ford, and the
//! straight comma2k19 / udacity_ch2 drives), `derived` (bicycle-model proxy from yaw rate and
//! speed: css_canedge, driveplotr_nds), `simulated` (the simulator's drives).
//! Split by drive, never by turn: `openxc_ford` (the only real measured turns) is held out whole,
//! so its accuracy is a transfer result; of the other drives, every second one in sorted order
//! per source is held out; simulated drives with seeds 100..103 train, 200..203 are held out.

use crate::dataset::Drive;
use detector_core::sample::Signal;
use detector_core::strategy::turn::{self, Provenance, TemplateSet, TurnClass, TurnConfig, TurnStrategy, QUERY_LEN};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use serde::Serialize;
use std::collections::BTreeMap;

/// A segment is labelled a turn when GNSS confirms more than this course change, degrees ...
pub const LABEL_TURN_DEG: f32 = 45.0;
/// ... and `none` when GNSS changed by less than this (the detector's alarm rules are stricter).
pub const LABEL_STRAIGHT_DEG: f32 = 20.0;

/// Templates per class at most (3 classes x 48 x 66 bytes = 9.5 KB of flash at most; the
/// firmware image has no room for 64 since sddi_commuter's turns joined the training set, and
/// on the held-out turns 48 and 64 differ by one turn of 152).
pub const MAX_PER_CLASS: usize = 48;
/// Sakoe-Chiba band of the templates, points of 32 (12.5 %).
pub const BAND: u16 = 4;

#[derive(Clone, Debug)]
pub struct Turn {
    pub drive: String,
    pub provenance: Provenance,
    pub label: TurnClass,
    pub query: [f32; QUERY_LEN],
    pub t: f64,
    /// The GNSS course change the label was read from, degrees (+ = right).
    pub gnss_change_deg: f32,
}

pub fn provenance_of(d: &Drive) -> Option<Provenance> {
    if d.source == "simulated" {
        return Some(Provenance::Simulated);
    }
    let frac = |sig| d.samples.iter().filter(|s| s.signal(sig).is_valid()).count() as f64 / d.samples.len().max(1) as f64;
    if frac(Signal::Steering) > 0.5 {
        Some(Provenance::Measured)
    } else if frac(Signal::YawRate) > 0.5 {
        Some(Provenance::Derived)
    } else {
        None
    }
}

/// Labelled steering segments of a drive.
pub fn collect(d: &Drive) -> Vec<Turn> {
    let Some(provenance) = provenance_of(d) else { return Vec::new() };
    let mut ts = TurnStrategy::new(TurnConfig::default(), None);
    let mut out = Vec::new();
    for s in &d.samples {
        if let turn::TurnStep::Judged(o) = ts.step(s) {
            if o.mismatch == Some(turn::TurnMismatch::GnssTurnWheelStraight) {
                continue;
            }
            let label = if o.gnss_change_deg > LABEL_TURN_DEG {
                TurnClass::Right
            } else if o.gnss_change_deg < -LABEL_TURN_DEG {
                TurnClass::Left
            } else if o.gnss_change_deg.abs() < LABEL_STRAIGHT_DEG {
                TurnClass::None
            } else {
                continue;
            };
            out.push(Turn { drive: d.name.clone(), provenance, label, query: o.query, t: o.start_t, gnss_change_deg: o.gnss_change_deg });
        }
    }
    out
}

/// Is this drive held out? See the module documentation.
pub fn held_out(drives: &[Drive], i: usize) -> bool {
    let d = &drives[i];
    if d.source == "openxc_ford" {
        return true;
    }
    if d.source == "simulated" {
        return d.name.contains("seed2");
    }
    let mut same: Vec<&str> = drives.iter().filter(|x| x.source == d.source).map(|x| x.name.as_str()).collect();
    same.sort();
    same.iter().position(|n| *n == d.name).is_some_and(|k| k % 2 == 1)
}

/// Neighbours each training turn is compared with when the training set is edited.
pub const EDIT_K: usize = 3;

/// Wilson's editing of the training set: the turns whose label the majority of their
/// [`EDIT_K`] nearest other training turns (banded DTW, as the classifier measures) does not
/// share. A segment that GNSS calls straight while its steering is shaped like a right turn (a
/// curve driven slowly, a turn whose course GNSS measured short) would otherwise become a
/// `none` template that calls real right turns `none`. Training turns only: the held-out ones
/// are never seen.
pub fn mislabelled(train: &[Turn]) -> Vec<bool> {
    use detector_core::strategy::turn::dtw::dtw_reference;
    train
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mut d: Vec<(f32, TurnClass)> = train.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, o)| (dtw_reference(&t.query, &o.query, BAND as usize), o.label)).collect();
            d.sort_by(|a, b| a.0.total_cmp(&b.0));
            let agree = d.iter().take(EDIT_K).filter(|(_, c)| *c == t.label).count();
            d.len() >= EDIT_K && 2 * agree < EDIT_K
        })
        .collect()
}

/// Chooses at most `MAX_PER_CLASS` templates per class (seeded) from the edited training set
/// ([`mislabelled`] turns left out) and encodes the blob.
pub fn select(train: &[Turn], seed: u64) -> Vec<u8> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut chosen = Vec::new();
    let drop = mislabelled(train);
    let kept: Vec<&Turn> = train.iter().zip(&drop).filter(|(_, d)| !**d).map(|(t, _)| t).collect();
    for class in [TurnClass::None, TurnClass::Left, TurnClass::Right] {
        let mut c: Vec<&Turn> = kept.iter().copied().filter(|t| t.label == class).collect();
        c.shuffle(&mut rng);
        chosen.extend(c.into_iter().take(MAX_PER_CLASS).map(|t| (t.label, t.provenance, t.query)));
    }
    let mut buf = vec![0u8; 14 + chosen.len() * (2 + 2 * QUERY_LEN) + 4];
    let n = TemplateSet::encode(BAND, &chosen, &mut buf).expect("buffer sized for the templates");
    buf.truncate(n);
    buf
}

#[derive(Clone, Debug, Serialize)]
pub struct ClassStats {
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct ProvStats {
    pub n: usize,
    pub accuracy: f64,
    pub ci95_low: f64,
    pub ci95_high: f64,
}

/// A held-out segment the classifier read otherwise than its label.
#[derive(Clone, Debug, Serialize)]
pub struct TurnMiss {
    pub drive: String,
    /// The segment's start, seconds on the drive's clock.
    pub t: f64,
    pub provenance: &'static str,
    pub label: &'static str,
    pub predicted: &'static str,
    /// The GNSS course change the label was read from, degrees (+ = right).
    pub gnss_change_deg: f32,
    /// The largest steering wheel angle of the segment's query, degrees (+ = left).
    pub steering_peak_deg: f32,
}

#[derive(Clone, Debug, Serialize)]
pub struct TurnReport {
    pub train_turns: usize,
    pub templates: usize,
    pub templates_bytes: usize,
    pub held_out: usize,
    pub accuracy: f64,
    pub ci95_low: f64,
    pub ci95_high: f64,
    /// Macro F1 over left and right.
    pub f1: f64,
    pub per_class: BTreeMap<&'static str, ClassStats>,
    /// confusion[true][predicted], classes none/left/right.
    pub confusion: BTreeMap<&'static str, BTreeMap<&'static str, usize>>,
    pub by_provenance: BTreeMap<&'static str, ProvStats>,
    /// Every held-out segment read otherwise than its label.
    pub misses: Vec<TurnMiss>,
    /// The pruned classifier gave the reference's label and distance on every held-out query.
    pub exact: bool,
    pub exact_checked: usize,
    pub us_per_query_pruned: f64,
    pub us_per_query_reference: f64,
}

/// Two-sided 95 % Clopper-Pearson interval for k successes in n.
pub fn clopper_pearson(k: usize, n: usize) -> (f64, f64) {
    use statrs::distribution::{Beta, ContinuousCDF};
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, nf) = (k as f64, n as f64);
    let lo = if k == 0.0 { 0.0 } else { Beta::new(k, nf - k + 1.0).map(|b| b.inverse_cdf(0.025)).unwrap_or(0.0) };
    let hi = if k == nf { 1.0 } else { Beta::new(k + 1.0, nf - k).map(|b| b.inverse_cdf(0.975)).unwrap_or(1.0) };
    (lo, hi)
}

pub fn evaluate(blob: &[u8], train_turns: usize, test: &[Turn], k: usize) -> TurnReport {
    let set = TemplateSet::parse(blob).expect("our own blob");
    let classes = [TurnClass::None, TurnClass::Left, TurnClass::Right];
    let mut conf = [[0usize; 3]; 3];
    let mut exact = true;
    let mut prov: BTreeMap<&'static str, (usize, usize)> = BTreeMap::new();
    let mut misses = Vec::new();
    let t0 = std::time::Instant::now();
    let preds: Vec<_> = test.iter().map(|t| turn::classify(&set, &t.query, k)).collect();
    let pruned_us = t0.elapsed().as_secs_f64() * 1e6 / test.len().max(1) as f64;
    let t1 = std::time::Instant::now();
    let refs: Vec<_> = test.iter().map(|t| turn::classify_reference(&set, &t.query, k)).collect();
    let ref_us = t1.elapsed().as_secs_f64() * 1e6 / test.len().max(1) as f64;
    for ((t, p), r) in test.iter().zip(&preds).zip(&refs) {
        let pc = p.map_or(TurnClass::None, |n| n.class);
        exact &= p.map(|n| (n.class, n.distance)) == r.map(|n| (n.class, n.distance));
        conf[t.label as usize][pc as usize] += 1;
        if pc != t.label {
            let peak = t.query.iter().fold(0.0f32, |a, q| if q.abs() > a.abs() { *q } else { a });
            misses.push(TurnMiss { drive: t.drive.clone(), t: t.t, provenance: t.provenance.name(), label: t.label.name(), predicted: pc.name(), gnss_change_deg: t.gnss_change_deg, steering_peak_deg: peak });
        }
        let e = prov.entry(t.provenance.name()).or_default();
        e.0 += 1;
        e.1 += usize::from(pc == t.label);
    }
    let n = test.len();
    let correct: usize = (0..3).map(|i| conf[i][i]).sum();
    let (lo, hi) = clopper_pearson(correct, n);
    let mut per_class = BTreeMap::new();
    for c in classes {
        let i = c as usize;
        let tp = conf[i][i] as f64;
        let pred: f64 = (0..3).map(|r| conf[r][i] as f64).sum();
        let actual: f64 = conf[i].iter().sum::<usize>() as f64;
        let p = if pred > 0.0 { tp / pred } else { 0.0 };
        let r = if actual > 0.0 { tp / actual } else { 0.0 };
        per_class.insert(c.name(), ClassStats { precision: p, recall: r, f1: if p + r > 0.0 { 2.0 * p * r / (p + r) } else { 0.0 } });
    }
    let confusion = classes.iter().map(|a| (a.name(), classes.iter().map(|b| (b.name(), conf[*a as usize][*b as usize])).collect())).collect();
    TurnReport {
        train_turns,
        templates: set.len(),
        templates_bytes: blob.len(),
        held_out: n,
        accuracy: if n > 0 { correct as f64 / n as f64 } else { 0.0 },
        ci95_low: lo,
        ci95_high: hi,
        f1: (per_class["left"].f1 + per_class["right"].f1) / 2.0,
        per_class,
        confusion,
        by_provenance: prov.into_iter().map(|(k, (n, c))| {
            let (lo, hi) = clopper_pearson(c, n);
            (k, ProvStats { n, accuracy: c as f64 / n.max(1) as f64, ci95_low: lo, ci95_high: hi })
        }).collect(),
        misses,
        exact,
        exact_checked: n,
        us_per_query_pruned: pruned_us,
        us_per_query_reference: ref_us,
    }
}

/// Collects turns from `drives`, trains on the training split, evaluates on the held-out split.
pub fn train_and_evaluate(drives: &[Drive], seed: u64) -> (Vec<u8>, TurnReport, Vec<Turn>) {
    use rayon::prelude::*;
    let per: Vec<Vec<Turn>> = drives.par_iter().map(collect).collect();
    let (mut train, mut test) = (Vec::new(), Vec::new());
    for (i, t) in per.into_iter().enumerate() {
        if held_out(drives, i) { test.extend(t) } else { train.extend(t) }
    }
    let blob = select(&train, seed);
    let rep = evaluate(&blob, train.len(), &test, TurnConfig::default().k);
    (blob, rep, test)
}

/// Held-out evaluation of the committed default templates (what `eval` reports as `turns`).
pub fn evaluate_default(drives: &[Drive]) -> TurnReport {
    use rayon::prelude::*;
    let per: Vec<Vec<Turn>> = drives.par_iter().map(collect).collect();
    let (mut n_train, mut test) = (0, Vec::new());
    for (i, t) in per.into_iter().enumerate() {
        if held_out(drives, i) { test.extend(t) } else { n_train += t.len() }
    }
    evaluate(turn::DEFAULT_TEMPLATES, n_train, &test, TurnConfig::default().k)
}

/// The simulated drives used for turn templates: seeds 100..103 train, 200..203 are held out.
pub fn sim_drives() -> Vec<Drive> {
    use detector_core::sync::SyncConfig;
    [100, 101, 102, 103, 200, 201, 202, 203]
        .iter()
        .map(|&s| Drive::new(gnss_data::sim::drive(s, 15.0, if s % 2 == 0 { 10.0 } else { 1.0 }), SyncConfig::default()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn turn(label: TurnClass, peak: f32, phase: f32) -> Turn {
        let mut query = [0.0f32; QUERY_LEN];
        for (k, q) in query.iter_mut().enumerate() {
            let x = k as f32 / (QUERY_LEN - 1) as f32;
            *q = peak * (std::f32::consts::PI * x).sin() + phase * (7.0 * x).sin();
        }
        Turn { drive: "d".into(), provenance: Provenance::Measured, label, query, t: 0.0, gnss_change_deg: 0.0 }
    }

    #[test]
    fn a_straight_labelled_segment_shaped_like_right_turns_is_edited_out_and_the_rest_kept() {
        let mut train: Vec<Turn> = (0..4).map(|k| turn(TurnClass::Right, -70.0 - 5.0 * k as f32, k as f32)).collect();
        train.extend((0..4).map(|k| turn(TurnClass::Left, 70.0 + 5.0 * k as f32, k as f32)));
        train.extend((0..3).map(|k| turn(TurnClass::None, 3.0 * k as f32, 4.0)));
        // GNSS called it straight, its steering is a right turn's.
        train.push(turn(TurnClass::None, -72.0, 1.5));
        let drop = mislabelled(&train);
        assert_eq!(drop.iter().filter(|d| **d).count(), 1, "{drop:?}");
        assert!(drop[train.len() - 1]);
        // The edited set's template classifies a right turn right; the unedited set's nearest
        // template for it is the mislabelled one.
        let q = turn(TurnClass::Right, -72.0, 1.4).query;
        let edited = select(&train, 1);
        let set = TemplateSet::parse(&edited).unwrap();
        assert_eq!(set.len(), train.len() - 1);
        assert_eq!(turn::classify(&set, &q, 1).map(|n| n.class), Some(TurnClass::Right));
        let all: Vec<_> = train.iter().map(|t| (t.label, t.provenance, t.query)).collect();
        let mut buf = vec![0u8; 14 + all.len() * (2 + 2 * QUERY_LEN) + 4];
        let n = TemplateSet::encode(BAND, &all, &mut buf).unwrap();
        let unedited = TemplateSet::parse(&buf[..n]).unwrap();
        assert_eq!(turn::classify(&unedited, &q, 1).map(|n| n.class), Some(TurnClass::None));
    }

    /// The report lists every held-out segment read otherwise than its label, with the GNSS
    /// course change its label came from and the steering's peak (signed), and nothing else.
    #[test]
    fn the_report_lists_the_segments_read_otherwise_than_their_label() {
        let mut train: Vec<Turn> = (0..4).map(|k| turn(TurnClass::Right, -70.0 - 5.0 * k as f32, k as f32)).collect();
        train.extend((0..4).map(|k| turn(TurnClass::Left, 70.0 + 5.0 * k as f32, k as f32)));
        let blob = select(&train, 1);
        let mut test = vec![turn(TurnClass::Right, -74.0, 1.0), turn(TurnClass::Left, 76.0, 2.0)];
        // GNSS called it straight (19 deg left), its steering is a left turn's.
        let mut straight = turn(TurnClass::None, 80.0, 0.5);
        straight.drive = "swing".into();
        straight.gnss_change_deg = -19.0;
        test.push(straight);
        let rep = evaluate(&blob, train.len(), &test, 1);
        assert_eq!(rep.misses.len(), 1, "{:?}", rep.misses);
        let m = &rep.misses[0];
        assert_eq!((m.drive.as_str(), m.label, m.predicted), ("swing", "none", "left"));
        assert_eq!(m.gnss_change_deg, -19.0);
        assert!((m.steering_peak_deg - 80.0).abs() < 3.0, "{}", m.steering_peak_deg);
    }
}
