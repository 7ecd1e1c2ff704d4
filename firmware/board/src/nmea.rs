//! NMEA 0183 sentences, the wire format: RMC, GGA, VTG and GST into plain values.
//!
//! A small byte-level parser instead of the `nmea` crate: that crate's nom-based parser keeps
//! 17 panic paths that no optimisation removes (`unreachable!`s and `&str` slicing at char
//! boundaries; `tests/nopanic-report.py` names them), so the firmware could not be proven
//! panic-free with it. This one works on bytes, indexes nothing it has not checked, and gives
//! the same numbers for the same sentences: decimals are parsed correctly rounded, latitude and
//! longitude are `degrees + minutes / 60` (the `nmea` crate's formula), speeds and courses f32.
//! `tests/nmea_vs_pynmea2.sh` cross-checks it against `pynmea2`, an independent implementation.
//!
//! Every sentence needs `$`, a two-letter talker (GP, GN, GL, GA, BD, ...) and a valid `*hh`
//! checksum; numbers are plain decimals (`-12.5`, no exponents).

/// Longest sentence accepted (NMEA says 82 characters; some receivers send a little more).
pub const MAX_SENTENCE: usize = 128;

/// RMC: the recommended minimum fix.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rmc {
    /// UTC seconds of the day.
    pub time_s: Option<f64>,
    /// Status `A` (autonomous) or `D` (differential); `V` is a warning: not a fix.
    pub valid: bool,
    pub lat_deg: Option<f64>,
    pub lon_deg: Option<f64>,
    pub speed_knots: Option<f32>,
    /// Course over ground, degrees true.
    pub course_deg: Option<f32>,
    /// Day, month, two-digit year.
    pub date: Option<(u8, u8, u8)>,
}

/// GGA: the fix with its quality.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gga {
    pub time_s: Option<f64>,
    pub lat_deg: Option<f64>,
    pub lon_deg: Option<f64>,
    /// 0 no fix, 1 GPS, 2 DGPS, 4 RTK, 5 float RTK, 6 estimated, ...
    pub quality: u8,
    pub satellites: Option<u8>,
    pub hdop: Option<f32>,
    pub altitude_m: Option<f32>,
}

/// VTG: course and speed over ground.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vtg {
    pub course_deg: Option<f32>,
    pub speed_knots: Option<f32>,
    pub speed_kmh: Option<f32>,
}

/// GST: the receiver's own estimate of its position error (1 sigma, metres).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gst {
    pub time_s: Option<f64>,
    pub rms: Option<f32>,
    pub sd_lat_m: Option<f32>,
    pub sd_lon_m: Option<f32>,
    pub sd_alt_m: Option<f32>,
}

/// One parsed sentence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sentence {
    Rmc(Rmc),
    Gga(Gga),
    Vtg(Vtg),
    Gst(Gst),
    /// A valid sentence of another type (GSA, GSV, proprietary `$P...`, ...).
    Other,
}

/// Why a line is not a sentence we accept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmeaError {
    /// Longer than [`MAX_SENTENCE`].
    TooLong,
    /// No `$`, no talker and type, or no `*hh`.
    Framing,
    /// The checksum does not match.
    Checksum,
    /// Field `n` (1 = the first after the type) is not what the sentence type needs.
    Field(u8),
}

/// Parses one sentence (without its line ending; surrounding spaces are ignored).
pub fn parse(line: &[u8]) -> Result<Sentence, NmeaError> {
    let line = trim(line);
    if line.len() > MAX_SENTENCE {
        return Err(NmeaError::TooLong);
    }
    let [b'$', rest @ ..] = line else { return Err(NmeaError::Framing) };
    let (body, sum) = match rest.iter().rposition(|&b| b == b'*') {
        Some(i) => (rest.get(..i).unwrap_or(&[]), rest.get(i + 1..).unwrap_or(&[])),
        None => return Err(NmeaError::Framing),
    };
    let want = match sum {
        [h, l] => hex(*h).zip(hex(*l)).map(|(h, l)| h << 4 | l).ok_or(NmeaError::Framing)?,
        _ => return Err(NmeaError::Framing),
    };
    if body.iter().fold(0u8, |c, b| c ^ b) != want {
        return Err(NmeaError::Checksum);
    }
    let mut fields = body.split(|&b| b == b',');
    let head = fields.next().unwrap_or(&[]);
    if head.first() == Some(&b'P') {
        return Ok(Sentence::Other);
    }
    let kind = match head {
        [a, b, k @ ..] if a.is_ascii_uppercase() && b.is_ascii_uppercase() => k,
        _ => return Err(NmeaError::Framing),
    };
    let mut f = Fields { it: fields, n: 0 };
    Ok(match kind {
        b"RMC" => {
            let time_s = f.opt(time_of_day)?;
            let valid = match f.next() {
                b"A" | b"D" => true,
                b"V" => false,
                _ => return Err(f.err()),
            };
            let (lat_deg, lon_deg) = f.lat_lon()?;
            let speed_knots = f.opt(dec_f32)?;
            let course_deg = f.opt(dec_f32)?;
            let date = f.opt(date)?;
            Sentence::Rmc(Rmc { time_s, valid, lat_deg, lon_deg, speed_knots, course_deg, date })
        }
        b"GGA" => {
            let time_s = f.opt(time_of_day)?;
            let (lat_deg, lon_deg) = f.lat_lon()?;
            let quality = match f.next() {
                [d @ b'0'..=b'8'] => d - b'0',
                _ => return Err(f.err()),
            };
            let satellites = f.opt(|s| dec(s).filter(|v| (0.0..=255.0).contains(v) && *v == libm::floor(*v)).map(|v| v as u8))?;
            let hdop = f.opt(dec_f32)?;
            let altitude_m = f.opt(dec_f32)?;
            Sentence::Gga(Gga { time_s, lat_deg, lon_deg, quality, satellites, hdop, altitude_m })
        }
        b"VTG" => {
            let course_deg = f.opt(dec_f32)?;
            // "T", then magnetic course and "M", then knots "N", then km/h "K" (the unit letters
            // are optional in NMEA 2.3's short form: `$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K`).
            let _ = f.next();
            let _ = f.next();
            let _ = f.next();
            let speed_knots = f.opt(dec_f32)?;
            let _ = f.next();
            let speed_kmh = f.opt(dec_f32)?;
            Sentence::Vtg(Vtg { course_deg, speed_knots, speed_kmh })
        }
        b"GST" => {
            let time_s = f.opt(time_of_day)?;
            let rms = f.opt(dec_f32)?;
            let _ = f.next(); // semi-major axis
            let _ = f.next(); // semi-minor axis
            let _ = f.next(); // orientation
            let sd_lat_m = f.opt(dec_f32)?;
            let sd_lon_m = f.opt(dec_f32)?;
            let sd_alt_m = f.opt(dec_f32)?;
            Sentence::Gst(Gst { time_s, rms, sd_lat_m, sd_lon_m, sd_alt_m })
        }
        _ => Sentence::Other,
    })
}

struct Fields<'a, I: Iterator<Item = &'a [u8]>> {
    it: I,
    n: u8,
}

impl<'a, I: Iterator<Item = &'a [u8]>> Fields<'a, I> {
    /// The next field (empty when the sentence ends early).
    fn next(&mut self) -> &'a [u8] {
        self.n = self.n.saturating_add(1);
        self.it.next().unwrap_or(&[])
    }
    fn err(&self) -> NmeaError {
        NmeaError::Field(self.n)
    }
    /// An optional field: empty is `None`, anything `parse` refuses is an error.
    fn opt<T>(&mut self, parse: impl Fn(&[u8]) -> Option<T>) -> Result<Option<T>, NmeaError> {
        match self.next() {
            [] => Ok(None),
            s => parse(s).map(Some).ok_or(self.err()),
        }
    }
    /// `ddmm.mmm,N|S,dddmm.mmm,E|W`: both or neither.
    fn lat_lon(&mut self) -> Result<(Option<f64>, Option<f64>), NmeaError> {
        let lat = self.opt(|s| angle(s, 2))?;
        let ns = self.next();
        let lat = match (lat, ns) {
            (None, []) => None,
            (Some(v), b"N") => Some(v),
            (Some(v), b"S") => Some(-v),
            _ => return Err(self.err()),
        };
        let lon = self.opt(|s| angle(s, 3))?;
        let ew = self.next();
        let lon = match (lon, ew) {
            (None, []) => None,
            (Some(v), b"E") => Some(v),
            (Some(v), b"W") => Some(-v),
            _ => return Err(self.err()),
        };
        Ok(match (lat, lon) {
            (Some(a), Some(b)) => (Some(a), Some(b)),
            _ => (None, None),
        })
    }
}

fn trim(mut s: &[u8]) -> &[u8] {
    while let [b' ' | b'\t' | b'\r' | b'\n', rest @ ..] = s {
        s = rest;
    }
    while let [rest @ .., b' ' | b'\t' | b'\r' | b'\n'] = s {
        s = rest;
    }
    s
}

fn hex(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'A'..=b'F' => Some(b - b'A' + 10),
        b'a'..=b'f' => Some(b - b'a' + 10),
        _ => None,
    }
}

/// Powers of ten exactly representable in f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];

/// The digits of a plain decimal `[+-]digits[.digits]`: sign, mantissa (at most 19 digits
/// kept) and decimals.
fn digits(s: &[u8]) -> Option<(bool, u64, usize)> {
    let (neg, s) = match s {
        [b'-', r @ ..] => (true, r),
        [b'+', r @ ..] => (false, r),
        r => (false, r),
    };
    let (mut m, mut frac, mut digits, mut dot) = (0u64, 0usize, 0usize, false);
    for &b in s {
        match b {
            b'0'..=b'9' => {
                digits += 1;
                if m < 1_000_000_000_000_000_000 {
                    m = m * 10 + (b - b'0') as u64;
                    if dot {
                        frac += 1;
                    }
                } else if !dot {
                    return None; // an integer part beyond 10^19: not an NMEA number
                }
            }
            b'.' if !dot => dot = true,
            _ => return None,
        }
    }
    (digits > 0).then_some((neg, m, frac))
}

/// A plain decimal `[+-]digits[.digits]` (at least one digit). Correctly rounded while the
/// digits fit in 2^53 and there are at most 22 decimals (always, for NMEA fields).
pub fn dec(s: &[u8]) -> Option<f64> {
    let (neg, m, frac) = digits(s)?;
    let v = match POW10.get(frac) {
        Some(p) if m <= 1 << 53 => m as f64 / p,
        _ => {
            let mut v = m as f64;
            for _ in 0..frac {
                v /= 10.0;
            }
            v
        }
    };
    Some(if neg { -v } else { v })
}

/// Powers of ten exactly representable in f32.
const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// [`dec`] to f32: one FPU division (correctly rounded: both operands exact) while the digits
/// fit in 2^24 and there are at most 10 decimals (speeds, courses, DOPs: always), else through
/// [`dec`]. Soft-float f64 costs hundreds of instructions a field on the Cortex-M4.
pub fn dec_f32(s: &[u8]) -> Option<f32> {
    let (neg, m, frac) = digits(s)?;
    let v = match POW10_F32.get(frac) {
        Some(p) if m <= 1 << 24 => m as f32 / p,
        _ => dec(s)? as f32,
    };
    let v = if neg { -v } else { v };
    v.is_finite().then_some(v)
}

/// `d..dmm.mmm` with `deg_digits` degree digits: degrees + minutes / 60.
fn angle(s: &[u8], deg_digits: usize) -> Option<f64> {
    let (d, m) = (s.get(..deg_digits)?, s.get(deg_digits..)?);
    if !d.iter().all(u8::is_ascii_digit) || m.first().is_some_and(|c| *c == b'-' || *c == b'+') {
        return None;
    }
    let deg = d.iter().fold(0u32, |a, c| a * 10 + (c - b'0') as u32);
    let min = dec(m)?;
    // 60.0 comes from formatters that round 59.9999...; the `nmea` crate and pynmea2 accept it too.
    (min <= 60.0).then(|| deg as f64 + min / 60.0)
}

/// `hhmmss[.ss]` to seconds of the day.
fn time_of_day(s: &[u8]) -> Option<f64> {
    let two = |i: usize| -> Option<u32> {
        match s.get(i..i + 2)? {
            [a @ b'0'..=b'9', b @ b'0'..=b'9'] => Some(((a - b'0') * 10 + (b - b'0')) as u32),
            _ => None,
        }
    };
    let (h, m) = (two(0)?, two(2)?);
    let sec = dec(s.get(4..)?)?;
    (h < 24 && m < 60 && (0.0..61.0).contains(&sec)).then(|| (h * 3600 + m * 60) as f64 + sec)
}

/// `ddmmyy`.
fn date(s: &[u8]) -> Option<(u8, u8, u8)> {
    let two = |i: usize| -> Option<u8> {
        match s.get(i..i + 2)? {
            [a @ b'0'..=b'9', b @ b'0'..=b'9'] => Some((a - b'0') * 10 + (b - b'0')),
            _ => None,
        }
    };
    let d = (two(0)?, two(2)?, two(4)?);
    (s.len() == 6 && (1..=31).contains(&d.0) && (1..=12).contains(&d.1)).then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmc_gga_vtg_gst() {
        let Ok(Sentence::Rmc(r)) = parse(b"$GPRMC,083447.00,A,3743.25986,N,12228.33832,W,15.207,2.14,020818,,,A*44") else { panic!() };
        assert!(r.valid);
        assert_eq!(r.lat_deg, Some(37.0 + 43.25986 / 60.0));
        assert_eq!(r.lon_deg, Some(-(122.0 + 28.33832 / 60.0)));
        assert_eq!((r.speed_knots, r.course_deg, r.date), (Some(15.207), Some(2.14), Some((2, 8, 18))));
        assert_eq!(r.time_s, Some(8.0 * 3600.0 + 34.0 * 60.0 + 47.0));
        let Ok(Sentence::Gga(g)) = parse(b"$GPGGA,092750.000,5321.6802,N,00630.3372,W,1,8,1.03,61.7,M,55.2,M,,*76") else { panic!() };
        assert_eq!((g.quality, g.satellites, g.hdop, g.altitude_m), (1, Some(8), Some(1.03), Some(61.7)));
        let Ok(Sentence::Vtg(v)) = parse(b"$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48") else { panic!() };
        assert_eq!((v.course_deg, v.speed_knots, v.speed_kmh), (Some(54.7), Some(5.5), Some(10.2)));
        let Ok(Sentence::Gst(s)) = parse(b"$GPGST,172814.0,0.006,0.023,0.020,273.6,0.023,0.020,0.031*6A") else { panic!() };
        assert_eq!((s.rms, s.sd_lat_m, s.sd_lon_m, s.sd_alt_m), (Some(0.006), Some(0.023), Some(0.020), Some(0.031)));
        // No fix yet: empty fields.
        let Ok(Sentence::Rmc(r)) = parse(b"$GNRMC,,V,,,,,,,,,,N*4D") else { panic!() };
        assert!(!r.valid && r.lat_deg.is_none());
    }

    #[test]
    fn bad_sentences_are_errors() {
        assert_eq!(parse(b"$GPRMC,083447.00,A,3743.25986,N,12228.33832,W,15.207,2.14,020818,,,A*45"), Err(NmeaError::Checksum));
        assert_eq!(parse(b"GPRMC,1*00"), Err(NmeaError::Framing));
        assert_eq!(parse(b"$GPRMC,1"), Err(NmeaError::Framing));
        assert_eq!(parse(b"$*00"), Err(NmeaError::Framing));
        assert_eq!(parse(&[b'$'; 200]), Err(NmeaError::TooLong));
        // A field of the wrong kind names its position: here the status (field 2).
        let s = b"GPRMC,083447.00,X,3743.25986,N,12228.33832,W,15.207,2.14,020818,,,A";
        let mut line = heapless::Vec::<u8, 128>::new();
        let _ = line.push(b'$');
        let _ = line.extend_from_slice(s);
        let c = s.iter().fold(0u8, |c, b| c ^ b);
        let _ = line.extend_from_slice(&[b'*', b"0123456789ABCDEF"[(c >> 4) as usize], b"0123456789ABCDEF"[(c & 15) as usize]]);
        assert_eq!(parse(&line), Err(NmeaError::Field(2)));
        assert_eq!(parse(b"$PUBX,00*33"), Ok(Sentence::Other));
    }

    #[test]
    fn f32_decimals_are_correctly_rounded() {
        extern crate std;
        for s in ["0", "0.5", "10.0", "005.5", "054.7", "359.99", "0.1", "0.8", "16777216", "16777217", "123.4567891", "-3.25", "+7.125", "99999.99999"] {
            assert_eq!(dec_f32(s.as_bytes()), s.parse::<f32>().ok(), "{s}");
        }
        let mut x = 1u32;
        for _ in 0..20_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let s = std::format!("{}.{:0w$}", x % 100_000, (x >> 7) % 1000, w = 1 + (x % 3) as usize);
            assert_eq!(dec_f32(s.as_bytes()), s.parse::<f32>().ok(), "{s}");
        }
    }

    #[test]
    fn decimals_are_correctly_rounded() {
        for s in ["0", "1.5", "-12.25", "3743.25986", "0.000001", "123456789.123456", "59.9999999"] {
            assert_eq!(dec(s.as_bytes()), Some(s.parse::<f64>().unwrap()), "{s}");
        }
        for s in ["", "-", ".", "1.2.3", "1e3", "nan", "inf", "1,5"] {
            assert_eq!(dec(s.as_bytes()), None, "{s}");
        }
    }
}
