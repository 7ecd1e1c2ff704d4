//! A DBC signal mapped onto a detector signal, and the decoder of a frame over a list of them.

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
}

impl Mapped {
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
        let mut v = self.field.physical(data)?;
        if let Some(p) = self.plus {
            v += p.physical(data)?;
        }
        let v = (v * self.factor) as f32;
        v.is_finite().then_some(v)
    }
}

/// Every detector signal a frame carries under these mappings, in our units.
pub fn decode<'a>(mappings: &'a [Mapped], id: u32, extended: bool, bus: Option<u8>, data: &'a [u8]) -> impl Iterator<Item = (Signal, f32)> + 'a {
    mappings.iter().filter(move |m| m.matches(id, extended, bus)).filter_map(move |m| Some((m.signal, m.value(data)?)))
}
