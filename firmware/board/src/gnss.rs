//! GNSS receiver input: NMEA 0183 sentences ([`crate::nmea`]) to receiver fixes.
//!
//! A fix is made from each valid RMC (position, speed over ground, course). GGA with fix quality
//! 0 invalidates the position until the next GGA with a fix; VTG supplies speed and course when
//! the RMC lacks them. GST (the receiver's own 1-sigma latitude and longitude errors) becomes the
//! fix's horizontal accuracy, `sqrt(sd_lat^2 + sd_lon^2)` as UBX's hAcc, on every RMC whose UTC
//! time is within [`GST_MAX_AGE_S`] of the GST's (receivers send GST after the epoch's RMC, so an
//! RMC takes the previous epoch's estimate). A sentence that does not parse (checksum, syntax,
//! length) is counted and dropped, never a panic.

use crate::nmea::{self, NmeaError, Sentence};
use detector_core::geo::LatLon;
use detector_core::sample::Fix;

const KNOTS_TO_MPS: f32 = 0.514_444;

/// The most a GST's UTC time may differ from an RMC's for its error estimate to be that fix's
/// accuracy, seconds: one epoch of a 1 Hz receiver, with room for one lost sentence.
pub const GST_MAX_AGE_S: f64 = 2.0;

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
    /// The last GST: (UTC seconds of the day, horizontal 1-sigma error in metres).
    gst: Option<(f64, f32)>,
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
                let h_acc_m = self.gst_for(r.time_s);
                Some(Fix { t, pos, speed_mps: r.speed_knots.map(|k| k * KNOTS_TO_MPS).or(vs), course_deg: r.course_deg.or(vc), h_acc_m, receiver_spoofing: false })
            }
            Ok(Sentence::Gga(g)) => {
                self.gga_no_fix = g.quality == 0;
                None
            }
            Ok(Sentence::Vtg(v)) => {
                self.vtg = Some((v.speed_knots.map(|k| k * KNOTS_TO_MPS), v.course_deg));
                None
            }
            Ok(Sentence::Gst(g)) => {
                let h = match (g.sd_lat_m, g.sd_lon_m) {
                    (Some(a), Some(b)) => gnss_guard_dsp::sqrtf(a * a + b * b),
                    _ => f32::NAN,
                };
                self.gst = match g.time_s {
                    Some(tod) if tod.is_finite() && h.is_finite() && h > 0.0 => Some((tod, h)),
                    _ => None,
                };
                None
            }
            Ok(Sentence::Other) => None,
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

    /// The last GST's horizontal error when its UTC time is within [`GST_MAX_AGE_S`] of `tod`
    /// (an RMC's time of day; across midnight too).
    fn gst_for(&self, tod: Option<f64>) -> Option<f32> {
        let ((g_tod, h), tod) = (self.gst?, tod?);
        let d = libm::fabs(tod - g_tod);
        (d.min(86_400.0 - d) <= GST_MAX_AGE_S).then_some(h)
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
    extern crate std;
    use std::format;

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

    /// `$<body>*<checksum>`.
    fn sentence(body: &str) -> heapless::Vec<u8, 128> {
        let sum = body.bytes().fold(0u8, |a, b| a ^ b);
        let mut v = heapless::Vec::new();
        for b in b"$".iter().chain(body.as_bytes()).chain(b"*") {
            v.push(*b).unwrap();
        }
        for nib in [sum >> 4, sum & 15] {
            v.push(b"0123456789ABCDEF"[nib as usize]).unwrap();
        }
        v
    }

    #[test]
    fn gst_gives_the_next_fixes_their_accuracy_while_it_is_recent() {
        let rmc = |hms: &str| sentence(&format!("GPRMC,{hms},A,3743.25986,N,12228.33832,W,15.207,2.14,020818,,,A"));
        let mut n = NmeaFixer::default();
        assert_eq!(n.line(0.0, &rmc("083447.00")).unwrap().h_acc_m, None, "no GST yet");
        assert!(n.line(0.0, &sentence("GPGST,083447.00,1.5,3.0,2.0,45.0,1.2,1.6,3.1")).is_none());
        let h = n.line(1.0, &rmc("083448.00")).unwrap().h_acc_m.unwrap();
        assert!((h - 2.0).abs() < 1e-6, "sqrt(1.2^2 + 1.6^2) = 2, got {h}");
        assert_eq!(n.line(2.0, &rmc("083449.00")).unwrap().h_acc_m, Some(h), "2 s: still recent");
        assert_eq!(n.line(3.0, &rmc("083450.00")).unwrap().h_acc_m, None, "3 s old: stale");
        // Across midnight, and a GST without its errors clears the estimate.
        n.line(4.0, &sentence("GPGST,235959.50,,,,,0.3,0.4,"));
        assert_eq!(n.line(5.0, &rmc("000000.50")).unwrap().h_acc_m, Some(0.5));
        n.line(6.0, &sentence("GPGST,000001.00,,,,,,,"));
        assert_eq!(n.line(7.0, &rmc("000001.00")).unwrap().h_acc_m, None);
        assert_eq!(n.counters.rejected, 0);
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
