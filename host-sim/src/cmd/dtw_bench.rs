//! `dtw-bench`: the turn classifier timed on the held-out turns, and its inputs exported for
//! `tests/bench/dtw_vs_fastdtw.sh`.

use super::{data_or_default, load_drives, outln};
use host_sim::bench;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long)]
    data: Option<PathBuf>,
    /// JSON with the templates and queries, for the Python comparison.
    #[arg(long)]
    export: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let dir = data_or_default(a.data);
    let mut drives = load_drives(&dir.join("drives"))?;
    drives.extend(host_sim::turns::sim_drives());
    let b = bench::dtw(&drives);
    host_sim::output::write_atomic(&a.export, |w| serde_json::to_writer(w, &serde_json::json!({
        "band": b.band, "templates": b.templates, "queries": b.queries.iter().map(|q| q.to_vec()).collect::<Vec<_>>(), "rust_us_per_query": b.us_per_query,
    })).map_err(std::io::Error::other))?;
    outln!("queries {} templates {} (checksum {:.1})", b.queries.len(), b.templates.len(), b.checksum);
    outln!("rust_us_per_query: {:.2}", b.us_per_query);
    Ok(())
}
