//! Little-endian reads from a byte slice. Out of range is `None`, never a panic.

/// `N` bytes at `at`.
pub fn bytes<const N: usize>(b: &[u8], at: usize) -> Option<[u8; N]> {
    b.get(at..at.checked_add(N)?)?.try_into().ok()
}
/// A `u16` at byte `at`.
pub fn u16(b: &[u8], at: usize) -> Option<u16> {
    bytes(b, at).map(u16::from_le_bytes)
}
/// A `u32` at byte `at`.
pub fn u32(b: &[u8], at: usize) -> Option<u32> {
    bytes(b, at).map(u32::from_le_bytes)
}
/// An `i16` at byte `at`.
pub fn i16(b: &[u8], at: usize) -> Option<i16> {
    bytes(b, at).map(i16::from_le_bytes)
}
/// An `i32` at byte `at`.
pub fn i32(b: &[u8], at: usize) -> Option<i32> {
    bytes(b, at).map(i32::from_le_bytes)
}
/// An `f32` at byte `at`.
pub fn f32(b: &[u8], at: usize) -> Option<f32> {
    bytes(b, at).map(f32::from_le_bytes)
}
/// An `f64` at byte `at`.
pub fn f64(b: &[u8], at: usize) -> Option<f64> {
    bytes(b, at).map(f64::from_le_bytes)
}

#[cfg(test)]
mod tests {
    #[test]
    fn reads_in_range_and_refuses_past_the_end() {
        let b = [1u8, 2, 3, 4, 5];
        assert_eq!(super::u16(&b, 0), Some(0x0201));
        assert_eq!(super::u32(&b, 1), Some(0x0504_0302));
        assert_eq!(super::u32(&b, 2), None);
        assert_eq!(super::u16(&b, usize::MAX), None);
    }
}
