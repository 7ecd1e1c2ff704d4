//! `calibrate`: the kinematic predictor's error and GNSS speeds at standstill on clean drives.

use super::{expand, outln, LoadArgs};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(required = true)]
    paths: Vec<PathBuf>,
    #[command(flatten)]
    load: LoadArgs,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let files = expand(&a.paths)?;
    let st = host_sim::calibrate::run(&files, &a.load.options(), a.load.sync())?;
    outln!("{}", serde_json::to_string_pretty(&st)?);
    Ok(())
}
