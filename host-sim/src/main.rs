//! The `host-sim` command line: parses arguments and calls the library (`host_sim`); what each
//! command does lives in the modules it calls (`detect`, `eval`, `inspect`, `calibrate`, `bench`,
//! training). Exit codes: 0 success, 2 bad input (the file, line and what was expected are
//! printed), 1 anything else.

use clap::{Parser, Subcommand, ValueEnum};
use detector_core::sync::SyncConfig;
use host_sim::attack::{self, AttackKind};
use host_sim::dataset::Drive;
use host_sim::input::{self, HddUnits, InputError, LoadOptions};
use host_sim::{bench, detect, eval, inspect, output, replay, sim};
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
        /// A drive in one of the research layouts (or give --can, --gnss, --dbc and --map).
        #[arg(required_unless_present = "can")]
        path: Option<PathBuf>,
        /// Your own car: a CAN log, SocketCAN candump (`candump -l`) or Vector ASC, with --gnss,
        /// --dbc and --map.
        #[arg(long, requires_all = ["gnss", "dbc", "map"], conflicts_with = "path")]
        can: Option<PathBuf>,
        /// The GNSS log: NMEA sentences, one per line, optionally after a host timestamp on the
        /// CAN log's clock; or a u-blox UBX binary log (fixes at their UTC time).
        #[arg(long, requires = "can")]
        gnss: Option<PathBuf>,
        /// The car's DBC file (any opendbc DBC).
        #[arg(long, requires = "can")]
        dbc: Option<PathBuf>,
        /// The map file: DBC signal -> detector signal, unit factor, bus (see
        /// firmware/board/profiles/toyota_rav4.map).
        #[arg(long, requires = "can")]
        map: Option<PathBuf>,
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
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Re-express a comma2k19 segment as the logs of one's own car, on one UTC clock: `can.log`
    /// (candump) and `can.asc` (Vector ASC) of its raw CAN frames, `gnss.nmea` (its fixes as NMEA
    /// with host timestamps) and `gnss.ubx` (as u-blox NAV-PVT + NAV-STATUS), for `detect --can`.
    ExportLogs {
        /// The segment folder (with processed_log/).
        segment: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Run live on Linux: CAN from a SocketCAN interface or `candump -L` text (`-`: stdin), GNSS
    /// from a serial device, a file or stdin; JSON lines as they happen (verdicts, status once a
    /// second, the receiver's own spoofing flag when it changes), a summary with the digest at
    /// the end of input or on Ctrl-C.
    Live {
        /// SocketCAN interface (`can0`), `-` (stdin, `candump -L` text) or a file/FIFO of it.
        #[arg(long)]
        can: String,
        /// Serial device (`/dev/ttyACM0`, a pseudo-terminal), `-` (stdin) or a file/FIFO: the
        /// receiver's NMEA and/or UBX bytes, or an NMEA log with host timestamps.
        #[arg(long)]
        gnss: String,
        /// The car's DBC file.
        #[arg(long)]
        dbc: PathBuf,
        /// The map file (see firmware/board/profiles/toyota_rav4.map).
        #[arg(long)]
        map: PathBuf,
        /// Serial baud rate of --gnss.
        #[arg(long, default_value_t = 38_400)]
        baud: u32,
        /// The time of a fix from the receiver's raw output: its arrival (as the firmware does)
        /// or the receiver's own UTC time (NAV-PVT, RMC), for a host clock that keeps UTC.
        #[arg(long, value_parser = ["arrival", "receiver"], default_value = "arrival")]
        gnss_time: String,
        /// Receiver profile (default: from the rate of the first --profile-epochs epochs).
        #[arg(long, value_parser = ["ublox-10hz", "logger-1hz"])]
        profile: Option<String>,
        /// Epochs looked at to choose the receiver profile (their verdicts follow at once).
        #[arg(long, default_value_t = 30)]
        profile_epochs: usize,
        /// Strategy 1's predictor.
        #[arg(long, value_enum, default_value = "lstm")]
        predictor: detect::PredictorKind,
        /// Release an event only when both inputs have passed its time (replays: the order and
        /// digest of `detect`); without it an event waits at most --max-wait-s.
        #[arg(long)]
        strict_merge: bool,
        /// Wall-clock seconds an event waits for the other input.
        #[arg(long, default_value_t = 0.5)]
        max_wait_s: f64,
        /// Largest gap, seconds, between an epoch and the observations it is interpolated from.
        #[arg(long, default_value_t = SyncConfig::default().max_gap_s)]
        max_gap: f64,
    },
    /// Write an attacked copy of a drive in the common CSV layout, plus an `attack_active` column.
    Attack {
        /// turn-by-turn, overshoot, stop, wrong-turn, slow-drift, small-biased, direction, replay, jump
        #[arg(long, value_parser = parse_attack_kind)]
        kind: AttackKind,
        #[command(flatten)]
        params: AttackArgs,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Onset time, seconds on the drive's clock (default: drawn from the seed among the times
        /// where the attack makes sense).
        #[arg(long)]
        onset: Option<f64>,
        path: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Write a clean drive transformed the way a new installation differs (not an attack), in the
    /// common CSV layout. Without options, a nuisance of `--kind` drawn from `--seed`.
    Nuisance {
        /// delay, speed-course-1hz, wheel-speed, gyro, rate-switch, jitter, outage, vehicle-late,
        /// coarse-steering, gnss-noise, combined
        #[arg(long, value_parser = parse_nuisance_kind, default_value = "combined")]
        kind: gnss_data::nuisance::NuisanceKind,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// GNSS position this late, seconds (with any of these options, only what they say is applied).
        #[arg(long)]
        pos_delay_s: Option<f64>,
        /// GNSS speed and course this late, seconds.
        #[arg(long)]
        vel_delay_s: Option<f64>,
        /// Speed and course from a separate 1 Hz receiver this late, seconds.
        #[arg(long)]
        vel_1hz_lag_s: Option<f64>,
        /// Wheel speed times this, resampled at 2 Hz and rounded to 1 km/h.
        #[arg(long)]
        wheel_scale: Option<f64>,
        /// Gyro bias, deg/s.
        #[arg(long)]
        gyro_bias_degps: Option<f64>,
        /// Gyro scale.
        #[arg(long)]
        gyro_scale: Option<f64>,
        /// Fix rate switching between 10, 5 and 1 Hz every this many seconds.
        #[arg(long)]
        rate_switch_s: Option<f64>,
        /// Timestamp jitter, +- seconds.
        #[arg(long)]
        jitter_s: Option<f64>,
        /// A GNSS outage START:LENGTH (seconds after the drive's start); repeatable.
        #[arg(long, value_parser = parse_outage)]
        outage: Vec<(f64, f64)>,
        /// Every vehicle signal this late, seconds.
        #[arg(long)]
        vehicle_delay_s: Option<f64>,
        /// The steering angle in steps of this many degrees.
        #[arg(long)]
        steering_step_deg: Option<f64>,
        /// GNSS position noise TAU:SD (a Gauss-Markov process per axis: time constant, seconds;
        /// standard deviation, metres).
        #[arg(long, value_parser = parse_gnss_noise)]
        gnss_noise: Option<(f64, f64)>,
        path: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Evaluate the detector on clean and attacked real drives; write report.json, report.md, figures.
    Eval {
        /// Data folder (with drives/); default ../shared/data or $GNSS_DATA_DIR.
        #[arg(long)]
        data: Option<PathBuf>,
        /// How the data-derived numbers are fitted: each source judged with numbers fitted on the
        /// others (`loso`, the default), or everything on everything (`in-sample`, for comparison).
        #[arg(long, value_parser = ["loso", "in-sample"], default_value = "loso")]
        protocol: String,
        /// Draws of each nuisance kind per drive with wheel speed (0: no nuisance suite).
        #[arg(long, default_value_t = 8)]
        nuisance_variants: usize,
        /// Scenarios per attack kind.
        #[arg(long, default_value_t = 10)]
        scenarios: usize,
        #[arg(long, default_value = "out/eval")]
        out: PathBuf,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Strategy 1's predictor for the main run (the report shows both side by side).
        #[arg(long, value_enum, default_value = "lstm")]
        predictor: detect::PredictorKind,
    },
    /// The main job: evaluate on the real drives if present, else on a simulated drive.
    Demo {
        #[arg(long)]
        data: Option<PathBuf>,
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        #[arg(long, default_value_t = 10)]
        scenarios: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Train a model: `turns` (DTW k-NN templates for strategy 2) or `lstm` (strategy 1's
    /// predictor; writes OUT (int8), OUT with `.f32.bin` and the training report `.train.json`).
    Train {
        #[arg(value_parser = ["turns", "lstm"])]
        what: String,
        #[arg(long)]
        data: Option<PathBuf>,
        #[arg(long)]
        out: PathBuf,
        #[arg(long)]
        seed: Option<u64>,
        /// lstm: units of the two layers.
        #[arg(long, value_delimiter = ',', default_values_t = [128usize, 64])]
        hidden: Vec<usize>,
        /// lstm: most epochs (early stopping on validation MAE ends sooner).
        #[arg(long, default_value_t = 500)]
        epochs: usize,
        /// lstm: epochs without a better validation MAE before stopping.
        #[arg(long, default_value_t = 25)]
        patience: usize,
        /// lstm: training window, GNSS epochs.
        #[arg(long, default_value_t = 32)]
        window: usize,
    },
    /// Time the turn classifier on the held-out turns and export them for tests/bench/dtw_vs_fastdtw.sh.
    DtwBench {
        #[arg(long)]
        data: Option<PathBuf>,
        /// JSON with the templates and queries, for the Python comparison.
        #[arg(long)]
        export: PathBuf,
    },
    /// Time the LSTM on this host (one core): the core's streaming step (f32 reference, integer
    /// on the portable dot product, integer on the optimised one, side by side) and burn's batch
    /// forward per observation; print the model blob sizes.
    LstmBench {
        #[arg(long)]
        data: Option<PathBuf>,
    },
    /// Run the QEMU image's input through the same board pipeline on the host; print the digest.
    Digest {
        #[arg(long)]
        data: Option<PathBuf>,
        /// Also write the input (what the QEMU image embeds) to this file.
        #[arg(long)]
        export: Option<PathBuf>,
    },
    /// Measure the kinematic predictor's error and GNSS speeds at standstill on clean drives.
    Calibrate {
        #[arg(required = true)]
        paths: Vec<PathBuf>,
        #[command(flatten)]
        load: LoadArgs,
    },
}

/// Attack parameters fixed instead of drawn from the seed.
#[derive(clap::Args, Clone, Debug, Default)]
struct AttackArgs {
    /// turn-by-turn, jump: the offset, metres.
    #[arg(long)]
    offset_m: Option<f64>,
    /// turn-by-turn, jump: the offset's bearing, degrees.
    #[arg(long)]
    bearing_deg: Option<f64>,
    /// stop: the spoofed speed, m/s.
    #[arg(long)]
    speed_mps: Option<f64>,
    /// slow-drift: the rate, m/s.
    #[arg(long)]
    rate_mps: Option<f64>,
    /// slow-drift: across the road (else along it).
    #[arg(long)]
    across: Option<bool>,
    /// small-biased: the step per epoch, metres.
    #[arg(long)]
    step_m: Option<f64>,
    /// direction: the rotation rate, deg/s (+ = clockwise).
    #[arg(long, allow_hyphen_values = true)]
    deg_per_s: Option<f64>,
    /// replay: the delay, seconds.
    #[arg(long)]
    delay_s: Option<f64>,
    /// wrong-turn on a straight road: turn right (else left).
    #[arg(long)]
    right: Option<bool>,
}

impl AttackArgs {
    fn params(&self) -> attack::AttackParams {
        attack::AttackParams {
            offset_m: self.offset_m,
            bearing_deg: self.bearing_deg,
            speed_mps: self.speed_mps,
            rate_mps: self.rate_mps,
            across: self.across,
            step_m: self.step_m,
            deg_per_s: self.deg_per_s,
            delay_s: self.delay_s,
            right: self.right,
        }
    }
}

fn parse_nuisance_kind(s: &str) -> Result<gnss_data::nuisance::NuisanceKind, String> {
    use gnss_data::nuisance::NuisanceKind;
    NuisanceKind::from_name(s).ok_or_else(|| format!("expected one of {:?}", NuisanceKind::ALL.map(NuisanceKind::name)))
}

fn parse_outage(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(':').ok_or("expected START:LENGTH in seconds")?;
    let (a, b) = (a.parse::<f64>().map_err(|e| e.to_string())?, b.parse::<f64>().map_err(|e| e.to_string())?);
    if a.is_finite() && b.is_finite() && a >= 0.0 && b > 0.0 { Ok((a, b)) } else { Err("expected START >= 0 and LENGTH > 0".into()) }
}

fn parse_gnss_noise(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(':').ok_or("expected TAU:SD (time constant, seconds; standard deviation, metres)")?;
    let (a, b) = (a.parse::<f64>().map_err(|e| e.to_string())?, b.parse::<f64>().map_err(|e| e.to_string())?);
    if a.is_finite() && b.is_finite() && a > 0.0 && b >= 0.0 { Ok((a, b)) } else { Err("expected TAU > 0 and SD >= 0".into()) }
}

fn parse_attack_kind(s: &str) -> Result<AttackKind, String> {
    AttackKind::from_name(s).ok_or_else(|| format!("expected one of {:?}", AttackKind::ALL.map(AttackKind::name)))
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

/// `println!` that ends the program quietly when stdout is closed (`host-sim ... | head`).
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($t)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
        }
    }};
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) => ExitCode::SUCCESS,
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
                    outln!("{}", serde_json::to_string(s)?);
                } else {
                    print_stats(s);
                }
            }
            Ok(())
        }
        Cmd::Detect { path, can, gnss, dbc, map, json, profile, predictor, calibration, load } => {
            let r = match (path, can, gnss, dbc, map) {
                (_, Some(can), Some(gnss), Some(dbc), Some(map)) => {
                    let read = |p: &PathBuf| std::fs::read_to_string(p).map_err(|e| InputError::file(p, format!("cannot read as text: {e}")));
                    let profile = gnss_guard_profile::load::load(&read(&dbc)?, &read(&map)?).map_err(|e| InputError::file(&map, e.to_string()))?;
                    input::logs::load(&can, &gnss, &profile, &load.options())?
                }
                (Some(path), ..) => {
                    let files = expand(std::slice::from_ref(&path))?;
                    if files.len() != 1 {
                        anyhow::bail!(InputError::file(&path, format!("expected one drive, found {} inside", files.len())));
                    }
                    input::load(&files[0], &load.options())?
                }
                _ => anyhow::bail!("give a drive, or --can, --gnss, --dbc and --map"),
            };
            let (samples, _) = replay::synchronize(&r, load.sync());
            let p = match profile.as_deref() {
                Some("ublox-10hz") => &detector_core::profile::UBLOX_10HZ,
                Some(_) => &detector_core::profile::LOGGER_1HZ,
                None => detect::profile_of(&samples),
            };
            let stored = match &calibration {
                Some(f) => detect::read_calibration(f),
                None => None,
            };
            let (verdicts, learnt) = detect::run_calibrated(&samples, detect::config(p, predictor), predictor, detect::default_templates(), stored.as_ref());
            let cal_outcome = match &calibration {
                Some(f) => Some(detect::write_calibration(f, stored.as_ref(), learnt.as_ref(), &verdicts)?),
                None => None,
            };
            let summary = detect::summarize(&verdicts, p);
            let status = detect::status_lines(&verdicts, stored.is_some());
            let mut out = std::io::BufWriter::new(std::io::stdout().lock());
            use std::io::Write;
            // Verdicts and, once a second of drive time, the device's status, in time order.
            let mut next_status = status.iter().peekable();
            for v in &verdicts {
                if json {
                    while let Some((_, s)) = next_status.next_if(|(t, _)| *t < v.t) {
                        writeln!(out, "{}", serde_json::json!({ "status": s }))?;
                    }
                    writeln!(out, "{}", detect::verdict_json(v))?;
                } else {
                    writeln!(out, "{}", detect::verdict_line(v))?;
                }
            }
            let last_status = status.last().map(|(_, s)| s.clone());
            if json {
                for (_, s) in next_status {
                    writeln!(out, "{}", serde_json::json!({ "status": s }))?;
                }
                writeln!(out, "{}", serde_json::json!({ "summary": summary, "status": last_status, "status_seconds": detect::state_seconds(&status), "digest": detect::digest_hex(&verdicts), "calibration": cal_outcome }))?;
            } else {
                writeln!(out, "verdict digest: {}", detect::digest_hex(&verdicts))?;
                writeln!(out, "summary: {}", serde_json::to_string_pretty(&summary)?)?;
                writeln!(out, "status at the end: {}", last_status.map_or("none".into(), |s| s.to_string()))?;
                writeln!(out, "status seconds per state: {:?}", detect::state_seconds(&status))?;
                if let Some(c) = &cal_outcome {
                    writeln!(out, "calibration: {}", c["said"].as_str().unwrap_or(""))?;
                }
            }
            Ok(())
        }
        Cmd::ExportLogs { segment, out } => {
            let logs = input::logs::comma2k19_as_logs(&segment)?;
            std::fs::create_dir_all(&out).map_err(|e| InputError::file(&out, format!("cannot create: {e}")))?;
            outln!("clock: UTC = segment time + {:.3} s (the first u-blox fix's UTC time)", logs.offset_s);
            for (name, bytes, what) in [
                ("can.log", logs.candump.as_bytes(), "candump lines"),
                ("can.asc", logs.asc.as_bytes(), "ASC lines"),
                ("gnss.nmea", logs.nmea.as_bytes(), "NMEA lines"),
                ("gnss.ubx", &logs.ubx[..], "bytes of UBX"),
            ] {
                let p = out.join(name);
                output::write_atomic(&p, |w| w.write_all(bytes)).map_err(|e| InputError::file(&p, format!("cannot write: {e}")))?;
                let n = if name.ends_with(".ubx") { bytes.len() } else { bytes.iter().filter(|b| **b == b'\n').count() };
                outln!("wrote {} ({n} {what})", p.display());
            }
            Ok(())
        }
        Cmd::Live { can, gnss, dbc, map, baud, gnss_time, profile, profile_epochs, predictor, strict_merge, max_wait_s, max_gap } => {
            if can == "-" && gnss == "-" {
                anyhow::bail!("--can and --gnss cannot both read stdin");
            }
            if predictor == detect::PredictorKind::LstmF32 {
                anyhow::bail!("live runs the kinematic or the integer LSTM predictor (lstm-f32 is for fidelity checks)");
            }
            if !(max_wait_s.is_finite() && max_wait_s >= 0.0) {
                anyhow::bail!("--max-wait-s must be a non-negative number of seconds");
            }
            let read = |p: &PathBuf| std::fs::read_to_string(p).map_err(|e| InputError::file(p, format!("cannot read as text: {e}")));
            let prof = gnss_guard_profile::load::load(&read(&dbc)?, &read(&map)?).map_err(|e| InputError::file(&map, e.to_string()))?;
            let opts = host_sim::live::Options {
                profile: profile.as_deref().map(|p| if p == "ublox-10hz" { &detector_core::profile::UBLOX_10HZ } else { &detector_core::profile::LOGGER_1HZ }),
                predictor,
                strict_merge,
                max_wait: std::time::Duration::from_secs_f64(max_wait_s),
                sync: SyncConfig { max_gap_s: max_gap, ..SyncConfig::default() },
                profile_epochs,
                receiver_time: gnss_time == "receiver",
            };
            let mut out = std::io::stdout().lock();
            host_sim::live::run(host_sim::live::CanSource::parse(&can), host_sim::live::GnssSource::parse(&gnss, baud), &prof, &opts, &mut out)
        }
        Cmd::Attack { kind, params, seed, onset, path, out, load } => {
            let r = input::load(&path, &load.options())?;
            let (samples, _) = replay::synchronize(&r, load.sync());
            let onset = match onset {
                Some(t) => t,
                None => {
                    use rand::{seq::IndexedRandom, SeedableRng};
                    let c = attack::candidate_onsets(kind, &samples);
                    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                    *c.choose(&mut rng).ok_or_else(|| anyhow::anyhow!(InputError::file(&path,
                        format!("this drive cannot host a {} attack (see `host-sim attack --help`)", kind.name()))))?
                }
            };
            let a = attack::apply_with(&r, kind, seed, onset, &params.params());
            host_sim::output::write_atomic(&out, |w| input::drive_csv::write(&a.replay, Some(onset), w))?;
            eprintln!("wrote {}: {} from t={onset:.2} s ({})", out.display(), kind.name(), a.spec.params);
            Ok(())
        }
        Cmd::Nuisance { kind, seed, pos_delay_s, vel_delay_s, vel_1hz_lag_s, wheel_scale, gyro_bias_degps, gyro_scale, rate_switch_s, jitter_s, outage, vehicle_delay_s, steering_step_deg, gnss_noise, path, out, load } => {
            use gnss_data::nuisance::{self, Nuisance};
            let r = input::load(&path, &load.options())?;
            let (samples, _) = replay::synchronize(&r, load.sync());
            let given = Nuisance { pos_delay_s, vel_delay_s, vel_1hz_lag_s, wheel_scale, wheel_quantised: wheel_scale.is_some(), gyro_bias_degps, gyro_scale, rate_switch_s, jitter_s, outages: outage, vehicle_delay_s, steering_step_deg, gnss_noise };
            let n = if given == Nuisance::default() {
                let dur = samples.last().zip(samples.first()).map_or(0.0, |(a, b)| a.t - b.t);
                Nuisance::draw(kind, seed, dur, 1.0 / detect::profile_of(&samples).nominal_dt_s as f64)
            } else {
                given
            };
            let t = nuisance::apply(&r, &n, seed);
            host_sim::output::write_atomic(&out, |w| input::drive_csv::write(&t, None, w))?;
            eprintln!("wrote {}: {}", out.display(), n.describe());
            Ok(())
        }
        Cmd::Eval { data, protocol, nuisance_variants, scenarios, out, seed, predictor } => {
            let dir = data.unwrap_or_else(input::data_dir);
            let drives = load_drives(&dir.join("drives"))?;
            let protocol = if protocol == "in-sample" { eval::Protocol::InSample } else { eval::Protocol::LeaveOneSourceOut };
            run_eval(drives, "real", &dir, protocol, nuisance_variants, scenarios, seed, predictor, &out)
        }
        Cmd::Demo { data, out, scenarios, seed } => {
            let dir = data.unwrap_or_else(input::data_dir);
            if dir.join("drives").is_dir() {
                outln!("demo: using the REAL drives in {}", dir.display());
                let drives = load_drives(&dir.join("drives"))?;
                run_eval(drives, "real", &dir, eval::Protocol::LeaveOneSourceOut, 5, scenarios, seed, detect::PredictorKind::Lstm, &out)
            } else {
                outln!("demo: {} not found: using two SIMULATED drives (10 Hz and 1 Hz receivers; seed {seed})", dir.display());
                let drives = sim::demo_drives(seed).into_iter().map(|r| Drive::new(r, SyncConfig::default())).collect();
                run_eval(drives, "simulated", &dir, eval::Protocol::LeaveOneSourceOut, 5, scenarios, seed, detect::PredictorKind::Lstm, &out)
            }
        }
        Cmd::Train { what, data, out, seed, hidden, epochs, patience, window } if what == "lstm" => {
            train_lstm(data, out, seed, hidden, epochs, patience, window)
        }
        Cmd::Train { what: _, data, out, seed, .. } => {
            let seed = seed.unwrap_or(1);
            let dir = data.unwrap_or_else(input::data_dir);
            let mut drives = load_drives(&dir.join("drives"))?;
            drives.extend(host_sim::turns::sim_drives());
            let (blob, rep, _) = host_sim::turns::train_and_evaluate(&drives, seed);
            host_sim::output::write_atomic(&out, |w| w.write_all(&blob))?;
            outln!("{}", serde_json::to_string_pretty(&rep)?);
            eprintln!("wrote {} ({} templates, {} bytes)", out.display(), rep.templates, blob.len());
            Ok(())
        }
        Cmd::DtwBench { data, export } => {
            let dir = data.unwrap_or_else(input::data_dir);
            let mut drives = load_drives(&dir.join("drives"))?;
            drives.extend(host_sim::turns::sim_drives());
            let b = bench::dtw(&drives);
            host_sim::output::write_atomic(&export, |w| serde_json::to_writer(w, &serde_json::json!({
                "band": b.band, "templates": b.templates, "queries": b.queries.iter().map(|q| q.to_vec()).collect::<Vec<_>>(), "rust_us_per_query": b.us_per_query,
            })).map_err(std::io::Error::other))?;
            outln!("queries {} templates {} (checksum {:.1})", b.queries.len(), b.templates.len(), b.checksum);
            outln!("rust_us_per_query: {:.2}", b.us_per_query);
            Ok(())
        }
        Cmd::LstmBench { data } => {
            let dir = data.unwrap_or_else(input::data_dir);
            let drives = load_drives(&dir.join("drives"))?;
            let runs = eval::validation_runs(&drives);
            anyhow::ensure!(!runs.is_empty(), "no validation drives in {}", dir.display());
            let t = bench::lstm_kernels(&runs);
            outln!("validation steps timed: {} (one core, best of 3 passes)", t.steps);
            outln!("streaming step, f32 reference kernel:            {:.2} us", t.us_ref);
            outln!("streaming step, integer kernel, portable dot:    {:.2} us", t.us_portable);
            outln!("streaming step, integer kernel, optimised dot:   {:.2} us ({:?})", t.us_fast, gnss_guard_dsp::kernel());
            outln!("optimised vs portable integer outputs: {} of {} steps differ", t.differ, t.steps);
            anyhow::ensure!(t.differ == 0, "the optimised integer kernel differs from the portable one");
            #[cfg(feature = "train")]
            outln!("burn batch forward [50 x 32] per observation: {:.2} us (paper: 0.691 us on a dual Xeon)", bench::burn_batch_us(&runs));
            #[cfg(not(feature = "train"))]
            outln!("burn batch forward: not in this build (cargo build -p host-sim --features train)");
            let (int8, f32b) = bench::model_bytes();
            outln!("model blob: {int8} bytes int8, {f32b} bytes f32");
            Ok(())
        }
        Cmd::Digest { data, export } => {
            let dir = data.unwrap_or_else(input::data_dir);
            let (bytes, desc) = host_sim::qemu_input::generate(&dir)?;
            if let Some(p) = export {
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
        Cmd::Calibrate { paths, load } => {
            let files = expand(&paths)?;
            let st = host_sim::calibrate::run(&files, &load.options(), load.sync())?;
            outln!("{}", serde_json::to_string_pretty(&st)?);
            Ok(())
        }
    }
}

fn print_stats(s: &inspect::DriveStats) {
    outln!("{}", s.path);
    outln!("  format {}  epochs {}  duration {:.1} s  GNSS {:.2} Hz  distance {:.0} m", s.format, s.epochs, s.duration_s, s.gnss_hz, s.distance_m);
    let sig: Vec<String> = s.signals.iter().map(|(k, v)| format!("{k} {:.0}%", v * 100.0)).collect();
    outln!("  valid: {}", sig.join(", "));
    outln!("  stops {}  turns left {} right {}", s.stops, s.turns_left, s.turns_right);
    if s.skipped_rows > 0 {
        outln!("  skipped bad rows: {}", s.skipped_rows);
    }
    for n in &s.notes {
        outln!("  note: {n}");
    }
}

fn load_drives(dir: &std::path::Path) -> anyhow::Result<Vec<Drive>> {
    use rayon::prelude::*;
    let files = expand(&[dir.to_path_buf()])?;
    let opts = LoadOptions::default();
    files.par_iter()
        .map(|f| Ok(Drive::new(input::load(f, &opts)?, SyncConfig::default())))
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn run_eval(drives: Vec<Drive>, data: &str, dir: &std::path::Path, protocol: eval::Protocol, nuisance_variants: usize, scenarios: usize, seed: u64, predictor: detect::PredictorKind, out: &std::path::Path) -> anyhow::Result<()> {
    let o = eval::EvalOptions { scenarios, seed, predictor, protocol, ..Default::default() };
    let nuisance_runs = drives.iter().filter(|d| d.has_wheel_speed()).count() * gnss_data::nuisance::NuisanceKind::ALL.len() * nuisance_variants;
    let total = drives.len() + eval::plan(&drives, &o).len() + nuisance_runs;
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}").unwrap().progress_chars("=> "));
    bar.set_message("evaluating");
    let r = eval::full(drives, &o, data, &dir.display().to_string(), nuisance_variants, &|| bar.inc(1));
    bar.finish_and_clear();
    for (k, st) in &r.attacks {
        if st.scenarios < st.requested {
            outln!("note: {k}: {} scenarios of the {} asked for: the data can host {} ({} drives)", st.scenarios, st.requested, st.capacity, st.hosting_drives);
        }
    }
    let files = eval::report::write_all(&r, out)?;
    outln!("{}", eval::report::headline(&r));
    outln!("Table 3 (scenarios in which each strategy fired):\n{}", eval::report::table3(&r));
    if let Some(p) = &r.predictors {
        outln!("Strategy 1 predictors:\n{}", eval::report::predictors(p, r.quantization.as_ref()));
    }
    outln!("wrote {} files under {} (report.json, report.md, figures/)", files.len(), out.display());
    Ok(())
}

/// `train lstm`: burn, only with the `train` feature.
#[cfg(feature = "train")]
fn train_lstm(data: Option<PathBuf>, out: PathBuf, seed: Option<u64>, hidden: Vec<usize>, epochs: usize, patience: usize, window: usize) -> anyhow::Result<()> {
    let dir = data.unwrap_or_else(input::data_dir);
    let drives = load_drives(&dir.join("drives"))?;
    anyhow::ensure!(hidden.len() == 2, "--hidden takes two sizes, e.g. 128,64");
    let d = host_sim::lstm::TrainOptions::default();
    let o = host_sim::lstm::TrainOptions { h1: hidden[0], h2: hidden[1], max_epochs: epochs, patience, window, seed: seed.unwrap_or(d.seed), ..d };
    let (int_blob, f32_blob, rep) = host_sim::lstm::train(&drives, &o, &|e, t, v| eprintln!("epoch {e:4}  train MAE {t:.5}  validation MAE {v:.5}"))?;
    let f32_path = out.with_extension("f32.bin");
    host_sim::output::write_atomic(&out, |w| w.write_all(&int_blob))?;
    host_sim::output::write_atomic(&f32_path, |w| w.write_all(&f32_blob))?;
    let json = serde_json::to_string_pretty(&rep)?;
    host_sim::output::write_atomic(&out.with_extension("train.json"), |w| w.write_all(json.as_bytes()))?;
    outln!("{json}");
    eprintln!("wrote {} ({} bytes, int8) and {} ({} bytes, f32)", out.display(), int_blob.len(), f32_path.display(), f32_blob.len());
    Ok(())
}

#[cfg(not(feature = "train"))]
fn train_lstm(_: Option<PathBuf>, _: PathBuf, _: Option<u64>, _: Vec<usize>, _: usize, _: usize, _: usize) -> anyhow::Result<()> {
    anyhow::bail!("this build has no LSTM training: build host-sim with `--features train` (burn), e.g. `cargo run --release -p host-sim --features train -- train lstm ...`")
}
