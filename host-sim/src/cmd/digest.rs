//! `digest`: the QEMU image's input through the same board pipeline on the host.

use super::{data_or_default, outln};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long)]
    data: Option<PathBuf>,
    /// Also write the input (what the QEMU image embeds) to this file.
    #[arg(long)]
    export: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let dir = data_or_default(a.data);
    let (bytes, desc) = host_sim::qemu_input::generate(&dir)?;
    if let Some(p) = a.export {
        host_sim::output::write_atomic(&p, |w| w.write_all(&bytes))?;
    }
    outln!("input: {desc}");
    let (lines, pass) = host_sim::qemu_input::run_all(&bytes);
    for l in lines {
        outln!("{l}");
    }
    if !pass {
        anyhow::bail!("a scenario failed");
    }
    Ok(())
}
