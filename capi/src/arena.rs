//! A scene inside memory the caller provides.
//!
//! ```text
//!  caller's buffer (any address, `corofem_scene_bytes` long)
//!  ┌─────┬──────────────┬──────────────┬──────────────────┬──────────────────┬────────────────┐
//!  │ pad │ SceneHandle  │ Node × N     │ NodeWork × N     │ ElementBlock × B │ NodeEntry ×    │
//!  │     │              │              │                  │                  │ (G + L)        │
//!  │ 0–7 │ magic, range,│ state, mass, │ CG scratch       │ rest frame,      │ grab offsets,  │
//!  │     │ Scene<Slice… │ flags        │                  │ E/(36V₀), world  │ then loads     │
//!  │     │              │              │                  │ gradients        │ (G + L slots)  │
//!  └─────┴──────────────┴──────────────┴──────────────────┴──────────────────┴────────────────┘
//!        ▲ the handle: aligned to 8; the arrays follow at their own alignment
//! ```
//!
//! `B = element_blocks(T)`: elements are stored in blocks of
//! `ELEMENTS_PER_BLOCK` (8 on targets with vector registers, 1 on a Cortex-M4F).
//! With the feature `two-level`, the preconditioners' slots follow: a
//! `NodeBlock` per node, `A = aggregates_for(N, MAX_AGGREGATES)` aggregates
//! and `coarse_blocks_for(A)` slots of their coarse solve.
//!
//! The handle holds a `Scene<SliceStorage<'static>>` whose slices point into
//! the same buffer, so the buffer must stay where it is, untouched by the
//! caller, until `corofem_scene_deinit` or until it is no longer used. The
//! handle records its own address: a buffer copied or moved elsewhere is
//! refused as an invalid handle rather than followed to stale memory.
//!
//! All the raw-pointer work on the scene buffer is in this file.

use core::alloc::Layout;
use core::mem::{align_of, size_of};

use corofem_core::{
    element_blocks, ElementBlock, Node, NodeEntry, NodeWork, Scene, SliceStorage, StepStats,
};
#[cfg(feature = "two-level")]
use corofem_core::{Aggregate, CoarseBlock, NodeBlock};

use crate::status::Status;

/// "COFE" — a live scene.
const MAGIC: u32 = 0xC0FE_0001;
/// Largest node count the core addresses (`u16` indices).
pub const COROFEM_MAX_NODES: usize = 1 << 16;

/// The scene handle: the front of the caller's buffer. Opaque to C.
pub struct SceneHandle {
    /// [`MAGIC`] while the scene is live, 0 after de-initialisation.
    magic: u32,
    /// The address of this handle when it was made.
    this: usize,
    /// The caller's whole buffer `[start, end)`: arrays passed in or out
    /// must not overlap it.
    buffer: (usize, usize),
    /// The element capacity the caller asked for. The storage holds whole
    /// element blocks, which can be a few elements more; builds are held to
    /// this number so that a scene behaves the same on every target.
    pub(crate) max_tets: usize,
    /// Whether a build has succeeded.
    pub(crate) built: bool,
    /// Steps taken since the build.
    pub(crate) steps: u64,
    /// Statistics of the last step.
    pub(crate) last: StepStats,
    /// The id of the mesh of the last build (`surface::mesh_id`): the
    /// surfaces bound to it are the ones this scene moves.
    #[cfg(feature = "surface")]
    pub(crate) mesh: u64,
    /// The scene; its storage is the rest of the buffer.
    pub(crate) scene: Scene<SliceStorage<'static>>,
}

/// Where each part goes, relative to the aligned start.
struct Plan {
    nodes: usize,
    work: usize,
    elems: usize,
    /// Grab slots, then load slots.
    entries: usize,
    /// Element blocks for the element capacity.
    blocks: usize,
    /// The preconditioners' slots (feature `two-level`): node blocks (one
    /// per node), aggregates, the coarse factor, and how many aggregates.
    #[cfg(feature = "two-level")]
    precond: (usize, usize, usize, usize),
    size: usize,
    align: usize,
}

/// Grab and load slots of a scene: how many nodes the tool can hold and how
/// many can carry a constant force at once (16 bytes each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slots {
    /// Grab slots.
    pub grabs: usize,
    /// Load slots.
    pub loads: usize,
}

impl Slots {
    /// A slot of each kind for every node: what `corofem_scene_bytes` and
    /// `corofem_scene_init` reserve.
    #[must_use]
    pub fn every_node(max_nodes: usize) -> Self {
        Self {
            grabs: max_nodes,
            loads: max_nodes,
        }
    }
}

fn plan(max_nodes: usize, max_tets: usize, slots: Slots) -> Option<Plan> {
    let head = Layout::new::<SceneHandle>();
    let (l, nodes) = head.extend(Layout::array::<Node>(max_nodes).ok()?).ok()?;
    let (l, work) = l.extend(Layout::array::<NodeWork>(max_nodes).ok()?).ok()?;
    let blocks = element_blocks(max_tets);
    let (l, elems) = l.extend(Layout::array::<ElementBlock>(blocks).ok()?).ok()?;
    let (l, entries) = l
        .extend(Layout::array::<NodeEntry>(slots.grabs.checked_add(slots.loads)?).ok()?)
        .ok()?;
    // As `VecStorage` sizes them: the aggregates a body of `max_nodes` free
    // nodes would use, and their coarse factor.
    #[cfg(feature = "two-level")]
    let (l, precond) = {
        let aggs = corofem_core::aggregates_for(max_nodes, corofem_core::MAX_AGGREGATES);
        let coarse = corofem_core::coarse_blocks_for(aggs);
        let (l, b) = l.extend(Layout::array::<NodeBlock>(max_nodes).ok()?).ok()?;
        let (l, a) = l.extend(Layout::array::<Aggregate>(aggs).ok()?).ok()?;
        let (l, c) = l.extend(Layout::array::<CoarseBlock>(coarse).ok()?).ok()?;
        (l, (b, a, c, aggs))
    };
    Some(Plan {
        nodes,
        work,
        elems,
        entries,
        blocks,
        #[cfg(feature = "two-level")]
        precond,
        size: l.size(),
        align: l.align(),
    })
}

/// Bytes a buffer at any address needs for a scene of `max_nodes` nodes,
/// `max_tets` tetrahedra and `slots`: the parts, plus `align − 1` bytes so
/// that an unaligned buffer still fits. More slots of a kind than nodes is
/// an invalid argument.
pub fn scene_bytes(max_nodes: usize, max_tets: usize, slots: Slots) -> Result<usize, Status> {
    if max_nodes == 0 || max_tets == 0 || slots.grabs > max_nodes || slots.loads > max_nodes {
        return Err(Status::InvalidArgument);
    }
    if max_nodes > COROFEM_MAX_NODES {
        return Err(Status::Capacity);
    }
    let p = plan(max_nodes, max_tets, slots).ok_or(Status::Capacity)?;
    p.size.checked_add(p.align - 1).ok_or(Status::Capacity)
}

/// Initialises a scene in `buffer` and returns its handle.
///
/// # Safety
///
/// `buffer` is null or valid for writes of `bytes` bytes, and nothing else
/// uses that memory while the scene lives.
pub unsafe fn init(
    buffer: *mut u8,
    bytes: usize,
    max_nodes: usize,
    max_tets: usize,
    slots: Slots,
) -> Result<*mut SceneHandle, Status> {
    if buffer.is_null() {
        return Err(Status::NullPointer);
    }
    let need = scene_bytes(max_nodes, max_tets, slots)?;
    let p = plan(max_nodes, max_tets, slots).ok_or(Status::Capacity)?;
    let start = buffer as usize;
    let end = start.checked_add(bytes).ok_or(Status::InvalidArgument)?;
    let pad = start.wrapping_neg() & (p.align - 1);
    // `need` counts the worst-case padding, so the same size works at every
    // address (an aligned buffer that is a few bytes short is still refused,
    // so that a size that works once works everywhere).
    if bytes < need {
        return Err(Status::BufferTooSmall);
    }
    // pad ≤ align − 1, so pad + size ≤ need ≤ bytes.
    // SAFETY: `pad + p.size <= need <= bytes`, so every pointer below stays inside
    // the caller's buffer; each is aligned for its type because `plan` laid
    // the parts out from an address aligned to `p.align` (the largest
    // alignment of all parts).
    unsafe {
        let base = buffer.add(pad);
        let nodes = base.add(p.nodes).cast::<Node>();
        let work = base.add(p.work).cast::<NodeWork>();
        let elems = base.add(p.elems).cast::<ElementBlock>();
        let grabs = base.add(p.entries).cast::<NodeEntry>();
        let loads = grabs.add(slots.grabs);
        for i in 0..max_nodes {
            nodes.add(i).write(Node::EMPTY);
            work.add(i).write(NodeWork::EMPTY);
        }
        for i in 0..slots.grabs + slots.loads {
            grabs.add(i).write(NodeEntry::EMPTY);
        }
        for i in 0..p.blocks {
            elems.add(i).write(ElementBlock::EMPTY);
        }
        // The slices are initialised and disjoint from each other and from
        // the handle. `'static` stands for "until the caller frees the
        // buffer", the contract of every C function taking the handle.
        let storage = SliceStorage::new(
            core::slice::from_raw_parts_mut(nodes, max_nodes),
            core::slice::from_raw_parts_mut(work, max_nodes),
            core::slice::from_raw_parts_mut(elems, p.blocks),
        )
        .with_grabs(core::slice::from_raw_parts_mut(grabs, slots.grabs))
        .with_loads(core::slice::from_raw_parts_mut(loads, slots.loads));
        #[cfg(feature = "two-level")]
        let storage = {
            let (b, a, c, aggs) = p.precond;
            let coarse = corofem_core::coarse_blocks_for(aggs);
            let blocks = base.add(b).cast::<NodeBlock>();
            let agg = base.add(a).cast::<Aggregate>();
            let fac = base.add(c).cast::<CoarseBlock>();
            for i in 0..max_nodes {
                blocks.add(i).write(NodeBlock::EMPTY);
            }
            for i in 0..aggs {
                agg.add(i).write(Aggregate::EMPTY);
            }
            for i in 0..coarse {
                fac.add(i).write(CoarseBlock::EMPTY);
            }
            storage.with_preconditioner(
                core::slice::from_raw_parts_mut(blocks, max_nodes),
                core::slice::from_raw_parts_mut(agg, aggs),
                core::slice::from_raw_parts_mut(fac, coarse),
            )
        };
        let handle = base.cast::<SceneHandle>();
        handle.write(SceneHandle {
            magic: MAGIC,
            this: handle as usize,
            buffer: (start, end),
            max_tets,
            built: false,
            steps: 0,
            last: StepStats::default(),
            #[cfg(feature = "surface")]
            mesh: 0,
            scene: Scene::with_storage(storage),
        });
        Ok(handle)
    }
}

/// The live scene behind a handle.
///
/// # Safety
///
/// `h` is null or points to at least `size_of::<SceneHandle>()` readable
/// bytes (a handle from [`init`] whose buffer is still allocated, or any
/// other readable memory, which is then refused), and no other call uses
/// the same scene at the same time.
pub unsafe fn scene<'a>(h: *mut SceneHandle) -> Result<&'a mut SceneHandle, Status> {
    // SAFETY: the caller's contract.
    unsafe { check_stamp(h.cast_const(), MAGIC)? };
    // SAFETY: a live handle written by `init` at this very address; the
    // caller guarantees exclusive use for the duration of the call.
    Ok(unsafe { &mut *h })
}

/// A handle that stamps itself: a magic number and the address it was made
/// at, read before anything else of it is trusted, so that a pointer to
/// anything else, or to a copy of a handle, is refused.
pub trait Stamped {
    /// The handle's magic number and address, read alone.
    ///
    /// # Safety
    ///
    /// `h` is aligned and points to `size_of::<Self>()` readable bytes.
    unsafe fn stamp(h: *const Self) -> (u32, usize);
}

/// Checks that `h` is a live handle stamped `magic`: not null
/// (`NullPointer`), aligned and stamped at its own address
/// (`InvalidHandle` otherwise).
///
/// # Safety
///
/// `h` is null or points to at least `size_of::<T>()` readable bytes.
pub unsafe fn check_stamp<T: Stamped>(h: *const T, magic: u32) -> Result<(), Status> {
    if h.is_null() {
        return Err(Status::NullPointer);
    }
    if h as usize % align_of::<T>() != 0 {
        return Err(Status::InvalidHandle);
    }
    // SAFETY: aligned, and readable by the caller's contract.
    let (m, this) = unsafe { T::stamp(h) };
    if m != magic || this != h as usize {
        return Err(Status::InvalidHandle);
    }
    Ok(())
}

/// [`Stamped`] for a handle type with the fields `magic: u32` and
/// `this: usize`.
macro_rules! stamped {
    ($handle:ty) => {
        impl $crate::arena::Stamped for $handle {
            unsafe fn stamp(h: *const Self) -> (u32, usize) {
                // SAFETY: the caller's contract; only the two plain integer
                // fields are read.
                unsafe {
                    (
                        core::ptr::addr_of!((*h).magic).read(),
                        core::ptr::addr_of!((*h).this).read(),
                    )
                }
            }
        }
    };
}
#[cfg_attr(
    not(any(feature = "probe", feature = "surface")),
    allow(unused_imports)
)]
pub(crate) use stamped;

stamped!(SceneHandle);

impl SceneHandle {
    /// Marks the scene dead: every later call with this handle is refused.
    pub fn kill(&mut self) {
        self.magic = 0;
        self.this = 0;
    }

    /// Whether `len` elements of `T` at `addr` overlap the scene buffer.
    pub fn overlaps<T>(&self, addr: usize, len: usize) -> bool {
        let bytes = len.saturating_mul(size_of::<T>());
        let (start, end) = self.buffer;
        bytes > 0 && addr < end && addr.saturating_add(bytes) > start
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_add_up() {
        let b = scene_bytes(4, 1, Slots::every_node(4)).unwrap();
        #[allow(unused_mut)] // only the preconditioners' slots add to it
        let mut parts = size_of::<SceneHandle>()
            + 4 * (size_of::<Node>() + size_of::<NodeWork>() + 2 * size_of::<NodeEntry>())
            + size_of::<ElementBlock>();
        #[cfg(feature = "two-level")]
        {
            // One aggregate for four nodes, the slots of its coarse solve.
            parts += 4 * size_of::<NodeBlock>()
                + size_of::<Aggregate>()
                + corofem_core::coarse_blocks_for(1) * size_of::<CoarseBlock>();
        }
        assert!(b >= parts && b < parts + 16, "{b} vs {parts}");
        let n = COROFEM_MAX_NODES + 1;
        assert_eq!(
            scene_bytes(n, 1, Slots::every_node(n)),
            Err(Status::Capacity)
        );
        assert_eq!(
            scene_bytes(0, 1, Slots::every_node(0)),
            Err(Status::InvalidArgument)
        );
        let one = Slots::every_node(1);
        assert_eq!(scene_bytes(1, usize::MAX / 2, one), Err(Status::Capacity));
        let none = Slots { grabs: 0, loads: 0 };
        assert_eq!(
            b - scene_bytes(4, 1, none).unwrap(),
            8 * size_of::<NodeEntry>()
        );
        let more = Slots { grabs: 5, loads: 0 };
        assert_eq!(scene_bytes(4, 1, more), Err(Status::InvalidArgument));
    }
}
