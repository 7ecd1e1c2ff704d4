//! u-blox UBX: the binary wire format of u-blox receivers, and the two messages the detector
//! reads from it. Panic-free on any input; no allocation.
//!
//! A UBX frame is `B5 62 <class> <id> <length: u16 LE> <payload> <CK_A> <CK_B>`, with an 8-bit
//! Fletcher checksum over class, id, length and payload. A receiver's UART may carry UBX frames
//! and NMEA sentences interleaved; [`Framer`] tells them apart byte by byte (a sentence starts
//! with `$`, a frame with `B5 62`) and hands out either.
//!
//! The messages (u-blox 8 / M8 protocol 18+, and later):
//! - NAV-PVT (`01 07`, 92 bytes): UTC time, fix type and flags, position (1e-7 deg), ground
//!   speed (mm/s), heading of motion (1e-5 deg) and the receiver's own accuracy estimates: `hAcc`
//!   (mm), `sAcc` (mm/s), `headAcc` (1e-5 deg);
//! - NAV-STATUS (`01 03`, 16 bytes): among others, `flags2.spoofDetState` (bits 3-4): the
//!   receiver's own spoofing detection (0 unknown or off, 1 none indicated, 2 indicated,
//!   3 indicated by several sources).
//!
//! Why not the `ublox` crate: 0.10 (no_std, proto23) links to 4.9 KB, but after LTO its parser
//! keeps 15 bounds-check panics and 4 formatted panics on the receive path, which the firmware's
//! no-panic link check (`firmware/nopanic`) refuses. The framing and decoding are cross-checked
//! against `pyubx2`, an independent implementation (`tests/tests/ubx_crosscheck.rs`).

use detector_core::geo::LatLon;
use detector_core::sample::Fix;

use crate::gnss::LineSplitter;

pub const SYNC: [u8; 2] = [0xB5, 0x62];
pub const NAV: u8 = 0x01;
pub const NAV_PVT: u8 = 0x07;
pub const NAV_STATUS: u8 = 0x03;
pub const NAV_PVT_LEN: usize = 92;
pub const NAV_STATUS_LEN: usize = 16;
/// Payloads up to this size are buffered and checked; longer frames (which the detector does not
/// read) are skipped by their length and counted.
pub const MAX_PAYLOAD: usize = 100;

/// The 8-bit Fletcher checksum over `bytes` (class, id, length and payload).
pub fn checksum(bytes: &[u8]) -> [u8; 2] {
    checksum_more([0, 0], bytes)
}

/// [`checksum`] continued over more bytes (a frame's header and payload kept apart).
pub fn checksum_more(sum: [u8; 2], bytes: &[u8]) -> [u8; 2] {
    let [mut a, mut b] = sum;
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    [a, b]
}

/// Writes a whole frame into `out`; its length, or `None` when `out` is too small or the payload
/// longer than a UBX length field holds.
pub fn encode(class: u8, id: u8, payload: &[u8], out: &mut [u8]) -> Option<usize> {
    let len = u16::try_from(payload.len()).ok()?;
    let n = payload.len().checked_add(8)?;
    let frame = out.get_mut(..n)?;
    let (head, rest) = frame.split_at_mut(6);
    head.copy_from_slice(&[SYNC[0], SYNC[1], class, id, len.to_le_bytes()[0], len.to_le_bytes()[1]]);
    let (body, ck) = rest.split_at_mut(payload.len());
    body.copy_from_slice(payload);
    ck.copy_from_slice(&checksum_more(checksum(&head[2..]), payload));
    Some(n)
}

fn u8_at(p: &[u8], i: usize) -> u8 {
    p.get(i).copied().unwrap_or(0)
}
fn u16_at(p: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([u8_at(p, i), u8_at(p, i + 1)])
}
fn u32_at(p: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([u8_at(p, i), u8_at(p, i + 1), u8_at(p, i + 2), u8_at(p, i + 3)])
}
fn i32_at(p: &[u8], i: usize) -> i32 {
    u32_at(p, i) as i32
}

/// NAV-PVT, the fields the detector reads, in the message's own units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NavPvt {
    pub itow_ms: u32,
    pub year: u16,
    pub month: u8,
    pub day: u8,
    pub hour: u8,
    pub min: u8,
    pub sec: u8,
    /// Bit 0 validDate, bit 1 validTime, bit 2 fullyResolved.
    pub valid: u8,
    /// Fraction of the second, ns (-1e9..1e9).
    pub nano: i32,
    /// 0 no fix, 1 dead reckoning only, 2 2D, 3 3D, 4 GNSS + dead reckoning, 5 time only.
    pub fix_type: u8,
    /// Bit 0 gnssFixOK.
    pub flags: u8,
    pub num_sv: u8,
    pub lon_e7: i32,
    pub lat_e7: i32,
    pub h_acc_mm: u32,
    pub g_speed_mm_s: i32,
    pub head_mot_e5: i32,
    pub s_acc_mm_s: u32,
    pub head_acc_e5: u32,
    /// Bit 0 invalidLlh (protocol 27+; 0 before).
    pub flags3: u16,
}

impl NavPvt {
    /// Decodes a NAV-PVT payload; `None` unless it is 92 bytes.
    pub fn parse(p: &[u8]) -> Option<Self> {
        if p.len() != NAV_PVT_LEN {
            return None;
        }
        Some(NavPvt {
            itow_ms: u32_at(p, 0),
            year: u16_at(p, 4),
            month: u8_at(p, 6),
            day: u8_at(p, 7),
            hour: u8_at(p, 8),
            min: u8_at(p, 9),
            sec: u8_at(p, 10),
            valid: u8_at(p, 11),
            nano: i32_at(p, 16),
            fix_type: u8_at(p, 20),
            flags: u8_at(p, 21),
            num_sv: u8_at(p, 23),
            lon_e7: i32_at(p, 24),
            lat_e7: i32_at(p, 28),
            h_acc_mm: u32_at(p, 40),
            g_speed_mm_s: i32_at(p, 60),
            head_mot_e5: i32_at(p, 64),
            s_acc_mm_s: u32_at(p, 68),
            head_acc_e5: u32_at(p, 72),
            flags3: u16_at(p, 78),
        })
    }

    /// The 92-byte payload (fields the detector does not read are zero).
    pub fn to_payload(&self) -> [u8; NAV_PVT_LEN] {
        let mut p = [0u8; NAV_PVT_LEN];
        let mut put = |i: usize, b: &[u8]| {
            if let Some(d) = p.get_mut(i..i + b.len()) {
                d.copy_from_slice(b);
            }
        };
        put(0, &self.itow_ms.to_le_bytes());
        put(4, &self.year.to_le_bytes());
        put(6, &[self.month, self.day, self.hour, self.min, self.sec, self.valid]);
        put(16, &self.nano.to_le_bytes());
        put(20, &[self.fix_type, self.flags, 0, self.num_sv]);
        put(24, &self.lon_e7.to_le_bytes());
        put(28, &self.lat_e7.to_le_bytes());
        put(40, &self.h_acc_mm.to_le_bytes());
        put(60, &self.g_speed_mm_s.to_le_bytes());
        put(64, &self.head_mot_e5.to_le_bytes());
        put(68, &self.s_acc_mm_s.to_le_bytes());
        put(72, &self.head_acc_e5.to_le_bytes());
        put(78, &self.flags3.to_le_bytes());
        p
    }

    /// A position fix the receiver stands behind: gnssFixOK, a 2D/3D (or GNSS + dead
    /// reckoning) fix, and a valid latitude/longitude.
    pub fn has_fix(&self) -> bool {
        self.flags & 1 == 1 && matches!(self.fix_type, 2..=4) && self.flags3 & 1 == 0
    }

    /// The fix's UTC time as UNIX seconds, when date and time are valid.
    pub fn utc_s(&self) -> Option<f64> {
        let ok = self.valid & 0b11 == 0b11
            && (1..=12).contains(&self.month)
            && (1..=31).contains(&self.day)
            && self.hour < 24
            && self.min < 60
            && self.sec <= 60
            && (-1_000_000_000..=1_000_000_000).contains(&self.nano);
        if !ok {
            return None;
        }
        let days = days_from_civil(self.year as i64, self.month as i64, self.day as i64);
        let secs = days * 86_400 + self.hour as i64 * 3600 + self.min as i64 * 60 + self.sec as i64;
        Some(secs as f64 + self.nano as f64 / 1e9)
    }

    /// NAV-PVT's date and time fields for UNIX time `t` (what a receiver writes at that time).
    pub fn set_utc(&mut self, t: f64) {
        let secs = libm::floor(t);
        let mut nano = libm::round((t - secs) * 1e9) as i32;
        let mut s = secs as i64;
        if nano >= 1_000_000_000 {
            nano -= 1_000_000_000;
            s += 1;
        }
        let (days, tod) = (s.div_euclid(86_400), s.rem_euclid(86_400));
        let (y, m, d) = civil_from_days(days);
        self.year = y as u16;
        self.month = m as u8;
        self.day = d as u8;
        self.hour = (tod / 3600) as u8;
        self.min = (tod % 3600 / 60) as u8;
        self.sec = (tod % 60) as u8;
        self.nano = nano;
        self.valid |= 0b111;
        self.itow_ms = ((s - 315_964_800 + 18).rem_euclid(604_800) * 1000 + nano as i64 / 1_000_000) as u32;
    }
}

/// Days from 1970-01-01 to a civil date (proleptic Gregorian).
pub fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The civil date of a day number (the inverse of [`days_from_civil`]).
pub fn civil_from_days(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// The receiver's own spoofing detection (NAV-STATUS `flags2.spoofDetState`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpoofState {
    /// Unknown, or the receiver's detection is off (and before any NAV-STATUS).
    #[default]
    Unknown = 0,
    None = 1,
    Indicated = 2,
    Multiple = 3,
}

impl SpoofState {
    pub fn of_flags2(flags2: u8) -> Self {
        match (flags2 >> 3) & 0b11 {
            1 => SpoofState::None,
            2 => SpoofState::Indicated,
            3 => SpoofState::Multiple,
            _ => SpoofState::Unknown,
        }
    }
    /// The receiver says it is being spoofed.
    pub fn indicated(self) -> bool {
        matches!(self, SpoofState::Indicated | SpoofState::Multiple)
    }
    pub const fn name(self) -> &'static str {
        match self {
            SpoofState::Unknown => "unknown",
            SpoofState::None => "none",
            SpoofState::Indicated => "indicated",
            SpoofState::Multiple => "multiple",
        }
    }
}

/// A NAV-STATUS payload's spoofing state; `None` unless it is 16 bytes.
pub fn nav_status_spoof(p: &[u8]) -> Option<SpoofState> {
    (p.len() == NAV_STATUS_LEN).then(|| SpoofState::of_flags2(u8_at(p, 7)))
}

/// A checked UBX frame: class, id and payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame<'a> {
    pub class: u8,
    pub id: u8,
    pub payload: &'a [u8],
}

/// What [`Framer`] hands out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chunk<'a> {
    /// An NMEA sentence (from `$`, without its line end).
    Nmea(&'a [u8]),
    Ubx(Frame<'a>),
}

/// UBX framing counters; each saturates at `u32::MAX`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UbxCounters {
    pub frames: u32,
    pub bad_checksum: u32,
    /// Frames longer than [`MAX_PAYLOAD`], skipped.
    pub skipped_long: u32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum State {
    /// Outside a UBX frame: bytes go to the NMEA line splitter.
    #[default]
    Text,
    /// After `B5`.
    Sync,
    /// Collecting class, id and length (`have` bytes so far).
    Header { have: u8 },
    /// Collecting payload and checksum.
    Body { len: u16 },
    /// Skipping a frame too long to keep: bytes left.
    Skip { left: u32 },
}

/// Splits a receiver's byte stream into NMEA sentences and checked UBX frames.
#[derive(Clone, Debug, Default)]
pub struct Framer {
    state: State,
    head: [u8; 4],
    buf: heapless::Vec<u8, { MAX_PAYLOAD + 2 }>,
    pub lines: LineSplitter,
    pub counters: UbxCounters,
}

impl Framer {
    /// Inside a UBX frame (a stream that ends here was cut).
    pub fn pending(&self) -> bool {
        !matches!(self.state, State::Text)
    }

    /// Feeds bytes; calls `f` with every sentence and every frame whose checksum holds.
    pub fn push(&mut self, bytes: &[u8], mut f: impl FnMut(Chunk<'_>)) {
        for &b in bytes {
            self.byte(b, &mut f);
        }
    }

    fn byte(&mut self, b: u8, f: &mut impl FnMut(Chunk<'_>)) {
        match self.state {
            State::Text => {
                if b == SYNC[0] {
                    // NMEA is ASCII: B5 starts a frame (and ends a sentence that lost its line end).
                    self.lines.discard_partial();
                    self.state = State::Sync;
                } else {
                    self.lines.push(&[b], |l| f(Chunk::Nmea(l)));
                }
            }
            State::Sync => {
                if b == SYNC[1] {
                    self.state = State::Header { have: 0 };
                } else {
                    self.state = State::Text;
                    self.byte(b, f);
                }
            }
            State::Header { have } => {
                if let Some(h) = self.head.get_mut(have as usize) {
                    *h = b;
                }
                let have = have.saturating_add(1);
                if (have as usize) < self.head.len() {
                    self.state = State::Header { have };
                    return;
                }
                let len = u16::from_le_bytes([self.head[2], self.head[3]]);
                self.buf.clear();
                self.state = if len as usize <= MAX_PAYLOAD {
                    State::Body { len }
                } else {
                    self.counters.skipped_long = self.counters.skipped_long.saturating_add(1);
                    State::Skip { left: len as u32 + 2 }
                };
            }
            State::Body { len } => {
                let _ = self.buf.push(b);
                if self.buf.len() < len as usize + 2 {
                    return;
                }
                self.state = State::Text;
                let (payload, ck) = self.buf.split_at(len as usize);
                if checksum_more(checksum(&self.head), payload) != ck {
                    self.counters.bad_checksum = self.counters.bad_checksum.saturating_add(1);
                    return;
                }
                self.counters.frames = self.counters.frames.saturating_add(1);
                f(Chunk::Ubx(Frame { class: self.head[0], id: self.head[1], payload }));
            }
            State::Skip { left } => {
                let left = left.saturating_sub(1);
                self.state = if left == 0 { State::Text } else { State::Skip { left } };
            }
        }
    }
}

/// Turns UBX frames into fixes, and keeps the receiver's spoofing state.
#[derive(Clone, Debug, Default)]
pub struct UbxFixer {
    /// From the last NAV-STATUS.
    pub spoof: SpoofState,
    /// The last NAV-PVT read.
    pub last_pvt: Option<NavPvt>,
    /// NAV-PVTs without a usable fix (no gnssFixOK, fix type, invalid position or time).
    pub no_fix: u32,
    pub fixes: u32,
}

impl UbxFixer {
    /// One checked frame; a fix for a NAV-PVT with one, carrying the last NAV-STATUS's spoofing
    /// flag. The fix's time is `t` when given (the
    /// firmware's receive time), else the NAV-PVT's own UTC time (logs without a host clock).
    /// `hAcc` becomes the fix's accuracy; 0, which no receiver reports with a fix, is taken as
    /// not reported.
    pub fn frame(&mut self, t: Option<f64>, fr: Frame<'_>) -> Option<Fix> {
        match (fr.class, fr.id) {
            (NAV, NAV_STATUS) => {
                if let Some(s) = nav_status_spoof(fr.payload) {
                    self.spoof = s;
                }
                None
            }
            (NAV, NAV_PVT) => {
                let pvt = NavPvt::parse(fr.payload)?;
                self.last_pvt = Some(pvt);
                let fix = Self::fix_of(t, &pvt).map(|f| Fix { receiver_spoofing: self.spoof.indicated(), ..f });
                match fix {
                    Some(_) => self.fixes = self.fixes.wrapping_add(1),
                    None => self.no_fix = self.no_fix.saturating_add(1),
                }
                fix
            }
            _ => None,
        }
    }

    /// The fix a NAV-PVT carries (see [`UbxFixer::frame`]).
    pub fn fix_of(t: Option<f64>, pvt: &NavPvt) -> Option<Fix> {
        if !pvt.has_fix() {
            return None;
        }
        let t = match t {
            Some(t) => t,
            None => pvt.utc_s()?,
        };
        let pos = LatLon::new(pvt.lat_e7 as f64 * 1e-7, pvt.lon_e7 as f64 * 1e-7);
        if !pos.is_valid() || !t.is_finite() {
            return None;
        }
        Some(Fix {
            t,
            pos,
            speed_mps: Some(pvt.g_speed_mm_s as f32 / 1000.0),
            course_deg: Some(pvt.head_mot_e5 as f32 / 1e5),
            h_acc_m: (pvt.h_acc_mm > 0).then(|| pvt.h_acc_mm as f32 / 1000.0),
            receiver_spoofing: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pvt() -> NavPvt {
        let mut p = NavPvt { fix_type: 3, flags: 1, num_sv: 12, lat_e7: 377_209_977, lon_e7: -1_224_723_053, h_acc_mm: 1500, g_speed_mm_s: 7823, head_mot_e5: 214_000, s_acc_mm_s: 300, head_acc_e5: 150_000, ..Default::default() };
        p.set_utc(1_533_198_887.25);
        p
    }

    fn frame_of(class: u8, id: u8, payload: &[u8]) -> heapless::Vec<u8, 128> {
        let mut out = [0u8; 128];
        let n = encode(class, id, payload, &mut out).unwrap();
        heapless::Vec::from_slice(&out[..n]).unwrap()
    }

    #[test]
    fn nav_pvt_round_trips_and_gives_a_fix() {
        let p = pvt();
        assert_eq!(NavPvt::parse(&p.to_payload()), Some(p));
        assert_eq!((p.year, p.month, p.day, p.hour, p.min, p.sec, p.nano), (2018, 8, 2, 8, 34, 47, 250_000_000));
        assert_eq!(p.utc_s(), Some(1_533_198_887.25));
        let f = UbxFixer::fix_of(None, &p).unwrap();
        assert_eq!(f.t, 1_533_198_887.25);
        assert!((f.pos.lat_deg - 37.720_997_7).abs() < 1e-9 && (f.pos.lon_deg + 122.472_305_3).abs() < 1e-9);
        assert_eq!((f.speed_mps, f.course_deg, f.h_acc_m), (Some(7.823), Some(2.14), Some(1.5)));
        // No gnssFixOK, a time-only fix, an invalid position: no fix.
        for q in [NavPvt { flags: 0, ..p }, NavPvt { fix_type: 5, ..p }, NavPvt { flags3: 1, ..p }, NavPvt { valid: 0, ..p }] {
            assert_eq!(UbxFixer::fix_of(None, &q), None);
        }
        assert!(UbxFixer::fix_of(Some(3.0), &NavPvt { valid: 0, ..p }).is_some(), "a receive time needs no UTC");
        assert_eq!(UbxFixer::fix_of(None, &NavPvt { h_acc_mm: 0, ..p }).unwrap().h_acc_m, None);
    }

    #[test]
    fn civil_dates_round_trip() {
        for days in [-719_468, -1, 0, 11_016, 11_017, 17_745, 20_000, 100_000] {
            let (y, m, d) = civil_from_days(days);
            assert_eq!(days_from_civil(y, m, d), days, "{y}-{m}-{d}");
        }
        assert_eq!(civil_from_days(17_745), (2018, 8, 2));
    }

    #[test]
    fn framer_tells_ubx_from_nmea_and_checks() {
        let p = pvt().to_payload();
        let pvt_frame = frame_of(NAV, NAV_PVT, &p);
        let mut status = [0u8; 16];
        status[7] = 2 << 3;
        let st = frame_of(NAV, NAV_STATUS, &status);
        let mut stream: heapless::Vec<u8, 512> = heapless::Vec::new();
        stream.extend_from_slice(b"$GPRMC,1*00\r\n$GPGGA,half").unwrap();
        stream.extend_from_slice(&pvt_frame).unwrap();
        stream.extend_from_slice(b"\xB5\x00junk\r\n").unwrap();
        stream.extend_from_slice(&st).unwrap();
        let mut bad = pvt_frame.clone();
        bad[20] ^= 1;
        stream.extend_from_slice(&bad).unwrap();
        // A long frame (MON-VER style) is skipped by its length, whatever it holds.
        stream.extend_from_slice(&[0xB5, 0x62, 0x0A, 0x04, 200, 0]).unwrap();
        stream.extend_from_slice(&[b'$'; 202]).unwrap();
        stream.extend_from_slice(b"$GPVTG,3*00\n").unwrap();
        let mut fr = Framer::default();
        let mut fixer = UbxFixer::default();
        let mut seen: heapless::Vec<&str, 8> = heapless::Vec::new();
        let mut fixes = 0;
        fr.push(&stream, |c| match c {
            Chunk::Nmea(l) => {
                let _ = seen.push(if l.starts_with(b"$GPRMC") { "rmc" } else if l.starts_with(b"$GPVTG") { "vtg" } else { "other" });
            }
            Chunk::Ubx(f) => {
                let _ = seen.push("ubx");
                fixes += fixer.frame(None, f).is_some() as u32;
            }
        });
        assert_eq!(seen.as_slice(), ["rmc", "ubx", "ubx", "vtg"], "the half GGA is cut by the frame; B5 00 starts no frame");
        assert_eq!(fixes, 1);
        assert_eq!(fixer.spoof, SpoofState::Indicated);
        assert_eq!(fr.counters, UbxCounters { frames: 2, bad_checksum: 1, skipped_long: 1 });
        // Split anywhere, the same result.
        for cut in 0..stream.len() {
            let mut fr2 = Framer::default();
            let mut n = 0;
            fr2.push(&stream[..cut], |_| n += 1);
            fr2.push(&stream[cut..], |_| n += 1);
            assert_eq!(n, 4, "cut at {cut}");
        }
    }
}
