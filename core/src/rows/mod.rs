//! Moves between node storage and lanes on x86_64, for both compiled steps:
//! with AVX2 ([`Scene::step_avx2`](crate::Scene::step_avx2), [`Avx2`]) and
//! with the SSE2 every x86_64 CPU has ([`Scene::step`](crate::Scene::step),
//! [`Sse2`]).
//!
//! The element kernels are the same generic code in either build; what the
//! compiler cannot do well from safe code is moving node vectors in and out
//! of lanes. Built from scalars, a block's 96 gathered values went through the
//! stack (96 scalar stores, and a failed store-to-load forward on the first
//! vector load), and its 96 scattered sums through 96 scalar read-modify-writes
//! (docs/bench.md). Here a node's `[x, y, z]` moves as one 16-byte row:
//!
//! ```text
//! gather  8 rows [x y z ·] of a corner  → 4×4 transposes → X, Y, Z (8 lanes)
//! scatter X, Y, Z of a corner → 8 rows [x y z −0] → row += into the node, element by element
//! ```
//!
//! The two instruction sets differ only in the transposes ([`Moves`]): AVX2
//! does both 4×4 blocks of a corner in one 256-bit register, SSE2 one after
//! the other.
//!
//! A row is 16 bytes read from a 12-byte field: the fourth float is the next
//! field of the same node (checked at compile time below; `d` is read as
//! `[r.z, d]`, see [`WorkD`]). When scattering, that fourth float gets `−0.0`
//! added, which gives back its own bits for every value but a signalling NaN:
//! the fields it falls on (`d.x`, `inv_p`) are results of arithmetic or
//! finite inputs, never a signalling NaN. (A blend that kept them cost 32
//! of the product's ~300 vector micro-operations per block: 2–4 % of the
//! step.) Sums are still made one node at a time in element order, with
//! the same IEEE additions, so the bits are those of the targets without
//! these moves (wasm32, Cortex-M).

#![allow(unsafe_code)] // raw 16-byte loads and stores; the safety of each is argued below

mod avx2;
mod sse2;

pub(crate) use avx2::Avx2;
pub(crate) use sse2::{product_block as product_block_sse2, Sse2};

use core::arch::x86_64::{__m128, _mm_add_ps, _mm_loadu_ps, _mm_storeu_ps};
use core::marker::PhantomData;
use core::mem::{offset_of, size_of};

use crate::element::{hform, Batch, ElementBlock};
use crate::lanes::LANES;
use crate::math::{add, sub, Real};
use crate::pass::share_of_a;
use crate::storage::{Node, NodeWork};

const _: () = assert!(LANES == 8, "the row moves fill 8 lanes");

/// An instruction set's transposes between node rows and lanes.
///
/// Every method is `unsafe` for one reason: the CPU must support the
/// instruction set (always true of [`Sse2`] on x86_64). The methods are
/// `#[inline(always)]`, so their intrinsics are compiled for the function
/// they are inlined into (for [`Avx2`], one with `#[target_feature(enable =
/// "avx2")]`).
pub(crate) trait Moves {
    /// `nodes[k][j] · size` for every corner `k` and lane `j`.
    unsafe fn offsets(nodes: &[[u16; LANES]; 4], size: u32) -> [[u32; LANES]; 4];
    /// The rows `row(j)` of lanes `j = 0..8`, `[x y z ·]` (or, with `lead`,
    /// `[· x y z]`), as lanes `[X, Y, Z]`.
    unsafe fn to_lanes(row: impl Fn(usize) -> __m128, lead: bool) -> [Batch; 3];
    /// `[X, Y, Z]` as the rows `[xⱼ, yⱼ, zⱼ, −0]` of lanes `j = 0..8`
    /// (`−0.0`: adding it leaves any other float's bits, `+0 + −0 = +0`).
    unsafe fn to_rows(v: &[Batch; 3]) -> [__m128; LANES];
    /// Keeps the lane values `v` apart from the code around them, in
    /// registers: an empty `asm!` that takes and returns them, so LLVM
    /// cannot merge the transposes into the kernels. (Without any barrier it
    /// did, and computed the product's second half 4 lanes wide: 1 195
    /// instructions per block instead of 630 with AVX2; `black_box` kept
    /// them apart through the stack.)
    unsafe fn fence<const N: usize>(v: &mut [[Batch; 3]; N]);
}

/// A `Vec3` field of a node slot, read and written as a 16-byte row: its
/// byte offset, with the row inside the slot.
pub(crate) trait Row {
    /// The slot type.
    type Slot;
    /// Byte offset of the row in the slot.
    const OFFSET: usize;
    /// Whether the row starts one float before the field (the field is in
    /// floats 1..4 of the row, not 0..3).
    const LEAD: bool = false;
}

/// Checks at compile time that a 16-byte row at `offset` lies inside a slot
/// of `size` bytes (so reading it never leaves the slot).
const fn row_fits(offset: usize, size: usize) -> usize {
    assert!(
        offset + 16 <= size,
        "a 16-byte row must stay inside its slot"
    );
    offset
}

macro_rules! row {
    ($name:ident, $slot:ty, $field:ident) => {
        #[doc = concat!("`", stringify!($slot), "::", stringify!($field), "` as a row.")]
        pub(crate) struct $name;
        impl Row for $name {
            type Slot = $slot;
            const OFFSET: usize = row_fits(offset_of!($slot, $field), size_of::<$slot>());
        }
    };
}
/// `NodeWork::d`, read as the row `[r.z, d.x, d.y, d.z]`: the row
/// `[d.x, d.y, d.z, q.x]` would overlap the product's stores of `q` rows
/// (`[q.x, q.y, q.z, inv_p]`) to the same node in an earlier block, and a
/// load that overlaps a pending store only in part cannot take its data from
/// it: it waits until the store has reached the cache.
pub(crate) struct WorkD;
impl Row for WorkD {
    type Slot = NodeWork;
    const OFFSET: usize = row_fits(offset_of!(NodeWork, d) - 4, size_of::<NodeWork>());
    const LEAD: bool = true;
}
row!(WorkQ, NodeWork, q);
row!(WorkR, NodeWork, r);
row!(NodeX0, Node, x0);
row!(NodeU, Node, u);
row!(NodeV, Node, v);

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
    /// The offsets of `nodes` into slots `T`, if every index is below `len`.
    ///
    /// # Safety
    ///
    /// The CPU must support `M`'s instruction set.
    #[inline(always)]
    pub(crate) unsafe fn new<M: Moves>(nodes: &[[u16; LANES]; 4], len: usize) -> Option<Self> {
        // `max` over all 32 indices, then one test (vectorised, no early exit).
        let mut max = 0u16;
        for c in nodes {
            for &i in c {
                max = max.max(i);
            }
        }
        if usize::from(max) >= len {
            return None;
        }
        // (Below 2¹⁶ too, as `Sse2::offsets`' 16-bit multiply needs.)
        const { assert!(size_of::<T>() < 1024, "offsets must fit in u32") };
        // SAFETY: the caller's.
        let offsets = unsafe { M::offsets(nodes, size_of::<T>() as u32) };
        Some(Self {
            offsets,
            len,
            slot: PhantomData,
        })
    }

    /// The row `R` of lane `j` of corner `k` in `slots`, as a function of
    /// `j` (which must be below `LANES`); `None` if `slots` is shorter than
    /// the corners need.
    #[inline(always)]
    fn loader<'a, R: Row<Slot = T>>(
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
            _mm_loadu_ps(base.add(offsets[j] as usize + R::OFFSET).cast::<f32>())
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
fn opaque<T>(r: &T) -> &T {
    let mut p: *const T = r;
    // SAFETY: an empty template; the pointer comes back unchanged.
    unsafe {
        core::arch::asm!("/* {0} */", inout(reg) p, options(pure, readonly, nostack, preserves_flags));
    }
    // SAFETY: `p` is `r`, borrowed as long as the result.
    unsafe { &*p }
}

/// The row field `R` of corner `k` (8 lanes) of `slots`, in lanes
/// `[X, Y, Z]`; zeros if `slots` is shorter than `corners` needs.
///
/// # Safety
///
/// The CPU must support `M`'s instruction set. (This and the other helpers
/// are `#[inline(always)]` functions rather than `#[target_feature]` ones,
/// which cannot be forced inline: their intrinsics are compiled for the
/// function they are inlined into, the AVX2 step's or the baseline's.)
#[inline(always)]
unsafe fn gather<M: Moves, R: Row>(
    slots: &[R::Slot],
    corners: &Corners<R::Slot>,
    k: usize,
) -> [Batch; 3] {
    let Some(row) = corners.loader::<R>(slots, k) else {
        return [Batch::splat(0.0); 3];
    };
    // SAFETY: the caller's.
    unsafe { M::to_lanes(row, R::LEAD) }
}

/// [`gather`] of the four corners: `[corner][component]`.
///
/// # Safety
///
/// The CPU must support `M`'s instruction set.
#[inline(always)]
unsafe fn gather4<M: Moves, R: Row>(slots: &[R::Slot], c: &Corners<R::Slot>) -> [[Batch; 3]; 4] {
    // SAFETY: the caller's.
    unsafe {
        [
            gather::<M, R>(slots, c, 0),
            gather::<M, R>(slots, c, 1),
            gather::<M, R>(slots, c, 2),
            gather::<M, R>(slots, c, 3),
        ]
    }
}

/// `slot.R += [x, y, z]` for the rows `rows[k][j] = [x, y, z, −0]` of the
/// nodes of `corners` in lanes `first + j`, lane after lane (element
/// order), corners `a, b, c, d` in each: the sums the scalar code makes, in
/// its order, each `field + value`; the fourth float (the next field) gets
/// `−0.0` added, which leaves its bits (see the module's documentation).
/// Nothing if `slots` is shorter than `corners` needs. (SSE only: every
/// x86_64 CPU has it.) `first` and `N` are constants at every call
/// (`0`/`8`, `0`/`4`, `4`/`4`); the AVX2 step kept its time when the lane
/// checks were added.
#[inline(always)]
fn scatter<R: Row, const N: usize>(
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
            // SAFETY: as in `gather`; `slots` is borrowed mutably.
            unsafe {
                let p = base.add(at as usize + R::OFFSET).cast::<f32>();
                let old = _mm_loadu_ps(p);
                _mm_storeu_ps(p, _mm_add_ps(old, v));
            }
        }
    }
}

/// Adds each element's `[f_b, f_c, f_d]` (lanes) and node `a`'s share
/// `−(f_b + f_c + f_d)` into the field `R` of its four nodes, as rows, in
/// element order: the sums of `pass::scatter`, with its bits.
///
/// # Safety
///
/// The CPU must support `M`'s instruction set.
#[inline(always)]
unsafe fn add_to_nodes<M: Moves, R: Row<Slot = NodeWork>>(
    work: &mut [NodeWork],
    c: &Corners<NodeWork>,
    f: &[[Batch; 3]; 3],
) {
    // Node a's share in lanes too, before the barrier (after it, LLVM
    // computed it half in 4-wide, half in 2-wide pieces).
    let mut fa = [share_of_a(f), f[0], f[1], f[2]];
    // SAFETY: the caller's. (Not `array::map`: it was not inlined.)
    unsafe {
        M::fence(&mut fa);
        let r = [
            M::to_rows(&fa[0]),
            M::to_rows(&fa[1]),
            M::to_rows(&fa[2]),
            M::to_rows(&fa[3]),
        ];
        scatter::<R, LANES>(work, c, 0, &r);
    }
}

/// The stiffness product `q += −K d` of one whole block (see
/// `pass::stiffness`): the same kernel as on targets without these moves,
/// with the corners' `d` gathered and the results scattered as rows.
/// Returns `false`, having done nothing, if a node index is out of range
/// (impossible after `build`; the caller then takes the general path, which
/// skips such elements).
///
/// # Safety
///
/// The CPU must support `M`'s instruction set.
#[inline(always)]
pub(crate) unsafe fn product_block<M: Moves>(
    per_young: [f32; 2],
    blk: &ElementBlock,
    work: &mut [NodeWork],
) -> bool {
    // SAFETY (of every call below): the caller's.
    let Some(corners) = (unsafe { Corners::<NodeWork>::new::<M>(&blk.nodes, work.len()) }) else {
        return false;
    };
    let mut x = unsafe { gather4::<M, WorkD>(work, &corners) };
    unsafe { M::fence(&mut x) };
    let lame = crate::material::lame(blk.stiffness, per_young);
    let s = hform::product_stress(&x, &blk.grad, lame);
    // The gradients again for the forces: kept in registers from the
    // stress, LLVM spilled them.
    let kd = hform::product_forces(&s, opaque(&blk.grad));
    unsafe { add_to_nodes::<M, WorkQ>(work, &corners, &kd) };
    true
}

/// [`product_block`] with AVX2, out of line from the step's CG loop. The
/// caller must run on a CPU with AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn product_block_avx2(
    per_young: [f32; 2],
    blk: &ElementBlock,
    work: &mut [NodeWork],
) -> bool {
    // SAFETY: this function runs only on CPUs with AVX2.
    unsafe { product_block::<Avx2>(per_young, blk, work) }
}

/// Three edge vectors in lanes, `[edge][component]`.
type Edges3 = [[Batch; 3]; 3];

/// The edges `b − a, c − a, d − a` of a block's elements `ids`, in lanes:
/// rest (`x0`), displacement (`u`) and current (their sum), as
/// `pass::diffs` and `element::current_edges` form them, and the block's
/// node offsets for [`scatter_forces`]; `None` if an index is out of range.
/// Corner by corner, so that only the edges stay live.
///
/// # Safety
///
/// The CPU must support `M`'s instruction set. (Inlined into the force pass,
/// as [`scatter_forces`] is.)
#[inline(always)]
pub(crate) unsafe fn gather_edges<M: Moves>(
    nodes: &[Node],
    ids: &[[u16; LANES]; 4],
) -> Option<(Corners<Node>, [Edges3; 3])> {
    // SAFETY (of every call below): the caller's.
    let c = unsafe { Corners::<Node>::new::<M>(ids, nodes.len()) }?;
    let mut a = unsafe {
        [
            gather::<M, NodeX0>(nodes, &c, 0),
            gather::<M, NodeU>(nodes, &c, 0),
        ]
    };
    unsafe { M::fence(&mut a) };
    let [b, cc, d] = unsafe {
        [
            edge::<M>(nodes, &c, 1, &a),
            edge::<M>(nodes, &c, 2, &a),
            edge::<M>(nodes, &c, 3, &a),
        ]
    };
    let edges = [
        [b[0], cc[0], d[0]],
        [b[1], cc[1], d[1]],
        [b[2], cc[2], d[2]],
    ];
    Some((c, edges))
}

/// The rest, displacement and current edge from corner `a` to corner `k`
/// of the nodes `c` (`a` holds corner `a`'s rest position and displacement).
///
/// # Safety
///
/// The CPU must support `M`'s instruction set.
#[inline(always)]
unsafe fn edge<M: Moves>(
    nodes: &[Node],
    c: &Corners<Node>,
    k: usize,
    a: &[[Batch; 3]; 2],
) -> [[Batch; 3]; 3] {
    // SAFETY: the caller's.
    let mut p = unsafe {
        [
            gather::<M, NodeX0>(nodes, c, k),
            gather::<M, NodeU>(nodes, c, k),
        ]
    };
    // SAFETY: as above.
    unsafe { M::fence(&mut p) };
    let (rest, du) = (sub(p[0], a[0]), sub(p[1], a[1]));
    [rest, du, add(rest, du)]
}

/// The force pass's sums for a whole block: `r += f` and (with `WITH_KV`)
/// `q += −K v` of each node, element after element, node `a` getting
/// `−(f_b + f_c + f_d)` (and the same of `−K v`), as
/// [`crate::pass::IntoWork`] adds them. `−K v` is computed here, from the
/// velocities of `nodes` (at the offsets `at`, from [`gather_edges`]) and
/// the world gradients `grad`, after the forces
/// are out: gathered before the kernel and kept through it, the velocities
/// spilled. Returns `false`, having done nothing, if a node index is out of
/// range.
///
/// # Safety
///
/// The CPU must support `M`'s instruction set. (Not a `#[target_feature]`
/// function but one inlined into the force pass compiled for AVX2: with
/// every method built, LLVM left a `#[target_feature]` one out of line,
/// called from each method's pass, and the forces and gradients went
/// through memory.)
#[inline(always)]
pub(crate) unsafe fn scatter_forces<M: Moves, const WITH_KV: bool>(
    work: &mut [NodeWork],
    nodes: &[Node],
    at: &Corners<Node>,
    ids: &[[u16; LANES]; 4],
    f: &[[Batch; 3]; 3],
    grad: &[[Batch; 3]; 3],
    lame: [Batch; 2],
) -> bool {
    // SAFETY (of every call below): the caller's.
    let Some(c) = (unsafe { Corners::<NodeWork>::new::<M>(ids, work.len()) }) else {
        return false;
    };
    unsafe { add_to_nodes::<M, WorkR>(work, &c, f) };
    if WITH_KV {
        let mut vel = unsafe { gather4::<M, NodeV>(nodes, at) };
        unsafe { M::fence(&mut vel) };
        let kv = hform::stiffness_product(&vel, grad, lame);
        unsafe { add_to_nodes::<M, WorkQ>(work, &c, &kv) };
    }
    true
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

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
        for size in [4, 44, 52, 1023] {
            let expect = nodes.map(|c| c.map(|i| u32::from(i) * size));
            // SAFETY: every x86_64 CPU has SSE2.
            assert_eq!(unsafe { Sse2::offsets(&nodes, size) }, expect);
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: checked just above.
                assert_eq!(unsafe { Avx2::offsets(&nodes, size) }, expect);
            }
        }
    }
}
