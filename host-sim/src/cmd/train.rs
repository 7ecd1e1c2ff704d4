//! `train`: strategy 2's turn templates, or strategy 1's LSTM (with the `train` feature).

use super::{data_or_default, load_drives, outln};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(value_parser = ["turns", "lstm"])]
    what: String,
    #[arg(long)]
    data: Option<PathBuf>,
    #[arg(long)]
    out: PathBuf,
    #[arg(long)]
    seed: Option<u64>,
    /// lstm: units of the two layers.
    #[arg(long, value_delimiter = ',', default_values_t = [128usize, 64])]
    hidden: Vec<usize>,
    /// lstm: most epochs (early stopping on validation MAE ends sooner).
    #[arg(long, default_value_t = 500)]
    epochs: usize,
    /// lstm: epochs without a better validation MAE before stopping.
    #[arg(long, default_value_t = 25)]
    patience: usize,
    /// lstm: training window, GNSS epochs.
    #[arg(long, default_value_t = 32)]
    window: usize,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.what == "lstm" {
        return train_lstm(a);
    }
    let seed = a.seed.unwrap_or(1);
    let dir = data_or_default(a.data);
    let mut drives = load_drives(&dir.join("drives"))?;
    drives.extend(host_sim::turns::sim_drives());
    let (blob, rep, _) = host_sim::turns::train_and_evaluate(&drives, seed);
    host_sim::output::write_atomic(&a.out, |w| w.write_all(&blob))?;
    outln!("{}", serde_json::to_string_pretty(&rep)?);
    eprintln!("wrote {} ({} templates, {} bytes)", a.out.display(), rep.templates, blob.len());
    Ok(())
}

/// `train lstm`: burn, only with the `train` feature.
#[cfg(feature = "train")]
fn train_lstm(a: Args) -> anyhow::Result<()> {
    let dir = data_or_default(a.data);
    let drives = load_drives(&dir.join("drives"))?;
    anyhow::ensure!(a.hidden.len() == 2, "--hidden takes two sizes, e.g. 128,64");
    let d = host_sim::lstm::TrainOptions::default();
    let o = host_sim::lstm::TrainOptions { h1: a.hidden[0], h2: a.hidden[1], max_epochs: a.epochs, patience: a.patience, window: a.window, seed: a.seed.unwrap_or(d.seed), ..d };
    let (int_blob, f32_blob, rep) = host_sim::lstm::train(&drives, &o, &|e, t, v| eprintln!("epoch {e:4}  train MAE {t:.5}  validation MAE {v:.5}"))?;
    let out = a.out;
    let f32_path = out.with_extension("f32.bin");
    host_sim::output::write_atomic(&out, |w| w.write_all(&int_blob))?;
    host_sim::output::write_atomic(&f32_path, |w| w.write_all(&f32_blob))?;
    let json = serde_json::to_string_pretty(&rep)?;
    host_sim::output::write_atomic(&out.with_extension("train.json"), |w| w.write_all(json.as_bytes()))?;
    outln!("{json}");
    eprintln!("wrote {} ({} bytes, int8) and {} ({} bytes, f32)", out.display(), int_blob.len(), f32_path.display(), f32_blob.len());
    Ok(())
}

#[cfg(not(feature = "train"))]
fn train_lstm(_: Args) -> anyhow::Result<()> {
    anyhow::bail!("this build has no LSTM training: build host-sim with `--features train` (burn), e.g. `cargo run --release -p host-sim --features train -- train lstm ...`")
}
