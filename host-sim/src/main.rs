use clap::{Parser, Subcommand, ValueEnum};
use detector_core::sync::SyncConfig;
use host_sim::input::{self, hdd::HddUnits, InputError, LoadOptions};
use host_sim::{detect, inspect, replay};
use std::path::PathBuf;
use std::process::ExitCode;

/// GNSS spoofing detector: host tools over real drives.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Clone, Copy, ValueEnum)]
enum SpeedUnit {
    Kmh,
    Mps,
}

#[derive(Clone, Copy, ValueEnum)]
enum SteerSign {
    Left,
    Right,
}

#[derive(clap::Args, Clone)]
struct LoadArgs {
    /// Count and drop malformed rows instead of failing.
    #[arg(long)]
    skip_bad_rows: bool,
    /// Unit of `speed` in HDD `vel.csv`.
    #[arg(long, value_enum, default_value = "kmh")]
    hdd_speed_unit: SpeedUnit,
    /// Direction that is positive in HDD `steer.csv`.
    #[arg(long, value_enum, default_value = "left")]
    hdd_steer_positive: SteerSign,
    /// Largest gap, seconds, between an epoch and the observations it is interpolated from.
    #[arg(long, default_value_t = SyncConfig::default().max_gap_s)]
    max_gap: f64,
}

impl LoadArgs {
    fn options(&self) -> LoadOptions {
        LoadOptions {
            skip_bad_rows: self.skip_bad_rows,
            hdd: HddUnits {
                speed_scale: match self.hdd_speed_unit { SpeedUnit::Kmh => 1.0 / 3.6, SpeedUnit::Mps => 1.0 },
                steer_sign: match self.hdd_steer_positive { SteerSign::Left => 1.0, SteerSign::Right => -1.0 },
            },
        }
    }
    fn sync(&self) -> SyncConfig {
        SyncConfig { max_gap_s: self.max_gap, ..SyncConfig::default() }
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Summarise drives: format, epochs, duration, GNSS rate, distance, signal validity, stops, turns.
    Inspect {
        /// Drive files or folders (searched recursively).
        #[arg(required = true)]
        paths: Vec<PathBuf>,
        /// One JSON object per drive and line.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Run the detector over one drive: per-epoch verdicts, then a summary.
    Detect {
        path: PathBuf,
        /// JSON lines: one per epoch, then {"summary": ...}.
        #[arg(long)]
        json: bool,
        /// Receiver profile (default: from the drive's fix rate).
        #[arg(long, value_parser = ["ublox-10hz", "logger-1hz"])]
        profile: Option<String>,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Measure the kinematic predictor's error and GNSS speeds at standstill on clean drives.
    Calibrate {
        #[arg(required = true)]
        paths: Vec<PathBuf>,
        #[command(flatten)]
        load: LoadArgs,
    },
}

fn expand(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for p in paths {
        files.extend(input::discover(p)?);
    }
    if files.is_empty() {
        anyhow::bail!(InputError::file(&paths[0], "no drive found: expected .csv, .jsonl, a comma2k19 segment or an HDD session"));
    }
    Ok(files)
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.downcast_ref::<InputError>().is_some() || e.downcast_ref::<std::io::Error>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.cmd {
        Cmd::Inspect { paths, json, load } => {
            let opts = load.options();
            let files = expand(&paths)?;
            // Load everything first: a bad file fails the run before anything is printed.
            let mut all = Vec::new();
            for f in &files {
                let r = input::load(f, &opts)?;
                let (samples, _) = replay::synchronize(&r, load.sync());
                all.push(inspect::stats(&r, &samples, load.sync().earth_radius_m));
            }
            for s in &all {
                if json {
                    println!("{}", serde_json::to_string(s)?);
                } else {
                    print_stats(s);
                }
            }
            Ok(())
        }
        Cmd::Detect { path, json, profile, load } => {
            let files = expand(std::slice::from_ref(&path))?;
            if files.len() != 1 {
                anyhow::bail!(InputError::file(&path, format!("expected one drive, found {} inside", files.len())));
            }
            let r = input::load(&files[0], &load.options())?;
            let (samples, _) = replay::synchronize(&r, load.sync());
            let p = match profile.as_deref() {
                Some("ublox-10hz") => &detector_core::profile::UBLOX_10HZ,
                Some(_) => &detector_core::profile::LOGGER_1HZ,
                None => detect::profile_of(&samples),
            };
            let verdicts = detect::run(&samples, detector_core::fusion::Config::for_profile(p));
            let summary = detect::summarize(&verdicts, p);
            let mut out = std::io::BufWriter::new(std::io::stdout().lock());
            use std::io::Write;
            for v in &verdicts {
                if json {
                    writeln!(out, "{}", detect::verdict_json(v))?;
                } else {
                    writeln!(out, "{}", detect::verdict_line(v))?;
                }
            }
            if json {
                writeln!(out, "{}", serde_json::json!({ "summary": summary }))?;
            } else {
                writeln!(out, "summary: {}", serde_json::to_string_pretty(&summary)?)?;
            }
            Ok(())
        }
        Cmd::Calibrate { paths, load } => {
            let files = expand(&paths)?;
            let st = host_sim::calibrate::run(&files, &load.options(), load.sync())?;
            println!("{}", serde_json::to_string_pretty(&st)?);
            Ok(())
        }
    }
}

fn print_stats(s: &inspect::DriveStats) {
    println!("{}", s.path);
    println!("  format {}  epochs {}  duration {:.1} s  GNSS {:.2} Hz  distance {:.0} m", s.format, s.epochs, s.duration_s, s.gnss_hz, s.distance_m);
    let sig: Vec<String> = s.signals.iter().map(|(k, v)| format!("{k} {:.0}%", v * 100.0)).collect();
    println!("  valid: {}", sig.join(", "));
    println!("  stops {}  turns left {} right {}", s.stops, s.turns_left, s.turns_right);
    if s.skipped_rows > 0 {
        println!("  skipped bad rows: {}", s.skipped_rows);
    }
    for n in &s.notes {
        println!("  note: {n}");
    }
}
