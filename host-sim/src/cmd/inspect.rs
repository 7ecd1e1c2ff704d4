//! `inspect`: what each drive holds.

use super::{expand, outln, LoadArgs};
use host_sim::{input, inspect, replay};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Drive files or folders (searched recursively).
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
    let files = expand(&a.paths)?;
    // Load everything first: a bad file fails the run before anything is printed.
    let mut all = Vec::new();
    for f in &files {
        let r = input::load(f, &opts)?;
        let (samples, _) = replay::synchronize(&r, a.load.sync());
        all.push(inspect::stats(&r, &samples, a.load.sync().earth_radius_m));
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
