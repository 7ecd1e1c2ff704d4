//! Input decoding: real drives in their native formats, turned into a time-ordered stream of
//! receiver fixes and vehicle-signal observations (a [`Replay`]).
//!
//! Every loader is strict: a malformed input is an [`InputError`] naming the file, the line (or
//! array) and what was expected. With [`LoadOptions::skip_bad_rows`] a bad row is counted in
//! [`Replay::skipped_rows`] instead, and the rest of the file is kept.

pub mod can;
pub mod comma2k19;
pub mod drive_csv;
pub mod hdd;
pub mod openxc;

use detector_core::sample::{Fix, Signal};
use std::fmt;
use std::path::{Path, PathBuf};

/// One input event, in the order a device would see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    Fix(Fix),
    Obs { sig: Signal, t: f64, v: f32 },
}

impl Event {
    pub fn t(&self) -> f64 {
        match self {
            Event::Fix(f) => f.t,
            Event::Obs { t, .. } => *t,
        }
    }
}

/// The formats host-sim reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// One CSV per drive in the common layout of `../shared/data/drives`.
    DriveCsv,
    /// A Honda Research Institute Driving Dataset session (`<session>/general/csv/*.csv`).
    Hdd,
    /// A raw comma2k19 segment (`processed_log/.../{t,value}` NumPy arrays).
    Comma2k19,
    /// An OpenXC vehicle-interface JSON trace.
    OpenXc,
    /// A drive made by `host-sim`'s kinematic simulator (never real data).
    Simulated,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::DriveCsv => "drive-csv",
            Format::Hdd => "hdd",
            Format::Comma2k19 => "comma2k19",
            Format::OpenXc => "openxc",
            Format::Simulated => "simulated",
        }
    }
}

/// A drive as a time-ordered event stream.
#[derive(Clone, Debug)]
pub struct Replay {
    pub path: PathBuf,
    pub format: Format,
    /// Sorted by time (stable: same-time events keep file order).
    pub events: Vec<Event>,
    /// Rows dropped under `--skip-bad-rows`.
    pub skipped_rows: usize,
    /// What the loader repaired or assumed (e.g. swapped columns).
    pub notes: Vec<String>,
}

impl Replay {
    pub fn new(path: &Path, format: Format, mut events: Vec<Event>, skipped_rows: usize) -> Self {
        events.sort_by(|a, b| a.t().total_cmp(&b.t()));
        Self { path: path.to_path_buf(), format, events, skipped_rows, notes: Vec::new() }
    }

    pub fn fixes(&self) -> impl Iterator<Item = &Fix> {
        self.events.iter().filter_map(|e| match e {
            Event::Fix(f) => Some(f),
            _ => None,
        })
    }
}

/// Where in a file an error is.
#[derive(Clone, Debug, PartialEq)]
pub enum Location {
    Line(u64),
    Array(String),
    File,
}

/// A malformed input: which file, where, and what was expected.
#[derive(Clone, Debug, PartialEq)]
pub struct InputError {
    pub file: PathBuf,
    pub at: Location,
    pub msg: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.at {
            Location::Line(n) => write!(f, "{}:{}: {}", self.file.display(), n, self.msg),
            Location::Array(a) => write!(f, "{} (array {}): {}", self.file.display(), a, self.msg),
            Location::File => write!(f, "{}: {}", self.file.display(), self.msg),
        }
    }
}

impl std::error::Error for InputError {}

impl InputError {
    pub fn line(file: &Path, line: u64, msg: impl Into<String>) -> Self {
        Self { file: file.to_path_buf(), at: Location::Line(line), msg: msg.into() }
    }
    pub fn array(file: &Path, array: &str, msg: impl Into<String>) -> Self {
        Self { file: file.to_path_buf(), at: Location::Array(array.to_string()), msg: msg.into() }
    }
    pub fn file(file: &Path, msg: impl Into<String>) -> Self {
        Self { file: file.to_path_buf(), at: Location::File, msg: msg.into() }
    }
}

/// Loader options.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Count and drop malformed rows instead of failing.
    pub skip_bad_rows: bool,
    pub hdd: hdd::HddUnits,
}

/// Tells the format of `path` from its shape, or `None` when it is not a drive.
pub fn detect(path: &Path) -> Option<Format> {
    if path.is_dir() {
        if path.join("processed_log").is_dir() {
            return Some(Format::Comma2k19);
        }
        if path.join("general").join("csv").is_dir() {
            return Some(Format::Hdd);
        }
        return None;
    }
    match path.extension().and_then(|e| e.to_str()) {
        Some("csv") => Some(Format::DriveCsv),
        Some("jsonl") | Some("json") => Some(Format::OpenXc),
        _ => None,
    }
}

/// Loads one drive, detecting its format.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    match detect(path) {
        Some(Format::DriveCsv) => drive_csv::load(path, opts),
        Some(Format::Hdd) => hdd::load(path, opts),
        Some(Format::Comma2k19) => comma2k19::load(path),
        Some(Format::OpenXc) => openxc::load(path, opts),
        Some(Format::Simulated) | None => Err(InputError::file(
            path,
            "not a drive: expected a .csv drive file, an OpenXC .jsonl trace, a comma2k19 segment \
             folder (with processed_log/) or an HDD session folder (with general/csv/)",
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

/// The data folder: `GNSS_DATA_DIR` if set, else `../shared/data` from the project root.
pub fn data_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("GNSS_DATA_DIR") {
        return PathBuf::from(d);
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data")
}

/// Parses a number field; empty and `NaN` mean "no value".
pub(crate) fn parse_opt_f64(s: &str) -> Result<Option<f64>, String> {
    let s = s.trim();
    if s.is_empty() || s.eq_ignore_ascii_case("nan") {
        return Ok(None);
    }
    s.parse::<f64>().map(Some).map_err(|_| format!("expected a number, found {s:?}"))
}
