//! Where a scene's data lives. The type that owns storage knows the capacity
//! (`ArrayStorage<C>`, whose [`Capacity`] `C` [`capacity!`](crate::capacity)
//! declares, usable in a `static`; `VecStorage`, sized at run time);
//! everything else works on slices, so the solver is not compiled once per
//! capacity. Elements are stored in [`ElementBlock`]s of
//! [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK) elements each;
//! [`element_blocks`](crate::element_blocks) gives how many a mesh needs.
//!
//! [`Storage`] is sealed: the scene relies on what its implementations
//! lend (node and work slices of one length), and the slot types
//! ([`Node`], [`NodeWork`], [`ElementBlock`], [`NodeEntry`]) are opaque. A
//! caller names them only to provide memory ([`SliceStorage`]).

use crate::element::ElementBlock;
use crate::math::Vec3;
use crate::settings::Preconditioner;

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
/// scene ([`Slots::grabs`] and [`Slots::loads`]), so a node costs nothing for
/// what it does not carry.
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

    /// Every slot of a storage that says how much it holds: what
    /// [`Sealed::parts`] lends.
    #[derive(Debug)]
    pub struct Parts<'a> {
        /// Node slots.
        pub(crate) nodes: &'a [Node],
        /// Element blocks.
        pub(crate) elems: &'a [ElementBlock],
        /// Slots for the nodes the tool holds.
        pub(crate) grabs: &'a [NodeEntry],
        /// Slots for constant external forces.
        pub(crate) loads: &'a [NodeEntry],
        /// Node-block preconditioner slots (none, or one per node).
        #[cfg(feature = "two-level")]
        pub(crate) blocks: &'a [crate::slots::NodeBlock],
        /// Aggregate slots of the two-level preconditioner.
        #[cfg(feature = "two-level")]
        pub(crate) aggs: &'a [crate::slots::Aggregate],
        /// Coarse factor slots.
        #[cfg(feature = "two-level")]
        pub(crate) coarse: &'a [crate::slots::CoarseBlock],
    }

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
        /// All slots.
        fn parts(&self) -> Parts<'_>;
        /// All slots, mutable.
        fn parts_mut(&mut self) -> PartsMut<'_>;
    }

    /// A slot type: what an array of a [`Capacity`](super::Capacity) holds.
    pub trait Slot: Copy + core::fmt::Debug {
        /// An unused slot (all zero bits).
        const EMPTY: Self;
    }

    /// The sealed part of [`SlotArray`](super::SlotArray): arrays of slots.
    pub trait Array<T> {}

    impl<T: Slot, const N: usize> Array<T> for [T; N] {}
}

pub(crate) use sealed::{Parts, PartsMut};

/// Storage for a scene: the node, solver-scratch, element-block, grab and
/// load slots, and with the feature `two-level` the preconditioners'. The
/// capacity is the number of slots ([`Storage::capacity`]).
///
/// Sealed: implemented by [`ArrayStorage`] (fixed capacity, `const`),
/// [`SliceStorage`] (caller-owned slices), `VecStorage` (feature `alloc`)
/// and `&mut` of any storage.
pub trait Storage: sealed::Sealed {
    /// What the storage holds: its nodes (at most the 65 536 a scene
    /// addresses), tetrahedra (whole [`ElementBlock`]s), grab and load
    /// slots, and the richest preconditioner it has room for, with the
    /// two-level preconditioner's aggregates. `preconditioner` is what
    /// [`Scene::supports`](crate::Scene::supports) allows: `BlockJacobi`
    /// when there is a node-block slot per node slot, `TwoLevel` when there
    /// are also aggregates and the slots of their coarse solve; `Mass`
    /// without the feature `two-level`.
    fn capacity(&self) -> Slots {
        let p = self.parts();
        let (preconditioner, aggregates) = preconditioner_room(&p);
        Slots {
            nodes: p.nodes.len().min(MAX_NODES),
            elements: p.elems.len().saturating_mul(crate::lanes::LANES),
            grabs: p.grabs.len(),
            loads: p.loads.len(),
            preconditioner,
            aggregates,
        }
    }
}

impl<S: sealed::Sealed + ?Sized> Storage for S {}

/// The richest preconditioner `p` has the slots for, and the aggregates it
/// can use (0 unless that is `TwoLevel`).
#[inline(always)]
fn preconditioner_room(p: &Parts<'_>) -> (Preconditioner, usize) {
    #[cfg(feature = "two-level")]
    {
        let aggs = p.aggs.len();
        if p.blocks.len() < p.nodes.len() {
            (Preconditioner::Mass, 0)
        } else if aggs >= 1 && p.coarse.len() >= crate::slots::coarse_blocks_for(aggs) {
            (Preconditioner::TwoLevel, aggs)
        } else {
            (Preconditioner::BlockJacobi, 0)
        }
    }
    #[cfg(not(feature = "two-level"))]
    {
        let _ = p;
        (Preconditioner::Mass, 0)
    }
}

/// Borrowed storage: lets the storage live apart from the scene, e.g. an
/// `ArrayStorage` in a zero-initialised `static` (`.bss`) while the scene
/// header stays on the stack.
impl<S: sealed::Sealed + ?Sized> sealed::Sealed for &mut S {
    fn parts(&self) -> Parts<'_> {
        (**self).parts()
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        (**self).parts_mut()
    }
}

/// A storage's capacity in numbers: how many slots of each kind it has.
/// [`capacity!`](crate::capacity) declares one for an [`ArrayStorage`]
/// ([`Capacity::SLOTS`]), and [`Storage::capacity`] (or
/// [`Scene::capacity`](crate::Scene::capacity)) reports what any storage
/// holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Slots {
    /// Nodes (a scene addresses at most 65 536), 44 bytes each, and their
    /// solver scratch ([`NodeWork`]).
    pub nodes: usize,
    /// Tetrahedra. They are stored in [`ElementBlock`]s of
    /// [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK) each
    /// ([`Slots::element_blocks`]), so a storage reports whole blocks.
    pub elements: usize,
    /// Nodes the haptic tool can hold at once (feature `tool`), 16 bytes
    /// each.
    pub grabs: usize,
    /// Nodes that can carry a constant external force at once (feature
    /// `loads`), 16 bytes each.
    pub loads: usize,
    /// The richest preconditioner the storage has the slots for: `Mass`
    /// needs none, `BlockJacobi` a node block per node (32 bytes each,
    /// [`Slots::node_blocks`]), `TwoLevel` node blocks and `aggregates`.
    /// Its slots exist only with the feature `two-level`: without it a
    /// storage holds none and reports `Mass`.
    pub preconditioner: Preconditioner,
    /// Aggregates of the two-level preconditioner's coarse space, 176 bytes
    /// each, plus the slots of its coarse solve ([`Slots::coarse_blocks`]):
    /// at least one with `TwoLevel`, none otherwise. A scene uses
    /// [`aggregates_for`](crate::aggregates_for)`(free nodes, aggregates)`
    /// of them.
    pub aggregates: usize,
}

impl Slots {
    /// No slot of any kind, and the lumped mass: what
    /// [`capacity!`](crate::capacity) starts from.
    pub const NONE: Self = Self {
        nodes: 0,
        elements: 0,
        grabs: 0,
        loads: 0,
        preconditioner: Preconditioner::Mass,
        aggregates: 0,
    };

    /// The element blocks that hold `elements` tetrahedra:
    /// [`element_blocks`](crate::element_blocks)`(elements)`.
    #[must_use]
    pub const fn element_blocks(self) -> usize {
        crate::element_blocks(self.elements)
    }

    /// The node-block preconditioner's slots (feature `two-level`): one per
    /// node for `BlockJacobi` and `TwoLevel`, none for `Mass`.
    #[cfg(feature = "two-level")]
    #[must_use]
    pub const fn node_blocks(self) -> usize {
        match self.preconditioner {
            Preconditioner::Mass => 0,
            Preconditioner::BlockJacobi | Preconditioner::TwoLevel => self.nodes,
        }
    }

    /// The slots of the coarse solve of `aggregates` aggregates (feature
    /// `two-level`), 32 bytes each:
    /// [`coarse_blocks_for`](crate::coarse_blocks_for)`(aggregates)`, about
    /// `4.5 aggregates²`.
    #[cfg(feature = "two-level")]
    #[must_use]
    pub const fn coarse_blocks(self) -> usize {
        crate::slots::coarse_blocks_for(self.aggregates)
    }
}

/// An array of slots, `[T; N]`: the form of every slot list of a
/// [`Capacity`]. Sealed: implemented for arrays of the slot types
/// ([`Node`], [`NodeWork`], [`ElementBlock`], [`NodeEntry`] and the
/// preconditioners') only.
pub trait SlotArray<T>: sealed::Array<T> {
    /// The number of slots, `N`.
    const LEN: usize;
    /// Every slot unused: all zero bits.
    const EMPTY: Self;
    /// The slots.
    fn as_slice(&self) -> &[T];
    /// The slots, mutable.
    fn as_mut_slice(&mut self) -> &mut [T];
}

impl<T: sealed::Slot, const N: usize> SlotArray<T> for [T; N] {
    const LEN: usize = N;
    const EMPTY: Self = [T::EMPTY; N];
    #[inline(always)]
    fn as_slice(&self) -> &[T] {
        self
    }
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [T] {
        self
    }
}

/// Implements [`sealed::Slot`] for slot types, with their `EMPTY`.
macro_rules! slot {
    ($($t:ty),*) => {
        $(impl sealed::Slot for $t {
            const EMPTY: Self = <$t>::EMPTY;
        })*
    };
}
slot!(Node, NodeWork, ElementBlock, NodeEntry);
#[cfg(feature = "two-level")]
slot!(
    crate::slots::NodeBlock,
    crate::slots::Aggregate,
    crate::slots::CoarseBlock
);

/// The capacity of an [`ArrayStorage`], as a type: its numbers
/// ([`Capacity::SLOTS`]) and the arrays that hold them. Declare one with
/// [`capacity!`](crate::capacity), which derives every array from the
/// numbers.
///
/// An implementation written by hand gives arrays of exactly the lengths
/// that `SLOTS` asks for (the ones documented on each type), and `SLOTS`
/// asks for aggregates with `TwoLevel` and only then: [`ArrayStorage::new`]
/// checks both at compile time, so an implementation that breaks them does
/// not compile, and neither does a declaration that does:
///
/// ```compile_fail
/// use corofem::StaticScene;
/// // Aggregates without `preconditioner: Preconditioner::TwoLevel`.
/// corofem::capacity! { struct Odd { nodes: 8, elements: 4, aggregates: 2 } }
/// let scene = StaticScene::<Odd>::new();
/// ```
pub trait Capacity {
    /// What a storage of this capacity holds (in a build without the
    /// feature `two-level`, no preconditioner slots whatever
    /// `SLOTS.preconditioner` says).
    const SLOTS: Slots;
    /// Node slots: `[Node; SLOTS.nodes]`.
    type Nodes: SlotArray<Node>;
    /// Solver scratch, one per node slot: `[NodeWork; SLOTS.nodes]`.
    type Work: SlotArray<NodeWork>;
    /// Element blocks: `[ElementBlock; SLOTS.element_blocks()]`.
    type ElementBlocks: SlotArray<ElementBlock>;
    /// Slots for the nodes the tool holds: `[NodeEntry; SLOTS.grabs]`.
    type Grabs: SlotArray<NodeEntry>;
    /// Slots for constant external forces: `[NodeEntry; SLOTS.loads]`.
    type Loads: SlotArray<NodeEntry>;
    /// Node-block preconditioner slots (feature `two-level`):
    /// `[NodeBlock; SLOTS.node_blocks()]`.
    #[cfg(feature = "two-level")]
    type NodeBlocks: SlotArray<crate::slots::NodeBlock>;
    /// Aggregate slots of the two-level preconditioner (feature
    /// `two-level`): `[Aggregate; SLOTS.aggregates]`.
    #[cfg(feature = "two-level")]
    type Aggregates: SlotArray<crate::slots::Aggregate>;
    /// Slots of its coarse solve (feature `two-level`):
    /// `[CoarseBlock; SLOTS.coarse_blocks()]`.
    #[cfg(feature = "two-level")]
    type CoarseBlocks: SlotArray<crate::slots::CoarseBlock>;
}

/// Declares a storage capacity: a unit struct that implements [`Capacity`]
/// (and derives `Clone`, `Copy`, `Debug`, `Default`, `PartialEq`, `Eq` and
/// `Hash`), for an [`ArrayStorage`] or a [`StaticScene`](crate::StaticScene).
///
/// The fields are those of [`Slots`], as constant expressions: `nodes` and
/// `elements` (tetrahedra) first, then any of `grabs`, `loads`,
/// `preconditioner` and `aggregates`, each 0 (or `Mass`) when left out. The
/// macro derives the rest: the element blocks for `elements` tetrahedra on
/// this target, and for a `preconditioner` other than `Mass` a node block
/// per node and the coarse solve's slots of `aggregates`
/// ([`Slots::node_blocks`], [`Slots::coarse_blocks`]).
///
/// ```
/// use corofem::{Capacity, Preconditioner, Slots, StaticScene, Storage};
///
/// corofem::capacity! {
///     /// A 10×2×2-cell beam, 3 of its nodes held by the tool, with the
///     /// two-level preconditioner's slots for 8 aggregates.
///     pub struct Beam {
///         nodes: 99,
///         elements: 240,
///         grabs: 3,
///         preconditioner: Preconditioner::TwoLevel,
///         aggregates: 8,
///     }
/// }
///
/// static mut SCENE: StaticScene<Beam> = StaticScene::new(); // zero bits: .bss
/// let scene = StaticScene::<Beam>::new();
/// // The mesh's arrays, sized by the same numbers.
/// let nodes = [[0.0f32; 3]; Beam::SLOTS.nodes];
/// # let _ = nodes;
/// # #[cfg(feature = "two-level")]
/// assert_eq!(scene.capacity(), Slots { elements: 240, loads: 0, ..Beam::SLOTS });
/// ```
#[macro_export]
macro_rules! capacity {
    (
        $(#[$attr:meta])*
        $vis:vis struct $name:ident {
            nodes: $nodes:expr,
            elements: $elements:expr
            $(, $key:ident: $value:expr)* $(,)?
        }
    ) => {
        $(#[$attr])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        $vis struct $name;

        impl $crate::Capacity for $name {
            // All the fields may be given: the update is then a no-op.
            #[allow(clippy::needless_update)]
            const SLOTS: $crate::Slots = $crate::Slots {
                nodes: $nodes,
                elements: $elements,
                $($key: $value,)*
                ..$crate::Slots::NONE
            };
            type Nodes = [$crate::Node; <Self as $crate::Capacity>::SLOTS.nodes];
            type Work = [$crate::NodeWork; <Self as $crate::Capacity>::SLOTS.nodes];
            type ElementBlocks =
                [$crate::ElementBlock; <Self as $crate::Capacity>::SLOTS.element_blocks()];
            type Grabs = [$crate::NodeEntry; <Self as $crate::Capacity>::SLOTS.grabs];
            type Loads = [$crate::NodeEntry; <Self as $crate::Capacity>::SLOTS.loads];
            $crate::__capacity_two_level! {
                type NodeBlocks =
                    [$crate::NodeBlock; <Self as $crate::Capacity>::SLOTS.node_blocks()];
                type Aggregates =
                    [$crate::Aggregate; <Self as $crate::Capacity>::SLOTS.aggregates];
                type CoarseBlocks =
                    [$crate::CoarseBlock; <Self as $crate::Capacity>::SLOTS.coarse_blocks()];
            }
        }
    };
}

/// The items it is given where the feature `two-level` is on: what
/// [`capacity!`] writes for the preconditioners' slots.
#[cfg(feature = "two-level")]
#[doc(hidden)]
#[macro_export]
macro_rules! __capacity_two_level {
    ($($item:tt)*) => { $($item)* };
}

/// Nothing: the feature `two-level` is off, so there are no
/// preconditioner slots.
#[cfg(not(feature = "two-level"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __capacity_two_level {
    ($($item:tt)*) => {};
}

/// Fixed-capacity storage in plain arrays, as the [`Capacity`] `C` declares
/// them ([`capacity!`](crate::capacity)): up to `C::SLOTS.nodes` nodes and
/// `C::SLOTS.elements` tetrahedra, `C::SLOTS.grabs` nodes held by the tool
/// (feature `tool`) and `C::SLOTS.loads` nodes with a constant external
/// force (feature `loads`), and with the feature `two-level` the slots of
/// `C::SLOTS.preconditioner` ([`Slots`]). `const fn new` is all zero bits,
/// so a whole scene can live in a `static` in `.bss`.
#[derive(Clone, Debug)]
pub struct ArrayStorage<C: Capacity> {
    nodes: C::Nodes,
    work: C::Work,
    elems: C::ElementBlocks,
    grabs: C::Grabs,
    loads: C::Loads,
    #[cfg(feature = "two-level")]
    blocks: C::NodeBlocks,
    #[cfg(feature = "two-level")]
    aggs: C::Aggregates,
    #[cfg(feature = "two-level")]
    coarse: C::CoarseBlocks,
}

impl<C: Capacity> ArrayStorage<C> {
    /// `C`'s arrays have the lengths `C::SLOTS` asks for, and `C::SLOTS`
    /// asks for aggregates exactly with `TwoLevel`: evaluated by
    /// [`ArrayStorage::new`], so a capacity that breaks it does not compile.
    const CHECK: () = {
        let s = C::SLOTS;
        assert!(
            matches!(s.preconditioner, Preconditioner::TwoLevel) == (s.aggregates > 0),
            "capacity: `aggregates` (at least 1) goes with `preconditioner: Preconditioner::TwoLevel`, and only with it"
        );
        assert!(
            <C::Nodes as SlotArray<Node>>::LEN == s.nodes
                && <C::Work as SlotArray<NodeWork>>::LEN == s.nodes,
            "capacity: `Nodes` and `Work` are `SLOTS.nodes` long"
        );
        assert!(
            <C::ElementBlocks as SlotArray<ElementBlock>>::LEN == s.element_blocks(),
            "capacity: `ElementBlocks` is `SLOTS.element_blocks()` long"
        );
        assert!(
            <C::Grabs as SlotArray<NodeEntry>>::LEN == s.grabs
                && <C::Loads as SlotArray<NodeEntry>>::LEN == s.loads,
            "capacity: `Grabs` and `Loads` are `SLOTS.grabs` and `SLOTS.loads` long"
        );
        #[cfg(feature = "two-level")]
        assert!(
            <C::NodeBlocks as SlotArray<crate::slots::NodeBlock>>::LEN == s.node_blocks()
                && <C::Aggregates as SlotArray<crate::slots::Aggregate>>::LEN == s.aggregates
                && <C::CoarseBlocks as SlotArray<crate::slots::CoarseBlock>>::LEN
                    == s.coarse_blocks(),
            "capacity: the preconditioner's arrays are `SLOTS.node_blocks()`, `SLOTS.aggregates` and `SLOTS.coarse_blocks()` long"
        );
    };

    /// Empty storage: every slot unused, all zero bits.
    #[must_use]
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        Self {
            nodes: SlotArray::EMPTY,
            work: SlotArray::EMPTY,
            elems: SlotArray::EMPTY,
            grabs: SlotArray::EMPTY,
            loads: SlotArray::EMPTY,
            #[cfg(feature = "two-level")]
            blocks: SlotArray::EMPTY,
            #[cfg(feature = "two-level")]
            aggs: SlotArray::EMPTY,
            #[cfg(feature = "two-level")]
            coarse: SlotArray::EMPTY,
        }
    }
}

impl<C: Capacity> Default for ArrayStorage<C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<C: Capacity> sealed::Sealed for ArrayStorage<C> {
    fn parts(&self) -> Parts<'_> {
        Parts {
            nodes: self.nodes.as_slice(),
            elems: self.elems.as_slice(),
            grabs: self.grabs.as_slice(),
            loads: self.loads.as_slice(),
            #[cfg(feature = "two-level")]
            blocks: self.blocks.as_slice(),
            #[cfg(feature = "two-level")]
            aggs: self.aggs.as_slice(),
            #[cfg(feature = "two-level")]
            coarse: self.coarse.as_slice(),
        }
    }
    fn parts_mut(&mut self) -> PartsMut<'_> {
        PartsMut {
            nodes: self.nodes.as_mut_slice(),
            work: self.work.as_mut_slice(),
            elems: self.elems.as_mut_slice(),
            grabs: self.grabs.as_mut_slice(),
            loads: self.loads.as_mut_slice(),
            #[cfg(feature = "two-level")]
            blocks: self.blocks.as_mut_slice(),
            #[cfg(feature = "two-level")]
            aggs: self.aggs.as_mut_slice(),
            #[cfg(feature = "two-level")]
            coarse: self.coarse.as_mut_slice(),
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
    fn parts(&self) -> Parts<'_> {
        Parts {
            nodes: self.nodes,
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
    fn parts(&self) -> Parts<'_> {
        Parts {
            nodes: &self.nodes,
            elems: &self.elems,
            grabs: &self.grabs,
            loads: &self.loads,
            #[cfg(feature = "two-level")]
            blocks: &self.blocks,
            #[cfg(feature = "two-level")]
            aggs: &self.aggs,
            #[cfg(feature = "two-level")]
            coarse: &self.coarse,
        }
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

    crate::capacity! {
        /// Every kind of slot, the preconditioner's included.
        struct Full {
            nodes: 27,
            elements: 45,
            grabs: 3,
            loads: 2,
            preconditioner: Preconditioner::TwoLevel,
            aggregates: 2,
        }
    }

    crate::capacity! {
        /// Nodes and elements only.
        struct Bare { nodes: 5, elements: 2 }
    }

    /// An array storage is its arrays, no byte more, and each is as long as
    /// its capacity's numbers say.
    #[test]
    fn an_array_storage_holds_what_its_capacity_declares() {
        use core::mem::size_of;
        let s = Full::SLOTS;
        let blocks = crate::element_blocks(45);
        assert_eq!(s.element_blocks(), blocks);
        #[cfg(feature = "two-level")]
        let preconditioner = {
            use crate::slots::{coarse_blocks_for, Aggregate, CoarseBlock, NodeBlock};
            assert_eq!(
                (s.node_blocks(), s.coarse_blocks()),
                (27, coarse_blocks_for(2))
            );
            27 * size_of::<NodeBlock>()
                + 2 * size_of::<Aggregate>()
                + coarse_blocks_for(2) * size_of::<CoarseBlock>()
        };
        #[cfg(not(feature = "two-level"))]
        let preconditioner = 0;
        let bytes = 27 * (size_of::<Node>() + size_of::<NodeWork>())
            + blocks * size_of::<ElementBlock>()
            + 5 * size_of::<NodeEntry>()
            + preconditioner;
        assert_eq!(size_of::<ArrayStorage<Full>>(), bytes);
        let full = ArrayStorage::<Full>::new();
        let want = Slots {
            elements: blocks * crate::ELEMENTS_PER_BLOCK,
            ..Full::SLOTS
        };
        #[cfg(not(feature = "two-level"))]
        let want = Slots {
            preconditioner: Preconditioner::Mass,
            aggregates: 0,
            ..want
        };
        assert_eq!(full.capacity(), want);
        let bare = ArrayStorage::<Bare>::new();
        assert_eq!(bare.capacity().preconditioner, Preconditioner::Mass);
        assert_eq!((bare.capacity().grabs, bare.capacity().loads), (0, 0));
    }

    /// A storage reports the richest preconditioner whose slots it has
    /// all of: node blocks for every node slot, then aggregates with the
    /// whole of their coarse solve.
    #[cfg(feature = "two-level")]
    #[test]
    fn a_storage_reports_the_preconditioner_it_has_every_slot_for() {
        use crate::slots::{coarse_blocks_for, Aggregate, CoarseBlock, NodeBlock};
        let (mut nodes, mut work) = ([Node::EMPTY; 4], [NodeWork::EMPTY; 4]);
        let mut elems = [ElementBlock::EMPTY; 1];
        let mut blocks = [NodeBlock::EMPTY; 4];
        let mut aggs = [Aggregate::EMPTY; 2];
        let mut coarse = [CoarseBlock::EMPTY; coarse_blocks_for(2)];
        let mut room = |b: usize, c: usize| {
            let s = SliceStorage::new(&mut nodes, &mut work, &mut elems).with_preconditioner(
                &mut blocks[..b],
                &mut aggs,
                &mut coarse[..c],
            );
            let cap = s.capacity();
            (cap.preconditioner, cap.aggregates)
        };
        let all = coarse_blocks_for(2);
        assert_eq!(room(4, all), (Preconditioner::TwoLevel, 2));
        assert_eq!(room(4, all - 1), (Preconditioner::BlockJacobi, 0));
        assert_eq!(room(3, all), (Preconditioner::Mass, 0));
    }
}
