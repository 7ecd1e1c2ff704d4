//! A car's calibration record, the wire format (`GGCR`): what the track check learnt about the
//! car, kept across drives (the board in flash, `host-sim detect --calibration` in a file).
//!
//! Little endian, [`RECORD_LEN`] bytes:
//! `"GGCR" | version u16 = 1 | payload length u16 = 64 |
//! scale f32 | delay of the position f32 | delay of the velocity f32 (NaN: none) | learnt s f32 |
//! drives u16 | flags u16 = 0 | gyro bias deg/s f32 (NaN: none) | its weight s f32 |
//! gyro scale error f32 | its sd f32 | s0 m f32 x 2 | k f32 x 2 | velocity sigma m/s f32 x 2 |
//! nominal epoch s f32 | crc32 u32` (CRC over all bytes before it).
//!
//! [`Record::decode`] refuses a record that is short, of another magic, version or length, whose
//! CRC does not match, or whose fields are not physically possible ([`Record::plausible`]), and
//! says where.

use super::crc32::crc32;
use super::le;

/// The record's magic and version.
pub const MAGIC: &[u8; 4] = b"GGCR";
/// The record version this build reads and writes.
pub const VERSION: u16 = 1;
const HEADER: usize = 8;
const PAYLOAD: usize = 64;
/// The encoded record's length, bytes.
pub const RECORD_LEN: usize = HEADER + PAYLOAD + 4;
/// The delays a record may hold, seconds (the track check's candidates).
pub const MAX_DELAY_S: f32 = 3.0;

/// What a car's calibration holds between drives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// GNSS distance over wheel-speed distance.
    pub scale: f32,
    /// How late the GNSS position and the GNSS velocity are behind the vehicle signals,
    /// seconds (negative: the vehicle signals late); the velocity's NaN where the receiver
    /// reported none.
    pub delay_s: [f32; 2],
    /// Seconds of driving the record was learnt from, over all its drives.
    pub learnt_s: f32,
    /// Drives that contributed.
    pub drives: u16,
    /// The gyro's bias, deg/s (NaN: no gyro, or never measured), and the seconds of standstill
    /// behind it.
    pub gyro_bias_degps: f32,
    /// Seconds of standstill behind the gyro bias.
    pub gyro_bias_weight_s: f32,
    /// The gyro's scale error (true turn = (1 + e) measured turn) and its uncertainty.
    pub gyro_scale_error: f32,
    /// The gyro scale error's uncertainty (1 sigma).
    pub gyro_scale_sd: f32,
    /// The position windows' learnt noise (10 s, 30 s): `s0` metres and `k`.
    pub noise_s0_m: [f32; 2],
    /// The position windows' learnt relative noise `k` (10 s, 30 s).
    pub noise_k: [f32; 2],
    /// The velocity channels' quiet noise (along, across), m/s.
    pub velocity_sigma_mps: [f32; 2],
    /// The epoch length of the receiver it was learnt with, seconds (noise is the receiver's).
    pub nominal_dt_s: f32,
}

/// Why a record was refused, and where (a byte offset into it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordError {
    /// Fewer bytes than a record has.
    TooShort {
        /// How many bytes there were.
        len: usize,
    },
    /// The first four bytes are not `GGCR`.
    BadMagic,
    /// A version this build does not read.
    BadVersion {
        /// The version found.
        version: u16,
    },
    /// The length field does not match this version's record.
    BadLength {
        /// The length found.
        length: u16,
    },
    /// The CRC over header and payload does not match.
    BadCrc {
        /// The CRC stored in the record.
        stored: u32,
        /// The CRC of the bytes as read.
        computed: u32,
    },
    /// A field that is not physically possible: its name and offset.
    Implausible {
        /// The field's name.
        field: &'static str,
        /// Its byte offset in the record.
        at: usize,
    },
}

impl RecordError {
    /// The byte offset of the problem.
    pub fn offset(&self) -> usize {
        match *self {
            RecordError::TooShort { len } => len,
            RecordError::BadMagic => 0,
            RecordError::BadVersion { .. } => 4,
            RecordError::BadLength { .. } => 6,
            RecordError::BadCrc { .. } => HEADER + PAYLOAD,
            RecordError::Implausible { at, .. } => at,
        }
    }
    /// What was expected there.
    pub fn expected(&self) -> &'static str {
        match self {
            RecordError::TooShort { .. } => "a calibration record of 76 bytes",
            RecordError::BadMagic => "the magic \"GGCR\"",
            RecordError::BadVersion { .. } => "version 1",
            RecordError::BadLength { .. } => "a payload of 64 bytes",
            RecordError::BadCrc { .. } => "the CRC-32 of the bytes before it",
            RecordError::Implausible { field, .. } => field,
        }
    }
}

/// Each field's offset in the encoded record.
mod at {
    pub const SCALE: usize = 8;
    pub const DELAY: usize = 12;
    pub const LEARNT: usize = 20;
    pub const DRIVES: usize = 24;
    pub const FLAGS: usize = 26;
    pub const BIAS: usize = 28;
    pub const BIAS_W: usize = 32;
    pub const GSCALE: usize = 36;
    pub const GSCALE_SD: usize = 40;
    pub const S0: usize = 44;
    pub const K: usize = 52;
    pub const SIGMA: usize = 60;
    pub const DT: usize = 68;
}

/// The wheel-speed scales that are physically possible (a wheel-speed signal 20 % slow or 25 %
/// fast is another signal, not a tyre): a record's and every learnt scale stay within them.
pub const SCALE_MIN: f32 = 0.8;
/// See [`SCALE_MIN`].
pub const SCALE_MAX: f32 = 1.25;

impl Record {
    /// Every field finite and physically possible (what a decoded record must satisfy): the
    /// name and offset of the first that is not.
    pub fn check(&self) -> Result<(), RecordError> {
        let ok = |v: f32, lo: f32, hi: f32| v.is_finite() && (lo..=hi).contains(&v);
        let bad = |field, at| Err(RecordError::Implausible { field, at });
        if !ok(self.scale, SCALE_MIN, SCALE_MAX) {
            return bad("scale between 0.8 and 1.25", at::SCALE);
        }
        if !ok(self.delay_s[0], -MAX_DELAY_S, MAX_DELAY_S) {
            return bad("a position delay within 3 s", at::DELAY);
        }
        if !(self.delay_s[1].is_nan() || ok(self.delay_s[1], -MAX_DELAY_S, MAX_DELAY_S)) {
            return bad("a velocity delay within 3 s, or NaN", at::DELAY + 4);
        }
        if !ok(self.learnt_s, 0.0, 1.0e9) {
            return bad("seconds learnt between 0 and 1e9", at::LEARNT);
        }
        if !(self.gyro_bias_degps.is_nan() || ok(self.gyro_bias_degps, -10.0, 10.0)) {
            return bad("a gyro bias within 10 deg/s, or NaN", at::BIAS);
        }
        if !ok(self.gyro_bias_weight_s, 0.0, 1.0e9) {
            return bad("a gyro bias weight between 0 and 1e9 s", at::BIAS_W);
        }
        if !ok(self.gyro_scale_error, -0.2, 0.2) {
            return bad("a gyro scale error within 0.2", at::GSCALE);
        }
        if !ok(self.gyro_scale_sd, 0.0, 1.0) {
            return bad("a gyro scale sd between 0 and 1", at::GSCALE_SD);
        }
        if !self.noise_s0_m.iter().all(|v| ok(*v, 0.0, 1000.0)) {
            return bad("window noise s0 between 0 and 1000 m", at::S0);
        }
        if !self.noise_k.iter().all(|v| ok(*v, 0.0, 10.0)) {
            return bad("window noise k between 0 and 10", at::K);
        }
        if !self.velocity_sigma_mps.iter().all(|v| ok(*v, 0.0, 100.0)) {
            return bad("velocity noise between 0 and 100 m/s", at::SIGMA);
        }
        if !ok(self.nominal_dt_s, 0.01, 10.0) {
            return bad("a nominal epoch between 0.01 and 10 s", at::DT);
        }
        Ok(())
    }

    /// [`Record::check`] as a plain result (the field's description on failure).
    pub fn plausible(&self) -> Result<(), &'static str> {
        self.check().map_err(|e| e.expected())
    }

    /// The record's bytes.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut b = [0u8; RECORD_LEN];
        let mut put = |at: usize, x: &[u8]| {
            if let Some(d) = b.get_mut(at..at + x.len()) {
                d.copy_from_slice(x);
            }
        };
        put(0, MAGIC);
        put(4, &VERSION.to_le_bytes());
        put(6, &(PAYLOAD as u16).to_le_bytes());
        put(at::SCALE, &self.scale.to_le_bytes());
        put(at::DELAY, &self.delay_s[0].to_le_bytes());
        put(at::DELAY + 4, &self.delay_s[1].to_le_bytes());
        put(at::LEARNT, &self.learnt_s.to_le_bytes());
        put(at::DRIVES, &self.drives.to_le_bytes());
        put(at::FLAGS, &0u16.to_le_bytes());
        put(at::BIAS, &self.gyro_bias_degps.to_le_bytes());
        put(at::BIAS_W, &self.gyro_bias_weight_s.to_le_bytes());
        put(at::GSCALE, &self.gyro_scale_error.to_le_bytes());
        put(at::GSCALE_SD, &self.gyro_scale_sd.to_le_bytes());
        for i in 0..2 {
            put(at::S0 + 4 * i, &self.noise_s0_m[i].to_le_bytes());
            put(at::K + 4 * i, &self.noise_k[i].to_le_bytes());
            put(at::SIGMA + 4 * i, &self.velocity_sigma_mps[i].to_le_bytes());
        }
        put(at::DT, &self.nominal_dt_s.to_le_bytes());
        let crc = crc32(b.get(..HEADER + PAYLOAD).unwrap_or(&[]));
        if let Some(d) = b.get_mut(HEADER + PAYLOAD..) {
            d.copy_from_slice(&crc.to_le_bytes());
        }
        b
    }

    /// A record from its bytes (extra bytes after it are ignored), validated.
    pub fn decode(b: &[u8]) -> Result<Record, RecordError> {
        if b.len() < RECORD_LEN {
            return Err(RecordError::TooShort { len: b.len() });
        }
        if b.get(..4) != Some(&MAGIC[..]) {
            return Err(RecordError::BadMagic);
        }
        let version = le::u16(b, 4).unwrap_or(0);
        if version != VERSION {
            return Err(RecordError::BadVersion { version });
        }
        let length = le::u16(b, 6).unwrap_or(0);
        if length as usize != PAYLOAD {
            return Err(RecordError::BadLength { length });
        }
        let stored = le::u32(b, HEADER + PAYLOAD).unwrap_or(0);
        let computed = crc32(b.get(..HEADER + PAYLOAD).unwrap_or(&[]));
        if stored != computed {
            return Err(RecordError::BadCrc { stored, computed });
        }
        let f = |at: usize| le::f32(b, at).unwrap_or(f32::NAN);
        let r = Record {
            scale: f(at::SCALE),
            delay_s: [f(at::DELAY), f(at::DELAY + 4)],
            learnt_s: f(at::LEARNT),
            drives: le::u16(b, at::DRIVES).unwrap_or(0),
            gyro_bias_degps: f(at::BIAS),
            gyro_bias_weight_s: f(at::BIAS_W),
            gyro_scale_error: f(at::GSCALE),
            gyro_scale_sd: f(at::GSCALE_SD),
            noise_s0_m: [f(at::S0), f(at::S0 + 4)],
            noise_k: [f(at::K), f(at::K + 4)],
            velocity_sigma_mps: [f(at::SIGMA), f(at::SIGMA + 4)],
            nominal_dt_s: f(at::DT),
        };
        r.check()?;
        Ok(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn example() -> Record {
        Record {
            scale: 0.9926,
            delay_s: [0.375, f32::NAN],
            learnt_s: 3600.0,
            drives: 3,
            gyro_bias_degps: 0.39,
            gyro_bias_weight_s: 40.0,
            gyro_scale_error: -0.01,
            gyro_scale_sd: 0.004,
            noise_s0_m: [1.2, 1.4],
            noise_k: [0.011, 0.012],
            velocity_sigma_mps: [0.14, 0.2],
            nominal_dt_s: 1.0,
        }
    }

    fn same(a: &Record, b: &Record) -> bool {
        a.encode() == b.encode()
    }

    #[test]
    fn a_record_reads_back_bit_for_bit() {
        let r = example();
        let b = r.encode();
        assert_eq!(b.len(), RECORD_LEN);
        assert_eq!(&b[..4], b"GGCR");
        let d = Record::decode(&b).unwrap();
        assert!(same(&r, &d) && d.delay_s[1].is_nan());
        // Trailing bytes (a flash page's rest) are ignored.
        let mut longer = b.to_vec();
        longer.extend_from_slice(&[0xff; 20]);
        assert!(same(&Record::decode(&longer).unwrap(), &r));
    }

    #[test]
    fn every_damage_is_refused_and_located() {
        let b = example().encode();
        assert_eq!(Record::decode(&b[..RECORD_LEN - 1]), Err(RecordError::TooShort { len: RECORD_LEN - 1 }));
        // Every single flipped bit is caught (the CRC, or the header before it).
        for i in 0..RECORD_LEN * 8 {
            let mut c = b;
            c[i / 8] ^= 1 << (i % 8);
            assert!(Record::decode(&c).is_err(), "bit {i}");
        }
        let mut c = b;
        c[4] = 2;
        assert_eq!(Record::decode(&c), Err(RecordError::BadVersion { version: 2 }));
        // A well-formed record of an impossible car: refused by field, with its offset.
        let mut r = example();
        r.scale = 1.5;
        let e = Record::decode(&r.encode()).unwrap_err();
        assert_eq!(e.offset(), 8);
        assert!(e.expected().contains("scale"));
        r = example();
        r.noise_k[1] = f32::INFINITY;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 52);
    }
}
