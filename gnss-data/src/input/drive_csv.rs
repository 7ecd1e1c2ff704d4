//! The common drive CSV of `../shared/data/drives`: a 10 Hz grid, header-driven.
//!
//! Real GNSS epochs are the rows with `gnss_new_fix = 1`; the fix time is `t_s - gnss_fix_age_s`
//! (the row is the first grid point after the fix). Every finite vehicle value on a row is an
//! observation at `t_s`; an empty or `NaN` field means the source has no such signal.
//!
//! The writer (`write`) emits the same layout, optionally with an `attack_active` column.

use super::drive::{parse_opt_f64, Event, Format, InputError, LoadOptions, Replay};
use detector_core::geo::LatLon;
use detector_core::sample::{Fix, Signal};
use std::path::Path;

/// The columns of the layout, in file order.
pub const COLUMNS: [&str; 13] = [
    "t_s",
    "unix_time_s",
    "lat_deg",
    "lon_deg",
    "gnss_new_fix",
    "gnss_fix_age_s",
    "gnss_speed_mps",
    "gnss_course_deg",
    "veh_speed_mps",
    "steer_wheel_deg",
    "accel_pedal_pct",
    "long_accel_mps2",
    "yaw_rate_degps",
];

pub fn load(path: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    let mut rdr = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .map_err(|e| InputError::file(path, format!("cannot open: {e}")))?;
    let headers = rdr.headers().map_err(|e| InputError::line(path, 1, format!("expected a CSV header: {e}")))?.clone();
    let col = |name: &str| headers.iter().position(|h| h.trim() == name);
    for r in REQUIRED {
        if col(r).is_none() {
            return Err(InputError::line(path, 1, format!("missing column `{r}` (the header must name {REQUIRED:?})")));
        }
    }
    let (ct, clat, clon, cnew) = (col("t_s").unwrap(), col("lat_deg").unwrap(), col("lon_deg").unwrap(), col("gnss_new_fix").unwrap());
    let (cage, cspd, ccrs) = (col("gnss_fix_age_s"), col("gnss_speed_mps"), col("gnss_course_deg"));
    let sigs: Vec<(usize, Signal, &str)> = SIGNALS.iter().filter_map(|&(n, s)| col(n).map(|c| (c, s, n))).collect();

    let mut events = Vec::new();
    let mut skipped = 0usize;
    let mut last_t = f64::NEG_INFINITY;
    let mut rec = csv::StringRecord::new();
    loop {
        let line = rdr.position().line();
        match rdr.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let err = InputError::line(path, line, format!("unreadable CSV row: {e}"));
                if opts.skip_bad_rows { skipped += 1; continue; }
                return Err(err);
            }
        }
        match parse_row(&rec, headers.len(), ct, clat, clon, cnew, cage, cspd, ccrs, &sigs, last_t) {
            Ok((t, evs)) => {
                last_t = t;
                events.extend(evs);
            }
            Err(msg) => {
                if opts.skip_bad_rows {
                    skipped += 1;
                    continue;
                }
                return Err(InputError::line(path, line, msg));
            }
        }
    }
    if events.is_empty() {
        return Err(InputError::file(path, "no data rows: expected at least one row after the header"));
    }
    Ok(Replay::new(path, Format::DriveCsv, events, skipped))
}

/// One row's values by column (`None`: empty, `NaN`, or no such column), whatever the file's
/// format (this CSV, or Parquet with the same columns).
#[derive(Clone, Copy, Debug, Default)]
pub struct RowValues {
    /// `t_s`, `lat_deg`, `lon_deg`, `gnss_new_fix`, `gnss_fix_age_s`, `gnss_speed_mps`,
    /// `gnss_course_deg`.
    pub t: Option<f64>,
    pub lat: Option<f64>,
    pub lon: Option<f64>,
    pub new_fix: Option<f64>,
    pub age: Option<f64>,
    pub speed: Option<f64>,
    pub course: Option<f64>,
    /// The vehicle signals, in [`SIGNALS`] order.
    pub signals: [Option<f64>; 5],
}

/// The vehicle signals' columns and the detector signal each is.
pub const SIGNALS: [(&str, Signal); 5] = [
    ("veh_speed_mps", Signal::WheelSpeed),
    ("steer_wheel_deg", Signal::Steering),
    ("accel_pedal_pct", Signal::Pedal),
    ("yaw_rate_degps", Signal::YawRate),
    ("long_accel_mps2", Signal::LongAccel),
];

/// The columns a drive must have.
pub const REQUIRED: [&str; 4] = ["t_s", "lat_deg", "lon_deg", "gnss_new_fix"];

#[allow(clippy::too_many_arguments)]
fn parse_row(
    rec: &csv::StringRecord,
    ncols: usize,
    ct: usize,
    clat: usize,
    clon: usize,
    cnew: usize,
    cage: Option<usize>,
    cspd: Option<usize>,
    ccrs: Option<usize>,
    sigs: &[(usize, Signal, &str)],
    last_t: f64,
) -> Result<(f64, Vec<Event>), String> {
    if rec.len() != ncols {
        return Err(format!("expected {ncols} fields as in the header, found {} (truncated row?)", rec.len()));
    }
    let num = |c: usize, name: &str| parse_opt_f64(&rec[c]).map_err(|e| format!("column `{name}`: {e}"));
    let opt = |c: Option<usize>, name: &str| -> Result<Option<f64>, String> { c.map_or(Ok(None), |c| num(c, name)) };
    let mut v = RowValues { t: num(ct, "t_s")?, new_fix: num(cnew, "gnss_new_fix")?, ..RowValues::default() };
    // Coordinates, age, speed and course are only read on a new fix's row (as before: a bad one
    // elsewhere is not an error).
    if matches!(v.new_fix, Some(x) if x == 1.0) {
        v.lat = num(clat, "lat_deg")?;
        v.lon = num(clon, "lon_deg")?;
        v.age = opt(cage, "gnss_fix_age_s")?;
        v.speed = opt(cspd, "gnss_speed_mps")?;
        v.course = opt(ccrs, "gnss_course_deg")?;
    }
    for &(c, sig, name) in sigs {
        if let Some(k) = SIGNALS.iter().position(|(_, s)| *s == sig) {
            v.signals[k] = num(c, name)?;
        }
    }
    row_events(&v, || (rec[clat].to_string(), rec[clon].to_string()), last_t)
}

/// One row's events: a fix where `gnss_new_fix` is 1 (at `t_s - gnss_fix_age_s`), and an
/// observation per vehicle value. `coords` gives how the row wrote its coordinates, for the
/// error only (called only then: formatting them for every row would cost more than the row).
pub fn row_events(v: &RowValues, coords: impl FnOnce() -> (String, String), last_t: f64) -> Result<(f64, Vec<Event>), String> {
    let t = v.t.ok_or("column `t_s`: expected a time in seconds, found nothing")?;
    if !t.is_finite() {
        return Err("column `t_s`: expected a finite time".into());
    }
    if t < last_t {
        return Err(format!("time goes backwards: t_s = {t} after {last_t}; expected non-decreasing time"));
    }
    let mut evs = Vec::new();
    let new_fix = match v.new_fix {
        None => false,
        Some(0.0) => false,
        Some(1.0) => true,
        Some(x) => return Err(format!("column `gnss_new_fix`: expected 0 or 1, found {x}")),
    };
    if new_fix {
        let pos = match (v.lat, v.lon) {
            (Some(a), Some(b)) if LatLon::new(a, b).is_valid() => LatLon::new(a, b),
            _ => {
                let (lat, lon) = coords();
                return Err(format!(
                    "a new GNSS fix (gnss_new_fix = 1) needs coordinates: expected lat_deg in [-90, 90] and \
                     lon_deg in [-180, 180], found {lat:?}, {lon:?}"
                ));
            }
        };
        let ft = match v.age { Some(a) if (0.0..1.0).contains(&a) => t - a, _ => t };
        evs.push(Event::Fix(Fix { t: ft, pos, speed_mps: v.speed.map(|x| x as f32), course_deg: v.course.map(|x| x as f32), h_acc_m: None, receiver_spoofing: false }));
    }
    for (k, &(_, sig)) in SIGNALS.iter().enumerate() {
        if let Some(x) = v.signals[k] {
            evs.push(Event::Obs { sig, t, v: x as f32 });
        }
    }
    Ok((t, evs))
}

/// A replay as the layout's rows: one per distinct event time, the [`COLUMNS`] in order
/// (`t_s` from the first event; `unix_time_s` not known for every source, left empty;
/// `gnss_new_fix` 1 or 0; GNSS values held between fixes with `gnss_fix_age_s`; a vehicle
/// signal's value on the rows where it was observed), and `attack_active` where asked for (from
/// the time given on).
pub fn rows(r: &Replay, attack_from: Option<f64>) -> Vec<([Option<f64>; 13], Option<bool>)> {
    let t0 = r.events.first().map_or(0.0, |e| e.t());
    let mut out = Vec::new();
    let mut last_fix: Option<Fix> = None;
    let mut i = 0;
    while i < r.events.len() {
        let t = r.events[i].t();
        let mut new_fix = false;
        let mut vals: [Option<f64>; 5] = [None; 5];
        // One row per written time (`t - t0`: far from t0, distinct times can round to one).
        while i < r.events.len() && r.events[i].t() - t0 == t - t0 {
            match r.events[i] {
                Event::Fix(f) => {
                    last_fix = Some(f);
                    new_fix = true;
                }
                Event::Obs { sig, v, .. } => vals[sig.index()] = Some(v as f64),
            }
            i += 1;
        }
        let f = last_fix;
        out.push((
            [
                Some(t - t0),
                None,
                f.map(|f| f.pos.lat_deg),
                f.map(|f| f.pos.lon_deg),
                Some(if new_fix { 1.0 } else { 0.0 }),
                f.map(|f| t - f.t),
                f.and_then(|f| f.speed_mps).map(f64::from),
                f.and_then(|f| f.course_deg).map(f64::from),
                vals[Signal::WheelSpeed.index()],
                vals[Signal::Steering.index()],
                vals[Signal::Pedal.index()],
                vals[Signal::LongAccel.index()],
                vals[Signal::YawRate.index()],
            ],
            attack_from.map(|a| t >= a),
        ));
    }
    out
}

/// Writes a replay in this layout ([`rows`]), with an `attack_active` column when
/// `attack_from` is given. Reading the file back gives the same events, times counted from the
/// first, except where rows share a time: they become one row (each signal's last value).
pub fn write(r: &Replay, attack_from: Option<f64>, mut out: impl std::io::Write) -> std::io::Result<()> {
    let mut header: Vec<&str> = COLUMNS.to_vec();
    if attack_from.is_some() {
        header.push("attack_active");
    }
    writeln!(out, "{}", header.join(","))?;
    let fmt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x}"));
    for (vals, attack) in rows(r, attack_from) {
        let row: Vec<String> = vals
            .iter()
            .enumerate()
            .map(|(k, v)| if k == 4 { if *v == Some(1.0) { "1".into() } else { "0".into() } } else { fmt(*v) })
            .collect();
        write!(out, "{}", row.join(","))?;
        if let Some(a) = attack {
            write!(out, ",{}", if a { 1 } else { 0 })?;
        }
        writeln!(out)?;
    }
    Ok(())
}
