//! AVX2 moves between node storage and lanes, for the step compiled for AVX2
//! ([`Scene::step_avx2`](crate::Scene::step_avx2)).
//!
//! The element kernels are the same generic code in either build; what the
//! compiler cannot do well from safe code is moving node vectors in and out
//! of lanes. Built from scalars, a block's 96 gathered values went through the
//! stack (96 scalar stores, and a failed store-to-load forward on the first
//! vector load), and its 96 scattered sums through 96 scalar read-modify-writes
//! (docs/bench.md). Here a node's `[x, y, z]` moves as one 16-byte row:
//!
//! ```text
//! gather  8 rows [x y z ·] of a corner  → 4×4 transposes in both halves → X, Y, Z (8 lanes)
//! scatter X, Y, Z of a corner → 8 rows [x y z −0] → row += into the node, element by element
//! ```
//!
//! A row is 16 bytes read from a 12-byte field: the fourth float is the next
//! field of the same node (checked at compile time below; `d` is read as
//! `[r.z, d]`, see [`WorkD`]). When scattering, that fourth float gets `−0.0`
//! added, which gives back its own bits for every value but a signalling NaN:
//! the fields it falls on (`d.x`, `inv_p`) are results of arithmetic or
//! finite inputs, never a signalling NaN. (A blend that kept them cost 32
//! of the product's ~300 vector micro-operations per block: 2–4 % of the
//! step.) Sums are still made one node at a time in element order, with
//! the same IEEE additions, so the bits are those of the baseline build.

#![allow(unsafe_code)] // raw 16-byte loads and stores; the safety of each is argued below

use core::arch::x86_64::{
    __m128, __m256, _mm256_castps256_ps128, _mm256_cvtepu16_epi32, _mm256_extractf128_ps,
    _mm256_mullo_epi32, _mm256_set1_epi32, _mm256_set1_ps, _mm256_set_m128, _mm256_shuffle_ps,
    _mm256_storeu_si256, _mm256_unpackhi_ps, _mm256_unpacklo_ps, _mm_add_ps, _mm_loadu_ps,
    _mm_loadu_si128, _mm_storeu_ps,
};
use core::marker::PhantomData;
use core::mem::{offset_of, size_of, transmute};

use crate::element::{hform, Batch, ElementBlock};
use crate::lanes::{Lanes, LANES};
use crate::math::{add, sub, Real};
use crate::pass::share_of_a;
use crate::storage::{Node, NodeWork};

/// Keeps the lane values `v` apart from the code around them, in
/// registers: an empty `asm!` that takes and returns them, so LLVM cannot
/// merge the transposes into the kernels. (Without any barrier it did, and
/// computed the product's second half 4 lanes wide: 1 195 instructions per
/// block instead of 630; `black_box` kept them apart through the stack.)
/// Compiled for AVX, as `asm!` with `ymm` registers must be; inlined, like
/// the helpers below, where it is called.
#[inline]
#[target_feature(enable = "avx")]
fn fence<const N: usize>(v: &mut [[Batch; 3]; N]) {
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

const _: () = assert!(LANES == 8, "the AVX2 moves fill 8 lanes");

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
    /// The CPU must support AVX2.
    #[inline(always)]
    pub(crate) unsafe fn new(nodes: &[[u16; LANES]; 4], len: usize) -> Option<Self> {
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
        const { assert!(size_of::<T>() < 1024, "offsets must fit in u32") };
        let size = _mm256_set1_epi32(size_of::<T>() as i32);
        let mut offsets = [[0; LANES]; 4];
        // Widened to 32 bits and multiplied in vector registers (written as
        // scalars, LLVM made it 32 scalar multiplications in the force pass),
        // then read back one by one where used.
        for (o, c) in offsets.iter_mut().zip(nodes) {
            // SAFETY: `c` and `o` are 16 and 32 bytes (8 `u16`, 8 `u32`);
            // AVX2 is the caller's promise.
            unsafe {
                let ids = _mm256_cvtepu16_epi32(_mm_loadu_si128(c.as_ptr().cast()));
                _mm256_storeu_si256(o.as_mut_ptr().cast(), _mm256_mullo_epi32(ids, size));
            }
        }
        Some(Self {
            offsets,
            len,
            slot: PhantomData,
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
/// The CPU must support AVX2. (This and the other helpers are
/// `#[inline(always)]` functions rather than `#[target_feature]` ones, which
/// cannot be forced inline: inlined into the `#[target_feature]` entry points
/// below, their intrinsics are compiled for AVX2.)
#[inline(always)]
unsafe fn gather<R: Row>(slots: &[R::Slot], corners: &Corners<R::Slot>, k: usize) -> [Batch; 3] {
    let (Some(offsets), true) = (corners.table().get(k), slots.len() >= corners.len) else {
        return [Batch::splat(0.0); 3];
    };
    let base = slots.as_ptr().cast::<u8>();
    // SAFETY: every offset is `i · size_of::<Slot>()` with `i < corners.len
    // ≤ slots.len()` (`Corners::new`, checked above), and the 16 bytes at
    // `R::OFFSET` lie inside the slot (`row_fits`); `loadu` is unaligned.
    let row =
        |j: usize| unsafe { _mm_loadu_ps(base.add(offsets[j] as usize + R::OFFSET).cast::<f32>()) };
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

/// [`gather`] of the four corners: `[corner][component]`.
///
/// # Safety
///
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn gather4<R: Row>(slots: &[R::Slot], c: &Corners<R::Slot>) -> [[Batch; 3]; 4] {
    // SAFETY: the caller's.
    unsafe {
        [
            gather::<R>(slots, c, 0),
            gather::<R>(slots, c, 1),
            gather::<R>(slots, c, 2),
            gather::<R>(slots, c, 3),
        ]
    }
}

/// `[X, Y, Z]` (8 lanes) as the rows `[xⱼ, yⱼ, zⱼ, −0]` of lanes `j = 0..8`.
///
/// # Safety
///
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn rows(v: &[Batch; 3]) -> [__m128; LANES] {
    let [x, y, z] = v.map(vector);
    // −0.0: adding it leaves any other float's bits (+0 + −0 = +0).
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

/// `slot.R += [x, y, z]` for the rows `rows[k][j] = [x, y, z, −0]` of the
/// nodes of `corners`, lane after lane (element order), corners `a, b, c, d`
/// in each: the sums the scalar code makes, in its order, each `field +
/// value`; the fourth float (the next field) gets `−0.0` added, which
/// leaves its bits (see the module's documentation). Nothing if `slots` is
/// shorter than `corners` needs.
///
/// # Safety
///
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn scatter<R: Row>(
    slots: &mut [R::Slot],
    corners: &Corners<R::Slot>,
    rows: &[[__m128; LANES]; 4],
) {
    if slots.len() < corners.len {
        return;
    }
    let base = slots.as_mut_ptr().cast::<u8>();
    for j in 0..LANES {
        for (offsets, rk) in corners.table().iter().zip(rows) {
            // SAFETY: as in `gather`; `slots` is borrowed mutably.
            unsafe {
                let p = base.add(offsets[j] as usize + R::OFFSET).cast::<f32>();
                let old = _mm_loadu_ps(p);
                _mm_storeu_ps(p, _mm_add_ps(old, rk[j]));
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
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn add_to_nodes<R: Row<Slot = NodeWork>>(
    work: &mut [NodeWork],
    c: &Corners<NodeWork>,
    f: &[[Batch; 3]; 3],
) {
    // Node a's share in lanes too, before the barrier (after it, LLVM
    // computed it half in 4-wide, half in 2-wide pieces).
    let mut fa = [share_of_a(f), f[0], f[1], f[2]];
    // SAFETY: the caller's. (Not `array::map`: it was not inlined.)
    unsafe {
        fence(&mut fa);
        let r = [rows(&fa[0]), rows(&fa[1]), rows(&fa[2]), rows(&fa[3])];
        scatter::<R>(work, c, &r);
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

/// The stiffness product `q += −K d` of one whole block (see
/// `pass::stiffness`): the same kernel as the baseline build, with the
/// corners' `d` gathered and the results scattered as rows. Returns `false`,
/// having done nothing, if a node index is out of range (impossible after
/// `build`; the caller then takes the baseline path, which skips such
/// elements). The caller must run on a CPU with AVX2.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn product_block(
    per_young: [f32; 2],
    blk: &ElementBlock,
    work: &mut [NodeWork],
) -> bool {
    // SAFETY: this function runs only on CPUs with AVX2.
    let Some(corners) = (unsafe { Corners::<NodeWork>::new(&blk.nodes, work.len()) }) else {
        return false;
    };
    // SAFETY (of the helpers): this function runs only on CPUs with AVX2.
    let mut x = unsafe { gather4::<WorkD>(work, &corners) };
    fence(&mut x);
    let lame = crate::material::lame(blk.stiffness, per_young);
    let s = hform::product_stress(&x, &blk.grad, lame);
    // The gradients again for the forces: kept in registers from the
    // stress, LLVM spilled them.
    let kd = hform::product_forces(&s, opaque(&blk.grad));
    // SAFETY: as above.
    unsafe { add_to_nodes::<WorkQ>(work, &corners, &kd) };
    true
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
/// The CPU must support AVX2. (Inlined into the force pass compiled for
/// AVX2, as [`scatter_forces`] is.)
#[inline(always)]
pub(crate) unsafe fn gather_edges(
    nodes: &[Node],
    ids: &[[u16; LANES]; 4],
) -> Option<(Corners<Node>, [Edges3; 3])> {
    // SAFETY (of every call below): the caller's.
    let c = unsafe { Corners::<Node>::new(ids, nodes.len()) }?;
    let mut a = unsafe {
        [
            gather::<NodeX0>(nodes, &c, 0),
            gather::<NodeU>(nodes, &c, 0),
        ]
    };
    unsafe { fence(&mut a) };
    let [b, cc, d] = unsafe {
        [
            edge(nodes, &c, 1, &a),
            edge(nodes, &c, 2, &a),
            edge(nodes, &c, 3, &a),
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
/// The CPU must support AVX2.
#[inline(always)]
unsafe fn edge(
    nodes: &[Node],
    c: &Corners<Node>,
    k: usize,
    a: &[[Batch; 3]; 2],
) -> [[Batch; 3]; 3] {
    // SAFETY: the caller's.
    let mut p = unsafe { [gather::<NodeX0>(nodes, c, k), gather::<NodeU>(nodes, c, k)] };
    // SAFETY: as above.
    unsafe { fence(&mut p) };
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
/// The CPU must support AVX2. (Not a `#[target_feature]` function but one
/// inlined into the force pass compiled for AVX2: with every method built,
/// LLVM left a `#[target_feature]` one out of line, called from each
/// method's pass, and the forces and gradients went through memory.)
#[inline(always)]
pub(crate) unsafe fn scatter_forces<const WITH_KV: bool>(
    work: &mut [NodeWork],
    nodes: &[Node],
    at: &Corners<Node>,
    ids: &[[u16; LANES]; 4],
    f: &[[Batch; 3]; 3],
    grad: &[[Batch; 3]; 3],
    lame: [Batch; 2],
) -> bool {
    // SAFETY (of every call below): the caller's.
    let Some(c) = (unsafe { Corners::<NodeWork>::new(ids, work.len()) }) else {
        return false;
    };
    unsafe { add_to_nodes::<WorkR>(work, &c, f) };
    if WITH_KV {
        let mut vel = unsafe { gather4::<NodeV>(nodes, at) };
        unsafe { fence(&mut vel) };
        let kv = hform::stiffness_product(&vel, grad, lame);
        unsafe { add_to_nodes::<WorkQ>(work, &c, &kv) };
    }
    true
}
