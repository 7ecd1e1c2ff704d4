//! Property tests: no input makes the synchroniser or the detector panic, and both stay usable.

use detector_core::fusion::{Config, Detector};
use detector_core::geo::{destination, haversine_m, LatLon, EARTH_RADIUS_PAPER_M};
use detector_core::profile::LOGGER_1HZ;
use detector_core::sample::{Fix, Reading, Sample, Signal};
use detector_core::strategy::location_shift::KinematicPredictor;
use detector_core::strategy::StrategyId;
use detector_core::sync::{SyncConfig, Synchronizer};
use proptest::prelude::*;

fn wild_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(0.0), Just(-0.0),
        Just(1e300), Just(-1e300), Just(f64::MIN_POSITIVE), Just(1.7e9), -1e6..1e6f64, 0.0..100.0f64,
        1.3e9..1.3e9 + 100.0,
    ]
}

fn wild_f32() -> impl Strategy<Value = f32> {
    prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(-f32::INFINITY), Just(f32::MAX), -1e3..1e3f32]
}

fn reading() -> impl Strategy<Value = Reading> {
    prop_oneof![wild_f32().prop_map(Reading::Valid), Just(Reading::Stale), Just(Reading::Missing)]
}

fn sample() -> impl Strategy<Value = Sample> {
    (wild_f64(), wild_f32(), wild_f64(), wild_f64(), (reading(), reading(), reading(), reading()), proptest::array::uniform5(reading()), (reading(), reading(), reading(), any::<bool>(), wild_f32()))
        .prop_map(|(t, dt_s, lat, lon, (shift_m, gnss_speed, gnss_course, gnss_h_acc), signals, (dist_m, turn_deg, turn_abs_deg, receiver_spoofing, wheel_step_mps))| Sample {
            t, dt_s, pos: LatLon::new(lat, lon), shift_m, gnss_speed, gnss_course, gnss_h_acc, signals, dist_m, turn_deg, turn_abs_deg, receiver_spoofing, wheel_step_mps,
        })
}

/// 30 clean 1 Hz epochs from time `t0` at 10 m/s, with a 200 m jump at epoch 20.
fn clean_with_jump(t0: f64) -> Vec<Sample> {
    let mut out = Vec::new();
    let mut p = LatLon::new(40.0, -83.0);
    let mut prev: Option<LatLon> = None;
    for k in 0..30 {
        p = destination(p, 45.0, 10.0, EARTH_RADIUS_PAPER_M);
        let rep = if k >= 20 { destination(p, 135.0, 200.0, EARTH_RADIUS_PAPER_M) } else { p };
        let mut signals = [Reading::Missing; Signal::COUNT];
        signals[Signal::WheelSpeed.index()] = Reading::Valid(10.0);
        out.push(Sample {
            t: t0 + k as f64,
            dt_s: if prev.is_some() { 1.0 } else { 0.0 },
            pos: rep,
            shift_m: prev.map_or(Reading::Missing, |q| Reading::Valid(haversine_m(q, rep, EARTH_RADIUS_PAPER_M) as f32)),
            gnss_speed: Reading::Valid(10.0),
            gnss_course: Reading::Missing,
            gnss_h_acc: Reading::Missing,
            signals,
            ..Default::default()
        });
        prev = Some(rep);
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn detector_survives_anything_and_still_detects(garbage in proptest::collection::vec(sample(), 0..60)) {
        let set = detector_core::strategy::turn::TemplateSet::parse(detector_core::strategy::turn::DEFAULT_TEMPLATES).unwrap();
        let mut d = Detector::new(Config::for_profile(&LOGGER_1HZ), KinematicPredictor::default()).with_turns(set);
        for s in &garbage {
            let v = d.step(s);
            // A verdict is always coherent: nothing both ran and was degraded.
            prop_assert_eq!(v.ran.0 & v.degraded.0, 0);
            prop_assert!(v.fired.0 & !v.ran.0 == 0, "only strategies that ran can fire");
        }
        d.clear_alarm();
        // Afterwards: a clean drive (starting after any time the garbage reached) is judged again,
        // raises nothing before the attack, and detects the jump.
        let t0 = garbage.iter().map(|s| s.t).filter(|t| t.is_finite() && t.abs() < 1e12).fold(0.0, f64::max) + 100.0;
        let v: Vec<_> = clean_with_jump(t0).iter().map(|s| d.step(s)).collect();
        prop_assert!(v[..20].iter().all(|x| !x.alarm));
        prop_assert!(v[5..20].iter().all(|x| x.ran.contains(StrategyId::LocationShift)));
        prop_assert!(v[20].fired.contains(StrategyId::LocationShift));
    }

    #[test]
    fn synchronizer_survives_anything(
        events in proptest::collection::vec((0u8..7, wild_f64(), wild_f64(), wild_f64(), wild_f32()), 0..200)
    ) {
        let mut s = Synchronizer::new(SyncConfig::default());
        let mut n = 0usize;
        let mut emit = |x: &Sample| {
            assert!(x.t.is_finite() && x.pos.is_valid());
            for r in x.signals { if let Reading::Valid(v) = r { assert!(v.is_finite()) } }
            n += 1;
        };
        for (kind, t, lat, lon, v) in events {
            if kind < 5 {
                s.push_obs(Signal::ALL[kind as usize], t, v, &mut emit);
            } else {
                s.push_fix(Fix { t, pos: LatLon::new(lat, lon), speed_mps: Some(v), course_deg: None, h_acc_m: None, receiver_spoofing: false }, &mut emit);
            }
        }
        s.flush(&mut emit);
        prop_assert_eq!(s.pending(), 0);
        // Still usable: a fresh clean sequence far in the future comes out interpolated.
        let mut got = Vec::new();
        let base = 1e9;
        let mut e2 = |x: &Sample| got.push(*x);
        s.push_obs(Signal::WheelSpeed, base - 0.5, 1.0, &mut e2);
        s.push_fix(Fix { t: base, pos: LatLon::new(1.0, 1.0), speed_mps: None, course_deg: None, h_acc_m: None, receiver_spoofing: false }, &mut e2);
        s.push_obs(Signal::WheelSpeed, base + 0.5, 3.0, &mut e2);
        prop_assert_eq!(got.len(), 1);
        prop_assert_eq!(got[0].wheel_speed(), Reading::Valid(2.0));
    }
}

/// The receiver's own spoofing flag is a reason of its own and supporting only: on a clean drive
/// it never fires a strategy nor raises the alarm, and it shows at exactly the flagged epochs.
#[test]
fn the_receivers_spoofing_flag_is_a_reason_never_an_alarm() {
    use detector_core::fusion::Reason;
    let mut d = Detector::new(Config::for_profile(&LOGGER_1HZ), KinematicPredictor::default());
    let clean: Vec<Sample> = clean_with_jump(1000.0).into_iter().take(20).enumerate().map(|(k, s)| Sample { receiver_spoofing: k % 3 == 1, ..s }).collect();
    for (k, s) in clean.iter().enumerate() {
        let v = d.step(s);
        assert!(!v.alarm && v.fired.is_empty(), "epoch {k}: {v:?}");
        assert_eq!(v.reasons.contains(Reason::ReceiverSpoofing), k % 3 == 1, "epoch {k}");
    }
}
