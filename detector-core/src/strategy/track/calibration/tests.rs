use super::*;

/// Velocity pairs of a car whose GNSS speed is `true_scale` times its wheel speed,
/// straight north.
fn feed(c: &mut Calibration, true_scale: f32, secs: usize) {
    for _ in 0..secs {
        let d = [(0.0f32, 15.0f32); DELAYS];
        c.learn(Source::Velocity, (0.0, 15.0 * true_scale), &d, (1.0, 0.0), 1.0, 0.15, 5.0);
        c.learn_own(Source::Velocity, (0.0, 15.0 * true_scale), &d, (1.0, 0.0), 1.0, 0.15, 5.0);
    }
}

fn record() -> Record {
    Record {
        scale: 0.99,
        delay_s: [-0.75, -0.5],
        learnt_s: 3600.0,
        drives: 4,
        gyro_bias_degps: f32::NAN,
        gyro_bias_weight_s: 0.0,
        gyro_scale_error: 0.0,
        gyro_scale_sd: 0.05,
        noise_s0_m: [1.0; 2],
        noise_k: [0.01; 2],
        velocity_sigma_mps: [0.2; 2],
        nominal_dt_s: 1.0,
        anchor_scale: 0.99,
        anchor_delay_s: [-0.75, -0.5],
        anchor_gyro_scale_error: 0.0,
        anchor_noise_s0_m: [1.0; 2],
        anchor_noise_k: [0.01; 2],
        anchor_velocity_sigma_mps: [0.2; 2],
    }
}

#[test]
fn a_first_drive_learns_freely_then_only_within_rate() {
    let mut c = Calibration::new(CalLimits::default());
    feed(&mut c, 1.03, 100);
    // Free: only the prior's pull (2 s against 100 s) is left.
    assert!(!c.calibrated() && (c.scale() - 1.03).abs() < 2e-3, "scale {}", c.scale());
    feed(&mut c, 1.03, 30);
    assert!(c.calibrated());
    // A spoofer's 2 % more: one minute moves the scale by at most its own uncertainty.
    let sd = c.scale_sd(0.15, 5.0);
    assert!(sd < 0.003, "sd {sd}");
    feed(&mut c, 1.03 * 1.02, 60);
    assert!(c.scale() - 1.03 <= 1.03 * sd * 1.01, "scale {} sd {sd}", c.scale());
}

#[test]
fn a_first_drives_first_slow_pairs_do_not_make_the_scale() {
    let mut c = Calibration::new(CalLimits::default());
    // Three seconds at 2 m/s whose GNSS says half the wheel speed (a standing start, the
    // delay not yet found): the fit alone says 0.5.
    for _ in 0..3 {
        c.learn(Source::Velocity, (0.0, 1.0), &[(0.0, 2.0); DELAYS], (1.0, 0.0), 1.0, 0.15, 5.0);
    }
    assert!(c.scale() > 0.98, "scale {}", c.scale());
    // Nothing physical is half as fast as its wheels say: the scale stays within bounds.
    feed(&mut c, 0.5, 100);
    assert_eq!(c.scale(), SCALE_MIN);
}

#[test]
fn a_stored_record_bounds_the_drive_and_is_contradicted_not_relearnt() {
    let rec = record();
    let mut c = Calibration::from_record(CalLimits::default(), &rec);
    assert!(c.calibrated() && c.delay_s(Source::Position) == -0.75 && c.delay_s(Source::Velocity) == -0.5 && c.scale() == 0.99);
    // The same car: nothing contradicted.
    feed(&mut c, 0.991, 600);
    assert_eq!(c.contradiction(), None);
    assert_eq!(c.record_base().1, [-0.75, -0.5]);
    // Another tyre (+3 %) from the start of a drive: held at the bound, and reported.
    let mut c = Calibration::from_record(CalLimits::default(), &rec);
    feed(&mut c, 0.99 * 1.03, 600);
    assert!(c.scale() <= 0.99 * 1.01 + 1e-6, "scale {}", c.scale());
    assert_eq!(c.contradiction(), Some(Contradiction::Scale));
}

/// The record a drive leaves for the next one, as the track check writes it: none when the
/// drive contradicted its record (the stored one stays).
fn next(c: &Calibration, r: &Record) -> Option<Record> {
    let (scale, delay_s, learnt_s) = c.record_base();
    let (anchor_scale, anchor_delay_s) = c.anchors();
    c.contradiction().is_none().then_some(Record { scale, delay_s, learnt_s, drives: r.drives + 1, anchor_scale, anchor_delay_s, ..*r })
}

/// Drive after drive, a spoofer asks 0.8 % more of the scale than the record holds, within
/// the bound of one drive: the car's anchor stops the walk at its allowance and the drive
/// that asks beyond it is reported. The same car honestly (its scale wobbling by 0.2 %
/// from drive to drive) is never reported in 50 drives, and its anchor never moves.
#[test]
fn a_spoofer_on_every_drive_cannot_walk_the_record() {
    let lim = CalLimits::default();
    let mut rec = record();
    let mut reported = None;
    for drive in 0..10 {
        let mut c = Calibration::from_record(lim, &rec);
        feed(&mut c, rec.scale * 1.008, 1800);
        let top = rec.anchor_scale * (1.0 + c.walk_allowance(&rec));
        assert!(c.scale() <= top + 1e-6, "drive {drive}: scale {} beyond {top}", c.scale());
        match next(&c, &rec) {
            Some(r) => rec = r,
            None => {
                reported = Some(drive);
                break;
            }
        }
    }
    // 0.99 -> 0.998 -> 1.006 asked: the second drive asks beyond 1 % of the anchor.
    assert_eq!(reported, Some(1), "record {rec:?}");
    assert!(rec.scale <= 0.99 * 1.0101 && rec.anchor_scale == 0.99, "record {rec:?}");

    let mut rec = record();
    for drive in 0..50 {
        let mut c = Calibration::from_record(lim, &rec);
        feed(&mut c, 0.99 * (1.0 + 0.002 * ((drive % 3) as f32 - 1.0)), 1800);
        rec = next(&c, &rec).unwrap_or_else(|| panic!("drive {drive} contradicted {rec:?}"));
        assert_eq!((rec.anchor_scale, rec.anchor_delay_s), (0.99, [-0.75, -0.5]));
    }
    assert_eq!(rec.drives, 54);
}

/// The delay too: a record whose delay has walked a bound from the car's anchor keeps the
/// next drive within the anchor's bound, and a drive whose delay is beyond it is reported.
#[test]
fn a_delay_walked_from_the_anchor_is_bounded_by_it() {
    let mut rec = record();
    rec.delay_s[1] = 0.5;
    let mut c = Calibration::from_record(CalLimits::default(), &rec);
    // Twenty minutes of accelerations whose velocity is 1.5 s late: the record's bound
    // (+-1 s around 0.5 s) would allow 1.5 s, the anchor's (-0.5 +- 1 s) 0.5 s at most.
    // Slow ones (a minute's period): the scale's own fit at the stored delay stays within
    // its bound, so the delay is what is reported.
    let v = |t: f32| 15.0 + 5.0 * libm::sinf(core::f32::consts::TAU * t / 60.0);
    for s in 0..1200 {
        let t = s as f32;
        let mut d = [(0.0f32, 0.0f32); DELAYS];
        for (k, x) in d.iter_mut().enumerate() {
            *x = (0.0, v(t - delay_of(k) + 1.5) / 0.99);
        }
        c.learn(Source::Velocity, (0.0, v(t)), &d, (1.0, 0.0), 1.0, 0.15, 5.0);
        c.learn_own(Source::Velocity, (0.0, v(t)), &d, (1.0, 0.0), 1.0, 0.15, 5.0);
    }
    assert_eq!(c.free_delay_s(Source::Velocity), 1.5);
    assert!(c.delay_s(Source::Velocity) <= 0.5, "delay {}", c.delay_s(Source::Velocity));
    assert_eq!(c.contradiction(), Some(Contradiction::Delay));
}

/// A drive from a stored record takes the delay its own fits choose within the bound at
/// once during its first warm-up of learning (a logger's latency differs from boot to boot),
/// and never beyond the bound.
#[test]
fn a_drive_from_a_record_finds_its_own_delay_within_the_bound_at_first() {
    let mut rec = record();
    rec.delay_s[1] = -0.5;
    rec.anchor_delay_s[1] = -0.5;
    let lim = CalLimits::default();
    let mut c = Calibration::from_record(lim, &rec);
    let v = |t: f32| 15.0 + 5.0 * libm::sinf(core::f32::consts::TAU * t / 20.0);
    let feed = |c: &mut Calibration, from: usize, secs: usize, late: f32| {
        for s in from..from + secs {
            let t = s as f32;
            let mut d = [(0.0f32, 0.0f32); DELAYS];
            for (k, x) in d.iter_mut().enumerate() {
                *x = (0.0, v(t - delay_of(k) + late) / 0.99);
            }
            c.learn(Source::Velocity, (0.0, v(t)), &d, (1.0, 0.0), 1.0, 0.15, 5.0);
        }
    };
    // The GNSS velocity 0.25 s late this drive: 0.75 s (six candidates) from the record's,
    // within its bound; one candidate per dwell would take three minutes. Ten seconds of
    // it are judged with it, not yet kept: the record keeps its own until the warm-up.
    feed(&mut c, 0, 10, 0.25);
    assert_eq!((c.delay_s(Source::Velocity), c.record_base().1[1]), (0.25, -0.5));
    feed(&mut c, 10, lim.warmup_s as usize - 10, 0.25);
    assert_eq!((c.delay_s(Source::Velocity), c.record_base().1[1]), (0.25, -0.5));
    feed(&mut c, lim.warmup_s as usize, 1, 0.25);
    assert_eq!((c.delay_s(Source::Velocity), c.record_base().1[1]), (0.25, 0.25));
    // And never beyond the bound: 1.5 s from the record is held at 1 s from it.
    let mut c = Calibration::from_record(lim, &rec);
    feed(&mut c, 0, lim.warmup_s as usize, 1.0);
    assert_eq!((c.free_delay_s(Source::Velocity), c.delay_s(Source::Velocity)), (1.0, 0.5));
}

#[test]
fn the_delays_uncertainty_is_what_the_accelerations_resolve() {
    // Five minutes of a car speeding up and braking (15 +- 5 m/s over 20 s, up to
    // 1.6 m/s^2) whose wheels are 0.5 s late, and five at a constant 15 m/s.
    let v = |t: f32| 15.0 + 5.0 * libm::sinf(core::f32::consts::TAU * t / 20.0);
    let (mut moving, mut steady) = (Calibration::new(CalLimits::default()), Calibration::new(CalLimits::default()));
    for s in 0..300 {
        let t = s as f32;
        let mut d = [(0.0f32, 0.0f32); DELAYS];
        for (k, x) in d.iter_mut().enumerate() {
            *x = (0.0, v(t - delay_of(k) - 0.5));
        }
        moving.learn(Source::Velocity, (0.0, v(t)), &d, (1.0, 0.0), 1.0, 0.15, 5.0);
        steady.learn(Source::Velocity, (0.0, 15.0), &[(0.0, 15.0); DELAYS], (1.0, 0.0), 1.0, 0.15, 5.0);
    }
    assert_eq!(moving.delay_s(Source::Velocity), -0.5);
    // The fits resolve it to well under the floor: the floor.
    assert_eq!(moving.delay_sd_s(Source::Velocity, 0.15, 5.0), 0.1);
    // Without accelerations nothing resolves it: the minutes' 0.5 sqrt(2 / 5) s.
    let sd = steady.delay_sd_s(Source::Velocity, 0.15, 5.0);
    assert!((sd - 0.316).abs() < 0.001, "sd {sd}");
    // A first drive's first two minutes: 0.5 s.
    let mut young = Calibration::new(CalLimits::default());
    young.learn(Source::Velocity, (0.0, 15.0), &[(0.0, 15.0); DELAYS], (1.0, 0.0), 100.0, 0.15, 5.0);
    assert_eq!(young.delay_sd_s(Source::Velocity, 0.15, 5.0), 0.5);
}

#[test]
fn delays_are_candidates_of_either_sign() {
    assert_eq!(delay_of(0), -3.0);
    assert_eq!(delay_of(ZERO), 0.0);
    assert_eq!(delay_of(DELAYS - 1), 3.0);
    assert_eq!(candidate(-0.8), 18);
    assert_eq!(candidate(f32::NAN), ZERO);
    assert_eq!(candidate(1e30), DELAYS - 1);
    let mut r = record();
    assert!(r.plausible().is_ok());
    r.delay_s[1] = f32::NAN;
    assert!(r.plausible().is_ok());
    r.delay_s[0] = f32::NAN;
    assert_eq!(r.plausible(), Err("a position delay within 3 s"));
}
