//! `ElementBlock`: the storage of [`LANES`] elements, field by field.
//!
//! Element `e` of a scene of `n` lives in slot [`slot`]`(e, n)`: block
//! `slot / LANES`, lane `slot % LANES`. Passes visit the slots in order, so
//! every node sum is made in slot order, the same on every target. Each field holds
//! one value per lane side by side (a structure of arrays in blocks), so a
//! batched pass loads a field of a whole block as one vector: the stiffness
//! product, run once per CG iteration, reads its gradients and stiffnesses
//! without moving them between elements and lanes. With array-of-structs
//! elements, moving each element's gradients into lanes costs about what the
//! lanes save.
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
            // Zeros, not the identity, so that an empty scene is all zero
            // bits (a `static` in `.bss`): `Scene::build` and switching to
            // `Polar` start every element's rotation at the identity
            // (`POLAR_START`), and only used lanes are ever computed.
            #[cfg(feature = "polar")]
            rot: [zero; 4],
        }
    };

    /// Every lane's polar rotation at the identity: where `Polar` starts.
    #[cfg(feature = "polar")]
    pub(crate) const POLAR_START: [Batch; 4] = [
        Lanes([super::rotation::IDENTITY[0]; LANES]),
        Lanes([super::rotation::IDENTITY[1]; LANES]),
        Lanes([super::rotation::IDENTITY[2]; LANES]),
        Lanes([super::rotation::IDENTITY[3]; LANES]),
    ];

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

/// Blocks needed for `elements` elements: the length of the element slice
/// of [`SliceStorage`](crate::SliceStorage) (an
/// [`ArrayStorage`](crate::ArrayStorage)'s [`capacity!`](crate::capacity)
/// takes the element count and sizes its blocks with it). It depends on the
/// target ([`ELEMENTS_PER_BLOCK`](crate::ELEMENTS_PER_BLOCK)), so size
/// storage with it.
#[must_use]
pub const fn element_blocks(elements: usize) -> usize {
    elements.div_ceil(LANES)
}

/// Elements interleaved by [`slot`]: the lanes of a host block. Fixed, not
/// [`LANES`], so that a target with one lane stores, and sums, in the same
/// order.
const INTERLEAVE: usize = 8;

const _: () = assert!(
    LANES == 1 || LANES == INTERLEAVE,
    "a block holds one interleave"
);

/// Elements in a run of [`slot`].
const RUN: usize = 64;

/// The storage slot of element `e` of a scene of `count` elements. The
/// elements go in groups of `8 · 64`; a group of `n` elements (all 512 but
/// the last) is dealt out in eight runs of `q = n / 8`:
///
/// ```text
/// element base + l·q + i  (l < 8, i < q)   →   slot base + 8·i + l
/// ```
///
/// and the last `n % 8` of the last group stay in place. The lanes of a
/// block are then `q` (64) elements apart in the input's order. Meshes list
/// their elements with some spatial order (a mesher's sweep, a box's
/// cells), so elements 64 apart rarely share a node, and the scatter of a
/// block's results into its nodes rarely adds into a node one lane after
/// another did: such a chain of adds waits on the store before it each time.
/// (A box's cell lists its six tetrahedra one after the other, all sharing
/// the cell's diagonal: in input order a block of them would add into that
/// node six times in a row.) Runs of 64 rather than `count / 8` keep a
/// block's nodes within a few hundred elements, where the caches still hold
/// them, and cannot fall in step with a mesh's period (on a regular beam,
/// lanes `count / 8` apart can land on the same nodes).
///
/// A bijection of `0..count` (slots of `e ≥ count` are `e`).
#[must_use]
pub(crate) fn slot(e: usize, count: usize) -> usize {
    const GROUP: usize = INTERLEAVE * RUN;
    let base = e / GROUP * GROUP;
    let q = count.saturating_sub(base).min(GROUP) / INTERLEAVE;
    let i = e - base;
    match (i.checked_div(q), i.checked_rem(q)) {
        (Some(l), Some(k)) if l < INTERLEAVE => base + k * INTERLEAVE + l,
        _ => e,
    }
}

/// The block and lane of element `e` of a scene of `count` elements.
#[inline]
#[must_use]
pub(crate) fn block_and_lane(e: usize, count: usize) -> (usize, usize) {
    let s = slot(e, count);
    (s / LANES, s % LANES)
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

#[cfg(test)]
mod tests {
    use super::{slot, Batch, ElementBlock};

    /// An unused block is all zero bits in every build (the polar
    /// rotations included), so that a `static` scene lands in `.bss`.
    #[test]
    fn an_empty_block_is_all_zero_bits() {
        let b = ElementBlock::EMPTY;
        assert!(b.nodes.iter().flatten().all(|&i| i == 0));
        let mut values: std::vec::Vec<&Batch> = b.rest.iter().collect();
        values.push(&b.stiffness);
        values.extend(b.grad.iter().flatten());
        #[cfg(any(feature = "polar", feature = "linear"))]
        values.extend(b.rest_grad.iter().flatten());
        #[cfg(feature = "polar")]
        values.extend(b.rot.iter());
        assert!(values.iter().all(|v| v.0.iter().all(|x| x.to_bits() == 0)));
    }

    /// Counts from 0 to 1 100 (whole groups, a partial last group, a tail,
    /// fewer than eight elements): `slot` is a bijection of `0..count`, and
    /// the lanes of a whole block in a whole group are 64 elements apart.
    #[test]
    fn slots_are_a_bijection() {
        let mut seen = [false; 1100];
        for count in 0..1100 {
            seen.fill(false);
            for e in 0..count {
                let s = slot(e, count);
                assert!(s < count && !seen[s], "count {count}, element {e}");
                seen[s] = true;
            }
            for s in 0..count / 512 * 512 {
                let (group, i) = (s / 512, s % 512);
                assert_eq!(group * 512 + (i % 8) * 64 + i / 8, inverse(s, count));
            }
        }
    }

    /// The element in slot `s` (by search: test only).
    fn inverse(s: usize, count: usize) -> usize {
        (0..count).find(|&e| slot(e, count) == s).unwrap()
    }
}
