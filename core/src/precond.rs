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
//!   (the rest shape, usually), inverted once (Cholesky, the inverse of the
//!   factor, its Gram matrix), so that each solve is one product by a dense
//!   symmetric matrix whose rows a vector unit runs through eight entries at
//!   a time. Because `Φ` turns with the aggregates, `Φᵀ A Φ` changes little
//!   as the body rotates, and the inverse serves later steps unchanged
//!   (SOFA's `WarpPreconditioner` makes the same bet with a fine-level
//!   factor). It is prepared again, on the next step, after anything that
//!   changes `A`'s rest value: the settings, the material, the fixed nodes,
//!   a rebuild.
//!
//! Both parts are symmetric positive (semi)definite, so `P⁻¹` is a valid CG
//! preconditioner whatever the state; an approximate `A_c` only costs
//! iterations, never correctness.

use crate::element::rotation::{closest_rotation, IDENTITY};
use crate::element::ElementBlock;
use crate::math::{add, cross, dot, mat_vec, sqrt, sub, Mat3, Vec3};
use crate::pass::each_element;
pub use crate::slots::{
    aggregates_for, coarse_blocks_for, Aggregate, CoarseBlock, NodeBlock, MAX_AGGREGATES,
    NODES_PER_AGGREGATE,
};
pub(crate) use crate::slots::{stride, Parts, CHUNK, NONE};
use crate::storage::{Node, NodeWork, FIXED};

/// Rounds of seeding and growth (`grow`): each round moves every seed to
/// the node nearest its aggregate's centroid (Lloyd's algorithm, on the
/// mesh), which evens out the aggregates the first round leaves.
const LLOYD_ROUNDS: usize = 3;

/// A new aggregate: not turned.
const FRESH: Aggregate = Aggregate {
    rot: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    q_step: IDENTITY,
    q: IDENTITY,
    ..Aggregate::EMPTY
};

/// Makes the preconditioner's data current for this step and returns the
/// preconditioner to use: the node blocks of `A`, the aggregates' rotations,
/// and, after anything that changed `A`'s rest value, the aggregates and
/// the coarse factor. `Mass` when the storage has no room for the one the
/// settings ask for (`Scene::set_settings` refuses that, so only a scene
/// whose defaults were never written reaches it).
#[allow(clippy::too_many_arguments)]
pub(crate) fn prepare(
    hdr: &mut crate::state::Header,
    per_young: [f32; 2],
    nodes: &[Node],
    elems: &[crate::element::ElementBlock],
    n_elems: usize,
    pre: &mut Parts<'_>,
    mass_coef: f32,
    k_coef: f32,
) -> crate::Preconditioner {
    let mut kind = hdr.settings.preconditioner;
    if kind == crate::Preconditioner::Mass || pre.blocks.len() != nodes.len() {
        return crate::Preconditioner::Mass;
    }
    let spring = hdr.spring();
    let h = hdr.settings.dt;
    let two_level = kind == crate::Preconditioner::TwoLevel;
    // The aggregation first: it moves the node slots around.
    if two_level && !hdr.coarse_ready {
        hdr.n_aggs = aggregate(per_young, elems, n_elems, nodes, pre.blocks, pre.aggs);
    }
    // The aggregates in use (none for block-Jacobi): what `apply`
    // works with.
    let n = pre.keep(if two_level { hdr.n_aggs } else { 0 });
    if n > 0 {
        rotations(nodes, pre.blocks, pre.aggs);
    } else {
        kind = crate::Preconditioner::BlockJacobi;
    }
    // Block-Jacobi's node blocks follow the state every step (with the
    // tool's spring); the two-level ones are prepared with the factor, in
    // their aggregate's frame, and turn with it.
    if n == 0 || !hdr.coarse_ready {
        node_blocks(
            per_young,
            elems,
            n_elems,
            nodes,
            pre.blocks,
            mass_coef,
            k_coef,
            |node| {
                if n == 0 && spring.holds(node) {
                    h * h * spring.k()
                } else {
                    0.0
                }
            },
        );
    }
    if n > 0 && !hdr.coarse_ready {
        factor(per_young, elems, n_elems, nodes, pre, mass_coef, k_coef);
    }
    hdr.coarse_ready = true;
    kind
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
/// not empty, else block-Jacobi); returns `(S r)ᵀz` summed in node order.
/// `project(i, v)` applies node `i`'s filter `S`, to the residual and to
/// the output; `input(i, S r)` gives what node `i` contributes in place of
/// `S r` (itself, or with the rigid part taken out).
///
/// `(S r)ᵀz`, not `rᵀz`: a held node's contact impulse in `r` would meet
/// `z`'s rounding there (`cg`'s module docs).
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
            let rf = project(i, w.r);
            w.q = project(i, sym_vec(&b.inv, input(i, rf)));
            rz += dot(rf, w.q);
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
            let rl = mat_t_vec(&a.rot, input(i, project(i, w.r)));
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
        rz += dot(project(i, w.r), w.q);
    }
    rz
}

/// Adds `Σ_k a_k b_k` over whole blocks into eight partial sums, one per
/// lane, each summed in block order: the same operations on every target,
/// which a vector unit runs side by side.
#[inline(always)]
fn lanes_dot(acc: &mut [f32; CHUNK], a: &[CoarseBlock], b: &[CoarseBlock]) {
    for (x, y) in a.iter().zip(b) {
        // Indices, not zipped lanes: the form LLVM is surest to keep in
        // whole vector registers.
        #[allow(clippy::needless_range_loop)]
        for l in 0..CHUNK {
            acc[l] += x.m[l] * y.m[l];
        }
    }
}

/// The sum of the partial sums, lane after lane. (A tree of pairs would be
/// shorter, but LLVM then splits the sums of `lanes_dot` into pairs.)
#[inline(always)]
fn lanes_sum(a: [f32; CHUNK]) -> f32 {
    a.iter().fold(0.0, |s, x| s + x)
}

/// `z += s x` over whole blocks (lanes independent).
#[inline(always)]
fn axpy_blocks(z: &mut [CoarseBlock], s: f32, x: &[CoarseBlock]) {
    for (zb, xb) in z.iter_mut().zip(x) {
        #[allow(clippy::needless_range_loop)] // as in `lanes_dot`
        for l in 0..CHUNK {
            zb.m[l] += s * xb.m[l];
        }
    }
}

/// Row `r` of a matrix of rows of `stride` blocks.
#[inline(always)]
fn row(mat: &[CoarseBlock], stride: usize, r: usize) -> &[CoarseBlock] {
    let start = r.saturating_mul(stride);
    mat.get(start..start.saturating_add(stride))
        .unwrap_or_default()
}

/// Row `r` of a matrix of rows of `stride` blocks, to write.
#[inline(always)]
fn row_mut(mat: &mut [CoarseBlock], stride: usize, r: usize) -> &mut [CoarseBlock] {
    let start = r.saturating_mul(stride);
    mat.get_mut(start..start.saturating_add(stride))
        .unwrap_or_default()
}

/// The blocks of a row up to and including column `c`.
#[inline(always)]
fn upto(row: &[CoarseBlock], c: usize) -> &[CoarseBlock] {
    row.get(..c / CHUNK + 1).unwrap_or(row)
}

/// Entry `k` of a row of blocks (0 past its end).
#[inline(always)]
fn get(v: &[CoarseBlock], k: usize) -> f32 {
    v.get(k / CHUNK)
        .and_then(|b| b.m.get(k % CHUNK))
        .copied()
        .unwrap_or(0.0)
}

/// Entry `k` of a row of blocks, to write.
#[inline(always)]
fn get_mut(v: &mut [CoarseBlock], k: usize) -> Option<&mut f32> {
    v.get_mut(k / CHUNK)?.m.get_mut(k % CHUNK)
}

/// `y ← A_c⁻¹ y = Σ_j y_j S_j` with the rows `S_j` of the inverse
/// (`factor`), into the vector after the matrix, then back: updates whose
/// lanes are independent, six rows (an aggregate's) per pass over the
/// vector, each lane summed in row order. (Triangular solves with the
/// Cholesky factor do as much arithmetic, but each unknown waits for the
/// ones before it.)
#[inline(always)]
fn coarse_solve(aggs: &mut [Aggregate], coarse: &mut [CoarseBlock]) {
    let dim = aggs.len() * 6;
    let st = stride(dim);
    let Some((mat, rest)) = coarse.split_at_mut_checked(dim * st) else {
        return;
    };
    let z = rest.get_mut(..st).unwrap_or_default();
    for b in z.iter_mut() {
        *b = CoarseBlock::EMPTY;
    }
    // The rows zipped with the vector's blocks: no bounds check in the
    // inner loop.
    let mut rows = mat
        .chunks_exact(st.max(1))
        .zip(aggs.iter().flat_map(|a| a.y));
    loop {
        let mut next = || rows.next();
        let (Some((r0, y0)), Some((r1, y1)), Some((r2, y2))) = (next(), next(), next()) else {
            break;
        };
        let (Some((r3, y3)), Some((r4, y4)), Some((r5, y5))) = (next(), next(), next()) else {
            break;
        };
        let lanes = z.iter_mut().zip(r0).zip(r1).zip(r2).zip(r3).zip(r4).zip(r5);
        for ((((((zb, x0), x1), x2), x3), x4), x5) in lanes {
            let mut acc = zb.m;
            #[allow(clippy::needless_range_loop)] // as in `lanes_dot`
            for l in 0..CHUNK {
                acc[l] += y0 * x0.m[l];
                acc[l] += y1 * x1.m[l];
                acc[l] += y2 * x2.m[l];
                acc[l] += y3 * x3.m[l];
                acc[l] += y4 * x4.m[l];
                acc[l] += y5 * x5.m[l];
            }
            zb.m = acc;
        }
    }
    for (k, a) in aggs.iter_mut().enumerate() {
        for (r, y) in a.y.iter_mut().enumerate() {
            *y = get(z, 6 * k + r);
        }
    }
}

/// Splits the free nodes into at most `aggs.len()` aggregates: recursive
/// coordinate bisection of their rest positions (ties broken by node index,
/// so the result does not depend on the sort) places one seed per part,
/// and the seeds grow over the mesh into connected aggregates (`grow`).
/// Computes each one's rest centroid and second moment; returns the number
/// of aggregates used. Deterministic: only comparisons and sums in node
/// order.
pub(crate) fn aggregate(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    elems_count: usize,
    nodes: &[Node],
    blocks: &mut [NodeBlock],
    aggs: &mut [Aggregate],
) -> usize {
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
        *a = FRESH;
    }
    moments(nodes, blocks, aggs);
    for _ in 0..LLOYD_ROUNDS {
        grow(per_young, elems, elems_count, nodes, blocks, aggs);
        moments(nodes, blocks, aggs);
    }
    count
}

/// Each aggregate's mass-weighted rest centroid `c₀` and second moment
/// `S₀ = Σ m (x₀ − c₀)(x₀ − c₀)ᵀ`, summed in node order.
fn moments(nodes: &[Node], blocks: &[NodeBlock], aggs: &mut [Aggregate]) {
    // The mass is summed in `s0[0][0]` until the division.
    for a in aggs.iter_mut() {
        a.c0 = [0.0; 3];
        a.s0 = [[0.0; 3]; 3];
    }
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
}

/// Makes every aggregate connected: keeps, of each part the bisection cut,
/// only the node nearest its centroid (the first in node order among equals)
/// as a seed, then grows the seeds over the mesh, one ring of elements per
/// round, each free node joining the lowest-numbered aggregate among its
/// labelled neighbours. A part of a non-convex body (two ears) is not one
/// rigid piece, and a coarse mode that moves both as one serves neither.
/// Free nodes no seed reaches (another piece of mesh, joined only through
/// fixed nodes) join the nearest seed. Deterministic: comparisons, and
/// minima that do not depend on the order of the elements.
fn grow(
    per_young: [f32; 2],
    elems: &[ElementBlock],
    count: usize,
    nodes: &[Node],
    blocks: &mut [NodeBlock],
    aggs: &mut [Aggregate],
) {
    // Scratch: `apq[0][0]` the nearest squared distance to the centroid,
    // `apq[1]` the seed's position (both rebuilt every step by `rotations`).
    for a in aggs.iter_mut() {
        a.apq[0][0] = f32::INFINITY;
    }
    let dist = |n: &Node, c: Vec3| dot(sub(n.x0, c), sub(n.x0, c));
    for (n, b) in nodes.iter().zip(blocks.iter()) {
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            a.apq[0][0] = a.apq[0][0].min(dist(n, a.c0));
        }
    }
    for (n, b) in nodes.iter().zip(blocks.iter_mut()) {
        b.order = NONE;
        if let Some(a) = aggs.get_mut(b.aggregate as usize) {
            if dist(n, a.c0) == a.apq[0][0] {
                b.order = b.aggregate;
                a.apq[1] = n.x0;
                // No distance is below zero: no other seed.
                a.apq[0][0] = -1.0;
            }
        }
    }
    let free = |i: usize| nodes.get(i).is_some_and(|n| n.flags & FIXED == 0);
    // Rounds: each labels at least one node, or is the last.
    for _ in 0..blocks.len() {
        for b in blocks.iter_mut() {
            b.aggregate = b.order;
        }
        each_element(per_young, elems, count, |ids, _, _| {
            for i in ids {
                if !free(i) || blocks.get(i).is_none_or(|b| b.aggregate != NONE) {
                    continue;
                }
                let Some(x) = nodes.get(i) else { continue };
                // The nearest seed among the labelled neighbours (then the
                // lowest label): ties of ring counts are common, and the
                // lowest label alone would starve the higher ones.
                let key = |label: u32| {
                    aggs.get(label as usize)
                        .map_or((f32::INFINITY, label), |a| (dist(x, a.apq[1]), label))
                };
                for j in ids {
                    let label = blocks.get(j).map_or(NONE, |b| b.aggregate);
                    if let Some(b) = blocks.get_mut(i) {
                        let (new, old) = (key(label), key(b.order));
                        if new.0 < old.0 || (new.0 == old.0 && new.1 < old.1) {
                            b.order = label;
                        }
                    }
                }
            }
        });
        if blocks.iter().all(|b| b.order == b.aggregate) {
            break;
        }
    }
    for (i, (n, b)) in nodes.iter().zip(blocks.iter_mut()).enumerate() {
        if b.aggregate == NONE && free(i) {
            let mut best = (f32::INFINITY, 0);
            for (k, a) in aggs.iter().enumerate() {
                let d = dist(n, a.apq[1]);
                if d < best.0 {
                    best = (d, k);
                }
            }
            b.aggregate = best.1 as u32;
        }
        b.order = i as u32;
    }
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
/// inverts it in place: `A_c = L Lᵀ` (`cholesky`), `W = L⁻¹` (`invert`),
/// `A_c⁻¹ = Wᵀ W` (`gram`), each `O(dim³)` at `dim = 6 n`. An unknown whose
/// pivot falls to round-off of its diagonal (the rotations of an aggregate
/// of one node, or of nodes on a line) is dropped: its row and column of
/// the inverse are zero.
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
    let dim = 6 * n;
    let st = stride(dim);
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
        let lp = mat_mul(l, pj); // L [p_j]×
        let pl = mat_mul(pi, l); // [pᵢ]× L
        let plp = mat_mul(pi, &lp); // [pᵢ]× L [p_j]×
                                    // Entry (r, c) of the block, on or below the diagonal of the matrix.
        let mut add = |r: usize, c: usize, x: f32| {
            let (i, j) = (6 * ai + r, 6 * aj + c);
            if j <= i {
                if let Some(e) = get_mut(row_mut(coarse, st, i), j) {
                    *e += x;
                }
            }
        };
        for r in 0..3 {
            for c in 0..3 {
                add(r, c, l[r][c]);
                add(r, 3 + c, -lp[r][c]);
                add(3 + r, c, pl[r][c]);
                add(3 + r, 3 + c, -plp[r][c]);
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
    let (mat, tmp) = coarse.split_at_mut((dim * st).min(coarse.len()));
    cholesky(mat, dim);
    invert(mat, tmp, dim);
    gram(mat, tmp, dim);
}

/// In-place Cholesky factorisation `A = L Lᵀ` of the symmetric matrix of
/// dimension `dim` whose lower triangle `mat` holds, row by row
/// (Cholesky–Banachiewicz: `L_ij = (A_ij − Σ_{k<j} L_ik L_jk) / L_jj`, each
/// sum over two row prefixes in lanes). A pivot at or below `dim · ε` of its
/// original diagonal drops its unknown: its column of `L` is zero.
fn cholesky(mat: &mut [CoarseBlock], dim: usize) {
    let st = stride(dim);
    let floor = dim as f32 * f32::EPSILON;
    for i in 0..dim {
        let (above, rest) = mat.split_at_mut((i * st).min(mat.len()));
        let ri = row_mut(rest, st, 0);
        for j in 0..=i {
            // Σ_{k<j} L_ik L_jk: whole blocks, then the lanes of the last.
            let rj = if j < i { row(above, st, j) } else { &*ri };
            let whole = j / CHUNK;
            let mut acc = [0.0; CHUNK];
            lanes_dot(
                &mut acc,
                ri.get(..whole).unwrap_or_default(),
                rj.get(..whole).unwrap_or_default(),
            );
            if let (Some(x), Some(y)) = (ri.get(whole), rj.get(whole)) {
                for ((s, p), q) in acc.iter_mut().zip(x.m).zip(y.m).take(j % CHUNK) {
                    *s += p * q;
                }
            }
            let a = get(ri, j);
            let s = a - lanes_sum(acc);
            let l = if j == i {
                let ok = s > a.abs() * floor && s.is_finite();
                if ok {
                    sqrt(s)
                } else {
                    0.0
                }
            } else {
                let d = get(rj, j);
                if d > 0.0 {
                    s / d
                } else {
                    0.0
                }
            };
            if let Some(x) = get_mut(ri, j) {
                *x = l;
            }
        }
    }
}

/// Replaces the factor `L` in `mat` by `W = L⁻¹`, in place, row by row:
/// row `i` of `L W = I` gives `Wᵢ = (eᵢ − Σ_{k<i} L_ik W_k) / L_ii`, the
/// sum an update by the rows above, in the row `tmp`. A dropped unknown
/// (`L_ii = 0`) gets a zero row; its column is zero already. Entries past
/// the diagonal stay zero.
fn invert(mat: &mut [CoarseBlock], tmp: &mut [CoarseBlock], dim: usize) {
    let st = stride(dim);
    for i in 0..dim {
        let (above, rest) = mat.split_at_mut((i * st).min(mat.len()));
        let ri = row_mut(rest, st, 0);
        let t = tmp.get_mut(..i / CHUNK + 1).unwrap_or_default();
        for b in t.iter_mut() {
            *b = CoarseBlock::EMPTY;
        }
        for k in 0..i {
            axpy_blocks(t, get(ri, k), upto(row(above, st, k), k));
        }
        let d = get(ri, i);
        let inv = if d > 0.0 { 1.0 / d } else { 0.0 };
        for (k, (b, tb)) in ri.iter_mut().zip(t.iter()).enumerate() {
            for (l, (x, s)) in b.m.iter_mut().zip(tb.m).enumerate() {
                let j = k * CHUNK + l;
                *x = if d > 0.0 && j < i {
                    -s * inv
                } else if j == i {
                    inv
                } else {
                    0.0
                };
            }
        }
    }
}

/// Replaces `W` (lower triangular, in `mat`) by the whole symmetric
/// `S = Wᵀ W = A⁻¹`, in place: row `i`'s lower part
/// `S_i,≤i = Σ_{k≥i} W_ki W_k,≤i` (an update by the rows below, in the row
/// `tmp`) needs only rows `k ≥ i` of `W`, so rows are replaced in order;
/// then the upper part is mirrored.
fn gram(mat: &mut [CoarseBlock], tmp: &mut [CoarseBlock], dim: usize) {
    let st = stride(dim);
    for i in 0..dim {
        let t = tmp.get_mut(..i / CHUNK + 1).unwrap_or_default();
        for b in t.iter_mut() {
            *b = CoarseBlock::EMPTY;
        }
        for k in i..dim {
            let rk = row(mat, st, k);
            axpy_blocks(t, get(rk, i), upto(rk, i));
        }
        let ri = row_mut(mat, st, i);
        for (k, (b, tb)) in ri.iter_mut().zip(t.iter()).enumerate() {
            for (l, (x, s)) in b.m.iter_mut().zip(tb.m).enumerate() {
                *x = if k * CHUNK + l <= i { s } else { 0.0 };
            }
        }
    }
    for i in 0..dim {
        for j in 0..i {
            let s = get(row(mat, st, i), j);
            if let Some(x) = get_mut(row_mut(mat, st, j), i) {
                *x = s;
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
    /// fixed pseudo-random `B` (entries in [−1, 1], variance 1/3): `BᵀB`
    /// has eigenvalues up to about `4 · 6n / 3` (Marchenko–Pastur), so the
    /// condition number is below 2.5.
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

    /// The lower triangle of `a` in coarse blocks, rows padded.
    fn pack(a: &[std::vec::Vec<f64>], n: usize) -> std::vec::Vec<CoarseBlock> {
        let mut c = std::vec![CoarseBlock::EMPTY; coarse_blocks_for(n)];
        for i in 0..6 * n {
            for j in 0..=i {
                let st = stride(6 * n);
                c[i * st + j / CHUNK].m[j % CHUNK] = a[i][j] as f32;
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
        let (mat, tmp) = coarse.split_at_mut(6 * n * stride(6 * n));
        cholesky(mat, 6 * n);
        invert(mat, tmp, 6 * n);
        gram(mat, tmp, 6 * n);
        let mut aggs = std::vec![Aggregate::EMPTY; n];
        for (k, v) in y.iter().enumerate() {
            aggs[k / 6].y[k % 6] = *v as f32;
        }
        coarse_solve(&mut aggs, &mut coarse);
        (0..6 * n)
            .map(|k| f64::from(aggs[k / 6].y[k % 6]))
            .collect()
    }

    #[test]
    fn the_inverse_factor_solves_like_a_dense_f64_solve() {
        for n in [1, 2, 5, 11] {
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
            // f32 factor, inverse and products of a matrix with condition
            // number below 2.5 (`spd`): relative error ~ κ · dim · ε ≈
            // 2.5 · 66 · 6e-8 ≈ 1e-5; the bound leaves room for the constant.
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
        assert_eq!(core::mem::size_of::<CoarseBlock>(), 32);
    }
}
