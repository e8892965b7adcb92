//! Where a scene's data lives. The type that owns storage knows the capacity
//! (`ArrayStorage<N, B>`, usable in a `static`); everything else works on
//! slices, so the solver is not compiled once per capacity. Elements are
//! stored in [`ElementBlock`]s of [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK)
//! elements each; [`element_blocks`](crate::element_blocks) gives how many a
//! mesh needs.

use crate::element::ElementBlock;
use crate::math::Vec3;

/// Node flag: the node does not move (its velocity change is filtered out).
pub(crate) const FIXED: u8 = 1;
/// Node flag: the node is held by the haptic tool's spring.
#[cfg(feature = "tool")]
pub(crate) const GRABBED: u8 = 2;
/// Node flag: the ground held this node last step but would have had to pull
/// it; it is left free for the next step.
#[cfg(feature = "ground")]
pub(crate) const RELEASED: u8 = 4;
/// Node flag: the ground holds this node during the current step.
pub(crate) const CONTACT: u8 = 8;

/// Per-node state (41 bytes of data; 44 with padding, +12 with `loads`, +12
/// with `tool`).
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
    /// External force (N), constant until changed.
    #[cfg(feature = "loads")]
    pub(crate) f_ext: Vec3,
    /// Lumped mass (kg): a quarter of `ρ V₀` of every element around the node.
    pub(crate) mass: f32,
    /// `FIXED | GRABBED | RELEASED | CONTACT`.
    pub(crate) flags: u8,
    /// Offset from the grabbed nodes' centroid when grabbed (m).
    #[cfg(feature = "tool")]
    pub(crate) grab: Vec3,
}

impl Node {
    /// An unused slot.
    pub const EMPTY: Self = Self {
        x0: [0.0; 3],
        u: [0.0; 3],
        v: [0.0; 3],
        #[cfg(feature = "loads")]
        f_ext: [0.0; 3],
        mass: 0.0,
        flags: 0,
        #[cfg(feature = "tool")]
        grab: [0.0; 3],
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

/// Per-node scratch of the linear solver (52 bytes). Only `x` (the last
/// velocity change, the warm start) carries from one step to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
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
}

impl NodeWork {
    /// An unused slot.
    pub const EMPTY: Self = Self {
        x: [0.0; 3],
        r: [0.0; 3],
        d: [0.0; 3],
        q: [0.0; 3],
        inv_p: 0.0,
    };
}

impl Default for NodeWork {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Storage for a scene: the node, solver-scratch and element-block slots.
/// The capacity is the length of the slices (times
/// [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK) for elements).
pub trait Storage {
    /// Node and element-block slots.
    fn parts(&self) -> (&[Node], &[ElementBlock]);
    /// All slots, mutable.
    fn parts_mut(&mut self) -> (&mut [Node], &mut [NodeWork], &mut [ElementBlock]);
}

/// Borrowed storage: lets the storage live apart from the scene, e.g. an
/// `ArrayStorage` in a zero-initialised `static` (`.bss`) while the scene
/// header stays on the stack.
impl<S: Storage + ?Sized> Storage for &mut S {
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (**self).parts()
    }
    fn parts_mut(&mut self) -> (&mut [Node], &mut [NodeWork], &mut [ElementBlock]) {
        (**self).parts_mut()
    }
}

/// Fixed-capacity storage in plain arrays: up to `N` nodes and `B` element
/// blocks, that is `B × ELEMENTS_PER_BLOCK` tetrahedra; size `B` with
/// [`element_blocks`](crate::element_blocks).
/// `const fn new` lets a whole scene live in a `static`.
#[derive(Clone, Debug)]
pub struct ArrayStorage<const N: usize, const B: usize> {
    nodes: [Node; N],
    work: [NodeWork; N],
    elems: [ElementBlock; B],
}

impl<const N: usize, const B: usize> ArrayStorage<N, B> {
    /// Empty storage.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            nodes: [Node::EMPTY; N],
            work: [NodeWork::EMPTY; N],
            elems: [ElementBlock::EMPTY; B],
        }
    }
}

impl<const N: usize, const B: usize> Default for ArrayStorage<N, B> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const B: usize> Storage for ArrayStorage<N, B> {
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (&self.nodes, &self.elems)
    }
    fn parts_mut(&mut self) -> (&mut [Node], &mut [NodeWork], &mut [ElementBlock]) {
        (&mut self.nodes, &mut self.work, &mut self.elems)
    }
}

/// Storage in slices the caller owns (an arena, or vectors on a host).
/// The node and work slices must have the same length; the shorter one sets
/// the node capacity.
#[derive(Debug)]
pub struct SliceStorage<'a> {
    nodes: &'a mut [Node],
    work: &'a mut [NodeWork],
    elems: &'a mut [ElementBlock],
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
        Self { nodes, work, elems }
    }
}

impl Storage for SliceStorage<'_> {
    fn parts(&self) -> (&[Node], &[ElementBlock]) {
        (self.nodes, self.elems)
    }
    fn parts_mut(&mut self) -> (&mut [Node], &mut [NodeWork], &mut [ElementBlock]) {
        (self.nodes, self.work, self.elems)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The storage the core keeps, per feature set (the numbers the docs and
    /// the benchmark report quote): an element is 72 bytes with `qr` (a block
    /// holds `ELEMENTS_PER_BLOCK` of them, without padding), plus the
    /// rest gradients (36) for `polar`/`linear` and the rotation (16) for
    /// `polar`; a node is 44 + 52 bytes, plus 12 for each of `tool` and `loads`.
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
        let tool = if cfg!(feature = "tool") { 12 } else { 0 };
        let loads = if cfg!(feature = "loads") { 12 } else { 0 };
        assert_eq!(core::mem::size_of::<Node>(), 44 + tool + loads);
        assert_eq!(core::mem::size_of::<NodeWork>(), 52);
    }
}
