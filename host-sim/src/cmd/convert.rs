//! `convert`: one drive, in any format a command reads (the research layouts, one's own car's
//! logs), written in the common layout as CSV or Parquet: how a data lake of drives is made.

use super::{DriveSource, LoadArgs};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    source: DriveSource,
    /// Where to write the drive: Parquet when it ends in `.parquet`, else CSV.
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    load: LoadArgs,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let r = a.source.load(&a.load)?;
    host_sim::output::write_atomic(&a.out, |w| super::write_drive(&a.out, &r, None, w))?;
    let fixes = r.fixes().count();
    eprintln!("wrote {}: {} events, {fixes} fixes, from {} ({})", a.out.display(), r.events.len(), r.path.display(), r.format.name());
    Ok(())
}
