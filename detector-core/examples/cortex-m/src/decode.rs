//! The integrator's own input decoding: this car's two CAN messages, and NMEA RMC.
//! (The firmware generates its CAN decoding from a DBC and has a full NMEA parser; an
//! integrator brings whatever their car and receiver need.)

use crate::car::{Frame, ID_STEER_PEDAL, ID_WHEEL_SPEED};
use detector_core::geo::LatLon;
use detector_core::sample::{Fix, Signal};

/// The detector signals in one frame: wheel speed m/s; steering degrees + left; pedal %.
pub fn can(f: &Frame) -> heapless::Vec<(Signal, f32), 2> {
    let mut out = heapless::Vec::new();
    let [a, b, c, ..] = f.data;
    match f.id {
        ID_WHEEL_SPEED => {
            let _ = out.push((Signal::WheelSpeed, u16::from_le_bytes([a, b]) as f32 * 0.01 / 3.6));
        }
        ID_STEER_PEDAL => {
            let _ = out.push((Signal::Steering, i16::from_le_bytes([a, b]) as f32 * 0.1));
            let _ = out.push((Signal::Pedal, c as f32 * 0.5));
        }
        _ => {}
    }
    out
}

/// A fix from an RMC sentence with a valid checksum and status `A`, timed at its arrival `t`.
pub fn rmc(t: f64, sentence: &str) -> Option<Fix> {
    let body = sentence.strip_prefix('$')?;
    let (body, sum) = body.split_once('*')?;
    if u8::from_str_radix(sum.trim(), 16).ok()? != body.bytes().fold(0u8, |a, b| a ^ b) {
        return None;
    }
    let mut f = body.split(',');
    if !f.next()?.ends_with("RMC") {
        return None;
    }
    let _time = f.next()?;
    if f.next()? != "A" {
        return None;
    }
    let lat = degrees(f.next()?, 2)? * if f.next()? == "S" { -1.0 } else { 1.0 };
    let lon = degrees(f.next()?, 3)? * if f.next()? == "W" { -1.0 } else { 1.0 };
    let speed_mps = f.next()?.parse::<f32>().ok().map(|kn| kn * 0.514_444);
    let course_deg = f.next()?.parse::<f32>().ok();
    Some(Fix { t, pos: LatLon::new(lat, lon), speed_mps, course_deg, ..Fix::default() })
}

/// `ddmm.mmmm` (or `dddmm.mmmm`) as degrees.
fn degrees(field: &str, deg_digits: usize) -> Option<f64> {
    let d: f64 = field.get(..deg_digits)?.parse().ok()?;
    let m: f64 = field.get(deg_digits..)?.parse().ok()?;
    Some(d + m / 60.0)
}
