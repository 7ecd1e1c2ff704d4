//! `demo`: the main job: the evaluation on the real drives if present, else on simulated ones.

use super::eval::run_eval;
use super::{data_or_default, load_drives, outln};
use detector_core::sync::SyncConfig;
use host_sim::dataset::Drive;
use host_sim::{detect, eval, sim};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long)]
    data: Option<PathBuf>,
    #[arg(long, default_value = "out/demo")]
    out: PathBuf,
    #[arg(long, default_value_t = 10)]
    scenarios: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let dir = data_or_default(a.data);
    if dir.join("drives").is_dir() {
        outln!("demo: using the REAL drives in {}", dir.display());
        let drives = load_drives(&dir.join("drives"))?;
        run_eval(drives, "real", &dir, eval::Protocol::LeaveOneSourceOut, 5, a.scenarios, a.seed, detect::PredictorKind::Lstm, &a.out).map(drop)
    } else {
        outln!("demo: {} not found: using two SIMULATED drives (10 Hz and 1 Hz receivers; seed {})", dir.display(), a.seed);
        let drives = sim::demo_drives(a.seed).into_iter().map(|r| Drive::new(r, SyncConfig::default())).collect();
        run_eval(drives, "simulated", &dir, eval::Protocol::LeaveOneSourceOut, 5, a.scenarios, a.seed, detect::PredictorKind::Lstm, &a.out).map(drop)
    }
}
