//! Single-precision square root: the FPU's `VSQRT.F32` where the target has one, libm elsewhere.
//!
//! libm has no Arm path for `sqrtf`: on a Cortex-M4F it computes the root in integer arithmetic
//! with a 256-byte table (about 480 bytes of flash and tens of instructions a call), although
//! the FPU has the instruction. IEEE 754 requires a square root to be correctly rounded, and
//! libm's is too, so both give the same bits for every input that is not a NaN (a NaN's payload
//! and sign may differ; it is a NaN either way). The QEMU run checks that on the target itself
//! (`firmware/qemu-run`), edge cases and a sweep of bit patterns; [`tests`] checks libm's side.

/// `sqrt(x)`, correctly rounded; a NaN for `x < 0` and for a NaN.
#[inline]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(fpu_sqrt)]
    {
        vsqrt(x)
    }
    #[cfg(not(fpu_sqrt))]
    {
        libm::sqrtf(x)
    }
}

/// Whether [`sqrtf`] is the FPU instruction on this build.
pub const HARDWARE_SQRT: bool = cfg!(fpu_sqrt);

#[cfg(fpu_sqrt)]
#[inline(never)]
fn vsqrt(x: f32) -> f32 {
    let bits: u32;
    // Stable Rust does not let inline assembly name the FPU's registers on Arm (their register
    // classes need the unstable `vfp2` target feature), so the value travels through core
    // registers and S0 is saved and restored around the instruction: five instructions, against
    // libm's tens.
    //
    // SAFETY: the block reads and writes only core registers it declares and S0, which it
    // restores before it ends, so no register the compiler uses changes. VSQRT.F32 touches no
    // memory, no stack and no condition flags (only FPSCR's cumulative exception bits, which
    // nothing in this program reads). `fpu_sqrt` is set only for hard-float ARMv7E-M targets,
    // whose FPU (FPv4-SP, FPv5) has the instruction; an interrupt that uses the FPU gets S0
    // stacked and restored by the hardware.
    unsafe {
        core::arch::asm!(
            "vmov {save}, s0",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {r}, s0",
            "vmov s0, {save}",
            x = in(reg) x.to_bits(),
            r = lateout(reg) bits,
            save = out(reg) _,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::sqrtf;

    /// The reference itself: libm's root is correctly rounded (neither neighbour of the result
    /// is nearer the exact root, taken in f64), on a sweep of bit patterns over every exponent,
    /// subnormals included.
    #[test]
    fn libm_sqrtf_is_correctly_rounded() {
        let mut bits = 0u32;
        while bits < 0x7F80_0000 {
            let x = f32::from_bits(bits);
            let r = sqrtf(x);
            let exact = (x as f64).sqrt();
            let err = |v: f32| ((v as f64) - exact).abs();
            let up = f32::from_bits(r.to_bits() + 1);
            assert!(err(r) <= err(up), "sqrtf({x:e}) = {r:e} but {up:e} is nearer");
            if r.to_bits() > 0 {
                let down = f32::from_bits(r.to_bits() - 1);
                assert!(err(r) <= err(down), "sqrtf({x:e}) = {r:e} but {down:e} is nearer");
            }
            bits += 0x3F1; // a prime-ish stride: about 2.1 million inputs, every exponent
        }
    }

    #[test]
    fn edge_cases() {
        assert_eq!(sqrtf(0.0).to_bits(), 0);
        assert_eq!(sqrtf(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrtf(f32::INFINITY), f32::INFINITY);
        assert!(sqrtf(-1.0).is_nan());
        assert!(sqrtf(f32::NEG_INFINITY).is_nan());
        assert!(sqrtf(f32::NAN).is_nan());
        assert_eq!(sqrtf(4.0), 2.0);
    }
}
