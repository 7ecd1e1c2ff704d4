//! `inspect`: what each drive holds, and what a car's calibration record (`detect
//! --calibration FILE`) keeps.

use super::{expand, outln, LoadArgs};
use detector_core::wire::calibration::{Record, MAGIC};
use host_sim::input::InputError;
use host_sim::{input, inspect, replay};
use std::io::Read;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Drive files or folders (searched recursively), or a car's calibration record (the file
    /// `detect --calibration` keeps: its fields and the car's anchors).
    #[arg(required = true)]
    paths: Vec<PathBuf>,
    /// One JSON object per drive and line.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    load: LoadArgs,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let opts = a.load.options();
    let (records, drives): (Vec<PathBuf>, Vec<PathBuf>) = a.paths.iter().cloned().partition(|p| is_record(p));
    // Every record is read before anything is printed, as every drive is.
    let records = records.iter().map(|p| read_record(p).map(|(r, v)| (p, r, v))).collect::<anyhow::Result<Vec<_>>>()?;
    let files = if drives.is_empty() { Vec::new() } else { expand(&drives)? };
    // Load everything first: a bad file fails the run before anything is printed.
    let mut all = Vec::new();
    for f in &files {
        let r = input::load(f, &opts)?;
        let (samples, _) = replay::synchronize(&r, a.load.sync());
        all.push(inspect::stats(&r, &samples, a.load.sync().earth_radius_m));
    }
    for (p, r, version) in &records {
        if a.json {
            let mut j = host_sim::detect::record_json(r);
            j["path"] = p.display().to_string().into();
            j["version"] = (*version).into();
            outln!("{}", serde_json::to_string(&j)?);
        } else {
            outln!("{}: calibration record, version {version}", p.display());
            for l in host_sim::detect::record_text(r) {
                outln!("  {l}");
            }
        }
    }
    for s in &all {
        if a.json {
            outln!("{}", serde_json::to_string(s)?);
        } else {
            print_stats(s);
        }
    }
    Ok(())
}

/// A file whose first bytes are a calibration record's magic.
fn is_record(p: &Path) -> bool {
    let mut m = [0u8; 4];
    p.is_file() && std::fs::File::open(p).and_then(|mut f| f.read_exact(&mut m)).is_ok() && &m == MAGIC
}

/// The record in `p` and its version, or where and why it is refused.
fn read_record(p: &Path) -> anyhow::Result<(Record, u16)> {
    let b = std::fs::read(p)?;
    let r = Record::decode(&b).map_err(|e| InputError::file(p, format!("calibration record: byte {}: expected {}", e.offset(), e.expected())))?;
    Ok((r, u16::from_le_bytes([b[4], b[5]])))
}

fn print_stats(s: &inspect::DriveStats) {
    outln!("{}", s.path);
    outln!("  format {}  epochs {}  duration {:.1} s  GNSS {:.2} Hz  distance {:.0} m", s.format, s.epochs, s.duration_s, s.gnss_hz, s.distance_m);
    let sig: Vec<String> = s.signals.iter().map(|(k, v)| format!("{k} {:.0}%", v * 100.0)).collect();
    outln!("  fix interval {:.3} s, stamps' jitter {:.3} s (sd of the intervals within 30 % of it)", s.fix_interval_s, s.fix_jitter_s);
    outln!("  valid: {}", sig.join(", "));
    outln!("  stops {}  turns left {} right {}", s.stops, s.turns_left, s.turns_right);
    if s.skipped_rows > 0 {
        outln!("  skipped bad rows: {}", s.skipped_rows);
    }
    for n in &s.notes {
        outln!("  note: {n}");
    }
}
