//! Input decoding: real drives in their native formats, turned into a time-ordered stream of
//! receiver fixes and vehicle-signal observations (a [`Replay`]).
//!
//! Every loader is strict: a malformed input is an [`InputError`] naming the file, the line (or
//! array) and what was expected. With [`LoadOptions::skip_bad_rows`] a bad row is counted in
//! [`Replay::skipped_rows`] instead, and the rest of the file is kept.

pub mod asc;
pub mod blf;
pub mod can;
pub mod can_gnss;
pub mod candump;
pub mod comma2k19;
pub mod drive;
pub mod drive_csv;
#[cfg(feature = "parquet")]
pub mod drive_parquet;
#[cfg(feature = "parquet")]
pub mod parquet_gate;
pub mod hdd;
pub mod logs;
pub mod mdf4;
pub mod openxc;
pub mod ubx_log;

pub use drive::{data_dir, Event, Format, HddUnits, InputError, LoadOptions, Location, Replay};
use std::path::{Path, PathBuf};

/// Tells the format of `path` from its shape, or `None` when it is not a drive.
pub fn detect(path: &Path) -> Option<Format> {
    if path.is_dir() {
        if path.join("processed_log").is_dir() {
            return Some(Format::Comma2k19);
        }
        if path.join("general").join("csv").is_dir() {
            return Some(Format::Hdd);
        }
        if logs::folder_profile(path).is_some() {
            return Some(Format::Logs);
        }
        return None;
    }
    match path.extension().and_then(|e| e.to_str()) {
        Some("csv") => Some(Format::DriveCsv),
        Some("parquet") | Some("pq") => Some(Format::DriveParquet),
        Some("jsonl") | Some("json") => Some(Format::OpenXc),
        _ => None,
    }
}

/// Loads one drive, detecting its format.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    match detect(path) {
        Some(Format::DriveCsv) => drive_csv::load(path, opts),
        #[cfg(feature = "parquet")]
        Some(Format::DriveParquet) => drive_parquet::load(path, opts),
        #[cfg(not(feature = "parquet"))]
        Some(Format::DriveParquet) => Err(InputError::file(path, "a Parquet drive: this build reads none (gnss-data's `parquet` feature)")),
        Some(Format::Hdd) => hdd::load(path, opts),
        Some(Format::Comma2k19) => comma2k19::load(path),
        Some(Format::OpenXc) => openxc::load(path, opts),
        Some(Format::Logs) => logs::load_folder(path, opts),
        Some(Format::Simulated) | None => Err(InputError::file(
            path,
            "not a drive: expected a .csv or .parquet drive file, an OpenXC .jsonl trace, a comma2k19 segment \
             folder (with processed_log/), an HDD session folder (with general/csv/) or a logs \
             folder (a CAN log, a GNSS log, one .dbc and one .map)",
        )),
    }
}

/// Every drive under `path`, recursively, in sorted order (the path itself if it is a drive).
/// CSV files inside an HDD session or comma2k19 segment belong to it and are not listed alone.
pub fn discover(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    if detect(path).is_some() {
        out.push(path.to_path_buf());
        return Ok(out);
    }
    if !path.exists() {
        return Err(std::io::Error::new(std::io::ErrorKind::NotFound, format!("{}: no such file or folder", path.display())));
    }
    if path.is_dir() {
        let mut entries: Vec<PathBuf> =
            std::fs::read_dir(path)?.map(|e| e.map(|e| e.path())).collect::<Result<_, _>>()?;
        entries.sort();
        for e in entries {
            if e.is_dir() || detect(&e).is_some() {
                out.extend(discover(&e)?);
            }
        }
    }
    Ok(out)
}
