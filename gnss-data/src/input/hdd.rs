//! The Honda Research Institute Driving Dataset session layout:
//! `<session>/general/csv/<sensor>.csv`, each with a `# unix_timestamp` first column.
//!
//! Header-driven: columns are found by name (case-insensitive, `#` and spaces ignored), never by
//! position. Read:
//!
//! | file | column | signal | default unit |
//! |---|---|---|---|
//! | `rtk_pos.csv` (required) | `lat`, `lng` (or `lon`) | GNSS fix | degrees |
//! | `rtk_track.csv` | `GPS_course` | GNSS course | degrees, 0 = north, clockwise |
//! | `vel.csv` | `speed` | wheel speed | km/h ([`HddUnits::speed_scale`]) |
//! | `steer.csv` | `steer_angle` | steering wheel angle | degrees, + = left ([`HddUnits::steer_sign`]) |
//! | `accel_pedal.csv` | `pedalangle(percent)` | accelerator pedal | percent |
//! | `yaw.csv` | `yaw(degree/s)` | yaw rate | deg/s, + = left |
//!
//! Timestamps are UNIX seconds; values above 1e11 are taken as milliseconds. A few HDD sessions
//! have `lat` and `lng` swapped: when every `lat` value lies outside [-90, 90] while every `lng`
//! value lies inside, the columns are swapped back and the replay notes it (from ranges alone a
//! swap cannot be seen where |longitude| <= 90).

use super::drive::{parse_opt_f64, Event, Format, InputError, LoadOptions, Replay};
use detector_core::geo::LatLon;
use detector_core::sample::{Fix, Signal};
use std::path::Path;

type Row = (f64, Vec<Option<f64>>);

struct Table {
    rows: Vec<Row>,
}

fn norm(h: &str) -> String {
    h.trim().trim_start_matches('#').trim().to_ascii_lowercase()
}

/// Reads `file`, keeping the time and the named columns (each a list of accepted names).
fn read_table(file: &Path, cols: &[&[&str]], opts: &LoadOptions, skipped: &mut usize) -> Result<Table, InputError> {
    let mut rdr = csv::ReaderBuilder::new().flexible(true).from_path(file)
        .map_err(|e| InputError::file(file, format!("cannot open: {e}")))?;
    let headers: Vec<String> = rdr.headers().map_err(|e| InputError::line(file, 1, format!("expected a CSV header: {e}")))?
        .iter().map(norm).collect();
    if headers.first().map(String::as_str) != Some("unix_timestamp") {
        return Err(InputError::line(file, 1, format!("expected `# unix_timestamp` as the first column, found {:?}", headers.first())));
    }
    let mut idx = Vec::new();
    for names in cols {
        let i = headers.iter().position(|h| names.iter().any(|n| h == &n.to_ascii_lowercase()))
            .ok_or_else(|| InputError::line(file, 1, format!("missing column: expected one of {names:?}, header has {headers:?}")))?;
        idx.push(i);
    }
    let mut rows = Vec::new();
    let mut last = f64::NEG_INFINITY;
    let mut rec = csv::StringRecord::new();
    loop {
        let line = rdr.position().line();
        let row: Result<Option<Row>, String> = match rdr.read_record(&mut rec) {
            Ok(false) => break,
            Err(e) => Err(format!("unreadable CSV row: {e}")),
            Ok(true) if rec.len() != headers.len() => Err(format!("expected {} fields as in the header, found {} (truncated row?)", headers.len(), rec.len())),
            Ok(true) => (|| {
                let t = parse_opt_f64(&rec[0]).map_err(|e| format!("column `unix_timestamp`: {e}"))?
                    .ok_or("column `unix_timestamp`: expected a time, found nothing")?;
                let t = if t > 1e11 { t / 1000.0 } else { t };
                if !t.is_finite() || t < last {
                    return Err(format!("time goes backwards: {t} after {last}; expected non-decreasing timestamps"));
                }
                let vals = idx.iter().map(|&i| parse_opt_f64(&rec[i]).map_err(|e| format!("column `{}`: {e}", headers[i])))
                    .collect::<Result<Vec<_>, _>>()?;
                Ok(Some((t, vals)))
            })(),
        };
        match row {
            Ok(Some(r)) => { last = r.0; rows.push(r); }
            Ok(None) => {}
            Err(_) if opts.skip_bad_rows => *skipped += 1,
            Err(m) => return Err(InputError::line(file, line, m)),
        }
    }
    Ok(Table { rows })
}

pub fn load(session: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    let dir = session.join("general").join("csv");
    let mut skipped = 0;
    let pos_file = dir.join("rtk_pos.csv");
    if !pos_file.is_file() {
        return Err(InputError::file(&pos_file, "expected the GNSS position file rtk_pos.csv in general/csv/"));
    }
    let pos = read_table(&pos_file, &[&["lat"], &["lng", "lon"]], opts, &mut skipped)?;
    let fin = |v: &Option<f64>| v.is_some_and(f64::is_finite);
    let lat_out = pos.rows.iter().filter(|r| fin(&r.1[0])).all(|r| r.1[0].unwrap().abs() > 90.0);
    let lng_in = pos.rows.iter().filter(|r| fin(&r.1[1])).all(|r| r.1[1].unwrap().abs() <= 90.0);
    let swapped = lat_out && lng_in && pos.rows.iter().any(|r| fin(&r.1[0]));
    let mut notes = Vec::new();
    if swapped {
        notes.push("rtk_pos.csv: lat and lng columns are swapped in the file; swapped back".to_string());
    }
    let courses = match dir.join("rtk_track.csv") {
        p if p.is_file() => Some(read_table(&p, &[&["gps_course"]], opts, &mut skipped)?),
        _ => None,
    };
    let course_at = |t: f64| -> Option<f32> {
        let c = courses.as_ref()?;
        let i = c.rows.partition_point(|r| r.0 < t - 1e-3);
        let r = c.rows.get(i)?;
        ((r.0 - t).abs() < 0.05).then_some(r.1[0]? as f32)
    };
    let mut events = Vec::new();
    for (line_ix, (t, v)) in pos.rows.iter().enumerate() {
        let (a, b) = if swapped { (v[1], v[0]) } else { (v[0], v[1]) };
        let p = match (a, b) {
            (Some(a), Some(b)) if LatLon::new(a, b).is_valid() => LatLon::new(a, b),
            _ if opts.skip_bad_rows => { skipped += 1; continue; }
            _ => return Err(InputError::line(&pos_file, line_ix as u64 + 2, format!(
                "expected lat in [-90, 90] and lng in [-180, 180], found {a:?}, {b:?}"))),
        };
        events.push(Event::Fix(Fix { t: *t, pos: p, speed_mps: None, course_deg: course_at(*t), h_acc_m: None, receiver_spoofing: false }));
    }
    let u = &opts.hdd;
    let sensors: [(&str, &[&str], Signal, f64); 4] = [
        ("vel.csv", &["speed"], Signal::WheelSpeed, u.speed_scale),
        ("steer.csv", &["steer_angle"], Signal::Steering, u.steer_sign),
        ("accel_pedal.csv", &["pedalangle(percent)", "pedalangle"], Signal::Pedal, 1.0),
        ("yaw.csv", &["yaw(degree/s)", "yaw"], Signal::YawRate, 1.0),
    ];
    for (name, col, sig, scale) in sensors {
        let p = dir.join(name);
        if !p.is_file() {
            continue;
        }
        for (t, v) in read_table(&p, &[col], opts, &mut skipped)?.rows {
            if let Some(x) = v[0].filter(|x| x.is_finite()) {
                events.push(Event::Obs { sig, t, v: (x * scale) as f32 });
            }
        }
    }
    let mut r = Replay::new(session, Format::Hdd, events, skipped);
    r.notes = notes;
    Ok(r)
}
