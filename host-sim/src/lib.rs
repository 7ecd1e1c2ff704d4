//! host-sim: the host side of the GNSS spoofing detector.
//!
//! Data path: [`input`] decodes real drives into a time-ordered event stream, [`replay`] runs it
//! through the core's synchroniser (the same code the firmware runs) into per-epoch samples,
//! and [`inspect`] summarises a drive.

pub mod attack;
pub mod calibrate;
pub mod detect;
pub mod eval;
pub mod input;
pub mod inspect;
pub mod lstm;
pub mod output;
pub mod qemu_input;
pub mod replay;
pub mod report;
pub mod sim;
pub mod turns;

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
