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

use crate::math::{axpy, dot, scale, sqrt, Vec3};
use crate::storage::NodeWork;

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
/// (`step.rs`); a solve that needs no such check passes `|_| true`, and
/// then runs exactly as the plain algorithm.
///
/// Loops are fused where the order of operations allows it, so the result
/// has the bits of the plain algorithm: `dᵀq` is summed inside `apply`'s
/// node loop, and `q` is zeroed for the next product in the loop that updates
/// `d`: two passes over the nodes fewer per iteration, which a Cortex-M4F,
/// with no cache to hide them, pays for in full.
#[cfg_attr(any(target_arch = "x86", target_arch = "x86_64"), inline(always))]
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
