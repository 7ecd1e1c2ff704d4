//! The beyond-the-paper detectors on hand-made 1 Hz sequences: what must fire, when, and what
//! must not (thresholds: the logger-1hz profile's measured ones).

use detector_core::fusion::Config;
use detector_core::geo::LatLon;
use detector_core::profile::LOGGER_1HZ;
use detector_core::sample::{Reading, Sample, Signal};
use detector_core::strategy::consistency::{Check, ConsistencyConfig, HeadingCheck, MovingSum, ResidualCusum, SpeedCheck};

fn cfg() -> ConsistencyConfig {
    Config::for_profile(&LOGGER_1HZ).consistency
}

/// A 1 Hz epoch at `t` with wheel speed, GNSS speed and course, and yaw rate (+ = left).
fn sample(t: f64, wheel: f32, gnss: f32, course: f32, yaw: f32) -> Sample {
    let mut signals = [Reading::Missing; Signal::COUNT];
    signals[Signal::WheelSpeed.index()] = Reading::Valid(wheel);
    signals[Signal::YawRate.index()] = Reading::Valid(yaw);
    Sample {
        t,
        dt_s: if t > 0.0 { 1.0 } else { 0.0 },
        pos: LatLon::new(48.1, 11.5),
        shift_m: Reading::Valid(gnss),
        gnss_speed: Reading::Valid(gnss),
        gnss_course: Reading::Valid(course),
        signals,
    }
}

fn first_fired(v: &[Option<Check>]) -> Option<usize> {
    v.iter().position(|c| c.is_some_and(|c| c.fired))
}

#[test]
fn moving_sum_covers_the_last_window_only() {
    let mut m = MovingSum::default();
    let out: Vec<_> = (1..=20).map(|_| m.push(1.0, 1.0, 2.0, 10.0)).collect();
    // Not judged until 80 % of the window is covered.
    assert!(out[..7].iter().all(Option::is_none), "{out:?}");
    assert_eq!(out[7], Some((8.0, 16.0)));
    // Then the last 10 s: entries older than the window leave.
    assert_eq!(out[19], Some((10.0, 20.0)));
    // At 50 Hz the 128 entries (2.56 s) are all it can hold: it still answers.
    let mut m = MovingSum::default();
    let last = (1..=1000).map(|_| m.push(0.02, 1.0, 0.0, 10.0)).last().unwrap();
    assert_eq!(last, Some((128.0, 0.0)));
}

#[test]
fn residual_window_fires_on_small_biased_steps_before_the_cusum() {
    let c = cfg();
    let mut r = ResidualCusum::default();
    // 40 s clean (the 30 s warm-up learns the scale), then 3 m more than predicted per epoch:
    // 20 % of strategy 1's threshold, far under it.
    let outs: Vec<_> = (1..=80)
        .map(|k| r.step(&c, if k > 40 { 13.0 } else { 10.0 }, 10.0, 1.0, 10.0))
        .collect();
    assert!(outs[..40].iter().all(|o| !o.window_fired && !o.cusum_fired));
    let w = outs.iter().position(|o| o.window_fired).expect("window fires") as i32 - 39;
    let s = outs.iter().position(|o| o.cusum_fired).expect("cusum fires") as i32 - 39;
    // The window sum needs about 19.9 m / 3 m = 7 epochs; the CUSUM (k 0.6 m, h 29 m) about 13.
    assert!((7..=9).contains(&w), "window after {w} epochs");
    assert!(s > w, "cusum after {s} epochs, window after {w}");
}

#[test]
fn residual_tests_wait_for_the_warm_up_and_ignore_a_constant_scale_error() {
    let c = cfg();
    let mut r = ResidualCusum::default();
    // Wheel speed reads 8 % low (worn tyres, or a loaded car): learnt, never an alarm.
    for k in 1..=600 {
        let o = r.step(&c, 10.8, 10.0, 1.0, 10.0);
        assert!(!o.window_fired && !o.cusum_fired, "epoch {k}: {o:?}");
        if k < 30 {
            assert_eq!(o.window_m, None);
        }
    }
}

#[test]
fn speed_check_fires_on_a_sustained_offset_not_on_a_spike() {
    let c = cfg();
    let run = |g: &dyn Fn(usize) -> f32| {
        let mut sp = SpeedCheck::default();
        (0..80).map(|k| sp.step(&c, &sample(k as f64, 15.0, g(k), 0.0, 0.0))).collect::<Vec<_>>()
    };
    // A 5 m/s spike for one epoch (a logger's timing glitch) moves the 10 s mean by 0.5 m/s.
    assert_eq!(first_fired(&run(&|k| if k == 50 { 20.0 } else { 15.0 })), None);
    // A drift of 1.5 m/s along the road from epoch 50: the mean crosses 0.68 + 3 % of 16.5 m/s
    // once 8 of the window's 10 epochs carry it, 9 as the slow scale estimate absorbs a little.
    let f = first_fired(&run(&|k| if k >= 50 { 16.5 } else { 15.0 })).expect("fires");
    assert!((57..=58).contains(&f), "fired at {f}");
    // Without wheel speed it is degraded.
    let mut s = sample(1.0, 15.0, 15.0, 0.0, 0.0);
    s.signals[Signal::WheelSpeed.index()] = Reading::Missing;
    assert_eq!(SpeedCheck::default().step(&c, &s), None);
}

/// A drive at 10 m/s whose gyro reads `bias` deg/s more than the truth; `course(k)` is what
/// the receiver reports, `yaw(k)` the true yaw rate, `wheel(k)` the wheel speed.
fn heading_run(n: usize, bias: f32, wheel: &dyn Fn(usize) -> f32, course: &dyn Fn(usize) -> f32, yaw: &dyn Fn(usize) -> f32) -> Vec<Option<Check>> {
    let c = cfg();
    let mut h = HeadingCheck::default();
    (0..n).map(|k| h.step(&c, &sample(k as f64, wheel(k), wheel(k).max(0.0), course(k), yaw(k) + bias))).collect()
}

#[test]
fn heading_learns_the_gyro_bias_and_fires_on_a_slow_rotation() {
    // Straight road, the gyro 0.5 deg/s off: 5 deg per 10 s window, learnt, no alarm.
    let clean = heading_run(200, 0.5, &|_| 10.0, &|_| 90.0, &|_| 0.0);
    assert_eq!(first_fired(&clean), None);
    assert!(clean[199].unwrap().diff.abs() < 1.0, "{:?}", clean[199]);
    // From epoch 100 the reported course turns at 1.5 deg/s while the car goes straight:
    // 11.1 deg of tolerance (+ 20 % of the little the gyro turned) is passed after 8 epochs.
    let v = heading_run(200, 0.5, &|_| 10.0, &|k| 90.0 + 1.5 * k.saturating_sub(100) as f32, &|_| 0.0);
    let f = first_fired(&v).expect("fires");
    assert!((107..=109).contains(&f), "fired at {f}");
}

#[test]
fn heading_follows_a_real_turn_and_bridges_a_stop() {
    // A real right turn of 90 deg over 10 s at speed: course + 9 deg/s, yaw -9 deg/s.
    let turn = |k: usize| if (60..70).contains(&k) { -9.0 } else { 0.0 };
    let crs = |k: usize| 90.0 + 9.0 * (k.clamp(60, 70) - 60) as f32;
    assert_eq!(first_fired(&heading_run(120, 0.3, &|_| 10.0, &crs, &turn)), None);
    // The same turn made slowly (3 m/s, under the check's 5 m/s): bridged by the gyro alone.
    let slow = |k: usize| if (55..75).contains(&k) { 3.0 } else { 10.0 };
    let v = heading_run(120, 0.3, &slow, &crs, &turn);
    assert_eq!(first_fired(&v), None);
    // A stop of 20 s during which the spoofer turns the reported course by 60 deg: seen at the
    // first epoch back at speed.
    let stop = |k: usize| if (60..80).contains(&k) { 0.0 } else { 10.0 };
    let spoofed = |k: usize| if k >= 70 { 150.0 } else { 90.0 };
    let v = heading_run(120, 0.3, &stop, &spoofed, &|_| 0.0);
    assert_eq!(first_fired(&v), Some(80));
    // Without wheel speed (GNSS speed alone says nothing the spoofer does not control): degraded.
    let mut s = sample(1.0, 10.0, 10.0, 90.0, 0.0);
    s.signals[Signal::WheelSpeed.index()] = Reading::Missing;
    assert_eq!(HeadingCheck::default().step(&cfg(), &s), None);
}

#[test]
fn a_short_gnss_gap_keeps_what_was_learnt_a_long_one_does_not() {
    use detector_core::fusion::Detector;
    use detector_core::strategy::location_shift::KinematicPredictor;
    // GNSS speed 5 % above the wheels (tyre radius): learnt in the warm-up, never an alarm.
    let after_gap = |gap: f64| {
        let mut d = Detector::new(Config::for_profile(&LOGGER_1HZ), KinematicPredictor::default());
        let mut last = None;
        for k in 0..60 {
            d.step(&sample(k as f64, 15.0, 15.75, 90.0, 0.0));
        }
        for k in 0..15 {
            let v = d.step(&sample(59.0 + gap + k as f64, 15.0, 15.75, 90.0, 0.0));
            assert!(!v.alarm, "gap {gap}: {v:?}");
            last = v.speed_diff_mps;
        }
        last
    };
    // 5 s of jamming: the window refills, the speed check judges again 10 s later.
    assert!(after_gap(5.0).is_some_and(|d| d != 0.0 && d.abs() < 0.2), "{:?}", after_gap(5.0));
    // 100 s: another trip; the scale is learnt afresh (30 s warm-up, nothing judged yet).
    assert_eq!(after_gap(100.0), Some(0.0));
}
