//! The Cortex-M4 kernel's algorithm in Rust, one function per instruction, on activations in
//! the DSP layout ([`crate::dsp_index`]). It lets the host test the layout and the pairing of
//! bytes with halfwords that the assembly relies on; the QEMU run tests the assembly itself.

/// `SXTB16 Rd, Rm, ROR #rot`: bytes 0 and 2 of `Rm` rotated right by `rot` bits, each
/// sign-extended into a halfword.
pub fn sxtb16(rm: u32, rot: u32) -> u32 {
    let r = rm.rotate_right(rot);
    let lo = (r as u8 as i8 as i16) as u16 as u32;
    let hi = ((r >> 16) as u8 as i8 as i16) as u16 as u32;
    lo | (hi << 16)
}

/// `SMLAD Rd, Rn, Rm, Ra`: `Ra + Rn.lo * Rm.lo + Rn.hi * Rm.hi`, halfwords signed (wrapping, as
/// the instruction; the kernel's sums never wrap).
pub fn smlad(rn: u32, rm: u32, ra: i32) -> i32 {
    let p0 = (rn as u16 as i16 as i32) * (rm as u16 as i16 as i32);
    let p1 = ((rn >> 16) as u16 as i16 as i32) * ((rm >> 16) as u16 as i16 as i32);
    ra.wrapping_add(p0).wrapping_add(p1)
}

/// Little-endian word of four weight bytes (an `LDR`).
fn ldr(w: &[u8]) -> u32 {
    let b = |i: usize| w.get(i).copied().unwrap_or(0) as u32;
    b(0) | b(1) << 8 | b(2) << 16 | b(3) << 24
}

/// Two halfwords as one word (half of an `LDRD`).
fn pair(lo: i16, hi: i16) -> u32 {
    lo as u16 as u32 | (hi as u16 as u32) << 16
}

/// The assembly's loop: `groups` groups of four columns of two rows against activations in the
/// DSP layout (`v` holds at least `4 * groups` of them).
pub fn dot2_groups(w0: &[u8], w1: &[u8], v: &[i16], groups: usize) -> (i32, i32) {
    let (mut a0, mut a1) = (0i32, 0i32);
    for g in 0..groups {
        let at = |i: usize| v.get(4 * g + i).copied().unwrap_or(0);
        let (x, y) = (pair(at(0), at(1)), pair(at(2), at(3)));
        let r0 = ldr(w0.get(4 * g..).unwrap_or(&[]));
        a0 = smlad(sxtb16(r0, 0), x, a0);
        a0 = smlad(sxtb16(r0, 8), y, a0);
        let r1 = ldr(w1.get(4 * g..).unwrap_or(&[]));
        a1 = smlad(sxtb16(r1, 0), x, a1);
        a1 = smlad(sxtb16(r1, 8), y, a1);
    }
    (a0, a1)
}

/// The whole Cortex-M4 `dot2` on natural-order activations: lays them out as
/// [`crate::Activations::load`] does, runs [`dot2_groups`] over the complete groups and adds the
/// tail in natural order, as [`crate::Activations::dot2`] does on the target. Sums over
/// `i < min(w0.len(), w1.len(), v.len())`; must equal [`crate::portable::dot2`].
pub fn dot2(w0: &[u8], w1: &[u8], v: &[i16]) -> (i32, i32) {
    let n = w0.len().min(w1.len()).min(v.len());
    let at = |i: usize| v.get(crate::dsp_index(i, n)).copied().unwrap_or(0);
    let mut laid = [0i16; 4];
    let (mut a0, mut a1) = (0i32, 0i32);
    for g in 0..n / 4 {
        for (k, x) in laid.iter_mut().enumerate() {
            *x = at(4 * g + k);
        }
        let (s0, s1) = dot2_groups(w0.get(4 * g..).unwrap_or(&[]), w1.get(4 * g..).unwrap_or(&[]), &laid, 1);
        a0 += s0;
        a1 += s1;
    }
    for i in n / 4 * 4..n {
        let x = v.get(i).map_or(0, |x| *x as i32);
        a0 += w0.get(i).map_or(0, |w| *w as i8 as i32) * x;
        a1 += w1.get(i).map_or(0, |w| *w as i8 as i32) * x;
    }
    (a0, a1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::portable;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_dsp_algorithm_on_the_dsp_layout_equals_the_reference(
            w0 in proptest::collection::vec(any::<u8>(), 0..200),
            w1 in proptest::collection::vec(any::<u8>(), 0..200),
            v in proptest::collection::vec(any::<i16>(), 0..200),
        ) {
            prop_assert_eq!(dot2(&w0, &w1, &v), portable::dot2(&w0, &w1, &v));
        }
    }

    #[test]
    fn instruction_models_match_the_architecture_manual() {
        // Bytes 0x80 (-128) and 0x7f (127) at positions 0 and 2; 0xff (-1) and 0x01 at 1 and 3.
        let w = 0x01_7f_ff_80u32;
        assert_eq!(sxtb16(w, 0), 0x007f_ff80);
        assert_eq!(sxtb16(w, 8), 0x0001_ffff);
        assert_eq!(smlad(0x0002_fffd, 0x0004_0005, 10), 10 - 15 + 8);
        // Extremes: -128 * -32768 twice is 2^23: no wrap.
        assert_eq!(smlad(sxtb16(0x0080_0080, 0), pair(i16::MIN, i16::MIN), 0), 1 << 23);
    }
}
