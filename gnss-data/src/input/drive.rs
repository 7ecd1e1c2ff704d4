//! What a decoded drive is: a time-ordered stream of receiver fixes and vehicle-signal
//! observations (a [`Replay`]), the formats it can come from, and the errors that name where a
//! file is wrong.

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
    /// The same layout as Apache Parquet (a data lake's drives).
    DriveParquet,
    /// A Honda Research Institute Driving Dataset session (`<session>/general/csv/*.csv`).
    Hdd,
    /// A raw comma2k19 segment (`processed_log/.../{t,value}` NumPy arrays).
    Comma2k19,
    /// An OpenXC vehicle-interface JSON trace.
    OpenXc,
    /// A drive made by `host-sim`'s kinematic simulator (never real data).
    Simulated,
    /// A CAN log (candump) and a GNSS log (NMEA) with a DBC and a map ([`super::logs`]).
    Logs,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::DriveCsv => "drive-csv",
            Format::DriveParquet => "drive-parquet",
            Format::Hdd => "hdd",
            Format::Comma2k19 => "comma2k19",
            Format::OpenXc => "openxc",
            Format::Simulated => "simulated",
            Format::Logs => "can+gnss logs",
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
    pub hdd: HddUnits,
}

/// Units of the HDD files.
#[derive(Clone, Debug, PartialEq)]
pub struct HddUnits {
    /// m/s per unit of `vel.csv`'s `speed`. Default 1/3.6 (km/h).
    pub speed_scale: f64,
    /// +1 when `steer_angle` is + = left (default), -1 when + = right.
    pub steer_sign: f64,
}

impl Default for HddUnits {
    fn default() -> Self {
        Self { speed_scale: 1.0 / 3.6, steer_sign: 1.0 }
    }
}

/// The data folder: `GNSS_DATA_DIR` if set, else `../shared/data` from the project root.
pub fn data_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("GNSS_DATA_DIR") {
        return PathBuf::from(d);
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data")
}

/// Parses a number field; empty and `NaN` mean "no value".
pub fn parse_opt_f64(s: &str) -> Result<Option<f64>, String> {
    let s = s.trim();
    if s.is_empty() || s.eq_ignore_ascii_case("nan") {
        return Ok(None);
    }
    s.parse::<f64>().map(Some).map_err(|_| format!("expected a number, found {s:?}"))
}
