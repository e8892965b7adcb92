//! The instruction-set layer: what differs between instruction sets, and
//! nothing else.
//!
//! The element kernels are written once, over [`Real`] values: `f32` for one
//! element, [`Batch`] for a block of [`LANES`] elements. What an instruction
//! set changes is how node vectors move between node storage (one `[x, y, z]`
//! per node, 44 or 52-byte slots) and lanes, and how wide a register is. A
//! [`Backend`] provides exactly that:
//!
//! ```text
//! corners   the block's node indices, checked once against the slots
//! gather    field R of corner k of every lane          → [X, Y, Z] in lanes
//! scatter   [Δa, Δb, Δc, Δd] in lanes → slot.R += Δ, element after element,
//!           corners a, b, c, d in each (the sums of one element at a time)
//! chunk     the part of a block the stiffness product runs at once (SSE2:
//!           half a block, whose values fit its 16 registers)
//! fence     keeps lane values in registers, apart from the moves around them
//! call      an out-of-line call compiled for the instruction set
//! ```
//!
//! Three backends implement it: [`Portable`] (every target: lanes filled one
//! value at a time, the loops left to the compiler's vectoriser), and on
//! x86_64 `Sse2` (every x86_64 CPU) and `Avx2`, which move a node vector as
//! one 16-byte row and transpose rows to lanes in registers. The force pass
//! and the stiffness product (`crate::pass`) and the step (`crate::step`)
//! are generic over the backend and compiled once per instruction set; the
//! step picks one at run time ([`InstructionSet`]).
//!
//! Every backend makes the same IEEE operations in the same order (no fused
//! multiply-add: Rust never contracts, and the `fma` feature is never
//! enabled), and every sum into a node is made in element order, so every
//! backend gives the same bits.
//!
//! A backend value is a token: `Avx2` can only be made where the CPU is
//! known to have AVX2, so its methods are safe to call.

/// Marks a function (an item) or a closure (an expression, where attributes
/// on closures are allowed: a `let` initialiser's block tail, an argument)
/// `#[inline(always)]` on x86 hosts: the step is compiled there once per
/// instruction set ([`Backend::call`]), and code left out of line would
/// stay at the baseline (every AVX2 intrinsic inlined into it a call).
/// Elsewhere the compiler chooses: one out-of-line copy saves flash.
macro_rules! isa_inline {
    (move $($closure:tt)*) => {{
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        move $($closure)*
    }};
    (| $($closure:tt)*) => {{
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        | $($closure)*
    }};
    ($item:item) => {
        #[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
        $item
    };
}
pub(crate) use isa_inline;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(all(
    feature = "fpu-product",
    target_arch = "arm",
    target_os = "none",
    target_abi = "eabihf"
))]
pub(crate) mod fpu_product;
#[cfg(target_arch = "x86_64")]
mod rows;
#[cfg(target_arch = "x86_64")]
mod sse2;

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::Avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) use sse2::Sse2;

use crate::element::Batch;
use crate::lanes::LANES;
use crate::math::{add, Real, Vec3};
use crate::storage::{Node, NodeWork};

/// An instruction set's moves between node storage and lanes (see the
/// module's documentation).
pub(crate) trait Backend: Copy {
    /// Lanes of a chunk: the part of a block that the stiffness product
    /// computes at once.
    type Chunk: Real;
    /// Chunks in a block.
    const CHUNKS: usize;
    /// A block's node indices, checked, in the form the moves use, for slots
    /// of type `T`.
    type Corners<T>;

    /// The corners of a whole block with node indices `ids`, in a slice of
    /// `len` slots `T`; `None` if an index is `len` or more (impossible
    /// after `Scene::build`). (A partial block goes through
    /// [`Portable::partial`].)
    fn corners<T>(self, ids: &[[u16; LANES]; 4], len: usize) -> Option<Self::Corners<T>>;

    /// Field `R` of corner `k` (`a, b, c, d` for 0..4) of every lane, as
    /// lanes `[X, Y, Z]`. Zeros if `slots` is shorter than the corners were
    /// checked against.
    fn gather<R: Row>(self, slots: &[R::Slot], c: &Self::Corners<R::Slot>, k: usize) -> [Batch; 3];

    /// `slot.R += v[k]` for the node of corner `k` of every lane: lane
    /// after lane (element order), corners `a, b, c, d` in each, every sum
    /// `field + value`. Nothing if `slots` is shorter than the corners were
    /// checked against.
    fn scatter<R: Row>(
        self,
        slots: &mut [R::Slot],
        c: &Self::Corners<R::Slot>,
        v: &[[Batch; 3]; 4],
    );

    /// Lanes of chunk `h` of `v`.
    fn chunk(self, v: &Batch, h: usize) -> Self::Chunk;

    /// [`Backend::gather`] of the lanes of chunk `h`.
    fn gather_chunk<R: Row>(
        self,
        slots: &[R::Slot],
        c: &Self::Corners<R::Slot>,
        k: usize,
        h: usize,
    ) -> [Self::Chunk; 3];

    /// [`Backend::scatter`] of the lanes of chunk `h`.
    fn scatter_chunk<R: Row>(
        self,
        slots: &mut [R::Slot],
        c: &Self::Corners<R::Slot>,
        h: usize,
        v: &[[Self::Chunk; 3]; 4],
    );

    /// Keeps the values `v` apart from the code around them, in registers:
    /// the compiler may not merge the moves into the kernels (where it did,
    /// it computed half of the AVX2 product four lanes wide, at twice the
    /// instructions). Nothing on backends without such moves.
    #[inline(always)]
    fn fence<const N: usize>(self, v: &mut [[Batch; 3]; N]) {
        let _ = v;
    }

    /// [`Backend::fence`] for chunks.
    #[inline(always)]
    fn fence_chunk<const N: usize>(self, v: &mut [[Self::Chunk; 3]; N]) {
        let _ = v;
    }

    /// `r`, with every value read through it loaded where it is used rather
    /// than kept in a register from an earlier load (where registers are
    /// short, keeping them spilled). `r` itself elsewhere.
    #[inline(always)]
    fn reread<T>(self, r: &T) -> &T {
        r
    }

    /// `f()`, out of line and compiled for this instruction set (`f` must be
    /// an `#[inline(always)]` closure, so that its body is compiled there).
    fn call<T>(self, f: impl FnOnce() -> T) -> T;
}

/// A `Vec3` field of a node slot that the backends move: its slot type, its
/// place in the slot, and (for [`Portable`]) access to it.
pub(crate) trait Row {
    /// The slot type.
    type Slot;
    /// Byte offset of the 16 bytes read and written as a row (x86_64); the
    /// row lies inside the slot (checked at compile time where used).
    // (Only the x86_64 backends move rows.)
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    const OFFSET: usize;
    /// Whether the row starts one float before the field (the field is in
    /// floats 1..4 of the row, not 0..3).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    const LEAD: bool = false;
    /// The field.
    fn get(slot: &Self::Slot) -> Vec3;
    /// The field, to add into.
    fn get_mut(slot: &mut Self::Slot) -> &mut Vec3;
}

macro_rules! row {
    ($(#[$doc:meta])* $name:ident, $slot:ty, $field:ident, $offset:expr, $lead:expr) => {
        $(#[$doc])*
        pub(crate) struct $name;
        impl Row for $name {
            type Slot = $slot;
            const OFFSET: usize = $offset;
            const LEAD: bool = $lead;
            #[inline(always)]
            fn get(slot: &$slot) -> Vec3 {
                slot.$field
            }
            #[inline(always)]
            fn get_mut(slot: &mut $slot) -> &mut Vec3 {
                &mut slot.$field
            }
        }
    };
    ($name:ident, $slot:ty, $field:ident) => {
        row!(
            #[doc = concat!("`", stringify!($slot), "::", stringify!($field), "` as a row.")]
            $name, $slot, $field, core::mem::offset_of!($slot, $field), false
        );
    };
}

row!(
    /// `NodeWork::d`, read as the row `[r.z, d.x, d.y, d.z]`: the row
    /// `[d.x, d.y, d.z, q.x]` would overlap the product's stores of `q`
    /// rows (`[q.x, q.y, q.z, inv_p]`) to the same node in an earlier block,
    /// and a load that overlaps a pending store only in part cannot take its
    /// data from it: it waits until the store has reached the cache.
    WorkD, NodeWork, d, core::mem::offset_of!(NodeWork, d) - 4, true
);
row!(WorkQ, NodeWork, q);
row!(WorkR, NodeWork, r);
row!(NodeX0, Node, x0);
row!(NodeU, Node, u);

/// The chunk methods of a backend whose chunk is the whole block
/// (`type Chunk = Batch; const CHUNKS: usize = 1;`): the block's own.
macro_rules! whole_block_chunks {
    () => {
        #[inline(always)]
        fn chunk(self, v: &Batch, _h: usize) -> Batch {
            *v
        }

        #[inline(always)]
        fn gather_chunk<R: Row>(
            self,
            slots: &[R::Slot],
            c: &Self::Corners<R::Slot>,
            k: usize,
            _h: usize,
        ) -> [Batch; 3] {
            self.gather::<R>(slots, c, k)
        }

        #[inline(always)]
        fn scatter_chunk<R: Row>(
            self,
            slots: &mut [R::Slot],
            c: &Self::Corners<R::Slot>,
            _h: usize,
            v: &[[Batch; 3]; 4],
        ) {
            self.scatter::<R>(slots, c, v);
        }

        #[inline(always)]
        fn fence_chunk<const N: usize>(self, v: &mut [[Batch; 3]; N]) {
            self.fence(v);
        }
    };
}
#[cfg(target_arch = "x86_64")]
pub(crate) use whole_block_chunks;

/// The portable backend: lanes filled and emptied one value at a time. The
/// baseline of every target but x86_64, and (with one lane) of a
/// Cortex-M4F; on every target, the partial block of the stiffness product
/// ([`Portable::partial`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable;

/// [`Portable`]'s corners: the node index of corner `k` of lane `j`, for the
/// used lanes (all below the slot count checked); lanes past them are
/// neither gathered (zeros) nor scattered.
pub(crate) struct Indices {
    ids: [[u16; LANES]; 4],
    lanes: usize,
    len: usize,
}

impl Portable {
    /// The corners of the first `lanes` lanes of a block with node indices
    /// `ids`, in a slice of `len` slots; `None` if an index of those lanes
    /// is `len` or more (impossible after `Scene::build`). Every backend's
    /// passes take a partial block (the last) through this.
    #[inline(always)]
    pub(crate) fn partial(ids: &[[u16; LANES]; 4], lanes: usize, len: usize) -> Option<Indices> {
        let lanes = lanes.min(LANES);
        let fits = ids
            .iter()
            .all(|c| c.iter().take(lanes).all(|&i| usize::from(i) < len));
        fits.then_some(Indices {
            ids: *ids,
            lanes,
            len,
        })
    }
}

impl Backend for Portable {
    type Chunk = Batch;
    const CHUNKS: usize = 1;
    type Corners<T> = Indices;

    #[inline(always)]
    fn corners<T>(self, ids: &[[u16; LANES]; 4], len: usize) -> Option<Indices> {
        Self::partial(ids, LANES, len)
    }

    #[inline(always)]
    fn gather<R: Row>(self, slots: &[R::Slot], c: &Indices, k: usize) -> [Batch; 3] {
        let mut out = [Batch::splat(0.0); 3];
        let (Some(ids), true) = (c.ids.get(k), slots.len() >= c.len) else {
            return out;
        };
        for (j, &i) in ids.iter().enumerate().take(c.lanes) {
            if let Some(slot) = slots.get(usize::from(i)) {
                Batch::put(&mut out, j, R::get(slot));
            }
        }
        out
    }

    #[inline(always)]
    fn scatter<R: Row>(self, slots: &mut [R::Slot], c: &Indices, v: &[[Batch; 3]; 4]) {
        if slots.len() < c.len {
            return;
        }
        for j in 0..c.lanes {
            for (ids, vk) in c.ids.iter().zip(v) {
                let (Some(&i), value) = (ids.get(j), Batch::lane(vk, j)) else {
                    continue;
                };
                if let Some(slot) = slots.get_mut(usize::from(i)) {
                    let field = R::get_mut(slot);
                    *field = add(*field, value);
                }
            }
        }
    }

    whole_block_chunks!();

    #[inline(never)]
    fn call<T>(self, f: impl FnOnce() -> T) -> T {
        f()
    }
}

/// An instruction set the step can run with. Every one gives the same bits;
/// they differ in speed only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum InstructionSet {
    /// The target's baseline: on x86_64, SSE2 (every x86_64 CPU has it);
    /// elsewhere what the target enables (with `simd128` on wasm32, NEON on
    /// AArch64), through the compiler's vectoriser.
    Baseline,
    /// AVX2, on x86_64 CPUs that have it: the same bits as SSE2 in less time
    /// per step (`cargo run --release -p corofem --features std --example
    /// cube_timing` times both on the 10k-tet cube).
    Avx2,
}

impl InstructionSet {
    /// Every instruction set, in order of preference (fastest last).
    pub const ALL: &'static [InstructionSet] = &[InstructionSet::Baseline, InstructionSet::Avx2];

    /// The name used by the command-line program and the reports:
    /// `"baseline"` or `"avx2"`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            InstructionSet::Baseline => "baseline",
            InstructionSet::Avx2 => "avx2",
        }
    }

    /// The instruction set with this name, if any.
    #[must_use]
    pub fn from_name(name: &str) -> Option<InstructionSet> {
        Self::ALL.iter().copied().find(|i| i.name() == name)
    }

    /// Whether this CPU can run it: always for [`InstructionSet::Baseline`];
    /// for AVX2, when the build targets it (`-C target-feature=+avx2` or a
    /// `target-cpu` that has it) or, with the `std` feature, when the CPU
    /// reports it (detected once per process). Without `std` and without
    /// `+avx2` at build time, AVX2 is never used: a `no_std` build cannot
    /// ask the CPU.
    #[must_use]
    pub fn is_supported(self) -> bool {
        match self {
            InstructionSet::Baseline => true,
            InstructionSet::Avx2 => avx2_supported(),
        }
    }

    /// The fastest supported instruction set: what [`Scene::step`](crate::Scene::step)
    /// uses unless told otherwise ([`Scene::set_instruction_set`](crate::Scene::set_instruction_set)).
    #[must_use]
    pub fn best() -> InstructionSet {
        if avx2_supported() {
            InstructionSet::Avx2
        } else {
            InstructionSet::Baseline
        }
    }
}

/// Whether AVX2 can be used: known at build time, or detected once (`std`).
#[inline]
fn avx2_supported() -> bool {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        true
    }
    // (The unit tests detect it too, so that they compare every backend.)
    #[cfg(all(
        target_arch = "x86_64",
        not(target_feature = "avx2"),
        any(feature = "std", test)
    ))]
    {
        use core::sync::atomic::{AtomicU8, Ordering};
        // 0: not asked yet, 1: no, 2: yes. Relaxed: any thread that asks
        // again gets the same answer from the CPU.
        static DETECTED: AtomicU8 = AtomicU8::new(0);
        match DETECTED.load(Ordering::Relaxed) {
            0 => {
                let yes = std::is_x86_feature_detected!("avx2");
                DETECTED.store(1 + u8::from(yes), Ordering::Relaxed);
                yes
            }
            v => v == 2,
        }
    }
    #[cfg(not(all(
        target_arch = "x86_64",
        any(target_feature = "avx2", feature = "std", test)
    )))]
    {
        false
    }
}

/// The backend of the target's baseline instruction set: the one every
/// CPU of the target has, used where no choice is made (the static solver,
/// the diagnostics).
#[cfg(target_arch = "x86_64")]
pub(crate) const BASELINE: Sse2 = Sse2;
/// The backend of the target's baseline instruction set: the one every
/// CPU of the target has, used where no choice is made (the static solver,
/// the diagnostics).
#[cfg(not(target_arch = "x86_64"))]
pub(crate) const BASELINE: Portable = Portable;
