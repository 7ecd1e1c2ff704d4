//! A DBC signal mapped onto a detector signal, and the decoder of a frame over a list of them;
//! and a DBC signal mapped onto a field of the GNSS fix (a receiver that reports on CAN).

use crate::field::Field;
use detector_core::sample::Signal;

/// A DBC signal mapped to a detector signal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mapped {
    /// The frame's identifier (11 bits, or 29 with `extended`).
    pub id: u32,
    pub extended: bool,
    /// Only frames from this bus (logs with several buses); `None`: any.
    pub bus: Option<u8>,
    pub field: Field,
    /// A second field added to the first (e.g. a steering fraction).
    pub plus: Option<Field>,
    /// A multiplexed signal: present only when this multiplexor field holds this value.
    pub mux: Option<(Field, u64)>,
    pub signal: Signal,
    /// Our unit = DBC physical value * factor (a negative factor flips the sign convention).
    pub factor: f64,
    /// `factor` rounded to f32 once (the FPU path of [`Mapped::value`]).
    pub factor32: f32,
    /// Negated where this field is non-zero: a magnitude with a separate sign bit (VW's
    /// steering angle and yaw rate).
    pub neg: Option<Field>,
}

impl Mapped {
    /// A mapping; the f32 copy of the factor is made here.
    #[allow(clippy::too_many_arguments)]
    pub const fn new(id: u32, extended: bool, bus: Option<u8>, field: Field, plus: Option<Field>, mux: Option<(Field, u64)>, signal: Signal, factor: f64) -> Self {
        Mapped { id, extended, bus, field, plus, mux, signal, factor, factor32: factor as f32, neg: None }
    }

    /// This mapping, negated where `sign` (a field of the same message) is non-zero.
    pub const fn with_sign(mut self, sign: Field) -> Self {
        self.neg = Some(sign);
        self
    }

    /// Does this mapping read frames with this id, id space and bus?
    pub fn matches(&self, id: u32, extended: bool, bus: Option<u8>) -> bool {
        self.id == id && self.extended == extended && (self.bus.is_none() || bus.is_none() || self.bus == bus)
    }

    /// The value in our units, or `None` when the frame does not carry it (too short, another
    /// multiplexer value, not finite).
    pub fn value(&self, data: &[u8]) -> Option<f32> {
        if let Some((f, want)) = self.mux {
            if f.raw(data)? as u64 != want {
                return None;
            }
        }
        // Fields of up to 24 bits convert to f32 exactly: scale them on the FPU (within a few
        // f32 roundings of the f64 path, far below any sensor's resolution; f64 is soft float on
        // the Cortex-M4). Wider fields take f64.
        let narrow = |f: &Field| f.size <= 24;
        let v = if narrow(&self.field) && self.plus.as_ref().is_none_or(narrow) {
            let phys = |f: &Field| -> Option<f32> { Some(f.raw(data)? as f32 * f.factor32 + f.offset32) };
            let mut v = phys(&self.field)?;
            if let Some(p) = &self.plus {
                v += phys(p)?;
            }
            v * self.factor32
        } else {
            let mut v = self.field.physical(data)?;
            if let Some(p) = self.plus {
                v += p.physical(data)?;
            }
            (v * self.factor) as f32
        };
        let v = match &self.neg {
            Some(sign) if sign.raw(data)? != 0 => -v,
            _ => v,
        };
        v.is_finite().then_some(v)
    }
}

/// Every detector signal a frame carries under these mappings, in our units.
pub fn decode<'a>(mappings: &'a [Mapped], id: u32, extended: bool, bus: Option<u8>, data: &'a [u8]) -> impl Iterator<Item = (Signal, f32)> + 'a {
    mappings.iter().filter(move |m| m.matches(id, extended, bus)).filter_map(move |m| Some((m.signal, m.value(data)?)))
}

/// A field of the GNSS fix that a CAN message can carry (a logger's or a car's own receiver).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum GnssField {
    /// Latitude, degrees, + north. The message that carries it makes the fix's epoch.
    Lat,
    /// Longitude, degrees, + east.
    Lon,
    /// Speed over ground, m/s.
    Speed,
    /// Course over ground, degrees, 0 = north, clockwise.
    Course,
    /// The receiver's horizontal accuracy (1 sigma), metres.
    HAcc,
    /// Non-zero while the receiver has a valid fix (the fix is dropped where it is 0).
    Valid,
}

impl GnssField {
    /// Every field, in the order above.
    pub const ALL: [GnssField; 6] = [GnssField::Lat, GnssField::Lon, GnssField::Speed, GnssField::Course, GnssField::HAcc, GnssField::Valid];
    /// The field's name in map files (`gnss_lat`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            GnssField::Lat => "gnss_lat",
            GnssField::Lon => "gnss_lon",
            GnssField::Speed => "gnss_speed",
            GnssField::Course => "gnss_course",
            GnssField::HAcc => "gnss_h_acc",
            GnssField::Valid => "gnss_valid",
        }
    }
}

/// A DBC signal mapped to a field of the GNSS fix. Decoded in `f64`: a latitude needs 1e-7 deg
/// (1 cm), which `f32` holds only to about 4e-6 deg.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssMapped {
    /// The frame's identifier (11 bits, or 29 with `extended`).
    pub id: u32,
    /// The identifier is extended (29 bits).
    pub extended: bool,
    /// Only frames from this bus; `None`: any.
    pub bus: Option<u8>,
    /// Where the signal is in the payload.
    pub field: Field,
    /// A multiplexed signal: present only when this multiplexor field holds this value.
    pub mux: Option<(Field, u64)>,
    /// The fix's field it gives.
    pub target: GnssField,
    /// Our unit = DBC physical value * factor.
    pub factor: f64,
}

impl GnssMapped {
    /// Does this mapping read frames with this id, id space and bus?
    pub fn matches(&self, id: u32, extended: bool, bus: Option<u8>) -> bool {
        self.id == id && self.extended == extended && (self.bus.is_none() || bus.is_none() || self.bus == bus)
    }

    /// The value in our units, or `None` when the frame does not carry it.
    pub fn value(&self, data: &[u8]) -> Option<f64> {
        if let Some((f, want)) = self.mux {
            if f.raw(data)? as u64 != want {
                return None;
            }
        }
        let v = self.field.physical(data)? * self.factor;
        v.is_finite().then_some(v)
    }
}

/// Every GNSS field a frame carries under these mappings, in our units.
pub fn decode_gnss<'a>(mappings: &'a [GnssMapped], id: u32, extended: bool, bus: Option<u8>, data: &'a [u8]) -> impl Iterator<Item = (GnssField, f64)> + 'a {
    mappings.iter().filter(move |m| m.matches(id, extended, bus)).filter_map(move |m| Some((m.target, m.value(data)?)))
}
