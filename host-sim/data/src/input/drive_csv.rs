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
const REQUIRED: [&str; 4] = ["t_s", "lat_deg", "lon_deg", "gnss_new_fix"];
const SIGNALS: [(&str, Signal); 5] = [
    ("veh_speed_mps", Signal::WheelSpeed),
    ("steer_wheel_deg", Signal::Steering),
    ("accel_pedal_pct", Signal::Pedal),
    ("yaw_rate_degps", Signal::YawRate),
    ("long_accel_mps2", Signal::LongAccel),
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
    let t = num(ct, "t_s")?.ok_or("column `t_s`: expected a time in seconds, found nothing")?;
    if !t.is_finite() {
        return Err("column `t_s`: expected a finite time".into());
    }
    if t < last_t {
        return Err(format!("time goes backwards: t_s = {t} after {last_t}; expected non-decreasing time"));
    }
    let mut evs = Vec::new();
    let new_fix = match num(cnew, "gnss_new_fix")? {
        None => false,
        Some(0.0) => false,
        Some(1.0) => true,
        Some(v) => return Err(format!("column `gnss_new_fix`: expected 0 or 1, found {v}")),
    };
    if new_fix {
        let lat = num(clat, "lat_deg")?;
        let lon = num(clon, "lon_deg")?;
        let pos = match (lat, lon) {
            (Some(a), Some(b)) if LatLon::new(a, b).is_valid() => LatLon::new(a, b),
            _ => return Err(format!(
                "a new GNSS fix (gnss_new_fix = 1) needs coordinates: expected lat_deg in [-90, 90] and \
                 lon_deg in [-180, 180], found {:?}, {:?}", &rec[clat], &rec[clon])),
        };
        let age = match cage { Some(c) => num(c, "gnss_fix_age_s")?, None => None };
        let ft = match age { Some(a) if (0.0..1.0).contains(&a) => t - a, _ => t };
        let speed = match cspd { Some(c) => num(c, "gnss_speed_mps")?, None => None };
        let course = match ccrs { Some(c) => num(c, "gnss_course_deg")?, None => None };
        evs.push(Event::Fix(Fix { t: ft, pos, speed_mps: speed.map(|v| v as f32), course_deg: course.map(|v| v as f32), h_acc_m: None, receiver_spoofing: false }));
    }
    for &(c, sig, name) in sigs {
        if let Some(v) = num(c, name)? {
            evs.push(Event::Obs { sig, t, v: v as f32 });
        }
    }
    Ok((t, evs))
}

/// Writes a replay in this layout: one row per distinct event time; GNSS values held between
/// fixes with `gnss_fix_age_s`; a vehicle signal's field is filled on the rows where it was
/// observed and left empty elsewhere. With `attack_active`, adds that column (1 from the time
/// given on). Reading the file back gives the same events.
pub fn write(r: &Replay, attack_from: Option<f64>, mut out: impl std::io::Write) -> std::io::Result<()> {
    let t0 = r.events.first().map_or(0.0, |e| e.t());
    let mut header: Vec<&str> = COLUMNS.to_vec();
    if attack_from.is_some() {
        header.push("attack_active");
    }
    writeln!(out, "{}", header.join(","))?;
    let mut last_fix: Option<Fix> = None;
    let fmt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x}"));
    let mut i = 0;
    while i < r.events.len() {
        let t = r.events[i].t();
        let mut new_fix = false;
        let mut vals: [Option<f64>; 5] = [None; 5];
        while i < r.events.len() && r.events[i].t() == t {
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
        let row = [
            format!("{}", t - t0),
            String::new(), // not known for every source
            fmt(f.map(|f| f.pos.lat_deg)),
            fmt(f.map(|f| f.pos.lon_deg)),
            (if new_fix { "1" } else { "0" }).to_string(),
            fmt(f.map(|f| t - f.t)),
            fmt(f.and_then(|f| f.speed_mps).map(f64::from)),
            fmt(f.and_then(|f| f.course_deg).map(f64::from)),
            fmt(vals[Signal::WheelSpeed.index()]),
            fmt(vals[Signal::Steering.index()]),
            fmt(vals[Signal::Pedal.index()]),
            fmt(vals[Signal::LongAccel.index()]),
            fmt(vals[Signal::YawRate.index()]),
        ];
        write!(out, "{}", row.join(","))?;
        if let Some(a) = attack_from {
            write!(out, ",{}", if t >= a { 1 } else { 0 })?;
        }
        writeln!(out)?;
    }
    Ok(())
}
