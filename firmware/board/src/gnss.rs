//! GNSS receiver input: NMEA 0183 sentences ([`crate::nmea`]) to receiver fixes.
//!
//! A fix is made from each valid RMC (position, speed over ground, course). GGA with fix quality
//! 0 invalidates the position until the next GGA with a fix; VTG supplies speed and course when
//! the RMC lacks them. A sentence that does not parse (checksum, syntax, length) is counted and
//! dropped, never a panic.

use crate::nmea::{self, NmeaError, Sentence};
use detector_core::geo::LatLon;
use detector_core::sample::Fix;

const KNOTS_TO_MPS: f32 = 0.514_444;

pub use crate::nmea::MAX_SENTENCE;

/// Sentences and fixes wrap at `u32::MAX`; the error counters saturate there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GnssCounters {
    pub sentences: u32,
    pub fixes: u32,
    pub rejected: u32,
    pub overlong: u32,
}

/// Turns NMEA lines into fixes.
#[derive(Clone, Debug, Default)]
pub struct NmeaFixer {
    gga_no_fix: bool,
    vtg: Option<(Option<f32>, Option<f32>)>,
    pub counters: GnssCounters,
}

impl NmeaFixer {
    /// One sentence (without line ending) received at time `t`. Returns a fix for a valid RMC.
    pub fn line(&mut self, t: f64, line: &[u8]) -> Option<Fix> {
        self.counters.sentences = self.counters.sentences.wrapping_add(1);
        match nmea::parse(line) {
            Ok(Sentence::Rmc(r)) => {
                let (Some(lat), Some(lon), true) = (r.lat_deg, r.lon_deg, r.valid && !self.gga_no_fix) else { return None };
                let pos = LatLon::new(lat, lon);
                if !pos.is_valid() {
                    self.counters.rejected = self.counters.rejected.saturating_add(1);
                    return None;
                }
                let (vs, vc) = self.vtg.take().unwrap_or((None, None));
                self.counters.fixes = self.counters.fixes.wrapping_add(1);
                Some(Fix { t, pos, speed_mps: r.speed_knots.map(|k| k * KNOTS_TO_MPS).or(vs), course_deg: r.course_deg.or(vc), h_acc_m: None, receiver_spoofing: false })
            }
            Ok(Sentence::Gga(g)) => {
                self.gga_no_fix = g.quality == 0;
                None
            }
            Ok(Sentence::Vtg(v)) => {
                self.vtg = Some((v.speed_knots.map(|k| k * KNOTS_TO_MPS), v.course_deg));
                None
            }
            Ok(Sentence::Gst(_) | Sentence::Other) => None,
            Err(NmeaError::TooLong) => {
                self.counters.overlong = self.counters.overlong.saturating_add(1);
                None
            }
            Err(_) => {
                self.counters.rejected = self.counters.rejected.saturating_add(1);
                None
            }
        }
    }
}

/// Splits a byte stream (UART) into sentences: `$...` up to CR or LF. Overlong input is dropped
/// up to the next line end and counted.
#[derive(Clone, Debug, Default)]
pub struct LineSplitter {
    buf: heapless::Vec<u8, MAX_SENTENCE>,
    overflow: bool,
    pub dropped: u32,
}

impl LineSplitter {
    /// Feeds bytes; calls `f` with every complete line.
    pub fn push(&mut self, bytes: &[u8], mut f: impl FnMut(&[u8])) {
        for &b in bytes {
            match b {
                b'\r' | b'\n' => {
                    if !self.overflow && self.buf.first() == Some(&b'$') {
                        f(&self.buf);
                    }
                    self.buf.clear();
                    self.overflow = false;
                }
                b'$' => {
                    // A new sentence always starts here (recovers from a lost line end).
                    if !self.buf.is_empty() {
                        self.dropped = self.dropped.saturating_add(1);
                    }
                    self.buf.clear();
                    self.overflow = false;
                    let _ = self.buf.push(b);
                }
                _ => {
                    if self.buf.push(b).is_err() && !self.overflow {
                        self.overflow = true;
                        self.dropped = self.dropped.saturating_add(1);
                    }
                }
            }
        }
    }

    /// After a UART overrun or framing error: the partial line is unusable.
    pub fn discard_partial(&mut self) {
        if !self.buf.is_empty() {
            self.dropped = self.dropped.saturating_add(1);
        }
        self.buf.clear();
        self.overflow = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmc_gives_a_fix_with_speed_and_course() {
        let mut n = NmeaFixer::default();
        let f = n.line(1.0, b"$GPRMC,083447.00,A,3743.25986,N,12228.33832,W,15.207,2.14,020818,,,A*44").unwrap();
        assert!((f.pos.lat_deg - 37.720_997_7).abs() < 1e-6, "{}", f.pos.lat_deg);
        assert!((f.pos.lon_deg + 122.472_305_3).abs() < 1e-6);
        assert!((f.speed_mps.unwrap() - 7.823).abs() < 0.01);
        assert_eq!(f.course_deg, Some(2.14));
        assert!(n.line(1.0, b"$GPRMC,garbage*00").is_none());
        assert!(n.line(1.0, &[0xFF, 0xFE]).is_none());
        assert_eq!(n.counters.rejected, 2);
    }

    #[test]
    fn splitter_recovers_from_noise() {
        let mut s = LineSplitter::default();
        let mut lines = 0;
        s.push(b"junk\r\n$GPRMC,1*00\r\n$GPGGA,2", |_| lines += 1);
        s.push(&[b'x'; 300], |_| lines += 1);
        s.push(b"\n$GPVTG,3*00\n", |_| lines += 1);
        assert_eq!(lines, 2, "RMC and VTG; the junk line and the overlong GGA are dropped");
        assert_eq!(s.dropped, 1);
    }
}
