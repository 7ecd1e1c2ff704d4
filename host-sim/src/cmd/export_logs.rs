//! `export-logs`: a comma2k19 segment re-expressed as the logs of one's own car.

use super::outln;
use host_sim::input::{self, InputError};
use host_sim::output;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The segment folder (with processed_log/).
    segment: PathBuf,
    #[arg(short, long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let logs = input::logs::comma2k19_as_logs(&a.segment)?;
    std::fs::create_dir_all(&a.out).map_err(|e| InputError::file(&a.out, format!("cannot create: {e}")))?;
    outln!("clock: UTC = segment time + {:.3} s (the first u-blox fix's UTC time)", logs.offset_s);
    for (name, bytes, what) in [
        ("can.log", logs.candump.as_bytes(), "candump lines"),
        ("can.asc", logs.asc.as_bytes(), "ASC lines"),
        ("gnss.nmea", logs.nmea.as_bytes(), "NMEA lines"),
        ("gnss.ubx", &logs.ubx[..], "bytes of UBX"),
    ] {
        let p = a.out.join(name);
        output::write_atomic(&p, |w| w.write_all(bytes)).map_err(|e| InputError::file(&p, format!("cannot write: {e}")))?;
        let n = if name.ends_with(".ubx") { bytes.len() } else { bytes.iter().filter(|b| **b == b'\n').count() };
        outln!("wrote {} ({n} {what})", p.display());
    }
    Ok(())
}
