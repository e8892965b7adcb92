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
//!
//! The step sees one interface: [`prepare`] makes the data current and says
//! which preconditioner runs, [`whole`] is what CG applies, and
//! [`commit_rotations`] keeps the aggregates' rotations of a step that was
//! applied. Behind it: the node blocks ([`jacobi`]), the aggregates
//! ([`aggregate`](mod@aggregate)) and the coarse space ([`coarse`]); the
//! slot types a storage provides are in `crate::slots`, below the storages.

use crate::backend::isa_inline;
use crate::element::rotation::{closest_rotation, IDENTITY};
use crate::element::ElementBlock;
use crate::math::{add, cross, dot, mat_vec, sqrt, sub, Mat3, Vec3};
use crate::pass::each_element;
use crate::rigid::Rigid;
pub(crate) use crate::slots::{
    aggregates_for, coarse_blocks_for, Aggregate, CoarseBlock, NodeBlock,
};
pub(crate) use crate::slots::{stride, Parts, CHUNK, NONE};
use crate::storage::{Node, NodeWork, FIXED};

mod aggregate;
mod coarse;
mod jacobi;

pub(crate) use aggregate::aggregate;
pub(crate) use coarse::factor;
use coarse::*;
pub(crate) use jacobi::node_blocks;
use jacobi::*;

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

/// The preconditioner `kind` as CG applies it to the whole residual (its
/// `whole`): `None` for the lumped mass, which CG applies as a scalar per
/// node; else [`apply`] of block-Jacobi or the two-level preconditioner.
/// With the isolated body `rigid`, it is made exact on the body's rigid
/// modes ([`Rigid::finish`]): `P⁻¹` of the residual less the rigid motion of
/// its net force and torque, then those modes' exact part. (Nothing holds an
/// isolated body, so `S r` is `r` there.) Returns `rᵀz`.
#[inline(always)]
pub(crate) fn whole<'a, 'b, P: Fn(usize, Vec3) -> Vec3 + Copy>(
    kind: crate::Preconditioner,
    rigid: Option<Rigid>,
    nodes: &'a [Node],
    pre: &'a mut Parts<'b>,
    project: P,
    mass_coef: f32,
) -> Option<impl FnMut(&mut [NodeWork]) -> f32 + use<'a, 'b, P>> {
    (kind != crate::Preconditioner::Mass).then_some(isa_inline!(move |work: &mut [NodeWork]| {
        match rigid {
            None => apply(nodes, work, pre, |_, r| r, project),
            Some(body) => {
                let force = body.fit(nodes, work, |_, w| w.r);
                let input = |i: usize, r: Vec3| match nodes.get(i) {
                    Some(n) => crate::math::axpy(r, -n.mass, body.at(n, force)),
                    None => r,
                };
                apply(nodes, work, pre, input, project);
                body.finish(nodes, work, mass_coef, force)
            }
        }
    }))
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
