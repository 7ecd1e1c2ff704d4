//! A car's calibration record, the wire format (`GGCR`): what the track check learnt about the
//! car, kept across drives (the board in flash, `host-sim detect --calibration` in a file).
//!
//! Little endian, [`RECORD_LEN`] bytes:
//! `"GGCR" | version u16 = 3 | payload length u16 = 104 |
//! scale f32 | delay of the position f32 | delay of the velocity f32 (NaN: none) | learnt s f32 |
//! drives u16 | flags u16 = 0 | gyro bias deg/s f32 (NaN: none) | its weight s f32 |
//! gyro scale error f32 | its sd f32 | s0 m f32 x 2 | k f32 x 2 | velocity sigma m/s f32 x 2 |
//! nominal epoch s f32 | anchor scale f32 | anchor delays f32 x 2 (the velocity's NaN: none) |
//! anchor gyro scale error f32 | anchor s0 m f32 x 2 | anchor k f32 x 2 |
//! anchor velocity sigma m/s f32 x 2 | crc32 u32` (CRC over all bytes before it).
//!
//! Version 2 (92 bytes, payload 80) is the same without the noise's anchors, version 1 (76
//! bytes, payload 64) without any anchor; both are still read, the record's own values taken as
//! the anchors it lacks, so a car's calibration survives the update.
//!
//! [`Record::decode`] refuses a record that is short, of another magic, version or length, whose
//! CRC does not match, or whose fields are not physically possible ([`Record::plausible`]), and
//! says where.

use super::crc32::crc32;
use super::le;

/// The record's magic and version.
pub const MAGIC: &[u8; 4] = b"GGCR";
/// The record version this build writes (it reads versions 2 and 1 too).
pub const VERSION: u16 = 3;
const HEADER: usize = 8;
/// The payload's length, bytes (the header's length field).
pub const PAYLOAD_LEN: usize = 104;
const PAYLOAD: usize = PAYLOAD_LEN;
/// Version 2's payload, bytes: no anchors of the noise.
const PAYLOAD_V2: usize = 80;
/// Version 1's payload, bytes: no anchors.
const PAYLOAD_V1: usize = 64;
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
    /// The gyro's bias, deg/s (NaN: no gyro, or never measured).
    pub gyro_bias_degps: f32,
    /// The gyro bias's weight, seconds of standstill: the last drive's own, and at most 10 s of
    /// the drives before (a stored bias counts as 10 s at most when a drive starts from it).
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
    /// The car's anchor: the scale of its first record, which no later drive moves. Every
    /// drive's scale stays within a bound of it as well as of the record it starts from, so a
    /// spoofer present on drive after drive cannot walk the calibration a little per drive.
    pub anchor_scale: f32,
    /// The delays of the car's first record (the velocity's: of the first record that had one,
    /// NaN before), the anchor of every later drive's delays.
    pub anchor_delay_s: [f32; 2],
    /// The gyro scale error of the car's first record: every later drive's stays near it.
    pub anchor_gyro_scale_error: f32,
    /// The noise of the car's first record (of its receiver class): the windows' `s0`, m, ...
    pub anchor_noise_s0_m: [f32; 2],
    /// ... their `k` ...
    pub anchor_noise_k: [f32; 2],
    /// ... and the velocity channels' quiet noise, m/s. A record's noise stays within a
    /// bound of these, however many drives each raised it a little.
    pub anchor_velocity_sigma_mps: [f32; 2],
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
        /// Where the CRC is (after the version's payload).
        at: usize,
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
            RecordError::BadCrc { at, .. } => at,
            RecordError::Implausible { at, .. } => at,
        }
    }
    /// What was expected there.
    pub fn expected(&self) -> &'static str {
        match self {
            RecordError::TooShort { .. } => "a calibration record of 116 bytes (92 in version 2, 76 in version 1)",
            RecordError::BadMagic => "the magic \"GGCR\"",
            RecordError::BadVersion { .. } => "version 3, 2 or 1",
            RecordError::BadLength { .. } => "a payload of 104 bytes (80 in version 2, 64 in version 1)",
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
    pub const ANCHOR_SCALE: usize = 72;
    pub const ANCHOR_DELAY: usize = 76;
    pub const ANCHOR_GSCALE: usize = 84;
    pub const ANCHOR_S0: usize = 88;
    pub const ANCHOR_K: usize = 96;
    pub const ANCHOR_SIGMA: usize = 104;
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
        // One table and one loop (each field as its own `if` took 1.3 KB of flash): the value,
        // its range, whether NaN is allowed (none) and what is expected, at its offset.
        let fields: [(f32, f32, f32, bool, &'static str, usize); 25] = [
            (self.scale, SCALE_MIN, SCALE_MAX, false, "scale between 0.8 and 1.25", at::SCALE),
            (self.delay_s[0], -MAX_DELAY_S, MAX_DELAY_S, false, "a position delay within 3 s", at::DELAY),
            (self.delay_s[1], -MAX_DELAY_S, MAX_DELAY_S, true, "a velocity delay within 3 s, or NaN", at::DELAY + 4),
            (self.learnt_s, 0.0, 1.0e9, false, "seconds learnt between 0 and 1e9", at::LEARNT),
            (self.gyro_bias_degps, -10.0, 10.0, true, "a gyro bias within 10 deg/s, or NaN", at::BIAS),
            (self.gyro_bias_weight_s, 0.0, 1.0e9, false, "a gyro bias weight between 0 and 1e9 s", at::BIAS_W),
            (self.gyro_scale_error, -0.2, 0.2, false, "a gyro scale error within 0.2", at::GSCALE),
            (self.gyro_scale_sd, 0.0, 1.0, false, "a gyro scale sd between 0 and 1", at::GSCALE_SD),
            (self.noise_s0_m[0], 0.0, 1000.0, false, "window noise s0 between 0 and 1000 m", at::S0),
            (self.noise_s0_m[1], 0.0, 1000.0, false, "window noise s0 between 0 and 1000 m", at::S0 + 4),
            (self.noise_k[0], 0.0, 10.0, false, "window noise k between 0 and 10", at::K),
            (self.noise_k[1], 0.0, 10.0, false, "window noise k between 0 and 10", at::K + 4),
            (self.velocity_sigma_mps[0], 0.0, 100.0, false, "velocity noise between 0 and 100 m/s", at::SIGMA),
            (self.velocity_sigma_mps[1], 0.0, 100.0, false, "velocity noise between 0 and 100 m/s", at::SIGMA + 4),
            (self.nominal_dt_s, 0.01, 10.0, false, "a nominal epoch between 0.01 and 10 s", at::DT),
            (self.anchor_scale, SCALE_MIN, SCALE_MAX, false, "an anchor scale between 0.8 and 1.25", at::ANCHOR_SCALE),
            (self.anchor_delay_s[0], -MAX_DELAY_S, MAX_DELAY_S, false, "an anchor position delay within 3 s", at::ANCHOR_DELAY),
            (self.anchor_delay_s[1], -MAX_DELAY_S, MAX_DELAY_S, true, "an anchor velocity delay within 3 s, or NaN", at::ANCHOR_DELAY + 4),
            (self.anchor_gyro_scale_error, -0.2, 0.2, false, "an anchor gyro scale error within 0.2", at::ANCHOR_GSCALE),
            (self.anchor_noise_s0_m[0], 0.0, 1000.0, false, "window noise s0 between 0 and 1000 m", at::ANCHOR_S0),
            (self.anchor_noise_s0_m[1], 0.0, 1000.0, false, "window noise s0 between 0 and 1000 m", at::ANCHOR_S0 + 4),
            (self.anchor_noise_k[0], 0.0, 10.0, false, "window noise k between 0 and 10", at::ANCHOR_K),
            (self.anchor_noise_k[1], 0.0, 10.0, false, "window noise k between 0 and 10", at::ANCHOR_K + 4),
            (self.anchor_velocity_sigma_mps[0], 0.0, 100.0, false, "velocity noise between 0 and 100 m/s", at::ANCHOR_SIGMA),
            (self.anchor_velocity_sigma_mps[1], 0.0, 100.0, false, "velocity noise between 0 and 100 m/s", at::ANCHOR_SIGMA + 4),
        ];
        for (v, lo, hi, nan_ok, field, at) in fields {
            if !(nan_ok && v.is_nan() || v.is_finite() && v >= lo && v <= hi) {
                return Err(RecordError::Implausible { field, at });
            }
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
            put(at::ANCHOR_S0 + 4 * i, &self.anchor_noise_s0_m[i].to_le_bytes());
            put(at::ANCHOR_K + 4 * i, &self.anchor_noise_k[i].to_le_bytes());
            put(at::ANCHOR_SIGMA + 4 * i, &self.anchor_velocity_sigma_mps[i].to_le_bytes());
        }
        put(at::DT, &self.nominal_dt_s.to_le_bytes());
        put(at::ANCHOR_SCALE, &self.anchor_scale.to_le_bytes());
        put(at::ANCHOR_DELAY, &self.anchor_delay_s[0].to_le_bytes());
        put(at::ANCHOR_DELAY + 4, &self.anchor_delay_s[1].to_le_bytes());
        put(at::ANCHOR_GSCALE, &self.anchor_gyro_scale_error.to_le_bytes());
        let crc = crc32(b.get(..HEADER + PAYLOAD).unwrap_or(&[]));
        if let Some(d) = b.get_mut(HEADER + PAYLOAD..) {
            d.copy_from_slice(&crc.to_le_bytes());
        }
        b
    }

    /// A record from its bytes (extra bytes after it are ignored), validated: version 3, or
    /// version 2 with its own noise as the noise's anchors, or version 1 with its own values as
    /// every anchor.
    pub fn decode(b: &[u8]) -> Result<Record, RecordError> {
        if b.len() < HEADER {
            return Err(RecordError::TooShort { len: b.len() });
        }
        if b.get(..4) != Some(&MAGIC[..]) {
            return Err(RecordError::BadMagic);
        }
        let version = le::u16(b, 4).unwrap_or(0);
        let payload = match version {
            VERSION => PAYLOAD,
            2 => PAYLOAD_V2,
            1 => PAYLOAD_V1,
            _ => return Err(RecordError::BadVersion { version }),
        };
        let length = le::u16(b, 6).unwrap_or(0);
        if length as usize != payload {
            return Err(RecordError::BadLength { length });
        }
        if b.len() < HEADER + payload + 4 {
            return Err(RecordError::TooShort { len: b.len() });
        }
        let stored = le::u32(b, HEADER + payload).unwrap_or(0);
        let computed = crc32(b.get(..HEADER + payload).unwrap_or(&[]));
        if stored != computed {
            return Err(RecordError::BadCrc { at: HEADER + payload, stored, computed });
        }
        let f = |at: usize| le::f32(b, at).unwrap_or(f32::NAN);
        let (scale, delay_s) = (f(at::SCALE), [f(at::DELAY), f(at::DELAY + 4)]);
        let gse = f(at::GSCALE);
        let (anchor_scale, anchor_delay_s, anchor_gyro_scale_error) = if version == 1 { (scale, delay_s, gse) } else { (f(at::ANCHOR_SCALE), [f(at::ANCHOR_DELAY), f(at::ANCHOR_DELAY + 4)], f(at::ANCHOR_GSCALE)) };
        let (s0, k, sigma) = ([f(at::S0), f(at::S0 + 4)], [f(at::K), f(at::K + 4)], [f(at::SIGMA), f(at::SIGMA + 4)]);
        let noise_anchors = if version < 3 { (s0, k, sigma) } else { ([f(at::ANCHOR_S0), f(at::ANCHOR_S0 + 4)], [f(at::ANCHOR_K), f(at::ANCHOR_K + 4)], [f(at::ANCHOR_SIGMA), f(at::ANCHOR_SIGMA + 4)]) };
        let r = Record {
            scale,
            delay_s,
            learnt_s: f(at::LEARNT),
            drives: le::u16(b, at::DRIVES).unwrap_or(0),
            gyro_bias_degps: f(at::BIAS),
            gyro_bias_weight_s: f(at::BIAS_W),
            gyro_scale_error: gse,
            gyro_scale_sd: f(at::GSCALE_SD),
            noise_s0_m: s0,
            noise_k: k,
            velocity_sigma_mps: sigma,
            nominal_dt_s: f(at::DT),
            anchor_scale,
            anchor_delay_s,
            anchor_gyro_scale_error,
            anchor_noise_s0_m: noise_anchors.0,
            anchor_noise_k: noise_anchors.1,
            anchor_velocity_sigma_mps: noise_anchors.2,
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
            anchor_scale: 0.9951,
            anchor_delay_s: [0.25, f32::NAN],
            anchor_gyro_scale_error: -0.012,
            anchor_noise_s0_m: [1.1, 1.3],
            anchor_noise_k: [0.01, 0.011],
            anchor_velocity_sigma_mps: [0.13, 0.18],
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
        c[4] = 4;
        assert_eq!(Record::decode(&c), Err(RecordError::BadVersion { version: 4 }));
        // A well-formed record of an impossible car: refused by field, with its offset.
        let mut r = example();
        r.scale = 1.5;
        let e = Record::decode(&r.encode()).unwrap_err();
        assert_eq!(e.offset(), 8);
        assert!(e.expected().contains("scale"));
        r = example();
        r.noise_k[1] = f32::INFINITY;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 56);
        r = example();
        r.anchor_scale = 0.5;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 72);
        r = example();
        r.anchor_delay_s[0] = f32::NAN;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 76);
        r = example();
        r.anchor_gyro_scale_error = 0.3;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 84);
        r = example();
        r.anchor_noise_k[1] = -0.01;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 100);
        r = example();
        r.anchor_velocity_sigma_mps[0] = f32::NAN;
        assert_eq!(Record::decode(&r.encode()).unwrap_err().offset(), 104);
    }

    /// The record as an older build wrote it: the first `payload` bytes of this version's,
    /// under that version's header and CRC (the bytes and their length).
    fn older(r: &Record, version: u16, payload: usize) -> ([u8; RECORD_LEN], usize) {
        let mut b = r.encode();
        b[4..6].copy_from_slice(&version.to_le_bytes());
        b[6..8].copy_from_slice(&(payload as u16).to_le_bytes());
        let crc = crc32(&b[..HEADER + payload]);
        b[HEADER + payload..HEADER + payload + 4].copy_from_slice(&crc.to_le_bytes());
        (b, HEADER + payload + 4)
    }

    /// A version 1 record (before the anchors) is read, its own scale and delays its anchors;
    /// short or with a payload of the other version's length, it is refused.
    #[test]
    fn a_version_1_record_is_read_with_its_own_values_as_anchors() {
        let r = example();
        let (b, n) = older(&r, 1, PAYLOAD_V1);
        let v1 = &b[..n];
        let d = Record::decode(v1).unwrap();
        assert_eq!((d.scale, d.anchor_scale, d.anchor_delay_s[0]), (r.scale, r.scale, r.delay_s[0]));
        assert_eq!(d.anchor_gyro_scale_error, r.gyro_scale_error);
        assert!(d.anchor_delay_s[1].is_nan());
        assert_eq!(d.learnt_s, r.learnt_s);
        assert_eq!((d.anchor_noise_s0_m, d.anchor_noise_k, d.anchor_velocity_sigma_mps), (r.noise_s0_m, r.noise_k, r.velocity_sigma_mps));
        // Written back, it is a version 3 record.
        assert_eq!(&d.encode()[4..6], &VERSION.to_le_bytes());
        assert_eq!(Record::decode(&v1[..v1.len() - 1]), Err(RecordError::TooShort { len: 75 }));
        let mut wrong = b;
        wrong[6..8].copy_from_slice(&(PAYLOAD as u16).to_le_bytes());
        assert_eq!(Record::decode(&wrong[..n]), Err(RecordError::BadLength { length: PAYLOAD as u16 }));
        let mut bad = b;
        bad[20] ^= 1;
        assert_eq!(Record::decode(&bad[..n]).unwrap_err().offset(), HEADER + PAYLOAD_V1);
    }

    /// A version 2 record (before the noise's anchors) is read with its anchors of scale,
    /// delays and gyro scale, and its own noise as the noise's anchors.
    #[test]
    fn a_version_2_record_is_read_with_its_own_noise_as_the_noise_anchors() {
        let r = example();
        let (b, n) = older(&r, 2, PAYLOAD_V2);
        let v2 = &b[..n];
        assert_eq!(v2.len(), 92);
        let d = Record::decode(v2).unwrap();
        assert_eq!((d.anchor_scale, d.anchor_delay_s[0], d.anchor_gyro_scale_error), (r.anchor_scale, r.anchor_delay_s[0], r.anchor_gyro_scale_error));
        assert_eq!((d.anchor_noise_s0_m, d.anchor_noise_k, d.anchor_velocity_sigma_mps), (r.noise_s0_m, r.noise_k, r.velocity_sigma_mps));
        assert_eq!(&d.encode()[4..6], &VERSION.to_le_bytes());
        let mut wrong = b;
        wrong[6..8].copy_from_slice(&(PAYLOAD_V1 as u16).to_le_bytes());
        assert_eq!(Record::decode(&wrong[..n]), Err(RecordError::BadLength { length: PAYLOAD_V1 as u16 }));
        let mut bad = b;
        bad[90] ^= 1;
        assert_eq!(Record::decode(&bad[..n]).unwrap_err().offset(), HEADER + PAYLOAD_V2);
    }
}
