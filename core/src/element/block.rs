//! `ElementBlock`: the storage of [`LANES`] elements, field by field.
//!
//! Element `e` lives in block `e / LANES`, lane `e % LANES`. Each field holds
//! one value per lane side by side (a structure of arrays in blocks), so a
//! batched pass loads a field of a whole block as one vector: the stiffness
//! product, run once per CG iteration, reads its gradients and stiffnesses
//! without moving them between elements and lanes. Measured on the 10k-tet
//! cube (docs/bench.md): array-of-structs elements, batched or not, cost
//! about what the lanes saved.
//!
//! With one lane (targets without vector registers, such as a Cortex-M4F) a
//! block holds one element, with no padding between lanes.

use super::Element;
use crate::lanes::{Lanes, LANES};
use crate::math::Vec3;

/// Values of a block, one per lane.
pub(crate) type Batch = Lanes<LANES>;

/// Storage of up to [`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK) elements (72 bytes per element with `Qr`
/// only; +36 with `polar` or `linear` for the rest world gradients; +16 with
/// `polar` for the rotation). Lanes past the scene's element count are unused.
// `repr(C)`: fields in this order, so that the Cortex-M4F's assembly product
// (`fpu_product`) finds the gradients right after the stiffness with every
// feature set (no padding: every field is 4-aligned and a multiple of 4).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct ElementBlock {
    /// Node indices `a, b, c, d` of each lane.
    pub(crate) nodes: [[u16; LANES]; 4],
    /// Rest local coordinates `[xb, xc, yc, xd, yd, zd]` in the QR frame (m).
    pub(crate) rest: [Batch; 6],
    /// `E / (36 V₀)` (Pa/m³), see [`Element`].
    pub(crate) stiffness: Batch,
    /// World gradients of `b, c, d` from the last force evaluation (m²).
    pub(crate) grad: [[Batch; 3]; 3],
    /// Rest world gradients of `b, c, d` (m²).
    #[cfg(any(feature = "polar", feature = "linear"))]
    pub(crate) rest_grad: [[Batch; 3]; 3],
    /// Polar rotations (quaternions `w, x, y, z`).
    #[cfg(feature = "polar")]
    pub(crate) rot: [Batch; 4],
}

impl ElementBlock {
    /// An unused block.
    pub const EMPTY: Self = {
        let zero = Lanes([0.0; LANES]);
        Self {
            nodes: [[0; LANES]; 4],
            rest: [zero; 6],
            stiffness: zero,
            grad: [[zero; 3]; 3],
            #[cfg(any(feature = "polar", feature = "linear"))]
            rest_grad: [[zero; 3]; 3],
            #[cfg(feature = "polar")]
            rot: [
                Lanes([super::polar::IDENTITY[0]; LANES]),
                Lanes([super::polar::IDENTITY[1]; LANES]),
                Lanes([super::polar::IDENTITY[2]; LANES]),
                Lanes([super::polar::IDENTITY[3]; LANES]),
            ],
        }
    };

    /// Node indices of lane `j` (zeros if `j ≥ LANES`).
    #[inline(always)]
    #[must_use]
    pub(crate) fn nodes(&self, j: usize) -> [u16; 4] {
        self.nodes.map(|c| c.get(j).copied().unwrap_or(0))
    }

    /// The element in lane `j`, as a value (all zeros, not a usable element,
    /// if `j ≥ LANES`).
    #[inline(always)]
    #[must_use]
    pub(crate) fn get(&self, j: usize) -> Element {
        Element {
            nodes: self.nodes(j),
            rest: Batch::lane(&self.rest, j),
            stiffness: self.stiffness.0.get(j).copied().unwrap_or(0.0),
            grad: lane3(&self.grad, j),
            #[cfg(any(feature = "polar", feature = "linear"))]
            rest_grad: lane3(&self.rest_grad, j),
            #[cfg(feature = "polar")]
            rot: Batch::lane(&self.rot, j),
        }
    }

    /// Writes every field of lane `j` (nothing if `j ≥ LANES`).
    #[inline(always)]
    pub(crate) fn set(&mut self, j: usize, el: &Element) {
        for (c, id) in self.nodes.iter_mut().zip(el.nodes) {
            if let Some(slot) = c.get_mut(j) {
                *slot = id;
            }
        }
        Batch::put(&mut self.rest, j, el.rest);
        self.set_stiffness(j, el.stiffness);
        #[cfg(any(feature = "polar", feature = "linear"))]
        put3(&mut self.rest_grad, j, &el.rest_grad);
        self.set_state(j, el);
    }

    /// Writes what a force evaluation changes in lane `j`: the world
    /// gradients (and the polar rotation).
    #[inline(always)]
    pub(crate) fn set_state(&mut self, j: usize, el: &Element) {
        self.set_grad(j, &el.grad);
        #[cfg(feature = "polar")]
        Batch::put(&mut self.rot, j, el.rot);
    }

    /// Writes the world gradients of lane `j`.
    #[inline(always)]
    pub(crate) fn set_grad(&mut self, j: usize, grad: &[Vec3; 3]) {
        put3(&mut self.grad, j, grad);
    }

    /// Writes the stiffness `E / (36 V₀)` of lane `j` (Pa/m³).
    #[inline(always)]
    pub(crate) fn set_stiffness(&mut self, j: usize, stiffness: f32) {
        if let Some(s) = self.stiffness.0.get_mut(j) {
            *s = stiffness;
        }
    }
}

impl Default for ElementBlock {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Blocks needed for `elements` elements: the second parameter of
/// [`ArrayStorage`](crate::ArrayStorage) and the length of the element slice
/// of [`SliceStorage`](crate::SliceStorage). It depends on the target
/// ([`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK)), so size storage with
/// it, e.g. `StaticScene<99, { corofem::element_blocks(240) }>`.
#[must_use]
pub const fn element_blocks(elements: usize) -> usize {
    elements.div_ceil(LANES)
}

/// Lane `j` of three vectors held in lanes.
#[inline(always)]
#[must_use]
pub(crate) fn lane3(v: &[[Batch; 3]; 3], j: usize) -> [Vec3; 3] {
    [
        Batch::lane(&v[0], j),
        Batch::lane(&v[1], j),
        Batch::lane(&v[2], j),
    ]
}

/// Sets lane `j` of three vectors held in lanes.
#[inline(always)]
fn put3(dst: &mut [[Batch; 3]; 3], j: usize, v: &[Vec3; 3]) {
    for (d, x) in dst.iter_mut().zip(v) {
        Batch::put(d, j, *x);
    }
}
