//! `gnss_guard._gnss_guard`: the detector for Python. Every function calls the same library
//! code `host-sim` runs (drive loading, synchronisation, the core's detector, attacks, nuisances,
//! the evaluation), so a drive gives the same verdicts, bit for bit, from Python and from the
//! command line. Tables cross the boundary as Parquet bytes (the package's Python side converts
//! pandas and pyarrow tables), read by the same reader as a Parquet drive on disk. The Python
//! wrapper (`gnss_guard/__init__.py`) is the documented interface; this module is its engine.

use gnss_data::attack::{AttackKind, AttackParams};
use gnss_data::input::{drive_parquet, logs, InputError as DriveError, LoadOptions, Replay};
use gnss_data::nuisance::{Nuisance, NuisanceKind};
use host_sim::detect::{self, DetectOptions, PredictorKind};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::{Path, PathBuf};
use std::time::Instant;

create_exception!(
    _gnss_guard,
    InputError,
    PyValueError,
    "A drive, log or table that is not what was expected; the message names the file (`<table>` for \
     an in-memory table), the row, line or column, and what was expected."
);

fn input_error(e: DriveError) -> PyErr {
    InputError::new_err(e.to_string())
}

fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

fn predictor_kind(name: &str) -> PyResult<PredictorKind> {
    match name {
        "lstm" => Ok(PredictorKind::Lstm),
        "kinematic" => Ok(PredictorKind::Kinematic),
        _ => Err(value_error(format!("predictor: expected 'lstm' or 'kinematic', found {name:?}"))),
    }
}

fn receiver_profile(name: Option<&str>) -> PyResult<Option<&'static detector_core::profile::ReceiverProfile>> {
    match name {
        None => Ok(None),
        Some(x) => detect::receiver_profile(x).map(Some).ok_or_else(|| value_error(format!("profile: expected 'ublox-10hz' or 'logger-1hz', found {x:?}"))),
    }
}

fn record(bytes: Option<&[u8]>) -> PyResult<Option<detector_core::wire::calibration::Record>> {
    match bytes {
        None => Ok(None),
        Some(b) => detector_core::wire::calibration::Record::decode(b).map(Some).map_err(|e| value_error(format!("calibration: not a valid record: {e:?}"))),
    }
}

/// What `detect` hands back: the verdicts as Parquet bytes, the summary as JSON, the digest, and
/// the calibration record the drive leaves (None: nothing to store).
type Detected = (Py<PyBytes>, String, String, Option<Py<PyBytes>>);

/// `judge`'s input: the drive and the seconds its reading took.
struct Loaded {
    replay: Replay,
    read_s: f64,
}

fn timed<E>(f: impl FnOnce() -> Result<Replay, E>) -> Result<Loaded, E> {
    let t0 = Instant::now();
    let replay = f()?;
    Ok(Loaded { replay, read_s: t0.elapsed().as_secs_f64() })
}

/// The detector's options, checked before any input is read.
struct Judging {
    profile: Option<&'static detector_core::profile::ReceiverProfile>,
    predictor: PredictorKind,
    stored: Option<detector_core::wire::calibration::Record>,
    verdicts: bool,
}

impl Judging {
    fn new(profile: Option<&str>, predictor: &str, calibration: Option<&[u8]>, verdicts: bool) -> PyResult<Self> {
        Ok(Judging { profile: receiver_profile(profile)?, predictor: predictor_kind(predictor)?, stored: record(calibration)?, verdicts })
    }
}

fn judge(py: Python<'_>, l: Loaded, o: Judging) -> PyResult<Detected> {
    let Judging { profile, predictor, stored, verdicts } = o;
    let r = l.replay;
    let (table, summary, digest, learnt) = py
        .detach(|| -> Result<_, String> {
            let d = detect::detect_replay(&r, &DetectOptions { profile, predictor, stored: stored.as_ref(), ..DetectOptions::default() });
            let t1 = Instant::now();
            let mut buf = Vec::new();
            if verdicts {
                host_sim::verdict_table::write_parquet(&d.verdicts, &mut buf).map_err(|e| e.to_string())?;
            }
            let write_s = t1.elapsed().as_secs_f64();
            let duration = match (d.verdicts.first(), d.verdicts.last()) {
                (Some(a), Some(b)) => b.t - a.t,
                _ => 0.0,
            };
            let summary = serde_json::json!({
                "summary": d.summary,
                "digest": d.digest,
                "format": r.format.name(),
                "duration_s": duration,
                "judged_s": detect::judged_s(&d.verdicts),
                "timing": { "read_s": l.read_s, "sync_s": d.sync_s, "detector_s": d.core_s, "write_s": write_s },
            });
            Ok((buf, summary.to_string(), d.digest, d.learnt.map(|x| x.encode())))
        })
        .map_err(value_error)?;
    Ok((PyBytes::new(py, &table).unbind(), summary, digest, learnt.map(|b| PyBytes::new(py, &b).unbind())))
}

fn table_replay(parquet: &[u8], name: &str, skip_bad_rows: bool) -> PyResult<Replay> {
    drive_parquet::load_bytes(Path::new(name), parquet.to_vec(), &LoadOptions { skip_bad_rows, ..LoadOptions::default() }).map_err(input_error)
}

/// Judges a drive given as a table in the common layout (Parquet bytes).
#[pyfunction]
#[pyo3(signature = (parquet, name = "<table>", profile = None, predictor = "lstm", calibration = None, skip_bad_rows = false, verdicts = true))]
#[allow(clippy::too_many_arguments, reason = "the Python signature's keyword arguments")]
fn detect_table(py: Python<'_>, parquet: &[u8], name: &str, profile: Option<&str>, predictor: &str, calibration: Option<&[u8]>, skip_bad_rows: bool, verdicts: bool) -> PyResult<Detected> {
    let o = Judging::new(profile, predictor, calibration, verdicts)?;
    let l = timed(|| table_replay(parquet, name, skip_bad_rows))?;
    judge(py, l, o)
}

/// Judges a drive on disk, in any format `host-sim detect` reads (CSV, Parquet, comma2k19,
/// OpenXC, HDD, a logs folder).
#[pyfunction]
#[pyo3(signature = (path, profile = None, predictor = "lstm", calibration = None, skip_bad_rows = false, verdicts = true))]
#[allow(clippy::too_many_arguments, reason = "the Python signature's keyword arguments")]
fn detect_path(py: Python<'_>, path: PathBuf, profile: Option<&str>, predictor: &str, calibration: Option<&[u8]>, skip_bad_rows: bool, verdicts: bool) -> PyResult<Detected> {
    let o = Judging::new(profile, predictor, calibration, verdicts)?;
    let l = py.detach(|| timed(|| gnss_data::input::load(&path, &LoadOptions { skip_bad_rows, ..LoadOptions::default() }))).map_err(input_error)?;
    judge(py, l, o)
}

/// Judges one's own car's logs: a CAN log (candump, ASC, BLF, MF4 or a folder of one session's
/// MF4 files), a GNSS log (or none, with GNSS on CAN), DBCs and a map.
#[pyfunction]
#[pyo3(signature = (can, dbc, map, gnss = None, profile = None, predictor = "lstm", calibration = None, skip_bad_rows = false, verdicts = true))]
#[allow(clippy::too_many_arguments, reason = "the Python signature's keyword arguments")]
fn detect_logs(py: Python<'_>, can: PathBuf, dbc: Vec<PathBuf>, map: PathBuf, gnss: Option<PathBuf>, profile: Option<&str>, predictor: &str, calibration: Option<&[u8]>, skip_bad_rows: bool, verdicts: bool) -> PyResult<Detected> {
    let o = Judging::new(profile, predictor, calibration, verdicts)?;
    let l = py
        .detach(|| {
            timed(|| -> Result<Replay, DriveError> {
                let p = logs::load_profile(&dbc, &map)?;
                logs::load(&can, gnss.as_deref(), &p, &LoadOptions { skip_bad_rows, ..LoadOptions::default() })
            })
        })
        .map_err(input_error)?;
    judge(py, l, o)
}

fn attack_params(json: &str) -> PyResult<AttackParams> {
    let v: serde_json::Value = serde_json::from_str(json).map_err(|e| value_error(format!("attack parameters: {e}")))?;
    let f = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
    let b = |k: &str| v.get(k).and_then(serde_json::Value::as_bool);
    const KNOWN: [&str; 9] = ["offset_m", "bearing_deg", "speed_mps", "rate_mps", "across", "step_m", "deg_per_s", "delay_s", "right"];
    if let Some(bad) = v.as_object().and_then(|o| o.keys().find(|k| !KNOWN.contains(&k.as_str()))) {
        return Err(value_error(format!("attack parameter {bad:?}: expected one of {KNOWN:?}")));
    }
    Ok(AttackParams {
        offset_m: f("offset_m"),
        bearing_deg: f("bearing_deg"),
        speed_mps: f("speed_mps"),
        rate_mps: f("rate_mps"),
        across: b("across"),
        step_m: f("step_m"),
        deg_per_s: f("deg_per_s"),
        delay_s: f("delay_s"),
        right: b("right"),
    })
}

/// An attacked copy of a drive table: the drive in the common layout with `attack_active`
/// (Parquet bytes), and the attack as applied (JSON: kind, seed, onset, parameters).
#[pyfunction]
#[pyo3(signature = (parquet, kind, seed = 1, onset = None, params = "{}", name = "<table>"))]
fn attack_table(py: Python<'_>, parquet: &[u8], kind: &str, seed: u64, onset: Option<f64>, params: &str, name: &str) -> PyResult<(Py<PyBytes>, String)> {
    let k = AttackKind::from_name(kind).ok_or_else(|| value_error(format!("kind: expected one of {:?}, found {kind:?}", AttackKind::ALL.map(AttackKind::name))))?;
    let p = attack_params(params)?;
    let r = table_replay(parquet, name, false)?;
    let (bytes, spec) = py
        .detach(|| -> Result<_, String> {
            let at = host_sim::transform::attack(&r, k, seed, onset, &p, detector_core::sync::SyncConfig::default())?;
            let mut buf = Vec::new();
            drive_parquet::write(&at.replay, Some(at.spec.onset_t), &mut buf).map_err(|e| e.to_string())?;
            Ok((buf, serde_json::to_string(&at.spec).map_err(|e| e.to_string())?))
        })
        .map_err(|e| InputError::new_err(format!("{name}: {e}")))?;
    Ok((PyBytes::new(py, &bytes).unbind(), spec))
}

fn nuisance_params(json: &str) -> PyResult<Nuisance> {
    let v: serde_json::Value = serde_json::from_str(json).map_err(|e| value_error(format!("nuisance parameters: {e}")))?;
    let f = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
    const KNOWN: [&str; 12] = ["pos_delay_s", "vel_delay_s", "vel_1hz_lag_s", "wheel_scale", "gyro_bias_degps", "gyro_scale", "rate_switch_s", "jitter_s", "outages", "vehicle_delay_s", "steering_step_deg", "gnss_noise"];
    if let Some(bad) = v.as_object().and_then(|o| o.keys().find(|k| !KNOWN.contains(&k.as_str()))) {
        return Err(value_error(format!("nuisance parameter {bad:?}: expected one of {KNOWN:?}")));
    }
    let pair = |x: &serde_json::Value| -> Option<(f64, f64)> { Some((x.get(0)?.as_f64()?, x.get(1)?.as_f64()?)) };
    let outages = v.get("outages").and_then(|o| o.as_array()).map(|a| a.iter().filter_map(pair).collect()).unwrap_or_default();
    Ok(Nuisance {
        pos_delay_s: f("pos_delay_s"),
        vel_delay_s: f("vel_delay_s"),
        vel_1hz_lag_s: f("vel_1hz_lag_s"),
        wheel_scale: f("wheel_scale"),
        wheel_quantised: f("wheel_scale").is_some(),
        gyro_bias_degps: f("gyro_bias_degps"),
        gyro_scale: f("gyro_scale"),
        rate_switch_s: f("rate_switch_s"),
        jitter_s: f("jitter_s"),
        outages,
        vehicle_delay_s: f("vehicle_delay_s"),
        steering_step_deg: f("steering_step_deg"),
        gnss_noise: v.get("gnss_noise").and_then(pair),
    })
}

/// A drive table transformed as a new installation differs (not an attack): Parquet bytes,
/// and what was applied.
#[pyfunction]
#[pyo3(signature = (parquet, kind = "combined", seed = 1, params = "{}", name = "<table>"))]
fn nuisance_table(py: Python<'_>, parquet: &[u8], kind: &str, seed: u64, params: &str, name: &str) -> PyResult<(Py<PyBytes>, String)> {
    let k = NuisanceKind::from_name(kind).ok_or_else(|| value_error(format!("kind: expected one of {:?}, found {kind:?}", NuisanceKind::ALL.map(NuisanceKind::name))))?;
    let given = nuisance_params(params)?;
    let r = table_replay(parquet, name, false)?;
    let (bytes, what) = py
        .detach(|| -> Result<_, String> {
            let (t, n) = host_sim::transform::nuisance(&r, k, seed, given, detector_core::sync::SyncConfig::default());
            let mut buf = Vec::new();
            drive_parquet::write(&t, None, &mut buf).map_err(|e| e.to_string())?;
            Ok((buf, n.describe()))
        })
        .map_err(value_error)?;
    Ok((PyBytes::new(py, &bytes).unbind(), what))
}

/// The evaluation of `host-sim eval` on a data folder (with `drives/`, or a folder of drives):
/// the report as JSON; with `out`, report.json, report.md and the figures written there too.
#[pyfunction]
#[pyo3(signature = (data, scenarios = 10, seed = 1, nuisance_variants = 8, protocol = "loso", predictor = "lstm", out = None))]
#[allow(clippy::too_many_arguments, reason = "the Python signature's keyword arguments")]
fn evaluate(py: Python<'_>, data: PathBuf, scenarios: usize, seed: u64, nuisance_variants: usize, protocol: &str, predictor: &str, out: Option<PathBuf>) -> PyResult<String> {
    let protocol = match protocol {
        "loso" => host_sim::eval::Protocol::LeaveOneSourceOut,
        "in-sample" => host_sim::eval::Protocol::InSample,
        x => return Err(value_error(format!("protocol: expected 'loso' or 'in-sample', found {x:?}"))),
    };
    let predictor = predictor_kind(predictor)?;
    py.detach(|| -> PyResult<String> {
        let dir = if data.join("drives").is_dir() { data.join("drives") } else { data.clone() };
        let drives = host_sim::dataset::load_drives(&dir).map_err(input_error)?;
        let o = host_sim::eval::EvalOptions { scenarios, seed, predictor, protocol, ..Default::default() };
        let r = host_sim::eval::full(drives, &o, "real", &data.display().to_string(), nuisance_variants, &|| {});
        if let Some(out) = out {
            host_sim::eval::report::write_all(&r, &out).map_err(|e| value_error(format!("{}: {e}", out.display())))?;
        }
        serde_json::to_string(&r).map_err(|e| value_error(e.to_string()))
    })
}

/// The engine's version (the crate's).
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _gnss_guard(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add_function(wrap_pyfunction!(detect_table, m)?)?;
    m.add_function(wrap_pyfunction!(detect_path, m)?)?;
    m.add_function(wrap_pyfunction!(detect_logs, m)?)?;
    m.add_function(wrap_pyfunction!(attack_table, m)?)?;
    m.add_function(wrap_pyfunction!(nuisance_table, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
