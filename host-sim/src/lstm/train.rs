//! Training the paper's LSTM with burn (feature `train`), and exporting it as the core's blob.

use super::runs::{kinematic_errors, lstm_errors, split, stats, stream_predict, ErrStats, Run, TrainOptions};
use crate::dataset::Drive;
use burn::module::Module;
use burn::nn::{Linear, LinearConfig, Lstm, LstmConfig};
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use detector_core::strategy::location_shift::lstm::{BlobSpec, LstmModel, LstmPredictor, WeightKind, N_IN};
use serde::Serialize;

#[derive(Module, Debug)]
pub struct Net {
    l1: Lstm,
    l2: Lstm,
    out: Linear,
}

impl Net {
    pub fn new(h1: usize, h2: usize, device: &Device) -> Self {
        Net {
            l1: LstmConfig::new(N_IN, h1, true).init(device),
            l2: LstmConfig::new(h1, h2, true).init(device),
            out: LinearConfig::new(h2, 1).init(device),
        }
    }
    /// `[batch, time, 4]` normalised inputs to `[batch, time, 1]` normalised outputs, from zero state.
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let (a, _) = self.l1.forward(x, None);
        let (b, _) = self.l2.forward(a, None);
        self.out.forward(b)
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct TrainReport {
    pub train_drives: Vec<String>,
    pub val_drives: Vec<String>,
    pub skipped_drives: Vec<String>,
    pub train_steps: usize,
    pub train_windows: usize,
    pub val_steps: usize,
    pub hidden: [usize; 2],
    pub window: usize,
    pub epochs_run: usize,
    pub best_epoch: usize,
    pub best_val_mae_norm: f64,
    /// (epoch, train MAE, validation MAE), normalised units.
    pub history: Vec<(usize, f64, f64)>,
    pub in_min: [f32; N_IN],
    pub in_max: [f32; N_IN],
    pub out_min: f32,
    pub out_max: f32,
    /// Streaming f32 step of the core on the exported blob, per profile `[10 Hz, 1 Hz]`.
    pub lstm: [ErrStats; 2],
    /// The kinematic predictor on the same epochs.
    pub kinematic: [ErrStats; 2],
    /// Largest |burn batch forward - core streaming step| over the validation runs, m/s.
    pub streaming_vs_batch_max_diff_mps: f64,
    pub train_seconds: f64,
    pub blob_bytes_int8: usize,
    pub blob_bytes_f32: usize,
}

/// A tiny deterministic PRNG for shuffling (splitmix64).
struct Mix(u64);
impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

fn norm(v: f32, lo: f32, hi: f32) -> f32 {
    (v - lo) / (hi - lo)
}

fn to_vec(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_to_vec::<f32>().expect("f32 tensor")
}

/// Weights of one LSTM layer as the blob's rows `[i; f; g; o] x [input | hidden]`, and biases.
fn lstm_rows(l: &Lstm, d_in: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
    let gates = [&l.input_gate, l.forget_gate.as_ref().expect("forget gate"), &l.cell_gate, &l.output_gate];
    let cols = d_in + h;
    let mut w = vec![0.0f32; 4 * h * cols];
    let mut b = vec![0.0f32; 4 * h];
    for (g, gate) in gates.iter().enumerate() {
        // Row layout: weight is [d_in, d_out], y = x W + b.
        let wi = to_vec(gate.input_transform.weight.val());
        let wh = to_vec(gate.hidden_transform.weight.val());
        let bi = gate.input_transform.bias.as_ref().map(|p| p.val().into_data().try_to_vec::<f32>().expect("f32")).unwrap_or(vec![0.0; h]);
        let bh = gate.hidden_transform.bias.as_ref().map(|p| p.val().into_data().try_to_vec::<f32>().expect("f32")).unwrap_or(vec![0.0; h]);
        for k in 0..h {
            let r = g * h + k;
            for j in 0..d_in {
                w[r * cols + j] = wi[j * h + k];
            }
            for j in 0..h {
                w[r * cols + d_in + j] = wh[j * h + k];
            }
            b[r] = bi[k] + bh[k];
        }
    }
    (w, b)
}

pub struct Ranges {
    pub in_min: [f32; N_IN],
    pub in_max: [f32; N_IN],
    pub out_min: f32,
    pub out_max: f32,
}

/// Exports the net as a blob of `kind`, with the given threshold terms.
pub fn export(net: &Net, h1: usize, h2: usize, r: &Ranges, max_err_m: [f32; 2], rmse_m: [f32; 2], kind: WeightKind) -> Vec<u8> {
    let (w1, b1) = lstm_rows(&net.l1, N_IN, h1);
    let (w2, b2) = lstm_rows(&net.l2, h1, h2);
    let wd = to_vec(net.out.weight.val()); // [h2, 1]
    let bd = net.out.bias.as_ref().map(|p| p.val().into_data().try_to_vec::<f32>().expect("f32")).unwrap_or(vec![0.0]);
    let spec = BlobSpec {
        kind,
        h1,
        h2,
        in_min: r.in_min,
        in_max: r.in_max,
        out_min: r.out_min,
        out_max: r.out_max,
        max_err_m,
        rmse_m,
        layers: [(&w1, &b1), (&w2, &b2), (&wd, &bd)],
    };
    let mut out = vec![0u8; spec.byte_len()];
    assert!(spec.write(&mut out), "blob shapes");
    out
}

fn batch_tensor(rows: &[&[[f32; N_IN]]], r: &Ranges, device: &Device) -> Tensor<3> {
    let t = rows[0].len();
    let mut v = Vec::with_capacity(rows.len() * t * N_IN);
    for row in rows {
        for x in row.iter() {
            for (i, xi) in x.iter().enumerate() {
                v.push(norm(*xi, r.in_min[i], r.in_max[i]));
            }
        }
    }
    Tensor::from_data(TensorData::new(v, [rows.len(), t, N_IN]), device)
}

/// The net's batch forward over a whole run, de-normalised to m/s.
pub fn batch_predict(net: &Net, run: &Run, r: &Ranges, device: &Device) -> Vec<f32> {
    let y = net.forward(batch_tensor(&[&run.x], r, device));
    y.into_data().try_to_vec::<f32>().expect("f32").into_iter().map(|v| r.out_min + v * (r.out_max - r.out_min)).collect()
}

/// Trains, validates and exports `(int8 blob, f32 blob, report)`.
pub fn train(drives: &[Drive], o: &TrainOptions, progress: &dyn Fn(usize, f64, f64)) -> anyhow::Result<(Vec<u8>, Vec<u8>, TrainReport)> {
    let start = std::time::Instant::now();
    let (train_runs, val_runs, skipped) = split(drives, o);
    let names = |rs: &[Run]| {
        let mut v: Vec<String> = rs.iter().map(|r| r.drive.clone()).collect();
        v.dedup();
        v
    };
    anyhow::ensure!(!train_runs.is_empty(), "no training drive has wheel speed, pedal, steering (or yaw) and GNSS");
    for class in 0..2 {
        anyhow::ensure!(
            val_runs.iter().any(|r| r.class == class),
            "no validation epochs for the {} profile: pass a validation drive of that rate",
            ["10 Hz", "1 Hz"][class]
        );
    }
    // Min-max ranges from the training set.
    let mut r = Ranges { in_min: [f32::INFINITY; N_IN], in_max: [f32::NEG_INFINITY; N_IN], out_min: f32::INFINITY, out_max: f32::NEG_INFINITY };
    for run in &train_runs {
        for (x, y) in run.x.iter().zip(&run.y) {
            for (i, xi) in x.iter().enumerate() {
                r.in_min[i] = r.in_min[i].min(*xi);
                r.in_max[i] = r.in_max[i].max(*xi);
            }
            r.out_min = r.out_min.min(*y);
            r.out_max = r.out_max.max(*y);
        }
    }
    for i in 0..N_IN {
        if r.in_max[i] <= r.in_min[i] {
            r.in_max[i] = r.in_min[i] + 1.0;
        }
    }
    if r.out_max <= r.out_min {
        r.out_max = r.out_min + 1.0;
    }
    // Windows of `window` steps from zero state (runs shorter than that are one window each
    // in a batch of their own length).
    let mut windows: Vec<(usize, usize, usize)> = vec![];
    for (ri, run) in train_runs.iter().enumerate() {
        let n = run.x.len();
        if n >= o.window {
            windows.extend((0..=n - o.window).map(|s| (ri, s, o.window)));
        }
    }
    anyhow::ensure!(!windows.is_empty(), "no training run is {} epochs long", o.window);

    let device = Device::default().autodiff();
    device.seed(o.seed);
    let mut net = Net::new(o.h1, o.h2, &device);
    let mut optim = AdamConfig::new().init();
    let valid_device = Device::default();
    let mut rng = Mix(o.seed);
    let (mut best, mut best_epoch, mut best_net) = (f64::INFINITY, 0, net.valid());
    let mut history = vec![];
    let val_steps: usize = val_runs.iter().map(|r| r.x.len()).sum();
    for epoch in 1..=o.max_epochs {
        for i in (1..windows.len()).rev() {
            windows.swap(i, (rng.next() % (i as u64 + 1)) as usize);
        }
        let mut train_loss = 0.0;
        let mut batches = 0;
        for chunk in windows.chunks(o.batch) {
            let xs: Vec<&[[f32; N_IN]]> = chunk.iter().map(|&(ri, s, l)| &train_runs[ri].x[s..s + l]).collect();
            let mut ys = Vec::with_capacity(chunk.len() * o.window);
            for &(ri, s, l) in chunk {
                ys.extend(train_runs[ri].y[s..s + l].iter().map(|v| norm(*v, r.out_min, r.out_max)));
            }
            let x = batch_tensor(&xs, &r, &device);
            let y: Tensor<3> = Tensor::from_data(TensorData::new(ys, [chunk.len(), o.window, 1]), &device);
            let loss = (net.forward(x) - y).abs().mean();
            train_loss += loss.clone().into_scalar::<f32>() as f64;
            batches += 1;
            let grads = GradientsParams::from_grads(loss.backward(), &net);
            net = optim.step(o.lr, net, grads);
        }
        let v = net.valid();
        let mut abs_sum = 0.0;
        for run in &val_runs {
            let p = batch_predict(&v, run, &r, &valid_device);
            abs_sum += p.iter().zip(&run.y).map(|(a, b)| ((a - b) / (r.out_max - r.out_min)).abs() as f64).sum::<f64>();
        }
        let val_mae = abs_sum / val_steps as f64;
        let tl = train_loss / batches as f64;
        history.push((epoch, tl, val_mae));
        progress(epoch, tl, val_mae);
        if val_mae < best {
            (best, best_epoch, best_net) = (val_mae, epoch, v);
        } else if epoch - best_epoch >= o.patience {
            break;
        }
    }
    let net = best_net;
    // Threshold terms from the core's own streaming step on the f32 export.
    let probe = export(&net, o.h1, o.h2, &r, [0.0; 2], [0.0; 2], WeightKind::F32);
    let lstm = stats(&lstm_errors(&mut LstmPredictor::reference(LstmModel::parse(&probe).expect("own blob")), &val_runs));
    let kinematic = stats(&kinematic_errors(&val_runs, drives));
    let max_err = [lstm[0].max_abs_m as f32, lstm[1].max_abs_m as f32];
    let rmse = [lstm[0].rmse_m as f32, lstm[1].rmse_m as f32];
    let f32_blob = export(&net, o.h1, o.h2, &r, max_err, rmse, WeightKind::F32);
    let int_blob = export(&net, o.h1, o.h2, &r, max_err, rmse, WeightKind::I8);
    // Streaming (core f32 step) == batch (burn forward over the whole run).
    let mut p = LstmPredictor::reference(LstmModel::parse(&f32_blob).expect("own blob"));
    let mut diff = 0.0f64;
    for run in &val_runs {
        let a = batch_predict(&net, run, &r, &valid_device);
        let b = stream_predict(&mut p, run);
        diff = a.iter().zip(&b).fold(diff, |d, (x, y)| d.max((x - y).abs() as f64));
    }
    let report = TrainReport {
        train_drives: names(&train_runs),
        val_drives: names(&val_runs),
        skipped_drives: skipped,
        train_steps: train_runs.iter().map(|r| r.x.len()).sum(),
        train_windows: windows.len(),
        val_steps,
        hidden: [o.h1, o.h2],
        window: o.window,
        epochs_run: history.len(),
        best_epoch,
        best_val_mae_norm: best,
        history,
        in_min: r.in_min,
        in_max: r.in_max,
        out_min: r.out_min,
        out_max: r.out_max,
        lstm,
        kinematic,
        streaming_vs_batch_max_diff_mps: diff,
        train_seconds: start.elapsed().as_secs_f64(),
        blob_bytes_int8: int_blob.len(),
        blob_bytes_f32: f32_blob.len(),
    };
    Ok((int_blob, f32_blob, report))
}
