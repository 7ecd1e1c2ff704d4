//! host-sim: the host side of the GNSS spoofing detector: real drives through the same core
//! the firmware runs, attacks, evaluation, training, reports.
//!
//! The data path, layer by layer (each module uses only those before it):
//! - from `gnss-data` (light, shared with the QEMU image's build): [`input`] decodes drives,
//!   [`replay`] synchronises them, [`tracks`], [`attack`], [`sim`], [`qemu_input`];
//! - [`output`]: files written whole or not at all;
//! - [`detect`]: the core's detector over a drive, verdicts as JSON, the device's status;
//!   [`verdict_table`]: the verdicts as an Arrow table (Parquet);
//! - [`dataset`]: drives prepared for evaluation and training, a data folder loaded;
//!   [`transform`]: attacked and transformed drives;
//! - [`inspect`], [`calibrate`]: what a drive holds, what the thresholds are made of;
//! - [`turns`], [`lstm`]: strategy 2's templates and strategy 1's LSTM (data; training with
//!   the `train` feature);
//! - [`eval`]: the evaluation (plan, run, results, statistics, report);
//! - [`live`]: the detector on live inputs (SocketCAN, serial, stdin), JSON lines as they come;
//! - [`bench`]: the benchmarks the command line prints.

pub use gnss_data::{attack, input, nuisance, qemu_input, replay, sim, tracks};

pub mod output;
pub mod detect;
pub mod verdict_table;
pub mod dataset;
pub mod transform;
pub mod inspect;
pub mod calibrate;
pub mod turns;
pub mod lstm;
pub mod eval;
pub mod live;
pub mod bench;

/// The real-data folder for a test, or `None` (with the reason printed) when it is absent.
/// In CI (`CI=true`) an absent folder is a failure, not a skip.
pub fn require_data(test: &str) -> Option<std::path::PathBuf> {
    let d = input::data_dir();
    if d.join("drives").is_dir() {
        return Some(d);
    }
    let msg = format!("{test}: real data not found at {} (set GNSS_DATA_DIR)", d.display());
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{msg}; CI must run with ../shared/data");
    }
    eprintln!("SKIPPED {msg}");
    None
}
