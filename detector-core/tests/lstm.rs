//! The LSTM predictor's kernels and blob: the integer kernel against the f32 reference (the
//! CMSIS-NN / TFLite Micro parity pattern), blob validation, and the streaming predictor's
//! handling of missing inputs.

use detector_core::sample::Sample;
use detector_core::strategy::location_shift::ShiftPredictor;
use detector_core::strategy::location_shift::lstm::*;

/// A small deterministic model (weights from a fixed LCG) as both blob kinds.
fn test_blobs(h1: usize, h2: usize) -> (Vec<u8>, Vec<u8>) {
    use Vec;
    let mut seed = 0x1234_5678u32;
    let mut rnd = |scale: f32| {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 2.0 * scale
    };
    let mut mk = |r: usize, c: usize| -> (Vec<f32>, Vec<f32>) {
        ((0..r * c).map(|_| rnd(0.15)).collect(), (0..r).map(|_| rnd(0.1)).collect())
    };
    let l1 = mk(4 * h1, N_IN + h1);
    let l2 = mk(4 * h2, h1 + h2);
    let d = mk(1, h2);
    let mk_blob = |kind| {
        let spec = BlobSpec {
            kind, h1, h2,
            in_min: [0.0, 0.0, -300.0, 0.0], in_max: [40.0, 100.0, 300.0, 40.0],
            out_min: 0.0, out_max: 40.0, max_err_m: [0.5, 3.0], rmse_m: [0.1, 1.0],
            layers: [(&l1.0, &l1.1), (&l2.0, &l2.1), (&d.0, &d.1)],
        };
        let mut b = vec![0u8; spec.byte_len()];
        assert!(spec.write(&mut b));
        b
    };
    (mk_blob(WeightKind::F32), mk_blob(WeightKind::I8))
}

fn inputs(k: usize) -> [f32; N_IN] {
    let t = k as f32 * 0.37;
    [15.0 + 5.0 * libm::sinf(t), 30.0 + 25.0 * libm::sinf(1.3 * t), 90.0 * libm::sinf(0.7 * t), 15.0 + 5.0 * libm::cosf(t)]
}

#[test]
fn int_kernel_matches_reference_on_same_weights() {
    for (h1, h2) in [(8, 4), (MAX_H1, MAX_H2)] {
        let (_, q) = test_blobs(h1, h2);
        let m = LstmModel::parse(&q).unwrap();
        let mut a = LstmPredictor::int(m).unwrap();
        let mut b = LstmPredictor::reference(m);
        let mut worst = 0.0f32;
        for k in 0..300 {
            let (ya, yb) = (a.step_raw(inputs(k)), b.step_raw(inputs(k)));
            worst = worst.max((ya - yb).abs());
        }
        // Output range 40 m/s: the integer path stays within 0.5 % of it.
        assert!(worst < 0.2, "h {h1}/{h2}: max |int - ref| {worst} m/s");
    }
}

/// The optimised dot-product kernel of this build (AVX2 here, the DSP extension on the
/// Cortex-M4, where the QEMU run checks the same) against the reference, bit for bit: layer
/// sizes that leave every kind of tail (columns not a multiple of 4 or 16, an odd number of
/// rows), the paper's 128/64, and the deployed model.
#[test]
fn optimised_and_portable_dot_products_give_identical_outputs() {
    let check = |q: &[u8], what: &str| {
        let m = LstmModel::parse(q).unwrap();
        let mut a = LstmPredictor::int(m).unwrap();
        let mut b = LstmPredictor::int_portable(m).unwrap();
        for k in 0..300 {
            let (ya, yb) = (a.step_raw(inputs(k)), b.step_raw(inputs(k)));
            assert_eq!(ya.to_bits(), yb.to_bits(), "{what}, step {k}: {ya} vs {yb}");
        }
    };
    for (h1, h2) in [(1, 1), (3, 5), (7, 2), (8, 4), (13, 9), (29, 31), (MAX_H1, MAX_H2)] {
        check(&test_blobs(h1, h2).1, &format!("random weights h {h1}/{h2}"));
    }
    check(DEFAULT_MODEL, "the deployed model");
    if gnss_guard_dsp::kernel() == gnss_guard_dsp::Kernel::Portable {
        eprintln!("note: this host has no AVX2, so the optimised kernel here is the reference itself");
    }
}

#[test]
fn f32_and_int8_blobs_agree_and_reset_restarts() {
    let (f, q) = test_blobs(16, 8);
    let (mf, mq) = (LstmModel::parse(&f).unwrap(), LstmModel::parse(&q).unwrap());
    assert_eq!((mf.kind, mq.kind), (WeightKind::F32, WeightKind::I8));
    assert_eq!(LstmPredictor::int(mf).unwrap_err(), LstmError::NotQuantized);
    let mut a = LstmPredictor::reference(mf);
    let mut b = LstmPredictor::int(mq).unwrap();
    let first: Vec<f32> = (0..20).map(|k| a.step_raw(inputs(k))).collect();
    for (k, y) in first.iter().enumerate() {
        assert!((y - b.step_raw(inputs(k))).abs() < 0.5);
    }
    ShiftPredictor::reset(&mut a);
    for (k, y) in first.iter().enumerate() {
        assert_eq!(*y, a.step_raw(inputs(k)), "after reset the run repeats exactly");
    }
}

#[test]
fn bad_blobs_are_refused() {
    let (_, q) = test_blobs(8, 4);
    assert!(LstmModel::parse(&q).is_ok());
    assert_eq!(LstmModel::parse(&q[..10]), Err(LstmError::TooShort));
    let mut b = q.clone();
    b[0] = b'X';
    assert_eq!(LstmModel::parse(&b), Err(LstmError::BadMagic));
    let mut b = q.clone();
    b[4] = 9;
    assert_eq!(LstmModel::parse(&b), Err(LstmError::BadVersion));
    let mut b = q.clone();
    b[6] = 7;
    assert_eq!(LstmModel::parse(&b), Err(LstmError::BadKind));
    let mut b = q.clone();
    b[8] = 200;
    assert_eq!(LstmModel::parse(&b), Err(LstmError::BadShape));
    assert_eq!(LstmModel::parse(&q[..q.len() - 1]), Err(LstmError::BadLength));
    let mut b = q.clone();
    let mid = b.len() / 2;
    b[mid] ^= 1;
    assert_eq!(LstmModel::parse(&b), Err(LstmError::BadCrc));
    let mut b = q.clone();
    b[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    assert_eq!(LstmModel::parse(&b), Err(LstmError::BadRange));
    // Every truncation and every single-byte corruption is refused or parses; never a panic.
    for n in 0..q.len() {
        let _ = LstmModel::parse(&q[..n]);
    }
}

#[test]
fn predictor_runs_on_samples_and_breaks_runs_on_missing_inputs() {
    use detector_core::sample::{Reading, Signal};
    let (_, q) = test_blobs(8, 4);
    let mut p = LstmPredictor::int(LstmModel::parse(&q).unwrap()).unwrap();
    let mut s = Sample { dt_s: 1.0, ..Default::default() };
    s.signals[Signal::WheelSpeed.index()] = Reading::Valid(10.0);
    s.signals[Signal::Pedal.index()] = Reading::Valid(20.0);
    s.signals[Signal::Steering.index()] = Reading::Valid(0.0);
    assert_eq!(p.predict(&s), None, "no previous shift yet");
    s.shift_m = Reading::Valid(10.0);
    assert_eq!(p.predict(&s), None, "the previous epoch had no shift");
    let y = p.predict(&s).unwrap();
    assert!(y.is_finite() && y >= 0.0);
    s.signals[Signal::Pedal.index()] = Reading::Stale;
    assert_eq!(p.predict(&s), None);
    s.signals[Signal::Pedal.index()] = Reading::Valid(20.0);
    s.signals[Signal::Steering.index()] = Reading::Missing;
    assert_eq!(p.predict(&s), None, "no steering and no yaw rate");
    s.signals[Signal::YawRate.index()] = Reading::Valid(3.0);
    assert!(p.predict(&s).is_some(), "steering from the yaw-rate proxy");
    for dt in [f32::NAN, -1.0, 0.0, 10.0] {
        s.dt_s = dt;
        assert_eq!(p.predict(&s), None);
    }
    s.dt_s = 1.0;
    s.signals[Signal::WheelSpeed.index()] = Reading::Valid(f32::INFINITY);
    assert_eq!(p.predict(&s), None);
}
