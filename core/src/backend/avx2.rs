//! [`Avx2`]: the transposes of one corner's eight rows in 256-bit registers,
//! both 4×4 blocks at once (lanes `j` and `j + 4` share a register).
//!
//! An `Avx2` value exists only where the CPU has AVX2 ([`Avx2::new`]), so its
//! methods, inlined into code compiled for AVX2 ([`Backend::call`] and the
//! step's own wrapper), are safe to call.

#![allow(unsafe_code)] // intrinsics that need AVX2, which an `Avx2` value proves

use core::arch::x86_64::{
    __m128, __m256, _mm256_castps256_ps128, _mm256_cvtepu16_epi32, _mm256_extractf128_ps,
    _mm256_mullo_epi32, _mm256_set1_epi32, _mm256_set1_ps, _mm256_set_m128, _mm256_shuffle_ps,
    _mm256_storeu_si256, _mm256_unpackhi_ps, _mm256_unpacklo_ps, _mm_loadu_si128,
};
use core::mem::transmute;

use super::rows::{opaque, scatter_lanes, Corners};
use super::{Backend, Row};
use crate::element::Batch;
use crate::lanes::{Lanes, LANES};
use crate::math::Real;

/// The AVX2 backend: a token that this CPU has AVX2.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// The token, if this CPU has AVX2 (see
    /// [`InstructionSet::is_supported`](crate::InstructionSet::is_supported)).
    #[inline]
    pub(crate) fn new() -> Option<Self> {
        crate::InstructionSet::Avx2
            .is_supported()
            .then_some(Self(()))
    }
}

impl Avx2 {
    /// `nodes[k][j] · size` for every corner `k` and lane `j`: widened to
    /// 32 bits and multiplied in vector registers (written as scalars, LLVM
    /// made it 32 scalar multiplications in the force pass).
    #[inline(always)]
    pub(crate) fn offsets(self, nodes: &[[u16; LANES]; 4], size: u32) -> [[u32; LANES]; 4] {
        let mut offsets = [[0; LANES]; 4];
        // SAFETY: `c` and `o` are 16 and 32 bytes (8 `u16`, 8 `u32`);
        // `self` proves AVX2.
        unsafe {
            let size = _mm256_set1_epi32(size as i32);
            for (o, c) in offsets.iter_mut().zip(nodes) {
                let ids = _mm256_cvtepu16_epi32(_mm_loadu_si128(c.as_ptr().cast()));
                _mm256_storeu_si256(o.as_mut_ptr().cast(), _mm256_mullo_epi32(ids, size));
            }
        }
        offsets
    }
}

impl Backend for Avx2 {
    type Chunk = Batch;
    const CHUNKS: usize = 1;
    type Corners<T> = Corners<T>;

    #[inline(always)]
    fn corners<T>(self, ids: &[[u16; LANES]; 4], len: usize) -> Option<Corners<T>> {
        Corners::new(
            ids,
            len,
            #[inline(always)]
            |ids, size| self.offsets(ids, size),
        )
    }

    #[inline(always)]
    fn gather<R: Row>(self, slots: &[R::Slot], c: &Corners<R::Slot>, k: usize) -> [Batch; 3] {
        let Some(row) = c.loader::<R>(slots, k) else {
            return [Batch::splat(0.0); 3];
        };
        // SAFETY: `self` proves AVX2.
        unsafe {
            // Lanes j and j + 4 share a register: t_j = [row_j | row_{j+4}].
            let t0 = _mm256_set_m128(row(4), row(0));
            let t1 = _mm256_set_m128(row(5), row(1));
            let t2 = _mm256_set_m128(row(6), row(2));
            let t3 = _mm256_set_m128(row(7), row(3));
            // 4×4 transpose in each half.
            let a = _mm256_unpacklo_ps(t0, t1); // x0 x1 y0 y1 | x4 x5 y4 y5
            let b = _mm256_unpacklo_ps(t2, t3); // x2 x3 y2 y3 | x6 x7 y6 y7
            let c = _mm256_unpackhi_ps(t0, t1); // z0 z1 ·  ·  | z4 z5 ·  ·
            let d = _mm256_unpackhi_ps(t2, t3); // z2 z3 ·  ·  | z6 z7 ·  ·
            if R::LEAD {
                // Rows [· x y z]: a, b hold · and x, c, d hold y and z.
                return [
                    lanes(_mm256_shuffle_ps::<0xEE>(a, b)),
                    lanes(_mm256_shuffle_ps::<0x44>(c, d)),
                    lanes(_mm256_shuffle_ps::<0xEE>(c, d)),
                ];
            }
            [
                lanes(_mm256_shuffle_ps::<0x44>(a, b)), // x0 x1 x2 x3 | x4 x5 x6 x7
                lanes(_mm256_shuffle_ps::<0xEE>(a, b)), // y0 .. y7
                lanes(_mm256_shuffle_ps::<0x44>(c, d)), // z0 .. z7
            ]
        }
    }

    #[inline(always)]
    fn scatter<R: Row>(self, slots: &mut [R::Slot], c: &Corners<R::Slot>, v: &[[Batch; 3]; 4]) {
        scatter_lanes::<R>(
            slots,
            c,
            v,
            // SAFETY: `self` proves AVX2.
            #[inline(always)]
            |v| unsafe { to_rows(v) },
        );
    }

    #[inline(always)]
    fn fence<const N: usize>(self, v: &mut [[Batch; 3]; N]) {
        // SAFETY: `self` proves AVX2 (which implies AVX).
        unsafe { fence_avx(v) }
    }

    super::whole_block_chunks!();

    #[inline(always)]
    fn reread<T>(self, r: &T) -> &T {
        opaque(r)
    }

    #[inline(always)]
    fn call<T>(self, f: impl FnOnce() -> T) -> T {
        // SAFETY: `self` proves AVX2.
        unsafe { call_avx2(f) }
    }
}

/// `f()`, out of line, compiled for AVX2.
#[inline(never)]
#[target_feature(enable = "avx2")]
fn call_avx2<T>(f: impl FnOnce() -> T) -> T {
    f()
}

/// `[X, Y, Z]` as the rows `[xⱼ, yⱼ, zⱼ, −0]` of lanes `j = 0..8`.
///
/// # Safety
///
/// The CPU must have AVX2.
#[inline(always)]
unsafe fn to_rows(v: &[Batch; 3]) -> [__m128; LANES] {
    let [x, y, z] = v.map(vector);
    // SAFETY: the caller's.
    unsafe {
        let zero = _mm256_set1_ps(-0.0);
        let a = _mm256_unpacklo_ps(x, y); // x0 y0 x1 y1 | x4 y4 x5 y5
        let b = _mm256_unpackhi_ps(x, y); // x2 y2 x3 y3 | x6 y6 x7 y7
        let c = _mm256_unpacklo_ps(z, zero); // z0 −0 z1 −0 | z4 −0 z5 −0
        let d = _mm256_unpackhi_ps(z, zero); // z2 −0 z3 −0 | z6 −0 z7 −0
        let r04 = _mm256_shuffle_ps::<0x44>(a, c); // x0 y0 z0 −0 | x4 y4 z4 −0
        let r15 = _mm256_shuffle_ps::<0xEE>(a, c);
        let r26 = _mm256_shuffle_ps::<0x44>(b, d);
        let r37 = _mm256_shuffle_ps::<0xEE>(b, d);
        [
            _mm256_castps256_ps128(r04),
            _mm256_castps256_ps128(r15),
            _mm256_castps256_ps128(r26),
            _mm256_castps256_ps128(r37),
            _mm256_extractf128_ps::<1>(r04),
            _mm256_extractf128_ps::<1>(r15),
            _mm256_extractf128_ps::<1>(r26),
            _mm256_extractf128_ps::<1>(r37),
        ]
    }
}

/// [`Backend::fence`] with one `ymm` register per value: compiled for AVX, as
/// `asm!` with `ymm` registers must be; `#[inline]`, and inlined where it is
/// called from AVX2 code.
#[inline]
#[target_feature(enable = "avx")]
fn fence_avx<const N: usize>(v: &mut [[Batch; 3]; N]) {
    for c in v.iter_mut() {
        let [mut x, mut y, mut z] = c.map(vector);
        // SAFETY: an empty template; the registers come back unchanged.
        unsafe {
            core::arch::asm!(
                "/* {0} {1} {2} */",
                inout(ymm_reg) x,
                inout(ymm_reg) y,
                inout(ymm_reg) z,
                options(pure, nomem, nostack, preserves_flags)
            );
        }
        *c = [lanes(x), lanes(y), lanes(z)];
    }
}

/// An AVX register as lanes.
#[inline(always)]
fn lanes(v: __m256) -> Batch {
    // SAFETY: both are 32 bytes of 8 `f32`s in order; every bit pattern is
    // valid for both.
    Lanes(unsafe { transmute::<__m256, [f32; LANES]>(v) })
}

/// Lanes as an AVX register.
#[inline(always)]
fn vector(v: Batch) -> __m256 {
    // SAFETY: as in `lanes`.
    unsafe { transmute::<[f32; LANES], __m256>(v.0) }
}
