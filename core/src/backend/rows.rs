//! Node vectors as 16-byte rows, for the x86_64 backends (`Sse2`, `Avx2`).
//!
//! Built from scalars, a block's 96 gathered values went through the stack
//! (96 scalar stores, and a failed store-to-load forward on the first vector
//! load), and its 96 scattered sums through 96 scalar read-modify-writes.
//! Here a node's `[x, y, z]` moves as one 16-byte row, and each instruction
//! set transposes eight rows to three lanes and back in registers:
//!
//! ```text
//! gather  8 rows [x y z ·] of a corner  → 4×4 transposes → X, Y, Z (8 lanes)
//! scatter X, Y, Z of a corner → 8 rows [x y z −0] → row += into the node, element by element
//! ```
//!
//! A row is 16 bytes read from a 12-byte field: the fourth float is the next
//! field of the same node (checked at compile time below; `d` is read as
//! `[r.z, d]`, see [`WorkD`](super::WorkD)). When scattering, that fourth
//! float gets `−0.0` added, which gives back its own bits for every value
//! but a signalling NaN: the fields it falls on (`d.x`, `inv_p`) are results
//! of arithmetic or finite inputs, never a signalling NaN. (A blend that kept
//! them cost 32 of the product's ~300 vector micro-operations per block: 2–4 %
//! of the step.) Sums are still made one node at a time in element order,
//! with the same IEEE additions, so the bits are those of the portable
//! backend.

#![allow(unsafe_code)] // raw 16-byte loads and stores; the safety of each is argued below

use core::arch::x86_64::{__m128, _mm_add_ps, _mm_loadu_ps, _mm_storeu_ps};
use core::marker::PhantomData;
use core::mem::size_of;

use super::Row;
use crate::element::Batch;
use crate::lanes::LANES;

const _: () = assert!(LANES == 8, "the row moves fill 8 lanes");

/// Checks at compile time that a 16-byte row at `offset` lies inside a slot
/// of `size` bytes (so reading it never leaves the slot).
const fn row_fits(offset: usize, size: usize) -> usize {
    assert!(
        offset + 16 <= size,
        "a 16-byte row must stay inside its slot"
    );
    offset
}

/// The byte offset of row `R` in its slot, checked to lie inside it.
struct At<R>(PhantomData<R>);
impl<R: Row> At<R> {
    const OFFSET: usize = row_fits(R::OFFSET, size_of::<R::Slot>());
}

/// The byte offsets of a block's nodes (`index · size_of::<T>()`) in a
/// slice of at least `len` slots `T`: every index is below `len`, checked
/// once by [`Corners::new`] for all the gathers and scatters of the block.
pub(crate) struct Corners<T> {
    /// Byte offset of node `k` of lane `j`: `offsets[k][j]` (below 2²⁶:
    /// a `u16` index times a slot of less than 1 kB; `u32` so that the
    /// compiler computes them in vector registers).
    offsets: [[u32; LANES]; 4],
    /// Every index is below this.
    len: usize,
    slot: PhantomData<T>,
}

impl<T> Corners<T> {
    /// The offsets of `ids` (a whole block) into slots `T`, if every index
    /// is below `len`; `offsets(ids, size)` multiplies them (`ids[k][j] ·
    /// size`) with the instruction set's vector multiply.
    #[inline(always)]
    pub(crate) fn new(
        ids: &[[u16; LANES]; 4],
        len: usize,
        offsets: impl FnOnce(&[[u16; LANES]; 4], u32) -> [[u32; LANES]; 4],
    ) -> Option<Self> {
        // `max` over all 32 indices, then one test (vectorised, no early
        // exit); `len == 0` fails it too.
        let mut max = 0u16;
        for c in ids {
            for &i in c {
                max = max.max(i);
            }
        }
        if usize::from(max) >= len {
            return None;
        }
        // (Below 2¹⁶ too, as `Sse2`'s 16-bit multiply needs.)
        const { assert!(size_of::<T>() < 1024, "offsets must fit in u32") };
        Some(Self {
            offsets: offsets(ids, size_of::<T>() as u32),
            len,
            slot: PhantomData,
        })
    }

    /// The row `R` of lane `j` of corner `k` in `slots`, as a function of
    /// `j` (which must be below `LANES`); `None` if `slots` is shorter than
    /// the corners need.
    #[inline(always)]
    pub(crate) fn loader<'a, R: Row<Slot = T>>(
        &'a self,
        slots: &'a [T],
        k: usize,
    ) -> Option<impl Fn(usize) -> __m128 + 'a> {
        let (Some(offsets), true) = (self.table().get(k), slots.len() >= self.len) else {
            return None;
        };
        let base = slots.as_ptr().cast::<u8>();
        // SAFETY: every offset is `i · size_of::<T>()` with `i < self.len
        // ≤ slots.len()` (`Corners::new`, checked above), and the 16 bytes at
        // `R::OFFSET` lie inside the slot (`row_fits`); `loadu` is unaligned;
        // SSE is part of x86_64.
        Some(move |j: usize| unsafe {
            _mm_loadu_ps(
                base.add(offsets[j] as usize + At::<R>::OFFSET)
                    .cast::<f32>(),
            )
        })
    }

    /// The offsets, read from memory where used ([`opaque`]): not taken
    /// from the vector registers they were computed in (with `vpextrd`, two
    /// micro-operations on the vector ports each, which the product is
    /// short of) but each loaded into a general register.
    #[inline(always)]
    fn table(&self) -> &[[u32; LANES]; 4] {
        opaque(&self.offsets)
    }
}

/// `r`, passed through an empty `asm!`: LLVM no longer knows where it points,
/// so every value read through it is loaded where it is used (and can be a
/// memory operand) rather than kept in a register, or spilled, from an
/// earlier load.
#[inline(always)]
pub(crate) fn opaque<T>(r: &T) -> &T {
    let mut p: *const T = r;
    // SAFETY: an empty template; the pointer comes back unchanged.
    unsafe {
        core::arch::asm!("/* {0} */", inout(reg) p, options(pure, readonly, nostack, preserves_flags));
    }
    // SAFETY: `p` is `r`, borrowed as long as the result.
    unsafe { &*p }
}

/// `slot.R += [x, y, z]` for the rows `rows[k][j] = [x, y, z, −0]` of the
/// nodes of `corners` in lanes `first + j`, lane after lane (element order), corners `a, b, c, d` in each: the sums the portable
/// backend makes, in its order, each `field + value`; the fourth float (the
/// next field) gets `−0.0` added, which leaves its bits (see the module's
/// documentation). Nothing if `slots` is shorter than `corners` needs.
/// `first` and `N` are constants at every call (`0`/`8`, `0`/`4`, `4`/`4`).
#[inline(always)]
pub(crate) fn scatter<R: Row, const N: usize>(
    slots: &mut [R::Slot],
    corners: &Corners<R::Slot>,
    first: usize,
    rows: &[[__m128; N]; 4],
) {
    if slots.len() < corners.len {
        return;
    }
    let base = slots.as_mut_ptr().cast::<u8>();
    for j in 0..N {
        for (offsets, rk) in corners.table().iter().zip(rows) {
            let (Some(&at), Some(&v)) = (offsets.get(first + j), rk.get(j)) else {
                continue;
            };
            // SAFETY: as in `Corners::loader`; `slots` is borrowed mutably.
            unsafe {
                let p = base.add(at as usize + At::<R>::OFFSET).cast::<f32>();
                let old = _mm_loadu_ps(p);
                _mm_storeu_ps(p, _mm_add_ps(old, v));
            }
        }
    }
}

/// [`scatter`] of the four corners' values `v` (lanes), each turned into
/// eight rows by the instruction set's `to_rows`.
#[inline(always)]
pub(crate) fn scatter_lanes<R: Row>(
    slots: &mut [R::Slot],
    corners: &Corners<R::Slot>,
    v: &[[Batch; 3]; 4],
    to_rows: impl Fn(&[Batch; 3]) -> [__m128; LANES],
) {
    let r = [
        to_rows(&v[0]),
        to_rows(&v[1]),
        to_rows(&v[2]),
        to_rows(&v[3]),
    ];
    scatter::<R, LANES>(slots, corners, 0, &r);
}

#[cfg(test)]
mod tests {
    use crate::backend::{sse2, Avx2};
    use crate::lanes::LANES;

    /// The node offsets of both instruction sets are `index · size` for
    /// every `u16` index, the largest included (SSE2 forms them from 16-bit
    /// halves, where an index ≥ 2¹⁵ would go wrong with a signed multiply).
    #[test]
    fn offsets_are_index_times_size_for_every_u16() {
        let mut nodes = [[0u16; LANES]; 4];
        let picks: [u16; 11] = [
            0, 1, 2, 255, 256, 4_095, 32_767, 32_768, 40_000, 65_534, 65_535,
        ];
        for (n, id) in nodes.iter_mut().flatten().enumerate() {
            *id = picks[n % picks.len()].wrapping_add((n / picks.len()) as u16 * 7);
        }
        let avx2 = Avx2::new();
        // On a CPU with AVX2 (this machine, CI) both must be checked.
        assert_eq!(avx2.is_some(), std::is_x86_feature_detected!("avx2"));
        for size in [4, 44, 52, 1023] {
            let expect = nodes.map(|c| c.map(|i| u32::from(i) * size));
            assert_eq!(sse2::offsets(&nodes, size), expect);
            if let Some(avx2) = avx2 {
                assert_eq!(avx2.offsets(&nodes, size), expect);
            }
        }
    }
}
