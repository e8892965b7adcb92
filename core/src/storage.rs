//! Where a scene's data lives. The type that owns storage knows the capacity
//! (`ArrayStorage<N, B, G, L>`, usable in a `static`; `VecStorage`, sized at
//! run time); everything else works on slices, so the solver is not compiled
//! once per capacity. Elements are stored in [`ElementBlock`]s of
//! [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK) elements each;
//! [`element_blocks`](crate::element_blocks) gives how many a mesh needs.
//!
//! [`Storage`] is sealed: the scene relies on what its implementations
//! lend (node and work slices of one length), and the slot types
//! ([`Node`], [`NodeWork`], [`ElementBlock`], [`NodeEntry`]) are opaque. A
//! caller names them only to provide memory ([`SliceStorage`]).

use crate::element::ElementBlock;
use crate::math::Vec3;

/// Node flag: the node does not move (its velocity change is filtered out).
pub(crate) const FIXED: u8 = 1;
/// Node flag: the node is held by the haptic tool's spring (it has an entry,
/// its grab offset, in the storage's grab list).
#[cfg(feature = "tool")]
pub(crate) const GRABBED: u8 = 2;
/// Node flag: a constant external force acts on the node (it has an entry
/// in the storage's load list).
#[cfg(feature = "loads")]
pub(crate) const LOADED: u8 = 16;
/// Node flag: the ground held this node last step but would have had to pull
/// it; it is left free for the next step.
#[cfg(feature = "ground")]
pub(crate) const RELEASED: u8 = 4;
/// Node flag: the ground holds this node during the current step.
#[cfg(feature = "ground")]
pub(crate) const CONTACT: u8 = 8;
/// Node flag set only inside `Scene::grab`, to count the distinct nodes asked
/// for before anything changes.
#[cfg(feature = "tool")]
pub(crate) const LISTED: u8 = 32;
/// Node flag: the node is on the mesh's boundary (in a face that only one
/// tetrahedron has), set at `build`: only these touch a probe.
#[cfg(feature = "probe")]
pub(crate) const BOUNDARY: u8 = 64;
/// Node flag: the node sticks to what holds it (`CONTACT`): its velocity
/// along the contact plane is prescribed too (Coulomb friction).
#[cfg(feature = "friction")]
pub(crate) const STUCK: u8 = 128;
/// `Node::contact` of a node the ground holds; a probe's is its index + 1.
#[cfg(feature = "ground")]
pub(crate) const ON_GROUND: u16 = 0;

/// Most nodes a scene holds: what the elements' `u16` node indices address.
pub(crate) const MAX_NODES: usize = 1 << 16;

/// A node slot (41 bytes of data, 44 with padding): opaque, named only to
/// provide memory (`[Node::EMPTY; N]` for a [`SliceStorage`]). What only
/// some nodes carry (a grab offset, a constant load) lives in [`NodeEntry`]
/// lists sized per scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// Rest position (m).
    pub(crate) x0: Vec3,
    /// Displacement from rest (m); the position is `x0 + u`. Keeping the
    /// displacement rather than the position keeps forces accurate in f32
    /// wherever the body sits.
    pub(crate) u: Vec3,
    /// Velocity (m/s).
    pub(crate) v: Vec3,
    /// Lumped mass (kg): a quarter of `ρ V₀` of every element around the node.
    pub(crate) mass: f32,
    /// `FIXED | GRABBED | RELEASED | CONTACT | LOADED | BOUNDARY`.
    pub(crate) flags: u8,
    /// What holds the node while it has `CONTACT`: [`ON_GROUND`], or a
    /// probe's index + 1. (In the slot's padding: no byte more.)
    #[cfg(feature = "ground")]
    pub(crate) contact: u16,
}

impl Node {
    /// An unused slot.
    pub const EMPTY: Self = Self {
        x0: [0.0; 3],
        u: [0.0; 3],
        v: [0.0; 3],
        mass: 0.0,
        flags: 0,
        #[cfg(feature = "ground")]
        contact: 0,
    };

    /// Current position `x0 + u` (m).
    #[inline(always)]
    #[must_use]
    pub(crate) fn position(&self) -> Vec3 {
        crate::math::add(self.x0, self.u)
    }
}

impl Default for Node {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// A node's slot of linear-solver scratch (52 bytes): opaque, named only to
/// provide memory. Only the last velocity change (the warm start) carries
/// from one step to the next.
// `repr(C)`: `q` right after `d`, as the assembly product (`fpu_product`)
// reads them.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct NodeWork {
    /// Solution `Δv` (m/s).
    pub(crate) x: Vec3,
    /// Residual `b − A x`, kept unfiltered so that its constrained components
    /// give the constraint forces.
    pub(crate) r: Vec3,
    /// Search direction.
    pub(crate) d: Vec3,
    /// `A d`, then the preconditioned residual.
    pub(crate) q: Vec3,
    /// Inverse of the preconditioner's diagonal (0 on fixed nodes).
    pub(crate) inv_p: f32,
    /// The step's velocity change, kept while the solve of a push out of
    /// the ground runs in `x` (`contact::relax`).
    #[cfg(feature = "ground")]
    pub(crate) dv: Vec3,
    /// The step's contact impulse along the ground's normal, `n·r`
    /// (positive: the plane would pull), kept for the same reason.
    #[cfg(feature = "ground")]
    pub(crate) pull: f32,
    /// The step's residual `r` at a held node, whose tangential part is a
    /// sticking node's friction impulse (`−r`), kept for the same reason;
    /// then the kinetic friction force planned for the next step.
    #[cfg(feature = "friction")]
    pub(crate) reaction: Vec3,
    /// The kinetic friction force (N) on a node that slides on what holds
    /// it, planned by the last step for this one (zero for the others):
    /// like the warm start, it carries from one step to the next.
    #[cfg(feature = "friction")]
    pub(crate) drag: Vec3,
}

impl NodeWork {
    /// The node's state at the step's end, displacement and velocity, from
    /// the step's candidates to its commit. It is kept in the CG's direction
    /// slots `d` and `q`, which the solves have spent by then: the step's
    /// end costs no memory of its own.
    #[inline(always)]
    pub(crate) fn end(&self) -> (Vec3, Vec3) {
        (self.d, self.q)
    }

    /// Sets the node's state at the step's end ([`NodeWork::end`]).
    #[inline(always)]
    pub(crate) fn set_end(&mut self, u: Vec3, v: Vec3) {
        self.d = u;
        self.q = v;
    }

    /// An unused slot.
    pub const EMPTY: Self = Self {
        x: [0.0; 3],
        r: [0.0; 3],
        d: [0.0; 3],
        q: [0.0; 3],
        inv_p: 0.0,
        #[cfg(feature = "ground")]
        dv: [0.0; 3],
        #[cfg(feature = "ground")]
        pull: 0.0,
        #[cfg(feature = "friction")]
        reaction: [0.0; 3],
        #[cfg(feature = "friction")]
        drag: [0.0; 3],
    };
}

impl Default for NodeWork {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// A slot for a vector that only some nodes carry (16 bytes; opaque, named
/// only to provide memory): the tool's grab offset
/// (m, from the grabbed nodes' centroid) or a constant external force (N).
/// A scene keeps each kind in its own list, in node order, one entry per node
/// whose flag says it has one; the lists' lengths are capacities chosen per
/// scene (`G` and `L` of [`ArrayStorage`]), so a node costs nothing for what
/// it does not carry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeEntry {
    /// The node it belongs to.
    pub(crate) node: u32,
    /// The grab offset (m) or the force (N).
    pub(crate) value: Vec3,
}

impl NodeEntry {
    /// An unused slot.
    pub const EMPTY: Self = Self {
        node: 0,
        value: [0.0; 3],
    };
}

impl Default for NodeEntry {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Reads a [`NodeEntry`] list alongside a walk over the nodes in order:
/// [`Entries::next`] at each node that has the list's flag gives that node's
/// value (zero past the end, which the lists' invariant rules out).
#[cfg(any(feature = "tool", feature = "loads"))]
pub(crate) struct Entries<'a>(core::slice::Iter<'a, NodeEntry>);

#[cfg(any(feature = "tool", feature = "loads"))]
impl<'a> Entries<'a> {
    /// A walk over `list` from its first entry.
    #[inline(always)]
    pub(crate) fn new(list: &'a [NodeEntry]) -> Self {
        Self(list.iter())
    }

    /// The value of the next flagged node.
    #[inline(always)]
    pub(crate) fn next(&mut self) -> Vec3 {
        self.0.next().map_or([0.0; 3], |e| e.value)
    }

    /// At a node with `flags`: its value if it has `flag`, else zero (which
    /// callers still add, so that a node without a load gets the bits it got
    /// when every node stored a force).
    #[cfg(feature = "loads")]
    #[inline(always)]
    pub(crate) fn at(&mut self, flags: u8, flag: u8) -> Vec3 {
        if flags & flag != 0 {
            self.next()
        } else {
            [0.0; 3]
        }
    }
}

/// The sealed part of [`Storage`]: what the scene borrows from a storage.
/// Public in a private module, so that no other crate can name it, call it
/// or implement it.
pub(crate) mod sealed {
    use super::{ElementBlock, Node, NodeEntry, NodeWork};

    /// Every slot of a storage, mutable: what [`Sealed::parts_mut`] lends.
    #[derive(Debug)]
    pub struct PartsMut<'a> {
        /// Node slots.
        pub(crate) nodes: &'a mut [Node],
        /// Solver scratch, one per node slot (the same length as `nodes`).
        pub(crate) work: &'a mut [NodeWork],
        /// Element blocks.
        pub(crate) elems: &'a mut [ElementBlock],
        /// Slots for the nodes the tool holds (feature `tool`; may be empty:
        /// then nothing can be grabbed).
        // Every storage has the slots; only the tool reads them.
        #[cfg_attr(not(feature = "tool"), allow(dead_code))]
        pub(crate) grabs: &'a mut [NodeEntry],
        /// Slots for constant external forces (feature `loads`; may be
        /// empty: then no force can be set).
        // Every storage has the slots; only the loads read them.
        #[cfg_attr(not(feature = "loads"), allow(dead_code))]
        pub(crate) loads: &'a mut [NodeEntry],
        /// Node-block preconditioner slots (none, or one per node).
        #[cfg(feature = "two-level")]
        pub(crate) blocks: &'a mut [crate::slots::NodeBlock],
        /// Aggregate slots of the two-level preconditioner.
        #[cfg(feature = "two-level")]
        pub(crate) aggs: &'a mut [crate::slots::Aggregate],
        /// Coarse factor slots (the square of the aggregate slots).
        #[cfg(feature = "two-level")]
        pub(crate) coarse: &'a mut [crate::slots::CoarseBlock],
    }

    /// Access to a storage's slots.
    pub trait Sealed {
        /// Node-block, aggregate and coarse-block slots.
        #[cfg(feature = "two-level")]
        fn preconditioner_capacity(&self) -> (usize, usize, usize);
        /// Node and element-block slots.
        fn parts(&self) -> (&[Node], &[ElementBlock]);
        /// All slots, mutable.
        fn parts_mut(&mut self) -> PartsMut<'_>;
    }
}

pub(crate) use sealed::PartsMut;

/// Storage for a scene: the node, solver-scratch, element-block, grab and
/// load slots. The capacity is the number of slots (times
/// [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK) for elements).
///
/// Sealed: implemented by [`ArrayStorage`] (fixed capacity, `const`),
/// [`SliceStorage`] (caller-owned slices), `VecStorage` (feature `alloc`)
/// and `&mut` of any storage.
pub trait Storage: sealed::Sealed {}

impl<S: sealed::Sealed + ?Sized> Storage for S {}

/// Borrowed storage: lets the storage live apart from the scene, e.g. an
/// `ArrayStorage` in a zero-initialised `static` (`.bss`) while the scene
/// header stays on the stack.
impl<S: sealed::Sealed + ?Sized> sealed::Sealed for &mut S {
    #[cfg(feature = "two-level")]
    fn preconditioner_capacity(&self) -> (usize, usize, usize) {
        (**self).preconditioner_capacity()
    }
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (**self).parts()
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        (**self).parts_mut()
    }
}

/// Fixed-capacity storage in plain arrays: up to `N` nodes and `B` element
/// blocks, that is `B × ELEMENTS_PER_BLOCK` tetrahedra (size `B` with
/// [`element_blocks`](crate::element_blocks)); up to `G` nodes held by the
/// tool (feature `tool`) and `L` nodes with a constant external force
/// (feature `loads`), 16 bytes each; with the feature `two-level`, `P` node
/// slots of preconditioner data (32 bytes each: `N` of them, or 0 for the
/// mass preconditioner only), up to `A` aggregates for the two-level
/// preconditioner's coarse space (176 bytes each) and `C` slots of its
/// coarse solve (32 bytes each: `n` aggregates use
/// [`coarse_blocks_for`](crate::coarse_blocks_for)`(n)`, about `4.5 n²`;
/// 0 for block-Jacobi at most). With constants `A` and `C`, write
/// `ArrayStorage<N, B, G, L, N, A, { corofem::coarse_blocks_for(A) }>`.
/// `const fn new` lets a whole scene live in a `static`.
#[derive(Clone, Debug)]
pub struct ArrayStorage<
    const N: usize,
    const B: usize,
    const G: usize = 0,
    const L: usize = 0,
    const P: usize = 0,
    const A: usize = 0,
    const C: usize = 0,
> {
    nodes: [Node; N],
    work: [NodeWork; N],
    elems: [ElementBlock; B],
    grabs: [NodeEntry; G],
    loads: [NodeEntry; L],
    #[cfg(feature = "two-level")]
    blocks: [crate::slots::NodeBlock; P],
    #[cfg(feature = "two-level")]
    aggs: [crate::slots::Aggregate; A],
    #[cfg(feature = "two-level")]
    coarse: [crate::slots::CoarseBlock; C],
}

impl<
        const N: usize,
        const B: usize,
        const G: usize,
        const L: usize,
        const P: usize,
        const A: usize,
        const C: usize,
    > ArrayStorage<N, B, G, L, P, A, C>
{
    /// Empty storage.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            nodes: [Node::EMPTY; N],
            work: [NodeWork::EMPTY; N],
            elems: [ElementBlock::EMPTY; B],
            grabs: [NodeEntry::EMPTY; G],
            loads: [NodeEntry::EMPTY; L],
            #[cfg(feature = "two-level")]
            blocks: [crate::slots::NodeBlock::EMPTY; P],
            #[cfg(feature = "two-level")]
            aggs: [crate::slots::Aggregate::EMPTY; A],
            #[cfg(feature = "two-level")]
            coarse: [crate::slots::CoarseBlock::EMPTY; C],
        }
    }
}

impl<
        const N: usize,
        const B: usize,
        const G: usize,
        const L: usize,
        const P: usize,
        const A: usize,
        const C: usize,
    > Default for ArrayStorage<N, B, G, L, P, A, C>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<
        const N: usize,
        const B: usize,
        const G: usize,
        const L: usize,
        const P: usize,
        const A: usize,
        const C: usize,
    > sealed::Sealed for ArrayStorage<N, B, G, L, P, A, C>
{
    #[cfg(feature = "two-level")]
    fn preconditioner_capacity(&self) -> (usize, usize, usize) {
        (P, A, C)
    }
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (&self.nodes, &self.elems)
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        PartsMut {
            nodes: &mut self.nodes,
            work: &mut self.work,
            elems: &mut self.elems,
            grabs: &mut self.grabs,
            loads: &mut self.loads,
            #[cfg(feature = "two-level")]
            blocks: &mut self.blocks,
            #[cfg(feature = "two-level")]
            aggs: &mut self.aggs,
            #[cfg(feature = "two-level")]
            coarse: &mut self.coarse,
        }
    }
}

/// Storage in slices the caller owns (an arena, or vectors on a host).
/// The node and work slices must have the same length; the shorter one sets
/// the node capacity. No grab or load slots unless given with
/// [`SliceStorage::with_grabs`] and [`SliceStorage::with_loads`].
#[derive(Debug)]
pub struct SliceStorage<'a> {
    nodes: &'a mut [Node],
    work: &'a mut [NodeWork],
    elems: &'a mut [ElementBlock],
    grabs: &'a mut [NodeEntry],
    loads: &'a mut [NodeEntry],
    #[cfg(feature = "two-level")]
    blocks: &'a mut [crate::slots::NodeBlock],
    #[cfg(feature = "two-level")]
    aggs: &'a mut [crate::slots::Aggregate],
    #[cfg(feature = "two-level")]
    coarse: &'a mut [crate::slots::CoarseBlock],
}

impl<'a> SliceStorage<'a> {
    /// Wraps caller-owned slots (`elems`: [`element_blocks`](crate::element_blocks)
    /// of the element count).
    pub fn new(
        nodes: &'a mut [Node],
        work: &'a mut [NodeWork],
        elems: &'a mut [ElementBlock],
    ) -> Self {
        let n = nodes.len().min(work.len());
        let (nodes, _) = nodes.split_at_mut(n);
        let (work, _) = work.split_at_mut(n);
        Self {
            nodes,
            work,
            elems,
            grabs: &mut [],
            loads: &mut [],
            #[cfg(feature = "two-level")]
            blocks: &mut [],
            #[cfg(feature = "two-level")]
            aggs: &mut [],
            #[cfg(feature = "two-level")]
            coarse: &mut [],
        }
    }

    /// With `blocks` (one per node) as the node-block preconditioner's
    /// slots, and `aggs` and `coarse` (at least
    /// [`coarse_blocks_for`](crate::coarse_blocks_for)`(aggs.len())` of
    /// them) for up to
    /// `aggs.len()` aggregates of the two-level preconditioner's coarse
    /// space (feature `two-level`).
    #[cfg(feature = "two-level")]
    #[must_use]
    pub fn with_preconditioner(
        self,
        blocks: &'a mut [crate::slots::NodeBlock],
        aggs: &'a mut [crate::slots::Aggregate],
        coarse: &'a mut [crate::slots::CoarseBlock],
    ) -> Self {
        Self {
            blocks,
            aggs,
            coarse,
            ..self
        }
    }

    /// With `grabs` as the slots for the nodes the tool holds.
    #[must_use]
    pub fn with_grabs(self, grabs: &'a mut [NodeEntry]) -> Self {
        Self { grabs, ..self }
    }

    /// With `loads` as the slots for constant external forces.
    #[must_use]
    pub fn with_loads(self, loads: &'a mut [NodeEntry]) -> Self {
        Self { loads, ..self }
    }
}

impl sealed::Sealed for SliceStorage<'_> {
    #[cfg(feature = "two-level")]
    fn preconditioner_capacity(&self) -> (usize, usize, usize) {
        (self.blocks.len(), self.aggs.len(), self.coarse.len())
    }
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (self.nodes, self.elems)
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        PartsMut {
            nodes: self.nodes,
            work: self.work,
            elems: self.elems,
            grabs: self.grabs,
            loads: self.loads,
            #[cfg(feature = "two-level")]
            blocks: self.blocks,
            #[cfg(feature = "two-level")]
            aggs: self.aggs,
            #[cfg(feature = "two-level")]
            coarse: self.coarse,
        }
    }
}

/// Storage in `Vec`s, sized at run time (feature `alloc`): for host
/// programs whose meshes are known only when they run. Every node has a grab
/// and a load slot, so any node can be grabbed or loaded.
///
/// ```
/// # use corofem::{BoxMesh, BuildOptions, Material, VecScene};
/// // A 2×2×2-cell box (27 nodes, 48 tetrahedra), its size known at run time.
/// let mesh = BoxMesh { size: [0.1; 3], cells: [2; 3], tets_per_cell: 6 };
/// let mut nodes = vec![[0.0f32; 3]; mesh.node_count()];
/// let mut tets = vec![[0u32; 4]; mesh.tet_count()];
/// let (n, t) = mesh.generate(&mut nodes, &mut tets)?;
/// // Room for exactly those nodes and tetrahedra.
/// let mut scene = VecScene::with_capacity(n, t);
/// let material = Material { young: 1.0e5, poisson: 0.3, density: 1000.0 };
/// scene.build(&nodes[..n], &tets[..t], &material, BuildOptions::default())?;
/// scene.step()?;
/// assert_eq!(scene.node_count(), n);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[cfg(feature = "alloc")]
#[derive(Clone, Debug, Default)]
pub struct VecStorage {
    nodes: alloc::vec::Vec<Node>,
    work: alloc::vec::Vec<NodeWork>,
    elems: alloc::vec::Vec<ElementBlock>,
    grabs: alloc::vec::Vec<NodeEntry>,
    loads: alloc::vec::Vec<NodeEntry>,
    #[cfg(feature = "two-level")]
    blocks: alloc::vec::Vec<crate::slots::NodeBlock>,
    #[cfg(feature = "two-level")]
    aggs: alloc::vec::Vec<crate::slots::Aggregate>,
    #[cfg(feature = "two-level")]
    coarse: alloc::vec::Vec<crate::slots::CoarseBlock>,
}

#[cfg(feature = "alloc")]
impl VecStorage {
    /// Room for `nodes` nodes (at most the 65 536 a scene addresses), each
    /// with a grab and a load slot, and `elements` tetrahedra, every slot
    /// empty. Never panics: if the memory cannot be had (or its size
    /// overflows), that part of the storage stays empty and
    /// [`Scene::build`](crate::Scene::build) refuses a mesh that needs it
    /// ([`Error::TooManyNodes`](crate::Error::TooManyNodes),
    /// [`Error::TooManyElements`](crate::Error::TooManyElements)).
    #[must_use]
    pub fn with_capacity(nodes: usize, elements: usize) -> Self {
        let nodes = nodes.min(MAX_NODES);
        let blocks = crate::element_blocks(elements);
        let node_slots = (slots(nodes, Node::EMPTY), slots(nodes, NodeWork::EMPTY));
        // The node and work slots have one length: both, or neither.
        let (nodes, work) = match node_slots {
            (n, w) if n.len() == w.len() => (n, w),
            _ => (alloc::vec::Vec::new(), alloc::vec::Vec::new()),
        };
        let entries = nodes.len();
        #[cfg(feature = "two-level")]
        let aggs = crate::slots::aggregates_for(entries, crate::slots::MAX_AGGREGATES);
        Self {
            nodes,
            work,
            elems: slots(blocks, ElementBlock::EMPTY),
            grabs: slots(entries, NodeEntry::EMPTY),
            loads: slots(entries, NodeEntry::EMPTY),
            #[cfg(feature = "two-level")]
            blocks: slots(entries, crate::slots::NodeBlock::EMPTY),
            #[cfg(feature = "two-level")]
            aggs: slots(aggs, crate::slots::Aggregate::EMPTY),
            #[cfg(feature = "two-level")]
            coarse: slots(
                crate::slots::coarse_blocks_for(aggs),
                crate::slots::CoarseBlock::EMPTY,
            ),
        }
    }
}

/// `n` copies of `value`, or none if the memory cannot be had.
#[cfg(feature = "alloc")]
fn slots<T: Copy>(n: usize, value: T) -> alloc::vec::Vec<T> {
    let mut v = alloc::vec::Vec::new();
    if v.try_reserve_exact(n).is_ok() {
        v.resize(n, value);
    }
    v
}

#[cfg(feature = "alloc")]
impl sealed::Sealed for VecStorage {
    #[cfg(feature = "two-level")]
    fn preconditioner_capacity(&self) -> (usize, usize, usize) {
        (self.blocks.len(), self.aggs.len(), self.coarse.len())
    }
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (&self.nodes, &self.elems)
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        PartsMut {
            nodes: &mut self.nodes,
            work: &mut self.work,
            elems: &mut self.elems,
            grabs: &mut self.grabs,
            loads: &mut self.loads,
            #[cfg(feature = "two-level")]
            blocks: &mut self.blocks,
            #[cfg(feature = "two-level")]
            aggs: &mut self.aggs,
            #[cfg(feature = "two-level")]
            coarse: &mut self.coarse,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The storage the core keeps, per feature set (the numbers the docs and
    /// the benchmark report quote): an element is 72 bytes with `qr` (a block
    /// holds `ELEMENTS_PER_BLOCK` of them, without padding), plus the
    /// rest gradients (36) for `polar`/`linear` and the rotation (16) for
    /// `polar`; a node is 44 + 52 bytes, and its solver scratch 16 bytes more
    /// with `ground` and 24 more with `friction` (the tool's grab offsets and
    /// the loads are 16-byte entries in lists of their own).
    /// CI runs this with `qr` alone, with the firmware's set and with `full`.
    #[test]
    fn storage_sizes_per_feature() {
        let rest_grad = if cfg!(any(feature = "polar", feature = "linear")) {
            36
        } else {
            0
        };
        let rot = if cfg!(feature = "polar") { 16 } else { 0 };
        assert_eq!(
            core::mem::size_of::<ElementBlock>(),
            (72 + rest_grad + rot) * crate::ELEMENTS_PER_BLOCK
        );
        assert_eq!(core::mem::size_of::<Node>(), 44);
        let ground = if cfg!(feature = "ground") { 16 } else { 0 };
        let friction = if cfg!(feature = "friction") { 24 } else { 0 };
        assert_eq!(core::mem::size_of::<NodeWork>(), 52 + ground + friction);
        assert_eq!(core::mem::size_of::<NodeEntry>(), 16);
    }
}
