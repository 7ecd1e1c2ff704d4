//! `lstm-bench`: the LSTM's streaming step timed on this host, kernel by kernel.

use super::{data_or_default, load_drives, outln};
use host_sim::{bench, eval};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long)]
    data: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let dir = data_or_default(a.data);
    let drives = load_drives(&dir.join("drives"))?;
    let runs = eval::validation_runs(&drives);
    anyhow::ensure!(!runs.is_empty(), "no validation drives in {}", dir.display());
    let t = bench::lstm_kernels(&runs);
    outln!("validation steps timed: {} (one core, best of 3 passes)", t.steps);
    outln!("streaming step, f32 reference kernel:            {:.2} us", t.us_ref);
    outln!("streaming step, integer kernel, portable dot:    {:.2} us", t.us_portable);
    outln!("streaming step, integer kernel, optimised dot:   {:.2} us ({:?})", t.us_fast, gnss_guard_dsp::kernel());
    outln!("optimised vs portable integer outputs: {} of {} steps differ", t.differ, t.steps);
    anyhow::ensure!(t.differ == 0, "the optimised integer kernel differs from the portable one");
    #[cfg(feature = "train")]
    outln!("burn batch forward [50 x 32] per observation: {:.2} us (paper: 0.691 us on a dual Xeon)", bench::burn_batch_us(&runs));
    #[cfg(not(feature = "train"))]
    outln!("burn batch forward: not in this build (cargo build -p host-sim --features train)");
    let (int8, f32b) = bench::model_bytes();
    outln!("model blob: {int8} bytes int8, {f32b} bytes f32");
    Ok(())
}
