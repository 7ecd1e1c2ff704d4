//! One module per command: its arguments (`Args`) and what it does (`run`). What the commands
//! share lives here: the drive-loading options, finding drives under a path, and printing to a
//! stdout that may be closed (`host-sim ... | head`).

pub mod attack;
pub mod calibrate;
pub mod convert;
pub mod demo;
pub mod detect;
pub mod digest;
pub mod dtw_bench;
pub mod eval;
pub mod export_logs;
pub mod inspect;
pub mod live;
pub mod lstm_bench;
pub mod nuisance;
pub mod train;

use clap::ValueEnum;
use detector_core::sync::SyncConfig;
use host_sim::dataset::Drive;
use host_sim::input::{self, HddUnits, InputError, LoadOptions};
use std::path::{Path, PathBuf};

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
pub(crate) use outln;

#[derive(Clone, Copy, ValueEnum)]
pub enum SpeedUnit {
    Kmh,
    Mps,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum SteerSign {
    Left,
    Right,
}

/// How drives are read and synchronised: every command that loads a drive takes these.
#[derive(clap::Args, Clone)]
pub struct LoadArgs {
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
    pub fn options(&self) -> LoadOptions {
        LoadOptions {
            skip_bad_rows: self.skip_bad_rows,
            hdd: HddUnits {
                speed_scale: match self.hdd_speed_unit { SpeedUnit::Kmh => 1.0 / 3.6, SpeedUnit::Mps => 1.0 },
                steer_sign: match self.hdd_steer_positive { SteerSign::Left => 1.0, SteerSign::Right => -1.0 },
            },
        }
    }
    pub fn sync(&self) -> SyncConfig {
        SyncConfig { max_gap_s: self.max_gap, ..SyncConfig::default() }
    }
}

/// One drive: a file or folder in one of the layouts `input::load` reads, or one's own car's
/// logs (a CAN log, DBCs, a map, and a GNSS log unless the map reads GNSS on CAN).
#[derive(clap::Args)]
pub struct DriveSource {
    /// A drive: a .csv or .parquet file in the common layout, an OpenXC trace, a comma2k19
    /// segment, an HDD session, a logs folder (or give --can, --dbc, --map and --gnss).
    #[arg(required_unless_present = "can")]
    path: Option<PathBuf>,
    /// Your own car: a CAN log (SocketCAN candump, Vector ASC, Vector BLF, an ASAM MDF 4 file
    /// or a folder of one session's MF4 files), with --dbc, --map and --gnss (or GNSS on CAN).
    #[arg(long, requires_all = ["dbc", "map"], conflicts_with = "path")]
    can: Option<PathBuf>,
    /// The GNSS log: NMEA sentences, one per line, optionally after a host timestamp on the
    /// CAN log's clock; or a u-blox UBX binary log (fixes at their UTC time). Not needed when
    /// the map names GNSS fields on CAN (gnss_lat, gnss_lon, ...).
    #[arg(long, requires = "can")]
    gnss: Option<PathBuf>,
    /// A DBC file (any opendbc DBC); repeat it for several (the car's, a logger's, OBD-II).
    #[arg(long, requires = "can")]
    dbc: Vec<PathBuf>,
    /// The map file: DBC signal -> detector signal or GNSS field, unit factor, bus (see
    /// firmware/board/profiles/toyota_rav4.map and docs/your-own-car.md).
    #[arg(long, requires = "can")]
    map: Option<PathBuf>,
}

impl DriveSource {
    /// Loads the drive (a folder must hold exactly one).
    pub fn load(&self, load: &LoadArgs) -> anyhow::Result<host_sim::input::Replay> {
        match (&self.path, &self.can, &self.map) {
            (_, Some(can), Some(map)) if !self.dbc.is_empty() => {
                let profile = input::logs::load_profile(&self.dbc, map)?;
                Ok(input::logs::load(can, self.gnss.as_deref(), &profile, &load.options())?)
            }
            (Some(path), ..) => {
                let files = expand(std::slice::from_ref(path))?;
                if files.len() != 1 {
                    anyhow::bail!(InputError::file(path, format!("expected one drive, found {} inside", files.len())));
                }
                Ok(input::load(&files[0], &load.options())?)
            }
            _ => anyhow::bail!("give a drive, or --can, --dbc and --map (and --gnss unless the map reads GNSS on CAN)"),
        }
    }
}

/// Every drive under the given paths (files, or folders searched recursively).
pub fn expand(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for p in paths {
        files.extend(input::discover(p)?);
    }
    if files.is_empty() {
        anyhow::bail!(InputError::file(&paths[0], "no drive found: expected .csv or .parquet drives, .jsonl traces, comma2k19 segments, HDD sessions or logs folders"));
    }
    Ok(files)
}

/// Every drive under `dir`, loaded and synchronised (in parallel).
pub fn load_drives(dir: &Path) -> anyhow::Result<Vec<Drive>> {
    Ok(host_sim::dataset::load_drives(dir)?)
}

/// The data folder a command was given, or the default one.
pub fn data_or_default(data: Option<PathBuf>) -> PathBuf {
    data.unwrap_or_else(input::data_dir)
}

/// Writes a drive in the common layout: Parquet when `path` ends in `.parquet`, else CSV.
pub fn write_drive(path: &Path, r: &host_sim::input::Replay, attack_from: Option<f64>, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    if path.extension().is_some_and(|e| e == "parquet") {
        // Built in memory (the Parquet writer needs a `Send` sink), then written whole.
        let mut buf = Vec::new();
        input::drive_parquet::write(r, attack_from, &mut buf)?;
        w.write_all(&buf)
    } else {
        input::drive_csv::write(r, attack_from, w)
    }
}
