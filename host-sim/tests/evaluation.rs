//! The evaluation harness on the real drives: coverage, results from verdicts, determinism.

use detector_core::sync::SyncConfig;
use host_sim::attack::{self, AttackKind};
use host_sim::dataset::Drive;
use host_sim::eval::{self, fold, EvalOptions, Protocol};
use host_sim::input::{self, LoadOptions};
use host_sim::require_data;

fn drives(d: &std::path::Path) -> Vec<Drive> {
    input::discover(&d.join("drives")).unwrap().iter()
        .map(|f| Drive::new(input::load(f, &LoadOptions::default()).unwrap(), SyncConfig::default()))
        .collect()
}

/// The evaluation as `host-sim eval` runs it: leave-one-source-out folds.
fn evaluate(ds: &[Drive], o: &EvalOptions) -> eval::Report {
    let folds = fold::folds(ds, Protocol::LeaveOneSourceOut);
    eval::evaluate(ds, o, "real", "test", &folds, &|| {})
}

#[test]
fn real_drives_paper_attacks_detected_without_false_alarms() {
    let Some(d) = require_data("real_drives_paper_attacks_detected_without_false_alarms") else { return };
    let ds = drives(&d);
    let r = evaluate(&ds, &EvalOptions::default());
    assert_eq!(r.clean.drives, ds.len());
    assert_eq!(r.clean.false_alarms, 0, "{:?}", r.clean.per_drive);
    for kind in AttackKind::ALL {
        let a = &r.attacks[kind.name()];
        assert!(a.scenarios >= 10, "{}: {} scenarios", kind.name(), a.scenarios);
        assert!(a.sources.len() >= 2, "{}: sources {:?}", kind.name(), a.sources);
    }
    for kind in ["turn-by-turn", "overshoot", "stop", "jump"] {
        assert_eq!(r.attacks[kind].detection_rate, 1.0, "{kind}: missed {:?}", r.attacks[kind].missed);
    }
    // Wrong turns on sddi_commuter (1 Hz position only, no gyro, 2.88 deg steering steps) are
    // not all found: 8 of these 10 (43 of 56 in the 100-per-kind run, README "Measured").
    assert!(r.attacks["wrong-turn"].detection_rate >= 0.8, "wrong-turn: missed {:?}", r.attacks["wrong-turn"].missed);
    assert!(r.scenarios.iter().all(|s| s.pre_onset_alarms == 0));
    // Table 3 rows as the strategies of this detector give them.
    assert_eq!(r.attacks["turn-by-turn"].strategies["location_shift"], 10);
    assert_eq!(r.attacks["stop"].strategies["motion"], 10);
    assert_eq!(r.attacks["overshoot"].strategies["motion"], 10);
    assert!(r.attacks["wrong-turn"].strategies["turn"] >= 8, "wrong turns are caught by S2");
    // Strategy 2 tells a coarse, long-constant steering sensor (sddi_commuter) from a stuck one:
    // degraded on under 5 % of every judged source's clean epochs.
    for src in ["sddi_commuter", "css_canedge", "comma2k19"] {
        let (e, dg) = r.clean.per_drive.iter().filter(|c| c.source == src && c.judged)
            .fold((0, 0), |(e, dg), c| (e + c.epochs, dg + c.degraded_epochs["turn"]));
        assert!(e > 0 && dg * 20 < e, "{src}: strategy 2 degraded on {dg} of {e} epochs");
    }
}

#[test]
fn no_source_is_judged_with_numbers_fitted_on_it() {
    let Some(d) = require_data("no_source_is_judged_with_numbers_fitted_on_it") else { return };
    let ds = drives(&d);
    let folds = fold::folds(&ds, Protocol::LeaveOneSourceOut);
    let sources = fold::sources(&ds);
    assert!(sources.len() >= 5, "{sources:?}");
    for src in &sources {
        let f = &folds[src];
        assert!(!f.fitted_on.contains(src), "{src} fitted on {:?}", f.fitted_on);
        assert_eq!(f.fitted_on.len(), sources.len() - 1);
    }
    // The proof that nothing leaks: make one source's drives different (its GNSS positions
    // scattered, so the kinematic error term it would give is far larger, and its courses
    // turned, so the turns its templates are cut from are others) and refit. Its own fold is
    // unchanged, bit for bit; a fold that trains on it changes.
    let held = "css_canedge";
    let mut changed = ds.clone();
    for dr in changed.iter_mut().filter(|dr| dr.source == held) {
        for (k, s) in dr.samples.iter_mut().enumerate() {
            s.pos.lat_deg += if k % 2 == 0 { 2e-4 } else { -2e-4 };
            if let Some(c) = s.gnss_course.get() {
                s.gnss_course = detector_core::sample::Reading::Valid(c + (k / 50 % 2) as f32 * 90.0);
            }
        }
    }
    let refit = fold::folds(&changed, Protocol::LeaveOneSourceOut);
    let same = |a: &eval::Fitted, b: &eval::Fitted| a.kinematic_error_m == b.kinematic_error_m && a.templates == b.templates && a.fitted_on == b.fitted_on;
    assert!(same(&folds[held], &refit[held]), "{held}'s own numbers moved with its data");
    assert!(!same(&folds["openxc_ford"], &refit["openxc_ford"]), "the fold trained on {held} must see the change");
    // And the report's held-out figures say what they were fitted on.
    let r = eval::evaluate(&ds, &EvalOptions { scenarios: 1, ..Default::default() }, "real", "test", &folds, &|| {});
    for (src, c) in &r.cross_source {
        assert!(!c.fitted_on.contains(src), "{src}");
    }
}

#[test]
fn turn_classifier_held_out_by_drive() {
    let Some(d) = require_data("turn_classifier_held_out_by_drive") else { return };
    let mut ds = drives(&d);
    ds.extend(host_sim::turns::sim_drives().into_iter().filter(|d| d.name.contains("seed2")));
    let t = host_sim::turns::evaluate_default(&ds);
    assert!(t.held_out >= 100, "{} held-out turns", t.held_out);
    assert!(t.exact && t.exact_checked == t.held_out, "pruned == plain DTW on every query");
    // 98.0 % measured (149 of 152) with the edited training set; 93.4 % before the editing.
    assert!(t.accuracy >= 0.97, "accuracy {}", t.accuracy);
    assert!(t.ci95_low < t.accuracy && t.accuracy < t.ci95_high);
    for p in ["measured", "derived", "simulated"] {
        assert!(t.by_provenance[p].n > 0, "{p}");
    }
}

#[test]
fn training_the_templates_reproduces_the_committed_blob() {
    let Some(d) = require_data("training_the_templates_reproduces_the_committed_blob") else { return };
    let mut ds = drives(&d);
    ds.extend(host_sim::turns::sim_drives());
    let (blob, rep, _) = host_sim::turns::train_and_evaluate(&ds, 1);
    assert_eq!(blob, detector_core::strategy::turn::DEFAULT_TEMPLATES, "re-run `host-sim train turns` and commit the blob");
    assert!(rep.templates <= 3 * host_sim::turns::MAX_PER_CLASS);
}

#[test]
fn numbers_come_from_verdicts_a_blind_detector_detects_nothing() {
    let Some(d) = require_data("numbers_come_from_verdicts_a_blind_detector_detects_nothing") else { return };
    let ds = drives(&d);
    let o = EvalOptions {
        tweak: Some(|c| {
            c.shift.predictor_error_m = f32::INFINITY;
            c.shift.fallback_error_m = f32::INFINITY;
            c.motion.persist_s = f32::INFINITY;
            c.turn.gnss_turn_deg = f32::INFINITY;
            c.turn.straight_turn_deg = f32::INFINITY;
            c.track.enabled = false;
        }),
        ..Default::default()
    };
    let r = evaluate(&ds, &o);
    for (k, a) in &r.attacks {
        assert!(a.scenarios >= 10);
        assert_eq!(a.detected, 0, "{k}");
        assert_eq!(a.detection_rate, 0.0);
    }
}

#[test]
fn evaluation_is_deterministic_for_a_seed() {
    let Some(d) = require_data("evaluation_is_deterministic_for_a_seed") else { return };
    let ds = drives(&d);
    let a = serde_json::to_string(&evaluate(&ds, &EvalOptions::default())).unwrap();
    let b = serde_json::to_string(&evaluate(&ds, &EvalOptions::default())).unwrap();
    assert_eq!(a, b);
    let c = serde_json::to_string(&evaluate(&ds, &EvalOptions { seed: 2, ..Default::default() })).unwrap();
    assert_ne!(a, c, "another seed draws other scenarios");
}

#[test]
fn attacks_rewrite_position_speed_and_course_consistently() {
    let Some(d) = require_data("attacks_rewrite_position_speed_and_course_consistently") else { return };
    let r = input::load(&d.join("drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv"), &LoadOptions::default()).unwrap();
    let onset = 20.0;
    let fixes = |r: &input::Replay| r.fixes().copied().collect::<Vec<_>>();
    let clean = fixes(&r);
    // turn-by-turn: constant offset after the onset, untouched before; speed and course kept.
    let a = attack::apply(&r, AttackKind::TurnByTurn, 7, onset);
    let f = fixes(&a.replay);
    let off: Vec<f64> = clean.iter().zip(&f).filter(|(c, _)| c.t >= onset)
        .map(|(c, x)| detector_core::geo::haversine_m(c.pos, x.pos, 6_378_000.0)).collect();
    assert!(off.iter().all(|o| (o - off[0]).abs() < 0.5 && *o >= 30.0 && *o <= 300.0), "{:?}", &off[..3]);
    assert!(clean.iter().zip(&f).filter(|(c, _)| c.t < onset).all(|(c, x)| c == x));
    // overshoot: frozen, reported speed 0.
    let a = attack::apply(&r, AttackKind::Overshoot, 7, onset);
    let f: Vec<_> = fixes(&a.replay).into_iter().filter(|x| x.t >= onset).collect();
    assert!(f.iter().all(|x| x.pos == f[0].pos && x.speed_mps == Some(0.0)));
    // ground truth
    assert!(!a.active(onset - 0.1) && a.active(onset));
    // the vehicle signals are never touched
    let obs = |r: &input::Replay| r.events.iter().filter(|e| matches!(e, input::Event::Obs { .. })).copied().collect::<Vec<_>>();
    assert_eq!(obs(&a.replay), obs(&r));
}
