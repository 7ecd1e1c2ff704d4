use super::*;
use crate::geo::LatLon;

fn fix(t: f64) -> Fix {
    Fix { t, pos: LatLon::new(48.0, 11.0 + t * 1e-5), speed_mps: Some(1.0), course_deg: None, h_acc_m: None, receiver_spoofing: false }
}

fn collect(f: impl FnOnce(&mut Synchronizer, &mut dyn FnMut(&Sample))) -> heapless::Vec<Sample, 64> {
    let mut s = Synchronizer::new(SyncConfig::default());
    let mut out = heapless::Vec::new();
    f(&mut s, &mut |x: &Sample| {
        let _ = out.push(*x);
    });
    out
}

#[test]
fn interpolates_between_bracketing_observations() {
    let out = collect(|s, e| {
        let mut e = e;
        s.push_obs(Signal::WheelSpeed, 0.0, 10.0, &mut e);
        s.push_fix(fix(0.25), &mut e);
        s.push_obs(Signal::WheelSpeed, 0.5, 20.0, &mut e);
    });
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].wheel_speed(), Reading::Valid(15.0));
    assert_eq!(out[0].steering(), Reading::Missing);
    assert_eq!(out[0].shift_m, Reading::Missing);
}

/// The epochs carry the wheel speed's resolution: its smallest step between two
/// observations, not an interpolated value's (an OBD speed in whole km/h interpolated to a
/// fix between two readings is no longer a multiple of 1 km/h).
#[test]
fn the_wheel_speeds_resolution_is_its_smallest_step() {
    let kmh = 1.0 / 3.6;
    let out = collect(|s, e| {
        let mut e = e;
        // 2 Hz readings of 50, 50, 51, 53, 53 km/h; fixes between them.
        for (k, v) in [50.0f32, 50.0, 51.0, 53.0, 53.0].iter().enumerate() {
            s.push_obs(Signal::WheelSpeed, k as f64 * 0.5, v * kmh, &mut e);
            s.push_fix(fix(k as f64 * 0.5 + 0.2), &mut e);
        }
    });
    let last = out.last().map(|x| x.wheel_step_mps);
    assert!(last.is_some_and(|q| (q - kmh).abs() < 1e-4), "{last:?}");
    // Before any change it is unknown (0).
    assert_eq!(out.first().map(|x| x.wheel_step_mps), Some(0.0));
    // A fine signal's is its own step.
    let fine = collect(|s, e| {
        let mut e = e;
        for k in 0..6 {
            s.push_obs(Signal::WheelSpeed, k as f64 * 0.1, 10.0 + 0.01 * k as f32, &mut e);
        }
        s.push_fix(fix(0.25), &mut e);
    });
    assert!(fine.first().is_some_and(|x| x.wheel_step_mps > 0.0 && x.wheel_step_mps < 0.011), "{:?}", fine.first());
}

/// Across a GNSS gap the epoch carries the net turn and the turning whatever its direction:
/// an S-bend (10 deg/s left for 2 s, then right for 2 s) turns 0 deg net and 40 deg in all.
#[test]
fn the_turning_of_an_s_bend_is_kept_beside_its_net_turn() {
    let out = collect(|s, e| {
        let mut e = e;
        for k in 0..=50 {
            let t = k as f64 * 0.1;
            let yaw = if t < 0.5 { 0.0 } else if t < 2.5 { 10.0 } else if t < 4.5 { -10.0 } else { 0.0 };
            s.push_obs(Signal::YawRate, t, yaw, &mut e);
            s.push_obs(Signal::WheelSpeed, t, 10.0, &mut e);
            if k == 0 {
                s.push_fix(fix(0.0), &mut e);
            }
        }
        s.push_fix(fix(5.0), &mut e);
        s.flush(&mut e);
    });
    let last = out.last().copied().unwrap_or_default();
    let (net, all) = (last.turn_deg.get().unwrap_or(f32::NAN), last.turn_abs_deg.get().unwrap_or(f32::NAN));
    assert!(net.abs() < 1e-3 && (all - 40.0).abs() < 1.01, "net {net}, in all {all}");
    assert!(out.first().is_some_and(|x| !x.turn_abs_deg.is_valid()), "no turning before the first epoch");
}

/// The magnitude's integral wraps, its differences do not.
#[test]
fn the_turning_survives_its_integrals_wrap() {
    let out = collect(|s, e| {
        let mut e = e;
        for k in 0..=60 {
            let t = k as f64 * 0.1;
            if k % 10 == 0 {
                s.push_fix(fix(t + 0.05), &mut e);
            }
            s.push_obs(Signal::YawRate, t, 30_000.0, &mut e);
        }
        s.flush(&mut e);
    });
    let turns: heapless::Vec<f32, 8> = out.iter().skip(1).filter_map(|x| x.turn_abs_deg.get()).collect();
    assert!(turns.len() >= 4 && turns.iter().all(|a| (a - 30_000.0).abs() < 1.0), "{turns:?}");
}

#[test]
fn late_fix_uses_history() {
    let out = collect(|s, e| {
        let mut e = e;
        for k in 0..10 {
            s.push_obs(Signal::WheelSpeed, k as f64 * 0.1, k as f32, &mut e);
        }
        s.push_fix(fix(0.55), &mut e); // arrives after observations up to 0.9
    });
    assert_eq!(out.len(), 1);
    match out[0].wheel_speed() {
        Reading::Valid(v) => assert!((v - 5.5).abs() < 1e-4),
        r => panic!("{r:?}"),
    }
}

#[test]
fn gap_makes_stale_not_extrapolated() {
    let out = collect(|s, e| {
        let mut e = e;
        s.push_obs(Signal::WheelSpeed, 0.0, 10.0, &mut e);
        s.push_fix(fix(0.5), &mut e);
        s.push_fix(fix(1.5), &mut e); // clock passes 0.5 + 1.0: epoch 0.5 times out
        s.push_obs(Signal::WheelSpeed, 3.0, 10.0, &mut e); // too far after 1.5
        s.flush(&mut e);
    });
    assert_eq!(out.len(), 2);
    assert_eq!(out[0].wheel_speed(), Reading::Stale);
    assert_eq!(out[1].wheel_speed(), Reading::Stale);
    assert!((out[1].dt_s - 1.0).abs() < 1e-6);
    assert!(out[1].shift_m.is_valid());
}

#[test]
fn bad_input_is_dropped_and_counted() {
    let mut s = Synchronizer::new(SyncConfig::default());
    let mut n = 0;
    let mut e = |_: &Sample| n += 1;
    s.push_obs(Signal::Steering, f64::NAN, 1.0, &mut e);
    s.push_obs(Signal::Steering, 1.0, f32::INFINITY, &mut e);
    s.push_obs(Signal::Steering, 2.0, 1.0, &mut e);
    s.push_obs(Signal::Steering, 1.5, 1.0, &mut e);
    s.push_fix(Fix { pos: LatLon::new(f64::NAN, 0.0), ..fix(2.0) }, &mut e);
    s.push_fix(fix(2.0), &mut e);
    s.push_fix(fix(2.0), &mut e);
    let c = s.counters();
    assert_eq!((c.obs_invalid, c.obs_out_of_order, c.fixes_invalid, c.fixes_out_of_order), (2, 1, 1, 1));
    assert_eq!(n, 1);
}

#[test]
fn big_backjump_resets_and_recovers() {
    let out = collect(|s, e| {
        let mut e = e;
        s.push_obs(Signal::WheelSpeed, 100.0, 1.0, &mut e);
        s.push_fix(fix(100.0), &mut e);
        s.push_obs(Signal::WheelSpeed, 0.9, 2.0, &mut e); // this signal's clock restarts
        s.push_fix(fix(1.0), &mut e); // the receiver's too: a full reset
        s.push_obs(Signal::WheelSpeed, 1.0, 2.0, &mut e);
        s.push_fix(fix(1.1), &mut e);
        s.push_obs(Signal::WheelSpeed, 1.2, 2.0, &mut e);
    });
    assert_eq!(out.len(), 3);
    assert_eq!(out[2].wheel_speed(), Reading::Valid(2.0));
    assert_eq!(out[1].wheel_speed(), Reading::Valid(2.0), "observations after the reset are used");
    assert_eq!(out[1].shift_m, Reading::Missing, "no shift across a reset");
}

#[test]
fn overflow_emits_oldest() {
    let mut s = Synchronizer::new(SyncConfig { max_gap_s: 1e9, ..SyncConfig::default() });
    let mut n = 0;
    let mut e = |_: &Sample| n += 1;
    s.push_obs(Signal::Pedal, 0.0, 1.0, &mut e);
    for k in 1..=(PENDING as u32 + 3) {
        s.push_fix(fix(k as f64), &mut e);
    }
    assert_eq!(n, 3);
    assert_eq!(s.counters().overflow_emits, 3);
}
