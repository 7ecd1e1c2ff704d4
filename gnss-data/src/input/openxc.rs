//! OpenXC vehicle-interface traces: one `TIMESTAMP: {"name": ..., "value": ...}` line per event.
//!
//! Used: `vehicle_speed` (km/h), `steering_wheel_angle` (deg; OpenXC counts + to the right, so
//! the sign is flipped to our + = left, as the common CSV does), `accelerator_pedal_position` (%),
//! and `latitude` / `longitude`, which arrive as separate events: a fix is made when both have
//! arrived within [`PAIR_WINDOW_S`] of each other, at the later one's time. OpenXC reports no GNSS
//! speed or course. Other names (engine speed, odometer, door status, ...) are ignored.

use super::drive::{Event, Format, InputError, LoadOptions, Replay};
use detector_core::geo::LatLon;
use detector_core::sample::{Fix, Signal};
use std::io::BufRead;
use std::path::Path;

/// Latitude and longitude events further apart than this are not one fix.
pub const PAIR_WINDOW_S: f64 = 0.5;

#[derive(serde::Deserialize)]
struct Msg {
    name: String,
    value: serde_json::Value,
}

pub fn load(path: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    let f = std::fs::File::open(path).map_err(|e| InputError::file(path, format!("cannot open: {e}")))?;
    let mut events = Vec::new();
    let mut skipped = 0;
    // (time, degrees) of the latest unpaired latitude and longitude events
    let mut lat: Option<(f64, f64)> = None;
    let mut lon: Option<(f64, f64)> = None;
    let mut last_t = f64::NEG_INFINITY;
    for (i, line) in std::io::BufReader::new(f).lines().enumerate() {
        let n = i as u64 + 1;
        let line = line.map_err(|e| InputError::line(path, n, format!("unreadable line: {e}")))?;
        if line.trim().is_empty() {
            continue;
        }
        let parsed = parse_line(&line, last_t);
        let (t, msg) = match parsed {
            Ok(x) => x,
            Err(m) if opts.skip_bad_rows => {
                let _ = m;
                skipped += 1;
                continue;
            }
            Err(m) => return Err(InputError::line(path, n, m)),
        };
        last_t = t;
        let Some(v) = msg.value.as_f64() else { continue };
        let obs = |sig, v: f64| Event::Obs { sig, t, v: v as f32 };
        match msg.name.as_str() {
            "vehicle_speed" => events.push(obs(Signal::WheelSpeed, v / 3.6)),
            "steering_wheel_angle" => events.push(obs(Signal::Steering, -v)),
            "accelerator_pedal_position" => events.push(obs(Signal::Pedal, v)),
            "latitude" => lat = Some((t, v)),
            "longitude" => lon = Some((t, v)),
            _ => continue,
        }
        if let (Some((ta, a)), Some((tb, b))) = (lat, lon) {
            if (ta - tb).abs() <= PAIR_WINDOW_S {
                let pos = LatLon::new(a, b);
                if !pos.is_valid() {
                    if opts.skip_bad_rows {
                        skipped += 1;
                    } else {
                        return Err(InputError::line(path, n, format!(
                            "expected latitude in [-90, 90] and longitude in [-180, 180], found {a}, {b}")));
                    }
                } else {
                    events.push(Event::Fix(Fix { t: ta.max(tb), pos, speed_mps: None, course_deg: None, h_acc_m: None, receiver_spoofing: false }));
                }
                lat = None;
                lon = None;
            }
        }
    }
    if !events.iter().any(|e| matches!(e, Event::Fix(_))) {
        return Err(InputError::file(path, "no GNSS fix: expected latitude and longitude events"));
    }
    Ok(Replay::new(path, Format::OpenXc, events, skipped))
}

fn parse_line(line: &str, last_t: f64) -> Result<(f64, Msg), String> {
    let (ts, json) = line
        .split_once(':')
        .ok_or_else(|| format!("expected `TIMESTAMP: {{json}}`, found {:?}", truncate(line)))?;
    let t: f64 = ts.trim().parse().map_err(|_| format!("expected a UNIX timestamp before `:`, found {:?}", truncate(ts)))?;
    if !t.is_finite() {
        return Err("expected a finite timestamp".into());
    }
    if t < last_t {
        return Err(format!("time goes backwards: {t} after {last_t}; expected non-decreasing timestamps"));
    }
    let msg: Msg = serde_json::from_str(json.trim())
        .map_err(|e| format!("expected a JSON object with `name` and `value`: {e}"))?;
    if let Some(v) = msg.value.as_f64() {
        if !v.is_finite() {
            return Err(format!("`{}`: expected a finite value", msg.name));
        }
    }
    Ok((t, msg))
}

fn truncate(s: &str) -> String {
    s.chars().take(60).collect()
}
