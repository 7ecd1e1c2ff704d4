//! `live`: the detector on live inputs, JSON lines as they happen.

use detector_core::sync::SyncConfig;
use host_sim::detect;
use host_sim::input::InputError;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// SocketCAN interface (`can0`), `-` (stdin, `candump -L` text) or a file/FIFO of it.
    #[arg(long)]
    can: String,
    /// Serial device (`/dev/ttyACM0`, a pseudo-terminal), `-` (stdin) or a file/FIFO: the
    /// receiver's NMEA and/or UBX bytes, or an NMEA log with host timestamps. Without it, the
    /// fixes come from CAN (the map's GNSS fields: a receiver that reports on the bus).
    #[arg(long)]
    gnss: Option<String>,
    /// A DBC file; repeat it for several (the car's, a logger's, OBD-II).
    #[arg(long, required = true)]
    dbc: Vec<PathBuf>,
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
    /// The car's calibration record, as `detect --calibration`: read before the detector starts
    /// (none yet: this drive learns the car), saved as the board saves it (at a standstill of
    /// 2 s without an alarm, at most every 5 minutes) and at the end of input or Ctrl-C.
    #[arg(long)]
    calibration: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.can == "-" && a.gnss.as_deref() == Some("-") {
        anyhow::bail!("--can and --gnss cannot both read stdin");
    }
    if a.predictor == detect::PredictorKind::LstmF32 {
        anyhow::bail!("live runs the kinematic or the integer LSTM predictor (lstm-f32 is for fidelity checks)");
    }
    if !(a.max_wait_s.is_finite() && a.max_wait_s >= 0.0) {
        anyhow::bail!("--max-wait-s must be a non-negative number of seconds");
    }
    let prof = host_sim::input::logs::load_profile(&a.dbc, &a.map)?;
    if a.gnss.is_none() && prof.gnss.is_empty() {
        anyhow::bail!(InputError::file(&a.map, "expected --gnss, or GNSS fields (gnss_lat, gnss_lon, ...) in the map for a receiver that reports on CAN"));
    }
    let opts = host_sim::live::Options {
        profile: a.profile.as_deref().and_then(host_sim::detect::receiver_profile),
        predictor: a.predictor,
        strict_merge: a.strict_merge,
        max_wait: std::time::Duration::from_secs_f64(a.max_wait_s),
        sync: SyncConfig { max_gap_s: a.max_gap, ..SyncConfig::default() },
        profile_epochs: a.profile_epochs,
        receiver_time: a.gnss_time == "receiver",
        gnss_from_can: a.gnss.is_none(),
        calibration: a.calibration.as_ref().map(|path| host_sim::live::Calibration { stored: detect::read_calibration(path), path: path.clone() }),
    };
    let gnss = match &a.gnss {
        Some(g) => host_sim::live::GnssSource::parse(g, a.baud),
        None => host_sim::live::GnssSource::Can,
    };
    let mut out = std::io::stdout().lock();
    host_sim::live::run(host_sim::live::CanSource::parse(&a.can), gnss, &prof, &opts, &mut out)
}
