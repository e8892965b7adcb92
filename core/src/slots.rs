//! The preconditioners' slot types (feature `two-level`): memory a storage
//! provides, sized by [`aggregates_for`] and [`coarse_blocks_for`]. At the
//! bottom of the crate, below the storages that hold them and the
//! preconditioners that use them.

use crate::math::{Mat3, Vec3};

/// What [`NodeBlock::aggregate`] holds for a node in no aggregate (fixed).
pub(crate) const NONE: u32 = u32::MAX;

/// A node's slot of preconditioner data (32 bytes): opaque, named only to
/// provide memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeBlock {
    /// The inverse of the node's 3×3 block of `A`, `[xx, yy, zz, xy, yz, zx]`
    /// (zero on fixed nodes).
    pub(crate) inv: [f32; 6],
    /// The node's aggregate, or `NONE`.
    pub(crate) aggregate: u32,
    /// Scratch of the aggregation: a node index.
    pub(crate) order: u32,
}

impl NodeBlock {
    /// An unused slot: all zero bits, so that a storage of them in a
    /// `static` lands in `.bss` and costs no flash. (Its aggregate reads 0
    /// until the aggregation assigns every slot; nothing reads it before.)
    pub const EMPTY: Self = Self {
        inv: [0.0; 6],
        aggregate: 0,
        order: 0,
    };
}

impl Default for NodeBlock {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// An aggregate's slot (176 bytes): opaque, named only to provide memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aggregate {
    /// Mass-weighted rest centroid `c₀` (m).
    pub(crate) c0: Vec3,
    /// Rest second moment `Σ m p pᵀ` (kg m²).
    pub(crate) s0: Mat3,
    /// Current rotation `R_a` (rows), and its quaternion `q_step`.
    pub(crate) rot: Mat3,
    pub(crate) q_step: [f32; 4],
    /// The rotation of the last step that was applied (the warm start of
    /// the next step's search): a refused step leaves it as it was, so that
    /// what follows does not depend on it.
    pub(crate) q: [f32; 4],
    /// `Σ m u pᵀ`, then `S₀ + Σ m u pᵀ = Σ m (x − c) pᵀ`.
    pub(crate) apq: Mat3,
    /// Coarse vector `(t, ω)`.
    pub(crate) y: [f32; 6],
}

impl Aggregate {
    /// An unused slot: all zero bits, so that a storage of them in a
    /// `static` lands in `.bss` and costs no flash. The aggregation starts
    /// every aggregate it uses from a slot that is not turned.
    pub const EMPTY: Self = Self {
        c0: [0.0; 3],
        s0: [[0.0; 3]; 3],
        rot: [[0.0; 3]; 3],
        q_step: [0.0; 4],
        q: [0.0; 4],
        apq: [[0.0; 3]; 3],
        y: [0.0; 6],
    };
}

impl Default for Aggregate {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Eight consecutive entries of a row of the coarse solve's matrix, or of
/// its vector (32 bytes): opaque, named only to provide memory. A scene
/// with `n` aggregates uses [`coarse_blocks_for`]`(n)` of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoarseBlock {
    pub(crate) m: [f32; CHUNK],
}

impl CoarseBlock {
    /// An unused slot.
    pub const EMPTY: Self = Self { m: [0.0; CHUNK] };
}

impl Default for CoarseBlock {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Entries per [`CoarseBlock`]: the lanes the coarse solve works on at once.
pub(crate) const CHUNK: usize = 8;

/// Free nodes per aggregate that [`aggregates_for`] aims at on small
/// bodies: fewer nodes per aggregate keep reducing the error of a few
/// iterations on the report's scenes.
pub const NODES_PER_AGGREGATE: usize = 16;

/// The aggregates `VecStorage` has room for: the coarse solve costs
/// `(6 n)²` multiply-adds per CG iteration for `n` aggregates.
pub const MAX_AGGREGATES: usize = 64;

/// The number of aggregates the two-level preconditioner uses for a body of
/// `free_nodes` free nodes with room for `capacity`: one per
/// [`NODES_PER_AGGREGATE`] nodes, but at most `√(4 n / 3) + 1`, at least
/// one, at most `capacity`. The coarse solve costs `(6 a)²` per iteration
/// for `a` aggregates and the rest of an iteration `O(n)`: with `a ~ √n`,
/// the coarse solve's share of an iteration stays the same as bodies grow.
#[must_use]
pub const fn aggregates_for(free_nodes: usize, capacity: usize) -> usize {
    let n = free_nodes.div_ceil(NODES_PER_AGGREGATE);
    let root = (free_nodes.saturating_mul(4) / 3).isqrt() + 1;
    let n = if n < root { n } else { root };
    let n = if n == 0 { 1 } else { n };
    if n < capacity {
        n
    } else {
        capacity
    }
}

/// The [`CoarseBlock`]s the coarse solve of `aggs` aggregates takes: a
/// `6 aggs × 6 aggs` matrix and one vector of `6 aggs` entries, each row
/// padded to whole blocks of eight entries.
#[must_use]
pub const fn coarse_blocks_for(aggs: usize) -> usize {
    let dim = aggs.saturating_mul(6);
    dim.saturating_add(1).saturating_mul(stride(dim))
}

/// The blocks a row of the coarse matrix of dimension `dim` takes.
#[inline(always)]
pub(crate) const fn stride(dim: usize) -> usize {
    dim.div_ceil(CHUNK)
}

/// The slices the preconditioners work on.
pub(crate) struct Parts<'a> {
    pub(crate) blocks: &'a mut [NodeBlock],
    pub(crate) aggs: &'a mut [Aggregate],
    pub(crate) coarse: &'a mut [CoarseBlock],
}

impl Parts<'_> {
    /// Narrows `aggs` and `coarse` to the first `n` aggregates and their
    /// factor's blocks; returns `n`, or 0 (and empty slices: block-Jacobi)
    /// when the storage has not that many.
    pub(crate) fn keep(&mut self, n: usize) -> usize {
        let blocks = coarse_blocks_for(n);
        let n = if n <= self.aggs.len() && blocks <= self.coarse.len() {
            n
        } else {
            0
        };
        self.aggs = core::mem::take(&mut self.aggs)
            .get_mut(..n)
            .unwrap_or_default();
        self.coarse = core::mem::take(&mut self.coarse)
            .get_mut(..coarse_blocks_for(n))
            .unwrap_or_default();
        n
    }
}
