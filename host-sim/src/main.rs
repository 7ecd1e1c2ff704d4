//! The `host-sim` command line: the parser and the dispatch. Each command is a module of
//! [`cmd`] (its arguments and what it does), calling the library (`host_sim`). Exit codes:
//! 0 success, 2 bad input (the file, line and what was expected are printed), 1 anything else.

mod cmd;

use clap::{Parser, Subcommand};
use host_sim::input::InputError;
use std::process::ExitCode;

/// GNSS spoofing detector: host tools over real drives.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Summarise drives: format, epochs, duration, GNSS rate, distance, signal validity, stops, turns.
    Inspect(cmd::inspect::Args),
    /// Run the detector over one drive: per-epoch verdicts, then a summary.
    Detect(cmd::detect::Args),
    /// Re-express a comma2k19 segment as the logs of one's own car, on one UTC clock: `can.log`
    /// (candump) and `can.asc` (Vector ASC) of its raw CAN frames, `gnss.nmea` (its fixes as NMEA
    /// with host timestamps) and `gnss.ubx` (as u-blox NAV-PVT + NAV-STATUS), for `detect --can`.
    ExportLogs(cmd::export_logs::Args),
    /// Run live on Linux: CAN from a SocketCAN interface or `candump -L` text (`-`: stdin), GNSS
    /// from a serial device, a file or stdin; JSON lines as they happen (verdicts, status once a
    /// second, the receiver's own spoofing flag when it changes), a summary with the digest at
    /// the end of input or on Ctrl-C.
    Live(cmd::live::Args),
    /// Write a drive (any format read here, or one's own car's logs) in the common layout: CSV,
    /// or Parquet when OUT ends in `.parquet` (a data lake's file).
    Convert(cmd::convert::Args),
    /// Write an attacked copy of a drive in the common layout (CSV, or Parquet when OUT ends in
    /// `.parquet`), plus an `attack_active` column.
    Attack(cmd::attack::Args),
    /// Write a clean drive transformed the way a new installation differs (not an attack), in the
    /// common layout (CSV, or Parquet when OUT ends in `.parquet`). Without options, a nuisance
    /// of `--kind` drawn from `--seed`.
    Nuisance(cmd::nuisance::Args),
    /// Evaluate the detector on clean and attacked real drives; write report.json, report.md, figures.
    Eval(cmd::eval::Args),
    /// The main job: evaluate on the real drives if present, else on a simulated drive.
    Demo(cmd::demo::Args),
    /// Train a model: `turns` (DTW k-NN templates for strategy 2) or `lstm` (strategy 1's
    /// predictor; writes OUT (int8), OUT with `.f32.bin` and the training report `.train.json`).
    Train(cmd::train::Args),
    /// Time the turn classifier on the held-out turns and export them for tests/bench/dtw_vs_fastdtw.sh.
    DtwBench(cmd::dtw_bench::Args),
    /// Time the LSTM on this host (one core): the core's streaming step (f32 reference, integer
    /// on the portable dot product, integer on the optimised one, side by side) and burn's batch
    /// forward per observation; print the model blob sizes.
    LstmBench(cmd::lstm_bench::Args),
    /// Run the QEMU image's input through the same board pipeline on the host; print the digest.
    Digest(cmd::digest::Args),
    /// Measure the kinematic predictor's error and GNSS speeds at standstill on clean drives.
    Calibrate(cmd::calibrate::Args),
}

fn main() -> ExitCode {
    let result = match Cli::parse().cmd {
        Cmd::Inspect(a) => cmd::inspect::run(a),
        Cmd::Detect(a) => cmd::detect::run(a),
        Cmd::ExportLogs(a) => cmd::export_logs::run(a),
        Cmd::Live(a) => cmd::live::run(a),
        Cmd::Convert(a) => cmd::convert::run(a),
        Cmd::Attack(a) => cmd::attack::run(a),
        Cmd::Nuisance(a) => cmd::nuisance::run(a),
        Cmd::Eval(a) => cmd::eval::run(a),
        Cmd::Demo(a) => cmd::demo::run(a),
        Cmd::Train(a) => cmd::train::run(a),
        Cmd::DtwBench(a) => cmd::dtw_bench::run(a),
        Cmd::LstmBench(a) => cmd::lstm_bench::run(a),
        Cmd::Digest(a) => cmd::digest::run(a),
        Cmd::Calibrate(a) => cmd::calibrate::run(a),
    };
    match result {
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
