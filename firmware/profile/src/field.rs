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
}

impl Field {
    /// The raw integer, or `None` when the field does not fit in `data` or is malformed.
    pub fn raw(&self, data: &[u8]) -> Option<i64> {
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
        if self.signed && n < 64 && (v >> (n - 1)) & 1 == 1 {
            Some((v | (!0u64 << n)) as i64)
        } else {
            Some(v as i64)
        }
    }

    pub fn physical(&self, data: &[u8]) -> Option<f64> {
        self.raw(data).map(|r| r as f64 * self.factor + self.offset)
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
