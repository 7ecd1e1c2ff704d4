//! CAN signal decoding driven by a DBC file (parsed with `can-dbc`): no hand-written bit
//! positions. A [`Profile`] maps DBC signals onto the detector's [`Signal`]s with a unit scale.

use detector_core::sample::Signal;

/// Where one detector signal lives in a DBC, and how to convert it to our units.
#[derive(Clone, Debug)]
pub struct Mapping {
    pub message: &'static str,
    pub signal: &'static str,
    /// Optional second DBC signal added to the first (e.g. a steering fraction).
    pub plus: Option<&'static str>,
    pub to: Signal,
    /// Our value = DBC physical value * scale.
    pub scale: f64,
}

/// The Toyota RAV4 profile of the comma2k19 data (opendbc `toyota_rav4_2017` names).
pub const RAV4: &[Mapping] = &[
    Mapping { message: "SPEED", signal: "SPEED", plus: None, to: Signal::WheelSpeed, scale: 1.0 / 3.6 },
    Mapping { message: "STEER_ANGLE_SENSOR", signal: "STEER_ANGLE", plus: Some("STEER_FRACTION"), to: Signal::Steering, scale: 1.0 },
    Mapping { message: "GAS_PEDAL", signal: "GAS_PEDAL", plus: None, to: Signal::Pedal, scale: 100.0 },
    Mapping { message: "KINEMATICS", signal: "YAW_RATE", plus: None, to: Signal::YawRate, scale: 1.0 },
    Mapping { message: "ACCELEROMETER", signal: "ACCEL_X", plus: None, to: Signal::LongAccel, scale: 1.0 },
];

/// The bit-field decoder is the firmware's own (one implementation for both).
pub use gnss_guard_board::can::Field;

fn field_from_dbc(s: &can_dbc::Signal) -> Field {
    Field {
        start_bit: s.start_bit as u16,
        size: s.size as u8,
        big_endian: s.byte_order == can_dbc::ByteOrder::BigEndian,
        signed: s.value_type == can_dbc::ValueType::Signed,
        factor: s.factor,
        offset: s.offset,
    }
}

/// A compiled decoder: message id -> (fields, target signal, scale).
#[derive(Clone, Debug)]
pub struct Decoder {
    entries: Vec<(u32, Field, Option<Field>, Signal, f64)>,
}

impl Decoder {
    /// Compiles `profile` against the DBC text; names the first mapping the DBC lacks.
    pub fn new(dbc_text: &str, profile: &[Mapping]) -> Result<Self, String> {
        let dbc = can_dbc::Dbc::try_from(dbc_text).map_err(|e| format!("not a valid DBC: {e:?}"))?;
        let mut entries = Vec::new();
        for m in profile {
            let msg = dbc.messages.iter().find(|x| x.name == m.message)
                .ok_or_else(|| format!("expected message {} in the DBC", m.message))?;
            let find = |name: &str| msg.signals.iter().find(|s| s.name == name).map(field_from_dbc)
                .ok_or_else(|| format!("expected signal {}.{} in the DBC", m.message, name));
            let main = find(m.signal)?;
            let plus = m.plus.map(find).transpose()?;
            entries.push((msg.id.raw(), main, plus, m.to, m.scale));
        }
        Ok(Decoder { entries })
    }

    /// Every detector signal carried by one frame, in our units.
    pub fn decode<'a>(&'a self, id: u32, data: &'a [u8]) -> impl Iterator<Item = (Signal, f64)> + 'a {
        self.entries.iter().filter(move |e| e.0 == id).filter_map(move |(_, f, p, sig, scale)| {
            let mut v = f.physical(data)?;
            if let Some(p) = p {
                v += p.physical(data)?;
            }
            v.is_finite().then_some((*sig, v * scale))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motorola_and_intel_fields() {
        // 12-bit signed Motorola field starting at bit 3 (STEER_ANGLE): bytes 0..2 = 0x0F 0xFF -> -1
        let f = Field { start_bit: 3, size: 12, big_endian: true, signed: true, factor: 1.5, offset: 0.0 };
        assert_eq!(f.raw(&[0x0F, 0xFF, 0, 0, 0, 0, 0, 0]), Some(-1));
        assert_eq!(f.physical(&[0x00, 0x01, 0, 0, 0, 0, 0, 0]), Some(1.5));
        // 16-bit unsigned Motorola SPEED at 47: bytes 5..6
        let s = Field { start_bit: 47, size: 16, big_endian: true, signed: false, factor: 0.01, offset: 0.0 };
        assert_eq!(s.raw(&[0, 0, 0, 0, 0, 0x12, 0x34, 0]), Some(0x1234));
        let le = Field { start_bit: 4, size: 8, big_endian: false, signed: false, factor: 1.0, offset: 0.0 };
        assert_eq!(le.raw(&[0xA0, 0x0B]), Some(0xBA));
        assert_eq!(s.raw(&[0, 0]), None, "short frame");
    }
}
