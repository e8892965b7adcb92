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
//! uses to release nodes.

use crate::math::{axpy, dot, scale, sqrt, Vec3};
use crate::storage::NodeWork;

/// What a CG solve did.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct CgOutcome {
    /// Iterations run.
    pub(crate) iterations: u32,
    /// `sqrt(rᵀz / r₀ᵀz₀)`: the final residual relative to the initial one.
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
/// set to `b − A x`, or, with `from_guess`, to `b` (the solve then subtracts
/// `A x` itself, with the same `apply`). `project(node, v)` applies the
/// filter `S` of a node; `apply(work)` finds every `work.q` zero, must set it
/// to `A work.d`, and returns `dᵀq = Σ dᵢ·qᵢ` summed in node order.
///
/// With `scale_guess`, a guess `x₀` is first replaced by `γ x₀` with
/// `γ = bᵀx₀ / x₀ᵀAx₀`, the multiple that minimises the energy norm of the
/// error `½ xᵀAx − bᵀx` along `x₀` (≤ 0, the value of no guess): a guess
/// never starts the solve worse than zero, and CG only lowers that norm.
/// (Not for guesses that prescribe constrained components.)
///
/// The preconditioner is `project(i, inv_pᵢ rᵢ)` node by node, fused into
/// the update loop, or with `whole`, a pass that sets every `q` to the
/// preconditioned residual `z` and returns `rᵀz` summed in node order.
///
/// The solve stops once `max_iterations` have run or the residual is below
/// `tolerance`, but only where `certify(work)` accepts the iterate; until
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
    from_guess: bool,
    scale_guess: bool,
    project: impl Fn(usize, Vec3) -> Vec3,
    mut whole: Option<impl FnMut(&mut [NodeWork]) -> f32>,
    mut apply: impl FnMut(&mut [NodeWork]) -> f32,
    mut certify: impl FnMut(&[NodeWork]) -> bool,
) -> CgOutcome {
    if from_guess {
        // r = b − A x₀.
        for w in work.iter_mut() {
            w.d = w.x;
            w.q = [0.0; 3];
        }
        let xax = apply(work);
        let mut gamma = 1.0f32;
        if scale_guess {
            let bx = work.iter().fold(0.0f32, |s, w| s + dot(w.r, w.x));
            gamma = bx / xax;
            if !(xax > 0.0 && gamma.is_finite()) {
                gamma = 0.0;
            }
        }
        if gamma == 0.0 {
            // No multiple of the guess helps (or it overflowed, a leftover
            // of a refused step): start from zero, without touching r.
            for w in work.iter_mut() {
                w.x = [0.0; 3];
            }
        } else {
            for w in work.iter_mut() {
                if scale_guess {
                    w.x = scale(w.x, gamma);
                }
                w.r = axpy(w.r, -gamma, w.q);
            }
        }
    }
    let mut rz = 0.0f32;
    if let Some(pre) = whole.as_mut() {
        rz = pre(work);
        for w in work.iter_mut() {
            w.d = w.q;
            w.q = [0.0; 3];
        }
    } else {
        for (i, w) in work.iter_mut().enumerate() {
            let z = project(i, scale(w.r, w.inv_p));
            w.d = z;
            w.q = [0.0; 3];
            rz += dot(w.r, z);
        }
    }
    let rz0 = rz;
    if !rz0.is_finite() {
        return CgOutcome {
            overflow: true,
            ..CgOutcome::default()
        };
    }
    if !(rz0 > 0.0) {
        // A zero preconditioned residual: the guess solves the system.
        return CgOutcome {
            certified: true,
            ..CgOutcome::default()
        };
    }
    let floor = (FLOOR * rz0).max(f32::MIN_POSITIVE);
    let stop = (tolerance * tolerance * rz0).max(floor);
    let mut iterations = 0;
    let mut certified = false;
    loop {
        if iterations >= max_iterations || rz <= stop {
            if certify(work) {
                certified = true;
                break;
            }
            if iterations >= cap || rz <= floor {
                break;
            }
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
        let mut rz_new = 0.0f32;
        if let Some(pre) = whole.as_mut() {
            for w in work.iter_mut() {
                w.x = axpy(w.x, alpha, w.d);
                w.r = axpy(w.r, -alpha, w.q);
            }
            rz_new = pre(work);
        } else {
            for (i, w) in work.iter_mut().enumerate() {
                w.x = axpy(w.x, alpha, w.d);
                w.r = axpy(w.r, -alpha, w.q);
                let z = project(i, scale(w.r, w.inv_p));
                w.q = z;
                rz_new += dot(w.r, z);
            }
        }
        iterations += 1;
        let beta = rz_new / rz;
        rz = rz_new;
        for w in work.iter_mut() {
            w.d = axpy(w.q, beta, w.d);
            w.q = [0.0; 3];
        }
    }
    CgOutcome {
        iterations,
        // Square roots first and a clamp: the ratio of a grown residual to a tiny
        // initial one can exceed f32 (found by fuzzing); the statistic stays finite.
        residual: (sqrt(rz.max(0.0)) / sqrt(rz0)).min(f32::MAX),
        overflow: !rz.is_finite(),
        certified,
    }
}
