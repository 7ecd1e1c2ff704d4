//! The track check on a simulated car whose sensors differ from the nominal ones the way a new
//! installation does (wheel-speed scale, gyro bias and scale, GNSS latency and noise), over
//! the minutes of driving its learning takes: what it learns, that it stays silent, and what
//! it finds after that.

use detector_core::geo::{destination, haversine_m, LatLon, EARTH_RADIUS_PAPER_M};
use detector_core::profile::LOGGER_1HZ;
use detector_core::sample::{Reading, Sample, Signal};
use detector_core::strategy::track::{HeadingSource, TrackCheck, TrackConfig, TrackOutcome};

/// xorshift64*: deterministic noise without a dependency.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-12), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// How the simulated installation differs from the truth, and what the GNSS reports.
#[derive(Clone)]
struct Car {
    wheel_scale: f64,
    gyro_bias_degps: f64,
    gyro_scale: f64,
    gnss_delay_s: f64,
    gnss_noise_m: f64,
    h_acc_m: Option<f32>,
    /// Spoofing: the offset of the reported position at time t (metres east, north).
    spoof: fn(f64) -> (f64, f64),
    /// No GNSS fix in these intervals.
    gaps: Vec<(f64, f64)>,
    /// The car does not stop before this time (s).
    first_stop_s: f64,
    /// The wheel speed and yaw rate this late (s).
    vehicle_delay_s: f64,
    /// Each fix up to this much early or late against the one-second grid (s).
    fix_jitter_s: f64,
    /// The receiver reports its course (and so its velocity) too.
    course: bool,
    /// The receiver's own position error at time t, smooth (metres east, north): in its
    /// position, not in its velocity (multipath moves the one, not the Doppler other).
    wander: fn(f64) -> (f64, f64),
    /// The receiver's own course error at time t, degrees (with `course`).
    course_off: fn(f64) -> f64,
    /// Yaw rate added to the truth's at time t, deg/s (+ left).
    s_bend: fn(f64) -> f64,
    /// Yaw rate added to the gyro's reading alone at time t, deg/s (an error of the gyro's).
    gyro_off: fn(f64) -> f64,
    /// The car crawls at 2 m/s over this interval (s), straight ahead.
    crawl: Option<(f64, f64)>,
    /// Speed added to the receiver's reported speed at time t, m/s (a spoofer's).
    speed_off: fn(f64) -> f64,
    /// No turns: a straight road (its stops kept).
    straight: bool,
    /// Where this gives a motion, the car makes it instead of the truth's: a signed speed (m/s,
    /// negative: reversing, which its wheel speed does not say) and a yaw rate (deg/s, + left).
    manoeuvre: fn(f64) -> Option<(f64, f64)>,
}

impl Default for Car {
    fn default() -> Self {
        Car { wheel_scale: 1.03, gyro_bias_degps: 0.3, gyro_scale: 1.02, gnss_delay_s: 0.5, gnss_noise_m: 0.7, h_acc_m: None, spoof: |_| (0.0, 0.0), gaps: Vec::new(), first_stop_s: 0.0, vehicle_delay_s: 0.0, fix_jitter_s: 0.0, course: false, wander: |_| (0.0, 0.0), course_off: |_| 0.0, s_bend: |_| 0.0, gyro_off: |_| 0.0, crawl: None, speed_off: |_| 0.0, straight: false, manoeuvre: |_| None }
    }
}

/// The true motion at time t: speed (m/s) and yaw rate (deg/s, + left). A stop of 20 s every
/// 150 s (from `first_stop_s` on), a 90 deg turn (9 deg/s for 10 s) every 60 s, alternating
/// left and right.
fn truth(t: f64, first_stop_s: f64) -> (f64, f64) {
    let c = t % 150.0;
    let v = if t < first_stop_s { 15.0 } else if c < 20.0 { 0.0 } else if c < 25.0 { 3.0 * (c - 20.0) } else { 15.0 };
    let k = (t / 60.0) as u64;
    let p = t % 60.0;
    let yaw = if v > 5.0 && (30.0..40.0).contains(&p) { if k % 2 == 0 { 9.0 } else { -9.0 } } else { 0.0 };
    (v, yaw)
}

/// The samples of a car without a gyro: no yaw rate, no turn integrals.
fn without_gyro(mut v: Vec<Sample>) -> Vec<Sample> {
    for s in v.iter_mut() {
        s.signals[Signal::YawRate.index()] = Reading::Missing;
        s.turn_deg = Reading::Missing;
        s.turn_abs_deg = Reading::Missing;
    }
    v
}

/// One sample per second for `secs` seconds, as the synchroniser would make them (the
/// integrals of wheel speed and yaw rate since the previous epoch included).
fn drive(car: &Car, secs: f64, seed: u64) -> Vec<Sample> {
    let mut rng = Rng(seed | 1);
    let dt = 0.01;
    let mut pos = LatLon::new(55.9, 10.1);
    let mut heading = 30.0f64; // bearing, degrees
    let mut track: Vec<(f64, LatLon)> = Vec::new();
    let (mut dist, mut turn, mut turn_abs) = (0.0f64, 0.0f64, 0.0f64);
    let mut out = Vec::new();
    let mut prev: Option<(f64, LatLon)> = None;
    let mut t = 0.0;
    let mut next_epoch = 1.0;
    let truth = |t: f64| match (car.crawl, (car.manoeuvre)(t)) {
        (_, Some(m)) => m,
        (Some((a, b)), _) if (a..b).contains(&t) => (2.0, 0.0),
        _ => {
            let (v, yaw) = truth(t, car.first_stop_s);
            (v, if car.straight { 0.0 } else { yaw })
        }
    };
    while t < secs {
        let (v, yaw) = truth(t);
        let yaw = yaw + (car.s_bend)(t);
        heading -= yaw * dt;
        pos = destination(pos, heading, v * dt, EARTH_RADIUS_PAPER_M);
        // What the vehicle's sensors say now: the truth `vehicle_delay_s` ago.
        let (v, yaw) = if car.vehicle_delay_s > 0.0 {
            let late = (t - car.vehicle_delay_s).max(0.0);
            let (v, yaw) = truth(late);
            (v, yaw + (car.s_bend)(late))
        } else {
            (v, yaw)
        };
        // The wheels say how fast, not which way (ABS and OBD speeds).
        let v = v.abs();
        t += dt;
        track.push((t, pos));
        dist += v * car.wheel_scale * dt;
        let gyro = yaw * car.gyro_scale + car.gyro_bias_degps + (car.gyro_off)(t);
        turn += gyro * dt;
        turn_abs += gyro.abs() * dt;
        if t + 1e-9 < next_epoch {
            continue;
        }
        next_epoch += 1.0;
        if car.fix_jitter_s > 0.0 {
            next_epoch += (rng.uniform() * 2.0 - 1.0) * car.fix_jitter_s;
        }
        if car.gaps.iter().any(|&(a, b)| t > a && t < b) {
            continue;
        }
        // The receiver reports where the car was `gnss_delay_s` ago, with noise and spoofing.
        let when = t - car.gnss_delay_s;
        let i = track.partition_point(|(tt, _)| *tt <= when).saturating_sub(1);
        let mut rep = track.get(i).map_or(pos, |x| x.1);
        let (se, sn) = (car.spoof)(t);
        let (we, wn) = (car.wander)(t);
        let (se, sn) = (se + we, sn + wn);
        let (ne, nn) = (rng.gauss() * car.gnss_noise_m + se, rng.gauss() * car.gnss_noise_m + sn);
        rep = destination(rep, 90.0, ne, EARTH_RADIUS_PAPER_M);
        rep = destination(rep, 0.0, nn, EARTH_RADIUS_PAPER_M);
        let mut signals = [Reading::Missing; Signal::COUNT];
        signals[Signal::WheelSpeed.index()] = Reading::Valid((v * car.wheel_scale) as f32);
        signals[Signal::YawRate.index()] = Reading::Valid((yaw * car.gyro_scale + car.gyro_bias_degps + (car.gyro_off)(t)) as f32);
        let (dt_s, shift_m) = match prev {
            Some((pt, pp)) => ((t - pt) as f32, Reading::Valid(haversine_m(pp, rep, EARTH_RADIUS_PAPER_M) as f32)),
            None => (0.0, Reading::Missing),
        };
        let first = prev.is_none();
        out.push(Sample {
            t,
            dt_s,
            pos: rep,
            shift_m,
            gnss_speed: Reading::Valid((v + (car.speed_off)(t)) as f32),
            gnss_course: if car.course {
                // The course is the way the car moves: behind it while it reverses.
                let back = if truth(when).0 < 0.0 { 180.0 } else { 0.0 };
                Reading::Valid((heading + back + (car.course_off)(t)).rem_euclid(360.0) as f32)
            } else {
                Reading::Missing
            },
            gnss_h_acc: Reading::from_opt(car.h_acc_m),
            receiver_spoofing: false,
            signals,
            dist_m: if first { Reading::Stale } else { Reading::Valid(dist as f32) },
            turn_deg: if first { Reading::Stale } else { Reading::Valid(turn as f32) },
            turn_abs_deg: if first { Reading::Stale } else { Reading::Valid(turn_abs as f32) },
            wheel_step_mps: 0.0,
        });
        (dist, turn, turn_abs) = (0.0, 0.0, 0.0);
        prev = Some((t, rep));
    }
    out
}

fn run(samples: &[Sample]) -> Vec<(f64, Option<TrackOutcome>)> {
    let mut c = TrackCheck::new(TrackConfig::for_profile(&LOGGER_1HZ));
    samples.iter().map(|s| (s.t, c.step(s))).collect()
}

/// The epochs at which anything of the check fired: a position window, the velocity test, or a
/// contradicted calibration (the position windows alone, before, let a velocity test's false
/// alarm pass every "stays silent" assertion here).
fn fired(o: &[(f64, Option<TrackOutcome>)]) -> Vec<f64> {
    o.iter().filter(|(_, x)| x.is_some_and(|x| x.any_fired())).map(|(t, _)| *t).collect()
}

#[test]
fn learns_the_installation_and_stays_silent() {
    let out = run(&drive(&Car::default(), 1800.0, 1));
    assert!(fired(&out).is_empty(), "fired at {:?}", fired(&out));
    let last = out.iter().rev().find_map(|(_, o)| *o).unwrap();
    assert!(!last.learning && !last.uninformative && last.heading == HeadingSource::Gyro);
    // G = s D: the DR runs 3 % long, so s = 1 / 1.03.
    assert!((last.scale - 1.0 / 1.03).abs() < 0.01, "scale {}", last.scale);
    assert!((last.delay_s - 0.5).abs() <= 0.25, "delay {}", last.delay_s);
    assert!((last.gyro_bias_degps - 0.3).abs() < 0.05, "bias {}", last.gyro_bias_degps);
    assert!((last.turn_scale - 1.0 / 1.02).abs() < 0.01, "turn scale {}", last.turn_scale);
    // Judged most of the driving after the warm-up.
    let judged = out.iter().filter(|(t, o)| *t > 300.0 && o.is_some_and(|o| o.windows[1].is_some())).count();
    assert!(judged > 800, "{judged} epochs judged");
}

#[test]
fn finds_a_drift_after_minutes_of_driving() {
    for (rate, within) in [(2.0, 30.0), (8.0, 10.0)] {
        let car = Car {
            // From 945 s: at 15 m/s on a straight (the stop of each 150 s is at 1050 s).
            spoof: if rate > 4.0 { |t: f64| (8.0 * (t - 945.0).max(0.0), 0.0) } else { |t: f64| (2.0 * (t - 945.0).max(0.0), 0.0) },
            ..Car::default()
        };
        let out = run(&drive(&car, 1045.0, 2));
        let f = fired(&out);
        assert!(f.iter().all(|t| *t >= 945.0), "{rate} m/s: fired before the onset at {:?}", f.first());
        assert!(f.first().is_some_and(|t| *t <= 945.0 + within), "{rate} m/s: first alarm {:?}", f.first());
    }
}

#[test]
fn a_jump_hidden_in_a_gnss_gap_is_found_and_a_turn_in_one_is_not() {
    // The car drives at 15 m/s from 925 to 1050 s, and turns 90 deg from 930 to 940 s (turns run
    // from 30 to 40 s of each minute). A gap on the straight: 950 to 965 s, with a 120 m jump
    // inside it. A gap across the turn: 928 to 943 s.
    let jump = Car { gaps: vec![(950.0, 965.0)], spoof: |t| if t > 957.0 { (120.0, 0.0) } else { (0.0, 0.0) }, ..Car::default() };
    let out = run(&drive(&jump, 1000.0, 3));
    let f = fired(&out);
    assert!(f.first().is_some_and(|t| (965.0..968.0).contains(t)), "first alarm {:?}", f.first());
    let turn = Car { gaps: vec![(928.0, 943.0)], ..Car::default() };
    let out = run(&drive(&turn, 1000.0, 3));
    assert!(fired(&out).is_empty(), "fired at {:?}", fired(&out));
    // The gap was bridged, not restarted: judged again right after it.
    assert!(out.iter().any(|(t, o)| (943.0..946.0).contains(t) && o.is_some_and(|o| o.windows[1].is_some())));
}

#[test]
fn the_receivers_own_accuracy_widens_the_threshold() {
    let plain = run(&drive(&Car::default(), 600.0, 4));
    let gst = run(&drive(&Car { h_acc_m: Some(10.0), ..Car::default() }, 600.0, 4));
    let thr = |o: &[(f64, Option<TrackOutcome>)]| o.iter().rev().find_map(|(_, x)| x.and_then(|x| x.windows[0])).map(|w| w.threshold_m).unwrap();
    let c = TrackConfig::for_profile(&LOGGER_1HZ).threshold();
    assert!(thr(&gst) >= c * (2.0f32 * 100.0).sqrt(), "{} with hAcc 10 m", thr(&gst));
    assert!(thr(&plain) < 0.5 * thr(&gst), "{} without", thr(&plain));
}

#[test]
fn a_check_that_cannot_tell_says_so_instead_of_alarming() {
    let car = Car { gnss_noise_m: 40.0, ..Car::default() };
    let out = run(&drive(&car, 900.0, 5));
    assert!(fired(&out).is_empty(), "fired at {:?}", fired(&out));
    let late: Vec<TrackOutcome> = out.iter().filter(|(t, _)| *t > 600.0).filter_map(|(_, o)| *o).collect();
    assert!(late.iter().all(|o| o.uninformative || o.learning), "judged with 40 m of GNSS noise");
    assert!(late.iter().any(|o| o.uninformative && o.bound_10s_mps.is_some_and(|b| b > 5.0)));
}

#[test]
fn huge_sensor_values_end_every_step() {
    // A turn of 1e30 degrees: an angle wrapped by subtracting 2 pi in a loop never ends there
    // (`x - 2 pi == x`); found by the long-horizon fuzz corpus. Every step must return.
    let mut samples = drive(&Car::default(), 120.0, 6);
    for (k, s) in samples.iter_mut().enumerate().skip(40) {
        let v = [1e30f32, -3e38, f32::MAX, 1e9][k % 4];
        s.turn_deg = Reading::Valid(v);
        s.signals[Signal::YawRate.index()] = Reading::Valid(v);
    }
    let out = run(&samples);
    assert_eq!(out.len(), samples.len());
    assert!(fired(&out).is_empty(), "hostile gyro values alone are not spoofing evidence here: {:?}", fired(&out));
}

#[test]
fn a_first_standstill_after_minutes_of_driving_agrees_with_the_bias_learnt_while_driving() {
    // Power-up at speed: the gyro's bias (0.3 deg/s) is first learnt while driving, by the
    // rotation filter; the first standstill at 600 s measures the same bias. Counting the
    // filter's part twice turned the heading by 0.3 deg/s after that stop and fired (found on
    // a css_canedge scenario replayed from mid-drive).
    let car = Car { first_stop_s: 600.0, ..Car::default() };
    let out = run(&drive(&car, 1000.0, 7));
    assert!(fired(&out).is_empty(), "fired at {:?}", fired(&out));
    let last = out.iter().rev().find_map(|(_, o)| *o).unwrap();
    assert!((last.gyro_bias_degps - 0.3).abs() < 0.05, "bias {}", last.gyro_bias_degps);
}

/// A car without a gyro at `v` m/s, one fix a second, no fix from `gap.0` to `gap.1` s, turning
/// at `turn_degps` inside the gap; from the gap's end the reported position is moved by
/// `offset` (metres along the heading at the gap's start, metres to its left).
fn no_gyro_gap(v: f64, gap: (f64, f64), turn_degps: f64, offset: (f64, f64)) -> Vec<Sample> {
    let (dt, mut t, mut heading) = (0.01, 0.0, 70.0f64);
    let mut pos = LatLon::new(52.0, 5.7);
    let (mut out, mut prev, mut dist): (Vec<Sample>, Option<(f64, LatLon)>, f64) = (Vec::new(), None, 0.0);
    let mut next_epoch = 1.0;
    let mut heading_at_gap = heading;
    while t < gap.1 + 60.0 {
        if t > gap.0 && t < gap.1 {
            heading += turn_degps * dt;
        } else if t <= gap.0 {
            heading_at_gap = heading;
        }
        pos = destination(pos, heading, v * dt, EARTH_RADIUS_PAPER_M);
        t += dt;
        dist += v * dt;
        if t + 1e-9 < next_epoch {
            continue;
        }
        next_epoch += 1.0;
        if t > gap.0 && t < gap.1 {
            continue;
        }
        let mut rep = pos;
        if t >= gap.1 {
            rep = destination(rep, heading_at_gap, offset.0, EARTH_RADIUS_PAPER_M);
            rep = destination(rep, heading_at_gap - 90.0, offset.1, EARTH_RADIUS_PAPER_M);
        }
        let mut signals = [Reading::Missing; Signal::COUNT];
        signals[Signal::WheelSpeed.index()] = Reading::Valid(v as f32);
        let first = prev.is_none();
        out.push(Sample {
            t,
            dt_s: prev.map_or(0.0, |(pt, _)| (t - pt) as f32),
            pos: rep,
            shift_m: prev.map_or(Reading::Missing, |(_, pp)| Reading::Valid(haversine_m(pp, rep, EARTH_RADIUS_PAPER_M) as f32)),
            gnss_speed: Reading::Valid(v as f32),
            gnss_course: Reading::Missing,
            gnss_h_acc: Reading::Missing,
            receiver_spoofing: false,
            signals,
            dist_m: if first { Reading::Stale } else { Reading::Valid(dist as f32) },
            turn_deg: Reading::Missing,
            turn_abs_deg: Reading::Missing,
            wheel_step_mps: 0.0,
        });
        dist = 0.0;
        prev = Some((t, rep));
    }
    out
}

#[test]
fn without_a_gyro_a_jump_hidden_in_a_gap_is_found_by_the_distance_and_a_bend_in_one_is_not() {
    // Fixes at 120 s and 130 s, none between (sddi_commuter's motorway outage: 10.5 s).
    let gap = (120.5, 129.5);
    let fired_after = |s: &[Sample]| fired(&run(s));
    // Clean, straight and through a bend at 3 m/s^2 (28 m/s, 6.1 deg/s: 64 deg in the gap).
    for turn in [0.0, 6.1, -6.1] {
        let f = fired_after(&no_gyro_gap(28.0, gap, turn, (0.0, 0.0)));
        assert!(f.is_empty(), "turning {turn} deg/s: fired at {f:?}");
    }
    // 137 m toward the rear left (a chord of 184 m across 280 m driven) and 100 m ahead: found at
    // the first fix after the gap.
    for offset in [(-113.0, 77.0), (100.0, 0.0)] {
        let f = fired_after(&no_gyro_gap(28.0, gap, 0.0, offset));
        assert!(f.first().is_some_and(|t| (gap.1..gap.1 + 1.5).contains(t)), "offset {offset:?}: fired at {f:?}");
    }
    // At 15 m/s a car can turn around in 10 s: only a chord longer than the path is a jump, so
    // 100 m back is not found by this bound (the windows, restarted, judge what follows).
    let f = fired_after(&no_gyro_gap(15.0, gap, 0.0, (-100.0, 0.0)));
    assert!(f.first().is_none_or(|t| *t > gap.1 + 1.5), "fired at {f:?}");
}

/// Across a gap the car stood through, a quiet receiver's 30 m jump is found at the first fix
/// after it; a receiver wandering by 12 m (rms, smooth over 8 to 17 s, as in town) moves its two
/// ends of the same gap by 30 m, and that is its noise, not a jump: the slack is the learnt
/// noise's where it is above the fixed one.
#[test]
fn a_gap_while_standing_is_judged_against_the_receivers_learnt_wander() {
    // The car stands from 600 to 620 s; no fix from 601.5 to 615.5 s.
    let gap = vec![(601.5, 615.5)];
    let quiet = Car { spoof: |t| if t > 615.5 { (30.0, 0.0) } else { (0.0, 0.0) }, gaps: gap.clone(), ..Car::default() };
    let f = fired(&run(&without_gyro(drive(&quiet, 700.0, 3))));
    assert!(f.first().is_some_and(|t| (615.5..617.0).contains(t)), "quiet receiver, 30 m jump: fired at {f:?}");
    let wander: fn(f64) -> (f64, f64) = |t| (10.0 * (t / 8.0 + 2.4).sin() + 6.0 * (t / 13.0).sin(), 10.0 * (t / 9.0).cos() + 6.0 * (t / 17.0 + 2.0).sin());
    let (a, b) = (wander(601.0), wander(616.0));
    assert!((a.0 - b.0).hypot(a.1 - b.1) > 29.0);
    let town = Car { wander, gaps: gap, ..Car::default() };
    let f = fired(&run(&without_gyro(drive(&town, 700.0, 3))));
    assert!(f.is_empty(), "wandering receiver: fired at {f:?}");
}

/// A car without a gyro on a straight road stops at 1050 s inside a 15 s gap, its GNSS 2.5 s
/// late: the fix before
/// the gap is where the car was 2.5 s earlier, so the chord across the gap is 37.5 m longer
/// than the wheels' distance over it (at 15 m/s), beyond the ends' fixed 25 m. The delay in use
/// takes that back; a jump of 566 m hidden in the same gap is still found.
#[test]
fn a_gap_the_car_stops_in_is_judged_at_the_gnss_delay() {
    let gaps = vec![(1040.5, 1055.5)];
    let late = Car { gnss_delay_s: 2.5, gaps: gaps.clone(), straight: true, ..Car::default() };
    let o = run(&without_gyro(drive(&late, 1100.0, 4)));
    let delay = o.iter().filter(|(t, _)| *t < 1040.5).filter_map(|(_, x)| *x).next_back().map_or(f32::NAN, |x| x.delay_s);
    assert!((2.0..=3.0).contains(&delay), "learnt delay {delay}");
    assert!(fired(&o).is_empty(), "GNSS 2.5 s late: fired at {:?}", fired(&o));
    let jump = Car { spoof: |t| if t > 1055.5 { (400.0, 400.0) } else { (0.0, 0.0) }, ..late };
    let f = fired(&run(&without_gyro(drive(&jump, 1100.0, 4))));
    assert!(f.first().is_some_and(|t| (1055.5..1057.0).contains(t)), "a jump of 566 m: fired at {f:?}");
}

/// With the vehicle signals a second late, a fix's dead reckoning is known only about a second
/// after it, so with a little jitter two fixes often become ready in the same epoch: every one
/// is judged by the velocity test, none dropped for the newer.
#[test]
fn with_the_vehicle_signals_late_every_fix_is_judged() {
    let car = Car { vehicle_delay_s: 1.0, gnss_delay_s: 0.0, fix_jitter_s: 0.05, ..Car::default() };
    let o = run(&drive(&car, 900.0, 11));
    let late = o.iter().filter(|(t, _)| *t > 400.0).filter_map(|(_, x)| *x).collect::<Vec<_>>();
    let delay = late.last().map_or(f32::NAN, |x| x.delay_s);
    assert!((-1.25..=-0.75).contains(&delay), "learnt delay {delay}");
    // Every fix after 400 s judged once (the last few are judged after the drive ends).
    let judged: usize = late.iter().filter_map(|x| x.velocity).map(|v| v.pairs as usize).sum();
    assert!(late.len() > 450, "{} epochs", late.len());
    assert!(judged + 3 >= late.len() && judged <= late.len(), "{judged} fixes judged of {}", late.len());
    assert!(fired(&o).is_empty(), "false alarm at {:?}", fired(&o));
}

/// A car without a gyro is judged by the velocity test alone: it learns at first, and once
/// calibrated it is running, not learning all drive (the old flag followed the position
/// windows, which never judge without a gyro: sddi_commuter said "learning" for whole drives).
#[test]
fn without_a_gyro_the_check_stops_learning_once_calibrated() {
    let samples = without_gyro(drive(&Car { gnss_noise_m: 2.0, ..Car::default() }, 1500.0, 5));
    let o = run(&samples);
    let outs: Vec<(f64, TrackOutcome)> = o.iter().filter_map(|(t, x)| x.map(|x| (*t, x))).collect();
    assert!(outs.first().is_some_and(|(_, x)| x.learning && !x.calibrated), "a first drive starts learning");
    let calibrated_at = outs.iter().find(|(_, x)| x.calibrated).map(|(t, _)| *t);
    assert!(calibrated_at.is_some_and(|t| t < 900.0), "calibrated at {calibrated_at:?}");
    let after: Vec<&TrackOutcome> = outs.iter().filter(|(t, _)| *t > 1000.0).map(|(_, x)| x).collect();
    let learning = after.iter().filter(|x| x.learning).count();
    assert!(after.len() > 400 && learning * 20 <= after.len(), "learning at {learning} of {} epochs once calibrated", after.len());
    assert!(after.iter().any(|x| x.velocity.is_some()), "the velocity test judges");
    // Where its noise hides drifts (this simulated receiver, 2 m of white noise per fix, in the
    // turns) it says it cannot tell.
    let blind = after.iter().filter(|x| x.velocity.is_some_and(|v| v.blind)).collect::<Vec<_>>();
    assert!(!blind.is_empty() && blind.iter().all(|x| x.uninformative && !x.learning), "{} blind pairs", blind.len());
    assert!(fired(&o).is_empty(), "false alarm at {:?}", fired(&o));
}

/// Where its noise hides slow drifts the velocity test says it cannot tell, but what it does see
/// in units of a settled noise it still reports: a spoofer's step raises the noise of a 1 Hz
/// position-only receiver (one large difference of the residual), and the blindness that
/// followed silenced a drift of 5 to 9 m/s that the test itself had found (sddi_commuter,
/// `eval`'s small-biased scenarios). (With 40 m of noise, whose estimate is still catching up,
/// nothing fires: `a_check_that_cannot_tell_says_so_instead_of_alarming`.)
#[test]
fn a_velocity_test_blind_to_slow_drifts_still_fires_on_a_fast_one() {
    let car = Car {
        gnss_noise_m: 3.0,
        first_stop_s: 2000.0,
        // 25 m/s along the road (bearing 30 deg) from 1200 s.
        spoof: |t| {
            let d = 25.0 * (t - 1200.0).max(0.0);
            (d * 0.5, d * 0.866)
        },
        ..Car::default()
    };
    let samples = without_gyro(drive(&car, 1230.0, 12));
    let o = run(&samples);
    let before: Vec<TrackOutcome> = o.iter().filter(|(t, _)| (1000.0..1200.0).contains(t)).filter_map(|(_, x)| *x).collect();
    assert!(before.iter().any(|x| x.velocity.is_some_and(|v| v.blind) && x.uninformative), "never blind before the drift");
    let f = fired(&o);
    assert!(f.first().is_some_and(|t| (1200.0..1220.0).contains(t)), "first alarm {:?}", f.first());
}

/// A 1 Hz position-only receiver's velocity is a difference of two fixes, and each fix's own
/// error (a logger stamping fixes on arrival: sddi_commuter's 0.04 s of jitter is 1.1 m at
/// 28 m/s) enters it twice with opposite signs: over one second it doubles the noise a drift
/// is measured against, over two it halves it. A drift of 6 m/s along the road against 1.5 m
/// of white noise per fix is found within 35 s (over one second: not within the 40 s run).
#[test]
fn position_differences_over_two_seconds_find_a_drift_through_white_fix_noise() {
    let car = Car {
        gnss_noise_m: 1.5,
        first_stop_s: 2000.0,
        // 6 m/s along the road (bearing 30 deg) from 1200 s.
        spoof: |t| {
            let d = 6.0 * (t - 1200.0).max(0.0);
            (d * 0.5, d * 0.866)
        },
        ..Car::default()
    };
    let samples = without_gyro(drive(&car, 1240.0, 12));
    let o = run(&samples);
    let f = fired(&o);
    assert!(f.first().is_some_and(|t| (1200.0..1235.0).contains(t)), "first alarm {:?}", f.first());
}

/// Past 2048 s of a stretch an `f32` time's step is 2.4e-4 s, so "newer than the last pair
/// judged" cannot be `t > last + 1e-4`: that judged every fix twice from then on (the second
/// time with no time between, so no acceleration, and the rotation learnt from it as if the
/// car drove straight). Every fix is judged once however long the stretch.
#[test]
fn past_2048_s_every_fix_is_judged_once() {
    let o = run(&drive(&Car { first_stop_s: 3000.0, ..Car::default() }, 2500.0, 3));
    let late = o.iter().filter(|(t, _)| *t > 2100.0).filter_map(|(_, x)| *x).collect::<Vec<_>>();
    let judged: usize = late.iter().filter_map(|x| x.velocity).map(|v| v.pairs as usize).sum();
    assert!(late.len() > 350, "{} epochs", late.len());
    assert!(judged + 3 >= late.len() && judged <= late.len(), "{judged} fixes judged of {}", late.len());
    assert!(fired(&o).is_empty(), "false alarm at {:?}", fired(&o));
}

/// A receiver that reports its velocity, its position wandering by metres over a minute (town:
/// multipath moves the position, not the Doppler velocity): the position windows take the
/// wander as the GNSS's own noise, learnt from its position against its own velocity, and stay
/// silent. A jump of the position alone still fires; a drift (position and velocity together)
/// is not excused.
#[test]
fn a_receivers_own_position_wander_is_its_noise_not_a_spoofer() {
    let wander = |t: f64| {
        let a = (t - 300.0).max(0.0) / 60.0;
        let amp = if t < 300.0 { 0.0 } else { 8.0 };
        (amp * (2.0 * std::f64::consts::PI * a).sin(), amp * (2.0 * std::f64::consts::PI * a / 1.3).cos() - amp)
    };
    let car = Car { course: true, gnss_delay_s: 0.0, wander, ..Car::default() };
    let o = run(&drive(&car, 1500.0, 11));
    let f = fired(&o);
    let max_e30 = o.iter().filter_map(|(_, x)| x.and_then(|x| x.windows[1])).map(|w| w.e_m).fold(0.0f32, f32::max);
    assert!(max_e30 > 8.0, "the wander reaches the 30 s window: {max_e30} m");
    assert!(f.is_empty(), "fired at {:?}", &f[..f.len().min(10)]);
    // The position alone jumps 100 m at 960 s, amid the wander: found within seconds. (One of
    // 40 m is not found by this check here: amid this wander the 30 s window allows it, and
    // the fast path needs both windows; strategy 1 judges jumps on its own.)
    let jumped = Car { spoof: |t| if t >= 960.0 { (70.0, 70.0) } else { (0.0, 0.0) }, ..car };
    let f = fired(&run(&drive(&jumped, 1000.0, 11)));
    assert!(f.first().is_some_and(|t| (960.0..=966.0).contains(t)), "fired at {:?}", &f[..f.len().min(10)]);
}

/// Right after a GNSS outage the velocity test's across-track noise is the one from before it
/// (the outage hid the receiver getting worse), so the receiver's course a few fixes off (6 deg,
/// then 3) reads as a precise measurement of the frame's rotation. Taken at face value it
/// turned the frame by degrees; the check then became suspicious, learning froze and the
/// across-track error stayed for the rest of the drive (css_canedge after a 10 s outage).
/// The frame takes such a course as an outlier, and still follows a frame that is really off.
#[test]
fn a_course_excursion_right_after_an_outage_does_not_turn_the_frame() {
    let off = |t: f64| if (713.0..714.0).contains(&t) { -6.0 } else if (714.0..716.0).contains(&t) { -3.0 } else { 0.0 };
    let car = Car { course: true, gnss_delay_s: 0.0, gaps: vec![(700.0, 712.0)], course_off: off, ..Car::default() };
    let o = run(&drive(&car, 900.0, 13));
    let rot = |a: f64, b: f64| o.iter().filter(|(t, _)| (a..b).contains(t)).filter_map(|(_, x)| x.map(|x| x.rotation_deg)).fold(0.0f32, |m, r| if r.abs() > m.abs() { r } else { m });
    let (before, after) = (rot(695.0, 700.0), rot(713.0, 720.0));
    assert!((after - before).abs() < 0.5, "the frame turned from {before} to {after} deg");
    assert!(fired(&o).is_empty(), "fired at {:?}", fired(&o));
    // The gyro's integral 3 deg out across the outage (0.25 deg/s more than its bias for the
    // 12 s; a gyro's noise and bias instability do not do that, a scale error in a turn in the
    // gap can): the frame follows part of it at once, the rest once the across-track evidence
    // has cleared, and nothing fires. (Before the frame's rates were a gyro's it followed all
    // 3 deg within seconds, as it did a spoofer's course step. This test's case before, a
    // receiver whose course stays 3 deg off its own positions after the outage, now fires after
    // about 100 s: no gyro drifts so, and nothing here tells such a receiver from a spoofer.)
    let err = |t: f64| if (700.0..712.0).contains(&t) { 0.25 } else { 0.0 };
    let o = run(&drive(&Car { gyro_off: err, course_off: |_| 0.0, ..car }, 900.0, 13));
    assert!(fired(&o).is_empty(), "fired at {:?}", fired(&o));
    let across = |a: f64, b: f64| o.iter().filter(|(t, _)| (a..b).contains(t)).filter_map(|(_, x)| x.and_then(|x| x.velocity).and_then(|v| v.residual_mps[1])).fold(0.0f32, |m, r| m.max(r.abs()));
    let (first, later) = (across(714.0, 720.0), across(785.0, 800.0));
    assert!(first > 0.3 && later < 0.1, "across-track residual {first} m/s after the outage, {later} m/s a minute later");
}

/// A GNSS outage bridged by the gyro through an S-bend (40 deg left and back within the gap):
/// the synchroniser gives the distance and the net turn (none here), so the DR's chord is a
/// straight line, while the car's end is metres to the side. The turning undone within the gap
/// (from the yaw rate's magnitude) widens the windows that span it; a jump hidden in a gap on
/// a straight is still found at the first fix after it
/// (`a_jump_hidden_in_a_gnss_gap_is_found_and_a_turn_in_one_is_not`).
#[test]
fn an_s_bend_in_a_gnss_gap_is_not_a_jump() {
    // 15 m/s from 925 to 1050 s, no turn of the truth's between 940 and 990 s.
    let s_bend = |t: f64| if (951.0..956.0).contains(&t) { 8.0 } else if (956.0..961.0).contains(&t) { -8.0 } else { 0.0 };
    let car = Car { gaps: vec![(950.0, 962.0)], s_bend, ..Car::default() };
    let o = run(&drive(&car, 1000.0, 3));
    let e10 = o.iter().filter(|(t, _)| (962.0..965.0).contains(t)).filter_map(|(_, x)| x.and_then(|x| x.windows[0])).map(|w| w.e_m).fold(0.0f32, f32::max);
    assert!(e10 > 15.0, "the S-bend puts the DR {e10} m off");
    assert!(fired(&o).is_empty(), "fired at {:?}", fired(&o));
}

/// A receiver of position alone and no gyro (sddi_commuter's): a drift along the road is in
/// the position differences the velocity test sums, whose error over a window is its two ends'
/// (the learnt along-track noise at the distance driven) more than a sum of per-second noises.
/// 3 m/s is found within 30 s (before: after 47 s); the clean drive stays silent.
#[test]
fn without_a_gyro_a_drift_along_the_road_is_found_from_the_position_differences() {
    let clean = run(&without_gyro(drive(&Car::default(), 1500.0, 21)));
    assert!(fired(&clean).is_empty(), "false alarm at {:?}", fired(&clean));
    // 3 m/s along the road from 1245 s: the car drives straight at 15 m/s from its left turn at
    // 1230 to 1240 s (bearing 30 - 90 deg) until the next turn at 1290 s.
    let car = Car {
        spoof: |t| {
            let d = 3.0 * (t - 1245.0).max(0.0);
            let b = 300f64.to_radians();
            (d * b.sin(), d * b.cos())
        },
        ..Car::default()
    };
    let f = fired(&run(&without_gyro(drive(&car, 1300.0, 21))));
    assert!(f.first().is_some_and(|t| (1245.0..=1275.0).contains(t)), "fired at {:?}", &f[..f.len().min(10)]);
}

/// A receiver that reports its course, a gyro, and a spoofer drifting the position across the
/// road at 0.7 m/s with the course to match (a step of 2.7 deg at 15 m/s): the DR frame's
/// rotation and the gyro's residual bias follow only as fast as a gyro's noise and bias
/// instability let them, so the step stays in the across-track residual until the velocity test
/// fires (after 26 s here). With the rates before (a rotation random walk of 0.01 deg^2/s, a
/// bias one of 1e-5 (deg/s)^2/s) the frame took a third of the step within 20 s and nothing fired
/// before the next turn (css_canedge: 1.2 deg of a 2.3 deg step in 6 s).
#[test]
fn a_drift_across_the_road_is_not_learnt_as_the_frames_rotation() {
    // From 1245 s the car drives straight at 15 m/s on bearing 300 deg until 1290 s (see
    // `without_a_gyro_a_drift_along_the_road_is_found_from_the_position_differences`).
    let step = (0.7f64 / 15.0).atan().to_degrees();
    let spoof = |t: f64| {
        let d = 0.7 * (t - 1245.0).max(0.0);
        let b = 30f64.to_radians();
        (d * b.sin(), d * b.cos())
    };
    let car = Car { course: true, gnss_delay_s: 0.0, spoof, course_off: |t| if t >= 1245.0 { (0.7f64 / 15.0).atan().to_degrees() } else { 0.0 }, ..Car::default() };
    let o = run(&drive(&car, 1290.0, 21));
    let rot = |at: f64| o.iter().filter(|(t, _)| *t <= at).filter_map(|(_, x)| x.map(|x| x.rotation_deg)).next_back().unwrap_or(f32::NAN);
    let learnt = (rot(1265.0) - rot(1245.0)).abs() as f64;
    assert!(learnt < 0.25 * step, "the frame took {learnt} deg of the {step} deg step within 20 s");
    let f = fired(&o);
    assert!(f.first().is_some_and(|t| (1245.0..=1280.0).contains(t)), "fired at {:?}", &f[..f.len().min(10)]);
}

/// A standstill measures the gyro's bias: before driving has taught the frame the bias, its
/// uncertainty grows by the driving bias's offset from the standstill's (0.1 deg/s), not by
/// the power-up half degree per second. The car stands for its first 20 s; its frame is
/// aligned within the next 30 s of driving (with the power-up uncertainty: not before the gap)
/// and a 30 s GNSS gap leaves it 4 deg uncertain (10.5 deg with the power-up uncertainty).
#[test]
fn a_standstill_bounds_what_the_frame_does_not_know_of_the_bias() {
    let car = Car { gaps: vec![(50.0, 80.0)], ..Car::default() };
    let out = run(&drive(&car, 120.0, 3));
    let aligned = out.iter().filter(|(t, _)| *t < 50.0).any(|(_, o)| o.is_some_and(|o| o.rotation_sd_deg < 2.0));
    let after = out.iter().find(|(t, _)| *t >= 81.0).and_then(|(_, o)| o.map(|o| o.rotation_sd_deg));
    assert!(aligned, "the frame aligned before the gap");
    assert!(after.is_some_and(|sd| sd < 5.0), "rotation sd after the gap {after:?}");
    assert!(fired(&out).is_empty(), "fired at {:?}", fired(&out));
}

/// A receiver that reports its velocity is judged at a crawl too (its Doppler speed holds
/// there, where a position difference's does not): a car creeping at 2 m/s in a queue while
/// the receiver reports 7 m/s more is found, and the crawl alone is not. Judged only above
/// 3 m/s before, such a spoofer went unjudged to the end of a drive (css_canedge session 1,
/// `eval`'s small-biased-46).
#[test]
fn a_receiver_reporting_speed_is_judged_at_a_crawl() {
    let crawl = Car { first_stop_s: 2000.0, course: true, crawl: Some((900.0, 1100.0)), ..Car::default() };
    let quiet = run(&drive(&crawl, 1100.0, 21));
    assert!(fired(&quiet).is_empty(), "the crawl alone: {:?}", fired(&quiet));
    let spoofed = Car { speed_off: |t| if t >= 1000.0 { 7.0 } else { 0.0 }, ..crawl };
    let o = run(&drive(&spoofed, 1100.0, 21));
    let f = fired(&o);
    assert!(f.first().is_some_and(|t| (1000.0..1010.0).contains(t)), "first alarm {:?}", f.first());
}

/// A receiver's velocity (this simulated one's is not late) at 1 Hz needs the DR's second to
/// half a second past its fix: the pair is judged at the fix's own epoch on the DR's last
/// second carried forward at its last change, not a whole epoch later (css_canedge,
/// its velocity 0.38 s late: every pair a second late, every finding too). A spoofed speed
/// 6 m/s high fires on its third fix's epoch; the clean drive stays silent.
#[test]
fn a_pair_due_just_past_the_newest_epoch_is_judged_at_it() {
    let car = Car { first_stop_s: 2000.0, course: true, ..Car::default() };
    let quiet = run(&drive(&car, 1300.0, 23));
    assert!(fired(&quiet).is_empty(), "clean: {:?}", fired(&quiet));
    let delay = quiet.last().and_then(|x| x.1).map(|x| x.delay_velocity_s);
    assert!(delay.is_some_and(|d| (-0.1..0.5).contains(&d)), "learnt velocity delay {delay:?}");
    let spoofed = Car { speed_off: |t| if t >= 1199.5 { 6.0 } else { 0.0 }, ..car };
    let o = run(&drive(&spoofed, 1300.0, 23));
    let f = fired(&o);
    assert!(f.first().is_some_and(|t| (1199.5..1202.5).contains(t)), "first alarm {:?}", f.first());
}

/// The same receiver, its position wandering by 6 m every 20 s from 330 s on, after five
/// minutes in which the windows learnt a quiet receiver: the 10 s window (which learns its noise
/// only while nothing is suspicious, so never learnt this) takes the GNSS's own noise over its
/// own 10 s too, where it exceeds the window's whole learnt noise, and stays silent (before: it
/// reached 9.5 times its noise's scale and fired at 384 s; css_canedge under GNSS noise of 4.7
/// and 6.8 m entering town, nuisance seeds 15 and 41). That noise rises only while the window is
/// within its threshold, so a spoofer's step of the position alone (its velocity left as it
/// was) buys no slack there: 42 m on a quiet receiver fires within 2 s (taken without that
/// condition, the step raised the noise it was judged against and nothing fired).
#[test]
fn a_receivers_sudden_wander_is_the_10_s_windows_noise_too() {
    let wander = |t: f64| {
        let a = (t - 330.0).max(0.0) / 20.0;
        let amp = if t < 330.0 { 0.0 } else { 6.0 };
        let w = 2.0 * std::f64::consts::PI * a;
        (amp * w.sin(), amp * (w / 1.3).cos() - amp)
    };
    let car = Car { course: true, gnss_delay_s: 0.0, wander, ..Car::default() };
    let o = run(&drive(&car, 1500.0, 11));
    let w10 = || o.iter().filter_map(|(_, x)| x.and_then(|x| x.windows[0]));
    let z10 = w10().map(|w| w.z).fold(0.0f32, f32::max);
    let e10 = w10().map(|w| w.e_m).fold(0.0f32, f32::max);
    assert!(e10 > 8.0 && z10 < 2.5, "the 10 s window's error {e10} m, z {z10}");
    assert!(fired(&o).is_empty(), "fired at {:?}", fired(&o));
    let quiet = Car { course: true, gnss_delay_s: 0.0, ..Car::default() };
    let stepped = Car { spoof: |t| if t >= 960.0 { (30.0, 30.0) } else { (0.0, 0.0) }, ..quiet };
    let f = fired(&run(&drive(&stepped, 1000.0, 11)));
    let first = f.first();
    assert!(first.is_some_and(|t| (960.0..=962.0).contains(t)), "fired at {first:?}");
}

/// A drive from the car's stored record that learns nothing of its own (the engine started
/// for a few seconds, the car never driven) writes the record's noise back as it was. The
/// windows' noise blended the receiver profile's prior in again on top of the record's (the
/// record had it already), so every such drive raised the stored noise, a quarter a time, to
/// twice the car's anchor: a car moved in and out of its garage was judged with a town's noise.
#[test]
fn a_drive_that_learns_nothing_keeps_the_records_noise() {
    let cfg = TrackConfig::for_profile(&LOGGER_1HZ);
    let mut c = TrackCheck::new(cfg);
    for s in &drive(&Car::default(), 1800.0, 1) {
        c.step(s);
    }
    let first = c.record().expect("calibrated after 30 minutes");
    let mut rec = first;
    for seed in 2..5 {
        let mut c = TrackCheck::with_record(cfg, &rec);
        // 15 s: the car stands for its first 20.
        for s in &drive(&Car { first_stop_s: 0.0, ..Car::default() }, 15.0, seed) {
            c.step(s);
        }
        rec = c.record().expect("the stored record is kept");
        assert_eq!((rec.noise_s0_m, rec.noise_k, rec.velocity_sigma_mps), (first.noise_s0_m, first.noise_k, first.velocity_sigma_mps), "after drive {seed}");
    }
}

/// A first drive learns freely for its warm-up, but not from pairs beyond the gross path's
/// bounds: a spoofer who drifts the position at 8 m/s along the road 37 s into the car's first
/// driving is found within seconds, and the delay stays the installation's while the drift
/// lasts. Before, the fits took the drift: here the delay went from -1.125 to -0.375 s within
/// ten seconds and the alarm ended after seven; on sddi_commuter (`eval`'s small-biased-56) it
/// swung from -1.5 to +3 and -3 s and nothing fired for 52 s.
#[test]
fn a_first_drives_warm_up_does_not_learn_a_gross_drift() {
    // The vehicle signals 1 s late, no gyro, a 1 Hz position-only receiver.
    let base = Car { vehicle_delay_s: 1.0, gnss_delay_s: 0.0, ..Car::default() };
    let clean = run(&without_gyro(drive(&base, 120.0, 31)));
    assert!(fired(&clean).is_empty(), "false alarm at {:?}", fired(&clean));
    // The car stands until 20 s, drives from 25 s, turns left at 30 to 40 s (bearing 30 -> 300
    // deg) and drives straight at 15 m/s until 90 s.
    let car = Car {
        spoof: |t| {
            let d = 8.0 * (t - 62.0).max(0.0);
            let b = 300f64.to_radians();
            (d * b.sin(), d * b.cos())
        },
        ..base
    };
    let o = run(&without_gyro(drive(&car, 120.0, 31)));
    let first = fired(&o).first().copied();
    assert!(first.is_some_and(|t| (62.0..=72.0).contains(&t)), "fired at {first:?}");
    for (t, x) in o.iter().filter(|(t, _)| (55.0..=90.0).contains(t)).filter_map(|(t, x)| x.map(|x| (*t, x))) {
        assert!(!x.calibrated, "still the first drive's warm-up at {t}");
        assert!((-1.5..=-0.5).contains(&x.delay_s), "delay {} s at {t} (the vehicle signals 1 s late)", x.delay_s);
    }
}

/// Out of each stop from 300 s on (the first drive's warm-up has learnt the car by then):
/// backwards at 2 m/s for 10 s, turning 35 deg left, into a standstill: 20 m, as out of a
/// parking space.
fn back_out(t: f64) -> Option<(f64, f64)> {
    let c = t % 150.0;
    if t < 300.0 || !(3.0..14.0).contains(&c) {
        return None;
    }
    let v = if c < 4.0 { -2.0 * (c - 3.0) } else if c < 13.0 { -2.0 } else { -2.0 * (14.0 - c) };
    Some((v, if (5.0..12.0).contains(&c) { 5.0 } else { 0.0 }))
}

/// A car reverses out of a parking space, and its wheel speed says 2 m/s, not which way. The
/// dead reckoning drove on along the gyro's heading, so the velocity test's along-track
/// residual was twice the speed and a car with a gyro raised the alarm four seconds into every
/// reversal. After a standstill the direction of travel is now the one the GNSS shows, within
/// a reversal's bounds (see `REVERSE_MAX_MPS`, `REVERSE_MAX_M`). A car without a gyro takes its
/// direction from the GNSS track, and never alarmed.
#[test]
fn a_car_reversing_out_of_a_stop_raises_no_alarm() {
    for course in [true, false] {
        let car = Car { course, manoeuvre: back_out, ..Car::default() };
        let samples = drive(&car, 1800.0, 31);
        let out = run(&samples);
        assert!(fired(&out).is_empty(), "course {course}: fired at {:?}", fired(&out));
        let reversing = out.iter().filter(|(_, o)| o.is_some_and(|o| o.reversing)).count();
        assert!(reversing >= 5 * 10, "course {course}: taken as reversing at {reversing} epochs of ten reversals");
        let f = fired(&run(&without_gyro(samples)));
        assert!(f.is_empty(), "course {course}, no gyro: fired at {f:?}");
    }
}

/// ... but a track going backwards faster or further than a car reverses is judged as forward
/// driving, and found: at 4 m/s; for 40 m; or 14 m at a time between standstills, as a queue's
/// crawls could be faked, beyond the 25 m a car may reverse in all before it drives on at speed.
/// A receiver of position alone is judged from 3 m/s up, so its faked crawls are found once the
/// car drives on (at 15 m/s from 495 s), by the windows that span them.
#[test]
fn a_track_going_backwards_faster_or_further_than_a_car_reverses_is_found() {
    // One manoeuvre in the stop at 450 s (the car starts off again at 15 m/s from 470 s, or
    // from `restart` where the manoeuvre holds it longer).
    let fast: fn(f64) -> Option<(f64, f64)> = |t| {
        let c = t - 450.0;
        (3.0..10.0).contains(&c).then(|| (if c < 4.0 { -4.0 * (c - 3.0) } else if c < 9.0 { -4.0 } else { -4.0 * (10.0 - c) }, 0.0))
    };
    let far: fn(f64) -> Option<(f64, f64)> = |t| {
        let c = t - 450.0;
        (2.0..30.0).contains(&c).then(|| {
            let v = if c < 3.0 { -2.0 * (c - 2.0) } else if c < 23.0 { -2.0 } else if c < 24.0 { -2.0 * (24.0 - c) } else if c < 25.0 { 0.0 } else { 3.0 * (c - 25.0) };
            (v, 0.0)
        })
    };
    let queue: fn(f64) -> Option<(f64, f64)> = |t| {
        let c = t - 450.0;
        (0.0..50.0).contains(&c).then(|| {
            let p = c % 10.0;
            let v = if c >= 45.0 { 3.0 * (c - 45.0) } else if c >= 40.0 || !(2.0..9.0).contains(&p) { 0.0 } else if p < 3.0 { -2.0 * (p - 2.0) } else if p < 8.0 { -2.0 } else { -2.0 * (9.0 - p) };
            (v, 0.0)
        })
    };
    for (name, manoeuvre, within) in [("4 m/s", fast, [10.0; 2]), ("40 m", far, [30.0; 2]), ("a queue's crawls", queue, [45.0, 70.0])] {
        for (course, within) in [true, false].into_iter().zip(within) {
            let car = Car { course, manoeuvre, ..Car::default() };
            let f = fired(&run(&drive(&car, 540.0, 32)));
            assert!(f.first().is_some_and(|t| (450.0..=450.0 + within).contains(t)), "{name}, course {course}: fired at {:?}", &f[..f.len().min(5)]);
        }
    }
}
