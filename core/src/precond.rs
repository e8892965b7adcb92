//! Preconditioners that see stiffness (feature `two-level`): 3×3 node-block
//! Jacobi, and a two-level additive preconditioner that adds a coarse space
//! of rigid-body modes per aggregate of nodes.
//!
//! With `A = (1 + h α_M) M + h (h + α_K) K` and the filter `S` of the
//! constraints, the two-level preconditioner is
//!
//! ```text
//! P⁻¹ = S (D⁻¹ + Φ A_c⁻¹ Φᵀ) S,    A_c = Φᵀ A Φ
//! ```
//!
//! - `D` holds the 3×3 node blocks of `A`, from the element gradients: for
//!   node `i` of an element, `K_ii = (λ' + μ') gᵢ gᵢᵀ + μ' |gᵢ|² I` (the
//!   `i = j` case of `K_ij = λ' gᵢ g_jᵀ + μ' g_j gᵢᵀ + μ' (gᵢ·g_j) I`,
//!   `crate::element::hform`). It sees what a lumped mass cannot: a node of a
//!   small or sliver element is far stiffer than its mass says.
//!   Block-Jacobi rebuilds `D` every step from the gradients the force pass
//!   has just refreshed; the two-level preconditioner prepares it with the
//!   coarse factor, in each aggregate's frame, and turns it with the
//!   aggregate (`D = R_a D_local R_aᵀ`), which costs nothing per step.
//! - `Φ` has six columns per aggregate `a` (a compact group of free nodes,
//!   from recursive coordinate bisection of the rest positions): the rigid
//!   translations and rotations of its nodes, turned by the aggregate's
//!   current rotation `R_a` (the rotation closest to `Σ m (x − c)(x₀ − c₀)ᵀ`,
//!   shape matching): node `i` of `a` moves by `R_a (t + ω × pᵢ)`,
//!   `pᵢ = x₀ᵢ − c₀ₐ`. Each CG iteration spreads information one ring of
//!   elements further; the coarse space carries the low-frequency motion
//!   (bending, sagging) across the body at once, which is what a few
//!   iterations miss.
//! - `A_c` is the Galerkin operator at the state where it was last prepared
//!   (the rest shape, usually), factorised once by block Cholesky (6×6
//!   blocks, the lower block triangle packed). Because `Φ`
//!   turns with the aggregates, `Φᵀ A Φ` changes little as the body
//!   rotates, and the factor serves later steps unchanged (SOFA's
//!   `WarpPreconditioner` makes the same bet with a fine-level factor). It
//!   is prepared again, on the next step, after anything that changes `A`'s
//!   rest value: the settings, the material, the fixed nodes, a rebuild.
//!
//! Both parts are symmetric positive (semi)definite, so `P⁻¹` is a valid CG
//! preconditioner whatever the state; an approximate `A_c` only costs
//! iterations, never correctness.

use crate::element::rotation::{closest_rotation, IDENTITY};
use crate::element::ElementBlock;
use crate::math::{add, cross, dot, mat_vec, sqrt, sub, Mat3, Vec3};
use crate::pass::each_element;
use crate::storage::{Node, NodeWork, FIXED};

/// What [`NodeBlock::aggregate`] holds for a node in no aggregate (fixed).
const NONE: u32 = u32::MAX;

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

    /// A new aggregate: not turned.
    const FRESH: Self = Self {
        rot: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        q_step: IDENTITY,
        q: IDENTITY,
        ..Self::EMPTY
    };
}

impl Default for Aggregate {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// A 6×6 block of the coarse operator's Cholesky factor, row-major (144
/// bytes): opaque, named only to provide memory. A scene with `n`
/// aggregates uses `n²` of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoarseBlock {
    pub(crate) m: [f32; 36],
}

impl CoarseBlock {
    /// An unused slot.
    pub const EMPTY: Self = Self { m: [0.0; 36] };
}

impl Default for CoarseBlock {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Free nodes per aggregate that [`aggregates_for`] aims at on small
/// bodies: fewer nodes per aggregate keep reducing the error of a few
/// iterations on the report's scenes.
pub const NODES_PER_AGGREGATE: usize = 24;

/// The aggregates `VecStorage` has room for: the coarse solve costs
/// `(6 n)²` multiply-adds per CG iteration for `n` aggregates.
pub const MAX_AGGREGATES: usize = 64;

/// The number of aggregates the two-level preconditioner uses for a body of
/// `free_nodes` free nodes with room for `capacity`: one per
/// [`NODES_PER_AGGREGATE`] nodes, but at most `√(2 n / 3) + 1`, at least
/// one, at most `capacity`. The coarse solve costs `(6 a)²` per iteration
/// for `a` aggregates and the rest of an iteration `O(n)`: with `a ~ √n`,
/// the coarse solve's share of an iteration stays the same as bodies grow.
#[must_use]
pub const fn aggregates_for(free_nodes: usize, capacity: usize) -> usize {
    let n = free_nodes.div_ceil(NODES_PER_AGGREGATE);
    let root = (free_nodes.saturating_mul(2) / 3).isqrt() + 1;
    let n = if n < root { n } else { root };
    let n = if n == 0 { 1 } else { n };
    if n < capacity {
        n
    } else {
        capacity
    }
}

/// The coarse blocks the factor of `aggs` aggregates takes: the lower
/// block triangle of a symmetric `aggs × aggs` matrix of 6×6 blocks,
/// `aggs (aggs + 1) / 2`.
#[must_use]
pub const fn coarse_blocks_for(aggs: usize) -> usize {
    aggs.saturating_mul(aggs.saturating_add(1)) / 2
}

/// The slot of block `(i, j)`, `j ≤ i`, of the packed lower block triangle.
#[inline(always)]
const fn packed(i: usize, j: usize) -> usize {
    i * (i + 1) / 2 + j
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

/// `[p]×`, the matrix of `v ↦ p × v`.
fn skew(p: Vec3) -> Mat3 {
    [[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]]
}

fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    core::array::from_fn(|i| {
        core::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j])
    })
}

fn transpose(a: &Mat3) -> Mat3 {
    core::array::from_fn(|i| core::array::from_fn(|j| a[j][i]))
}

/// `Rᵀ v`.
fn mat_t_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

/// `s v` for a symmetric `s = [xx, yy, zz, xy, yz, zx]`.
#[inline(always)]
fn sym_vec(s: &[f32; 6], v: Vec3) -> Vec3 {
    [
        s[0] * v[0] + s[3] * v[1] + s[5] * v[2],
        s[3] * v[0] + s[1] * v[1] + s[4] * v[2],
        s[5] * v[0] + s[4] * v[1] + s[2] * v[2],
    ]
}

/// The inverse of the symmetric positive definite `s`, or `None` when its
/// determinant is not a positive normal number.
fn sym_inverse(s: &[f32; 6]) -> Option<[f32; 6]> {
    let [xx, yy, zz, xy, yz, zx] = *s;
    let cxx = yy * zz - yz * yz;
    let cyy = xx * zz - zx * zx;
    let czz = xx * yy - xy * xy;
    let cxy = zx * yz - xy * zz;
    let cyz = xy * zx - xx * yz;
    let czx = xy * yz - yy * zx;
    let det = xx * cxx + xy * cxy + zx * czx;
    if !(det >= f32::MIN_POSITIVE && det.is_finite()) {
        return None;
    }
    let inv = 1.0 / det;
    let out = [
        cxx * inv,
        cyy * inv,
        czz * inv,
        cxy * inv,
        cyz * inv,
        czx * inv,
    ];
    out.iter().all(|x| x.is_finite()).then_some(out)
}

/// Sets every node's `inv` to the inverse of its 3×3 block of
/// `A = mass_coef M + k_coef K` plus `extra(node)` on the diagonal (the tool's
/// spring); zero on fixed nodes. A block that cannot be inverted (not
/// reachable with a validated scene) falls back to the inverse of its
/// diagonal's mass part, or zero without one (a static solve's `A = K`).
#[allow(clippy::too_many_arguments)] // the step's state, passed apart so that each borrow stays narrow
pub(crate) fn node_blocks(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    nodes: &[Node],
    blocks: &mut [NodeBlock],
    mass_coef: f32,
    k_coef: f32,
    extra: impl Fn(&Node) -> f32,
) {
    for b in blocks.iter_mut() {
        b.inv = [0.0; 6];
    }
    each_element(per_young, elems, count, |n, g, [l, m]| {
        let lm = l + m;
        for (i, gi) in n.into_iter().zip(g) {
            if let Some(b) = blocks.get_mut(i) {
                let (x, y, z) = (gi[0], gi[1], gi[2]);
                let iso = m * dot(gi, gi);
                b.inv[0] += lm * x * x + iso;
                b.inv[1] += lm * y * y + iso;
                b.inv[2] += lm * z * z + iso;
                b.inv[3] += lm * x * y;
                b.inv[4] += lm * y * z;
                b.inv[5] += lm * z * x;
            }
        }
    });
    for (n, b) in nodes.iter().zip(blocks.iter_mut()) {
        if n.flags & FIXED != 0 {
            b.inv = [0.0; 6];
            continue;
        }
        let p = mass_coef * n.mass + extra(n);
        let mut s = b.inv.map(|x| k_coef * x);
        s[0] += p;
        s[1] += p;
        s[2] += p;
        let fallback = if p > 0.0 { 1.0 / p } else { 0.0 };
        b.inv = sym_inverse(&s).unwrap_or([fallback, fallback, fallback, 0.0, 0.0, 0.0]);
    }
}

/// Each aggregate's current rotation: the rotation closest to
/// `S₀ + Σ m u pᵀ = Σ m (x − c)(x₀ − c₀)ᵀ` (the `Σ m (x₀ − c₀) = 0` of the
/// rest centroid removes the centroid's own displacement).
pub(crate) fn rotations(nodes: &[Node], blocks: &[NodeBlock], aggs: &mut [Aggregate]) {
    for a in aggs.iter_mut() {
        a.apq = a.s0;
    }
    for (n, b) in nodes.iter().zip(blocks) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            let p = sub(n.x0, a.c0);
            for (row, uk) in a.apq.iter_mut().zip(n.u) {
                let mu = n.mass * uk;
                row[0] += mu * p[0];
                row[1] += mu * p[1];
                row[2] += mu * p[2];
            }
        }
    }
    for a in aggs.iter_mut() {
        let mut q = a.q;
        a.rot = closest_rotation(&a.apq, &mut q).0;
        a.q_step = q;
    }
}

/// Keeps the step's rotations as the warm start of the next one: called
/// once the step is applied.
pub(crate) fn commit_rotations(aggs: &mut [Aggregate]) {
    for a in aggs.iter_mut() {
        a.q = a.q_step;
    }
}

/// `z = S (D⁻¹ + Φ A_c⁻¹ Φᵀ) S r` into every `q` (two-level when `aggs` is
/// not empty, else block-Jacobi); returns `rᵀz` summed in node order.
/// `input(i, r)` gives what node `i` contributes in place of `S r` (its
/// filter, or a residual with the rigid part taken out), and
/// `project(i, v)` applies node `i`'s filter `S` to the output.
///
/// With aggregates, node blocks are held in their aggregate's frame
/// (`D = R_a D_local R_aᵀ`, prepared with the factor), so that both parts
/// work on `R_aᵀ S r` and one rotation brings their sum back:
/// `z = S R_a (D_local⁻¹ R_aᵀ S r + t + ω × p)`.
#[inline(always)]
pub(crate) fn apply(
    nodes: &[Node],
    work: &mut [NodeWork],
    p: &mut Parts<'_>,
    input: impl Fn(usize, Vec3) -> Vec3,
    project: impl Fn(usize, Vec3) -> Vec3,
) -> f32 {
    if p.aggs.is_empty() {
        let mut rz = 0.0f32;
        for (i, (w, b)) in work.iter_mut().zip(p.blocks.iter()).enumerate() {
            w.q = project(i, sym_vec(&b.inv, input(i, w.r)));
            rz += dot(w.r, w.q);
        }
        return rz;
    }
    for a in p.aggs.iter_mut() {
        a.y = [0.0; 6];
    }
    // Restriction y = Φᵀ S r, and the local smoother part into q.
    for (i, ((n, w), b)) in nodes
        .iter()
        .zip(work.iter_mut())
        .zip(p.blocks.iter())
        .enumerate()
    {
        w.q = [0.0; 3];
        if let Some(a) = p.aggs.get_mut(b.aggregate as usize) {
            let rl = mat_t_vec(&a.rot, input(i, w.r));
            w.q = sym_vec(&b.inv, rl);
            let m = cross(sub(n.x0, a.c0), rl);
            a.y = [
                a.y[0] + rl[0],
                a.y[1] + rl[1],
                a.y[2] + rl[2],
                a.y[3] + m[0],
                a.y[4] + m[1],
                a.y[5] + m[2],
            ];
        }
    }
    coarse_solve(p.aggs, p.coarse);
    // Prolongation, and rᵀz.
    let mut rz = 0.0f32;
    for (i, ((n, w), b)) in nodes
        .iter()
        .zip(work.iter_mut())
        .zip(p.blocks.iter())
        .enumerate()
    {
        if let Some(a) = p.aggs.get(b.aggregate as usize) {
            let t = [a.y[0], a.y[1], a.y[2]];
            let om = [a.y[3], a.y[4], a.y[5]];
            let local = add(add(w.q, t), cross(om, sub(n.x0, a.c0)));
            w.q = project(i, mat_vec(&a.rot, local));
        }
        rz += dot(w.r, w.q);
    }
    rz
}

/// `m v` for a row-major 6×6 `m`.
#[inline(always)]
fn mv6(m: &[f32; 36], v: &[f32; 6]) -> [f32; 6] {
    core::array::from_fn(|r| {
        let row = &m[r * 6..r * 6 + 6];
        row[0] * v[0]
            + row[1] * v[1]
            + row[2] * v[2]
            + row[3] * v[3]
            + row[4] * v[4]
            + row[5] * v[5]
    })
}

/// `mᵀ v` for a row-major 6×6 `m`.
#[inline(always)]
fn mtv6(m: &[f32; 36], v: &[f32; 6]) -> [f32; 6] {
    let mut out = [0.0f32; 6];
    for (row, vr) in m.chunks_exact(6).zip(v) {
        for (o, x) in out.iter_mut().zip(row) {
            *o += x * vr;
        }
    }
    out
}

/// `L⁻¹ v` for the lower triangle of `l`; an unknown with a zero pivot
/// (dropped) gets zero.
#[inline(always)]
fn lower_solve(l: &[f32; 36], mut v: [f32; 6]) -> [f32; 6] {
    for r in 0..6 {
        let mut s = v[r];
        for c in 0..r {
            s -= l[r * 6 + c] * v[c];
        }
        let d = l[r * 6 + r];
        v[r] = if d > 0.0 { s / d } else { 0.0 };
    }
    v
}

/// `L⁻ᵀ v` for the lower triangle of `l`, zero for dropped unknowns.
#[inline(always)]
fn lower_t_solve(l: &[f32; 36], mut v: [f32; 6]) -> [f32; 6] {
    for r in (0..6).rev() {
        let mut s = v[r];
        for c in r + 1..6 {
            s -= l[c * 6 + r] * v[c];
        }
        let d = l[r * 6 + r];
        v[r] = if d > 0.0 { s / d } else { 0.0 };
    }
    v
}

/// `y ← A_c⁻¹ y` with the block Cholesky factor `L` (packed lower block
/// triangle of `coarse`): forward substitution by block rows, then
/// backward substitution as updates by block rows (`y_j −= L_ijᵀ y_i`), so
/// that both read `L` in slot order.
fn coarse_solve(aggs: &mut [Aggregate], coarse: &[CoarseBlock]) {
    let n = aggs.len();
    for i in 0..n {
        let Some(row) = coarse.get(packed(i, 0)..packed(i, 0) + i + 1) else {
            return;
        };
        let Some((d, off)) = row.split_last() else {
            continue;
        };
        let mut s = aggs.get(i).map_or([0.0; 6], |a| a.y);
        for (l, a) in off.iter().zip(aggs.iter()) {
            let p = mv6(&l.m, &a.y);
            for (x, y) in s.iter_mut().zip(p) {
                *x -= y;
            }
        }
        if let Some(a) = aggs.get_mut(i) {
            a.y = lower_solve(&d.m, s);
        }
    }
    for i in (0..n).rev() {
        let Some(row) = coarse.get(packed(i, 0)..packed(i, 0) + i + 1) else {
            return;
        };
        let Some((d, off)) = row.split_last() else {
            continue;
        };
        let yi = match aggs.get_mut(i) {
            Some(a) => {
                a.y = lower_t_solve(&d.m, a.y);
                a.y
            }
            None => continue,
        };
        for (l, a) in off.iter().zip(aggs.iter_mut()) {
            let p = mtv6(&l.m, &yi);
            for (x, y) in a.y.iter_mut().zip(p) {
                *x -= y;
            }
        }
    }
}

/// Splits the free nodes into at most `aggs.len()` aggregates by recursive
/// coordinate bisection of their rest positions (ties broken by node index,
/// so the result does not depend on the sort), and computes each one's rest
/// centroid and second moment. Returns the number of aggregates used.
/// Deterministic: only comparisons and sums in node order.
pub(crate) fn aggregate(nodes: &[Node], blocks: &mut [NodeBlock], aggs: &mut [Aggregate]) -> usize {
    let len = nodes.len().min(blocks.len());
    let blocks = blocks.get_mut(..len).unwrap_or_default();
    let mut free = 0usize;
    for (i, b) in blocks.iter_mut().enumerate() {
        b.aggregate = NONE;
        b.order = i as u32;
    }
    // Free nodes first, in node order: swapping the order fields of slots
    // `free` and `i` (slot `i` still holds order `i` when it is reached).
    for (i, n) in nodes.iter().enumerate().take(len) {
        if n.flags & FIXED == 0 {
            let displaced = blocks.get(free).map_or(0, |b| b.order);
            if let Some(b) = blocks.get_mut(free) {
                b.order = i as u32;
            }
            if let Some(b) = blocks.get_mut(i) {
                b.order = displaced;
            }
            free += 1;
        }
    }
    // The swaps above keep free nodes in node order but scramble the rest;
    // only the free part matters.
    let count = aggregates_for(free, aggs.len());
    if free == 0 || count == 0 {
        return 0;
    }
    bisect(nodes, blocks.get_mut(..free).unwrap_or_default(), 0, count);
    // Back to node order: the order fields are a permutation.
    heap_sort(blocks, |a, b| a.order < b.order);
    let aggs = &mut aggs[..count];
    for a in aggs.iter_mut() {
        *a = Aggregate::FRESH;
    }
    // Centroids: Σ m x₀ / Σ m, in node order (the mass summed in `s0[0][0]`
    // until the division).
    for (n, b) in nodes.iter().zip(blocks.iter()) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            a.c0 = add(a.c0, n.x0.map(|x| x * n.mass));
            a.s0[0][0] += n.mass;
        }
    }
    for a in aggs.iter_mut() {
        let m = a.s0[0][0];
        a.c0 = if m > 0.0 {
            a.c0.map(|x| x / m)
        } else {
            [0.0; 3]
        };
        a.s0 = [[0.0; 3]; 3];
    }
    for (n, b) in nodes.iter().zip(blocks.iter()) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            let p = sub(n.x0, a.c0);
            for (row, pk) in a.s0.iter_mut().zip(p) {
                for (s, pj) in row.iter_mut().zip(p) {
                    *s += n.mass * pk * pj;
                }
            }
        }
    }
    count
}

/// Assigns aggregates `first .. first + parts` to `slots` (whose `order`
/// fields name nodes): splits at the median of the longest axis of their
/// bounding box, in proportion to the parts on each side.
fn bisect(nodes: &[Node], slots: &mut [NodeBlock], first: usize, parts: usize) {
    if parts <= 1 || slots.len() <= 1 {
        for s in slots.iter_mut() {
            s.aggregate = first as u32;
        }
        return;
    }
    let pos = |s: &NodeBlock| nodes.get(s.order as usize).map_or([0.0; 3], |n| n.x0);
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for s in slots.iter() {
        let p = pos(s);
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let ext = sub(hi, lo);
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let left = parts / 2;
    let mid = slots.len() * left / parts;
    // In 1 ..= len − 1 (len ≥ 2 here), written out: `clamp` asserts its
    // bounds, a panicking branch.
    let last = slots.len().saturating_sub(1);
    let mid = if mid < 1 {
        1
    } else if mid > last {
        last
    } else {
        mid
    };
    // The `mid` first slots in the order of the axis (ties by node index: a
    // total order, so the two sides are the same sets whatever the
    // algorithm). A full sort where a selection would do: it runs once per
    // preparation, and core's selection keeps panicking branches that a
    // firmware build must not link.
    let coord = |s: &NodeBlock| match (axis, pos(s)) {
        (0, [x, _, _]) => x,
        (1, [_, y, _]) => y,
        (_, [_, _, z]) => z,
    };
    heap_sort(slots, |a, b| {
        coord(a)
            .total_cmp(&coord(b))
            .then(a.order.cmp(&b.order))
            .is_lt()
    });
    let Some((l, r)) = slots.split_at_mut_checked(mid) else {
        return;
    };
    bisect(nodes, l, first, left);
    bisect(nodes, r, first + left, parts - left);
}

/// Sorts `s` by `less` (a strict order): heapsort, in place, `O(n log n)`,
/// every index checked by the loop conditions, so that no panicking branch
/// remains.
fn heap_sort(s: &mut [NodeBlock], less: impl Fn(&NodeBlock, &NodeBlock) -> bool) {
    // Moves `s[root]` down the heap of the first `end` slots.
    let sift = |s: &mut [NodeBlock], mut root: usize, end: usize| {
        let end = end.min(s.len());
        loop {
            let mut child = 2 * root + 1;
            if child >= end {
                break;
            }
            if let (Some(a), Some(b)) = (s.get(child), s.get(child + 1)) {
                if child + 1 < end && less(a, b) {
                    child += 1;
                }
            }
            match (s.get(root), s.get(child)) {
                (Some(r), Some(c)) if less(r, c) => {}
                _ => break,
            }
            if root < s.len() && child < s.len() {
                s.swap(root, child);
            }
            root = child;
        }
    };
    let n = s.len();
    for start in (0..n / 2).rev() {
        sift(s, start, n);
    }
    for end in (1..n).rev() {
        if end < s.len() {
            s.swap(0, end);
        }
        sift(s, 0, end);
    }
}

/// Prepares the two-level preconditioner at the current state: turns every
/// node block (`node_blocks`, world frame) into its aggregate's frame,
/// `D_local = R_aᵀ D R_a`, then assembles the Galerkin coarse operator
/// `Φᵀ A Φ` with the aggregates' rotations and the elements' gradients, and
/// factorises it (block Cholesky, in place). An unknown whose pivot falls
/// to round-off of its diagonal (the rotations of an aggregate of one node,
/// or of nodes on a line) is dropped: its column of the factor is zero.
pub(crate) fn factor(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    nodes: &[Node],
    p: &mut Parts<'_>,
    mass_coef: f32,
    k_coef: f32,
) {
    let n = p.aggs.len();
    let Some(coarse) = p.coarse.get_mut(..coarse_blocks_for(n)) else {
        return;
    };
    for b in coarse.iter_mut() {
        *b = CoarseBlock::EMPTY;
    }
    let aggs = &*p.aggs;
    for b in p.blocks.iter_mut() {
        if let Some(a) = aggs.get(b.aggregate as usize) {
            // D⁻¹ turns like D: (Rᵀ D R)⁻¹ = Rᵀ D⁻¹ R.
            let [xx, yy, zz, xy, yz, zx] = b.inv;
            let d = [[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]];
            let l = mat_mul(&transpose(&a.rot), &mat_mul(&d, &a.rot));
            b.inv = [l[0][0], l[1][1], l[2][2], l[0][1], l[1][2], l[2][0]];
        }
    }
    let blocks = &*p.blocks;
    // Node i's modes: Φᵢ = R [I, −[pᵢ]×].
    let frame = |i: usize| -> Option<(usize, Mat3, Mat3)> {
        let b = blocks.get(i)?;
        let a = aggs.get(b.aggregate as usize)?;
        let node = nodes.get(i)?;
        Some((b.aggregate as usize, a.rot, skew(sub(node.x0, a.c0))))
    };
    // Adds the 6×6 `[I; [pᵢ]×] L [I, −[p_j]×]` for L = Rᵢᵀ K_ij R_j to block
    // (aᵢ, a_j) of the lower block triangle (the upper one is its transpose).
    let mut add_block = |ai: usize, aj: usize, l: &Mat3, pi: &Mat3, pj: &Mat3| {
        if aj > ai {
            return;
        }
        let Some(blk) = coarse.get_mut(packed(ai, aj)) else {
            return;
        };
        let lp = mat_mul(l, pj); // L [p_j]×
        let pl = mat_mul(pi, l); // [pᵢ]× L
        let plp = mat_mul(pi, &lp); // [pᵢ]× L [p_j]×
        for r in 0..3 {
            for c in 0..3 {
                blk.m[r * 6 + c] += l[r][c];
                blk.m[r * 6 + 3 + c] -= lp[r][c];
                blk.m[(3 + r) * 6 + c] += pl[r][c];
                blk.m[(3 + r) * 6 + 3 + c] -= plp[r][c];
            }
        }
    };
    each_element(per_young, elems, count, |ids, g, [l, m]| {
        let f: [Option<(usize, Mat3, Mat3)>; 4] = ids.map(frame);
        for (i, fi) in f.iter().enumerate() {
            let Some((ai, ri, pi)) = fi else { continue };
            for (j, fj) in f.iter().enumerate() {
                let Some((aj, rj, pj)) = fj else { continue };
                if aj > ai {
                    continue;
                }
                let (gi, gj) = (g[i], g[j]);
                let gg = m * dot(gi, gj);
                let k: Mat3 = core::array::from_fn(|r| {
                    core::array::from_fn(|c| {
                        k_coef
                            * (l * gi[r] * gj[c]
                                + m * gj[r] * gi[c]
                                + if r == c { gg } else { 0.0 })
                    })
                });
                let lmat = mat_mul(&transpose(ri), &mat_mul(&k, rj));
                add_block(*ai, *aj, &lmat, pi, pj);
            }
        }
    });
    // Mass: (1 + h α_M) m Φᵢᵀ Φᵢ = c m [I, −[p]×; [p]×, −[p]×[p]×].
    for (i, node) in nodes.iter().enumerate() {
        if let Some((a, _, pi)) = frame(i) {
            let eye: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            let cm = mass_coef * node.mass;
            let l = eye.map(|row| row.map(|x| x * cm));
            add_block(a, a, &l, &pi, &pi);
        }
    }
    cholesky(coarse, n);
}

/// `a −= b cᵀ` for row-major 6×6 blocks.
fn sub_abt(a: &mut [f32; 36], b: &[f32; 36], c: &[f32; 36]) {
    for (r, arow) in a.chunks_exact_mut(6).enumerate() {
        let brow = &b[r * 6..r * 6 + 6];
        for (x, crow) in arow.iter_mut().zip(c.chunks_exact(6)) {
            *x -= brow[0] * crow[0]
                + brow[1] * crow[1]
                + brow[2] * crow[2]
                + brow[3] * crow[3]
                + brow[4] * crow[4]
                + brow[5] * crow[5];
        }
    }
}

/// In-place block Cholesky of the symmetric matrix of `n × n` 6×6 blocks
/// whose lower block triangle `coarse` holds (`A = L Lᵀ`, right-looking by
/// block columns). Inside a diagonal block, a pivot at or below
/// `6 n · ε` of its original diagonal drops its unknown: its column of `L`
/// is zero, and the solves give it zero.
fn cholesky(coarse: &mut [CoarseBlock], n: usize) {
    let floor = (6 * n) as f32 * f32::EPSILON;
    for j in 0..n {
        // Diagonal block: A_jj − Σ_k L_jk L_jkᵀ, then its own Cholesky.
        let Some(mut d) = coarse.get(packed(j, j)).map(|b| b.m) else {
            return;
        };
        let orig: [f32; 6] = core::array::from_fn(|r| d[r * 6 + r]);
        for k in 0..j {
            if let Some(l) = coarse.get(packed(j, k)).map(|b| b.m) {
                sub_abt(&mut d, &l, &l);
            }
        }
        for c in 0..6 {
            let mut dc = d[c * 6 + c];
            for k in 0..c {
                dc -= d[c * 6 + k] * d[c * 6 + k];
            }
            let ok = dc > orig[c].abs() * floor && dc.is_finite();
            let ljj = if ok { sqrt(dc) } else { 0.0 };
            d[c * 6 + c] = ljj;
            for r in c + 1..6 {
                let mut s = d[r * 6 + c];
                for k in 0..c {
                    s -= d[r * 6 + k] * d[c * 6 + k];
                }
                d[r * 6 + c] = if ok { s / ljj } else { 0.0 };
            }
            // The upper triangle is not read: clear it.
            for r in 0..c {
                d[r * 6 + c] = 0.0;
            }
        }
        if let Some(b) = coarse.get_mut(packed(j, j)) {
            b.m = d;
        }
        // Off-diagonal blocks below: L_ij = (A_ij − Σ_k L_ik L_jkᵀ) L_jj⁻ᵀ.
        for i in j + 1..n {
            let Some(mut b) = coarse.get(packed(i, j)).map(|b| b.m) else {
                return;
            };
            for k in 0..j {
                if let (Some(lik), Some(ljk)) = (
                    coarse.get(packed(i, k)).map(|b| b.m),
                    coarse.get(packed(j, k)).map(|b| b.m),
                ) {
                    sub_abt(&mut b, &lik, &ljk);
                }
            }
            // Each row x of L_ij solves L_jj xᵀ = bᵀ.
            for r in 0..6 {
                let row: [f32; 6] = core::array::from_fn(|c| b[r * 6 + c]);
                for (c, x) in lower_solve(&d, row).into_iter().enumerate() {
                    b[r * 6 + c] = x;
                }
            }
            if let Some(slot) = coarse.get_mut(packed(i, j)) {
                slot.m = b;
            }
        }
    }
}

#[cfg(test)]
// The dense f64 reference reads as the textbook algorithm, with indices.
#[allow(clippy::needless_range_loop)]
mod tests {
    extern crate std;
    use super::*;

    /// A symmetric positive definite `6n × 6n` matrix `BᵀB + 6n I` from a
    /// fixed pseudo-random `B` (entries in [−1, 1]): condition number of a
    /// few tens.
    fn spd(n: usize, seed: u32) -> std::vec::Vec<std::vec::Vec<f64>> {
        let dim = 6 * n;
        let mut state = seed;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            f64::from(state >> 8) / f64::from(1u32 << 23) - 1.0
        };
        let b: std::vec::Vec<std::vec::Vec<f64>> = (0..dim)
            .map(|_| (0..dim).map(|_| next()).collect())
            .collect();
        (0..dim)
            .map(|i| {
                (0..dim)
                    .map(|j| {
                        let bb: f64 = (0..dim).map(|k| b[k][i] * b[k][j]).sum();
                        bb + if i == j { dim as f64 } else { 0.0 }
                    })
                    .collect()
            })
            .collect()
    }

    /// Packs the lower block triangle of `a` into coarse blocks.
    fn pack(a: &[std::vec::Vec<f64>], n: usize) -> std::vec::Vec<CoarseBlock> {
        let mut c = std::vec![CoarseBlock::EMPTY; coarse_blocks_for(n)];
        for bi in 0..n {
            for bj in 0..=bi {
                for r in 0..6 {
                    for k in 0..6 {
                        c[packed(bi, bj)].m[r * 6 + k] = a[bi * 6 + r][bj * 6 + k] as f32;
                    }
                }
            }
        }
        c
    }

    /// `A x = y` by Gaussian elimination in f64 (the reference).
    fn dense_solve(a: &[std::vec::Vec<f64>], y: &[f64]) -> std::vec::Vec<f64> {
        let dim = y.len();
        let mut m: std::vec::Vec<std::vec::Vec<f64>> = a.to_vec();
        let mut x = y.to_vec();
        for c in 0..dim {
            for r in c + 1..dim {
                let f = m[r][c] / m[c][c];
                for k in c..dim {
                    m[r][k] -= f * m[c][k];
                }
                x[r] -= f * x[c];
            }
        }
        for c in (0..dim).rev() {
            let s: f64 = (c + 1..dim).map(|k| m[c][k] * x[k]).sum();
            x[c] = (x[c] - s) / m[c][c];
        }
        x
    }

    fn solve_with_factor(a: &[std::vec::Vec<f64>], n: usize, y: &[f64]) -> std::vec::Vec<f64> {
        let mut coarse = pack(a, n);
        cholesky(&mut coarse, n);
        let mut aggs = std::vec![Aggregate::EMPTY; n];
        for (k, v) in y.iter().enumerate() {
            aggs[k / 6].y[k % 6] = *v as f32;
        }
        coarse_solve(&mut aggs, &coarse);
        (0..6 * n)
            .map(|k| f64::from(aggs[k / 6].y[k % 6]))
            .collect()
    }

    #[test]
    fn block_cholesky_solves_like_a_dense_f64_solve() {
        for n in [1, 2, 5] {
            let a = spd(n, 7 + n as u32);
            let y: std::vec::Vec<f64> = (0..6 * n).map(|k| ((k * 37) % 11) as f64 - 5.0).collect();
            let exact = dense_solve(&a, &y);
            let got = solve_with_factor(&a, n, &y);
            let norm = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
            let err = exact
                .iter()
                .zip(&got)
                .map(|(e, g)| (e - g) * (e - g))
                .sum::<f64>()
                .sqrt();
            // f32 factor and solves of a matrix with condition number of a
            // few tens: relative error ~ κ · dim · ε ≈ 30 · 30 · 6e-8 ≈ 5e-5.
            assert!(
                err <= 1.0e-4 * norm,
                "n = {n}: relative error {}",
                err / norm
            );
        }
    }

    #[test]
    fn a_dropped_unknown_gets_zero_and_the_rest_is_solved() {
        let n = 2;
        let mut a = spd(n, 3);
        // Unknown 4 (a rotation of aggregate 0) has no stiffness at all.
        let dropped = 4;
        for k in 0..6 * n {
            a[dropped][k] = 0.0;
            a[k][dropped] = 0.0;
        }
        let y: std::vec::Vec<f64> = (0..6 * n).map(|k| (k % 5) as f64 - 2.0).collect();
        let got = solve_with_factor(&a, n, &y);
        assert_eq!(got[dropped], 0.0);
        // The reduced system without the dropped unknown.
        let keep: std::vec::Vec<usize> = (0..6 * n).filter(|&k| k != dropped).collect();
        let ar: std::vec::Vec<std::vec::Vec<f64>> = keep
            .iter()
            .map(|&i| keep.iter().map(|&j| a[i][j]).collect())
            .collect();
        let yr: std::vec::Vec<f64> = keep.iter().map(|&k| y[k]).collect();
        let exact = dense_solve(&ar, &yr);
        let norm = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
        let err = keep
            .iter()
            .zip(&exact)
            .map(|(&k, e)| (e - got[k]) * (e - got[k]))
            .sum::<f64>()
            .sqrt();
        // As above.
        assert!(err <= 1.0e-4 * norm, "relative error {}", err / norm);
    }

    #[test]
    fn slot_sizes_are_as_documented() {
        assert_eq!(core::mem::size_of::<NodeBlock>(), 32);
        assert_eq!(core::mem::size_of::<Aggregate>(), 176);
        assert_eq!(core::mem::size_of::<CoarseBlock>(), 144);
    }
}
