//! `detect`: the detector over one drive, verdicts and status as text or JSON lines.

use super::{DriveSource, LoadArgs};
use host_sim::detect;
use host_sim::input::InputError;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    source: DriveSource,
    /// JSON lines: one per epoch, {"status": ...} once a second (the firmware's status frame),
    /// then {"summary": ..., "status": ..., "status_seconds": ..., "digest": ...} (the verdict
    /// digest that `host-sim digest` and the QEMU run compute, over this run's verdicts).
    #[arg(long)]
    json: bool,
    /// Receiver profile (default: from the drive's fix rate).
    #[arg(long, value_parser = ["ublox-10hz", "logger-1hz"])]
    profile: Option<String>,
    /// Strategy 1's predictor (default: the LSTM, whose model is built in).
    #[arg(long, value_enum, default_value = "lstm")]
    predictor: detect::PredictorKind,
    /// The car's calibration record (the board keeps the same bytes in flash): read at the
    /// start when the file exists (the drive starts calibrated), written at the end when the
    /// drive left the car calibrated; kept as it is when the drive contradicts it.
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// Also write the per-epoch verdicts as a Parquet table (an Arrow table: time, alarm, fired,
    /// reasons, each strategy's numbers; see host-sim/src/verdict_table.rs).
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    load: LoadArgs,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let r = a.source.load(&a.load)?;
    let profile = a.profile.as_deref().and_then(detect::receiver_profile);
    let stored = match &a.calibration {
        Some(f) => detect::read_calibration(f),
        None => None,
    };
    let d = detect::detect_replay(&r, &detect::DetectOptions { profile, predictor: a.predictor, sync: a.load.sync(), stored: stored.as_ref() });
    let (verdicts, learnt) = (d.verdicts, d.learnt);
    let cal_outcome = match &a.calibration {
        Some(f) => Some(detect::write_calibration(f, stored.as_ref(), learnt.as_ref(), &verdicts)?),
        None => None,
    };
    if let Some(o) = &a.out {
        let mut buf = Vec::new();
        host_sim::verdict_table::write_parquet(&verdicts, &mut buf)?;
        host_sim::output::write_atomic(o, |w| w.write_all(&buf)).map_err(|e| InputError::file(o, format!("cannot write: {e}")))?;
    }
    let summary = d.summary;
    let status = detect::status_lines(&verdicts, stored.is_some());
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    // Verdicts and, once a second of drive time, the device's status, in time order.
    let mut next_status = status.iter().peekable();
    for v in &verdicts {
        if a.json {
            while let Some((_, s)) = next_status.next_if(|(t, _)| *t < v.t) {
                writeln!(out, "{}", serde_json::json!({ "status": s }))?;
            }
            writeln!(out, "{}", detect::verdict_json(v))?;
        } else {
            writeln!(out, "{}", detect::verdict_line(v))?;
        }
    }
    let last_status = status.last().map(|(_, s)| s.clone());
    if a.json {
        for (_, s) in next_status {
            writeln!(out, "{}", serde_json::json!({ "status": s }))?;
        }
        writeln!(out, "{}", serde_json::json!({ "summary": summary, "status": last_status, "status_seconds": detect::state_seconds(&status), "digest": d.digest, "calibration": cal_outcome }))?;
    } else {
        writeln!(out, "verdict digest: {}", d.digest)?;
        writeln!(out, "summary: {}", serde_json::to_string_pretty(&summary)?)?;
        writeln!(out, "status at the end: {}", last_status.map_or("none".into(), |s| s.to_string()))?;
        writeln!(out, "status seconds per state: {:?}", detect::state_seconds(&status))?;
        if let Some(c) = &cal_outcome {
            writeln!(out, "calibration: {}", c["said"].as_str().unwrap_or(""))?;
        }
    }
    Ok(())
}
