//! Hand-made sequences that must fire and must not fire, per strategy and for fusion.

use detector_core::fusion::{Config, Detector, Reason, Verdict};
use detector_core::geo::{destination, haversine_m, LatLon, EARTH_RADIUS_PAPER_M};
use detector_core::profile::{LOGGER_1HZ, UBLOX_10HZ};
use detector_core::sample::{Reading, Sample, Signal};
use detector_core::strategy::location_shift::KinematicPredictor;
use detector_core::strategy::StrategyId;

/// A car driving north. `gnss(k, true_pos)` returns the reported position of epoch k.
struct Drive {
    dt: f64,
    samples: Vec<Sample>,
}

impl Drive {
    fn new(dt: f64, n: usize, speed: impl Fn(usize) -> f32, gnss: impl Fn(usize, LatLon) -> LatLon) -> Self {
        let mut samples = Vec::new();
        let mut truth = LatLon::new(48.1, 11.5);
        let mut prev_rep: Option<LatLon> = None;
        for k in 0..n {
            if k > 0 {
                let v = 0.5 * (speed(k - 1) + speed(k)) as f64;
                truth = destination(truth, 0.0, v * dt, EARTH_RADIUS_PAPER_M);
            }
            let rep = gnss(k, truth);
            let mut signals = [Reading::Missing; Signal::COUNT];
            signals[Signal::WheelSpeed.index()] = Reading::Valid(speed(k));
            let (dt_s, shift_m) = match prev_rep {
                Some(p) => (dt as f32, Reading::Valid(haversine_m(p, rep, EARTH_RADIUS_PAPER_M) as f32)),
                None => (0.0, Reading::Missing),
            };
            let gs = match prev_rep {
                Some(p) => haversine_m(p, rep, EARTH_RADIUS_PAPER_M) as f32 / dt as f32,
                None => speed(k),
            };
            samples.push(Sample { t: k as f64 * dt, dt_s, pos: rep, shift_m, gnss_speed: Reading::Valid(gs), gnss_course: Reading::Missing, gnss_h_acc: Reading::Missing, signals, ..Default::default() });
            prev_rep = Some(rep);
        }
        Drive { dt, samples }
    }
    fn run(&self) -> Vec<Verdict> {
        let p = if self.dt < 0.5 { &UBLOX_10HZ } else { &LOGGER_1HZ };
        let mut d = Detector::new(Config::for_profile(p), KinematicPredictor::default());
        self.samples.iter().map(|s| d.step(s)).collect()
    }
}

fn fired(v: &[Verdict], s: StrategyId) -> Vec<u32> {
    v.iter().filter(|x| x.fired.contains(s)).map(|x| x.epoch).collect()
}

#[test]
fn consistent_drive_never_fires() {
    for dt in [0.1, 1.0] {
        let d = Drive::new(dt, 300, |k| 12.0 + 5.0 * ((k as f32) * 0.05).sin(), |_, p| p);
        let v = d.run();
        assert!(v.iter().all(|x| !x.alarm), "dt {dt}");
        // S1 waits for the receiver to settle (5 s after start-up), then runs at every epoch.
        let settled = (5.0 / dt).round() as usize;
        assert!(v[..settled].iter().all(|x| !x.ran.contains(StrategyId::LocationShift) && x.reasons.contains(Reason::GnssSettling)));
        assert!(v.iter().skip(settled).all(|x| x.ran.contains(StrategyId::LocationShift) && x.ran.contains(StrategyId::Motion)));
        assert!(v.iter().skip(2).all(|x| x.ran.contains(StrategyId::Motion)));
    }
}

#[test]
fn settling_is_only_at_start_up() {
    // A time discontinuity restarts the strategies but S1 does not wait again.
    let mut d = Drive::new(1.0, 60, |_| 10.0, |_, p| p);
    for s in d.samples.iter_mut().skip(30) {
        s.t += 100.0;
    }
    let v = d.run();
    assert!(v[30].reasons.contains(Reason::TimeDiscontinuity));
    assert!(v[31..].iter().all(|x| x.ran.contains(StrategyId::LocationShift) && !x.reasons.contains(Reason::GnssSettling)));
    // Time going backwards at start-up ends the wait instead of prolonging it.
    let mut d = Drive::new(1.0, 20, |_| 10.0, |_, p| p);
    d.samples[2].t = -50.0;
    let v = d.run();
    assert!(v[4..].iter().all(|x| !x.reasons.contains(Reason::GnssSettling)));
}

#[test]
fn location_shift_fires_on_a_jump_at_the_jump_epoch() {
    for (dt, jump) in [(0.1, 20.0), (1.0, 40.0)] {
        let d = Drive::new(dt, 100, |_| 10.0, |k, p| if k >= 50 { destination(p, 90.0, jump, EARTH_RADIUS_PAPER_M) } else { p });
        let v = d.run();
        assert_eq!(fired(&v, StrategyId::LocationShift), vec![50], "dt {dt}");
        assert!(v[50].reasons.contains(Reason::ShiftExceedsPrediction));
        assert!(v[49..].iter().skip(1).all(|x| x.alarm), "latched");
        assert_eq!(v[99].first_alarm.unwrap().epoch, 50);
        let s = v[50].shift.unwrap();
        assert!(s.residual_m > s.threshold_m);
    }
}

#[test]
fn location_shift_below_threshold_does_not_fire() {
    // A 1 m step at 10 Hz is under the 3.65 m threshold (1.15 m measured error + 2.5 m GNSS).
    let d = Drive::new(0.1, 100, |_| 10.0, |k, p| if k >= 50 { destination(p, 90.0, 1.0, EARTH_RADIUS_PAPER_M) } else { p });
    assert!(fired(&d.run(), StrategyId::LocationShift).is_empty());
}

#[test]
fn stale_wheel_speed_degrades_s1_and_never_alarms() {
    let mut d = Drive::new(1.0, 60, |_| 10.0, |k, p| if k >= 30 { destination(p, 90.0, 200.0, EARTH_RADIUS_PAPER_M) } else { p });
    for s in d.samples.iter_mut().skip(25) {
        s.signals[Signal::WheelSpeed.index()] = Reading::Stale;
    }
    let v = d.run();
    assert!(v.iter().all(|x| !x.alarm));
    assert!(v[30].degraded.contains(StrategyId::LocationShift) && v[30].degraded.contains(StrategyId::Motion));
    assert!(v[30].reasons.contains(Reason::NoPrediction) && v[30].reasons.contains(Reason::NoMotionInputs));
    assert!(!v[30].ran.contains(StrategyId::LocationShift));
}

#[test]
fn motion_fires_on_gnss_moving_while_wheels_stand() {
    // Stop attack: the car stands, GNSS moves on at 8 m/s from epoch 20.
    let d = Drive::new(1.0, 40, |_| 0.0, |k, p| if k >= 20 { destination(p, 0.0, 8.0 * (k - 19) as f64, EARTH_RADIUS_PAPER_M) } else { p });
    let v = d.run();
    let f = fired(&v, StrategyId::Motion);
    assert_eq!(f.first(), Some(&23), "fires once the disagreement lasted persist_s = 3 s: {f:?}");
    assert!(v[23].reasons.contains(Reason::GnssMovingWheelsStanding));
}

#[test]
fn motion_short_disagreement_does_not_fire() {
    // GNSS moves for 2 s only, then is consistent again (back where it was).
    let d = Drive::new(1.0, 40, |_| 0.0, |k, p| if (20..22).contains(&k) { destination(p, 0.0, 8.0 * (k - 19) as f64, EARTH_RADIUS_PAPER_M) } else { p });
    assert!(fired(&d.run(), StrategyId::Motion).is_empty());
}

#[test]
fn motion_fires_on_frozen_gnss_while_wheels_turn() {
    // Overshoot: GNSS frozen from epoch 30 while the car keeps 10 m/s.
    let frozen = std::cell::Cell::new(None);
    let d = Drive::new(0.1, 100, |_| 10.0, |k, p| {
        if k == 30 { frozen.set(Some(p)); }
        if k >= 30 { frozen.get().unwrap() } else { p }
    });
    let v = d.run();
    let f = fired(&v, StrategyId::Motion);
    // Epoch 31 is the first with zero shift; 3 s (30 epochs) later it fires.
    assert_eq!(f.first(), Some(&61), "{f:?}");
    assert!(v[61].reasons.contains(Reason::GnssStandingWheelsMoving));
}

#[test]
fn a_slow_crawl_is_not_a_frozen_position() {
    // 2 m/s crawl at 1 Hz with a GNSS that reports almost no motion: under GNSS's moving threshold.
    let d = Drive::new(1.0, 40, |_| 2.0, |k, p| destination(p, 0.0, -1.5 * k as f64, EARTH_RADIUS_PAPER_M));
    assert!(fired(&d.run(), StrategyId::Motion).is_empty());
}

#[test]
fn a_frozen_position_during_a_crawl_fires_on_distance() {
    // Overshoot in a queue: 2 m/s at 1 Hz, a position-only receiver (no reported speed) frozen
    // from epoch 20. Each epoch alone is under GNSS's moving threshold for positions (3 m/s);
    // the wheels' 25 m against a position that did not move is not.
    let frozen = std::cell::Cell::new(None);
    let mut d = Drive::new(1.0, 60, |_| 2.0, |k, p| {
        if k == 20 { frozen.set(Some(p)); }
        if k >= 20 { frozen.get().unwrap() } else { p }
    });
    for s in d.samples.iter_mut() {
        s.gnss_speed = Reading::Missing;
    }
    let v = d.run();
    let f = fired(&v, StrategyId::Motion);
    let first = *f.first().unwrap_or_else(|| panic!("never fired: {:?}", v.iter().map(|x| x.motion).collect::<Vec<_>>()));
    // GNSS stands from about epoch 21; 25 m at 2 m/s is 13 epochs more, then 3 s of persistence.
    assert!((33..=45).contains(&first), "{f:?}");
    assert!(v[first as usize].reasons.contains(Reason::GnssStandingWheelsMoving));
}

#[test]
fn a_crawl_whose_gnss_wanders_back_to_its_start_is_not_a_frozen_position() {
    // A queue at 1.2 m/s, a position-only 1 Hz receiver whose noise first holds the position,
    // then carries it 9.6 m east at 0.8 m/s (under GNSS's standing threshold of 1 m/s) and back.
    // After the wheels' 25 m it is within a fifth of their distance of where it stood (judged
    // on the newest position alone, this fired), but it was farther than that on the way.
    let start = std::cell::Cell::new(None);
    let mut d = Drive::new(1.0, 38, |_| 1.2, |k, p| {
        if k == 0 { start.set(Some(p)); }
        let east = match k { 0..=4 => 0.0, 5..=16 => 0.8 * (k - 4) as f64, 17..=28 => 0.8 * (28 - k) as f64, _ => 0.0 };
        destination(start.get().unwrap(), 90.0, east, EARTH_RADIUS_PAPER_M)
    });
    for s in d.samples.iter_mut() {
        s.gnss_speed = Reading::Missing;
    }
    let v = d.run();
    assert!(fired(&v, StrategyId::Motion).is_empty(), "{:?}", v.iter().map(|x| x.motion).collect::<Vec<_>>());
    assert!(v[20].motion.is_some_and(|m| m.gnss == detector_core::strategy::motion::MotionState::Standing && m.wheel == detector_core::strategy::motion::MotionState::Moving), "judged as a crawl");
}

#[test]
fn time_discontinuity_restarts_without_alarm() {
    let mut d = Drive::new(1.0, 40, |_| 10.0, |_, p| p);
    // A 10 s outage: times jump forward, and the position jumps accordingly.
    for s in d.samples.iter_mut().skip(20) {
        s.t += 10.0;
    }
    d.samples[20].dt_s = 11.0;
    d.samples[20].shift_m = Reading::Valid(110.0);
    let v = d.run();
    assert!(v.iter().all(|x| !x.alarm));
    assert!(v[20].reasons.contains(Reason::TimeDiscontinuity));
    assert!(v[22].ran.contains(StrategyId::LocationShift), "back to normal after the gap");
}
