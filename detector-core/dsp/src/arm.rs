//! The Cortex-M4 kernel: inline assembly with the DSP extension (ARMv7E-M).
//!
//! Per group of four columns and two rows: one `LDRD` of the activations (`v0 v2 | v1 v3`, the
//! DSP layout), one `LDR` of each row's four weight bytes, two `SXTB16` per row (bytes 0 and 2,
//! then with `ROR #8` bytes 1 and 3) and two `SMLAD` per row. The loop body covers two groups:
//! 22 instructions and `SUBS` + `BNE` per 16 multiply-accumulates (1.5 per MAC). Its algorithm,
//! instruction by instruction, is [`crate::emulated::dot2_groups`].
//!
//! [`matvec`] does four consecutive rows of a matrix with `S` columns at a time: one `LDRD` of
//! the activations serves four rows, and the rows are reached by immediate offsets `S`, `2S`,
//! `3S` from one pointer, so eleven registers suffice. 21 instructions per group of four columns
//! of four rows (1.31 per multiply-accumulate), eight groups per loop iteration.

use core::arch::asm;

/// One group of four columns of two rows: the body of the loop, as text.
macro_rules! group {
    () => {
        concat!(
            "ldrd {x}, {y}, [{pv}], #8\n",
            "ldr {w}, [{p0}], #4\n",
            "sxtb16 {t}, {w}\n",
            "smlad {a0}, {t}, {x}, {a0}\n",
            "sxtb16 {t}, {w}, ror #8\n",
            "smlad {a0}, {t}, {y}, {a0}\n",
            "ldr {w}, [{p1}], #4\n",
            "sxtb16 {t}, {w}\n",
            "smlad {a1}, {t}, {x}, {a1}\n",
            "sxtb16 {t}, {w}, ror #8\n",
            "smlad {a1}, {t}, {y}, {a1}\n",
        )
    };
}

/// One group of four columns of four rows at `{p}`, `{p} + S`, `{p} + 2S`, `{p} + 3S`.
macro_rules! group4 {
    () => {
        concat!(
            "ldrd {x}, {y}, [{pv}], #8\n",
            "ldr {w}, [{p}, #{s1}]\n",
            "sxtb16 {t}, {w}\n",
            "smlad {a1}, {t}, {x}, {a1}\n",
            "sxtb16 {t}, {w}, ror #8\n",
            "smlad {a1}, {t}, {y}, {a1}\n",
            "ldr {w}, [{p}, #{s2}]\n",
            "sxtb16 {t}, {w}\n",
            "smlad {a2}, {t}, {x}, {a2}\n",
            "sxtb16 {t}, {w}, ror #8\n",
            "smlad {a2}, {t}, {y}, {a2}\n",
            "ldr {w}, [{p}, #{s3}]\n",
            "sxtb16 {t}, {w}\n",
            "smlad {a3}, {t}, {x}, {a3}\n",
            "sxtb16 {t}, {w}, ror #8\n",
            "smlad {a3}, {t}, {y}, {a3}\n",
            "ldr {w}, [{p}], #4\n",
            "sxtb16 {t}, {w}\n",
            "smlad {a0}, {t}, {x}, {a0}\n",
            "sxtb16 {t}, {w}, ror #8\n",
            "smlad {a0}, {t}, {y}, {a0}\n",
        )
    };
}

/// Four consecutive rows of a row-major matrix with `S` columns times `v` (only for `S` a
/// multiple of 4; else nothing is written): `out[r] = sum w[r * S + i] * v[i]`, four rows per pass, for the rows in `out` that `w`
/// holds whole (a last `out.len() % 4` rows are left as they are). `v` must be the storage of an
/// [`crate::Activations`] (8-byte aligned, DSP layout) holding at least `S` activations; if it
/// holds fewer, nothing is written. Returns the number of rows written.
pub fn matvec<const S: usize>(w: &[u8], v: &[i16], out: &mut [i32]) -> usize {
    // The offsets are LDR immediates (12 bits).
    const { assert!(3 * S <= 4095) };
    if v.len() < S || S % 4 != 0 {
        return 0;
    }
    let mut rows = 0;
    for (o, wq) in out.chunks_exact_mut(4).zip(w.chunks_exact(4 * S)) {
        o.copy_from_slice(&quad::<S>(wq, v));
        rows += 4;
    }
    rows
}

/// One pass of [`matvec`]: `w` holds exactly four rows (`4 * S` bytes) and `v` at least `S`
/// activations (both checked by the caller's `chunks_exact` and length test).
#[inline(always)]
fn quad<const S: usize>(w: &[u8], v: &[i16]) -> [i32; 4] {
    let mut a = [0i32; 4];
    if w.len() < 4 * S || v.len() < S {
        return a;
    }
    let (mut p, mut pv) = (w.as_ptr(), v.as_ptr());
    let eights = S / 32;
    if eights > 0 {
        // SAFETY: the loop reads 32 * eights <= S bytes from p + k * S (k = 0..4), within `w`
        // (4 * S bytes, checked above), and 64 * eights <= 2 * S bytes from pv, within `v`
        // (at least S halfwords); pv is 8-byte aligned as LDRD needs (Activations is `align(8)`,
        // steps of 8); LDR of the weights may be unaligned, which the Cortex-M4 allows for LDR.
        // Only registers named as operands and the flags are written; nothing is stored.
        unsafe {
            asm!(
                "2:",
                group4!(),
                group4!(),
                group4!(),
                group4!(),
                group4!(),
                group4!(),
                group4!(),
                group4!(),
                "subs {n}, {n}, #1",
                "bne 2b",
                n = inout(reg) eights => _,
                pv = inout(reg) pv,
                p = inout(reg) p,
                a0 = inout(reg) a[0],
                a1 = inout(reg) a[1],
                a2 = inout(reg) a[2],
                a3 = inout(reg) a[3],
                x = out(reg) _,
                y = out(reg) _,
                w = out(reg) _,
                t = out(reg) _,
                s1 = const S,
                s2 = const 2 * S,
                s3 = const 3 * S,
                options(nostack, readonly),
            );
        }
    }
    for _ in 0..(S / 4) % 8 {
        // SAFETY: one more group of four columns: the pointers stand after 8 * eights + k
        // groups with k < (S / 4) % 8, so the group lies within the S columns of each row and
        // the S activations; alignment as above.
        unsafe {
            asm!(
                group4!(),
                pv = inout(reg) pv,
                p = inout(reg) p,
                a0 = inout(reg) a[0],
                a1 = inout(reg) a[1],
                a2 = inout(reg) a[2],
                a3 = inout(reg) a[3],
                x = out(reg) _,
                y = out(reg) _,
                w = out(reg) _,
                t = out(reg) _,
                s1 = const S,
                s2 = const 2 * S,
                s3 = const 3 * S,
                options(nostack, readonly, preserves_flags),
            );
        }
    }
    a
}

/// Sums over the first `groups` groups of four columns (clamped to what all three slices hold).
/// `v` must be the storage of an [`crate::Activations`] (8-byte aligned, DSP layout).
pub fn dot2_groups(w0: &[u8], w1: &[u8], v: &[i16], groups: usize) -> (i32, i32) {
    let groups = groups.min(w0.len() / 4).min(w1.len() / 4).min(v.len() / 4);
    let (mut a0, mut a1) = (0i32, 0i32);
    let (mut p0, mut p1, mut pv) = (w0.as_ptr(), w1.as_ptr(), v.as_ptr());
    let pairs = groups / 2;
    if pairs > 0 {
        // SAFETY: the loop reads 8 * pairs bytes from each of p0 and p1 and 16 * pairs bytes
        // from pv, all within the slices (clamped above); pv is 8-byte aligned as LDRD needs
        // (Activations is `align(8)` and the pointer advances by 8); LDR of the weights may be
        // unaligned, which the Cortex-M4 allows for LDR. Only registers named as operands and
        // the flags are written; nothing is stored.
        unsafe {
            asm!(
                "2:",
                group!(),
                group!(),
                "subs {n}, {n}, #1",
                "bne 2b",
                n = inout(reg) pairs => _,
                pv = inout(reg) pv,
                p0 = inout(reg) p0,
                p1 = inout(reg) p1,
                a0 = inout(reg) a0,
                a1 = inout(reg) a1,
                x = out(reg) _,
                y = out(reg) _,
                w = out(reg) _,
                t = out(reg) _,
                options(nostack, readonly),
            );
        }
    }
    if groups % 2 == 1 {
        // SAFETY: one more group: 4 bytes from p0 and p1 and 8 from pv, within the slices since
        // `groups` is odd and the pointers stand after `groups - 1` groups; alignment as above.
        unsafe {
            asm!(
                group!(),
                pv = inout(reg) pv => _,
                p0 = inout(reg) p0 => _,
                p1 = inout(reg) p1 => _,
                a0 = inout(reg) a0,
                a1 = inout(reg) a1,
                x = out(reg) _,
                y = out(reg) _,
                w = out(reg) _,
                t = out(reg) _,
                options(nostack, readonly, preserves_flags),
            );
        }
    }
    (a0, a1)
}
