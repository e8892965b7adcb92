//! `Lanes<L>`: `L` independent `f32` values, one element of a batch per lane.
//!
//! The element kernels are written once over [`Real`]; run on `Lanes<L>` they
//! process `L` elements together, and each lane goes through exactly the
//! operations the `f32` kernel does (no reassociation, no fused multiply-add,
//! Rust never contracts), so a batched element gets the bits of a lone one
//! on every target. The loops below are what the compiler vectorises: with
//! SSE2 two or four lanes per instruction, with AVX-512 all of them.
//!
//! The loops must be vectorised to pay off: at `opt-level = "s"` or `"z"` the
//! compiler leaves them as loops and a batched pass is about twice as slow as
//! one element at a time (docs/web.md); build the core at `opt-level` 2 or 3.
//!
//! Why batches at all: one element's QR kernel is a long chain of dependent
//! operations (two square roots and two divisions in the frame alone), so a
//! scalar pass waits on latency; `L` elements side by side fill the pipeline.

use crate::math::{sqrt, Real};
use core::ops::{Add, Div, Mul, Neg, Sub};

/// Elements per batch (and per [`ElementBlock`](crate::ElementBlock)): eight where the target has
/// vector registers (x86, x86_64, AArch64, wasm32 with `simd128`; measured on
/// x86_64, where 8 beat 4 and 16, and on wasm32 in Node, same bits), one
/// elsewhere (a Cortex-M4F has none, and a batch would only cost stack and
/// flash there).
pub(crate) const LANES: usize = if cfg!(any(
    target_arch = "x86_64",
    target_arch = "x86",
    target_arch = "aarch64",
    all(target_arch = "wasm32", target_feature = "simd128")
)) {
    8
} else {
    1
};

/// `L` independent `f32` lanes (units: those of what they hold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lanes<const L: usize>(pub(crate) [f32; L]);

impl<const L: usize> Lanes<L> {
    /// Sets lane `j` of each value to the entries of `v` (nothing if `j ≥ L`).
    #[inline(always)]
    pub(crate) fn put<const N: usize>(dst: &mut [Self; N], j: usize, v: [f32; N]) {
        for (d, x) in dst.iter_mut().zip(v) {
            if let Some(lane) = d.0.get_mut(j) {
                *lane = x;
            }
        }
    }

    /// Lane by lane, `a` where `take` is true, else `b`.
    #[cfg(feature = "polar")]
    #[inline(always)]
    pub(crate) fn select<const N: usize>(
        take: &[bool; L],
        a: [Self; N],
        b: [Self; N],
    ) -> [Self; N] {
        core::array::from_fn(|k| {
            let mut out = b[k].0;
            for ((o, t), x) in out.iter_mut().zip(take).zip(a[k].0) {
                if *t {
                    *o = x;
                }
            }
            Lanes(out)
        })
    }

    /// Lane `j` of each value, as an `f32` array.
    #[inline(always)]
    pub(crate) fn lane<const N: usize>(v: &[Self; N], j: usize) -> [f32; N] {
        core::array::from_fn(|k| v[k].0.get(j).copied().unwrap_or(0.0))
    }
}

// The arithmetic is written out lane by lane for each lane count in use,
// not as loops over the lanes: the kernels are long chains of these
// operations, and a loop per operation left LLVM thousands of tiny loops per
// function to canonicalise, unroll and vectorise, which dominated the
// build. Written out, the lanes are straight-line code that the SLP
// vectoriser packs into the same vector instructions.
macro_rules! lanewise {
    ($l:literal: $($i:literal)*) => {
        impl Add for Lanes<$l> {
            type Output = Self;
            #[inline(always)]
            fn add(self, o: Self) -> Self {
                Lanes([$(self.0[$i] + o.0[$i]),*])
            }
        }
        impl Sub for Lanes<$l> {
            type Output = Self;
            #[inline(always)]
            fn sub(self, o: Self) -> Self {
                Lanes([$(self.0[$i] - o.0[$i]),*])
            }
        }
        impl Mul for Lanes<$l> {
            type Output = Self;
            #[inline(always)]
            fn mul(self, o: Self) -> Self {
                Lanes([$(self.0[$i] * o.0[$i]),*])
            }
        }
        impl Div for Lanes<$l> {
            type Output = Self;
            #[inline(always)]
            fn div(self, o: Self) -> Self {
                Lanes([$(self.0[$i] / o.0[$i]),*])
            }
        }
        impl Neg for Lanes<$l> {
            type Output = Self;
            #[inline(always)]
            fn neg(self) -> Self {
                Lanes([$(-self.0[$i]),*])
            }
        }
        impl Real for Lanes<$l> {
            #[inline(always)]
            fn splat(x: f32) -> Self {
                Lanes([x; $l])
            }
            #[inline(always)]
            fn root(self) -> Self {
                Lanes([$(sqrt(self.0[$i])),*])
            }
        }
    };
}
lanewise!(1: 0);
lanewise!(4: 0 1 2 3);
lanewise!(8: 0 1 2 3 4 5 6 7);
