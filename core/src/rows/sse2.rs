//! [`Sse2`]: the transposes of one corner's eight rows in 128-bit registers,
//! one 4×4 block after the other: SSE2, which every x86_64 CPU has, so the
//! baseline step ([`Scene::step`](crate::Scene::step)) uses them.

#![allow(unsafe_code)] // `asm!` and layout casts; SSE2 is part of x86_64

use core::arch::x86_64::{
    __m128, __m128i, _mm_loadu_si128, _mm_mulhi_epu16, _mm_mullo_epi16, _mm_set1_epi16,
    _mm_set1_ps, _mm_shuffle_ps, _mm_storeu_si128, _mm_unpackhi_epi16, _mm_unpackhi_ps,
    _mm_unpacklo_epi16, _mm_unpacklo_ps,
};
use core::mem::transmute;

use super::Moves;
use crate::element::Batch;
use crate::lanes::{Lanes, LANES};

/// The moves of the step compiled for the baseline instruction set.
pub(crate) struct Sse2;

impl Moves for Sse2 {
    #[inline(always)]
    unsafe fn offsets(nodes: &[[u16; LANES]; 4], size: u32) -> [[u32; LANES]; 4] {
        // `size` < 1024 (`Corners::new`), so it fits 16 bits (its `i16` cast
        // keeps the bits; `pmulhuw` reads them unsigned), and a 16 × 16
        // bit product fits 32: its low and high halves (`pmullw`, `pmulhuw`)
        // interleaved are the 32-bit products. (Written as scalars, LLVM
        // made it 32 `pextrw` + `imul` + store per block.)
        let mut offsets = [[0; LANES]; 4];
        // SAFETY: SSE2 is part of x86_64; `c` is 16 bytes (8 `u16`) and
        // `o` 32 (8 `u32`), both read and written unaligned.
        unsafe {
            let m = _mm_set1_epi16(size as i16);
            for (o, c) in offsets.iter_mut().zip(nodes) {
                let ids = _mm_loadu_si128(c.as_ptr().cast());
                let (lo, hi) = (_mm_mullo_epi16(ids, m), _mm_mulhi_epu16(ids, m));
                let out = o.as_mut_ptr().cast::<__m128i>();
                _mm_storeu_si128(out, _mm_unpacklo_epi16(lo, hi));
                _mm_storeu_si128(out.add(1), _mm_unpackhi_epi16(lo, hi));
            }
        }
        offsets
    }

    #[inline(always)]
    unsafe fn to_lanes(row: impl Fn(usize) -> __m128, lead: bool) -> [Batch; 3] {
        // One 4×4 transpose per half: lanes 0..4 from rows 0..4, 4..8 from 4..8.
        let half = |h: usize| {
            let (t0, t1, t2, t3) = (row(h), row(h + 1), row(h + 2), row(h + 3));
            // SAFETY: SSE is part of x86_64.
            unsafe {
                let a = _mm_unpacklo_ps(t0, t1); // x0 x1 y0 y1
                let b = _mm_unpacklo_ps(t2, t3); // x2 x3 y2 y3
                let c = _mm_unpackhi_ps(t0, t1); // z0 z1 ·  ·
                let d = _mm_unpackhi_ps(t2, t3); // z2 z3 ·  ·
                if lead {
                    // Rows [· x y z]: a, b hold · and x, c, d hold y and z.
                    [
                        _mm_shuffle_ps::<0xEE>(a, b),
                        _mm_shuffle_ps::<0x44>(c, d),
                        _mm_shuffle_ps::<0xEE>(c, d),
                    ]
                } else {
                    [
                        _mm_shuffle_ps::<0x44>(a, b), // x0 x1 x2 x3
                        _mm_shuffle_ps::<0xEE>(a, b), // y0 .. y3
                        _mm_shuffle_ps::<0x44>(c, d), // z0 .. z3
                    ]
                }
            }
        };
        let (lo, hi) = (half(0), half(4));
        [
            lanes([lo[0], hi[0]]),
            lanes([lo[1], hi[1]]),
            lanes([lo[2], hi[2]]),
        ]
    }

    #[inline(always)]
    unsafe fn to_rows(v: &[Batch; 3]) -> [__m128; LANES] {
        let [x, y, z] = [halves(v[0]), halves(v[1]), halves(v[2])];
        // Rows of lanes 4h .. 4h + 4 from the half `h` of each vector.
        let half = |h: usize| {
            // SAFETY: SSE is part of x86_64.
            unsafe {
                let zero = _mm_set1_ps(-0.0);
                let a = _mm_unpacklo_ps(x[h], y[h]); // x0 y0 x1 y1
                let b = _mm_unpackhi_ps(x[h], y[h]); // x2 y2 x3 y3
                let c = _mm_unpacklo_ps(z[h], zero); // z0 −0 z1 −0
                let d = _mm_unpackhi_ps(z[h], zero); // z2 −0 z3 −0
                [
                    _mm_shuffle_ps::<0x44>(a, c), // x0 y0 z0 −0
                    _mm_shuffle_ps::<0xEE>(a, c),
                    _mm_shuffle_ps::<0x44>(b, d),
                    _mm_shuffle_ps::<0xEE>(b, d),
                ]
            }
        };
        let (lo, hi) = (half(0), half(1));
        [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]]
    }

    #[inline(always)]
    unsafe fn fence<const N: usize>(v: &mut [[Batch; 3]; N]) {
        for c in v.iter_mut() {
            let [[mut x0, mut x1], [mut y0, mut y1], [mut z0, mut z1]] =
                [halves(c[0]), halves(c[1]), halves(c[2])];
            // SAFETY: an empty template; the registers come back unchanged.
            unsafe {
                core::arch::asm!(
                    "/* {0} {1} {2} {3} {4} {5} */",
                    inout(xmm_reg) x0,
                    inout(xmm_reg) x1,
                    inout(xmm_reg) y0,
                    inout(xmm_reg) y1,
                    inout(xmm_reg) z0,
                    inout(xmm_reg) z1,
                    options(pure, nomem, nostack, preserves_flags)
                );
            }
            *c = [lanes([x0, x1]), lanes([y0, y1]), lanes([z0, z1])];
        }
    }
}

/// Two SSE registers (lanes 0..4, 4..8) as lanes.
#[inline(always)]
fn lanes(v: [__m128; 2]) -> Batch {
    // SAFETY: both are 32 bytes of 8 `f32`s in order; every bit pattern is
    // valid for both.
    Lanes(unsafe { transmute::<[__m128; 2], [f32; LANES]>(v) })
}

/// Lanes as two SSE registers.
#[inline(always)]
fn halves(v: Batch) -> [__m128; 2] {
    // SAFETY: as in `lanes`.
    unsafe { transmute::<[f32; LANES], [__m128; 2]>(v.0) }
}
