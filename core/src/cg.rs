//! Matrix-free preconditioned conjugate gradient with Baraff–Witkin filtering.
//!
//! Solves `S A S x = S b` where `S` filters constrained directions out of every
//! node (fixed nodes: all three; ground contacts: the normal). The operator is
//! a closure that computes `q = A d` element by element; `A` is never stored.
//!
//! The preconditioner is either a scalar per node (`inv_p`) or a closure
//! (`whole`) that preconditions the whole residual at once (the
//! `block-jacobi` and `two-level` preconditioners, `crate::precond`). The
//! scalar is the lumped mass for dynamics, which makes every iterate
//! conserve linear and angular momentum of an isolated body (the mass
//! preconditioner maps a net force to the rigid motion it drives, and `K`
//! annihilates rigid motions), or the stiffness diagonal for statics. Fixed
//! nodes have `inv_p = 0`, which filters them for free.
//!
//! The residual `r` is kept *unfiltered*: the iterates are the same as with a
//! filtered residual (every inner product goes through `z = S P⁻¹ r`), and
//! its constrained components are the constraint forces, which the ground
//! and the probes use to release nodes.
//!
//! Inner products take the *filtered* residual, `rᵀz` as `(S r)ᵀ z`. The two
//! are equal in exact arithmetic (`z` is filtered), but in f32 `S`'s output
//! keeps a constrained component of rounding size, and a held node's
//! residual there is its contact impulse. Near rest that impulse is many
//! orders of magnitude above the free residual, so `rᵀz` formed from the
//! unfiltered `r` is mostly rounding, and so are the step lengths made
//! from it: a long solve on a body resting against a probe then wanders,
//! leaks velocity into the held nodes' normals and releases them (the
//! contact chatters), or ends with its residual grown. `(S r)ᵀ z` has no
//! such term. Nodes that nothing holds see no difference (`S` returns them
//! unchanged).

use crate::guard::Correction;
use crate::math::{add, axpy, dot, scale, sqrt, sub, Vec3};
use crate::rigid::{Motion, Rigid};
use crate::storage::{Node, NodeWork, FIXED};

/// What a CG solve did.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct CgOutcome {
    /// Iterations run.
    pub(crate) iterations: u32,
    /// The final residual relative to the initial one, in the norm the
    /// solve stops on (`solve`).
    pub(crate) residual: f32,
    /// The residual or an inner product overflowed: the system itself is
    /// beyond f32 (absurd loads), so no solution can be trusted.
    pub(crate) overflow: bool,
    /// The solve stopped where `certify` accepted it (or at an exact zero
    /// residual). `false`: it stopped at the iteration cap, at the round-off
    /// floor or at a direction without curvature, without that acceptance.
    pub(crate) certified: bool,
}

/// Relative floor of `rᵀz` (f32 epsilon squared): iterating below it only
/// produces round-off and, eventually, slow subnormal numbers.
const FLOOR: f32 = f32::EPSILON * f32::EPSILON;

crate::backend::isa_inline!(
    /// Runs at most `max_iterations` CG iterations from `work.x` with `work.r`
    /// set to `b − A x`. `project(node, v)` applies the filter `S` of a node;
    /// `apply(work)` finds every `work.q` zero, must set it to `A work.d`, and
    /// returns `dᵀq = Σ dᵢ·qᵢ` summed in node order.
    ///
    /// The preconditioner is `project(i, inv_pᵢ rᵢ)` node by node, fused into
    /// the update loop, or with `whole`, a pass that sets every `q` to the
    /// preconditioned residual `z` and returns `rᵀz` summed in node order.
    ///
    /// The residual is measured in the preconditioner's norm `sqrt(rᵀz)`, or,
    /// with `whole` and `scalar_norm`, in the norm `sqrt(rᵀ S P₀⁻¹ S r)` of the
    /// scalar preconditioner `P₀⁻¹ = inv_p` (for the step, the lumped mass: the
    /// norm the mass-preconditioned solve measures). That norm is a sum the
    /// update loop makes on the way, so a solve that stops there never applies
    /// `whole` to its last residual: one application per solve fewer.
    ///
    /// The solve stops once `max_iterations` have run or the relative residual
    /// is below `tolerance`, but only where `certify(work)` accepts the iterate; until
    /// then it goes on, to at most `cap` iterations (`cap ≥ max_iterations`).
    /// The step's certificate is that the truncation adds no energy
    /// (`step::solve`); a solve that needs no such check passes `|_| true`, and
    /// then runs exactly as the plain algorithm.
    ///
    /// Loops are fused where the order of operations allows it, so the result
    /// has the bits of the plain algorithm: `dᵀq` is summed inside `apply`'s
    /// node loop, and `q` is zeroed for the next product in the loop that updates
    /// `d`: two passes over the nodes fewer per iteration, which a Cortex-M4F,
    /// with no cache to hide them, pays for in full.
    #[allow(clippy::too_many_arguments)] // the step's state, passed apart so that each borrow stays narrow
    pub(crate) fn solve(
        work: &mut [NodeWork],
        max_iterations: u32,
        cap: u32,
        tolerance: f32,
        scalar_norm: bool,
        project: impl Fn(usize, Vec3) -> Vec3,
        mut whole: Option<impl FnMut(&mut [NodeWork]) -> f32>,
        mut apply: impl FnMut(&mut [NodeWork]) -> f32,
        mut certify: impl FnMut(&[NodeWork]) -> bool,
    ) -> CgOutcome {
        // `rz`: `rᵀz` of the residual the direction `d` was made from. `rm`:
        // the squared norm the stopping rules and the statistic measure, `rᵀz`
        // itself, or with `scalar_norm` and `whole`, `rᵀ S P₀⁻¹ S r` of the
        // scalar preconditioner `P₀⁻¹ = inv_p`.
        let mut rz = 0.0f32;
        let mut rm = 0.0f32;
        if let Some(pre) = whole.as_mut() {
            rz = pre(work);
            for (i, w) in work.iter_mut().enumerate() {
                if scalar_norm {
                    let rf = project(i, w.r);
                    rm += dot(rf, scale(rf, w.inv_p));
                }
                w.d = w.q;
                w.q = [0.0; 3];
            }
            if !scalar_norm {
                rm = rz;
            }
        } else {
            for (i, w) in work.iter_mut().enumerate() {
                let rf = project(i, w.r);
                let z = scale(rf, w.inv_p);
                w.d = z;
                w.q = [0.0; 3];
                rz += dot(rf, z);
            }
            rm = rz;
        }
        let rm0 = rm;
        if !(rz.is_finite() && rm0.is_finite()) {
            return CgOutcome {
                overflow: true,
                ..CgOutcome::default()
            };
        }
        if !(rz > 0.0 && rm0 > 0.0) {
            // A zero preconditioned residual: the guess solves the system.
            return CgOutcome {
                certified: true,
                ..CgOutcome::default()
            };
        }
        let floor = (FLOOR * rm0).max(f32::MIN_POSITIVE);
        let stop = (tolerance * tolerance * rm0).max(floor);
        let mut iterations = 0;
        let mut certified = false;
        // With `whole`: `r` has changed since `d` was made, and the next
        // direction waits for `P⁻¹ r` (`next`: its `rᵀz`, when already known).
        // Made only once the solve goes on, so that a solve that stops needs
        // no preconditioner for its last residual.
        let mut stale = false;
        let mut next = 0.0f32;
        loop {
            if iterations >= max_iterations || rm <= stop {
                if certify(work) {
                    certified = true;
                    break;
                }
                if iterations >= cap || rm <= floor {
                    break;
                }
            }
            if stale {
                if let Some(pre) = whole.as_mut() {
                    if scalar_norm {
                        next = pre(work);
                    }
                    // A preconditioned residual `rᵀ P⁻¹ r` that rounds to
                    // zero (or below) while the scalar norm `rm` is still
                    // above the floor: the preconditioner has resolved all
                    // it can, and `β = next / rz` would divide by it next
                    // time (0/0 once it is zero). Stop: the iterate is the
                    // solve's best, and the certificate or the Galerkin step
                    // decides what it is worth. `rz > 0` then holds for
                    // every division.
                    if !(next > 0.0) {
                        break;
                    }
                    let beta = next / rz;
                    rz = next;
                    for w in work.iter_mut() {
                        w.d = axpy(w.q, beta, w.d);
                        w.q = [0.0; 3];
                    }
                }
                stale = false;
            }
            let dq = apply(work);
            if !dq.is_finite() {
                return CgOutcome {
                    iterations,
                    residual: f32::INFINITY,
                    overflow: true,
                    certified: false,
                };
            }
            if !(dq > 0.0) {
                break;
            }
            let alpha = rz / dq;
            iterations += 1;
            if let Some(pre) = whole.as_mut() {
                let mut sum = 0.0f32;
                for (i, w) in work.iter_mut().enumerate() {
                    w.x = axpy(w.x, alpha, w.d);
                    w.r = axpy(w.r, -alpha, w.q);
                    if scalar_norm {
                        let rf = project(i, w.r);
                        sum += dot(rf, scale(rf, w.inv_p));
                        w.q = [0.0; 3];
                    }
                }
                if scalar_norm {
                    rm = sum;
                } else {
                    next = pre(work);
                    rm = next;
                }
                stale = true;
                continue;
            }
            let mut rz_new = 0.0f32;
            for (i, w) in work.iter_mut().enumerate() {
                w.x = axpy(w.x, alpha, w.d);
                w.r = axpy(w.r, -alpha, w.q);
                let rf = project(i, w.r);
                let z = scale(rf, w.inv_p);
                w.q = z;
                rz_new += dot(rf, z);
            }
            let beta = rz_new / rz;
            rz = rz_new;
            rm = rz;
            for w in work.iter_mut() {
                w.d = axpy(w.q, beta, w.d);
                w.q = [0.0; 3];
            }
        }
        CgOutcome {
            iterations,
            // Square roots first and a clamp: the ratio of a grown residual to a tiny
            // initial one can exceed f32 (found by fuzzing); the statistic stays finite.
            residual: (sqrt(rm.max(0.0)) / sqrt(rm0)).min(f32::MAX),
            overflow: !(rm.is_finite() && rz.is_finite()),
            certified,
        }
    }
);

crate::backend::isa_inline!(
    /// The energy certificate of a truncated solve. Linearised at the current
    /// state, a step that solves `A Δv = b − r` changes the kinetic plus elastic
    /// energy by (with `v' = v + Δv`, the tool's spring counted with `K`)
    ///
    /// ```text
    /// h v'ᵀf_ext − v'ᵀr − ½ ΔvᵀMΔv − (h²/2 + h α_K) v'ᵀKv' − h α_M v'ᵀMv'
    /// ```
    ///
    /// (expand `v'ᵀ M Δv` with `M Δv = b − r − h α_M M Δv − h (α_K + h) K Δv`
    /// and add `E(x + h v') − E(x) ≈ −h f_elᵀv' + ½ h² v'ᵀKv'`). The exact step
    /// has `r = 0` and only dissipates; a truncated one is accepted when its
    /// residual injects no more than the dissipation the step has anyway:
    /// `−v'ᵀ S r ≤ ½ ΔvᵀMΔv + h α_M v'ᵀMv' + ε KE`. The `K` terms are left out
    /// (they need another product; leaving out a dissipation only makes the test
    /// stricter). `S` filters the held ground normals (the ground's force does
    /// no work on a node it holds still); fixed nodes do not move.
    /// `ε = f32::EPSILON`: the kinetic energy `KE`, a sum of f32 terms, is not
    /// known more finely, so a finer test would reject round-off.
    pub(crate) fn certified(
        nodes: &[Node],
        work: &[NodeWork],
        project: impl Fn(usize, Vec3) -> Vec3,
        h_alpha_m: f32,
        correction: Option<&Correction>,
    ) -> bool {
        let (mut inject, mut dissipate, mut kinetic) = (0.0f32, 0.0f32, 0.0f32);
        for (i, (n, w)) in nodes.iter().zip(work.iter()).enumerate() {
            if n.flags & FIXED != 0 {
                continue;
            }
            let v1 = add(n.v, w.x);
            // The step starts from the guard's velocity `v + δ`: `Δv = x − δ`.
            let (v0, dv) = match correction {
                Some(c) => {
                    let delta = c.delta(n);
                    (add(n.v, delta), sub(w.x, delta))
                }
                None => (n.v, w.x),
            };
            inject -= dot(v1, project(i, w.r));
            dissipate += n.mass * (0.5 * dot(dv, dv) + h_alpha_m * dot(v1, v1));
            kinetic += n.mass * dot(v0, v0);
        }
        inject <= dissipate + f32::EPSILON * 0.5 * kinetic
    }
);

crate::backend::isa_inline!(
    /// The Galerkin step that ends a solve without an energy certificate: the
    /// solution is replaced by the best one (least energy norm of the error) in
    /// `x₀ + span{P Δv, P v}`, where `P` takes the part that CG may change (the
    /// filter `S` of held normals and fixed nodes, or for an isolated body, the
    /// part without the rigid motion of the same momentum), and `x₀` keeps the
    /// rest (held normals; for an isolated body, the rigid part, which the
    /// preconditioners keep exact). The new residual is then orthogonal to both
    /// directions (and, for an isolated body, still free of net force and
    /// torque: `A` maps the `M`-orthogonal directions to forces without them),
    /// so `v'ᵀ S r = 0`: the truncation adds no energy.
    ///
    /// The second direction is made `A`-orthogonal to the first and multiplied
    /// by `A` again rather than updated: where a stiff step all but stops the
    /// deformation, `A P v` and `A P Δv` are nearly parallel and their
    /// difference cancels to noise in f32. Three products with `A` in all.
    pub(crate) fn galerkin(
        nodes: &[Node],
        work: &mut [NodeWork],
        isolated: bool,
        rotations: bool,
        project: impl Fn(usize, Vec3) -> Vec3,
        mut apply: impl FnMut(&mut [NodeWork]) -> f32,
        start: impl Fn(&Node) -> Vec3,
    ) {
        let rigid = if isolated {
            Rigid::new(nodes, rotations)
        } else {
            None
        };
        let none = ([0.0; 3], [0.0; 3]);
        let (fit_x, fit_v) = match rigid {
            Some(body) => (
                body.fit(nodes, work, |n, w| scale(w.x, n.mass)),
                body.fit(nodes, work, |n, _| scale(start(n), n.mass)),
            ),
            None => (none, none),
        };
        // `P a` at node `i`, with the rigid motion `fit` of the field `a`.
        let part = |i: usize, n: &Node, a: Vec3, fit: Motion| -> Vec3 {
            if n.flags & FIXED != 0 {
                return [0.0; 3];
            }
            match rigid {
                Some(body) => body.less_rigid(n, a, fit),
                None => project(i, a),
            }
        };
        // Along e = P Δv: Δv += a e, with a = eᵀr / eᵀAe. Since P is a
        // projection, P Δv is then (1 + a) e, with A-norm² (1 + a)² eᵀAe.
        for (i, (n, w)) in nodes.iter().zip(work.iter_mut()).enumerate() {
            w.d = part(i, n, w.x, fit_x);
            w.q = [0.0; 3];
        }
        let eae = apply(work);
        let e_norm = descend(work, eae).map_or(0.0, |a| (1.0 + a) * (1.0 + a) * eae);
        // Along f = P v, made A-orthogonal to e = P Δv.
        for (i, (n, w)) in nodes.iter().zip(work.iter_mut()).enumerate() {
            w.d = part(i, n, start(n), fit_v);
            w.q = [0.0; 3];
        }
        let mut faf = apply(work);
        if e_norm > 0.0 && e_norm.is_finite() && faf.is_finite() {
            let mut eaf = 0.0f32;
            for (i, (n, w)) in nodes.iter().zip(work.iter()).enumerate() {
                eaf += dot(part(i, n, w.x, fit_x), w.q);
            }
            let c = eaf / e_norm;
            if c != 0.0 && c.is_finite() {
                for (i, (n, w)) in nodes.iter().zip(work.iter_mut()).enumerate() {
                    w.d = axpy(w.d, -c, part(i, n, w.x, fit_x));
                    w.q = [0.0; 3];
                }
                faf = apply(work);
            }
        }
        descend(work, faf);
    }
);

/// The exact line search along `d` (with `q = A d`, `dad = dᵀAd`):
/// `x += a d`, `r −= a q` with `a = dᵀr / dᵀAd`, after which `dᵀr = 0`.
/// Returns `a`, or `None` (nothing changed) for a direction without
/// positive, finite curvature.
fn descend(work: &mut [NodeWork], dad: f32) -> Option<f32> {
    if !(dad > 0.0 && dad.is_finite()) {
        return None;
    }
    let a = work.iter().fold(0.0f32, |s, w| s + dot(w.d, w.r)) / dad;
    for w in work.iter_mut() {
        w.x = axpy(w.x, a, w.d);
        w.r = axpy(w.r, -a, w.q);
    }
    Some(a)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `A` of a chain of four nodes: `(2 + i) I` on the diagonal, `−I`
    /// between neighbours (symmetric, diagonally dominant).
    fn chain(work: &mut [NodeWork]) -> f32 {
        let d: std::vec::Vec<Vec3> = work.iter().map(|w| w.d).collect();
        let mut dq = 0.0f32;
        for (i, w) in work.iter_mut().enumerate() {
            let mut q = scale(d[i], 2.0 + i as f32);
            if i > 0 {
                q = axpy(q, -1.0, d[i - 1]);
            }
            if let Some(next) = d.get(i + 1) {
                q = axpy(q, -1.0, *next);
            }
            w.q = q;
            dq += dot(w.d, w.q);
        }
        dq
    }

    fn system() -> [NodeWork; 4] {
        let mut work = [NodeWork::EMPTY; 4];
        for (i, w) in work.iter_mut().enumerate() {
            let t = i as f32;
            w.r = [1.0 + t, -0.5 * t, 0.25];
            w.inv_p = 1.0 / (1.5 + t);
        }
        work
    }

    /// With a whole-residual preconditioner and the scalar norm, a solve
    /// that stops at its budget applies the preconditioner once per
    /// iteration (the last residual is measured without it), where the
    /// preconditioner's own norm needs one application more; the iterates
    /// are the same bits, and the statistic is the scalar norm's.
    #[test]
    fn the_scalar_norm_skips_the_last_application() {
        let run = |scalar_norm: bool| {
            let mut work = system();
            let mut calls = 0;
            // A block preconditioner other than the scalar one: 1/(2 + i).
            let whole = |work: &mut [NodeWork]| {
                calls += 1;
                let mut rz = 0.0f32;
                for (i, w) in work.iter_mut().enumerate() {
                    w.q = scale(w.r, 1.0 / (2.0 + i as f32));
                    rz += dot(w.r, w.q);
                }
                rz
            };
            let out = solve(
                &mut work,
                3,
                3,
                0.0,
                scalar_norm,
                |_, z| z,
                Some(whole),
                chain,
                |_| true,
            );
            (out, work, calls)
        };
        let (lazy, lazy_work, lazy_calls) = run(true);
        let (eager, eager_work, eager_calls) = run(false);
        assert_eq!((lazy.iterations, eager.iterations), (3, 3));
        assert_eq!((lazy_calls, eager_calls), (3, 4));
        for (a, b) in lazy_work.iter().zip(&eager_work) {
            assert_eq!(a.x.map(f32::to_bits), b.x.map(f32::to_bits));
            assert_eq!(a.r.map(f32::to_bits), b.r.map(f32::to_bits));
        }
        // The statistic: sqrt(rᵀ P₀⁻¹ r / r₀ᵀ P₀⁻¹ r₀) with P₀⁻¹ = inv_p.
        let norm = |work: &[NodeWork]| {
            work.iter()
                .map(|w| dot(w.r, scale(w.r, w.inv_p)))
                .sum::<f32>()
        };
        let want = (norm(&lazy_work) / norm(&system())).sqrt();
        // The same sums in the same order; the solve divides square roots
        // rather than taking the root of the quotient: a few ulps apart.
        assert!(
            (lazy.residual - want).abs() <= 1e-5 * want,
            "{} against {want}",
            lazy.residual
        );
        // Three iterations on four nodes reduce the residual, not to zero.
        assert!(lazy.residual > 0.0 && lazy.residual < 1.0);
    }
}
