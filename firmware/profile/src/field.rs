//! A signal's bits in a CAN payload, as a DBC describes them: start bit, size, byte order
//! (Intel little-endian or Motorola big-endian), sign, factor and offset. Decoding and encoding;
//! out of range is `None` or `false`, never a panic.

/// A bit field of a CAN payload as a DBC describes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Field {
    pub start_bit: u16,
    pub size: u8,
    pub big_endian: bool,
    pub signed: bool,
    pub factor: f64,
    pub offset: f64,
    /// `factor` and `offset` rounded to f32 once (the Cortex-M4's FPU path; see
    /// [`crate::Mapped::value`]).
    pub factor32: f32,
    pub offset32: f32,
}

impl Field {
    /// A field; the f32 copies of factor and offset are made here.
    pub const fn new(start_bit: u16, size: u8, big_endian: bool, signed: bool, factor: f64, offset: f64) -> Self {
        Field { start_bit, size, big_endian, signed, factor, offset, factor32: factor as f32, offset32: offset as f32 }
    }

    /// The raw integer, or `None` when the field does not fit in `data` or is malformed.
    pub fn raw(&self, data: &[u8]) -> Option<i64> {
        let n = self.size as u32;
        if n == 0 || n > 64 {
            return None;
        }
        // The bits lie in consecutive bytes `first..=last`: Intel from the start bit up,
        // Motorola from the start bit (the MSB) down a byte and on to the next byte's MSB,
        // which in big-endian bit order is a run too. Read them as one word and shift.
        let start = self.start_bit as usize;
        let first = start / 8;
        let (skip, last) = if self.big_endian {
            let msb = 7 - start % 8; // bits above the MSB in the first byte
            (msb, (8 * first + msb + n as usize - 1) / 8)
        } else {
            (start % 8, (start + n as usize - 1) / 8)
        };
        if last - first < 8 {
            let bytes = data.get(first..=last)?;
            let v = if self.big_endian {
                let w = bytes.iter().fold(0u64, |w, b| (w << 8) | *b as u64);
                w >> (8 * bytes.len() - skip - n as usize)
            } else {
                bytes.iter().rev().fold(0u64, |w, b| (w << 8) | *b as u64) >> skip
            };
            let v = if n == 64 { v } else { v & ((1u64 << n) - 1) };
            return Some(self.extend(v, n));
        }
        self.raw_bitwise(data)
    }

    /// Sign extension of an `n`-bit raw value.
    fn extend(&self, v: u64, n: u32) -> i64 {
        if self.signed && n < 64 && (v >> (n - 1)) & 1 == 1 {
            (v | (!0u64 << n)) as i64
        } else {
            v as i64
        }
    }

    /// [`Field::raw`] bit by bit, as the DBC defines the layout: the reference for the word
    /// reads above, and what fields spanning nine bytes (CAN FD) take.
    pub fn raw_bitwise(&self, data: &[u8]) -> Option<i64> {
        let n = self.size as u32;
        if n == 0 || n > 64 {
            return None;
        }
        let mut v: u64 = 0;
        let mut bit = self.start_bit as usize;
        for i in 0..n {
            let byte = *data.get(bit / 8)?;
            let b = (byte >> (bit % 8)) & 1;
            if self.big_endian {
                // Motorola: the start bit is the MSB; walk down a byte, then to the next byte's MSB.
                v = (v << 1) | b as u64;
                bit = if bit.is_multiple_of(8) { bit + 15 } else { bit - 1 };
            } else {
                v |= (b as u64) << i;
                bit += 1;
            }
        }
        Some(self.extend(v, n))
    }

    /// The physical value, `raw * factor + offset`. An unsigned 64-bit field's raw value is
    /// taken as unsigned (`raw` returns its bits as `i64`; found by the cantools cross-check).
    pub fn physical(&self, data: &[u8]) -> Option<f64> {
        let r = self.raw(data)?;
        let x = if self.signed { r as f64 } else { r as u64 as f64 };
        Some(x * self.factor + self.offset)
    }

    /// Writes `raw` into `data` (the inverse of [`Field::raw`]); `false` when it does not fit.
    pub fn put_raw(&self, data: &mut [u8], raw: i64) -> bool {
        let n = self.size as u32;
        if n == 0 || n > 64 {
            return false;
        }
        let v = raw as u64;
        let mut bit = self.start_bit as usize;
        for i in 0..n {
            let Some(byte) = data.get_mut(bit / 8) else { return false };
            let b = if self.big_endian { (v >> (n - 1 - i)) & 1 } else { (v >> i) & 1 } as u8;
            *byte = (*byte & !(1 << (bit % 8))) | (b << (bit % 8));
            bit = if self.big_endian {
                if bit.is_multiple_of(8) { bit + 15 } else { bit - 1 }
            } else {
                bit + 1
            };
        }
        true
    }

    /// Writes a physical value (rounded to the field's resolution).
    pub fn put(&self, data: &mut [u8], value: f64) -> bool {
        if !value.is_finite() || self.factor == 0.0 {
            return false;
        }
        self.put_raw(data, libm::round((value - self.offset) / self.factor) as i64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn an_unsigned_64_bit_field_is_unsigned() {
        let f = Field::new(0, 64, false, false, 1.0, 0.0);
        assert_eq!(f.physical(&[0xFF; 8]), Some(u64::MAX as f64));
        assert_eq!(Field::new(0, 64, false, true, 1.0, 0.0).physical(&[0xFF; 8]), Some(-1.0));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The word reads equal the bit-by-bit definition for every layout, including fields
        /// running past the payload (both `None`).
        #[test]
        fn word_reads_equal_the_bitwise_definition(
            start in 0u16..520, size in 0u8..=66, big_endian: bool, signed: bool,
            data in proptest::collection::vec(any::<u8>(), 0..=64),
        ) {
            let f = Field::new(start, size, big_endian, signed, 1.0, 0.0);
            prop_assert_eq!(f.raw(&data), f.raw_bitwise(&data));
        }
    }
}
