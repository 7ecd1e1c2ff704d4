//! CAN frames decoded through a vehicle profile: a DBC and a map file, loaded by
//! `gnss-guard-profile`, the same loader and decoder the firmware's build script uses. No
//! hand-written bit positions, and no second mapping: the RAV4 profile is the firmware's own map.

use detector_core::sample::Signal;
use gnss_guard_profile::load::{self, LoadError, Profile};

/// The Toyota RAV4 map of the comma2k19 data (opendbc `toyota_rav4_2017` names): the firmware's
/// `firmware/board/profiles/toyota_rav4.map`.
pub const RAV4_MAP: &str = include_str!("../../../firmware/board/profiles/toyota_rav4.map");

/// A compiled decoder: the profile's mappings.
#[derive(Clone, Debug)]
pub struct Decoder {
    profile: Profile,
}

impl Decoder {
    /// Loads the map against the DBC's text.
    pub fn new(dbc_text: &str, map_text: &str) -> Result<Self, LoadError> {
        Ok(Decoder { profile: load::load(dbc_text, map_text)? })
    }

    /// Every detector signal one standard-id frame carries, in our units.
    pub fn decode<'a>(&'a self, id: u32, data: &'a [u8]) -> impl Iterator<Item = (Signal, f32)> + 'a {
        gnss_guard_profile::decode(&self.profile.mappings, id, false, None, data)
    }
}

#[cfg(test)]
mod tests {
    use gnss_guard_profile::Field;

    #[test]
    fn motorola_and_intel_fields() {
        // 12-bit signed Motorola field starting at bit 3 (STEER_ANGLE): bytes 0..2 = 0x0F 0xFF -> -1
        let f = Field::new(3, 12, true, true, 1.5, 0.0);
        assert_eq!(f.raw(&[0x0F, 0xFF, 0, 0, 0, 0, 0, 0]), Some(-1));
        assert_eq!(f.physical(&[0x00, 0x01, 0, 0, 0, 0, 0, 0]), Some(1.5));
        // 16-bit unsigned Motorola SPEED at 47: bytes 5..6
        let s = Field::new(47, 16, true, false, 0.01, 0.0);
        assert_eq!(s.raw(&[0, 0, 0, 0, 0, 0x12, 0x34, 0]), Some(0x1234));
        let le = Field::new(4, 8, false, false, 1.0, 0.0);
        assert_eq!(le.raw(&[0xA0, 0x0B]), Some(0xBA));
        assert_eq!(s.raw(&[0, 0]), None, "short frame");
    }
}
