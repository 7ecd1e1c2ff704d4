//! Strategy 1's LSTM on the real drives: the trainer's split, streaming == batch, the committed
//! model's threshold terms and its int8 fidelity. Needs the `train` feature (burn).

#![cfg(feature = "train")]

use burn::tensor::Device;
use detector_core::strategy::location_shift::lstm::{LstmModel, LstmPredictor, WeightKind};
use host_sim::dataset::Drive;
use host_sim::input::{self, LoadOptions};
use host_sim::lstm::{self, Net, TrainOptions};
use detector_core::sync::SyncConfig;

fn drives(d: &std::path::Path) -> Vec<Drive> {
    input::discover(&d.join("drives"))
        .unwrap()
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "csv"))
        .map(|f| Drive::new(input::load(f, &LoadOptions::default()).unwrap(), SyncConfig::default()))
        .collect()
}

#[test]
fn split_is_by_drive_and_covers_both_receiver_rates() {
    let Some(d) = host_sim::require_data("split_is_by_drive_and_covers_both_receiver_rates") else { return };
    let ds = drives(&d);
    let (train, val, _) = lstm::split(&ds, &TrainOptions::default());
    let names = |rs: &[lstm::Run]| rs.iter().map(|r| r.drive.clone()).collect::<std::collections::BTreeSet<_>>();
    assert!(names(&train).is_disjoint(&names(&val)), "a drive is in both sets");
    assert!(val.iter().any(|r| r.class == 0) && val.iter().any(|r| r.class == 1), "validation at 10 Hz and 1 Hz");
    assert!(train.iter().map(|r| r.x.len()).sum::<usize>() > 2000);
    // Every step's target is its own epoch's shift per second, its first input the previous one's.
    for r in &train {
        for j in 1..r.x.len() {
            assert_eq!(r.x[j][0], r.y[j - 1], "{}: step {j}", r.drive);
        }
    }
}

/// The core's streaming step (state carried, one epoch at a time) gives what burn's batch
/// forward over the whole run gives, on real drives, for any weights.
#[test]
fn streaming_step_equals_batch_forward_on_real_drives() {
    let Some(d) = host_sim::require_data("streaming_step_equals_batch_forward_on_real_drives") else { return };
    let ds = drives(&d);
    let (_, val, _) = lstm::split(&ds, &TrainOptions::default());
    let device = Device::default();
    device.seed(7);
    let net = Net::new(16, 8, &device);
    let r = lstm::Ranges { in_min: [0.0, 0.0, -400.0, 0.0], in_max: [30.0, 100.0, 400.0, 30.0], out_min: 0.0, out_max: 30.0 };
    let blob = lstm::export(&net, 16, 8, &r, [1.0; 2], [0.5; 2], WeightKind::F32);
    let mut p = LstmPredictor::reference(LstmModel::parse(&blob).unwrap());
    let mut worst = 0.0f32;
    let mut n = 0;
    for run in val.iter().filter(|r| r.x.len() > 100) {
        let a = lstm::batch_predict(&net, run, &r, &device);
        let b = lstm::stream_predict(&mut p, run);
        assert_eq!(a.len(), b.len());
        n += a.len();
        worst = a.iter().zip(&b).fold(worst, |w, (x, y)| w.max((x - y).abs()));
    }
    assert!(n > 1000, "{n} steps compared");
    assert!(worst < 1e-4, "max |batch - streaming| {worst} m/s");
}

/// The committed model: its threshold terms are the maximum validation errors of its f32 twin,
/// and the int8 integer kernel stays within 2 % of strategy 1's threshold of it on every
/// validation epoch.
#[test]
fn committed_model_thresholds_and_int8_fidelity() {
    let Some(d) = host_sim::require_data("committed_model_thresholds_and_int8_fidelity") else { return };
    let ds = drives(&d);
    let runs = host_sim::eval::validation_runs(&ds);
    let (q, f) = (host_sim::detect::default_lstm(), host_sim::detect::default_lstm_f32());
    assert_eq!((q.kind, f.kind, q.h1, q.h2), (WeightKind::I8, WeightKind::F32, 128, 64));
    assert_eq!((q.max_err_m, q.rmse_m), (f.max_err_m, f.rmse_m));
    let ef = lstm::stats(&lstm::lstm_errors(&mut LstmPredictor::reference(f), &runs));
    for (c, e) in ef.iter().enumerate() {
        assert!((e.max_abs_m as f32 - f.max_err_m[c]).abs() < 1e-4, "profile {c}: {} vs header {}", e.max_abs_m, f.max_err_m[c]);
    }
    let ei = lstm::lstm_errors(&mut LstmPredictor::int(q).unwrap(), &runs);
    let er = lstm::lstm_errors(&mut LstmPredictor::reference(f), &runs);
    let profiles = [&detector_core::profile::UBLOX_10HZ, &detector_core::profile::LOGGER_1HZ];
    let mut worst = 0.0f64;
    for c in 0..2 {
        let th = (q.max_err_m[c] + profiles[c].gnss_error_m) as f64;
        for (a, b) in ei[c].iter().zip(&er[c]) {
            worst = worst.max((a - b).abs() / th);
        }
    }
    assert!(worst <= 0.02, "max |int - f32| is {:.2} % of the threshold", worst * 100.0);
}

/// `host-sim train lstm` end to end with a tiny model: three files, a valid blob of each kind.
#[test]
fn train_lstm_cli_writes_valid_blobs() {
    let Some(d) = host_sim::require_data("train_lstm_cli_writes_valid_blobs") else { return };
    let dir = std::env::temp_dir().join(format!("gnss-guard-lstm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("tiny.bin");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["train", "lstm", "--data", d.to_str().unwrap(), "--hidden", "8,4", "--epochs", "2", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let q = std::fs::read(&out).unwrap();
    let f = std::fs::read(dir.join("tiny.f32.bin")).unwrap();
    let (mq, mf) = (LstmModel::parse(&q).unwrap(), LstmModel::parse(&f).unwrap());
    assert_eq!((mq.kind, mq.h1, mq.h2, mf.kind), (WeightKind::I8, 8, 4, WeightKind::F32));
    let rep: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("tiny.train.json")).unwrap()).unwrap();
    assert_eq!(rep["epochs_run"], 2);
    assert!(rep["streaming_vs_batch_max_diff_mps"].as_f64().unwrap() < 1e-4);
    for k in ["lstm", "kinematic"] {
        for c in 0..2 {
            assert!(rep[k][c]["max_abs_m"].as_f64().unwrap() > 0.0 && rep[k][c]["epochs"].as_u64().unwrap() > 100, "{k}[{c}]");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
