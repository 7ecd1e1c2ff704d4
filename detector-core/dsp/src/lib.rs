//! The LSTM's dot-product kernels: `sum w[i] * v[i]` of int8 weights (stored as bytes) and int16
//! Q4.12 activations, accumulated exactly in i32, for two weight rows at once.
//!
//! This crate owns the hot loop of strategy 1 and, beside it, [`sqrtf`] (the FPU's `VSQRT.F32`
//! where libm cannot reach it). Both follow the CMSIS-NN / TFLite Micro pattern: one plain
//! reference kernel, optimised kernels beside it, parity tests between them:
//!
//! - [`portable`]: the reference, plain Rust in natural order, on every target.
//! - Cortex-M4 (ARMv7E-M, chosen by `build.rs` from the target name): inline assembly with the DSP
//!   extension. `SXTB16` sign-extends bytes 0 and 2 of a weight word into two halfwords (and,
//!   with `ROR #8`, bytes 1 and 3); `SMLAD` multiplies two halfword pairs and adds both products
//!   to the accumulator. [`Activations::load`] stores each group of four activations as
//!   `v0 v2 v1 v3` so that one `LDRD` fetches the two pairs that match, and the weights stay as
//!   trained (no blob change). 24 instructions per 16 multiply-accumulates. [`emulated`] is the
//!   same algorithm in Rust (instruction by instruction) so the layout is tested on the host;
//!   the QEMU run checks the assembly itself against [`portable`].
//! - x86-64 with the `std` feature: AVX2 (`VPMOVSXBW` + `VPMADDWD`, four rows per pass sharing
//!   each load of sixteen activations), chosen at run time; without AVX2 the portable kernel.
//!
//! Every kernel computes the same exact integer sums: with |w| <= 128, |v| <= 32768 and at most
//! a few hundred columns no partial sum overflows i32 (see [`MAX_EXACT_COLS`]), so the order of
//! additions cannot change a result and the kernels agree bit for bit.
//!
//! This is the one crate of the detector where `unsafe` is allowed; each block states why it is
//! sound, and the public interface is safe: lengths are clamped before any pointer is read.
#![no_std]

#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod emulated;
pub mod portable;
mod sqrt;

pub use sqrt::{sqrtf, HARDWARE_SQRT};

#[cfg(dsp_ext)]
mod arm;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86;

/// Columns up to which the sums are exact in i32 for any weights and activations:
/// `cols * 128 * 32768 < 2^31`.
pub const MAX_EXACT_COLS: usize = 511;

/// Which kernel [`Activations::dot2`] runs on this build and machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// [`portable`]: no SIMD.
    Portable,
    /// The Cortex-M4 DSP extension (SXTB16 + SMLAD), inline assembly.
    CortexM4Dsp,
    /// x86-64 AVX2, detected at run time.
    Avx2,
}

/// The kernel that [`Activations::dot2`] uses here.
pub fn kernel() -> Kernel {
    #[cfg(dsp_ext)]
    {
        Kernel::CortexM4Dsp
    }
    #[cfg(all(not(dsp_ext), feature = "std", target_arch = "x86_64"))]
    {
        if x86::has_avx2() {
            Kernel::Avx2
        } else {
            Kernel::Portable
        }
    }
    #[cfg(all(not(dsp_ext), not(all(feature = "std", target_arch = "x86_64"))))]
    {
        Kernel::Portable
    }
}

/// Whether the optimised kernel reads activations in the DSP layout (`v0 v2 v1 v3` per group).
const DSP_LAYOUT: bool = cfg!(dsp_ext);

/// Position of natural column `i` in a buffer of `len` activations laid out for `SXTB16`: the
/// middle two of each complete group of four swap places; an incomplete last group stays in
/// natural order. The map is its own inverse.
pub const fn dsp_index(i: usize, len: usize) -> usize {
    let g = i & !3;
    if g + 4 <= len {
        match i & 3 {
            1 => g + 2,
            2 => g + 1,
            r => g + r,
        }
    } else {
        i
    }
}

/// One layer's input vector (the step's input, then the previous hidden state), laid out for
/// this build's kernel. At most `N` activations; 8-byte aligned for `LDRD`.
#[repr(C, align(8))]
#[derive(Clone, Debug)]
pub struct Activations<const N: usize> {
    v: [i16; N],
    len: usize,
}

impl<const N: usize> Default for Activations<N> {
    fn default() -> Self {
        Self { v: [0; N], len: 0 }
    }
}

impl<const N: usize> Activations<N> {
    /// Loads the concatenation of `parts` (as much as fits in `N`).
    pub fn load(&mut self, parts: &[&[i16]]) {
        let mut n = 0;
        for p in parts {
            let room = self.v.get_mut(n..).unwrap_or(&mut []);
            let k = p.len().min(room.len());
            if let (Some(d), Some(s)) = (room.get_mut(..k), p.get(..k)) {
                d.copy_from_slice(s);
            }
            n += k;
        }
        self.len = n;
        if DSP_LAYOUT {
            for g in self.v.chunks_exact_mut(4).take(n / 4) {
                g.swap(1, 2);
            }
        }
    }

    /// Number of activations loaded.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether none are loaded.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Natural column `i` (0 when out of range).
    pub fn get(&self, i: usize) -> i16 {
        if i >= self.len {
            return 0;
        }
        let j = if DSP_LAYOUT { dsp_index(i, self.len) } else { i };
        self.v.get(j).copied().unwrap_or(0)
    }

    /// `(sum w0[i] * v[i], sum w1[i] * v[i])` over `i < min(w0.len(), w1.len(), self.len())`,
    /// with the weights read as i8. Exact (see [`MAX_EXACT_COLS`]); the same value from every
    /// kernel.
    pub fn dot2(&self, w0: &[u8], w1: &[u8]) -> (i32, i32) {
        let n = w0.len().min(w1.len()).min(self.len);
        let (w0, w1) = (w0.get(..n).unwrap_or(&[]), w1.get(..n).unwrap_or(&[]));
        let v = self.v.get(..n).unwrap_or(&[]);
        #[cfg(dsp_ext)]
        {
            let groups = n / 4;
            let (mut a0, mut a1) = arm::dot2_groups(w0, w1, v, groups);
            for i in groups * 4..n {
                let x = self.get(i) as i32;
                a0 += w0.get(i).map_or(0, |w| *w as i8 as i32) * x;
                a1 += w1.get(i).map_or(0, |w| *w as i8 as i32) * x;
            }
            (a0, a1)
        }
        #[cfg(all(not(dsp_ext), feature = "std", target_arch = "x86_64"))]
        {
            if x86::has_avx2() {
                x86::dot2(w0, w1, v)
            } else {
                portable::dot2(w0, w1, v)
            }
        }
        #[cfg(all(not(dsp_ext), not(all(feature = "std", target_arch = "x86_64"))))]
        {
            portable::dot2(w0, w1, v)
        }
    }

    /// Four consecutive rows of a row-major int8 matrix with `S` columns (`w` starts at the
    /// first of them): `[sum w[k * S + i] * v[i] for k in 0..4]` over `i < min(S, self.len())`.
    /// Rows that `w` does not hold in full count what it holds.
    pub fn dot4<const S: usize>(&self, w: &[u8]) -> [i32; 4] {
        let n = S.min(self.len);
        let row = |k: usize| w.get(k * S..).unwrap_or(&[]).get(..n).unwrap_or(w.get(k * S..).unwrap_or(&[]));
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        if r3.len() < n {
            return [self.dot1(r0), self.dot1(r1), self.dot1(r2), self.dot1(r3)];
        }
        let (a0, a1) = self.dot2(r0, r1);
        let (a2, a3) = self.dot2(r2, r3);
        [a0, a1, a2, a3]
    }

    /// A row-major int8 matrix with `S` columns times the activations:
    /// `out[r] = sum w[r * S + i] * v[i]` over `i < min(S, self.len())`, for `r < out.len()`.
    /// Rows that `w` does not hold in full count what it holds. Four rows at a time: on the
    /// Cortex-M4 one activation load then serves four rows (for `S` a multiple of 4).
    pub fn matvec<const S: usize>(&self, w: &[u8], out: &mut [i32]) {
        #[allow(unused_mut)]
        let mut done = 0;
        #[cfg(dsp_ext)]
        {
            if S % 4 == 0 && S <= self.len {
                done = arm::matvec::<S>(w, self.v.get(..S).unwrap_or(&[]), out);
            }
        }
        #[cfg(all(not(dsp_ext), feature = "std", target_arch = "x86_64"))]
        {
            if S <= self.len {
                done = x86::matvec::<S>(w, self.v.get(..S).unwrap_or(&[]), out);
            }
        }
        let mut quads = out.get_mut(done..).unwrap_or(&mut []).chunks_exact_mut(4);
        for o in &mut quads {
            o.copy_from_slice(&self.dot4::<S>(w.get(done * S..).unwrap_or(&[])));
            done += 4;
        }
        for o in quads.into_remainder() {
            let row = w.get(done * S..).unwrap_or(&[]);
            *o = self.dot1(row.get(..S).unwrap_or(row));
            done += 1;
        }
    }

    /// `sum w[i] * v[i]`, as [`Self::dot2`].
    pub fn dot1(&self, w: &[u8]) -> i32 {
        self.dot2(w, w).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dsp_index_swaps_the_middle_of_complete_groups_only() {
        let m: [usize; 10] = core::array::from_fn(|i| dsp_index(i, 10));
        assert_eq!(m, [0, 2, 1, 3, 4, 6, 5, 7, 8, 9]);
        for i in 0..10 {
            assert_eq!(dsp_index(dsp_index(i, 10), 10), i);
        }
    }

    #[test]
    fn activations_read_back_in_natural_order() {
        let x = [1i16, -2, 3];
        let h: [i16; 8] = core::array::from_fn(|i| 100 * i as i16 - 300);
        let mut a = Activations::<16>::default();
        a.load(&[&x, &h]);
        assert_eq!(a.len(), 11);
        let all: [i16; 11] = core::array::from_fn(|i| a.get(i));
        assert_eq!(&all[..3], &x);
        assert_eq!(&all[3..], &h);
        assert_eq!(a.get(11), 0);
    }

    #[test]
    fn four_rows_equal_the_reference_row_by_row() {
        const S: usize = 13;
        let w: [u8; 4 * S] = core::array::from_fn(|i| (i * 37 % 256) as u8);
        let v: [i16; S] = core::array::from_fn(|i| (i as i16 - 6) * 1234);
        let mut a = Activations::<16>::default();
        a.load(&[&v]);
        let want: [i32; 4] = core::array::from_fn(|k| portable::dot(&w[k * S..(k + 1) * S], &v));
        assert_eq!(a.dot4::<S>(&w), want);
        // A matrix cut short: the last row counts what there is.
        let cut = &w[..3 * S + 5];
        let want_cut = [want[0], want[1], want[2], portable::dot(&w[3 * S..3 * S + 5], &v)];
        assert_eq!(a.dot4::<S>(cut), want_cut);
    }

    #[test]
    fn matrix_times_vector_equals_the_reference_row_by_row() {
        const S: usize = 12;
        let w: [u8; 7 * S] = core::array::from_fn(|i| (i * 91 % 256) as u8);
        let v: [i16; S] = core::array::from_fn(|i| (i as i16 - 6) * 2345);
        let mut a = Activations::<16>::default();
        a.load(&[&v]);
        for rows in 0..=7 {
            let mut out = [0i32; 7];
            a.matvec::<S>(&w, &mut out[..rows]);
            for r in 0..rows {
                assert_eq!(out[r], portable::dot(&w[r * S..(r + 1) * S], &v), "{rows} rows, row {r}");
            }
        }
        // A matrix cut short.
        let mut out = [0i32; 7];
        a.matvec::<S>(&w[..5 * S + 3], &mut out);
        assert_eq!(out[5], portable::dot(&w[5 * S..5 * S + 3], &v));
        assert_eq!(out[6], 0);
    }

    #[test]
    fn overflowing_input_is_cut_to_capacity() {
        let mut a = Activations::<4>::default();
        a.load(&[&[1, 2, 3], &[4, 5, 6]]);
        assert_eq!(a.len(), 4);
        assert_eq!(a.dot2(&[1, 1, 1, 1, 1], &[255, 0, 0, 0]), (10, -1));
    }
}
