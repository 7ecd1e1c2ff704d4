//! Benchmarks the command line runs: strategy 2's classifier (and the queries and templates
//! for the Python fastdtw comparison), and the LSTM kernels on this host.

use crate::dataset::Drive;
use crate::detect;
use crate::lstm::Run;
use detector_core::strategy::location_shift::lstm::{LstmPredictor, DEFAULT_MODEL, N_IN};

/// Strategy 2's classifier on the held-out turns of `drives`.
pub struct DtwBench {
    pub queries: Vec<[f32; 32]>,
    pub templates: Vec<Vec<f32>>,
    pub band: usize,
    pub us_per_query: f64,
    pub checksum: f32,
}

/// Times the pruned k-NN (k = 1) over the held-out turns, 200 repetitions.
pub fn dtw(drives: &[Drive]) -> DtwBench {
    let q: Vec<[f32; 32]> = drives
        .iter()
        .enumerate()
        .filter(|(i, _)| crate::turns::held_out(drives, *i))
        .flat_map(|(_, d)| crate::turns::collect(d))
        .map(|t| t.query)
        .collect();
    let set = detect::default_templates();
    let templates: Vec<Vec<f32>> = (0..set.len()).map(|i| set.get(i).2.to_vec()).collect();
    let reps = 200;
    let t0 = std::time::Instant::now();
    let mut checksum = 0.0f32;
    for _ in 0..reps {
        for x in &q {
            checksum += detector_core::strategy::turn::classify(&set, x, 1).map_or(0.0, |n| n.distance);
        }
    }
    let us_per_query = t0.elapsed().as_secs_f64() * 1e6 / (reps * q.len().max(1)) as f64;
    DtwBench { queries: q, templates, band: set.band(), us_per_query, checksum }
}

/// The LSTM's streaming step on the validation inputs, microseconds per step: the integer
/// kernel, the f32 reference.
pub fn lstm_kernels(runs: &[Run]) -> LstmTimes {
    let xs: Vec<[f32; N_IN]> = runs.iter().flat_map(|r| r.x.iter().copied()).collect();
    // Best of three passes over the validation steps (the first also warms the caches).
    let time_stream = |step: &mut dyn FnMut([f32; N_IN]) -> f32| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t0 = std::time::Instant::now();
            let mut sink = 0.0;
            for x in &xs {
                sink += step(*x);
            }
            std::hint::black_box(sink);
            best = best.min(t0.elapsed().as_secs_f64() * 1e6 / xs.len().max(1) as f64);
        }
        best
    };
    let mut fast = LstmPredictor::int(detect::default_lstm()).expect("int8");
    let mut portable = LstmPredictor::int_portable(detect::default_lstm()).expect("int8");
    // The two integer kernels agree bit for bit on every validation step (also a test).
    let differ = xs.iter().filter(|x| fast.step_raw(**x).to_bits() != portable.step_raw(**x).to_bits()).count();
    let (mut fast, mut portable) = (LstmPredictor::int(detect::default_lstm()).expect("int8"), LstmPredictor::int_portable(detect::default_lstm()).expect("int8"));
    let us_fast = time_stream(&mut |x| fast.step_raw(x));
    let us_portable = time_stream(&mut |x| portable.step_raw(x));
    let mut f = LstmPredictor::reference(detect::default_lstm_f32());
    let us_ref = time_stream(&mut |x| f.step_raw(x));
    LstmTimes { steps: xs.len(), us_fast, us_portable, us_ref, differ }
}

/// [`lstm_kernels`]' result: microseconds per streaming step, best of three passes.
pub struct LstmTimes {
    pub steps: usize,
    /// The integer kernel on this machine's optimised dot product (AVX2 where present).
    pub us_fast: f64,
    /// The integer kernel on the portable reference dot product.
    pub us_portable: f64,
    /// The f32 reference kernel.
    pub us_ref: f64,
    /// Validation steps where the optimised and portable integer kernels differ (must be 0).
    pub differ: usize,
}

/// burn's batch forward per observation, [50 x 32] batches of the 128/64 net (the timing does
/// not depend on the weights). Only with the `train` feature.
#[cfg(feature = "train")]
pub fn burn_batch_us(runs: &[Run]) -> f64 {
    let xs: Vec<[f32; N_IN]> = runs.iter().flat_map(|r| r.x.iter().copied()).collect();
    let device = burn::tensor::Device::default();
    let net = crate::lstm::Net::new(128, 64, &device);
    let (b, t) = (50usize, 32usize);
    let data: Vec<f32> = xs.iter().cycle().take(b * t).flat_map(|x| x.map(|v| v / 30.0)).collect();
    let input: burn::tensor::Tensor<3> = burn::tensor::Tensor::from_data(burn::tensor::TensorData::new(data, [b, t, 4]), &device);
    let reps = 20;
    let _ = net.forward(input.clone()).into_data();
    let t0 = std::time::Instant::now();
    for _ in 0..reps {
        let _ = net.forward(input.clone()).into_data();
    }
    t0.elapsed().as_secs_f64() * 1e6 / (reps * b * t) as f64
}

/// The model blobs' sizes: int8 (deployed) and f32.
pub fn model_bytes() -> (usize, usize) {
    (DEFAULT_MODEL.len(), detect::DEFAULT_MODEL_F32.len())
}
