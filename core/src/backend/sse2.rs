//! [`Sse2`]: the transposes of one corner's eight rows in 128-bit registers,
//! one 4×4 block after the other. SSE2 is part of x86_64, so this backend
//! needs no detection: it is the baseline of every x86_64 build.
//!
//! Its stiffness product runs half a block at a time ([`Backend::Chunk`] of
//! four lanes), the gradients read from memory at each use: each half's
//! values then nearly fit the 16 `xmm` registers, where the whole block's,
//! two registers per value, would spill.

#![allow(unsafe_code)] // intrinsics, `asm!` and layout casts; SSE2 is part of x86_64

use core::arch::x86_64::{
    __m128, __m128i, _mm_loadu_si128, _mm_mulhi_epu16, _mm_mullo_epi16, _mm_set1_epi16,
    _mm_set1_ps, _mm_shuffle_ps, _mm_storeu_si128, _mm_unpackhi_epi16, _mm_unpackhi_ps,
    _mm_unpacklo_epi16, _mm_unpacklo_ps,
};
use core::mem::transmute;

use super::rows::{opaque, scatter, scatter_lanes, Corners};
use super::{Backend, Row};
use crate::element::Batch;
use crate::lanes::{Lanes, LANES};
use crate::math::Real;

/// The SSE2 backend (every x86_64 CPU).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sse2;

/// Four lanes (half a block).
type Quarter = Lanes<4>;

impl Backend for Sse2 {
    type Chunk = Quarter;
    const CHUNKS: usize = 2;
    type Corners<T> = Corners<T>;

    #[inline(always)]
    fn corners<T>(self, ids: &[[u16; LANES]; 4], len: usize) -> Option<Corners<T>> {
        Corners::new(ids, len, offsets)
    }

    #[inline(always)]
    fn gather<R: Row>(self, slots: &[R::Slot], c: &Corners<R::Slot>, k: usize) -> [Batch; 3] {
        let Some(row) = c.loader::<R>(slots, k) else {
            return [Batch::splat(0.0); 3];
        };
        // One 4×4 transpose per half: lanes 0..4 from rows 0..4, 4..8 from 4..8.
        let half = |h: usize| rows_to_lanes([row(h), row(h + 1), row(h + 2), row(h + 3)], R::LEAD);
        let (lo, hi) = (half(0), half(4));
        [
            lanes([lo[0], hi[0]]),
            lanes([lo[1], hi[1]]),
            lanes([lo[2], hi[2]]),
        ]
    }

    #[inline(always)]
    fn scatter<R: Row>(self, slots: &mut [R::Slot], c: &Corners<R::Slot>, v: &[[Batch; 3]; 4]) {
        scatter_lanes::<R>(slots, c, v, to_rows);
    }

    #[inline(always)]
    fn chunk(self, v: &Batch, h: usize) -> Quarter {
        let [lo, hi] = halves(*v);
        quarters([lo, hi, lo])[h & 1]
    }

    #[inline(always)]
    fn gather_chunk<R: Row>(
        self,
        slots: &[R::Slot],
        c: &Corners<R::Slot>,
        k: usize,
        h: usize,
    ) -> [Quarter; 3] {
        let Some(row) = c.loader::<R>(slots, k) else {
            return [Lanes([0.0; 4]); 3];
        };
        let at = 4 * (h & 1);
        quarters(rows_to_lanes(
            [row(at), row(at + 1), row(at + 2), row(at + 3)],
            R::LEAD,
        ))
    }

    #[inline(always)]
    fn scatter_chunk<R: Row>(
        self,
        slots: &mut [R::Slot],
        c: &Corners<R::Slot>,
        h: usize,
        v: &[[Quarter; 3]; 4],
    ) {
        let out = [
            lanes_to_rows(xmms(&v[0])),
            lanes_to_rows(xmms(&v[1])),
            lanes_to_rows(xmms(&v[2])),
            lanes_to_rows(xmms(&v[3])),
        ];
        scatter::<R, 4>(slots, c, 4 * (h & 1), &out);
    }

    #[inline(always)]
    fn fence<const N: usize>(self, v: &mut [[Batch; 3]; N]) {
        // Each value's halves through the four-lane barrier.
        for c in v.iter_mut() {
            let [x, y, z] = [halves(c[0]), halves(c[1]), halves(c[2])];
            let mut q = [quarters([x[0], y[0], z[0]]), quarters([x[1], y[1], z[1]])];
            self.fence_chunk(&mut q);
            let [lo, hi] = [xmms(&q[0]), xmms(&q[1])];
            *c = [
                lanes([lo[0], hi[0]]),
                lanes([lo[1], hi[1]]),
                lanes([lo[2], hi[2]]),
            ];
        }
    }

    #[inline(always)]
    fn fence_chunk<const N: usize>(self, v: &mut [[Quarter; 3]; N]) {
        for c in v.iter_mut() {
            let [mut x, mut y, mut z] = xmms(c);
            // SAFETY: an empty template; the registers come back unchanged.
            unsafe {
                core::arch::asm!(
                    "/* {0} {1} {2} */",
                    inout(xmm_reg) x,
                    inout(xmm_reg) y,
                    inout(xmm_reg) z,
                    options(pure, nomem, nostack, preserves_flags)
                );
            }
            *c = quarters([x, y, z]);
        }
    }

    #[inline(always)]
    fn reread<T>(self, r: &T) -> &T {
        opaque(r)
    }

    #[inline(never)]
    fn call<T>(self, f: impl FnOnce() -> T) -> T {
        f()
    }
}

/// `nodes[k][j] · size` for every corner `k` and lane `j`.
#[inline(always)]
pub(crate) fn offsets(nodes: &[[u16; LANES]; 4], size: u32) -> [[u32; LANES]; 4] {
    // `size` < 1024 (`Corners::new`), so it fits 16 bits (its `i16` cast
    // keeps the bits; `pmulhuw` reads them unsigned), and a 16 × 16 bit
    // product fits 32: its low and high halves (`pmullw`, `pmulhuw`)
    // interleaved are the 32-bit products. (Written as scalars, LLVM made it
    // 32 `pextrw` + `imul` + store per block.)
    let mut offsets = [[0; LANES]; 4];
    // SAFETY: SSE2 is part of x86_64; `c` is 16 bytes (8 `u16`) and `o` 32
    // (8 `u32`), both read and written unaligned.
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

/// `[X, Y, Z]` as the rows `[xⱼ, yⱼ, zⱼ, −0]` of lanes `j = 0..8`.
#[inline(always)]
fn to_rows(v: &[Batch; 3]) -> [__m128; LANES] {
    let [x, y, z] = [halves(v[0]), halves(v[1]), halves(v[2])];
    // Rows of lanes 4h .. 4h + 4 from the half `h` of each vector.
    let lo = lanes_to_rows([x[0], y[0], z[0]]);
    let hi = lanes_to_rows([x[1], y[1], z[1]]);
    [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]]
}

/// Four rows `[x y z ·]` (or, with `lead`, `[· x y z]`) as the lanes
/// `[X, Y, Z]`: a 4×4 transpose.
#[inline(always)]
fn rows_to_lanes(t: [__m128; 4], lead: bool) -> [__m128; 3] {
    // SAFETY: SSE is part of x86_64.
    unsafe {
        let a = _mm_unpacklo_ps(t[0], t[1]); // x0 x1 y0 y1
        let b = _mm_unpacklo_ps(t[2], t[3]); // x2 x3 y2 y3
        let c = _mm_unpackhi_ps(t[0], t[1]); // z0 z1 ·  ·
        let d = _mm_unpackhi_ps(t[2], t[3]); // z2 z3 ·  ·
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
}

/// The lanes `[X, Y, Z]` as four rows `[xⱼ, yⱼ, zⱼ, −0]`: a 4×4 transpose
/// (`−0.0`: adding it leaves any other float's bits, `+0 + −0 = +0`).
#[inline(always)]
fn lanes_to_rows(v: [__m128; 3]) -> [__m128; 4] {
    let [x, y, z] = v;
    // SAFETY: SSE is part of x86_64.
    unsafe {
        let zero = _mm_set1_ps(-0.0);
        let a = _mm_unpacklo_ps(x, y); // x0 y0 x1 y1
        let b = _mm_unpackhi_ps(x, y); // x2 y2 x3 y3
        let c = _mm_unpacklo_ps(z, zero); // z0 −0 z1 −0
        let d = _mm_unpackhi_ps(z, zero); // z2 −0 z3 −0
        [
            _mm_shuffle_ps::<0x44>(a, c), // x0 y0 z0 −0
            _mm_shuffle_ps::<0xEE>(a, c),
            _mm_shuffle_ps::<0x44>(b, d),
            _mm_shuffle_ps::<0xEE>(b, d),
        ]
    }
}

/// Three four-lane values as SSE registers.
#[inline(always)]
fn xmms(v: &[Quarter; 3]) -> [__m128; 3] {
    // SAFETY: 16 bytes of 4 `f32`s each; every bit pattern is valid for both.
    unsafe { transmute::<[Quarter; 3], [__m128; 3]>(*v) }
}

/// Three SSE registers as four-lane values.
#[inline(always)]
fn quarters(v: [__m128; 3]) -> [Quarter; 3] {
    // SAFETY: as in `xmms`.
    unsafe { transmute::<[__m128; 3], [Quarter; 3]>(v) }
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
