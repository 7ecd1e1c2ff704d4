//! Strategy 2's turn templates, the wire format (`GGTT`): labelled steering series, read in place
//! from flash ([`TemplateSet::parse`] validates once; reads never panic).
//!
//! Little endian:
//! `"GGTT" | version u16 = 1 | len u16 (= QUERY_LEN) | band u16 | count u16 | reserved u16 |
//! count x (class u8 | provenance u8 | len x i16 steering in 0.1 deg) | crc32 u32` (CRC over all
//! bytes before it).

use super::crc32::crc32;
use super::le;

/// Points of a classified segment (and of every template).
pub const QUERY_LEN: usize = 32;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
/// What a steering segment is: a left turn, a right turn or neither.
pub enum TurnClass {
    /// No turn.
    None = 0,
    /// A left turn.
    Left = 1,
    /// A right turn.
    Right = 2,
}

impl TurnClass {
    /// The class of its byte in a blob.
    pub fn from_u8(x: u8) -> Option<Self> {
        match x {
            0 => Some(TurnClass::None),
            1 => Some(TurnClass::Left),
            2 => Some(TurnClass::Right),
            _ => None,
        }
    }
    /// `none`, `left` or `right`.
    pub const fn name(self) -> &'static str {
        match self {
            TurnClass::None => "none",
            TurnClass::Left => "left",
            TurnClass::Right => "right",
        }
    }
}

/// Where a template's steering came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Provenance {
    /// A steering wheel angle sensor.
    Measured = 0,
    /// The yaw-rate proxy through the bicycle model.
    Derived = 1,
    /// The simulator.
    Simulated = 2,
}

impl Provenance {
    /// The provenance of its byte in a blob.
    pub fn from_u8(x: u8) -> Option<Self> {
        match x {
            0 => Some(Provenance::Measured),
            1 => Some(Provenance::Derived),
            2 => Some(Provenance::Simulated),
            _ => None,
        }
    }
    /// `measured`, `derived` or `simulated`.
    pub const fn name(self) -> &'static str {
        match self {
            Provenance::Measured => "measured",
            Provenance::Derived => "derived",
            Provenance::Simulated => "simulated",
        }
    }
}

/// Why a template blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlobError {
    /// Shorter than a header and a CRC.
    TooShort,
    /// The first four bytes are not `GGTT`.
    BadMagic,
    /// A version this build does not read.
    BadVersion,
    /// Not 32 points per template, a band beyond them, or a length that does not match.
    BadShape,
    /// The CRC does not match.
    BadCrc,
    /// A template's class or provenance byte is unknown.
    BadRecord,
}

/// The blob's magic and version.
pub const MAGIC: &[u8; 4] = b"GGTT";
/// The blob version this build reads.
pub const VERSION: u16 = 1;
const HEADER: usize = 14;

/// A validated view of a template blob. The templates stay where the bytes are (flash).
#[derive(Clone, Copy, Debug)]
pub struct TemplateSet<'a> {
    bytes: &'a [u8],
    count: usize,
    band: usize,
}

impl<'a> TemplateSet<'a> {
    /// Validates a blob (magic, version, shape, CRC, every record) and reads it in place.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        if bytes.len() < HEADER + 4 {
            return Err(BlobError::TooShort);
        }
        if bytes.get(..4) != Some(&MAGIC[..]) {
            return Err(BlobError::BadMagic);
        }
        if le::u16(bytes, 4) != Some(VERSION) {
            return Err(BlobError::BadVersion);
        }
        let len = le::u16(bytes, 6).unwrap_or(0) as usize;
        let band = le::u16(bytes, 8).unwrap_or(0) as usize;
        let count = le::u16(bytes, 10).unwrap_or(0) as usize;
        if len != QUERY_LEN || band > QUERY_LEN {
            return Err(BlobError::BadShape);
        }
        let rec = 2 + 2 * len;
        if bytes.len() != HEADER + count * rec + 4 {
            return Err(BlobError::BadShape);
        }
        let body = bytes.len() - 4;
        if Some(crc32(bytes.get(..body).unwrap_or(&[]))) != le::u32(bytes, body) {
            return Err(BlobError::BadCrc);
        }
        let set = TemplateSet { bytes, count, band };
        for i in 0..count {
            let r = set.record(i);
            if r.first().copied().and_then(TurnClass::from_u8).is_none() || r.get(1).copied().and_then(Provenance::from_u8).is_none() {
                return Err(BlobError::BadRecord);
            }
        }
        Ok(set)
    }

    /// Templates in the set.
    pub fn len(&self) -> usize {
        self.count
    }
    /// No template.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
    /// The Sakoe-Chiba band the templates were trained with.
    pub fn band(&self) -> usize {
        self.band
    }

    /// Template `i`'s bytes (empty past the end: `parse` checked the length).
    fn record(&self, i: usize) -> &'a [u8] {
        let rec = 2 + 2 * QUERY_LEN;
        self.bytes.get(HEADER + i * rec..HEADER + (i + 1) * rec).unwrap_or(&[])
    }

    /// Template `i`: class, provenance, and its series in degrees.
    pub fn get(&self, i: usize) -> (TurnClass, Provenance, [f32; QUERY_LEN]) {
        let r = self.record(i);
        let mut v = [0.0f32; QUERY_LEN];
        for (x, b) in v.iter_mut().zip(r.get(2..).unwrap_or(&[]).chunks_exact(2)) {
            *x = i16::from_le_bytes([b.first().copied().unwrap_or(0), b.get(1).copied().unwrap_or(0)]) as f32 * 0.1;
        }
        let class = r.first().copied().and_then(TurnClass::from_u8).unwrap_or(TurnClass::None);
        let provenance = r.get(1).copied().and_then(Provenance::from_u8).unwrap_or(Provenance::Measured);
        (class, provenance, v)
    }

    /// Writes a blob (host tools use this; no allocation: into `out`, returns the length).
    pub fn encode(band: u16, templates: &[(TurnClass, Provenance, [f32; QUERY_LEN])], out: &mut [u8]) -> Option<usize> {
        let rec = 2 + 2 * QUERY_LEN;
        let n = HEADER + templates.len() * rec + 4;
        if out.len() < n || templates.len() > u16::MAX as usize {
            return None;
        }
        out[0..4].copy_from_slice(MAGIC);
        out[4..6].copy_from_slice(&VERSION.to_le_bytes());
        out[6..8].copy_from_slice(&(QUERY_LEN as u16).to_le_bytes());
        out[8..10].copy_from_slice(&band.to_le_bytes());
        out[10..12].copy_from_slice(&(templates.len() as u16).to_le_bytes());
        out[12..14].copy_from_slice(&0u16.to_le_bytes());
        for (i, (c, p, v)) in templates.iter().enumerate() {
            let o = HEADER + i * rec;
            out[o] = *c as u8;
            out[o + 1] = *p as u8;
            for (k, x) in v.iter().enumerate() {
                let q = libm::roundf(x * 10.0).clamp(i16::MIN as f32, i16::MAX as f32) as i16;
                out[o + 2 + 2 * k..o + 4 + 2 * k].copy_from_slice(&q.to_le_bytes());
            }
        }
        let crc = crc32(&out[..n - 4]);
        out[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        Some(n)
    }
}
